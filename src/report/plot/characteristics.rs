//! `characteristics.svg`: identified against true characteristics over the observed ranges,
//! each estimate with its 95 % pointwise band (from the jackknife's covariance of its
//! coefficients, [`crate::report::Curve::half_width_95`]).

use super::{draw_histogram_strip, drawable, legend_box, not_drawable, svg_to_file, PlotResult, COLORS};
use crate::model::Characteristic;
use crate::report::text::fmt_err;
use crate::report::Report;
use crate::stats;
use plotters::prelude::*;
use std::path::Path;

/// For every link and characteristic: truth and each method's estimate over the observed
/// range, with the data's distribution beneath.
pub fn plot_characteristics(r: &Report, path: &Path) -> PlotResult {
    let s = r.scenario_def.as_ref().expect("scenario");
    let [ux, uv, _, uf, _] = s.motion.units();
    let mut panels = Vec::new();
    for (l, link) in s.links.iter().enumerate() {
        for kind in [Characteristic::Stiffness, Characteristic::Damping] {
            let truth = r.truth.characteristic(&link.name, kind);
            let identified = r
                .methods
                .iter()
                .any(|m| m.curves.iter().any(|c| c.link == link.name && c.kind == kind.name()));
            if truth.is_empty() && !identified {
                continue;
            }
            panels.push((l, kind));
        }
    }
    let cols = 2usize;
    let rows = panels.len().div_ceil(cols).max(1);
    svg_to_file(path, (1100, 420 * rows as u32), |root| {
        let areas = root.split_evenly((rows, cols));
        for ((l, kind), area) in panels.iter().zip(areas) {
            let link = &s.links[*l];
            let (hist, var, unit) = match kind {
                Characteristic::Stiffness => (&r.plot.link_hist[*l].0, "u", ux),
                Characteristic::Damping => (&r.plot.link_hist[*l].1, "w", uv),
            };
            let (top, bottom) = area.split_vertically((area.dim_in_pixel().1 as f64 * 0.74) as u32);
            let truth = r.truth.characteristic(&link.name, *kind);
            let (lo, hi) = (hist.lo, hist.hi);
            let xs: Vec<f64> = (0..=200).map(|k| lo + (hi - lo) * k as f64 / 200.0).collect();
            // Per method with standard errors: its 95 % pointwise band, `(lower, upper)`.
            let mut bands: Vec<(Vec<f64>, Vec<f64>, RGBColor)> = Vec::new();
            let mut curves: Vec<(String, Vec<f64>, RGBColor, bool)> = vec![(
                "true".into(),
                xs.iter().map(|&z| truth.eval(z)).collect(),
                RGBColor(0, 0, 0),
                false,
            )];
            for (mi, m) in r.methods.iter().enumerate() {
                if let Some(c) = m.curves.iter().find(|c| c.link == link.name && c.kind == kind.name()) {
                    let p = stats::characteristic(&c.identified);
                    let color = COLORS[mi % COLORS.len()];
                    if c.half_width_95(0.0).is_some() {
                        let half: Vec<f64> = xs.iter().map(|&z| c.half_width_95(z).unwrap_or(0.0)).collect();
                        bands.push((
                            xs.iter().zip(&half).map(|(&z, h)| p.eval(z) - h).collect(),
                            xs.iter().zip(&half).map(|(&z, h)| p.eval(z) + h).collect(),
                            color,
                        ));
                    }
                    curves.push((
                        format!("{} ({} error)", m.method, fmt_err(c.rel_l2_error)),
                        xs.iter().map(|&z| p.eval(z)).collect(),
                        COLORS[mi % COLORS.len()],
                        true,
                    ));
                }
            }
            let ymin = curves
                .iter()
                .flat_map(|c| c.1.iter())
                .copied()
                .fold(f64::INFINITY, f64::min);
            let ymax = curves
                .iter()
                .flat_map(|c| c.1.iter())
                .copied()
                .fold(f64::NEG_INFINITY, f64::max);
            let pad = 0.05 * (ymax - ymin).max(1e-12);
            let title = format!(
                "{} {}: {} force vs {var} ({})",
                link.name,
                kind.name(),
                if *kind == Characteristic::Stiffness {
                    "spring"
                } else {
                    "damper"
                },
                if *kind == Characteristic::Stiffness {
                    "relative displacement"
                } else {
                    "relative velocity"
                }
            );
            let (y0, y1) = (ymin - pad, ymax + pad);
            if !drawable(lo, hi) || !drawable(y0, y1) {
                not_drawable(&top, &title, (lo, hi), (y0, y1))?;
                continue;
            }
            let mut chart = ChartBuilder::on(&top)
                .caption(title, ("sans-serif", 16))
                .margin_left(10)
                .margin_right(15)
                .margin_top(5)
                .x_label_area_size(20)
                .y_label_area_size(60)
                .build_cartesian_2d(lo..hi, y0..y1)?;
            chart
                .configure_mesh()
                .y_desc(format!(
                    "{} ({uf})",
                    if *kind == Characteristic::Stiffness {
                        "K(u)"
                    } else {
                        "C(w)"
                    }
                ))
                .x_label_formatter(&|_| String::new())
                .draw()?;
            // Bands first, beneath every line; clipped to the panel's range.
            for (lower, upper, color) in &bands {
                let clip = |y: f64| y.clamp(y0, y1);
                let outline: Vec<(f64, f64)> = xs
                    .iter()
                    .zip(upper)
                    .map(|(&x, &y)| (x, clip(y)))
                    .chain(xs.iter().zip(lower).rev().map(|(&x, &y)| (x, clip(y))))
                    .collect();
                chart.draw_series(std::iter::once(Polygon::new(outline, color.mix(0.18).filled())))?;
            }
            for (name, ys, color, dashed) in &curves {
                let pts: Vec<(f64, f64)> = xs.iter().copied().zip(ys.iter().copied()).collect();
                let style = ShapeStyle {
                    color: color.to_rgba(),
                    filled: false,
                    stroke_width: if *dashed { 2 } else { 3 },
                };
                if *dashed {
                    chart
                        .draw_series(DashedLineSeries::new(pts, 8, 5, style))?
                        .label(name.clone())
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
                } else {
                    chart
                        .draw_series(LineSeries::new(pts, style))?
                        .label(name.clone())
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
                }
            }
            legend_box(&mut chart, SeriesLabelPosition::UpperLeft)?;
            draw_histogram_strip(
                &bottom,
                hist,
                &format!("{var} ({unit}) — observed range; grey: distribution of the data"),
            )?;
        }
        Ok(())
    })
}
