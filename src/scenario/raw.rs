//! The scenario file as written: serde structs that mirror the TOML, with spans for error
//! locations. Nothing here is checked; [`super::validate`] turns it into a [`super::Scenario`].

use super::{Method, Motion, Scheme};
use serde::Deserialize;
use std::collections::BTreeMap;
use toml::Spanned;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawScenario {
    pub(super) name: Option<Spanned<String>>,
    pub(super) description: Option<String>,
    #[serde(default)]
    pub(super) motion: Motion,
    #[serde(default)]
    pub(super) mass: Vec<RawMass>,
    #[serde(default)]
    pub(super) link: Vec<RawLink>,
    #[serde(default)]
    pub(super) excitation: Vec<RawExcitation>,
    pub(super) simulation: Option<RawSimulation>,
    pub(super) identify: Option<RawIdentify>,
    pub(super) accept: Option<RawAccept>,
    pub(super) data: Option<Spanned<RawData>>,
    pub(super) measurement: Option<RawMeasurement>,
}

/// `[measurement]`: the sensors' noise.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawMeasurement {
    #[serde(default)]
    pub(super) noise: super::NoiseScale,
    pub(super) displacement: Option<Spanned<f64>>,
    pub(super) velocity: Option<Spanned<f64>>,
    pub(super) acceleration: Option<Spanned<f64>>,
    pub(super) force: Option<Spanned<f64>>,
    pub(super) adc_bits: Option<Spanned<i64>>,
    pub(super) adc_range: Option<Spanned<f64>>,
    pub(super) anti_alias: Option<Spanned<f64>>,
    pub(super) anti_alias_order: Option<Spanned<i64>>,
    pub(super) bandwidth: Option<Spanned<f64>>,
    pub(super) sensors: Option<Spanned<BTreeMap<String, Spanned<Words>>>>,
}

/// A list of words, each with its place in the file.
pub(crate) type Words = Vec<Spanned<String>>;

/// `[data]`: how measured data map onto the model (a model file for `identify --model`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawData {
    pub(super) time: Option<Spanned<String>>,
    pub(super) sample_interval: Option<Spanned<f64>>,
    pub(super) record: Option<Spanned<String>>,
    pub(super) columns: Spanned<BTreeMap<String, Spanned<String>>>,
    pub(super) scale: Option<BTreeMap<String, Spanned<f64>>>,
    pub(super) remove_mean: Option<Vec<Spanned<String>>>,
    pub(super) npy_columns: Option<Vec<Spanned<String>>>,
    pub(super) topic: Option<Spanned<String>>,
    pub(super) derive: Option<bool>,
    pub(super) drift_period: Option<Spanned<f64>>,
    pub(super) acceleration_samples: Option<Spanned<String>>,
    pub(super) split_gaps: Option<Spanned<bool>>,
    pub(super) delimiter: Option<Spanned<String>>,
    pub(super) decimal: Option<Spanned<String>>,
    pub(super) independent: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawMass {
    pub(super) name: Spanned<String>,
    pub(super) value: Option<Spanned<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawLink {
    pub(super) name: Option<Spanned<String>>,
    pub(super) ends: Spanned<Vec<Spanned<String>>>,
    pub(super) stiffness: Option<Spanned<BTreeMap<String, Spanned<f64>>>>,
    pub(super) damping: Option<Spanned<BTreeMap<String, Spanned<f64>>>>,
    pub(super) hysteresis: Option<Spanned<RawHysteresis>>,
}

/// A link's Bouc–Wen element (`model::BoucWen`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawHysteresis {
    pub(super) stiffness: Spanned<f64>,
    #[serde(rename = "A")]
    pub(super) a: Option<Spanned<f64>>,
    pub(super) beta: Spanned<f64>,
    pub(super) gamma: Spanned<f64>,
    pub(super) n: Option<Spanned<f64>>,
}

#[derive(Deserialize, Clone, Copy, PartialEq, Eq, Debug)]
#[serde(rename_all = "kebab-case")]
pub(crate) enum RawKind {
    White,
    Filtered,
    Multisine,
    BandLimited,
    KanaiTajimi,
    Recorded,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawExcitation {
    pub(super) name: Option<Spanned<String>>,
    pub(super) kind: Spanned<RawKind>,
    pub(super) sigma: Option<Spanned<f64>>,
    #[serde(rename = "A")]
    pub(super) a: Option<Spanned<f64>>,
    #[serde(rename = "B")]
    pub(super) b: Option<Spanned<f64>>,
    pub(super) acts_on: Spanned<Vec<Spanned<String>>>,
    #[serde(default = "yes")]
    pub(super) measured: bool,
    // The lab signals' keys (docs/excitations.md).
    pub(super) rms: Option<Spanned<f64>>,
    pub(super) band: Option<Spanned<Vec<Spanned<f64>>>>,
    pub(super) period: Option<Spanned<f64>>,
    pub(super) lines: Option<Spanned<String>>,
    pub(super) amplitude: Option<Spanned<Vec<(f64, f64)>>>,
    pub(super) order: Option<Spanned<i64>>,
    pub(super) omega_g: Option<Spanned<f64>>,
    pub(super) zeta_g: Option<Spanned<f64>>,
    // A recorded signal's keys.
    pub(super) file: Option<Spanned<String>>,
    pub(super) column: Option<Spanned<String>>,
    pub(super) time: Option<Spanned<String>>,
    pub(super) sample_interval: Option<Spanned<f64>>,
    pub(super) scale: Option<Spanned<f64>>,
}

pub(crate) fn yes() -> bool {
    true
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawSimulation {
    pub(super) dt: Spanned<f64>,
    pub(super) record_length: Spanned<f64>,
    pub(super) burn_in: Option<Spanned<f64>>,
    pub(super) sample_interval: Spanned<f64>,
    pub(super) trajectories: Option<Spanned<i64>>,
    pub(super) seed: Option<Spanned<i64>>,
    #[serde(default)]
    pub(super) scheme: Scheme,
    pub(super) substeps: Option<Spanned<i64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawIdentify {
    pub(super) methods: Option<Spanned<Vec<Method>>>,
    pub(super) unknown_masses: Option<Vec<Spanned<String>>>,
    pub(super) unknown_intensities: Option<Vec<Spanned<String>>>,
    pub(super) known_filters: Option<Vec<Spanned<String>>>,
    pub(super) unknown_corners: Option<Vec<Spanned<String>>>,
    pub(super) equivalent_white: Option<Vec<Spanned<String>>>,
    pub(super) choose_force_model: Option<Vec<Spanned<String>>>,
    pub(super) links: Option<BTreeMap<String, Spanned<RawIdentifyLink>>>,
    pub(super) compare: Option<BTreeMap<String, Spanned<RawCompare>>>,
    pub(super) disturbance: Option<Spanned<RawDisturbance>>,
    pub(super) sensor_noise: Option<Spanned<super::NoiseHandling>>,
    pub(super) select: Option<Spanned<RawSelect>>,
    pub(super) profile: Option<Spanned<RawProfile>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawProfile {
    pub(super) parameter: Spanned<String>,
    /// Optional here so that a missing range is named at `[identify.profile]`, not at its
    /// parent table (serde's own error).
    pub(super) range: Option<Spanned<Vec<f64>>>,
    pub(super) points: Option<Spanned<i64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawSelect {
    pub(super) stiffness: Option<Vec<Spanned<RawTerm>>>,
    pub(super) damping: Option<Vec<Spanned<RawTerm>>>,
}

/// A term in a list: a power as a number (`3`) or any term as its name (`"sign"`,
/// `"gap(0.05)"`).
#[derive(Deserialize)]
#[serde(untagged)]
pub(crate) enum RawTerm {
    Power(i64),
    Named(String),
}

impl std::fmt::Display for RawTerm {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RawTerm::Power(p) => write!(f, "{p}"),
            RawTerm::Named(s) => f.write_str(s),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawDisturbance {
    pub(super) max_steps: Option<Spanned<i64>>,
    pub(super) tolerance: Option<Spanned<f64>>,
    pub(super) sweep: Option<Spanned<Vec<Spanned<f64>>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawCompare {
    pub(super) links: BTreeMap<String, Spanned<RawIdentifyLink>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawIdentifyLink {
    pub(super) stiffness: Option<Vec<Spanned<RawTerm>>>,
    pub(super) damping: Option<Vec<Spanned<RawTerm>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawAccept {
    pub(super) worst_rel_error: Option<Spanned<f64>>,
    pub(super) methods: Option<BTreeMap<String, Spanned<f64>>>,
}

// ---------------------------------------------------------------------------------------
// Checked scenario.
