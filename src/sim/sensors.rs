//! The sensors between the simulated motion and the log: white Gaussian noise added to
//! every mass's displacement and velocity, and to the accelerations and forces where the
//! rig measures them, as `[measurement]` states (docs/measurement.md). With `sensors`, only
//! the channels the rig's sensors give; the others are logged clean ([`channels`]).
//!
//! Each noise value comes from a counter-based generator keyed by the run's seed, the
//! trajectory, the sample's index in it and the column, so it does not depend on the thread
//! count or the block size, and adding sensors leaves the motion itself untouched (its
//! generators draw exactly as without them).

use super::sinks::SampleBatch;
use crate::model::Model;
use crate::scenario::{NoiseScale, Sensors};
use rayon::prelude::*;

/// What a log column is on a rig ([`channels`]): a sensor's output (noise, ADC and
/// filters apply), or a clean state kept for diagnostics — a value at the sample instant,
/// or a mean over the interval (an acceleration as `Δv/h`, a white force's impulse).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Channel {
    Sensor,
    Instant,
    Mean,
}

/// Per log column of `model`, what `sensors` make of it: every column a sensor's without
/// `[measurement] sensors`, else those its masses' sensors give.
pub(crate) fn channels(model: &Model, sensors: &Sensors) -> Vec<Channel> {
    let c = model.columns();
    let Some(rig) = &sensors.rig else {
        return vec![Channel::Sensor; c.len()];
    };
    let mut out = vec![Channel::Instant; c.len()];
    let pick = |on: bool, clean: Channel| if on { Channel::Sensor } else { clean };
    for (i, m) in rig.iter().enumerate() {
        out[c.x(i)] = pick(m.displacement, Channel::Instant);
        out[c.v(i)] = pick(m.velocity, Channel::Instant);
        out[c.a(i)] = pick(m.acceleration, Channel::Mean);
    }
    for (e, exc) in model.excitations.iter().enumerate() {
        let white = matches!(exc.process, crate::scenario::Process::White { .. });
        let cell = exc.targets.iter().any(|&i| rig[i].force);
        out[c.force(e)] = pick(cell, if white { Channel::Mean } else { Channel::Instant });
    }
    out
}

/// The noise of a run's sensors.
pub(crate) struct SensorNoise {
    seed: u64,
    /// Per log column: the noise's standard deviation and the ADC's half range (resolved
    /// from the first block for relative levels; a range of 0: no ADC).
    resolved: Option<(Vec<f64>, Vec<f64>)>,
    /// Per log column: its noise level and ADC range as stated.
    level: Vec<f64>,
    range: Vec<f64>,
    relative: bool,
    bits: u32,
    /// Values clipped by the ADC so far.
    pub(crate) clipped: u64,
}

impl SensorNoise {
    /// The sensors of `model`'s columns, `None` without noise or ADC.
    pub(crate) fn new(model: &Model, sensors: &Sensors, seed: u64) -> Option<SensorNoise> {
        if !sensors.noisy() {
            return None;
        }
        let c = model.columns();
        let mut level = vec![0.0; c.len()];
        let mut range = vec![0.0; c.len()];
        let adc = sensors.adc.map_or(0.0, |a| a.range);
        for i in 0..model.masses() {
            level[c.x(i)] = sensors.displacement;
            level[c.v(i)] = sensors.velocity;
            range[c.x(i)] = adc;
            range[c.v(i)] = adc;
            if let Some(a) = sensors.acceleration {
                level[c.a(i)] = a;
                range[c.a(i)] = adc;
            }
        }
        if let Some(f) = sensors.force {
            for e in 0..model.excitations.len() {
                level[c.force(e)] = f;
                range[c.force(e)] = adc;
            }
        }
        if !sensors.columns.is_empty() {
            level.clone_from(&sensors.columns);
            level.resize(c.len(), 0.0);
        }
        if sensors.rig.is_some() {
            // A rig's sensors alone: its ADC converts every one of them, the clean states
            // stay clean.
            for (k, ch) in channels(model, sensors).into_iter().enumerate() {
                if ch != Channel::Sensor {
                    level[k] = 0.0;
                }
                range[k] = if ch == Channel::Sensor { adc } else { 0.0 };
            }
        }
        let relative = sensors.scale == NoiseScale::Relative && sensors.columns.is_empty();
        Some(SensorNoise {
            seed: seed ^ 0x5e45_0a15_e000_0001,
            resolved: (!relative).then(|| (level.clone(), range.clone())),
            level,
            range,
            relative,
            bits: sensors.adc.map_or(0, |a| a.bits),
            clipped: 0,
        })
    }

    /// Add the noise to `batch`, whose first instant is sample `first` of every trajectory,
    /// then quantise and clip where there is an ADC.
    pub(crate) fn apply(&mut self, batch: &mut SampleBatch, first: usize) {
        let (cols, per_k) = (batch.columns, batch.trajectories);
        if self.resolved.is_none() {
            // Relative levels: of each column's standard deviation over this first block.
            let n = (batch.instants() * per_k) as f64;
            let std: Vec<f64> = (0..cols)
                .map(|c| {
                    let (mut s, mut s2) = (0.0, 0.0);
                    for k in 0..batch.instants() {
                        for &v in &batch.instant(k)[c * per_k..(c + 1) * per_k] {
                            s += v;
                            s2 += v * v;
                        }
                    }
                    (s2 / n - (s / n).powi(2)).max(0.0).sqrt()
                })
                .collect();
            let scaled = |v: &[f64]| v.iter().zip(&std).map(|(a, s)| a * s).collect::<Vec<f64>>();
            debug_assert!(self.relative);
            self.resolved = Some((scaled(&self.level), scaled(&self.range)));
        }
        let (sigma, range) = self.resolved.as_ref().expect("resolved above");
        let (seed, bits) = (self.seed, self.bits);
        let clipped: u64 = batch
            .values
            .par_chunks_mut(cols * per_k)
            .enumerate()
            .map(|(k, instant)| {
                let sample = (first + k) as u64;
                let mut clipped = 0;
                for (c, column) in instant.chunks_mut(per_k).enumerate() {
                    if sigma[c] > 0.0 {
                        for (j, v) in column.iter_mut().enumerate() {
                            *v += sigma[c] * normal(seed, j as u64, sample, c as u64);
                        }
                    }
                    if range[c] > 0.0 {
                        for v in column.iter_mut() {
                            let (q, hit) = quantise(*v, range[c], bits);
                            *v = q;
                            clipped += hit as u64;
                        }
                    }
                }
                clipped
            })
            .sum();
        self.clipped += clipped;
    }
}

/// A mid-rise ADC of `2^bits` levels over `±range`: the level of `y` (the centre of its
/// step, so the rounding error is uniform over a step, of mean 0 and variance `q²/12`),
/// and whether `y` was beyond the range (clipped to the outermost level).
pub(crate) fn quantise(y: f64, range: f64, bits: u32) -> (f64, bool) {
    let steps = (1u64 << bits) as f64;
    let q = 2.0 * range / steps;
    let k = ((y + range) / q).floor();
    let clipped = !(0.0..steps).contains(&k);
    let k = k.clamp(0.0, steps - 1.0);
    ((k + 0.5) * q - range, clipped)
}

/// SplitMix64's finaliser.
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_133f_11eb);
    z ^ (z >> 31)
}

/// A standard normal value for `(seed, trajectory, sample, column)` (Box–Muller on two
/// uniforms from chained SplitMix64 mixes of the key).
pub(crate) fn normal(seed: u64, trajectory: u64, sample: u64, column: u64) -> f64 {
    let a = mix(seed ^ mix(trajectory.wrapping_add(0x9e37_79b9_7f4a_7c15)));
    let b = mix(a ^ mix(sample.wrapping_mul(0xd1b5_4a32_d192_ed03) ^ column));
    let c = mix(b ^ 0x2545_f491_4f6c_dd1d);
    // Uniforms in (0, 1] and [0, 1).
    let u1 = ((b >> 11) + 1) as f64 * (1.0 / (1u64 << 53) as f64);
    let u2 = (c >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ADC's levels: the rounding error within half a step, uniform (mean 0, variance
    /// `q²/12` over a fine sweep), values beyond the range clipped to the outermost level.
    #[test]
    fn the_adc_rounds_to_the_centre_of_its_step_and_clips_beyond_its_range() {
        let (range, bits) = (2.0, 6);
        let q = 2.0 * range / 64.0;
        // 1000 points in each of the 64 steps, placed alike in each.
        let n = 64_000;
        let (mut m1, mut m2) = (0.0, 0.0);
        for i in 0..n {
            let y = -range + 2.0 * range * (i as f64 + 0.5) / n as f64;
            let (v, clipped) = quantise(y, range, bits);
            assert!(!clipped && (v - y).abs() <= 0.5 * q + 1e-12, "{y} -> {v}");
            m1 += v - y;
            m2 += (v - y).powi(2);
        }
        assert!(
            (m1 / n as f64).abs() < 1e-9 * q,
            "mean rounding error {}",
            m1 / n as f64
        );
        assert!((m2 / n as f64 / (q * q / 12.0) - 1.0).abs() < 1e-3);
        assert_eq!(quantise(5.0, range, bits), (range - 0.5 * q, true));
        assert_eq!(quantise(-2.0 - 1e-9, range, bits), (-range + 0.5 * q, true));
    }

    /// The keyed normals have the moments of a standard normal and no correlation between
    /// neighbouring samples, trajectories or columns.
    #[test]
    fn keyed_normals_are_standard_and_uncorrelated() {
        let n = 200_000u64;
        let (mut m1, mut m2, mut m4) = (0.0, 0.0, 0.0);
        let (mut lag, mut traj, mut col) = (0.0, 0.0, 0.0);
        let mut prev = normal(7, 0, 0, 0);
        for s in 1..n {
            let z = normal(7, 0, s, 0);
            m1 += z;
            m2 += z * z;
            m4 += z.powi(4);
            lag += z * prev;
            traj += z * normal(7, 1, s, 0);
            col += z * normal(7, 0, s, 1);
            prev = z;
        }
        let nf = (n - 1) as f64;
        let se = 1.0 / nf.sqrt();
        assert!((m1 / nf).abs() < 4.0 * se, "mean {}", m1 / nf);
        assert!((m2 / nf - 1.0).abs() < 4.0 * 2f64.sqrt() * se, "variance {}", m2 / nf);
        assert!(
            (m4 / nf - 3.0).abs() < 4.0 * 96f64.sqrt() * se,
            "fourth moment {}",
            m4 / nf
        );
        for (what, r) in [("lag 1", lag), ("trajectories", traj), ("columns", col)] {
            assert!((r / nf).abs() < 4.0 * se, "correlation between {what}: {}", r / nf);
        }
    }
}
