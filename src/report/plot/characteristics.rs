//! `characteristics.svg`: identified against true characteristics over the observed ranges.
//! The truth is a thin black line drawn on top, so every estimate stays visible beneath
//! it; each FPK estimate carries its 95 % pointwise band (from the jackknife's covariance of
//! its coefficients, [`crate::report::CurveReport::half_width_95`]). The y-range is set by the
//! truth and the FPK estimators that are meant to be right; baselines and deliberately
//! wrong models (naive white noise, product of marginals, comparison models) are dashed
//! and clipped, with an arrow where they leave the range. Under each characteristic a
//! residual panel draws what the main panel cannot show at these accuracies: each FPK
//! estimate minus the truth with its band (on measured data, with no truth, the band alone
//! around zero).

use super::{histogram_strip, write_figure};
use crate::model::Characteristic;
use crate::report::figure::{color, padded, unit, Axis, Corner, Figure, Mark, Panel, Stroke, Swatch, BLACK};
use crate::report::text::fmt_err;
use crate::report::{MethodReport, Report};
use crate::scenario::ReportMethod;
use crate::stats;
use crate::stats::Histogram;
use std::path::{Path, PathBuf};

/// Whether a method's curve is meant to be right, and so sets the y-range: a gated FPK
/// estimator other than the product of marginals — gated, or one that would be on
/// simulated data (on measured data nothing is graded, but the weak and strong forms are
/// still the estimates the page is about).
pub(crate) fn sets_range(m: &MethodReport) -> bool {
    match &m.method {
        ReportMethod::Estimator(x) => x.is_gated(),
        _ => m.gated,
    }
}

/// The true characteristic, when the truth knows every coefficient of it (measured data
/// leave the unknowns without values).
pub(crate) fn truth_of(r: &Report, link: &str, kind: Characteristic) -> Option<crate::scenario::Curve> {
    let t = r.truth.characteristic(link, kind);
    (!t.is_empty() && t.terms.iter().all(|x| x.1.is_finite())).then_some(t)
}

/// Names for a characteristic's panel: (what it is, its function, its argument).
pub(crate) fn words(kind: Characteristic) -> (&'static str, &'static str, &'static str) {
    match kind {
        Characteristic::Stiffness => ("spring force", "K(u)", "u"),
        Characteristic::Damping => ("damper force", "C(w)", "w"),
    }
}

/// A characteristic's argument over link `l`'s observed range: the data's histogram, the
/// argument's unit and 241 points spanning the range.
pub(crate) fn observed(r: &Report, l: usize, kind: Characteristic) -> (&Histogram, String, Vec<f64>) {
    let [ux, uv, ..] = r.scenario_def.as_ref().expect("scenario").motion.units();
    let (hist, u) = match kind {
        Characteristic::Stiffness => (&r.plot.link_hist[l].0, ux),
        Characteristic::Damping => (&r.plot.link_hist[l].1, uv),
    };
    let (lo, hi) = (hist.lo, hist.hi);
    let xs = (0..=240).map(|k| lo + (hi - lo) * k as f64 / 240.0).collect();
    (hist, unit(u), xs)
}

/// For every link and characteristic: truth and each method's estimate over the observed
/// range, with the data's distribution beneath.
/// Whether any characteristic has something to draw: nothing does when every method was
/// refused and there is no truth (measured data), and the figure is then left out.
pub fn has_panels(r: &Report) -> bool {
    let Some(s) = r.scenario_def.as_ref() else {
        return false;
    };
    let uf = unit(s.motion.units()[3]);
    s.links.iter().enumerate().any(|(l, link)| {
        [Characteristic::Stiffness, Characteristic::Damping]
            .into_iter()
            .any(|kind| characteristic_panels(r, l, link, kind, &uf).is_some())
    })
}

pub fn plot_characteristics(r: &Report, path: &Path) -> std::io::Result<Vec<PathBuf>> {
    let s = r.scenario_def.as_ref().expect("scenario");
    let uf = unit(s.motion.units()[3]);
    let mut panels = Vec::new();
    let mut residuals = Vec::new();
    let mut strips = Vec::new();
    for (l, link) in s.links.iter().enumerate() {
        for kind in [Characteristic::Stiffness, Characteristic::Damping] {
            if let Some((panel, residual, strip)) = characteristic_panels(r, l, link, kind, &uf) {
                panels.push(panel);
                residuals.push(residual);
                strips.push(strip);
            }
        }
    }
    let mut fig = Figure::new(1200.0);
    let cols = 2;
    let mut panels = panels.into_iter();
    let mut residuals = residuals.into_iter();
    let mut strips = strips.into_iter();
    loop {
        let mut top: Vec<Option<Panel>> = panels.by_ref().take(cols).map(Some).collect();
        if top.is_empty() {
            break;
        }
        let n = top.len();
        let mut middle: Vec<Option<Panel>> = residuals.by_ref().take(n).collect();
        let mut bottom: Vec<Option<Panel>> = strips.by_ref().take(n).map(Some).collect();
        for row in [&mut top, &mut middle, &mut bottom] {
            row.resize_with(cols, || None);
        }
        fig.row(380.0, top);
        fig.row(150.0, middle);
        fig.row(100.0, bottom);
    }
    write_figure(path, &fig)
}

/// One characteristic's three panels: the estimates over the truth with their bands, the
/// residual (none where no FPK estimator identifies it) and the data's distribution of its
/// argument; `None` where nothing is known or identified about it.
fn characteristic_panels(
    r: &Report,
    l: usize,
    link: &crate::scenario::Link,
    kind: Characteristic,
    uf: &str,
) -> Option<(Panel, Option<Panel>, Panel)> {
    let truth = truth_of(r, &link.name, kind).unwrap_or_default();
    let identified = r
        .methods
        .iter()
        .any(|m| m.curves.iter().any(|c| c.link == link.name && c.kind == kind.name()));
    if truth.is_empty() && !identified {
        return None;
    }
    let (hist, unit, xs) = observed(r, l, kind);
    let (what, func, var) = words(kind);
    let (lo, hi) = (hist.lo, hist.hi);
    let true_ys: Vec<f64> = xs.iter().map(|&z| truth.eval(z)).collect();
    let known = !truth.is_empty();
    let mut range_values: Vec<f64> = if known { true_ys.clone() } else { Vec::new() };
    let mut marks = Vec::new();
    let mut lines = Vec::new();
    let mut legend = Vec::new();
    let mut residual = Panel::new(
        "",
        Axis::linear(lo, hi, "").unlabelled(),
        Axis::linear(
            0.0,
            1.0,
            if known {
                format!("{} − {func} ({uf})", func.replacen('(', "\u{302}(", 1))
            } else {
                format!("95 % band ({uf})")
            },
        ),
    );
    let mut residual_values = vec![0.0];
    for (mi, m) in r.methods.iter().enumerate() {
        let Some(c) = m.curves.iter().find(|c| c.link == link.name && c.kind == kind.name()) else {
            continue;
        };
        let p = stats::characteristic(&c.identified);
        let ys: Vec<f64> = xs.iter().map(|&z| p.eval(z)).collect();
        let col = color(mi);
        let right = sets_range(m);
        if right {
            range_values.extend(&ys);
            let half: Vec<f64> = xs.iter().map(|&z| c.half_width_95(z).unwrap_or(0.0)).collect();
            if c.half_width_95(0.0).is_some() {
                marks.push(Mark::Band {
                    xs: xs.clone(),
                    lower: ys.iter().zip(&half).map(|(y, h)| y - h).collect(),
                    upper: ys.iter().zip(&half).map(|(y, h)| y + h).collect(),
                    color: col,
                    opacity: 0.2,
                });
            }
            let truth_ys = known.then_some(true_ys.as_slice());
            residual_marks(&mut residual, &mut residual_values, (&xs, &ys, &half), truth_ys, col);
        }
        let stroke = if right {
            Stroke::solid(col, 3.2)
        } else {
            Stroke::dashed(col, 1.6, 7.0, 4.0)
        };
        let mut notes = Vec::new();
        if c.rel_l2_error.is_finite() {
            notes.push(format!("{} error", fmt_err(c.rel_l2_error)));
        }
        if right && !c.covariance.is_empty() {
            notes.push("95 % band".into());
        }
        let label = if notes.is_empty() {
            m.method.to_string()
        } else {
            format!("{} ({})", m.method, notes.join(", "))
        };
        lines.push((xs.iter().copied().zip(ys).collect::<Vec<_>>(), stroke, label));
    }
    if range_values.is_empty() {
        // Nothing is meant to be right (measured data, baselines only): every curve.
        range_values = lines.iter().flat_map(|l| l.0.iter().map(|p| p.1)).collect();
    }
    let (y0, y1) = padded(range_values, 0.06);
    for (pts, stroke, mut label) in lines {
        if pts.iter().any(|p| p.1 < y0 || p.1 > y1) {
            label += " — off scale ▲▼";
        }
        legend.push((Swatch::Line(stroke), label));
        marks.push(Mark::Line { points: pts, stroke });
    }
    let mut title = format!("{} {}: {what} {func}", link.name, kind.name());
    let mut notes = Vec::new();
    if known {
        let truth_stroke = Stroke::solid(BLACK, 1.3);
        marks.push(Mark::Line {
            points: xs.iter().copied().zip(true_ys).collect(),
            stroke: truth_stroke,
        });
        legend.insert(0, (Swatch::Line(truth_stroke), "true".into()));
        if legend.len() == 1 {
            title += " — known, not identified";
            notes.push("given in the scenario as known; no method estimates it".to_string());
        }
    }
    let mut panel = Panel::new(
        title,
        Axis::linear(lo, hi, "").unlabelled(),
        Axis::linear(y0, y1, format!("{func} ({uf})")),
    );
    panel.marks = marks;
    panel.legend = legend;
    panel.legend_at = Corner::Above;
    panel.notes = notes;
    panel.mark_exits = true;
    let (r0, r1) = padded(residual_values, 0.08);
    residual.y.lo = r0;
    residual.y.hi = r1;
    // Zero under the residuals, not over them.
    residual.marks.insert(
        0,
        Mark::HLine {
            y: 0.0,
            stroke: Stroke::solid(BLACK, 1.0),
        },
    );
    let strip = histogram_strip(
        hist,
        &format!(
            "{var} ({unit}): relative {} over the observed range; grey: the data's distribution",
            if kind == Characteristic::Stiffness {
                "displacement"
            } else {
                "velocity"
            }
        ),
    );
    // A characteristic that no FPK estimator identifies has no residual to show.
    Some((panel, (residual.marks.len() > 1).then_some(residual), strip))
}

/// The residual of one estimate, `estimate − truth` (or 0 with no truth), with its band:
/// drawn on `residual`, its extent added to `values`.
fn residual_marks(
    residual: &mut Panel,
    values: &mut Vec<f64>,
    (xs, ys, half): (&[f64], &[f64], &[f64]),
    truth: Option<&[f64]>,
    col: crate::report::figure::Color,
) {
    let d: Vec<f64> = match truth {
        Some(t) => ys.iter().zip(t).map(|(y, t)| y - t).collect(),
        None => vec![0.0; xs.len()],
    };
    let lower: Vec<f64> = d.iter().zip(half).map(|(y, h)| y - h).collect();
    let upper: Vec<f64> = d.iter().zip(half).map(|(y, h)| y + h).collect();
    values.extend(lower.iter().chain(&upper));
    residual.mark(Mark::Band {
        xs: xs.to_vec(),
        lower,
        upper,
        color: col,
        opacity: 0.2,
    });
    if truth.is_some() {
        residual.mark(Mark::Line {
            points: xs.iter().copied().zip(d).collect(),
            stroke: Stroke::solid(col, 2.2),
        });
    }
}
