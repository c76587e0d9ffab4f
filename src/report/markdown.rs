//! `report.md`: the report as a page a reader opens first — the verdict, the estimates
//! with their uncertainty per method, the figures embedded, the diagnostics and where the
//! run came from. Markdown tables and image links only, so any renderer shows it; `report.html`
//! is made from the same text ([`super::html`]), folding the blocks after `<!-- fold: … -->`.

use super::figures::image;
use super::text::{fmt_err, iteration_summary, GATE_MEANING};
use super::{MethodReport, Report, Validation};

/// One method's line in the verdict list.
fn verdict(m: &MethodReport) -> String {
    if let Some(why) = m.outcome.not_applicable() {
        return format!("**{}**: not applicable — {why}", m.method);
    }
    if let Some(e) = m.outcome.error() {
        return format!("**{}**: {}, no estimate — {e}", m.method, m.outcome.kind().name());
    }
    let kind = if m.threshold_default {
        "default gate (not calibrated: the scenario's [accept] sets none)"
    } else {
        "regression gate"
    };
    let gate = match (m.threshold, m.passed) {
        (Some(t), Some(true)) => format!("within its {kind} of {}", fmt_err(t)),
        (Some(t), Some(false)) => format!("**exceeds** its {kind} of {}", fmt_err(t)),
        _ => "a baseline or comparison, not gated".into(),
    };
    let mut s = format!(
        "**{}**: worst error {} over {} parameters and curves; {gate}",
        m.method,
        fmt_err(m.worst_rel_error),
        m.parameters.len() + m.curves.len()
    );
    if m.weakly_determined {
        s += "; weakly determined (singular-value ratio below 1e-3)";
    }
    for w in &m.warnings {
        s += &format!("; warning: {w}");
    }
    s
}

/// The estimates of one method: value, standard error, 95 % interval, error, and the
/// efficiency against the Cramér–Rao bound where there is one.
fn parameter_table(m: &MethodReport, motion: crate::scenario::Motion) -> String {
    let mut s = super::table::estimates(m, motion).markdown();
    if let Some(e) = super::text::efficiency(m) {
        s += &format!("\n{e}.\n");
    }
    s
}

/// The whole page.
pub fn markdown(r: &Report) -> String {
    let mut s = format!("# fpkbench report: {}\n\n", r.scenario);
    s += &match &r.records {
        Some(d) => format!("Measured data: {}.\n\n", d.describe(r.samples, r.sample_interval_s)),
        None => format!(
            "{} samples every {} s from {} trajectories × {} s ({} s of record), {} scheme with dt {} s, seed {}.\n\n",
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
            "> **Truncated log**: identified from the {} samples it still holds, of {} the run was to write.\n\n",
            r.samples, r.expected_samples
        );
    }
    if !r.data_notes.is_empty() {
        s += "## Reading the data\n\n";
        for n in &r.data_notes {
            s += &format!("- {}\n", n.replacen("WARNING:", "**Warning:**", 1));
        }
        s += "\n";
    }
    if let Some(n) = &r.sensor_noise {
        s += &sensor_noise_section(n);
    }
    if let Some(sel) = &r.selection {
        s += &super::selection::selection_section(sel, &image(r, "selection"));
    }
    if let Some(p) = &r.profile {
        s += &super::selection::profile_section(p);
    }
    s += "## Verdict\n\n";
    for m in &r.methods {
        let mut line = verdict(m);
        // A sequence that converged is not a sequence that got closer to the truth.
        if let Some(it) = r.iterations.iter().find(|it| it.method == m.method) {
            let judged = super::text::against_step0(it);
            if judged.contains("further from the truth") {
                line += &format!(
                    "; converged, but {}",
                    judged.trim().trim_start_matches("against the truth: ")
                );
            }
        }
        s += &format!("- {line}\n");
    }
    s += &format!(
        "\n{} — {GATE_MEANING}.\n\n",
        if r.passed {
            "Every regression gate holds"
        } else if !r.failed_checks.is_empty() {
            "**A check of the method's premises failed**"
        } else {
            "**A regression gate is exceeded or its method failed**"
        }
    );
    for c in &r.failed_checks {
        s += &format!("- **Failed check: {}** ({}): {}\n", c.check, c.method, c.message);
    }
    if !r.failed_checks.is_empty() {
        s += "\n";
    }
    s += &image(r, "characteristics");
    s += "## Estimates\n\n";
    s += "Errors are relative to the truth; a coefficient whose true value is 0 is measured against its \
          characteristic's scale, and a characteristic's L2 error is taken, under the observed density of its \
          argument (where the samples are; evenly over the observed range where a term is not a power). Standard errors: delete-one jackknife over the \
          record's batches; 95 % intervals: ± Student's t(0.975) standard errors. They measure the sampling \
          noise only, not a method's bias. A characteristic whose model cannot represent the truth (powers for a \
          friction, hinges for a cubic) has no coefficient errors (—): its coefficients estimate no true ones, and \
          its curve's L2 error grades it.\n\n";
    let motion = r.scenario_def.as_ref().map_or(Default::default(), |d| d.motion);
    for m in &r.methods {
        s += &method_section(m, motion);
    }
    let compared = image(r, "compare");
    if !compared.is_empty() {
        s += "## Models compared\n\n";
        s += &compared;
    }
    s += &filters_section(r);
    s += &white_levels_section(r);
    s += &iterations_section(r);
    if let Some(v) = &r.validation {
        s += &validation_section(r, v);
    }
    if let Some(p) = &r.prediction {
        s += &format!(
            "## Prediction on held-out records\n\n```\n{}```\n\n",
            super::text::prediction(p).trim_start()
        );
    }
    if let Some(b) = &r.integrator_bias {
        s += &integrator_bias_section(b);
    }
    s += &provenance_section(r);
    s
}

/// One method's estimates, curves and diagnostics.
fn method_section(m: &MethodReport, motion: crate::scenario::Motion) -> String {
    let mut s = format!("### {}\n\n", m.method);
    if let Some(why) = m.outcome.not_applicable() {
        return s + &format!("Not applicable: {why}\n\n");
    }
    if let Some(e) = m.outcome.error() {
        return s + &format!("No estimate ({}): {e}\n\n", m.outcome.kind().name());
    }
    s += &parameter_table(m, motion);
    if let Some(why) = super::text::no_std_errors(m) {
        s += &format!("\nNo standard errors: {why}.\n");
    }
    if !m.curves.is_empty() {
        s += "\n";
        s += &super::table::curves(m).markdown();
    }
    s += &format!("\n<!-- fold: diagnostics of {} -->\n", m.method);
    if let Some(d) = &m.diagnostics {
        s += &format!(
            "- identifiability: rank {}/{}, singular-value ratio {:.2e}\n",
            d.rank, d.cols, d.sv_ratio
        );
    }
    for (k, v) in &m.facts {
        s += &format!("- {k}: {v}\n");
    }
    for d in &m.dissipativity {
        if !d.holds {
            s += &format!("- **dissipativity** {} {}: {}\n", d.link, d.kind, d.message);
        }
    }
    if !m.dissipativity.is_empty() && m.dissipativity.iter().all(|d| d.holds) {
        s += "- dissipativity (3.4): K(u)·u > 0 and C(w)·w > 0 hold over the observed ranges\n";
    }
    s += &format!("- time: {}\n\n", super::text::fmt_seconds(m.seconds));
    s
}

/// The sensors' noise: estimate per channel, what the scenario simulated, what was taken
/// out.
fn sensor_noise_section(n: &super::SensorNoiseReport) -> String {
    let mut s = format!(
        "## Sensor noise\n\nEstimated from the samples themselves (docs/measurement.md); `sensor_noise = \"{}\"`: {}.\n\n",
        n.handling,
        if n.corrected {
            "the weak form reads moments corrected for the sensors (the notes say for what)"
        } else {
            "nothing was corrected"
        }
    );
    if let Some(why) = &n.not_estimated {
        s += &format!("Not estimated: {why}.\n\n");
    }
    if !n.channels.is_empty() {
        s += &super::table::sensor_noise(n).markdown();
        s += "\n";
    }
    for note in &n.notes {
        s += &format!("- {note}\n");
    }
    if !n.notes.is_empty() {
        s += "\n";
    }
    s
}

/// The filtered excitations' fits.
fn filters_section(r: &Report) -> String {
    let mut s = String::new();
    if !r.filters.is_empty() {
        s += "## Filtered excitations\n\n";
        s += &super::table::filters(r).markdown();
        s += "\n";
        s += &image(r, "spectrum");
    }
    s
}

/// The forces read as their equivalent white noise.
fn white_levels_section(r: &Report) -> String {
    let mut s = String::new();
    if !r.force_models.is_empty() {
        s += "## Force models chosen from the spectra\n\n";
        for c in &r.force_models {
            s += &format!("- {}", super::text::force_model_line(c));
        }
        s += "\n";
    }
    if r.white_levels.is_empty() {
        return s;
    }
    s += "## Forces read as white\n\n";
    for w in &r.white_levels {
        s += &format!("- {}", super::text::white_level_line(w));
    }
    s + "\n"
}

/// The section-4 procedure's sequences, step by step.
fn iterations_section(r: &Report) -> String {
    let mut s = String::new();
    if !r.iterations.is_empty() {
        s += "## Iterative procedure (paper section 4)\n\n";
        s += &image(r, "iteration");
        for it in &r.iterations {
            s += &format!(
                "<!-- fold: {} step by step -->\n```\n{}\n```\n\n",
                it.method,
                iteration_summary(it).trim()
            );
        }
    }
    s
}

/// The integrator's bias on the estimates.
fn integrator_bias_section(b: &crate::report::IntegratorBias) -> String {
    let mut s = format!(
        "## Integrator bias\n\nRichardson's estimate: the same Brownian paths simulated at h = {:.3e} s and at h/2 \
         and identified alike; with weak order {} the bias at h is (estimate at h − at h/2) / (1 − 2^−{}).\n\n",
        b.step_s, b.order, b.order
    );
    s += &super::table::integrator_bias(b).markdown();
    let exceeding = b.exceeding();
    s += &if exceeding.is_empty() {
        "\nEvery bias is below a quarter of its standard error.\n\n".to_string()
    } else {
        format!(
            "\n**The integrator's bias exceeds a quarter of the standard error for {}**: reduce dt or raise \
             substeps.\n\n",
            exceeding.join(", ")
        )
    };
    s
}

/// The identified model re-simulated against the data.
fn validation_section(r: &Report, v: &Validation) -> String {
    let mut s = String::new();
    s += &format!(
        "## Validation\n\nThe {} model re-simulated ({} trajectories × {:.0} s, seed {}) against the data.\n\n",
        v.method, v.trajectories, v.record_length_s, v.seed
    );
    if !v.left_out.is_empty() {
        s += &format!("{}\n\n", v.left_out_note());
    }
    match &v.error {
        Some(e) => s += &format!("{e}\n\n"),
        None => {
            s += &super::table::validation(v).markdown();
            s += "\nThe difference of the stds with its standard error from the sampling of both (the spread \
                  between trajectory groups); the spectra are compared over the band that holds 99 % of the data's \
                  variance.\n\n";
        }
    }
    if let Some(verdict) = v.verdict() {
        let mut c = verdict.chars();
        let first = c
            .next()
            .map(|f| f.to_uppercase().collect::<String>())
            .unwrap_or_default();
        s += &format!("**{first}{}.**\n\n", c.as_str());
    }
    s += &image(r, "densities");
    s += &image(r, "response_spectra");
    s
}

/// Tool, scenario hash, log, timings and overrides.
fn provenance_section(r: &Report) -> String {
    let mut s = String::new();
    let p = &r.provenance;
    let time = if r.records.is_some() {
        format!("identify {:.2} s", r.timings_s.identify)
    } else {
        format!(
            "simulate {:.2} s, identify {:.2} s, total {:.2} s",
            r.timings_s.simulate, r.timings_s.identify, r.timings_s.total
        )
    };
    s += &format!(
        "## Provenance\n\n<!-- fold: tool, scenario hash, log and timings -->\n- {} {}{}\n- scenario SHA-256 `{}`\n- log `{}`\n- time: {time}\n",
        p.tool,
        p.version,
        p.commit.map_or(String::new(), |c| format!(", commit `{c}`")),
        p.scenario_sha256,
        r.log,
    );
    if !p.overrides.is_empty() {
        s += &format!("- overrides: `--set {}`\n", p.overrides.join("` `--set "));
    }
    s
}
