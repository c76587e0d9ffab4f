//! `iteration.svg`: the section-4 sequences step by step.

use super::write_figure;
use crate::model::{Characteristic, ParameterName, UnknownName};
use crate::report::figure::{color, padded, Axis, Figure, Mark, Panel, Stroke, Swatch, BLACK};
use crate::report::Report;
use crate::scenario::{Motion, ReportMethod};
use std::path::{Path, PathBuf};

/// The unit of an unknown (`k3[ground-m1]`: N/m³), empty for one that is no parameter.
pub(crate) fn parameter_unit(name: &UnknownName, motion: Motion) -> String {
    let [ux, uv, _, uf, um] = motion.units().map(crate::report::figure::unit);
    let (ux, uv, uf, um) = (ux.as_str(), uv.as_str(), uf.as_str(), um.as_str());
    let sup = |p: u32| match p {
        1 => String::new(),
        2 => "²".into(),
        3 => "³".into(),
        p => format!("^{p}"),
    };
    // `m` to a power: `m³`; a compound unit in brackets: `(m/s)³`, and `N/(m/s)`.
    let over = |u: &str, p: u32| {
        if u.contains('/') {
            format!("({u}){}", sup(p))
        } else {
            format!("{u}{}", sup(p))
        }
    };
    match name.parameter() {
        Some(ParameterName::Mass(_)) => um.into(),
        // A coefficient is a force per its term's unit (the argument's to the term's degree).
        Some(ParameterName::Coefficient { kind, term, .. }) => match (term.degree(), kind) {
            (0, _) => uf.into(),
            (d, Characteristic::Stiffness) => format!("{uf}/{}", over(ux, d)),
            (d, Characteristic::Damping) => format!("{uf}/{}", over(uv, d)),
        },
        Some(ParameterName::Corner(_)) => "1/s".into(),
        _ => String::new(),
    }
}

/// Every parameter of the iterative procedure against the step number, one line per
/// sequence, with the true value (dashed black), each sequence's bound — the estimate with
/// the disturbance given as measured (dotted, in the sequence's colour) — and the one-step
/// `direct-force` estimate (long dashes); one legend for all panels in a cell of its own.
pub fn plot_iteration(r: &Report, path: &Path) -> std::io::Result<Vec<PathBuf>> {
    let Some(first) = r.iterations.first() else {
        return Ok(Vec::new());
    };
    let motion = r.scenario_def.as_ref().map_or(Motion::Translational, |s| s.motion);
    let names = &first.iteration.names;
    let estimates = |method: &ReportMethod| {
        r.methods
            .iter()
            .find(|m| m.method == *method && m.outcome.error().is_none())
            .map(|m| m.parameters.iter().map(|p| p.estimate).collect::<Vec<f64>>())
    };
    // Reference lines: (stroke, label, estimates): each sequence's bound, in its colour,
    // and the one-step estimate.
    let mut lines: Vec<(Stroke, String, Vec<f64>)> = r
        .iterations
        .iter()
        .enumerate()
        .filter_map(|(j, it)| {
            let v = estimates(&it.bound)?;
            let label = format!("{}: P_z given as measured, bound of {}", it.bound, it.method);
            Some((Stroke::dashed(color(j), 1.3, 2.0, 3.0), label, v))
        })
        .collect();
    if let Some(v) = estimates(&ReportMethod::DirectForce) {
        let label = format!("{}: one solve of (4.8), no iteration", ReportMethod::DirectForce);
        lines.push((Stroke::dashed(color(r.iterations.len()), 2.0, 10.0, 4.0), label, v));
    }
    let truth_stroke = Stroke::dashed(BLACK, 1.2, 6.0, 4.0);
    let steps = r
        .iterations
        .iter()
        .map(|it| it.iteration.steps.len())
        .max()
        .unwrap_or(0);
    let last = steps.max(2) as f64 - 1.0;
    let mut panels = Vec::new();
    for (k, name) in names.iter().enumerate() {
        let sequences: Vec<Vec<(f64, f64)>> = r
            .iterations
            .iter()
            .map(|it| {
                it.iteration
                    .steps
                    .iter()
                    .map(|s| (s.step as f64, s.values[k]))
                    .collect()
            })
            .collect();
        let truth = first.truth[k];
        let (lo, hi) = padded(
            sequences
                .iter()
                .flat_map(|v| v.iter().map(|p| p.1))
                .chain([truth])
                .chain(lines.iter().map(|l| l.2[k])),
            0.1,
        );
        let unit = parameter_unit(name, motion);
        let mut p = Panel::new(
            name.to_string(),
            Axis::linear(-0.2, last + 0.2, "step"),
            Axis::linear(
                lo,
                hi,
                if unit.is_empty() {
                    "estimate".to_string()
                } else {
                    format!("estimate ({unit})")
                },
            ),
        );
        p.mark(Mark::HLine {
            y: truth,
            stroke: truth_stroke,
        });
        for (stroke, _, values) in &lines {
            p.mark(Mark::HLine {
                y: values[k],
                stroke: *stroke,
            });
        }
        for (j, values) in sequences.into_iter().enumerate() {
            p.mark(Mark::Line {
                points: values.clone(),
                stroke: Stroke::solid(color(j), 2.0),
            });
            p.mark(Mark::Points {
                points: values,
                color: color(j),
                radius: 3.5,
            });
        }
        panels.push(p);
    }
    // The legend, in a cell of its own after the panels.
    let mut entries: Vec<(Swatch, String)> = r
        .iterations
        .iter()
        .enumerate()
        .map(|(j, it)| {
            (
                Swatch::LinePoint(Stroke::solid(color(j), 2.0), 3.5),
                format!("{}: {} single-mass step", it.method, it.iteration.single_mass.name()),
            )
        })
        .collect();
    entries.push((Swatch::Line(truth_stroke), "true value".into()));
    entries.extend(lines.iter().map(|(s, l, _)| (Swatch::Line(*s), l.clone())));
    panels.push(Panel::legend_cell(entries));
    let mut fig = Figure::new(1100.0);
    fig.grid(2, 300.0, panels);
    write_figure(path, &fig)
}
