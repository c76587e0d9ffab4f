//! `[measurement]`, the sensors between the motion and the samples (docs/measurement.md):
//! their noise levels, ADC and filters ([`Sensors`]), and, with `sensors`, what each mass's
//! sensors give on a simulated rig ([`MassSensors`]; without it a simulation logs and
//! identifies every mass's displacement and velocity). Also the rate at which the
//! sensors' filters run (`anti_alias`, `bandwidth`): the scenario's checks and the
//! simulator's filters (`sim::sensor_filters`) take it from here, so both refuse the same
//! settings.
//!
//! The measurement chain has one name in every layer: `scenario::sensors` (what the
//! sensors are), `scenario::validate::sensors` (their checks), `sim::sensors` and
//! `sim::sensor_filters` (what they do to a simulated motion), `pipeline::sensors` (what
//! the identification does about them) — apart from `io::measured`, a lab's own tables.

use serde::Deserialize;

/// How `[measurement]`'s noise levels are read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum NoiseScale {
    /// Fractions of each channel's standard deviation (the simulator takes it over the
    /// first block of samples, every trajectory's).
    #[default]
    Relative,
    /// In the channel's unit (m, m/s, or rad, rad/s).
    Absolute,
}

/// `[measurement]`: the sensors — white Gaussian noise, independent between channels and
/// instants, on every mass's measured displacement and velocity (docs/measurement.md).
/// The simulator adds it to the logged samples; a model file of measured data states what
/// is known of its sensors.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Sensors {
    /// Whether the levels are fractions of each channel's std or in its unit.
    pub scale: NoiseScale,
    /// Noise level on every displacement (0: none).
    pub displacement: f64,
    /// Noise level on every velocity (0: none).
    pub velocity: f64,
    /// Noise level on every acceleration, if the accelerations are sensors of the rig
    /// (then the ADC converts them too).
    pub acceleration: Option<f64>,
    /// Noise level on every excitation force (force cells), likewise.
    pub force: Option<f64>,
    /// Per log column, the noise's standard deviation in its unit, when it is known
    /// channel by channel (a validation re-simulates measured data with the noise
    /// estimated from them); empty: the levels above.
    pub columns: Vec<f64>,
    /// The analogue-to-digital converter of every displacement and velocity channel (and
    /// acceleration and force channel with a level above):
    /// `2^bits` levels over `±range` (in the channel's std for relative noise, else in its
    /// unit); values beyond the range are clipped to it, and counted.
    pub adc: Option<Adc>,
    /// The anti-alias low-pass before the ADC, on every logged channel.
    pub anti_alias: Option<AntiAlias>,
    /// Every sensor's bandwidth, Hz: a second-order Butterworth low-pass at it.
    pub bandwidth: Option<f64>,
    /// `sensors`: per mass, what the rig measures; `None`: every displacement and velocity.
    pub rig: Option<Vec<MassSensors>>,
}

/// An anti-alias filter: a Butterworth low-pass of `order` with its −3 dB corner at
/// `corner` × the sampling rate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AntiAlias {
    /// The −3 dB corner, a fraction of the sampling rate.
    pub corner: f64,
    /// The Butterworth order, 1–8.
    pub order: u32,
}

/// An ADC: `2^bits` levels over `±range`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Adc {
    /// Bits of the converter.
    pub bits: u32,
    /// Its range `±range` (in the channel's std for relative levels, else in its unit).
    pub range: f64,
}

impl Sensors {
    /// The noise variance a channel gets from these sensors at `level`: `(level·unit)²`
    /// plus the ADC's rounding `q²/12` for its step `q = 2·range·unit/2^bits`, where
    /// `unit` is the channel's own std `std` for relative levels and 1 for absolute ones.
    pub fn noise_variance(&self, level: f64, std: f64) -> f64 {
        let unit = match self.scale {
            NoiseScale::Absolute => 1.0,
            NoiseScale::Relative => std,
        };
        let rounding = self.adc.map_or(0.0, |a| {
            let q = 2.0 * a.range * unit / (1u64 << a.bits) as f64;
            q * q / 12.0
        });
        (level * unit).powi(2) + rounding
    }

    /// Whether any channel has noise.
    pub fn noisy(&self) -> bool {
        self.displacement > 0.0
            || self.velocity > 0.0
            || self.acceleration.is_some_and(|a| a > 0.0)
            || self.force.is_some_and(|f| f > 0.0)
            || self.columns.iter().any(|&s| s > 0.0)
            || self.adc.is_some()
    }
}

/// The spread a measured quantity's values may have in the identification's units (a
/// table column's middle half after `[data.scale]`, an absolute ADC range): moments of
/// degree 12 of values outside it leave the range of `f64` (1e±300), and with them every
/// estimate.
pub const MAGNITUDE: (f64, f64) = (1e-25, 1e25);

/// The sensors' filters run on the motion sampled at least this many times faster than
/// the log.
pub const MIN_OVERSAMPLING: usize = 8;

impl Sensors {
    /// Fast samples per logged sample at which the sensors' filters run, for a log sampled
    /// every `interval` s with `steps` steps of `dt` per sample, each in `substeps`: the
    /// smallest divisor of `steps` (else of `steps · substeps`) that is at least
    /// [`MIN_OVERSAMPLING`] and resolves the bandwidth (a fifth of the fast rate); `None`
    /// without filters. Divisors of the `dt` grid come first, so a run at half the step
    /// (twice the substeps: the integrator's bias) filters at the same rate as its pair.
    /// `Err`: the steps cannot carry the filters, or no divisor resolves the bandwidth.
    pub fn filter_oversampling(&self, interval: f64, steps: usize, substeps: usize) -> Result<Option<usize>, String> {
        if self.anti_alias.is_none() && self.bandwidth.is_none() {
            return Ok(None);
        }
        let all = steps * substeps.max(1);
        let candidates: Vec<usize> = (MIN_OVERSAMPLING..=steps)
            .filter(|r| steps.is_multiple_of(*r))
            .chain((MIN_OVERSAMPLING..=all).filter(|r| all.is_multiple_of(*r)))
            .collect();
        if candidates.is_empty() {
            return Err(format!(
                "the filters run on the motion sampled at least {MIN_OVERSAMPLING} times faster than the log, and \
                 a sample interval is {all} integration steps: make dt at most sample_interval / {MIN_OVERSAMPLING}"
            ));
        }
        let resolves = |r: usize| self.bandwidth.is_none_or(|b| b * 5.0 <= r as f64 / interval);
        match candidates.iter().find(|&&r| resolves(r)) {
            Some(&r) => Ok(Some(r)),
            None => {
                let fast = candidates.iter().max().copied().unwrap_or(MIN_OVERSAMPLING) as f64 / interval;
                Err(format!(
                    "a sensor bandwidth of {} Hz is beyond what the simulation resolves (the filters run at \
                     {fast} Hz at most and resolve up to a fifth of it, {} Hz): a sensor that fast is ideal here, \
                     leave `bandwidth` out, or make dt smaller",
                    self.bandwidth.unwrap_or(0.0),
                    fast / 5.0
                ))
            }
        }
    }
}

/// One mass's sensors: which of its quantities the rig measures. `force`: the cells of the
/// excitations acting on it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MassSensors {
    /// The mass's displacement.
    pub displacement: bool,
    /// Its velocity.
    pub velocity: bool,
    /// Its acceleration.
    pub acceleration: bool,
    /// The force cells of the excitations acting on it.
    pub force: bool,
}

impl MassSensors {
    /// The words a scenario writes, in order.
    pub const WORDS: [&'static str; 4] = ["displacement", "velocity", "acceleration", "force"];

    /// Whether the rig gives the mass's whole state (its displacement and velocity), so the
    /// log's samples are read as they are.
    pub fn whole_state(&self) -> bool {
        self.displacement && self.velocity
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The filters' rate comes from the `dt` grid first, so a run at half the step (twice
    /// the substeps) filters at its pair's rate, and a bandwidth the smallest divisor does
    /// not resolve takes the next that does.
    #[test]
    fn a_run_at_half_the_step_filters_at_its_pairs_rate() {
        let bandwidth = Sensors {
            bandwidth: Some(20.0),
            ..Sensors::default()
        };
        // 100 steps of 1 ms per 0.1 s sample: 10 fast samples per sample (100 Hz, resolving
        // 20 Hz); the refined run's 200 steps used to give 8 (80 Hz) and fail.
        assert_eq!(bandwidth.filter_oversampling(0.1, 100, 1), Ok(Some(10)));
        assert_eq!(bandwidth.filter_oversampling(0.1, 100, 2), Ok(Some(10)));
        // 25 Hz needs 125 fast samples a second: 20 per sample.
        let faster = Sensors {
            bandwidth: Some(25.0),
            ..Sensors::default()
        };
        assert_eq!(faster.filter_oversampling(0.1, 100, 1), Ok(Some(20)));
        // Beyond every divisor: refused, the fastest rate named.
        let too_fast = Sensors {
            bandwidth: Some(300.0),
            ..Sensors::default()
        };
        let e = too_fast.filter_oversampling(0.1, 100, 1).unwrap_err();
        assert!(e.contains("1000 Hz at most"), "{e}");
        let anti_alias = Sensors {
            anti_alias: Some(AntiAlias { corner: 0.4, order: 4 }),
            ..Sensors::default()
        };
        assert_eq!(anti_alias.filter_oversampling(0.1, 100, 2), Ok(Some(10)));
        // Only the substeps carry the rate: 4 steps of 8 substeps.
        assert_eq!(anti_alias.filter_oversampling(0.1, 4, 8), Ok(Some(8)));
        assert!(anti_alias.filter_oversampling(0.1, 4, 1).is_err());
        assert_eq!(Sensors::default().filter_oversampling(0.1, 4, 1), Ok(None));
    }
}
