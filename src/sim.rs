//! Stochastic simulation of a [`Model`]: semi-implicit or explicit Euler–Maruyama steps,
//! exact Ornstein–Uhlenbeck transitions, burn-in, sampling, parallel trajectories.
//!
//! Performance design: trajectories are stepped [`LANES`] at a time in struct-of-arrays
//! lanes, so the CPU always has independent work while one lane waits on its state's
//! dependency chain, and the per-link polynomial loop is amortised over the lanes. The
//! shaped kernel (`advance_shaped`, up to four masses and four excitations) separates the
//! two kinds of work: the normals of a block of steps are drawn first, one generator at a
//! time (`fill_noise`), then the steps run over them as straight-line vector arithmetic,
//! 16 lanes at a time in registers, with every link's ends known at compile time (the
//! links are rewritten as one per pair of ends, `LaneModel::complete_links`). Each
//! lane has its own `Xoshiro256PlusPlus`, seeded from `(seed, trajectory)`, so the output is
//! bit-identical whatever the number of threads. Time advances in blocks of samples: in a
//! block every lane group runs in parallel (rayon), then the block's samples are handed,
//! in (time, trajectory) order, to a [`SampleSink`] — memory is bounded by one block.
//!
//! This module knows nothing of files: sinks (the MCAP writer, moment accumulators in
//! tests) are supplied by the caller.

use crate::model::{Model, GROUND};
use crate::scenario::{Process, Scheme, Simulation};
use multiversion::multiversion;
use rand::rngs::Xoshiro256PlusPlus;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;

/// Trajectories stepped together in one group (a group is the unit of parallel work:
/// multiples of `2 × LANES` trajectories keep two cores busy).
pub const LANES: usize = 32;
type Lane = [f64; LANES];

/// States whose magnitude passes this are taken as diverged.
pub const DIVERGENCE_LIMIT: f64 = 1e10;

/// Errors of a simulation run.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The state became non-finite or exploded (usually `dt` too large for the stiffness).
    #[error(
        "simulation diverged in trajectory {trajectory} between t = {t_from:.6} s and t = {t_to:.6} s \
         (time after burn-in; negative = during burn-in): state {}. Reduce dt (or raise substeps) \
         or check the stiffness and damping signs",
        .state.iter().map(|(n, v)| format!("{n} = {v:e}")).collect::<Vec<_>>().join(", ")
    )]
    Diverged {
        trajectory: usize,
        t_from: f64,
        t_to: f64,
        state: Vec<(String, f64)>,
    },
    /// The sink refused a batch (e.g. the log file could not be written).
    #[error("writing samples failed")]
    Sink(#[source] Box<dyn std::error::Error + Send + Sync>),
}

/// Samples of every trajectory at consecutive sampling instants (one block of a run).
///
/// Per instant the values are column-major, as the log's messages carry them: for each
/// column (see [`columns`]) one value per trajectory, so trajectory `j`'s value of column `c`
/// at instant `k` is `values[(k * columns + c) * trajectories + j]`.
#[derive(Debug, Clone, Default)]
pub struct SampleBatch {
    /// Values per sample (see [`columns`]).
    pub columns: usize,
    /// Trajectories per instant (all of the run's, in order).
    pub trajectories: usize,
    /// Time after burn-in of each instant, s.
    pub time: Vec<f64>,
    /// `instants × columns × trajectories` values.
    pub values: Vec<f64>,
}

impl SampleBatch {
    /// Sampling instants in the batch.
    pub fn instants(&self) -> usize {
        self.time.len()
    }
    /// Samples in the batch (instants × trajectories).
    pub fn len(&self) -> usize {
        self.time.len() * self.trajectories
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Instant `k`'s values: `columns` runs of `trajectories` values.
    pub fn instant(&self, k: usize) -> &[f64] {
        let n = self.columns * self.trajectories;
        &self.values[k * n..(k + 1) * n]
    }
    /// Every sample as `f(trajectory, t, values)`, in (time, trajectory) order.
    pub fn for_each_sample(&self, mut f: impl FnMut(u32, f64, &[f64])) {
        let mut row = vec![0.0; self.columns];
        for (k, &t) in self.time.iter().enumerate() {
            let instant = self.instant(k);
            for j in 0..self.trajectories {
                for (c, r) in row.iter_mut().enumerate() {
                    *r = instant[c * self.trajectories + j];
                }
                f(j as u32, t, &row);
            }
        }
    }
}

/// Where samples go.
pub trait SampleSink {
    fn write(&mut self, batch: SampleBatch) -> Result<(), Box<dyn std::error::Error + Send + Sync>>;
    /// A batch the sink is done with, for the simulator to fill again instead of allocating
    /// (and first touching) a new one.
    fn recycle(&mut self) -> Option<SampleBatch> {
        None
    }
}

/// Names of the logged values per sample: `x_<mass>`, `v_<mass>`, `a_<mass>` for every mass,
/// then `p_<excitation>` for every excitation.
pub fn columns(model: &Model) -> Vec<String> {
    let mut c = Vec::new();
    for m in &model.mass_names {
        c.push(format!("x_{m}"));
        c.push(format!("v_{m}"));
        c.push(format!("a_{m}"));
    }
    for e in &model.excitation_names {
        c.push(format!("p_{e}"));
    }
    c
}

/// What a finished run did.
#[derive(Debug, Clone, Copy)]
pub struct RunStats {
    pub samples: u64,
    /// Integration steps summed over trajectories (including burn-in and sub-steps).
    pub steps: u64,
}

/// The seed of trajectory `j`'s generator: a SplitMix64 mix of the master seed and `j`.
pub fn trajectory_seed(seed: u64, j: usize) -> u64 {
    let mut z = seed ^ (j as u64).wrapping_add(1).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_133f_11eb);
    z ^ (z >> 31)
}

/// Mixed into a trajectory's seed for its bridge generator (see [`Group::run`]).
const BRIDGE_STREAM: u64 = 0x4252_4944_4745_5f31;

/// Advances a group by a number of steps.
type Stepper<const D: usize> = fn(&mut Group, &LaneModel<D>, usize);

/// The model compiled for lane stepping: every characteristic padded to degree `D` (a
/// compile-time constant, so each link is one fused, vectorised lane loop with no branch),
/// and the ground as a phantom mass `n` whose state stays 0.
struct LaneModel<const D: usize> {
    n: usize,
    h: f64,
    semi_implicit: bool,
    a: Vec<usize>,
    b: Vec<usize>,
    /// `k[l][p − 1]`, `c[l][p − 1]`.
    k: Vec<[f64; D]>,
    c: Vec<[f64; D]>,
    /// `h / m_i`.
    h_inv_mass: Vec<f64>,
    inv_mass: Vec<f64>,
    /// Per white excitation (slot): its excitation index.
    white: Vec<usize>,
    /// Per excitation: `σ√h` (a white excitation's impulse over a step per standard
    /// normal), 0 if filtered.
    impulse_scale: Vec<f64>,
    /// Per mass: (white-excitation slot, `σ√h/m_i`) of the white forces acting on it: the
    /// velocity change per standard normal.
    white_on: Vec<Vec<(usize, f64)>>,
    /// Per filtered excitation: index, exact-transition decay and standard deviation.
    ou: Vec<(usize, f64, f64)>,
    /// Per mass: the filtered excitations acting on it.
    ou_on: Vec<Vec<usize>>,
    /// Whether excitation `e` is white.
    is_white: Vec<bool>,
    /// Per link: the number of stiffness and damping coefficients before padding.
    lens: Vec<(usize, usize)>,
    /// `white_weight[i·n_white + slot] = σ√h/m_i` if white slot acts on mass `i`, else 0.
    white_weight: Vec<f64>,
    /// `ou_weight[i·n_ou + slot] = 1` if filtered slot acts on mass `i`, else 0.
    ou_weight: Vec<f64>,
    /// Advances a group by a number of steps: the shaped kernel when one fits.
    advance: Stepper<D>,
}

impl<const D: usize> LaneModel<D> {
    /// The model compiled for stepping with the kernel `shaped` picks for its size (see
    /// [`shaped_kernel`]), or the generic stepper.
    fn new(m: &Model, sim: &Simulation, shaped: fn(&LaneModel<D>) -> Option<Stepper<D>>) -> Self {
        let n = m.masses();
        let h = sim.dt / sim.substeps as f64;
        let pad = |cs: &[f64]| {
            let mut out = [0.0; D];
            out[..cs.len()].copy_from_slice(cs);
            out
        };
        let mut lm = LaneModel {
            n,
            h,
            semi_implicit: sim.scheme == Scheme::SemiImplicit,
            a: m.link_a.clone(),
            b: m.link_b.iter().map(|&b| if b == GROUND { n } else { b }).collect(),
            k: (0..m.links()).map(|l| pad(m.stiffness(l))).collect(),
            c: (0..m.links()).map(|l| pad(m.damping(l))).collect(),
            h_inv_mass: m.inv_mass.iter().map(|im| h * im).collect(),
            inv_mass: m.inv_mass.clone(),
            white: Vec::new(),
            impulse_scale: Vec::new(),
            white_on: vec![Vec::new(); n],
            ou: Vec::new(),
            ou_on: vec![Vec::new(); n],
            is_white: Vec::new(),
            lens: (0..m.links()).map(|l| (m.k_len[l], m.c_len[l])).collect(),
            white_weight: Vec::new(),
            ou_weight: Vec::new(),
            advance: advance_generic::<D>,
        };
        for (e, exc) in m.excitations.iter().enumerate() {
            match exc.process {
                Process::White { sigma } => {
                    for &i in &exc.targets {
                        lm.white_on[i].push((lm.white.len(), sigma * h.sqrt() * m.inv_mass[i]));
                    }
                    lm.white.push(e);
                    lm.impulse_scale.push(sigma * h.sqrt());
                    lm.is_white.push(true);
                }
                Process::Filtered { a, b } => {
                    // Exact transition of dP = −B P dt + A dW over h.
                    let d = (-b * h).exp();
                    for &i in &exc.targets {
                        lm.ou_on[i].push(e);
                    }
                    lm.ou.push((e, d, a * ((1.0 - d * d) / (2.0 * b)).sqrt()));
                    lm.impulse_scale.push(0.0);
                    lm.is_white.push(false);
                }
            }
        }
        let (nw, no) = (lm.white.len(), lm.ou.len());
        lm.white_weight = vec![0.0; n * nw];
        lm.ou_weight = vec![0.0; n * no];
        for i in 0..n {
            for &(slot, im) in &lm.white_on[i] {
                lm.white_weight[i * nw + slot] = im;
            }
            for &e in &lm.ou_on[i] {
                let slot = lm.ou.iter().position(|o| o.0 == e).expect("filtered slot");
                lm.ou_weight[i * no + slot] = 1.0;
            }
        }
        if let Some(kernel) = shaped(&lm) {
            lm.complete_links();
            lm.advance = kernel;
        }
        lm
    }
}

/// The shaped kernel for `lm`'s size, if there is one: up to [`SHAPED_MAX_MASSES`] masses
/// and four excitations (white and filtered together). Only the padded degrees up to 5 have one
/// (each degree instantiates the kernel for every size); higher ones step generically.
fn shaped_kernel<const D: usize>(lm: &LaneModel<D>) -> Option<Stepper<D>> {
    macro_rules! by_excitations {
        ($n:literal) => {
            match (lm.white.len(), lm.ou.len()) {
                (1, 0) => Some(advance_shaped::<$n, D, 1, 0>),
                (0, 1) => Some(advance_shaped::<$n, D, 0, 1>),
                (2, 0) => Some(advance_shaped::<$n, D, 2, 0>),
                (1, 1) => Some(advance_shaped::<$n, D, 1, 1>),
                (0, 2) => Some(advance_shaped::<$n, D, 0, 2>),
                (3, 0) => Some(advance_shaped::<$n, D, 3, 0>),
                (2, 1) => Some(advance_shaped::<$n, D, 2, 1>),
                (1, 2) => Some(advance_shaped::<$n, D, 1, 2>),
                (0, 3) => Some(advance_shaped::<$n, D, 0, 3>),
                (4, 0) => Some(advance_shaped::<$n, D, 4, 0>),
                (3, 1) => Some(advance_shaped::<$n, D, 3, 1>),
                (2, 2) => Some(advance_shaped::<$n, D, 2, 2>),
                (1, 3) => Some(advance_shaped::<$n, D, 1, 3>),
                (0, 4) => Some(advance_shaped::<$n, D, 0, 4>),
                _ => None,
            }
        };
    }
    match lm.n {
        1 => by_excitations!(1),
        2 => by_excitations!(2),
        3 => by_excitations!(3),
        4 => by_excitations!(4),
        _ => None,
    }
}

/// For padded degrees without a shaped kernel.
fn no_kernel<const D: usize>(_: &LaneModel<D>) -> Option<Stepper<D>> {
    None
}

/// One step's noise for every lane: the white excitations' standard normals into `dw` (and
/// summed in `p`: the impulse since the last sample in units of `σ√h`), exact OU
/// transitions of the filtered forces in `p`. The draw order is
/// fixed (white excitations, then filtered, in scenario order), so every stepper consumes
/// each lane's generator identically.
#[inline(always)]
fn draw_noise<const D: usize>(
    lm: &LaneModel<D>,
    rng: &mut [Xoshiro256PlusPlus; LANES],
    p: &mut [Lane],
    dw: &mut [Lane],
) {
    for (slot, &e) in lm.white.iter().enumerate() {
        let mut d = zero();
        for j in 0..LANES {
            d[j] = StandardNormal.sample(&mut rng[j]);
        }
        for j in 0..LANES {
            p[e][j] += d[j];
        }
        dw[slot] = d;
    }
    for &(e, decay, sd) in &lm.ou {
        let mut pe = p[e];
        for j in 0..LANES {
            let z: f64 = StandardNormal.sample(&mut rng[j]);
            pe[j] = pe[j].mul_add(decay, sd * z);
        }
        p[e] = pe;
    }
}

/// The generic stepper: any shape, intermediates in memory.
#[multiversion(targets(
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
    "x86_64+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
))]
fn advance_generic<const D: usize>(g: &mut Group, lm: &LaneModel<D>, steps: usize) {
    for _ in 0..steps {
        g.step(lm);
    }
}

/// Steps whose normals are drawn in one go by [`fill_noise`]: a block's normals
/// (`NOISE_STEPS × excitations × LANES` doubles, 16 KiB for two excitations) stay in L1.
const NOISE_STEPS: usize = 32;

/// Draws the normals of `steps` steps for every lane into `noise[(t·nz + slot)·LANES + j]`,
/// one lane at a time so its generator's state stays in registers across the run. Each
/// lane's generator is consumed in exactly the order of [`draw_noise`] (per step: white
/// slots, then filtered), so the samples do not depend on the blocking. Kept out of line:
/// the generator's slow path calls `exp`, which would force the kernel's vector state out
/// of registers.
#[inline(never)]
fn fill_noise(rng: &mut [Xoshiro256PlusPlus; LANES], nz: usize, steps: usize, noise: &mut [f64]) {
    let noise = &mut noise[..steps * nz * LANES];
    for (j, r) in rng.iter_mut().enumerate() {
        for z in noise[j..].iter_mut().step_by(LANES) {
            *z = StandardNormal.sample(r);
        }
    }
}

/// Masses the shaped kernel handles.
const SHAPED_MAX_MASSES: usize = 4;
/// Link slots of the shaped kernel: one per pair of ends among its masses and the ground.
const SHAPED_LINK_SLOTS: usize = SHAPED_MAX_MASSES * (SHAPED_MAX_MASSES + 1) / 2;

/// The `l`-th link slot of `n` masses: `(a, b)` with `a < b ≤ n` (`n` is the ground), in
/// lexicographic order, so slot `l` of a `n`-mass model is known at compile time.
const fn link_slot(n: usize, l: usize) -> (usize, usize) {
    let mut i = 0;
    let mut a = 0;
    while a < n {
        let mut b = a + 1;
        while b <= n {
            if i == l {
                return (a, b);
            }
            i += 1;
            b += 1;
        }
        a += 1;
    }
    (usize::MAX, usize::MAX)
}

impl<const D: usize> LaneModel<D> {
    /// Rewrites the links as the complete set of [`link_slot`]s of `n` masses, so a kernel
    /// knows every link's ends at compile time. A link joining `b` to `a < b` is turned
    /// round, exactly: with `u → −u`, `F̃(u) = −F(−u)` negates the even powers' coefficients
    /// and gives the same forces bit for bit. Links joining the same two ends are summed
    /// into one; a pair with no link is a slot with zero coefficients, which adds exact
    /// zeros. Both steppers use the result, so they stay bit-identical.
    fn complete_links(&mut self) {
        let n = self.n;
        let slots = n * (n + 1) / 2;
        let (mut k, mut c) = (vec![[0.0; D]; slots], vec![[0.0; D]; slots]);
        let mut lens = vec![(0, 0); slots];
        for l in 0..self.a.len() {
            let (a, b) = (self.a[l].min(self.b[l]), self.a[l].max(self.b[l]));
            let turned = self.a[l] > self.b[l];
            let slot = (0..slots)
                .find(|&s| link_slot(n, s) == (a, b))
                .expect("every pair has a slot");
            lens[slot] = (lens[slot].0.max(self.lens[l].0), lens[slot].1.max(self.lens[l].1));
            for q in 0..D {
                // Power q + 1: even powers change sign when the link is turned round.
                let sign = if turned && q % 2 == 1 { -1.0 } else { 1.0 };
                k[slot][q] += sign * self.k[l][q];
                c[slot][q] += sign * self.c[l][q];
            }
        }
        (self.a, self.b) = (0..slots).map(|s| link_slot(n, s)).unzip();
        (self.k, self.c) = (k, c);
        self.lens = lens;
    }
}

/// The shaped kernel: `N` masses, `NW` white and `NO` filtered excitations known at compile
/// time, and the links in the complete set of [`link_slot`]s (see
/// [`LaneModel::complete_links`]), so every link's ends are constants and the step is
/// straight-line vector arithmetic on registers, with no branch: Horner over the padded
/// degree, each excitation into every mass with its weight (zero where it does not act).
/// The operations are those of [`Group::forces`] and [`Group::step`] in the same order, so
/// the kernel is bit-identical to the generic stepper (tested).
///
/// The normals are drawn [`NOISE_STEPS`] steps at a time by [`fill_noise`], then the steps
/// run over them, [`W`] lanes at a time. The white impulse enters the velocity before the
/// force does: it does not wait on the force's dependency chain.
#[multiversion(targets(
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
    "x86_64+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
))]
fn advance_shaped<const N: usize, const D: usize, const NW: usize, const NO: usize>(
    g: &mut Group,
    lm: &LaneModel<D>,
    steps: usize,
) {
    let k: [[f64; D]; SHAPED_LINK_SLOTS] = std::array::from_fn(|l| lm.k.get(l).copied().unwrap_or([0.0; D]));
    let c: [[f64; D]; SHAPED_LINK_SLOTS] = std::array::from_fn(|l| lm.c.get(l).copied().unwrap_or([0.0; D]));
    let lens: [(usize, usize); SHAPED_LINK_SLOTS] = std::array::from_fn(|l| lm.lens.get(l).copied().unwrap_or((0, 0)));
    let him: [f64; N] = std::array::from_fn(|i| lm.h_inv_mass[i]);
    let white: [usize; NW] = std::array::from_fn(|s| lm.white[s]);
    let white_weight: [[f64; NW]; N] = std::array::from_fn(|i| std::array::from_fn(|s| lm.white_weight[i * NW + s]));
    let ou: [(usize, f64, f64); NO] = std::array::from_fn(|s| lm.ou[s]);
    let ou_weight: [[f64; NO]; N] = std::array::from_fn(|i| std::array::from_fn(|s| lm.ou_weight[i * NO + s]));
    let (h, semi) = (lm.h, lm.semi_implicit);
    let nz = NW + NO;
    let mut done = 0;
    while done < steps {
        let block = (steps - done).min(NOISE_STEPS);
        fill_noise(&mut g.rng, nz, block, &mut g.noise);
        for h0 in (0..LANES).step_by(W) {
            let part = |lane: &Lane| -> Part { lane[h0..h0 + W].try_into().expect("part") };
            let mut x: [Part; N] = std::array::from_fn(|i| part(&g.x[i]));
            let mut v: [Part; N] = std::array::from_fn(|i| part(&g.v[i]));
            let mut pw: [Part; NW] = std::array::from_fn(|s| part(&g.p[white[s]]));
            let mut po: [Part; NO] = std::array::from_fn(|s| part(&g.p[ou[s].0]));
            for t in 0..block {
                let noise = &g.noise;
                // Used as a copied value (`*z(slot)`): read in place through the reference,
                // LLVM sometimes leaves the lane loops that use it scalar.
                let z = |slot: usize| -> &Part { noise[(t * nz + slot) * LANES + h0..][..W].try_into().expect("part") };
                let mut f = [[0.0; W]; N];
                // One link slot; `$l` is a literal, so its ends fold to constants.
                macro_rules! link {
                    ($l:literal) => {
                        // From three masses on, an empty slot (no link between its ends) is
                        // skipped, a branch on a constant of the run; below, the branch costs
                        // more than the slot's few exact zeros.
                        if $l < N * (N + 1) / 2 && (N < 3 || lens[$l] != (0, 0)) {
                            let (a, b) = const { link_slot(N, $l) };
                            let (mut u, mut w) = (x[a], v[a]);
                            if b < N {
                                for j in 0..W {
                                    u[j] -= x[b][j];
                                    w[j] -= v[b][j];
                                }
                            }
                            let (dk, dc) = lens[$l];
                            let (mut ku, mut cw) = ([0.0; W], [0.0; W]);
                            for q in (0..D).rev() {
                                if q + 1 == dk {
                                    ku = [k[$l][q]; W];
                                } else if q + 1 < dk {
                                    for j in 0..W {
                                        ku[j] = ku[j].mul_add(u[j], k[$l][q]);
                                    }
                                }
                                if q + 1 == dc {
                                    cw = [c[$l][q]; W];
                                } else if q + 1 < dc {
                                    for j in 0..W {
                                        cw[j] = cw[j].mul_add(w[j], c[$l][q]);
                                    }
                                }
                            }
                            for j in 0..W {
                                let force = ku[j].mul_add(u[j], cw[j] * w[j]);
                                f[a][j] -= force;
                                if b < N {
                                    f[b][j] += force;
                                }
                            }
                        }
                    };
                }
                link!(0);
                link!(1);
                link!(2);
                link!(3);
                link!(4);
                link!(5);
                link!(6);
                link!(7);
                link!(8);
                link!(9);
                // Unrolled by hand like the links: as a loop, LLVM leaves it scalar from
                // three filtered excitations on.
                macro_rules! filtered {
                    ($s:literal) => {
                        if $s < NO {
                            for i in 0..N {
                                for j in 0..W {
                                    f[i][j] = ou_weight[i][$s].mul_add(po[$s][j], f[i][j]);
                                }
                            }
                            let (_, decay, sd) = ou[$s];
                            let zo = *z(NW + $s);
                            for j in 0..W {
                                po[$s][j] = po[$s][j].mul_add(decay, sd * zo[j]);
                            }
                        }
                    };
                }
                filtered!(0);
                filtered!(1);
                filtered!(2);
                filtered!(3);
                if !semi {
                    for i in 0..N {
                        for j in 0..W {
                            x[i][j] = h.mul_add(v[i][j], x[i][j]);
                        }
                    }
                }
                // The white impulses first: they do not wait for this step's forces.
                for s in 0..NW {
                    let zw = *z(s);
                    for j in 0..W {
                        pw[s][j] += zw[j];
                    }
                    for i in 0..N {
                        for j in 0..W {
                            v[i][j] = white_weight[i][s].mul_add(zw[j], v[i][j]);
                        }
                    }
                }
                for i in 0..N {
                    for j in 0..W {
                        v[i][j] = him[i].mul_add(f[i][j], v[i][j]);
                    }
                    if semi {
                        for j in 0..W {
                            x[i][j] = h.mul_add(v[i][j], x[i][j]);
                        }
                    }
                }
            }
            for i in 0..N {
                g.x[i][h0..h0 + W].copy_from_slice(&x[i]);
                g.v[i][h0..h0 + W].copy_from_slice(&v[i]);
            }
            for s in 0..NW {
                g.p[white[s]][h0..h0 + W].copy_from_slice(&pw[s]);
            }
            for s in 0..NO {
                g.p[ou[s].0][h0..h0 + W].copy_from_slice(&po[s]);
            }
        }
        done += block;
    }
}

/// Lanes the shaped kernel carries through a noise block at once: few enough that the
/// state and the temporaries stay in vector registers (32 lanes spill), enough independent
/// chains to overlap the step's latency (8 lanes wait on it); 16 measured fastest.
const W: usize = 16;
type Part = [f64; W];
/// `LANES` trajectories in struct-of-arrays form.
struct Group {
    first: usize,
    active: usize,
    rng: [Xoshiro256PlusPlus; LANES],
    /// Positions and velocities of the `n` masses and the phantom ground (index `n`).
    x: Vec<Lane>,
    v: Vec<Lane>,
    /// Scratch: force on each mass (and on the ground, ignored).
    f: Vec<Lane>,
    /// Per excitation: OU force, or the white impulse since the last sample in units of
    /// `σ√h` (the sum of its standard normals).
    p: Vec<Lane>,
    /// Scratch: this step's white-noise increments, per white excitation.
    dw: Vec<Lane>,
    /// Scratch: a block of standard normals for the shaped kernel (see [`fill_noise`]).
    noise: Vec<f64>,
    /// Velocities at the previous sample (for `Δv ÷ interval`).
    v_mark: Vec<Lane>,
    /// Scratch: the displacements while a sample is taken at the velocity's instant.
    x_keep: Vec<Lane>,
    /// Per excitation: a filtered force one step before the sample, then its value at the
    /// sample's instant (see [`Group::run`]).
    p_mid: Vec<Lane>,
    /// Per lane: the generator of the filtered forces' bridge normals at sampling instants,
    /// a stream of its own so the trajectories do not depend on the sampling.
    bridge: [Xoshiro256PlusPlus; LANES],
}

#[inline(always)]
fn zero() -> Lane {
    [0.0; LANES]
}

impl Group {
    fn new(model: &Model, seed: u64, first: usize, active: usize) -> Group {
        let n = model.masses();
        let ne = model.excitations.len();
        Group {
            first,
            active,
            rng: std::array::from_fn(|l| Xoshiro256PlusPlus::seed_from_u64(trajectory_seed(seed, first + l))),
            x: vec![zero(); n + 1],
            v: vec![zero(); n + 1],
            f: vec![zero(); n + 1],
            p: vec![zero(); ne],
            dw: vec![zero(); ne],
            noise: vec![0.0; NOISE_STEPS * ne * LANES],
            v_mark: vec![zero(); n],
            x_keep: vec![zero(); n],
            p_mid: vec![zero(); ne],
            bridge: std::array::from_fn(|l| {
                Xoshiro256PlusPlus::seed_from_u64(trajectory_seed(seed, first + l) ^ BRIDGE_STREAM)
            }),
        }
    }

    /// Link forces plus filtered excitation forces on every mass, into `self.f`.
    #[inline(always)]
    fn forces<const D: usize>(&mut self, lm: &LaneModel<D>) {
        for f in self.f.iter_mut() {
            *f = zero();
        }
        let (x, v, f) = (&self.x, &self.v, &mut self.f);
        for l in 0..lm.a.len() {
            let (a, b) = (lm.a[l], lm.b[l]);
            let (k, c) = (&lm.k[l], &lm.c[l]);
            let (xa, xb, va, vb) = (&x[a], &x[b], &v[a], &v[b]);
            let mut u = zero();
            let mut w = zero();
            for j in 0..LANES {
                u[j] = xa[j] - xb[j];
                w[j] = va[j] - vb[j];
            }
            // Horner, whole lanes at a time; D is a constant so this unrolls completely.
            let mut ku = [k[D - 1]; LANES];
            let mut cw = [c[D - 1]; LANES];
            for p in (0..D - 1).rev() {
                for j in 0..LANES {
                    ku[j] = ku[j].mul_add(u[j], k[p]);
                    cw[j] = cw[j].mul_add(w[j], c[p]);
                }
            }
            let mut force = zero();
            for j in 0..LANES {
                force[j] = ku[j].mul_add(u[j], cw[j] * w[j]);
            }
            let fa = &mut f[a];
            for j in 0..LANES {
                fa[j] -= force[j];
            }
            let fb = &mut f[b];
            for j in 0..LANES {
                fb[j] += force[j];
            }
        }
        for i in 0..lm.n {
            for &e in &lm.ou_on[i] {
                let p = self.p[e];
                for j in 0..LANES {
                    self.f[i][j] += p[j];
                }
            }
        }
    }

    /// One integration step of length `h` for every lane.
    #[inline(always)]
    fn step<const D: usize>(&mut self, lm: &LaneModel<D>) {
        self.forces(lm);
        let h = lm.h;
        draw_noise(lm, &mut self.rng, &mut self.p, &mut self.dw);
        for i in 0..lm.n {
            let (mut x, mut v, f) = (self.x[i], self.v[i], self.f[i]);
            let him = lm.h_inv_mass[i];
            if !lm.semi_implicit {
                for j in 0..LANES {
                    x[j] = h.mul_add(v[j], x[j]);
                }
            }
            for &(slot, im) in &lm.white_on[i] {
                let dw = self.dw[slot];
                for j in 0..LANES {
                    v[j] = im.mul_add(dw[j], v[j]);
                }
            }
            for j in 0..LANES {
                v[j] = him.mul_add(f[j], v[j]);
            }
            if lm.semi_implicit {
                for j in 0..LANES {
                    x[j] = h.mul_add(v[j], x[j]);
                }
            }
            self.x[i] = x;
            self.v[i] = v;
        }
    }

    /// First lane (if any) whose state is non-finite or beyond [`DIVERGENCE_LIMIT`].
    fn diverged_lane(&self) -> Option<usize> {
        // Whole lanes first (vector compares, no branch per value; a NaN fails `<`):
        // padding lanes count here, so a flagged group is searched lane by lane over its
        // active ones.
        let mut ok = [true; LANES];
        for s in self.x.iter().chain(&self.v).chain(&self.p) {
            for j in 0..LANES {
                ok[j] &= s[j].abs() < DIVERGENCE_LIMIT;
            }
        }
        if !ok.contains(&false) {
            return None;
        }
        (0..self.active).find(|&j| {
            self.x
                .iter()
                .chain(&self.v)
                .chain(&self.p)
                .any(|s| s[j].is_nan() || s[j].abs() >= DIVERGENCE_LIMIT)
        })
    }

    /// Lane `j`'s state by name; a white excitation's `p` is its impulse since the last
    /// sample (N·s), a filtered one's its force.
    fn state_of<const D: usize>(&self, m: &Model, lm: &LaneModel<D>, j: usize) -> Vec<(String, f64)> {
        let mut s = Vec::new();
        for (i, n) in m.mass_names.iter().enumerate() {
            s.push((format!("x_{n}"), self.x[i][j]));
            s.push((format!("v_{n}"), self.v[i][j]));
        }
        for (e, n) in m.excitation_names.iter().enumerate() {
            let scale = if lm.is_white[e] { lm.impulse_scale[e] } else { 1.0 };
            s.push((format!("p_{n}"), self.p[e][j] * scale));
        }
        s
    }

    /// Advance `samples` sample intervals of `steps` steps each, checking divergence after
    /// every interval. When `out` is not empty, the sample at the end of interval `k` goes
    /// into `out[k * columns .. (k + 1) * columns]`: per column, the group's active lanes'
    /// values (its part of the batch at that instant, so samples are written once, straight
    /// where they go).
    #[allow(clippy::too_many_arguments)]
    fn run<const D: usize>(
        &mut self,
        m: &Model,
        lm: &LaneModel<D>,
        steps: usize,
        samples: usize,
        interval: f64,
        t0: f64,
        out: &mut [&mut [f64]],
    ) -> Result<(), SimError> {
        let n = lm.n;
        let ne = lm.is_white.len();
        let cols = 3 * n + ne;
        let act = self.active;
        let record = !out.is_empty();
        debug_assert!(!record || out.len() == samples * cols);
        // Masses with no white force get their acceleration from the force balance.
        let balance = lm.white_on.iter().any(|w| w.is_empty());
        let bridged = record && !lm.ou.is_empty();
        for k in 0..samples {
            if bridged {
                // The filtered forces one step before the sample, for their bridge below.
                (lm.advance)(self, lm, steps - 1);
                for &(e, ..) in &lm.ou {
                    self.p_mid[e] = self.p[e];
                }
                (lm.advance)(self, lm, 1);
            } else {
                (lm.advance)(self, lm, steps);
            }
            if let Some(j) = self.diverged_lane() {
                return Err(SimError::Diverged {
                    trajectory: self.first + j,
                    t_from: t0 + k as f64 * interval,
                    t_to: t0 + (k + 1) as f64 * interval,
                    state: self.state_of(m, lm, j),
                });
            }
            if record {
                // The semi-implicit step is staggered: the new velocity is the step's mean,
                // i.e. the velocity at its midpoint, so the displacement logged with it is the
                // midpoint's, (x_n + x_(n+1)) / 2 = x_(n+1) − h v_(n+1) / 2 — then the sample is
                // one instant's state, and the stationary moments lose the scheme's O(h)
                // displacement–velocity correlation (E[x v] = h E[v²] / 2 otherwise, which biases
                // damping estimates by k h / 2c).
                //
                // A filtered force at that instant, the step's midpoint: the step used P_n
                // and ended at P_(n+1) = ρ P_n + sd z, so either end is h/2 off the state and
                // biases the cross-moments E[x P], E[v P] by ∓Bh/2 (which reads as a damping
                // bias of the same size). The sample is drawn from the exact Ornstein–Uhlenbeck
                // bridge instead: given both ends, P(t_n + h/2) is normal with mean
                // √ρ (P_n + P_(n+1)) / (1 + ρ) and standard deviation sd / (1 + ρ), so its
                // variance stays exactly A²/2B and the cross-moments keep only the scheme's
                // own discretisation error (tested against the recursion's exact covariance).
                // Explicit Euler–Maruyama logs the step's end state, but its step applied P_n
                // too, and the same midpoint sample puts its E[v P] within 0.03 % of the
                // continuous value at B·h = 0.06 (the end value: −2.9 %; exact recursion).
                if bridged {
                    for &(e, decay, sd) in &lm.ou {
                        let (w, s) = (decay.sqrt() / (1.0 + decay), sd / (1.0 + decay));
                        let (mid, end) = (&mut self.p_mid[e], &self.p[e]);
                        for j in 0..LANES {
                            let z: f64 = StandardNormal.sample(&mut self.bridge[j]);
                            mid[j] = w * (mid[j] + end[j]) + s * z;
                        }
                    }
                }
                let o = &mut out[k * cols..(k + 1) * cols];
                for i in 0..n {
                    let (x, v) = (&self.x[i], &self.v[i]);
                    if lm.semi_implicit {
                        for ((y, &x), &v) in o[3 * i].iter_mut().zip(x).zip(v) {
                            *y = x - 0.5 * lm.h * v;
                        }
                    } else {
                        o[3 * i].copy_from_slice(&x[..act]);
                    }
                    o[3 * i + 1].copy_from_slice(&v[..act]);
                }
                if balance {
                    // Instantaneous force balance, at the logged displacements and forces.
                    self.x_keep.copy_from_slice(&self.x[..n]);
                    for i in 0..n {
                        self.x[i][..act].copy_from_slice(o[3 * i]);
                    }
                    for &(e, ..) in &lm.ou {
                        std::mem::swap(&mut self.p[e], &mut self.p_mid[e]);
                    }
                    self.forces(lm);
                    for &(e, ..) in &lm.ou {
                        std::mem::swap(&mut self.p[e], &mut self.p_mid[e]);
                    }
                    self.x[..n].copy_from_slice(&self.x_keep);
                }
                for i in 0..n {
                    let a = &mut o[3 * i + 2];
                    if lm.white_on[i].is_empty() {
                        for (a, &f) in a.iter_mut().zip(&self.f[i]) {
                            *a = f * lm.inv_mass[i];
                        }
                    } else {
                        for ((a, &v), &v0) in a.iter_mut().zip(&self.v[i]).zip(&self.v_mark[i]) {
                            *a = (v - v0) / interval;
                        }
                    }
                }
                for e in 0..ne {
                    let p = &mut o[3 * n + e];
                    if lm.is_white[e] {
                        for (y, &z) in p.iter_mut().zip(&self.p[e]) {
                            *y = z * lm.impulse_scale[e] / interval;
                        }
                    } else {
                        p.copy_from_slice(&self.p_mid[e][..act]);
                    }
                }
            }
            self.v_mark.copy_from_slice(&self.v[..n]);
            for e in 0..ne {
                if lm.is_white[e] {
                    self.p[e] = zero();
                }
            }
        }
        Ok(())
    }
}

/// Instants per block: a group's block is at most about `2e5` steps (cheap
/// synchronisation), and a batch at most about 2 MB of values (it stays in the caches
/// between the simulator and the sink, and recycled batches come back quickly).
fn block_samples(steps_per_sample: usize, values_per_instant: usize, total: usize) -> usize {
    (200_000 / steps_per_sample.max(1))
        .min((1 << 18) / values_per_instant.max(1))
        .clamp(1, 4096)
        .min(total.max(1))
}

/// Simulate every trajectory of `sim` and hand the samples to `sink`, block by block, in
/// (time, trajectory) order. `progress` is called with the number of samples written so far.
pub fn simulate(
    model: &Model,
    sim: &Simulation,
    sink: &mut dyn SampleSink,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<RunStats, SimError> {
    simulate_with(model, sim, sink, progress, false)
}

/// [`simulate`] with the generic stepper only (no shaped kernel, but the same rewritten
/// links): the reference the kernel is tested against, bit for bit.
pub fn simulate_generic(
    model: &Model,
    sim: &Simulation,
    sink: &mut dyn SampleSink,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<RunStats, SimError> {
    simulate_with(model, sim, sink, progress, true)
}

fn simulate_with(
    model: &Model,
    sim: &Simulation,
    sink: &mut dyn SampleSink,
    progress: &(dyn Fn(u64) + Sync),
    generic: bool,
) -> Result<RunStats, SimError> {
    let degree = (0..model.links())
        .map(|l| model.k_len[l].max(model.c_len[l]))
        .max()
        .unwrap_or(1);
    // One monomorphised stepper per padded degree.
    match degree {
        0 | 1 => simulate_padded::<1>(model, sim, sink, progress, generic, shaped_kernel),
        2 | 3 => simulate_padded::<3>(model, sim, sink, progress, generic, shaped_kernel),
        4 | 5 => simulate_padded::<5>(model, sim, sink, progress, generic, shaped_kernel),
        6 | 7 => simulate_padded::<7>(model, sim, sink, progress, generic, no_kernel),
        _ => simulate_padded::<15>(model, sim, sink, progress, generic, no_kernel),
    }
}

fn simulate_padded<const D: usize>(
    model: &Model,
    sim: &Simulation,
    sink: &mut dyn SampleSink,
    progress: &(dyn Fn(u64) + Sync),
    generic: bool,
    shaped: fn(&LaneModel<D>) -> Option<Stepper<D>>,
) -> Result<RunStats, SimError> {
    let mut lm = LaneModel::<D>::new(model, sim, shaped);
    if generic {
        lm.advance = advance_generic::<D>;
    }
    let steps = sim.steps_per_sample() * sim.substeps;
    let interval = sim.sample_interval;
    let total = sim.samples_per_trajectory();
    let cols = 3 * model.masses() + model.excitations.len();
    let mut groups: Vec<Group> = (0..sim.trajectories.div_ceil(LANES))
        .map(|g| Group::new(model, sim.seed, g * LANES, (sim.trajectories - g * LANES).min(LANES)))
        .collect();

    // Burn-in, in whole sample intervals (plus the remainder) so divergence is caught early.
    let burn_steps = sim.burn_in_steps() * sim.substeps;
    let burn_intervals = burn_steps / steps;
    let burn_rest = burn_steps % steps;
    let t_burn = -(burn_steps as f64) * lm.h;
    groups.par_iter_mut().try_for_each(|g| {
        g.run(model, &lm, steps, burn_intervals, interval, t_burn, &mut [])?;
        let t_rest = t_burn + burn_intervals as f64 * interval;
        g.run(model, &lm, burn_rest, 1, burn_rest as f64 * lm.h, t_rest, &mut [])?;
        // The first sample's Δv and impulse start here.
        g.v_mark.copy_from_slice(&g.v[..model.masses()]);
        for (e, p) in g.p.iter_mut().enumerate() {
            if lm.is_white[e] {
                *p = zero();
            }
        }
        Ok::<(), SimError>(())
    })?;

    let block = block_samples(steps, cols * sim.trajectories, total);
    let mut done = 0usize;
    while done < total {
        let b = block.min(total - done);
        let t0 = done as f64 * interval;
        let per_k = sim.trajectories;
        let len = b * cols * per_k;
        // A batch the sink has finished with is refilled as it is (every value is
        // overwritten); a new one is lazily zeroed memory, its pages first touched by the
        // groups writing their samples, in parallel, straight into their parts of it.
        let mut batch = match sink.recycle() {
            Some(mut r) if r.values.len() >= len => {
                r.values.truncate(len);
                r
            }
            _ => SampleBatch {
                values: vec![0.0; len],
                ..SampleBatch::default()
            },
        };
        batch.columns = cols;
        batch.trajectories = per_k;
        batch.time.clear();
        batch.time.extend((1..=b).map(|k| (done + k) as f64 * interval));
        // Each group's lanes of each column at each instant: contiguous, so the batch
        // splits into disjoint slices, `b × cols` per group.
        let mut parts: Vec<Vec<&mut [f64]>> = groups.iter().map(|_| Vec::with_capacity(b * cols)).collect();
        for column in batch.values.chunks_exact_mut(per_k) {
            let mut rest = column;
            for (g, part) in groups.iter().zip(parts.iter_mut()) {
                let (mine, tail) = rest.split_at_mut(g.active);
                part.push(mine);
                rest = tail;
            }
        }
        let results: Vec<Result<(), SimError>> = groups
            .par_iter_mut()
            .zip(parts.par_iter_mut())
            .map(|(g, out)| g.run(model, &lm, steps, b, interval, t0, out))
            .collect();
        drop(parts);
        // The first failing group in trajectory order, whatever the thread count.
        results.into_iter().collect::<Result<Vec<()>, SimError>>()?;
        sink.write(batch).map_err(SimError::Sink)?;
        done += b;
        progress((done * sim.trajectories) as u64);
    }
    let steps_total = (groups.len() * LANES) as u64 * (burn_steps + total * steps) as u64;
    Ok(RunStats {
        samples: (total * sim.trajectories) as u64,
        steps: steps_total,
    })
}

/// A sink that calls `f(trajectory, t, values)` for every sample, in order.
pub struct ForEach<F: FnMut(u32, f64, &[f64])>(pub F);

impl<F: FnMut(u32, f64, &[f64])> SampleSink for ForEach<F> {
    fn write(&mut self, batch: SampleBatch) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
        batch.for_each_sample(&mut self.0);
        Ok(())
    }
}

/// A sink that keeps every sample in memory (tests and small runs).
#[derive(Debug, Default)]
pub struct Collect {
    pub batches: Vec<SampleBatch>,
}

impl SampleSink for Collect {
    fn write(&mut self, batch: SampleBatch) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
        self.batches.push(batch);
        Ok(())
    }
}

/// A sink that accumulates, per column, the sum and the matrix of cross products in
/// constant memory: means and covariances of the stationary response.
#[derive(Debug, Clone)]
pub struct Moments {
    pub count: u64,
    pub sum: Vec<f64>,
    /// Row-major `columns × columns`.
    pub cross: Vec<f64>,
}

impl Moments {
    pub fn new(columns: usize) -> Moments {
        Moments {
            count: 0,
            sum: vec![0.0; columns],
            cross: vec![0.0; columns * columns],
        }
    }
    pub fn mean(&self, i: usize) -> f64 {
        self.sum[i] / self.count as f64
    }
    pub fn covariance(&self, i: usize, j: usize) -> f64 {
        let n = self.sum.len();
        self.cross[i * n + j] / self.count as f64 - self.mean(i) * self.mean(j)
    }
}

impl SampleSink for Moments {
    fn write(&mut self, batch: SampleBatch) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
        let n = self.sum.len();
        batch.for_each_sample(|_, _, row| {
            for i in 0..n {
                self.sum[i] += row[i];
                for j in 0..n {
                    self.cross[i * n + j] += row[i] * row[j];
                }
            }
        });
        self.count += batch.len() as u64;
        Ok(())
    }
}
