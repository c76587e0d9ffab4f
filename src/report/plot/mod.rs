//! SVG plots, one file per figure; shared colours, legend and file handling here.

pub mod characteristics;
pub mod densities;
pub mod iteration;
pub mod response_spectra;
pub mod spectra;
pub mod sweep;

use crate::report::write_atomic;
use crate::stats::Histogram;
use plotters::prelude::*;
use std::path::Path;

pub(crate) const COLORS: [RGBColor; 7] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
];

pub(crate) type PlotResult = Result<(), Box<dyn std::error::Error>>;

/// The series legend in a framed, lightly opaque box at `position`.
pub(crate) fn legend_box<'a, DB: DrawingBackend + 'a, CT: plotters::coord::CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
) -> PlotResult
where
    DB::ErrorType: 'static,
{
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

pub(crate) fn svg_to_file(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(DrawingArea<SVGBackend, plotters::coord::Shift>) -> PlotResult,
) -> PlotResult {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE)?;
        draw(root.clone())?;
        root.present()?;
    }
    write_atomic(path, svg.as_bytes())?;
    Ok(())
}

/// Whether `lo..hi` is an axis plotters can draw in finite time: finite, ordered, within
/// ±1e100 and wider than rounding at its magnitude (the tick search steps through it).
pub(crate) fn drawable(lo: f64, hi: f64) -> bool {
    let big = lo.abs().max(hi.abs());
    lo.is_finite() && hi.is_finite() && hi > lo && big < 1e100 && hi - lo > 1e-9 * big
}

/// In place of a chart whose axes cannot be drawn (non-finite or extreme values): say so.
pub(crate) fn not_drawable(
    area: &DrawingArea<SVGBackend, plotters::coord::Shift>,
    what: &str,
    x: (f64, f64),
    y: (f64, f64),
) -> PlotResult {
    let text = format!(
        "{what}: not drawn, axis range x [{:.3e}, {:.3e}], y [{:.3e}, {:.3e}] (non-finite or extreme values)",
        x.0, x.1, y.0, y.1
    );
    area.draw(&Text::new(text, (20, 30), ("sans-serif", 14)))?;
    Ok(())
}

pub(crate) fn draw_histogram_strip(
    area: &DrawingArea<SVGBackend, plotters::coord::Shift>,
    h: &Histogram,
    xlabel: &str,
) -> PlotResult {
    let max = h.counts.iter().copied().fold(0.0, f64::max).max(1.0);
    if !drawable(h.lo, h.hi) {
        return not_drawable(area, xlabel, (h.lo, h.hi), (0.0, 1.05));
    }
    let mut chart = ChartBuilder::on(area)
        .margin_left(10)
        .margin_right(15)
        .x_label_area_size(32)
        .y_label_area_size(60)
        .build_cartesian_2d(h.lo..h.hi, 0.0..1.05)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .y_labels(2)
        .y_desc("data")
        .x_desc(xlabel)
        .draw()?;
    let w = (h.hi - h.lo) / h.counts.len() as f64;
    chart.draw_series(h.counts.iter().enumerate().map(|(i, &c)| {
        let x0 = h.lo + i as f64 * w;
        Rectangle::new([(x0, 0.0), (x0 + w, c / max)], RGBColor(160, 160, 160).filled())
    }))?;
    Ok(())
}
