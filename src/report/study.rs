//! A study's summary: `summary.json`, `summary.md` and `study.svg` (worst error against
//! record length with a `1/√T` guide, against the sample interval, and the coverage of the
//! 95 % intervals).

use super::plot::{drawable, legend_box, svg_to_file, PlotResult, COLORS};
use crate::pipeline::study::{Paired, Summary};
use plotters::prelude::*;
use std::path::Path;

fn pct(x: f64) -> String {
    if x.is_finite() {
        format!("{:.2} %", 100.0 * x)
    } else {
        "–".into()
    }
}

/// The summary as a markdown page (with the paired differences from a reference method,
/// if the study names one).
pub fn study_markdown(name: &str, rows: usize, summary: &[Summary], paired: &[Paired]) -> String {
    let mut s = format!(
        "# fpkbench study: {name}\n\n{rows} rows. Per configuration and method: the worst error over the \
         parameters and curves of each item, its median, quartiles and maximum over the seeds; per parameter \
         the bias and spread of the signed relative error over the seeds and the coverage of the 95 % \
         intervals; the mean and standard deviation of the worst error (a regression gate is about the \
         mean + 4 sd) and the coverage of all 95 % intervals.\n\n![Worst error against record length and \
         sample interval, coverage](study.svg)\n\n"
    );
    s += "| record length (s) | interval (s) | method | items | failed | median | q1 | q3 | max | mean | sd | coverage | s per item |\n\
          |---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for x in summary {
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.2} |\n",
            x.record_length,
            x.sample_interval,
            x.method,
            x.items,
            x.failed,
            pct(x.worst_median),
            pct(x.worst_q1),
            pct(x.worst_q3),
            pct(x.worst_max),
            pct(x.worst_mean),
            pct(x.worst_sd),
            x.coverage.map_or("–".into(), |c| format!("{:.1} %", 100.0 * c)),
            x.item_s_median
        );
    }
    s += "\n## Parameters\n\n| record length (s) | interval (s) | method | parameter | bias | spread | coverage of 95 % intervals |\n\
          |---:|---:|---|---|---:|---:|---:|\n";
    for x in summary {
        for p in &x.parameters {
            s += &format!(
                "| {} | {} | {} | {} | {:+.2} % | {:.2} % | {} |\n",
                x.record_length,
                x.sample_interval,
                x.method,
                p.name,
                100.0 * p.bias,
                100.0 * p.spread,
                p.coverage.map_or("–".into(), |c| format!("{:.0} %", 100.0 * c))
            );
        }
    }
    if let Some(first) = paired.first() {
        s += &format!(
            "\n## Paired differences from `{}`\n\nOn the same samples: `(θ̂ − θ̂_{0}) / sd`, with `sd` the seed \
             standard deviation of `{0}`'s estimate; mean, standard deviation and largest magnitude over the \
             items.\n\n| record length (s) | interval (s) | method | parameter | sd of {0} | mean | sd | max abs |\n\
             |---:|---:|---|---|---:|---:|---:|---:|\n",
            first.reference
        );
        for p in paired {
            s += &format!(
                "| {} | {} | {} | {} | {:.5} | {:+.2} | {:.2} | {:.2} |\n",
                p.record_length, p.sample_interval, p.method, p.parameter, p.reference_sd, p.mean, p.sd, p.max_abs
            );
        }
    }
    s
}

/// `study.svg`: median worst error (quartiles as bars) against record length per method and
/// interval, with a `1/√T` guide; and against the sample interval at the longest record.
pub fn plot_study(summary: &[Summary], path: &Path) -> PlotResult {
    let mut methods: Vec<&str> = Vec::new();
    for x in summary {
        if !methods.contains(&x.method.as_str()) {
            methods.push(&x.method);
        }
    }
    let ok: Vec<&Summary> = summary
        .iter()
        .filter(|x| x.worst_median.is_finite() && x.worst_median > 0.0)
        .collect();
    let (ylo, yhi) = ok.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), x| {
        (
            lo.min(x.worst_q1.max(x.worst_median * 0.1)),
            hi.max(x.worst_q3.max(x.worst_max)),
        )
    });
    let count = |f: fn(&Summary) -> f64| {
        let mut v: Vec<f64> = ok.iter().map(|x| f(x)).collect();
        v.sort_by(f64::total_cmp);
        v.dedup();
        v.len()
    };
    // A panel per axis the study varies (the interval's when it varies neither).
    let panels: Vec<usize> = match (count(|x| x.record_length) > 1, count(|x| x.sample_interval) > 1) {
        (true, true) => vec![0, 1],
        (true, false) => vec![0],
        _ => vec![1],
    };
    // And the coverage of the 95 % intervals, against the first varied axis.
    let with_coverage = ok.iter().any(|x| x.coverage.is_some());
    let width = 520 * (panels.len() + with_coverage as usize) as u32;
    svg_to_file(path, (width, 440), |root| {
        let areas = root.split_evenly((1, panels.len() + with_coverage as usize));
        if !(ylo > 0.0 && drawable(ylo.ln(), (yhi * 2.0).ln())) {
            return Ok(());
        }
        let style = |k: usize| ShapeStyle {
            color: COLORS[k % COLORS.len()].to_rgba(),
            filled: true,
            stroke_width: 2,
        };
        let mut intervals: Vec<f64> = ok.iter().map(|x| x.sample_interval).collect();
        intervals.sort_by(f64::total_cmp);
        intervals.dedup();
        let mut lengths: Vec<f64> = ok.iter().map(|x| x.record_length).collect();
        lengths.sort_by(f64::total_cmp);
        lengths.dedup();
        // Panel 0: against record length; panel 1: against the sample interval.
        for (&panel, area) in panels.iter().zip(&areas) {
            let xs = if panel == 0 { &lengths } else { &intervals };
            let (x0, x1) = (xs[0] / 1.5, xs[xs.len() - 1] * 1.5);
            if !drawable(x0.ln(), x1.ln()) {
                continue;
            }
            let mut chart = ChartBuilder::on(area)
                .caption(
                    if panel == 0 {
                        "worst error against record length"
                    } else {
                        "worst error against sample interval"
                    },
                    ("sans-serif", 16),
                )
                .margin(12)
                .x_label_area_size(38)
                .y_label_area_size(60)
                .build_cartesian_2d((x0..x1).log_scale(), (ylo / 1.5..yhi * 2.0).log_scale())?;
            chart
                .configure_mesh()
                .x_desc(if panel == 0 {
                    "record length per trajectory T (s)"
                } else {
                    "sample interval h (s)"
                })
                .y_desc("worst relative error (median, quartiles)")
                .draw()?;
            for (k, m) in methods.iter().enumerate() {
                // Per interval (panel 1) or at the longest record (panel 2).
                let groups: Vec<f64> = if panel == 0 {
                    intervals.clone()
                } else {
                    vec![lengths[lengths.len() - 1]]
                };
                for (g, &other) in groups.iter().enumerate() {
                    let pts: Vec<&&Summary> = ok
                        .iter()
                        .filter(|x| {
                            x.method == *m
                                && if panel == 0 {
                                    x.sample_interval == other
                                } else {
                                    x.record_length == other
                                }
                        })
                        .collect();
                    if pts.is_empty() {
                        continue;
                    }
                    let at = |x: &Summary| if panel == 0 { x.record_length } else { x.sample_interval };
                    let line: Vec<(f64, f64)> = pts.iter().map(|x| (at(x), x.worst_median)).collect();
                    let st = style(k + g * methods.len());
                    let label = if panel == 0 && intervals.len() > 1 {
                        format!("{m}, h = {other} s")
                    } else {
                        m.to_string()
                    };
                    chart
                        .draw_series(LineSeries::new(line.clone(), st).point_size(3))?
                        .label(label)
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], st));
                    chart.draw_series(pts.iter().map(|x| {
                        PathElement::new(vec![(at(x), x.worst_q1.max(ylo / 1.5)), (at(x), x.worst_q3)], st)
                    }))?;
                }
            }
            if panel == 0 && lengths.len() > 1 {
                // The 1/√T guide through the first method's first point.
                if let Some(first) = ok
                    .iter()
                    .find(|x| x.method == methods[0] && x.record_length == lengths[0])
                {
                    let guide: Vec<(f64, f64)> = lengths
                        .iter()
                        .map(|&t| (t, first.worst_median * (lengths[0] / t).sqrt()))
                        .collect();
                    let grey = ShapeStyle {
                        color: RGBColor(120, 120, 120).to_rgba(),
                        filled: false,
                        stroke_width: 1,
                    };
                    chart
                        .draw_series(LineSeries::new(guide, grey))?
                        .label("1/√T")
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], grey));
                }
            }
            legend_box(
                &mut chart,
                if panel == 0 {
                    SeriesLabelPosition::UpperRight
                } else {
                    SeriesLabelPosition::UpperLeft
                },
            )?;
        }
        if with_coverage {
            let panel = panels[0];
            let xs = if panel == 0 { &lengths } else { &intervals };
            let (x0, x1) = (xs[0] / 1.5, xs[xs.len() - 1] * 1.5);
            if !drawable(x0.ln(), x1.ln()) {
                return Ok(());
            }
            let lowest = ok.iter().filter_map(|x| x.coverage).fold(1.0f64, f64::min);
            let y0 = if lowest > 0.8 { 0.75 } else { 0.0 };
            let mut chart = ChartBuilder::on(&areas[panels.len()])
                .caption("coverage of the 95 % intervals", ("sans-serif", 16))
                .margin(12)
                .x_label_area_size(38)
                .y_label_area_size(60)
                .build_cartesian_2d((x0..x1).log_scale(), y0..1.02)?;
            chart
                .configure_mesh()
                .x_desc(if panel == 0 {
                    "record length per trajectory T (s)"
                } else {
                    "sample interval h (s)"
                })
                .y_desc("fraction of intervals holding the truth")
                .draw()?;
            let grey = ShapeStyle {
                color: RGBColor(120, 120, 120).to_rgba(),
                filled: false,
                stroke_width: 1,
            };
            chart
                .draw_series(DashedLineSeries::new(vec![(x0, 0.95), (x1, 0.95)], 6, 4, grey))?
                .label("nominal 0.95")
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], grey));
            for (k, m) in methods.iter().enumerate() {
                let groups: Vec<f64> = if panel == 0 {
                    intervals.clone()
                } else {
                    vec![lengths[lengths.len() - 1]]
                };
                for (g, &other) in groups.iter().enumerate() {
                    let pts: Vec<(f64, f64)> = ok
                        .iter()
                        .filter(|x| {
                            x.method == *m
                                && if panel == 0 {
                                    x.sample_interval == other
                                } else {
                                    x.record_length == other
                                }
                        })
                        .filter_map(|x| {
                            let at = if panel == 0 { x.record_length } else { x.sample_interval };
                            x.coverage.map(|c| (at, c.max(y0)))
                        })
                        .collect();
                    if pts.is_empty() {
                        continue;
                    }
                    let st = style(k + g * methods.len());
                    chart.draw_series(LineSeries::new(pts, st).point_size(3))?;
                }
            }
            legend_box(&mut chart, SeriesLabelPosition::LowerLeft)?;
        }
        Ok(())
    })
}
