//! fpkbench: a stochastic simulator and identification test bench for nonlinear random
//! vibration, after B. Stępiński (1980): spring and damper characteristics of a randomly
//! excited multi-mass system identified from the stationary density of its response via
//! the Fokker–Planck–Kolmogorov equation.
//!
//! Dependencies point one way: `io` → `sim` → `model` → `scenario`; the numerics never
//! import file formats or the CLI (which lives in the binary).

pub mod bench;
pub mod ident;
pub mod io;
pub mod model;
pub mod report;
pub mod scenario;
pub mod sim;
pub mod stats;
pub mod zoo;

pub use model::Model;
pub use scenario::Scenario;
