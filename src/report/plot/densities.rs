//! `densities.svg`: marginal densities of the data against the re-simulated identified
//! model's, each on a linear scale and on a log scale (the tails, where a nonlinearity shows).

use super::write_figure;
use crate::report::figure::{color, log_range, unit, Axis, Corner, Figure, Mark, Panel, Stroke, Swatch, LIGHT_GREY};
use crate::report::Report;
use std::path::{Path, PathBuf};

/// Marginal density of every response: data against the re-simulated identified model.
pub fn plot_densities(r: &Report, path: &Path) -> std::io::Result<Vec<PathBuf>> {
    let model_name = r.validation.as_ref().map_or("model".to_string(), |v| v.method.name());
    let mut panels = Vec::new();
    for (name, raw_unit, data, model) in &r.plot.marginals {
        let unit = unit(raw_unit);
        let dd = data.density(r.plot.samples.max(1.0));
        let md = model.as_ref().map(|h| h.density(r.plot.model_samples.max(1.0)));
        let w = (data.hi - data.lo) / data.counts.len().max(1) as f64;
        let ymax = dd.iter().chain(md.iter().flatten()).copied().fold(0.0, f64::max) * 1.08;
        for log in [false, true] {
            let y = if log {
                let (_, hi) = log_range(dd.iter().chain(md.iter().flatten()).copied(), 2.0);
                // Down to the smallest density the data resolve (one sample in a bin), at
                // most five decades below the peak.
                let floor = 1.0 / (r.plot.samples.max(1.0) * w);
                Axis::log(floor.max(hi * 1e-5) / 2.0, hi, format!("density (1/{unit}), log scale"))
            } else {
                Axis::linear(0.0, ymax.max(1e-300), format!("density (1/{unit})"))
            };
            let mut p = Panel::new(
                format!("marginal density of {name}{}", if log { ": the tails" } else { "" }),
                Axis::linear(data.lo, data.hi, format!("{name} ({unit})")),
                y,
            );
            p.mark(Mark::Histogram {
                lo: data.lo,
                width: w,
                heights: dd.clone(),
                color: LIGHT_GREY,
            });
            p.entry(Swatch::Patch(LIGHT_GREY, 1.0), "data (histogram)");
            if let Some(md) = &md {
                let pts = md
                    .iter()
                    .enumerate()
                    .map(|(i, &d)| {
                        (
                            data.lo + (i as f64 + 0.5) * w,
                            if log && d <= 0.0 { f64::NAN } else { d },
                        )
                    })
                    .collect();
                p.line(
                    pts,
                    Stroke::solid(color(0), 2.0),
                    Some(format!("re-simulated {model_name} model")),
                );
            }
            p.legend_at = if log { Corner::LowerMiddle } else { Corner::UpperRight };
            panels.push(p);
        }
    }
    let mut fig = Figure::new(1100.0);
    fig.grid(2, 330.0, panels);
    write_figure(path, &fig)
}
