//! Reports of an identification: the printed table, `report.json`, `report.md`, and SVG
//! plots (plotters' SVG backend, no system fonts). Every file is written to a temporary
//! name and renamed when complete.

use crate::bench::{Histogram, Report};
use crate::io::partial_path;
use crate::model::Characteristic;
use crate::scenario::DIRECT_FORCE;
use crate::stats;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// Write `text` to `path` atomically.
pub fn write_atomic(path: &Path, text: &[u8]) -> std::io::Result<()> {
    if let Some(d) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d)?;
    }
    let tmp = partial_path(path);
    std::fs::write(&tmp, text)?;
    std::fs::rename(&tmp, path)
}

fn fmt_err(e: f64) -> String {
    if e.is_nan() {
        "—".into()
    } else if e < 1e-3 {
        format!("{e:.1e}")
    } else {
        format!("{:.2} %", 100.0 * e)
    }
}

/// The human summary (also the body of `report.md`).
pub fn summary(r: &Report) -> String {
    let mut s = String::new();
    s += &format!(
        "scenario {}: {} samples every {} s, {} trajectories x {} s = {} s of record ({}; dt {} s, seed {})\n",
        r.scenario,
        r.samples,
        r.sample_interval_s,
        r.trajectories,
        r.record_length_s,
        r.total_record_s,
        r.scheme,
        r.dt_s,
        r.seed
    );
    s += &format!(
        "time: simulate {:.2} s, identify {:.2} s, total {:.2} s\n\n",
        r.timings_s.simulate, r.timings_s.identify, r.timings_s.total
    );
    for f in &r.filters {
        s += &format!(
            "filter {}: A = {:.4}, B = {:.4} 1/s used ({}); spectral fit A = {:.4} ({:+.2} %), B = {:.4} ({:+.2} %) vs true {}, {}; \
             log residual RMS {:.3} (averaging alone: {:.3}) over {} segments of {}\n",
            f.excitation,
            f.a,
            f.b,
            f.used,
            f.fitted_a,
            100.0 * (f.fitted_a / f.true_a - 1.0),
            f.fitted_b,
            100.0 * (f.fitted_b / f.true_b - 1.0),
            f.true_a,
            f.true_b,
            f.rms_log_residual,
            f.expected_rms_log_residual,
            f.segments,
            f.segment_len
        );
    }
    if !r.filters.is_empty() {
        s += "\n";
    }
    let methods: Vec<_> = r.methods.iter().collect();
    // Parameter table: one column per method.
    s += &format!("| {:<18} | {:>10} |", "parameter", "true");
    for m in &methods {
        s += &format!(" {:>12} {:>9} |", m.method, "error");
    }
    s += "\n|";
    s += &"-".repeat(20);
    s += "|";
    s += &"-".repeat(12);
    s += "|";
    for _ in &methods {
        s += &"-".repeat(24);
        s += "|";
    }
    s += "\n";
    let names: Vec<String> = methods
        .iter()
        .find(|m| !m.parameters.is_empty())
        .map(|m| m.parameters.iter().map(|p| p.name.clone()).collect())
        .unwrap_or_default();
    for (k, name) in names.iter().enumerate() {
        let t = methods
            .iter()
            .find_map(|m| m.parameters.get(k))
            .map(|p| p.true_value)
            .unwrap_or(f64::NAN);
        s += &format!("| {name:<18} | {t:>10.4} |");
        for m in &methods {
            match m.parameters.get(k) {
                Some(p) => s += &format!(" {:>12.5} {:>9} |", p.estimate, fmt_err(p.rel_error)),
                None => s += &format!(" {:>12} {:>9} |", "—", "—"),
            }
        }
        s += "\n";
    }
    s += "\n";
    for m in &methods {
        s += &format!("{}: ", m.method);
        if let Some(e) = &m.error {
            s += &format!("FAILED: {e}\n");
            continue;
        }
        if m.gated {
            s += &format!(
                "worst error {} (threshold {}) {}",
                fmt_err(m.worst_rel_error),
                fmt_err(m.threshold),
                if m.passed { "PASS" } else { "FAIL" }
            );
        } else {
            s += &format!(
                "worst error {} (baseline or comparison, not gated)",
                fmt_err(m.worst_rel_error)
            );
        }
        if let Some(d) = &m.diagnostics {
            s += &format!("; rank {}/{}, sv ratio {:.2e}", d.rank, d.cols, d.sv_ratio);
        }
        s += &format!("; {:.2} s\n", m.seconds);
        if m.weakly_determined {
            s += "  WARNING: smallest/largest singular value below 1e-3: the estimates are weakly determined\n";
        }
        for c in &m.curves {
            s += &format!(
                "  curve {} {}: relative L2 error {} over [{:.4}, {:.4}]\n",
                c.link,
                c.kind,
                fmt_err(c.rel_l2_error),
                c.range[0],
                c.range[1]
            );
        }
        for (k, v) in &m.facts {
            s += &format!("  {k}: {v}\n");
        }
        for d in m.dissipativity.iter().filter(|d| !d.holds) {
            s += &format!("  DISSIPATIVITY: {} {}: {}\n", d.link, d.kind, d.message);
        }
        if m.dissipativity.iter().all(|d| d.holds) && !m.dissipativity.is_empty() {
            s += "  dissipativity (3.4): K(u)·u > 0 and C(w)·w > 0 hold over the observed ranges\n";
        }
    }
    if let (Some(j), Some(m)) = (
        r.methods.iter().find(|m| m.method == "strong" && m.error.is_none()),
        r.methods
            .iter()
            .find(|m| m.method == "strong-marginals" && m.error.is_none()),
    ) {
        let worst = m.parameters.iter().max_by(|a, b| a.rel_error.total_cmp(&b.rel_error));
        s +=
            &format!(
            "\nproduct of marginals (3.21): replacing the joint density by the product of its marginals ignores the \
             dependence between the state variables; on the same grid it gives a worst error of {} against {} for the \
             joint density{}.\n",
            fmt_err(m.worst_rel_error),
            fmt_err(j.worst_rel_error),
            worst.map(|p| format!(" ({} off by {})", p.name, fmt_err(p.rel_error))).unwrap_or_default()
        );
    }
    for it in &r.iterations {
        s += &iteration_summary(it);
    }
    if let Some(v) = &r.validation {
        s += &format!(
            "\nvalidation: the {} model re-simulated ({} trajectories x {:.0} s, seed {})\n",
            v.method, v.trajectories, v.record_length_s, v.seed
        );
        if let Some(e) = &v.error {
            s += &format!("  {e}\n");
        } else {
            s += &format!(
                "| {:<10} | {:>10} | {:>10} | {:>9} | {:>10} | {:>10} |\n",
                "response", "data std", "model std", "diff", "data kurt", "model kurt"
            );
            s += "|------------|------------|------------|-----------|------------|------------|\n";
            for row in &v.rows {
                s += &format!(
                    "| {:<10} | {:>10.5} | {:>10.5} | {:>8.2}% | {:>10.3} | {:>10.3} |\n",
                    row.variable,
                    row.data_std,
                    row.model_std,
                    100.0 * (row.model_std / row.data_std - 1.0),
                    row.data_kurtosis,
                    row.model_kurtosis
                );
            }
        }
    }
    s += &format!(
        "\nresult: {}\n",
        if r.passed {
            "every acceptance gate passed"
        } else {
            "an acceptance gate FAILED"
        }
    );
    s
}

/// The iterative procedure's sequence (paper section 4): every step's estimates and
/// worst error, the fit of `P3s`, the changes, and how it stopped.
fn iteration_summary(r: &crate::bench::IterationReport) -> String {
    let it = &r.iteration;
    let mut s = format!(
        "\niterative procedure for the unmeasured disturbance (paper section 4, weak form in every step), \
         single-mass step: {} (method {})\n",
        it.single_mass.name(),
        r.method
    );
    s += &format!("| {:>4} |", "step");
    for n in &it.names {
        s += &format!(" {n:>14} |");
    }
    s += &format!(
        " {:>9} | {:>22} | {:>28} |\n",
        "worst", "P3s fit A, B", "change k1 / K2 / C2"
    );
    s += &format!("|{}|", "-".repeat(6));
    for _ in &it.names {
        s += &format!("{}|", "-".repeat(16));
    }
    s += &format!("{}|{}|{}|\n", "-".repeat(11), "-".repeat(24), "-".repeat(30));
    s += &format!("| {:>4} |", "true");
    for t in &it.truth {
        s += &format!(" {t:>14.5} |");
    }
    s += &format!(" {:>9} | {:>22} | {:>28} |\n", "", "", "");
    for (k, st) in it.steps.iter().enumerate() {
        s += &format!("| {:>4} |", st.step);
        for v in &st.values {
            s += &format!(" {v:>14.5} |");
        }
        let fit = st.p3_fit.map(|f| format!("{:.3}, {:.3}", f.a, f.b)).unwrap_or_default();
        let changes = st
            .changes
            .iter()
            .map(|(_, c)| format!("{c:.1e}"))
            .collect::<Vec<_>>()
            .join(" / ");
        s += &format!(
            " {:>9} | {fit:>22} | {changes:>28} |\n",
            fmt_err(r.step_worst_rel_error[k])
        );
    }
    s += &format!(
        "stopped by {} after {} steps (max {}, tolerance {:.1e} relative); successive differences {} (the paper's criterion): {}\n",
        it.stopped_by,
        it.steps.len() - 1,
        it.max_steps,
        it.tolerance,
        if it.monotone { "decrease monotonically" } else { "do NOT decrease monotonically" },
        if it.converged { "converged" } else { "not converged" }
    );
    s += &format!(
        "worst error: step 0 {}, final {}, with the disturbance given as measured (bound, {}) {}\n",
        fmt_err(r.step0_worst_rel_error),
        fmt_err(r.final_worst_rel_error),
        r.bound,
        fmt_err(r.bound_worst_rel_error)
    );
    s
}

/// The sweep as a table.
pub fn sweep_summary(sw: &crate::bench::Sweep) -> String {
    let mut s = format!(
        "disturbance sweep of {} (level = std of the unmeasured force / std of the measured one)\n",
        sw.scenario
    );
    let methods: Vec<&str> = sw
        .points
        .first()
        .map(|p| p.sequences.iter().map(|q| q.method.as_str()).collect())
        .unwrap_or_default();
    s += &format!("| {:>6} | {:>12} | {:>12} |", "level", "step 0", DIRECT_FORCE);
    for m in &methods {
        s += &format!(
            " {m:>14} | {:>5} | {:>8} | {:<12} | {:>17} |",
            "steps", "monotone", "stopped by", "its bound"
        );
    }
    s += "\n|--------|--------------|--------------|";
    for _ in &methods {
        s += "----------------|-------|----------|--------------|-------------------|";
    }
    s += "\n";
    for p in &sw.points {
        s += &format!(
            "| {:>6} | {:>12} | {:>12} |",
            p.level,
            fmt_err(p.step0_worst_rel_error),
            fmt_err(p.direct_worst_rel_error)
        );
        for q in &p.sequences {
            s += &format!(
                " {:>14} | {:>5} | {:>8} | {:<12} | {:>17} |",
                fmt_err(q.final_worst_rel_error),
                q.steps,
                q.monotone,
                q.stopped_by,
                fmt_err(q.bound_worst_rel_error)
            );
        }
        s += "\n";
    }
    if let Some(p) = sw.points.first() {
        s += "(bounds: ";
        s += &p
            .sequences
            .iter()
            .map(|q| format!("{} for {}", q.bound_method, q.method))
            .collect::<Vec<_>>()
            .join(", ");
        s += ": the disturbance given as if measured; direct-force: k1, K2, C2 in one solve of (4.8), no iteration)\n";
    }
    s += "(worst relative error over every parameter and curve, as in the run reports)\n";
    s
}

/// Write `sweep.json`, `sweep.md` and `sweep.svg` into `dir`.
pub fn write_sweep(sw: &crate::bench::Sweep, dir: &Path) -> std::io::Result<Vec<PathBuf>> {
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

/// Worst error of step 0, of each sequence's final iterate and of its bound against the disturbance
/// level (log scale).
pub fn plot_sweep(sw: &crate::bench::Sweep, path: &Path) -> PlotResult {
    svg_to_file(path, (900, 520), |root| {
        let pts = &sw.points;
        // (label, worst error per level): step 0, each sequence's final iterate, the bound.
        let mut curves: Vec<(String, Vec<(f64, f64)>)> = vec![(
            "step 0 (P_z ignored)".into(),
            pts.iter().map(|p| (p.level, p.step0_worst_rel_error)).collect(),
        )];
        let methods: Vec<String> = pts
            .first()
            .map(|p| p.sequences.iter().map(|q| q.method.clone()).collect())
            .unwrap_or_default();
        for (k, m) in methods.iter().enumerate() {
            curves.push((
                format!("final iterate, {m}"),
                pts.iter()
                    .map(|p| (p.level, p.sequences[k].final_worst_rel_error))
                    .collect(),
            ));
        }
        curves.push((
            format!("{DIRECT_FORCE}: one solve of (4.8), no iteration"),
            pts.iter().map(|p| (p.level, p.direct_worst_rel_error)).collect(),
        ));
        for (k, m) in methods.iter().enumerate() {
            let bound = pts.first().map_or("", |p| p.sequences[k].bound_method.as_str());
            curves.push((
                format!("P_z given as measured ({bound}): bound of {m}"),
                pts.iter()
                    .map(|p| (p.level, p.sequences[k].bound_worst_rel_error))
                    .collect(),
            ));
        }
        for (_, c) in &mut curves {
            c.iter_mut().for_each(|(_, e)| *e *= 100.0);
            c.retain(|(_, e)| e.is_finite() && *e > 0.0);
        }
        let all: Vec<f64> = curves.iter().flat_map(|(_, c)| c.iter().map(|p| p.1)).collect();
        let lo = all.iter().copied().fold(f64::INFINITY, f64::min).min(1.0) * 0.5;
        let hi = all.iter().copied().fold(0.0, f64::max).max(10.0) * 8.0; // headroom for the legend
        let xmax = pts.iter().map(|p| p.level).fold(0.0, f64::max).max(1e-3) * 1.05;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!("{}: worst relative error against disturbance level", sw.scenario),
                ("sans-serif", 18),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(-0.02 * xmax..xmax, (lo..hi).log_scale())?;
        chart
            .configure_mesh()
            .x_desc("disturbance level: std(P_z) / std(P_2)")
            .y_desc("worst relative error (%)")
            .draw()?;
        for (k, (label, data)) in curves.into_iter().enumerate() {
            let color = COLORS[k % COLORS.len()];
            chart
                .draw_series(LineSeries::new(data.clone(), color.stroke_width(2)))?
                .label(label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)));
            chart.draw_series(
                data.into_iter()
                    .map(move |(x, y)| Circle::new((x, y), 4, color.filled())),
            )?;
        }
        legend_box(&mut chart, SeriesLabelPosition::UpperLeft)?;
        Ok(())
    })
}

/// Every parameter of the iterative procedure against the step number, one line per
/// sequence, with the true value (dashed), each sequence's bound — the estimate with the
/// disturbance given as measured (dotted, in the sequence's colour) — and the one-step
/// `direct-force` estimate (long dashes); one legend for all panels in a cell of its own.
pub fn plot_iteration(r: &Report, path: &Path) -> PlotResult {
    let Some(first) = r.iterations.first() else {
        return Ok(());
    };
    let names = &first.iteration.names;
    // One cell more than the panels: the legend's.
    let rows = (names.len() + 1).div_ceil(2);
    let estimates = |method: &str| {
        r.methods
            .iter()
            .find(|m| m.method == method && m.error.is_none())
            .map(|m| m.parameters.iter().map(|p| p.estimate).collect::<Vec<f64>>())
    };
    // Reference lines: (style, label, estimates, dash, gap): each sequence's bound, in its
    // colour, and the one-step estimate.
    let mut lines: Vec<(ShapeStyle, String, Vec<f64>, u32, u32)> = r
        .iterations
        .iter()
        .enumerate()
        .filter_map(|(j, it)| {
            let v = estimates(&it.bound)?;
            let label = format!("{}: P_z given as measured, bound of {}", it.bound, it.method);
            Some((COLORS[j].stroke_width(1), label, v, 2, 3))
        })
        .collect();
    if let Some(v) = estimates(DIRECT_FORCE) {
        let label = format!("{DIRECT_FORCE}: one solve of (4.8), no iteration");
        lines.push((COLORS[r.iterations.len()].stroke_width(2), label, v, 10, 4));
    }
    let tstyle = ShapeStyle {
        color: BLACK.to_rgba(),
        filled: false,
        stroke_width: 1,
    };
    svg_to_file(path, (1000, 300 * rows as u32), |root| {
        let cells = root.split_evenly((rows, 2));
        for (k, area) in cells.iter().enumerate().take(names.len()) {
            let sequences: Vec<Vec<(f64, f64)>> = r
                .iterations
                .iter()
                .map(|it| {
                    it.iteration
                        .steps
                        .iter()
                        .map(|s| (s.step as f64, s.values[k]))
                        .collect()
                })
                .collect();
            let truth = first.iteration.truth[k];
            let ys = sequences
                .iter()
                .flat_map(|v| v.iter().map(|p| p.1))
                .chain([truth])
                .chain(lines.iter().map(|l| l.2[k]))
                .filter(|y| y.is_finite());
            let (lo, hi) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), y| (l.min(y), h.max(y)));
            let pad = 0.1 * (hi - lo).max(1e-3 * truth.abs().max(1e-12));
            let steps = sequences.iter().map(Vec::len).max().unwrap_or(0);
            let last = steps.max(2) as f64 - 1.0;
            let mut chart = ChartBuilder::on(area)
                .caption(&names[k], ("sans-serif", 16))
                .margin(10)
                .x_label_area_size(34)
                .y_label_area_size(70)
                .build_cartesian_2d(-0.2..last + 0.2, lo - pad..hi + pad)?;
            chart
                .configure_mesh()
                .x_desc("step")
                .y_desc("estimate")
                .x_labels(steps.clamp(2, 12))
                .draw()?;
            chart.draw_series(DashedLineSeries::new(
                vec![(-0.2, truth), (last + 0.2, truth)],
                6,
                4,
                tstyle,
            ))?;
            for (style, _, values, dash, gap) in &lines {
                let b = values[k];
                if b.is_finite() {
                    chart.draw_series(DashedLineSeries::new(
                        vec![(-0.2, b), (last + 0.2, b)],
                        *dash,
                        *gap,
                        *style,
                    ))?;
                }
            }
            for (j, values) in sequences.into_iter().enumerate() {
                let c = COLORS[j];
                chart.draw_series(LineSeries::new(values.clone(), c.stroke_width(2)))?;
                chart.draw_series(values.iter().map(|&(x, y)| Circle::new((x, y), 4, c.filled())))?;
            }
        }
        // The legend, in the first free cell.
        let area = &cells[names.len()];
        let font = ("sans-serif", 15).into_font();
        let mut y = 30;
        let mut entry = |sample: &dyn Fn(i32) -> PlotResult, label: &str| -> PlotResult {
            sample(y)?;
            area.draw(&Text::new(label.to_string(), (90, y - 8), font.clone()))?;
            y += 28;
            Ok(())
        };
        for (j, it) in r.iterations.iter().enumerate() {
            let c = COLORS[j];
            entry(
                &|y| {
                    area.draw(&PathElement::new(vec![(30, y), (75, y)], c.stroke_width(2)))?;
                    area.draw(&Circle::new((52, y), 4, c.filled()))?;
                    Ok(())
                },
                &format!("{}: {} single-mass step", it.method, it.iteration.single_mass.name()),
            )?;
        }
        // A dashed sample of the panels' pattern (in pixels).
        let dashed = |y: i32, dash: u32, gap: u32, style: ShapeStyle| -> PlotResult {
            let mut x = 30;
            while x < 75 {
                let end = (x + dash as i32).min(75);
                area.draw(&PathElement::new(vec![(x, y), (end, y)], style))?;
                x = end + gap as i32;
            }
            Ok(())
        };
        entry(&|y| dashed(y, 6, 4, tstyle), "true value")?;
        for (style, label, _, dash, gap) in &lines {
            entry(&|y| dashed(y, *dash, *gap, *style), label)?;
        }
        Ok(())
    })
}

/// Write `report.json`, `report.md` and the plots into `dir`; returns the files written.
pub fn write_all(r: &Report, dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    let json = serde_json::to_string_pretty(r).map_err(std::io::Error::other)?;
    let p = dir.join("report.json");
    write_atomic(&p, json.as_bytes())?;
    files.push(p);
    let md = format!(
        "# fpkbench report: {}\n\n```\n{}```\n\nPlots: `characteristics.svg` (identified vs true characteristics over the observed range, data distribution beneath), `densities.svg` (marginal densities, data vs re-simulated model).\n",
        r.scenario,
        summary(r)
    );
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
    Ok(files)
}

const COLORS: [RGBColor; 7] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
];

type PlotResult = Result<(), Box<dyn std::error::Error>>;

/// The series legend in a framed, lightly opaque box at `position`.
fn legend_box<'a, DB: DrawingBackend + 'a, CT: plotters::coord::CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
) -> PlotResult
where
    DB::ErrorType: 'static,
{
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

fn svg_to_file(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(DrawingArea<SVGBackend, plotters::coord::Shift>) -> PlotResult,
) -> PlotResult {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE)?;
        draw(root.clone())?;
        root.present()?;
    }
    write_atomic(path, svg.as_bytes())?;
    Ok(())
}

fn draw_histogram_strip(
    area: &DrawingArea<SVGBackend, plotters::coord::Shift>,
    h: &Histogram,
    xlabel: &str,
) -> PlotResult {
    let max = h.counts.iter().copied().fold(0.0, f64::max).max(1.0);
    let mut chart = ChartBuilder::on(area)
        .margin_left(10)
        .margin_right(15)
        .x_label_area_size(32)
        .y_label_area_size(60)
        .build_cartesian_2d(h.lo..h.hi, 0.0..1.05)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .y_labels(2)
        .y_desc("data")
        .x_desc(xlabel)
        .draw()?;
    let w = (h.hi - h.lo) / h.counts.len() as f64;
    chart.draw_series(h.counts.iter().enumerate().map(|(i, &c)| {
        let x0 = h.lo + i as f64 * w;
        Rectangle::new([(x0, 0.0), (x0 + w, c / max)], RGBColor(160, 160, 160).filled())
    }))?;
    Ok(())
}

/// For every link and characteristic: truth and each method's estimate over the observed
/// range, with the data's distribution beneath.
pub fn plot_characteristics(r: &Report, path: &Path) -> PlotResult {
    let s = r.scenario_def.as_ref().expect("scenario");
    let [ux, uv, _, uf, _] = s.motion.units();
    let mut panels = Vec::new();
    for (l, link) in s.links.iter().enumerate() {
        for kind in [Characteristic::Stiffness, Characteristic::Damping] {
            let truth = stats::true_characteristic(s, l, kind);
            let identified = r
                .methods
                .iter()
                .any(|m| m.curves.iter().any(|c| c.link == link.name && c.kind == kind.name()));
            if truth.is_empty() && !identified {
                continue;
            }
            panels.push((l, kind));
        }
    }
    let cols = 2usize;
    let rows = panels.len().div_ceil(cols).max(1);
    svg_to_file(path, (1100, 420 * rows as u32), |root| {
        let areas = root.split_evenly((rows, cols));
        for ((l, kind), area) in panels.iter().zip(areas) {
            let link = &s.links[*l];
            let (hist, var, unit) = match kind {
                Characteristic::Stiffness => (&r.plot.link_hist[*l].0, "u", ux),
                Characteristic::Damping => (&r.plot.link_hist[*l].1, "w", uv),
            };
            let (top, bottom) = area.split_vertically((area.dim_in_pixel().1 as f64 * 0.74) as u32);
            let truth = stats::true_characteristic(s, *l, *kind);
            let (lo, hi) = (hist.lo, hist.hi);
            let xs: Vec<f64> = (0..=200).map(|k| lo + (hi - lo) * k as f64 / 200.0).collect();
            let mut curves: Vec<(String, Vec<f64>, RGBColor, bool)> = vec![(
                "true".into(),
                xs.iter().map(|&z| truth.eval(z)).collect(),
                RGBColor(0, 0, 0),
                false,
            )];
            for (mi, m) in r.methods.iter().enumerate() {
                if let Some(c) = m.curves.iter().find(|c| c.link == link.name && c.kind == kind.name()) {
                    let p = stats::characteristic(&c.identified);
                    curves.push((
                        format!("{} ({} error)", m.method, fmt_err(c.rel_l2_error)),
                        xs.iter().map(|&z| p.eval(z)).collect(),
                        COLORS[mi % COLORS.len()],
                        true,
                    ));
                }
            }
            let ymin = curves
                .iter()
                .flat_map(|c| c.1.iter())
                .copied()
                .fold(f64::INFINITY, f64::min);
            let ymax = curves
                .iter()
                .flat_map(|c| c.1.iter())
                .copied()
                .fold(f64::NEG_INFINITY, f64::max);
            let pad = 0.05 * (ymax - ymin).max(1e-12);
            let title = format!(
                "{} {}: {} force vs {var} ({})",
                link.name,
                kind.name(),
                if *kind == Characteristic::Stiffness {
                    "spring"
                } else {
                    "damper"
                },
                if *kind == Characteristic::Stiffness {
                    "relative displacement"
                } else {
                    "relative velocity"
                }
            );
            let mut chart = ChartBuilder::on(&top)
                .caption(title, ("sans-serif", 16))
                .margin_left(10)
                .margin_right(15)
                .margin_top(5)
                .x_label_area_size(20)
                .y_label_area_size(60)
                .build_cartesian_2d(lo..hi, (ymin - pad)..(ymax + pad))?;
            chart
                .configure_mesh()
                .y_desc(format!(
                    "{} ({uf})",
                    if *kind == Characteristic::Stiffness {
                        "K(u)"
                    } else {
                        "C(w)"
                    }
                ))
                .x_label_formatter(&|_| String::new())
                .draw()?;
            for (name, ys, color, dashed) in &curves {
                let pts: Vec<(f64, f64)> = xs.iter().copied().zip(ys.iter().copied()).collect();
                let style = ShapeStyle {
                    color: color.to_rgba(),
                    filled: false,
                    stroke_width: if *dashed { 2 } else { 3 },
                };
                if *dashed {
                    chart
                        .draw_series(DashedLineSeries::new(pts, 8, 5, style))?
                        .label(name.clone())
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
                } else {
                    chart
                        .draw_series(LineSeries::new(pts, style))?
                        .label(name.clone())
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
                }
            }
            legend_box(&mut chart, SeriesLabelPosition::UpperLeft)?;
            draw_histogram_strip(
                &bottom,
                hist,
                &format!("{var} ({unit}) — observed range; grey: distribution of the data"),
            )?;
        }
        Ok(())
    })
}

/// Marginal density of every response: data against the re-simulated identified model.
pub fn plot_densities(r: &Report, path: &Path) -> PlotResult {
    let m = &r.plot.marginals;
    let cols = 2usize;
    let rows = m.len().div_ceil(cols).max(1);
    let model_name = r.validation.as_ref().map(|v| v.method).unwrap_or("model");
    svg_to_file(path, (1000, 340 * rows as u32), |root| {
        for ((name, unit, data, model), area) in m.iter().zip(root.split_evenly((rows, cols))) {
            let dd = data.density(r.plot.samples.max(1.0));
            let md = model.as_ref().map(|h| h.density(r.plot.model_samples.max(1.0)));
            let ymax = dd.iter().chain(md.iter().flatten()).copied().fold(0.0, f64::max) * 1.08;
            let w = (data.hi - data.lo) / data.counts.len() as f64;
            let mut chart = ChartBuilder::on(&area)
                .caption(format!("marginal density of {name}"), ("sans-serif", 16))
                .margin(10)
                .x_label_area_size(35)
                .y_label_area_size(55)
                .build_cartesian_2d(data.lo..data.hi, 0.0..ymax.max(1e-12))?;
            chart
                .configure_mesh()
                .x_desc(format!("{name} ({unit})"))
                .y_desc(format!("density (1/{unit})"))
                .draw()?;
            chart
                .draw_series(dd.iter().enumerate().map(|(i, &d)| {
                    let x0 = data.lo + i as f64 * w;
                    Rectangle::new([(x0, 0.0), (x0 + w, d)], RGBColor(170, 170, 170).filled())
                }))?
                .label("data (histogram)")
                .legend(|(x, y)| Rectangle::new([(x, y - 5), (x + 18, y + 5)], RGBColor(170, 170, 170).filled()));
            if let Some(md) = md {
                let pts: Vec<(f64, f64)> = md
                    .iter()
                    .enumerate()
                    .map(|(i, &d)| (data.lo + (i as f64 + 0.5) * w, d))
                    .collect();
                let style = ShapeStyle {
                    color: COLORS[0].to_rgba(),
                    filled: false,
                    stroke_width: 2,
                };
                chart
                    .draw_series(LineSeries::new(pts, style))?
                    .label(format!("re-simulated {model_name} model"))
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
            }
            legend_box(&mut chart, SeriesLabelPosition::UpperRight)?;
        }
        Ok(())
    })
}

/// Estimated force spectra with the fitted (3.20) and true curves, log–log (the paper's
/// Fig. 6).
pub fn plot_spectra(r: &Report, path: &Path) -> PlotResult {
    let sp = &r.plot.spectra;
    let unit = r.scenario_def.as_ref().map(|s| s.motion.units()[3]).unwrap_or("N");
    svg_to_file(path, (900, 420 * sp.len().max(1) as u32), |root| {
        for ((name, spec, fit, (ta, tb)), area) in sp.iter().zip(root.split_evenly((sp.len().max(1), 1))) {
            let (w0, w1) = (spec.omega[0], spec.omega[spec.omega.len() - 1]);
            let dmin = spec
                .density
                .iter()
                .copied()
                .filter(|d| *d > 0.0)
                .fold(f64::INFINITY, f64::min);
            let dmax = spec.density.iter().copied().fold(0.0, f64::max);
            let mut chart = ChartBuilder::on(&area)
                .caption(format!("spectral density of the force p_{name}"), ("sans-serif", 16))
                .margin(10)
                .x_label_area_size(38)
                .y_label_area_size(70)
                .build_cartesian_2d((w0..w1).log_scale(), (dmin * 0.5..dmax * 2.0).log_scale())?;
            chart
                .configure_mesh()
                .x_desc("ω (rad/s)")
                .y_desc(format!("S(ω) (({unit})²·s/rad)"))
                .draw()?;
            chart
                .draw_series(
                    spec.omega
                        .iter()
                        .zip(&spec.density)
                        .map(|(&w, &d)| Circle::new((w, d), 2, RGBColor(150, 150, 150).filled())),
                )?
                .label(format!("Welch estimate ({} segments)", spec.segments))
                .legend(|(x, y)| Circle::new((x + 9, y), 3, RGBColor(150, 150, 150).filled()));
            let fitted: Vec<(f64, f64)> = spec
                .omega
                .iter()
                .map(|&w| {
                    (
                        w,
                        crate::ident::spectrum::sampled_ou_density(fit.a, fit.b, spec.sample_interval, w),
                    )
                })
                .collect();
            let style = ShapeStyle {
                color: COLORS[0].to_rgba(),
                filled: false,
                stroke_width: 2,
            };
            chart
                .draw_series(LineSeries::new(fitted, style))?
                .label(format!("fit: A = {:.3}, B = {:.3} 1/s", fit.a, fit.b))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
            let truth: Vec<(f64, f64)> = spec
                .omega
                .iter()
                .map(|&w| {
                    (
                        w,
                        crate::ident::spectrum::sampled_ou_density(*ta, *tb, spec.sample_interval, w),
                    )
                })
                .collect();
            let tstyle = ShapeStyle {
                color: BLACK.to_rgba(),
                filled: false,
                stroke_width: 1,
            };
            if ta.is_finite() {
                chart
                    .draw_series(DashedLineSeries::new(truth, 6, 4, tstyle))?
                    .label(format!("true: A = {ta}, B = {tb} 1/s"))
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], tstyle));
            }
            legend_box(&mut chart, SeriesLabelPosition::LowerLeft)?;
        }
        Ok(())
    })
}
