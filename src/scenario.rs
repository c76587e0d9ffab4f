//! Scenario files: the TOML a user writes, checked once, up front.
//!
//! Raw TOML is deserialised into `Raw*` structs that keep the source span of every value,
//! then [`Scenario::parse`] validates everything and returns a checked [`Scenario`]. Any
//! mistake becomes a [`ScenarioError`] that names the file, line, column and key and says
//! what is allowed. Nothing downstream re-validates: a `Scenario` is correct by
//! construction. This module depends on nothing else in the crate.

use serde::Deserialize;
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::Path;
use toml::Spanned;

/// An error in a scenario file, located in the source.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// The file could not be read at all.
    #[error("{path}: cannot read scenario: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    /// A syntax error, a wrong type, an unknown key or an invalid value.
    #[error("{path}:{line}:{column}: `{key}`: {message}")]
    Invalid {
        path: String,
        line: usize,
        column: usize,
        key: String,
        message: String,
    },
}

/// Whether the coordinates are translations (m, kg, N) or rotations (rad, kg·m², N·m).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Motion {
    #[default]
    Translational,
    Rotational,
}

impl Motion {
    /// Units of (displacement, velocity, acceleration, force, mass).
    pub fn units(self) -> [&'static str; 5] {
        match self {
            Motion::Translational => ["m", "m/s", "m/s^2", "N", "kg"],
            Motion::Rotational => ["rad", "rad/s", "rad/s^2", "N*m", "kg*m^2"],
        }
    }
}

/// Time-stepping scheme of the simulator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Scheme {
    /// Update `v` with the old state, then `x` with the new `v` (symplectic Euler–Maruyama).
    /// About 100× less stationary-variance bias than the explicit scheme at the same cost.
    #[default]
    SemiImplicit,
    /// Explicit Euler–Maruyama: inflates the stationary variance by about `k·dt/c`.
    EulerMaruyama,
}

impl Scheme {
    pub fn name(self) -> &'static str {
        match self {
            Scheme::SemiImplicit => "semi-implicit",
            Scheme::EulerMaruyama => "euler-maruyama",
        }
    }
}

/// Identification method named in `[identify] methods`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Deserialize, Hash)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Weak form: stationarity of test-function expectations (DESIGN §5).
    Weak,
    /// Strong form: the paper's FPK residual on a density grid (3.8)–(3.15).
    Strong,
    /// Strong form with the joint density replaced by the product of marginals (3.21).
    StrongMarginals,
}

impl Method {
    pub const ALL: [Method; 3] = [Method::Weak, Method::Strong, Method::StrongMarginals];
    pub fn name(self) -> &'static str {
        match self {
            Method::Weak => "weak",
            Method::Strong => "strong",
            Method::StrongMarginals => "strong-marginals",
        }
    }
}

// ---------------------------------------------------------------------------------------
// Raw TOML, spans kept.

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScenario {
    name: Option<Spanned<String>>,
    description: Option<String>,
    #[serde(default)]
    motion: Motion,
    #[serde(default)]
    mass: Vec<RawMass>,
    #[serde(default)]
    link: Vec<RawLink>,
    #[serde(default)]
    excitation: Vec<RawExcitation>,
    simulation: Option<RawSimulation>,
    identify: Option<RawIdentify>,
    accept: Option<RawAccept>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMass {
    name: Spanned<String>,
    value: Spanned<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLink {
    name: Option<Spanned<String>>,
    ends: Spanned<Vec<Spanned<String>>>,
    stiffness: Option<Spanned<BTreeMap<String, Spanned<f64>>>>,
    damping: Option<Spanned<BTreeMap<String, Spanned<f64>>>>,
}

#[derive(Deserialize, Clone, Copy, PartialEq, Eq, Debug)]
#[serde(rename_all = "kebab-case")]
enum RawKind {
    White,
    Filtered,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawExcitation {
    name: Option<Spanned<String>>,
    kind: Spanned<RawKind>,
    sigma: Option<Spanned<f64>>,
    #[serde(rename = "A")]
    a: Option<Spanned<f64>>,
    #[serde(rename = "B")]
    b: Option<Spanned<f64>>,
    acts_on: Spanned<Vec<Spanned<String>>>,
    #[serde(default = "yes")]
    measured: bool,
}

fn yes() -> bool {
    true
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSimulation {
    dt: Spanned<f64>,
    record_length: Spanned<f64>,
    burn_in: Option<Spanned<f64>>,
    sample_interval: Spanned<f64>,
    trajectories: Option<Spanned<i64>>,
    seed: Option<Spanned<i64>>,
    #[serde(default)]
    scheme: Scheme,
    substeps: Option<Spanned<i64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawIdentify {
    methods: Option<Vec<Method>>,
    unknown_masses: Option<Vec<Spanned<String>>>,
    unknown_intensities: Option<Vec<Spanned<String>>>,
    known_filters: Option<Vec<Spanned<String>>>,
    unknown_corners: Option<Vec<Spanned<String>>>,
    links: Option<BTreeMap<String, Spanned<RawIdentifyLink>>>,
    compare: Option<BTreeMap<String, Spanned<RawCompare>>>,
    disturbance: Option<Spanned<RawDisturbance>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawDisturbance {
    max_steps: Option<Spanned<i64>>,
    tolerance: Option<Spanned<f64>>,
    sweep: Option<Spanned<Vec<Spanned<f64>>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCompare {
    links: BTreeMap<String, Spanned<RawIdentifyLink>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawIdentifyLink {
    stiffness: Option<Vec<Spanned<i64>>>,
    damping: Option<Vec<Spanned<i64>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAccept {
    worst_rel_error: Option<Spanned<f64>>,
    methods: Option<BTreeMap<String, Spanned<f64>>>,
}

// ---------------------------------------------------------------------------------------
// Checked scenario.

/// A point mass (or rotational inertia).
#[derive(Debug, Clone, PartialEq)]
pub struct Mass {
    pub name: String,
    /// kg (translational) or kg·m² (rotational).
    pub value: f64,
}

/// One end of a link.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum End {
    Ground,
    Mass(usize),
}

/// A polynomial characteristic `Σ c_p z^p` over positive integer powers, sorted by power.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Polynomial {
    pub terms: Vec<(u32, f64)>,
}

impl Polynomial {
    pub fn eval(&self, z: f64) -> f64 {
        self.terms.iter().map(|&(p, c)| c * z.powi(p as i32)).sum()
    }
    pub fn max_power(&self) -> u32 {
        self.terms.last().map_or(0, |t| t.0)
    }
    pub fn is_empty(&self) -> bool {
        self.terms.is_empty()
    }
    /// Coefficient of `z^p` (0 when absent).
    pub fn coefficient(&self, p: u32) -> f64 {
        self.terms.iter().find(|t| t.0 == p).map_or(0.0, |t| t.1)
    }
}

/// A spring and/or damper between a mass and the ground or another mass.
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    pub name: String,
    /// The force `K(u) + C(w)` with `u = x_a − x_b` acts against `ends[0]` and, reversed,
    /// against `ends[1]`.
    pub ends: [End; 2],
    pub stiffness: Polynomial,
    pub damping: Polynomial,
}

/// The random process of an excitation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Process {
    /// `P dt = σ dW`: two-sided spectral density `σ²/2π`.
    White { sigma: f64 },
    /// Ornstein–Uhlenbeck `dP = −B P dt + A dW` (3.20): spectral density `A²/(2π(B²+ω²))`,
    /// stationary variance `A²/(2B)`.
    Filtered { a: f64, b: f64 },
}

/// A random force acting, as one and the same process, on one or more masses.
#[derive(Debug, Clone, PartialEq)]
pub struct Excitation {
    pub name: String,
    pub process: Process,
    pub acts_on: Vec<usize>,
    /// An unmeasured excitation is a disturbance the identifier is never told about.
    pub measured: bool,
}

/// `[simulation]`: how the response is generated and sampled.
#[derive(Debug, Clone, PartialEq)]
pub struct Simulation {
    /// Integration step, s.
    pub dt: f64,
    /// Recorded time per trajectory after burn-in, s.
    pub record_length: f64,
    /// Time simulated and discarded before recording, s (default: 10 slowest decay times,
    /// see [`Scenario::parse`]).
    pub burn_in: f64,
    /// Time between logged samples, s; a whole multiple of `dt`.
    pub sample_interval: f64,
    /// Number of independent trajectories (default 16).
    pub trajectories: usize,
    /// Master seed; trajectory `j` uses a generator seeded from `(seed, j)`.
    pub seed: u64,
    pub scheme: Scheme,
    /// Internal integration steps per `dt` (default 1).
    pub substeps: usize,
}

impl Simulation {
    /// Integration steps (of `dt`) between two samples.
    pub fn steps_per_sample(&self) -> usize {
        (self.sample_interval / self.dt).round() as usize
    }
    /// Samples recorded per trajectory.
    pub fn samples_per_trajectory(&self) -> usize {
        (self.record_length / self.sample_interval + 1e-9).floor() as usize
    }
    /// Integration steps (of `dt`) of burn-in.
    pub fn burn_in_steps(&self) -> usize {
        (self.burn_in / self.dt).round() as usize
    }
}

/// Unknown coefficients of one link in `[identify.links.NAME]`.
#[derive(Debug, Clone, PartialEq)]
pub struct IdentifyLink {
    pub link: usize,
    /// Powers of the stiffness model to identify; `None`: the stiffness is known.
    pub stiffness: Option<Vec<u32>>,
    /// Powers of the damping model to identify; `None`: the damping is known.
    pub damping: Option<Vec<u32>>,
}

/// `[identify]`: what the identifier is asked to find and how.
#[derive(Debug, Clone, PartialEq)]
pub struct Identify {
    pub methods: Vec<Method>,
    /// Per link; links not listed are known. Default when the section has no `links`:
    /// every link's stiffness and damping unknown with the true powers.
    pub links: Vec<IdentifyLink>,
    pub unknown_masses: Vec<usize>,
    /// Excitations whose intensity (`sigma`, or `A`) is unknown.
    pub unknown_intensities: Vec<usize>,
    /// Filtered excitations whose `A`, `B` the identifier is given; the others' are
    /// fitted to the measured force's spectrum.
    pub known_filters: Vec<usize>,
    /// Filtered excitations whose corner `B` is unknown: the drift is then bilinear, and
    /// the identifier solves for the monomial coefficients `B`, `B·θ`, `θ`.
    pub unknown_corners: Vec<usize>,
    /// Alternative models identified alongside for comparison (e.g. the paper's linear
    /// case 1), by name: each replaces `links`; reported, not gated.
    pub compare: Vec<(String, Vec<IdentifyLink>)>,
    /// `[identify.disturbance]`: identify with the paper's iterative procedure for an
    /// unmeasured disturbance (section 4) instead of the ordinary methods.
    pub disturbance: Option<Disturbance>,
}

/// `[identify.disturbance]`: the paper's successive approximations (section 4).
#[derive(Debug, Clone, PartialEq)]
pub struct Disturbance {
    /// Stop after this many steps after step 0 (the paper's rule 1).
    pub max_steps: usize,
    /// Stop when every coefficient changed by less than this fraction of its value in the
    /// last step (the paper's rule 2, with relative rather than absolute ε).
    pub tolerance: f64,
    /// Disturbance levels of `fpkbench sweep`: standard deviation of the unmeasured force
    /// over that of the measured one (0 = no disturbance).
    pub sweep: Vec<f64>,
    pub structure: PaperStructure,
}

/// The paper's two-mass structure (4.3), as found in a scenario: a free mass `m1` tied by
/// a linear spring `k1` (the coupling link) to a driven mass `m2`, which is tied to the
/// ground by `K2`, `C2` and driven by the one measured force `P2`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PaperStructure {
    pub free: usize,
    pub driven: usize,
    pub coupling: usize,
    pub ground: usize,
    pub measured: usize,
}

/// `[accept]`: the accuracy gate.
#[derive(Debug, Clone, PartialEq)]
pub struct Accept {
    /// Largest allowed worst relative error (DESIGN §7), for every method without its own.
    pub worst_rel_error: f64,
    /// Per report method (a [`Method`]'s name, or [`ITERATED_FORCE`] or [`DIRECT_FORCE`]
    /// with `[identify.disturbance]`): its own threshold.
    pub methods: BTreeMap<String, f64>,
}

/// The report method of the iterative procedure with the measured-force single-mass step
/// (`[identify.disturbance]`; the paper's own is `iterated`).
pub const ITERATED_FORCE: &str = "iterated-force";

/// The report method of the one-step solve of the subtracted equation (4.8) for `k1`,
/// `K2`, `C2` with `P3` as a measured force (`[identify.disturbance]`).
pub const DIRECT_FORCE: &str = "direct-force";

impl Accept {
    /// The threshold of report method `method` (e.g. `weak`, `iterated-force`).
    pub fn threshold(&self, method: &str) -> f64 {
        self.methods.get(method).copied().unwrap_or(self.worst_rel_error)
    }
}

/// A checked scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    pub name: String,
    pub description: String,
    pub motion: Motion,
    pub masses: Vec<Mass>,
    pub links: Vec<Link>,
    pub excitations: Vec<Excitation>,
    pub simulation: Simulation,
    pub identify: Identify,
    pub accept: Accept,
    /// The TOML text it was parsed from (stored in logs).
    pub source: String,
}

/// Byte-offset → line/column and key lookup for error messages.
struct Locator<'a> {
    path: &'a str,
    src: &'a str,
}

impl Locator<'_> {
    fn at(&self, span: Range<usize>, key: impl Into<String>, message: impl Into<String>) -> ScenarioError {
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
    fn key_at(&self, offset: usize) -> String {
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

fn finite_positive(loc: &Locator, v: &Spanned<f64>, key: &str, what: &str) -> Result<f64, ScenarioError> {
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
fn check_name(loc: &Locator, s: &Spanned<String>, key: &str, field: bool) -> Result<String, ScenarioError> {
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

fn polynomial(
    loc: &Locator,
    raw: &Option<Spanned<BTreeMap<String, Spanned<f64>>>>,
    key: &str,
) -> Result<Polynomial, ScenarioError> {
    let Some(map) = raw else {
        return Ok(Polynomial::default());
    };
    let mut terms = Vec::new();
    for (p, c) in map.get_ref() {
        let power: u32 = match p.parse::<u32>() {
            Ok(p) if (1..=15).contains(&p) => p,
            _ => {
                return Err(loc.at(
                    c.span(),
                    format!("{key}.{p}"),
                    format!(
                        "power {p:?} is not allowed: powers are whole numbers 1..=15, e.g. {{ 1 = 10.0, 3 = 20.0 }}"
                    ),
                ))
            }
        };
        let v = *c.get_ref();
        if !v.is_finite() {
            return Err(loc.at(
                c.span(),
                format!("{key}.{p}"),
                format!("coefficient must be a finite number, got {v}"),
            ));
        }
        terms.push((power, v));
    }
    if terms.is_empty() {
        return Err(loc.at(
            map.span(),
            key,
            "empty: give at least one power, e.g. { 1 = 10.0 }, or leave the key out",
        ));
    }
    terms.sort_by_key(|t| t.0);
    Ok(Polynomial { terms })
}

fn powers(loc: &Locator, raw: &Option<Vec<Spanned<i64>>>, key: &str) -> Result<Option<Vec<u32>>, ScenarioError> {
    let Some(list) = raw else { return Ok(None) };
    let mut out = Vec::new();
    for p in list {
        let v = *p.get_ref();
        if !(1..=15).contains(&v) {
            return Err(loc.at(
                p.span(),
                key,
                format!("power {v} is not allowed: powers are whole numbers 1..=15"),
            ));
        }
        if out.contains(&(v as u32)) {
            return Err(loc.at(p.span(), key, format!("power {v} is listed twice")));
        }
        out.push(v as u32);
    }
    if out.is_empty() {
        return Ok(None);
    }
    out.sort_unstable();
    Ok(Some(out))
}

impl Scenario {
    /// Read and validate a scenario file.
    pub fn from_file(path: &Path) -> Result<Scenario, ScenarioError> {
        let label = path.display().to_string();
        let src = std::fs::read_to_string(path).map_err(|source| ScenarioError::Io {
            path: label.clone(),
            source,
        })?;
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scenario".into());
        Scenario::parse(&src, &label, &stem)
    }

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
            loc.at(span, key, msg)
        })?;

        let name = match &raw.name {
            Some(n) => check_name(&loc, n, "name", false)?,
            None => default_name.to_string(),
        };

        // Masses.
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
            let n = check_name(&loc, &m.name, &format!("{key}.name"), true)?;
            if masses.iter().any(|x| x.name == n) {
                return Err(loc.at(
                    m.name.span(),
                    format!("{key}.name"),
                    format!("duplicate mass name {n:?}: names must be unique"),
                ));
            }
            let v = finite_positive(&loc, &m.value, &format!("{key}.value"), raw.motion.units()[4])?;
            masses.push(Mass { name: n, value: v });
        }
        let mass_index = |s: &Spanned<String>, key: &str, allow_ground: bool| -> Result<End, ScenarioError> {
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
        };

        // Links.
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
            let e0 = mass_index(&ends_raw[0], &format!("{key}.ends"), true)?;
            let e1 = mass_index(&ends_raw[1], &format!("{key}.ends"), true)?;
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
                Some(n) => check_name(&loc, n, &format!("{key}.name"), false)?,
                None => default_name,
            };
            if links.iter().any(|x| x.name == n) {
                return Err(loc.at(
                    l.name.as_ref().map_or(l.ends.span(), |s| s.span()),
                    format!("{key}.name"),
                    format!("duplicate link name {n:?}: give the links distinct `name`s"),
                ));
            }
            let stiffness = polynomial(&loc, &l.stiffness, &format!("{key}.stiffness"))?;
            let damping = polynomial(&loc, &l.damping, &format!("{key}.damping"))?;
            if stiffness.is_empty() && damping.is_empty() {
                return Err(loc.at(l.ends.span(), &key, "a link needs `stiffness` or `damping` (or both)"));
            }
            links.push(Link {
                name: n,
                ends,
                stiffness,
                damping,
            });
        }

        // Excitations.
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
                let End::Mass(m) = mass_index(t, &format!("{key}.acts_on"), false)? else {
                    unreachable!()
                };
                if acts_on.contains(&m) {
                    return Err(loc.at(t.span(), format!("{key}.acts_on"), "mass listed twice"));
                }
                acts_on.push(m);
            }
            let process = match *e.kind.get_ref() {
                RawKind::White => {
                    if let Some(x) = e.a.as_ref().or(e.b.as_ref()) {
                        return Err(loc.at(
                            x.span(),
                            key.to_string(),
                            "`A` and `B` belong to kind = \"filtered\"; white noise takes `sigma`",
                        ));
                    }
                    let s = e.sigma.as_ref().ok_or_else(|| {
                        loc.at(e.kind.span(), format!("{key}.sigma"), "white noise needs `sigma` (> 0)")
                    })?;
                    Process::White {
                        sigma: finite_positive(&loc, s, &format!("{key}.sigma"), "noise intensity")?,
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
                        a: finite_positive(&loc, a, &format!("{key}.A"), "filter gain")?,
                        b: finite_positive(&loc, b, &format!("{key}.B"), "corner frequency, 1/s")?,
                    }
                }
            };
            let default_name = targets
                .iter()
                .map(|t| t.get_ref().as_str())
                .collect::<Vec<_>>()
                .join("_");
            let n = match &e.name {
                Some(n) => check_name(&loc, n, &format!("{key}.name"), true)?,
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

        // Simulation.
        let s = raw.simulation.as_ref().ok_or_else(|| {
            loc.at(
                src.len()..src.len(),
                "simulation",
                "missing [simulation] section (dt, record_length, sample_interval)",
            )
        })?;
        let dt = finite_positive(&loc, &s.dt, "simulation.dt", "s")?;
        let record_length = finite_positive(&loc, &s.record_length, "simulation.record_length", "s per trajectory")?;
        let sample_interval = finite_positive(&loc, &s.sample_interval, "simulation.sample_interval", "s")?;
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
            None => default_burn_in(&masses, &links),
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
        let trajectories = count(&s.trajectories, "simulation.trajectories", 16, 1 << 20)?;
        let substeps = count(&s.substeps, "simulation.substeps", 1, 1000)?;
        let seed = match &s.seed {
            None => 1,
            Some(x) if *x.get_ref() >= 0 => *x.get_ref() as u64,
            Some(x) => return Err(loc.at(x.span(), "simulation.seed", "must be a whole number >= 0")),
        };
        let steps = record_length / dt * trajectories as f64 * substeps as f64;
        if steps > 1e13 {
            return Err(loc.at(
                s.record_length.span(),
                "simulation.record_length",
                format!("{steps:.1e} integration steps in total is beyond what this tool will run (1e13)"),
            ));
        }
        let simulation = Simulation {
            dt,
            record_length,
            burn_in,
            sample_interval,
            trajectories,
            seed,
            scheme: s.scheme,
            substeps,
        };

        // Identify.
        let ident = raw.identify.as_ref();
        let methods = ident
            .and_then(|i| i.methods.clone())
            .unwrap_or_else(|| vec![Method::Weak]);
        let parse_links = |map: &BTreeMap<String, Spanned<RawIdentifyLink>>,
                           prefix: &str|
         -> Result<Vec<IdentifyLink>, ScenarioError> {
            let mut out = Vec::new();
            for (lname, spec) in map {
                let key = format!("{prefix}.{lname}");
                let link = links.iter().position(|l| &l.name == lname).ok_or_else(|| {
                    let names: Vec<_> = links.iter().map(|l| l.name.as_str()).collect();
                    loc.at(
                        spec.span(),
                        &key,
                        format!("unknown link {lname:?}: links are {}", names.join(", ")),
                    )
                })?;
                let sp = spec.get_ref();
                out.push(IdentifyLink {
                    link,
                    stiffness: powers(&loc, &sp.stiffness, &format!("{key}.stiffness"))?,
                    damping: powers(&loc, &sp.damping, &format!("{key}.damping"))?,
                });
            }
            out.sort_by_key(|l| l.link);
            Ok(out)
        };
        let id_links = match ident.and_then(|i| i.links.as_ref()) {
            Some(map) => parse_links(map, "identify.links")?,
            None => links
                .iter()
                .enumerate()
                .map(|(i, l)| {
                    let ps = |p: &Polynomial| (!p.is_empty()).then(|| p.terms.iter().map(|t| t.0).collect());
                    IdentifyLink {
                        link: i,
                        stiffness: ps(&l.stiffness),
                        damping: ps(&l.damping),
                    }
                })
                .collect(),
        };
        let mut compare = Vec::new();
        for (name, c) in ident.and_then(|i| i.compare.as_ref()).into_iter().flatten() {
            compare.push((
                name.clone(),
                parse_links(&c.get_ref().links, &format!("identify.compare.{name}.links"))?,
            ));
        }
        // Names of filtered excitations in an `[identify]` list.
        let filtered_list = |list: Option<&Vec<Spanned<String>>>, key: &str| -> Result<Vec<usize>, ScenarioError> {
            let mut out = Vec::new();
            for e in list.into_iter().flatten() {
                let k = excitations.iter().position(|x| &x.name == e.get_ref()).ok_or_else(|| {
                    let names: Vec<_> = excitations.iter().map(|x| x.name.as_str()).collect();
                    loc.at(
                        e.span(),
                        key,
                        format!(
                            "unknown excitation {:?}: excitations are {}",
                            e.get_ref(),
                            names.join(", ")
                        ),
                    )
                })?;
                if !matches!(excitations[k].process, Process::Filtered { .. }) {
                    return Err(loc.at(
                        e.span(),
                        key,
                        format!(
                            "excitation {:?} is white: only filtered excitations have A and B",
                            e.get_ref()
                        ),
                    ));
                }
                out.push(k);
            }
            Ok(out)
        };
        let known_filters = filtered_list(ident.and_then(|i| i.known_filters.as_ref()), "identify.known_filters")?;
        let unknown_corners = filtered_list(
            ident.and_then(|i| i.unknown_corners.as_ref()),
            "identify.unknown_corners",
        )?;
        let mut unknown_masses = Vec::new();
        for m in ident.and_then(|i| i.unknown_masses.as_ref()).into_iter().flatten() {
            let End::Mass(k) = mass_index(m, "identify.unknown_masses", false)? else {
                unreachable!()
            };
            unknown_masses.push(k);
        }
        let mut unknown_intensities = Vec::new();
        for e in ident.and_then(|i| i.unknown_intensities.as_ref()).into_iter().flatten() {
            let k = excitations.iter().position(|x| &x.name == e.get_ref()).ok_or_else(|| {
                let names: Vec<_> = excitations.iter().map(|x| x.name.as_str()).collect();
                loc.at(
                    e.span(),
                    "identify.unknown_intensities",
                    format!(
                        "unknown excitation {:?}: excitations are {}",
                        e.get_ref(),
                        names.join(", ")
                    ),
                )
            })?;
            unknown_intensities.push(k);
        }
        let disturbance = match ident.and_then(|i| i.disturbance.as_ref()) {
            None => None,
            Some(d) => {
                let raw_d = d.get_ref();
                let max_steps = match &raw_d.max_steps {
                    None => 10,
                    Some(v) if (1..=1000).contains(v.get_ref()) => *v.get_ref() as usize,
                    Some(v) => {
                        return Err(loc.at(
                            v.span(),
                            "identify.disturbance.max_steps",
                            format!("must be a whole number 1..=1000, got {}", v.get_ref()),
                        ))
                    }
                };
                let tolerance = match &raw_d.tolerance {
                    None => 1e-3,
                    Some(v) => finite_positive(
                        &loc,
                        v,
                        "identify.disturbance.tolerance",
                        "largest relative change of any coefficient in the last step, e.g. 1e-3",
                    )?,
                };
                let sweep = match &raw_d.sweep {
                    None => vec![0.0, 0.25, 0.5, 1.0, 2.0],
                    Some(list) => {
                        let mut out = Vec::new();
                        for v in list.get_ref() {
                            let x = *v.get_ref();
                            if !(x.is_finite() && x >= 0.0) {
                                return Err(loc.at(
                                    v.span(),
                                    "identify.disturbance.sweep",
                                    format!("levels are finite numbers >= 0 (std of the disturbance over std of the measured force), got {x}"),
                                ));
                            }
                            out.push(x);
                        }
                        if out.is_empty() {
                            return Err(loc.at(
                                list.span(),
                                "identify.disturbance.sweep",
                                "empty: give the levels, e.g. [0, 0.25, 0.5, 1, 2]",
                            ));
                        }
                        out
                    }
                };
                let structure = paper_structure(
                    &masses,
                    &links,
                    &excitations,
                    &id_links,
                    &unknown_masses,
                    &unknown_intensities,
                    &unknown_corners,
                )
                .map_err(|m| loc.at(d.span(), "identify.disturbance", m))?;
                Some(Disturbance {
                    max_steps,
                    tolerance,
                    sweep,
                    structure,
                })
            }
        };
        let identify = Identify {
            methods,
            links: id_links,
            unknown_masses,
            unknown_intensities,
            known_filters,
            unknown_corners,
            compare,
            disturbance,
        };

        // Accept.
        let mut accept = Accept {
            worst_rel_error: 0.05,
            methods: BTreeMap::new(),
        };
        if let Some(a) = &raw.accept {
            if let Some(w) = &a.worst_rel_error {
                accept.worst_rel_error =
                    finite_positive(&loc, w, "accept.worst_rel_error", "relative error, e.g. 0.03")?;
            }
            let mut allowed: Vec<&str> = Method::ALL.iter().map(|x| x.name()).collect();
            if identify.disturbance.is_some() {
                allowed.extend([ITERATED_FORCE, DIRECT_FORCE]);
            }
            for (m, v) in a.methods.iter().flatten() {
                let key = format!("accept.methods.{m}");
                if !allowed.contains(&m.as_str()) {
                    return Err(loc.at(
                        v.span(),
                        &key,
                        format!("unknown method {m:?}: methods are {}", allowed.join(", ")),
                    ));
                }
                accept
                    .methods
                    .insert(m.clone(), finite_positive(&loc, v, &key, "relative error")?);
            }
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
            source: src.to_string(),
        })
    }

    /// This scenario with every unmeasured excitation scaled so that its standard deviation
    /// is `level` times the measured force's (at level 0 they are removed) — the source
    /// text is rewritten too, so a log of it describes what was simulated. White noise
    /// counts at the sample interval (it is logged as interval means). `[simulation]` is
    /// kept as it is in memory, so changes made to it before or after both hold.
    pub fn with_disturbance_level(&self, level: f64) -> Result<Scenario, ScenarioError> {
        let dt = self.simulation.sample_interval;
        let std = |p: Process| match p {
            Process::White { sigma } => sigma / dt.sqrt(),
            Process::Filtered { a, b } => a / (2.0 * b).sqrt(),
        };
        let reference = self
            .excitations
            .iter()
            .find(|e| e.measured)
            .map_or(1.0, |e| std(e.process));
        let mut table: toml::Table = toml::from_str(&self.source).map_err(|e| ScenarioError::Invalid {
            path: self.name.clone(),
            line: 1,
            column: 1,
            key: "(top level)".into(),
            message: e.to_string(),
        })?;
        if let Some(toml::Value::Array(list)) = table.get_mut("excitation") {
            let mut kept = Vec::new();
            for (e, v) in self.excitations.iter().zip(list.drain(..)) {
                let mut v = v;
                if !e.measured {
                    if level == 0.0 {
                        continue;
                    }
                    let k = level * reference / std(e.process);
                    if let Some(t) = v.as_table_mut() {
                        let key = if t.contains_key("sigma") { "sigma" } else { "A" };
                        let old = t
                            .get(key)
                            .and_then(|x| x.as_float().or(x.as_integer().map(|i| i as f64)));
                        t.insert(key.into(), toml::Value::Float(k * old.unwrap_or(0.0)));
                    }
                }
                kept.push(v);
            }
            *list = kept;
        }
        let src = format!(
            "# {} with its unmeasured disturbance at level {level} (std relative to the measured force), written by fpkbench\n{}",
            self.name,
            toml::to_string(&table).map_err(|e| ScenarioError::Invalid {
                path: self.name.clone(),
                line: 1,
                column: 1,
                key: "(top level)".into(),
                message: e.to_string(),
            })?
        );
        let mut out = Scenario::parse(&src, &format!("{} at disturbance level {level}", self.name), &self.name)?;
        // `[simulation]` as this scenario has it, edits made since parsing included (a log's
        // run facts record them).
        out.simulation = self.simulation.clone();
        Ok(out)
    }

    /// The true value of every parameter, by its human-readable name
    /// (`m[m1]`, `k3[ground-m1]`, `c1[m1-m2]`, `sigma[m1]`, `A[P]`, `B[P]`).
    pub fn truth(&self) -> Vec<(String, f64)> {
        let mut out = Vec::new();
        for m in &self.masses {
            out.push((format!("m[{}]", m.name), m.value));
        }
        for l in &self.links {
            for &(p, c) in &l.stiffness.terms {
                out.push((format!("k{p}[{}]", l.name), c));
            }
            for &(p, c) in &l.damping.terms {
                out.push((format!("c{p}[{}]", l.name), c));
            }
        }
        for e in &self.excitations {
            match e.process {
                Process::White { sigma } => out.push((format!("sigma[{}]", e.name), sigma)),
                Process::Filtered { a, b } => {
                    out.push((format!("A[{}]", e.name), a));
                    out.push((format!("B[{}]", e.name), b));
                }
            }
        }
        out
    }
}

/// Find the paper's structure (4.3) for the iterative procedure of section 4, or say what
/// is missing.
fn paper_structure(
    masses: &[Mass],
    links: &[Link],
    excitations: &[Excitation],
    id_links: &[IdentifyLink],
    unknown_masses: &[usize],
    unknown_intensities: &[usize],
    unknown_corners: &[usize],
) -> Result<PaperStructure, String> {
    let need = "the iterative procedure (paper section 4) is defined for its two-mass structure (4.3): \
                a free mass tied only by a linear spring k1 (no damper; identify stiffness = [1]) to a \
                driven mass, which is tied to the ground by K2, C2 (identified) and driven by the one \
                measured force; any unmeasured disturbances";
    let fail = |what: &str| Err(format!("{what}; {need}"));
    if masses.len() != 2 {
        return fail(&format!("the scenario has {} masses", masses.len()));
    }
    let measured: Vec<usize> = (0..excitations.len()).filter(|&e| excitations[e].measured).collect();
    let [measured] = measured[..] else {
        return fail(&format!("the scenario has {} measured excitations", measured.len()));
    };
    let [driven] = excitations[measured].acts_on[..] else {
        return fail(&format!(
            "the measured excitation {:?} acts on several masses",
            excitations[measured].name
        ));
    };
    let free = 1 - driven;
    if links.len() != 2 {
        return fail(&format!("the scenario has {} links", links.len()));
    }
    let coupling = links
        .iter()
        .position(|l| l.ends.contains(&End::Mass(free)) && l.ends.contains(&End::Mass(driven)));
    let ground = links.iter().position(|l| l.ends == [End::Mass(driven), End::Ground]);
    let (Some(coupling), Some(ground)) = (coupling, ground) else {
        return fail(&format!(
            "the links must join {} to {} and {} to the ground",
            masses[free].name, masses[driven].name, masses[driven].name
        ));
    };
    if !links[coupling].damping.is_empty() {
        return fail(&format!("link {:?} has a damper", links[coupling].name));
    }
    let id = |l: usize| id_links.iter().find(|x| x.link == l);
    match id(coupling) {
        Some(IdentifyLink {
            stiffness: Some(p),
            damping: None,
            ..
        }) if p == &[1] => {}
        _ => {
            return fail(&format!(
                "[identify.links.{}] must be {{ stiffness = [1] }}",
                links[coupling].name
            ))
        }
    }
    match id(ground) {
        Some(IdentifyLink { stiffness, damping, .. }) if stiffness.is_some() || damping.is_some() => {}
        _ => {
            return fail(&format!(
                "[identify.links.{}] must list K2 and/or C2 powers",
                links[ground].name
            ))
        }
    }
    if !unknown_masses.is_empty() || !unknown_intensities.is_empty() || !unknown_corners.is_empty() {
        return fail("masses, intensities and corners must be known");
    }
    Ok(PaperStructure {
        free,
        driven,
        coupling,
        ground,
        measured,
    })
}

/// Ten times the slowest modal decay time estimated per mass from its own links
/// (`2m / Σc1`), at least 20 s: enough to forget the zero initial state.
fn default_burn_in(masses: &[Mass], links: &[Link]) -> f64 {
    let mut worst: f64 = 0.0;
    for (i, m) in masses.iter().enumerate() {
        let c: f64 = links
            .iter()
            .filter(|l| l.ends.contains(&End::Mass(i)))
            .map(|l| l.damping.coefficient(1).abs())
            .sum();
        let tau = if c > 0.0 { 2.0 * m.value / c } else { 100.0 };
        worst = worst.max(tau);
    }
    (10.0 * worst).max(20.0)
}
