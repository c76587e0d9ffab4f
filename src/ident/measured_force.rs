//! The weak form with the measured forces as inputs (docs/methods.md, "The weak form with
//! the measured force"). The FPK equation knows a force as a process of its own — white,
//! or first-order filtered (3.20) — whose spectrum must be modelled; a lab's multisine or
//! band-limited noise is neither. A force that is *measured* need not be modelled: for a
//! test function `ψ(x, v)` of the masses' state alone, stationarity gives
//!
//! `E[Σ_i v_i ∂ψ/∂x_i + Σ_i ∂ψ/∂v_i (F_i(t) − K_i(x) − C_i(v)) / m_i] = 0`
//!
//! whatever the force's process is: the force's own dynamics act on the force's variables,
//! of which `ψ` does not depend (the paper's measured-force step (4.11) is this equation
//! for one mass). It is linear in the coefficients over `m_i`, and the measured force
//! enters through the moments `E[∂ψ/∂v_i · F_i]` with the known factor `1/m_i`, so it fixes
//! the coefficients' scale. It does not fix a mass left unknown against the stiffness:
//! one-time moments of a linear system give only `k E[x²] − m E[v²] = E[xF]` (rank
//! deficient), of a nonlinear one weakly (docs/methods.md, "The weak form with the measured
//! force").
//!
//! It holds for a force whose samples are its values at the sample instants, band-limited
//! well inside the sampling's band (a multisine, band-limited noise, a filtered force); a
//! white force is no function of time, and its samples (an fpkbench log keeps the mean over
//! the interval) are not what multiplies the state in the equation: white forces stay
//! noise, as in the weak form.

use super::poly::Poly;
use super::{IdentError, Layout, Problem, Unknown};

/// The problem of `mechanical` (the white-noise layout, no measured inputs yet) with the
/// forces of the excitations `inputs` entering every mass they act on as measured inputs
/// (their log columns `p_<name>`) instead of as noise sources.
pub fn problem(mechanical: &Problem, inputs: &[usize]) -> Result<Problem, IdentError> {
    if mechanical.layout != Layout::White || mechanical.inputs > 0 {
        return Err(IdentError::Unsupported(
            "the measured forces enter the white-noise layout of the masses' state only".into(),
        ));
    }
    if !mechanical.atoms.is_empty() {
        return Err(IdentError::NotApplicable(
            "terms without a polynomial form together with measured forces as inputs are not supported yet: \
             the weak form reads them under white or filtered forces"
                .into(),
        ));
    }
    let model = &mechanical.model;
    for &e in inputs {
        if !model.excitations[e].measured {
            return Err(IdentError::NotApplicable(format!(
                "the force of `{}` is not measured",
                model.excitation_names[e]
            )));
        }
        if mechanical.unknowns.contains(&Unknown::Intensity(e)) {
            return Err(IdentError::NotApplicable(format!(
                "the intensity of `{}` is an unknown, and a measured force read as an input has none",
                model.excitation_names[e]
            )));
        }
    }
    let mut p = mechanical.clone();
    // One noise source per measured excitation, in their order (`Problem::build`).
    let measured = (0..model.excitations.len()).filter(|&e| model.excitations[e].measured);
    p.white = measured
        .zip(std::mem::take(&mut p.white))
        .filter(|(e, _)| !inputs.contains(e))
        .map(|(_, source)| source)
        .collect();
    let log = model.columns();
    let first = p.dim();
    for (k, &e) in inputs.iter().enumerate() {
        for &i in &model.excitations[e].targets {
            p.known_force[i].add(&Poly::linear(&[(first + k, 1.0)]), 1.0);
        }
        p.columns.push(log.force(e));
        p.state_names.push(format!("p_{}", model.excitation_names[e]));
    }
    p.inputs = inputs.len();
    Ok(p)
}
