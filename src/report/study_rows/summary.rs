//! A study's summary: per configuration and method, the worst error's distribution over
//! the seeds, the coverage of the 95 % intervals, and per parameter the bias, spread,
//! coverage and how the standard errors and the Cramér–Rao bound compare with the spread
//! over the seeds; the paired differences from a reference method on the same samples.

use super::{Configuration, Row, RowParameter};
use crate::report::Outcome;
use serde::Serialize;

/// Summary of one configuration and method over its seeds.
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    #[serde(flatten)]
    pub configuration: Configuration,
    pub method: String,
    /// Items with an estimate.
    pub items: usize,
    /// Items the method refused (the data could not decide), did not apply to, or where
    /// the item could not be run.
    pub refused: usize,
    pub not_applicable: usize,
    pub failed: usize,
    pub worst_median: f64,
    pub worst_q1: f64,
    pub worst_q3: f64,
    pub worst_max: f64,
    /// Mean and standard deviation of the worst error over the seeds (a regression gate
    /// is about the mean + 4 sd).
    pub worst_mean: f64,
    pub worst_sd: f64,
    /// Fraction of all 95 % intervals (every parameter of every item) that hold the truth,
    /// and its 95 % interval over the items (`stats::clustered_95`).
    pub coverage: Option<f64>,
    pub coverage_ci: Option<[f64; 2]>,
    pub parameters: Vec<ParameterSummary>,
    /// Median seconds per item (all its methods together).
    pub item_s_median: f64,
    /// With structure selection: how often the selected model was the true structure.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub selection: Option<SelectionSummary>,
}

/// Structure selection over the seeds (docs/selection.md).
#[derive(Debug, Clone, Serialize)]
pub struct SelectionSummary {
    /// Items with a selection.
    pub items: usize,
    /// Fraction of items whose selection is exactly the true structure.
    pub exact: f64,
    /// Fraction of items that dropped a true term, and of all true terms dropped.
    pub true_dropped_items: f64,
    pub true_dropped_terms: f64,
    /// Fraction of items that kept a false term, and false terms kept per item.
    pub false_kept_items: f64,
    pub false_kept_per_item: f64,
    /// Each term dropped or kept wrongly, with the number of items that did so.
    pub mistakes: Vec<(String, usize)>,
    /// Fraction of items whose model has a link the truth lacks.
    pub false_link_items: f64,
    /// Per candidate: whether the truth has it and the fraction of items that kept it (a
    /// false term's false-inclusion rate; one minus it, a true term's false-exclusion
    /// rate).
    pub terms: Vec<TermRate>,
    /// The inclusion frequencies against the truth (the selection's own rows).
    pub reliability: Vec<ReliabilityBin>,
}

/// One candidate over a configuration's items.
#[derive(Debug, Clone, Serialize)]
pub struct TermRate {
    pub term: String,
    pub truth: bool,
    pub kept: f64,
}

/// The candidates whose inclusion frequency fell in `[from, to)` (the last bin holds 1),
/// over every item: how many, and the fraction of them the truth has. Inclusion
/// frequencies that mean what they say have that fraction near the bin's frequencies.
#[derive(Debug, Clone, Serialize)]
pub struct ReliabilityBin {
    pub from: f64,
    pub to: f64,
    pub terms: usize,
    /// The mean inclusion frequency in the bin (`None` for an empty bin).
    pub mean_inclusion: Option<f64>,
    /// `None` for an empty bin.
    pub true_share: Option<f64>,
}

/// The bins of the reliability table: the ends, where nearly every candidate falls, on
/// their own.
const RELIABILITY_EDGES: [f64; 7] = [0.0, 0.05, 0.2, 0.4, 0.6, 0.8, 0.95];

/// The reliability table of `inclusion` (frequency, truth) pairs.
pub fn reliability(inclusion: impl Iterator<Item = (f64, bool)>) -> Vec<ReliabilityBin> {
    let n = RELIABILITY_EDGES.len();
    let mut bins: Vec<(usize, f64, usize)> = vec![(0, 0.0, 0); n];
    for (f, truth) in inclusion {
        let b = RELIABILITY_EDGES.iter().rposition(|&e| f >= e).unwrap_or(0);
        bins[b].0 += 1;
        bins[b].1 += f;
        bins[b].2 += truth as usize;
    }
    (bins.into_iter().enumerate())
        .map(|(b, (terms, sum, truths))| ReliabilityBin {
            from: RELIABILITY_EDGES[b],
            to: RELIABILITY_EDGES.get(b + 1).copied().unwrap_or(1.0),
            terms,
            mean_inclusion: (terms > 0).then(|| sum / terms as f64),
            true_share: (terms > 0).then(|| truths as f64 / terms as f64),
        })
        .collect()
}

impl SelectionSummary {
    fn of(rows: &[&Row]) -> Option<SelectionSummary> {
        let sel: Vec<&super::RowSelection> = rows.iter().filter_map(|r| r.selection.as_ref()).collect();
        if sel.is_empty() {
            return None;
        }
        let n = sel.len() as f64;
        let share = |f: &dyn Fn(&super::RowSelection) -> bool| sel.iter().filter(|s| f(s)).count() as f64 / n;
        let true_terms: usize = sel
            .iter()
            .map(|s| s.selected.len() - s.false_kept.len() + s.true_dropped.len())
            .sum();
        let dropped: usize = sel.iter().map(|s| s.true_dropped.len()).sum();
        let mut mistakes: Vec<(String, usize)> = Vec::new();
        for name in sel.iter().flat_map(|s| s.true_dropped.iter().chain(&s.false_kept)) {
            match mistakes.iter_mut().find(|m| &m.0 == name) {
                Some(m) => m.1 += 1,
                None => mistakes.push((name.clone(), 1)),
            }
        }
        mistakes.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
        // Per candidate, from the rows that list every candidate with its truth.
        let mut terms: Vec<TermRate> = Vec::new();
        let listed: Vec<&&super::RowSelection> = sel.iter().filter(|s| !s.inclusion.is_empty()).collect();
        for s in &listed {
            for t in &s.inclusion {
                let kept = s.selected.contains(&t.term) as u8 as f64 / listed.len() as f64;
                match terms.iter_mut().find(|x| x.term == t.term) {
                    Some(x) => x.kept += kept,
                    None => terms.push(TermRate {
                        term: t.term.clone(),
                        truth: t.truth,
                        kept,
                    }),
                }
            }
        }
        let reliability = match listed.is_empty() {
            true => Vec::new(),
            false => reliability(
                listed
                    .iter()
                    .flat_map(|s| s.inclusion.iter().map(|t| (t.share, t.truth))),
            ),
        };
        Some(SelectionSummary {
            items: sel.len(),
            exact: share(&|s| s.exact()),
            true_dropped_items: share(&|s| !s.true_dropped.is_empty()),
            true_dropped_terms: dropped as f64 / true_terms.max(1) as f64,
            false_kept_items: share(&|s| !s.false_kept.is_empty()),
            false_kept_per_item: sel.iter().map(|s| s.false_kept.len()).sum::<usize>() as f64 / n,
            mistakes,
            false_link_items: share(&|s| !s.false_links.is_empty()),
            terms,
            reliability,
        })
    }
}

impl Summary {
    /// Refused / (estimated + refused): how often the data could not decide; `None` when
    /// the method never applied.
    pub fn refusal_rate(&self) -> Option<f64> {
        let n = self.items + self.refused;
        (n > 0).then(|| self.refused as f64 / n as f64)
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct ParameterSummary {
    pub name: String,
    /// Mean of `(θ̂ − θ)/|θ|` over the seeds (relative to the characteristic's scale for a
    /// zero truth: the mean signed error scaled like `rel_error`).
    pub bias: f64,
    /// Standard deviation of the same over the seeds.
    pub spread: f64,
    /// Fraction of the 95 % intervals that hold the truth (`None` without intervals), and
    /// its binomial 95 % interval over the seeds (`stats::wilson_95`).
    pub coverage: Option<f64>,
    pub coverage_ci: Option<[f64; 2]>,
    /// The root mean square of the items' standard errors over the standard deviation of
    /// the estimates over the seeds: below 1 the standard errors understate the error.
    pub std_error_ratio: Option<f64>,
    /// Efficiency against the Cramér–Rao bound of continuous observation: the mean square
    /// bound over the variance of the estimates over the seeds (1: as good as any unbiased
    /// estimator from the whole path; sampled data may do worse, never better).
    pub efficiency: Option<f64>,
    /// Its 95 % interval from the seeds' variance (chi-square, `stats::variance_ratio_95`).
    pub efficiency_ci: Option<[f64; 2]>,
    /// The integrator's bias (a study with `integrator_bias`): the mean of the items'
    /// Richardson estimates over the root mean square of their standard errors. Above a
    /// quarter, the integrator moves the estimate by a share of its error bar that the
    /// intervals' coverage feels.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub integrator_bias_share: Option<f64>,
}

fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let x = q * (sorted.len() - 1) as f64;
    let (lo, hi) = (x.floor() as usize, x.ceil() as usize);
    sorted[lo] + (sorted[hi] - sorted[lo]) * (x - lo as f64)
}

/// Per configuration and method, in the rows' order of first appearance.
pub fn summarize(rows: &[Row]) -> Vec<Summary> {
    let mut keys: Vec<(Configuration, String)> = Vec::new();
    for r in rows {
        let k = (r.item.configuration(), r.method.clone());
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    keys.sort_by(|a, b| a.0.order(&b.0));
    keys.into_iter()
        .map(|(configuration, method)| {
            let group: Vec<&Row> = rows
                .iter()
                .filter(|r| r.item.configuration() == configuration && r.method == method)
                .collect();
            let ok: Vec<&Row> = group
                .iter()
                .copied()
                .filter(|r| r.outcome == Outcome::Estimated)
                .collect();
            let count = |o: Outcome| group.iter().filter(|r| r.outcome == o).count();
            let mut worst: Vec<f64> = ok.iter().filter_map(|r| r.worst_rel_error).collect();
            worst.sort_by(f64::total_cmp);
            let mut secs: Vec<f64> = group.iter().map(|r| r.item_s).collect();
            secs.sort_by(f64::total_cmp);
            let names: Vec<String> = ok
                .first()
                .map_or(Vec::new(), |r| r.parameters.iter().map(|p| p.name.clone()).collect());
            let parameters = names
                .iter()
                .map(|name| {
                    let ps: Vec<&RowParameter> = ok
                        .iter()
                        .filter_map(|r| r.parameters.iter().find(|p| &p.name == name))
                        .collect();
                    let signed: Vec<f64> = ps
                        .iter()
                        .map(|p| {
                            let scale = if p.true_value != 0.0 {
                                p.true_value.abs()
                            } else {
                                (p.estimate - p.true_value).abs() / p.rel_error.max(1e-300)
                            };
                            (p.estimate - p.true_value) / scale
                        })
                        .collect();
                    let n = signed.len().max(1) as f64;
                    let mean = signed.iter().sum::<f64>() / n;
                    let var = signed.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
                    let cov: Vec<bool> = ps.iter().filter_map(|p| p.covered).collect();
                    let held = cov.iter().filter(|c| **c).count();
                    // Spread of the estimates themselves, and the mean squares of the
                    // standard errors and bounds, over the items that have them all.
                    let (_, sd) = mean_sd(&ps.iter().map(|p| p.estimate).collect::<Vec<_>>());
                    let mean_square = |v: Vec<Option<f64>>| -> Option<f64> {
                        let v: Option<Vec<f64>> = v.into_iter().collect();
                        v.filter(|v| v.len() >= 3)
                            .map(|v| v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64)
                    };
                    let est_var = sd * sd;
                    let ratio = |ms: Option<f64>| ms.filter(|_| est_var > 0.0).map(|ms| ms / est_var);
                    let efficiency = ratio(mean_square(ps.iter().map(|p| p.cramer_rao_std).collect()));
                    let share = {
                        let b: Vec<f64> = ps.iter().filter_map(|p| p.integrator_bias).collect();
                        let se = mean_square(ps.iter().map(|p| p.std_error).collect());
                        match (b.is_empty(), se) {
                            (false, Some(se)) if se > 0.0 => Some(b.iter().sum::<f64>() / b.len() as f64 / se.sqrt()),
                            _ => None,
                        }
                    };
                    ParameterSummary {
                        integrator_bias_share: share,
                        std_error_ratio: ratio(mean_square(ps.iter().map(|p| p.std_error).collect())).map(f64::sqrt),
                        efficiency,
                        efficiency_ci: efficiency.and_then(|e| crate::stats::variance_ratio_95(e, ps.len())),
                        coverage_ci: (!cov.is_empty()).then(|| crate::stats::wilson_95(held, cov.len())),
                        name: name.clone(),
                        bias: mean,
                        spread: var.sqrt(),
                        coverage: (!cov.is_empty())
                            .then(|| cov.iter().filter(|c| **c).count() as f64 / cov.len() as f64),
                    }
                })
                .collect();
            let (worst_mean, worst_sd) = mean_sd(&worst);
            let covered: Vec<bool> = ok
                .iter()
                .flat_map(|r| r.parameters.iter().filter_map(|p| p.covered))
                .collect();
            let per_item: Vec<(usize, usize)> = ok
                .iter()
                .map(|r| {
                    let c: Vec<bool> = r.parameters.iter().filter_map(|p| p.covered).collect();
                    (c.iter().filter(|x| **x).count(), c.len())
                })
                .filter(|c| c.1 > 0)
                .collect();
            Summary {
                selection: SelectionSummary::of(&ok),
                coverage_ci: crate::stats::clustered_95(&per_item),
                configuration,
                method,
                items: ok.len(),
                refused: count(Outcome::Refused),
                not_applicable: count(Outcome::NotApplicable),
                failed: count(Outcome::Failed),
                worst_mean,
                worst_sd,
                coverage: (!covered.is_empty())
                    .then(|| covered.iter().filter(|c| **c).count() as f64 / covered.len() as f64),
                worst_median: quantile(&worst, 0.5),
                worst_q1: quantile(&worst, 0.25),
                worst_q3: quantile(&worst, 0.75),
                worst_max: worst.last().copied().unwrap_or(f64::NAN),
                parameters,
                item_s_median: quantile(&secs, 0.5),
            }
        })
        .collect()
}

/// How far a method's estimates sit from the reference method's on the same samples.
#[derive(Debug, Clone, Serialize)]
pub struct Paired {
    #[serde(flatten)]
    pub configuration: Configuration,
    pub method: String,
    pub reference: String,
    pub parameter: String,
    /// Seed standard deviation of the reference's estimate (absolute).
    pub reference_sd: f64,
    /// Mean, standard deviation and largest magnitude of `(θ̂ − θ̂_reference) / reference_sd`
    /// over the items.
    pub mean: f64,
    pub sd: f64,
    pub max_abs: f64,
}

/// Per configuration, method and parameter: the paired differences from `reference`.
pub fn paired(rows: &[Row], reference: &str) -> Vec<Paired> {
    let mut out = Vec::new();
    for x in summarize(rows).iter().filter(|x| x.method != reference) {
        let same = |r: &&Row| r.item.configuration() == x.configuration && r.outcome == Outcome::Estimated;
        let refs: Vec<&Row> = rows.iter().filter(same).filter(|r| r.method == reference).collect();
        let mine: Vec<&Row> = rows.iter().filter(same).filter(|r| r.method == x.method).collect();
        for p in &x.parameters {
            let value = |r: &Row| r.parameters.iter().find(|q| q.name == p.name).map(|q| q.estimate);
            let reference_values: Vec<f64> = refs.iter().filter_map(|r| value(r)).collect();
            let (_, reference_sd) = mean_sd(&reference_values);
            let d: Vec<f64> = mine
                .iter()
                .filter_map(|r| {
                    let base = refs.iter().find(|q| q.item.index == r.item.index)?;
                    Some((value(r)? - value(base)?) / reference_sd)
                })
                .collect();
            if d.is_empty() {
                continue;
            }
            let (mean, sd) = mean_sd(&d);
            out.push(Paired {
                configuration: x.configuration,
                method: x.method.clone(),
                reference: reference.to_string(),
                parameter: p.name.clone(),
                reference_sd,
                mean,
                sd,
                max_abs: d.iter().fold(0.0, |m, v| m.max(v.abs())),
            });
        }
    }
    out
}

fn mean_sd(v: &[f64]) -> (f64, f64) {
    if v.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    (
        mean,
        (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reliability_table_bins_frequencies_with_the_ends_on_their_own() {
        let table = reliability(
            [
                (0.0, false),
                (0.03, false),
                (0.1, true),
                (0.5, true),
                (0.5, false),
                (0.97, true),
                (1.0, true),
            ]
            .into_iter(),
        );
        let counts: Vec<usize> = table.iter().map(|b| b.terms).collect();
        assert_eq!(counts, vec![2, 1, 0, 2, 0, 0, 2]);
        assert_eq!(table[0].true_share, Some(0.0));
        assert_eq!(table[3].true_share, Some(0.5));
        assert_eq!(table[6].true_share, Some(1.0));
        assert_eq!((table[2].true_share, table[2].mean_inclusion), (None, None));
        assert_eq!((table[6].from, table[6].to), (0.95, 1.0));
        assert!((table[0].mean_inclusion.unwrap() - 0.015).abs() < 1e-12);
    }
}
