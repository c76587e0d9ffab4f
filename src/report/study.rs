//! A study's summary: `summary.json`, `summary.md`, `study.html` and `study.svg` (worst
//! error against record length with a `1/√T` guide, against the sample interval, against
//! the sensor noise level, and the coverage of the 95 % intervals, and the share of items
//! each method refused; for a study
//! of one configuration, every seed's worst error, the coverage and the refusals per
//! method; PNG and PDF beside it).

use super::figure::{color, log_range, Axis, Color, Corner, Figure, Mark, Panel, Stroke, Swatch, BLACK, GREY};
use super::plot::write_figure;
use super::study_rows::{Configuration, Paired, Row, Summary};
use super::table::Table;
use std::path::{Path, PathBuf};

/// A share in percent to two decimals; one under 0.005 % but not 0 (an exact case, such
/// as whole periods of a periodic steady state) in exponent form, not as `0.00 %`.
fn pct(x: f64) -> String {
    let p = 100.0 * x;
    if !x.is_finite() {
        "–".into()
    } else if p != 0.0 && p.abs() < 0.005 {
        format!("{p:.1e} %")
    } else {
        format!("{p:.2} %")
    }
}

/// A coverage and its 95 % interval in percent, to `digits` decimals: `94.0 % [92.1, 95.7]`.
fn coverage(c: Option<f64>, ci: Option<[f64; 2]>, digits: usize) -> String {
    match (c, ci) {
        (Some(c), Some([lo, hi])) => format!(
            "{:.digits$} % [{:.digits$}, {:.digits$}]",
            100.0 * c,
            100.0 * lo,
            100.0 * hi
        ),
        (Some(c), None) => format!("{:.digits$} %", 100.0 * c),
        _ => "–".into(),
    }
}

/// A vertical interval `[lo, hi]` (%) at `x`, with caps `half` wide.
fn error_bar(p: &mut Panel, x: f64, [lo, hi]: [f64; 2], half: f64, col: Color) {
    p.mark(Mark::Line {
        points: vec![(x, lo), (x, hi)],
        stroke: Stroke::solid(col, 1.2),
    });
    for y in [lo, hi] {
        p.mark(Mark::Line {
            points: vec![(x - half, y), (x + half, y)],
            stroke: Stroke::solid(col, 1.2),
        });
    }
}

/// Tables longer than this are folded on the page (`<details>`), closed until opened.
const FOLD_ROWS: usize = 30;

/// A table whose first columns are the configuration's, the sensor noise level's only in a
/// study over noise levels (`noisy`), then the method's.
fn configuration_table(noisy: bool) -> Table {
    let t = Table::new().right("record length (s)").right("interval (s)");
    let t = if noisy { t.right("sensor noise (of std)") } else { t };
    t.left("method")
}

/// The configuration's and the method's cells of a table row.
fn configuration_cells(c: &Configuration, method: &str, noisy: bool) -> Vec<String> {
    let mut cells = vec![c.record_length.to_string(), c.sample_interval.to_string()];
    if noisy {
        cells.push(c.sensor_noise.map_or("–".into(), |n| format!("{} %", 100.0 * n)));
    }
    cells.push(method.to_string());
    cells
}

/// The summary as a markdown page (with the paired differences from a reference method,
/// if the study names one).
pub fn study_markdown(name: &str, rows: usize, summary: &[Summary], paired: &[Paired]) -> String {
    let mut s = format!(
        "# fpkbench study: {name}\n\n{rows} rows. Per configuration and method: the worst error over the \
         parameters and curves of each item, its median, quartiles and maximum over the seeds; per parameter \
         the bias and spread of the signed relative error over the seeds and the coverage of the 95 % \
         intervals; the mean and standard deviation of the worst error (a regression gate is about the \
         mean + 4 sd) and the coverage of all 95 % intervals. Beside a coverage, in brackets, its own 95 % \
         interval: per parameter binomial over the seeds (Wilson), pooled over the items (the intervals of one \
         item come from the same samples, so the spread between items sets it). Per parameter also the root \
         mean square of the standard errors over the estimates' standard deviation over the seeds (below 1 \
         the standard errors understate), and the efficiency: the mean square Cramér–Rao bound of continuous \
         observation over the estimates' variance over the seeds (1: the best any unbiased estimator does \
         from the whole path). Where the study estimated the integrator's bias (`integrator_bias`), the mean \
         of the items' Richardson estimates over the root mean square of their standard errors, in bold \
         above a quarter.\n\n![Worst error against record length and \
         sample interval, coverage](study.svg)\n\n"
    );
    s += "Every item × method has a row: estimated, refused (the data could not separate the \
          unknowns, or too few samples: no estimates), not applicable (the method does not apply to this \
          problem) or failed (the item could not be run). The error statistics are over the estimated \
          items; the refusal rate is refused / (estimated + refused).\n\n";
    let noisy = summary.iter().any(|x| x.configuration.sensor_noise.is_some());
    s += &summary_table(summary, noisy);
    s += &selection_table(summary, noisy);
    s += &parameters_table(summary, noisy);
    s += &paired_table(paired, noisy);
    s
}

/// The main table: per configuration and method, the outcomes and the worst error.
fn summary_table(summary: &[Summary], noisy: bool) -> String {
    let mut s = String::new();
    let mut table = configuration_table(noisy);
    for title in [
        "estimated",
        "refused",
        "refusal rate",
        "n/a",
        "failed",
        "median",
        "q1",
        "q3",
        "max",
    ] {
        table = table.right(title);
    }
    let mut table = table.right("mean").right("sd").right("coverage").right("s per item");
    for x in summary {
        let mut cells = configuration_cells(&x.configuration, &x.method, noisy);
        cells.extend([
            x.items.to_string(),
            x.refused.to_string(),
            x.refusal_rate().map_or("–".into(), |r| format!("{:.0} %", 100.0 * r)),
            x.not_applicable.to_string(),
            x.failed.to_string(),
            pct(x.worst_median),
            pct(x.worst_q1),
            pct(x.worst_q3),
            pct(x.worst_max),
            pct(x.worst_mean),
            pct(x.worst_sd),
            coverage(x.coverage, x.coverage_ci, 1),
            format!("{:.2}", x.item_s_median),
        ]);
        table.row(cells);
    }
    s += &table.markdown();
    s
}

/// The structure selection's tables, where items made one: outcomes, the terms wrong on
/// some item, and the inclusion frequencies against the truth.
fn selection_table(summary: &[Summary], noisy: bool) -> String {
    let mut s = String::new();
    if summary.iter().any(|x| x.selection.is_some()) {
        s += "\n## Structure selection\n\nPer configuration and method, over the items with a selection \
              (docs/selection.md): how often the selected model was exactly the true structure among the \
              candidates, how often a true term was dropped (items, and share of all true terms), how often \
              a term the truth lacks was kept (items, and terms per item), how often a link the truth lacks \
              was kept, and the terms most often wrong.\n\n";
        let mut table = configuration_table(noisy).right("items").right("exact structure");
        for title in [
            "true term dropped (items)",
            "true terms dropped",
            "false term kept (items)",
        ] {
            table = table.right(title);
        }
        let mut table = table
            .right("false terms per item")
            .right("false link (items)")
            .left("wrong most often");
        for x in summary {
            let Some(sel) = &x.selection else { continue };
            let wrong: Vec<String> = sel.mistakes.iter().take(4).map(|(n, k)| format!("{n} ({k})")).collect();
            let mut cells = configuration_cells(&x.configuration, &x.method, noisy);
            cells.extend([
                sel.items.to_string(),
                format!("{:.0} %", 100.0 * sel.exact),
                format!("{:.0} %", 100.0 * sel.true_dropped_items),
                format!("{:.1} %", 100.0 * sel.true_dropped_terms),
                format!("{:.0} %", 100.0 * sel.false_kept_items),
                format!("{:.2}", sel.false_kept_per_item),
                format!("{:.0} %", 100.0 * sel.false_link_items),
                if wrong.is_empty() {
                    "–".to_string()
                } else {
                    wrong.join(", ")
                },
            ]);
            table.row(cells);
        }
        s += &table.markdown();
        s += &term_rates_table(summary, noisy);
        s += &reliability_table(summary, noisy);
    }
    s
}

/// Per candidate wrong on some item: a false term's false-inclusion rate, a true term's
/// false-exclusion rate.
fn term_rates_table(summary: &[Summary], noisy: bool) -> String {
    let mut table = configuration_table(noisy)
        .left("term")
        .left("truth")
        .right("false inclusion")
        .right("false exclusion");
    let mut rows = 0;
    let mut right = 0;
    for x in summary {
        let Some(sel) = &x.selection else { continue };
        for t in &sel.terms {
            let wrong = if t.truth { 1.0 - t.kept } else { t.kept };
            if wrong <= 0.0 {
                right += 1;
                continue;
            }
            let mut cells = configuration_cells(&x.configuration, &x.method, noisy);
            cells.extend([
                t.term.clone(),
                if t.truth { "true" } else { "false" }.to_string(),
                if t.truth {
                    "–".into()
                } else {
                    format!("{:.0} %", 100.0 * t.kept)
                },
                if t.truth {
                    format!("{:.0} %", 100.0 * wrong)
                } else {
                    "–".into()
                },
            ]);
            table.row(cells);
            rows += 1;
        }
    }
    if rows + right == 0 {
        return String::new();
    }
    let mut s = match rows {
        0 => format!(
            "\nPer candidate: each of the {right} (over the configurations and methods) was right on every \
             item — no false inclusion, no false exclusion.\n"
        ),
        _ => format!(
            "\nPer candidate, the share of items that kept a term the truth lacks (false inclusion) or \
             dropped one it has (false exclusion): the {rows} wrong on some item; the other {right} \
             were right on every item.\n\n"
        ),
    };
    if rows > 0 {
        if rows > FOLD_ROWS {
            s += &format!("<!-- fold: per candidate: false inclusion and exclusion ({rows} rows) -->\n");
        }
        s += &table.markdown();
    }
    s
}

/// The inclusion frequencies over the bootstrap resamples against the truth: per bin of
/// frequency, the candidates in it and the share of them the truth has.
fn reliability_table(summary: &[Summary], noisy: bool) -> String {
    let with: Vec<(&Summary, &Vec<crate::report::study_rows::ReliabilityBin>)> = (summary.iter())
        .filter_map(|x| x.selection.as_ref().map(|s| (x, &s.reliability)))
        .filter(|(_, r)| !r.is_empty())
        .collect();
    let Some((_, first)) = with.first() else {
        return String::new();
    };
    let mut table = configuration_table(noisy);
    for b in first.iter() {
        table = table.right(format!(
            "inclusion [{:.2}, {:.2}{}",
            b.from,
            b.to,
            if b.to == 1.0 { "]" } else { ")" }
        ));
    }
    for (x, bins) in &with {
        let mut cells = configuration_cells(&x.configuration, &x.method, noisy);
        cells.extend(bins.iter().map(|b| match b.true_share {
            Some(t) => format!("{} · {:.0} % true", b.terms, 100.0 * t),
            None => "–".into(),
        }));
        table.row(cells);
    }
    format!(
        "\nInclusion frequencies (the share of the bootstrap resamples whose selection has a \
         candidate) against the truth: per bin, the candidates over all items and the share of them \
         that are true. Frequencies that mean what they say have that share within the bin.\n\n{}",
        table.markdown()
    )
}

/// Per parameter: bias, spread, coverage, standard errors, efficiency and the integrator's bias.
fn parameters_table(summary: &[Summary], noisy: bool) -> String {
    let mut s = String::new();
    s += "\n## Parameters\n\n";
    // A long table folded (report.html shows its title; report.md its comment is unseen).
    let rows: usize = summary.iter().map(|x| x.parameters.len()).sum();
    if rows > FOLD_ROWS {
        s += &format!("<!-- fold: per parameter: bias, spread and coverage ({rows} rows) -->\n");
    }
    // The integrator's bias, where the study estimated it (docs/methods.md).
    let with_bias = summary
        .iter()
        .any(|x| x.parameters.iter().any(|p| p.integrator_bias_share.is_some()));
    let mut table = configuration_table(noisy)
        .left("parameter")
        .right("bias")
        .right("spread");
    table = table
        .right("coverage of 95 % intervals")
        .right("std. error / spread")
        .right("efficiency");
    if with_bias {
        table = table.right("integrator bias / std. error");
    }
    let ratio = |r: Option<f64>| r.map_or("–".to_string(), |r| format!("{r:.2}"));
    for x in summary {
        for p in &x.parameters {
            let mut cells = configuration_cells(&x.configuration, &x.method, noisy);
            cells.extend([
                p.name.clone(),
                format!("{:+.2} %", 100.0 * p.bias),
                format!("{:.2} %", 100.0 * p.spread),
                coverage(p.coverage, p.coverage_ci, 0),
                ratio(p.std_error_ratio),
                match (p.efficiency, p.efficiency_ci) {
                    (Some(e), Some([lo, hi])) => format!("{e:.2} [{lo:.2}, {hi:.2}]"),
                    (e, _) => ratio(e),
                },
            ]);
            if with_bias {
                cells.push(match p.integrator_bias_share {
                    Some(b) if b.abs() > super::BIAS_SHARE => format!("**{b:+.2}**"),
                    Some(b) => format!("{b:+.2}"),
                    None => "–".to_string(),
                });
            }
            table.row(cells);
        }
    }
    s += &table.markdown();
    s
}

/// The paired differences from the reference method, where the study names one.
fn paired_table(paired: &[Paired], noisy: bool) -> String {
    let mut s = String::new();
    if let Some(first) = paired.first() {
        s += &format!(
            "\n## Paired differences from `{}`\n\nOn the same samples: `(θ̂ − θ̂_{0}) / sd`, with `sd` the seed \
             standard deviation of `{0}`'s estimate; mean, standard deviation and largest magnitude over the \
             items.\n\n",
            first.reference
        );
        let table = configuration_table(noisy).left("parameter");
        let mut table = table
            .right(format!("sd of {}", first.reference))
            .right("mean")
            .right("sd")
            .right("max abs");
        for p in paired {
            let mut cells = configuration_cells(&p.configuration, &p.method, noisy);
            cells.extend([
                p.parameter.clone(),
                format!("{:.5}", p.reference_sd),
                format!("{:+.2}", p.mean),
                format!("{:.2}", p.sd),
                format!("{:.2}", p.max_abs),
            ]);
            table.row(cells);
        }
        s += &table.markdown();
    }
    s
}

/// `study.svg` (with PNG and PDF): median worst error (quartiles as bars) against each
/// varied axis — record length per method and interval with a `1/√T` guide, the sample
/// interval at the longest record, the sensor noise level — and the coverage of the 95 %
/// intervals and the refused items against the first. A study of one configuration has no
/// axis to vary: its figure is [`plot_methods`]'.
pub fn plot_study(summary: &[Summary], rows: &[Row], path: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut configurations: Vec<Configuration> = Vec::new();
    for x in summary {
        if !configurations.contains(&x.configuration) {
            configurations.push(x.configuration);
        }
    }
    if configurations.len() == 1 {
        return plot_methods(summary, rows, path);
    }
    let st = StudyLines::new(summary);
    let mut panels: Vec<Panel> = st.axes.iter().map(|&axis| error_panel(&st, axis)).collect();
    if st.ok.iter().any(|x| x.coverage.is_some()) {
        panels.push(coverage_panel(&st));
    }
    if summary.iter().any(|x| x.refused + x.failed > 0) {
        panels.push(refusal_panel(&st, summary));
    }
    let mut fig = Figure::new(540.0 * panels.len().max(2) as f64);
    fig.row(460.0, panels.into_iter().map(Some).collect());
    selection_rows(&mut fig, summary);
    write_figure(path, &fig)
}

/// The structure selection's panels, one row each, where items made a selection.
fn selection_rows(fig: &mut Figure, summary: &[Summary]) {
    for p in crate::report::plot::study_selection::selection_panels(summary) {
        fig.row(360.0, vec![Some(p)]);
    }
}

/// An axis a study varies.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Varied {
    RecordLength,
    SampleInterval,
    SensorNoise,
}

/// What the panels of [`plot_study`] share: the methods in order, the configurations with
/// a positive median worst error, the record lengths, intervals and noise levels they span,
/// the error axis's range and the axes the study varies.
struct StudyLines<'a> {
    methods: Vec<&'a str>,
    ok: Vec<&'a Summary>,
    lengths: Vec<f64>,
    intervals: Vec<f64>,
    /// The noise levels (`-1` for a configuration without one).
    noises: Vec<f64>,
    ylo: f64,
    yhi: f64,
    /// One entry per panel of errors.
    axes: Vec<Varied>,
}

/// The sensor noise level of a configuration, `-1` without one.
fn noise_of(x: &Summary) -> f64 {
    x.configuration.sensor_noise.unwrap_or(-1.0)
}

impl<'a> StudyLines<'a> {
    fn new(summary: &'a [Summary]) -> StudyLines<'a> {
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
        let sorted = |f: fn(&Summary) -> f64| {
            let mut v: Vec<f64> = ok.iter().map(|x| f(x)).collect();
            v.sort_by(f64::total_cmp);
            v.dedup();
            v
        };
        let lengths = sorted(|x| x.configuration.record_length);
        let intervals = sorted(|x| x.configuration.sample_interval);
        let noises = sorted(noise_of);
        let mut axes: Vec<Varied> = [
            (lengths.len(), Varied::RecordLength),
            (intervals.len(), Varied::SampleInterval),
            (noises.len(), Varied::SensorNoise),
        ]
        .into_iter()
        .filter(|(n, _)| *n > 1)
        .map(|(_, a)| a)
        .collect();
        if axes.is_empty() {
            axes.push(Varied::SampleInterval);
        }
        let (ylo, yhi) = log_range(
            ok.iter()
                .flat_map(|x| [x.worst_q1.max(x.worst_median * 0.1), x.worst_q3, x.worst_max]),
            1.6,
        );
        StudyLines {
            methods,
            ok,
            lengths,
            intervals,
            noises,
            ylo,
            yhi,
            axes,
        }
    }

    /// The values that make one line each: every interval against record length and
    /// against the noise level; one line (the longest record) against the interval.
    fn groups(&self, axis: Varied) -> Vec<f64> {
        match axis {
            Varied::RecordLength | Varied::SensorNoise => self.intervals.clone(),
            Varied::SampleInterval => self.lengths.last().copied().into_iter().collect(),
        }
    }

    /// Whether `x` is on the line of method `m` at `other` (the group's value) against
    /// `axis`: the axes neither plotted nor grouped at their reference, the longest record
    /// and the lowest noise level.
    fn on_line(&self, x: &Summary, m: &str, axis: Varied, other: f64) -> bool {
        let c = &x.configuration;
        let longest = self.lengths.last().copied();
        let lowest = self.noises.first().copied();
        x.method == m
            && match axis {
                Varied::RecordLength => c.sample_interval == other && Some(noise_of(x)) == lowest,
                Varied::SampleInterval => c.record_length == other && Some(noise_of(x)) == lowest,
                Varied::SensorNoise => c.sample_interval == other && Some(c.record_length) == longest,
            }
    }

    /// The configurations on the line of method `m` at `other`.
    fn line_of(&self, m: &str, axis: Varied, other: f64) -> Vec<&'a Summary> {
        self.ok
            .iter()
            .copied()
            .filter(|x| self.on_line(x, m, axis, other))
            .collect()
    }

    /// The x axis: logarithmic over the record lengths or the intervals, linear over the
    /// noise levels in percent.
    fn x_axis(&self, axis: Varied) -> Axis {
        let span = |values: &[f64]| {
            (
                values.first().copied().unwrap_or(1.0),
                values.last().copied().unwrap_or(1.0),
            )
        };
        match axis {
            Varied::RecordLength => {
                let (lo, hi) = span(&self.lengths);
                Axis::log(lo / 1.5, hi * 1.5, "record length per trajectory T (s)")
            }
            Varied::SampleInterval => {
                let (lo, hi) = span(&self.intervals);
                Axis::log(lo / 1.5, hi * 1.5, "sample interval h (s)")
            }
            Varied::SensorNoise => {
                let (_, hi) = span(&self.noises);
                Axis::linear(0.0, 100.0 * hi.max(0.01) * 1.08, "sensor noise std / response std (%)")
            }
        }
    }
}

/// Where `x` sits on the plotted axis (a noise level in percent).
fn at(x: &Summary, axis: Varied) -> f64 {
    match axis {
        Varied::RecordLength => x.configuration.record_length,
        Varied::SampleInterval => x.configuration.sample_interval,
        Varied::SensorNoise => 100.0 * noise_of(x).max(0.0),
    }
}

/// Median worst error (quartiles as bars) per method against the varied axis, with the
/// `1/√T` guide against record length.
fn error_panel(st: &StudyLines, axis: Varied) -> Panel {
    let mut p = Panel::new(
        match axis {
            Varied::RecordLength => "worst error against record length",
            Varied::SampleInterval => "worst error against sample interval",
            Varied::SensorNoise => "worst error against sensor noise (the same motion at every level)",
        },
        st.x_axis(axis),
        Axis::log(
            100.0 * st.ylo,
            100.0 * st.yhi * 2.5,
            "worst relative error (%): median, quartiles",
        ),
    );
    for (k, m) in st.methods.iter().enumerate() {
        for (g, &other) in st.groups(axis).iter().enumerate() {
            let pts = st.line_of(m, axis, other);
            if pts.is_empty() {
                continue;
            }
            let col = color(k + g * st.methods.len());
            let stroke = Stroke::solid(col, 2.0);
            let line: Vec<(f64, f64)> = pts.iter().map(|x| (at(x, axis), 100.0 * x.worst_median)).collect();
            p.mark(Mark::Bars {
                bars: pts
                    .iter()
                    .map(|x| (at(x, axis), 100.0 * x.worst_q1, 100.0 * x.worst_q3))
                    .collect(),
                stroke: Stroke::solid(col, 1.5),
            });
            p.mark(Mark::Line {
                points: line.clone(),
                stroke,
            });
            p.mark(Mark::Points {
                points: line,
                color: col,
                radius: 3.0,
            });
            let label = if axis != Varied::SampleInterval && st.intervals.len() > 1 {
                format!("{m}, h = {other} s")
            } else {
                m.to_string()
            };
            p.entry(Swatch::LinePoint(stroke, 3.0), label);
        }
    }
    if axis == Varied::RecordLength && st.lengths.len() > 1 {
        // The 1/√T guide through the first method's first point.
        if let Some(first) = st.ok.iter().find(|x| {
            x.method == st.methods[0]
                && x.configuration.record_length == st.lengths[0]
                && Some(noise_of(x)) == st.noises.first().copied()
        }) {
            let guide = st
                .lengths
                .iter()
                .map(|&t| (t, 100.0 * first.worst_median * (st.lengths[0] / t).sqrt()))
                .collect();
            p.line(guide, Stroke::dashed(GREY, 1.2, 6.0, 4.0), Some("1/√T".into()));
        }
    }
    p.legend_at = Corner::Above;
    p
}

/// The coverage of the 95 % intervals against the first varied axis.
fn coverage_panel(st: &StudyLines) -> Panel {
    let axis = st.axes[0];
    let lowest = st.ok.iter().filter_map(|x| x.coverage).fold(1.0f64, f64::min);
    let y0 = if lowest > 0.8 { 75.0 } else { 0.0 };
    let mut p = Panel::new(
        "coverage of the 95 % intervals (bars: its 95 % interval over the items)",
        st.x_axis(axis),
        Axis::linear(y0, 102.0, "intervals holding the truth (%)"),
    );
    let nominal = Stroke::dashed(GREY, 1.2, 6.0, 4.0);
    p.mark(Mark::HLine {
        y: 95.0,
        stroke: nominal,
    });
    p.entry(Swatch::Line(nominal), "nominal 95 %");
    // Each method's bars a little to the side, so that equal intervals stay visible: by a
    // factor on a log axis, by a share of the span on the linear one.
    let span = st.noises.last().copied().unwrap_or(0.0).max(0.01) * 100.0;
    for (k, m) in st.methods.iter().enumerate() {
        for (g, &other) in st.groups(axis).iter().enumerate() {
            let pts: Vec<(f64, f64)> = st
                .line_of(m, axis, other)
                .iter()
                .filter_map(|x| x.coverage.map(|c| (at(x, axis), (100.0 * c).max(y0))))
                .collect();
            if pts.is_empty() {
                continue;
            }
            let col = color(k + g * st.methods.len());
            let offset = 0.012 * (k as f64 - (st.methods.len() - 1) as f64 / 2.0);
            for x in st.line_of(m, axis, other) {
                if let Some([lo, hi]) = x.coverage_ci {
                    let bar = [(100.0 * lo).max(y0), (100.0 * hi).max(y0)];
                    let place = match axis {
                        Varied::SensorNoise => at(x, axis) + offset * span,
                        _ => at(x, axis) * (1.0 + offset),
                    };
                    error_bar(&mut p, place, bar, 0.0, col);
                }
            }
            connected(&mut p, pts, col);
        }
    }
    p.legend_at = Corner::Above;
    p
}

/// How often each method could not decide (or the item could not be run), against the
/// first varied axis: a refusal is a result of the study.
fn refusal_panel(st: &StudyLines, summary: &[Summary]) -> Panel {
    let axis = st.axes[0];
    let mut p = Panel::new(
        "refused or failed items",
        st.x_axis(axis),
        Axis::linear(0.0, 102.0, "items refused or failed (%)"),
    );
    for (k, m) in st.methods.iter().enumerate() {
        for (g, &other) in st.groups(axis).iter().enumerate() {
            let pts: Vec<(f64, f64)> = summary
                .iter()
                .filter(|x| st.on_line(x, m, axis, other))
                .filter_map(|x| {
                    let n = x.items + x.refused + x.failed;
                    (n > 0).then(|| (at(x, axis), 100.0 * (x.refused + x.failed) as f64 / n as f64))
                })
                .collect();
            if pts.is_empty() {
                continue;
            }
            connected(&mut p, pts, color(k + g * st.methods.len()));
        }
    }
    p.legend_at = Corner::Above;
    p
}

/// A line through `pts` with a point on each.
fn connected(p: &mut Panel, pts: Vec<(f64, f64)>, col: Color) {
    p.mark(Mark::Line {
        points: pts.clone(),
        stroke: Stroke::solid(col, 2.0),
    });
    p.mark(Mark::Points {
        points: pts,
        color: col,
        radius: 3.0,
    });
}

/// The figure of a study of one configuration: per method, every seed's worst error (a
/// point each, spread sideways so that equal errors stay visible) with the median (a bar
/// across) and the quartiles (a bar beside), on a log scale; below, the coverage of each
/// method's 95 % intervals against the nominal 0.95 (dashed).
pub fn plot_methods(summary: &[Summary], rows: &[Row], path: &Path) -> std::io::Result<Vec<PathBuf>> {
    let methods: Vec<&Summary> = summary.iter().collect();
    let names: Vec<String> = methods.iter().map(|x| x.method.clone()).collect();
    let worst = |m: &str| -> Vec<f64> {
        rows.iter()
            .filter(|r| r.method == m)
            .filter_map(|r| r.worst_rel_error)
            .filter(|e| e.is_finite() && *e > 0.0)
            .collect()
    };
    let (ylo, yhi) = log_range(names.iter().flat_map(|m| worst(m)), 1.6);
    let (ylo, yhi) = if ylo.is_finite() && yhi > ylo {
        (ylo, yhi)
    } else {
        (1e-3, 1.0)
    };
    let config = methods.first().map_or(String::new(), |x| {
        let c = &x.configuration;
        let noise = c
            .sensor_noise
            .map_or(String::new(), |n| format!(", sensor noise {} %", 100.0 * n));
        format!(", T = {} s, h = {} s{noise}", c.record_length, c.sample_interval)
    });
    let mut p = Panel::new(
        format!("worst error over the seeds{config}"),
        Axis::categories(names.clone(), ""),
        Axis::log(
            100.0 * ylo,
            100.0 * yhi * 1.5,
            "worst relative error (%): seeds, median, quartiles",
        ),
    );
    for (k, m) in names.iter().enumerate() {
        let x = (k + 1) as f64;
        let errors = worst(m);
        let n = errors.len().max(2) as f64;
        let points = errors
            .iter()
            .enumerate()
            .map(|(i, e)| (x - 0.3 + 0.6 * i as f64 / (n - 1.0), 100.0 * e))
            .collect();
        p.mark(Mark::Points {
            points,
            color: color(k),
            radius: 2.0,
        });
        let s = methods[k];
        if s.worst_median.is_finite() && s.worst_median > 0.0 {
            let black = Stroke::solid(BLACK, 2.0);
            p.mark(Mark::Bars {
                bars: vec![(x + 0.36, 100.0 * s.worst_q1, 100.0 * s.worst_q3)],
                stroke: black,
            });
            p.mark(Mark::Line {
                points: vec![(x - 0.36, 100.0 * s.worst_median), (x + 0.36, 100.0 * s.worst_median)],
                stroke: black,
            });
        }
    }
    let mut fig = Figure::new(1080.0);
    fig.row(420.0, vec![Some(p)]);
    if methods.iter().any(|x| x.coverage.is_some()) {
        let mut c = Panel::new(
            "coverage of the 95 % intervals (dashed: the nominal 95 %; grey: its 95 % interval over the items)",
            Axis::categories(names.clone(), ""),
            Axis::linear(0.0, 102.0, "intervals holding the truth (%)"),
        );
        c.mark(Mark::HLine {
            y: 95.0,
            stroke: Stroke::dashed(GREY, 1.2, 6.0, 4.0),
        });
        for (k, s) in methods.iter().enumerate() {
            if let Some(v) = s.coverage {
                let at = ((k + 1) as f64, 100.0 * v);
                c.mark(Mark::Line {
                    points: vec![((k + 1) as f64, 0.0), at],
                    stroke: Stroke::solid(color(k), 3.0),
                });
                c.mark(Mark::Points {
                    points: vec![at],
                    color: color(k),
                    radius: 4.0,
                });
                if let Some([lo, hi]) = s.coverage_ci {
                    error_bar(&mut c, (k + 1) as f64, [100.0 * lo, 100.0 * hi], 0.12, GREY);
                }
            }
        }
        fig.row(280.0, vec![Some(c)]);
    }
    if methods.iter().any(|x| x.refused + x.failed + x.not_applicable > 0) {
        // Every item × method has an outcome: the share of items each method refused
        // (dark), could not run (failed) or did not apply to, stacked.
        let mut c = Panel::new(
            "items without estimates: refused (the data could not decide), failed, not applicable",
            Axis::categories(names.clone(), ""),
            Axis::linear(0.0, 102.0, "items (%)"),
        );
        for (k, s) in methods.iter().enumerate() {
            let n = (s.items + s.refused + s.failed + s.not_applicable).max(1) as f64;
            let x = (k + 1) as f64;
            let mut base = 0.0;
            for (count, width, shade) in [
                (s.refused, 6.0, color(k)),
                (s.failed, 3.0, BLACK),
                (s.not_applicable, 1.5, GREY),
            ] {
                if count == 0 {
                    continue;
                }
                let top = base + 100.0 * count as f64 / n;
                c.mark(Mark::Line {
                    points: vec![(x, base), (x, top)],
                    stroke: Stroke::solid(shade, width),
                });
                base = top;
            }
        }
        fig.row(240.0, vec![Some(c)]);
    }
    selection_rows(&mut fig, summary);
    write_figure(path, &fig)
}

#[cfg(test)]
mod tests {
    /// Shares print to two decimals; a tiny one that is not 0 keeps its size.
    #[test]
    fn a_tiny_share_is_not_printed_as_zero() {
        assert_eq!(super::pct(0.0123), "1.23 %");
        assert_eq!(super::pct(0.0), "0.00 %");
        assert_eq!(super::pct(4.6e-6), "4.6e-4 %");
        assert_eq!(super::pct(f64::NAN), "–");
    }
}
