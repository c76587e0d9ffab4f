//! `sweep.svg`: the iterative procedure's final errors against the disturbance level.

use super::write_figure;
use crate::report::figure::{color, log_range, Axis, Corner, Figure, Mark, Panel, Stroke, Swatch};
use crate::scenario::ReportMethod;
use std::path::{Path, PathBuf};

/// Worst error of step 0, of each sequence's final iterate and of its bound against the
/// disturbance level (log scale).
pub fn plot_sweep(sw: &crate::report::Sweep, path: &Path) -> std::io::Result<Vec<PathBuf>> {
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
    let (lo, hi) = log_range(curves.iter().flat_map(|(_, c)| c.iter().map(|p| p.1)), 1.5);
    // Headroom above for the legend.
    let hi = hi * 10f64.powf(0.35 * curves.len() as f64 * (hi / lo).log10().max(1.0) / 4.0);
    let xmax = pts.iter().map(|p| p.level).fold(0.0, f64::max).max(1e-3) * 1.05;
    let mut p = Panel::new(
        format!("{}: worst relative error against disturbance level", sw.scenario),
        Axis::linear(-0.02 * xmax, xmax, "disturbance level: std(P_z) / std(P_2)"),
        Axis::log(lo, hi, "worst relative error (%)"),
    );
    for (k, (label, data)) in curves.into_iter().enumerate() {
        let stroke = Stroke::solid(color(k), 2.0);
        p.mark(Mark::Line {
            points: data.clone(),
            stroke,
        });
        p.mark(Mark::Points {
            points: data,
            color: color(k),
            radius: 3.5,
        });
        p.entry(Swatch::LinePoint(stroke, 3.5), label);
    }
    p.legend_at = Corner::Above;
    let mut fig = Figure::new(900.0);
    fig.row(520.0, vec![Some(p)]);
    write_figure(path, &fig)
}
