//! The sensors in the identification (docs/measurement.md): which displacement–velocity
//! pairs the samples measure, their noise estimated in the first pass, and the weak
//! form's moments corrected as `[identify] sensor_noise` asks; a simulated rig read
//! through its sensors ([`rig`]).

pub(crate) mod rig;

use super::source::Input;
use crate::estimators::Method;
use crate::ident::data::{Deconvolution, StationaryData};
use crate::ident::noise::{ChannelNoise, NoiseFloor, Pair};
use crate::ident::Problem;
use crate::io::table::{differentiate, DifferencedNoise, IntegratedNoise, Measured};
use crate::report::{ChannelNoiseReport, FilterLossReport, MethodOutcome, MethodReport, SensorNoiseReport};
use crate::scenario::ReportMethod;
use crate::scenario::{NoiseHandling, Scenario};

/// The noise estimator for `input`, if its samples may carry sensor noise: a scenario
/// with `[measurement]` noise, or measured data. Every mass whose displacement and
/// velocity are both in the problem's state and measured (not derived) is a pair.
pub(crate) fn noise_floor(input: &Input, structure: &Problem, batches: usize) -> Option<NoiseFloor> {
    let s = &input.info.scenario;
    if !s.simulation.sensors.noisy() && input.measured().is_none() {
        return None;
    }
    let layout = structure.model.columns();
    let state_of = |c: usize| structure.columns.iter().position(|&k| k == c);
    let pairs = (0..structure.model.masses())
        .filter_map(|i| {
            let (cx, cv) = (layout.x(i), layout.v(i));
            if let Some(m) = input.measured() {
                if !m.present[cx] || !m.present[cv] || m.derived(cx) || m.derived(cv) {
                    return None;
                }
            }
            Some(Pair {
                columns: [cx, cv],
                state: [state_of(cx)?, state_of(cv)?],
                names: [input.info.columns[cx].clone(), input.info.columns[cv].clone()],
            })
        })
        .collect();
    Some(NoiseFloor::new(pairs, s.simulation.sample_interval, batches))
}

/// The log column of a channel.
fn column_of(floor: &NoiseFloor, ch: &ChannelNoise) -> usize {
    floor
        .pairs()
        .iter()
        .find_map(|p| (0..2).find(|&w| p.state[w] == ch.state).map(|w| p.columns[w]))
        .expect("a channel of a pair")
}

/// What a correction builds up: per log column the noise variance to take out, the
/// report's rows and notes, and the variance to put back (taken out as noise of negative
/// variance).
struct Correction {
    by_column: Vec<f64>,
    rows: Vec<ChannelNoiseReport>,
    notes: Vec<String>,
    put_back: Vec<f64>,
    /// Columns whose noise taken out is at least their variance, with the share.
    exceeds: Vec<String>,
}

/// Estimate the noise, correct `data` (and `also`, the naive white-noise row's) as the
/// scenario asks, and say what was done; the noise variance taken out of each log column.
pub(crate) fn correct(
    floor: &NoiseFloor,
    s: &Scenario,
    measured: Option<&Measured>,
    structure: &Problem,
    data: &mut StationaryData,
    also: Option<&mut StationaryData>,
    loss: Option<&FilterLoss>,
) -> (SensorNoiseReport, Vec<f64>, Option<Deconvolution>) {
    let handling = s.identify.sensor_noise;
    let (channels, replicates, not_estimated) = match floor.estimate_with_replicates() {
        Ok((c, r)) => (c, r, None),
        Err(why) => (Vec::new(), Vec::new(), Some(why)),
    };
    let columns = structure.model.columns().len();
    let mut k = Correction {
        by_column: vec![0.0; columns],
        rows: Vec::new(),
        notes: Vec::new(),
        put_back: vec![0.0; columns],
        exceeds: Vec::new(),
    };
    pair_rows(&mut k, floor, &channels, s, structure);
    // Velocities differenced from noisy displacements: the displacement's noise, and what
    // the differences make of it on the velocity (io::measured::differentiate).
    let differenced = measured.map_or(&[][..], |m| &m.differenced[..]);
    differenced_rows(&mut k, differenced, s, structure);
    differences_tail(&mut k, differenced, s, structure);
    let integrated = measured.map_or(&[][..], |m| &m.integrated_noise[..]);
    integrated_rows(&mut k, integrated, s, structure);
    let Correction {
        mut by_column,
        rows,
        mut notes,
        mut put_back,
        exceeds,
    } = k;
    let noise_only = by_column.clone();
    // What the filters and the differences took goes back in as noise of negative variance
    // (a convolution).
    if let Some(l) = loss.filter(|l| l.put_back) {
        for (b, v) in put_back.iter_mut().zip(&l.by_column) {
            *b += v;
        }
    }
    for (b, v) in by_column.iter_mut().zip(&put_back) {
        *b -= v;
    }
    let corrected = by_column.iter().any(|&v| v != 0.0) && structure.atoms.is_empty();
    let replicates = match handling {
        NoiseHandling::Estimate => replicate_corrections(floor, &channels, &replicates, &noise_only, &put_back),
        _ => Vec::new(),
    };
    if let Some(l) = loss {
        notes.push(l.note.clone());
    }
    let applied = corrected.then(|| Deconvolution {
        by_column: by_column.clone(),
        replicates: replicates.clone(),
    });
    if corrected {
        data.deconvolve(&by_column, &replicates);
        // The naive row's problem batches its samples its own way: its replicates keep
        // the whole record's correction.
        if let Some(d) = also {
            d.deconvolve(&by_column, &[]);
        }
        notes.push(
            "the weak form reads moments with the noise taken out; the strong forms and the baselines read the \
             noisy samples as they are; the validation adds the same noise to the model's response"
                .to_string(),
        );
    } else if handling == NoiseHandling::Estimate && !channels.is_empty() && !channels.iter().any(|c| c.detected()) {
        notes.push(
            "no channel shows noise beyond 3 standard errors and within its spectrum's ceiling: nothing taken out"
                .to_string(),
        );
    } else if by_column.iter().any(|&v| v > 0.0) {
        notes.push(
            "not corrected: the model has terms without a polynomial form, whose moments the correction does not reach"
                .to_string(),
        );
    }
    let masses = structure.model.masses();
    let covered = floor.pairs().len() + integrated.len() / 2 + differenced.len();
    if covered < masses {
        notes.push(format!(
            "{} of {masses} masses have no measured displacement–velocity pair: their sensors' noise is neither \
             estimated nor corrected",
            masses - covered,
        ));
    }
    let report = SensorNoiseReport {
        handling: match handling {
            NoiseHandling::Estimate => "estimate",
            NoiseHandling::Given => "given",
            NoiseHandling::Ignore => "ignore",
        }
        .to_string(),
        channels: rows,
        // Without pairs, the differenced or integrated channels' own estimates stand.
        not_estimated: not_estimated
            .filter(|_| !floor.pairs().is_empty() || (integrated.is_empty() && differenced.is_empty())),
        corrected,
        notes,
        filter_loss: loss.map_or_else(Vec::new, |l| l.rows.clone()),
        exceeds_variance: exceeds,
    };
    let noise_taken_out = corrected && noise_only.iter().any(|&v| v > 0.0);
    (report, if noise_taken_out { noise_only } else { Vec::new() }, applied)
}

/// The measured displacement–velocity pairs' channels: the noise each shows, and what is
/// taken out of its column as `[identify] sensor_noise` asks.
fn pair_rows(k: &mut Correction, floor: &NoiseFloor, channels: &[ChannelNoise], s: &Scenario, structure: &Problem) {
    let handling = s.identify.sensor_noise;
    let sensors = &s.simulation.sensors;
    let layout = structure.model.columns();
    let level = |c: usize| {
        let (q, _) = layout.at(c);
        match q {
            crate::model::Quantity::Displacement => sensors.displacement,
            crate::model::Quantity::Velocity => sensors.velocity,
            _ => 0.0,
        }
    };
    // The scenario's sensors in the channel's unit: relative levels times the estimated
    // signal std. An ADC adds its rounding, of variance q²/12 for a step q.
    let stated = |ch: &ChannelNoise, c: usize| -> f64 { sensors.noise_variance(level(c), ch.signal_std).sqrt() };
    let (by_column, rows) = (&mut k.by_column, &mut k.rows);
    for ch in channels {
        let c = column_of(floor, ch);
        if let (true, Some(ceiling), NoiseHandling::Estimate) = (ch.above_ceiling(), ch.ceiling, handling) {
            k.notes.push(format!(
                "{}: the lag expansion's noise, {:.4e} ({:.2} % of the signal's std), is more than its spectrum can \
                 hold (white noise spreads evenly up to Nyquist: at most {:.4e}, {:.2} %): the signal has power \
                 towards Nyquist, where the expansion over the first lags does not hold, so the estimate is the \
                 expansion's truncation and the sensor's noise is at most that ceiling; nothing taken out (a sensor \
                 known to be noisy can be given its level: `sensor_noise = \"given\"` with `[measurement]`; \
                 docs/measurement.md)",
                ch.column,
                ch.std(),
                100.0 * ch.std() / ch.signal_std,
                ceiling.max(0.0).sqrt(),
                100.0 * ceiling.max(0.0).sqrt() / ch.signal_std,
            ));
        }
        let used = match handling {
            // Only noise the data show: clean data are identified exactly as without the
            // estimate (a channel without noise would otherwise take out its sampling
            // noise).
            NoiseHandling::Estimate if ch.detected() => ch.std(),
            NoiseHandling::Estimate => 0.0,
            NoiseHandling::Given => stated(ch, c),
            NoiseHandling::Ignore => 0.0,
        };
        by_column[c] = used * used;
        let std = ch.std();
        rows.push(ChannelNoiseReport {
            column: ch.column.clone(),
            std,
            std_se: ch.variance_std_error / (2.0 * std.max(ch.variance_std_error.sqrt())),
            signal_std: ch.signal_std,
            detected: ch.detected(),
            ceiling_std: ch.ceiling.map(|c| c.max(0.0).sqrt()),
            above_ceiling: ch.above_ceiling(),
            corrected_std: used,
            simulated_std: (sensors.noisy() && s.data.is_none()).then(|| stated(ch, c)),
            at_limits: ch.at_limits,
        });
    }
}

/// Velocities differenced from noisy displacements: each pair's noise, on the
/// displacement and through the differences on the velocity.
fn differenced_rows(k: &mut Correction, differenced: &[DifferencedNoise], s: &Scenario, structure: &Problem) {
    let handling = s.identify.sensor_noise;
    let sensors = &s.simulation.sensors;
    let (by_column, rows) = (&mut k.by_column, &mut k.rows);
    for d in differenced {
        let f = &d.found;
        let h = s.simulation.sample_interval;
        let gain = differentiate::noise_gain(&f.weights(), h);
        let used = match handling {
            NoiseHandling::Estimate if f.detected() => f.noise,
            NoiseHandling::Given => sensors.noise_variance(sensors.displacement, f.signal.sqrt()),
            _ => 0.0,
        };
        by_column[d.displacement] = used;
        by_column[d.velocity] = used * gain;
        let std = f.noise.max(0.0).sqrt();
        let std_se = f.noise_std_error / (2.0 * std.max(f.noise_std_error.sqrt()));
        for (column, scale, signal) in [(d.displacement, 1.0, f.signal), (d.velocity, gain.sqrt(), f.velocity)] {
            rows.push(ChannelNoiseReport {
                column: structure.model.column_names()[column].clone(),
                std: scale * std,
                std_se: scale * std_se,
                signal_std: signal.max(0.0).sqrt(),
                detected: f.detected(),
                ceiling_std: None,
                above_ceiling: false,
                corrected_std: (by_column[column]).sqrt(),
                simulated_std: None,
                at_limits: 0,
            });
        }
    }
}

/// The differences' loss of a white-forced velocity's tail
/// (`differentiate::white_tail_loss`), put back where nothing blocks it.
fn differences_tail(k: &mut Correction, differenced: &[DifferencedNoise], s: &Scenario, structure: &Problem) {
    let handling = s.identify.sensor_noise;
    let layout = structure.model.columns();
    let (notes, put_back) = (&mut k.notes, &mut k.put_back);
    for d in differenced {
        let Some(i) = (0..structure.model.masses()).find(|&i| layout.v(i) == d.velocity) else {
            continue;
        };
        let mut blocked = Vec::new();
        let intensity = white_intensity(s, i, &mut blocked);
        if intensity == 0.0 {
            continue;
        }
        let m = structure.model.mass[i];
        let h = s.simulation.sample_interval;
        let tail = intensity / (m * m) * differentiate::white_tail_loss(&d.found.weights(), h);
        let name = &structure.model.column_names()[d.velocity];
        if handling == NoiseHandling::Ignore {
            blocked.insert(0, "[identify] sensor_noise = \"ignore\"".to_string());
        }
        if blocked.is_empty() {
            put_back[d.velocity] += tail;
            notes.push(format!(
                "the differences take the white-forced tail of {name} out ({:.3} % of its variance, std {:.3e}); the \
                 weak form's moments have it put back (docs/data.md)",
                100.0 * tail / d.found.velocity,
                tail.sqrt()
            ));
        } else {
            blocked.sort();
            blocked.dedup();
            notes.push(format!(
                "the differences take the white-forced tail of {name} out ({:.3} % of its variance), NOT put back: {}",
                100.0 * tail / d.found.velocity,
                blocked.join("; ")
            ));
        }
    }
    if !differenced.is_empty() {
        notes.push(
            "a differenced velocity's noise is its displacement's through the differences: noise of variance σ² \
             becomes σ²·2Σw²/h² over the stencil's weights w, independent of the displacement's own (docs/data.md)"
                .to_string(),
        );
    }
}

/// Accelerometers: their noise estimated below the modes (io::measured, module
/// `integrate`) or stated, through the integration onto velocity and displacement.
fn integrated_rows(k: &mut Correction, integrated: &[IntegratedNoise], s: &Scenario, structure: &Problem) {
    let handling = s.identify.sensor_noise;
    let sensors = &s.simulation.sensors;
    let (by_column, rows, notes) = (&mut k.by_column, &mut k.rows, &mut k.notes);
    let names = structure.model.column_names();
    // Accelerometers: their noise estimated below the modes (io::measured, module
    // `integrate`) or stated, through the integration onto velocity and displacement.
    let (mut parts, mut unknown) = (Vec::new(), Vec::new());
    for n in integrated {
        let stated = sensors
            .acceleration
            .map(|l| sensors.noise_variance(l, n.acceleration_std));
        let found = n.estimated.as_ref().ok();
        let var = match handling {
            NoiseHandling::Estimate => found.filter(|e| e.detected()).map_or(0.0, |e| e.variance),
            NoiseHandling::Given => stated.unwrap_or(0.0),
            NoiseHandling::Ignore => 0.0,
        };
        by_column[n.column] = n.gain * var;
        parts.push(format!("{} {:.4}", names[n.column], by_column[n.column].sqrt()));
        if rows.iter().any(|r| r.column == names[n.acceleration]) {
            continue;
        }
        match &n.estimated {
            Ok(e) => {
                let std = e.variance.max(0.0).sqrt();
                rows.push(ChannelNoiseReport {
                    column: names[n.acceleration].clone(),
                    std,
                    std_se: e.std_error / (2.0 * std.max(e.std_error.sqrt())),
                    signal_std: (n.acceleration_std.powi(2) - e.variance.max(0.0)).max(0.0).sqrt(),
                    detected: e.detected(),
                    ceiling_std: None,
                    above_ceiling: false,
                    corrected_std: var.sqrt(),
                    simulated_std: None,
                    at_limits: 0,
                });
            }
            Err(why) => unknown.push(format!("{}: {why}", names[n.acceleration])),
        }
    }
    // Noise that is much of a column's variance leaves the corrected moments resting on the
    // noise estimate: a few per cent off in it is tens of per cent in them.
    let swamped: Vec<String> = integrated
        .iter()
        .filter(|n| by_column[n.column] > NOISE_SHARE_WARNING * n.variance)
        .map(|n| format!("{} {:.0} %", names[n.column], 100.0 * by_column[n.column] / n.variance))
        .collect();
    k.exceeds.extend(
        (integrated.iter())
            .filter(|n| by_column[n.column] >= n.variance)
            .map(|n| format!("{} {:.0} %", names[n.column], 100.0 * by_column[n.column] / n.variance)),
    );
    if !swamped.is_empty() {
        notes.push(format!(
            "WARNING: the integrated accelerometer noise is much of the motion's variance ({}): the estimates rest \
             on the noise taken out, and an error of a few per cent in it moves them far beyond their standard \
             errors; a quieter accelerometer, or a shorter [data] drift_period (less slow noise), helps \
             (docs/measurement.md)",
            swamped.join(", ")
        ));
    }
    let estimating = handling == NoiseHandling::Estimate;
    if !integrated.is_empty() && (estimating || handling == NoiseHandling::Given && sensors.acceleration.is_some()) {
        notes.push(format!(
            "noise of the columns integrated from accelerations, from the accelerometers' noise {} through the \
             integration: std {} (docs/measurement.md)",
            if estimating {
                "estimated below the modes (the displacement's spectrum near the drift removal's corner)"
            } else {
                "as stated"
            },
            parts.join(", ")
        ));
    }
    if estimating && !unknown.is_empty() {
        notes.push(format!(
            "WARNING: an accelerometer's noise is not estimated ({}), and the integration turns it into slow noise \
             that biases the estimates (1 % of the acceleration's std: k3 by −31 % on duffing2dof): state it in \
             [measurement] acceleration with [identify] sensor_noise = \"given\" (docs/measurement.md)",
            unknown.join("; ")
        ));
    }
    if handling == NoiseHandling::Given && sensors.acceleration.is_none() && !integrated.is_empty() {
        notes.push(
            "WARNING: [identify] sensor_noise = \"given\" but [measurement] states no accelerometer noise: the \
             integration's slow noise is not taken out (docs/measurement.md)"
                .to_string(),
        );
    }
}

/// Estimated noise: each jackknife replicate corrected with its own estimate (columns the
/// pairs do not estimate keep the whole record's correction), less what is put back.
fn replicate_corrections(
    floor: &NoiseFloor,
    channels: &[ChannelNoise],
    replicates: &[Option<Vec<f64>>],
    noise_only: &[f64],
    put_back: &[f64],
) -> Vec<Option<Vec<f64>>> {
    let mut replicates: Vec<Option<Vec<f64>>> = replicates
        .iter()
        .map(|r| {
            r.as_ref().map(|r| {
                // Columns the pairs do not estimate keep the whole record's correction.
                let mut v = noise_only.to_vec();
                for (ch, &var) in channels.iter().zip(r) {
                    let c = column_of(floor, ch);
                    if noise_only[c] > 0.0 {
                        v[c] = var.max(0.0);
                    }
                }
                v
            })
        })
        .collect();
    for r in replicates.iter_mut().flatten() {
        for (b, v) in r.iter_mut().zip(put_back) {
            *b -= v;
        }
    }
    replicates
}

/// What the sensors' filters (`[measurement] anti_alias`, `bandwidth`) take out of a
/// simulated rig's samples: per log column the variance lost, the report's rows and note,
/// and whether the weak form can have it put back.
pub(crate) struct FilterLoss {
    pub by_column: Vec<f64>,
    pub rows: Vec<FilterLossReport>,
    pub note: String,
    pub put_back: bool,
}

/// The share of an integrated column's variance its noise may be before the report warns
/// that the corrected moments rest on the noise estimate (at 25 %, 1 % off in the noise is
/// 0.25 % off in the motion's variance, about a standard error of duffing2dof's k1).
const NOISE_SHARE_WARNING: f64 = 0.25;

/// The velocity tail the sensors' filters take from masses under white forces (module
/// `sim::sensor_filters`, `white_velocity_loss`), computed from the stated filters, intensities
/// and masses; `None` without filters. It is put back only where every white force on the
/// mass is measured, of known intensity, and acts on that mass alone (a force on two masses
/// gives their tails a covariance the per-channel correction does not carry), and the mass
/// is known.
pub(crate) fn filter_loss(s: &Scenario, structure: &Problem) -> Option<FilterLoss> {
    let sim = &s.simulation;
    if s.data.is_some() {
        return None;
    }
    let filter = crate::sim::sensor_filters::SensorFilter::new(
        &sim.sensors,
        sim.sample_interval,
        sim.steps_per_sample(),
        sim.substeps,
    )
    .ok()??;
    let unit = filter.white_velocity_loss(sim.sample_interval);
    let layout = structure.model.columns();
    let names = structure.model.column_names();
    let mut by_column = vec![0.0; layout.len()];
    let mut rows = Vec::new();
    let mut blocked = Vec::new();
    for i in 0..structure.model.masses() {
        let intensity = white_intensity(s, i, &mut blocked);
        if intensity == 0.0 {
            continue;
        }
        let m = structure.model.mass[i];
        let c = layout.v(i);
        by_column[c] = intensity / (m * m) * unit;
        rows.push(FilterLossReport {
            column: names[c].clone(),
            std: by_column[c].sqrt(),
        });
    }
    if rows.is_empty() {
        return None;
    }
    blocked.sort();
    blocked.dedup();
    if s.identify.sensor_noise == NoiseHandling::Ignore {
        blocked.insert(0, "[identify] sensor_noise = \"ignore\"".to_string());
    }
    let put_back = blocked.is_empty() && structure.atoms.is_empty();
    let list = rows
        .iter()
        .map(|r| format!("{} {:.4e}", r.column, r.std))
        .collect::<Vec<_>>()
        .join(", ");
    let note = format!(
        "the sensors' filters take the white-forced velocities' tail above their corner out of the samples (std {list}); {}",
        if put_back {
            "the weak form's moments have it put back (docs/measurement.md)".to_string()
        } else if !structure.atoms.is_empty() {
            "NOT put back: the model has terms without a polynomial form, whose moments the correction does not reach"
                .to_string()
        } else {
            format!("NOT put back: {} (docs/measurement.md)", blocked.join("; "))
        }
    );
    Some(FilterLoss {
        by_column,
        rows,
        note,
        put_back,
    })
}

/// `Σσ_e²` of the white forces on mass `i`, and in `blocked` why a tail computed from it
/// cannot be put back: a force the identifier is not told of, or of unknown intensity, or
/// acting on more than one mass (their tails then covary), or the mass unknown.
fn white_intensity(s: &Scenario, i: usize, blocked: &mut Vec<String>) -> f64 {
    use crate::scenario::Process;
    let mut intensity = 0.0;
    for (e, x) in s.excitations.iter().enumerate() {
        let Process::White { sigma } = x.process else { continue };
        if !x.acts_on.contains(&i) {
            continue;
        }
        intensity += sigma * sigma;
        if !x.measured || s.identify.unknown_intensities.contains(&e) {
            blocked.push(format!("{} is not known to the identifier", x.name));
        } else if s.identify.equivalent_white.contains(&e) {
            blocked.push(format!("{}'s level is read from its spectrum after the pass", x.name));
        } else if x.acts_on.len() > 1 {
            blocked.push(format!("{} acts on more than one mass", x.name));
        }
    }
    if intensity > 0.0 && s.identify.unknown_masses.contains(&i) {
        blocked.push(format!("the mass {} is unknown", s.masses[i].name));
    }
    intensity
}

/// Without sensor noise to estimate: put the filters' loss back into `data` (and `also`)
/// and say so.
pub(crate) fn put_back_filter_loss(
    loss: &FilterLoss,
    s: &Scenario,
    data: &mut StationaryData,
    also: Option<&mut StationaryData>,
) -> SensorNoiseReport {
    if loss.put_back {
        let negative: Vec<f64> = loss.by_column.iter().map(|v| -v).collect();
        data.deconvolve(&negative, &[]);
        if let Some(d) = also {
            d.deconvolve(&negative, &[]);
        }
    }
    SensorNoiseReport {
        handling: match s.identify.sensor_noise {
            NoiseHandling::Estimate => "estimate",
            NoiseHandling::Given => "given",
            NoiseHandling::Ignore => "ignore",
        }
        .to_string(),
        channels: Vec::new(),
        not_estimated: Some("the sensors add no noise".to_string()),
        corrected: loss.put_back,
        notes: vec![loss.note.clone()],
        filter_loss: loss.rows.clone(),
        exceeds_variance: Vec::new(),
    }
}

/// The scenario the validation re-simulates: with the data's noise, so that its
/// statistics compare like with like — a simulation's own sensors, or for measured data
/// the noise taken out of each column.
pub(crate) fn for_validation(s: &Scenario, taken_out: &[f64]) -> Option<Scenario> {
    if (s.simulation.sensors.noisy() && s.data.is_none()) || taken_out.iter().all(|&v| v == 0.0) {
        return None;
    }
    let mut v = s.clone();
    // Measured data: the noise taken out, on the columns it was taken out of (a model
    // file's stated sensors are in it).
    v.simulation.sensors = Default::default();
    v.simulation.sensors.columns = taken_out.iter().map(|v| v.sqrt()).collect();
    Some(v)
}

/// Samples at a channel's limits, more than this many: every row warns of clipping (a
/// continuous signal reaches each extreme once, a quantised one a few times: test
/// `an_adc_is_noise_and_its_clipping_is_flagged`).
pub const CLIPPED: u64 = 10;

/// Every row, where a channel looks clipped: a warning naming it; and every row that
/// reads the noisy samples as they are, where the data show noise: a warning naming the
/// largest noise (the weak form's rows read corrected moments when `n.corrected`).
pub(crate) fn warn_uncorrected(n: &SensorNoiseReport, methods: &mut [MethodReport]) {
    // Noise taken out beyond a column's variance leaves moments of no density: a weak row
    // that failed on them failed for that, not for the data's units.
    if n.corrected && !n.exceeds_variance.is_empty() {
        for m in methods.iter_mut() {
            if let MethodOutcome::Failed(why) = &m.outcome {
                if reads_corrected(m) {
                    m.outcome = MethodOutcome::Failed(format!(
                        "the sensor noise taken out is at least the variance of {} (the integrated accelerometer \
                         noise): the corrected moments are those of no density, and on them {why}; a quieter \
                         accelerometer, a shorter drift window, or the velocities measured (docs/measurement.md)",
                        n.exceeds_variance.join(", ")
                    ));
                }
            }
        }
    }
    let clipped: Vec<String> = n
        .channels
        .iter()
        .filter(|c| c.at_limits > CLIPPED)
        .map(|c| format!("{} ({} samples)", c.column, c.at_limits))
        .collect();
    if !clipped.is_empty() {
        for m in methods.iter_mut() {
            m.warnings.push(format!(
                "samples sit at their channel's smallest or largest value (exactly, or piled up within a thousandth of \
                 its std): {} — a clipped sensor or ADC, \
                 which biases every moment (docs/measurement.md)",
                clipped.join(", ")
            ));
        }
    }
    // The weak form's rows read corrected moments when `n.corrected`.
    let weak = reads_corrected;
    if let Some(most) = n.filter_loss.iter().max_by(|a, b| a.std.total_cmp(&b.std)) {
        for m in methods.iter_mut() {
            if weak(m) && n.corrected {
                continue;
            }
            m.warnings.push(format!(
                "reads the filtered samples as they are: the sensors' filters took the white-forced velocities' \
                 tail out (std up to {:.3e}, on {}), which biases the damping and the nonlinear terms \
                 (docs/measurement.md)",
                most.std, most.column
            ));
        }
    }
    let Some(worst) = n
        .channels
        .iter()
        .filter(|c| c.detected)
        .max_by(|a, b| (a.std / a.signal_std).total_cmp(&(b.std / b.signal_std)))
    else {
        return;
    };
    for m in methods {
        let weak = weak(m);
        if weak && n.corrected {
            continue;
        }
        m.warnings.push(format!(
            "reads the samples with their sensor noise (up to {:.1} % of the signal's std, on {}): {} (docs/measurement.md)",
            100.0 * worst.std / worst.signal_std,
            worst.column,
            if weak {
                "the correction is off, so the estimates carry the noise's bias"
            } else {
                "this method is not corrected for it, so its estimates carry the noise's bias"
            }
        ));
    }
}

/// Whether a row reads the weak form's moments, which the sensor correction corrects.
fn reads_corrected(m: &MethodReport) -> bool {
    matches!(
        m.method,
        ReportMethod::Estimator(Method::Weak | Method::WeakMeasuredForce)
            | ReportMethod::WeakWhiteNaive
            | ReportMethod::Compare(_)
    )
}
