//! `compare.svg`, the paper's Fig. 7 for a scenario with `[identify.compare.NAME]` models:
//! each characteristic a comparison model identifies, drawn against the main model's
//! estimate and the truth over the data's range, with the data's distribution beneath.
//! On `silentblock` this is the identified cubic `K_N` (3.27) against the equivalent-linear
//! `K_L` (3.23).

use super::characteristics::{observed, words};
use super::{histogram_strip, write_figure};
use crate::model::{Characteristic, Term};
use crate::report::figure::{color, padded, unit, Axis, Corner, Figure, Mark, Panel, Stroke, Swatch, BLACK};
use crate::report::{CurveReport, MethodReport, Report};
use crate::scenario::ReportMethod;
use crate::stats;
use std::path::{Path, PathBuf};

/// `x` to `digits` significant digits, without exponent below 10⁶ (no trailing zeros).
fn significant(x: f64, digits: i32) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let e = x.log10().floor() as i32;
    if !(-4..6).contains(&e) {
        return format!("{:.*e}", (digits - 1) as usize, x);
    }
    let d = (digits - 1 - e).max(0) as usize;
    let s = format!("{x:.d$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// A characteristic as a formula: `225.2 u + 1.335e4 u³`.
fn formula(coefficients: &[(Term, f64)], var: &str) -> String {
    let mut s = String::new();
    for (k, &(t, c)) in coefficients.iter().enumerate() {
        let mag = significant(c.abs(), 5);
        let sign = if c < 0.0 { "−" } else { "+" };
        s += &match (k, c < 0.0) {
            (0, false) => String::new(),
            (0, true) => "−".into(),
            _ => format!(" {sign} "),
        };
        s += &format!("{mag} {}", t.written(var));
    }
    s
}

/// Terms a legend writes out; a longer characteristic (e.g. eight hinges) is shortened
/// there, and written whole in the figure's description.
const LEGEND_TERMS: usize = 4;

/// [`formula`] for a legend: at most [`LEGEND_TERMS`] terms, then how many more.
fn legend_formula(coefficients: &[(Term, f64)], var: &str) -> String {
    match coefficients.len() {
        n if n <= LEGEND_TERMS => formula(coefficients, var),
        n => format!(
            "{} + … ({} more terms)",
            formula(&coefficients[..LEGEND_TERMS - 1], var),
            n - LEGEND_TERMS + 1
        ),
    }
}

/// Whether the report has comparison models to draw.
pub fn has_comparisons(r: &Report) -> bool {
    r.methods
        .iter()
        .any(|m| matches!(m.method, ReportMethod::Compare(_)) && !m.curves.is_empty())
}

/// The method whose estimate of the scenario's own model is drawn beside the comparisons.
fn main_method(r: &Report) -> Option<&MethodReport> {
    r.methods
        .iter()
        .find(|m| super::characteristics::sets_range(m) && m.outcome.error().is_none())
}

/// The comparison models' estimates of one characteristic.
fn compared<'a>(r: &'a Report, link: &str, kind: Characteristic) -> Vec<(&'a MethodReport, &'a CurveReport)> {
    r.methods
        .iter()
        .filter(|m| matches!(m.method, ReportMethod::Compare(_)))
        .filter_map(|m| {
            m.curves
                .iter()
                .find(|c| c.link == link && c.kind == kind.name())
                .map(|c| (m, c))
        })
        .collect()
}

/// The main method's curve of one characteristic.
fn main_curve<'a>(r: &'a Report, link: &str, kind: Characteristic) -> Option<(&'a MethodReport, &'a CurveReport)> {
    let m = main_method(r)?;
    let c = m.curves.iter().find(|c| c.link == link && c.kind == kind.name())?;
    Some((m, c))
}

/// The figure's caption, written in the page under it: what is compared, and every curve
/// as a formula.
pub fn caption(r: &Report) -> String {
    let mut out = vec![
        "Identified models compared on the same samples, as the paper's Fig. 7 compares the bushing's cubic \
         K_N(φ) = k1 φ + k3 φ³ (3.27) with its equivalent-linear K_L(φ) = k φ (3.23) over the range of φ the \
         data cover."
            .to_string(),
    ];
    let Some(s) = r.scenario_def.as_ref() else {
        return out.join(" ");
    };
    let uf = unit(s.motion.units()[3]);
    for link in &s.links {
        for kind in [Characteristic::Stiffness, Characteristic::Damping] {
            let compared = compared(r, &link.name, kind);
            if compared.is_empty() {
                continue;
            }
            let (_, func, var) = words(kind);
            if let Some((m, c)) = main_curve(r, &link.name, kind) {
                out.push(format!(
                    "{} {}: the scenario's model identified by {}, {func} = {} ({uf}).",
                    link.name,
                    kind.name(),
                    m.method,
                    formula(&c.identified, var)
                ));
            }
            for (m, c) in compared {
                let linear = c.identified.len() == 1 && c.identified[0].0 == Term::Power(1);
                out.push(format!(
                    "{}: {func} = {} ({uf}){}",
                    m.method,
                    formula(&c.identified, var),
                    if linear {
                        ", the equivalent-linear model: the straight line whose drift best matches the data's \
                         stationary density. It agrees with the nonlinear characteristic where most samples lie \
                         and misses the stiffening (or softening) at large amplitudes, which the cubic model \
                         captures; its slope is an amplitude-weighted mean of the nonlinear characteristic's."
                    } else {
                        "."
                    }
                ));
            }
        }
    }
    out.join(" ")
}

/// The comparison figure; `Ok(empty)` without comparison models.
pub fn plot_compare(r: &Report, path: &Path) -> std::io::Result<Vec<PathBuf>> {
    let Some(s) = r.scenario_def.as_ref() else {
        return Ok(Vec::new());
    };
    let uf = unit(s.motion.units()[3]);
    let mut panels = Vec::new();
    let mut strips = Vec::new();
    for (l, link) in s.links.iter().enumerate() {
        for kind in [Characteristic::Stiffness, Characteristic::Damping] {
            let compared = compared(r, &link.name, kind);
            if compared.is_empty() {
                continue;
            }
            let (hist, unit, xs) = observed(r, l, kind);
            let (what, func, var) = words(kind);
            let (lo, hi) = (hist.lo, hist.hi);
            let mut p = Panel::new(
                format!(
                    "{} {}: {what} {func}, identified models compared",
                    link.name,
                    kind.name()
                ),
                Axis::linear(lo, hi, "").unlabelled(),
                Axis::linear(0.0, 1.0, format!("{func} ({uf})")),
            );
            let mut ys_all = Vec::new();
            let mut curve = |p: &mut Panel, coefficients: &[(Term, f64)], stroke: Stroke, label: String| {
                let poly = stats::characteristic(coefficients);
                let pts: Vec<(f64, f64)> = xs.iter().map(|&z| (z, poly.eval(z))).collect();
                ys_all.extend(pts.iter().map(|q| q.1));
                p.line(pts, stroke, Some(label));
            };
            if let Some((m, c)) = main_curve(r, &link.name, kind) {
                curve(
                    &mut p,
                    &c.identified,
                    Stroke::solid(color(0), 2.4),
                    format!(
                        "{} (scenario model): {func} = {}",
                        m.method,
                        legend_formula(&c.identified, var)
                    ),
                );
            }
            for (j, (m, c)) in compared.iter().enumerate() {
                curve(
                    &mut p,
                    &c.identified,
                    Stroke::dashed(color(j + 1), 2.0, 8.0, 4.0),
                    format!("{}: {func} = {}", m.method, legend_formula(&c.identified, var)),
                );
            }
            if let Some(truth) = super::characteristics::truth_of(r, &link.name, kind) {
                let stroke = Stroke::solid(BLACK, 1.3);
                let pts: Vec<(f64, f64)> = xs.iter().map(|&z| (z, truth.eval(z))).collect();
                ys_all.extend(pts.iter().map(|q| q.1));
                p.mark(Mark::Line { points: pts, stroke });
                p.legend.insert(0, (Swatch::Line(stroke), "true".into()));
            }
            let (y0, y1) = padded(ys_all, 0.06);
            p.y.lo = y0;
            p.y.hi = y1;
            p.legend_at = Corner::Above;
            panels.push(p);
            strips.push(histogram_strip(
                hist,
                &format!("{var} ({unit}) over the observed range; grey: the data's distribution"),
            ));
        }
    }
    if panels.is_empty() {
        return Ok(Vec::new());
    }
    let mut fig = Figure::new(900.0);
    for (p, s) in panels.into_iter().zip(strips) {
        fig.row(440.0, vec![Some(p)]);
        fig.row(110.0, vec![Some(s)]);
    }
    write_figure(path, &fig)
}
