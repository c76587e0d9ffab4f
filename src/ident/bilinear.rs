//! An unknown filter corner `B` makes the augmented drift (3.22)–(3.28) bilinear: first the
//! coefficients of its distinct monomials (linear), then `B` and the physical
//! coefficients recovered from them by Gauss–Newton.

use super::poly::Poly;
use super::{
    data,
    estimate::{jackknife, std_errors},
    identify_weak, lsq, poly, weak, Estimate, IdentError, Problem, Unknown, INSEPARABLE_RATIO, WEAK_RATIO,
};
use crate::model::UnknownName;
use nalgebra::{DMatrix, DVector};

impl Problem {
    /// The bilinear problem (an unknown corner) in its linear form: one unknown per
    /// distinct monomial of the unknown part of each mass's drift. Returns that problem and
    /// the map `M` with `monomial coefficients = M · φ`, `φ` this problem's linear unknowns
    /// (coefficients, products `B·θ`, corners).
    pub fn monomial_form(&self) -> (Problem, DMatrix<f64>) {
        let rc = self.coefficient_count();
        let mut keys: Vec<(usize, poly::Exponents)> = Vec::new();
        for r in 0..rc {
            for i in 0..self.n {
                for &e in self.unit_force[r][i].terms.keys() {
                    if !keys.contains(&(i, e)) {
                        keys.push((i, e));
                    }
                }
            }
        }
        keys.sort();
        let mut map: DMatrix<f64> = DMatrix::zeros(keys.len(), rc);
        for r in 0..rc {
            for i in 0..self.n {
                for (&e, &c) in &self.unit_force[r][i].terms {
                    let k = keys.iter().position(|x| *x == (i, e)).expect("collected");
                    map[(k, r)] += c;
                }
            }
        }
        let mut out = self.clone();
        out.unknowns = keys.iter().map(|&(i, e)| Unknown::Monomial(i, e)).collect();
        out.unit_force = keys
            .iter()
            .map(|&(i, e)| {
                (0..self.n)
                    .map(|j| if j == i { Poly::monomial(e, 1.0) } else { Poly::zero() })
                    .collect()
            })
            .collect();
        out.start = vec![0.0; keys.len()];
        out.names = keys
            .iter()
            .map(|&(i, e)| {
                let term: Vec<String> = (0..self.dim())
                    .filter(|&j| poly::exponent(e, j) > 0)
                    .map(|j| match poly::exponent(e, j) {
                        1 => self.state_names[j].clone(),
                        p => format!("{}^{p}", self.state_names[j]),
                    })
                    .collect();
                UnknownName::Monomial {
                    mass: self.model.mass_names[i].clone(),
                    monomial: if term.is_empty() { "1".into() } else { term.join("*") },
                }
            })
            .collect();
        (out, map)
    }

    /// The physical unknowns of a bilinear problem: coefficients and corners (products
    /// dropped), in order, for reporting.
    pub fn physical(&self) -> Problem {
        let keep: Vec<usize> = (0..self.unknowns.len())
            .filter(|&k| !matches!(self.unknowns[k], Unknown::CornerProduct(..)))
            .collect();
        let mut out = self.clone();
        out.unknowns = keep.iter().map(|&k| self.unknowns[k]).collect();
        out.names = keep.iter().map(|&k| self.names[k].clone()).collect();
        out.start = keep.iter().map(|&k| self.start[k]).collect();
        out.unit_force = keep
            .iter()
            .filter(|&&k| k < self.unit_force.len())
            .map(|&k| self.unit_force[k].clone())
            .collect();
        out
    }

    /// `φ(p)`: the linear unknowns (coefficients, products, corners) from the physical
    /// ones `p` (coefficients and corners, in the order of [`Problem::physical`]).
    fn phi(&self, p: &[f64]) -> Vec<f64> {
        let phys = self.physical();
        let val = |u: Unknown| {
            phys.unknowns
                .iter()
                .position(|x| *x == u)
                .map(|k| p[k])
                .expect("physical unknown")
        };
        self.unknowns[..self.coefficient_count()]
            .iter()
            .map(|u| match *u {
                Unknown::CornerProduct(c, e) => val(Unknown::Coefficient(c)) * val(Unknown::Corner(e)),
                other => val(other),
            })
            .collect()
    }

    /// Physical coefficients and corners from monomial coefficients `mono` (Gauss–Newton
    /// on `M φ(p) = mono`), starting from `start_b` for every corner.
    pub fn recover_physical(&self, map: &DMatrix<f64>, mono: &[f64], start_b: f64) -> (Vec<f64>, lsq::Diagnostics) {
        let phys = self.physical();
        let np = phys.unknowns.len();
        let mut p: Vec<f64> = phys
            .unknowns
            .iter()
            .map(|u| if let Unknown::Corner(_) = u { start_b } else { 0.0 })
            .collect();
        let target = DVector::from_column_slice(mono);
        let scale: Vec<f64> = vec![1.0; np];
        let mut diag = None;
        for _ in 0..200 {
            let f = map * DVector::from_vec(self.phi(&p));
            let r = &target - &f;
            // Numerical Jacobian of M φ(p) (φ is bilinear, so central differences are exact
            // up to rounding).
            let mut j = DMatrix::zeros(mono.len(), np);
            for k in 0..np {
                let h = 1e-6 * p[k].abs().max(1e-3);
                let (mut up, mut dn) = (p.clone(), p.clone());
                up[k] += h;
                dn[k] -= h;
                let d = (map * DVector::from_vec(self.phi(&up)) - map * DVector::from_vec(self.phi(&dn))) / (2.0 * h);
                j.set_column(k, &d);
            }
            let (dx, d) = lsq::solve(&j, &r, &scale);
            diag = Some(d);
            let mut change: f64 = 0.0;
            for k in 0..np {
                p[k] += dx[k];
                change = change.max((dx[k] / p[k].abs().max(1e-12)).abs());
            }
            if change < 1e-14 {
                break;
            }
        }
        (p, diag.expect("iterated"))
    }
}

/// The weak-form estimate of a bilinear problem (an unknown corner): the monomial
/// coefficients by linear least squares, then the physical coefficients and corners by
/// Gauss–Newton; both are reported (the monomial ones in the facts).
pub fn identify_weak_bilinear(problem: &Problem, data: &data::StationaryData) -> Result<Estimate, IdentError> {
    if !problem.atoms.is_empty() {
        return Err(IdentError::Unsupported(
            "an unknown filter corner together with terms without a polynomial form is not supported".into(),
        ));
    }
    let (mono, map) = problem.monomial_form();
    let linear = identify_weak(&mono, data)?;
    let start_b = problem.filters.iter().map(|f| f.b).next().unwrap_or(1.0);
    let (values, recov) = problem.recover_physical(&map, &linear.values, start_b);
    let phys = problem.physical();
    if recov.rank < recov.cols || recov.sv_ratio < INSEPARABLE_RATIO {
        return Err(IdentError::NotIdentifiable {
            names: phys.names.clone(),
            direction: phys
                .names
                .iter()
                .cloned()
                .zip(recov.weakest_direction.iter().copied())
                .collect(),
            singular_values: recov.singular_values.clone(),
            sv_ratio: recov.sv_ratio,
            rank: recov.rank,
            cols: recov.cols,
            reason: "the physical coefficients cannot be recovered from the monomial coefficients".into(),
        });
    }
    // Standard errors: the jackknife, each replicate's monomial estimate recovered too.
    let replicates: Vec<Vec<f64>> = data
        .leave_one_out()
        .iter()
        .map(|b| {
            let pc = weak::pieces(&mono, b);
            let (m, _) = mono.solve(&pc, &mono.typical(b), None);
            problem.recover_physical(&map, &m, start_b).0
        })
        .collect();
    let covariance = jackknife(&replicates, values.len());
    let std_error = std_errors(&covariance, values.len());
    let mut facts = linear.facts.clone();
    for (n, v) in mono.names.iter().zip(&linear.values) {
        facts.push((format!("monomial {n}"), format!("{v:.6}")));
    }
    facts.push((
        "recovery".into(),
        format!("rank {}/{}, sv ratio {:.2e}", recov.rank, recov.cols, recov.sv_ratio),
    ));
    Ok(Estimate {
        method: "weak",
        names: phys.names.clone(),
        values,
        std_error,
        covariance,
        dof: replicates.len().saturating_sub(1),
        weakly_determined: linear.weakly_determined || recov.sv_ratio < WEAK_RATIO,
        diagnostics: linear.diagnostics,
        facts,
        warnings: linear.warnings,
    })
}
