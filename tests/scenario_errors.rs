//! Bad scenarios, run through the real binary: each gives a message naming the file, line,
//! column and key, exits 2, and writes nothing.

use std::process::Command;

const GOOD: &str = r#"name = "t"
[[mass]]
name = "m1"
value = 1.0

[[mass]]
name = "m2"
value = 2.0

[[link]]
ends = ["ground", "m1"]
stiffness = { 1 = 10.0, 3 = 20.0 }
damping = { 1 = 0.5 }

[[link]]
ends = ["m1", "m2"]
stiffness = { 1 = 5.0 }

[[excitation]]
kind = "white"
sigma = 1.0
acts_on = ["m1"]

[simulation]
dt = 1e-3
record_length = 1.0
sample_interval = 0.1
trajectories = 2
"#;

/// Replace `from` (which must occur) with `to` in the good scenario.
fn bad(from: &str, to: &str) -> String {
    assert!(GOOD.contains(from), "test setup: {from:?} not in the scenario");
    GOOD.replacen(from, to, 1)
}

fn run_bad(name: &str, text: &str, line: usize, key: &str, allowed: &str) {
    run_bad_beside(name, text, &[], line, key, allowed);
}

/// [`run_bad`] with `files` (name, text) written beside the scenario.
fn run_bad_beside(name: &str, text: &str, files: &[(&str, &str)], line: usize, key: &str, allowed: &str) {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join(format!("{name}.toml"));
    std::fs::write(&file, text).unwrap();
    for (f, t) in files {
        std::fs::write(dir.path().join(f), t).unwrap();
    }
    let out_file = dir.path().join("out").join("run.mcap");
    let out = Command::new(env!("CARGO_BIN_EXE_fpkbench"))
        .args(["simulate", file.to_str().unwrap(), "-o", out_file.to_str().unwrap()])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{name}: exit code; stderr: {stderr}");
    let located = format!("{}:{line}:", file.display());
    assert!(
        stderr.contains(&located),
        "{name}: expected location {located} in: {stderr}"
    );
    assert!(stderr.contains(key), "{name}: expected key {key:?} in: {stderr}");
    assert!(stderr.contains(allowed), "{name}: expected {allowed:?} in: {stderr}");
    let leftovers = std::fs::read_dir(dir.path().join("out"))
        .map(|d| d.count())
        .unwrap_or(0);
    assert!(!out_file.exists() && leftovers == 0, "{name}: output written");
    assert!(out.stdout.is_empty(), "{name}: stdout not empty");
}

#[test]
fn unknown_key_is_rejected_with_the_allowed_keys() {
    run_bad(
        "unknown_key",
        &bad("trajectories = 2", "trajectories = 2\nthreads = 4"),
        29,
        "threads",
        "expected one of",
    );
}

#[test]
fn negative_mass() {
    run_bad(
        "negative_mass",
        &bad("value = 2.0", "value = -2.0"),
        8,
        "mass[1].value",
        "> 0",
    );
}

/// Only an unknown mass of a model file may leave its value out (docs/data.md, "A rig in
/// volts"); a simulation's mass needs one.
#[test]
fn mass_without_value() {
    run_bad(
        "mass_without_value",
        &bad("value = 2.0\n", ""),
        7,
        "mass[1].value",
        "only an unknown mass of a model file",
    );
}

#[test]
fn duplicate_mass_name() {
    run_bad(
        "duplicate_mass",
        &bad("name = \"m2\"", "name = \"m1\""),
        7,
        "mass[1].name",
        "duplicate",
    );
}

#[test]
fn link_to_unknown_mass() {
    run_bad(
        "unknown_mass",
        &bad("ends = [\"m1\", \"m2\"]", "ends = [\"m1\", \"m3\"]"),
        16,
        "link[1].ends",
        "allowed are `ground`, m1, m2",
    );
}

#[test]
fn link_with_equal_ends() {
    run_bad(
        "equal_ends",
        &bad("ends = [\"m1\", \"m2\"]", "ends = [\"m2\", \"m2\"]"),
        16,
        "link[1].ends",
        "must differ",
    );
}

#[test]
fn non_positive_dt() {
    run_bad("zero_dt", &bad("dt = 1e-3", "dt = 0.0"), 25, "simulation.dt", "> 0");
}

#[test]
fn sample_interval_not_a_multiple_of_dt() {
    run_bad(
        "interval",
        &bad("sample_interval = 0.1", "sample_interval = 0.10005"),
        27,
        "simulation.sample_interval",
        "whole multiple of dt",
    );
}

#[test]
fn non_finite_coefficient() {
    run_bad(
        "nan_coef",
        &bad("{ 1 = 10.0, 3 = 20.0 }", "{ 1 = 10.0, 3 = nan }"),
        12,
        "link[0].stiffness.3",
        "finite",
    );
}

#[test]
fn power_that_is_not_a_positive_integer() {
    run_bad(
        "bad_power",
        &bad("damping = { 1 = 0.5 }", "damping = { 0 = 0.5 }"),
        13,
        "link[0].damping.0",
        "whole numbers 1..=15",
    );
}

#[test]
fn excitation_on_unknown_mass() {
    run_bad(
        "exc_target",
        &bad("acts_on = [\"m1\"]", "acts_on = [\"m9\"]"),
        22,
        "excitation[0].acts_on",
        "allowed are m1, m2",
    );
}

#[test]
fn white_noise_without_sigma() {
    run_bad(
        "no_sigma",
        &bad("sigma = 1.0\n", ""),
        20,
        "excitation[0].sigma",
        "needs `sigma`",
    );
}

#[test]
fn filtered_noise_given_sigma() {
    run_bad(
        "filtered_sigma",
        &bad("kind = \"white\"", "kind = \"filtered\""),
        21,
        "excitation[0].sigma",
        "`A` and `B`",
    );
}

#[test]
fn unknown_scheme_lists_the_schemes() {
    run_bad(
        "scheme",
        &bad("trajectories = 2", "trajectories = 2\nscheme = \"rk4\""),
        29,
        "simulation.scheme",
        "semi-implicit",
    );
}

#[test]
fn zero_trajectories() {
    run_bad(
        "zero_traj",
        &bad("trajectories = 2", "trajectories = 0"),
        28,
        "simulation.trajectories",
        "1..=",
    );
}

#[test]
fn wrong_type() {
    run_bad(
        "wrong_type",
        &bad("record_length = 1.0", "record_length = \"long\""),
        26,
        "simulation.record_length",
        "expected f64",
    );
}

#[test]
fn syntax_error() {
    run_bad("syntax", &bad("value = 1.0", "value = 1.0 ]"), 4, "mass.value", "");
}

#[test]
fn identify_names_an_unknown_link() {
    let text = format!("{GOOD}\n[identify]\nmethods = [\"weak\"]\nlinks.ground-m7 = {{ stiffness = [1, 3] }}\n");
    run_bad(
        "identify_link",
        &text,
        32,
        "identify.links.ground-m7",
        "links are ground-m1, m1-m2",
    );
}

#[test]
fn unknown_method_lists_the_methods() {
    let text = format!("{GOOD}\n[identify]\nmethods = [\"neural\"]\n");
    run_bad("method", &text, 31, "identify.methods", "weak");
}

#[test]
fn missing_file_is_an_error_not_a_panic() {
    let out = Command::new(env!("CARGO_BIN_EXE_fpkbench"))
        .args(["simulate", "/nonexistent/x.toml"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/x.toml"));
}

#[test]
fn disturbance_procedure_needs_the_papers_structure() {
    let text = format!(
        "{}\n[identify.disturbance]\nmax_steps = 5\n",
        bad(
            "stiffness = { 1 = 5.0 }",
            "stiffness = { 1 = 5.0 }\ndamping = { 1 = 0.1 }"
        )
    );
    run_bad(
        "disturbance_structure",
        &text,
        31,
        "identify.disturbance",
        "link \"m1-m2\" has a damper; the iterative procedure (paper section 4) is defined for its two-mass structure",
    );
}

#[test]
fn disturbance_tolerance_must_be_positive() {
    let text = format!("{GOOD}\n[identify.disturbance]\ntolerance = -1.0\n");
    run_bad(
        "disturbance_tolerance",
        &text,
        31,
        "identify.disturbance.tolerance",
        "> 0",
    );
}

#[test]
fn iterated_force_gate_needs_the_disturbance_procedure() {
    // `iterated-force` is a report method only with [identify.disturbance].
    let text = format!("{GOOD}\n[accept]\nmethods = {{ iterated-force = 0.05 }}\n");
    run_bad(
        "iterated_force_gate",
        &text,
        31,
        "accept.methods.iterated-force",
        "the gated methods are weak, strong, weak-measured-force\n",
    );
}

#[test]
fn empty_method_list() {
    run_bad(
        "no_methods",
        &format!("{GOOD}\n[identify]\nmethods = []\n"),
        31,
        "identify.methods",
        "name at least one method",
    );
}

#[test]
fn a_power_written_twice() {
    run_bad(
        "power_twice",
        &bad(
            "stiffness = { 1 = 10.0, 3 = 20.0 }",
            "stiffness = { 1 = 10.0, 3 = 20.0, \"01\" = 3.0 }",
        ),
        12,
        "link[0].stiffness",
        "power 1 is given twice",
    );
}

#[test]
fn parallel_links_with_the_same_unknowns_before_any_simulation() {
    let parallel = bad(
        "[[excitation]]",
        "[[link]]\nends = [\"m1\", \"ground\"]\nstiffness = { 1 = 4.0 }\n\n[[excitation]]",
    );
    run_bad(
        "parallel",
        &format!(
            "{parallel}\n[identify.links.ground-m1]\nstiffness = [1]\n[identify.links.m1-ground]\nstiffness = [1, 3]\n"
        ),
        36,
        "identify.links.m1-ground",
        "only their sum acts",
    );
    // With the default unknowns (every coefficient) such a system can still be simulated,
    // but `run` refuses it before simulating.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("parallel.toml");
    std::fs::write(&file, &parallel).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_fpkbench"))
        .current_dir(dir.path())
        .args(["run", file.to_str().unwrap()])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr.contains("only their sum acts") && stderr.contains("parallel.toml"),
        "{stderr}"
    );
    assert!(!dir.path().join("out").exists(), "nothing simulated");
}

#[test]
fn a_single_table_where_a_list_of_tables_belongs() {
    run_bad(
        "single_table",
        "name = \"t\"\n[mass]\nname = \"m1\"\nvalue = 1.0\n",
        2,
        "`mass`",
        "write [[mass]]",
    );
}

#[test]
fn a_run_longer_than_the_budget_says_how_to_shorten() {
    run_bad(
        "long_burn_in",
        &bad("trajectories = 2", "trajectories = 2\nburn_in = 1e15"),
        29,
        "simulation.burn_in",
        "shorten burn_in",
    );
    // The default burn-in (10 decay times) of a nearly undamped system.
    run_bad(
        "default_burn_in",
        &bad("damping = { 1 = 0.5 }", "damping = { 1 = 1e-9 }"),
        26,
        "simulation.burn_in",
        "set simulation.burn_in",
    );
    run_bad(
        "huge_mass",
        &bad("value = 1.0", "value = 1e308"),
        26,
        "simulation.burn_in",
        "got inf",
    );
}

#[test]
fn a_file_that_is_not_utf8_is_located() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("latin1.toml");
    let mut bytes = GOOD.as_bytes().to_vec();
    let at = GOOD.find("m2").unwrap();
    bytes[at] = 0xe9;
    std::fs::write(&file, bytes).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_fpkbench"))
        .args(["simulate", file.to_str().unwrap()])
        .current_dir(dir.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr.contains(&format!("{}:7:9:", file.display())) && stderr.contains("not UTF-8"),
        "{stderr}"
    );
}

#[test]
fn a_system_without_a_stationary_density_is_refused_naming_the_link() {
    // An even highest power: the potential of the m1–m2 spring is unbounded below.
    run_bad(
        "even_power",
        &bad("stiffness = { 1 = 5.0 }", "stiffness = { 1 = 6.0, 2 = 3.0 }"),
        17,
        "link[1].stiffness",
        "highest power 2 is even",
    );
    // A softening cubic: the potential 5u² − 5u⁴ is unbounded below.
    run_bad(
        "softening",
        &bad(
            "stiffness = { 1 = 10.0, 3 = 20.0 }",
            "stiffness = { 1 = 10.0, 3 = -20.0 }",
        ),
        12,
        "link[0].stiffness",
        "negative coefficient",
    );
    // Negative damping at large speeds pumps energy in.
    run_bad(
        "negative_damping",
        &bad("damping = { 1 = 0.5 }", "damping = { 1 = 0.5, 3 = -0.1 }"),
        13,
        "link[0].damping",
        "energy is pumped in",
    );
    run_bad(
        "no_damper",
        &bad("damping = { 1 = 0.5 }\n", ""),
        11,
        "link",
        "no link has a damping",
    );
    run_bad(
        "no_spring_path",
        &bad("stiffness = { 1 = 5.0 }", "damping = { 1 = 0.2 }"),
        7,
        "mass[1]",
        "no spring path to ground",
    );
    // In a loop of springs: m2 held by a linear spring to ground as well, so moving m2
    // alone stretches the even m1–m2 spring and only a lower-degree one: still escapes.
    let looped = bad("stiffness = { 1 = 5.0 }", "stiffness = { 1 = 6.0, 2 = 3.0 }")
        + "\n[[link]]\nends = [\"ground\", \"m2\"]\nstiffness = { 1 = 8.0 }\n";
    run_bad(
        "even_power_in_a_loop",
        &looped,
        17,
        "link[1].stiffness",
        "highest power 2 is even",
    );
}

#[test]
fn an_even_power_bounded_by_higher_degree_springs_in_its_loop_is_accepted() {
    // Every motion that stretches the m1–m2 spring (6u + 3u²: a cubic potential) also
    // stretches a ground spring with a cubic force (a quartic potential): bounded below.
    let text = bad("stiffness = { 1 = 5.0 }", "stiffness = { 1 = 6.0, 2 = 3.0 }")
        + "\n[[link]]\nends = [\"ground\", \"m2\"]\nstiffness = { 1 = 8.0, 3 = 10.0 }\n";
    fpkbench::Scenario::parse(&text, "t.toml", "t").unwrap();
}

#[test]
fn sensor_noise_level_out_of_range() {
    run_bad(
        "negative_noise",
        &format!("{GOOD}[measurement]\ndisplacement = -0.1\n"),
        30,
        "measurement.displacement",
        "0..=10 (0.1 = 10 %)",
    );
    run_bad(
        "accelerometer_noise",
        &format!("{GOOD}[measurement]\nacceleration = 12.0\n"),
        30,
        "measurement.acceleration",
        "0..=10 (0.1 = 10 %)",
    );
    run_bad(
        "noise_scale",
        &format!("{GOOD}[measurement]\nnoise = \"percent\"\nvelocity = 0.1\n"),
        30,
        "measurement.noise",
        "relative",
    );
}

/// The sensors' filters: a corner beyond the sampling rate, an order out of range or
/// without its filter, a bandwidth the simulation cannot resolve, and steps too coarse
/// to carry the filters at all.
#[test]
fn sensor_filters_out_of_range() {
    run_bad(
        "anti_alias_corner",
        &format!("{GOOD}[measurement]\nanti_alias = 1.5\n"),
        30,
        "measurement.anti_alias",
        "0 < corner <= 1",
    );
    run_bad(
        "anti_alias_order",
        &format!("{GOOD}[measurement]\nanti_alias = 0.4\nanti_alias_order = 12\n"),
        31,
        "measurement.anti_alias_order",
        "1..=8",
    );
    run_bad(
        "order_alone",
        &format!("{GOOD}[measurement]\nanti_alias_order = 2\n"),
        30,
        "measurement.anti_alias_order",
        "anti_alias = 0.4",
    );
    run_bad(
        "bandwidth_unresolved",
        &format!("{GOOD}[measurement]\nbandwidth = 500.0\n"),
        30,
        "measurement.bandwidth",
        "leave `bandwidth` out",
    );
    let coarse = GOOD.replace("dt = 1e-3", "dt = 0.05");
    assert_ne!(coarse, GOOD);
    run_bad(
        "too_few_steps",
        &format!("{coarse}[measurement]\nanti_alias = 0.4\n"),
        30,
        "measurement.anti_alias",
        "dt at most sample_interval / 8",
    );
}

/// ADC ranges the identification cannot read are refused before anything runs: one that
/// clips nearly everything, a step that rounds nearly everything to zero, an absolute
/// range whose values leave the floating-point range when raised to powers.
#[test]
fn adc_ranges_the_identification_cannot_read_are_refused() {
    run_bad(
        "adc_clips_all",
        &format!("{GOOD}[measurement]\ndisplacement = 0.01\nadc_bits = 16\nadc_range = 1e-300\n"),
        32,
        "measurement.adc_range",
        "±1e-300 of the channel's standard deviation clips most of its samples",
    );
    run_bad(
        "adc_step_too_coarse",
        &format!("{GOOD}[measurement]\ndisplacement = 0.01\nadc_bits = 2\nadc_range = 5.0\n"),
        32,
        "measurement.adc_range",
        "rounds most samples to zero",
    );
    run_bad(
        "adc_absolute_tiny",
        &format!("{GOOD}[measurement]\nnoise = \"absolute\"\ndisplacement = 0.01\nadc_bits = 16\nadc_range = 1e-40\n"),
        33,
        "measurement.adc_range",
        "units of order 1",
    );
}

#[test]
fn given_sensor_noise_needs_a_measurement_section() {
    run_bad(
        "given_noise",
        &format!("{GOOD}[identify]\nsensor_noise = \"given\"\n"),
        30,
        "identify.sensor_noise",
        "add [measurement]",
    );
}

/// `[measurement] sensors`: a mass that does not exist, a sensor that is none, a mass with
/// neither a displacement nor an acceleration sensor, a mass left out, a force cell where no
/// force acts, and a noise level for a quantity no sensor gives.
#[test]
fn a_rigs_sensors_that_make_no_sense() {
    let both = r#"m1 = ["acceleration"], m2 = ["acceleration"]"#;
    for (name, sensors, key, allowed) in [
        (
            "unknown_mass",
            r#"m3 = ["acceleration"]"#,
            "measurement.sensors.m3",
            "the masses: m1, m2",
        ),
        (
            "no_sensor",
            r#"m1 = ["strain"], m2 = ["acceleration"]"#,
            "measurement.sensors.m1",
            "one of displacement, velocity, acceleration, force",
        ),
        (
            "velocity_alone",
            r#"m1 = ["velocity"], m2 = ["acceleration"]"#,
            "measurement.sensors.m1",
            "a displacement or an acceleration sensor",
        ),
        (
            "mass_left_out",
            r#"m1 = ["acceleration"]"#,
            "measurement.sensors",
            "`m2` has no sensors",
        ),
        (
            "cell_without_force",
            r#"m1 = ["acceleration"], m2 = ["acceleration", "force"]"#,
            "measurement.sensors.m2",
            "no excitation acts on `m2`",
        ),
    ] {
        run_bad(
            name,
            &format!("{GOOD}[measurement]\nsensors = {{ {sensors} }}\n"),
            30,
            key,
            allowed,
        );
    }
    run_bad(
        "level_without_sensor",
        &format!("{GOOD}[measurement]\ndisplacement = 0.1\nsensors = {{ {both} }}\n"),
        30,
        "measurement.displacement",
        "no sensor gives",
    );
}

/// The lab excitations (docs/excitations.md): another kind's key, a missing key, a band
/// the sampling cannot hold, a multisine's amplitude shape out of order and a measured
/// white force beside a lab signal are each refused where they are written.
#[test]
fn lab_excitations_refuse_what_their_kind_does_not_take() {
    run_bad(
        "multisine_sigma",
        &bad(
            "kind = \"white\"",
            "kind = \"multisine\"\nrms = 1.0\nband = [0.0, 2.0]\nperiod = 10.0",
        ),
        24,
        "excitation[0].sigma",
        "takes rms, band, period, lines, amplitude",
    );
    run_bad(
        "multisine_amplitude_falling_frequency",
        &bad(
            "kind = \"white\"\nsigma = 1.0",
            "kind = \"multisine\"\nrms = 1.0\nband = [0.0, 2.0]\nperiod = 10.0\namplitude = [[1.0, 1.0], [0.5, 2.0]]",
        ),
        24,
        "excitation[0].amplitude",
        "point 2: frequency 0.5 Hz: the frequencies are finite, non-negative and rising",
    );
    run_bad(
        "amplitude_on_white",
        &bad("sigma = 1.0", "sigma = 1.0\namplitude = [[1.0, 1.0]]"),
        22,
        "excitation[0].amplitude",
        "belongs to the lab kind(s) multisine",
    );
    run_bad(
        "band_limited_order",
        &bad(
            "kind = \"white\"\nsigma = 1.0",
            "kind = \"band-limited\"\nsigma = 1.0\nband = [0.0, 2.0]",
        ),
        20,
        "excitation[0].order",
        "Butterworth",
    );
    run_bad(
        "multisine_beyond_nyquist",
        &bad(
            "kind = \"white\"\nsigma = 1.0",
            "kind = \"multisine\"\nrms = 1.0\nband = [0.0, 6.0]\nperiod = 10.0",
        ),
        22,
        "excitation[0].band",
        "Nyquist frequency 5 Hz",
    );
    run_bad(
        "multisine_period",
        &bad(
            "kind = \"white\"\nsigma = 1.0",
            "kind = \"multisine\"\nrms = 1.0\nband = [0.0, 2.0]\nperiod = 10.05",
        ),
        23,
        "excitation[0].period",
        "whole number (at least 2) of sample intervals",
    );
    run_bad(
        "measured_white_beside_lab",
        &bad(
            "acts_on = [\"m1\"]",
            "acts_on = [\"m1\"]\n\n[[excitation]]\nkind = \"kanai-tajimi\"\nsigma = 1.0\nomega_g = 15.0\nzeta_g = 0.6\nacts_on = [\"m2\"]",
        ),
        20,
        "excitation[0].kind",
        "declare it measured = false (a disturbance)",
    );
}

/// A recorded signal (`kind = "recorded"`): its table is read with the scenario, and what
/// cannot drive the run is refused at its `file` key — a missing column (with the table's
/// columns), a recording shorter than the trajectories' stretches, one sampled finer than
/// the run, an uneven time column, no table; `time` and `sample_interval` together at
/// `time`; its keys on white noise where they are written.
#[test]
fn a_recorded_signal_that_cannot_drive_the_run_is_refused_at_its_file() {
    let table = |rows: usize, h: f64| -> String {
        let mut s = String::from("t,u\n");
        for k in 0..rows {
            s += &format!("{},{}\n", k as f64 * h, (k as f64 * 0.3).sin());
        }
        s
    };
    let good = table(100, 0.1);
    let recorded = |extra: &str| {
        bad(
            "kind = \"white\"\nsigma = 1.0",
            &format!("kind = \"recorded\"\nfile = \"u.csv\"\ncolumn = \"u\"\n{extra}"),
        )
        .replace("trajectories = 2", "trajectories = 2\nburn_in = 0.5")
    };
    let with_time = recorded("time = \"t\"");
    run_bad_beside(
        "recorded_column",
        &with_time.replace("column = \"u\"", "column = \"v\""),
        &[("u.csv", &good)],
        21,
        "excitation[0].file",
        "has no column \"v\" (the signal); it has t, u",
    );
    run_bad_beside(
        "recorded_short",
        &with_time,
        &[("u.csv", &table(25, 0.1))],
        21,
        "excitation[0].file",
        "2 trajectory stretch(es) of 1.5 s (burn-in and record) need 3 s",
    );
    run_bad_beside(
        "recorded_fine",
        &recorded("sample_interval = 0.05"),
        &[("u.csv", &good)],
        21,
        "excitation[0].file",
        "coarser than the recording's 0.05 s",
    );
    let mut uneven = good.clone();
    uneven = uneven.replacen("\n0.2,", "\n0.23,", 1);
    run_bad_beside(
        "recorded_uneven",
        &with_time,
        &[("u.csv", &uneven)],
        21,
        "excitation[0].file",
        "sampled evenly",
    );
    run_bad_beside("recorded_missing", &with_time, &[], 21, "excitation[0].file", "u.csv");
    run_bad_beside(
        "recorded_time_and_interval",
        &recorded("time = \"t\"\nsample_interval = 0.1"),
        &[("u.csv", &good)],
        23,
        "excitation[0].time",
        "not both",
    );
    run_bad(
        "file_on_white",
        &bad("sigma = 1.0", "sigma = 1.0\nfile = \"u.csv\""),
        22,
        "excitation[0].file",
        "belongs to the lab kind(s) recorded",
    );
}

#[test]
fn an_alternative_model_with_no_terms_is_refused_where_it_is_written() {
    // Before: validated, simulated, then "the scenario has no unknowns" (issue 70).
    let text = format!("{GOOD}\n[identify.compare.alt]\nlinks = {{}}\n");
    let line = text.lines().position(|l| l == "[identify.compare.alt]").unwrap() + 1;
    run_bad(
        "compare_without_terms",
        &text,
        line,
        "identify.compare.alt.links",
        "identifies no term",
    );
}

#[test]
fn a_profile_without_its_range_is_named_at_the_profile() {
    // Before: "`identify`: missing field `range`", at the [identify] table (issue 70).
    let shipped = std::fs::read_to_string("scenarios/clearance2dof.toml").unwrap();
    assert!(shipped.contains("range = [0.075, 0.225]\n"));
    let text = shipped.replace("range = [0.075, 0.225]\n", "");
    let line = text.lines().position(|l| l == "[identify.profile]").unwrap() + 1;
    run_bad(
        "profile_without_range",
        &text,
        line,
        "identify.profile.range",
        "missing: give the positions to try",
    );
}

/// A force's model is chosen from its spectrum or given another way, not both.
#[test]
fn a_force_whose_model_is_chosen_and_also_read_as_white() {
    run_bad(
        "chosen_and_white",
        &format!("{GOOD}[identify]\nequivalent_white = [\"m1\"]\nchoose_force_model = [\"m1\"]\n"),
        31,
        "identify.choose_force_model",
        "is also in identify.equivalent_white",
    );
}
