//! `response_spectra.svg`: spectral densities of the data's responses against the
//! re-simulated identified model's (the validation's spectra).

use super::{drawable, legend_box, not_drawable, svg_to_file, PlotResult, COLORS};
use crate::report::Report;
use plotters::prelude::*;
use std::path::Path;

/// Log–log spectral density of every response: data (Welch) against the model.
pub fn plot_response_spectra(r: &Report, path: &Path) -> PlotResult {
    let sp = &r.plot.response_spectra;
    let cols = 2usize;
    let rows = sp.len().div_ceil(cols).max(1);
    let model_name = r.validation.as_ref().map_or("model".to_string(), |v| v.method.name());
    svg_to_file(path, (1000, 340 * rows as u32), |root| {
        for ((name, unit, data, model), area) in sp.iter().zip(root.split_evenly((rows, cols))) {
            let positive = |s: &crate::ident::spectrum::Spectrum| -> Vec<(f64, f64)> {
                s.omega
                    .iter()
                    .zip(&s.density)
                    .filter(|(_, d)| **d > 0.0)
                    .map(|(&w, &d)| (w, d))
                    .collect()
            };
            let dp = positive(data);
            let mp = model.as_ref().map(positive).unwrap_or_default();
            let (lo, hi) = dp
                .iter()
                .chain(&mp)
                .fold((f64::INFINITY, 0.0f64), |(lo, hi), p| (lo.min(p.1), hi.max(p.1)));
            let (w0, w1) = (
                data.omega.first().copied().unwrap_or(0.0),
                data.omega.last().copied().unwrap_or(0.0),
            );
            if dp.len() < 2 || !(w0 > 0.0 && drawable(w0.ln(), w1.ln())) || !(lo > 0.0 && drawable(lo.ln(), hi.ln())) {
                not_drawable(&area, &format!("spectrum of {name}"), (w0, w1), (lo, hi))?;
                continue;
            }
            let mut chart = ChartBuilder::on(&area)
                .caption(format!("spectral density of {name}"), ("sans-serif", 16))
                .margin(10)
                .x_label_area_size(35)
                .y_label_area_size(70)
                .build_cartesian_2d((w0..w1).log_scale(), (lo * 0.5..hi * 2.0).log_scale())?;
            chart
                .configure_mesh()
                .x_desc("ω (rad/s)")
                .y_desc(format!("S(ω) (({unit})²·s/rad)"))
                .draw()?;
            let grey = ShapeStyle {
                color: RGBColor(120, 120, 120).to_rgba(),
                filled: false,
                stroke_width: 1,
            };
            chart
                .draw_series(LineSeries::new(dp, grey))?
                .label(format!("data (Welch, {} segments)", data.segments))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], grey));
            if !mp.is_empty() {
                let style = ShapeStyle {
                    color: COLORS[0].to_rgba(),
                    filled: false,
                    stroke_width: 2,
                };
                chart
                    .draw_series(LineSeries::new(mp, style))?
                    .label(format!("re-simulated {model_name} model"))
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
            }
            legend_box(&mut chart, SeriesLabelPosition::LowerLeft)?;
        }
        Ok(())
    })
}
