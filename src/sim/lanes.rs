//! Lane groups: [`LANES`] trajectories in struct-of-arrays form, their generators, the
//! noise draws, the generic stepper (any shape) and a group's run over sample intervals
//! with sampling and the divergence check.

use super::normals::{self, Xoshiro};
use super::{trajectory_seed, Lane, SimError, DIVERGENCE_LIMIT, LANES};
use crate::model::{BoucWen, Characteristic, Model, Quantity, Term, GROUND};
use crate::scenario::{Process, Scheme, Simulation};
use multiversion::multiversion;
use rand::rngs::Xoshiro256PlusPlus;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

/// Mixed into a trajectory's seed for its bridge generator (see [`run_group`]).
pub(crate) const BRIDGE_STREAM: u64 = 0x4252_4944_4745_5f31;

/// Mixed into a trajectory's seed for the generator that splits a step's normals over two
/// half steps ([`Group::draw_refined`]).
pub(crate) const REFINE_STREAM: u64 = 0x5245_4649_4e45_5f32;

/// Advances a group by a number of steps.
pub(crate) type Stepper<const D: usize> = fn(&mut Group, &LaneModel<D>, usize);

/// The model compiled for lane stepping: every characteristic padded to degree `D` (a
/// compile-time constant, so each link is one fused, vectorised lane loop with no branch),
/// and the ground as a phantom mass `n` whose state stays 0.
pub(crate) struct LaneModel<const D: usize> {
    pub(super) n: usize,
    pub(super) h: f64,
    pub(super) semi_implicit: bool,
    /// The stochastic Heun scheme ([`Group::step_heun`], and the fused kernels' own).
    pub(super) heun: bool,
    pub(super) a: Vec<usize>,
    pub(super) b: Vec<usize>,
    /// `k[l][p − 1]`, `c[l][p − 1]`: the polynomial part.
    pub(super) k: Vec<[f64; D]>,
    pub(super) c: Vec<[f64; D]>,
    /// Per link: its terms without a polynomial form, `(is damping, term, coefficient)`.
    /// Only the generic stepper evaluates them; with any, no fast kernel is chosen.
    pub(super) other: Vec<Vec<(bool, Term, f64)>>,
    /// The hysteretic links and their Bouc–Wen elements; with any, the generic stepper
    /// carries their states ([`Group::z`]).
    pub(super) hysteresis: Vec<(usize, BoucWen)>,
    /// `h / m_i`.
    pub(super) h_inv_mass: Vec<f64>,
    pub(super) inv_mass: Vec<f64>,
    /// Per white excitation (slot): its excitation index.
    pub(super) white: Vec<usize>,
    /// Per excitation: `σ√h` (a white excitation's impulse over a step per standard
    /// normal), 0 if filtered.
    pub(super) impulse_scale: Vec<f64>,
    /// Per mass: (white-excitation slot, `σ√h/m_i`) of the white forces acting on it: the
    /// velocity change per standard normal.
    pub(super) white_on: Vec<Vec<(usize, f64)>>,
    /// Per filtered excitation: index, exact-transition decay and standard deviation.
    pub(super) ou: Vec<(usize, f64, f64)>,
    /// Per mass: the filtered excitations acting on it.
    pub(super) ou_on: Vec<Vec<usize>>,
    /// Whether excitation `e` is white.
    pub(super) is_white: Vec<bool>,
    /// Per link: the number of stiffness and damping coefficients before padding.
    pub(super) lens: Vec<(usize, usize)>,
    /// `white_weight[i·n_white + slot] = σ√h/m_i` if white slot acts on mass `i`, else 0.
    pub(super) white_weight: Vec<f64>,
    /// `ou_weight[i·n_ou + slot] = 1` if filtered slot acts on mass `i`, else 0.
    pub(super) ou_weight: Vec<f64>,
    /// Advances a group by a number of steps: the shaped kernel when one fits.
    pub(super) advance: Stepper<D>,
    /// Steps of half the length on the same Brownian paths as the run at twice the step
    /// ([`super::Stepping::Refined`], [`Group::draw_refined`]).
    pub(super) refined: bool,
}

impl<const D: usize> LaneModel<D> {
    /// The model compiled for stepping with the kernel `shaped` picks for its size (see
    /// [`shaped_kernel`]), or the generic stepper.
    pub(super) fn new(m: &Model, sim: &Simulation, shaped: fn(&LaneModel<D>) -> Option<Stepper<D>>) -> Self {
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
            heun: sim.scheme == Scheme::Heun,
            a: m.link_a.clone(),
            b: m.link_b.iter().map(|&b| if b == GROUND { n } else { b }).collect(),
            k: (0..m.links()).map(|l| pad(m.stiffness(l))).collect(),
            c: (0..m.links()).map(|l| pad(m.damping(l))).collect(),
            other: (0..m.links())
                .map(|l| {
                    m.other_terms
                        .iter()
                        .filter(|(c, _)| c.link == l)
                        .map(|&(c, v)| (c.kind == Characteristic::Damping, c.term, v))
                        .collect()
                })
                .collect(),
            hysteresis: m.hysteresis.clone(),
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
            refined: false,
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
                Process::Lab(_) => unreachable!("simulate runs a model with lab excitations by sim::lab"),
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
        if !m.other_terms.is_empty() || !m.hysteresis.is_empty() {
            // Terms and states the fused kernels do not have: the generic stepper.
        } else if let Some(kernel) = shaped(&lm) {
            lm.complete_links();
            lm.advance = kernel;
        } else {
            lm.advance = super::blocked::advance_blocked::<D>;
        }
        lm
    }
}

/// For padded degrees without a shaped kernel (they run on the blocked one).
pub(crate) fn no_kernel<const D: usize>(_: &LaneModel<D>) -> Option<Stepper<D>> {
    None
}

/// One step's noise for every lane: the white excitations' standard normals into `dw` (and
/// summed in `p`: the impulse since the last sample in units of `σ√h`), exact OU
/// transitions of the filtered forces in `p`. The draw order is
/// fixed (white excitations, then filtered, in scenario order), so every stepper consumes
/// each lane's generator identically.
#[inline(always)]
pub(crate) fn draw_noise<const D: usize>(
    lm: &LaneModel<D>,
    rng: &mut [Xoshiro; LANES],
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

pub(crate) fn advance_generic<const D: usize>(g: &mut Group, lm: &LaneModel<D>, steps: usize) {
    for _ in 0..steps {
        g.step(lm);
    }
}

/// Steps whose normals are drawn in one go by [`fill_noise`]: a block's normals
/// (`NOISE_STEPS × excitations × LANES` doubles, 16 KiB for two excitations) stay in L1.
pub(crate) const NOISE_STEPS: usize = 32;

/// Draws the normals of `steps` steps for every lane into `noise[(t·nz + slot)·LANES + j]`,
/// all lanes side by side ([`normals::fill`]). Each lane's generator is consumed in exactly
/// the order of [`draw_noise`] (per step: white slots, then filtered), so the samples do
/// not depend on the blocking. Kept out of line: the generator's slow path calls `exp`,
/// which would force the kernel's vector state out of registers.
#[inline(never)]
pub(crate) fn fill_noise(rng: &mut [Xoshiro; LANES], nz: usize, steps: usize, noise: &mut [f64]) {
    normals::fill(rng, steps * nz, noise);
}

/// `LANES` trajectories in struct-of-arrays form.
pub(crate) struct Group {
    pub(super) first: usize,
    pub(super) active: usize,
    pub(super) rng: [Xoshiro; LANES],
    /// Positions and velocities of the `n` masses and the phantom ground (index `n`).
    pub(super) x: Vec<Lane>,
    pub(super) v: Vec<Lane>,
    /// Scratch: force on each mass (and on the ground, ignored).
    pub(super) f: Vec<Lane>,
    /// Per excitation: OU force, or the white impulse since the last sample in units of
    /// `σ√h` (the sum of its standard normals).
    pub(super) p: Vec<Lane>,
    /// Per hysteretic link ([`LaneModel::hysteresis`]): its Bouc–Wen state `z`, not logged.
    pub(super) z: Vec<Lane>,
    /// Scratch: this step's white-noise increments, per white excitation.
    pub(super) dw: Vec<Lane>,
    /// Scratch: a block of standard normals for the shaped kernel (see [`fill_noise`]).
    pub(super) noise: Vec<f64>,
    /// Scratch of the blocked kernel ([`super::blocked`]): `x`, `v`, `f` of the `n` masses,
    /// then one part per excitation, for the lanes it works on.
    pub(super) scratch: Vec<super::shaped::Part>,
    /// Velocities at the previous sample (for `Δv ÷ interval`).
    pub(super) v_mark: Vec<Lane>,
    /// Scratch: the displacements while a sample is taken at the velocity's instant.
    pub(super) x_keep: Vec<Lane>,
    /// Positions and velocities at the last divergence check passed: the last finite
    /// state a divergence reports.
    pub(super) x_ok: Vec<Lane>,
    pub(super) v_ok: Vec<Lane>,
    /// Per excitation: a filtered force one step before the sample, then its value at the
    /// sample's instant (see [`run_group`]).
    pub(super) p_mid: Vec<Lane>,
    /// Per lane: the generator of the filtered forces' bridge normals at sampling instants,
    /// a stream of its own so the trajectories do not depend on the sampling.
    pub(super) bridge: [Xoshiro256PlusPlus; LANES],
    /// A refined run's: per lane, the generator of the normals that split a coarse step's
    /// over its two halves; per excitation, the second half's normal; which half is next.
    pub(super) refine: [Xoshiro256PlusPlus; LANES],
    pub(super) second_half: Vec<Lane>,
    pub(super) in_second_half: bool,
    /// Scratch of the Heun step: the state, the forces and the hysteretic states and
    /// rates at the step's start.
    pub(super) x0: Vec<Lane>,
    pub(super) v0: Vec<Lane>,
    pub(super) f0: Vec<Lane>,
    pub(super) z0: Vec<Lane>,
    pub(super) z_rate: Vec<Lane>,
}

#[inline(always)]
pub(crate) fn zero() -> Lane {
    [0.0; LANES]
}

impl Group {
    pub(super) fn new(model: &Model, seed: u64, first: usize, active: usize) -> Group {
        let n = model.masses();
        let ne = model.excitations.len();
        Group {
            first,
            active,
            rng: std::array::from_fn(|l| Xoshiro::seed_from_u64(trajectory_seed(seed, first + l))),
            x: vec![zero(); n + 1],
            v: vec![zero(); n + 1],
            f: vec![zero(); n + 1],
            p: vec![zero(); ne],
            z: vec![zero(); model.hysteresis.len()],
            dw: vec![zero(); ne],
            noise: vec![0.0; NOISE_STEPS * ne * LANES],
            scratch: vec![[0.0; super::shaped::W]; 6 * n + ne],
            v_mark: vec![zero(); n],
            x_keep: vec![zero(); n],
            x_ok: vec![zero(); n + 1],
            v_ok: vec![zero(); n + 1],
            p_mid: vec![zero(); ne],
            bridge: std::array::from_fn(|l| {
                Xoshiro256PlusPlus::seed_from_u64(trajectory_seed(seed, first + l) ^ BRIDGE_STREAM)
            }),
            refine: std::array::from_fn(|l| {
                Xoshiro256PlusPlus::seed_from_u64(trajectory_seed(seed, first + l) ^ REFINE_STREAM)
            }),
            second_half: vec![zero(); ne],
            in_second_half: false,
            x0: vec![zero(); n + 1],
            v0: vec![zero(); n + 1],
            f0: vec![zero(); n + 1],
            z0: vec![zero(); model.hysteresis.len()],
            z_rate: vec![zero(); model.hysteresis.len()],
        }
    }

    /// Link forces plus filtered excitation forces on every mass, into `self.f`.
    #[inline(always)]
    pub(super) fn forces<const D: usize>(&mut self, lm: &LaneModel<D>) {
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
            for &(damping, term, coefficient) in &lm.other[l] {
                let z = if damping { &w } else { &u };
                for j in 0..LANES {
                    force[j] += coefficient * term.value(z[j]);
                }
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
        for (&(l, bw), z) in lm.hysteresis.iter().zip(&self.z) {
            let (a, b) = (lm.a[l], lm.b[l]);
            for j in 0..LANES {
                f[a][j] -= bw.stiffness * z[j];
                f[b][j] += bw.stiffness * z[j];
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
    pub(super) fn step<const D: usize>(&mut self, lm: &LaneModel<D>) {
        if lm.heun {
            return self.step_heun(lm);
        }
        self.forces(lm);
        let h = lm.h;
        if !lm.semi_implicit {
            self.advance_hysteresis(lm);
        }
        self.draw(lm);
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
        if lm.semi_implicit {
            self.advance_hysteresis(lm);
        }
    }

    /// The step's noise: the run's own, or a refined run's halves ([`Group::draw_refined`]).
    #[inline(always)]
    fn draw<const D: usize>(&mut self, lm: &LaneModel<D>) {
        if lm.refined {
            self.draw_refined(lm);
        } else {
            draw_noise(lm, &mut self.rng, &mut self.p, &mut self.dw);
        }
    }

    /// One stochastic Heun step ([`Scheme::Heun`]; Kloeden and Platen's explicit weak
    /// order 2 scheme for additive noise): with the drift `a(Y)` and the step's noise
    /// increment `ΔW` (the same normals as the other schemes draw),
    /// `Ȳ = Y + h·a(Y) + ΔW`, then `Y' = Y + h·(a(Y) + a(Ȳ))/2 + ΔW`. A filtered force
    /// takes its exact transition first and enters the drift at the step's start and end,
    /// the trapezoid of its integral; a Bouc–Wen state is stepped alike. The state is the
    /// step's end, all of it at one instant (docs/methods.md, "The integrator's bias").
    #[inline(always)]
    fn step_heun<const D: usize>(&mut self, lm: &LaneModel<D>) {
        let (h, n) = (lm.h, lm.n);
        self.forces(lm);
        self.x0.copy_from_slice(&self.x);
        self.v0.copy_from_slice(&self.v);
        self.f0.copy_from_slice(&self.f);
        for (k, &(l, bw)) in lm.hysteresis.iter().enumerate() {
            let (va, vb, z, r) = (&self.v[lm.a[l]], &self.v[lm.b[l]], &self.z[k], &mut self.z_rate[k]);
            for j in 0..LANES {
                r[j] = bw.rate(z[j], va[j] - vb[j]);
            }
        }
        self.z0.copy_from_slice(&self.z);
        self.draw(lm);
        // Predictor: an explicit Euler step on the increment.
        for i in 0..n {
            let (x, v, f) = (&mut self.x[i], &mut self.v[i], &self.f[i]);
            let him = lm.h_inv_mass[i];
            for j in 0..LANES {
                x[j] = h.mul_add(v[j], x[j]);
                v[j] = him.mul_add(f[j], v[j]);
            }
            for &(slot, im) in &lm.white_on[i] {
                let dw = &self.dw[slot];
                for j in 0..LANES {
                    v[j] = im.mul_add(dw[j], v[j]);
                }
            }
        }
        for (z, r) in self.z.iter_mut().zip(&self.z_rate) {
            for j in 0..LANES {
                z[j] = h.mul_add(r[j], z[j]);
            }
        }
        // The drift at the predicted end (the filtered forces at their end values).
        self.forces(lm);
        let half = 0.5 * h;
        for (k, &(l, bw)) in lm.hysteresis.iter().enumerate() {
            let (va, vb) = (&self.v[lm.a[l]], &self.v[lm.b[l]]);
            let (z, z0, r) = (&mut self.z[k], &self.z0[k], &self.z_rate[k]);
            for j in 0..LANES {
                z[j] = half.mul_add(r[j] + bw.rate(z[j], va[j] - vb[j]), z0[j]);
            }
        }
        // Corrector: the trapezoid of the drift on the same increment.
        for i in 0..n {
            let (x, v) = (&mut self.x[i], &mut self.v[i]);
            let (x0, v0, f0, f1) = (&self.x0[i], &self.v0[i], &self.f0[i], &self.f[i]);
            let him = 0.5 * lm.h_inv_mass[i];
            for j in 0..LANES {
                x[j] = half.mul_add(v0[j] + v[j], x0[j]);
                v[j] = him.mul_add(f0[j] + f1[j], v0[j]);
            }
            for &(slot, im) in &lm.white_on[i] {
                let dw = &self.dw[slot];
                for j in 0..LANES {
                    v[j] = im.mul_add(dw[j], v[j]);
                }
            }
        }
    }

    /// A refined run's noise ([`super::Stepping::Refined`]): every other step draws the
    /// normals `N` of the run at twice the step from the same generator in the same order
    /// ([`draw_noise`]'s), and `B` from a stream of its own, and splits them over the two
    /// half steps so that their sum is that run's increment: a white force's
    /// `(N ± B)/√2` (the halves' `√(h/2)` increments add up to `√h·N`); a filtered force's
    /// `(ρ N + B)/r` and `(N − ρ B)/r` with `ρ` the half step's decay and `r = √(1 + ρ²)`
    /// (two exact half-step transitions then give the coarse one's exactly). Both halves'
    /// normals are independent standard normals, so each run alone is exact in law; the
    /// pair differs by the integrator alone (Richardson's estimate of its bias,
    /// docs/methods.md).
    #[inline(always)]
    fn draw_refined<const D: usize>(&mut self, lm: &LaneModel<D>) {
        if self.in_second_half {
            for (slot, &e) in lm.white.iter().enumerate() {
                let d = self.second_half[e];
                for j in 0..LANES {
                    self.p[e][j] += d[j];
                }
                self.dw[slot] = d;
            }
            for &(e, decay, sd) in &lm.ou {
                let (pe, y) = (&mut self.p[e], &self.second_half[e]);
                for j in 0..LANES {
                    pe[j] = pe[j].mul_add(decay, sd * y[j]);
                }
            }
        } else {
            let half = std::f64::consts::FRAC_1_SQRT_2;
            for (slot, &e) in lm.white.iter().enumerate() {
                let mut d = zero();
                for j in 0..LANES {
                    let n: f64 = StandardNormal.sample(&mut self.rng[j]);
                    let b: f64 = StandardNormal.sample(&mut self.refine[j]);
                    d[j] = half * (n + b);
                    self.second_half[e][j] = half * (n - b);
                    self.p[e][j] += d[j];
                }
                self.dw[slot] = d;
            }
            for &(e, decay, sd) in &lm.ou {
                let r = (1.0 + decay * decay).sqrt();
                for j in 0..LANES {
                    let n: f64 = StandardNormal.sample(&mut self.rng[j]);
                    let b: f64 = StandardNormal.sample(&mut self.refine[j]);
                    self.p[e][j] = self.p[e][j].mul_add(decay, sd * (decay * n + b) / r);
                    self.second_half[e][j] = (n - decay * b) / r;
                }
            }
        }
        self.in_second_half = !self.in_second_half;
    }

    /// The hysteretic states over one step, with the velocities the displacements take: the
    /// step's new ones in the semi-implicit scheme, the old ones in explicit Euler–Maruyama.
    /// Then `z` follows `u` exactly where the loop is linear (`z = A·u`), and the element
    /// is the spring it should be there; with the other velocity it would lag `u` by
    /// `h·w`, a negative damping `k_z·h` (tested: tests/hysteresis.rs).
    #[inline(always)]
    fn advance_hysteresis<const D: usize>(&mut self, lm: &LaneModel<D>) {
        for (&(l, bw), z) in lm.hysteresis.iter().zip(&mut self.z) {
            let (va, vb) = (&self.v[lm.a[l]], &self.v[lm.b[l]]);
            for j in 0..LANES {
                z[j] += lm.h * bw.rate(z[j], va[j] - vb[j]);
            }
        }
    }

    /// First lane (if any) whose state is non-finite or beyond [`DIVERGENCE_LIMIT`].
    /// Inlined into the caller's vector build: a rig's sensor filters sample (and check)
    /// at every step or two.
    #[inline(always)]
    pub(super) fn diverged_lane(&self) -> Option<usize> {
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

    /// Positions `x` and velocities `v` by name.
    pub(super) fn state_at(&self, m: &Model, x: &[f64], v: &[f64]) -> Vec<(String, f64)> {
        let mut s = Vec::new();
        for (i, n) in m.mass_names.iter().enumerate() {
            s.push((Quantity::Displacement.column_name(n), x[i]));
            s.push((Quantity::Velocity.column_name(n), v[i]));
        }
        s
    }
}

/// Advance group `g` by `samples` sample intervals of `steps` steps each, checking divergence after
/// every interval. When `out` is not empty, the sample at the end of interval `k` goes
/// into `out[k * columns .. (k + 1) * columns]`: per column, the group's active lanes'
/// values (its part of the batch at that instant, so samples are written once, straight
/// where they go).
///
/// Compiled for the widest vector unit the CPU has (the sampling, the force balance and
/// the divergence check run here; results are the same on every CPU).
#[allow(clippy::too_many_arguments)]
#[multiversion(targets(
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
    "x86_64+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
))]
pub(super) fn run_group<const D: usize>(
    g: &mut Group,
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
    let layout = m.columns();
    let cols = layout.len();
    let act = g.active;
    let record = !out.is_empty();
    debug_assert!(!record || out.len() == samples * cols);
    // Masses with no white force get their acceleration from the force balance.
    let balance = lm.white_on.iter().any(|w| w.is_empty());
    let bridged = record && !lm.ou.is_empty();
    for k in 0..samples {
        if bridged {
            // The filtered forces one step before the sample, for their bridge below.
            (lm.advance)(g, lm, steps - 1);
            for &(e, ..) in &lm.ou {
                g.p_mid[e] = g.p[e];
            }
            (lm.advance)(g, lm, 1);
        } else {
            (lm.advance)(g, lm, steps);
        }
        if let Some(j) = g.diverged_lane() {
            let x: Vec<f64> = (0..n).map(|i| g.x_ok[i][j]).collect();
            let v: Vec<f64> = (0..n).map(|i| g.v_ok[i][j]).collect();
            return Err(SimError::Diverged {
                trajectory: g.first + j,
                t_from: t0 + k as f64 * interval,
                t_to: t0 + (k + 1) as f64 * interval,
                last_finite: g.state_at(m, &x, &v),
                cause: super::divergence_cause(m, lm.h, &x, &v),
            });
        }
        g.x_ok.copy_from_slice(&g.x);
        g.v_ok.copy_from_slice(&g.v);
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
            if bridged && lm.heun {
                // The Heun step's state is its end's, and so is the force's value.
                for &(e, ..) in &lm.ou {
                    g.p_mid[e] = g.p[e];
                }
            } else if bridged {
                for &(e, decay, sd) in &lm.ou {
                    let (w, s) = (decay.sqrt() / (1.0 + decay), sd / (1.0 + decay));
                    let (mid, end) = (&mut g.p_mid[e], &g.p[e]);
                    for j in 0..LANES {
                        let z: f64 = StandardNormal.sample(&mut g.bridge[j]);
                        mid[j] = w * (mid[j] + end[j]) + s * z;
                    }
                }
            }
            let o = &mut out[k * cols..(k + 1) * cols];
            for i in 0..n {
                let (x, v) = (&g.x[i], &g.v[i]);
                if lm.semi_implicit {
                    for ((y, &x), &v) in o[layout.x(i)].iter_mut().zip(x).zip(v) {
                        *y = x - 0.5 * lm.h * v;
                    }
                } else {
                    o[layout.x(i)].copy_from_slice(&x[..act]);
                }
                o[layout.v(i)].copy_from_slice(&v[..act]);
            }
            if balance {
                // Instantaneous force balance, at the logged displacements and forces.
                g.x_keep.copy_from_slice(&g.x[..n]);
                for i in 0..n {
                    g.x[i][..act].copy_from_slice(o[layout.x(i)]);
                }
                for &(e, ..) in &lm.ou {
                    std::mem::swap(&mut g.p[e], &mut g.p_mid[e]);
                }
                g.forces(lm);
                for &(e, ..) in &lm.ou {
                    std::mem::swap(&mut g.p[e], &mut g.p_mid[e]);
                }
                g.x[..n].copy_from_slice(&g.x_keep);
            }
            for i in 0..n {
                let a = &mut o[layout.a(i)];
                if lm.white_on[i].is_empty() {
                    for (a, &f) in a.iter_mut().zip(&g.f[i]) {
                        *a = f * lm.inv_mass[i];
                    }
                } else {
                    for ((a, &v), &v0) in a.iter_mut().zip(&g.v[i]).zip(&g.v_mark[i]) {
                        *a = (v - v0) / interval;
                    }
                }
            }
            for e in 0..ne {
                let p = &mut o[layout.force(e)];
                if lm.is_white[e] {
                    for (y, &z) in p.iter_mut().zip(&g.p[e]) {
                        *y = z * lm.impulse_scale[e] / interval;
                    }
                } else {
                    p.copy_from_slice(&g.p_mid[e][..act]);
                }
            }
        }
        g.v_mark.copy_from_slice(&g.v[..n]);
        for e in 0..ne {
            if lm.is_white[e] {
                g.p[e] = zero();
            }
        }
    }
    Ok(())
}
