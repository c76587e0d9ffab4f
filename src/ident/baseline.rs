//! Baseline estimators on the same samples, not FPK: what users of densely sampled data
//! reach for, so that the bench can show where the stationary-density methods win
//! (sparse, unsynchronised samples) and where they do not (docs/methods.md, "Baselines").
//!
//! Both regress the velocity increments between consecutive samples of a trajectory,
//! `Δv_i / h`, on the drift of the velocity equation,
//! `m_i v̇_i = K_i(y) + Σ_r θ_r b_ir(y)` (the known forces and the unknown coefficients'
//! unit forces, [`Problem::known_force`] and [`Problem::unit_force`]):
//!
//! - [`Increments`]: least squares over every pair of consecutive samples — the
//!   Euler–Maruyama pseudo-likelihood with the noise taken as equal per mass;
//! - [`KramersMoyal`]: the conditional mean increment in each cell of a grid over the
//!   state (the first Kramers–Moyal coefficient), then least squares of the drift at the
//!   cells' mean states, weighted by their counts (at the mean state rather than the
//!   centre, a drift linear in the state has no binning bias: on a linear oscillator the
//!   centres cost −1 % on k1, 1.8 standard errors, over 8 seeds).
//!
//! Both are biased when `h` is not small against the system's time scales (the increment
//! over `h` is not the drift), which is the point of comparing them with the weak form.
//! Standard errors: the delete-one jackknife over the same batches as the weak form.

use super::{estimate::estimate, Estimate, IdentError, Pieces, Problem, Unknown};
use std::collections::HashMap;

/// Why a baseline cannot run on `problem`, if it cannot: it regresses velocity increments,
/// so it needs white-noise forcing (no filtered excitations, no measured inputs) and
/// unknown coefficients only (a mass or an intensity is not in the drift's linear part).
pub fn applicable(problem: &Problem) -> Result<(), IdentError> {
    if !problem.filters.is_empty() || problem.inputs > 0 {
        return Err(IdentError::NotApplicable(
            "the increment baselines regress the velocity's drift, which filtered forces make unobserved \
             (their state is not in the data): white-noise excitation only"
                .into(),
        ));
    }
    if let Some(u) = problem.unknowns.iter().find(|u| !matches!(u, Unknown::Coefficient(_))) {
        return Err(IdentError::NotApplicable(format!(
            "the increment baselines estimate the drift's coefficients only, not {u:?}"
        )));
    }
    Ok(())
}

/// The normal equations of a weighted linear least-squares fit of the velocity equations,
/// as [`Pieces`] with one row per unknown (row `R` is `Σ w μ_i b_iR · residual_i`).
#[derive(Clone)]
struct Normal {
    pieces: Pieces,
}

impl Normal {
    fn new(problem: &Problem) -> Normal {
        let r = problem.unknowns.len();
        Normal {
            pieces: Pieces::new(r, problem.n, r),
        }
    }

    /// One equation per mass: `target_i ≈ μ_i (known_i + Σ_r θ_r unit_ir)`, weight `w`.
    fn add(&mut self, problem: &Problem, w: f64, target: &[f64], known: &[f64], unit: &[f64]) {
        let (n, r) = (problem.n, problem.unknowns.len());
        let p = &mut self.pieces;
        for i in 0..n {
            let mu = 1.0 / problem.model.mass[i];
            for row in 0..r {
                let f = w * mu * unit[row * n + i];
                if f == 0.0 {
                    continue;
                }
                p.t0[row] -= f * target[i];
                p.a[row * n + i] += f * known[i];
                for col in 0..r {
                    p.b[(row * n + i) * r + col] += f * unit[col * n + i];
                }
            }
        }
    }

    fn merge(&mut self, other: &Normal, sign: f64) {
        let (a, b) = (&mut self.pieces, &other.pieces);
        for (x, y) in a.t0.iter_mut().zip(&b.t0) {
            *x += sign * y;
        }
        for (x, y) in a.a.iter_mut().zip(&b.a) {
            *x += sign * y;
        }
        for (x, y) in a.b.iter_mut().zip(&b.b) {
            *x += sign * y;
        }
    }
}

/// The drift's parts at state `y`: known force per mass, unit force per unknown and mass.
fn drift_parts(problem: &Problem, y: &[f64], known: &mut [f64], unit: &mut [f64]) {
    let n = problem.n;
    for i in 0..n {
        known[i] = problem.known_force[i].eval(y);
    }
    for (row, per_mass) in problem.unit_force.iter().enumerate() {
        for i in 0..n {
            unit[row * n + i] = per_mass[i].eval(y);
        }
    }
}

/// Consecutive samples of each trajectory, `h` apart: the previous state per trajectory.
struct Pairs {
    h: f64,
    prev: Vec<Option<(f64, Vec<f64>)>>,
}

impl Pairs {
    fn new(h: f64) -> Pairs {
        Pairs { h, prev: Vec::new() }
    }

    /// The state `y` of the sample before `(trajectory, t)` if it is exactly one interval
    /// earlier; then remember this one (`y` in problem order).
    fn step(&mut self, trajectory: usize, t: f64, y: &[f64], mut f: impl FnMut(&[f64])) {
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

/// The increment regression (Euler–Maruyama pseudo-likelihood), streamed.
pub struct Increments {
    problem: Problem,
    pairs: Pairs,
    batches: Vec<Normal>,
    y: Vec<f64>,
    known: Vec<f64>,
    unit: Vec<f64>,
    target: Vec<f64>,
    used: u64,
}

impl Increments {
    /// For `problem` (see [`applicable`]), samples every `h` seconds, `batches` jackknife
    /// batches (the weak form's: [`super::data::StationaryData::batch_of`]).
    pub fn new(problem: &Problem, h: f64, batches: usize) -> Increments {
        let (n, r) = (problem.n, problem.unknowns.len());
        Increments {
            problem: problem.clone(),
            pairs: Pairs::new(h),
            batches: vec![Normal::new(problem); batches.max(1)],
            y: vec![0.0; problem.dim()],
            known: vec![0.0; n],
            unit: vec![0.0; r * n],
            target: vec![0.0; n],
            used: 0,
        }
    }

    /// One sample (a log row) of `trajectory` at `t`, in batch `batch`.
    pub fn push(&mut self, trajectory: usize, t: f64, batch: usize, row: &[f64]) {
        let p = &self.problem;
        for (j, &c) in p.columns.iter().enumerate() {
            self.y[j] = row[c];
        }
        let (known, unit, target, h) = (&mut self.known, &mut self.unit, &mut self.target, self.pairs.h);
        let y = &self.y;
        let last = self.batches.len() - 1;
        let normal = &mut self.batches[batch.min(last)];
        let used = &mut self.used;
        self.pairs.step(trajectory, t, y, |y0| {
            drift_parts(p, y0, known, unit);
            for i in 0..p.n {
                let v = p.noise_var[i];
                target[i] = (y[v] - y0[v]) / h;
            }
            normal.add(p, 1.0, target, known, unit);
            *used += 1;
        });
    }

    pub fn estimate(&self, typical: &[f64]) -> Result<Estimate, IdentError> {
        let facts = vec![
            ("pairs".into(), format!("{} consecutive sample pairs", self.used)),
            (
                "regression".into(),
                format!(
                    "Δv/h on the drift, h = {} s (Euler–Maruyama pseudo-likelihood)",
                    self.pairs.h
                ),
            ),
            (
                "standard errors".into(),
                format!("delete-one jackknife over {} batches", self.batches.len()),
            ),
        ];
        solve_batches(&self.problem, "increments", &self.batches, typical, facts, self.used)
    }
}

/// Solve the sum of the batches' normal equations, and each leave-one-out replicate.
fn solve_batches(
    problem: &Problem,
    method: &'static str,
    batches: &[Normal],
    typical: &[f64],
    facts: Vec<(String, String)>,
    equations: u64,
) -> Result<Estimate, IdentError> {
    if equations < 10 * problem.unknowns.len() as u64 {
        return Err(IdentError::TooLittleData(format!(
            "{equations} pairs of consecutive samples for {} unknowns",
            problem.unknowns.len()
        )));
    }
    let mut total = Normal::new(problem);
    for b in batches {
        total.merge(b, 1.0);
    }
    let replicates: Vec<Pieces> = if batches.len() >= 2 {
        batches
            .iter()
            .map(|b| {
                let mut r = total.clone();
                r.merge(b, -1.0);
                r.pieces
            })
            .collect()
    } else {
        Vec::new()
    };
    estimate(problem, method, &total.pieces, &replicates, typical, facts, None)
}

/// The binned conditional-mean increments (first Kramers–Moyal coefficient), streamed.
pub struct KramersMoyal {
    problem: Problem,
    pairs: Pairs,
    grid: Grid,
    /// Per occupied cell: the sum of the states `y` it holds, then per batch the count and
    /// the sum of `Δv_i/h` per mass.
    cells: HashMap<u64, Vec<f64>>,
    nb: usize,
    y: Vec<f64>,
    y0: Vec<f64>,
    incr: Vec<f64>,
    used: u64,
    outside: u64,
}

/// Smallest count of a cell whose mean increment enters the fit.
pub const KM_MIN_COUNT: f64 = 10.0;

/// A regular grid of `bins` per variable over mean ± `span` std.
struct Grid {
    lo: Vec<f64>,
    width: Vec<f64>,
    bins: usize,
    span: f64,
}

impl Grid {
    fn cell(&self, y: &[f64]) -> Option<u64> {
        let mut idx = 0u64;
        for (j, &x) in y.iter().enumerate() {
            let b = ((x - self.lo[j]) / self.width[j]).floor();
            if !(0.0..self.bins as f64).contains(&b) {
                return None;
            }
            idx = idx * self.bins as u64 + b as u64;
        }
        Some(idx)
    }
}

impl KramersMoyal {
    /// A grid of `bins` per state variable over mean ± `span` std (`mean`, `std` per state
    /// variable), samples every `h` seconds, `batches` jackknife batches.
    pub fn new(
        problem: &Problem,
        h: f64,
        batches: usize,
        (mean, std): (&[f64], &[f64]),
        bins: usize,
        span: f64,
    ) -> KramersMoyal {
        KramersMoyal {
            problem: problem.clone(),
            pairs: Pairs::new(h),
            grid: Grid {
                lo: mean.iter().zip(std).map(|(m, s)| m - span * s).collect(),
                width: std.iter().map(|s| 2.0 * span * s / bins as f64).collect(),
                bins,
                span,
            },
            cells: HashMap::new(),
            nb: batches.max(1),
            y: vec![0.0; problem.dim()],
            y0: vec![0.0; problem.dim()],
            incr: vec![0.0; problem.n],
            used: 0,
            outside: 0,
        }
    }

    /// One sample (a log row) of `trajectory` at `t`, in batch `batch`.
    pub fn push(&mut self, trajectory: usize, t: f64, batch: usize, row: &[f64]) {
        let p = &self.problem;
        for (j, &c) in p.columns.iter().enumerate() {
            self.y[j] = row[c];
        }
        let (y, incr, grid, h) = (&self.y, &mut self.incr, &self.grid, self.pairs.h);
        // The pair's starting cell (None when it starts outside the grid) and state.
        let mut start: Option<Option<u64>> = None;
        let y0s = &mut self.y0;
        self.pairs.step(trajectory, t, y, |y0| {
            for (i, d) in incr.iter_mut().enumerate() {
                let v = p.noise_var[i];
                *d = (y[v] - y0[v]) / h;
            }
            y0s.copy_from_slice(y0);
            start = Some(grid.cell(y0));
        });
        match start {
            None => {}
            Some(None) => self.outside += 1,
            Some(Some(c)) => {
                let (dim, stride, nb) = (p.dim(), 1 + p.n, self.nb);
                let acc = self.cells.entry(c).or_insert_with(|| vec![0.0; dim + nb * stride]);
                for (a, y) in acc.iter_mut().zip(&self.y0) {
                    *a += y;
                }
                let b = dim + batch.min(nb - 1) * stride;
                acc[b] += 1.0;
                for (i, d) in self.incr.iter().enumerate() {
                    acc[b + 1 + i] += d;
                }
                self.used += 1;
            }
        }
    }

    pub fn estimate(&self, typical: &[f64]) -> Result<Estimate, IdentError> {
        let p = &self.problem;
        let (n, r) = (p.n, p.unknowns.len());
        let stride = 1 + n;
        let mut batches = vec![Normal::new(p); self.nb];
        let (mut y, mut known, mut unit, mut mean) = (vec![0.0; p.dim()], vec![0.0; n], vec![0.0; r * n], vec![0.0; n]);
        let mut keys: Vec<u64> = self.cells.keys().copied().collect();
        keys.sort_unstable();
        let mut used_cells = 0usize;
        // Each cell enters with weight `count` and its mean increment; split over the
        // batches as (count_b, sum_b / count_b), the batches' normal equations sum to it
        // exactly, and all but one batch give the same fit on the remaining samples: the
        // delete-one-batch jackknife (which cells enter is decided once, by the full counts).
        let dim = p.dim();
        for c in keys {
            let acc = &self.cells[&c];
            let count: f64 = (0..self.nb).map(|b| acc[dim + b * stride]).sum();
            if count < KM_MIN_COUNT {
                continue;
            }
            used_cells += 1;
            for (yj, sum) in y.iter_mut().zip(&acc[..dim]) {
                *yj = sum / count;
            }
            drift_parts(p, &y, &mut known, &mut unit);
            for (b, normal) in batches.iter_mut().enumerate() {
                let at = dim + b * stride;
                let cb = acc[at];
                if cb == 0.0 {
                    continue;
                }
                for (i, m) in mean.iter_mut().enumerate() {
                    *m = acc[at + 1 + i] / cb;
                }
                normal.add(p, cb, &mean, &known, &unit);
            }
        }
        let facts = vec![
            (
                "grid".into(),
                format!(
                    "{} bins^{} over mean ± {} std; {used_cells} cells with ≥ {KM_MIN_COUNT} pairs, the drift at \
                     each cell's mean state",
                    self.grid.bins,
                    p.dim(),
                    self.grid.span
                ),
            ),
            (
                "pairs".into(),
                format!("{} in the grid, {} outside", self.used, self.outside),
            ),
            (
                "standard errors".into(),
                format!("delete-one jackknife over {} batches", self.nb),
            ),
        ];
        solve_batches(p, "kramers-moyal", &batches, typical, facts, self.used)
    }
}
