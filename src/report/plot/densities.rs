//! `densities.svg`: marginal densities of the data against the identified model's.

use super::{drawable, legend_box, not_drawable, svg_to_file, PlotResult, COLORS};
use crate::report::Report;
use plotters::prelude::*;
use std::path::Path;

/// Marginal density of every response: data against the re-simulated identified model.
pub fn plot_densities(r: &Report, path: &Path) -> PlotResult {
    let m = &r.plot.marginals;
    let cols = 2usize;
    let rows = m.len().div_ceil(cols).max(1);
    let model_name = r.validation.as_ref().map_or("model".to_string(), |v| v.method.name());
    svg_to_file(path, (1000, 340 * rows as u32), |root| {
        for ((name, unit, data, model), area) in m.iter().zip(root.split_evenly((rows, cols))) {
            let dd = data.density(r.plot.samples.max(1.0));
            let md = model.as_ref().map(|h| h.density(r.plot.model_samples.max(1.0)));
            let ymax = dd.iter().chain(md.iter().flatten()).copied().fold(0.0, f64::max) * 1.08;
            let w = (data.hi - data.lo) / data.counts.len() as f64;
            if !drawable(data.lo, data.hi) || !drawable(0.0, ymax.max(1e-12)) {
                not_drawable(&area, name, (data.lo, data.hi), (0.0, ymax))?;
                continue;
            }
            let mut chart = ChartBuilder::on(&area)
                .caption(format!("marginal density of {name}"), ("sans-serif", 16))
                .margin(10)
                .x_label_area_size(35)
                .y_label_area_size(55)
                .build_cartesian_2d(data.lo..data.hi, 0.0..ymax.max(1e-12))?;
            chart
                .configure_mesh()
                .x_desc(format!("{name} ({unit})"))
                .y_desc(format!("density (1/{unit})"))
                .draw()?;
            chart
                .draw_series(dd.iter().enumerate().map(|(i, &d)| {
                    let x0 = data.lo + i as f64 * w;
                    Rectangle::new([(x0, 0.0), (x0 + w, d)], RGBColor(170, 170, 170).filled())
                }))?
                .label("data (histogram)")
                .legend(|(x, y)| Rectangle::new([(x, y - 5), (x + 18, y + 5)], RGBColor(170, 170, 170).filled()));
            if let Some(md) = md {
                let pts: Vec<(f64, f64)> = md
                    .iter()
                    .enumerate()
                    .map(|(i, &d)| (data.lo + (i as f64 + 0.5) * w, d))
                    .collect();
                let style = ShapeStyle {
                    color: COLORS[0].to_rgba(),
                    filled: false,
                    stroke_width: 2,
                };
                chart
                    .draw_series(LineSeries::new(pts, style))?
                    .label(format!("re-simulated {model_name} model"))
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
            }
            legend_box(&mut chart, SeriesLabelPosition::UpperRight)?;
        }
        Ok(())
    })
}
