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
