//! The console report: tables of estimates, errors, diagnostics and validation.

use crate::report::types::Validation;
use crate::report::MethodReport;
use crate::report::Report;
use crate::scenario::{Method, ReportMethod};

/// A relative error (or gate) as a percentage: one unit everywhere.
pub(crate) fn fmt_err(e: f64) -> String {
    if e.is_nan() {
        "—".into()
    } else if 100.0 * e < 0.01 {
        format!("{:.1e} %", 100.0 * e)
    } else {
        format!("{:.2} %", 100.0 * e)
    }
}

/// Decimals that show a standard error to two significant digits (an estimate and its
/// interval are printed to the same place).
pub(crate) fn decimals(se: f64) -> usize {
    if se.is_finite() && se > 0.0 {
        (1.0 - se.log10().floor()).clamp(0.0, 12.0) as usize
    } else {
        5
    }
}

/// `x` to `d` decimals, `—` when not finite.
pub(crate) fn fixed(x: f64, d: usize) -> String {
    if x.is_finite() {
        format!("{x:.d$}")
    } else {
        "—".into()
    }
}

/// `estimate ± std_error`, with `°` when the 95 % interval contains 0.
pub(crate) fn fmt_estimate(p: &crate::report::Parameter) -> String {
    let zero = if p.differs_from_zero == Some(false) { "°" } else { "" };
    let d = decimals(p.std_error);
    if p.std_error.is_finite() {
        format!("{} ± {}{zero}", fixed(p.estimate, d), fixed(p.std_error, d))
    } else {
        format!("{}{zero}", fixed(p.estimate, d))
    }
}

/// `x` to six significant digits, as a table cell (`—` when not finite).
fn sig(x: f64) -> String {
    if !x.is_finite() {
        return "—".into();
    }
    let d = (5 - x.abs().log10().floor() as i32).clamp(0, 12) as usize;
    format!("{x:.d$}")
}

/// Width of one method's estimate column.
pub(crate) const EST_W: usize = 22;

/// The terminal's width: tables keep within it (methods side by side only as far as they
/// fit; the full tables are in report.md), and longer prose lines are wrapped.
pub const WIDTH: usize = 100;

/// `text` with every line over [`WIDTH`] characters that is not a table row wrapped at its
/// spaces, the continuation indented two more than the line.
pub fn fit(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + text.len() / 50);
    for line in text.split_inclusive('\n') {
        let body = line.trim_end_matches('\n');
        if body.chars().count() <= WIDTH || body.starts_with('|') {
            out += line;
            continue;
        }
        let indent = body.len() - body.trim_start().len() + 2;
        let mut width = 0;
        for (k, word) in body.split(' ').enumerate() {
            let n = word.chars().count();
            if k > 0 && width + 1 + n > WIDTH && width > indent {
                out += "\n";
                out += &" ".repeat(indent);
                width = indent;
            } else if k > 0 {
                out += " ";
                width += 1;
            }
            out += word;
            width += n;
        }
        out += "\n";
    }
    if !text.ends_with('\n') && out.ends_with('\n') {
        out.pop();
    }
    out
}

/// What a gate is, said once per report.
pub(crate) const GATE_MEANING: &str = "a regression gate is the mean + 4 sd of the worst error over seeds, set in the \
     scenario's [accept] section: it catches a regression of the method; the accuracy is in the errors, not in the gate";

/// The human summary (also the body of `report.md`).
pub fn summary(r: &Report) -> String {
    let mut s = header(r);
    s += &filters(r);
    if let Some(n) = &r.sensor_noise {
        s += &(sensor_noise_lines(n).join("\n") + "\n");
    }
    if let Some(sel) = &r.selection {
        s += &(super::selection::selection_lines(sel).join("\n") + "\n");
    }
    if let Some(p) = &r.profile {
        s += &(super::selection::profile_lines(p).join("\n") + "\n");
    }
    s += &parameter_table(r);
    for m in &r.methods {
        s += &method_lines(m);
    }
    s += &marginals_comparison(r);
    for it in &r.iterations {
        s += &iteration_summary(it);
    }
    if let Some(v) = &r.validation {
        s += &validation(v);
    }
    if let Some(p) = &r.prediction {
        s += &prediction(p);
    }
    if let Some(b) = &r.integrator_bias {
        s += &integrator_bias(b);
    }
    s += &format!(
        "\nresult: {}. Note: {GATE_MEANING}.\n",
        if r.passed && r.methods.iter().all(|m| m.threshold.is_none()) {
            "every method gave an estimate (nothing graded: no truth)"
        } else if r.passed && r.methods.iter().any(|m| m.threshold_default) {
            "every gate holds, some only the uncalibrated default (set [accept] from the spread over seeds)"
        } else if r.passed {
            "every regression gate holds"
        } else if !r.failed_checks.is_empty() {
            "a check of the method's premises FAILED (below)"
        } else {
            "a regression gate is EXCEEDED or its method failed"
        }
    );
    for c in &r.failed_checks {
        s += &format!("FAILED CHECK {} ({}): {}\n", c.check, c.method, c.message);
    }
    if r.validation.as_ref().and_then(|v| v.reproduces) == Some(false)
        && !r.failed_checks.iter().any(|c| c.check == "validation")
    {
        s += "WARNING: the identified model does not reproduce the data (validation above): the structure \
              assumed (the terms, or the link forces as functions of u and w) misses something the data have.\n";
    }
    fit(&s)
}

/// The sensors' noise as estimated, one line per channel, and what was done about it.
pub fn sensor_noise_lines(n: &super::SensorNoiseReport) -> Vec<String> {
    let mut out = Vec::new();
    let done = if n.corrected {
        "taken out of the weak form's moments"
    } else {
        "not corrected"
    };
    out.push(format!("sensor noise ({}; {done}):", n.handling));
    if let Some(why) = &n.not_estimated {
        out.push(format!("  not estimated: {why}"));
    }
    for c in &n.channels {
        let simulated = c
            .simulated_std
            .map(|v| format!(" (simulated {:.2} %)", 100.0 * v / c.signal_std))
            .unwrap_or_default();
        out.push(format!(
            "  {}: {:.4e} ± {:.1e} = {:.2} % of the signal's std{simulated}{}",
            c.column,
            c.std,
            c.std_se,
            100.0 * c.std / c.signal_std,
            if !c.detected {
                ", not distinguishable from none"
            } else if c.corrected_std > 0.0 {
                ", taken out"
            } else {
                ""
            },
        ));
    }
    for note in &n.notes {
        out.push(format!("  {note}"));
    }
    out
}

/// What was identified from: the scenario or measured records, a truncated log, the
/// variant, data notes and timings.
fn header(r: &Report) -> String {
    let mut s = String::new();
    s += &match &r.records {
        Some(d) => format!(
            "model {}: measured data, {}\n",
            r.scenario,
            d.describe(r.samples, r.sample_interval_s)
        ),
        None => format!(
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
        ),
    };
    if r.samples < r.expected_samples {
        s += &format!(
            "TRUNCATED LOG: identified from the {} samples it still holds, of {} the run was to write\n",
            r.samples, r.expected_samples
        );
    }
    if !r.provenance.overrides.is_empty() {
        s += &format!("variant: --set {}\n", r.provenance.overrides.join(" --set "));
    }
    for n in &r.data_notes {
        s += &format!("data: {n}\n");
    }
    // Measured data, or a log identified as it is: nothing was simulated.
    s += &if r.records.is_some() || r.timings_s.simulate == 0.0 {
        format!("time: identify {:.2} s\n\n", r.timings_s.identify)
    } else {
        format!(
            "time: simulate {:.2} s, identify {:.2} s, total {:.2} s\n\n",
            r.timings_s.simulate, r.timings_s.identify, r.timings_s.total
        )
    };
    s
}

/// Each filter: the `A`, `B` used, and where they were fitted, the fit against the truth
/// (once: a fitted filter's values are the ones used).
fn filters(r: &Report) -> String {
    let mut s = String::new();
    for f in &r.filters {
        let vs_truth = if f.true_a.is_finite() {
            format!(
                " ({:+.2} %, {:+.2} % against the true {}, {})",
                100.0 * (f.a / f.true_a - 1.0),
                100.0 * (f.b / f.true_b - 1.0),
                f.true_a,
                f.true_b
            )
        } else {
            String::new()
        };
        s += &if f.used == "fitted" {
            format!(
                "filter {}: A = {:.4}, B = {:.4} 1/s fitted{vs_truth}",
                f.excitation, f.a, f.b
            )
        } else {
            format!(
                "filter {}: A = {:.4}, B = {:.4} 1/s {} (the spectral fit gives A = {:.4}, B = {:.4})",
                f.excitation, f.a, f.b, f.used, f.fitted_a, f.fitted_b
            )
        };
        s += &format!(
            "; log residual RMS {:.3} (averaging alone: {:.3}) over {} segments of {}",
            f.rms_log_residual, f.expected_rms_log_residual, f.segments, f.segment_len
        );
        match (f.noise_floor, f.noise_floor_se) {
            (Some(n), Some(se)) => {
                s += &format!("; the force cell's noise floor, estimated at {n:.3e} ± {se:.1e}, taken out first")
            }
            (Some(n), None) => s += &format!("; the force cell's stated noise floor {n:.3e} taken out first"),
            (None, Some(se)) => s += &format!("; no force-cell noise floor beyond 3 standard errors ({se:.1e})"),
            (None, None) => {}
        }
        s += "\n";
    }
    for c in &r.force_models {
        s += &force_model_line(c);
    }
    for w in &r.white_levels {
        s += &white_level_line(w);
    }
    if !r.filters.is_empty() || !r.white_levels.is_empty() || !r.force_models.is_empty() {
        s += "\n";
    }
    s
}

/// A force whose model was chosen from its spectrum: every candidate's misfit, the choice.
pub(crate) fn force_model_line(c: &crate::report::ForceModelChoice) -> String {
    let times = |rms: f64, expected: f64| format!("{:.1}×", rms / expected);
    let second = c.second_order.map_or("not fitted".to_string(), |f| {
        format!(
            "{} (poles at {:.4} Hz, damping ratio {:.3})",
            times(f.rms_log_residual, f.expected_rms),
            f.omega / (2.0 * std::f64::consts::PI),
            f.zeta
        )
    });
    format!(
        "force {} model chosen from its spectrum: {}; misfit against averaging alone: white over the response's \
         band {}, first-order (3.20) {}, second-order {second}{}\n",
        c.excitation,
        c.chosen,
        times(c.white.rms_log_residual, c.white.expected_rms_log_residual),
        times(c.first_order.rms_log_residual, c.first_order.expected_rms),
        if c.refused.is_some() {
            "; the methods that need the force model are REFUSED"
        } else {
            ""
        }
    )
}

/// A force read as its equivalent white noise: its level, the bands and the misfit.
pub(crate) fn white_level_line(w: &crate::report::WhiteLevelReport) -> String {
    let vs_truth = if w.true_sigma.is_finite() {
        format!(
            " ({:+.2} % against the true {})",
            100.0 * (w.sigma / w.true_sigma - 1.0),
            w.true_sigma
        )
    } else {
        String::new()
    };
    // One record gives no spread to measure the level's standard error by.
    let se = if w.sigma_se.is_finite() {
        format!("± {:.2}", w.sigma_se)
    } else {
        "(one record: no standard error)".to_string()
    };
    format!(
        "force {} read as white: sigma = {:.4} {se}{vs_truth} over the response's band {:.2}–{:.2} Hz (the \
         force's band {:.2}–{:.2} Hz, {:.1} % of the gain beyond it, corrected for); log residual RMS {:.3} \
         (averaging alone: {:.3}) over {} segments of {}{}\n",
        w.excitation,
        w.sigma,
        w.band_hz.0,
        w.band_hz.1,
        w.force_band_hz.0,
        w.force_band_hz.1,
        100.0 * w.edge_share,
        w.rms_log_residual,
        w.expected_rms_log_residual,
        w.segments,
        w.segment_len,
        if w.accepted {
            ""
        } else {
            "; REJECTED (docs/methods.md, \"The force model\")"
        }
    )
}

/// Seconds as a reader wants them: milliseconds below a tenth of a second (a method's
/// time, "0.00 s" before).
pub(crate) fn fmt_seconds(t: f64) -> String {
    if t < 0.1 {
        format!("{:.1} ms", 1e3 * t)
    } else {
        format!("{t:.2} s")
    }
}

/// Per parameter and method: the estimate ± standard error and its error, with the legend;
/// the methods side by side as far as they fit in [`WIDTH`] columns, the rest in further
/// tables below.
fn parameter_table(r: &Report) -> String {
    let methods: Vec<_> = r.methods.iter().collect();
    let width = |m: &&MethodReport| EST_W.max(format!("{} ± std. error", m.method).chars().count());
    // "| parameter | unit | true |" is 48 wide, each method `w + 14`.
    let mut groups: Vec<Vec<&MethodReport>> = Vec::new();
    let mut used = WIDTH;
    for &m in &methods {
        let w = width(&m) + 14;
        if used + w > WIDTH {
            groups.push(Vec::new());
            used = 48;
        }
        groups.last_mut().expect("a group").push(m);
        used += w;
    }
    let motion = r.scenario_def.as_ref().map_or(Default::default(), |d| d.motion);
    let tables: Vec<String> = groups
        .iter()
        .map(|g| super::table::side_by_side(g, motion).text())
        .collect();
    let mut s = tables.join("\n");
    s += "\nerrors are relative to the truth (a coefficient whose true value is 0: to its characteristic's scale under the \
          observed density); std. error: delete-one jackknife over the record's batches; 95 % interval: ± t(0.975) std. errors";
    if methods
        .iter()
        .any(|m| m.parameters.iter().any(|p| p.differs_from_zero == Some(false)))
    {
        s += "; ° its 95 % interval contains 0 (the data do not ask for this term)";
    }
    if methods.iter().any(|m| {
        m.parameters
            .iter()
            .any(|p| p.rel_error.is_nan() && p.true_value.is_finite())
    }) {
        s += "; — the model's terms cannot represent the true characteristic: its coefficients estimate no true \
              ones, and the characteristic's curve error grades it";
    }
    s += "\n\n";
    s
}

/// One method's outcome, gate, diagnostics, warnings, curves, facts and dissipativity.
fn method_lines(m: &MethodReport) -> String {
    let mut s = format!("{}: ", m.method);
    if let Some(why) = m.outcome.not_applicable() {
        return s + &format!("NOT APPLICABLE: {why}\n");
    }
    if let Some(e) = m.outcome.error() {
        return s + &format!("{}: {e}\n", m.outcome.kind().name().to_uppercase());
    }
    match (m.threshold, m.passed) {
        (Some(t), Some(ok)) => {
            s += &format!(
                "worst error {}; {} {}: {}",
                fmt_err(m.worst_rel_error),
                if m.threshold_default {
                    "default gate (not calibrated: the scenario's [accept] sets none)"
                } else {
                    "regression gate"
                },
                fmt_err(t),
                if ok { "within" } else { "EXCEEDED" }
            )
        }
        _ if m.worst_rel_error.is_nan() => s += "not graded (no truth for its parameters)",
        _ => {
            s += &format!(
                "worst error {} (baseline or comparison, no gate)",
                fmt_err(m.worst_rel_error)
            )
        }
    }
    if let Some(d) = &m.diagnostics {
        s += &format!("; rank {}/{}, sv ratio {:.2e}", d.rank, d.cols, d.sv_ratio);
    }
    s += &format!("; {}\n", fmt_seconds(m.seconds));
    if m.weakly_determined {
        s += "  WARNING: smallest/largest singular value below 1e-3: the estimates are weakly determined\n";
    }
    for w in &m.warnings {
        s += &format!("  WARNING: {w}\n");
    }
    if let Some(why) = no_std_errors(m) {
        s += &format!("  no standard errors: {why}\n");
    }
    if let Some(e) = efficiency(m) {
        s += &format!("  {e}\n");
    }
    for c in &m.curves {
        s += &format!(
            "  curve {} {}: L2 error {} {} the {}, range [{:.4}, {:.4}]\n",
            c.link,
            c.kind,
            fmt_err(c.rel_l2_error),
            if c.norm == crate::report::NORM_DENSITY {
                "under"
            } else {
                "evenly over"
            },
            c.norm,
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
    s
}

/// The strong form on the joint density against the product of its marginals (3.21).
fn marginals_comparison(r: &Report) -> String {
    let mut s = String::new();
    if let (Some(j), Some(m)) = (
        r.methods
            .iter()
            .find(|m| m.method == ReportMethod::Estimator(Method::Strong) && m.outcome.error().is_none()),
        r.methods
            .iter()
            .find(|m| m.method == ReportMethod::Estimator(Method::StrongMarginals) && m.outcome.error().is_none()),
    ) {
        let worst = m.parameters.iter().max_by(|a, b| a.rel_error.total_cmp(&b.rel_error));
        s +=
            &format!(
            "\nproduct of marginals (3.21): replacing the joint density by the product of its marginals ignores the \
             dependence between the state variables; it gives a worst error of {} against {} for the strong form on \
             the joint density{}.\n",
            fmt_err(m.worst_rel_error),
            fmt_err(j.worst_rel_error),
            worst.map(|p| format!(" ({} off by {})", p.name, fmt_err(p.rel_error))).unwrap_or_default()
        );
    }
    s
}

/// The identified model re-simulated against the data.
fn validation(v: &Validation) -> String {
    let mut s = String::new();
    s += &format!(
        "\nvalidation: the {} model re-simulated ({} trajectories x {:.0} s, seed {})\n",
        v.method, v.trajectories, v.record_length_s, v.seed
    );
    if !v.left_out.is_empty() {
        s += &format!("  {}\n", v.left_out_note());
    }
    if let Some(e) = &v.error {
        s += &format!("  {e}\n");
    } else {
        // Compact (the full table, stds and kurtoses apart, is in report.md).
        s += &super::table::validation(v).text();
        s += "  diff: model std / data std − 1, ± its standard error from the sampling of both (the spread between \
              trajectory groups); kurt: kurtosis of data / model; spec rms ln: RMS of ln(S_model/S_data) over the \
              band holding 99 % of the data's variance, (in brackets) what the averaging alone gives; peak ω in rad/s.\n";
    }
    if let Some(v) = v.verdict() {
        s += &format!("  verdict: {v}.\n");
    }
    s
}

/// The integrator's bias on every estimate, with the parameters where it matters named.
fn integrator_bias(b: &crate::report::IntegratorBias) -> String {
    let mut s = format!(
        "\nintegrator bias (Richardson: the same Brownian paths at h = {:.3e} s and h/2, weak order {}; bias = \
         (estimate at h − at h/2) / (1 − 2^−{})):\n",
        b.step_s, b.order, b.order
    );
    s += &super::table::integrator_bias(b).text();
    let exceeding = b.exceeding();
    if exceeding.is_empty() {
        s += "  every bias is below a quarter of its standard error: the integrator does not limit these estimates.\n";
    } else {
        s += &format!(
            "WARNING: the integrator's bias exceeds a quarter of the standard error for {}: at this record the \
             bench grades its integrator as much as the estimator; reduce dt or raise substeps{}.\n",
            exceeding.join(", "),
            if b.order < 2 {
                ", or step with scheme = \"heun\" (weak order 2, about the same cost at 2.5 times the step; \
                 docs/simulation.md)"
            } else {
                ""
            }
        );
    }
    s
}

/// The iterative procedure's sequence (paper section 4): every step's estimates and
/// worst error, the fit of `P3s`, the changes, and how it stopped.
pub(crate) fn iteration_summary(r: &crate::report::IterationReport) -> String {
    let it = &r.iteration;
    let mut s = format!(
        "\niterative procedure for the unmeasured disturbance (paper section 4, weak form in every step), \
         single-mass step: {} (method {})\n",
        it.single_mass.name(),
        r.method
    );
    // Two tables to keep within the terminal's width: the estimates and worst error per
    // step, then the fit of P3s and the changes.
    let mut values = super::table::Table::new().right("step").min_width(4);
    for n in &it.names {
        values = values.right(n.to_string()).min_width(9);
    }
    values = values.right("worst").min_width(9);
    values.row(
        std::iter::once("true".to_string())
            .chain(r.truth.iter().map(|t| sig(*t)))
            .chain([String::new()]),
    );
    for (k, st) in it.steps.iter().enumerate() {
        values.row(
            std::iter::once(st.step.to_string())
                .chain(st.values.iter().map(|v| sig(*v)))
                .chain([fmt_err(r.step_worst_rel_error[k])]),
        );
    }
    s += &values.text();
    let mut fits = super::table::Table::new()
        .right("step")
        .min_width(4)
        .right("P3s fit A, B")
        .min_width(22)
        .right("change k1 / K2 / C2")
        .min_width(28);
    for st in &it.steps {
        let fit = st.p3_fit.map(|f| format!("{:.3}, {:.3}", f.a, f.b)).unwrap_or_default();
        let changes = st
            .changes
            .iter()
            .map(|(_, c)| format!("{c:.1e}"))
            .collect::<Vec<_>>()
            .join(" / ");
        fits.row([st.step.to_string(), fit, changes]);
    }
    s += "\n";
    s += &fits.text();
    s += &format!(
        "stopped by {} after {} steps (max {}, tolerance {:.1e} relative); successive differences {} (the paper's \
         criterion): the sequence {} — which says nothing about how close it is to the truth\n",
        it.stopped_by,
        it.steps.len() - 1,
        it.max_steps,
        it.tolerance,
        if it.monotone {
            "decrease monotonically"
        } else {
            "do NOT decrease monotonically"
        },
        if it.converged { "converged" } else { "did not converge" }
    );
    s += &format!(
        "worst error: step 0 {}, final {}, with the disturbance given as measured (bound, {}) {}\n",
        fmt_err(r.step0_worst_rel_error),
        fmt_err(r.final_worst_rel_error),
        r.bound,
        fmt_err(r.bound_worst_rel_error)
    );
    s += &against_step0(r);
    s
}

/// How the standard errors compare with the Cramér–Rao bound of continuous observation:
/// the range over the parameters of `(bound / std. error)²` (1: as good as the whole path
/// allows; a sampled path can do no better, so above 1 the standard error understates).
/// Only for the FPK estimators meant to be right (the gated ones).
pub(crate) fn efficiency(m: &crate::report::MethodReport) -> Option<String> {
    // A bound on unbiased estimators: not a yardstick for the known-biased rows.
    if !matches!(m.method, crate::scenario::ReportMethod::Estimator(x) if x.is_gated()) {
        return None;
    }
    let ratios: Vec<f64> = m
        .parameters
        .iter()
        .filter_map(|p| Some((p.cramer_rao_std? / p.std_error).powi(2)))
        .filter(|v| v.is_finite())
        .collect();
    if ratios.is_empty() {
        return None;
    }
    let (lo, hi) = ratios
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(l, h), &v| (l.min(v), h.max(v)));
    Some(format!(
        "efficiency against the Cramér–Rao bound of continuous observation, (bound / std. error)²: {lo:.2} to \
         {hi:.2} over the parameters (1 is the whole path's best; above 1 the standard error understates)"
    ))
}

/// Why a method's estimates carry no standard errors, when none of them has one.
pub(crate) fn no_std_errors(m: &crate::report::MethodReport) -> Option<&'static str> {
    use crate::scenario::ReportMethod;
    if m.parameters.is_empty() || m.parameters.iter().any(|p| p.std_error.is_finite()) {
        return None;
    }
    Some(match m.method {
        ReportMethod::Iterated | ReportMethod::IteratedForce | ReportMethod::Step => {
            "the section-4 sequence is run once on the whole record, not once per jackknife batch, so its \
             iterates have none; step-0's row shows the sampling noise of one solve, and the sequence's \
             error against the truth is its bias"
        }
        _ => "the record has fewer than two batches for the jackknife",
    })
}

/// The sequence judged parameter by parameter against the truth: which ended further
/// from it than step 0 (the worst error alone can fall while most parameters get worse).
pub(crate) fn against_step0(r: &crate::report::IterationReport) -> String {
    let (Some(first), Some(last)) = (r.step_rel_errors.first(), r.step_rel_errors.last()) else {
        return String::new();
    };
    let known: Vec<usize> = (0..first.len().min(last.len()))
        .filter(|&k| first[k].is_finite() && last[k].is_finite())
        .collect();
    if known.is_empty() {
        return String::new();
    }
    let worse: Vec<String> = known
        .iter()
        .filter(|&&k| last[k] > first[k])
        .map(|&k| format!("{} {} → {}", r.iteration.names[k], fmt_err(first[k]), fmt_err(last[k])))
        .collect();
    let verdict = if worse.is_empty() {
        "every parameter ended at least as close to the truth as at step 0".to_string()
    } else {
        format!(
            "{} of {} parameters ended further from the truth than at step 0 ({}){}",
            worse.len(),
            known.len(),
            worse.join(", "),
            if 2 * worse.len() > known.len() {
                ": the procedure made most estimates WORSE"
            } else {
                ""
            }
        )
    };
    format!("against the truth: {verdict}\n")
}

/// The sweep as a table.
pub fn sweep_summary(sw: &crate::report::Sweep) -> String {
    let mut s = format!(
        "disturbance sweep of {} (level = std of the unmeasured force / std of the measured one)\n",
        sw.scenario
    );
    let methods: Vec<&ReportMethod> = sw
        .points
        .first()
        .map(|p| p.sequences.iter().map(|q| &q.method).collect())
        .unwrap_or_default();
    s += &format!(
        "| {:>6} | {:>12} | {:>12} |",
        "level",
        "step 0",
        ReportMethod::DirectForce.name()
    );
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

/// The free-run simulation error on held-out records: a line per compared column, one per
/// method.
pub(crate) fn prediction(p: &crate::report::PredictionReport) -> String {
    let mut s = format!(
        "\nprediction: each identified model driven by the measured forces of {} held-out record(s) \
         ({} samples every {} s, {} Runge-Kutta steps per sample; {})\n",
        p.records,
        p.samples,
        p.sample_interval_s,
        p.substeps,
        p.files.join(", ")
    );
    for (q, (column, spread)) in p.columns.iter().enumerate() {
        s += &format!("  {column}: measured RMS {spread:.4e} about its mean\n");
        for row in &p.rows {
            s += &match &row.error {
                Some(e) => format!("    {:<18} not driven: {e}\n", row.method.to_string()),
                None => format!(
                    "    {:<18} RMS error {:.4e} ({:.2} % of the measured), mean error {:+.3e}\n",
                    row.method.to_string(),
                    row.rms_error[q],
                    100.0 * row.rms_error[q] / spread,
                    row.mean_error[q]
                ),
            };
        }
    }
    s
}
