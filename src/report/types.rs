//! The result types of a run, serialised as `report.json` (fields in `docs/methods.md`).

use super::MethodReport;
use crate::ident::{disturbance, spectrum};
use crate::model::{Term, Truth, UnknownName};
use crate::scenario::{ReportMethod, Scenario};
use crate::stats::Histogram;
use serde::Serialize;

/// One unknown's estimate in a method's report, with its uncertainty and, where there is a
/// truth, its error.
#[derive(Debug, Clone, Serialize)]
pub struct Parameter {
    /// The unknown, e.g. `k3[ground-m1]`, `m[m1]`, `sigma[m1]`.
    pub name: UnknownName,
    /// Its true value (NaN where there is no truth: measured data, a term the truth lacks
    /// a counterpart of).
    pub true_value: f64,
    /// The method's estimate.
    pub estimate: f64,
    /// The jackknife's standard error (NaN, `null` in JSON, where the method has none).
    pub std_error: f64,
    /// The 95 % interval `estimate ± t(0.975, dof) · std_error` (Student's t with the
    /// jackknife's degrees of freedom); `None` without a standard error.
    pub ci95: Option<[f64; 2]>,
    /// Whether the 95 % interval excludes 0 (for an extra term of an over-parameterised
    /// model: whether the data ask for it); `None` without an interval.
    pub differs_from_zero: Option<bool>,
    /// `estimate / true_value − 1`, or against the characteristic's scale where the true
    /// value is 0 (NaN without a truth).
    pub rel_error: f64,
    /// The Cramér–Rao bound of continuous observation on this parameter's standard
    /// deviation, from the samples ([`crate::ident::fisher`]); `None` where it does not
    /// apply (filtered forces, unknown masses or intensities, a mass without noise).
    pub cramer_rao_std: Option<f64>,
}

/// [`CurveReport::norm`]: a characteristic's L2 error under the observed density of its
/// argument (every term a power), or evenly over the observed range.
pub const NORM_DENSITY: &str = "observed density";
/// [`CurveReport::norm`]: evenly over the observed range (a term that is not a power).
pub const NORM_RANGE: &str = "observed range";

/// One identified characteristic against the true one, over the observed range of its
/// argument.
#[derive(Debug, Clone, Serialize)]
pub struct CurveReport {
    /// The link, e.g. `ground-m1`.
    pub link: String,
    /// `stiffness` or `damping`.
    pub kind: &'static str,
    /// `‖K̂ − K‖ / ‖K‖` under the observed density of the relative displacement or velocity
    /// (`stats::rel_l2`), or evenly over the observed range where a term is not a power.
    pub rel_l2_error: f64,
    /// Where that norm is taken: `"observed density"` or `"observed range"`.
    pub norm: &'static str,
    /// Observed range of the relative displacement or velocity.
    pub range: [f64; 2],
    /// `(term, coefficient)` of the identified characteristic.
    pub identified: Vec<(Term, f64)>,
    /// The jackknife's covariance of those coefficients (empty without standard errors).
    pub covariance: Vec<Vec<f64>>,
    /// Degrees of freedom of that covariance (batches − 1).
    pub dof: usize,
}

impl CurveReport {
    /// The 95 % pointwise interval's half-width of the identified characteristic at `z`:
    /// `t(0.975, dof) · √(gᵀ Σ g)` with `g` the terms at `z`; `None` without a covariance.
    pub fn half_width_95(&self, z: f64) -> Option<f64> {
        if self.covariance.is_empty() || self.dof == 0 {
            return None;
        }
        let g: Vec<f64> = self.identified.iter().map(|&(t, _)| t.value(z)).collect();
        let var: f64 = (0..g.len())
            .map(|a| (0..g.len()).map(|b| g[a] * self.covariance[a][b] * g[b]).sum::<f64>())
            .sum();
        Some(crate::stats::student_t_975(self.dof) * var.max(0.0).sqrt())
    }
}

/// A filtered excitation's `A`, `B`: the fit to the measured force spectrum (3.20) and
/// what the identifier used.
#[derive(Debug, Clone, Serialize)]
pub struct FilterReport {
    /// The excitation's name.
    pub excitation: String,
    /// `fitted` or `known`.
    pub used: &'static str,
    /// The `A` the identifier used (fitted, or known).
    pub a: f64,
    /// The `B` the identifier used, 1/s.
    pub b: f64,
    /// `A` of the fit of (3.20) to the measured spectrum.
    pub fitted_a: f64,
    /// `B` of that fit, 1/s.
    pub fitted_b: f64,
    /// The scenario's `A` where it is a truth (a simulation), else NaN.
    pub true_a: f64,
    /// The scenario's `B` where it is a truth, else NaN.
    pub true_b: f64,
    /// RMS of `ln Ŝ − ln S_fit` over the fitted frequencies (0 = perfect).
    pub rms_log_residual: f64,
    /// What the averaging alone gives of that RMS, `≈ 1/√K` over `K` segments.
    pub expected_rms_log_residual: f64,
    /// Welch segments averaged.
    pub segments: usize,
    /// Samples per Welch segment.
    pub segment_len: usize,
    /// The force cells' noise floor (two-sided density) taken out of the spectrum before
    /// the fit, if any: stated, or estimated.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noise_floor: Option<f64>,
    /// Where the floor was estimated: the estimate's standard error (taken out only
    /// beyond 3 of them).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noise_floor_se: Option<f64>,
}

/// A measured force read as its equivalent white noise (`[identify] equivalent_white`): the
/// level taken from its spectrum over the band where the response has its energy, and how
/// flat the spectrum is there (docs/methods.md, "The force model").
#[derive(Debug, Clone, Serialize)]
pub struct WhiteLevelReport {
    /// The excitation's name.
    pub excitation: String,
    /// The level used, `σ` of `P dt = σ dW` (two-sided density `σ²/2π`).
    pub sigma: f64,
    /// Its delete-one jackknife standard error over parts of the trajectories (NaN with
    /// fewer than three parts).
    pub sigma_se: f64,
    /// The scenario's `sigma` where it is a truth (a simulation), else NaN.
    pub true_sigma: f64,
    /// The response's band, Hz: its variance less 1 % at each end.
    pub band_hz: (f64, f64),
    /// The force's band, Hz: where its density is within a factor 10 of the level.
    pub force_band_hz: (f64, f64),
    /// The share of the system's gain beyond the force's band (extrapolated as a
    /// velocity's), which the level is corrected for.
    pub edge_share: f64,
    /// RMS of the log ratio of the force's density to the level over the band, weighted by
    /// the response.
    pub rms_log_residual: f64,
    /// What the averaging alone gives of it.
    pub expected_rms_log_residual: f64,
    /// Welch segments averaged (all parts).
    pub segments: usize,
    /// Samples per Welch segment.
    pub segment_len: usize,
    /// Whether the force is read as white: flat over the response's band (the misfit
    /// within 3 times the averaging's) and driving nearly all of the system's gain (the
    /// edge share within its limit).
    pub accepted: bool,
}

/// A measured force whose model the identifier chose from its spectrum (`[identify]
/// choose_force_model`, docs/methods.md "Choosing the force model"): every candidate's fit
/// and misfit against what averaging alone gives, and the choice — the simplest the data
/// accept.
#[derive(Debug, Clone, Serialize)]
pub struct ForceModelChoice {
    /// The excitation's name.
    pub excitation: String,
    /// `"white"`, `"first-order"`, `"second-order"` or `"none"`.
    pub chosen: &'static str,
    /// White over the response's band: the level, the bands and the misfit there.
    pub white: WhiteLevelReport,
    /// The first-order spectrum (3.20) fitted to the whole spectrum, its misfit.
    pub first_order: crate::ident::spectrum::OuFit,
    /// The second-order rational spectrum fitted to the whole spectrum, its misfit.
    pub second_order: Option<crate::ident::rational::Rational2Fit>,
    /// Why the methods that need the force model are refused (a second-order force, which
    /// the FPK equations here do not take, or none of the candidates fits).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refused: Option<String>,
}

/// Structure selection: what was chosen from the candidates and the evidence.
#[derive(Debug, Clone, Serialize)]
pub struct SelectionReport {
    #[serde(flatten)]
    /// The selection: candidates, the elimination path, the chosen terms and their
    /// inclusion frequencies.
    pub selection: crate::ident::select::Selection,
    /// The selection's own time (the candidate model's moments are shared).
    pub seconds: f64,
}

/// A profiled term position (`[identify.profile]`): the weak form's misfit at every position
/// tried, the one kept and the positions the data cannot tell from it.
#[derive(Debug, Clone, Serialize)]
pub struct ProfileReport {
    /// The profiled unknown as `[identify.profile]` names it (its declared position).
    pub parameter: String,
    /// The term's name at the chosen position, e.g. `kgap(0.147)[m1-m2]`.
    pub chosen_parameter: String,
    /// Per position: the GMM `J` of the model there, or why there is none.
    pub points: Vec<ProfilePoint>,
    /// The position kept (the least `J`, or the refined vertex).
    pub chosen: f64,
    /// The positions whose `J` is within `3.84 · dispersion` of the least (a 95 % interval
    /// from the χ²₁ difference, widened by the equations' dispersion `max(1, J/dof)`):
    /// their range.
    pub interval: (f64, f64),
    /// The equations' dispersion `max(1, J/dof)` at the chosen position.
    pub dispersion: f64,
    /// The true position, where the truth has one term of this kind on this characteristic.
    pub truth: Option<f64>,
    /// `J` at the parabola's vertex between the grid's positions, when that position was
    /// kept (`chosen` is then the vertex, between two positions tried).
    pub refined: Option<f64>,
    /// The profile's wall-clock time (s).
    pub seconds: f64,
}

/// One position of a profiled term.
#[derive(Debug, Clone, Serialize)]
pub struct ProfilePoint {
    /// The term's position (e.g. a clearance's gap).
    pub position: f64,
    /// The weak form's GMM `J` there (`None` where it was refused).
    pub j: Option<f64>,
    /// Degrees of freedom of `J`: equations less unknowns.
    pub dof: usize,
    /// Why the model at this position was refused, if it was.
    pub refused: Option<String>,
}

/// One response variable of the validation: the data's statistics against the
/// re-simulated model's.
#[derive(Debug, Clone, Serialize)]
pub struct ValidationRow {
    /// The log column, e.g. `x_m1`.
    pub variable: String,
    /// The data's standard deviation.
    pub data_std: f64,
    /// The re-simulated model's standard deviation.
    pub model_std: f64,
    /// The standard error of `model_std / data_std − 1` from the sampling of both (the
    /// spread between trajectory groups; NaN for a single record).
    pub std_difference_se: f64,
    /// The data's kurtosis.
    pub data_kurtosis: f64,
    /// The re-simulated model's kurtosis.
    pub model_kurtosis: f64,
    /// The standard error of `model_kurtosis − data_kurtosis` (as the std's).
    pub kurtosis_difference_se: f64,
    /// The response spectra compared (absent when either has no power).
    pub spectrum: Option<SpectrumComparison>,
}

/// Data and re-simulated model spectra of one response (Welch, the same segments).
#[derive(Debug, Clone, Serialize)]
pub struct SpectrumComparison {
    /// Upper end of the band compared: 99 % of the data's variance lies below it.
    pub band_rad_s: f64,
    /// RMS of `ln(S_model/S_data)` over the band.
    pub rms_log_difference: f64,
    /// What that RMS is from the averaging alone, `√(1/K_data + 1/K_model)`.
    pub averaging_alone: f64,
    /// The data's spectral peak, rad/s.
    pub data_peak_rad_s: f64,
    /// The model's spectral peak, rad/s.
    pub model_peak_rad_s: f64,
}

/// Sensor noise on the measured channels (displacements, velocities, accelerations):
/// estimated from the samples, and what the identification did about it, with the
/// sensors' filters (docs/measurement.md).
#[derive(Debug, Clone, Serialize)]
pub struct SensorNoiseReport {
    /// `estimate`, `given` or `ignore` (`[identify] sensor_noise`).
    pub handling: String,
    /// One row per measured channel.
    pub channels: Vec<ChannelNoiseReport>,
    /// Why the noise could not be estimated, if it could not.
    pub not_estimated: Option<String>,
    /// Whether the weak form's moments were corrected for the noise.
    pub corrected: bool,
    /// What the correction does not reach.
    pub notes: Vec<String>,
    /// Per velocity column, the tail the sensors' filters took out of it (`[measurement]
    /// anti_alias`, `bandwidth`; docs/measurement.md).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub filter_loss: Vec<FilterLossReport>,
    /// Columns whose noise taken out is at least their variance (`x_m1 141 %`): their
    /// corrected moments are no density's, and the weak form fails on them.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub exceeds_variance: Vec<String>,
}

/// The variance the sensors' filters take out of one velocity column.
#[derive(Debug, Clone, Serialize)]
pub struct FilterLossReport {
    /// The log column the filters acted on.
    pub column: String,
    /// The standard deviation of what was taken out (the column's unit).
    pub std: f64,
}

/// One sensor channel's noise.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelNoiseReport {
    /// The log column, e.g. `x_m1`.
    pub column: String,
    /// Estimated noise standard deviation (channel unit).
    pub std: f64,
    /// Its jackknife standard error.
    pub std_se: f64,
    /// The noise-free signal's standard deviation.
    pub signal_std: f64,
    /// The estimate's variance is more than 3 standard errors above 0, and within what
    /// the channel's spectrum can hold.
    pub detected: bool,
    /// The most noise std the channel's spectrum can hold (white noise spreads evenly up to
    /// Nyquist; `null` where the records are too short for a spectrum).
    pub ceiling_std: Option<f64>,
    /// The estimate exceeds that ceiling: what the lag expansion extrapolated is its
    /// truncation (the signal reaches towards Nyquist), not noise.
    pub above_ceiling: bool,
    /// The noise standard deviation taken out of the moments (0: none).
    pub corrected_std: f64,
    /// A simulation's sensors: the noise it was given (relative levels times the
    /// estimated signal std), for comparison.
    pub simulated_std: Option<f64>,
    /// Samples that sit at the channel's smallest or largest value, counted where more
    /// than one does: exactly, or 64 where the 64 most extreme all lie within a thousandth
    /// of its standard deviation (a clipped sensor or ADC, its limit steady or jittering).
    pub at_limits: u64,
}

/// The validation by re-simulation: the identified model simulated afresh and its
/// responses' statistics compared with the data's (docs/methods.md, "Validation by
/// re-simulation").
#[derive(Debug, Clone, Serialize)]
pub struct Validation {
    /// The method whose model was re-simulated.
    pub method: ReportMethod,
    /// Each re-simulated trajectory's length (s).
    pub record_length_s: f64,
    /// Trajectories re-simulated.
    pub trajectories: usize,
    /// The re-simulation's seed.
    pub seed: u64,
    /// One row per response variable.
    pub rows: Vec<ValidationRow>,
    /// Set when the identified model could not be simulated (e.g. not dissipative).
    pub error: Option<String>,
    /// The verdict: whether every response's std, kurtosis and spectrum agree with the
    /// data's within what the sampling of both allows (`None` when the model could not be
    /// simulated).
    pub reproduces: Option<bool>,
    /// The statistics that disagree, each named (empty when the model reproduces the data).
    pub misfits: Vec<Misfit>,
    /// Unmeasured excitations, left out of the re-simulation: the method does not know
    /// them, so the model's responses lack their share.
    pub left_out: Vec<String>,
}

impl ValidationRow {
    /// `model std / data std − 1` in percent with its standard error: `+0.04 ± 0.12 %`.
    pub fn std_difference(&self) -> String {
        let d = 100.0 * (self.model_std / self.data_std - 1.0);
        if self.std_difference_se.is_finite() {
            format!("{d:+.2} ± {:.2} %", 100.0 * self.std_difference_se)
        } else {
            format!("{d:+.2} %")
        }
    }
}

/// The integrator's bias on the estimates (`run --integrator-bias`, `pipeline::bias`).
#[derive(Debug, Clone, Serialize)]
pub struct IntegratorBias {
    /// The run's integration step `h` (dt / substeps), s; the pair ran at `h/2`.
    pub step_s: f64,
    /// The schemes' weak order `p`: the bias is `(θ_h − θ_h/2) / (1 − 2^−p)`.
    pub order: u32,
    /// Per method, its estimates with their bias.
    pub methods: Vec<MethodBias>,
}

impl IntegratorBias {
    /// The parameters, per method, whose bias exceeds a quarter of their standard error.
    pub fn exceeding(&self) -> Vec<String> {
        self.methods
            .iter()
            .flat_map(|m| {
                m.parameters
                    .iter()
                    .filter(|p| p.exceeds)
                    .map(move |p| format!("{} ({})", p.name, m.method))
            })
            .collect()
    }
}

/// One method's estimates with their integrator bias.
#[derive(Debug, Clone, Serialize)]
pub struct MethodBias {
    /// The method.
    pub method: ReportMethod,
    /// Its estimates, each with its bias.
    pub parameters: Vec<ParameterBias>,
}

/// One estimate's integrator bias.
#[derive(Debug, Clone, Serialize)]
pub struct ParameterBias {
    /// The unknown's name.
    pub name: String,
    /// The estimate at the run's step.
    pub estimate: f64,
    /// The estimate from the run at half the step on the same paths.
    pub refined_estimate: f64,
    /// Richardson's estimate of the bias at the run's step.
    pub bias: f64,
    /// The estimate's standard error (jackknife).
    pub std_error: f64,
    /// `|bias|` above a quarter of the standard error.
    pub exceeds: bool,
}

/// One statistic of one response on which the re-simulated model and the data disagree.
#[derive(Debug, Clone, Serialize)]
pub struct Misfit {
    /// The log column, e.g. `v_m1`.
    pub variable: String,
    /// `std`, `kurtosis` or `spectrum`.
    pub statistic: &'static str,
    /// How far apart, in the statistic's own terms and against what sampling allows.
    pub description: String,
}

impl Validation {
    /// The verdict as a sentence: whether the model reproduces the data and, if not, which
    /// statistics of which responses say so.
    pub fn verdict(&self) -> Option<String> {
        let reproduces = self.reproduces?;
        let unseen: Vec<&str> = self
            .rows
            .iter()
            .filter(|r| r.spectrum.is_none())
            .map(|r| r.variable.as_str())
            .collect();
        Some(if reproduces && unseen.is_empty() {
            "the model reproduces the data: every response's std, kurtosis and spectrum agree within what \
             the sampling of both allows"
                .to_string()
        } else if reproduces {
            format!(
                "the model reproduces the data: every response's std and kurtosis, and the other spectra, agree \
                 within what the sampling of both allows (the spectra of {} are not compared: integrated from \
                 accelerations, their noise is slow and coloured, docs/measurement.md)",
                unseen.join(", ")
            )
        } else {
            format!(
                "the model does not reproduce the data: {}",
                self.misfits
                    .iter()
                    .map(|m| format!("the {} of {} ({})", m.statistic, m.variable, m.description))
                    .collect::<Vec<_>>()
                    .join("; ")
            )
        })
    }

    /// What the re-simulation leaves out, as a sentence (empty when nothing is).
    pub fn left_out_note(&self) -> String {
        if self.left_out.is_empty() {
            return String::new();
        }
        format!(
            "Left out of the re-simulation: the unmeasured excitation {} (the method is not told about it, so \
             the model's responses lack its share; the differences below include it).",
            self.left_out.join(", ")
        )
    }
}

/// An integrator's bias above this share of a parameter's standard error is named
/// (docs/methods.md, "The integrator's bias").
pub const BIAS_SHARE: f64 = 0.25;

/// Wall-clock times of a run (s).
#[derive(Debug, Clone, Serialize)]
pub struct Timings {
    /// The simulation that wrote the log (0 when a log or measured data was identified).
    pub simulate: f64,
    /// The identification, from reading the log to the report.
    pub identify: f64,
    /// The whole command.
    pub total: f64,
    /// The identification's stages in the order they ran (`pipeline::stages`); empty for
    /// the iterative procedure of section 4, which runs as one.
    pub stages: Vec<StageTime>,
}

/// A check of the method's own premises that failed (docs/methods.md, "Checks").
#[derive(Debug, Clone, Serialize)]
pub struct FailedCheck {
    /// `dissipativity`, `validation`, `agreement` or a check of the samples (`dead stretch`)
    /// (docs/methods.md, "Checks").
    pub check: &'static str,
    /// The method whose result failed it (`data` for a check of the samples).
    pub method: String,
    /// What failed, and why it matters.
    pub message: String,
}

/// One stage's wall-clock time.
#[derive(Debug, Clone, Serialize)]
pub struct StageTime {
    /// The stage's name (docs/architecture.md, "Stages and passes").
    pub stage: String,
    /// Its wall-clock time (s).
    pub s: f64,
}

/// What the plots need beyond the report.
#[derive(Debug, Clone, Default)]
pub struct PlotData {
    /// Per link: histograms of `u` and `w`.
    pub link_hist: Vec<(Histogram, Histogram)>,
    /// Per state variable: (name, unit, data histogram, re-simulated model histogram).
    pub marginals: Vec<(String, String, Histogram, Option<Histogram>)>,
    /// Samples behind the data histograms.
    pub samples: f64,
    /// Samples behind the re-simulated model's histograms.
    pub model_samples: f64,
    /// Per filtered excitation: name, estimated spectrum, fit, true (A, B).
    pub spectra: Vec<(String, spectrum::Spectrum, spectrum::OuFit, (f64, f64))>,
    /// Per state variable: (name, unit, data spectrum, re-simulated model spectrum).
    pub response_spectra: Vec<(String, String, spectrum::Spectrum, Option<spectrum::Spectrum>)>,
}

/// What produced a report: the tool and the exact scenario.
#[derive(Debug, Clone, Serialize)]
pub struct Provenance {
    /// The program's name.
    pub tool: &'static str,
    /// Its version.
    pub version: &'static str,
    /// The git commit the binary was built from (`None` outside a git checkout), with
    /// `-dirty` when the tree had uncommitted changes.
    pub commit: Option<&'static str>,
    /// SHA-256 of the scenario text as stored in the log.
    pub scenario_sha256: String,
    /// The `--set KEY=VALUE` overrides the scenario was varied by (empty: the file as is).
    pub overrides: Vec<String>,
}

impl Provenance {
    /// The provenance of a run of the scenario `text` (as stored in the log, with its
    /// `# --set` lines).
    pub fn of_scenario(text: &str) -> Provenance {
        use sha2::Digest;
        let digest = sha2::Sha256::digest(text.as_bytes());
        Provenance {
            tool: env!("CARGO_PKG_NAME"),
            version: env!("CARGO_PKG_VERSION"),
            commit: option_env!("FPKBENCH_GIT_COMMIT").filter(|c| !c.is_empty()),
            scenario_sha256: digest.iter().map(|b| format!("{b:02x}")).collect(),
            overrides: text
                .lines()
                .map_while(|l| l.strip_prefix("# --set "))
                .map(str::to_string)
                .collect(),
        }
    }
}

/// The records of measured data, as they are.
#[derive(Debug, Clone, Serialize)]
pub struct Records {
    /// How many records.
    pub count: usize,
    /// Their lengths (samples × sample interval), in all, shortest and longest (s).
    pub total_s: f64,
    /// The shortest record (s).
    pub shortest_s: f64,
    /// The longest record (s).
    pub longest_s: f64,
}

impl Records {
    /// `N samples every h s in R records, T s in all (shortest a s, longest b s)`.
    pub fn describe(&self, samples: u64, sample_interval: f64) -> String {
        format!(
            "{samples} samples every {sample_interval} s in {} records, {} s in all (shortest {} s, longest {} s)",
            self.count, self.total_s, self.shortest_s, self.longest_s
        )
    }
}

/// The identified models driven by the measured forces of held-out records
/// (`identify --predict`), against the measured response (docs/methods.md, "Prediction").
#[derive(Debug, Clone, Serialize)]
pub struct PredictionReport {
    /// The data files driven with.
    pub files: Vec<String>,
    /// Their records.
    pub records: usize,
    /// Their samples.
    pub samples: u64,
    /// Their sample interval (s).
    pub sample_interval_s: f64,
    /// Runge–Kutta steps per sample interval.
    pub substeps: usize,
    /// Per displacement compared: its column name and the measured response's RMS about
    /// its mean, in the column's units.
    pub columns: Vec<(String, f64)>,
    /// One row per method with an estimate.
    pub rows: Vec<PredictionRow>,
}

/// One identified model's free-run simulation error.
#[derive(Debug, Clone, Serialize)]
pub struct PredictionRow {
    /// The method whose estimates make the model.
    pub method: ReportMethod,
    /// Per compared column: the RMS of the simulated minus the measured displacement, in
    /// the column's units (NaN where the run failed).
    pub rms_error: Vec<f64>,
    /// Per compared column: the mean of that difference (an offset the model does not
    /// reproduce).
    pub mean_error: Vec<f64>,
    /// Why the model could not be driven (it diverged), if it could not.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// The result of identifying one log.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// The tool, its version and commit, and the scenario's digest.
    pub provenance: Provenance,
    /// The scenario's (or model file's) name.
    pub scenario: String,
    /// The log (or data files) identified.
    pub log: String,
    /// Each trajectory's recorded length (s); the longest record's for measured data.
    pub record_length_s: f64,
    /// The whole record over all trajectories (s).
    pub total_record_s: f64,
    /// Samples identified from.
    pub samples: u64,
    /// Samples the run was to write; more than `samples` when a truncated log was
    /// identified from what it still holds (`identify --allow-truncated`).
    pub expected_samples: u64,
    /// The sample interval (s).
    pub sample_interval_s: f64,
    /// Trajectories (records of measured data).
    pub trajectories: usize,
    /// The simulation's seed.
    pub seed: u64,
    /// The integration scheme (`semi-implicit`, `heun`, `euler-maruyama`).
    pub scheme: String,
    /// The integration step (s).
    pub dt_s: f64,
    /// Where the time went: simulate, identify, total, and each identification stage.
    pub timings_s: Timings,
    /// What reading measured data did that a user should know: derived quantities, and
    /// warnings (lines starting `WARNING`) about sampling too coarse to differentiate; and,
    /// measured or simulated, what the standard errors take as independent draws where
    /// that is whole records (`pipeline::units`).
    pub data_notes: Vec<String>,
    /// Measured data: their records as they are (`None` for a simulation, whose records
    /// all have `record_length_s`).
    pub records: Option<Records>,
    /// Filtered excitations: fitted and used `A`, `B`.
    pub filters: Vec<FilterReport>,
    /// Measured forces read as their equivalent white noise.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub white_levels: Vec<WhiteLevelReport>,
    /// Measured forces whose model was chosen from their spectra.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub force_models: Vec<ForceModelChoice>,
    /// Sensor noise: estimated and corrected where the scenario declares sensors and for
    /// measured data (`None` otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sensor_noise: Option<SensorNoiseReport>,
    /// Structure selection (`[identify.select]`, `--select`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub selection: Option<SelectionReport>,
    /// A term's position profiled (`[identify.profile]`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub profile: Option<ProfileReport>,
    /// One row per method run, then the ungated comparison rows.
    pub methods: Vec<MethodReport>,
    /// The validation by re-simulation (`None` with `--no-validate`).
    pub validation: Option<Validation>,
    /// The free-run simulation error on held-out records (`identify --predict`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub prediction: Option<PredictionReport>,
    /// The integrator's bias on the estimates (`run --integrator-bias`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub integrator_bias: Option<IntegratorBias>,
    /// Whether the figures are written beside the report (`--no-figures` leaves them out,
    /// and the pages then show none).
    pub figures: bool,
    /// The iterative procedure for an unmeasured disturbance (paper section 4): the
    /// paper's sequence (spectral single-mass step, method `iterated`), then the one with
    /// the measured-force step (`iterated-force`). Empty without `[identify.disturbance]`.
    pub iterations: Vec<IterationReport>,
    /// Every applicable gated method within its regression gate (and at least one gated),
    /// and no check of [`Report::failed_checks`] failed.
    pub passed: bool,
    /// The checks of the method's own premises that failed (docs/methods.md, "Checks"):
    /// an FPK estimate with no stationary density, a model the validation rejects on
    /// measured data. Any of them fails the run (exit 1).
    pub failed_checks: Vec<FailedCheck>,
    #[serde(skip)]
    /// What the figures draw beyond the report.
    pub plot: PlotData,
    #[serde(skip)]
    /// The scenario (or model file) identified.
    pub scenario_def: Option<Scenario>,
    /// The truth the report was graded against (the log's truth record).
    #[serde(skip)]
    pub truth: Truth,
}

/// The iterative procedure's sequence with its accuracy at every step.
#[derive(Debug, Clone, Serialize)]
pub struct IterationReport {
    /// The report method of the final iterate (`iterated`, `iterated-force`).
    pub method: ReportMethod,
    #[serde(flatten)]
    /// The sequence: its estimates per step and how it stopped.
    pub iteration: disturbance::Iteration,
    /// The true value of every parameter (`iteration.names`), from the log's truth record.
    pub truth: Vec<f64>,
    /// Per step: the relative error of every parameter (as in `methods[]`).
    pub step_rel_errors: Vec<Vec<f64>>,
    /// Per step: the worst relative error, curves included.
    pub step_worst_rel_error: Vec<f64>,
    /// The worst relative error of step 0 (the identification without the disturbance).
    pub step0_worst_rel_error: f64,
    /// The worst relative error of the final iterate.
    pub final_worst_rel_error: f64,
    /// The report method of this sequence's bound: the identification given the
    /// disturbance as if it were measured, in the same model of the forces.
    pub bound: ReportMethod,
    /// The bound's worst error (NaN when it failed).
    pub bound_worst_rel_error: f64,
}

/// One level of a disturbance-strength sweep.
#[derive(Debug, Clone, Serialize)]
pub struct SweepPoint {
    /// Standard deviation of the disturbance over that of the measured force.
    pub level: f64,
    /// The worst relative error of step 0.
    pub step0_worst_rel_error: f64,
    /// Per sequence (the paper's, then the measured-force one): its final iterate and bound.
    pub sequences: Vec<SweepSequence>,
    /// Step 0's estimates.
    pub step0: Vec<f64>,
    /// The one-step solve of (4.8) (`direct-force`): worst error (NaN when it failed) and
    /// estimates.
    pub direct_worst_rel_error: f64,
    /// The one-step solve's estimates.
    pub direct: Vec<f64>,
}

/// One sequence's outcome at one sweep level.
#[derive(Debug, Clone, Serialize)]
pub struct SweepSequence {
    /// `iterated` or `iterated-force`.
    pub method: ReportMethod,
    /// Steps taken.
    pub steps: usize,
    /// Why the sequence stopped (converged, diverged, the step limit).
    pub stopped_by: disturbance::StopReason,
    /// Whether the worst error fell at every step.
    pub monotone: bool,
    /// The worst relative error of the final iterate.
    pub final_worst_rel_error: f64,
    #[serde(rename = "final")]
    /// The final iterate's estimates.
    pub last: Vec<f64>,
    /// The sequence's bound (the disturbance given as measured) and its worst error.
    pub bound_method: ReportMethod,
    /// The bound's worst relative error.
    pub bound_worst_rel_error: f64,
    /// The bound's estimates.
    pub bound: Vec<f64>,
}

/// A disturbance-strength sweep: the procedure's accuracy against the disturbance level.
#[derive(Debug, Clone, Serialize)]
pub struct Sweep {
    /// The disturbed scenario's name.
    pub scenario: String,
    /// The unknowns, in the order of every estimate vector.
    pub names: Vec<UnknownName>,
    /// Their true values.
    pub truth: Vec<f64>,
    /// One point per disturbance level.
    pub points: Vec<SweepPoint>,
}

impl SweepPoint {
    /// The sweep's entry for a report of the disturbed scenario at `level`.
    pub fn from_report(level: f64, r: &Report) -> Option<SweepPoint> {
        let first = r.iterations.first()?;
        let values = |m: &ReportMethod| {
            r.methods
                .iter()
                .find(|x| x.method == *m)
                .map(|x| x.parameters.iter().map(|p| p.estimate).collect())
                .unwrap_or_default()
        };
        Some(SweepPoint {
            level,
            step0_worst_rel_error: first.step0_worst_rel_error,
            sequences: r
                .iterations
                .iter()
                .map(|it| SweepSequence {
                    method: it.method.clone(),
                    steps: it.iteration.steps.len() - 1,
                    stopped_by: it.iteration.stopped_by.clone(),
                    monotone: it.iteration.monotone,
                    final_worst_rel_error: it.final_worst_rel_error,
                    last: values(&it.method),
                    bound_method: it.bound.clone(),
                    bound_worst_rel_error: it.bound_worst_rel_error,
                    bound: values(&it.bound),
                })
                .collect(),
            step0: values(&ReportMethod::Step0),
            direct_worst_rel_error: r
                .methods
                .iter()
                .find(|x| x.method == ReportMethod::DirectForce)
                .map_or(f64::NAN, |x| x.worst_rel_error),
            direct: values(&ReportMethod::DirectForce),
        })
    }
}
