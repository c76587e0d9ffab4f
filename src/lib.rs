//! fpkbench: a stochastic simulator and identification test bench for nonlinear random
//! vibration, after B. Stępiński (1980): spring and damper characteristics of a randomly
//! excited multi-mass system identified from the stationary density of its response via
//! the Fokker–Planck–Kolmogorov equation.
//!
//! Dependencies point one way, in the layers of `docs/architecture.md` ("Layers", kept by
//! `tests/layering.rs`); the numerics never import file formats, plotting or the CLI
//! (which lives in the binary). `docs/architecture.md` lists every module and the stages
//! of an identification; the mathematics, with the function implementing each equation,
//! is in `docs/theory.md`.
//!
//! Identify a linear oscillator from its simulated stationary response with the weak form:
//!
//! ```
//! use fpkbench::ident::{data::StationaryData, identify_weak, weak, Problem};
//! use fpkbench::sim::{simulate, Collect};
//! use fpkbench::{zoo, Model};
//!
//! let s = zoo::linear_sdof(1.0, 10.0, 2.0, 1.0,
//!     "dt = 1e-3\nrecord_length = 2000.0\nsample_interval = 0.1\ntrajectories = 8");
//! let mut samples = Collect::default();
//! simulate(&Model::new(&s), &s.simulation, &mut samples, &|_| {}).unwrap();
//!
//! let problem = Problem::new(&s).unwrap(); // k1 and c1 unknown
//! let mut data = StationaryData::new(&problem, weak::moment_degree(&problem), 2000.0, s.simulation.trajectories, 8);
//! for b in &samples.batches {
//!     b.for_each_sample(|trajectory, t, values| data.push(trajectory, t, values));
//! }
//! data.finish();
//! let estimate = identify_weak(&problem, &data).unwrap();
//! assert_eq!(estimate.names, ["k1[ground-m1]", "c1[ground-m1]"]);
//! assert!((estimate.values[0] - 10.0).abs() < 0.5 && (estimate.values[1] - 2.0).abs() < 0.2);
//! ```

// Numeric kernels index several same-length arrays by one index on purpose.
#![allow(clippy::needless_range_loop)]

pub mod estimators;
pub mod ident;
pub mod interrupt;
pub mod io;
pub mod method;
pub mod model;
pub mod pipeline;
pub mod report;
#[warn(missing_docs)]
pub mod scenario;
pub mod sim;
pub mod stats;
pub mod zoo;

pub use model::Model;
pub use scenario::Scenario;
