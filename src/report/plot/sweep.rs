//! `sweep.svg`: the iterative procedure's final errors against the disturbance level.

use super::{drawable, legend_box, not_drawable, svg_to_file, PlotResult, COLORS};
use crate::scenario::ReportMethod;
use plotters::prelude::*;
use std::path::Path;

/// Worst error of step 0, of each sequence's final iterate and of its bound against the disturbance
/// level (log scale).
pub fn plot_sweep(sw: &crate::report::Sweep, path: &Path) -> PlotResult {
    svg_to_file(path, (900, 520), |root| {
        let pts = &sw.points;
        // (label, worst error per level): step 0, each sequence's final iterate, the bound.
        let mut curves: Vec<(String, Vec<(f64, f64)>)> = vec![(
            "step 0 (P_z ignored)".into(),
            pts.iter().map(|p| (p.level, p.step0_worst_rel_error)).collect(),
        )];
        let methods: Vec<ReportMethod> = pts
            .first()
            .map(|p| p.sequences.iter().map(|q| q.method.clone()).collect())
            .unwrap_or_default();
        for (k, m) in methods.iter().enumerate() {
            curves.push((
                format!("final iterate, {m}"),
                pts.iter()
                    .map(|p| (p.level, p.sequences[k].final_worst_rel_error))
                    .collect(),
            ));
        }
        curves.push((
            format!("{}: one solve of (4.8), no iteration", ReportMethod::DirectForce),
            pts.iter().map(|p| (p.level, p.direct_worst_rel_error)).collect(),
        ));
        for (k, m) in methods.iter().enumerate() {
            let bound = pts
                .first()
                .map_or(String::new(), |p| p.sequences[k].bound_method.name());
            curves.push((
                format!("P_z given as measured ({bound}): bound of {m}"),
                pts.iter()
                    .map(|p| (p.level, p.sequences[k].bound_worst_rel_error))
                    .collect(),
            ));
        }
        for (_, c) in &mut curves {
            c.iter_mut().for_each(|(_, e)| *e *= 100.0);
            c.retain(|(_, e)| e.is_finite() && *e > 0.0);
        }
        let all: Vec<f64> = curves.iter().flat_map(|(_, c)| c.iter().map(|p| p.1)).collect();
        let lo = all.iter().copied().fold(f64::INFINITY, f64::min).min(1.0) * 0.5;
        let hi = all.iter().copied().fold(0.0, f64::max).max(10.0) * 8.0; // headroom for the legend
        let xmax = pts.iter().map(|p| p.level).fold(0.0, f64::max).max(1e-3) * 1.05;
        if !(drawable(-0.02 * xmax, xmax) && lo > 0.0 && drawable(lo.ln(), hi.ln())) {
            return not_drawable(&root, "sweep", (-0.02 * xmax, xmax), (lo, hi));
        }
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!("{}: worst relative error against disturbance level", sw.scenario),
                ("sans-serif", 18),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(-0.02 * xmax..xmax, (lo..hi).log_scale())?;
        chart
            .configure_mesh()
            .x_desc("disturbance level: std(P_z) / std(P_2)")
            .y_desc("worst relative error (%)")
            .draw()?;
        for (k, (label, data)) in curves.into_iter().enumerate() {
            let color = COLORS[k % COLORS.len()];
            chart
                .draw_series(LineSeries::new(data.clone(), color.stroke_width(2)))?
                .label(label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)));
            chart.draw_series(
                data.into_iter()
                    .map(move |(x, y)| Circle::new((x, y), 4, color.filled())),
            )?;
        }
        legend_box(&mut chart, SeriesLabelPosition::UpperLeft)?;
        Ok(())
    })
}
