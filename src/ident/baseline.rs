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

use super::estimate::{estimate, solve_replicates};
use super::{prefetch, Estimate, IdentError, Pieces, Problem, Unknown};
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

mod normal;
mod pairs;
pub(super) use normal::dot;
use normal::Normal;
pub(super) use pairs::{DriftParts, Pairs};

/// A multiplicative hash of a grid cell's index (Fibonacci hashing): the cell map is hit
/// once per sample pair, where the default SipHash cost as much as the rest of the pass.
#[derive(Default)]
struct CellHasher(u64);

impl Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0.rotate_left(8) ^ b as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        }
    }
    fn write_u64(&mut self, x: u64) {
        self.0 = (x ^ (x >> 29)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
}

/// Why a baseline cannot run on `problem`, if it cannot: it regresses velocity increments,
/// so it needs white-noise forcing (no filtered excitations, no measured inputs) and
/// unknown coefficients only (a mass or an intensity is not in the drift's linear part) —
/// but for the force regression (`forces`), where a mass is: with the force measured,
/// `m_i Δv_i/h` against the force fixes it (the mass rows of the normal equations, `baseline/normal.rs`).
pub fn applicable(problem: &Problem, forces: bool) -> Result<(), IdentError> {
    if !problem.filters.is_empty() || problem.inputs > 0 {
        return Err(IdentError::NotApplicable(
            "the increment baselines regress the velocity's drift, which filtered forces make unobserved \
             (their state is not in the data): white-noise excitation only"
                .into(),
        ));
    }
    let allowed = |u: &Unknown| matches!(u, Unknown::Coefficient(_)) || (forces && matches!(u, Unknown::Mass(_)));
    if let Some(u) = problem.unknowns.iter().find(|u| !allowed(u)) {
        return Err(IdentError::NotApplicable(format!(
            "the increment baselines estimate the drift's coefficients{} only, not {u:?}",
            if forces { " and the masses" } else { "" }
        )));
    }
    Ok(())
}

/// Where the force regression takes the drift over a sample interval.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DriftRule {
    /// Its mean by 3-point Gauss–Legendre on the state interpolated between the interval's
    /// ends: for any data, a bias of order `h²`.
    GaussLegendre,
    /// At the step's start, as an Euler scheme takes it: exact (to rounding) on
    /// fpkbench's own log of white-forced states sampled at every integration step, so the
    /// regression checks that the simulator and the identifier evaluate every term alike.
    /// `semi_implicit`: the log's displacement is the step's midpoint.
    EulerStep { semi_implicit: bool },
    /// At each sample instant, `m_i a_i = F_i + K_i(y) + Σ_r θ_r b_ir(y)` with the
    /// acceleration and the force the data hold there (measured, or derived by exact
    /// differences): no interval mean of a force is needed. The mean of a band-limited
    /// force over an interval, from its samples at the ends (the trapezoid rule), is
    /// `cos(ωh/2)` where it should be `sin(ωh/2)/(ωh/2)` at its frequency `ω` — 38 % off at
    /// 200 Hz sampled at 610 Hz — an error correlated with the force itself, which biases a
    /// mass estimated against the force by 10 % on the Silverbox twin (docs/methods.md,
    /// "Baselines").
    Instant,
}

/// Sample pairs of one batch an [`Increments`] gathers before it evaluates their drifts
/// together.
const BLOCK: usize = 64;

/// Pairs of one batch waiting for [`Increments::add_block`]: each pair's states at its
/// start and end (variable-major, `[j * BLOCK + pair]`) and its targets `Δv_i/h` (− the
/// forces over a known mass; mass-major, `[i * BLOCK + pair]`); the force regression's
/// force on each mass of unknown mass over the interval (mass-major), which joins its
/// known force instead.
#[derive(Clone)]
struct PairBlock {
    start: Vec<f64>,
    end: Vec<f64>,
    target: Vec<f64>,
    force: Vec<f64>,
    len: usize,
}

impl PairBlock {
    /// Pair `l`'s target on mass `i` with its force `force` placed: taken out over the
    /// known mass `mass`, or, where the mass is unknown, kept aside to join the known force
    /// (its row's instrument) and the target left the acceleration `g`.
    fn place_force(&mut self, l: usize, i: usize, g: f64, force: f64, mass: f64, unknown: bool) -> f64 {
        if unknown {
            self.force[i * BLOCK + l] = force;
            g
        } else {
            g - force / mass
        }
    }
}

/// The increment regression (Euler–Maruyama pseudo-likelihood), streamed; with measured
/// forces, the force regression (the equation error of the equations of motion).
///
/// Pairs are gathered per batch, 64 at a time; their drifts' parts are evaluated along the
/// block ([`super::poly::Compiled::eval_block`]) and the block enters its batch's normal equations as
/// sums along the block (one dot product per entry of the equations).
pub struct Increments {
    problem: Problem,
    parts: DriftParts,
    pairs: Pairs,
    batches: Vec<Normal>,
    /// Force regression: per mass, the log columns of the forces acting on it, and
    /// whether each is a mean over the interval (else a value at the sample instant).
    forces: Option<Vec<Vec<(usize, bool)>>>,
    /// Per state variable that is a displacement, its velocity's state variable (the
    /// force regression interpolates displacements by cubic Hermite).
    velocity_of: Vec<Option<usize>>,
    /// Force regression: where it takes the drift over an interval.
    rule: DriftRule,
    /// Per mass, whether it is an unknown (force regression: [`Normal`]'s mass rows).
    mass_unknown: Vec<bool>,
    /// The sample in problem order, the atoms' values after the state (then, for the force
    /// regression, the instant-valued force on each mass).
    y: Vec<f64>,
    /// Scratch: one state with its atoms, and a log row, to value the atoms at the force
    /// regression's interpolated states ([`Problem::fill_atoms`]).
    point: Vec<f64>,
    row: Vec<f64>,
    /// Per batch, the pairs gathered.
    blocks: Vec<PairBlock>,
    /// Scratch: states where the parts are evaluated, the parts there (part-major), and
    /// their Gauss–Legendre sum (force regression).
    at: Vec<f64>,
    values: Vec<f64>,
    sum: Vec<f64>,
    used: u64,
}

impl Increments {
    /// For `problem` (see [`applicable`]), samples every `h` seconds, `batches` jackknife
    /// batches (the weak form's: [`super::data::StationaryData::batch_of`]).
    pub fn new(problem: &Problem, h: f64, batches: usize) -> Increments {
        let (n, d) = (problem.n, problem.dim());
        let parts = DriftParts::of(problem);
        let width = parts.parts.len();
        Increments {
            problem: problem.clone(),
            parts,
            pairs: Pairs::new(h),
            batches: vec![Normal::new(problem); batches.max(1)],
            forces: None,
            rule: DriftRule::GaussLegendre,
            mass_unknown: (0..n).map(|i| problem.unknowns.contains(&Unknown::Mass(i))).collect(),
            velocity_of: problem
                .columns
                .iter()
                .map(|&c| {
                    (c % 3 == 0)
                        .then(|| problem.columns.iter().position(|&v| v == c + 1))
                        .flatten()
                })
                .collect(),
            y: vec![0.0; d],
            point: vec![0.0; d],
            row: vec![0.0; problem.columns.iter().max().map_or(0, |&c| c + 1)],
            blocks: vec![
                PairBlock {
                    start: vec![0.0; d * BLOCK],
                    end: vec![0.0; d * BLOCK],
                    target: vec![0.0; n * BLOCK],
                    force: vec![0.0; n * BLOCK],
                    len: 0,
                };
                batches.max(1)
            ],
            at: vec![0.0; d * BLOCK],
            values: vec![0.0; width * BLOCK],
            sum: vec![0.0; width * BLOCK],
            used: 0,
        }
    }

    /// The force regression: `m_i Δv_i/h − F̄_i` (the force measured as its mean over the
    /// interval, as fpkbench logs it) regressed on the drift's parts averaged over the
    /// interval: 3-point Gauss–Legendre on the state interpolated between the ends, the
    /// displacements by cubic Hermite (their derivatives, the velocities, are known at
    /// both ends), the velocities linearly. An oracle bound, not an FPK method: it
    /// uses the excitation forces, which the FPK methods never see. Needs every force
    /// measured ([`force_columns`]). With [`DriftRule::EulerStep`] the drift is the Euler
    /// step's own instead.
    pub fn with_forces(
        problem: &Problem,
        h: f64,
        batches: usize,
        forces: Vec<Vec<(usize, bool)>>,
        rule: DriftRule,
    ) -> Increments {
        Increments {
            // After the state: the instant-valued force on each mass.
            y: vec![0.0; problem.dim() + problem.n],
            forces: Some(forces),
            rule,
            ..Increments::new(problem, h, batches)
        }
    }

    fn name(&self) -> &'static str {
        if self.forces.is_some() {
            "force-regression"
        } else {
            "increments"
        }
    }

    /// One sample (a log row) of `trajectory` at `t`, in batch `batch`; [`Increments::finish`]
    /// after the last.
    pub fn push(&mut self, trajectory: usize, t: f64, batch: usize, row: &[f64]) {
        let p = &self.problem;
        let d = p.dim();
        for (j, &c) in p.columns.iter().enumerate() {
            self.y[j] = row[c];
        }
        // A term without a polynomial form enters the drift as an atom, valued here.
        let dd = p.density_dim();
        for (k, a) in p.atoms.iter().enumerate() {
            self.y[dd + k] = a.value(&p.model, row);
        }
        if let Some(forces) = &self.forces {
            for (i, cols) in forces.iter().enumerate() {
                self.y[d + i] = cols.iter().filter(|(_, mean)| !mean).map(|&(c, _)| row[c]).sum();
            }
        }
        let (y, h, forces, mass_unknown) = (&self.y, self.pairs.h, &self.forces, &self.mass_unknown);
        let b = batch.min(self.blocks.len() - 1);
        let block = &mut self.blocks[b];
        let l = block.len;
        if self.rule == DriftRule::Instant {
            // One equation per sample: the state, the acceleration and the force at its instant.
            let layout = p.model.columns();
            for j in 0..d {
                block.start[j * BLOCK + l] = y[j];
            }
            for i in 0..p.n {
                let g = block.place_force(l, i, row[layout.a(i)], y[d + i], p.model.mass[i], mass_unknown[i]);
                block.target[i * BLOCK + l] = g;
            }
            block.len += 1;
            if block.len == BLOCK {
                self.add_block(b);
            }
            return;
        }
        let mut paired = false;
        self.pairs.step(trajectory, t, y, |y0| {
            paired = true;
            for j in 0..d {
                block.start[j * BLOCK + l] = y0[j];
                block.end[j * BLOCK + l] = y[j];
            }
            for i in 0..p.n {
                let v = p.noise_var[i];
                let mut g = (y[v] - y0[v]) / h;
                if let Some(forces) = forces {
                    // The force's mean over the interval: as logged, or the trapezoid rule
                    // on its values at the two ends (their bridge's mean is linear).
                    let mean: f64 = forces[i].iter().filter(|(_, mean)| *mean).map(|&(c, _)| row[c]).sum();
                    let force = mean + 0.5 * (y0[d + i] + y[d + i]);
                    g = block.place_force(l, i, g, force, p.model.mass[i], mass_unknown[i]);
                }
                block.target[i * BLOCK + l] = g;
            }
        });
        if paired {
            block.len += 1;
            if block.len == BLOCK {
                self.add_block(b);
            }
        }
    }

    /// Add the pairs still gathered; call after the last [`Increments::push`].
    pub fn finish(&mut self) {
        for b in 0..self.blocks.len() {
            self.add_block(b);
        }
    }

    /// Batch `b`'s gathered pairs: their drifts' parts, then the block into the batch's
    /// normal equations.
    fn add_block(&mut self, b: usize) {
        let (p, block) = (&self.problem, &self.blocks[b]);
        let lanes = block.len;
        if lanes == 0 {
            return;
        }
        let (d, width) = (p.dim(), self.parts.parts.len());
        let values = &mut self.values[..width * lanes];
        // Variable-major with `lanes` per variable (the block may be partial).
        let pack = |from: &[f64], to: &mut [f64]| {
            for j in 0..d {
                to[j * lanes..(j + 1) * lanes].copy_from_slice(&from[j * BLOCK..j * BLOCK + lanes]);
            }
        };
        let parts: &mut [f64] = if self.forces.is_none() || self.rule == DriftRule::Instant {
            pack(&block.start, &mut self.at);
            self.parts.parts.eval_block(&self.at[..d * lanes], lanes, values);
            values
        } else if let DriftRule::EulerStep { semi_implicit } = self.rule {
            // The step's start state, where the scheme took the drift: the semi-implicit
            // scheme's logged displacement is its step's midpoint, x_n = x̃_n + h v_n / 2.
            let (h, dd) = (self.pairs.h, p.density_dim());
            let shift = if semi_implicit { 0.5 * h } else { 0.0 };
            for l in 0..lanes {
                for j in 0..dd {
                    let y0 = block.start[j * BLOCK + l];
                    self.point[j] = match self.velocity_of[j] {
                        Some(v) => shift.mul_add(block.start[v * BLOCK + l], y0),
                        None => y0,
                    };
                }
                p.fill_atoms(&mut self.point, &mut self.row);
                for k in 0..d {
                    self.at[k * lanes + l] = self.point[k];
                }
            }
            self.parts.parts.eval_block(&self.at[..d * lanes], lanes, values);
            values
        } else {
            // Gauss–Legendre nodes on [0, 1] and weights.
            const R: f64 = 0.387_298_334_620_741_7; // √15 / 10
            const NODES: [(f64, f64); 3] = [(0.5 - R, 5.0 / 18.0), (0.5, 8.0 / 18.0), (0.5 + R, 5.0 / 18.0)];
            let h = self.pairs.h;
            let sum = &mut self.sum[..width * lanes];
            sum.fill(0.0);
            for (tau, w) in NODES {
                let (t2, t3) = (tau * tau, tau * tau * tau);
                let (h00, h10, h01, h11) = (
                    2.0 * t3 - 3.0 * t2 + 1.0,
                    t3 - 2.0 * t2 + tau,
                    3.0 * t2 - 2.0 * t3,
                    t3 - t2,
                );
                let dd = p.density_dim();
                for j in 0..dd {
                    let (y0, y1) = (&block.start[j * BLOCK..], &block.end[j * BLOCK..]);
                    let at = &mut self.at[j * lanes..(j + 1) * lanes];
                    match self.velocity_of[j] {
                        Some(v) => {
                            let (v0, v1) = (&block.start[v * BLOCK..], &block.end[v * BLOCK..]);
                            for (l, a) in at.iter_mut().enumerate() {
                                *a = h00 * y0[l] + h10 * h * v0[l] + h01 * y1[l] + h11 * h * v1[l];
                            }
                        }
                        None => {
                            for (l, a) in at.iter_mut().enumerate() {
                                *a = (1.0 - tau) * y0[l] + tau * y1[l];
                            }
                        }
                    }
                }
                // The atoms at the interpolated state, not interpolated themselves (a
                // friction term's sign changes inside the interval).
                for l in (0..lanes).filter(|_| !p.atoms.is_empty()) {
                    for j in 0..dd {
                        self.point[j] = self.at[j * lanes + l];
                    }
                    p.fill_atoms(&mut self.point, &mut self.row);
                    for k in dd..d {
                        self.at[k * lanes + l] = self.point[k];
                    }
                }
                self.parts.parts.eval_block(&self.at[..d * lanes], lanes, values);
                for (a, b) in sum.iter_mut().zip(values.iter()) {
                    *a += w * b;
                }
            }
            sum
        };
        // A mass of unknown mass: its force joins its known force (the instrument of its row).
        for i in (0..p.n).filter(|&i| self.mass_unknown[i] && self.forces.is_some()) {
            for (k, f) in parts[i * lanes..(i + 1) * lanes]
                .iter_mut()
                .zip(&block.force[i * BLOCK..])
            {
                *k += f;
            }
        }
        self.batches[b].add_block(lanes, parts, &block.target, BLOCK);
        self.used += lanes as u64;
        self.blocks[b].len = 0;
    }

    /// The estimate, after [`Increments::finish`].
    pub fn estimate(&self, typical: &[f64]) -> Result<Estimate, IdentError> {
        assert!(
            self.blocks.iter().all(|b| b.len == 0),
            "Increments::finish before estimate"
        );
        let regression = match (&self.forces, self.rule) {
            (None, _) => "Δv/h on the drift at the interval's start (Euler–Maruyama pseudo-likelihood)",
            (Some(_), DriftRule::GaussLegendre) => "Δv/h − F̄/m on the drift's mean over the interval (3-point Gauss–Legendre, displacements by cubic Hermite), the forces measured (an oracle)",
            (Some(_), DriftRule::EulerStep { .. }) => "Δv/h − F̄/m on the drift at the integration step's start, as the simulator took it (the log holds every step; exact up to rounding), the forces measured (an oracle)",
            (Some(_), DriftRule::Instant) => "the acceleration − F/m on the drift at each sample instant, the acceleration and the forces as the data hold them there (an oracle)",
        };
        let mut facts = vec![
            match self.rule {
                DriftRule::Instant => ("samples".into(), format!("{} sample instants", self.used)),
                _ => ("pairs".into(), format!("{} consecutive sample pairs", self.used)),
            },
            ("regression".into(), format!("{regression}, h = {} s", self.pairs.h)),
            (
                "standard errors".into(),
                format!("delete-one jackknife over {} batches", self.batches.len()),
            ),
        ];
        if self.mass_unknown.iter().any(|&u| u) {
            facts.push((
                "masses".into(),
                "each unknown mass by its equation's residual times its known force (the measured force and \
                 the known terms): an instrument, zero in expectation at the true values"
                    .into(),
            ));
        }
        solve_batches(&self.problem, self.name(), &self.batches, typical, facts, self.used)
    }
}

/// The log columns of the forces on each mass (per mass, the columns of the excitations
/// acting on it, each with whether it holds means over the sample interval, per
/// excitation `interval_means`: white forces in fpkbench's logs; else values at the sample
/// instants), or why the force regression cannot run: an excitation's force is not
/// measured.
pub fn force_columns(problem: &Problem, interval_means: &[bool]) -> Result<Vec<Vec<(usize, bool)>>, IdentError> {
    let m = &problem.model;
    let layout = crate::model::Columns::new(m.masses(), m.excitations.len());
    let mut cols = vec![Vec::new(); problem.n];
    for (e, exc) in m.excitations.iter().enumerate() {
        if !exc.measured {
            return Err(IdentError::NotApplicable(format!(
                "the force regression needs every excitation's force, and `{}` is not measured",
                m.excitation_names[e]
            )));
        }
        for &i in &exc.targets {
            cols[i].push((layout.force(e), interval_means[e]));
        }
    }
    Ok(cols)
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
                r.pieces()
            })
            .collect()
    } else {
        Vec::new()
    };
    let replicates = solve_replicates(problem, method, replicates, typical, None)?;
    estimate(problem, method, &total.pieces(), &replicates, typical, facts, None)
}

/// The binned conditional-mean increments (first Kramers–Moyal coefficient), streamed.
pub struct KramersMoyal {
    problem: Problem,
    parts: DriftParts,
    pairs: Pairs,
    grid: Grid,
    /// Per occupied cell, where its slot starts in `arena`.
    cells: CellIndex,
    /// The cells' slots: per batch, the count of pairs starting in the cell, the sum of
    /// `Δv_i/h` per mass and the sum of the starting states `y` (kept together, so a
    /// sample touches one cache line: the pass is bound by memory, not arithmetic).
    arena: Vec<f64>,
    /// The last pairs binned, oldest first: where each goes in `arena` and where its
    /// `Δv/h` then `y` wait in `pending_values`. Each is added [`IN_FLIGHT`] pairs later (or
    /// by [`KramersMoyal::finish`]), once the prefetch of its slot has had time to arrive:
    /// a slot is a cache miss. First in, first added: a slot's sums see the same order.
    pending: std::collections::VecDeque<(usize, usize)>,
    pending_values: Vec<f64>,
    next_value: usize,
    nb: usize,
    y: Vec<f64>,
    y0: Vec<f64>,
    incr: Vec<f64>,
    used: u64,
    outside: u64,
    /// Where the cell arena comes from and goes back to.
    arenas: std::sync::Arc<super::Arenas>,
}

impl Drop for KramersMoyal {
    fn drop(&mut self) {
        self.arenas.cells.give(std::mem::take(&mut self.arena));
    }
}

/// Pairs whose slots are asked for before they are added (see [`KramersMoyal::pending`]).
const IN_FLIGHT: usize = 16;

/// Smallest count of a cell whose mean increment enters the fit.
pub const KM_MIN_COUNT: f64 = 10.0;

/// Where each occupied cell's slot is: a dense table when the grid is small enough
/// (`bins^dim` ≤ [`CellIndex::DENSE_MAX`] cells), else a hash map.
enum CellIndex {
    Dense(Vec<u32>),
    Sparse(HashMap<u64, usize, BuildHasherDefault<CellHasher>>),
}

impl CellIndex {
    const DENSE_MAX: u64 = 1 << 22;
    const EMPTY: u32 = u32::MAX;

    fn new(cells: u64) -> CellIndex {
        if cells <= Self::DENSE_MAX {
            CellIndex::Dense(vec![Self::EMPTY; cells as usize])
        } else {
            CellIndex::Sparse(HashMap::default())
        }
    }

    /// The slot of cell `c`, made (by `make`, which returns its start) if new.
    #[inline]
    fn slot(&mut self, c: u64, make: impl FnOnce() -> usize) -> usize {
        match self {
            CellIndex::Dense(v) => {
                let e = &mut v[c as usize];
                if *e == Self::EMPTY {
                    let at = make();
                    *e = u32::try_from(at).expect("a dense grid's arena is indexable by u32");
                }
                *e as usize
            }
            CellIndex::Sparse(m) => *m.entry(c).or_insert_with(make),
        }
    }

    /// The occupied cells and their slots, by cell index.
    fn occupied(&self) -> Vec<(u64, usize)> {
        match self {
            CellIndex::Dense(v) => v
                .iter()
                .enumerate()
                .filter(|(_, &e)| e != Self::EMPTY)
                .map(|(c, &e)| (c as u64, e as usize))
                .collect(),
            CellIndex::Sparse(m) => {
                let mut o: Vec<(u64, usize)> = m.iter().map(|(&c, &at)| (c, at)).collect();
                o.sort_unstable();
                o
            }
        }
    }
}

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
        arenas: &std::sync::Arc<super::Arenas>,
    ) -> KramersMoyal {
        KramersMoyal {
            arenas: arenas.clone(),
            problem: problem.clone(),
            parts: DriftParts::of(problem),
            pairs: Pairs::new(h),
            grid: Grid {
                lo: mean.iter().zip(std).map(|(m, s)| m - span * s).collect(),
                width: std.iter().map(|s| 2.0 * span * s / bins as f64).collect(),
                bins,
                span,
            },
            cells: CellIndex::new((bins as u64).saturating_pow(problem.dim() as u32)),
            arena: {
                // Room for every cell of a small grid (address space only until a cell
                // is first hit), so the arena never moves, on huge pages; kept from one
                // record to the next (a study's items), as its pages are costly to take
                // fresh (`super::Spare`).
                let cells = (bins as u64).saturating_pow(problem.dim() as u32);
                let slot = batches.max(1) * (1 + problem.n + problem.dim());
                if cells.saturating_mul(8 * slot as u64) <= 1 << 30 {
                    arenas.cells.empty(cells as usize * slot)
                } else {
                    Vec::new()
                }
            },
            pending: Default::default(),
            pending_values: vec![0.0; IN_FLIGHT * (problem.n + problem.dim())],
            next_value: 0,
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
                let (n, stride, nb) = (p.n, 1 + p.n + p.dim(), self.nb);
                let slot = nb * stride;
                let arena = &mut self.arena;
                let at = self.cells.slot(c, || {
                    arena.resize(arena.len() + slot, 0.0);
                    arena.len() - slot
                }) + batch.min(nb - 1) * stride;
                let width = n + p.dim();
                prefetch(&self.arena[at]);
                if self.pending.len() == IN_FLIGHT {
                    self.add_oldest();
                }
                let from = self.next_value * width;
                self.pending.push_back((at, from));
                self.next_value = (self.next_value + 1) % IN_FLIGHT;
                self.pending_values[from..from + n].copy_from_slice(&self.incr);
                self.pending_values[from + n..from + width].copy_from_slice(&self.y0);
                self.used += 1;
            }
        }
    }

    fn add_oldest(&mut self) {
        if let Some((at, from)) = self.pending.pop_front() {
            let width = self.problem.n + self.problem.dim();
            let acc = &mut self.arena[at..at + 1 + width];
            acc[0] += 1.0;
            for (a, v) in acc[1..].iter_mut().zip(&self.pending_values[from..from + width]) {
                *a += v;
            }
        }
    }

    /// Add the pairs still pending (call after the last sample).
    pub fn finish(&mut self) {
        while !self.pending.is_empty() {
            self.add_oldest();
        }
    }

    /// The estimate, after [`KramersMoyal::finish`].
    pub fn estimate(&self, typical: &[f64]) -> Result<Estimate, IdentError> {
        assert!(self.pending.is_empty(), "KramersMoyal::finish before estimate");
        let p = &self.problem;
        let (n, r) = (p.n, p.unknowns.len());
        let (dim, stride) = (p.dim(), 1 + n + p.dim());
        let mut batches = vec![Normal::new(p); self.nb];
        let (mut y, mut known, mut unit, mut mean) = (vec![0.0; dim], vec![0.0; n], vec![0.0; r * n], vec![0.0; n]);
        let mut used_cells = 0usize;
        let mut parts = self.parts.clone();
        // Each cell enters with weight `count` and its mean increment; split over the
        // batches as (count_b, sum_b / count_b), the batches' normal equations sum to it
        // exactly, and all but one batch give the same fit on the remaining samples: the
        // delete-one-batch jackknife (which cells enter is decided once, by the full counts).
        for (_, at) in self.cells.occupied() {
            let acc = &self.arena[at..at + self.nb * stride];
            let count: f64 = acc.chunks_exact(stride).map(|b| b[0]).sum();
            if count < KM_MIN_COUNT {
                continue;
            }
            used_cells += 1;
            y.fill(0.0);
            for b in acc.chunks_exact(stride) {
                for (yj, sum) in y.iter_mut().zip(&b[1 + n..]) {
                    *yj += sum;
                }
            }
            for yj in y.iter_mut() {
                *yj /= count;
            }
            parts.at(&y, &mut known, &mut unit);
            for (b, normal) in acc.chunks_exact(stride).zip(batches.iter_mut()) {
                let cb = b[0];
                if cb == 0.0 {
                    continue;
                }
                for (m, sum) in mean.iter_mut().zip(&b[1..]) {
                    *m = sum / cb;
                }
                normal.add(cb, &mean, &known, &unit);
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
