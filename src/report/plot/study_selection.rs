//! The structure selection's panel of `study.svg` (docs/selection.md, "Selection in
//! studies"): per configuration and method with a selection, the share of items whose
//! selection was exactly the true structure, kept a false term, kept a false link, or
//! dropped a true term; and each false term's false-inclusion rate.

use crate::report::figure::{color, Axis, Corner, Mark, Panel, Stroke, Swatch};
use crate::report::study_rows::{SelectionSummary, Summary};

/// A share of items a selection summary gives.
type Share = fn(&SelectionSummary) -> f64;

/// The most often wrong terms drawn.
const WRONG_TERMS: usize = 12;

/// The panels, or none when no item made a selection.
pub fn selection_panels(summary: &[Summary]) -> Vec<Panel> {
    let with: Vec<&Summary> = summary.iter().filter(|x| x.selection.is_some()).collect();
    if with.is_empty() {
        return Vec::new();
    }
    // The method and what varies: the record length, and the interval where it varies.
    let intervals = with
        .iter()
        .any(|x| x.configuration.sample_interval != with[0].configuration.sample_interval);
    let label = |x: &Summary| {
        let c = &x.configuration;
        match intervals {
            true => format!("{}, {} s, h {} s", x.method, c.record_length, c.sample_interval),
            false => format!("{}, {} s", x.method, c.record_length),
        }
    };
    let names: Vec<String> = with.iter().map(|x| label(x)).collect();
    let mut outcomes = Panel::new(
        "structure selection over the items (method, record length per trajectory)",
        Axis::categories(names.clone(), ""),
        Axis::linear(0.0, 102.0, "items (%)"),
    );
    let series: [(&str, Share); 4] = [
        ("exact structure", |s| s.exact),
        ("a false term kept", |s| s.false_kept_items),
        ("a false link kept", |s| s.false_link_items),
        ("a true term dropped", |s| s.true_dropped_items),
    ];
    for (k, (name, value)) in series.iter().enumerate() {
        let stroke = Stroke::solid(color(k), 7.0);
        outcomes.entry(Swatch::Line(stroke), *name);
        for (i, x) in with.iter().enumerate() {
            let at = (i + 1) as f64 - 0.3 + 0.2 * k as f64;
            let v = 100.0 * value(x.selection.as_ref().expect("filtered"));
            outcomes.mark(Mark::Line {
                points: vec![(at, 0.0), (at, v)],
                stroke,
            });
        }
    }
    outcomes.legend_at = Corner::Above;
    // The false terms kept on some item, each with its rate, per configuration.
    let mut wrong: Vec<(usize, String, f64)> = Vec::new();
    for (i, x) in with.iter().enumerate() {
        for t in &x.selection.as_ref().expect("filtered").terms {
            let rate = if t.truth { 1.0 - t.kept } else { t.kept };
            if rate > 0.0 {
                wrong.push((
                    i,
                    format!("{}{}", t.term, if t.truth { " (dropped)" } else { "" }),
                    rate,
                ));
            }
        }
    }
    let mut panels = vec![outcomes];
    wrong.sort_by(|a, b| b.2.total_cmp(&a.2));
    wrong.truncate(WRONG_TERMS);
    if !wrong.is_empty() {
        let terms: Vec<String> = wrong.iter().map(|w| format!("{} · {}", w.1, names[w.0])).collect();
        let mut rates = Panel::new(
            "terms wrong on some item: false inclusion (a false term kept), false exclusion (a true term dropped)",
            Axis::categories(terms, ""),
            Axis::linear(0.0, 102.0, "items (%)"),
        );
        for (j, (_, _, rate)) in wrong.iter().enumerate() {
            let at = (j + 1) as f64;
            rates.mark(Mark::Line {
                points: vec![(at, 0.0), (at, 100.0 * rate)],
                stroke: Stroke::solid(color(1), 7.0),
            });
        }
        panels.push(rates);
    }
    panels
}
