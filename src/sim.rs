//! Stochastic simulation of a [`Model`]: semi-implicit or explicit Euler–Maruyama steps,
//! exact Ornstein–Uhlenbeck transitions, burn-in, sampling, parallel trajectories.
//!
//! Performance design: trajectories are stepped [`LANES`] at a time in struct-of-arrays
//! lanes, so the CPU always has independent work while one lane waits on its state's
//! dependency chain, and the per-link polynomial loop is amortised over the lanes. The
//! fixed-shape kernel (`advance_fixed`) separates the two kinds of work: the normals of a
//! block of steps are drawn first, one generator at a time (`fill_noise`), then the steps
//! run over them as vector arithmetic, 16 lanes at a time in registers. Each
//! lane has its own `Xoshiro256PlusPlus`, seeded from `(seed, trajectory)`, so the output is
//! bit-identical whatever the number of threads. Time advances in blocks of samples: in a
//! block every lane group runs in parallel (rayon), then the block's samples are handed,
//! in (time, trajectory) order, to a [`SampleSink`] — memory is bounded by one block.
//!
//! This module knows nothing of files: sinks (the MCAP writer, moment accumulators in
//! tests) are supplied by the caller.

use crate::model::{Model, GROUND};
use crate::scenario::{Process, Scheme, Simulation};
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

/// Samples of one block, in (time, trajectory) order.
#[derive(Debug, Clone, Default)]
pub struct SampleBatch {
    /// Values per sample (see [`columns`]).
    pub columns: usize,
    pub trajectory: Vec<u32>,
    /// Time after burn-in, s.
    pub time: Vec<f64>,
    /// Row-major, `columns` values per sample.
    pub values: Vec<f64>,
}

impl SampleBatch {
    pub fn len(&self) -> usize {
        self.time.len()
    }
    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }
    pub fn row(&self, i: usize) -> &[f64] {
        &self.values[i * self.columns..(i + 1) * self.columns]
    }
}

/// Where samples go.
pub trait SampleSink {
    fn write(&mut self, batch: SampleBatch) -> Result<(), Box<dyn std::error::Error + Send + Sync>>;
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
    /// Per white excitation: its index and `σ√h`.
    white: Vec<(usize, f64)>,
    /// Per mass: (white-excitation slot, `1/m_i`) of the white forces acting on it.
    white_on: Vec<Vec<(usize, f64)>>,
    /// Per filtered excitation: index, exact-transition decay and standard deviation.
    ou: Vec<(usize, f64, f64)>,
    /// Per mass: the filtered excitations acting on it.
    ou_on: Vec<Vec<usize>>,
    /// Whether excitation `e` is white.
    is_white: Vec<bool>,
    /// Per link: the number of stiffness and damping coefficients before padding.
    lens: Vec<(usize, usize)>,
    /// `white_weight[i·n_white + slot] = 1/m_i` if white slot acts on mass `i`, else 0.
    white_weight: Vec<f64>,
    /// `ou_weight[i·n_ou + slot] = 1` if filtered slot acts on mass `i`, else 0.
    ou_weight: Vec<f64>,
    /// Advances a group by a number of steps: a fixed-shape kernel when one matches.
    advance: fn(&mut Group, &LaneModel<D>, usize),
}

impl<const D: usize> LaneModel<D> {
    fn new(m: &Model, sim: &Simulation) -> Self {
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
                        lm.white_on[i].push((lm.white.len(), m.inv_mass[i]));
                    }
                    lm.white.push((e, sigma * h.sqrt()));
                    lm.is_white.push(true);
                }
                Process::Filtered { a, b } => {
                    // Exact transition of dP = −B P dt + A dW over h.
                    let d = (-b * h).exp();
                    for &i in &exc.targets {
                        lm.ou_on[i].push(e);
                    }
                    lm.ou.push((e, d, a * ((1.0 - d * d) / (2.0 * b)).sqrt()));
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
        lm.advance = match (n, m.links()) {
            _ if lm.is_white.len() > MAX_KERNEL_EXCITATIONS => advance_generic::<D>,
            (1, 1) => advance_fixed::<1, 1, D>,
            (1, 2) => advance_fixed::<1, 2, D>,
            (2, 2) => advance_fixed::<2, 2, D>,
            (2, 3) => advance_fixed::<2, 3, D>,
            (3, 3) => advance_fixed::<3, 3, D>,
            (3, 4) => advance_fixed::<3, 4, D>,
            (4, 5) => advance_fixed::<4, 5, D>,
            _ => advance_generic::<D>,
        };
        lm
    }
}

/// One step's noise for every lane: white increments into `dw` (and accumulated into the
/// impulse in `p`), exact OU transitions of the filtered forces in `p`. The draw order is
/// fixed (white excitations, then filtered, in scenario order), so every stepper consumes
/// each lane's generator identically.
#[inline(always)]
fn draw_noise<const D: usize>(
    lm: &LaneModel<D>,
    rng: &mut [Xoshiro256PlusPlus; LANES],
    p: &mut [Lane],
    dw: &mut [Lane],
) {
    for (slot, &(e, scale)) in lm.white.iter().enumerate() {
        let mut d = zero();
        for j in 0..LANES {
            let z: f64 = StandardNormal.sample(&mut rng[j]);
            d[j] = scale * z;
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

/// Lanes the fixed kernel carries through a noise block at once: few enough that the
/// state and the temporaries stay in vector registers (32 lanes spill), enough independent
/// chains to overlap the step's latency (8 lanes wait on it); 16 measured fastest.
const W: usize = 16;
type Part = [f64; W];
/// Excitations the fixed kernel keeps in registers (more go to the generic stepper).
const MAX_KERNEL_EXCITATIONS: usize = 4;

/// The fixed-shape kernel: `N` masses and `L` links known at compile time, so the loops
/// over masses and links unroll and every lane array is addressed statically. Each link
/// costs only its own flops: `u = x_a − x_b` (a ground end contributes nothing), Horner from
/// the characteristic's own highest power, force into its two ends; each white force only
/// into the masses it acts on. The arithmetic is that of [`Group::forces`] and
/// [`Group::step`] operation for operation (the same fused multiply–adds in the same
/// order; starting Horner at the highest non-padded power gives the padded evaluation's
/// bits, `0·u + k = k`), so the kernel is bit-identical to the generic stepper (tested).
///
/// The normals are drawn [`NOISE_STEPS`] steps at a time by [`fill_noise`] (the
/// generator's tight loop), then the steps run over the buffer, [`W`] lanes at a time, as
/// pure vector arithmetic. The white impulse enters the velocity before the force does:
/// it does not wait on the force's dependency chain.
fn advance_fixed<const N: usize, const L: usize, const D: usize>(g: &mut Group, lm: &LaneModel<D>, steps: usize) {
    // Constant-size copies: the loops over masses and links are unrolled and every lane
    // array is addressed statically.
    let ends: [(usize, usize); L] = std::array::from_fn(|l| (lm.a[l], lm.b[l]));
    let lens: [(usize, usize); L] = std::array::from_fn(|l| lm.lens[l]);
    let k: [[f64; D]; L] = std::array::from_fn(|l| lm.k[l]);
    let c: [[f64; D]; L] = std::array::from_fn(|l| lm.c[l]);
    let him: [f64; N] = std::array::from_fn(|i| lm.h_inv_mass[i]);
    let (h, semi) = (lm.h, lm.semi_implicit);
    let (nw, no) = (lm.white.len(), lm.ou.len());
    let nz = nw + no;
    let mut done = 0;
    while done < steps {
        let block = (steps - done).min(NOISE_STEPS);
        fill_noise(&mut g.rng, nz, block, &mut g.noise);
        for h0 in (0..LANES).step_by(W) {
            let part = |lane: &Lane| -> Part { lane[h0..h0 + W].try_into().expect("part") };
            let mut x: [Part; N] = std::array::from_fn(|i| part(&g.x[i]));
            let mut v: [Part; N] = std::array::from_fn(|i| part(&g.v[i]));
            let mut p: [Part; MAX_KERNEL_EXCITATIONS] = std::array::from_fn(|e| g.p.get(e).map_or([0.0; W], part));
            for t in 0..block {
                let noise = &g.noise;
                let z = |slot: usize| -> &Part { noise[(t * nz + slot) * LANES + h0..][..W].try_into().expect("part") };
                let mut f = [[0.0; W]; N];
                for l in 0..L {
                    let (a, b) = ends[l];
                    let (mut u, mut w) = ([0.0; W], [0.0; W]);
                    for i in 0..N {
                        if i == a {
                            (u, w) = (x[i], v[i]);
                        }
                    }
                    for i in 0..N {
                        if i == b {
                            for j in 0..W {
                                u[j] -= x[i][j];
                                w[j] -= v[i][j];
                            }
                        }
                    }
                    let (dk, dc) = lens[l];
                    let (mut ku, mut cw) = ([0.0; W], [0.0; W]);
                    for q in (0..D).rev() {
                        if q + 1 == dk {
                            ku = [k[l][q]; W];
                        } else if q + 1 < dk {
                            for j in 0..W {
                                ku[j] = ku[j].mul_add(u[j], k[l][q]);
                            }
                        }
                        if q + 1 == dc {
                            cw = [c[l][q]; W];
                        } else if q + 1 < dc {
                            for j in 0..W {
                                cw[j] = cw[j].mul_add(w[j], c[l][q]);
                            }
                        }
                    }
                    let mut force = [0.0; W];
                    for j in 0..W {
                        force[j] = ku[j].mul_add(u[j], cw[j] * w[j]);
                    }
                    for i in 0..N {
                        if i == a {
                            for j in 0..W {
                                f[i][j] -= force[j];
                            }
                        }
                        if i == b {
                            for j in 0..W {
                                f[i][j] += force[j];
                            }
                        }
                    }
                }
                for (slot, &(e, decay, sd)) in lm.ou.iter().enumerate() {
                    for i in 0..N {
                        let wgt = lm.ou_weight[i * no + slot];
                        for j in 0..W {
                            f[i][j] = wgt.mul_add(p[e][j], f[i][j]);
                        }
                    }
                    let zo = z(nw + slot);
                    let mut pe = p[e];
                    for j in 0..W {
                        pe[j] = pe[j].mul_add(decay, sd * zo[j]);
                    }
                    p[e] = pe;
                }
                if !semi {
                    for i in 0..N {
                        for j in 0..W {
                            x[i][j] = h.mul_add(v[i][j], x[i][j]);
                        }
                    }
                }
                // The white impulses first: they do not wait for this step's forces.
                for (slot, &(e, scale)) in lm.white.iter().enumerate() {
                    let zw = z(slot);
                    let mut d = [0.0; W];
                    let mut pe = p[e];
                    for j in 0..W {
                        d[j] = scale * zw[j];
                        pe[j] += d[j];
                    }
                    p[e] = pe;
                    for i in 0..N {
                        let im = lm.white_weight[i * nw + slot];
                        if im != 0.0 {
                            for j in 0..W {
                                v[i][j] = im.mul_add(d[j], v[i][j]);
                            }
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
            for (e, pe) in g.p.iter_mut().enumerate() {
                pe[h0..h0 + W].copy_from_slice(&p[e]);
            }
        }
        done += block;
    }
}

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
    /// Per excitation: OU force, or the white impulse accumulated since the last sample.
    p: Vec<Lane>,
    /// Scratch: this step's white-noise increments, per white excitation.
    dw: Vec<Lane>,
    /// Scratch: a block of standard normals for the fixed kernel (see [`fill_noise`]).
    noise: Vec<f64>,
    /// Velocities at the previous sample (for `Δv ÷ interval`).
    v_mark: Vec<Lane>,
    /// Scratch: the displacements while a sample is taken at the velocity's instant.
    x_keep: Vec<Lane>,
    /// This block's samples: `[k][lane][column]`.
    buf: Vec<f64>,
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
            buf: Vec::new(),
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
        (0..self.active).find(|&j| {
            self.x
                .iter()
                .chain(&self.v)
                .chain(&self.p)
                .any(|s| s[j].is_nan() || s[j].abs() >= DIVERGENCE_LIMIT)
        })
    }

    fn state_of(&self, m: &Model, j: usize) -> Vec<(String, f64)> {
        let mut s = Vec::new();
        for (i, n) in m.mass_names.iter().enumerate() {
            s.push((format!("x_{n}"), self.x[i][j]));
            s.push((format!("v_{n}"), self.v[i][j]));
        }
        for (e, n) in m.excitation_names.iter().enumerate() {
            s.push((format!("p_{n}"), self.p[e][j]));
        }
        s
    }

    /// Advance `samples` sample intervals of `steps` steps each, recording into `buf`
    /// (when `record`), checking divergence after every interval.
    #[allow(clippy::too_many_arguments)]
    fn run<const D: usize>(
        &mut self,
        m: &Model,
        lm: &LaneModel<D>,
        steps: usize,
        samples: usize,
        interval: f64,
        t0: f64,
        record: bool,
    ) -> Result<(), SimError> {
        let n = lm.n;
        let ne = lm.is_white.len();
        let cols = 3 * n + ne;
        if record {
            self.buf.clear();
            self.buf.resize(samples * LANES * cols, 0.0);
        }
        for k in 0..samples {
            (lm.advance)(self, lm, steps);
            if let Some(j) = self.diverged_lane() {
                return Err(SimError::Diverged {
                    trajectory: self.first + j,
                    t_from: t0 + k as f64 * interval,
                    t_to: t0 + (k + 1) as f64 * interval,
                    state: self.state_of(m, j),
                });
            }
            if record {
                // The semi-implicit step is staggered: the new velocity is the step's mean,
                // i.e. the velocity at its midpoint, so the displacement logged with it is the
                // midpoint's, (x_n + x_(n+1)) / 2 = x_(n+1) − h v_(n+1) / 2 — then the sample is
                // one instant's state, and the stationary moments lose the scheme's O(h)
                // displacement–velocity correlation (E[x v] = h E[v²] / 2 otherwise, which biases
                // damping estimates by k h / 2c).
                self.x_keep.copy_from_slice(&self.x[..n]);
                if lm.semi_implicit {
                    for i in 0..n {
                        for j in 0..LANES {
                            self.x[i][j] -= 0.5 * lm.h * self.v[i][j];
                        }
                    }
                }
                // Instantaneous force balance for masses without white noise.
                self.forces(lm);
                let row0 = k * LANES * cols;
                for j in 0..LANES {
                    let row = &mut self.buf[row0 + j * cols..row0 + (j + 1) * cols];
                    for i in 0..n {
                        row[3 * i] = self.x[i][j];
                        row[3 * i + 1] = self.v[i][j];
                        row[3 * i + 2] = if lm.white_on[i].is_empty() {
                            self.f[i][j] * lm.inv_mass[i]
                        } else {
                            (self.v[i][j] - self.v_mark[i][j]) / interval
                        };
                    }
                    for e in 0..ne {
                        row[3 * n + e] = if lm.is_white[e] {
                            self.p[e][j] / interval
                        } else {
                            self.p[e][j]
                        };
                    }
                }
                self.x[..n].copy_from_slice(&self.x_keep);
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

/// Samples per block so that a group's block is about `2e5` steps (bounded memory, cheap
/// synchronisation).
fn block_samples(steps_per_sample: usize, total: usize) -> usize {
    (200_000 / steps_per_sample.max(1)).clamp(1, 4096).min(total.max(1))
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

/// [`simulate`] with the generic stepper only (no fixed-shape kernel): the reference the
/// kernels are tested against, bit for bit.
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
        0 | 1 => simulate_padded::<1>(model, sim, sink, progress, generic),
        2 => simulate_padded::<2>(model, sim, sink, progress, generic),
        3 => simulate_padded::<3>(model, sim, sink, progress, generic),
        4 | 5 => simulate_padded::<5>(model, sim, sink, progress, generic),
        6 | 7 => simulate_padded::<7>(model, sim, sink, progress, generic),
        _ => simulate_padded::<15>(model, sim, sink, progress, generic),
    }
}

fn simulate_padded<const D: usize>(
    model: &Model,
    sim: &Simulation,
    sink: &mut dyn SampleSink,
    progress: &(dyn Fn(u64) + Sync),
    generic: bool,
) -> Result<RunStats, SimError> {
    let mut lm = LaneModel::<D>::new(model, sim);
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
        g.run(model, &lm, steps, burn_intervals, interval, t_burn, false)?;
        let t_rest = t_burn + burn_intervals as f64 * interval;
        g.run(model, &lm, burn_rest, 1, burn_rest as f64 * lm.h, t_rest, false)?;
        // The first sample's Δv and impulse start here.
        g.v_mark.copy_from_slice(&g.v[..model.masses()]);
        for (e, p) in g.p.iter_mut().enumerate() {
            if lm.is_white[e] {
                *p = zero();
            }
        }
        Ok::<(), SimError>(())
    })?;

    let block = block_samples(steps, total);
    let mut done = 0usize;
    while done < total {
        let b = block.min(total - done);
        let t0 = done as f64 * interval;
        let results: Vec<Result<(), SimError>> = groups
            .par_iter_mut()
            .map(|g| g.run(model, &lm, steps, b, interval, t0, true))
            .collect();
        // The first failing group in trajectory order, whatever the thread count.
        results.into_iter().collect::<Result<Vec<()>, SimError>>()?;
        // The block's samples in (time, trajectory) order, gathered in parallel (a serial
        // copy here would idle the other cores between blocks). `vec![0.0; n]` is lazily
        // zeroed memory, so the pages are first touched by the parallel writers too.
        let per_k = sim.trajectories;
        let mut batch = SampleBatch {
            columns: cols,
            trajectory: vec![0; b * per_k],
            time: vec![0.0; b * per_k],
            values: vec![0.0; b * per_k * cols],
        };
        batch
            .values
            .par_chunks_mut(per_k * cols)
            .zip(batch.trajectory.par_chunks_mut(per_k))
            .zip(batch.time.par_chunks_mut(per_k))
            .enumerate()
            .for_each(|(k, ((values, trajectory), time))| {
                let t = (done + k + 1) as f64 * interval;
                time.fill(t);
                let mut r = 0;
                for g in &groups {
                    let at = k * LANES * cols;
                    values[r * cols..(r + g.active) * cols].copy_from_slice(&g.buf[at..at + g.active * cols]);
                    for j in 0..g.active {
                        trajectory[r + j] = (g.first + j) as u32;
                    }
                    r += g.active;
                }
            });
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
        for i in 0..batch.len() {
            (self.0)(batch.trajectory[i], batch.time[i], batch.row(i));
        }
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
        for r in 0..batch.len() {
            let row = batch.row(r);
            for i in 0..n {
                self.sum[i] += row[i];
                for j in 0..n {
                    self.cross[i * n + j] += row[i] * row[j];
                }
            }
        }
        self.count += batch.len() as u64;
        Ok(())
    }
}
