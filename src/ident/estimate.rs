//! Estimation with diagnostics: one least-squares solve per method, standard errors from
//! batches, and identifiability measured (rank, singular values, spread over batches)
//! before any number is reported (`docs/theory.md` §6).

use super::{data, lsq, moments, strong_histogram, strong_kernel, weak, IdentError, Pieces, Problem};
use crate::model::UnknownName;
use nalgebra::DMatrix;
use rayon::prelude::*;

/// Singular-value ratio below which unknowns count as inseparable outright.
pub const INSEPARABLE_RATIO: f64 = 1e-8;

/// Usable strong-form cells per unknown below which the estimate is flagged: measured on
/// duffing2dof, where ≈ 2 per unknown gave errors of 800–1500 % (docs/methods.md).
pub const USABLE_CELLS_PER_UNKNOWN: f64 = 10.0;

/// Below this ratio the estimates are weakly determined (a warning).
pub const WEAK_RATIO: f64 = 1e-3;

/// Below this ratio the batch spread decides whether the data separate the unknowns of the
/// weakest direction at all (a well-conditioned problem never counts as inseparable).
pub const SPREAD_CHECK_RATIO: f64 = 1e-2;

/// One method's estimate of the unknowns.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Estimate {
    pub method: &'static str,
    pub names: Vec<UnknownName>,
    pub values: Vec<f64>,
    /// Standard errors by the delete-one-batch jackknife ([`jackknife`]); NaN without
    /// batches.
    pub std_error: Vec<f64>,
    /// The jackknife's covariance of the estimates (empty without batches).
    pub covariance: Vec<Vec<f64>>,
    /// Degrees of freedom of the standard errors (batches − 1): intervals use Student's t.
    pub dof: usize,
    pub diagnostics: lsq::Diagnostics,
    /// `sv_ratio` below [`WEAK_RATIO`]: the estimates are weakly determined.
    pub weakly_determined: bool,
    /// Method-specific facts (grid size, occupied cells, test functions, …).
    pub facts: Vec<(String, String)>,
    /// What makes the estimate less reliable than its standard errors say.
    pub warnings: Vec<String>,
}

/// The delete-one jackknife's covariance of the estimates from `replicates` (each from all
/// data but one of `B` batches): `(B−1)/B Σ (θ₋ᵦ − θ̄)(θ₋ᵦ − θ̄)ᵀ`; empty with fewer than
/// two replicates. It follows the estimator's nonlinearity (ratios, Gauss–Newton) from
/// nearly all the data, where batch-by-batch solves would each see `1/B` of it.
pub fn jackknife(replicates: &[Vec<f64>], unknowns: usize) -> Vec<Vec<f64>> {
    if replicates.len() < 2 {
        return Vec::new();
    }
    let nb = replicates.len() as f64;
    let mean: Vec<f64> = (0..unknowns)
        .map(|k| replicates.iter().map(|b| b[k]).sum::<f64>() / nb)
        .collect();
    (0..unknowns)
        .map(|k| {
            (0..unknowns)
                .map(|l| {
                    (nb - 1.0) / nb
                        * replicates
                            .iter()
                            .map(|b| (b[k] - mean[k]) * (b[l] - mean[l]))
                            .sum::<f64>()
                })
                .collect()
        })
        .collect()
}

/// Standard errors from a covariance (NaN without one).
pub fn std_errors(covariance: &[Vec<f64>], unknowns: usize) -> Vec<f64> {
    (0..unknowns)
        .map(|k| covariance.get(k).map_or(f64::NAN, |row| row[k].sqrt()))
        .collect()
}

/// The batches the spread check compares (docs/theory.md §6): its threshold was set with
/// estimates from one eighth of the record each.
const SPREAD_BATCHES: f64 = 8.0;

/// The solution from each jackknife replicate's pieces, in order; each replicate's pieces
/// are dropped once solved (a thousand replicates' pieces need not be held at once).
/// Replicates holding non-finite numbers are refused as [`Pieces::check_finite`] refuses
/// the whole record's.
pub fn solve_replicates(
    problem: &Problem,
    method: &str,
    replicates: impl IntoParallelIterator<Item = Pieces, Iter: IndexedParallelIterator>,
    typical: &[f64],
    weight: Option<&DMatrix<f64>>,
) -> Result<Vec<Vec<f64>>, IdentError> {
    replicates
        .into_par_iter()
        .map(|b| {
            b.check_finite(method)?;
            Ok(problem.solve_values(&b, typical, weight))
        })
        .collect()
}

/// Solve `pieces` built from all data, and take `per_replicate`, the solutions from each
/// jackknife replicate (all data but one batch: `solve_replicates`); with the equations
/// weighted by `weight`, if given; decide identifiability.
pub fn estimate(
    problem: &Problem,
    method: &'static str,
    total: &Pieces,
    per_replicate: &[Vec<f64>],
    typical: &[f64],
    facts: Vec<(String, String)>,
    weight: Option<&DMatrix<f64>>,
) -> Result<Estimate, IdentError> {
    total.check_finite(method)?;
    let (values, diag) = problem.solve(total, typical, weight);
    let nu = values.len();
    let covariance = jackknife(per_replicate, nu);
    let std_error = std_errors(&covariance, nu);
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
    if per_replicate.len() >= 2 && diag.sv_ratio < SPREAD_CHECK_RATIO {
        // The scatter of estimates from an eighth of the record each (the standard error
        // times √8) of the unknowns along the weakest direction, relative to the scale each
        // is judged against (a coefficient: its characteristic's typical force; never the
        // estimate itself, which is 0 for a term the truth does not have).
        let scales = problem.judging_scales(&values, typical);
        let worst = involved
            .iter()
            .map(|&k| std_error[k] * SPREAD_BATCHES.sqrt() / scales[k].max(1e-300))
            .fold(0.0f64, f64::max);
        if worst > 0.5 {
            // A replicate that ran away scatters by orders of magnitude: said as a factor.
            let by = match worst < 10.0 {
                true => format!("{:.0} % of", 100.0 * worst),
                false => format!("{worst:.1e} times"),
            };
            return Err(inseparable(format!(
                "batch estimates along the weakest direction scatter by {by} the scale they \
                 are judged against (a coefficient: its characteristic's typical force)"
            )));
        }
    }
    Ok(Estimate {
        method,
        names: problem.names.clone(),
        values,
        std_error,
        covariance,
        dof: per_replicate.len().saturating_sub(1),
        weakly_determined: diag.sv_ratio < WEAK_RATIO,
        diagnostics: diag,
        facts,
        warnings: Vec::new(),
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
    let replicates: Vec<Pieces> = data.leave_one_out().iter().map(|b| map.apply(b)).collect();
    let (weight, fine) = efficient_weight(problem, data, &map, &pc, &typical);
    let replicates = solve_replicates(problem, "weak", replicates, &typical, weight.as_ref())?;
    let mut facts = vec![
        (
            "test functions".into(),
            match weak::local_tests(problem).len() {
                0 => format!("{} monomials of degree 1..={}", pc.rows, weak::test_degree(problem)),
                local => format!(
                    "{} monomials of degree 1..={} and {local} local ones on the hinges",
                    pc.rows - local,
                    weak::test_degree(problem)
                ),
            },
        ),
        ("moments".into(), {
            // The moments this problem's equations can use: the accumulator may be
            // shared with a problem of higher degree (a `[identify.compare]` row).
            let d = weak::moment_degree(problem);
            let n = total
                .monomials()
                .iter()
                .filter(|&&e| (1..=d).contains(&super::poly::degree(e)))
                .count();
            format!("{n} raw moments of degree <= {d}")
        }),
        (
            "standard errors".into(),
            format!("delete-one jackknife over {} batches", replicates.len()),
        ),
    ];
    facts.push((
        "weighting".into(),
        match weight {
            Some(_) => format!(
                "inverse covariance of the equations from {} batches (shrinkage {:.3})",
                fine,
                pc.rows as f64 / fine as f64
            ),
            None => format!(
                "none (natural scales): {} batches are too few for {} equations",
                fine, pc.rows
            ),
        },
    ));
    estimate(problem, "weak", &pc, &replicates, &typical, facts, weight.as_ref())
}

/// The weak form's equation weighting (the efficient generalised method of moments,
/// [`weak::weighting`]) from the spread of the fine batches' residuals at the unweighted
/// estimate of `pc`, the whole record's pieces through `map`; with the number of fine
/// batches it used. Two-step: the covariance at the unweighted estimate (iterating it
/// changed nothing measurable on silentblock). Each batch's moments go straight to its
/// residual through one sparse map, in parallel: a thousand equations' pieces for
/// thousands of batches would not fit in memory.
pub(crate) fn efficient_weight(
    problem: &Problem,
    data: &data::StationaryData,
    map: &weak::PiecesMap,
    pc: &Pieces,
    typical: &[f64],
) -> (Option<DMatrix<f64>>, usize) {
    let fine: Vec<&moments::RawMoments> = data.fine.iter().filter(|b| b.count > 0).collect();
    let counts: Vec<u64> = fine.iter().map(|b| b.count).collect();
    let (first, _) = problem.solve(pc, typical, None);
    let rmap = map.residual_map(problem, first.as_slice());
    let rows = rmap.rows();
    let mut flat = vec![0.0; rows * fine.len()];
    flat.par_chunks_mut(rows.max(1))
        .zip(fine.par_iter())
        .for_each(|(out, b)| rmap.apply_into(b, out));
    let residuals = DMatrix::from_vec(rows, fine.len(), flat);
    (weak::weighting(residuals, &counts), fine.len())
}

/// The strong-form estimate (the paper's procedure) from a filled density grid; with
/// `marginals`, from the product of its marginals (3.21).
pub fn identify_strong(
    problem: &Problem,
    grid: &strong_histogram::DensityGrid,
    marginals: bool,
    typical: &[f64],
) -> Result<Estimate, IdentError> {
    let (pc, usable, stencils) = grid.pieces_with(problem, marginals, None);
    if usable < 2 * problem.unknowns.len() {
        return Err(IdentError::TooLittleData(format!(
            "only {usable} usable grid cells for {} unknowns (grid {} bins per dimension, minimum count {}); use more samples, fewer bins or the weak form",
            problem.unknowns.len(), grid.options.bins, grid.options.min_count
        )));
    }
    // Standard errors: the jackknife over the weak form's batches (the grid without each).
    let method = if marginals { "strong-marginals" } else { "strong" };
    let replicates: Vec<Vec<f64>> = {
        let grids: Vec<strong_histogram::DensityGrid> = grid.leave_one_out().collect();
        grids
            .par_iter()
            .map(|g| {
                let pieces = g.pieces_with(problem, marginals, Some(&stencils)).0;
                pieces.check_finite(method)?;
                Ok(problem.solve_values(&pieces, typical, None))
            })
            .collect::<Result<_, IdentError>>()?
    };
    let cells = grid.counts.len();
    let per_unknown = usable as f64 / problem.unknowns.len() as f64;
    let mut warnings = Vec::new();
    if per_unknown < USABLE_CELLS_PER_UNKNOWN {
        warnings.push(format!(
            "only {usable} usable cells for {} unknowns ({per_unknown:.1} per unknown, fewer than {USABLE_CELLS_PER_UNKNOWN}): \
             the density's differences are dominated by histogram noise; use more samples, fewer bins or the weak form",
            problem.unknowns.len()
        ));
    }
    let default_bins = strong_histogram::GridOptions::auto(grid.dim, u64::MAX).bins;
    if grid.options.bins < default_bins {
        warnings.push(format!(
            "the grid is coarser than the default ({} bins per dimension against {default_bins}) for want of samples: \
             the central differences' bias grows with the bin width squared (duffing2dof with 1e5 samples, 8 bins: \
             worst errors of 80–145 % over 3 seeds); trust the weak form here",
            grid.options.bins
        ));
    }
    let mut facts = vec![
        (
            "standard errors".into(),
            match replicates.len() {
                0 => "none: the grid is too large to keep per-batch counts".to_string(),
                b => format!("delete-one jackknife over {b} batches"),
            },
        ),
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
                grid.occupied(marginals),
                100.0 * grid.occupied(marginals) as f64 / cells as f64
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
    facts.sort();
    let mut e = estimate(problem, method, &pc, &replicates, typical, facts, None)?;
    e.warnings = warnings;
    Ok(e)
}

/// The strong-form estimate from kernel estimates of the density and its fluxes
/// ([`strong_kernel`], the default `strong`).
pub fn identify_kernel(
    problem: &Problem,
    lattice: &strong_kernel::FluxLattice,
    typical: &[f64],
) -> Result<Estimate, IdentError> {
    let (pc, replicates, rows) = lattice.pieces(problem);
    if rows < 2 * problem.unknowns.len() {
        return Err(IdentError::TooLittleData(format!(
            "only {rows} lattice nodes hold {} effective samples under their kernel, for {} unknowns; use more samples, \
             a wider --smoothing or the weak form",
            lattice.options.min_count,
            problem.unknowns.len()
        )));
    }
    let replicates = solve_replicates(problem, "strong", replicates, typical, None)?;
    let o = lattice.options;
    let mut facts = vec![
        (
            "standard errors".into(),
            match replicates.len() {
                0 => "none: the lattice is too large to keep the jackknife's groups".to_string(),
                b => format!("delete-one jackknife over {b} groups of batches"),
            },
        ),
        (
            "density".into(),
            format!(
                "Gaussian kernel of {:.3} std on the density and on every flux (docs/methods.md)",
                o.smoothing
            ),
        ),
        (
            "lattice".into(),
            format!(
                "{} nodes^{} = {} over mean ± {:.2} std, {} residual nodes (>= {} effective samples each)",
                lattice.nodes,
                lattice.dim,
                lattice.nodes.pow(lattice.dim as u32),
                (lattice.nodes / 2) as f64 * lattice.h[0] / lattice.s[0] * o.smoothing,
                rows,
                o.min_count
            ),
        ),
        (
            "samples in lattice".into(),
            format!("{} of {}", lattice.inside, lattice.total),
        ),
    ];
    facts.sort();
    estimate(problem, "strong", &pc, &replicates, typical, facts, None)
}
