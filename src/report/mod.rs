//! Reports: the result types ([`types`]), the console text ([`text`]), `report.json`,
//! `report.md`, `report.html` ([`html`]) and the figures ([`plot`], drawn with [`figure`],
//! rasterised by `raster`), all written atomically under the run's folder.
//! Depends on the result types only; never on the numerics' internals.

pub mod figure;
pub mod figures;
pub mod html;
mod markdown;
mod method_report;
pub mod plot;
#[cfg(feature = "raster")]
pub mod raster;
mod selection;
pub mod study;
pub(crate) mod table;
pub mod text;
#[warn(missing_docs)]
pub mod types;
pub use method_report::*;

pub use markdown::markdown;
pub use plot::{
    characteristics::plot_characteristics, densities::plot_densities, iteration::plot_iteration,
    response_spectra::plot_response_spectra, spectra::plot_spectra, sweep::plot_sweep,
};
pub use text::{fit, summary, sweep_summary};
pub use types::*;

pub mod study_rows;

pub use crate::io::output::write_atomic;

/// Every file [`write_all`] may write into a report folder: the pages, and each figure of
/// the registry ([`figures::FIGURES`]) as `.svg`, `.png` and `.pdf`.
pub fn files() -> Vec<String> {
    let mut out: Vec<String> = ["report.json", "report.md", "report.html"].map(String::from).to_vec();
    for f in figures::FIGURES {
        for ext in ["svg", "png", "pdf"] {
            out.push(format!("{}.{ext}", f.name));
        }
    }
    out
}
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
    files.extend(plot_sweep(sw, &dir.join("sweep.svg"))?);
    Ok(files)
}

/// Write `report.json`, `report.md`, `report.html` and the figures (SVG, with PNG and PDF
/// beside each) into `dir`; returns the files written.
pub fn write_all(r: &Report, dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    let json = serde_json::to_string_pretty(r).map_err(std::io::Error::other)?;
    let p = dir.join("report.json");
    write_atomic(&p, json.as_bytes())?;
    files.push(p);
    files.extend(figures::write_figures(r, dir)?);
    let md = markdown(r);
    let p = dir.join("report.md");
    write_atomic(&p, md.as_bytes())?;
    files.push(p);
    let p = dir.join("report.html");
    write_atomic(
        &p,
        html::page(&format!("fpkbench report: {}", r.scenario), &md, dir)?.as_bytes(),
    )?;
    files.push(p);
    Ok(files)
}
