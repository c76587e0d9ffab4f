//! Lags between a measured quantity and its measured derivative: a velocity recorded a
//! sample late against its displacement (a logger that buffers one channel, a filter on one
//! channel only, columns shifted by a row in a spreadsheet). The identification reads the
//! pair as one state, so a lagged velocity is not the displacement's derivative: the sensor
//! correction reads the misfit as noise and takes it out, and the stiffness moves by tens
//! of standard errors with no other sign.
//!
//! Where both columns of a pair (displacement and velocity, velocity and acceleration) are
//! measured, the central difference of the first, `(y[k+1] − y[k−1]) / 2h`, is correlated
//! with the second at lags of −[`MAX_LAG`]…+[`MAX_LAG`] samples, per record. The central
//! difference has no phase, so for aligned channels the correlation peaks at lag 0 whatever
//! the sampling, the noise or a filter both channels share; a delay between them moves the
//! peak by the delay. The peak is refined by the parabola through it and its neighbours, and
//! a lag of [`LEAST_LAG`] samples or more is a fault. Accelerations that are interval means
//! (`[data] acceleration_samples = "interval_means"`: `a_k = (v_k − v_{k−1})/h`, centred half
//! a sample before `t_k`) peak at +½ against their velocity's difference, and that is where
//! their pair's lag is counted from.

use super::SampleCheck;
use crate::ident::accumulate::{Accumulator, Sample};

/// The lags tried, either way (samples).
pub(crate) const MAX_LAG: usize = 3;

/// A refined lag from which the channels are misaligned (samples): half a sample is the
/// least a shift by rows can be, far beyond what a sensor's own phase gives at the rates
/// the identification needs.
pub(crate) const LEAST_LAG: f64 = 0.5;

/// Rows kept per record: the central difference's centre is `MAX_LAG + 1` rows back, and
/// the derivative is read `MAX_LAG` rows either side of it.
const RING: usize = 2 * MAX_LAG + 2;

const LAGS: usize = 2 * MAX_LAG + 1;

/// One pair of columns: the quantity and its derivative.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Pair {
    pub quantity: usize,
    pub derivative: usize,
    /// The lag of aligned channels (samples): 0, or ½ for interval-mean accelerations.
    pub aligned: f64,
}

/// Per record and pair: the sums of the products at every lag and of the squares.
#[derive(Debug, Clone, Copy, Default)]
struct Sums {
    products: [f64; LAGS],
    difference: f64,
    derivative: f64,
}

impl Sums {
    /// The lag of the peak correlation, refined, and the correlations at the peak and at 0.
    fn lag(&self) -> Option<(f64, f64, f64)> {
        let norm = (self.difference * self.derivative).sqrt();
        if norm.is_nan() || norm <= 0.0 {
            return None;
        }
        let rho: Vec<f64> = self.products.iter().map(|p| p / norm).collect();
        let peak = (0..LAGS).max_by(|&a, &b| rho[a].total_cmp(&rho[b]))?;
        let shift = if peak > 0 && peak + 1 < LAGS {
            let (l, c, r) = (rho[peak - 1], rho[peak], rho[peak + 1]);
            let curvature = l - 2.0 * c + r;
            if curvature < 0.0 {
                0.5 * (l - r) / curvature
            } else {
                0.0
            }
        } else {
            0.0
        };
        Some((peak as f64 - MAX_LAG as f64 + shift, rho[peak], rho[MAX_LAG]))
    }
}

/// The cross-correlations of every measured pair, per record.
pub(crate) struct Lags {
    pairs: Vec<Pair>,
    h: f64,
    /// Per record: its rows so far, the ring of its last rows (per pair, the quantity and
    /// the derivative) and its sums per pair.
    records: Vec<(usize, Vec<[f64; 2]>, Vec<Sums>)>,
}

impl Lags {
    /// The check of every pair of `input`'s measured table whose quantity and derivative
    /// (displacement and velocity, velocity and acceleration) are both measured, not
    /// derived.
    pub(crate) fn of(input: &crate::pipeline::Input, data: &crate::io::table::Measured) -> Lags {
        let layout = crate::model::Model::new(&input.info.scenario).columns();
        let measured = |c: usize| data.present.get(c).copied().unwrap_or(false) && !data.derived(c);
        let means = (input.info.scenario.data.as_ref())
            .is_some_and(|d| d.acceleration_samples == crate::scenario::AccelerationSamples::IntervalMeans);
        let pairs = (0..input.info.scenario.masses.len())
            .flat_map(|i| {
                [
                    (layout.x(i), layout.v(i), 0.0),
                    (layout.v(i), layout.a(i), if means { 0.5 } else { 0.0 }),
                ]
            })
            .filter(|&(q, d, _)| measured(q) && measured(d))
            .map(|(quantity, derivative, aligned)| Pair {
                quantity,
                derivative,
                aligned,
            })
            .collect();
        Lags::new(pairs, data.sample_interval)
    }

    /// The check of `pairs` at sample interval `h`.
    pub(crate) fn new(pairs: Vec<Pair>, h: f64) -> Lags {
        Lags {
            pairs,
            h,
            records: Vec::new(),
        }
    }
}

impl Accumulator for Lags {
    fn push(&mut self, s: &Sample) {
        let (r, n) = (s.trajectory as usize, self.pairs.len());
        if n == 0 {
            return;
        }
        if self.records.len() <= r {
            self.records
                .resize(r + 1, (0, vec![[0.0; 2]; RING * n], vec![Sums::default(); n]));
        }
        let (seen, ring, sums) = &mut self.records[r];
        let k = *seen;
        *seen += 1;
        for (p, pair) in self.pairs.iter().enumerate() {
            ring[(k % RING) * n + p] = [s.row[pair.quantity], s.row[pair.derivative]];
        }
        if k + 1 < RING {
            return;
        }
        // The centre c = k − MAX_LAG − 1: the difference there, the derivative at c + lag.
        let c = k - MAX_LAG - 1;
        let at = |q: usize, p: usize| ring[(q % RING) * n + p];
        for (p, sum) in sums.iter_mut().enumerate() {
            let d = (at(c + 1, p)[0] - at(c - 1, p)[0]) / (2.0 * self.h);
            if !d.is_finite() {
                continue;
            }
            let mut products = [0.0; LAGS];
            for (l, product) in products.iter_mut().enumerate() {
                *product = d * at(c + l - MAX_LAG, p)[1];
            }
            if products.iter().any(|x| !x.is_finite()) {
                continue;
            }
            for (total, x) in sum.products.iter_mut().zip(products) {
                *total += x;
            }
            let w = at(c, p)[1];
            sum.difference += d * d;
            sum.derivative += w * w;
        }
    }
}

impl SampleCheck for Lags {
    fn name(&self) -> &'static str {
        "lag"
    }

    fn findings(&self, columns: &[String]) -> Vec<String> {
        let name = |c: usize| columns.get(c).map_or("?", String::as_str);
        let mut found = Vec::new();
        for (p, pair) in self.pairs.iter().enumerate() {
            // (record, lag, correlation at the peak and at 0) of every misaligned record.
            let lagged: Vec<(usize, f64, f64, f64)> = (self.records.iter().enumerate())
                .filter_map(|(r, (_, _, sums))| sums[p].lag().map(|(l, peak, zero)| (r, l, peak, zero)))
                .map(|(r, l, peak, zero)| (r, l - pair.aligned, peak, zero))
                .filter(|&(_, l, _, _)| l.abs() >= LEAST_LAG)
                .collect();
            let Some(&(first, lag, peak, zero)) = lagged.first() else {
                continue;
            };
            let mut records: Vec<String> = lagged.iter().take(10).map(|x| (x.0 + 1).to_string()).collect();
            if lagged.len() > 10 {
                records.push(format!("and {} more", lagged.len() - 10));
            }
            let which = if lagged.len() == self.records.len() {
                format!("every record ({})", self.records.len())
            } else {
                format!("record {}", records.join(", "))
            };
            found.push(format!(
                "{} lags the central difference of {} by {lag:+.2} samples in {which} (record {}: their \
                 correlation peaks at {peak:.3} there, {zero:.3} at lag 0; aligned channels peak at {}): one \
                 channel delayed against the other — a logger buffering one channel, a filter on one channel \
                 only, a column shifted by a row. The pair is read as one state, so the derivative no longer \
                 is one; align the columns (e.g. pandas' shift) or map only one of them and derive the other \
                 (`derive = true`)",
                name(pair.derivative),
                name(pair.quantity),
                first + 1,
                if pair.aligned == 0.0 {
                    "0"
                } else {
                    "+0.5, the accelerations being interval means"
                }
            ));
        }
        found
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two records of a displacement (a sum of three sines) and its exact velocity at
    /// `h`, the velocity read `delay` samples late in record 1; the findings.
    fn scan(h: f64, delay: usize) -> Vec<String> {
        let pair = Pair {
            quantity: 0,
            derivative: 1,
            aligned: 0.0,
        };
        let mut check = Lags::new(vec![pair], h);
        let (w, phase) = ([1.0, 2.3, 3.7], [0.1, 1.9, 4.2]);
        let x = |t: f64| (0..3).map(|j| (w[j] * t + phase[j]).sin() / w[j]).sum::<f64>();
        let v = |t: f64| (0..3).map(|j| (w[j] * t + phase[j]).cos()).sum::<f64>();
        for r in 0..2u32 {
            for k in 0..20_000 {
                let t = h * k as f64;
                let late = if r == 1 { delay } else { 0 };
                check.push(&Sample {
                    trajectory: r,
                    t,
                    batch: 0,
                    row: &[x(t), v(t - h * late as f64)],
                });
            }
        }
        check.findings(&["x_m1".into(), "v_m1".into()])
    }

    #[test]
    fn a_velocity_a_sample_late_is_named_with_its_record_and_lag() {
        // Fine (60 samples a period of the fastest line) and coarse (under 5) sampling.
        for h in [0.03, 0.35] {
            assert!(scan(h, 0).is_empty(), "aligned at h = {h}: {:?}", scan(h, 0));
            let found = scan(h, 1);
            assert_eq!(found.len(), 1, "{found:?}");
            assert!(
                found[0].starts_with("v_m1 lags the central difference of x_m1 by +1.0"),
                "{}",
                found[0]
            );
            assert!(found[0].contains("in record 2 "), "{}", found[0]);
            let two = scan(h, 2);
            assert!(two[0].contains("by +2.0"), "{}", two[0]);
        }
    }

    /// A velocity and its interval-mean accelerations `(v_k − v_{k−1})/h` (fpkbench's own
    /// log): aligned for a pair that knows them as such, half a sample late for one that
    /// takes them as values at instants; one row late beyond that is named as a lag of +1.
    #[test]
    fn interval_mean_accelerations_are_aligned_half_a_sample_late() {
        let h = 0.05;
        let v = |t: f64| (t + 0.3).sin() + 0.5 * (2.7 * t).cos();
        let scan = |aligned: f64, late: usize| {
            let mut check = Lags::new(
                vec![Pair {
                    quantity: 0,
                    derivative: 1,
                    aligned,
                }],
                h,
            );
            for k in 0..20_000usize {
                let t = h * k as f64;
                let tl = t - h * late as f64;
                check.push(&Sample {
                    trajectory: 0,
                    t,
                    batch: 0,
                    row: &[v(t), (v(tl) - v(tl - h)) / h],
                });
            }
            check.findings(&["v_m1".into(), "a_m1".into()])
        };
        assert!(scan(0.5, 0).is_empty(), "{:?}", scan(0.5, 0));
        let as_instants = scan(0.0, 0);
        assert!(as_instants[0].contains("by +0.50"), "{as_instants:?}");
        let late = scan(0.5, 1);
        assert!(
            late[0].contains("by +1.00") && late[0].contains("peak at +0.5, the accelerations being interval means"),
            "{late:?}"
        );
    }
}
