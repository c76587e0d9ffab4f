//! `characteristics.svg`: identified against true characteristics over the observed ranges.
//! The truth is a thin black line drawn on top, so every estimate stays visible beneath
//! it; each FPK estimate carries its 95 % pointwise band (from the jackknife's covariance of
//! its coefficients, [`crate::report::Curve::half_width_95`]). The y-range is set by the
//! truth and the FPK estimators that are meant to be right; baselines and deliberately
//! wrong models (naive white noise, product of marginals, comparison models) are dashed
//! and clipped, with an arrow where they leave the range.

use super::{histogram_strip, write_figure};
use crate::model::Characteristic;
use crate::report::figure::{color, padded, unit, Axis, Corner, Figure, Mark, Panel, Stroke, Swatch, BLACK};
use crate::report::text::fmt_err;
use crate::report::{MethodReport, Report};
use crate::scenario::{Method, ReportMethod};
use crate::stats;
use crate::stats::Histogram;
use std::path::{Path, PathBuf};

/// Whether a method's curve is meant to be right, and so sets the y-range: a gated FPK
/// estimator other than the product of marginals.
pub(crate) fn sets_range(m: &MethodReport) -> bool {
    m.gated && m.method != ReportMethod::Estimator(Method::StrongMarginals)
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
pub fn plot_characteristics(r: &Report, path: &Path) -> std::io::Result<Vec<PathBuf>> {
    let s = r.scenario_def.as_ref().expect("scenario");
    let uf = unit(s.motion.units()[3]);
    let mut panels = Vec::new();
    let mut strips = Vec::new();
    for (l, link) in s.links.iter().enumerate() {
        for kind in [Characteristic::Stiffness, Characteristic::Damping] {
            let truth = r.truth.characteristic(&link.name, kind);
            let identified = r
                .methods
                .iter()
                .any(|m| m.curves.iter().any(|c| c.link == link.name && c.kind == kind.name()));
            if truth.is_empty() && !identified {
                continue;
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
                    if c.half_width_95(0.0).is_some() {
                        let half: Vec<f64> = xs.iter().map(|&z| c.half_width_95(z).unwrap_or(0.0)).collect();
                        marks.push(Mark::Band {
                            xs: xs.clone(),
                            lower: ys.iter().zip(&half).map(|(y, h)| y - h).collect(),
                            upper: ys.iter().zip(&half).map(|(y, h)| y + h).collect(),
                            color: col,
                            opacity: 0.2,
                        });
                    }
                }
                let stroke = if right {
                    Stroke::solid(col, 3.2)
                } else {
                    Stroke::dashed(col, 1.6, 7.0, 4.0)
                };
                let label = format!(
                    "{} ({} error{})",
                    m.method,
                    fmt_err(c.rel_l2_error),
                    if right && !c.covariance.is_empty() {
                        ", 95 % band"
                    } else {
                        ""
                    }
                );
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
            panel.legend_at = Corner::UpperLeft;
            panel.notes = notes;
            panel.mark_exits = true;
            panels.push(panel);
            strips.push(histogram_strip(
                hist,
                &format!(
                    "{var} ({unit}): relative {} over the observed range; grey: the data's distribution",
                    if kind == Characteristic::Stiffness {
                        "displacement"
                    } else {
                        "velocity"
                    }
                ),
            ));
        }
    }
    let mut fig = Figure::new(1200.0);
    let cols = 2;
    let mut panels = panels.into_iter();
    let mut strips = strips.into_iter();
    loop {
        let top: Vec<Option<Panel>> = panels.by_ref().take(cols).map(Some).collect();
        if top.is_empty() {
            break;
        }
        let mut bottom: Vec<Option<Panel>> = strips.by_ref().take(top.len()).map(Some).collect();
        let mut top = top;
        top.resize_with(cols, || None);
        bottom.resize_with(cols, || None);
        fig.row(360.0, top);
        fig.row(100.0, bottom);
    }
    write_figure(path, &fig)
}
