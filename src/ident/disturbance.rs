//! The paper's successive approximations when part of the excitation is not measured
//! (section 4, (4.3)–(4.15)), and a variant of its single-mass step.
//!
//! The system is the paper's (4.3): `m1 ẍ1 + k1 (x1 − x2) = P_z`,
//! `m2 ẍ2 + K2(x2) + C2(ẋ2) − k1 (x1 − x2) = P2 + P_z`, with `P2` measured, `P_z` not, the
//! masses known and `k1`, `K2`, `C2` unknown.
//!
//! - Step 0 (4.4)–(4.7): identify everything ignoring `P_z`, in the state `(x1, ẋ1, x2, ẋ2)`
//!   with `P2` as white noise (the paper's assumption; a band-limited `P2` is taken at its
//!   low-frequency density, `σ = A/B`).
//! - Step s ≥ 1: subtracting the equations (4.8) removes `P_z`:
//!   `m2 ẍ2 + K2 + C2 = P3 = P2 + m1 ẍ1 + 2 k1 (x1 − x2)`. With `k1^(s−1)` in place of `k1`,
//!   `P3s` is known (4.9), and `K2`, `C2` are identified from the single-mass system (4.11)
//!   driven by it — by one of two [`SingleMass`] steps:
//!   - [`SingleMass::Spectral`], the paper's: the spectrum of `P3s` is fitted by the
//!     rational density (4.10), and the single-mass system is identified as driven by that
//!     filtered noise, in the state `(x2, ẋ2, ẍ2)` (4.12)–(4.15);
//!   - [`SingleMass::Force`], fpkbench's: `P3s` is a measured force, and the weak form of
//!     `(x2, ẋ2)` alone holds for it exactly — `E[ψ_x ẋ2 + ψ_v (P3 − K2 − C2)/m2] = 0` for
//!     any test function `ψ(x2, ẋ2)`, by stationarity of `E[ψ]`, whatever `P3`'s law (a
//!     white `P2` adds its Itô term `½ ψ_vv σ²/m2²`). The spectral step's model is not:
//!     `P3` contains the spring force `k1 (x1 − x2)`, fed back from the state, so it is not
//!     a filtered noise independent of `(x2, ẋ2)` and `(x2, ẋ2, P3)` is not Markov; its
//!     sequence drifts away from the truth even with no disturbance at all.
//!
//!   Then `K2`, `C2` go into the `k1` equation of (4.7), which gives `k1^(s)`.
//! - Beside the sequences, [`direct`]: in (4.8) `k1` is one more linear unknown (the gain
//!   of the input `x1 − x2`), so the measured-force weak form gives `k1`, `K2`, `C2` in one
//!   solve — no iteration, and no use of the `k1` equation of (4.7), which ignores `P_z`.
//! - Stop after a given number of steps, or when every coefficient changed by less than a
//!   tolerance (the paper's two rules); whether the successive differences decrease
//!   monotonically (the paper's convergence criterion) is reported either way.
//!
//! Every identification here is the weak form (the bench's default estimator) instead of
//! the paper's density grid. The spectrum of `P3s` for any `k1` comes from the spectra and
//! cross-spectrum of `P2 + m1 ẍ1` and `x1 − x2`, accumulated once; the moments of both
//! states, and of `(x2, ẋ2)` with those two forces, are accumulated once too, so each step
//! costs milliseconds.
//!
//! The procedure is specific to this structure — the subtraction (4.8) removes `P_z` only
//! because the same disturbance acts on both masses and `m1` has no other link — and
//! [`crate::scenario`] refuses `[identify.disturbance]` for any other. Scenarios may declare
//! unmeasured excitations anywhere; the ordinary methods simply never see them.

use super::data::StationaryData;
use super::poly::Poly;
use super::spectrum::{fit_ou, CrossWelch, OuFit};
use super::{identify_weak, Estimate, Filter, IdentError, Problem, Specification, Unknown};
use crate::model::{Characteristic, Coefficient, Columns, CompiledExcitation, Term, UnknownName};
use crate::scenario::{Disturbance, PaperStructure, Process, Scenario};
use serde::Serialize;

/// The specification step 0 and every `k1` update use: the logged system's unknowns,
/// the measured force white (`σ = A/B` when it is filtered; `p2` gives `A`, `B`).
pub fn step0_spec(s: &Scenario, st: &PaperStructure, p2: Option<Filter>) -> Specification {
    let mut w = Specification::from_scenario(s);
    if let Some(f) = p2 {
        w.model.excitations[st.measured].process = Process::White { sigma: f.a / f.b };
    }
    w
}

/// The specification of the bound: the identifier is given every disturbance as if it
/// were measured (filtered ones white at their fitted low-frequency density, as for `P2`).
pub fn bound_spec(s: &Scenario, st: &PaperStructure, filters: &[Filter]) -> Specification {
    let mut w = step0_spec(s, st, None);
    for e in &mut w.model.excitations {
        e.measured = true;
    }
    for f in filters {
        w.model.excitations[f.excitation].process = Process::White { sigma: f.a / f.b };
    }
    w
}

/// The single-mass system (4.11): `m2` on the ground link (its unknowns as in the logged
/// system), driven by one measured force `p3` of the given process.
pub fn driven_spec(s: &Scenario, st: &PaperStructure, process: Process) -> Specification {
    let full = Specification::from_scenario(s);
    let p3 = CompiledExcitation {
        process,
        targets: vec![0],
        measured: true,
    };
    let mut il = full
        .links
        .iter()
        .find(|l| l.link == st.ground)
        .expect("checked by the scenario")
        .clone();
    il.link = 0;
    Specification {
        model: full.model.single_mass(st.driven, st.ground, p3, "p3"),
        links: vec![il],
        unknown_masses: Vec::new(),
        unknown_intensities: Vec::new(),
        unknown_corners: Vec::new(),
    }
}

/// Which identification step s ≥ 1 uses for the single-mass system (4.11).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum SingleMass {
    /// The paper's (4.10)–(4.15): `P3s` as filtered noise of its fitted spectrum.
    Spectral,
    /// `P3s` as a measured force in the weak form of `(x2, ẋ2)`.
    Force,
}

impl SingleMass {
    pub fn name(self) -> &'static str {
        match self {
            SingleMass::Spectral => "spectral (the paper's (4.10)-(4.15))",
            SingleMass::Force => "measured force",
        }
    }
}

/// Whether the measured force `P2` is white (it is then noise with an Itô term in the
/// measured-force step; a filtered one is part of the measured input).
fn p2_is_white(s: &Scenario, st: &PaperStructure) -> bool {
    matches!(s.excitations[st.measured].process, Process::White { .. })
}

/// The row the measured-force step's moments are accumulated over, from a log row:
/// `(x2, ẋ2, q, r)` with `q = m1 ẍ1` (plus `P2` when it is filtered) and `r = x1 − x2`,
/// so that `P3 = q + 2 k1 r` (+ a white `P2`).
pub fn force_row(s: &Scenario, st: &PaperStructure, row: &[f64]) -> [f64; 4] {
    let log = Columns::new(s.masses.len(), s.excitations.len());
    let (x1, x2) = (log.x(st.free), log.x(st.driven));
    let mut q = s.masses[st.free].value * row[log.a(st.free)];
    if !p2_is_white(s, st) {
        q += row[log.force(st.measured)];
    }
    [row[x2], row[log.v(st.driven)], q, row[x1] - row[x2]]
}

/// The single-mass system (4.11) with `P3s = q + 2 k1 r` (see [`force_row`]) as a measured
/// input: the state `(x2, ẋ2)` and the inputs `q`, `r`; a white `P2` stays noise at its
/// declared intensity.
pub fn force_problem(s: &Scenario, st: &PaperStructure, k1: f64) -> Result<Problem, IdentError> {
    let sigma = match s.excitations[st.measured].process {
        Process::White { sigma } => sigma,
        // A lab signal is refused with the iterative procedure (scenario checks): 1 as for a
        // filtered force.
        Process::Filtered { .. } | Process::Lab(_) => 1.0,
    };
    let mut p = Problem::from_spec(&driven_spec(s, st, Process::White { sigma }), &[])?;
    if !p2_is_white(s, st) {
        p.white.clear();
    }
    if !p.atoms.is_empty() {
        return Err(IdentError::Unsupported(
            "terms without a polynomial form together with measured inputs are not supported".into(),
        ));
    }
    let (q, r) = (p.dim(), p.dim() + 1);
    p.inputs = 2;
    p.known_force[0].add(&Poly::linear(&[(q, 1.0), (r, 2.0 * k1)]), 1.0);
    p.columns = (0..4).collect();
    p.state_names
        .extend(["q = P2 + m1 a1".to_string(), "r = x1 - x2".to_string()]);
    Ok(p)
}

/// The subtracted equation (4.8) as one linear problem: [`force_problem`] with `k1` an
/// unknown too — the gain of the input `r = x1 − x2`, whose force is `2 k1 r` — so `k1`,
/// `K2`, `C2` come out of one solve, with no iteration and no use of the `k1` equation of
/// (4.7) (which ignores `P_z`). Unknown order: `K2`, `C2` as in [`force_problem`], then `k1`.
pub fn direct_problem(s: &Scenario, st: &PaperStructure) -> Result<Problem, IdentError> {
    let mut p = force_problem(s, st, 0.0)?;
    let r = p.dynamic_dim() + 1;
    let at = p.coefficient_count();
    p.unknowns.insert(at, Unknown::InputGain(1));
    p.unit_force.insert(at, vec![Poly::linear(&[(r, 2.0)])]);
    let coupling = Coefficient {
        link: st.coupling,
        kind: Characteristic::Stiffness,
        term: Term::Power(1),
    };
    p.names.insert(at, p.model.coefficient_name(coupling).into());
    p.start.insert(at, 0.0);
    Ok(p)
}

/// The one-step estimate of [`direct_problem`], in the unknown order of step 0 (`problem`).
pub fn direct(inp: &Inputs, problem: &Problem) -> Result<Estimate, IdentError> {
    let st = &inp.settings.structure;
    let dp = direct_problem(inp.scenario, st)?;
    let de = identify_weak(&dp, inp.force)?;
    let order: Vec<usize> = problem
        .unknowns
        .iter()
        .map(|u| match u {
            Unknown::Coefficient(c) if c.link == st.coupling => dp
                .unknowns
                .iter()
                .position(|x| matches!(x, Unknown::InputGain(_)))
                .expect("k1 is an input gain"),
            Unknown::Coefficient(c) => dp
                .unknowns
                .iter()
                .position(|x| matches!(x, Unknown::Coefficient(d) if d.kind == c.kind && d.term == c.term))
                .expect("same terms"),
            _ => unreachable!("step 0 has coefficients only"),
        })
        .collect();
    Ok(Estimate {
        names: problem.names.clone(),
        values: order.iter().map(|&k| de.values[k]).collect(),
        std_error: order.iter().map(|&k| de.std_error[k]).collect(),
        covariance: match de.covariance.is_empty() {
            true => Vec::new(),
            false => order
                .iter()
                .map(|&k| order.iter().map(|&l| de.covariance[k][l]).collect())
                .collect(),
        },
        ..de
    })
}

/// The bound of the measured-force sequence: the two-mass system with every force given as
/// measured, identified by the measured-force weak form of `(x1, ẋ1, x2, ẋ2)` — filtered
/// forces as measured inputs (their log columns), white ones as noise at their declared
/// intensity. Unlike [`bound_spec`]'s, it makes no white-noise approximation of a
/// band-limited force.
pub fn force_bound_problem(s: &Scenario, st: &PaperStructure) -> Result<Problem, IdentError> {
    let mut w = step0_spec(s, st, None);
    let filtered: Vec<usize> = (0..w.model.excitations.len())
        .filter(|&e| matches!(w.model.excitations[e].process, Process::Filtered { .. }))
        .collect();
    for e in &mut w.model.excitations {
        e.measured = true;
        if matches!(e.process, Process::Filtered { .. }) {
            e.process = Process::White { sigma: 1.0 };
        }
    }
    let p = Problem::from_spec(&w, &w.given_filters())?;
    super::measured_force::problem(&p, &filtered)
}

/// The `k1` equation of (4.7): the step-0 specification with `K2`, `C2` fixed at `values`
/// (step-0 unknown order) and only `k1` unknown.
fn k1_spec(step0: &Specification, st: &PaperStructure, problem: &Problem, values: &[f64]) -> Specification {
    let mut w = step0.clone();
    let mut k2 = Vec::new();
    let mut c2 = Vec::new();
    for (u, &v) in problem.unknowns.iter().zip(values) {
        if let Unknown::Coefficient(c) = u {
            if c.link == st.ground {
                match c.kind {
                    Characteristic::Stiffness => k2.push((c.term, v)),
                    Characteristic::Damping => c2.push((c.term, v)),
                }
            }
        }
    }
    let il = step0.links.iter().find(|l| l.link == st.ground).expect("checked");
    if il.stiffness.is_some() {
        w.model.set_characteristic(st.ground, Characteristic::Stiffness, &k2);
    }
    if il.damping.is_some() {
        w.model.set_characteristic(st.ground, Characteristic::Damping, &c2);
    }
    w.links.retain(|l| l.link == st.coupling);
    w
}

/// The data the procedure reads, accumulated in one pass over the samples.
pub struct Inputs<'a> {
    /// The scenario as logged (with `[identify.disturbance]`).
    pub scenario: &'a Scenario,
    pub settings: &'a Disturbance,
    /// `A`, `B` of the measured force when it is filtered (fitted or known).
    pub p2: Option<Filter>,
    /// Raw moments of `(x1, ẋ1, x2, ẋ2)` (every moment to the step-0 degree).
    pub white: &'a StationaryData,
    /// Raw moments of `(x2, ẋ2, ẍ2)` for [`driven_spec`]'s problem.
    pub driven: &'a StationaryData,
    /// Spectra of `q = P2 + m1 ẍ1` and `r = x1 − x2` and their cross-spectrum.
    pub p3: &'a CrossWelch,
    /// Moments of [`force_row`] for [`force_problem`].
    pub force: &'a StationaryData,
}

/// One step of the procedure.
#[derive(Debug, Clone, Serialize)]
pub struct Step {
    pub step: usize,
    /// Estimates in the order of [`Iteration::names`].
    pub values: Vec<f64>,
    /// Steps ≥ 1: `A`, `B` of (4.10) fitted to the spectrum of `P3s` (the spectral step),
    /// and the `k1` `P3s` used.
    pub p3_fit: Option<OuFit>,
    pub p3_k1: Option<f64>,
    /// Steps ≥ 1: change from the previous step per group (`k1`, `K2`, `C2`), each the
    /// largest change of one of its coefficients relative to the characteristic's typical
    /// force (`|Δθ_p|·E[z²]^(p/2)` over `√Σ (θ_p E[z²]^(p/2))²`; for one term `|Δθ|/|θ|`).
    pub changes: Vec<(String, f64)>,
    /// Smallest/largest singular value of the single-mass solve (steps ≥ 1) or of step 0.
    pub sv_ratio: f64,
}

/// Why a sequence stopped.
#[derive(Debug, Clone, PartialEq)]
pub enum StopReason {
    /// The step limit `max_steps` was reached.
    MaxSteps,
    /// Every coefficient changed by less than `tolerance` in the last step.
    Tolerance,
    /// A step could not be computed.
    Failed { step: usize, error: String },
}

impl std::fmt::Display for StopReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // `pad`, so that widths and alignment in format strings apply.
        match self {
            StopReason::MaxSteps => f.pad("max_steps"),
            StopReason::Tolerance => f.pad("tolerance"),
            StopReason::Failed { step, error } => f.pad(&format!("step {step} failed: {error}")),
        }
    }
}

impl Serialize for StopReason {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

/// The whole sequence.
#[derive(Debug, Clone, Serialize)]
pub struct Iteration {
    /// The single-mass step of steps ≥ 1.
    pub single_mass: SingleMass,
    pub names: Vec<UnknownName>,
    pub steps: Vec<Step>,
    /// `tolerance`, `max_steps`, or why a step failed.
    pub stopped_by: StopReason,
    pub max_steps: usize,
    pub tolerance: f64,
    /// The paper's criterion: every group's successive differences strictly decrease.
    pub monotone: bool,
    /// Monotone and stopped by the tolerance.
    pub converged: bool,
    #[serde(skip)]
    pub step0: Estimate,
    /// The step-0 problem (names and unknown order of every step).
    #[serde(skip)]
    pub problem: Problem,
}

impl Iteration {
    /// The last step's estimates.
    pub fn last(&self) -> &[f64] {
        &self.steps.last().expect("step 0 always exists").values
    }
}

/// Group of unknown `k` of the step-0 problem: `k1`, `K2` or `C2`.
fn group(problem: &Problem, st: &PaperStructure, k: usize) -> &'static str {
    match problem.unknowns[k] {
        Unknown::Coefficient(c) if c.link == st.coupling => "k1",
        Unknown::Coefficient(c) if c.kind == Characteristic::Stiffness => "K2",
        _ => "C2",
    }
}

/// Run the procedure. An error at step 0 (e.g. the unknowns are not identifiable) is
/// returned; a failure at a later step ends the sequence there and is reported in
/// `stopped_by`.
pub fn iterate(inp: &Inputs, single_mass: SingleMass) -> Result<Iteration, IdentError> {
    let s = inp.scenario;
    let st = &inp.settings.structure;
    let base = step0_spec(s, st, inp.p2);
    let problem = Problem::from_spec(&base, &base.given_filters())?;
    let step0 = identify_weak(&problem, inp.white)?;
    let typical = problem.typical(&inp.white.total());
    let groups: Vec<&str> = (0..problem.unknowns.len()).map(|k| group(&problem, st, k)).collect();
    let group_names: Vec<&str> = ["k1", "K2", "C2"].into_iter().filter(|g| groups.contains(g)).collect();
    let k1_index = groups.iter().position(|g| *g == "k1").expect("k1 is unknown");
    let mut steps = vec![Step {
        step: 0,
        values: step0.values.clone(),
        p3_fit: None,
        p3_k1: None,
        changes: Vec::new(),
        sv_ratio: step0.diagnostics.sv_ratio,
    }];
    let mut stopped_by = StopReason::MaxSteps;
    for step in 1..=inp.settings.max_steps {
        let prev = &steps[step - 1].values;
        let k1 = prev[k1_index];
        // (4.9): P3s = (P2 + m1 ẍ1) + 2 k1 (x1 − x2); (4.10)–(4.15) or the measured-force
        // weak form: K2, C2 of the single-mass system driven by P3s.
        let (fit, single) = match single_mass {
            SingleMass::Spectral => {
                let fit = fit_ou(&inp.p3.spectrum_of(2.0 * k1));
                let process = Process::Filtered { a: fit.a, b: fit.b };
                let filter = Filter {
                    excitation: 0,
                    a: fit.a,
                    b: fit.b,
                };
                (
                    Some(fit),
                    Problem::from_spec(&driven_spec(s, st, process), &[filter])
                        .and_then(|p| identify_weak(&p, inp.driven).map(|e| (p, e))),
                )
            }
            SingleMass::Force => (
                None,
                force_problem(s, st, k1).and_then(|p| identify_weak(&p, inp.force).map(|e| (p, e))),
            ),
        };
        let result = single.and_then(|(dp, de)| {
            let mut values = prev.clone();
            for (k, u) in problem.unknowns.iter().enumerate() {
                if let Unknown::Coefficient(c) = u {
                    if c.link == st.ground {
                        let j = dp
                            .unknowns
                            .iter()
                            .position(|x| matches!(x, Unknown::Coefficient(d) if d.kind == c.kind && d.term == c.term))
                            .expect("same powers");
                        values[k] = de.values[j];
                    }
                }
            }
            // One equation of (4.7): k1 with K2, C2 fixed.
            let kp = Problem::from_spec(&k1_spec(&base, st, &problem, &values), &base.given_filters())?;
            let ke = identify_weak(&kp, inp.white)?;
            values[k1_index] = ke.values[0];
            Ok((values, de.diagnostics.sv_ratio))
        });
        let (values, sv_ratio) = match result {
            Ok(v) => v,
            Err(e) => {
                stopped_by = StopReason::Failed {
                    step,
                    error: e.to_string(),
                };
                break;
            }
        };
        let changes: Vec<(String, f64)> = group_names
            .iter()
            .map(|g| {
                let members: Vec<usize> = (0..values.len()).filter(|&k| groups[k] == *g).collect();
                let size = members
                    .iter()
                    .map(|&k| (values[k] / typical[k]).powi(2))
                    .sum::<f64>()
                    .sqrt()
                    .max(1e-300);
                let change = members
                    .iter()
                    .map(|&k| ((values[k] - prev[k]) / typical[k]).abs() / size)
                    .fold(0.0, f64::max);
                (g.to_string(), change)
            })
            .collect();
        let done = changes.iter().all(|(_, c)| *c < inp.settings.tolerance);
        steps.push(Step {
            step,
            values,
            p3_fit: fit,
            p3_k1: Some(k1),
            changes,
            sv_ratio,
        });
        if done {
            stopped_by = StopReason::Tolerance;
            break;
        }
    }
    let monotone = (0..group_names.len()).all(|g| steps[1..].windows(2).all(|w| w[1].changes[g].1 < w[0].changes[g].1));
    Ok(Iteration {
        single_mass,
        names: problem.names.clone(),
        converged: monotone && stopped_by == StopReason::Tolerance,
        stopped_by,
        max_steps: inp.settings.max_steps,
        tolerance: inp.settings.tolerance,
        monotone,
        steps,
        step0,
        problem,
    })
}
