//! `densities.svg`: marginal densities of the data against the re-simulated identified
//! model's, each on a linear scale and on a log scale (the tails, where a nonlinearity shows),
//! with the exact stationary density drawn too where it is known in closed form
//! ([`crate::zoo::GibbsMarginals`]: one mass, linear damping, white forces).

use super::write_figure;
use crate::report::figure::{
    color, log_range, per, unit, Axis, Corner, Figure, Mark, Panel, Stroke, Swatch, BLACK, LIGHT_GREY,
};
use crate::report::Report;
use crate::zoo::GibbsMarginals;
use std::path::{Path, PathBuf};

/// Marginal density of every response: data against the re-simulated identified model.
pub fn plot_densities(r: &Report, path: &Path) -> std::io::Result<Vec<PathBuf>> {
    let model_name = r.validation.as_ref().map_or("model".to_string(), |v| v.method.name());
    // The exact density, for a simulated system that has one in closed form.
    let exact = r
        .scenario_def
        .as_ref()
        .filter(|s| s.data.is_none())
        .and_then(GibbsMarginals::of);
    let mut panels = Vec::new();
    for (name, raw_unit, data, model) in &r.plot.marginals {
        let unit = unit(raw_unit);
        let density_unit = per(raw_unit);
        let exact_at = |z: f64| -> Option<f64> {
            let g = exact.as_ref()?;
            match name.split_once('_')?.0 {
                "x" => Some(g.displacement(z)),
                "v" => Some(g.velocity(z)),
                _ => None,
            }
        };
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
                Axis::log(
                    floor.max(hi * 1e-5) / 2.0,
                    hi,
                    format!("density ({density_unit}), log scale"),
                )
            } else {
                Axis::linear(0.0, ymax.max(1e-300), format!("density ({density_unit})"))
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
            if let (Some(md), Some(mh)) = (&md, model) {
                // On the log scale, only bins with ten model samples or more: below that
                // the histogram's own noise would be drawn as a shape.
                let pts = md
                    .iter()
                    .zip(&mh.counts)
                    .enumerate()
                    .map(|(i, (&d, &n))| {
                        (
                            data.lo + (i as f64 + 0.5) * w,
                            if log && n < 10.0 { f64::NAN } else { d },
                        )
                    })
                    .collect();
                p.line(
                    pts,
                    Stroke::solid(color(0), 2.0),
                    Some(format!("re-simulated {model_name} model")),
                );
            }
            if exact_at(0.0).is_some() {
                let pts = (0..=400)
                    .map(|k| data.lo + (data.hi - data.lo) * k as f64 / 400.0)
                    .map(|z| (z, exact_at(z).unwrap_or(f64::NAN)))
                    .collect();
                p.line(
                    pts,
                    Stroke::dashed(BLACK, 1.4, 6.0, 4.0),
                    Some("exact stationary density (true system)".into()),
                );
            }
            p.legend_at = Corner::Above;
            panels.push(p);
        }
    }
    let mut fig = Figure::new(1100.0);
    fig.grid(2, 360.0, panels);
    write_figure(path, &fig)
}
