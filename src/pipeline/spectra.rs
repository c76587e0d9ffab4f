//! Spectra of the measured filtered forces: lag-1 correlation in pass 1, Welch estimates in
//! pass 2, and the rational-spectrum fit (3.20) that gives each filter's `A` and `B`, with
//! a force cell's noise floor, stated or estimated, taken out first (docs/measurement.md).
//! Beside them, the forces read as their equivalent white noise: their spectra and their
//! responses', whose band gives the level (docs/methods.md, "The force model").

use crate::ident::accumulate::{Accumulator, Sample};
use crate::ident::{spectrum, spectrum::Welch, Filter};
use crate::model::Columns;
use crate::report::{FilterReport, WhiteLevelReport};
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
    /// The forces read as their equivalent white noise.
    white: Vec<WhiteBand>,
}

/// A force read as its equivalent white noise: Welch estimates of it and of the velocity of
/// the first mass it drives, per part of the trajectories (trajectory `j` in part
/// `j % parts`, for the level's jackknife).
struct WhiteBand {
    excitation: usize,
    force: usize,
    response: usize,
    parts: Vec<(Welch, Welch)>,
}

impl WhiteBand {
    /// Excitation `e`'s force and the velocity of the first mass it drives, in the log's
    /// columns `log`.
    fn new(s: &Scenario, log: &Columns, e: usize) -> WhiteBand {
        WhiteBand {
            excitation: e,
            force: log.force(e),
            response: log.v(s.excitations[e].acts_on[0]),
            parts: Vec::new(),
        }
    }
}

/// Parts of the trajectories a force cell's noise-floor estimate leaves out in turn.
const FLOOR_PARTS: usize = 8;

/// A force is read as white over the response's band when its log density's RMS about the
/// level is within this multiple of what the averaging alone gives (as the first-order
/// fit's, `stages::excitation::REJECT`).
pub(crate) const REJECT_WHITE: f64 = 3.0;

/// The largest share of the system's gain a force read as white may leave beyond its band
/// (`spectrum::BandLevel::edge_share`): the level is corrected for it, by a tail
/// extrapolated as a velocity's, which is sound only while the tail is small.
pub(crate) const EDGE_LIMIT: f64 = 0.1;

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
            white: s
                .identify
                .equivalent_white
                .iter()
                .map(|&e| WhiteBand::new(s, &log, e))
                .collect(),
        }
    }

    /// The forces `excitations` as candidates for a model chosen from their spectra
    /// (`super::force_choice`): each read as white over the response's band, ready for the
    /// samples of one pass.
    pub(crate) fn for_choice(s: &Scenario, excitations: &[usize]) -> ForceSpectra {
        let log = Columns::new(s.masses.len(), s.excitations.len());
        let mut spectra = ForceSpectra {
            excitations: Vec::new(),
            columns: Vec::new(),
            lag: Vec::new(),
            welch: Vec::new(),
            parts: Vec::new(),
            welching: false,
            white: excitations.iter().map(|&e| WhiteBand::new(s, &log, e)).collect(),
        };
        spectra.start_welch(&s.simulation);
        spectra
    }

    /// The spectrum of each force read as white, its parts pooled (in the order of
    /// [`ForceSpectra::white_levels`]).
    pub(crate) fn white_force_spectra(&self) -> Vec<spectrum::Spectrum> {
        self.white
            .iter()
            .filter_map(|w| {
                let first = w.parts.first()?.0.spectrum();
                let parts: Vec<spectrum::Spectrum> = w.parts.iter().map(|(f, _)| f.spectrum()).collect();
                Some(spectrum::Spectrum {
                    density: spectrum::pooled_density(&parts),
                    segments: parts.iter().map(|p| p.segments).sum(),
                    ..first
                })
            })
            .collect()
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
        // The response's segments resolve a resonance: an eighth of a trajectory, at most
        // 4096 samples.
        let len = (sim.samples_per_trajectory() / 8).next_power_of_two().clamp(64, 4096);
        let welch = Welch::new(len, sim.sample_interval, sim.trajectories);
        let parts = sim.trajectories.clamp(1, FLOOR_PARTS);
        for w in &mut self.white {
            w.parts = vec![(welch.clone(), welch.clone()); parts];
        }
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
        for w in &mut self.white {
            let n = w.parts.len();
            let (f, v) = &mut w.parts[traj as usize % n];
            f.push(traj as usize, row[w.force]);
            v.push(traj as usize, row[w.response]);
        }
    }

    /// The level of every force read as its equivalent white noise, with its report: the
    /// band level of the pooled spectra ([`spectrum::band_level`]), its standard error the
    /// delete-one jackknife over the parts. A force without a level (no segment, no power
    /// in the band) has none and is reported as not accepted.
    ///
    /// With each, its level without each part in turn (part `p`: the trajectories
    /// `j ≡ p` mod the parts), where every part gives one: what a jackknife replicate over
    /// the same parts reads the force's level as.
    pub(crate) fn white_levels(&self, s: &Scenario) -> Vec<(usize, Option<f64>, WhiteLevelReport, Vec<f64>)> {
        self.white
            .iter()
            .map(|w| {
                let spectra: Vec<(spectrum::Spectrum, spectrum::Spectrum)> =
                    w.parts.iter().map(|(f, v)| (f.spectrum(), v.spectrum())).collect();
                let pooled = |leave: Option<usize>| {
                    let kept = || spectra.iter().enumerate().filter(move |&(p, _)| Some(p) != leave);
                    let (f0, v0) = &spectra[0];
                    let segments = kept().map(|(_, (f, _))| f.segments).sum();
                    let f = spectrum::Spectrum {
                        density: spectrum::pooled_density(kept().map(|(_, (f, _))| f)),
                        segments,
                        ..f0.clone()
                    };
                    let v = spectrum::Spectrum {
                        density: spectrum::pooled_density(kept().map(|(_, (_, v))| v)),
                        segments,
                        ..v0.clone()
                    };
                    spectrum::band_level(&f, &v)
                };
                let sigma_of = |l: &spectrum::BandLevel| (2.0 * std::f64::consts::PI * l.density).sqrt();
                let level = pooled(None);
                let reps: Vec<f64> = (0..spectra.len())
                    .filter_map(|leave| pooled(Some(leave)).map(|l| sigma_of(&l)))
                    .collect();
                let sigma_se = if reps.len() >= 3 && reps.len() == spectra.len() {
                    let g = reps.len() as f64;
                    let mean = reps.iter().sum::<f64>() / g;
                    ((g - 1.0) / g * reps.iter().map(|r| (r - mean).powi(2)).sum::<f64>()).sqrt()
                } else {
                    f64::NAN
                };
                let x = &s.excitations[w.excitation];
                let true_sigma = match x.process {
                    Process::White { sigma } if s.data.is_none() => sigma,
                    _ => f64::NAN,
                };
                let hz = |w: f64| w / (2.0 * std::f64::consts::PI);
                let accepted = level
                    .is_some_and(|l| l.rms_log_residual <= REJECT_WHITE * l.expected_rms && l.edge_share <= EDGE_LIMIT);
                let report = WhiteLevelReport {
                    excitation: x.name.clone(),
                    sigma: level.map_or(f64::NAN, |l| sigma_of(&l)),
                    sigma_se,
                    true_sigma,
                    band_hz: level.map_or((f64::NAN, f64::NAN), |l| (hz(l.band.0), hz(l.band.1))),
                    force_band_hz: level.map_or((f64::NAN, f64::NAN), |l| (hz(l.force_band.0), hz(l.force_band.1))),
                    edge_share: level.map_or(f64::NAN, |l| l.edge_share),
                    rms_log_residual: level.map_or(f64::NAN, |l| l.rms_log_residual),
                    expected_rms_log_residual: level.map_or(f64::NAN, |l| l.expected_rms),
                    segments: spectra.iter().map(|(f, _)| f.segments).sum(),
                    segment_len: spectra.first().map_or(0, |(f, _)| f.segment_len),
                    accepted,
                };
                let without = match reps.len() == spectra.len() {
                    true => reps,
                    false => Vec::new(),
                };
                (
                    w.excitation,
                    level.filter(|_| accepted).map(|l| sigma_of(&l)),
                    report,
                    without,
                )
            })
            .collect()
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
    /// Only where there is a force to fit or to read as white.
    fn reads_samples(&self) -> bool {
        !self.columns.is_empty() || !self.white.is_empty()
    }
}
