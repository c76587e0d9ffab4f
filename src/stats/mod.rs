//! Accuracy metrics (docs/methods.md, accuracy): per-parameter relative errors, per-characteristic
//! relative L2 errors under the observed density, and the dissipativity check (3.4) of
//! identified characteristics over the observed ranges (3.16)–(3.17); and the discrete
//! Fourier transform (`fft`).

pub mod fft;
mod histogram;

pub use histogram::Histogram;

use crate::model::{Characteristic, Coefficient, Term};
use crate::scenario::{Curve, Scenario};

/// The bin of a value at `q` bin widths from the low edge of `bins` bins, if inside.
/// Equal to `⌊q⌋` where `0 ≤ ⌊q⌋ < bins`, computed without `floor` (a library call on
/// baseline x86-64, and histograms bin every sample); NaN falls outside.
#[inline]
pub fn bin(q: f64, bins: usize) -> Option<usize> {
    (q >= 0.0 && q < bins as f64).then_some(q as usize)
}

/// A characteristic from `(term, coefficient)` pairs in any order.
pub fn characteristic(terms: &[(Term, f64)]) -> Curve {
    let mut t = terms.to_vec();
    t.sort_by_key(|x| x.0);
    Curve { terms: t }
}

/// The 0.975 quantile of Student's t with `dof` degrees of freedom (the half-width of a
/// 95 % interval in standard errors): exact values to 30, then the Cornish–Fisher series in
/// `1/dof` (error below 1e-4).
pub fn student_t_975(dof: usize) -> f64 {
    const TABLE: [f64; 30] = [
        12.7062, 4.3027, 3.1824, 2.7764, 2.5706, 2.4469, 2.3646, 2.3060, 2.2622, 2.2281, 2.2010, 2.1788, 2.1604,
        2.1448, 2.1314, 2.1199, 2.1098, 2.1009, 2.0930, 2.0860, 2.0796, 2.0739, 2.0687, 2.0639, 2.0595, 2.0555, 2.0518,
        2.0484, 2.0452, 2.0423,
    ];
    if dof == 0 {
        return f64::NAN;
    }
    if dof <= TABLE.len() {
        return TABLE[dof - 1];
    }
    let z: f64 = 1.959_963_984_540_054;
    let n = dof as f64;
    let (z3, z5, z7) = (z.powi(3), z.powi(5), z.powi(7));
    z + (z3 + z) / (4.0 * n)
        + (5.0 * z5 + 16.0 * z3 + 3.0 * z) / (96.0 * n * n)
        + (3.0 * z7 + 19.0 * z5 + 17.0 * z3 - 15.0 * z) / (384.0 * n * n * n)
}

/// The 95 % Wilson score interval of a proportion `k / n` of independent trials (a
/// parameter's interval over the seeds of a study).
pub fn wilson_95(k: usize, n: usize) -> [f64; 2] {
    let (z, n) = (1.959_963_984_540_054, n as f64);
    let p = k as f64 / n;
    let centre = (p + z * z / (2.0 * n)) / (1.0 + z * z / n);
    let half = z / (1.0 + z * z / n) * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt();
    [(centre - half).max(0.0), (centre + half).min(1.0)]
}

/// The 95 % interval of a variance ratio `c / s²` where `s²` is the sample variance of `n`
/// independent normal values: `[c / s² · q₀.₀₂₅/k, c / s² · q₀.₉₇₅/k]` with `q` the
/// chi-square quantiles of `k = n − 1` degrees of freedom (Wilson–Hilferty's cube-root
/// approximation: within 1 % at k = 9, 0.2 % at k = 49); `None` for fewer than 3 values.
pub fn variance_ratio_95(ratio: f64, n: usize) -> Option<[f64; 2]> {
    if n < 3 {
        return None;
    }
    let k = (n - 1) as f64;
    let q = |z: f64| k * (1.0 - 2.0 / (9.0 * k) + z * (2.0 / (9.0 * k)).sqrt()).powi(3);
    let z = 1.959_963_984_540_054;
    Some([ratio * q(-z) / k, ratio * q(z) / k])
}

/// The 95 % interval of a pooled proportion `Σk / Σn` over independent clusters `(k, n)`
/// whose trials are not independent within a cluster (a study's items: all of an item's
/// intervals come from the same samples). The ratio estimator's standard error from the
/// spread between clusters, `√(Σ (k − p̂ n)² / (m (m − 1) n̄²))`, times Student's t with
/// `m − 1` degrees of freedom; `None` with fewer than two clusters.
pub fn clustered_95(clusters: &[(usize, usize)]) -> Option<[f64; 2]> {
    let m = clusters.len();
    let total: usize = clusters.iter().map(|c| c.1).sum();
    if m < 2 || total == 0 {
        return None;
    }
    let p = clusters.iter().map(|c| c.0).sum::<usize>() as f64 / total as f64;
    let n_bar = total as f64 / m as f64;
    let ss: f64 = clusters.iter().map(|&(k, n)| (k as f64 - p * n as f64).powi(2)).sum();
    let se = (ss / (m as f64 * (m - 1) as f64)).sqrt() / n_bar;
    let half = student_t_975(m - 1) * se;
    Some([(p - half).max(0.0), (p + half).min(1.0)])
}

/// Points used for curve norms over a range.
const POINTS: usize = 401;

/// RMS of `p` over `[lo, hi]`.
pub fn rms(p: &Curve, lo: f64, hi: f64) -> f64 {
    let s: f64 = (0..POINTS)
        .map(|k| {
            let z = lo + (hi - lo) * k as f64 / (POINTS - 1) as f64;
            p.eval(z).powi(2)
        })
        .sum();
    (s / POINTS as f64).sqrt()
}

/// Where a characteristic's norm is taken: the observed range `[lo, hi]`, and where known
/// the power means `E[z^k]` of the observed density of its argument (`ident::data::Observed`).
#[derive(Debug, Clone, Copy)]
pub struct Observed<'a> {
    pub lo: f64,
    pub hi: f64,
    pub means: Option<&'a [f64]>,
}

impl Observed<'_> {
    /// The RMS of `p(z)` under the observed density, `√(Σ c_i c_j E[z^(p_i + p_j)])`, exact
    /// for powers; evenly over the range where a term is not a power or the degree is
    /// beyond the means kept.
    pub fn rms(&self, p: &Curve) -> f64 {
        self.rms_under_density(p).unwrap_or_else(|| rms(p, self.lo, self.hi))
    }

    /// Whether [`Observed::rms`] of `p` is under the observed density (else evenly over the
    /// observed range): every term a power within the means kept.
    pub fn under_density(&self, p: &Curve) -> bool {
        self.rms_under_density(p).is_some()
    }

    fn rms_under_density(&self, p: &Curve) -> Option<f64> {
        let under_density = || {
            let m = self.means?;
            let mut s = 0.0;
            for &(a, ca) in &p.terms {
                for &(b, cb) in &p.terms {
                    s += ca * cb * m.get((a.power()? + b.power()?) as usize)?;
                }
            }
            Some(s.max(0.0).sqrt())
        };
        under_density()
    }
}

/// Relative L2 error `‖p̂ − p‖ / ‖p‖` under the observed density (docs/methods.md,
/// accuracy): where the samples are, not evenly over a range whose ends they seldom reach;
/// evenly over the observed range where a term is not a power ([`Observed::under_density`]
/// of the difference says which).
pub fn rel_l2(estimate: &Curve, truth: &Curve, on: &Observed) -> f64 {
    let mut diff = estimate.clone();
    for &(p, c) in &truth.terms {
        match diff.terms.iter_mut().find(|t| t.0 == p) {
            Some(t) => t.1 -= c,
            None => diff.terms.push((p, -c)),
        }
    }
    let n = on.rms(truth);
    if n > 0.0 {
        on.rms(&diff) / n
    } else {
        on.rms(&diff)
    }
}

/// Relative error of one coefficient estimate. A coefficient whose true value is 0 is
/// measured against the scale of its characteristic under the observed density: the RMS
/// of `ĉ t(z)` divided by the RMS of the true characteristic.
pub fn coefficient_error(estimate: f64, truth: f64, term: Term, true_curve: &Curve, on: &Observed) -> f64 {
    if truth != 0.0 {
        ((estimate - truth) / truth).abs()
    } else {
        let term = Curve {
            terms: vec![(term, estimate)],
        };
        let scale = on.rms(true_curve);
        if scale > 0.0 {
            on.rms(&term) / scale
        } else {
            estimate.abs()
        }
    }
}

/// Outcome of the dissipativity check for one characteristic.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Dissipativity {
    pub link: String,
    pub kind: &'static str,
    pub holds: bool,
    /// Where it fails (the first observed point with `K(u)·u ≤ 0` or `C(w)·w ≤ 0`).
    pub fails_at: Option<f64>,
    pub message: String,
}

/// Check `K(u)·u > 0` (or `C(w)·w > 0`) over the observed `[lo, hi]` (3.4), (3.16)–(3.17).
pub fn dissipativity(link: &str, kind: Characteristic, p: &Curve, lo: f64, hi: f64) -> Dissipativity {
    let mut fails_at = None;
    for k in 0..POINTS {
        let z = lo + (hi - lo) * k as f64 / (POINTS - 1) as f64;
        if z.abs() < 1e-12 * (hi - lo).abs().max(1e-300) {
            continue;
        }
        if p.eval(z) * z <= 0.0 {
            fails_at = Some(z);
            break;
        }
    }
    let (f, v) = match kind {
        Characteristic::Stiffness => ("K(u)·u", "u"),
        Characteristic::Damping => ("C(w)·w", "w"),
    };
    let message = match fails_at {
        None => format!("{f} > 0 over the observed {v} in [{lo:.4}, {hi:.4}]"),
        Some(z) => {
            // The odd highest powers either side: only an odd highest power (with a positive
            // coefficient) keeps the characteristic dissipative at large amplitudes.
            let maxp = p.max_power();
            let (lower, upper) = if maxp % 2 == 1 {
                (maxp.saturating_sub(2).max(1), maxp + 2)
            } else {
                (maxp.saturating_sub(1).max(1), maxp + 1)
            };
            format!(
                "{f} <= 0 at {v} = {z:.4} within the observed range: the identified {} is not dissipative there; \
                 try another polynomial degree (e.g. powers up to {lower} or {upper}: the highest power odd) as \
                 the paper suggests",
                kind.name(),
            )
        }
    };
    Dissipativity {
        link: link.to_string(),
        kind: kind.name(),
        holds: fails_at.is_none(),
        fails_at,
        message,
    }
}

impl Dissipativity {
    /// A failure of a link between the masses `a` and `b` whose linear stiffness and
    /// linear damping `linear` are both negative: a spring and a damper that push their
    /// ends apart are what one end's sensors mounted the other way make of a chain (the
    /// end's coordinate reversed, the link's linear terms change sign and the difference
    /// moves to the end's other links), so the advice names that, not the degree.
    pub fn reversed_end(mut self, a: &str, b: &str, linear: [f64; 2]) -> Dissipativity {
        if let Some(z) = self.fails_at {
            let v = if self.kind == Characteristic::Stiffness.name() {
                "u"
            } else {
                "w"
            };
            self.message = format!(
                "{} <= 0 at {v} = {z:.4} within the observed range: this link's spring and damper both push {a} \
                 and {b} apart (linear stiffness {:.4e}, damping {:.4e}), which is what the samples give when one \
                 of them is measured with the opposite sign (a sensor mounted the other way): negate that mass's \
                 displacement, velocity and acceleration columns (`[data.scale]` column = -1.0) and identify again",
                if v == "u" { "K(u)·u" } else { "C(w)·w" },
                linear[0],
                linear[1],
            );
        }
        self
    }

    /// A failure put down to what the estimate's model ignores by design (`cause`), not to
    /// the polynomial degree: the advice to try another degree would mislead.
    pub fn blame(mut self, cause: &str) -> Dissipativity {
        if let Some(z) = self.fails_at {
            let (f, v) = if self.kind == Characteristic::Stiffness.name() {
                ("K(u)·u", "u")
            } else {
                ("C(w)·w", "w")
            };
            self.message = format!(
                "{f} <= 0 at {v} = {z:.4} within the observed range: the identified {} is not dissipative there; \
                 this row ignores {cause} by design, the likely cause (another polynomial degree would not mend it)",
                self.kind
            );
        }
        self
    }
}

/// The true characteristic of `(link, kind)` in a scenario.
pub fn true_characteristic(s: &Scenario, link: usize, kind: Characteristic) -> Curve {
    match kind {
        Characteristic::Stiffness => s.links[link].stiffness.clone(),
        Characteristic::Damping => s.links[link].damping.clone(),
    }
}

/// The estimated characteristic of `(link, kind)`: the identified coefficients if this
/// characteristic was unknown, else the true (known) one.
pub fn estimated_characteristic(
    s: &Scenario,
    unknowns: &[Option<Coefficient>],
    values: &[f64],
    link: usize,
    kind: Characteristic,
) -> (Curve, bool) {
    let terms: Vec<(Term, f64)> = unknowns
        .iter()
        .zip(values)
        .filter_map(|(u, &v)| u.filter(|c| c.link == link && c.kind == kind).map(|c| (c.term, v)))
        .collect();
    if terms.is_empty() {
        (true_characteristic(s, link, kind), false)
    } else {
        (characteristic(&terms), true)
    }
}

#[cfg(test)]
mod tests {
    /// Chi-square quantiles against tables: 49 degrees of freedom, 31.555 and 70.222;
    /// 9, 2.700 and 19.023.
    #[test]
    fn variance_ratio_interval_uses_the_chi_square_quantiles() {
        let [lo, hi] = super::variance_ratio_95(1.0, 50).unwrap();
        assert!(
            (lo * 49.0 / 31.555 - 1.0).abs() < 2e-3 && (hi * 49.0 / 70.222 - 1.0).abs() < 2e-3,
            "{lo} {hi}"
        );
        let [lo, hi] = super::variance_ratio_95(2.0, 10).unwrap();
        assert!(
            (lo * 9.0 / 2.0 / 2.700 - 1.0).abs() < 1e-2 && (hi * 9.0 / 2.0 / 19.023 - 1.0).abs() < 1e-2,
            "{lo} {hi}"
        );
    }

    use super::*;

    /// Under a standard normal density (power means 1, 0, 1, 0, 3, 0, 15, …) a cubic term's
    /// RMS is √15 ≈ 3.87, where evenly over [−4, 4] (the range a long record reaches) it is
    /// √(4⁶/7) ≈ 24.2: a zero-valued cubic estimated at 0.01 beside a true linear 1·z
    /// weighs 3.9 % under the density, 10.5 % evenly over [−4, 4] (the linear term's RMS
    /// there 2.31). A degree beyond the means kept falls back to the range.
    #[test]
    fn norms_are_taken_under_the_observed_density() {
        let normal = [1.0, 0.0, 1.0, 0.0, 3.0, 0.0, 15.0, 0.0, 105.0];
        let on = Observed {
            lo: -4.0,
            hi: 4.0,
            means: Some(&normal),
        };
        let evenly = Observed { means: None, ..on };
        let cubic = characteristic(&[(Term::Power(3), 1.0)]);
        assert!((on.rms(&cubic) - 15f64.sqrt()).abs() < 1e-12);
        assert!((evenly.rms(&cubic) - (4f64.powi(6) / 7.0).sqrt()).abs() < 0.01 * 24.2);
        let linear = characteristic(&[(Term::Power(1), 1.0)]);
        let e = coefficient_error(0.01, 0.0, Term::Power(3), &linear, &on);
        assert!((e - 0.01 * 15f64.sqrt()).abs() < 1e-12, "{e}");
        let e_evenly = coefficient_error(0.01, 0.0, Term::Power(3), &linear, &evenly);
        assert!((e_evenly / (0.01 * 24.2 / 2.31) - 1.0).abs() < 0.01, "{e_evenly}");
        // 1.1 z against z: 10 % under any density.
        let estimate = characteristic(&[(Term::Power(1), 1.1)]);
        assert!((rel_l2(&estimate, &linear, &on) - 0.1).abs() < 1e-12);
        // Degree 5 needs E[z^10], beyond these means: the range's norm.
        let quintic = characteristic(&[(Term::Power(5), 1.0)]);
        assert_eq!(on.rms(&quintic), evenly.rms(&quintic));
    }

    /// Wilson's interval against its textbook values (Agresti & Coull 1998: 0/10 →
    /// [0, 0.278], 9/10 → [0.596, 0.982]); the clustered one equals the plain normal
    /// interval of the cluster means when the clusters are equal in size, and is wider than
    /// a binomial interval that counts correlated trials as independent.
    #[test]
    fn coverage_intervals_match_known_values() {
        let close = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).abs() < 1e-3 && (a[1] - b[1]).abs() < 1e-3;
        assert!(close(wilson_95(0, 10), [0.0, 0.2775]), "{:?}", wilson_95(0, 10));
        assert!(close(wilson_95(9, 10), [0.5958, 0.9821]), "{:?}", wilson_95(9, 10));
        // Four items of 10 intervals each: 10, 9, 8, 10 hold the truth. The means 1, .9,
        // .8, 1: mean .925, sd .0957, se .0479, t(3) 3.1824: ± .1523.
        let c = clustered_95(&[(10, 10), (9, 10), (8, 10), (10, 10)]).unwrap();
        assert!(close(c, [0.925 - 0.1523, 1.0]), "{c:?}");
        let as_if_independent = wilson_95(37, 40);
        assert!(c[0] < as_if_independent[0]);
        assert_eq!(clustered_95(&[(3, 4)]), None);
    }

    #[test]
    fn student_t_quantiles_match_the_tables() {
        // Published 0.975 quantiles (e.g. NIST/SEMATECH e-Handbook, table 1.3.6.7.2).
        for (dof, t) in [
            (1, 12.706),
            (7, 2.365),
            (31, 2.0395),
            (40, 2.021),
            (60, 2.000),
            (120, 1.980),
        ] {
            assert!(
                (student_t_975(dof) - t).abs() < 1e-3,
                "dof {dof}: {}",
                student_t_975(dof)
            );
        }
        // Continuous across the table's end and decreasing towards the normal quantile.
        assert!(student_t_975(30) > student_t_975(31) && student_t_975(31) > student_t_975(32));
        assert!((student_t_975(100_000) - 1.95996).abs() < 1e-4);
    }

    #[test]
    fn the_dissipativity_advice_keeps_the_highest_power_odd() {
        // 6u + 3u²: K(u)·u = 6u² + 3u³ < 0 for u < −2.
        let even = Curve::powers(&[(1, 6.0), (2, 3.0)]);
        let d = dissipativity("m1-m2", Characteristic::Stiffness, &even, -3.0, 3.0);
        assert!(!d.holds && d.fails_at.is_some_and(|u| u <= -2.0), "{d:?}");
        assert!(d.message.contains("powers up to 1 or 3"), "{}", d.message);
        // 10u − 20u³ (softening): fails beyond |u| = 1/√2.
        let odd = Curve::powers(&[(1, 10.0), (3, -20.0)]);
        let d = dissipativity("ground-m1", Characteristic::Stiffness, &odd, -1.0, 1.0);
        assert!(!d.holds);
        assert!(d.message.contains("powers up to 1 or 5"), "{}", d.message);
        let good = Curve::powers(&[(1, 10.0), (3, 20.0)]);
        assert!(dissipativity("ground-m1", Characteristic::Stiffness, &good, -1.0, 1.0).holds);
        // A row that ignores a force by design: the failure is put down to that, with no
        // advice about the degree; a holding check keeps its message.
        let d = dissipativity(
            "ground-m1",
            Characteristic::Damping,
            &Curve::powers(&[(1, -0.04)]),
            -4.0,
            4.0,
        )
        .blame("the unmeasured disturbance");
        assert!(
            !d.holds && d.message.starts_with("C(w)·w <= 0 at w = -4.0000"),
            "{}",
            d.message
        );
        assert!(d.message.contains("ignores the unmeasured disturbance by design") && !d.message.contains("degree ("));
        let kept = dissipativity("ground-m1", Characteristic::Stiffness, &good, -1.0, 1.0);
        assert_eq!(kept.clone().blame("x").message, kept.message);
    }
}
