//! Validation: the raw TOML checked section by section into a [`Scenario`], every error
//! located by file, line, column and key, with what is allowed.

use super::paper::paper_structure;
use super::raw::*;
use super::*;
use crate::model::admissible::{self, NotStationary};
use crate::model::{BoucWen, Characteristic, Term};
use std::collections::BTreeMap;
use std::ops::Range;
use toml::Spanned;

mod data;
mod identify;
pub(crate) mod lab;
mod sensors;
pub(crate) use data::check_data;
pub(crate) use identify::{check_accept, check_identify, inseparable};
use sensors::{check_measurement, check_sensor_filters};

/// Byte-offset → line/column and key lookup for error messages.
pub(crate) struct Locator<'a> {
    path: &'a str,
    src: &'a str,
}

impl Locator<'_> {
    pub(super) fn at(&self, span: Range<usize>, key: impl Into<String>, message: impl Into<String>) -> ScenarioError {
        let offset = span.start.min(self.src.len());
        let before = &self.src[..offset];
        let line = before.matches('\n').count() + 1;
        let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
        ScenarioError::Invalid {
            path: self.path.to_string(),
            line,
            column,
            key: key.into(),
            message: message.into(),
        }
    }

    /// Best-effort dotted key at an offset: the last `[table]` header above it and the key
    /// left of `=` on its line.
    pub(super) fn key_at(&self, offset: usize) -> String {
        let offset = offset.min(self.src.len());
        let line_start = self.src[..offset].rfind('\n').map_or(0, |i| i + 1);
        let line_end = self.src[offset..].find('\n').map_or(self.src.len(), |i| offset + i);
        let line = &self.src[line_start..line_end];
        let header = self.src[..line_start]
            .lines()
            .rev()
            .map(str::trim)
            .find(|l| l.starts_with('['))
            .map(|l| l.trim_matches(|c| c == '[' || c == ']').trim().to_string());
        let local = line.split_once('=').map(|(k, _)| k.trim().to_string());
        match (header, local) {
            (Some(h), Some(k)) => format!("{h}.{k}"),
            (Some(h), None) => h,
            (None, Some(k)) => k,
            (None, None) => "(top level)".into(),
        }
    }
}

pub(crate) fn finite_positive(loc: &Locator, v: &Spanned<f64>, key: &str, what: &str) -> Result<f64, ScenarioError> {
    let x = *v.get_ref();
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(loc.at(v.span(), key, format!("must be a finite number > 0 ({what}), got {x}")))
    }
}

/// Check a name. Mass and excitation names become log field names (`x_<mass>`,
/// `p_<excitation>`), which ROS 2 message definitions restrict to `[a-z][a-z0-9_]*` with no
/// `__` and no trailing `_`; link names may also use `-`.
pub(crate) fn check_name(loc: &Locator, s: &Spanned<String>, key: &str, field: bool) -> Result<String, ScenarioError> {
    let n = s.get_ref();
    let ok_char = |c: char| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_' || (!field && c == '-');
    let ok = n.chars().next().is_some_and(|c| c.is_ascii_lowercase())
        && n.chars().all(ok_char)
        && !n.contains("__")
        && !n.ends_with('_')
        && n.len() <= 40;
    if ok && n != "ground" {
        Ok(n.clone())
    } else {
        let allowed = if field {
            "lower-case letters, digits and single `_`"
        } else {
            "lower-case letters, digits, single `_` and `-`"
        };
        Err(loc.at(
            s.span(),
            key,
            format!("invalid name {n:?}: names start with a lower-case letter and use only {allowed} (at most 40 characters, not ending in `_`); `ground` is reserved"),
        ))
    }
}

/// A characteristic `{ <term> = <coefficient>, … }` (docs/scenario.md): each key a
/// [`Term`] as names write it, each coefficient finite, each term once.
pub(crate) fn curve(
    loc: &Locator,
    raw: &Option<Spanned<BTreeMap<String, Spanned<f64>>>>,
    key: &str,
) -> Result<Curve, ScenarioError> {
    let Some(map) = raw else {
        return Ok(Curve::default());
    };
    let mut terms: Vec<(Term, f64)> = Vec::new();
    for (p, c) in map.get_ref() {
        let term: Term = p.parse().map_err(|e| {
            loc.at(
                c.span(),
                format!("{key}.{p}"),
                format!("{e}, e.g. {{ 1 = 10.0, 3 = 20.0 }}"),
            )
        })?;
        let v = *c.get_ref();
        if !v.is_finite() {
            return Err(loc.at(
                c.span(),
                format!("{key}.{p}"),
                format!("coefficient must be a finite number, got {v}"),
            ));
        }
        if let Some(&(_, first)) = terms.iter().find(|t| t.0 == term) {
            return Err(loc.at(
                c.span(),
                format!("{key}.{p}"),
                format!(
                    "{} is given twice ({p:?} = {v} and another key = {first}): give each term once",
                    term.describe()
                ),
            ));
        }
        terms.push((term, v));
    }
    if terms.is_empty() {
        return Err(loc.at(
            map.span(),
            key,
            "empty: give at least one term, e.g. { 1 = 10.0 }, or leave the key out",
        ));
    }
    terms.sort_by_key(|t| t.0);
    Ok(Curve { terms })
}

/// The terms of a characteristic to identify, `[1, 3]` (powers) or `[1, "sign"]`, each once;
/// an empty list is none.
pub(crate) fn terms(
    loc: &Locator,
    raw: &Option<Vec<Spanned<RawTerm>>>,
    key: &str,
) -> Result<Option<Vec<Term>>, ScenarioError> {
    let Some(list) = raw else { return Ok(None) };
    let mut out = Vec::new();
    for p in list {
        let v = p.get_ref();
        let term: Term = v.to_string().parse().map_err(|e| loc.at(p.span(), key, e))?;
        if out.contains(&term) {
            return Err(loc.at(p.span(), key, format!("{} is listed twice", term.describe())));
        }
        out.push(term);
    }
    if out.is_empty() {
        return Ok(None);
    }
    out.sort_unstable();
    Ok(Some(out))
}

impl Scenario {
    /// Validate scenario text. `path` labels error messages; `default_name` is used when
    /// the file has no `name`.
    pub fn parse(src: &str, path: &str, default_name: &str) -> Result<Scenario, ScenarioError> {
        let loc = Locator { path, src };
        let raw: RawScenario = toml::from_str(src).map_err(|e| {
            let span = e.span().unwrap_or(0..0);
            let msg = e.message().trim().to_string();
            // serde reports an unknown key at the key itself: name it as written.
            let key = if msg.starts_with("unknown field") {
                let k = src.get(span.clone()).unwrap_or("").trim().to_string();
                let full = loc.key_at(span.start);
                if full.ends_with(&k) {
                    full
                } else {
                    k
                }
            } else {
                loc.key_at(span.start)
            };
            // `[mass]` where `[[mass]]` is meant: serde sees a table where a list belongs.
            let written = src.get(span.clone()).unwrap_or("").trim();
            if msg.contains("expected a sequence") && written.starts_with('[') && !written.starts_with("[[") {
                let name = written.trim_matches(|c| c == '[' || c == ']').trim();
                return loc.at(
                    span.clone(),
                    name,
                    format!("[{name}] is one table, but `{name}` is a list: write [[{name}]] before each entry"),
                );
            }
            loc.at(span, key, msg)
        })?;

        let name = match &raw.name {
            Some(n) => check_name(&loc, n, "name", false)?,
            None => default_name.to_string(),
        };

        let masses = check_masses(&loc, &raw)?;
        let links = check_links(&loc, &raw, &masses)?;
        check_stationary(&loc, &raw, &masses, &links)?;
        let excitations = check_excitations(&loc, &raw, &masses)?;
        let data = check_data(&loc, &raw, &masses, &excitations)?;
        let mut simulation = match (&raw.simulation, &data) {
            // A model file: the simulation (for the validation) is set from the data.
            (None, Some(_)) => Simulation::placeholder(),
            _ => check_simulation(&loc, &raw, &masses, &links)?,
        };
        simulation.sensors = check_measurement(&loc, &raw)?;
        lab::check_lab_run(&loc, &raw, &excitations, &simulation, data.is_some())?;
        if raw.simulation.is_some() {
            check_filters_resolved(&loc, &raw, &excitations, simulation.dt)?;
        }
        check_sensor_filters(&loc, &raw, &simulation, data.is_some())?;
        let identify = check_identify(&loc, &raw, &masses, &links, &excitations)?;
        let accept = check_accept(&loc, &raw, &identify)?;
        identify::check_equivalent_white_columns(&loc, &raw, &identify, &excitations, data.as_ref())?;
        if identify.sensor_noise == NoiseHandling::Given && !simulation.sensors.noisy() {
            let span = raw
                .identify
                .as_ref()
                .and_then(|i| i.sensor_noise.as_ref())
                .map_or(0..0, |v| v.span());
            return Err(loc.at(
                span,
                "identify.sensor_noise",
                "\"given\" takes the noise [measurement] states, and there is none: add [measurement] with \
                 displacement and velocity noise levels, or use \"estimate\" or \"ignore\"",
            ));
        }

        Ok(Scenario {
            name,
            description: raw.description.clone().unwrap_or_default(),
            motion: raw.motion,
            masses,
            links,
            excitations,
            simulation,
            identify,
            accept,
            data,
            source: src.to_string(),
            disturbance_level: None,
        })
    }
}

/// A filtered excitation's corner `B` resolved by the step: `B·dt ≤ 1`. A faster filter
/// is white noise to the masses, and the step cannot follow it.
fn check_filters_resolved(
    loc: &Locator,
    raw: &RawScenario,
    excitations: &[Excitation],
    dt: f64,
) -> Result<(), ScenarioError> {
    for (k, e) in excitations.iter().enumerate() {
        if let Process::Filtered { a, b } = e.process {
            if b * dt > 1.0 {
                let span = raw.excitation[k].b.as_ref().map_or(0..0, |s| s.span());
                return Err(loc.at(
                    span,
                    format!("excitation[{k}].B"),
                    format!(
                        "B = {b:e} 1/s: the filter's time constant 1/B = {:.3e} s is shorter than the step dt = {dt} s \
                         (B·dt = {:.3e}; at most 1): the step cannot follow it, and a filter this fast is white noise to \
                         the masses. Use kind = \"white\" with sigma = A/B = {:.6e}, or a step dt <= 1/B",
                        1.0 / b,
                        b * dt,
                        a / b
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// `[[mass]]`: names unique, values positive.
pub(crate) fn check_masses(loc: &Locator, raw: &RawScenario) -> Result<Vec<Mass>, ScenarioError> {
    if raw.mass.is_empty() {
        return Err(loc.at(
            0..0,
            "mass",
            "no masses: add at least one [[mass]] with `name` and `value`",
        ));
    }
    let mut masses: Vec<Mass> = Vec::new();
    for (i, m) in raw.mass.iter().enumerate() {
        let key = format!("mass[{i}]");
        let n = check_name(loc, &m.name, &format!("{key}.name"), true)?;
        if masses.iter().any(|x| x.name == n) {
            return Err(loc.at(
                m.name.span(),
                format!("{key}.name"),
                format!("duplicate mass name {n:?}: names must be unique"),
            ));
        }
        let unknown = raw.data.is_some()
            && (raw.identify.as_ref())
                .and_then(|i| i.unknown_masses.as_ref())
                .is_some_and(|u| u.iter().any(|x| *x.get_ref() == n));
        let (value, valued) = match &m.value {
            Some(v) => (
                finite_positive(loc, v, &format!("{key}.value"), raw.motion.units()[4])?,
                true,
            ),
            None if unknown => (1.0, false),
            None => {
                return Err(loc.at(
                    m.name.span(),
                    format!("{key}.value"),
                    format!(
                        "mass {n:?} has no `value` ({}): only an unknown mass of a model file \
                         ([identify] unknown_masses, in a file with [data]) may leave it out",
                        raw.motion.units()[4]
                    ),
                ))
            }
        };
        masses.push(Mass { name: n, value, valued });
    }
    Ok(masses)
}

/// In a model file (one with `[data]`): whether link `name`'s stiffness and damping are
/// unknown (`[identify.links]`), so that they need no values.
pub(crate) fn unknown_in_model_file(raw: &RawScenario, name: &str) -> (bool, bool) {
    if raw.data.is_none() {
        return (false, false);
    }
    let declared = raw
        .identify
        .as_ref()
        .and_then(|i| i.links.as_ref())
        .and_then(|l| l.get(name));
    declared.map_or((false, false), |d| {
        let d = d.get_ref();
        (d.stiffness.is_some(), d.damping.is_some())
    })
}

/// The mass named by `s` (or the ground, where allowed).
pub(crate) fn mass_index(
    loc: &Locator,
    masses: &[Mass],
    s: &Spanned<String>,
    key: &str,
    allow_ground: bool,
) -> Result<End, ScenarioError> {
    let n = s.get_ref();
    if allow_ground && n == "ground" {
        return Ok(End::Ground);
    }
    masses.iter().position(|m| &m.name == n).map(End::Mass).ok_or_else(|| {
        let names: Vec<_> = masses.iter().map(|m| m.name.as_str()).collect();
        loc.at(
            s.span(),
            key,
            format!(
                "unknown mass {n:?}: allowed are {}{}",
                if allow_ground { "`ground`, " } else { "" },
                names.join(", ")
            ),
        )
    })
}

/// `[[link]]`: two distinct ends (a ground end put second), polynomials, unique names.
pub(crate) fn check_links(loc: &Locator, raw: &RawScenario, masses: &[Mass]) -> Result<Vec<Link>, ScenarioError> {
    let mut links: Vec<Link> = Vec::new();
    for (i, l) in raw.link.iter().enumerate() {
        let key = format!("link[{i}]");
        let ends_raw = l.ends.get_ref();
        if ends_raw.len() != 2 {
            return Err(loc.at(
                l.ends.span(),
                format!("{key}.ends"),
                "a link has exactly two ends, e.g. [\"ground\", \"m1\"]",
            ));
        }
        let e0 = mass_index(loc, masses, &ends_raw[0], &format!("{key}.ends"), true)?;
        let e1 = mass_index(loc, masses, &ends_raw[1], &format!("{key}.ends"), true)?;
        if e0 == e1 {
            return Err(loc.at(
                l.ends.span(),
                format!("{key}.ends"),
                "the two ends of a link must differ",
            ));
        }
        // A ground end always goes second, so that `u = x_i − 0` is the mass's own
        // displacement whichever way round the file lists the ends (this matters for
        // even powers).
        let ends = match (e0, e1) {
            (End::Ground, m) => [m, End::Ground],
            _ => [e0, e1],
        };
        let default_name = format!("{}-{}", ends_raw[0].get_ref(), ends_raw[1].get_ref());
        let n = match &l.name {
            Some(n) => check_name(loc, n, &format!("{key}.name"), false)?,
            None => default_name,
        };
        if links.iter().any(|x| x.name == n) {
            return Err(loc.at(
                l.name.as_ref().map_or(l.ends.span(), |s| s.span()),
                format!("{key}.name"),
                format!("duplicate link name {n:?}: give the links distinct `name`s"),
            ));
        }
        let stiffness = curve(loc, &l.stiffness, &format!("{key}.stiffness"))?;
        let damping = curve(loc, &l.damping, &format!("{key}.damping"))?;
        let (k_unknown, c_unknown) = unknown_in_model_file(raw, &n);
        // A link with neither is a candidate link when [identify.select] gives candidate
        // terms for every link: the selection decides whether the data need it.
        let candidate = raw
            .identify
            .as_ref()
            .and_then(|i| i.select.as_ref())
            .is_some_and(|s| s.get_ref().stiffness.is_some() || s.get_ref().damping.is_some());
        if stiffness.is_empty() && damping.is_empty() && !k_unknown && !c_unknown && !candidate {
            return Err(loc.at(
                l.ends.span(),
                &key,
                "a link needs `stiffness` or `damping` (or both; in a model file with [data], unknown \
                 powers in [identify.links], or candidate terms in [identify.select])",
            ));
        }
        let hysteresis = l
            .hysteresis
            .as_ref()
            .map(|h| hysteresis(loc, raw, h, &format!("{key}.hysteresis")))
            .transpose()?;
        links.push(Link {
            name: n,
            ends,
            stiffness,
            damping,
            hysteresis,
        });
    }
    Ok(links)
}

/// `hysteresis = { stiffness, A, beta, gamma, n }`: a Bouc–Wen element whose loop is
/// bounded and dissipates (`β > 0`, `|γ| ≤ β`), `n` in 1..=8; a simulated system's only.
fn hysteresis(
    loc: &Locator,
    raw: &RawScenario,
    h: &Spanned<RawHysteresis>,
    key: &str,
) -> Result<BoucWen, ScenarioError> {
    if raw.data.is_some() {
        return Err(loc.at(
            h.span(),
            key,
            "a measured system's hysteresis is in its data: `hysteresis` belongs to a simulated system's truth",
        ));
    }
    let r = h.get_ref();
    let value = |v: &Spanned<f64>, name: &str, allowed: &str, ok: fn(f64) -> bool| {
        let x = *v.get_ref();
        if x.is_finite() && ok(x) {
            Ok(x)
        } else {
            Err(loc.at(
                v.span(),
                format!("{key}.{name}"),
                format!("{name} must be {allowed}, got {x}"),
            ))
        }
    };
    let bw = BoucWen {
        stiffness: value(&r.stiffness, "stiffness", "a positive force per unit of z", |x| x > 0.0)?,
        a: r.a
            .as_ref()
            .map_or(Ok(1.0), |v| value(v, "A", "positive", |x| x > 0.0))?,
        beta: value(&r.beta, "beta", "positive (the loop dissipates)", |x| x > 0.0)?,
        gamma: *r.gamma.get_ref(),
        n: r.n.as_ref().map_or(Ok(1.0), |v| {
            value(v, "n", "between 1 and 8", |x| (1.0..=8.0).contains(&x))
        })?,
    };
    if !bw.gamma.is_finite() || bw.gamma <= -bw.beta || bw.gamma > bw.beta {
        return Err(loc.at(
            r.gamma.span(),
            format!("{key}.gamma"),
            format!(
                "gamma must lie in (−beta, beta] = (−{0}, {0}] for a bounded, dissipating loop, got {1}",
                bw.beta, bw.gamma
            ),
        ));
    }
    Ok(bw)
}

/// Refuse a system that cannot have a stationary density (docs/scenario.md, "what is
/// refused"), which the whole method assumes:
/// - a mass without a spring path to ground: its displacement wanders without bound;
/// - no damper anywhere: the excitation's energy is never dissipated;
/// - between some pair of ends, a combined stiffness whose highest power is even or whose
///   leading coefficient is negative (the potential is unbounded below), or the same for
///   the damping (`C(w)·w` negative at large speeds, energy pumped in) — refused when the
///   springs form no loop, so that each pair's relative displacement is a free coordinate;
///   with loops other links may bound it, and nothing is decided here.
///
/// The physics is [`admissible::stationary`]'s; this places its reason in the file.
pub(crate) fn check_stationary(
    loc: &Locator,
    raw: &RawScenario,
    masses: &[Mass],
    links: &[Link],
) -> Result<(), ScenarioError> {
    // In a model file an unknown characteristic is there, with signs the data will tell.
    let unknown = |l: usize| unknown_in_model_file(raw, &links[l].name);
    let Err(why) = admissible::stationary(masses, links, unknown) else {
        return Ok(());
    };
    let (span, key) = match &why {
        NotStationary::NoSpringPath { mass } => (raw.mass[*mass].name.span(), format!("mass[{mass}]")),
        NotStationary::NoDamping => (raw.link.first().map_or(0..0, |l| l.ends.span()), "link".to_string()),
        NotStationary::Unbounded { link, kind, .. } => {
            let raw_poly = match kind {
                Characteristic::Stiffness => &raw.link[*link].stiffness,
                Characteristic::Damping => &raw.link[*link].damping,
            };
            (
                raw_poly
                    .as_ref()
                    .map_or_else(|| raw.link[*link].ends.span(), |s| s.span()),
                format!("link[{link}].{}", kind.name()),
            )
        }
    };
    Err(loc.at(span, key, why.describe(masses, links)))
}

/// `[[excitation]]`: white or filtered processes on named masses.
pub(crate) fn check_excitations(
    loc: &Locator,
    raw: &RawScenario,
    masses: &[Mass],
) -> Result<Vec<Excitation>, ScenarioError> {
    let mut excitations: Vec<Excitation> = Vec::new();
    for (i, e) in raw.excitation.iter().enumerate() {
        let key = format!("excitation[{i}]");
        let targets = e.acts_on.get_ref();
        if targets.is_empty() {
            return Err(loc.at(
                e.acts_on.span(),
                format!("{key}.acts_on"),
                "list at least one mass, e.g. [\"m1\"]",
            ));
        }
        let mut acts_on = Vec::new();
        for t in targets {
            let End::Mass(m) = mass_index(loc, masses, t, &format!("{key}.acts_on"), false)? else {
                unreachable!()
            };
            if acts_on.contains(&m) {
                return Err(loc.at(t.span(), format!("{key}.acts_on"), "mass listed twice"));
            }
            acts_on.push(m);
        }
        if matches!(*e.kind.get_ref(), RawKind::White | RawKind::Filtered) {
            lab::refuse_signal_keys(loc, e, &key)?;
        }
        let process = match *e.kind.get_ref() {
            RawKind::Multisine | RawKind::BandLimited | RawKind::KanaiTajimi | RawKind::Recorded => {
                Process::Lab(lab::check_signal(loc, e, &key)?)
            }
            RawKind::White => {
                if let Some(x) = e.a.as_ref().or(e.b.as_ref()) {
                    return Err(loc.at(
                        x.span(),
                        key.to_string(),
                        "`A` and `B` belong to kind = \"filtered\"; white noise takes `sigma`",
                    ));
                }
                // An equivalent white noise's level comes from its measured spectrum: its
                // `sigma`, if written, is only a start.
                let listed = |l: &Vec<Spanned<String>>| {
                    let default_name = targets
                        .iter()
                        .map(|t| t.get_ref().as_str())
                        .collect::<Vec<_>>()
                        .join("_");
                    let name = e.name.as_ref().map_or(default_name, |n| n.get_ref().clone());
                    l.iter().any(|n| *n.get_ref() == name)
                };
                let equivalent = raw.identify.as_ref().is_some_and(|i| {
                    i.equivalent_white.as_ref().is_some_and(listed) || i.choose_force_model.as_ref().is_some_and(listed)
                });
                match e.sigma.as_ref() {
                    None if equivalent => Process::White { sigma: 1.0 },
                    None => {
                        return Err(loc.at(
                            e.kind.span(),
                            format!("{key}.sigma"),
                            "white noise needs `sigma` (> 0), unless its level or model is taken from its measured \
                             spectrum ([identify] equivalent_white, choose_force_model)",
                        ))
                    }
                    Some(s) => Process::White {
                        sigma: finite_positive(loc, s, &format!("{key}.sigma"), "noise intensity")?,
                    },
                }
            }
            RawKind::Filtered => {
                if let Some(s) = &e.sigma {
                    return Err(loc.at(
                        s.span(),
                        format!("{key}.sigma"),
                        "`sigma` belongs to kind = \"white\"; filtered noise takes `A` and `B`",
                    ));
                }
                let a = e.a.as_ref().ok_or_else(|| {
                    loc.at(
                        e.kind.span(),
                        format!("{key}.A"),
                        "filtered noise needs `A` (> 0) and `B` (> 0, 1/s)",
                    )
                })?;
                let b = e.b.as_ref().ok_or_else(|| {
                    loc.at(
                        e.kind.span(),
                        format!("{key}.B"),
                        "filtered noise needs `A` (> 0) and `B` (> 0, 1/s)",
                    )
                })?;
                Process::Filtered {
                    a: finite_positive(loc, a, &format!("{key}.A"), "filter gain")?,
                    b: finite_positive(loc, b, &format!("{key}.B"), "corner frequency, 1/s")?,
                }
            }
        };
        let default_name = targets
            .iter()
            .map(|t| t.get_ref().as_str())
            .collect::<Vec<_>>()
            .join("_");
        let n = match &e.name {
            Some(n) => check_name(loc, n, &format!("{key}.name"), true)?,
            None => default_name,
        };
        if excitations.iter().any(|x| x.name == n) {
            return Err(loc.at(
                e.name.as_ref().map_or(e.acts_on.span(), |s| s.span()),
                format!("{key}.name"),
                format!("duplicate excitation name {n:?}: give the excitations distinct `name`s"),
            ));
        }
        excitations.push(Excitation {
            name: n,
            process,
            acts_on,
            measured: e.measured,
        });
    }
    if excitations.is_empty() {
        return Err(loc.at(0..0, "excitation", "no excitation: add at least one [[excitation]]"));
    }
    Ok(excitations)
}

/// `[simulation]`: step, record, sampling, burn-in, trajectories, scheme.
pub(crate) fn check_simulation(
    loc: &Locator,
    raw: &RawScenario,
    masses: &[Mass],
    links: &[Link],
) -> Result<Simulation, ScenarioError> {
    let s = raw.simulation.as_ref().ok_or_else(|| {
        loc.at(
            loc.src.len()..loc.src.len(),
            "simulation",
            "missing [simulation] section (dt, record_length, sample_interval)",
        )
    })?;
    let dt = finite_positive(loc, &s.dt, "simulation.dt", "s")?;
    let record_length = finite_positive(loc, &s.record_length, "simulation.record_length", "s per trajectory")?;
    let sample_interval = finite_positive(loc, &s.sample_interval, "simulation.sample_interval", "s")?;
    let ratio = sample_interval / dt;
    if (ratio - ratio.round()).abs() > 1e-6 * ratio.max(1.0) || ratio.round() < 1.0 {
        return Err(loc.at(
            s.sample_interval.span(),
            "simulation.sample_interval",
            format!("must be a whole multiple of dt = {dt} s (got {sample_interval} s = {ratio} dt)"),
        ));
    }
    if record_length < sample_interval {
        return Err(loc.at(
            s.record_length.span(),
            "simulation.record_length",
            format!("must be at least one sample_interval ({sample_interval} s)"),
        ));
    }
    let burn_in = match &s.burn_in {
        Some(b) => {
            let v = *b.get_ref();
            if !(v.is_finite() && v >= 0.0) {
                return Err(loc.at(
                    b.span(),
                    "simulation.burn_in",
                    format!("must be a finite number >= 0 (s), got {v}"),
                ));
            }
            v
        }
        None => admissible::default_burn_in(masses, links),
    };
    let count = |v: &Option<Spanned<i64>>, key: &str, default: usize, max: i64| -> Result<usize, ScenarioError> {
        match v {
            None => Ok(default),
            Some(x) if (1..=max).contains(x.get_ref()) => Ok(*x.get_ref() as usize),
            Some(x) => Err(loc.at(
                x.span(),
                key,
                format!("must be a whole number 1..={max}, got {}", x.get_ref()),
            )),
        }
    };
    let trajectories = count(
        &s.trajectories,
        "simulation.trajectories",
        16,
        super::MAX_TRAJECTORIES as i64,
    )?;
    let substeps = count(&s.substeps, "simulation.substeps", 1, super::MAX_SUBSTEPS as i64)?;
    let seed = match &s.seed {
        None => 1,
        Some(x) if *x.get_ref() >= 0 => *x.get_ref() as u64,
        Some(x) => return Err(loc.at(x.span(), "simulation.seed", "must be a whole number >= 0")),
    };
    let simulation = Simulation {
        dt,
        record_length,
        burn_in,
        sample_interval,
        trajectories,
        seed,
        scheme: s.scheme,
        substeps,
        sensors: Sensors::default(),
    };
    if let Err(e) = simulation.check() {
        // Only the budget and a default burn-in are left to fail here: point at the
        // burn-in when it is the larger part of the run, else at the record length.
        let (span, key, why) = match &s.burn_in {
            Some(b) if burn_in > record_length => (b.span(), "simulation.burn_in", String::new()),
            None if burn_in > record_length || !burn_in.is_finite() => (
                s.record_length.span(),
                "simulation.burn_in",
                format!(
                    " (the default burn-in is 10 slowest decay times 2m/c1 = {burn_in:.3e} s: \
                     set simulation.burn_in)"
                ),
            ),
            _ => (s.record_length.span(), "simulation.record_length", String::new()),
        };
        return Err(loc.at(span, key, format!("{e}{why}")));
    }
    Ok(simulation)
}
