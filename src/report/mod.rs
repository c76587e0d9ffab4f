//! Reports: the result types ([`types`]), the console text ([`text`]), `report.json`,
//! `report.md` and the SVG plots ([`plot`]), all written atomically under the run's folder.
//! Depends on the result types only; never on the numerics' internals.

mod markdown;
pub mod plot;
pub mod study;
pub mod text;
pub mod types;

pub use markdown::markdown;
pub use plot::{
    characteristics::plot_characteristics, densities::plot_densities, iteration::plot_iteration,
    response_spectra::plot_response_spectra, spectra::plot_spectra, sweep::plot_sweep,
};
pub use text::{summary, sweep_summary};
pub use types::*;

pub use crate::io::output::write_atomic;

/// Every file [`write_all`] may write into a report folder.
pub const FILES: [&str; 7] = [
    "report.json",
    "report.md",
    "characteristics.svg",
    "iteration.svg",
    "spectrum.svg",
    "densities.svg",
    "response_spectra.svg",
];
use std::path::{Path, PathBuf};

/// Write `sweep.json`, `sweep.md` and `sweep.svg` into `dir`.
pub fn write_sweep(sw: &crate::report::Sweep, dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let p = dir.join("sweep.json");
    write_atomic(
        &p,
        serde_json::to_string_pretty(sw)
            .map_err(std::io::Error::other)?
            .as_bytes(),
    )?;
    let mut files = vec![p];
    let p = dir.join("sweep.md");
    write_atomic(
        &p,
        format!(
            "# fpkbench disturbance sweep: {}\n\n```\n{}```\n\nPlot: `sweep.svg`.\n",
            sw.scenario,
            sweep_summary(sw)
        )
        .as_bytes(),
    )?;
    files.push(p);
    let p = dir.join("sweep.svg");
    plot_sweep(sw, &p).map_err(|e| std::io::Error::other(e.to_string()))?;
    files.push(p);
    Ok(files)
}

/// Write `report.json`, `report.md` and the plots into `dir`; returns the files written.
pub fn write_all(r: &Report, dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    let json = serde_json::to_string_pretty(r).map_err(std::io::Error::other)?;
    let p = dir.join("report.json");
    write_atomic(&p, json.as_bytes())?;
    files.push(p);
    let md = markdown(r);
    let p = dir.join("report.md");
    write_atomic(&p, md.as_bytes())?;
    files.push(p);
    let p = dir.join("characteristics.svg");
    plot_characteristics(r, &p).map_err(|e| std::io::Error::other(e.to_string()))?;
    files.push(p);
    if !r.iterations.is_empty() {
        let p = dir.join("iteration.svg");
        plot_iteration(r, &p).map_err(|e| std::io::Error::other(e.to_string()))?;
        files.push(p);
    }
    if !r.plot.spectra.is_empty() {
        let p = dir.join("spectrum.svg");
        plot_spectra(r, &p).map_err(|e| std::io::Error::other(e.to_string()))?;
        files.push(p);
    }
    if !r.plot.marginals.is_empty() {
        let p = dir.join("densities.svg");
        plot_densities(r, &p).map_err(|e| std::io::Error::other(e.to_string()))?;
        files.push(p);
    }
    if r.plot.response_spectra.iter().any(|s| s.2.segments > 0) {
        let p = dir.join("response_spectra.svg");
        plot_response_spectra(r, &p).map_err(|e| std::io::Error::other(e.to_string()))?;
        files.push(p);
    }
    Ok(files)
}
