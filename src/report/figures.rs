//! The figure registry: one entry per figure a report may have — its file name, when it
//! applies, its writer and its caption. [`super::write_all`] writes the figures that apply,
//! [`super::files`] lists every file a report may hold, and `report.md` (so `report.html`,
//! which is made from it) places each with its caption through [`image`]: a new figure is
//! one entry here and one `image` call where the page shows it.

use super::{plot, Report};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// One figure of a report.
pub struct Figure {
    /// The file stem: `<name>.svg`, with `.png` and `.pdf` beside it.
    pub name: &'static str,
    /// Whether the report has what the figure draws.
    pub applies: fn(&Report) -> bool,
    /// Draw it to the `.svg` path given (and the raster formats beside it); the files
    /// written.
    pub write: fn(&Report, &Path) -> std::io::Result<Vec<PathBuf>>,
    /// Its caption in `report.md` and `report.html`.
    pub caption: fn(&Report) -> String,
}

/// Every figure, in the order they are written.
pub static FIGURES: &[Figure] = &[
    Figure {
        name: "characteristics",
        applies: plot::characteristics::has_panels,
        write: plot::characteristics::plot_characteristics,
        caption: |_| {
            "Identified and true characteristics over the observed range of each link's relative displacement \
             and velocity. Top: the truth (thin black) drawn over every estimate; the FPK estimators with their 95 % \
             pointwise bands; baselines and deliberately wrong models dashed, with a triangle where they leave the \
             range. Middle: each FPK estimate minus the truth, with its band (with no truth, the band alone about \
             zero). Bottom: the data's distribution of the argument."
                .into()
        },
    },
    Figure {
        name: "selection",
        applies: |r| r.selection.is_some(),
        write: plot::selection::plot_selection,
        caption: |_| {
            "The criterion along the elimination path against the number of terms, the selected model marked; \
             each candidate's share of the bootstrap resamples that select it"
                .into()
        },
    },
    Figure {
        name: "compare",
        applies: plot::compare::has_comparisons,
        write: plot::compare::plot_compare,
        caption: plot::compare::caption,
    },
    Figure {
        name: "iteration",
        applies: |r| !r.iterations.is_empty(),
        write: plot::iteration::plot_iteration,
        caption: |_| "Estimates over the steps".into(),
    },
    Figure {
        name: "spectrum",
        applies: |r| !r.plot.spectra.is_empty(),
        write: plot::spectra::plot_spectra,
        caption: plot::spectra::caption,
    },
    Figure {
        name: "densities",
        applies: |r| !r.plot.marginals.is_empty(),
        write: plot::densities::plot_densities,
        caption: |_| {
            "Marginal densities of the responses: the data (grey histogram) against the re-simulated model \
             (solid; on the log scale only where its bins hold ten samples or more), and, dashed, the exact \
             stationary density where it is known in closed form (one mass, linear damping, white forces)."
                .into()
        },
    },
    Figure {
        name: "response_spectra",
        applies: |r| r.plot.response_spectra.iter().any(|s| s.2.segments > 0),
        write: plot::response_spectra::plot_response_spectra,
        caption: |_| {
            "One-sided spectral densities G(ω) = 2 S(ω) of the responses (the area under G over ω > 0 is the \
             variance): the data (Welch) against the re-simulated model, on the same segments."
                .into()
        },
    },
];

/// The registry's entry for `name`.
pub fn figure(name: &str) -> &'static Figure {
    FIGURES
        .iter()
        .find(|f| f.name == name)
        .unwrap_or_else(|| panic!("no figure {name:?} in the registry"))
}

/// The markdown paragraph that shows figure `name` with its caption, or nothing where it
/// does not apply to `r`.
pub fn image(r: &Report, name: &str) -> String {
    let f = figure(name);
    match r.figures && (f.applies)(r) {
        true => format!("![{}]({name}.svg)\n\n", (f.caption)(r)),
        false => String::new(),
    }
}

/// Write every figure that applies to `r` into `dir`; the files written.
pub fn write_figures(r: &Report, dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    // The figures are independent: rendered in parallel, listed in the registry's order.
    let written: Vec<Vec<PathBuf>> = FIGURES
        .par_iter()
        .filter(|f| r.figures && (f.applies)(r))
        .map(|f| (f.write)(r, &dir.join(format!("{}.svg", f.name))))
        .collect::<std::io::Result<_>>()?;
    Ok(written.into_iter().flatten().collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every figure's name is unique, and [`figure`] finds each entry by it.
    #[test]
    fn the_registry_names_each_figure_once() {
        for (i, f) in FIGURES.iter().enumerate() {
            assert!(FIGURES[i + 1..].iter().all(|g| g.name != f.name), "{} twice", f.name);
            assert!(std::ptr::eq(figure(f.name), f));
        }
    }
}
