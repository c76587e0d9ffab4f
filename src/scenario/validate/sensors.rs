//! `[measurement]`: the sensors' noise levels, ADC and filters, every error located by
//! file, line, column and key (docs/measurement.md).

use super::*;

/// `[measurement]`: each level finite and ≥ 0, a relative one below 10 (a sensor a
/// thousand per cent noise measures nothing).
pub(crate) fn check_measurement(loc: &Locator, raw: &RawScenario) -> Result<Sensors, ScenarioError> {
    let Some(m) = &raw.measurement else {
        return Ok(Sensors::default());
    };
    let level = |v: &Option<Spanned<f64>>, key: &str| -> Result<f64, ScenarioError> {
        let Some(v) = v else { return Ok(0.0) };
        let x = *v.get_ref();
        let most = if m.noise == NoiseScale::Relative {
            10.0
        } else {
            f64::MAX
        };
        if x.is_finite() && (0.0..=most).contains(&x) {
            Ok(x)
        } else {
            Err(loc.at(
                v.span(),
                key,
                match m.noise {
                    NoiseScale::Relative => {
                        format!("must be a fraction of the channel's standard deviation, 0..=10 (0.1 = 10 %), got {x}")
                    }
                    NoiseScale::Absolute => {
                        format!("must be a finite noise standard deviation >= 0 in the channel's unit, got {x}")
                    }
                },
            ))
        }
    };
    let adc = match (&m.adc_bits, &m.adc_range) {
        (None, None) => None,
        (Some(b), Some(r)) => {
            let bits = *b.get_ref();
            if !(2..=32).contains(&bits) {
                return Err(loc.at(
                    b.span(),
                    "measurement.adc_bits",
                    format!("must be a whole number of bits 2..=32, got {bits}"),
                ));
            }
            let unit = match m.noise {
                NoiseScale::Relative => "the channel's standard deviations, e.g. 5",
                NoiseScale::Absolute => "the channel's unit",
            };
            let range = finite_positive(loc, r, "measurement.adc_range", unit)?;
            check_adc_range(loc, r.span(), m.noise, bits as u32, range)?;
            Some(Adc {
                bits: bits as u32,
                range,
            })
        }
        (Some(b), None) => {
            return Err(loc.at(
                b.span(),
                "measurement.adc_bits",
                "an ADC needs its range too: adc_range = ± the full scale",
            ))
        }
        (None, Some(r)) => {
            return Err(loc.at(
                r.span(),
                "measurement.adc_range",
                "an ADC needs its resolution too: adc_bits = 2..=32",
            ))
        }
    };
    let rig = check_rig(loc, raw, m)?;
    let measures = |f: fn(&MassSensors) -> bool| rig.as_ref().is_none_or(|r| r.iter().any(f));
    for (v, key, given, word) in [
        (
            &m.displacement,
            "measurement.displacement",
            measures(|s| s.displacement),
            "displacement",
        ),
        (
            &m.velocity,
            "measurement.velocity",
            measures(|s| s.velocity),
            "velocity",
        ),
        (
            &m.acceleration,
            "measurement.acceleration",
            measures(|s| s.acceleration),
            "acceleration",
        ),
        (&m.force, "measurement.force", measures(|s| s.force), "force"),
    ] {
        if let (Some(v), false) = (v, given) {
            return Err(loc.at(
                v.span(),
                key,
                format!("a noise level for a quantity no sensor gives: add \"{word}\" to a mass's `sensors`, or leave it out"),
            ));
        }
    }
    Ok(Sensors {
        rig,
        scale: m.noise,
        displacement: level(&m.displacement, "measurement.displacement")?,
        velocity: level(&m.velocity, "measurement.velocity")?,
        acceleration: m
            .acceleration
            .is_some()
            .then(|| level(&m.acceleration, "measurement.acceleration"))
            .transpose()?,
        force: m
            .force
            .is_some()
            .then(|| level(&m.force, "measurement.force"))
            .transpose()?,
        columns: Vec::new(),
        adc,
        anti_alias: check_anti_alias(loc, m)?,
        bandwidth: m
            .bandwidth
            .as_ref()
            .map(|b| finite_positive(loc, b, "measurement.bandwidth", "the sensors' −3 dB corner, Hz"))
            .transpose()?,
    })
}

/// `anti_alias` (the corner, a fraction of the sampling rate, 0 < · ≤ 1) and its
/// `anti_alias_order` (1..=8, default 4).
fn check_anti_alias(loc: &Locator, m: &RawMeasurement) -> Result<Option<AntiAlias>, ScenarioError> {
    let Some(c) = &m.anti_alias else {
        if let Some(o) = &m.anti_alias_order {
            return Err(loc.at(
                o.span(),
                "measurement.anti_alias_order",
                "an order without a filter: give its corner too, `anti_alias = 0.4` (× the sampling rate)",
            ));
        }
        return Ok(None);
    };
    let corner = *c.get_ref();
    if !(corner.is_finite() && corner > 0.0 && corner <= 1.0) {
        return Err(loc.at(
            c.span(),
            "measurement.anti_alias",
            format!(
                "must be the filter's corner as a fraction of the sampling rate, 0 < corner <= 1 (0.4 is usual: \
                 below the Nyquist frequency at 0.5), got {corner}"
            ),
        ));
    }
    let order = match &m.anti_alias_order {
        None => 4,
        Some(o) => {
            let n = *o.get_ref();
            if !(1..=8).contains(&n) {
                return Err(loc.at(
                    o.span(),
                    "measurement.anti_alias_order",
                    format!("must be the Butterworth filter's order, 1..=8, got {n}"),
                ));
            }
            n as u32
        }
    };
    Ok(Some(AntiAlias { corner, order }))
}

/// The sensors' filters are a simulated rig's (measured data carry theirs already), and
/// the simulation's steps must carry them (`Sensors::filter_oversampling`, as the simulator
/// will run them).
pub(crate) fn check_sensor_filters(
    loc: &Locator,
    raw: &RawScenario,
    sim: &Simulation,
    measured: bool,
) -> Result<(), ScenarioError> {
    let Some(m) = &raw.measurement else { return Ok(()) };
    let (key, span) = match (&m.anti_alias, &m.bandwidth) {
        (Some(a), _) => ("measurement.anti_alias", a.span()),
        (None, Some(b)) => ("measurement.bandwidth", b.span()),
        (None, None) => return Ok(()),
    };
    if measured {
        return Err(loc.at(
            span,
            key,
            "the sensors' filters shape a simulated rig's samples; measured data went through their rig's \
             filters already: leave anti_alias and bandwidth out of a model file",
        ));
    }
    sim.sensors
        .filter_oversampling(sim.sample_interval, sim.steps_per_sample(), sim.substeps)
        .map(|_| ())
        .map_err(|e| loc.at(span, key, e))
}

/// `sensors = { m1 = ["acceleration", "force"], … }`: every mass listed, each with a
/// displacement or an acceleration sensor (the state is rebuilt from one of them), a force
/// cell only where a force acts; not in a model file (its `[data]` says what was measured).
fn check_rig(loc: &Locator, raw: &RawScenario, m: &RawMeasurement) -> Result<Option<Vec<MassSensors>>, ScenarioError> {
    let Some(table) = &m.sensors else { return Ok(None) };
    if raw.data.is_some() {
        return Err(loc.at(
            table.span(),
            "measurement.sensors",
            "sensors describe a simulated rig; a model file's [data] maps the columns that were measured",
        ));
    }
    let names: Vec<&str> = raw.mass.iter().map(|m| m.name.get_ref().as_str()).collect();
    let mut rig = vec![None; names.len()];
    for (mass, words) in table.get_ref() {
        let key = format!("measurement.sensors.{mass}");
        let Some(i) = names.iter().position(|n| n == mass) else {
            return Err(loc.at(
                words.span(),
                key,
                format!("no mass is named `{mass}`; the masses: {}", names.join(", ")),
            ));
        };
        let mut s = MassSensors::default();
        for w in words.get_ref() {
            let flag = match w.get_ref().as_str() {
                "displacement" => &mut s.displacement,
                "velocity" => &mut s.velocity,
                "acceleration" => &mut s.acceleration,
                "force" => &mut s.force,
                other => {
                    return Err(loc.at(
                        w.span(),
                        key,
                        format!("`{other}` is no sensor: one of {}", MassSensors::WORDS.join(", ")),
                    ))
                }
            };
            *flag = true;
        }
        if !s.displacement && !s.acceleration {
            return Err(loc.at(
                words.span(),
                key,
                "a mass needs a displacement or an acceleration sensor: its motion is rebuilt from one of them",
            ));
        }
        let pushed = raw
            .excitation
            .iter()
            .any(|e| e.acts_on.get_ref().iter().any(|t| t.get_ref() == mass));
        if s.force && !pushed {
            return Err(loc.at(
                words.span(),
                key,
                format!("no excitation acts on `{mass}`: there is no force to measure"),
            ));
        }
        rig[i] = Some(s);
    }
    if let Some(i) = rig.iter().position(Option::is_none) {
        return Err(loc.at(
            table.span(),
            "measurement.sensors",
            format!(
                "`{}` has no sensors: list every mass with what its sensors give",
                names[i]
            ),
        ));
    }
    Ok(Some(rig.into_iter().flatten().collect()))
}

/// An ADC's range the identification can read: relative to the channel's std, at least half
/// of it (below, most samples clip and what is left is their sign) and with a step of at
/// most one std (above, most samples round to zero); absolute, within [`MAGNITUDE`] of the
/// channel's unit. (A range of 1e-300 std once made every value subnormal.)
fn check_adc_range(
    loc: &Locator,
    span: std::ops::Range<usize>,
    scale: NoiseScale,
    bits: u32,
    range: f64,
) -> Result<(), ScenarioError> {
    let step = 2.0 * range / (1u64 << bits) as f64;
    let shown = if (1e-3..1e6).contains(&range) {
        range.to_string()
    } else {
        format!("{range:e}")
    };
    let why = match scale {
        NoiseScale::Relative if range < 0.5 => format!(
            "an ADC whose full scale is ±{shown} of the channel's standard deviation clips most of its samples \
             (over 60 % of a Gaussian channel's below ±0.5): what is left is their sign, not the motion; a range of \
             4–6 clips a few in 10⁵–10⁹, 1–3 makes a clipping study"
        ),
        NoiseScale::Relative if step > 1.0 => format!(
            "the ADC's step 2·range/2^bits = {step} standard deviations rounds most samples to zero: more bits or a \
             smaller range"
        ),
        NoiseScale::Absolute if !(MAGNITUDE.0..=MAGNITUDE.1).contains(&range) => format!(
            "a full scale of ±{shown} in the channel's unit: values that small or large leave the floating-point \
             range when the identification raises them to powers of 12 and more; give the quantities units of \
             order 1 (the range within {:e}…{:e})",
            MAGNITUDE.0, MAGNITUDE.1
        ),
        _ => return Ok(()),
    };
    Err(loc.at(span, "measurement.adc_range", why))
}
