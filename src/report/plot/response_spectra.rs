//! `response_spectra.svg`: spectral densities of the data's responses against the
//! re-simulated identified model's (the validation's spectra), log–log, as one-sided
//! densities `G(ω) = 2 S(ω)` over `ω > 0` (the vibration engineer's convention: the area
//! under `G` over `ω > 0` is the variance). The force spectra of Fig. 6 stay two-sided, as
//! the paper's (3.20) writes them.

use super::write_figure;
use crate::ident::spectrum::Spectrum;
use crate::report::figure::{color, log_range, squared, unit, Axis, Corner, Figure, Panel, Stroke, GREY};
use crate::report::Report;
use std::path::{Path, PathBuf};

/// Log–log spectral density of every response: data (Welch) against the model.
pub fn plot_response_spectra(r: &Report, path: &Path) -> std::io::Result<Vec<PathBuf>> {
    let model_name = r.validation.as_ref().map_or("model".to_string(), |v| v.method.name());
    let positive = |s: &Spectrum| -> Vec<(f64, f64)> {
        s.omega
            .iter()
            .zip(&s.density)
            .filter(|(w, d)| **w > 0.0 && **d > 0.0)
            .map(|(&w, &d)| (w, 2.0 * d))
            .collect()
    };
    let mut panels = Vec::new();
    for (name, raw_unit, data, model) in &r.plot.response_spectra {
        let unit = unit(raw_unit);
        let dp = positive(data);
        let mp = model.as_ref().map(positive).unwrap_or_default();
        let (w0, w1) = (dp.first().map_or(0.0, |p| p.0), dp.last().map_or(0.0, |p| p.0));
        let (y0, y1) = log_range(dp.iter().chain(&mp).map(|p| p.1), 2.0);
        let mut p = Panel::new(
            format!("one-sided spectral density of {name}"),
            Axis::log(w0, w1, "ω (rad/s)"),
            Axis::log(y0, y1, format!("G(ω) = 2S(ω) ({}·s/rad)", squared(&unit))),
        );
        p.line(
            dp,
            Stroke::solid(GREY, 1.2),
            Some(format!("data (Welch, {} segments)", data.segments)),
        );
        if !mp.is_empty() {
            p.line(
                mp,
                Stroke::solid(color(0), 2.0),
                Some(format!("re-simulated {model_name} model")),
            );
        }
        p.legend_at = Corner::Above;
        panels.push(p);
    }
    let mut fig = Figure::new(1100.0);
    fig.grid(2, 360.0, panels);
    write_figure(path, &fig)
}
