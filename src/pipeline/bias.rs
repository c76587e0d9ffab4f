//! The integrator's bias on the estimates (docs/methods.md, "The integrator's bias"): the
//! scenario simulated again at half its step on the same Brownian paths
//! ([`Input::refined_simulation`]) and identified the same way; with the scheme's weak
//! order `p` (1 for explicit and semi-implicit Euler, 2 for Heun), Richardson's estimate
//! of the bias at the run's step is `(θ_h − θ_h/2) / (1 − 2^−p)`: `2·(θ_h − θ_h/2)` for
//! the Euler schemes. The pair shares its noise, so the difference holds
//! the integrator's error without the sampling error of either run. A parameter whose
//! bias exceeds a quarter of its standard error is named: there the bench grades its
//! integrator as much as the estimator.

use super::{identify, Input, Options, PipelineError};
use crate::report::{IntegratorBias, MethodBias, ParameterBias, Report};
use crate::scenario::Scenario;

pub use crate::report::BIAS_SHARE;

/// The bias of every estimate of `report` (identified from `scenario`'s simulation with
/// `options`), from the refined run's identification.
pub fn integrator_bias(
    scenario: &Scenario,
    options: &Options,
    report: &Report,
) -> Result<IntegratorBias, PipelineError> {
    let refined_options = Options {
        validate: false,
        plots: false,
        methods: report
            .methods
            .iter()
            .filter_map(|m| match &m.method {
                crate::scenario::ReportMethod::Estimator(x) => Some(*x),
                _ => None,
            })
            .collect(),
        ..options.clone()
    };
    let refined = identify(&Input::refined_simulation(scenario.clone()), &refined_options)?;
    let order = scenario.simulation.scheme.weak_order();
    let factor = 1.0 / (1.0 - 2f64.powi(-(order as i32)));
    let mut methods = Vec::new();
    for m in &report.methods {
        let Some(r) = refined.methods.iter().find(|r| r.method == m.method) else {
            continue;
        };
        let parameters: Vec<ParameterBias> = m
            .parameters
            .iter()
            .filter_map(|p| {
                let q = r.parameters.iter().find(|q| q.name == p.name)?;
                let bias = factor * (p.estimate - q.estimate);
                (bias.is_finite()).then(|| ParameterBias {
                    name: p.name.to_string(),
                    estimate: p.estimate,
                    refined_estimate: q.estimate,
                    bias,
                    std_error: p.std_error,
                    exceeds: bias.abs() > BIAS_SHARE * p.std_error,
                })
            })
            .collect();
        if !parameters.is_empty() {
            methods.push(MethodBias {
                method: m.method.clone(),
                parameters,
            });
        }
    }
    let sim = &scenario.simulation;
    Ok(IntegratorBias {
        step_s: sim.dt / sim.substeps as f64,
        order,
        methods,
    })
}
