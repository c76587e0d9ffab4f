//! `selection.svg`: the structure selection's criterion along the elimination path, and
//! each candidate's inclusion over the bootstrap resamples (docs/selection.md).

use super::write_figure;
use crate::report::figure::{color, log_range, Axis, Corner, Figure, Mark, Panel, Stroke, Swatch, BLACK, GREY};
use crate::report::Report;
use std::path::{Path, PathBuf};

pub fn plot_selection(r: &Report, path: &Path) -> std::io::Result<Vec<PathBuf>> {
    let Some(sel) = &r.selection else {
        return Ok(Vec::new());
    };
    let s = &sel.selection;
    let k = s.candidates.len() as f64;
    let fit: Vec<(f64, f64)> = s.path.iter().map(|st| (st.terms as f64, st.j / s.dispersion)).collect();
    let criterion: Vec<(f64, f64)> = (s.path.iter())
        .filter(|st| st.admissible)
        .map(|st| (st.terms as f64, st.criterion))
        .collect();
    let chosen = s.selected.iter().filter(|&&x| x).count() as f64;
    let (lo, hi) = log_range(fit.iter().chain(&criterion).map(|p| p.1).filter(|v| *v > 0.0), 1.5);
    let mut p = Panel::new(
        format!("the criterion along the elimination path ({})", s.criterion_name),
        Axis::linear(-0.5, k + 0.5, "terms in the model"),
        Axis::log(lo, hi, "J / dispersion, criterion"),
    );
    let fit_stroke = Stroke::dashed(GREY, 1.4, 5.0, 3.0);
    p.mark(Mark::Line {
        points: fit,
        stroke: fit_stroke,
    });
    p.mark(Mark::Points {
        points: criterion.clone(),
        color: color(0),
        radius: 2.5,
    });
    p.mark(Mark::Points {
        points: vec![(chosen, s.criterion)],
        color: color(1),
        radius: 5.0,
    });
    p.legend_at = Corner::Above;
    p.entry(Swatch::Line(fit_stroke), "J / dispersion (the fit)");
    p.entry(
        Swatch::Point(color(0), 2.5),
        "criterion = J / dispersion + terms · ln N (admissible models)",
    );
    p.entry(Swatch::Point(color(1), 5.0), format!("selected: {chosen} terms"));
    let mut fig = Figure::new(1080.0);
    fig.row(380.0, vec![Some(p)]);
    let names: Vec<String> = s.candidates.iter().map(|n| n.to_string()).collect();
    let mut q = Panel::new(
        format!(
            "selected by the {} bootstrap resamples (filled: in the selected model)",
            s.replicates
        ),
        Axis::categories(names, ""),
        Axis::linear(0.0, 105.0, "resamples selecting it (%)"),
    );
    for (i, (&f, &chosen)) in s.inclusion.iter().zip(&s.selected).enumerate() {
        let x = (i + 1) as f64;
        let c = if chosen { color(1) } else { GREY };
        q.mark(Mark::Line {
            points: vec![(x, 0.0), (x, 100.0 * f)],
            stroke: Stroke::solid(c, 6.0),
        });
    }
    q.mark(Mark::HLine {
        y: 50.0,
        stroke: Stroke::dashed(BLACK, 1.0, 4.0, 4.0),
    });
    fig.row(300.0, vec![Some(q)]);
    write_figure(path, &fig)
}
