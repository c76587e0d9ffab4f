//! A hysteretic link force with a state of its own (Bouc–Wen): the truth that no
//! one-argument characteristic `K(u) + C(w)` represents (docs/scenario.md, "Hysteresis").
//!
//! The link force gains `k_z·z`, where the hysteretic displacement `z` (in the unit of `u`)
//! follows the link's relative velocity `w`:
//!
//! `ż = A·w − β·|w|·|z|^(n−1)·z − γ·w·|z|^n`.
//!
//! With `β + γ > 0`, `z` stays within `z_max = (A/(β+γ))^(1/n)`: a bounded force whose loop
//! in the `(u, k_z z)` plane dissipates energy every cycle when `β > 0`. The simulator
//! carries `z` per trajectory; the identifier never sees it — it is not logged, which is
//! the point: the method assumes the link force is a function of `u` and `w` at the same
//! instant, and a hysteretic force is not.

/// The Bouc–Wen element of a link.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoucWen {
    /// `k_z`: force per unit of `z` (the link's force unit per displacement unit).
    pub stiffness: f64,
    /// `A`: the loop's initial slope `dz/du` (dimensionless).
    pub a: f64,
    /// `β`, `γ`: the loop's shape (per displacement unit to the power `n`).
    pub beta: f64,
    pub gamma: f64,
    /// `n ≥ 1`: the sharpness of the transition to the loop's plateau.
    pub n: f64,
}

impl BoucWen {
    /// `ż` at hysteretic displacement `z` and relative velocity `w`.
    #[inline(always)]
    pub fn rate(&self, z: f64, w: f64) -> f64 {
        let az = z.abs();
        // |z|^(n−1) z and |z|^n; n = 1 (the common case) without a power.
        let (zn1z, zn) = if self.n == 1.0 {
            (z, az)
        } else {
            let p = az.powf(self.n - 1.0);
            (p * z, p * az)
        };
        self.a * w - self.beta * w.abs() * zn1z - self.gamma * w * zn
    }

    /// The bound of `|z|` on the loop's plateau, `(A/(β+γ))^(1/n)`.
    pub fn z_max(&self) -> f64 {
        (self.a / (self.beta + self.gamma)).powf(1.0 / self.n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Driven at unit relative speed from `z = 0`, `z` follows (n = 1) the closed form
    /// `z(u) = z_max (1 − e^(−(β+γ) u))`, reaches the plateau `±z_max` at both ends of a
    /// ±15 stroke, and the closed loop 15 → −15 → 15 absorbs positive work `∮ k_z z du`.
    #[test]
    fn the_loop_follows_its_closed_form_saturates_and_dissipates() {
        for n in [1.0, 2.0] {
            let bw = BoucWen {
                stiffness: 3.0,
                a: 1.0,
                beta: 0.6,
                gamma: 0.4,
                n,
            };
            let h: f64 = 1e-5;
            let (mut z, mut u, mut work) = (0.0_f64, 0.0_f64, 0.0);
            for (leg, (w, len)) in [(1.0, 15.0), (-1.0, 30.0), (1.0, 30.0)].into_iter().enumerate() {
                let steps = (len / h).round() as usize;
                for _ in 0..steps {
                    // Midpoint rule: second order, so 1e-5 steps leave errors near 1e-10.
                    let zm = z + 0.5 * h * bw.rate(z, w);
                    if leg > 0 {
                        work += bw.stiffness * zm * w * h;
                    }
                    z += h * bw.rate(zm, w);
                    u += w * h;
                    if n == 1.0 && leg == 0 && (u - 1.0).abs() < 0.5 * h {
                        let exact = bw.z_max() * (1.0 - (-(bw.beta + bw.gamma)).exp());
                        assert!((z - exact).abs() < 1e-8, "z(1) {z} against {exact}");
                    }
                }
                let plateau = w * bw.z_max();
                assert!((z - plateau).abs() < 1e-3, "n {n}: z {z} against {plateau}");
            }
            assert!((u - 15.0).abs() < 1e-6);
            assert!(work > 0.1, "n {n}: loop work {work}");
        }
    }
}
