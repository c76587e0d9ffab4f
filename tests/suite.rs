//! The integration tests, as one test binary: each file of `tests/` is a module here (one
//! link instead of one per file, and one pool of test threads over all of them, so a file
//! with a few long tests no longer leaves a core idle). Run one file's tests with its
//! module's name as the filter: `cargo test --release --test suite checks::`.

mod common;

mod accuracy_regression;
mod augmented;
mod baselines;
mod checks;
mod cli_identify;
mod cli_output;
mod data;
mod disturbance;
mod doc_maps;
mod figures;
mod fuzz;
mod heun;
mod hysteresis;
mod identification;
mod integrator_bias;
mod layering;
mod log;
mod log_damage;
mod log_layouts;
mod measured_force;
mod measurement;
mod outcomes;
mod periodic;
mod scenario_errors;
mod selection;
mod simulation;
mod spectrum;
mod study;
mod terms;
