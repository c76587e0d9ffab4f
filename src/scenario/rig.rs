//! `[measurement] sensors`: what each mass's sensors give on a simulated rig
//! (docs/measurement.md, "A rig's sensors"). Without it a simulation logs and identifies
//! every mass's displacement and velocity.

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
