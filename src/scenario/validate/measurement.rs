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
            Some(Adc {
                bits: bits as u32,
                range: finite_positive(loc, r, "measurement.adc_range", unit)?,
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
    Ok(Sensors {
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
/// the simulation's steps must carry them (`sim::filters::SensorFilter::new`).
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
    crate::sim::filters::SensorFilter::new(&sim.sensors, sim.sample_interval, sim.steps_per_sample() * sim.substeps)
        .map(|_| ())
        .map_err(|e| loc.at(span, key, e))
}
