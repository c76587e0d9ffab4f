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
    let (h, semi) = (lm.h, lm.semi_implicit);
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
    let (xs, rest) = scratch.split_at_mut(n);
    let (vs, rest) = rest.split_at_mut(n);
    let (fs, ps) = rest.split_at_mut(n);
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
                for f in fs.iter_mut() {
                    *f = [0.0; W];
                }
                // Link forces, in the links' order (the ground is index n: no state).
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
                // Filtered forces onto their masses (per mass in excitation order), then
                // their exact transition.
                for (s, &(e, decay, sd)) in lm.ou.iter().enumerate() {
                    for i in 0..n {
                        if lm.ou_weight[i * no + s] != 0.0 {
                            for j in 0..W {
                                fs[i][j] += ps[e][j];
                            }
                        }
                    }
                    let zo = *z(nw + s);
                    for j in 0..W {
                        ps[e][j] = ps[e][j].mul_add(decay, sd * zo[j]);
                    }
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
