//! Whether a table's columns are what their mapping says: where a mass's displacement and
//! velocity (or velocity and acceleration) are both measured, the one must be the other's
//! rate of change — in size (units: a degree against a radian is 57.3), in sign (a sensor
//! mounted the other way) and in order (two columns swapped). Judged from the
//! cross-spectrum over the band that holds the motion's power, which holds at any sampling
//! that resolves the motion (docs/data.md, units).

use crate::ident::spectrum::Derivative;

/// How far a derivative's column may scale from the rate of change of its quantity's
/// column before the units count as wrong (a degree against a radian is 57.3, a
/// millimetre against a metre 1000, g against m/s² 9.81, Hz against rad/s 6.28).
pub const UNITS_TOLERANCE: f64 = 1.5;

/// Below this lead a derivative's column is taken to lag its quantity's rate of change
/// (−1 exactly for the negative; noise and coarse sampling keep a true derivative above
/// 0.9 on the shipped cases).
const LAGS: f64 = -0.5;

/// The unit mix-ups a factor suggests.
fn unit_hint(factor: f64) -> &'static str {
    let f = if factor < 1.0 { 1.0 / factor } else { factor };
    let near = |x: f64| (f / x - 1.0).abs() < 0.03;
    if near(180.0 / std::f64::consts::PI) {
        " (57.3: degrees against radians)"
    } else if near(1000.0) {
        " (1000: millimetres against metres)"
    } else if near(9.80665) {
        " (9.81: g against m/s²)"
    } else if near(2.0 * std::f64::consts::PI) {
        " (6.28: cycles against radians, Hz against rad/s)"
    } else if near(100.0) {
        " (100: centimetres against metres)"
    } else {
        ""
    }
}

/// The mapped columns of measured data, and how each relates to the rate of change of
/// another of its mass (`Measured`'s cross-spectra, both ways round, where both are mapped
/// and the first one's motion crosses its mean).
pub(super) struct Mapped<'a> {
    /// (the layout's column, the table's column name) of every mapped quantity.
    pub columns: &'a [(usize, String)],
    /// The layout's quantity names (`x_m1`, …).
    pub names: &'a [String],
    /// ((from, to), how `to` relates to the rate of change of `from`).
    pub derivatives: &'a [((usize, usize), Option<Derivative>)],
}

impl Mapped<'_> {
    fn column(&self, k: usize) -> Option<&str> {
        self.columns.iter().find(|x| x.0 == k).map(|x| x.1.as_str())
    }

    fn name(&self, k: usize) -> String {
        format!("{} (column {:?})", self.names[k], self.column(k).unwrap_or("?"))
    }

    /// How column `d` relates to the rate of change of column `f`, when both are mapped.
    fn derivative(&self, f: usize, d: usize) -> Option<Derivative> {
        self.derivatives.iter().find(|x| x.0 == (f, d)).and_then(|x| x.1)
    }
}

/// Units, signs and order that make no physical sense. For each mass's pairs (x, v) and
/// (v, a) that are both mapped, the derivative's cross-spectrum with its quantity must show
/// the rate of change: a gain within [`UNITS_TOLERANCE`] of 1 and a lead of a quarter period
/// (`CrossWelch::derivative_gain`). Otherwise the error — with the layout column it is
/// about — says which: two columns swapped (the reversed pair is a derivative), a sign
/// flipped (the size fits, the lead is −1), or a column off by a factor (with `x`, `v` and
/// `a` all given, the one that disagrees with both others).
pub(super) fn check_units(m: &Mapped, masses: &[(usize, usize, usize)]) -> Result<(), (usize, String)> {
    let off = |g: f64| !(1.0 / UNITS_TOLERANCE..=UNITS_TOLERANCE).contains(&g);
    for &(x, v, a) in masses {
        let (xv, va) = (m.derivative(x, v), m.derivative(v, a));
        for (f, d, fit) in [(x, v, xv), (v, a, va)] {
            match fit {
                Some(fit) if fit.lead < LAGS => return Err(order_or_sign(m, f, d, fit)),
                _ => {}
            }
        }
        let says = |k: usize, factor: f64, against: &str| {
            format!(
                "the units do not fit together: {} is {factor:.4} times what {against} says it should be{}; check \
                 [data.scale] for {:?} (docs/data.md, units)",
                m.name(k),
                unit_hint(factor),
                m.column(k).unwrap_or("?")
            )
        };
        let rate = |k: usize| format!("the rate of change of {}", m.name(k));
        let lone = |d: usize, f: usize, g: f64| {
            (
                d,
                format!(
                    "{}, or {} is {:.4} times too large",
                    says(d, g, &rate(f)),
                    m.name(f),
                    1.0 / g
                ),
            )
        };
        match (xv.map(|d| d.gain), va.map(|d| d.gain)) {
            (Some(g1), Some(g2)) if off(g1) && off(g2) => return Err((v, says(v, g1, &rate(x)))),
            (Some(g1), Some(_)) if off(g1) => {
                return Err((x, says(x, 1.0 / g1, &format!("{} (its rate of change)", m.name(v)))))
            }
            (Some(_), Some(g2)) if off(g2) => return Err((a, says(a, g2, &rate(v)))),
            // One pair only: either column may be the one off.
            (Some(g), None) if off(g) => return Err(lone(v, x, g)),
            (None, Some(g)) if off(g) => return Err(lone(a, v, g)),
            _ => {}
        }
    }
    Ok(())
}

/// A derivative's column `d` that lags the rate of change of `f`: the two columns swapped
/// when `f` is `d`'s rate of change instead, else a sign flipped when the size fits.
fn order_or_sign(m: &Mapped, f: usize, d: usize, fit: Derivative) -> (usize, String) {
    let swapped = m
        .derivative(d, f)
        .is_some_and(|r| r.lead > -LAGS && (1.0 / UNITS_TOLERANCE..=UNITS_TOLERANCE).contains(&r.gain));
    if swapped {
        (
            f,
            format!(
                "{} and {} look swapped: the first column is the second's rate of change, not the other way \
                 round (lead {:+.2} of a quarter period); check [data.columns] (docs/data.md, units)",
                m.name(f),
                m.name(d),
                fit.lead
            ),
        )
    } else {
        (
            d,
            format!(
                "{} is the negative of the rate of change of {} (lead {:+.2} of a quarter period, size {:.3}): a \
                 sensor mounted the other way? give column {:?} the factor -1 in [data.scale] (docs/data.md, units)",
                m.name(d),
                m.name(f),
                fit.lead,
                fit.gain,
                m.column(d).unwrap_or("?")
            ),
        )
    }
}
