//! The increment baselines' shared parts: the drift's parts compiled for evaluation per
//! sample, and the pairing of consecutive samples of each trajectory.

use crate::ident::poly::Compiled;
use crate::ident::Problem;

/// The drift's parts (known force per mass, unit force per unknown and mass:
/// [`Problem::known_force`], [`Problem::unit_force`]) compiled for per-sample evaluation.
#[derive(Clone)]
pub(in crate::ident) struct DriftParts {
    /// Known forces, then the unit forces unknown-major (`unit[row * n + i]`).
    pub(in crate::ident) parts: Compiled,
    n: usize,
    values: Vec<f64>,
}

impl DriftParts {
    pub(in crate::ident) fn of(problem: &Problem) -> DriftParts {
        let parts = Compiled::new(problem.known_force.iter().chain(problem.unit_force.iter().flatten()));
        DriftParts {
            values: vec![0.0; parts.len()],
            parts,
            n: problem.n,
        }
    }

    /// The parts at state `y`: known force per mass, unit force per unknown and mass.
    pub(in crate::ident) fn at(&mut self, y: &[f64], known: &mut [f64], unit: &mut [f64]) {
        self.parts.eval(y, &mut self.values);
        let (kv, uv) = self.values.split_at(self.n);
        for (k, v) in known.iter_mut().zip(kv) {
            *k = *v;
        }
        for (u, v) in unit.iter_mut().zip(uv) {
            *u = *v;
        }
    }
}

/// Consecutive samples of each trajectory, `h` apart: the previous state per trajectory.
pub(in crate::ident) struct Pairs {
    pub(in crate::ident) h: f64,
    prev: Vec<Option<(f64, Vec<f64>)>>,
}

impl Pairs {
    pub(in crate::ident) fn new(h: f64) -> Pairs {
        Pairs { h, prev: Vec::new() }
    }

    /// The state `y` of the sample before `(trajectory, t)` if it is exactly one interval
    /// earlier; then remember this one (`y` in problem order).
    pub(in crate::ident) fn step(&mut self, trajectory: usize, t: f64, y: &[f64], mut f: impl FnMut(&[f64])) {
        if self.prev.len() <= trajectory {
            self.prev.resize(trajectory + 1, None);
        }
        let h = self.h;
        match &mut self.prev[trajectory] {
            Some((t0, y0)) => {
                if ((t - *t0) - h).abs() <= 1e-6 * h {
                    f(y0);
                }
                *t0 = t;
                y0.copy_from_slice(y);
            }
            slot @ None => *slot = Some((t, y.to_vec())),
        }
    }
}
