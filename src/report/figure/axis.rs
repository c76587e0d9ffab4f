//! Axes: linear, logarithmic or categorical, their ranges, and ticks formatted for people
//! (`0.001` and `10⁻⁴` never mixed on one axis); units as the labels write them.

/// One axis: range, scale and label (with its unit).
#[derive(Debug, Clone)]
pub struct Axis {
    pub lo: f64,
    pub hi: f64,
    pub log: bool,
    pub label: String,
    /// Whether tick labels are written (a strip below a panel shares its x labels).
    pub tick_labels: bool,
    /// Named positions `1, 2, …` instead of numbers ([`Axis::categories`]).
    pub categories: Vec<String>,
}

impl Axis {
    pub fn linear(lo: f64, hi: f64, label: impl Into<String>) -> Axis {
        Axis {
            lo,
            hi,
            log: false,
            label: label.into(),
            tick_labels: true,
            categories: Vec::new(),
        }
    }
    pub fn log(lo: f64, hi: f64, label: impl Into<String>) -> Axis {
        Axis {
            lo,
            hi,
            log: true,
            label: label.into(),
            tick_labels: true,
            categories: Vec::new(),
        }
    }
    /// A linear axis of named positions: category `k` (from 0) is drawn at `k + 1`, the
    /// axis runs from 0.5 to `n + 0.5`, and the ticks carry the names.
    pub fn categories(names: Vec<String>, label: impl Into<String>) -> Axis {
        let mut a = Axis::linear(0.5, names.len() as f64 + 0.5, label);
        a.categories = names;
        a
    }
    /// The same axis without tick labels.
    pub fn unlabelled(mut self) -> Axis {
        self.tick_labels = false;
        self
    }

    /// Whether this axis can be drawn: finite, ordered, positive on a log scale, and wider
    /// than rounding at its magnitude.
    pub fn drawable(&self) -> bool {
        let (lo, hi) = (self.lo, self.hi);
        let big = lo.abs().max(hi.abs());
        lo.is_finite()
            && hi.is_finite()
            && hi > lo
            && big < 1e100
            && hi - lo > 1e-9 * big
            && (!self.log || (lo > 0.0 && (hi / lo).log10() > 1e-6))
    }

    /// `v`'s position in `[0, 1]` along the axis.
    pub(super) fn frac(&self, v: f64) -> f64 {
        if self.log {
            (v.ln() - self.lo.ln()) / (self.hi.ln() - self.lo.ln())
        } else {
            (v - self.lo) / (self.hi - self.lo)
        }
    }

    /// Major ticks `(value, label)` and unlabelled minor ticks.
    pub fn ticks(&self) -> (Vec<(f64, String)>, Vec<f64>) {
        if !self.categories.is_empty() {
            let named = self.categories.iter().enumerate();
            (named.map(|(k, n)| ((k + 1) as f64, n.clone())).collect(), Vec::new())
        } else if self.log {
            log_ticks(self.lo, self.hi)
        } else {
            (linear_ticks(self.lo, self.hi, 6), Vec::new())
        }
    }
}

/// A unit as printed on an axis: `N*m` → `N·m`, `m/s^2` → `m/s²`.
pub fn unit(u: &str) -> String {
    u.replace('*', "·").replace("^2", "²").replace("^3", "³")
}

/// The reciprocal of a unit, as a density's axis writes it: `1/m`, `s/m` (of `m/s`),
/// `s²/rad` (of `rad/s^2`), `1/(N·m)`.
pub fn per(u: &str) -> String {
    let u = unit(u);
    match u.split_once('/') {
        Some((num, den)) if !den.contains('/') && !num.is_empty() => {
            if num == "1" {
                den.to_string()
            } else {
                format!("{den}/{num}")
            }
        }
        _ if u.contains('·') => format!("1/({u})"),
        _ => format!("1/{u}"),
    }
}

/// A unit squared: `m²`, `(N·m)²`, `(m/s)²`.
pub fn squared(u: &str) -> String {
    if u.contains(['·', '/', '*']) {
        format!("({})²", unit(u))
    } else {
        format!("{}²", unit(u))
    }
}

/// A range padded by `pad` of its width on both sides (or around a single value).
pub fn padded(values: impl IntoIterator<Item = f64>, pad: f64) -> (f64, f64) {
    let (lo, hi) = values
        .into_iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| (l.min(v), h.max(v)));
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let w = if hi > lo { hi - lo } else { lo.abs().max(1e-12) * 0.1 };
    (lo - pad * w, hi + pad * w)
}

/// A positive range for a log axis, widened by `factor` on both sides.
pub fn log_range(values: impl IntoIterator<Item = f64>, factor: f64) -> (f64, f64) {
    let (lo, hi) = values
        .into_iter()
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(l, h), v| (l.min(v), h.max(v)));
    if !lo.is_finite() {
        return (0.1, 10.0);
    }
    let hi = if hi > lo { hi } else { lo * 10.0 };
    (lo / factor, hi * factor)
}

/// Ticks on a linear axis: steps of 1, 2 or 5 × 10^k, about `target` of them, labelled with
/// as many decimals as the step needs (no float artefacts, no `-0`).
pub fn linear_ticks(lo: f64, hi: f64, target: usize) -> Vec<(f64, String)> {
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) || !lo.is_finite() || !hi.is_finite() {
        return Vec::new();
    }
    let raw = (hi - lo) / target.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    // The largest round step that still gives about 60 % of the target count.
    let count = |step: f64| (hi / step + 1e-9).floor() - (lo / step - 1e-9).ceil() + 1.0;
    let want = (0.6 * target as f64).ceil().max(2.0);
    let step = [10.0, 5.0, 2.0, 1.0, 0.5, 0.2]
        .iter()
        .map(|m| m * mag)
        .find(|&s| count(s) >= want)
        .unwrap_or(0.1 * mag);
    let first = (lo / step - 1e-9).ceil() as i64;
    let last = (hi / step + 1e-9).floor() as i64;
    let big = lo.abs().max(hi.abs());
    let scientific = big >= 1e6 || (big < 1e-3 && big > 0.0);
    let decimals = (-(step.log10().floor())).max(0.0) as usize;
    (first..=last)
        .map(|k| {
            let v = k as f64 * step;
            let label = if k == 0 {
                "0".to_string()
            } else if scientific {
                sci(v, step)
            } else {
                format!("{v:.decimals$}")
            };
            (v, label.replace('-', "−"))
        })
        .collect()
}

/// `v` as `m×10^e` with the mantissa's decimals that `step` needs.
fn sci(v: f64, step: f64) -> String {
    let e = v.abs().log10().floor() as i32;
    let m = v / 10f64.powi(e);
    let d = (e as f64 - step.log10().floor()).clamp(0.0, 6.0) as usize;
    let m = format!("{m:.d$}");
    if m == "1" {
        format!("10{}", superscript(e))
    } else if m == "-1" {
        format!("-10{}", superscript(e))
    } else {
        format!("{m}×10{}", superscript(e))
    }
}

fn superscript(e: i32) -> String {
    e.to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            '0' => '⁰',
            '1' => '¹',
            '2' => '²',
            '3' => '³',
            '4' => '⁴',
            '5' => '⁵',
            '6' => '⁶',
            '7' => '⁷',
            '8' => '⁸',
            _ => '⁹',
        })
        .collect()
}

/// Whether a value on a log axis is written in plain decimals (0.001 to 10⁵).
fn plain(v: f64) -> bool {
    (-3..=5).contains(&(v.log10().floor() as i32))
}

/// A value on a log axis: plain decimals (when `plain`), otherwise `10ᵏ` or `m×10ᵏ`.
fn log_label(v: f64, plain: bool) -> String {
    let e = v.log10().floor() as i32;
    let m = (v / 10f64.powi(e)).round() as i64;
    if plain {
        let d = (-e).max(0) as usize;
        format!("{v:.d$}")
    } else if m == 1 {
        format!("10{}", superscript(e))
    } else {
        format!("{m}×10{}", superscript(e))
    }
}

/// Ticks on a log axis: decades labelled; 2 and 5 labelled too when the axis spans under
/// three and a half decades, every 1–9 under 1.2 decades (labels that would collide are
/// skipped when drawn); 1–9 minor ticks unlabelled. Under a third of a decade, linear ticks.
pub fn log_ticks(lo: f64, hi: f64) -> (Vec<(f64, String)>, Vec<f64>) {
    if !(lo > 0.0 && hi > lo) {
        return (Vec::new(), Vec::new());
    }
    let decades = (hi / lo).log10();
    if decades < 0.5 {
        return (linear_ticks(lo, hi, 4), Vec::new());
    }
    let (e0, e1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    // With many decades, label every n-th.
    let every = ((decades / 8.0).ceil() as i32).max(1);
    let (mut major, mut minor) = (Vec::new(), Vec::new());
    for e in e0..=e1 {
        let base = 10f64.powi(e);
        for m in 1..=9 {
            let v = m as f64 * base;
            if v < lo * (1.0 - 1e-9) || v > hi * (1.0 + 1e-9) {
                continue;
            }
            let labelled =
                (m == 1 && e.rem_euclid(every) == 0) || (decades < 3.5 && (m == 2 || m == 5)) || decades < 1.2;
            if labelled {
                major.push((v, String::new()));
            } else {
                minor.push(v);
            }
        }
    }
    if major.len() < 2 {
        // Less than one decade with no power of ten inside: 2 and 5 and their neighbours.
        major = (e0..=e1)
            .flat_map(|e| [1.0, 2.0, 3.0, 5.0].map(|m| m * 10f64.powi(e)))
            .filter(|v| *v >= lo * (1.0 - 1e-9) && *v <= hi * (1.0 + 1e-9))
            .map(|v| (v, String::new()))
            .collect();
        minor.retain(|v| !major.iter().any(|(m, _)| (m - v).abs() < 1e-9 * v));
    }
    // One style per axis: plain decimals only when every label can be plain.
    let all_plain = major.iter().all(|(v, _)| plain(*v));
    for (v, l) in &mut major {
        *l = log_label(*v, all_plain);
    }
    (major, minor)
}
