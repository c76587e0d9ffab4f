//! `spectrum.svg`: measured force spectra with their rational fits (3.20).

use super::{drawable, legend_box, not_drawable, svg_to_file, PlotResult, COLORS};
use crate::report::Report;
use plotters::prelude::*;
use std::path::Path;

/// Estimated force spectra with the fitted (3.20) and true curves, log–log (the paper's
/// Fig. 6).
pub fn plot_spectra(r: &Report, path: &Path) -> PlotResult {
    let sp = &r.plot.spectra;
    let unit = r.scenario_def.as_ref().map(|s| s.motion.units()[3]).unwrap_or("N");
    svg_to_file(path, (900, 420 * sp.len().max(1) as u32), |root| {
        for ((name, spec, fit, (ta, tb)), area) in sp.iter().zip(root.split_evenly((sp.len().max(1), 1))) {
            let (w0, w1) = (spec.omega[0], spec.omega[spec.omega.len() - 1]);
            let dmin = spec
                .density
                .iter()
                .copied()
                .filter(|d| *d > 0.0)
                .fold(f64::INFINITY, f64::min);
            let dmax = spec.density.iter().copied().fold(0.0, f64::max);
            let positive = |a: f64, b: f64| a > 0.0 && drawable(a.ln(), b.ln());
            if !positive(w0, w1) || !positive(dmin * 0.5, dmax * 2.0) {
                not_drawable(&area, &format!("spectrum of p_{name}"), (w0, w1), (dmin, dmax))?;
                continue;
            }
            let mut chart = ChartBuilder::on(&area)
                .caption(format!("spectral density of the force p_{name}"), ("sans-serif", 16))
                .margin(10)
                .x_label_area_size(38)
                .y_label_area_size(70)
                .build_cartesian_2d((w0..w1).log_scale(), (dmin * 0.5..dmax * 2.0).log_scale())?;
            chart
                .configure_mesh()
                .x_desc("ω (rad/s)")
                .y_desc(format!("S(ω) (({unit})²·s/rad)"))
                .draw()?;
            chart
                .draw_series(
                    spec.omega
                        .iter()
                        .zip(&spec.density)
                        .map(|(&w, &d)| Circle::new((w, d), 2, RGBColor(150, 150, 150).filled())),
                )?
                .label(format!("Welch estimate ({} segments)", spec.segments))
                .legend(|(x, y)| Circle::new((x + 9, y), 3, RGBColor(150, 150, 150).filled()));
            let fitted: Vec<(f64, f64)> = spec
                .omega
                .iter()
                .map(|&w| {
                    (
                        w,
                        crate::ident::spectrum::sampled_ou_density(fit.a, fit.b, spec.sample_interval, w),
                    )
                })
                .collect();
            let style = ShapeStyle {
                color: COLORS[0].to_rgba(),
                filled: false,
                stroke_width: 2,
            };
            chart
                .draw_series(LineSeries::new(fitted, style))?
                .label(format!("fit: A = {:.3}, B = {:.3} 1/s", fit.a, fit.b))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
            let truth: Vec<(f64, f64)> = spec
                .omega
                .iter()
                .map(|&w| {
                    (
                        w,
                        crate::ident::spectrum::sampled_ou_density(*ta, *tb, spec.sample_interval, w),
                    )
                })
                .collect();
            let tstyle = ShapeStyle {
                color: BLACK.to_rgba(),
                filled: false,
                stroke_width: 1,
            };
            if ta.is_finite() {
                chart
                    .draw_series(DashedLineSeries::new(truth, 6, 4, tstyle))?
                    .label(format!("true: A = {ta}, B = {tb} 1/s"))
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], tstyle));
            }
            legend_box(&mut chart, SeriesLabelPosition::LowerLeft)?;
        }
        Ok(())
    })
}
