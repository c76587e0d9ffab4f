//! The strong form with the joint density replaced by the product of its marginals, as
//! the paper's experiment had to (3.21): only the marginal histograms are counted.

use super::strong::{grid, HistogramStrong};
use super::{refused, Estimator, Setup};

pub(super) fn build(setup: &Setup) -> Box<dyn Estimator> {
    match grid(setup, false) {
        Ok(g) => Box::new(HistogramStrong {
            grid: g,
            marginals: true,
        }),
        Err(e) => refused(e),
    }
}
