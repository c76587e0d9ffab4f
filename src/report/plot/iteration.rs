//! `iteration.svg`: the section-4 sequences step by step.

use super::{drawable, not_drawable, svg_to_file, PlotResult, COLORS};
use crate::report::Report;
use crate::scenario::ReportMethod;
use plotters::prelude::*;
use std::path::Path;

/// Every parameter of the iterative procedure against the step number, one line per
/// sequence, with the true value (dashed), each sequence's bound — the estimate with the
/// disturbance given as measured (dotted, in the sequence's colour) — and the one-step
/// `direct-force` estimate (long dashes); one legend for all panels in a cell of its own.
pub fn plot_iteration(r: &Report, path: &Path) -> PlotResult {
    let Some(first) = r.iterations.first() else {
        return Ok(());
    };
    let names = &first.iteration.names;
    // One cell more than the panels: the legend's.
    let rows = (names.len() + 1).div_ceil(2);
    let estimates = |method: &ReportMethod| {
        r.methods
            .iter()
            .find(|m| m.method == *method && m.error.is_none())
            .map(|m| m.parameters.iter().map(|p| p.estimate).collect::<Vec<f64>>())
    };
    // Reference lines: (style, label, estimates, dash, gap): each sequence's bound, in its
    // colour, and the one-step estimate.
    let mut lines: Vec<(ShapeStyle, String, Vec<f64>, u32, u32)> = r
        .iterations
        .iter()
        .enumerate()
        .filter_map(|(j, it)| {
            let v = estimates(&it.bound)?;
            let label = format!("{}: P_z given as measured, bound of {}", it.bound, it.method);
            Some((COLORS[j].stroke_width(1), label, v, 2, 3))
        })
        .collect();
    if let Some(v) = estimates(&ReportMethod::DirectForce) {
        let label = format!("{}: one solve of (4.8), no iteration", ReportMethod::DirectForce);
        lines.push((COLORS[r.iterations.len()].stroke_width(2), label, v, 10, 4));
    }
    let tstyle = ShapeStyle {
        color: BLACK.to_rgba(),
        filled: false,
        stroke_width: 1,
    };
    svg_to_file(path, (1000, 300 * rows as u32), |root| {
        let cells = root.split_evenly((rows, 2));
        for (k, area) in cells.iter().enumerate().take(names.len()) {
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
            let ys = sequences
                .iter()
                .flat_map(|v| v.iter().map(|p| p.1))
                .chain([truth])
                .chain(lines.iter().map(|l| l.2[k]))
                .filter(|y| y.is_finite());
            let (lo, hi) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), y| (l.min(y), h.max(y)));
            let pad = 0.1 * (hi - lo).max(1e-3 * truth.abs().max(1e-12));
            let steps = sequences.iter().map(Vec::len).max().unwrap_or(0);
            let last = steps.max(2) as f64 - 1.0;
            if !drawable(lo - pad, hi + pad) {
                not_drawable(area, &names[k], (-0.2, last + 0.2), (lo - pad, hi + pad))?;
                continue;
            }
            let mut chart = ChartBuilder::on(area)
                .caption(&names[k], ("sans-serif", 16))
                .margin(10)
                .x_label_area_size(34)
                .y_label_area_size(70)
                .build_cartesian_2d(-0.2..last + 0.2, lo - pad..hi + pad)?;
            chart
                .configure_mesh()
                .x_desc("step")
                .y_desc("estimate")
                .x_labels(steps.clamp(2, 12))
                .draw()?;
            chart.draw_series(DashedLineSeries::new(
                vec![(-0.2, truth), (last + 0.2, truth)],
                6,
                4,
                tstyle,
            ))?;
            for (style, _, values, dash, gap) in &lines {
                let b = values[k];
                if b.is_finite() {
                    chart.draw_series(DashedLineSeries::new(
                        vec![(-0.2, b), (last + 0.2, b)],
                        *dash,
                        *gap,
                        *style,
                    ))?;
                }
            }
            for (j, values) in sequences.into_iter().enumerate() {
                let c = COLORS[j];
                chart.draw_series(LineSeries::new(values.clone(), c.stroke_width(2)))?;
                chart.draw_series(values.iter().map(|&(x, y)| Circle::new((x, y), 4, c.filled())))?;
            }
        }
        // The legend, in the first free cell.
        let area = &cells[names.len()];
        let font = ("sans-serif", 15).into_font();
        let mut y = 30;
        let mut entry = |sample: &dyn Fn(i32) -> PlotResult, label: &str| -> PlotResult {
            sample(y)?;
            area.draw(&Text::new(label.to_string(), (90, y - 8), font.clone()))?;
            y += 28;
            Ok(())
        };
        for (j, it) in r.iterations.iter().enumerate() {
            let c = COLORS[j];
            entry(
                &|y| {
                    area.draw(&PathElement::new(vec![(30, y), (75, y)], c.stroke_width(2)))?;
                    area.draw(&Circle::new((52, y), 4, c.filled()))?;
                    Ok(())
                },
                &format!("{}: {} single-mass step", it.method, it.iteration.single_mass.name()),
            )?;
        }
        // A dashed sample of the panels' pattern (in pixels).
        let dashed = |y: i32, dash: u32, gap: u32, style: ShapeStyle| -> PlotResult {
            let mut x = 30;
            while x < 75 {
                let end = (x + dash as i32).min(75);
                area.draw(&PathElement::new(vec![(x, y), (end, y)], style))?;
                x = end + gap as i32;
            }
            Ok(())
        };
        entry(&|y| dashed(y, 6, 4, tstyle), "true value")?;
        for (style, label, _, dash, gap) in &lines {
            entry(&|y| dashed(y, *dash, *gap, *style), label)?;
        }
        Ok(())
    })
}
