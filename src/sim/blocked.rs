//! The blocked kernel: any number of masses, links and excitations, with the shaped
//! kernel's way of working but the shape read at run time. The normals of a block of
//! [`NOISE_STEPS`] steps are drawn first, one generator at a time ([`fill_noise`]), then
//! the steps run over them [`W`] lanes at a time on a state small enough to stay in L1
//! (the group's scratch), links and excitations taken from lists. Bit-identical to the
//! generic stepper (tested): the same operations in the same order for every mass.
//!
//! It is what systems beyond the shaped kernel's four masses run on; the generic stepper
//! stays as the reference it is tested against.

use super::lanes::{fill_noise, Group, LaneModel, NOISE_STEPS};
use super::shaped::{Part, W};
use super::LANES;
use multiversion::multiversion;

/// Advances `g` by `steps` steps of `lm`, whatever its shape.
#[multiversion(targets(
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
    "x86_64+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
))]
pub(crate) fn advance_blocked<const D: usize>(g: &mut Group, lm: &LaneModel<D>, steps: usize) {
    let n = lm.n;
    let (nw, no) = (lm.white.len(), lm.ou.len());
    let nz = nw + no;
    let (h, semi, heun) = (lm.h, lm.semi_implicit, lm.heun);
    let half = 0.5 * h;
    let Group {
        rng,
        x: gx,
        v: gv,
        p: gp,
        noise,
        scratch,
        ..
    } = g;
    // The W lanes' state: positions, velocities, forces on the masses, and per excitation
    // its force (filtered) or impulse sum (white).
    // With the Heun scheme also the step's start: positions, velocities and forces.
    let (xs, rest) = scratch.split_at_mut(n);
    let (vs, rest) = rest.split_at_mut(n);
    let (fs, rest) = rest.split_at_mut(n);
    let (x0, rest) = rest.split_at_mut(n);
    let (v0, rest) = rest.split_at_mut(n);
    let (f0, ps) = rest.split_at_mut(n);
    let mut done = 0;
    while done < steps {
        let block = (steps - done).min(NOISE_STEPS);
        fill_noise(rng, nz, block, noise);
        for h0 in (0..LANES).step_by(W) {
            let part = |lane: &[f64; LANES]| -> Part { lane[h0..h0 + W].try_into().expect("part") };
            for i in 0..n {
                xs[i] = part(&gx[i]);
                vs[i] = part(&gv[i]);
            }
            for (e, p) in ps.iter_mut().enumerate() {
                *p = part(&gp[e]);
            }
            for t in 0..block {
                let z = |slot: usize| -> &Part { noise[(t * nz + slot) * LANES + h0..][..W].try_into().expect("part") };
                forces(lm, xs, vs, ps, fs);
                // The filtered forces' exact transitions.
                for (s, &(e, decay, sd)) in lm.ou.iter().enumerate() {
                    let zo = *z(nw + s);
                    for j in 0..W {
                        ps[e][j] = ps[e][j].mul_add(decay, sd * zo[j]);
                    }
                }
                if heun {
                    // As `Group::step_heun`: the Euler predictor, the drift at its end with
                    // the filtered forces at theirs, the trapezoid on the same increment.
                    x0.copy_from_slice(xs);
                    v0.copy_from_slice(vs);
                    f0.copy_from_slice(fs);
                    for (s, &e) in lm.white.iter().enumerate() {
                        let zw = *z(s);
                        for j in 0..W {
                            ps[e][j] += zw[j];
                        }
                    }
                    for i in 0..n {
                        let him = lm.h_inv_mass[i];
                        for j in 0..W {
                            xs[i][j] = h.mul_add(vs[i][j], xs[i][j]);
                            vs[i][j] = him.mul_add(f0[i][j], vs[i][j]);
                        }
                        white_into(lm, i, &z, &mut vs[i]);
                    }
                    forces(lm, xs, vs, ps, fs);
                    for i in 0..n {
                        let him = 0.5 * lm.h_inv_mass[i];
                        for j in 0..W {
                            xs[i][j] = half.mul_add(v0[i][j] + vs[i][j], x0[i][j]);
                            vs[i][j] = him.mul_add(f0[i][j] + fs[i][j], v0[i][j]);
                        }
                        white_into(lm, i, &z, &mut vs[i]);
                    }
                    continue;
                }
                if !semi {
                    for i in 0..n {
                        for j in 0..W {
                            xs[i][j] = h.mul_add(vs[i][j], xs[i][j]);
                        }
                    }
                }
                // White impulses (per mass in excitation order), then the forces.
                for (s, &e) in lm.white.iter().enumerate() {
                    let zw = *z(s);
                    for j in 0..W {
                        ps[e][j] += zw[j];
                    }
                    for i in 0..n {
                        let im = lm.white_weight[i * nw + s];
                        if im != 0.0 {
                            for j in 0..W {
                                vs[i][j] = im.mul_add(zw[j], vs[i][j]);
                            }
                        }
                    }
                }
                for i in 0..n {
                    let him = lm.h_inv_mass[i];
                    for j in 0..W {
                        vs[i][j] = him.mul_add(fs[i][j], vs[i][j]);
                    }
                    if semi {
                        for j in 0..W {
                            xs[i][j] = h.mul_add(vs[i][j], xs[i][j]);
                        }
                    }
                }
            }
            for i in 0..n {
                gx[i][h0..h0 + W].copy_from_slice(&xs[i]);
                gv[i][h0..h0 + W].copy_from_slice(&vs[i]);
            }
            for (e, p) in ps.iter().enumerate() {
                gp[e][h0..h0 + W].copy_from_slice(p);
            }
        }
        done += block;
    }
}

/// The forces on the masses at the state `xs`, `vs`, `ps` into `fs`: the links' in their
/// order (the ground is index `n`: no state), then the filtered forces onto their masses
/// (per mass in excitation order).
#[inline(always)]
fn forces<const D: usize>(lm: &LaneModel<D>, xs: &[Part], vs: &[Part], ps: &[Part], fs: &mut [Part]) {
    let n = lm.n;
    let no = lm.ou.len();
    for f in fs.iter_mut() {
        *f = [0.0; W];
    }
    for l in 0..lm.a.len() {
        let (a, b) = (lm.a[l], lm.b[l]);
        let (mut u, mut w) = (xs[a], vs[a]);
        if b < n {
            for j in 0..W {
                u[j] -= xs[b][j];
                w[j] -= vs[b][j];
            }
        }
        let (k, c) = (&lm.k[l], &lm.c[l]);
        let (dk, dc) = lm.lens[l];
        let (mut ku, mut cw) = ([0.0; W], [0.0; W]);
        for q in (0..D).rev() {
            if q + 1 == dk {
                ku = [k[q]; W];
            } else if q + 1 < dk {
                for j in 0..W {
                    ku[j] = ku[j].mul_add(u[j], k[q]);
                }
            }
            if q + 1 == dc {
                cw = [c[q]; W];
            } else if q + 1 < dc {
                for j in 0..W {
                    cw[j] = cw[j].mul_add(w[j], c[q]);
                }
            }
        }
        let mut force = [0.0; W];
        for j in 0..W {
            force[j] = ku[j].mul_add(u[j], cw[j] * w[j]);
        }
        for j in 0..W {
            fs[a][j] -= force[j];
        }
        if b < n {
            for j in 0..W {
                fs[b][j] += force[j];
            }
        }
    }
    for (s, &(e, _, _)) in lm.ou.iter().enumerate() {
        for i in 0..n {
            if lm.ou_weight[i * no + s] != 0.0 {
                for j in 0..W {
                    fs[i][j] += ps[e][j];
                }
            }
        }
    }
}

/// The white impulses on mass `i` (in excitation order) into its velocity `v`.
#[inline(always)]
fn white_into<'a, const D: usize>(lm: &LaneModel<D>, i: usize, z: &impl Fn(usize) -> &'a Part, v: &mut Part) {
    let nw = lm.white.len();
    for s in 0..nw {
        let im = lm.white_weight[i * nw + s];
        if im != 0.0 {
            let zw = *z(s);
            for j in 0..W {
                v[j] = im.mul_add(zw[j], v[j]);
            }
        }
    }
}
