//! The shaped kernel: up to four masses and four excitations, every link's ends known at
//! compile time, the state of 16 lanes in vector registers; bit-identical to the generic
//! stepper (tested).

use super::lanes::{fill_noise, Group, LaneModel, Stepper, NOISE_STEPS};
use super::{Lane, LANES};
use multiversion::multiversion;

/// The shaped kernel for `lm`'s size, if there is one: up to [`SHAPED_MAX_MASSES`] masses
/// and four excitations (white and filtered together). Only the padded degrees up to 5 have one
/// (each degree instantiates the kernel for every size); higher ones step generically.
pub(crate) fn shaped_kernel<const D: usize>(lm: &LaneModel<D>) -> Option<Stepper<D>> {
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

/// Masses the shaped kernel handles.
pub(crate) const SHAPED_MAX_MASSES: usize = 4;

/// Link slots of the shaped kernel: one per pair of ends among its masses and the ground.
pub(crate) const SHAPED_LINK_SLOTS: usize = SHAPED_MAX_MASSES * (SHAPED_MAX_MASSES + 1) / 2;

/// The `l`-th link slot of `n` masses: `(a, b)` with `a < b ≤ n` (`n` is the ground), in
/// lexicographic order, so slot `l` of a `n`-mass model is known at compile time.
pub(crate) const fn link_slot(n: usize, l: usize) -> (usize, usize) {
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
    pub(super) fn complete_links(&mut self) {
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
        // Chosen only when every term is a power (see `LaneModel::new`).
        debug_assert!(self.other.iter().all(Vec::is_empty));
        self.other = vec![Vec::new(); slots];
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
/// force does: it does not wait on the force's dependency chain. With [`Scheme::Heun`]
/// (`lm.heun`, a constant of the run) each step is [`Group::step_heun`]'s, the forces
/// evaluated twice.
///
/// [`Scheme::Heun`]: crate::scenario::Scheme::Heun
/// [`Group::step_heun`]: super::lanes::Group
#[multiversion(targets(
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
    "x86_64+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
))]

pub(crate) fn advance_shaped<const N: usize, const D: usize, const NW: usize, const NO: usize>(
    g: &mut Group,
    lm: &LaneModel<D>,
    steps: usize,
) {
    let links = Links {
        k: std::array::from_fn(|l| lm.k.get(l).copied().unwrap_or([0.0; D])),
        c: std::array::from_fn(|l| lm.c.get(l).copied().unwrap_or([0.0; D])),
        lens: std::array::from_fn(|l| lm.lens.get(l).copied().unwrap_or((0, 0))),
    };
    let him: [f64; N] = std::array::from_fn(|i| lm.h_inv_mass[i]);
    let white: [usize; NW] = std::array::from_fn(|s| lm.white[s]);
    let white_weight: [[f64; NW]; N] = std::array::from_fn(|i| std::array::from_fn(|s| lm.white_weight[i * NW + s]));
    let ou: [(usize, f64, f64); NO] = std::array::from_fn(|s| lm.ou[s]);
    let ou_weight: [[f64; NO]; N] = std::array::from_fn(|i| std::array::from_fn(|s| lm.ou_weight[i * NO + s]));
    let (h, semi, heun) = (lm.h, lm.semi_implicit, lm.heun);
    let (half, half_him): (f64, [f64; N]) = (0.5 * h, std::array::from_fn(|i| 0.5 * him[i]));
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
                // Each filtered force's exact transition over the step.
                macro_rules! transition {
                    ($s:literal) => {
                        if $s < NO {
                            let (_, decay, sd) = ou[$s];
                            let zo = *z(NW + $s);
                            for j in 0..W {
                                po[$s][j] = po[$s][j].mul_add(decay, sd * zo[j]);
                            }
                        }
                    };
                }
                let mut f = forces::<N, D, NO>(&x, &v, &po, &links, &ou_weight);
                transition!(0);
                transition!(1);
                transition!(2);
                transition!(3);
                if heun {
                    // As `Group::step_heun`: the Euler predictor, the drift at its end with
                    // the filtered forces at theirs, the trapezoid on the same increment.
                    let (x0, v0, f0) = (x, v, f);
                    let zw: [Part; NW] = std::array::from_fn(|s| *z(s));
                    for s in 0..NW {
                        for j in 0..W {
                            pw[s][j] += zw[s][j];
                        }
                    }
                    for i in 0..N {
                        for j in 0..W {
                            x[i][j] = h.mul_add(v[i][j], x[i][j]);
                            v[i][j] = him[i].mul_add(f0[i][j], v[i][j]);
                        }
                        kick(&mut v[i], &zw, &white_weight[i]);
                    }
                    f = forces::<N, D, NO>(&x, &v, &po, &links, &ou_weight);
                    for i in 0..N {
                        for j in 0..W {
                            x[i][j] = half.mul_add(v0[i][j] + v[i][j], x0[i][j]);
                            v[i][j] = half_him[i].mul_add(f0[i][j] + f[i][j], v0[i][j]);
                        }
                        kick(&mut v[i], &zw, &white_weight[i]);
                    }
                    continue;
                }
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
pub(crate) const W: usize = 16;

pub(crate) type Part = [f64; W];

/// A run's links in the shaped kernel's slots ([`link_slot`]): stiffness and damping
/// coefficients by power, and the degrees in use.
struct Links<const D: usize> {
    k: [[f64; D]; SHAPED_LINK_SLOTS],
    c: [[f64; D]; SHAPED_LINK_SLOTS],
    lens: [(usize, usize); SHAPED_LINK_SLOTS],
}

/// The forces on the `N` masses at the state `x`, `v` and the filtered forces `po`: every
/// link slot (its ends constants), then the filtered forces with their weights — the
/// operations of [`Group::forces`] in its order.
///
/// [`Group::forces`]: super::lanes::Group
#[inline(always)]
fn forces<const N: usize, const D: usize, const NO: usize>(
    x: &[Part; N],
    v: &[Part; N],
    po: &[Part; NO],
    links: &Links<D>,
    ou_weight: &[[f64; NO]; N],
) -> [Part; N] {
    let mut f = [[0.0; W]; N];
    // One link slot; `$l` is a literal, so its ends fold to constants.
    macro_rules! link {
        ($l:literal) => {
            // From three masses on, an empty slot (no link between its ends) is
            // skipped, a branch on a constant of the run; below, the branch costs
            // more than the slot's few exact zeros.
            if $l < N * (N + 1) / 2 && (N < 3 || links.lens[$l] != (0, 0)) {
                let (a, b) = const { link_slot(N, $l) };
                let (mut u, mut w) = (x[a], v[a]);
                if b < N {
                    for j in 0..W {
                        u[j] -= x[b][j];
                        w[j] -= v[b][j];
                    }
                }
                let (dk, dc) = links.lens[$l];
                let (mut ku, mut cw) = ([0.0; W], [0.0; W]);
                for q in (0..D).rev() {
                    if q + 1 == dk {
                        ku = [links.k[$l][q]; W];
                    } else if q + 1 < dk {
                        for j in 0..W {
                            ku[j] = ku[j].mul_add(u[j], links.k[$l][q]);
                        }
                    }
                    if q + 1 == dc {
                        cw = [links.c[$l][q]; W];
                    } else if q + 1 < dc {
                        for j in 0..W {
                            cw[j] = cw[j].mul_add(w[j], links.c[$l][q]);
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
    filtered!(0);
    filtered!(1);
    filtered!(2);
    filtered!(3);
    f
}

/// The white impulses `zw` onto one mass's velocity `v` with its weights, in excitation
/// order (a zero weight adds an exact zero).
#[inline(always)]
fn kick<const NW: usize>(v: &mut Part, zw: &[Part; NW], weight: &[f64; NW]) {
    for s in 0..NW {
        for j in 0..W {
            v[j] = weight[s].mul_add(zw[s][j], v[j]);
        }
    }
}
