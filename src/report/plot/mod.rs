//! The report's figures, one module per figure, built with [`crate::report::figure`]; each
//! is written as SVG and, with the `raster` feature (on by default), as PNG and PDF beside
//! it ([`write_figure`]).

pub mod characteristics;
pub mod compare;
pub mod densities;
pub mod iteration;
pub mod response_spectra;
pub mod selection;
pub mod spectra;
pub mod study_selection;
pub mod sweep;

use super::figure::{Axis, Figure, Mark, Panel, LIGHT_GREY};
use crate::report::write_atomic;
use crate::stats::Histogram;
use std::path::{Path, PathBuf};

/// Write `fig` to `path` (an `.svg`), and its `.png` and `.pdf` beside it; each file
/// atomically. Returns the files written.
pub fn write_figure(path: &Path, fig: &Figure) -> std::io::Result<Vec<PathBuf>> {
    let svg = fig.svg();
    write_atomic(path, svg.as_bytes())?;
    #[allow(unused_mut)]
    let mut files = vec![path.to_path_buf()];
    #[cfg(feature = "raster")]
    {
        let (png, pdf) = rayon::join(|| super::raster::png(&svg), || super::raster::pdf(&svg));
        let png = png.map_err(std::io::Error::other)?;
        let p = path.with_extension("png");
        write_atomic(&p, &png)?;
        files.push(p);
        let pdf = pdf.map_err(std::io::Error::other)?;
        let p = path.with_extension("pdf");
        write_atomic(&p, &pdf)?;
        files.push(p);
    }
    Ok(files)
}

/// A strip under a panel: the data's distribution over the same x range, in grey.
pub(crate) fn histogram_strip(h: &Histogram, xlabel: &str) -> Panel {
    let max = h.counts.iter().copied().fold(0.0, f64::max).max(1.0);
    let mut p = Panel::new(
        "",
        Axis::linear(h.lo, h.hi, xlabel),
        Axis::linear(0.0, 1.05, "data").unlabelled(),
    );
    p.mark(Mark::Histogram {
        lo: h.lo,
        width: (h.hi - h.lo) / h.counts.len().max(1) as f64,
        heights: h.counts.iter().map(|c| c / max).collect(),
        color: LIGHT_GREY,
    });
    p
}
