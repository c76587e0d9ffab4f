//! `--set KEY=VALUE`: a scenario variant without editing its file. The key is any scenario
//! key as a dotted path (`simulation.seed`, `link.1.damping.1`, an array's element by its
//! index); the value is TOML (`7`, `0.5`, `"rk"`, `[1, 3]`), or else taken as a string. The
//! result is validated like the file, and it records its overrides as leading comment lines
//! `# --set KEY=VALUE`, so that a log (which stores the scenario text) and the report made
//! from it say which variant they are (docs/scenario.md, "Variants").

use super::{Scenario, ScenarioError};

/// The comment a variant's text starts with, one line per override.
const MARK: &str = "# --set ";

fn invalid(label: &str, key: &str, message: String) -> ScenarioError {
    ScenarioError::Override {
        path: label.to_string(),
        key: key.to_string(),
        message,
    }
}

/// `KEY=VALUE` split and checked.
pub fn parse_set(label: &str, set: &str) -> Result<(String, toml::Value), ScenarioError> {
    let Some((key, value)) = set.split_once('=') else {
        return Err(invalid(
            label,
            set,
            format!("--set {set:?}: KEY=VALUE expected, e.g. --set simulation.seed=7"),
        ));
    };
    let (key, value) = (key.trim(), value.trim());
    if key.is_empty() || key.split('.').any(str::is_empty) {
        return Err(invalid(label, key, format!("--set {set:?}: an empty key segment")));
    }
    let value = match format!("v = {value}").parse::<toml::Table>() {
        Ok(mut t) => t.remove("v").expect("parsed"),
        Err(_) => toml::Value::String(value.to_string()),
    };
    Ok((key.to_string(), value))
}

/// The scenario text with `sets` applied (and recorded in its leading comments).
pub fn apply(label: &str, text: &str, sets: &[String]) -> Result<String, ScenarioError> {
    if sets.is_empty() {
        return Ok(text.to_string());
    }
    // The file must be valid as it is: its own errors keep their lines.
    let doc: toml::Table = text
        .parse()
        .map_err(|e: toml::de::Error| invalid(label, "", format!("not valid TOML: {}", e.message())))?;
    let mut root = toml::Value::Table(doc);
    // Overrides the text already records (a variant varied again) stay recorded.
    let mut header: String = text
        .lines()
        .take_while(|l| l.starts_with(MARK))
        .map(|l| format!("{l}\n"))
        .collect();
    for set in sets {
        let (key, value) = parse_set(label, set)?;
        let parts: Vec<&str> = key.split('.').collect();
        let mut at: &mut toml::Value = &mut root;
        for (k, part) in parts.iter().enumerate() {
            let last = k + 1 == parts.len();
            let path = parts[..=k].join(".");
            at = match at {
                toml::Value::Table(t) => {
                    if last {
                        t.insert(part.to_string(), value.clone());
                        break;
                    }
                    t.entry(part.to_string())
                        .or_insert_with(|| toml::Value::Table(toml::Table::new()))
                }
                toml::Value::Array(a) => {
                    let len = a.len();
                    let i: usize = part.parse().map_err(|_| {
                        invalid(label, &key, format!("`{path}`: an index 0..{len} expected (an array)"))
                    })?;
                    let Some(slot) = a.get_mut(i) else {
                        return Err(invalid(
                            label,
                            &key,
                            format!("`{path}`: index {i}, the array has {len}"),
                        ));
                    };
                    if last {
                        *slot = value.clone();
                        break;
                    }
                    slot
                }
                other => {
                    return Err(invalid(
                        label,
                        &key,
                        format!("`{}` is a {}, not a table", parts[..k].join("."), other.type_str()),
                    ))
                }
            };
        }
        header += &format!("{MARK}{key}={}\n", value_text(&value));
    }
    let body = toml::to_string(&root).map_err(|e| invalid(label, "", e.to_string()))?;
    Ok(format!("{header}{body}"))
}

/// A variant's error told where the user can find it: an error of a key an override set
/// (or lies within) names the `--set`; an error of a key the file holds gets the file's own
/// line and column (the varied text is re-serialised, so its positions are not the file's).
fn relocate(e: ScenarioError, label: &str, text: &str, sets: &[String]) -> ScenarioError {
    let ScenarioError::Invalid { key, message, .. } = &e else {
        return e;
    };
    let path = segments(key);
    let overridden = sets.iter().find(|set| {
        let k = segments(set.split_once('=').map_or(set.as_str(), |(k, _)| k.trim()));
        path.starts_with(&k) || k.starts_with(&path)
    });
    if let Some(set) = overridden {
        return ScenarioError::Override {
            path: label.to_string(),
            key: set.clone(),
            message: format!("`{key}`: {message}"),
        };
    }
    match position_of(text, &path) {
        Some((line, column)) => ScenarioError::Invalid {
            path: label.to_string(),
            line,
            column,
            key: key.clone(),
            message: message.clone(),
        },
        None => e,
    }
}

/// A dotted key's segments: `link[0].stiffness` and `link.0.stiffness` alike.
fn segments(key: &str) -> Vec<String> {
    key.replace('[', ".")
        .replace(']', "")
        .split('.')
        .filter(|p| !p.is_empty())
        .map(str::to_string)
        .collect()
}

/// The 1-based line and column of the key `path` in the TOML `text`; `None` where the text
/// does not hold it.
fn position_of(text: &str, path: &[String]) -> Option<(usize, usize)> {
    use toml::de::{DeTable, DeValue};
    let doc = DeTable::parse(text).ok()?;
    let mut span = doc.span();
    let mut at: Option<&DeValue> = None;
    let mut table: Option<&DeTable> = Some(doc.get_ref());
    for seg in path {
        let next = match (table, at) {
            (Some(t), _) => t
                .iter()
                .find(|(k, _)| k.get_ref().as_ref() == seg.as_str())
                .map(|(_, v)| (v.span(), v)),
            (None, Some(DeValue::Array(a))) => {
                let v = a.get(seg.parse::<usize>().ok()?)?;
                Some((v.span(), v))
            }
            _ => None,
        }?;
        span = next.0;
        at = Some(next.1.get_ref());
        table = match next.1.get_ref() {
            DeValue::Table(t) => Some(t),
            _ => None,
        };
    }
    let before = &text[..span.start.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
    Some((line, column))
}

fn value_text(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

impl Scenario {
    /// Read a scenario file with `--set` overrides applied (see [`apply`]).
    pub fn from_file_with(path: &std::path::Path, sets: &[String]) -> Result<Scenario, ScenarioError> {
        if sets.is_empty() {
            return Scenario::from_file(path);
        }
        let label = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Io {
            path: label.clone(),
            source,
        })?;
        let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("scenario");
        let varied = apply(&label, &text, sets)?;
        Scenario::parse(&varied, &format!("{label} with --set {}", sets.join(" --set ")), stem)
            .map_err(|e| relocate(e, &label, &text, sets))
    }

    /// The overrides this scenario's text records (`--set`), as `KEY=VALUE`.
    pub fn overrides(&self) -> Vec<String> {
        self.source
            .lines()
            .map_while(|l| l.strip_prefix(MARK))
            .map(str::to_string)
            .collect()
    }

    /// The folder name of this variant: the scenario's name, then each override's last key
    /// segment and value (`duffing2dof--seed=7--sample_interval=0.5`).
    pub fn variant_name(&self) -> String {
        let mut name = self.name.clone();
        for o in self.overrides() {
            let (k, v) = o.split_once('=').unwrap_or((&o, ""));
            // The last key segment, with its parent when it is an index or a power.
            let parts: Vec<&str> = k.split('.').collect();
            let keep = if parts.len() > 1 && parts[parts.len() - 1].parse::<usize>().is_ok() {
                2
            } else {
                1
            };
            let k = parts[parts.len() - keep..].join(".");
            let v: String = v
                .chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() || "+-._".contains(c) {
                        c
                    } else {
                        '_'
                    }
                })
                .collect();
            name += &format!("--{k}={v}");
        }
        name
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A variant's errors are told where the user finds them: a key the file holds at the
    /// file's own line and column (as without any `--set`), a key an override set by its
    /// `--set`.
    #[test]
    fn a_variants_error_is_located_in_the_file_or_at_its_override() {
        let path = format!("{}/scenarios/duffing2dof.toml", env!("CARGO_MANIFEST_DIR"));
        let text = std::fs::read_to_string(&path)
            .unwrap()
            .replace("stiffness = { 1 = 8.0, 3 = 10.0 }", "stiffness = { 1 = 8.0, 2 = 10.0 }");
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("bad.toml");
        std::fs::write(&file, &text).unwrap();
        let plain = Scenario::from_file(&file).unwrap_err().to_string();
        let varied = Scenario::from_file_with(&file, &["simulation.seed=3".into()])
            .unwrap_err()
            .to_string();
        let at = |e: &str| {
            e.split(": `")
                .next()
                .unwrap()
                .rsplit(".toml")
                .next()
                .unwrap()
                .to_string()
        };
        assert!(
            plain.contains("`link[2].stiffness`") && at(&plain).starts_with(':'),
            "{plain}"
        );
        assert_eq!(at(&varied), at(&plain), "{varied} against {plain}");
        // The override's own mistake names the override.
        let set = "link.0.stiffness={ 2 = 10.0 }".to_string();
        let e = Scenario::from_file_with(std::path::Path::new(&path), std::slice::from_ref(&set))
            .unwrap_err()
            .to_string();
        assert!(e.contains(&format!("--set {set}: `link[0].stiffness`")), "{e}");
        assert_eq!(segments("link[0].stiffness"), segments("link.0.stiffness"));
        assert_eq!(
            position_of("[simulation]\nseed = 3\n", &segments("simulation.seed")),
            Some((2, 8))
        );
        assert_eq!(
            position_of("[simulation]\nseed = 3\n", &segments("simulation.dt")),
            None
        );
    }
}
