//! `[[excitation]]` of the lab kinds (docs/excitations.md): a random-phase multisine,
//! band-limited Gaussian noise and Kanai–Tajimi noise — each kind's keys checked, the other
//! kinds' keys refused on it, and the signal checked against the run it drives.

use super::super::raw::{RawExcitation, RawKind, RawScenario};
use super::super::{Excitation, Process, Recorded, Shape, Signal, Simulation};
use super::{finite_positive, Locator};
use crate::scenario::ScenarioError;

/// A multisine's `amplitude = [[Hz, relative amplitude], …]`: at most [`Shape::MAX`]
/// points, frequencies finite, non-negative and rising, amplitudes finite and non-negative,
/// not all zero.
fn check_shape(loc: &Locator, e: &RawExcitation, key: &str) -> Result<Option<Shape>, ScenarioError> {
    let Some(a) = e.amplitude.as_ref() else {
        return Ok(None);
    };
    let points = a.get_ref();
    let bad = |why: String| loc.at(a.span(), format!("{key}.amplitude"), why);
    if points.is_empty() || points.len() > Shape::MAX {
        return Err(bad(format!(
            "{} points: give 1 to {} as [[frequency in Hz, relative amplitude], …]",
            points.len(),
            Shape::MAX
        )));
    }
    for (j, &(f, amp)) in points.iter().enumerate() {
        if !f.is_finite() || f < 0.0 || (j > 0 && f <= points[j - 1].0) {
            return Err(bad(format!(
                "point {}: frequency {f} Hz: the frequencies are finite, non-negative and rising",
                j + 1
            )));
        }
        if !amp.is_finite() || amp < 0.0 {
            return Err(bad(format!(
                "point {}: amplitude {amp}: the relative amplitudes are finite and non-negative",
                j + 1
            )));
        }
    }
    if points.iter().all(|p| p.1 == 0.0) {
        return Err(bad("every amplitude is 0: the multisine would have no line".into()));
    }
    Ok(Some(Shape::new(points)))
}

/// Highest Butterworth order.
const MAX_ORDER: i64 = 16;

/// The signal of a lab kind's `[[excitation]]` (`key` is `excitation[i]`).
pub(crate) fn check_signal(loc: &Locator, e: &RawExcitation, key: &str) -> Result<Signal, ScenarioError> {
    let kind = *e.kind.get_ref();
    let name = match kind {
        RawKind::Multisine => "multisine",
        RawKind::BandLimited => "band-limited",
        RawKind::Recorded => "recorded",
        _ => "kanai-tajimi",
    };
    // The keys each kind takes; any other one written is refused with what the kind takes.
    let takes: &[&str] = match kind {
        RawKind::Multisine => &["rms", "band", "period", "lines", "amplitude"],
        RawKind::BandLimited => &["sigma", "band", "order"],
        RawKind::Recorded => &["file", "column", "time", "sample_interval", "scale"],
        _ => &["sigma", "omega_g", "zeta_g"],
    };
    let written = [
        ("sigma", e.sigma.as_ref().map(|v| v.span())),
        ("A", e.a.as_ref().map(|v| v.span())),
        ("B", e.b.as_ref().map(|v| v.span())),
        ("rms", e.rms.as_ref().map(|v| v.span())),
        ("band", e.band.as_ref().map(|v| v.span())),
        ("period", e.period.as_ref().map(|v| v.span())),
        ("lines", e.lines.as_ref().map(|v| v.span())),
        ("amplitude", e.amplitude.as_ref().map(|v| v.span())),
        ("order", e.order.as_ref().map(|v| v.span())),
        ("omega_g", e.omega_g.as_ref().map(|v| v.span())),
        ("zeta_g", e.zeta_g.as_ref().map(|v| v.span())),
        ("file", e.file.as_ref().map(|v| v.span())),
        ("column", e.column.as_ref().map(|v| v.span())),
        ("time", e.time.as_ref().map(|v| v.span())),
        ("sample_interval", e.sample_interval.as_ref().map(|v| v.span())),
        ("scale", e.scale.as_ref().map(|v| v.span())),
    ];
    for (k, span) in written {
        if let Some(span) = span.filter(|_| !takes.contains(&k)) {
            return Err(loc.at(
                span,
                format!("{key}.{k}"),
                format!("kind = \"{name}\" takes {}, not `{k}`", takes.join(", ")),
            ));
        }
    }
    if !e.measured {
        return Err(loc.at(
            e.kind.span(),
            format!("{key}.measured"),
            "a lab excitation is the rig's input, and it is measured: an unmeasured disturbance is kind = \
             \"white\" or \"filtered\"",
        ));
    }
    let need = |k: &str, v: Option<&toml::Spanned<f64>>, what: &str| {
        let v = v.ok_or_else(|| {
            loc.at(
                e.kind.span(),
                format!("{key}.{k}"),
                format!("kind = \"{name}\" needs `{k}` ({what}); it takes {}", takes.join(", ")),
            )
        })?;
        finite_positive(loc, v, &format!("{key}.{k}"), what)
    };
    let band = || check_band(loc, e, key, name);
    let signal = match kind {
        RawKind::Multisine => {
            let odd = match e.lines.as_ref().map(|l| (l.get_ref().as_str(), l.span())) {
                None | Some(("all", _)) => false,
                Some(("odd", _)) => true,
                Some((other, span)) => {
                    return Err(loc.at(
                        span,
                        format!("{key}.lines"),
                        format!("lines = {other:?}: use \"all\" (every line of the band) or \"odd\""),
                    ))
                }
            };
            let period = need("period", e.period.as_ref(), "s, the time the multisine repeats in")?;
            let s = Signal::Multisine {
                rms: need("rms", e.rms.as_ref(), "the force's RMS")?,
                band: band()?,
                period,
                odd,
                shape: check_shape(loc, e, key)?,
            };
            if s.lines().is_empty() {
                return Err(loc.at(
                    e.band.as_ref().map_or(e.kind.span(), |b| b.span()),
                    format!("{key}.band"),
                    format!(
                        "no line of the period's grid (every {:.6} Hz{}) lies in the band{}",
                        1.0 / period,
                        if odd { ", odd lines only" } else { "" },
                        if e.amplitude.is_some() {
                            " where the amplitude is above 0"
                        } else {
                            ""
                        }
                    ),
                ));
            }
            s
        }
        RawKind::Recorded => check_recorded(loc, e, key)?,
        RawKind::BandLimited => {
            let order = e.order.as_ref().ok_or_else(|| {
                loc.at(
                    e.kind.span(),
                    format!("{key}.order"),
                    format!("kind = \"band-limited\" needs the Butterworth filter's `order` (1 to {MAX_ORDER})"),
                )
            })?;
            if !(1..=MAX_ORDER).contains(order.get_ref()) {
                return Err(loc.at(
                    order.span(),
                    format!("{key}.order"),
                    format!(
                        "the Butterworth order must be 1 to {MAX_ORDER}, got {}",
                        order.get_ref()
                    ),
                ));
            }
            Signal::BandLimited {
                sigma: need(
                    "sigma",
                    e.sigma.as_ref(),
                    "the white noise's intensity before the filter",
                )?,
                band: band()?,
                order: *order.get_ref() as u32,
            }
        }
        _ => Signal::KanaiTajimi {
            sigma: need(
                "sigma",
                e.sigma.as_ref(),
                "the white noise's intensity before the filter",
            )?,
            omega_g: need(
                "omega_g",
                e.omega_g.as_ref(),
                "the filter's natural angular frequency, rad/s",
            )?,
            zeta_g: need("zeta_g", e.zeta_g.as_ref(), "the filter's damping ratio")?,
        },
    };
    Ok(signal)
}

/// A recorded signal's keys: `file` and `column`, and either `sample_interval` (s) or
/// `time` (a column whose spacing gives it); `scale` a finite non-zero factor. The table is
/// read later, by [`crate::Scenario::read_recordings`].
fn check_recorded<'a>(loc: &Locator, e: &'a RawExcitation, key: &str) -> Result<Signal, ScenarioError> {
    let text = |v: Option<&'a toml::Spanned<String>>, k: &str, what: &str| {
        let v = v.ok_or_else(|| {
            loc.at(
                e.kind.span(),
                format!("{key}.{k}"),
                format!("kind = \"recorded\" needs `{k}` ({what})"),
            )
        })?;
        if v.get_ref().trim().is_empty() {
            return Err(loc.at(v.span(), format!("{key}.{k}"), format!("`{k}` is empty: {what}")));
        }
        Ok(v)
    };
    let file = text(
        e.file.as_ref(),
        "file",
        "the table holding the signal, CSV or .npy, relative to the scenario file",
    )?;
    let column = text(e.column.as_ref(), "column", "the table's column holding the signal")?;
    let time = e
        .time
        .as_ref()
        .map(|t| text(Some(t), "time", "the table's time column, s"))
        .transpose()?;
    let interval = match (time, e.sample_interval.as_ref()) {
        (Some(t), Some(_)) => {
            return Err(loc.at(
                t.span(),
                format!("{key}.time"),
                "give the recording's `sample_interval` or its `time` column, not both",
            ))
        }
        (None, None) => {
            return Err(loc.at(
                e.kind.span(),
                format!("{key}.sample_interval"),
                "kind = \"recorded\" needs the recording's `sample_interval` (s) or its `time` column",
            ))
        }
        (None, Some(h)) => Some(finite_positive(
            loc,
            h,
            &format!("{key}.sample_interval"),
            "the recording's sample interval, s",
        )?),
        (Some(_), None) => None,
    };
    let scale = match e.scale.as_ref() {
        None => 1.0,
        Some(s) if s.get_ref().is_finite() && *s.get_ref() != 0.0 => *s.get_ref(),
        Some(s) => {
            return Err(loc.at(
                s.span(),
                format!("{key}.scale"),
                format!(
                    "scale = {}: the force per unit of the column is a finite number other than 0",
                    s.get_ref()
                ),
            ))
        }
    };
    Ok(Signal::Recorded(std::sync::Arc::new(Recorded {
        file: file.get_ref().into(),
        column: column.get_ref().clone(),
        time: time.map(|t| t.get_ref().clone()),
        interval,
        scale,
        samples: Vec::new(),
        at: file.span(),
    })))
}

/// A white or filtered `[[excitation]]` with a lab signal's key: refused, naming the kinds
/// that take it.
pub(crate) fn refuse_signal_keys(loc: &Locator, e: &RawExcitation, key: &str) -> Result<(), ScenarioError> {
    let written = [
        ("rms", e.rms.as_ref().map(|v| v.span()), "multisine"),
        ("band", e.band.as_ref().map(|v| v.span()), "multisine and band-limited"),
        ("period", e.period.as_ref().map(|v| v.span()), "multisine"),
        ("lines", e.lines.as_ref().map(|v| v.span()), "multisine"),
        ("amplitude", e.amplitude.as_ref().map(|v| v.span()), "multisine"),
        ("order", e.order.as_ref().map(|v| v.span()), "band-limited"),
        ("omega_g", e.omega_g.as_ref().map(|v| v.span()), "kanai-tajimi"),
        ("zeta_g", e.zeta_g.as_ref().map(|v| v.span()), "kanai-tajimi"),
        ("file", e.file.as_ref().map(|v| v.span()), "recorded"),
        ("column", e.column.as_ref().map(|v| v.span()), "recorded"),
        ("time", e.time.as_ref().map(|v| v.span()), "recorded"),
        (
            "sample_interval",
            e.sample_interval.as_ref().map(|v| v.span()),
            "recorded",
        ),
        ("scale", e.scale.as_ref().map(|v| v.span()), "recorded"),
    ];
    match written.into_iter().find_map(|(k, span, kinds)| Some((k, span?, kinds))) {
        None => Ok(()),
        Some((k, span, kinds)) => Err(loc.at(
            span,
            format!("{key}.{k}"),
            format!("`{k}` belongs to the lab kind(s) {kinds} (docs/excitations.md), not to white or filtered noise"),
        )),
    }
}

/// `band = [low, high]` in Hz, `0 ≤ low < high` (a low of 0 makes a band-limited noise a
/// low-pass).
fn check_band(loc: &Locator, e: &RawExcitation, key: &str, name: &str) -> Result<(f64, f64), ScenarioError> {
    let k = format!("{key}.band");
    let b = e.band.as_ref().ok_or_else(|| {
        loc.at(
            e.kind.span(),
            k.clone(),
            format!("kind = \"{name}\" needs `band = [low, high]` in Hz"),
        )
    })?;
    let v: Vec<f64> = b.get_ref().iter().map(|x| *x.get_ref()).collect();
    match v[..] {
        [lo, hi] if lo.is_finite() && hi.is_finite() && lo >= 0.0 && hi > lo => Ok((lo, hi)),
        _ => Err(loc.at(
            b.span(),
            k,
            format!("band must be [low, high] in Hz with 0 <= low < high, got {v:?}"),
        )),
    }
}

/// The lab excitations against the run: they drive a simulation (a model file's measured
/// force is declared `kind = "white"` with `[identify] equivalent_white`), a white noise
/// beside them is a disturbance, a multisine repeats after whole sample intervals, and the
/// sampled force does not alias (its band ends below the sampling's Nyquist frequency).
pub(crate) fn check_lab_run(
    loc: &Locator,
    raw: &RawScenario,
    excitations: &[Excitation],
    sim: &Simulation,
    measured_data: bool,
) -> Result<(), ScenarioError> {
    let lab: Vec<usize> = (0..excitations.len())
        .filter(|&k| matches!(excitations[k].process, Process::Lab(_)))
        .collect();
    let Some(&first) = lab.first() else { return Ok(()) };
    let at = |k: usize| raw.excitation[k].kind.span();
    if measured_data {
        return Err(loc.at(
            at(first),
            format!("excitation[{first}].kind"),
            "a lab signal is simulated; the force of measured data is declared kind = \"white\" and listed in \
             [identify] equivalent_white (docs/data.md)",
        ));
    }
    // Beside lab signals white noise is band-limited to the step's Nyquist frequency
    // (sim::lab): a disturbance's response loses a fraction of a per cent, but a measured
    // white force's interval means would lack what lies beyond, a level read from them low.
    if let Some(k) = (0..excitations.len())
        .find(|&k| excitations[k].measured && matches!(excitations[k].process, Process::White { .. }))
    {
        return Err(loc.at(
            at(k),
            format!("excitation[{k}].kind"),
            "beside lab excitations white noise is simulated band-limited to the integration step's Nyquist \
             frequency, and a measured white force's logged interval means would lack what lies beyond it (7 % \
             of their variance at four steps a sample): declare it measured = false (a disturbance), or \
             kind = \"filtered\" or \"band-limited\"",
        ));
    }
    let nyquist = 0.5 / sim.sample_interval;
    for &k in &lab {
        let Process::Lab(s) = &excitations[k].process else {
            unreachable!()
        };
        let high = match *s {
            Signal::Multisine { band, .. } | Signal::BandLimited { band, .. } => band.1,
            Signal::KanaiTajimi { .. } => 0.0,
            // Its sampling against the run's is checked when it is read.
            Signal::Recorded(_) => continue,
        };
        if high >= nyquist {
            return Err(loc.at(
                raw.excitation[k].band.as_ref().map_or(at(k), |b| b.span()),
                format!("excitation[{k}].band"),
                format!(
                    "the band reaches {high} Hz, at or beyond the sampling's Nyquist frequency {nyquist} Hz \
                     (sample_interval {} s): the logged force would alias",
                    sim.sample_interval
                ),
            ));
        }
        if let Signal::Multisine { period, .. } = *s {
            let r = period / sim.sample_interval;
            if (r - r.round()).abs() > 1e-6 * r || r.round() < 2.0 {
                return Err(loc.at(
                    raw.excitation[k].period.as_ref().map_or(at(k), |p| p.span()),
                    format!("excitation[{k}].period"),
                    format!(
                        "the multisine's period must be a whole number (at least 2) of sample intervals, as a \
                         lab's generator and acquisition share a clock: {period} s is {r} × {} s",
                        sim.sample_interval
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Read every recorded signal's table (`file` relative to `dir`) into its samples, and
/// check it against the run: its samples finite, its time column (if named) evenly spaced,
/// the run sampled at the recording's interval or finer (the logged force would alias
/// otherwise), and every trajectory's stretch inside the recording. Errors point at the
/// excitation's `file` in `label`'s text (`s.source`).
pub(crate) fn read_recordings(
    s: &mut crate::Scenario,
    label: &str,
    dir: &std::path::Path,
    read: &crate::scenario::TableReader,
) -> Result<(), ScenarioError> {
    let source = s.source.clone();
    let loc = Locator {
        path: label,
        src: &source,
    };
    let sim = &s.simulation;
    let span = sim.trajectory_span();
    let (trajectories, run_interval) = (sim.trajectories, sim.sample_interval);
    for (k, e) in s.excitations.iter_mut().enumerate() {
        let Process::Lab(Signal::Recorded(r)) = &mut e.process else {
            continue;
        };
        let key = format!("excitation[{k}].file");
        let r = std::sync::Arc::make_mut(r);
        let bad = |why: String| loc.at(r.at.clone(), key.clone(), why);
        let path = dir.join(&r.file);
        let (names, columns) = read(&path).map_err(|e| bad(format!("the recording: {e}")))?;
        let column = |name: &str, role: &str| {
            names
                .iter()
                .position(|n| n == name)
                .map(|c| &columns[c])
                .ok_or_else(|| {
                    bad(format!(
                        "{} has no column {name:?} ({role}); it has {}",
                        path.display(),
                        names.join(", ")
                    ))
                })
        };
        let samples = column(&r.column, "the signal")?;
        if samples.len() < 2 {
            return Err(bad(format!(
                "{} holds {} row(s): a recording needs at least 2 samples",
                path.display(),
                samples.len()
            )));
        }
        if let Some(row) = samples.iter().position(|v| !v.is_finite()) {
            return Err(bad(format!(
                "column {:?} of {} is not a finite number at row {} (a recording drives the run sample by \
                 sample: fill or cut the gap first)",
                r.column,
                path.display(),
                row + 1
            )));
        }
        if let Some(name) = r.time.clone() {
            r.interval = Some(
                even_spacing(column(&name, "the time")?)
                    .map_err(|why| bad(format!("time column {name:?} of {}: {why}", path.display())))?,
            );
        }
        r.samples.clone_from(samples);
        let h = r.interval.expect("given, or read from the time column");
        if run_interval > h * (1.0 + 1e-9) {
            return Err(bad(format!(
                "the run samples every {run_interval} s, coarser than the recording's {h} s: the logged force \
                 would alias what the recording holds between its Nyquist frequency and the run's; sample \
                 at {h} s or finer"
            )));
        }
        if let Some(why) = r.too_short(trajectories, span) {
            return Err(bad(why));
        }
    }
    Ok(())
}

/// The spacing of an evenly spaced time column: its mean step, if every step is within a
/// thousandth of it.
fn even_spacing(t: &[f64]) -> Result<f64, String> {
    if t.len() < 2 || !t.iter().all(|v| v.is_finite()) {
        return Err("it needs at least 2 finite times".into());
    }
    let h = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    if h <= 0.0 {
        return Err("the times do not rise".into());
    }
    match t.windows(2).position(|w| ((w[1] - w[0]) - h).abs() > 1e-3 * h) {
        None => Ok(h),
        Some(row) => Err(format!(
            "the step between rows {} and {} is {} s, the mean step {h} s: a recording is sampled evenly \
             (resample it first)",
            row + 1,
            row + 2,
            t[row + 1] - t[row]
        )),
    }
}
