//! Structure selection (docs/selection.md): which of a set of candidate terms the data
//! need. The weak form of the candidate model — every candidate term unknown — is one set
//! of moment equations `r(θ) = r₀ + J θ` for all the models it contains: a model is a
//! subset `S` of the candidates, the others held at zero. Whitened by the efficient
//! weighting `T` ([`super::weak::weighting`], the inverse square root of the equations'
//! covariance per sample), `N·‖T r(θ)‖²` at its minimum over `θ_S` is the GMM `J`
//! statistic of `S`, χ²-distributed with (equations − |S|) degrees of freedom when `S`
//! holds the truth; dropping a term the truth has raises it by about the square of that
//! term's t-statistic, dropping one it lacks by a χ²₁ variable. The criterion is the GMM
//! analogue of the BIC (Andrews 1999), `J(S)/dispersion + |S|·ln N`, `N` the sample count
//! and the dispersion the candidate model's `J` per degree of freedom (at least 1): the
//! equations' systematic misfit (the integrator's and the sampling's bias) is measured in
//! units of their sampling noise, and on long simulated records it is ~10³ times that
//! noise; a term must explain more than the misfit every equation has (docs/selection.md).
//!
//! The search: backward elimination from the candidate model (each step drops the term
//! whose loss raises `J` least, among the drops that keep every leading term odd), the
//! path's best admissible point, then single additions and removals while they improve
//! the criterion. Only
//! admissible models are chosen: the system keeps a stationary density (3.4) — every
//! characteristic's leading term odd with a positive coefficient, springs to ground, some
//! damping — checked at the model's own estimates. The criterion's choice is then
//! confirmed by the jackknife (`select/confirm.rs`): each term, and each link's terms together,
//! must earn its penalty by its Wald statistic over the record's batches. The same search
//! and confirmation on bootstrap resamples of the batches gives each candidate's inclusion
//! frequency.
//!
//! Every model is fitted from the candidate model's moments and weighting: no pass over
//! the samples, one Cholesky factorisation of at most `K × K` per model tried.

use super::data::StationaryData;
use super::estimate::efficient_weight;
use super::{weak, IdentError, Pieces, Problem, Unknown};
use crate::model::{admissible, Characteristic, Coefficient, Term, UnknownName, GROUND};
use crate::scenario::{Curve, End, IdentifyLink, Link, Mass};
use nalgebra::DMatrix;
use rayon::prelude::*;

mod confirm;
mod equations;

use equations::{Equations, Whitened};

/// How many runner-up models a selection keeps.
pub const RUNNERS_UP: usize = 4;

/// Bootstrap resamples of the record's batches the inclusion frequencies are over.
pub const RESAMPLES: usize = 32;

/// One point of the backward-elimination path.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Step {
    /// The term dropped to reach this model (`None` for the candidate model).
    pub dropped: Option<UnknownName>,
    /// Terms in the model.
    pub terms: usize,
    /// The GMM `J` statistic.
    pub j: f64,
    /// `J/dispersion + terms·ln N`; infinite for a model without a stationary density.
    pub criterion: f64,
    pub admissible: bool,
}

/// A model next to the selected one.
#[derive(Debug, Clone, serde::Serialize)]
pub struct RunnerUp {
    /// What differs from the selected model: `+ c2[m1-m2]`, `− k3[ground-m2]`.
    pub change: String,
    pub terms: usize,
    pub criterion: f64,
}

/// What the selection chose and the evidence for it.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Selection {
    pub criterion_name: &'static str,
    /// The candidate terms, in the candidate problem's order.
    pub candidates: Vec<UnknownName>,
    /// Per candidate: whether the selected model has it.
    pub selected: Vec<bool>,
    /// The selected model's `J` and criterion.
    pub j: f64,
    pub criterion: f64,
    /// The criterion of the model the criterion chose, before the jackknife confirmation
    /// (the runners-up are its neighbours).
    pub criterion_choice: f64,
    pub criterion_choice_terms: usize,
    /// The penalty per term, `ln N`.
    pub penalty: f64,
    /// The candidate model's `J` per degree of freedom (equations − candidates), at
    /// least 1: how far the equations' misfit exceeds their sampling noise; `J` is divided
    /// by it, so that a term must explain more than the misfit every equation has.
    pub dispersion: f64,
    /// The weak-form equations the criterion sums over.
    pub equations: usize,
    pub samples: u64,
    pub path: Vec<Step>,
    /// The best admissible models one addition or removal away from the criterion's
    /// choice, best first.
    pub runners_up: Vec<RunnerUp>,
    /// What the jackknife confirmation removed from the criterion's choice, in order.
    pub confirmation: Vec<Unconfirmed>,
    /// Per candidate: the fraction of bootstrap resamples of the record's batches whose
    /// selection (searched and confirmed as the whole record's) has it.
    pub inclusion: Vec<f64>,
    /// The bootstrap resamples the inclusion frequencies are over.
    pub replicates: usize,
    /// The baseline on the same equations: sequentially thresholded least squares.
    pub thresholded: Thresholded,
}

/// Terms the criterion chose that the jackknife confirmation removed: their Wald
/// statistic under the jackknife covariance fell short of their penalty.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Unconfirmed {
    /// One term, or the selected terms of one link judged together.
    pub terms: Vec<UnknownName>,
    pub wald: f64,
    /// The terms' count times `ln N`.
    pub penalty: f64,
}

/// The baseline selection: sequentially thresholded least squares (STLSQ, PySINDy's
/// default) on the same whitened equations. A term is dropped while its force at the
/// data's typical amplitude is below `threshold` times its characteristic's; the
/// threshold is chosen by leave-one-batch-out cross-validation of the equations' fit.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Thresholded {
    pub threshold: f64,
    /// Per candidate: whether the thresholded model has it.
    pub selected: Vec<bool>,
    /// Whether that model has a stationary density at its own estimates.
    pub admissible: bool,
    /// `(threshold, cross-validated J)` over the grid of thresholds tried.
    pub curve: Vec<(f64, f64)>,
}

/// Thresholds STLSQ's cross-validation tries: log-spaced over `[1e-4, 0.5]`.
const THRESHOLDS: usize = 28;

impl Selection {
    /// The names of the selected terms.
    pub fn selected_names(&self) -> Vec<UnknownName> {
        self.candidates
            .iter()
            .zip(&self.selected)
            .filter(|(_, &s)| s)
            .map(|(n, _)| n.clone())
            .collect()
    }

    /// The selected model as `[identify.links]` entries over `links` (the candidates'):
    /// each characteristic keeps its selected terms; one with none left is absent.
    pub fn links(&self, problem: &Problem, links: &[IdentifyLink]) -> Vec<IdentifyLink> {
        model_links(&self.selected, problem, links)
    }

    /// The names the baseline (STLSQ) kept.
    pub fn thresholded_names(&self) -> Vec<UnknownName> {
        (self.candidates.iter().zip(&self.thresholded.selected))
            .filter(|(_, &s)| s)
            .map(|(n, _)| n.clone())
            .collect()
    }
}

/// The model of the candidates `selected` as `[identify.links]` entries over `links`.
pub fn model_links(selected: &[bool], problem: &Problem, links: &[IdentifyLink]) -> Vec<IdentifyLink> {
    let kept: Vec<Coefficient> = problem
        .unknowns
        .iter()
        .zip(selected)
        .filter_map(|(u, &s)| match (u, s) {
            (Unknown::Coefficient(c), true) => Some(*c),
            _ => None,
        })
        .collect();
    let terms = |l: usize, kind: Characteristic, candidates: &Option<Vec<crate::model::Term>>| {
        candidates.as_ref().map(|ts| {
            ts.iter()
                .copied()
                .filter(|&term| kept.contains(&Coefficient { link: l, kind, term }))
                .collect::<Vec<_>>()
        })
    };
    links
        .iter()
        .map(|il| IdentifyLink {
            link: il.link,
            stiffness: terms(il.link, Characteristic::Stiffness, &il.stiffness),
            damping: terms(il.link, Characteristic::Damping, &il.damping),
        })
        .collect()
}

/// Whether the model of the candidates' coefficients `theta` (zero: absent) has a
/// stationary density (3.4).
struct Admissibility {
    masses: Vec<Mass>,
    /// The known system's links: the candidates' characteristics zero.
    links: Vec<Link>,
    coefficients: Vec<Coefficient>,
}

impl Admissibility {
    fn new(problem: &Problem) -> Admissibility {
        let m = &problem.model;
        let end = |i: usize| if i == GROUND { End::Ground } else { End::Mass(i) };
        let curve = |l: usize, kind| Curve {
            terms: m.terms(l, kind).filter(|&(_, c)| c != 0.0).collect(),
        };
        Admissibility {
            masses: (m.mass_names.iter().zip(&m.mass))
                .map(|(name, &value)| Mass {
                    name: name.clone(),
                    value,
                    valued: true,
                })
                .collect(),
            links: (0..m.link_names.len())
                .map(|l| Link {
                    name: m.link_names[l].clone(),
                    ends: [end(m.link_a[l]), end(m.link_b[l])],
                    stiffness: curve(l, Characteristic::Stiffness),
                    damping: curve(l, Characteristic::Damping),
                    hysteresis: None,
                })
                .collect(),
            coefficients: problem
                .unknowns
                .iter()
                .map(|u| match u {
                    Unknown::Coefficient(c) => *c,
                    _ => unreachable!("checked by select"),
                })
                .collect(),
        }
    }

    /// Whether every characteristic's highest term is odd (whatever the coefficients): the
    /// models the elimination path keeps to once it reaches them.
    #[cfg(test)]
    fn odd_leading(&self, set: &[usize]) -> bool {
        self.even_leading(set) == 0
    }

    /// How far `set` is from every leading term odd: the sum, over the characteristics
    /// whose highest term is not odd, of that term's degree plus one. A path that starts
    /// from candidates with an even highest power (`--select-powers 2`) may pass through
    /// drops that lower it until it is 0, and from then on keeps it 0.
    fn even_leading(&self, set: &[usize]) -> u32 {
        let mut highest: Vec<[Option<Term>; 2]> = (self.links.iter())
            .map(|l| [&l.stiffness, &l.damping].map(|c| c.terms.iter().map(|t| t.0).max_by_key(|t| t.degree())))
            .collect();
        for &i in set {
            let c = self.coefficients[i];
            let slot = &mut highest[c.link][(c.kind == Characteristic::Damping) as usize];
            if slot.is_none_or(|t| t.degree() < c.term.degree()) {
                *slot = Some(c.term);
            }
        }
        (highest.iter().flatten().flatten())
            .filter(|t| !t.is_odd())
            .map(|t| t.degree() + 1)
            .sum()
    }

    fn admits(&self, set: &[usize], theta: &[f64]) -> bool {
        let mut links = self.links.clone();
        for &i in set {
            let c = self.coefficients[i];
            let curve = match c.kind {
                Characteristic::Stiffness => &mut links[c.link].stiffness,
                Characteristic::Damping => &mut links[c.link].damping,
            };
            curve.terms.push((c.term, theta[i]));
        }
        // Every characteristic's highest term odd with a positive coefficient (3.4), each on
        // its own: where links could bound each other's potential the structural check
        // accepts an even leading term, which a selected model must not have.
        for l in &mut links {
            for curve in [&mut l.stiffness, &mut l.damping] {
                curve.terms.sort_by_key(|t| t.0.degree());
                if let Some(&(term, c)) = curve.terms.last() {
                    if !term.is_odd() || c <= 0.0 {
                        return false;
                    }
                }
            }
        }
        admissible::stationary(&self.masses, &links, |_| (false, false)).is_ok()
    }
}

/// A model the search tried.
#[derive(Debug, Clone)]
struct Tried {
    set: Vec<usize>,
    j: f64,
    criterion: f64,
    admissible: bool,
}

/// The elimination path: each model with the candidate dropped to reach it.
type Path = Vec<(Option<usize>, Tried)>;

/// The search over one set of equations.
struct Search<'a> {
    eq: &'a Equations,
    admissibility: &'a Admissibility,
    penalty: f64,
    /// `J` of the candidate model per degree of freedom, at least 1 (see [`select`]).
    dispersion: f64,
}

impl<'a> Search<'a> {
    /// The search over `eq` (`rows` equations).
    fn new(eq: &'a Equations, admissibility: &'a Admissibility, rows: usize) -> Option<Search<'a>> {
        let k = eq.h.len();
        let (_, j) = eq.fit(&(0..k).collect::<Vec<_>>())?;
        Some(Search {
            eq,
            admissibility,
            penalty: eq.n.ln(),
            dispersion: (j / rows.saturating_sub(k).max(1) as f64).max(1.0),
        })
    }

    fn try_set(&self, set: Vec<usize>) -> Option<Tried> {
        let (theta, j) = self.eq.fit(&set)?;
        let admissible = self.admissibility.admits(&set, &theta);
        let criterion = if admissible {
            j / self.dispersion + set.len() as f64 * self.penalty
        } else {
            f64::INFINITY
        };
        Some(Tried {
            set,
            j,
            criterion,
            admissible,
        })
    }

    /// Backward elimination from all `k` candidates: the path, each step with the term it
    /// dropped.
    fn path(&self, k: usize) -> Path {
        let Some(mut at) = self.try_set((0..k).collect()) else {
            return Vec::new();
        };
        let mut path = vec![(None, at.clone())];
        while !at.set.is_empty() {
            // The drop that raises J least among those that keep every leading term odd, or
            // bring an even leading term closer to odd where the candidates start with one
            // (a negative leading coefficient may still be passed through: the model is
            // then recorded as not admissible, and never chosen).
            let even = self.admissibility.even_leading(&at.set);
            let next = at
                .set
                .par_iter()
                .filter_map(|&drop| {
                    let set: Vec<usize> = at.set.iter().copied().filter(|&i| i != drop).collect();
                    let after = self.admissibility.even_leading(&set);
                    (after == 0 || after < even).then_some(())?;
                    self.try_set(set).map(|t| (drop, t))
                })
                .min_by(|a, b| a.1.j.total_cmp(&b.1.j));
            let Some((drop, t)) = next else { break };
            at = t.clone();
            path.push((Some(drop), t));
        }
        path
    }

    /// The admissible models one addition or removal from `set` among `k` candidates.
    fn neighbours(&self, set: &[usize], k: usize) -> Vec<(String, usize, Tried)> {
        (0..k)
            .into_par_iter()
            .filter_map(|i| {
                let (sign, next) = if set.contains(&i) {
                    ("−", set.iter().copied().filter(|&x| x != i).collect::<Vec<_>>())
                } else {
                    let mut s = set.to_vec();
                    s.push(i);
                    s.sort_unstable();
                    ("+", s)
                };
                self.try_set(next)
                    .filter(|t| t.admissible)
                    .map(|t| (sign.to_string(), i, t))
            })
            .collect()
    }

    /// The selected model: the path's best, then single changes while they improve it.
    fn choose(&self, k: usize) -> Option<(Tried, Path)> {
        let path = self.path(k);
        let mut best = path
            .iter()
            .map(|(_, t)| t)
            .filter(|t| t.admissible)
            .min_by(|a, b| a.criterion.total_cmp(&b.criterion))?
            .clone();
        for _ in 0..k * k {
            let better = self
                .neighbours(&best.set, k)
                .into_iter()
                .map(|(_, _, t)| t)
                .filter(|t| t.criterion < best.criterion)
                .min_by(|a, b| a.criterion.total_cmp(&b.criterion));
            match better {
                Some(t) => best = t,
                None => break,
            }
        }
        Some((best, path))
    }
}

/// Sequentially thresholded least squares on `eq`: from all candidates, drop every term
/// whose force at the typical amplitude (`|θ_i| / typical_i`) is below `threshold` times
/// the sum over its characteristic, refit, until nothing changes.
fn stlsq(
    eq: &Equations,
    chars: &[(usize, Characteristic)],
    typical: &[f64],
    threshold: f64,
) -> Option<(Vec<usize>, Vec<f64>)> {
    let k = typical.len();
    let mut set: Vec<usize> = (0..k).collect();
    for _ in 0..=k {
        let (theta, _) = eq.fit(&set)?;
        let force = |i: usize| (theta[i] / typical[i]).abs();
        let keep: Vec<usize> = set
            .iter()
            .copied()
            .filter(|&i| {
                let total: f64 = set.iter().filter(|&&j| chars[j] == chars[i]).map(|&j| force(j)).sum();
                force(i) >= threshold * total
            })
            .collect();
        if keep.len() == set.len() {
            return Some((set, theta));
        }
        set = keep;
    }
    None
}

/// The baseline: STLSQ with its threshold chosen by leave-one-batch-out cross-validation
/// (fitted on all batches but one — `held_in` — and judged by `J` on the one left out).
fn thresholded(
    full: &Equations,
    held_in: &[Equations],
    held_out: &[Equations],
    chars: &[(usize, Characteristic)],
    typical: &[f64],
    admissibility: &Admissibility,
) -> Thresholded {
    let grid: Vec<f64> = (0..THRESHOLDS)
        .map(|i| 1e-4 * (0.5f64 / 1e-4).powf(i as f64 / (THRESHOLDS - 1) as f64))
        .collect();
    let curve: Vec<(f64, f64)> = grid
        .par_iter()
        .map(|&t| {
            let cv: f64 = held_in
                .iter()
                .zip(held_out)
                .map(|(fit, test)| match stlsq(fit, chars, typical, t) {
                    Some((_, theta)) => test.value(&theta),
                    None => f64::INFINITY,
                })
                .sum();
            (t, cv)
        })
        .collect();
    let threshold = curve.iter().min_by(|a, b| a.1.total_cmp(&b.1)).map_or(grid[0], |c| c.0);
    let (set, theta) = stlsq(full, chars, typical, threshold).unwrap_or_default();
    Thresholded {
        threshold,
        selected: (0..typical.len()).map(|i| set.contains(&i)).collect(),
        admissible: !set.is_empty() && admissibility.admits(&set, &theta),
        curve,
    }
}

/// How well the weak form of `problem` fits `data`: the GMM `J` statistic of its efficiently
/// weighted equations at its own estimate (`N · |T r(θ̂)|²`, `TᵀT` the inverse covariance
/// of the equations) and its degrees of freedom (equations − unknowns). Models over the
/// same test functions are compared by it: a term's position (a gap) is profiled by the
/// `J` of the model at each position (docs/scenario.md "Terms").
pub fn misfit(problem: &Problem, data: &StationaryData) -> Result<(f64, usize), IdentError> {
    let w = Weighted::new(problem, data, "profile", |fine, rows| {
        format!("{fine} fine batches are too few to weigh {rows} weak-form equations")
    })?;
    let k = problem.unknowns.len();
    let eq = Equations::new(problem, &w.pc, &w.weight, w.total.count as f64);
    let all: Vec<usize> = (0..k).collect();
    let (_, j) = eq.fit(&all).ok_or_else(|| dependent(problem, &eq))?;
    Ok((j, w.pc.rows.saturating_sub(k)))
}

/// Why the model's equations `eq` have no least-squares fit at this position, naming the
/// unknowns: those whose term is zero at every sample (a gap beyond the observed stroke),
/// else those without which the rest can be fitted.
fn dependent(problem: &Problem, eq: &Equations) -> IdentError {
    let k = problem.unknowns.len();
    let names = |ix: &[usize]| {
        ix.iter()
            .map(|&i| problem.names[i].to_string())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let idle: Vec<usize> = (0..k)
        .filter(|&i| eq.g[(i, i)].is_nan() || eq.g[(i, i)] <= 0.0)
        .collect();
    if !idle.is_empty() {
        return IdentError::NotApplicable(format!(
            "the model's equations are dependent at this position: {} never {} on these data (zero at every \
             sample, e.g. a gap beyond the observed stroke)",
            names(&idle),
            if idle.len() == 1 { "acts" } else { "act" }
        ));
    }
    let culprits: Vec<usize> = (0..k)
        .filter(|&i| {
            let rest: Vec<usize> = (0..k).filter(|&r| r != i).collect();
            eq.fit(&rest).is_some()
        })
        .collect();
    IdentError::NotApplicable(format!(
        "the model's equations are dependent at this position{}",
        match culprits.is_empty() {
            true => String::new(),
            false => format!(": {} and the other unknowns move together", names(&culprits)),
        }
    ))
}

/// The weak form's pieces of the whole record with their efficient weight: what the
/// selection and the profile's misfit start from.
struct Weighted {
    total: super::moments::RawMoments,
    map: weak::PiecesMap,
    pc: Pieces,
    weight: DMatrix<f64>,
    /// The unknowns' typical sizes ([`Problem::typical`]).
    typical: Vec<f64>,
}

impl Weighted {
    /// For `what` (the word non-finite pieces are reported with); `too_few(fine batches,
    /// equations)` says why when too few fine batches weigh the equations.
    fn new(
        problem: &Problem,
        data: &StationaryData,
        what: &str,
        too_few: impl FnOnce(usize, usize) -> String,
    ) -> Result<Weighted, IdentError> {
        let total = data.total();
        let typical = problem.typical(&total);
        let map = weak::PiecesMap::new(problem, &total);
        let pc = map.apply(&total);
        pc.check_finite(what)?;
        match efficient_weight(problem, data, &map, &pc, &typical) {
            (Some(weight), _) => Ok(Weighted {
                total,
                map,
                pc,
                weight,
                typical,
            }),
            (None, fine) => Err(IdentError::TooLittleData(too_few(fine, pc.rows))),
        }
    }
}

/// Select among the coefficients of `problem` (the candidate model: every candidate term
/// unknown, nothing else) from the weak form of `data`.
pub fn select(problem: &Problem, data: &StationaryData) -> Result<Selection, IdentError> {
    if let Some(u) = (problem.unknowns.iter().zip(&problem.names)).find(|(u, _)| !matches!(u, Unknown::Coefficient(_)))
    {
        return Err(IdentError::NotApplicable(format!(
            "structure selection chooses among spring and damper terms only: {} is unknown too \
             (give the masses, intensities and filters as known)",
            u.1
        )));
    }
    let k = problem.unknowns.len();
    let count = data.total().count;
    if count < 100 * k as u64 {
        return Err(IdentError::TooLittleData(format!(
            "{count} samples for {k} candidate terms: selection needs at least 100 per candidate"
        )));
    }
    let Weighted {
        total,
        map,
        pc,
        weight,
        typical,
    } = Weighted::new(problem, data, "selection", |fine, rows| {
        format!(
            "{fine} fine batches are too few to weigh {rows} weak-form equations ({} per equation \
             are needed): the selection criterion needs the equations' covariance; use longer \
             records or fewer candidate terms",
            weak::BATCHES_PER_EQUATION
        )
    })?;
    let n = total.count as f64;
    let admissibility = Admissibility::new(problem);
    // The equations of the whole record, of every coarse batch, and of every jackknife
    // replicate (all coarse batches but one; sums of the batches' unless each carries its
    // own noise correction), each built once.
    let eqs = |ms: &[super::moments::RawMoments]| -> Vec<Equations> {
        ms.par_iter()
            .map(|b| Equations::new(problem, &map.apply(b), &weight, b.count as f64))
            .collect()
    };
    let whole = Equations::new(problem, &pc, &weight, n);
    let whitened: Vec<Whitened> = data
        .batches()
        .par_iter()
        .map(|b| Whitened::new(problem, &map.apply(b), &weight, b.count as f64))
        .collect();
    let batches: Vec<Equations> = whitened.iter().map(Equations::of).collect();
    let resampled = |all: Vec<Vec<u32>>| -> Vec<Equations> {
        all.par_iter()
            .map(|times| Equations::resampled(&whitened, times))
            .collect()
    };
    let replicates = if data.has_noise_replicates() {
        eqs(&data.leave_one_out())
    } else {
        Equations::leave_one_out(&whitened)
    };
    // The criterion's choice, then the jackknife's confirmation of it (its spread over
    // the whole record's replicates).
    let search = |eq: &Equations| {
        let s = Search::new(eq, &admissibility, pc.rows)?;
        let (best, path) = s.choose(k)?;
        let (set, removed) = confirm::confirm(eq, &replicates, &admissibility, best.set.clone(), s.penalty);
        let confirmed = s.try_set(set)?;
        Some((best, confirmed, removed, path))
    };
    let Some((chosen_by_criterion, best, removed, path)) = search(&whole) else {
        return Err(IdentError::NotApplicable(
            "no model among the candidates has a stationary density at its own estimates \
             (every characteristic's highest term odd with a positive coefficient, springs to \
             ground, some damping): give other candidate terms"
                .into(),
        ));
    };
    let whole_search = Search::new(&whole, &admissibility, pc.rows).expect("searched above");
    let neighbours = whole_search.neighbours(&chosen_by_criterion.set, k);
    let dispersion = whole_search.dispersion;
    // The same search and confirmation on every bootstrap resample of the batches.
    let resamples = resampled(data.bootstrap(RESAMPLES));
    let nb = resamples.len() as f64;
    let chosen: Vec<Option<Vec<usize>>> = resamples
        .par_iter()
        .map(|eq| search(eq).map(|(_, t, ..)| t.set))
        .collect();
    let inclusion = (0..k)
        .map(|i| {
            chosen
                .iter()
                .filter(|s| s.as_ref().is_some_and(|s| s.contains(&i)))
                .count() as f64
                / nb.max(1.0)
        })
        .collect();
    // The baseline on the same equations, cross-validated over the coarse batches.
    let chars: Vec<(usize, Characteristic)> = admissibility.coefficients.iter().map(|c| (c.link, c.kind)).collect();
    let thresholded = thresholded(&whole, &replicates, &batches, &chars, &typical, &admissibility);
    let names = &problem.names;
    let mut runners_up: Vec<RunnerUp> = neighbours
        .into_iter()
        .map(|(sign, i, t)| RunnerUp {
            change: format!("{sign} {}", names[i]),
            terms: t.set.len(),
            criterion: t.criterion,
        })
        .collect();
    runners_up.sort_by(|a, b| a.criterion.total_cmp(&b.criterion));
    runners_up.truncate(RUNNERS_UP);
    Ok(Selection {
        criterion_name: "GMM-BIC: J/dispersion + (terms)·ln N, confirmed by the jackknife",
        dispersion,
        candidates: names.clone(),
        selected: (0..k).map(|i| best.set.contains(&i)).collect(),
        j: best.j,
        criterion: best.criterion,
        criterion_choice: chosen_by_criterion.criterion,
        criterion_choice_terms: chosen_by_criterion.set.len(),
        penalty: n.ln(),
        equations: pc.rows,
        samples: total.count,
        path: path
            .into_iter()
            .map(|(drop, t)| Step {
                dropped: drop.map(|i| names[i].clone()),
                terms: t.set.len(),
                j: t.j,
                criterion: t.criterion,
                admissible: t.admissible,
            })
            .collect(),
        runners_up,
        confirmation: removed
            .into_iter()
            .map(|r| Unconfirmed {
                terms: r.terms.iter().map(|&i| names[i].clone()).collect(),
                wald: r.wald,
                penalty: r.penalty,
            })
            .collect(),
        inclusion,
        replicates: chosen.len(),
        thresholded,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Term;

    /// One mass on one link to ground with candidates u, u², u³ and w, w², w³.
    pub(super) fn one_link() -> Admissibility {
        one_link_up_to(3)
    }

    /// One ground link whose stiffness and damping candidates are the powers 1..=`max`.
    fn one_link_up_to(max: u32) -> Admissibility {
        let mut coefficients = Vec::new();
        for kind in [Characteristic::Stiffness, Characteristic::Damping] {
            for p in 1..=max {
                coefficients.push(Coefficient {
                    link: 0,
                    kind,
                    term: Term::Power(p),
                });
            }
        }
        Admissibility {
            masses: vec![Mass {
                name: "m1".into(),
                value: 1.0,
                valued: true,
            }],
            links: vec![Link {
                name: "ground-m1".into(),
                ends: [End::Mass(0), End::Ground],
                stiffness: Curve { terms: Vec::new() },
                damping: Curve { terms: Vec::new() },
                hysteresis: None,
            }],
            coefficients,
        }
    }

    /// Consistent equations `A θ + b = 0` at a known `θ`, with `rows` rows of a fixed
    /// pseudo-random `A`, as from a million samples.
    pub(super) fn exact(theta: &[f64], rows: usize) -> Equations {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let a = DMatrix::from_fn(rows, theta.len(), |_, _| next());
        let b = -(&a * nalgebra::DVector::from_column_slice(theta));
        let n = 1e6;
        Equations {
            g: a.tr_mul(&a) * n,
            h: a.tr_mul(&b) * n,
            c: b.norm_squared() * n,
            n,
        }
    }

    #[test]
    fn exact_equations_select_exactly_the_true_terms() {
        let theta = [10.0, 0.0, 20.0, 0.5, 0.0, 0.0];
        let adm = one_link();
        let eq = exact(&theta, 40);
        let s = Search::new(&eq, &adm, 40).unwrap();
        // The candidate model fits exactly: no misfit to divide out.
        assert_eq!(s.dispersion, 1.0);
        let (best, path) = s.choose(6).unwrap();
        assert_eq!(best.set, vec![0, 2, 3]);
        assert!(best.j < 1e-12 * s.eq.c, "J = {}", best.j);
        // The path ran down from all six; dropping a true term costs far more than the
        // penalty, and the selected fit is the truth.
        assert_eq!(path[0].1.set.len(), 6);
        let (fitted, _) = s.eq.fit(&best.set).unwrap();
        for (f, t) in fitted.iter().zip(theta) {
            assert!((f - t).abs() < 1e-9 * t.abs().max(1.0), "{fitted:?}");
        }
        for drop in [0, 2, 3] {
            let rest: Vec<usize> = best.set.iter().copied().filter(|&i| i != drop).collect();
            if let Some(t) = s.try_set(rest) {
                assert!(t.criterion > best.criterion + 1e3 * s.penalty, "dropping {drop}");
            }
        }
    }

    #[test]
    fn an_even_leading_term_or_a_negative_one_is_never_selected() {
        let adm = one_link();
        // k2 leading (k3 absent): not odd.
        assert!(!adm.odd_leading(&[0, 1, 3]));
        assert!(adm.odd_leading(&[0, 1, 2, 3]));
        // A negative leading cubic: no stationary density.
        let theta = [10.0, 0.0, -20.0, 0.5, 0.0, 0.0];
        assert!(!adm.admits(&[0, 2, 3], &theta));
        assert!(adm.admits(&[0, 3], &theta));
        // No damping at all: not admissible either.
        assert!(!adm.admits(&[0], &theta));
        // A truth with a negative cubic: the selection keeps k1 and c1 only, or nothing
        // admissible at all — never the negative cubic.
        let eq = exact(&theta, 40);
        let s = Search::new(&eq, &adm, 40).unwrap();
        if let Some((best, _)) = s.choose(6) {
            let (fitted, _) = s.eq.fit(&best.set).unwrap();
            assert!(adm.admits(&best.set, &fitted));
            assert!(!best.set.contains(&2), "{:?}", best.set);
        }
    }

    #[test]
    fn candidates_whose_highest_power_is_even_still_reach_the_odd_models_below() {
        // Powers 1 and 2 (`--select-powers 2`): the path starts from k2 and c2 leading,
        // drops them, and selects the linear truth (before: "no model among the candidates
        // has a stationary density", the path never leaving its start).
        let adm = one_link_up_to(2);
        assert_eq!((adm.even_leading(&[0, 1, 2, 3]), adm.even_leading(&[0, 2])), (6, 0));
        let theta = [10.0, 0.0, 0.5, 0.0];
        let eq = exact(&theta, 40);
        let s = Search::new(&eq, &adm, 40).unwrap();
        let (best, path) = s.choose(4).expect("a model with a stationary density");
        assert_eq!(best.set, vec![0, 2]);
        assert!(path.len() >= 3, "{}", path.len());
    }
}
