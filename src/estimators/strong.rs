//! The strong form: the paper's FPK residual (3.8) point by point, least squares
//! (3.13)–(3.15). By default from kernel estimates of the density and of its probability
//! fluxes on a lattice (`ident::strong_kernel`); with [`StrongDensity::Histogram`] from the
//! paper's histogram and central differences (`ident::strong_histogram`).

use super::{refused, Context, Estimator, Setup, StrongDensity};
use crate::ident::accumulate::{Accumulator, Sample};
use crate::ident::strong_histogram::{self, DensityGrid};
use crate::ident::strong_kernel::FluxLattice;
use crate::ident::{self, Estimate, IdentError, Problem};

pub(super) fn build(setup: &Setup) -> Box<dyn Estimator> {
    match setup.settings.density {
        StrongDensity::Kernel => Box::new(KernelStrong {
            // Without filtered forces the problem is known now, and the lattice fills in
            // the second pass; with them, once the filters are fitted.
            lattice: setup.whitened.is_none().then(|| lattice(setup, setup.structure)),
        }),
        StrongDensity::Histogram => match grid(setup, true) {
            Ok(g) => Box::new(HistogramStrong {
                grid: g,
                marginals: false,
            }),
            Err(e) => refused(e),
        },
    }
}

/// The kernel lattice over `problem`'s state.
fn lattice(setup: &Setup, problem: &Problem) -> Result<FluxLattice, IdentError> {
    let options = setup.settings.kernel(problem.density_dim(), setup.total.count);
    let (mean, std) = setup.mean_std(problem.density_dim());
    FluxLattice::new(problem, &mean, &std, options, setup.data.batch_count(), setup.arenas)
}

/// The histogram grid over the structure's state: the settings' where given, else
/// automatic from the sample count, and not applicable when even the coarsest automatic
/// grid would be too sparse. `joint`: count the joint histogram, not only the marginals.
pub(super) fn grid(setup: &Setup, joint: bool) -> Result<DensityGrid, IdentError> {
    let (dim, count) = (setup.structure.density_dim(), setup.total.count);
    if !setup.settings.grid.is_set() {
        strong_histogram::applicable(dim, count).map_err(IdentError::NotApplicable)?;
    }
    let g = DensityGrid::new(setup.structure, setup.total, setup.settings.grid.resolve(dim, count))?;
    Ok(if joint { g } else { g.marginals_only() }.with_batches(setup.data.batch_count()))
}

fn bilinear_refused() -> IdentError {
    IdentError::Unsupported(
        "an unknown corner B makes the drift bilinear; the strong form here solves linear problems only".into(),
    )
}

struct KernelStrong {
    /// `None` until the filters are fitted (filtered forces only).
    lattice: Option<Result<FluxLattice, IdentError>>,
}

impl Accumulator for KernelStrong {
    fn push(&mut self, s: &Sample) {
        let Sample { batch, row, .. } = *s;
        if let Some(Ok(l)) = self.lattice.as_mut() {
            l.push_in(batch, row);
        }
    }

    fn finish(&mut self) {
        if let Some(Ok(l)) = self.lattice.as_mut() {
            l.finish();
        }
    }
}

impl Estimator for KernelStrong {
    fn needs_pass(&mut self, problem: &Problem, setup: &Setup) -> bool {
        if self.lattice.is_some() {
            return false;
        }
        let l = lattice(setup, problem);
        let ok = l.is_ok();
        self.lattice = Some(l);
        ok
    }

    fn estimate(&self, cx: &Context) -> Result<Estimate, IdentError> {
        if cx.bilinear {
            return Err(bilinear_refused());
        }
        match &self.lattice {
            Some(Ok(l)) => ident::identify_kernel(cx.problem, l, cx.typical),
            Some(Err(e)) => Err(e.clone()),
            None => unreachable!("the lattice is made by the end of the passes"),
        }
    }
}

/// The histogram forms: the paper's strong form as written, or (`marginals`) the product
/// of the marginal densities (3.21).
pub(super) struct HistogramStrong {
    pub(super) grid: DensityGrid,
    pub(super) marginals: bool,
}

impl Accumulator for HistogramStrong {
    fn push(&mut self, s: &Sample) {
        let Sample { batch, row, .. } = *s;
        self.grid.push_in(batch, row);
    }

    fn finish(&mut self) {
        self.grid.finish();
    }
}

impl Estimator for HistogramStrong {
    fn estimate(&self, cx: &Context) -> Result<Estimate, IdentError> {
        if cx.bilinear {
            return Err(bilinear_refused());
        }
        ident::identify_strong(cx.problem, &self.grid, self.marginals, cx.typical)
    }
}
