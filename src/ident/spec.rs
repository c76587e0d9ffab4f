//! What is to be identified, with no truth in it: the system as far as it is known, and
//! which of its coefficients, masses, intensities and filter corners are unknown. Built
//! from a scenario (its known values and its `[identify]` section) or edited by the
//! pipeline (a comparison model, the white-noise baseline); [`super::Problem`] is built
//! from it.

use super::Filter;
use crate::model::{Characteristic, Model};
use crate::scenario::{IdentifyLink, Process, Scenario};

/// The identification's specification.
#[derive(Debug, Clone)]
pub struct Specification {
    /// The known system. Every characteristic that has unknown powers is zero in it.
    pub model: Model,
    /// Per link with unknowns: the powers of its stiffness and damping to identify.
    pub links: Vec<IdentifyLink>,
    /// Masses to identify.
    pub unknown_masses: Vec<usize>,
    /// White excitations whose intensity is to be identified.
    pub unknown_intensities: Vec<usize>,
    /// Filtered excitations whose corner `B` is to be identified (bilinear drift).
    pub unknown_corners: Vec<usize>,
}

impl Specification {
    /// The scenario's `[identify]` section over its system.
    pub fn from_scenario(s: &Scenario) -> Specification {
        Specification::with_links(s, &s.identify.links)
    }

    /// The scenario's unknowns, with `links` in place of its `[identify] links` (e.g. an
    /// `[identify.compare]` model).
    pub fn with_links(s: &Scenario, links: &[IdentifyLink]) -> Specification {
        let mut model = Model::new(s);
        // The identifier knows link forces of `u` and `w` alone (model::BoucWen).
        model.hysteresis.clear();
        // A lab signal is read as its equivalent white noise (its level set from its
        // measured spectrum by the stage "excitation fit").
        for e in &mut model.excitations {
            if matches!(e.process, Process::Lab(_)) {
                e.process = Process::White { sigma: 1.0 };
            }
        }
        for il in links {
            if il.stiffness.is_some() {
                model.clear(il.link, Characteristic::Stiffness);
            }
            if il.damping.is_some() {
                model.clear(il.link, Characteristic::Damping);
            }
        }
        Specification {
            model,
            links: links.to_vec(),
            unknown_masses: s.identify.unknown_masses.clone(),
            unknown_intensities: s.identify.unknown_intensities.clone(),
            unknown_corners: s.identify.unknown_corners.clone(),
        }
    }

    /// The measured filtered excitations at their given `A` and `B`.
    pub fn given_filters(&self) -> Vec<Filter> {
        self.model
            .excitations
            .iter()
            .enumerate()
            .filter_map(|(e, x)| match x.process {
                Process::Filtered { a, b } if x.measured => Some(Filter { excitation: e, a, b }),
                _ => None,
            })
            .collect()
    }

    /// This specification with every filter in `filters` replaced by white noise of the
    /// same low-frequency density (`σ = A/B`): what ignoring the filters amounts to.
    pub fn whitened(&self, filters: &[Filter]) -> Specification {
        let mut w = self.clone();
        w.unknown_corners.clear();
        for f in filters {
            w.model.excitations[f.excitation].process = Process::White { sigma: f.a / f.b };
        }
        w
    }
}
