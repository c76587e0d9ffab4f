//! A scenario's unmeasured excitations set to a level relative to the measured force: the
//! disturbance-level axis of a study (docs/studies.md) and of the section-4 experiments.

use super::{Process, Scenario};

impl Scenario {
    /// This scenario with every unmeasured excitation scaled so that its standard deviation
    /// is `level` times the measured force's (at level 0 they are removed). White noise
    /// counts at the sample interval (it is logged as interval means). The level is
    /// absolute, whatever level the scenario had. The checked values are edited, never the
    /// text: `source` stays as written and `disturbance_level` records the level.
    pub fn with_disturbance_level(&self, level: f64) -> Scenario {
        let dt = self.simulation.sample_interval;
        let std = |p: &Process| match *p {
            Process::White { sigma } => sigma / dt.sqrt(),
            Process::Filtered { a, b } => a / (2.0 * b).sqrt(),
            Process::Lab(ref signal) => signal.rms(),
        };
        let reference = self
            .excitations
            .iter()
            .find(|e| e.measured)
            .map_or(1.0, |e| std(&e.process));
        let mut out = self.clone();
        out.disturbance_level = Some(level);
        // Old excitation index -> new one (none for a removed excitation).
        let mut index = Vec::with_capacity(self.excitations.len());
        out.excitations.clear();
        for e in &self.excitations {
            if !e.measured && level == 0.0 {
                index.push(None);
                continue;
            }
            let mut e = e.clone();
            if !e.measured {
                let k = level * reference / std(&e.process);
                match &mut e.process {
                    Process::White { sigma } => *sigma *= k,
                    Process::Filtered { a, .. } => *a *= k,
                    Process::Lab(signal) => *signal = signal.scaled(k),
                }
            }
            index.push(Some(out.excitations.len()));
            out.excitations.push(e);
        }
        let remap = |list: &mut Vec<usize>| *list = list.iter().filter_map(|&e| index[e]).collect();
        let id = &mut out.identify;
        remap(&mut id.unknown_intensities);
        remap(&mut id.known_filters);
        remap(&mut id.unknown_corners);
        remap(&mut id.equivalent_white);
        remap(&mut id.choose_force_model);
        if let Some(d) = &mut id.disturbance {
            d.structure.measured = index[d.structure.measured].expect("the measured force is kept");
        }
        out
    }
}
