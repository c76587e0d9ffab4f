//! The log reader on arbitrary bytes: `read_info`, then every sample.
#![no_main]

use fpkbench::io::log::{read_info, read_samples};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let path = std::env::temp_dir().join(format!("fpkbench-fuzz-log-{}.mcap", std::process::id()));
    std::fs::write(&path, data).unwrap();
    if let Ok(info) = read_info(&path) {
        let _ = read_samples(&info, |_, _, _| {});
    }
});
