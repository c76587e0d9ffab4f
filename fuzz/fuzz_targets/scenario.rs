//! The scenario parser on arbitrary text; every scenario it accepts is shortened,
//! simulated and identified (the pipeline a user's valid scenario goes through).
#![no_main]

use fpkbench::pipeline::{identify_log, simulate_log, Options};
use fpkbench::Scenario;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(src) = std::str::from_utf8(data) else { return };
    let Ok(mut s) = Scenario::parse(src, "fuzz.toml", "fuzz") else {
        return;
    };
    let sim = &mut s.simulation;
    sim.trajectories = 1;
    sim.record_length = sim.record_length.min(100.0 * sim.sample_interval);
    sim.burn_in = sim.burn_in.min(2.0);
    if sim.check().is_err() || sim.total_steps() > 2e6 {
        return;
    }
    let log = std::env::temp_dir().join(format!("fpkbench-fuzz-scenario-{}.mcap", std::process::id()));
    if simulate_log(&s, &log, Default::default(), &|_| {}).is_ok() {
        let options = Options {
            validate: false,
            ..Options::default()
        };
        if let Ok(report) = identify_log(&log, &options) {
            let out = std::env::temp_dir().join(format!("fpkbench-fuzz-scenario-{}", std::process::id()));
            fpkbench::report::write_all(&report, &out).unwrap();
        }
    }
    let _ = std::fs::remove_file(&log);
});
