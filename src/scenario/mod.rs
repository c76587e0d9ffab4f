//! Scenario files: the TOML a user writes, checked once, up front.
//!
//! Raw TOML is deserialised into `Raw*` structs that keep the source span of every value,
//! then [`Scenario::parse`] validates everything and returns a checked [`Scenario`]. Any
//! mistake becomes a [`ScenarioError`] that names the file, line, column and key and says
//! what is allowed. Nothing downstream re-validates: a `Scenario` is correct by
//! construction. This module depends on nothing else in the crate.

mod level;
pub mod overrides;
mod paper;
mod raw;
mod report_method;
mod sensors;
mod signal;
mod validate;

use crate::model::{Characteristic, Term};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;

/// An error in a scenario file, located in the source.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// The file could not be read at all.
    #[error("{path}: cannot read scenario: {source}")]
    Io {
        /// The file.
        path: String,
        /// Why it could not be read.
        #[source]
        source: std::io::Error,
    },
    /// A `--set KEY=VALUE` that cannot be applied (no line: it is not in the file).
    #[error("{path}: --set {key}: {message}")]
    Override {
        /// The scenario file.
        path: String,
        /// The key of the override.
        key: String,
        /// What is wrong with it.
        message: String,
    },
    /// A syntax error, a wrong type, an unknown key or an invalid value.
    #[error("{path}:{line}:{column}: `{key}`: {message}")]
    Invalid {
        /// The file.
        path: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// The dotted key, e.g. `link[2].stiffness`.
        key: String,
        /// What is wrong, and what is allowed.
        message: String,
    },
}

/// Whether the coordinates are translations (m, kg, N) or rotations (rad, kg·m², N·m).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Motion {
    #[default]
    /// Translations: m, kg, N.
    Translational,
    /// Rotations: rad, kg·m², N·m.
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
    /// About 100× less stationary-variance bias than the explicit scheme at the same cost;
    /// a bias of order `h` (`c·h/2m` on the velocity's variance) that long records resolve.
    SemiImplicit,
    /// Explicit Euler–Maruyama: inflates the stationary variance by about `k·dt/c`.
    EulerMaruyama,
    /// The stochastic Heun scheme (Kloeden–Platen's explicit weak order 2 scheme for
    /// additive noise): an Euler predictor, then the trapezoid of the drift at both ends on
    /// the same increment. Two force evaluations per step, a stationary bias of order
    /// `h²` (docs/methods.md, "The integrator's bias"). The default: at 2.5 ms it costs
    /// about half the semi-implicit scheme at 1 ms for a sixteenth of its bias or less
    /// (`benches/schemes.rs`), so intervals keep their coverage at long records.
    #[default]
    Heun,
}

impl Scheme {
    /// The word a scenario writes (`scheme = "…"`).
    pub fn name(self) -> &'static str {
        match self {
            Scheme::SemiImplicit => "semi-implicit",
            Scheme::EulerMaruyama => "euler-maruyama",
            Scheme::Heun => "heun",
        }
    }

    /// The scheme's weak order `p`: its bias on stationary statistics is `C·h^p`.
    pub fn weak_order(self) -> u32 {
        match self {
            Scheme::SemiImplicit | Scheme::EulerMaruyama => 1,
            Scheme::Heun => 2,
        }
    }
}

/// Identification methods are named by the estimators' registry (`estimators/mod.rs`).
pub use crate::method::Method;
pub use report_method::ReportMethod;
pub use sensors::{Adc, AntiAlias, MassSensors, NoiseScale, Sensors, MAGNITUDE, MIN_OVERSAMPLING};
pub use signal::{Recorded, Shape, Signal};

// ---------------------------------------------------------------------------------------
// Raw TOML, spans kept.

/// A point mass (or rotational inertia).
#[derive(Debug, Clone, PartialEq)]
pub struct Mass {
    /// The name links and excitations refer to.
    pub name: String,
    /// kg (translational) or kg·m² (rotational).
    pub value: f64,
    /// Whether the file gives the value: an unknown mass of a model file may leave it out
    /// (a rig in volts, whose "mass" is a gain's inverse), and then `value` is 1, only a
    /// start for its estimate ([`crate::ident::Problem::solve`] scales it), and no truth.
    pub valued: bool,
}

/// One end of a link.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum End {
    /// The ground (fixed).
    Ground,
    /// The mass of this index.
    Mass(usize),
}

/// A characteristic `K(u)` or `C(w)` as a scenario gives it: `Σ c_t t(z)` over its terms
/// (powers in the paper's (3.3)), each term once, sorted by term.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Curve {
    /// `(term, coefficient)`, each term once, sorted by term.
    pub terms: Vec<(Term, f64)>,
}

impl Curve {
    /// A power polynomial `Σ c_p z^p` from `(p, c_p)` pairs in ascending `p`.
    pub fn powers(terms: &[(u32, f64)]) -> Curve {
        Curve {
            terms: terms.iter().map(|&(p, c)| (Term::Power(p), c)).collect(),
        }
    }
    /// `Σ c_t t(z)`.
    pub fn eval(&self, z: f64) -> f64 {
        self.terms.iter().map(|&(t, c)| c * t.value(z)).sum()
    }
    /// The highest power among the terms (0 when there is none): the length of the
    /// model's dense polynomial form.
    pub fn max_power(&self) -> u32 {
        self.terms.iter().filter_map(|t| t.0.power()).max().unwrap_or(0)
    }
    /// The fastest growth far out among the terms ([`Term::far`]; 0 when there is none).
    pub fn growth(&self) -> u32 {
        self.terms
            .iter()
            .flat_map(|t| [1.0, -1.0].map(|s| t.0.far(s)))
            .filter(|f| f.coefficient != 0.0)
            .map(|f| f.growth)
            .max()
            .unwrap_or(0)
    }
    /// Whether it has no terms.
    pub fn is_empty(&self) -> bool {
        self.terms.is_empty()
    }
    /// The coefficient of term `t` (0 when absent).
    pub fn coefficient(&self, t: Term) -> f64 {
        self.terms.iter().find(|x| x.0 == t).map_or(0.0, |x| x.1)
    }
}

/// A spring and/or damper between a mass and the ground or another mass.
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    /// `ground-m1` style, from its ends.
    pub name: String,
    /// The force `K(u) + C(w)` with `u = x_a − x_b` acts against `ends[0]` and, reversed,
    /// against `ends[1]`.
    pub ends: [End; 2],
    /// `K(u)`, of the relative displacement `u`.
    pub stiffness: Curve,
    /// `C(w)`, of the relative velocity `w`.
    pub damping: Curve,
    /// A hysteretic force beside `K(u) + C(w)` (`hysteresis = { … }`): simulated, never
    /// identified (the method's link forces have one argument each).
    pub hysteresis: Option<crate::model::BoucWen>,
}

/// Reads a table: its column names and its columns, or why it cannot.
pub type TableReader = dyn Fn(&Path) -> Result<(Vec<String>, Vec<Vec<f64>>), String>;

/// The random process of an excitation.
#[derive(Debug, Clone, PartialEq)]
pub enum Process {
    /// `P dt = σ dW`: two-sided spectral density `σ²/2π`.
    White {
        /// The intensity σ (force·s^½).
        sigma: f64,
    },
    /// Ornstein–Uhlenbeck `dP = −B P dt + A dW` (3.20): spectral density `A²/(2π(B²+ω²))`,
    /// stationary variance `A²/(2B)`.
    Filtered {
        /// The white noise's intensity `A`.
        a: f64,
        /// The corner `B`, 1/s.
        b: f64,
    },
    /// A signal a lab drives its rig with (docs/excitations.md): each trajectory one
    /// realisation, simulated by `sim::lab`. The identifier knows it by its measured samples
    /// only, and reads it as its equivalent white noise (`[identify] equivalent_white`).
    Lab(Signal),
}

/// A random force acting, as one and the same process, on one or more masses.
#[derive(Debug, Clone, PartialEq)]
pub struct Excitation {
    /// The name its force column `p_<name>` carries.
    pub name: String,
    /// Its random process.
    pub process: Process,
    /// The masses it acts on (indices), with the same force.
    pub acts_on: Vec<usize>,
    /// An unmeasured excitation is a disturbance the identifier is never told about.
    pub measured: bool,
}

/// `[identify] sensor_noise`: what the identification does about sensor noise.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum NoiseHandling {
    /// Estimate each displacement's and velocity's noise from the samples, report it, and
    /// take it out of the weak form's moments (the default where `[measurement]` declares
    /// sensor noise and for measured data).
    #[default]
    Estimate,
    /// Take the noise `[measurement]` states as known (and still report the estimate).
    Given,
    /// Report the estimate, correct nothing.
    Ignore,
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
    /// The integration scheme.
    pub scheme: Scheme,
    /// Internal integration steps per `dt` (default 1).
    pub substeps: usize,
    /// `[measurement]`: the noise the sensors add to the logged samples.
    pub sensors: Sensors,
}

impl Simulation {
    /// The settings of a model file before its data are read (see
    /// [`crate::io::log::LogInfo::of_measured`]).
    pub fn placeholder() -> Simulation {
        Simulation {
            dt: 1.0,
            record_length: 1.0,
            burn_in: 0.0,
            sample_interval: 1.0,
            trajectories: 1,
            seed: 1,
            scheme: Scheme::default(),
            substeps: 1,
            sensors: Sensors::default(),
        }
    }

    /// Integration steps (of `dt`) between two samples.
    pub fn steps_per_sample(&self) -> usize {
        (self.sample_interval / self.dt).round() as usize
    }
    /// Samples recorded per trajectory.
    pub fn samples_per_trajectory(&self) -> usize {
        (self.record_length / self.sample_interval + 1e-9).floor() as usize
    }
    /// The time a trajectory spans, s: its burn-in steps and its samples.
    pub fn trajectory_span(&self) -> f64 {
        self.burn_in_steps() as f64 * self.dt + self.samples_per_trajectory() as f64 * self.sample_interval
    }
    /// Integration steps (of `dt`) of burn-in.
    pub fn burn_in_steps(&self) -> usize {
        (self.burn_in / self.dt).round() as usize
    }
    /// Internal integration steps of the whole run: burn-in and record, every trajectory,
    /// every substep.
    pub fn total_steps(&self) -> f64 {
        (self.burn_in + self.record_length) / self.dt * self.trajectories as f64 * self.substeps as f64
    }
    /// Whether these values describe a run this tool can make: the checks of
    /// [`Scenario::parse`] on already-typed values (a log's run facts, an edited scenario).
    /// The error says what is wrong and how to shorten a run that is too long.
    pub fn check(&self) -> Result<(), String> {
        let positive = |v: f64, key: &str| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{key} must be a finite number > 0, got {v}"))
            }
        };
        positive(self.dt, "dt")?;
        positive(self.sample_interval, "sample_interval")?;
        positive(self.record_length, "record_length")?;
        if !(self.burn_in.is_finite() && self.burn_in >= 0.0) {
            return Err(format!("burn_in must be a finite number >= 0, got {}", self.burn_in));
        }
        let ratio = self.sample_interval / self.dt;
        if (ratio - ratio.round()).abs() > 1e-6 * ratio.max(1.0) || ratio.round() < 1.0 {
            return Err(format!(
                "sample_interval must be a whole multiple of dt = {} s (got {} s = {ratio} dt)",
                self.dt, self.sample_interval
            ));
        }
        if self.record_length < self.sample_interval {
            return Err(format!(
                "record_length must be at least one sample_interval ({} s)",
                self.sample_interval
            ));
        }
        if !(1..=MAX_TRAJECTORIES).contains(&self.trajectories) {
            return Err(format!(
                "trajectories must be 1..={MAX_TRAJECTORIES}, got {}",
                self.trajectories
            ));
        }
        if !(1..=MAX_SUBSTEPS).contains(&self.substeps) {
            return Err(format!("substeps must be 1..={MAX_SUBSTEPS}, got {}", self.substeps));
        }
        let steps = self.total_steps();
        if steps > MAX_STEPS {
            return Err(format!(
                "the run is {steps:.1e} integration steps ((burn_in {} s + record_length {} s) / dt {} s \
                 x {} trajectories x {} substeps), beyond the {MAX_STEPS:.0e} this tool will run: \
                 shorten burn_in or record_length, or use fewer trajectories",
                self.burn_in, self.record_length, self.dt, self.trajectories, self.substeps
            ));
        }
        Ok(())
    }
}

/// Most trajectories a run may have.
pub const MAX_TRAJECTORIES: usize = 1 << 20;
/// Most substeps per `dt`.
pub const MAX_SUBSTEPS: usize = 1000;
/// Most integration steps a run may take, burn-in included (about a day on two cores).
pub const MAX_STEPS: f64 = 1e13;

/// Unknown coefficients of one link in `[identify.links.NAME]`.
#[derive(Debug, Clone, PartialEq)]
pub struct IdentifyLink {
    /// The link (index).
    pub link: usize,
    /// Terms of the stiffness model to identify; `None`: the stiffness is known.
    pub stiffness: Option<Vec<Term>>,
    /// Terms of the damping model to identify; `None`: the damping is known.
    pub damping: Option<Vec<Term>>,
}

/// `[identify]`: what the identifier is asked to find and how.
#[derive(Debug, Clone, PartialEq)]
pub struct Identify {
    /// The identification methods, in the order reported.
    pub methods: Vec<Method>,
    /// Per link; links not listed are known. Default when the section has no `links`:
    /// every link's stiffness and damping unknown with the true powers.
    pub links: Vec<IdentifyLink>,
    /// Masses whose value is unknown (indices).
    pub unknown_masses: Vec<usize>,
    /// Excitations whose intensity (`sigma`, or `A`) is unknown.
    pub unknown_intensities: Vec<usize>,
    /// Filtered excitations whose `A`, `B` the identifier is given; the others' are
    /// fitted to the measured force's spectrum.
    pub known_filters: Vec<usize>,
    /// Filtered excitations whose corner `B` is unknown: the drift is then bilinear, and
    /// the identifier solves for the monomial coefficients `B`, `B·θ`, `θ`.
    pub unknown_corners: Vec<usize>,
    /// Measured white excitations whose level `sigma` is not given but taken from the
    /// measured force's spectrum over the band where the response has its energy: the
    /// equivalent white noise of a band-limited or multisine input (docs/methods.md,
    /// "The force model").
    pub equivalent_white: Vec<usize>,
    /// Measured excitations whose model the identifier chooses from the force's spectrum:
    /// white over the response's band, first-order (3.20), or — a second-order rational
    /// spectrum or none — refused (docs/methods.md, "Choosing the force model").
    pub choose_force_model: Vec<usize>,
    /// Alternative models identified alongside for comparison (e.g. the paper's linear
    /// case 1), by name: each replaces `links`; reported, not gated.
    pub compare: Vec<(String, Vec<IdentifyLink>)>,
    /// `[identify.disturbance]`: identify with the paper's iterative procedure for an
    /// unmeasured disturbance (section 4) instead of the ordinary methods.
    pub disturbance: Option<Disturbance>,
    /// What to do about sensor noise (`sensor_noise`).
    pub sensor_noise: NoiseHandling,
    /// `[identify.select]`: choose the model's terms from candidates (docs/selection.md).
    pub select: Option<Select>,
    /// `[identify.profile]`: the position of one term (a gap) chosen over a range.
    pub profile: Option<Profile>,
}

/// `[identify.profile]`: a term whose position (a gap, a saturation amplitude, a knot) is
/// not given but chosen over a range: the weak form is identified at each of `points`
/// evenly spaced positions and the one whose equations fit best is kept (docs/scenario.md
/// "Terms").
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    /// The link (index).
    pub link: usize,
    /// Its stiffness or damping.
    pub kind: Characteristic,
    /// The term as `[identify.links]` lists it.
    pub term: Term,
    /// The positions' range, in the term's unit.
    pub range: (f64, f64),
    /// How many positions are tried, evenly over the range.
    pub points: usize,
}

impl Profile {
    /// The positions tried, ascending, each rounded to 10 significant digits (so they
    /// read as the decimals they are meant to be: 0.145, not 0.14500000000000002).
    pub fn positions(&self) -> Vec<f64> {
        let (a, b) = self.range;
        (0..self.points)
            .map(|i| {
                let x = a + (b - a) * i as f64 / (self.points - 1) as f64;
                format!("{x:.9e}").parse().unwrap_or(x)
            })
            .collect()
    }

    /// `links` with the profiled term at position `x`.
    pub fn links_at(&self, links: &[IdentifyLink], x: f64) -> Vec<IdentifyLink> {
        let moved = self
            .term
            .at_position(x)
            .expect("positions are checked against the term");
        let mut out = links.to_vec();
        for l in out.iter_mut().filter(|l| l.link == self.link) {
            let list = match self.kind {
                Characteristic::Stiffness => &mut l.stiffness,
                Characteristic::Damping => &mut l.damping,
            };
            for t in list.iter_mut().flatten().filter(|t| **t == self.term) {
                *t = moved;
            }
            if let Some(list) = list {
                list.sort_unstable();
            }
        }
        out
    }
}

impl Identify {
    /// Why structure selection cannot run on this `[identify]` section, if it cannot.
    pub fn select_unsupported(&self, excitations: &[Excitation]) -> Option<String> {
        let filtered_fitted = (0..excitations.len()).any(|e| {
            excitations[e].measured
                && matches!(excitations[e].process, Process::Filtered { .. })
                && !self.known_filters.contains(&e)
        });
        let why = if self.disturbance.is_some() {
            "the iterative procedure of [identify.disturbance]"
        } else if !self.unknown_masses.is_empty() {
            "unknown masses"
        } else if !self.unknown_intensities.is_empty() {
            "unknown intensities"
        } else if !self.unknown_corners.is_empty() || filtered_fitted {
            "filters fitted to the force spectra (list them in known_filters)"
        } else if !self.equivalent_white.is_empty() || !self.choose_force_model.is_empty() {
            "white levels or force models taken from the force spectra (give their sigma)"
        } else {
            return None;
        };
        Some(format!(
            "structure selection chooses among spring and damper terms with everything else known; \
             it does not combine with {why}"
        ))
    }
}

/// `[identify.select]` (or `--select`): the unknown terms are candidates, and the
/// identification keeps those the data need (docs/selection.md).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Select {
    /// Candidate terms of every link's stiffness; `None`: each link's `[identify.links]`
    /// stiffness terms.
    pub stiffness: Option<Vec<Term>>,
    /// Candidate terms of every link's damping; `None`: as for the stiffness.
    pub damping: Option<Vec<Term>>,
}

impl Select {
    /// The candidate model over `links`: `identify`'s unknown terms, every link's
    /// stiffness or damping replaced by the candidates given for all links.
    pub fn candidates(&self, links: &[Link], identify: &[IdentifyLink]) -> Vec<IdentifyLink> {
        (0..links.len())
            .filter_map(|l| {
                let own = identify.iter().find(|il| il.link == l);
                let stiffness = self
                    .stiffness
                    .clone()
                    .or_else(|| own.and_then(|il| il.stiffness.clone()));
                let damping = self.damping.clone().or_else(|| own.and_then(|il| il.damping.clone()));
                (stiffness.is_some() || damping.is_some()).then_some(IdentifyLink {
                    link: l,
                    stiffness,
                    damping,
                })
            })
            .collect()
    }
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
    /// The paper's two-mass structure in this scenario.
    pub structure: PaperStructure,
}

/// The paper's two-mass structure (4.3), as found in a scenario: a free mass `m1` tied by
/// a linear spring `k1` (the coupling link) to a driven mass `m2`, which is tied to the
/// ground by `K2`, `C2` and driven by the one measured force `P2`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PaperStructure {
    /// The free mass `m1`.
    pub free: usize,
    /// The driven mass `m2`.
    pub driven: usize,
    /// The coupling link `k1`.
    pub coupling: usize,
    /// The driven mass's ground link `K2`, `C2`.
    pub ground: usize,
    /// The measured force `P2`.
    pub measured: usize,
}

/// `[accept]`: the accuracy gate.
#[derive(Debug, Clone, PartialEq)]
pub struct Accept {
    /// Largest allowed worst relative error (docs/methods.md, accuracy), for every method without its own.
    pub worst_rel_error: f64,
    /// Per report method (a [`ReportMethod::gated`] name): its own threshold.
    pub methods: BTreeMap<String, f64>,
    /// Whether `worst_rel_error` is the scenario's own (else the 5 % default, which no
    /// spread over seeds calibrated).
    pub calibrated: bool,
}

impl Accept {
    /// Whether `method`'s threshold is the uncalibrated default.
    pub fn is_default(&self, method: &ReportMethod) -> bool {
        !self.calibrated && !self.methods.contains_key(&method.name())
    }

    /// The threshold of report method `method`.
    pub fn threshold(&self, method: &ReportMethod) -> f64 {
        self.methods
            .get(&method.name())
            .copied()
            .unwrap_or(self.worst_rel_error)
    }
}

/// `[data]` of a model file: where the model's quantities are in a measured table.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DataMapping {
    /// The time column (s), if the table has one.
    pub time: Option<String>,
    /// The sample interval when there is no time column (s).
    pub sample_interval: Option<f64>,
    /// The record-id column: each record is an independent trajectory.
    pub record: Option<String>,
    /// Per log column (`x_<mass>`, `v_<mass>`, `a_<mass>`, `p_<excitation>`): the table's
    /// column, by name.
    pub columns: Vec<(String, String)>,
    /// Factors to SI units, per table column (default 1).
    pub scale: BTreeMap<String, f64>,
    /// Table columns whose mean over the identification's data is taken out before the
    /// scale (a sensor's or an amplifier's DC offset; docs/data.md).
    pub remove_mean: Vec<String>,
    /// Column names of a plain 2-D `.npy` array, in order.
    pub npy_columns: Vec<String>,
    /// The topic of an MCAP file from another tool (JSON messages; the columns are the
    /// messages' fields, `log_time` their log time in s).
    pub topic: Option<String>,
    /// Derivatives the table lacks are derived (central differences): velocities from
    /// displacements, accelerations from velocities.
    pub derive: bool,
    /// With `derive`, velocities and displacements integrated from accelerations: the
    /// period (s) below which the drift removal takes the integrals' content out
    /// (docs/data.md); `None`: chosen from the data.
    pub drift_period: Option<f64>,
    /// What the accelerations' samples are: values at the instants (the default) or means
    /// over the intervals (`acceleration_samples = "interval_means"`).
    pub acceleration_samples: AccelerationSamples,
    /// A record's time gaps (a step of 1.5 sample intervals or more) split it into
    /// pieces, each an independent record, instead of being refused.
    pub split_gaps: bool,
    /// A CSV file's field delimiter; `None`: the header's own (`,`, `;` or tab).
    pub delimiter: Option<u8>,
    /// A CSV file's numbers use a decimal comma (`decimal = ","`).
    pub decimal_comma: bool,
    /// The jackknife's independent units (`[data] independent`): `None` chooses (whole
    /// records where the records are found to be periods of a periodic excitation).
    pub independent: Option<Independent>,
}

/// What the standard errors take as independent draws (`[data] independent`,
/// docs/data.md "Independent records"; `pipeline::units`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Independent {
    /// Stretches of the records (`"stretches"`): under stationary random excitation a
    /// stretch much longer than the motion's correlation time is a draw of its own.
    Stretches,
    /// Whole records only (`"records"`): each record one realisation of a periodic
    /// excitation (a multisine's blocks), whose stretches share its lines' phases.
    Records,
}

/// What a table's acceleration at `t_k` is (`[data] acceleration_samples`, docs/data.md;
/// the integration's rules are in `io::measured::integrate`): an accelerometer's value at
/// the instant (its anti-alias filter's output, sampled), or the mean over the interval
/// that ends there, `(v_k − v_{k−1})/h` (fpkbench's own log and export of a white-forced
/// motion, whose acceleration has no value at an instant). With interval means, a force
/// declared white is its interval's mean too (the acceleration balances that mean), as
/// the force regression reads it. The trapezoid rule is right for values at instants and
/// the rectangle rule exact for interval means; the trapezoid on interval means pairs two
/// intervals' forces, a white error on the velocity (docs/measurement.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AccelerationSamples {
    /// Values at the sample times (`"instants"`).
    #[default]
    Instants,
    /// Means over the intervals that end at the sample times (`"interval_means"`).
    IntervalMeans,
}

/// A checked scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// The scenario's name (file stem by default).
    pub name: String,
    /// One line on what it is.
    pub description: String,
    /// Translational or rotational coordinates.
    pub motion: Motion,
    /// The masses, in order.
    pub masses: Vec<Mass>,
    /// The links, in order.
    pub links: Vec<Link>,
    /// The excitations, in order.
    pub excitations: Vec<Excitation>,
    /// `[simulation]`.
    pub simulation: Simulation,
    /// `[identify]`.
    pub identify: Identify,
    /// `[accept]`.
    pub accept: Accept,
    /// `[data]`: a model file for measured data (`identify --model --data`); its
    /// `[simulation]` is then taken from the data, and the coefficients to identify need
    /// no values (no accuracy is reported without them).
    pub data: Option<DataMapping>,
    /// The TOML text it was parsed from (stored in logs).
    pub source: String,
    /// The unmeasured disturbances rescaled by [`Scenario::with_disturbance_level`]
    /// (`None`: as `source` has them). A log records it among its run facts, so that the
    /// scenario it describes is `source` at this level.
    pub disturbance_level: Option<f64>,
}

impl Scenario {
    /// Read and validate a scenario file.
    pub fn from_file(path: &Path) -> Result<Scenario, ScenarioError> {
        let label = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|source| ScenarioError::Io {
            path: label.clone(),
            source,
        })?;
        let src = String::from_utf8(bytes).map_err(|e| {
            let good = &e.as_bytes()[..e.utf8_error().valid_up_to()];
            let good = std::str::from_utf8(good).unwrap_or("");
            let line = good.matches('\n').count() + 1;
            ScenarioError::Invalid {
                path: label.clone(),
                line,
                column: good.len() - good.rfind('\n').map_or(0, |i| i + 1) + 1,
                key: "(text)".into(),
                message: "the file is not UTF-8 text (TOML must be UTF-8): an invalid byte here".into(),
            }
        })?;
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scenario".into());
        Scenario::parse(&src, &label, &stem)
    }

    /// Read the tables of the recorded signals that drive the run (`kind = "recorded"`,
    /// their `file` relative to `dir`, by `read`: a table's column names and columns) and
    /// check them against it; `label` names the text (`source`) in errors. A parsed
    /// scenario has its recordings unread until then (`io::scenario_file` reads them; a
    /// log's scenario needs none: its forces are in the log).
    pub fn read_recordings(&mut self, label: &str, dir: &Path, read: &TableReader) -> Result<(), ScenarioError> {
        validate::lab::read_recordings(self, label, dir, read)
    }

    /// Take the samples `from` has read for every unread recording of the same excitation
    /// and table (a study's items re-parse the scenario's text; the run checks that each
    /// item's trajectories fit in the recording).
    pub fn adopt_recordings(&mut self, from: &Scenario) {
        for e in &mut self.excitations {
            let Process::Lab(Signal::Recorded(r)) = &mut e.process else {
                continue;
            };
            let read = from.excitations.iter().find_map(|f| match &f.process {
                Process::Lab(Signal::Recorded(q))
                    if f.name == e.name && q.file == r.file && q.column == r.column && q.time == r.time =>
                {
                    Some(q)
                }
                _ => None,
            });
            if let Some(q) = read.filter(|_| r.samples.is_empty()) {
                let r = std::sync::Arc::make_mut(r);
                r.samples.clone_from(&q.samples);
                r.interval = r.interval.or(q.interval);
            }
        }
    }

    /// Whether the unknowns can be told apart at all, whatever the data: refused are
    /// parallel links (the same two ends) with an unknown coefficient of the same power,
    /// of which only the sum acts. Explicit `[identify.links]` are checked by
    /// [`Scenario::parse`]; the default unknowns (every coefficient of every link) only here,
    /// so that such a system can still be simulated. `run` and `identify` check it before
    /// any work.
    pub fn check_separable(&self) -> Result<(), String> {
        let l = &self.identify.links;
        for (i, a) in l.iter().enumerate() {
            for b in &l[i + 1..] {
                if let Some(why) = validate::inseparable(&self.links, a, b) {
                    return Err(why);
                }
            }
        }
        Ok(())
    }

    /// The true value of every parameter, by its human-readable name
    /// (`m[m1]`, `k3[ground-m1]`, `c1[m1-m2]`, `sigma[m1]`, `A[P]`, `B[P]`).
    pub fn truth(&self) -> Vec<(String, f64)> {
        use crate::model::{Characteristic, ParameterName as N};
        let mut out = Vec::new();
        for m in &self.masses {
            out.push((N::Mass(m.name.clone()), if m.valued { m.value } else { f64::NAN }));
        }
        for l in &self.links {
            for (kind, poly) in [
                (Characteristic::Stiffness, &l.stiffness),
                (Characteristic::Damping, &l.damping),
            ] {
                for &(term, c) in &poly.terms {
                    let link = l.name.clone();
                    // A hysteretic link's force is not a function of u and w: no
                    // one-argument characteristic is its truth, nothing of it is graded.
                    let c = if l.hysteresis.is_some() { f64::NAN } else { c };
                    out.push((N::Coefficient { kind, term, link }, c));
                }
            }
        }
        for e in &self.excitations {
            match e.process {
                Process::White { sigma } => out.push((N::Intensity(e.name.clone()), sigma)),
                Process::Filtered { a, b } => {
                    out.push((N::FilterGain(e.name.clone()), a));
                    out.push((N::Corner(e.name.clone()), b));
                }
                // Known to the identifier by its samples: no parameter of it is estimated.
                Process::Lab(_) => {}
            }
        }
        out.into_iter().map(|(n, v)| (n.to_string(), v)).collect()
    }
}
