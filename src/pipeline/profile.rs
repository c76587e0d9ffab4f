//! `[identify.profile]`: the position of one term (a clearance's gap, a saturation's `z₀`,
//! a knot) is not linear in the data, so it is chosen over a range: the weak form's moments
//! are gathered in the first pass for the model at every position tried, each model's
//! misfit (the GMM `J` of its efficiently weighted equations, [`ident::select::misfit`]) is
//! computed, and the position of least `J` is what every method then identifies with
//! (docs/scenario.md "Terms").

use super::PipelineError;
use crate::ident::accumulate::{Accumulator, Sample};
use crate::ident::{self, data::StationaryData, weak, Filter, IdentError, Problem, Specification};
use crate::model::{ParameterName, Truth};
use crate::pipeline::source::Input;
use crate::report::{ProfilePoint, ProfileReport};
use crate::scenario::{IdentifyLink, Profile, Scenario};
use rayon::prelude::*;
use std::time::Instant;

/// χ²₁'s 95 % point: the rise of `J` that separates a position from the best one.
const CHI2_1_95: f64 = 3.841;

/// The models at every position of a profile, gathering their moments in the first pass;
/// the least `J` among them is then refined by one more pass at the vertex of the parabola
/// through it and its neighbours ([`Chosen::refine`]).
pub(crate) struct Candidates {
    profile: Profile,
    /// The declared model's links, whose profiled term is moved.
    links: Vec<IdentifyLink>,
    positions: Vec<f64>,
    specs: Vec<Specification>,
    problems: Vec<Result<Problem, IdentError>>,
    data: Vec<Option<StationaryData>>,
}

impl Candidates {
    /// The candidates of the scenario's profile, if it has one, over the specification
    /// `spec` (the declared model) with the filters `placeholder`.
    pub(crate) fn new(
        s: &Scenario,
        spec: &Specification,
        placeholder: &[Filter],
        batches: usize,
    ) -> Option<Candidates> {
        let profile = s.identify.profile.clone()?;
        let positions = profile.positions();
        let specs: Vec<Specification> = positions
            .iter()
            .map(|&x| Specification::with_links(s, &profile.links_at(&spec.links, x)))
            .collect();
        let problems: Vec<_> = specs.iter().map(|sp| Problem::from_spec(sp, placeholder)).collect();
        let data = problems
            .iter()
            .map(|p| {
                p.as_ref().ok().map(|p| {
                    let sim = &s.simulation;
                    StationaryData::new(p, weak::moment_degree(p), sim.record_length, sim.trajectories, batches)
                })
            })
            .collect();
        Some(Candidates {
            profile,
            links: spec.links.clone(),
            positions,
            specs,
            problems,
            data,
        })
    }

    pub(crate) fn push(&mut self, traj: u32, t: f64, row: &[f64]) {
        for d in self.data.iter_mut().flatten() {
            d.push(traj, t, row);
        }
    }

    pub(crate) fn finish(&mut self) {
        self.data.par_iter_mut().flatten().for_each(|d| d.finish());
    }

    /// The position of least misfit: its specification and moments, and the profile's
    /// report (`truth` gives the true position where it has one; `s` names the link).
    pub(crate) fn choose(self, s: &Scenario, truth: &Truth, started: Instant) -> Result<Chosen, PipelineError> {
        let fits: Vec<Result<(f64, usize), IdentError>> = self
            .problems
            .par_iter()
            .zip(self.data.par_iter())
            .map(|(p, d)| match (p, d) {
                (Ok(p), Some(d)) => ident::select::misfit(p, d),
                (Err(e), _) => Err(e.clone()),
                (Ok(_), None) => unreachable!("a built problem gathers moments"),
            })
            .collect();
        let best = (0..fits.len())
            .filter_map(|i| fits[i].as_ref().ok().map(|f| (i, f.0)))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let Some((best, j_min)) = best else {
            let first = fits.into_iter().find_map(|f| f.err()).expect("a profile has points");
            return Err(first.into());
        };
        let dof = fits[best].as_ref().map_or(1, |f| f.1).max(1);
        let dispersion = (j_min / dof as f64).max(1.0);
        let within: Vec<f64> = (0..fits.len())
            .filter(|&i| fits[i].as_ref().is_ok_and(|f| f.0 <= j_min + CHI2_1_95 * dispersion))
            .map(|i| self.positions[i])
            .collect();
        let p = &self.profile;
        let link = &s.links[p.link].name;
        let name = |x: f64| position_name(s, p, x);
        // The vertex of the parabola through the least J and its two neighbours: where the
        // profile's minimum lies between the positions tried.
        let vertex = (best > 0 && best + 1 < fits.len())
            .then(|| {
                let (xa, xb, xc) = (self.positions[best - 1], self.positions[best], self.positions[best + 1]);
                let (ja, jb, jc) = match (&fits[best - 1], &fits[best + 1]) {
                    (Ok(a), Ok(c)) => (a.0, j_min, c.0),
                    _ => return None,
                };
                let num = (xb - xa).powi(2) * (jb - jc) - (xb - xc).powi(2) * (jb - ja);
                let den = (xb - xa) * (jb - jc) - (xb - xc) * (jb - ja);
                let x = xb - 0.5 * num / den;
                (den != 0.0 && x.is_finite()).then(|| round10(x.clamp(xa, xc)))
            })
            .flatten()
            .filter(|&x| x != self.positions[best]);
        let same_kind: Vec<f64> = truth
            .characteristic(link, p.kind)
            .terms
            .iter()
            .filter(|(t, _)| std::mem::discriminant(t) == std::mem::discriminant(&p.term))
            .filter_map(|(t, _)| t.position())
            .collect();
        let report = ProfileReport {
            parameter: name(p.term.position().expect("a profiled term has a position")),
            chosen_parameter: name(self.positions[best]),
            points: self
                .positions
                .iter()
                .zip(&fits)
                .map(|(&position, f)| ProfilePoint {
                    position,
                    j: f.as_ref().ok().map(|f| f.0),
                    dof: f.as_ref().map_or(0, |f| f.1),
                    refused: f.as_ref().err().map(|e| e.to_string()),
                })
                .collect(),
            chosen: self.positions[best],
            interval: (
                within.iter().copied().fold(f64::INFINITY, f64::min),
                within.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            ),
            dispersion,
            truth: (same_kind.len() == 1).then(|| same_kind[0]),
            refined: None,
            seconds: started.elapsed().as_secs_f64(),
        };
        let data = self
            .data
            .into_iter()
            .nth(best)
            .flatten()
            .expect("the best position has moments");
        let spec = self
            .specs
            .into_iter()
            .nth(best)
            .expect("one specification per position");
        Ok(Chosen {
            spec,
            data,
            report,
            j_min,
            vertex,
            profile: self.profile,
            links: self.links,
        })
    }
}

/// The position chosen on the grid, and where the profile's parabola puts its minimum.
pub(crate) struct Chosen {
    pub(crate) spec: Specification,
    pub(crate) data: StationaryData,
    pub(crate) report: ProfileReport,
    j_min: f64,
    vertex: Option<f64>,
    profile: Profile,
    links: Vec<IdentifyLink>,
}

impl Chosen {
    /// One more pass over `input` for the model at the parabola's vertex between the grid's
    /// positions; kept when its `J` is below the grid's least (the report says so).
    pub(crate) fn refine(
        &mut self,
        s: &Scenario,
        input: &Input,
        placeholder: &[Filter],
        batches: usize,
    ) -> Result<(), PipelineError> {
        let Some(x) = self.vertex else { return Ok(()) };
        let t = Instant::now();
        let spec = Specification::with_links(s, &self.profile.links_at(&self.links, x));
        let Ok(problem) = Problem::from_spec(&spec, placeholder) else {
            return Ok(());
        };
        let sim = &s.simulation;
        let mut data = StationaryData::new(
            &problem,
            weak::moment_degree(&problem),
            sim.record_length,
            sim.trajectories,
            batches,
        );
        super::pass::run(input, data.batching(), &mut [&mut data])?;
        if let Ok((j, _)) = ident::select::misfit(&problem, &data) {
            if j < self.j_min {
                self.report.chosen = x;
                self.report.chosen_parameter = position_name(s, &self.profile, x);
                self.report.refined = Some(j);
                self.spec = spec;
                self.data = data;
            }
        }
        self.report.seconds += t.elapsed().as_secs_f64();
        Ok(())
    }
}

/// The profiled unknown's name at position `x`.
fn position_name(s: &Scenario, p: &Profile, x: f64) -> String {
    ParameterName::Coefficient {
        kind: p.kind,
        term: p.term.at_position(x).expect("checked positions"),
        link: s.links[p.link].name.clone(),
    }
    .to_string()
}

/// `x` to 10 significant digits.
fn round10(x: f64) -> f64 {
    format!("{x:.9e}").parse().unwrap_or(x)
}

impl Accumulator for Candidates {
    fn push(&mut self, s: &Sample) {
        Candidates::push(self, s.trajectory, s.t, s.row)
    }
    fn finish(&mut self) {
        Candidates::finish(self)
    }
}
