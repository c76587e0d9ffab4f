//! A study's rows and their summary: what one method gave on one item (`Row`), the item's
//! coordinates, and per configuration and method the distribution over the seeds
//! (`summarize`, `paired`). They sit below the report writers (`super::study`) and above
//! nothing but the report's types; `crate::pipeline::study` runs the items that make them.

use super::{Outcome, Report};
use serde::{Deserialize, Serialize};

mod summary;
pub use summary::{paired, summarize, Paired, ParameterSummary, ReliabilityBin, SelectionSummary, Summary};

/// One item: a configuration and a seed index.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Item {
    pub index: usize,
    pub record_length: f64,
    pub sample_interval: f64,
    /// The sensor noise level of a study over noise levels (`noise_levels`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensor_noise: Option<f64>,
    pub seed_index: usize,
    pub seed: u64,
    /// How many items the whole study has (0 in rows written before it was recorded), so
    /// that a merge can tell a missing shard.
    #[serde(default)]
    pub of: usize,
}

impl Item {
    /// The item's file name: its configuration, never its shard.
    pub fn key(&self) -> String {
        let noise = self.sensor_noise.map_or(String::new(), |n| format!("-n{n}"));
        format!(
            "T{}-h{}{noise}-s{}",
            self.record_length, self.sample_interval, self.seed_index
        )
    }

    /// Its configuration: record length, sample interval and sensor noise level.
    pub fn configuration(&self) -> Configuration {
        Configuration {
            record_length: self.record_length,
            sample_interval: self.sample_interval,
            sensor_noise: self.sensor_noise,
        }
    }
}

/// What a study varies besides the seed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Configuration {
    pub record_length: f64,
    pub sample_interval: f64,
    /// The sensor noise's std as a fraction of each channel's std (a study over noise levels).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sensor_noise: Option<f64>,
}

impl Configuration {
    /// The order of a study's tables: by record length, interval, then noise level.
    pub fn order(&self, other: &Configuration) -> std::cmp::Ordering {
        let noise = |c: &Configuration| c.sensor_noise.unwrap_or(-1.0);
        self.record_length
            .total_cmp(&other.record_length)
            .then(self.sample_interval.total_cmp(&other.sample_interval))
            .then(noise(self).total_cmp(&noise(other)))
    }
}

/// One method's result on one item.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Row {
    pub study: String,
    pub item: Item,
    pub method: String,
    /// Estimated, refused, not applicable, or failed (the item could not be run).
    pub outcome: Outcome,
    pub samples: u64,
    /// Why the method gave no estimate (then the numbers are empty).
    pub error: Option<String>,
    pub worst_rel_error: Option<f64>,
    pub parameters: Vec<RowParameter>,
    /// Writing the log (0 without logs: the simulation then runs inside the passes).
    pub simulate_s: f64,
    /// This method's own solve.
    pub identify_s: f64,
    /// The whole item (simulation, passes over the samples, every method).
    pub item_s: f64,
    /// With structure selection: what the method's model kept and lost against the truth.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub selection: Option<RowSelection>,
}

/// A selected model against the truth (docs/selection.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RowSelection {
    pub candidates: usize,
    pub selected: Vec<String>,
    /// Candidates with a non-zero true coefficient that the selection dropped.
    pub true_dropped: Vec<String>,
    /// Candidates with a zero true coefficient that the selection kept.
    pub false_kept: Vec<String>,
    /// Links the model has a term of and the truth has none of (a candidate link the
    /// truth lacks, kept).
    #[serde(default)]
    pub false_links: Vec<String>,
    /// Every candidate's inclusion over the bootstrap resamples, with whether the truth
    /// has it: in the selection's own model's rows (empty in the baseline's).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub inclusion: Vec<TermInclusion>,
}

/// One candidate's share of the bootstrap resamples that selected it, against the truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TermInclusion {
    pub term: String,
    pub share: f64,
    pub truth: bool,
}

impl RowSelection {
    /// The terms a method's model kept (`selected`) from the report's candidates, against
    /// the truth; with the candidates' inclusion frequencies when `own` (the selection's
    /// own model, not a compared one).
    pub fn of(r: &Report, selected: &[String], own: bool) -> Option<RowSelection> {
        let s = &r.selection.as_ref()?.selection;
        let own = own
            && s.selected_names()
                .iter()
                .map(|n| n.to_string())
                .eq(selected.iter().cloned());
        let mut out = RowSelection {
            candidates: s.candidates.len(),
            selected: Vec::new(),
            true_dropped: Vec::new(),
            false_kept: Vec::new(),
            false_links: Vec::new(),
            inclusion: Vec::new(),
        };
        // Per link: whether the truth has a term of it, whether the model keeps one.
        let mut links: Vec<(String, bool, bool)> = Vec::new();
        for (name, &share) in s.candidates.iter().zip(&s.inclusion) {
            let kept = selected.contains(&name.to_string());
            let truth = r.truth.of(name).unwrap_or(0.0) != 0.0;
            match (kept, truth) {
                (true, false) => out.false_kept.push(name.to_string()),
                (false, true) => out.true_dropped.push(name.to_string()),
                _ => {}
            }
            if kept {
                out.selected.push(name.to_string());
            }
            if own {
                out.inclusion.push(TermInclusion {
                    term: name.to_string(),
                    share,
                    truth,
                });
            }
            if let Some(crate::model::ParameterName::Coefficient { link, .. }) = name.parameter() {
                match links.iter_mut().find(|l| &l.0 == link) {
                    Some(l) => {
                        l.1 |= truth;
                        l.2 |= kept;
                    }
                    None => links.push((link.clone(), truth, kept)),
                }
            }
        }
        out.false_links = (links.into_iter())
            .filter(|(_, truth, kept)| *kept && !truth)
            .map(|(l, ..)| l)
            .collect();
        Some(out)
    }

    /// Whether the selection is the true structure among the candidates.
    pub fn exact(&self) -> bool {
        self.true_dropped.is_empty() && self.false_kept.is_empty()
    }
}

/// A number written as JSON's `null` where it is NaN (as serde_json writes NaN: a
/// coefficient graded by its curve has no relative error) read back as NaN.
fn nan_from_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RowParameter {
    pub name: String,
    #[serde(deserialize_with = "nan_from_null")]
    pub true_value: f64,
    #[serde(deserialize_with = "nan_from_null")]
    pub estimate: f64,
    pub std_error: Option<f64>,
    #[serde(deserialize_with = "nan_from_null")]
    pub rel_error: f64,
    /// Whether the 95 % interval holds the true value (`None` without an interval).
    pub covered: Option<bool>,
    /// The Cramér–Rao bound of continuous observation on the parameter's standard
    /// deviation, from this item's samples (`None` where it does not apply).
    #[serde(default)]
    pub cramer_rao_std: Option<f64>,
    /// Richardson's estimate of the integrator's bias on the estimate (a study with
    /// `integrator_bias`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub integrator_bias: Option<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A parameter without a relative error (NaN, written as `null`) reads back as NaN:
    /// a study row with one stayed unreadable (`study --select-powers 3` on friction_sdof).
    #[test]
    fn a_parameter_without_a_relative_error_round_trips() {
        let p = RowParameter {
            name: "c1[ground-m1]".into(),
            true_value: 0.5,
            estimate: 1.087,
            std_error: Some(0.027),
            rel_error: f64::NAN,
            covered: Some(false),
            cramer_rao_std: None,
            integrator_bias: None,
        };
        let json = serde_json::to_string(&p).unwrap();
        assert!(json.contains("\"rel_error\":null"), "{json}");
        let back: RowParameter = serde_json::from_str(&json).unwrap();
        assert!(back.rel_error.is_nan() && back.estimate == p.estimate && back.true_value == p.true_value);
    }
}
