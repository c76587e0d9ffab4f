//! The first pass's look at the mapped samples (docs/data.md): the motion's frequency, how
//! well differences resolve each derived column (and so which stencil derives it), the
//! displacement's noise where a velocity is derived from it, and the cross-spectra the
//! units check reads.

use super::differentiate::{self, Resolution};
use super::{DataError, DifferencedNoise, Measured};
use crate::ident::spectrum::{CrossWelch, Derivative, Welch};

/// What a first pass over the samples tells about them.
pub(super) struct Look {
    pub(super) motion_frequency: f64,
    /// Per derived column, how well the differences resolve the column it comes from (in
    /// the first record).
    pub(super) derived: Vec<Resolution>,
    /// Per acceleration derived from a displacement alone: how well the first difference
    /// resolves the velocity derived from it, for the differences taken twice where the
    /// second difference cannot reach the acceleration's band edge.
    velocity: Vec<Option<Resolution>>,
    /// Per derived column that is a velocity from a displacement: the displacement's noise
    /// and the differences chosen against it.
    pub(super) differencing: Vec<Option<differentiate::Differencing>>,
    /// ((from, to), how `to` relates to the rate of change of `from`) for the units check.
    pub(super) derivatives: Vec<((usize, usize), Option<Derivative>)>,
}

impl Measured {
    /// In one pass: the motion's frequency, how well the derived columns are resolved, and
    /// how each mapped column relates to the rate of change of each other one of its mass
    /// (`units`; a cross-spectrum per pair, both ways round, in Welch segments of about 32
    /// periods of the first column's motion, so that the derivative's spectrum is
    /// resolved, at most half the longest record). Every sample of the pass is also handed
    /// to `also` (the integration's gathering shares the pass).
    pub(super) fn look(
        &self,
        mapped: &[(usize, String)],
        masses: &[(usize, usize, usize)],
        periods: &[(usize, Option<f64>)],
        also: &mut dyn FnMut(u32, f64, &[f64]),
    ) -> Result<Look, DataError> {
        let h = self.sample_interval;
        let welch_for = |n: usize| Welch::new((n / 4).next_power_of_two().clamp(16, 4096), h, 1);
        // The longest record (the last of equally long ones), each mass's velocity (else
        // displacement).
        let longest = (0..self.lengths.len())
            .max_by_key(|&j| self.lengths[j])
            .expect("a record") as u32;
        let motion: Vec<usize> = masses
            .iter()
            .filter_map(|&(x, v, _)| [v, x].into_iter().find(|&k| self.present[k]))
            .collect();
        let mut motion_welch: Vec<Welch> = motion
            .iter()
            .map(|_| welch_for(self.lengths[longest as usize]))
            .collect();
        let mut derived_welch: Vec<Welch> = self.derive.iter().map(|_| welch_for(self.lengths[0])).collect();
        let mut velocity_welch: Vec<Option<Welch>> = self
            .derive
            .iter()
            .map(|s| s.second.map(|_| welch_for(self.lengths[0])))
            .collect();
        let mut autocovariances: Vec<Option<differentiate::Autocovariance>> = self
            .derive
            .iter()
            .map(|s| {
                masses
                    .iter()
                    .any(|&(x, v, _)| (s.from, s.to) == (x, v))
                    .then(|| differentiate::Autocovariance::new(&self.lengths))
            })
            .collect();
        let has = |k: usize| mapped.iter().any(|m| m.0 == k);
        let most = self.lengths.iter().copied().max().unwrap_or(0);
        let mut pairs: Vec<((usize, usize), CrossWelch)> = Vec::new();
        for &(x, v, a) in masses {
            for (f, d) in [(x, v), (v, x), (v, a), (a, v)] {
                let period = periods.iter().find(|p| p.0 == f).and_then(|p| p.1);
                if let (true, true, Some(period)) = (has(f), has(d), period) {
                    let len = ((32.0 * period) as usize).clamp(16, (most / 2).max(16));
                    pairs.push(((f, d), CrossWelch::new(len, h, self.lengths.len())));
                }
            }
        }
        self.for_each_sample_ahead(&mut |j, t, row| {
            also(j, t, row);
            if j == longest {
                for (w, &k) in motion_welch.iter_mut().zip(&motion) {
                    w.push(0, row[k]);
                }
            }
            if j == 0 {
                for ((w, v), s) in derived_welch.iter_mut().zip(&mut velocity_welch).zip(&self.derive) {
                    w.push(0, row[s.from]);
                    if let (Some(v), Some(velocity)) = (v, s.second) {
                        v.push(0, row[velocity]);
                    }
                }
            }
            for (a, s) in autocovariances.iter_mut().zip(&self.derive) {
                if let Some(a) = a {
                    a.push(j as usize, row[s.from]);
                }
            }
            for ((f, d), w) in pairs.iter_mut() {
                w.push(j as usize, row[*f], row[*d]);
            }
        })?;
        Ok(Look {
            motion_frequency: motion_welch
                .iter()
                .map(|w| Resolution::of(w, h, false).wh / h)
                .fold(f64::NAN, f64::max),
            derived: derived_welch
                .iter()
                .zip(&self.derive)
                .map(|(w, s)| Resolution::of(w, h, s.second.is_some()))
                .collect(),
            velocity: velocity_welch
                .iter()
                .map(|w| w.as_ref().map(|w| Resolution::of(w, h, false)))
                .collect(),
            differencing: autocovariances
                .iter()
                .map(|a| a.as_ref().and_then(|a| a.differencing(h)))
                .collect(),
            derivatives: pairs.into_iter().map(|(p, w)| (p, w.derivative_gain())).collect(),
        })
    }

    /// Each derived column's differences: as wide as the displacement's noise asks
    /// (`differentiate`), or, where the sampling is coarse and the source shows no noise,
    /// the exact central difference of the order the source's spectrum asks for (for an
    /// acceleration from a clean displacement, its exact second difference, where that
    /// reaches the band edge); and every later derivative's lag after them.
    pub(super) fn choose_stencils(&mut self, look: &mut Look, width: usize) {
        let mut lags = vec![0usize; width];
        let mut noisy = vec![false; width];
        for (k, step) in self.derive.iter_mut().enumerate() {
            if let Some(v) = step.second {
                // The second derivative of a clean displacement where the sampling is coarse
                // and its differences reach the acceleration's band edge; else, as before,
                // the velocity differenced again, judged on the velocity's spectrum.
                let r = look.derived[k];
                if let (false, true, Some((half, ..))) = (noisy[v], r.band_limited, r.exact) {
                    (step.half, step.exact) = (half, true);
                    lags[step.to] = (lags[step.from] + half).max(lags[v] + 1);
                    step.lag = lags[step.to];
                    continue;
                }
                (step.from, step.second) = (v, None);
                look.derived[k] = look.velocity[k].expect("the velocity's spectrum of a second derivative");
            }
            let detected = look.differencing[k].is_some_and(|d| d.detected());
            if let (false, false, Some((half, ..))) = (detected, noisy[step.from], look.derived[k].exact) {
                step.half = half;
                step.exact = true;
            }
            if let Some(mut d) = look.differencing[k] {
                if !step.exact {
                    step.half = d.half;
                }
                (d.half, d.exact) = (step.half, step.exact);
                self.differenced.push(DifferencedNoise {
                    displacement: step.from,
                    velocity: step.to,
                    found: d,
                });
            }
            noisy[step.to] = detected || noisy[step.from];
            lags[step.to] = lags[step.from] + step.half;
            step.lag = lags[step.to];
        }
    }
}
