//! Spectra of the measured filtered forces: lag-1 correlation in pass 1, Welch estimates in
//! pass 2, and the rational-spectrum fit (3.20) that gives each filter's `A` and `B`, with
//! a force cell's noise floor, stated or estimated, taken out first (docs/measurement.md).

use crate::ident::accumulate::{Accumulator, Sample};
use crate::ident::{spectrum, spectrum::Welch, Filter};
use crate::model::Columns;
use crate::report::FilterReport;
use crate::scenario::{NoiseHandling, Process, Scenario};

/// The measured forces whose spectra are fitted: lag-1 sums in pass 1 (an AR(1) guess of
/// the corner sets the Welch segment length), Welch estimates in pass 2.
pub(crate) struct ForceSpectra {
    excitations: Vec<usize>,
    columns: Vec<usize>,
    /// Per force: `Σ p²`, `Σ p·p_prev`, the last value per trajectory.
    lag: Vec<(f64, f64, Vec<f64>)>,
    welch: Vec<Welch>,
    /// Per force, where its cell's noise floor is estimated: Welch estimates of the
    /// trajectories in [`FLOOR_PARTS`] parts (trajectory `j` in part `j % parts`), for the
    /// estimate's jackknife.
    parts: Vec<Vec<Welch>>,
    /// Whether the Welch estimates have started (the second pass): before, a sample feeds
    /// the lag-1 correlations.
    welching: bool,
}

/// Parts of the trajectories a force cell's noise-floor estimate leaves out in turn.
const FLOOR_PARTS: usize = 8;

impl ForceSpectra {
    pub(crate) fn new(s: &Scenario, excitations: &[usize]) -> ForceSpectra {
        let log = Columns::new(s.masses.len(), s.excitations.len());
        ForceSpectra {
            excitations: excitations.to_vec(),
            columns: excitations.iter().map(|&e| log.force(e)).collect(),
            lag: vec![(0.0, 0.0, vec![f64::NAN; s.simulation.trajectories]); excitations.len()],
            welch: Vec::new(),
            parts: Vec::new(),
            welching: false,
        }
    }

    pub(crate) fn push_lag(&mut self, traj: u32, row: &[f64]) {
        for (k, &c) in self.columns.iter().enumerate() {
            let p = row[c];
            let (s0, s1, last) = &mut self.lag[k];
            if let Some(prev) = last.get_mut(traj as usize) {
                if prev.is_finite() {
                    *s0 += p * p;
                    *s1 += p * *prev;
                }
                *prev = p;
            }
        }
    }

    pub(crate) fn start_welch(&mut self, sim: &crate::scenario::Simulation) {
        self.welching = true;
        self.welch = self
            .lag
            .iter()
            .map(|(s0, s1, _)| {
                let phi = (s1 / s0).clamp(1e-6, 1.0 - 1e-9);
                let b_guess = -phi.ln() / sim.sample_interval;
                Welch::new(
                    Welch::segment_for(b_guess, sim.sample_interval, sim.samples_per_trajectory()),
                    sim.sample_interval,
                    sim.trajectories,
                )
            })
            .collect();
    }

    /// Estimate each force cell's noise floor too (`sensor_noise = "estimate"` on data that
    /// may carry sensor noise): Welch estimates per part of the trajectories.
    pub(crate) fn estimate_floors(&mut self, trajectories: usize) {
        let parts = trajectories.min(FLOOR_PARTS);
        self.parts = self.welch.iter().map(|w| vec![w.fresh(trajectories); parts]).collect();
    }

    pub(crate) fn push(&mut self, traj: u32, row: &[f64]) {
        for (w, &c) in self.welch.iter_mut().zip(&self.columns) {
            w.push(traj as usize, row[c]);
        }
        for (parts, &c) in self.parts.iter_mut().zip(&self.columns) {
            let n = parts.len();
            parts[traj as usize % n].push(traj as usize, row[c]);
        }
    }

    /// Fit (3.20) to every spectrum: the filters the identifier uses (the fit, or the true
    /// values where the scenario declares them known), their reports and the plot data.
    #[allow(clippy::type_complexity)]
    pub(crate) fn filters(
        &self,
        s: &Scenario,
    ) -> (
        Vec<Filter>,
        Vec<FilterReport>,
        Vec<(String, spectrum::Spectrum, spectrum::OuFit, (f64, f64))>,
    ) {
        let mut filters = Vec::new();
        let mut reports = Vec::new();
        let mut spectra = Vec::new();
        for (k, (&e, w)) in self.excitations.iter().zip(&self.welch).enumerate() {
            let spec = w.spectrum();
            let mut floor_se = None;
            let floor = force_floor(s, &spec).or_else(|| {
                // Estimated: taken out where it stands 3 standard errors above 0.
                let mut all = vec![spec.clone()];
                all.extend(self.parts.get(k)?.iter().map(|p| p.spectrum()));
                let (n, se) = spectrum::ou_noise_floor(&all).filter(|(_, se)| se.is_finite())?;
                floor_se = Some(se);
                (n > 3.0 * se).then_some(n)
            });
            let fit = match floor {
                Some(n) => spectrum::fit_ou(&spectrum::without_floor(&spec, n)),
                None => spectrum::fit_ou(&spec),
            };
            let Process::Filtered { a: ta, b: tb } = s.excitations[e].process else {
                unreachable!("only filtered forces are fitted")
            };
            let known = s.identify.known_filters.contains(&e);
            // A model file's A and B of a fitted filter are placeholders, not a truth.
            let (ta, tb) = if s.data.is_some() && !known {
                (f64::NAN, f64::NAN)
            } else {
                (ta, tb)
            };
            let (a, b) = if known { (ta, tb) } else { (fit.a, fit.b) };
            filters.push(Filter { excitation: e, a, b });
            reports.push(FilterReport {
                excitation: s.excitations[e].name.clone(),
                used: match (s.excitations[e].measured, known) {
                    (false, _) => "fitted (disturbance: the bound only)",
                    (true, true) => "known",
                    (true, false) => "fitted",
                },
                a,
                b,
                fitted_a: fit.a,
                fitted_b: fit.b,
                true_a: ta,
                true_b: tb,
                rms_log_residual: fit.rms_log_residual,
                expected_rms_log_residual: fit.expected_rms,
                segments: spec.segments,
                segment_len: spec.segment_len,
                noise_floor: floor,
                noise_floor_se: floor_se,
            });
            spectra.push((s.excitations[e].name.clone(), spec, fit, (ta, tb)));
        }
        (filters, reports, spectra)
    }
}

/// The noise floor of a measured force's spectrum where the force cells' noise is stated
/// (`[measurement] force` with `sensor_noise = "given"`, and the ADC's rounding): the
/// two-sided density `σ²·h/(2π)` of a white noise of variance `σ²`. A relative level is
/// of the force's own std, the spectrum's variance without the noise's.
fn force_floor(s: &Scenario, spec: &spectrum::Spectrum) -> Option<f64> {
    let sensors = &s.simulation.sensors;
    let level = sensors
        .force
        .filter(|_| s.identify.sensor_noise == NoiseHandling::Given)?;
    let std = (spectrum::variance(spec) / (1.0 + level * level)).sqrt();
    let variance = sensors.noise_variance(level, std);
    (variance > 0.0).then(|| variance * spec.sample_interval / (2.0 * std::f64::consts::PI))
}

/// The first pass feeds the lag-1 correlations that place the Welch segments; after
/// [`ForceSpectra::start_welch`], the spectra.
impl Accumulator for ForceSpectra {
    fn push(&mut self, s: &Sample) {
        if self.welching {
            ForceSpectra::push(self, s.trajectory, s.row)
        } else {
            self.push_lag(s.trajectory, s.row)
        }
    }
}
