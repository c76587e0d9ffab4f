//! Reference systems with known answers, shared by tests, benches and examples.
//!
//! - scenario texts for the reference systems (linear SDOF, Duffing SDOF, linear 2-DOF,
//!   OU-driven SDOF);
//! - the exact stationary covariance of any linear model under white and filtered noise
//!   (continuous Lyapunov equation `AΣ + ΣAᵀ + GGᵀ = 0`);
//! - the exact stationary covariance of the *discrete* semi-implicit, explicit
//!   Euler–Maruyama and stochastic Heun recursions for a linear model under white noise (discrete Lyapunov
//!   equation `Σ = ΦΣΦᵀ + ΓΓᵀ`), which quantifies each scheme's bias;
//! - the exact stationary marginal densities of a single mass with linear damping under
//!   white forces ([`GibbsMarginals`]), drawn over the data in the report's densities.
//!
//! State order everywhere here: `x_1..x_n, v_1..v_n`, then one entry per filtered force.

use crate::model::Model;
use crate::scenario::{Process, Scenario, Scheme};
use nalgebra::{DMatrix, DVector};

/// A linear SDOF `m ẍ + c ẋ + k x = σ ξ` scenario.
pub fn linear_sdof(m: f64, k: f64, c: f64, sigma: f64, sim: &str) -> Scenario {
    let src = format!(
        "name = \"linear_sdof\"\n[[mass]]\nname = \"m1\"\nvalue = {m:?}\n\
         [[link]]\nends = [\"ground\", \"m1\"]\nstiffness = {{ 1 = {k:?} }}\ndamping = {{ 1 = {c:?} }}\n\
         [[excitation]]\nkind = \"white\"\nsigma = {sigma:?}\nacts_on = [\"m1\"]\n[simulation]\n{sim}\n"
    );
    Scenario::parse(&src, "zoo:linear_sdof", "linear_sdof").expect("zoo scenario is valid")
}

/// A linear 2-DOF chain ground–m1–m2–ground under white forces on both masses.
pub fn linear_2dof(sim: &str) -> Scenario {
    let src = format!(
        "name = \"linear_2dof\"\n\
         [[mass]]\nname = \"m1\"\nvalue = 1.0\n[[mass]]\nname = \"m2\"\nvalue = 2.0\n\
         [[link]]\nends = [\"ground\", \"m1\"]\nstiffness = {{ 1 = 10.0 }}\ndamping = {{ 1 = 1.0 }}\n\
         [[link]]\nends = [\"m1\", \"m2\"]\nstiffness = {{ 1 = 5.0 }}\ndamping = {{ 1 = 0.4 }}\n\
         [[link]]\nends = [\"ground\", \"m2\"]\nstiffness = {{ 1 = 8.0 }}\ndamping = {{ 1 = 0.6 }}\n\
         [[excitation]]\nkind = \"white\"\nsigma = 1.0\nacts_on = [\"m1\"]\n\
         [[excitation]]\nkind = \"white\"\nsigma = 0.7\nacts_on = [\"m2\"]\n\
         [simulation]\n{sim}\n"
    );
    Scenario::parse(&src, "zoo:linear_2dof", "linear_2dof").expect("zoo scenario is valid")
}

/// A linear SDOF driven by an Ornstein–Uhlenbeck force `dP = −B P dt + A dW`.
pub fn filtered_sdof(m: f64, k: f64, c: f64, a: f64, b: f64, sim: &str) -> Scenario {
    let src = format!(
        "name = \"filtered_sdof\"\n[[mass]]\nname = \"m1\"\nvalue = {m:?}\n\
         [[link]]\nends = [\"ground\", \"m1\"]\nstiffness = {{ 1 = {k:?} }}\ndamping = {{ 1 = {c:?} }}\n\
         [[excitation]]\nkind = \"filtered\"\nA = {a:?}\nB = {b:?}\nacts_on = [\"m1\"]\n[simulation]\n{sim}\n"
    );
    Scenario::parse(&src, "zoo:filtered_sdof", "filtered_sdof").expect("zoo scenario is valid")
}

/// Exact stationary variances `(E[x²], E[v²])` of `m ẍ + c ẋ + k x = σ ξ`:
/// `σ²/(2ck)` and `σ²/(2cm)`.
pub fn linear_sdof_variances(m: f64, k: f64, c: f64, sigma: f64) -> (f64, f64) {
    (sigma * sigma / (2.0 * c * k), sigma * sigma / (2.0 * c * m))
}

/// Drift matrix `A` and noise matrix `G` of a linear model (`dy = A y dt + G dW`), or
/// `None` if some link is nonlinear.
pub fn linear_system(model: &Model) -> Option<(DMatrix<f64>, DMatrix<f64>)> {
    if !model.is_linear() {
        return None;
    }
    let n = model.masses();
    let ou: Vec<usize> = (0..model.excitations.len())
        .filter(|&e| matches!(model.excitations[e].process, Process::Filtered { .. }))
        .collect();
    let dim = 2 * n + ou.len();
    let mut a = DMatrix::zeros(dim, dim);
    let mut g = DMatrix::zeros(dim, model.excitations.len());
    for i in 0..n {
        a[(i, n + i)] = 1.0;
    }
    for l in 0..model.links() {
        let k = model.stiffness(l).first().copied().unwrap_or(0.0);
        let c = model.damping(l).first().copied().unwrap_or(0.0);
        for (i, si) in model.geometry(l) {
            for (j, sj) in model.geometry(l) {
                // u = Σ_j s_j x_j; force on i is −s_i (k u + c w).
                a[(n + i, j)] -= si * sj * k / model.mass[i];
                a[(n + i, n + j)] -= si * sj * c / model.mass[i];
            }
        }
    }
    for (e, exc) in model.excitations.iter().enumerate() {
        match exc.process {
            Process::White { sigma } => {
                for &i in &exc.targets {
                    g[(n + i, e)] = sigma / model.mass[i];
                }
            }
            Process::Filtered { a: amp, b } => {
                let r = 2 * n + ou.iter().position(|&o| o == e).unwrap();
                a[(r, r)] = -b;
                g[(r, e)] = amp;
                for &i in &exc.targets {
                    a[(n + i, r)] = 1.0 / model.mass[i];
                }
            }
            // Not a linear filter of white noise in this form: no exact moments here.
            Process::Lab(_) => return None,
        }
    }
    Some((a, g))
}

/// Exact stationary covariance of a linear model, or `None` if it is nonlinear or has no
/// stationary state.
pub fn stationary_covariance(model: &Model) -> Option<DMatrix<f64>> {
    let (a, g) = linear_system(model)?;
    let dim = a.nrows();
    let id = DMatrix::<f64>::identity(dim, dim);
    // vec(AΣ + ΣAᵀ) = (I⊗A + A⊗I) vec(Σ), column-major vec.
    let op = id.kronecker(&a) + a.kronecker(&id);
    let q = &g * g.transpose();
    let rhs = -DVector::from_column_slice(q.as_slice());
    let sol = op.lu().solve(&rhs)?;
    Some(DMatrix::from_column_slice(dim, dim, sol.as_slice()))
}

/// Exact stationary covariance of the discrete recursion that `scheme` applies to a linear
/// model under white noise with step `h`. `None` if the model is nonlinear or has filtered
/// excitations.
pub fn discrete_stationary_covariance(model: &Model, scheme: Scheme, h: f64) -> Option<DMatrix<f64>> {
    let (a, g) = linear_system(model)?;
    let n = model.masses();
    if a.nrows() != 2 * n {
        return None;
    }
    let dim = 2 * n;
    let id = DMatrix::<f64>::identity(dim, dim);
    // Velocity rows: v' = v + h (A_vx x + A_vv v) + G_v ΔW.
    let mut phi = &id + &a * h;
    let mut gam = &g * h.sqrt();
    if scheme == Scheme::Heun {
        // Y' = Y + h (A Y + A Ȳ)/2 + G ΔW with Ȳ = Y + h A Y + G ΔW.
        phi += &a * &a * (h * h / 2.0);
        gam = (&id + &a * (h / 2.0)) * gam;
    }
    if scheme == Scheme::SemiImplicit {
        // x' = x + h v' : x rows become [I, 0] + h · (velocity rows).
        for i in 0..n {
            for j in 0..dim {
                phi[(i, j)] = if i == j { 1.0 } else { 0.0 } + h * phi[(n + i, j)];
            }
            for e in 0..gam.ncols() {
                gam[(i, e)] = h * gam[(n + i, e)];
            }
        }
    }
    let q = &gam * gam.transpose();
    let big = DMatrix::<f64>::identity(dim * dim, dim * dim) - phi.kronecker(&phi);
    let sol = big.lu().solve(&DVector::from_column_slice(q.as_slice()))?;
    Some(DMatrix::from_column_slice(dim, dim, sol.as_slice()))
}

/// The stationary covariance of the samples the simulator logs from `scheme`'s recursion
/// ([`discrete_stationary_covariance`]): the semi-implicit scheme logs the displacement at
/// the step's midpoint, `x − h v / 2` (`sim::lanes::run_group`), the others the step's end.
pub fn sampled_stationary_covariance(model: &Model, scheme: Scheme, h: f64) -> Option<DMatrix<f64>> {
    let s = discrete_stationary_covariance(model, scheme, h)?;
    if scheme != Scheme::SemiImplicit {
        return Some(s);
    }
    let n = model.masses();
    let mut l = DMatrix::<f64>::identity(2 * n, 2 * n);
    for i in 0..n {
        l[(i, n + i)] = -h / 2.0;
    }
    Some(&l * s * l.transpose())
}

/// `E[Y^β]` of a zero-mean Gaussian with covariance `cov` (Isserlis recursion:
/// `E[y_j y^γ] = Σ_k cov_jk γ_k E[y^(γ − e_k)]`).
pub fn gaussian_moment(cov: &DMatrix<f64>, e: crate::ident::poly::Exponents) -> f64 {
    use crate::ident::poly::{exponent, var};
    if e == 0 {
        return 1.0;
    }
    let d = cov.nrows();
    let j = (0..d).find(|&j| exponent(e, j) > 0).expect("nonzero exponent");
    let gamma = e - var(j);
    (0..d)
        .filter(|&k| exponent(gamma, k) > 0)
        .map(|k| cov[(j, k)] * exponent(gamma, k) as f64 * gaussian_moment(cov, gamma - var(k)))
        .sum()
}

/// Moments `E[x^a]` (a = 0..=max) of the stationary displacement of the SDOF Duffing
/// oscillator with linear damping, density `∝ exp(−(2c/σ²)(k1 x²/2 + k3 x⁴/4))`, by
/// trapezoidal quadrature (spectrally accurate for this smooth, fast-decaying integrand).
pub fn duffing_displacement_moments(k1: f64, k3: f64, c: f64, sigma: f64, max: u32) -> Vec<f64> {
    let beta = 2.0 * c / (sigma * sigma);
    let u = |x: f64| beta * (k1 * x * x / 2.0 + k3 * x.powi(4) / 4.0);
    // Integrate out to where the weight is below e^-80.
    let mut l = 1.0;
    while u(l) < 80.0 {
        l *= 1.5;
    }
    let n = 200_000;
    let h = 2.0 * l / n as f64;
    let mut m = vec![0.0; max as usize + 1];
    for i in 0..=n {
        let x = -l + i as f64 * h;
        let w = (-u(x)).exp() * if i == 0 || i == n { 0.5 } else { 1.0 };
        let mut xp = 1.0;
        for mk in m.iter_mut() {
            *mk += w * xp;
            xp *= x;
        }
    }
    let z = m[0];
    m.iter().map(|v| v / z).collect()
}

/// The exact stationary marginals of one mass on one link to the ground with linear damping
/// `c` and any odd power spring `K`, driven by independent white forces of total intensity
/// `σ²`: `f(x, v) ∝ exp(−(2c/σ²)(m v²/2 + V(x)))`, `V' = K` (docs/theory.md §6, the Gibbs
/// case). The velocity is Gaussian with variance `σ²/(2cm)`; the displacement's density is
/// normalised by quadrature.
#[derive(Debug, Clone)]
pub struct GibbsMarginals {
    /// `2c/σ²`.
    beta: f64,
    mass: f64,
    /// `(p + 1, c_p / (p + 1))`: the potential's terms.
    potential: Vec<(i32, f64)>,
    /// `∫ exp(−β V) dx`.
    norm: f64,
}

impl GibbsMarginals {
    /// The exact marginals of `s`, when it is such a system (one mass, one link to the
    /// ground, damping `c·w` only, power springs whose potential confines, white forces);
    /// `None` otherwise.
    pub fn of(s: &Scenario) -> Option<GibbsMarginals> {
        use crate::model::Term;
        use crate::scenario::End;
        let [mass] = s.masses.as_slice() else { return None };
        let [link] = s.links.as_slice() else { return None };
        if !link.ends.contains(&End::Ground) || !link.ends.contains(&End::Mass(0)) || link.hysteresis.is_some() {
            return None;
        }
        let [(Term::Power(1), c)] = link.damping.terms.as_slice() else {
            return None;
        };
        let mut sigma2 = 0.0;
        for e in &s.excitations {
            match e.process {
                Process::White { sigma } if e.acts_on == [0] => sigma2 += sigma * sigma,
                _ => return None,
            }
        }
        let mut potential = Vec::new();
        for &(t, k) in &link.stiffness.terms {
            let p = t.power()?;
            potential.push((p as i32 + 1, k / (p + 1) as f64));
        }
        // Confining: the leading power odd with a positive coefficient (3.4).
        let &(top, lead) = potential.iter().max_by_key(|t| t.0)?;
        if *c <= 0.0 || sigma2 <= 0.0 || top % 2 != 0 || lead <= 0.0 || mass.value <= 0.0 {
            return None;
        }
        let mut g = GibbsMarginals {
            beta: 2.0 * c / sigma2,
            mass: mass.value,
            potential,
            norm: 1.0,
        };
        let (l, n) = (g.reach(), 100_000);
        let h = 2.0 * l / n as f64;
        g.norm = (0..=n)
            .map(|i| {
                let w = if i == 0 || i == n { 0.5 } else { 1.0 };
                w * (-g.beta * g.potential(-l + i as f64 * h)).exp()
            })
            .sum::<f64>()
            * h;
        g.norm.is_finite().then_some(g)
    }

    fn potential(&self, x: f64) -> f64 {
        self.potential.iter().map(|&(q, a)| a * x.powi(q)).sum()
    }

    /// How far out the displacement's weight stays above `e^−80`.
    fn reach(&self) -> f64 {
        let mut l = 1e-6;
        while self.beta * self.potential(l).min(self.potential(-l)) < 80.0 && l < 1e12 {
            l *= 1.5;
        }
        l
    }

    /// The displacement's density at `x`.
    pub fn displacement(&self, x: f64) -> f64 {
        (-self.beta * self.potential(x)).exp() / self.norm
    }

    /// The velocity's density at `v` (Gaussian, variance `σ²/(2cm)`).
    pub fn velocity(&self, v: f64) -> f64 {
        let var = 1.0 / (self.beta * self.mass);
        (-v * v / (2.0 * var)).exp() / (2.0 * std::f64::consts::PI * var).sqrt()
    }
}

/// The true value of every unknown of `problem`, from the truth of the scenario it was
/// built from (what a log of that scenario records).
pub fn true_values(s: &Scenario, problem: &crate::ident::Problem) -> Vec<f64> {
    let truth = crate::model::Truth::from_pairs(&s.truth()).expect("a scenario's own truth parses");
    problem.true_values(&truth)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gibbs_marginals_match_the_duffing_moments_and_the_velocity_variance() {
        let s = crate::scenario::Scenario::from_file(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/scenarios/sdof_duffing.toml"
        )))
        .expect("shipped scenario");
        let g = GibbsMarginals::of(&s).expect("a Gibbs system");
        let exact = duffing_displacement_moments(10.0, 20.0, 0.5, 1.0, 4);
        // Moments of the densities by a fine midpoint sum over ±10 (both weights are below
        // e^-40 beyond).
        let (n, l) = (200_000, 10.0);
        let h = 2.0 * l / n as f64;
        let m = |k: i32, f: &dyn Fn(f64) -> f64| -> f64 {
            (0..n)
                .map(|i| -l + (i as f64 + 0.5) * h)
                .map(|x| x.powi(k) * f(x) * h)
                .sum()
        };
        assert!((m(0, &|x| g.displacement(x)) - 1.0).abs() < 1e-9);
        assert!((m(2, &|x| g.displacement(x)) - exact[2]).abs() < 1e-9 * exact[2].max(1.0));
        assert!((m(4, &|x| g.displacement(x)) - exact[4]).abs() < 1e-9 * exact[4].max(1.0));
        // σ²/(2cm) = 1.
        let var = m(2, &|v| g.velocity(v));
        assert!((var - 1.0).abs() < 1e-9, "{var}");
        // A two-mass system, or nonlinear damping, has no such form here.
        let two = crate::scenario::Scenario::from_file(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/scenarios/duffing2dof.toml"
        )))
        .expect("shipped scenario");
        assert!(GibbsMarginals::of(&two).is_none());
    }
}
