//! Estimation with diagnostics: one least-squares solve per method, standard errors from
//! batches, and identifiability measured (rank, singular values, spread over batches)
//! before any number is reported (`docs/theory.md` §6).

use super::{data, lsq, moments, strong, weak, IdentError, Pieces, Problem};
use nalgebra::{DMatrix, DVector};

/// Singular-value ratio below which unknowns count as inseparable outright.
pub const INSEPARABLE_RATIO: f64 = 1e-8;

/// Below this ratio the estimates are weakly determined (a warning).
pub const WEAK_RATIO: f64 = 1e-3;

/// Below this ratio the batch spread decides whether the data separate the unknowns of the
/// weakest direction at all (a well-conditioned problem never counts as inseparable).
pub const SPREAD_CHECK_RATIO: f64 = 1e-2;

/// One method's estimate of the unknowns.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Estimate {
    pub method: &'static str,
    pub names: Vec<String>,
    pub values: Vec<f64>,
    /// Standard errors from batch means (independent time windows); NaN with one batch.
    pub std_error: Vec<f64>,
    pub diagnostics: lsq::Diagnostics,
    /// `sv_ratio` below [`WEAK_RATIO`]: the estimates are weakly determined.
    pub weakly_determined: bool,
    /// Method-specific facts (grid size, occupied cells, test functions, …).
    pub facts: Vec<(String, String)>,
}

/// Solve `pieces` built from all data and from each batch (with the equations weighted by
/// `weight`, if given); decide identifiability.
pub fn estimate(
    problem: &Problem,
    method: &'static str,
    total: &Pieces,
    batches: &[Pieces],
    typical: &[f64],
    facts: Vec<(String, String)>,
    weight: Option<&DMatrix<f64>>,
) -> Result<Estimate, IdentError> {
    total.check_finite(method)?;
    let (values, diag) = problem.solve(total, typical, weight);
    let per_batch: Vec<Vec<f64>> = batches.iter().map(|b| problem.solve(b, typical, weight).0).collect();
    let nu = values.len();
    let std_error: Vec<f64> = (0..nu)
        .map(|k| {
            let nb = per_batch.len() as f64;
            if per_batch.len() < 2 {
                return f64::NAN;
            }
            let mean = per_batch.iter().map(|b| b[k]).sum::<f64>() / nb;
            let var = per_batch.iter().map(|b| (b[k] - mean).powi(2)).sum::<f64>() / (nb - 1.0);
            (var / nb).sqrt()
        })
        .collect();
    let involved: Vec<usize> = (0..nu).filter(|&k| diag.weakest_direction[k].abs() >= 0.1).collect();
    let inseparable = |reason: String| IdentError::NotIdentifiable {
        names: involved.iter().map(|&k| problem.names[k].clone()).collect(),
        direction: involved
            .iter()
            .map(|&k| (problem.names[k].clone(), diag.weakest_direction[k]))
            .collect(),
        singular_values: diag.singular_values.clone(),
        sv_ratio: diag.sv_ratio,
        rank: diag.rank,
        cols: diag.cols,
        reason,
    };
    if diag.rank < diag.cols || diag.sv_ratio < INSEPARABLE_RATIO {
        return Err(inseparable(format!(
            "numerical rank {} < {} unknowns",
            diag.rank, diag.cols
        )));
    }
    if per_batch.len() >= 2 && diag.sv_ratio < SPREAD_CHECK_RATIO {
        // Per-batch scatter of the unknowns along the weakest direction, relative to the
        // scale each is judged against (a coefficient: its characteristic's typical force;
        // never the estimate itself, which is 0 for a term the truth does not have).
        let nb = per_batch.len() as f64;
        let scales = problem.judging_scales(&values, typical);
        let worst = involved
            .iter()
            .map(|&k| std_error[k] * nb.sqrt() / scales[k].max(1e-300))
            .fold(0.0f64, f64::max);
        if worst > 0.5 {
            return Err(inseparable(format!(
                "batch estimates along the weakest direction scatter by {:.0} % of the scale they \
                 are judged against (a coefficient: its characteristic's typical force)",
                100.0 * worst
            )));
        }
    }
    Ok(Estimate {
        method,
        names: problem.names.clone(),
        values,
        std_error,
        weakly_determined: diag.sv_ratio < WEAK_RATIO,
        diagnostics: diag,
        facts,
    })
}

/// The weak-form estimate from streamed data.
pub fn identify_weak(problem: &Problem, data: &data::StationaryData) -> Result<Estimate, IdentError> {
    let total = data.total();
    if total.count < 10 * problem.unknowns.len() as u64 {
        return Err(IdentError::TooLittleData(format!(
            "{} samples for {} unknowns",
            total.count,
            problem.unknowns.len()
        )));
    }
    let typical = problem.typical(&total);
    let map = weak::PiecesMap::new(problem, &total);
    let pc = map.apply(&total);
    let batches: Vec<Pieces> = data
        .batches()
        .iter()
        .filter(|b| b.count > 0)
        .map(|b| map.apply(b))
        .collect();
    // The equations' covariance from the fine batches' residuals at a first estimate.
    let fine: Vec<&moments::RawMoments> = data.fine.iter().filter(|b| b.count > 0).collect();
    let fine_pieces: Vec<Pieces> = fine.iter().map(|b| map.apply(b)).collect();
    let counts: Vec<u64> = fine.iter().map(|b| b.count).collect();
    // Two-step: the covariance at the unweighted estimate (iterating it changed nothing
    // measurable on silentblock).
    let (first, _) = problem.solve(&pc, &typical, None);
    let residuals: Vec<DVector<f64>> = fine_pieces.iter().map(|b| problem.residual(b, &first).0).collect();
    let weight = weak::weighting(&residuals, &counts);
    let mut facts = vec![
        (
            "test functions".into(),
            format!("{} monomials of degree 1..={}", pc.rows, weak::test_degree(problem)),
        ),
        (
            "moments".into(),
            format!(
                "{} raw moments of degree <= {}",
                total.monomials.len() - 1,
                weak::moment_degree(problem)
            ),
        ),
        ("batches".into(), batches.len().to_string()),
    ];
    facts.push((
        "weighting".into(),
        match weight {
            Some(_) => format!(
                "inverse covariance of the equations from {} batches (shrinkage {:.3})",
                fine.len(),
                pc.rows as f64 / fine.len() as f64
            ),
            None => format!(
                "none (natural scales): {} batches are too few for {} equations",
                fine.len(),
                pc.rows
            ),
        },
    ));
    estimate(problem, "weak", &pc, &batches, &typical, facts, weight.as_ref())
}

/// The strong-form estimate (the paper's procedure) from a filled density grid; with
/// `marginals`, from the product of its marginals (3.21).
pub fn identify_strong(
    problem: &Problem,
    grid: &strong::DensityGrid,
    marginals: bool,
    typical: &[f64],
) -> Result<Estimate, IdentError> {
    let (pc, usable) = grid.pieces(problem, marginals);
    if usable < 2 * problem.unknowns.len() {
        return Err(IdentError::TooLittleData(format!(
            "only {usable} usable grid cells for {} unknowns (grid {} bins per dimension, minimum count {}); use more samples, fewer bins or the weak form",
            problem.unknowns.len(), grid.options.bins, grid.options.min_count
        )));
    }
    let cells = grid.counts.len();
    let facts = vec![
        (
            "grid".into(),
            format!(
                "{} bins^{} = {} cells over mean ± {} std",
                grid.options.bins, grid.dim, cells, grid.options.span_std
            ),
        ),
        (
            "occupied cells".into(),
            format!(
                "{} ({:.1} %)",
                grid.occupied(),
                100.0 * grid.occupied() as f64 / cells as f64
            ),
        ),
        (
            "usable cells".into(),
            format!(
                "{usable} (minimum count {} in every stencil cell)",
                grid.options.min_count
            ),
        ),
        ("samples in box".into(), format!("{} of {}", grid.inside, grid.total)),
        (
            "density".into(),
            if marginals {
                "product of 1-D marginals (3.21)".into()
            } else {
                "joint histogram".to_string()
            },
        ),
    ];
    estimate(
        problem,
        if marginals { "strong-marginals" } else { "strong" },
        &pc,
        &[],
        typical,
        facts,
        None,
    )
}
