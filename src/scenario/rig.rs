//! `[measurement] sensors`: what each mass's sensors give on a simulated rig
//! (docs/measurement.md, "A rig's sensors"). Without it a simulation logs and identifies
//! every mass's displacement and velocity. Also the rate at which the sensors' filters run
//! (`anti_alias`, `bandwidth`): the scenario's checks and the simulator's filters
//! (`sim::filters`) take it from here, so both refuse the same settings.

use super::Sensors;

/// The sensors' filters run on the motion sampled at least this many times faster than
/// the log.
pub const MIN_OVERSAMPLING: usize = 8;

impl Sensors {
    /// Fast samples per logged sample at which the sensors' filters run, for a log sampled
    /// every `interval` s with `steps` integration steps per sample: the smallest divisor
    /// of `steps` that is at least [`MIN_OVERSAMPLING`]; `None` without filters. `Err`: the
    /// steps cannot carry the filters, or a bandwidth is beyond what the fast rate
    /// resolves (a fifth of it).
    pub fn filter_oversampling(&self, interval: f64, steps: usize) -> Result<Option<usize>, String> {
        if self.anti_alias.is_none() && self.bandwidth.is_none() {
            return Ok(None);
        }
        let Some(oversampling) = (MIN_OVERSAMPLING..=steps).find(|r| steps.is_multiple_of(*r)) else {
            return Err(format!(
                "the filters run on the motion sampled at least {MIN_OVERSAMPLING} times faster than the log, and \
                 a sample interval is {steps} integration steps: make dt at most sample_interval / {MIN_OVERSAMPLING}"
            ));
        };
        let fast = oversampling as f64 / interval;
        if let Some(b) = self.bandwidth {
            if b * 5.0 > fast {
                return Err(format!(
                    "a sensor bandwidth of {b} Hz is beyond what the simulation resolves (the filters run at \
                     {fast} Hz and resolve up to a fifth of it, {} Hz): a sensor that fast is ideal here, leave \
                     `bandwidth` out, or make dt smaller",
                    fast / 5.0
                ));
            }
        }
        Ok(Some(oversampling))
    }
}

/// One mass's sensors: which of its quantities the rig measures. `force`: the cells of the
/// excitations acting on it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MassSensors {
    pub displacement: bool,
    pub velocity: bool,
    pub acceleration: bool,
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
