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
    identify_weak_with_levels(problem, data, &[])
}

/// [`identify_weak`] with forces whose level was measured from the same records:
/// `levels` gives, per such force, its noise source in `problem.white` and its level in
/// each jackknife replicate of `data` (without that replicate's records), and each
/// replicate reads the force at its own level as it reads its own moments. A level held
/// from all the records leaves its scatter out of the standard errors: the damping moves
/// with the level's square (docs/results.md, "Standard errors from whole records").
/// Levels that do not come per replicate are held.
pub fn identify_weak_with_levels(
    problem: &Problem,
    data: &data::StationaryData,
    levels: &[(usize, Vec<f64>)],
) -> Result<Estimate, IdentError> {
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
    let left_out = data.leave_one_out();
    let own = at_own_levels(problem, &total, levels, left_out.len());
    let replicates: Vec<Pieces> = left_out
        .iter()
        .enumerate()
        .map(|(b, m)| own.get(b).map_or(&map, |o| &o.1).apply(m))
        .collect();
    let (weight, fine) = efficient_weight(problem, data, &map, &pc, &typical);
    let work = replicates.len() as f64 * (pc.rows as f64).powi(2) * (fine + pc.rows) as f64;
    let affordable = work <= REWEIGHING_WORK;
    let reweighed = match weight.is_some() && affordable {
        true => reweighed_replicates(
            (problem, &map, &own),
            replicates.clone(),
            &data.leave_one_out_fine(),
            &typical,
        ),
        false => None,
    };
    let weighting_per_replicate = reweighed.is_some();
    let replicates = match reweighed {
        Some(r) => r?,
        None => solve_replicates(problem, "weak", replicates, &typical, weight.as_ref())?,
    };
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
            standard_errors_fact(
                replicates.len(),
                (&weight, weighting_per_replicate, affordable),
                pc.rows,
                !own.is_empty(),
            ),
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
/// changed nothing measurable on silentblock).
pub(crate) fn efficient_weight(
    problem: &Problem,
    data: &data::StationaryData,
    map: &weak::PiecesMap,
    pc: &Pieces,
    typical: &[f64],
) -> (Option<DMatrix<f64>>, usize) {
    let fine: Vec<&moments::RawMoments> = data.fine.iter().filter(|b| b.count > 0).collect();
    (weight_from(problem, &fine, map, pc, typical), fine.len())
}

/// [`efficient_weight`] from the batches `fine` and their sum's pieces `pc`. Each batch's
/// moments go straight to its residual through one sparse map, in parallel: a thousand
/// equations' pieces for thousands of batches would not fit in memory.
fn weight_from(
    problem: &Problem,
    fine: &[&moments::RawMoments],
    map: &weak::PiecesMap,
    pc: &Pieces,
    typical: &[f64],
) -> Option<DMatrix<f64>> {
    let counts: Vec<u64> = fine.iter().map(|b| b.count).collect();
    let (first, _) = problem.solve(pc, typical, None);
    let rmap = map.residual_map(problem, first.as_slice());
    let rows = rmap.rows();
    let mut flat = vec![0.0; rows * fine.len()];
    flat.par_chunks_mut(rows.max(1))
        .zip(fine.par_iter())
        .for_each(|(out, b)| rmap.apply_into(b, out));
    let residuals = DMatrix::from_vec(rows, fine.len(), flat);
    weak::weighting(residuals, &counts)
}

/// The weak form's "standard errors" fact: `replicates` of the jackknife, whether each
/// weighted its equations anew (and if not, why), whether each read the forces at its own
/// level.
fn standard_errors_fact(
    replicates: usize,
    (weight, per_replicate, affordable): (&Option<DMatrix<f64>>, bool, bool),
    rows: usize,
    own_levels: bool,
) -> String {
    let weighting = match (weight, per_replicate, affordable) {
        (Some(_), true, _) => ", each with its own weighting".to_string(),
        (Some(_), false, false) => format!(
            ", the whole record's weighting in each ({rows} equations: too many to weight every replicate anew)"
        ),
        (Some(_), false, true) => {
            ", the whole record's weighting in each (a replicate's batches are too few for a weighting of its own)"
                .to_string()
        }
        (None, _, _) => String::new(),
    };
    let level = match (own_levels, weighting.is_empty()) {
        (false, _) => "",
        (true, false) => " and its own force level",
        (true, true) => ", each with its own force level",
    };
    format!("delete-one jackknife over {replicates} batches{weighting}{level}")
}

/// Work (multiply–adds) for re-estimating the weighting in every jackknife replicate
/// beyond which it is held at the whole record's: per replicate a covariance of `rows`
/// equations over the fine batches and its Cholesky root. duffing2dof (69 equations,
/// 1024 batches, 32 replicates) needs 1.7·10⁸; frame4 (494 equations, 2048 batches)
/// would need 2·10¹⁰, seconds beside its weak form's 0.1 s.
pub const REWEIGHING_WORK: f64 = 2e9;

/// The jackknife replicates of the two-step weak form, each the whole estimator on the
/// record without its batch (`pieces` and `fine`, from [`data::StationaryData::leave_one_out`]
/// and [`data::StationaryData::leave_one_out_fine`]): its own unweighted estimate, its own
/// weighting from its own batches, its weighted estimate. Holding the whole record's
/// weighting in every replicate leaves out how much the estimate moves with the weighting:
/// with whole records as the units, the damping's standard error came out a fifth to a half
/// of its spread over seeds (docs/results.md, "Standard errors from whole records").
/// `None` where a replicate has too few batches for a weighting of its own.
fn reweighed_replicates(
    (problem, map, own): (&Problem, &weak::PiecesMap, &[(Problem, weak::PiecesMap)]),
    pieces: Vec<Pieces>,
    fine: &[Vec<&moments::RawMoments>],
    typical: &[f64],
) -> Option<Result<Vec<Vec<f64>>, IdentError>> {
    let out: Vec<Option<Result<Vec<f64>, IdentError>>> = pieces
        .into_par_iter()
        .zip(fine.par_iter())
        .enumerate()
        .map(|(b, (pc, fine))| {
            if let Err(e) = pc.check_finite("weak") {
                return Some(Err(e));
            }
            let (problem, map) = own.get(b).map_or((problem, map), |(p, m)| (p, m));
            let weight = weight_from(problem, fine, map, &pc, typical)?;
            Some(Ok(problem.solve_values(&pc, typical, Some(&weight))))
        })
        .collect();
    out.into_iter().collect()
}

/// Per jackknife replicate (`count` of them), `problem` with the forces of `levels` at
/// that replicate's level, and its pieces map over the whole record's moments `total` (the
/// test functions' scales stay the whole record's); empty where `levels` is, or does not
/// give a level for every replicate.
fn at_own_levels(
    problem: &Problem,
    total: &moments::RawMoments,
    levels: &[(usize, Vec<f64>)],
    count: usize,
) -> Vec<(Problem, weak::PiecesMap)> {
    if levels.is_empty()
        || levels
            .iter()
            .any(|(source, l)| l.len() != count || *source >= problem.white.len())
    {
        return Vec::new();
    }
    (0..count)
        .into_par_iter()
        .map(|b| {
            let mut p = problem.clone();
            for (source, l) in levels {
                p.white[*source].1 = l[b];
            }
            let map = weak::PiecesMap::new(&p, total);
            (p, map)
        })
        .collect()
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
    // Each replicate's grid is made where it is solved: one per thread at a time, not all
    // of them held together (32 of duffing2dof's were 41 MB).
    let replicates: Vec<Vec<f64>> = grid
        .replicate_batches()
        .par_iter()
        .map(|&b| {
            let pieces = grid.without_batch(b).pieces_with(problem, marginals, Some(&stencils)).0;
            pieces.check_finite(method)?;
            Ok(problem.solve_values(&pieces, typical, None))
        })
        .collect::<Result<_, IdentError>>()?;
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
    let enough = |rows: usize| rows >= 2 * problem.unknowns.len();
    // Every replicate has the record's rows: with too few, none is solved (refused below).
    let (pc, replicates, rows) = lattice.pieces(problem, |b| {
        enough(b.rows).then(|| {
            b.check_finite("strong")?;
            Ok(problem.solve_values(&b, typical, None))
        })
    });
    if !enough(rows) {
        return Err(IdentError::TooLittleData(format!(
            "only {rows} lattice nodes hold {} effective samples under their kernel, for {} unknowns; use more samples, \
             a wider --smoothing or the weak form",
            lattice.options.min_count,
            problem.unknowns.len()
        )));
    }
    let replicates = replicates
        .into_iter()
        .flatten()
        .collect::<Result<Vec<_>, IdentError>>()?;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ident::Specification;
    use crate::model::Model;
    use crate::scenario::Scenario;

    /// duffing2dof at 32 × 2500 s, its problem and its samples.
    fn duffing2dof() -> (Problem, crate::sim::Collect) {
        let path = format!("{}/scenarios/duffing2dof.toml", env!("CARGO_MANIFEST_DIR"));
        let mut s = Scenario::parse(&std::fs::read_to_string(&path).unwrap(), &path, "t").unwrap();
        (s.simulation.record_length, s.simulation.trajectories) = (2500.0, 32);
        let mut samples = crate::sim::Collect::default();
        crate::sim::simulate(&Model::new(&s), &s.simulation, &mut samples, &|_| {}).unwrap();
        let spec = Specification::from_scenario(&s);
        (Problem::from_spec(&spec, &spec.given_filters()).unwrap(), samples)
    }

    /// The moments of `samples` in 8 jackknife batches, of the batches `keep` keeps only.
    fn moments_of(p: &Problem, samples: &crate::sim::Collect, keep: &dyn Fn(usize) -> bool) -> data::StationaryData {
        let mut data = data::StationaryData::new(p, weak::moment_degree(p), 2500.0, 32, 8);
        let batching = data.batching();
        for b in &samples.batches {
            b.for_each_sample(|j, t, row| {
                if keep(batching.batch_of(j, t)) {
                    data.push(j, t, row)
                }
            });
        }
        data.finish();
        data
    }

    /// A jackknife replicate of the two-step weak form is the whole estimator on the
    /// record without its batch: its own unweighted estimate, its own weighting, its own
    /// weighted estimate — the estimate of the record with that batch's samples left out,
    /// but for the test functions' natural scales, which a replicate keeps from the whole
    /// record (they enter through the first step only: at most 10⁻⁴ standard errors here).
    /// And it is not the replicate with the whole record's weighting held.
    #[test]
    fn a_replicate_is_the_two_step_estimate_without_its_batch() {
        let (p, samples) = duffing2dof();
        let filled = |keep: &dyn Fn(usize) -> bool| moments_of(&p, &samples, keep);
        let data = filled(&|_| true);
        let total = data.total();
        let typical = p.typical(&total);
        let map = weak::PiecesMap::new(&p, &total);
        let pieces: Vec<Pieces> = data.leave_one_out().iter().map(|b| map.apply(b)).collect();
        assert_eq!(pieces.len(), 8);
        let own = reweighed_replicates((&p, &map, &[]), pieces.clone(), &data.leave_one_out_fine(), &typical)
            .expect("every replicate has batches enough")
            .unwrap();
        let (weight, _) = efficient_weight(&p, &data, &map, &map.apply(&total), &typical);
        let held = solve_replicates(&p, "weak", pieces, &typical, weight.as_ref()).unwrap();
        let whole = identify_weak(&p, &data).unwrap();
        assert!(whole
            .facts
            .iter()
            .any(|(k, v)| k == "standard errors" && v.ends_with("each with its own weighting")));
        let (mut moved, mut off) = (0.0f64, 0.0f64);
        for out in [0, 5] {
            let without = identify_weak(&p, &filled(&|b| b != out)).unwrap();
            for k in 0..p.unknowns.len() {
                let se = whole.std_error[k];
                let (a, b) = (own[out][k], without.values[k]);
                off = off.max((a - b).abs() / se);
                assert!(
                    (a - b).abs() <= 1e-3 * se,
                    "{} without batch {out}: {a} against {b}",
                    p.names[k]
                );
                moved = moved.max((own[out][k] - held[out][k]).abs() / se);
            }
        }
        assert!(off < 1e-3, "{off}");
        // The weighting's own share of a replicate: up to 0.19 standard errors here.
        assert!(
            moved > 0.05,
            "the replicates moved by {moved} standard errors with their weighting"
        );
    }

    /// A force read as white at a level measured from the same records: a replicate with
    /// its own level is the two-step estimate without its batch at that level (to the same
    /// 10⁻³ of a standard error), and the damping moves with the level's square.
    #[test]
    fn a_replicate_reads_the_force_at_its_own_level() {
        let (p, samples) = duffing2dof();
        let filled = |keep: &dyn Fn(usize) -> bool| moments_of(&p, &samples, keep);
        let data = filled(&|_| true);
        // The first force's level as if read without each batch: ±2 % about its own.
        let levels = vec![(
            0,
            (0..8)
                .map(|b| 1.0 + 0.02 * (b as f64 - 3.5) / 3.5)
                .collect::<Vec<f64>>(),
        )];
        let whole = identify_weak_with_levels(&p, &data, &levels).unwrap();
        assert!(whole
            .facts
            .iter()
            .any(|(k, v)| k == "standard errors" && v.ends_with("and its own force level")));
        let held = identify_weak(&p, &data).unwrap();
        assert_eq!(
            whole.values, held.values,
            "the estimate itself reads the level from all the records"
        );
        let c1 = p.names.iter().position(|n| *n == "c1[ground-m1]").unwrap();
        assert!(
            whole.std_error[c1] > 1.5 * held.std_error[c1],
            "{} against {}",
            whole.std_error[c1],
            held.std_error[c1]
        );
        let total = data.total();
        let typical = p.typical(&total);
        let own = at_own_levels(&p, &total, &levels, 8);
        let map = weak::PiecesMap::new(&p, &total);
        let pieces: Vec<Pieces> = data
            .leave_one_out()
            .iter()
            .enumerate()
            .map(|(b, m)| own[b].1.apply(m))
            .collect();
        let replicates = reweighed_replicates((&p, &map, &own), pieces, &data.leave_one_out_fine(), &typical)
            .unwrap()
            .unwrap();
        for out in [0, 7] {
            let mut at = p.clone();
            at.white[0].1 = levels[0].1[out];
            let without = identify_weak(&at, &filled(&|b| b != out)).unwrap();
            for k in 0..p.unknowns.len() {
                let (a, b) = (replicates[out][k], without.values[k]);
                assert!(
                    (a - b).abs() <= 1e-3 * whole.std_error[k],
                    "{} without batch {out}: {a} against {b}",
                    p.names[k]
                );
            }
        }
    }
}
