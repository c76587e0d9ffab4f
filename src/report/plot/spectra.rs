//! `spectrum.svg`, the paper's Fig. 6: the measured force's spectral density (Welch
//! estimate), the rational spectrum (3.20) fitted to it and the true one, log–log.

use super::write_figure;
use crate::ident::spectrum::sampled_ou_density;
use crate::report::figure::{
    color, log_range, squared, unit, Axis, Corner, Figure, Mark, Panel, Stroke, Swatch, BLACK, GREY,
};
use crate::report::Report;
use std::path::{Path, PathBuf};

/// The figure's caption, written in the page under it.
pub fn caption(r: &Report) -> String {
    format!(
        "The paper's Fig. 6: points, the two-sided spectral density of each force (∫ S dω over all ω is its \
         variance), estimated by Welch's method from the samples; solid, the first-order rational spectrum \
         S(ω) = A²/(2π(B² + ω²)) (3.20) fitted to them (as sampled every {} s, with its aliasing); dashed, the \
         true spectrum, where the scenario gives one. The fitted A and B define the filter the identifier's \
         augmented state uses.",
        r.sample_interval_s
    )
}

/// Estimated force spectra with the fitted (3.20) and true curves, log–log.
pub fn plot_spectra(r: &Report, path: &Path) -> std::io::Result<Vec<PathBuf>> {
    let unit = unit(r.scenario_def.as_ref().map(|s| s.motion.units()[3]).unwrap_or("N"));
    let mut panels = Vec::new();
    for (name, spec, fit, (ta, tb)) in &r.plot.spectra {
        let (w0, w1) = (
            spec.omega.first().copied().unwrap_or(0.0),
            spec.omega.last().copied().unwrap_or(0.0),
        );
        let (y0, y1) = log_range(spec.density.iter().copied(), 2.0);
        // An excitation of the scenario, or the force the paper's section 4 reconstructs.
        let excitation = r
            .scenario_def
            .as_ref()
            .and_then(|s| s.excitations.iter().find(|e| &e.name == name).map(|e| (s, e)));
        let title = match excitation {
            Some((s, e)) => format!(
                "{} {name} on {}: two-sided spectral density",
                if e.measured {
                    "measured excitation"
                } else {
                    "disturbance"
                },
                e.acts_on
                    .iter()
                    .map(|&i| s.masses[i].name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            None => format!("{name}: two-sided spectral density"),
        };
        let mut p = Panel::new(
            title,
            Axis::log(w0, w1, "ω (rad/s)"),
            Axis::log(y0, y1, format!("S(ω) ({}·s/rad)", squared(&unit))),
        );
        p.mark(Mark::Points {
            points: spec.omega.iter().copied().zip(spec.density.iter().copied()).collect(),
            color: GREY,
            radius: 1.8,
        });
        p.entry(
            Swatch::Point(GREY, 3.0),
            format!(
                "Welch estimate ({} segments of {} samples)",
                spec.segments, spec.segment_len
            ),
        );
        let curve = |a: f64, b: f64| -> Vec<(f64, f64)> {
            spec.omega
                .iter()
                .map(|&w| (w, sampled_ou_density(a, b, spec.sample_interval, w)))
                .collect()
        };
        p.line(
            curve(fit.a, fit.b),
            Stroke::solid(color(0), 2.2),
            Some(format!("fitted (3.20): A = {:.4}, B = {:.4} 1/s", fit.a, fit.b)),
        );
        if ta.is_finite() {
            p.line(
                curve(*ta, *tb),
                Stroke::dashed(BLACK, 1.3, 6.0, 4.0),
                Some(format!("true: A = {ta}, B = {tb} 1/s")),
            );
        }
        if !ta.is_finite() {
            p.notes
                .push("reconstructed from the responses: no true spectrum to draw".into());
        }
        p.legend_at = Corner::Above;
        panels.push(p);
    }
    let mut fig = Figure::new(900.0);
    fig.grid(1, 450.0, panels);
    write_figure(path, &fig)
}
