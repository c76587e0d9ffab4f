//! Identification: from stationary samples back to spring and damper characteristics.
//!
//! The numerics of three parts (docs/theory.md §2, §5); `crate::estimators` wires each
//! method's accumulators and estimate from them:
//! - the **term library** ([`Problem`]): which coefficients, masses and intensities are
//!   unknown, the drift split into a known part and unknown features, human-readable names;
//! - the **accumulators and residuals** that turn data into the pieces of a residual that
//!   is linear in the coefficients — the weak form ([`weak`], from raw moments), the strong
//!   form ([`strong_kernel`] from kernel estimates of the density and its fluxes, [`strong_histogram`] from
//!   the paper's histogram), the baselines ([`baseline`]);
//! - **least squares with diagnostics** ([`lsq`]) and Gauss–Newton for unknown masses and
//!   intensities, with identifiability measured, never assumed.
//!
//! White-noise state: `y = (x_1, v_1, …, x_n, v_n)` (the paper's ordering). For every
//! test function or grid cell `k` the stationary FPK / generator identity reads
//!
//! `r_k = t0_k + Σ_i μ_i (a_ki + Σ_r θ_r b_kir) + ½ Σ_ij Q_ij c_kij = 0`,
//!
//! with `μ_i = 1/m_i`, `Q_ij = Σ_e σ_e² [i,j ∈ e] μ_i μ_j` (velocity noise covariance) and
//! `θ` the unknown coefficients. Depends on `model`, `scenario` and `stats` (histogram
//! bins) only: no file formats, no pipeline.

mod bilinear;
mod estimate;
mod problem;
mod spec;
mod symmetry;

pub mod accumulate;
pub mod baseline;
pub mod data;
pub mod disturbance;
pub mod fisher;
pub mod local_linear;
pub mod lsq;
pub mod measured_force;
pub mod moments;
pub mod noise;
pub mod poly;
pub mod rational;
pub mod select;
pub mod spectrum;
pub mod strong_histogram;
pub mod strong_kernel;
pub mod weak;

use crate::model::UnknownName;
pub use bilinear::identify_weak_bilinear;
pub use estimate::{
    estimate, identify_kernel, identify_strong, identify_weak, identify_weak_with_levels, jackknife, Estimate,
    INSEPARABLE_RATIO, SPREAD_CHECK_RATIO, WEAK_RATIO,
};
pub use problem::{y, Atom, Filter, Layout, Pieces, Problem, Unknown};
pub use spec::Specification;
pub use symmetry::{exact_symmetry, Symmetry};

/// Errors of identification.
#[derive(Debug, Clone, thiserror::Error)]
pub enum IdentError {
    /// The requested unknowns cannot be separated by the method's equations on these data
    /// (for the FPK methods: by the stationary density).
    #[error(
        "the unknowns cannot be separated by the method's equations on these data: {} move together \
         along the direction [{}] (singular values {}; smallest/largest = {:.2e}, rank {} of {}; {}). \
         No estimates are given. Declare some of them known, or measure what separates them \
         (docs/theory.md §6: for the density methods the excitation intensity and the masses \
         must be known)",
        .names.iter().map(ToString::to_string).collect::<Vec<_>>().join(", "),
        .direction.iter().map(|(n, d)| format!("{n}: {d:+.3}")).collect::<Vec<_>>().join(", "),
        .singular_values.iter().map(|s| format!("{s:.3e}")).collect::<Vec<_>>().join(" "),
        .sv_ratio, .rank, .cols, .reason
    )]
    NotIdentifiable {
        names: Vec<UnknownName>,
        direction: Vec<(UnknownName, f64)>,
        singular_values: Vec<f64>,
        sv_ratio: f64,
        rank: usize,
        cols: usize,
        /// What decided it: numerical rank or the spread over data batches.
        reason: String,
    },
    /// The model's stationary density is exactly unchanged along a direction of the
    /// unknowns, whatever the data ([`exact_symmetry`], docs/theory.md §6).
    #[error(
        "the unknowns cannot be separated by the stationary density of this model, whatever \
         the data: it is exactly unchanged along {} (relative changes, d ln value) because {}. \
         No estimates are given. Declare some of them known (docs/theory.md §6)",
        .directions.iter().map(|d| format!("[{}]", d.iter().map(|(n, x)| format!("{n}: {x:+.3}")).collect::<Vec<_>>().join(", "))).collect::<Vec<_>>().join(" and "),
        .why
    )]
    Symmetric {
        /// Per null direction: the unknowns it moves and by how much.
        directions: Vec<Vec<(UnknownName, f64)>>,
        why: String,
    },
    #[error("too little data: {0}")]
    TooLittleData(String),
    #[error("{0}")]
    NonFinite(String),
    /// Unknowns no data can separate (see `Scenario::check_separable`).
    #[error("the unknowns cannot be separated: {0}")]
    Inseparable(String),
    #[error("the scenario has no unknowns to identify (see [identify] in the scenario)")]
    NothingToIdentify,
    #[error("{0}")]
    Unsupported(String),
    /// The method does not apply to this problem (e.g. a density grid in too many
    /// dimensions): reported as not applicable, never as a failed gate.
    #[error("not applicable: {0}")]
    NotApplicable(String),
    /// The measured force's spectrum rejects the force model the problem needs (its
    /// first-order filter (3.20) misses the spectrum far beyond what averaging allows):
    /// identifying with it would contradict the data (docs/methods.md, "Checks").
    #[error("the force model is rejected by the data: {0}")]
    ForceModelRejected(String),
}

/// Ask for the cache line holding `x` (no effect where there is no prefetch instruction):
/// streaming estimators whose tables exceed the caches ask a few samples ahead.
#[inline(always)]
pub(crate) fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is a hint that never faults; SSE is part of x86_64.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>((x as *const T).cast());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}

/// Ask the kernel to back `v` with huge pages (Linux, transparent huge pages in `madvise`
/// mode): the streaming estimators' tables (the kernel lattice and its groups, the
/// Kramers–Moyal cells, the histogram's batches) are hit at random, and with 4 KiB pages
/// nearly every hit also misses the TLB. Call before the memory is first written (a fresh
/// zeroed allocation is not yet touched); no effect elsewhere or for small tables.
pub(crate) fn huge_pages<T>(v: &[T]) {
    #[cfg(target_os = "linux")]
    {
        const PAGE: usize = 2 << 20;
        let start = v.as_ptr() as usize;
        let (from, to) = (
            start.next_multiple_of(PAGE),
            (start + std::mem::size_of_val(v)) / PAGE * PAGE,
        );
        if to > from {
            // SAFETY: advice on whole pages inside `v`'s own allocation; it changes how the
            // pages are backed, never their contents.
            unsafe {
                libc::madvise(from as *mut libc::c_void, to - from, libc::MADV_HUGEPAGE);
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = v;
}

/// Large tables kept between uses. A study's items allocate the same tables again and
/// again, and where the operating system hands freed memory back (as virtual machines
/// with free-page reporting do) every fresh page costs a fault and a zeroing: a tenth of
/// an item's time as measured in docs/performance.md. Tables given back here are handed
/// out again, zeroed in place; at most [`Spare::BYTES`] are kept per kind.
#[derive(Default)]
pub struct Spare<T> {
    pool: std::sync::Mutex<Vec<Vec<T>>>,
}

/// The large tables identifications keep for the next ones ([`Spare`]), one pool per kind:
/// owned by whoever runs many identifications (a study hands every item the same) and
/// passed to the accumulators that take tables from them; a single run has its own.
#[derive(Debug, Default)]
pub struct Arenas {
    /// The kernel strong form's lattices of fluxes and its filters' scratch.
    pub lattices: Spare<f64>,
    /// The kernel strong form's jackknife groups' lattices.
    pub groups: Spare<f32>,
    /// The Kramers–Moyal baseline's cell arenas.
    pub cells: Spare<f64>,
    /// The samples a simulation in memory keeps for its later passes.
    pub samples: Spare<f64>,
}

impl<T> std::fmt::Debug for Spare<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let pool = self.pool.lock().unwrap_or_else(|e| e.into_inner());
        write!(f, "Spare({} tables kept)", pool.len())
    }
}

impl<T: Copy + Default> Spare<T> {
    /// Bytes kept at most per kind of table.
    pub const BYTES: usize = 640 << 20;

    pub const fn new() -> Spare<T> {
        Spare {
            pool: std::sync::Mutex::new(Vec::new()),
        }
    }

    /// An empty table with room for `capacity` values: a kept one if one is large enough
    /// (the smallest), else a new one on huge pages.
    pub fn empty(&self, capacity: usize) -> Vec<T> {
        let found = {
            let mut pool = self.pool.lock().unwrap_or_else(|e| e.into_inner());
            let best = (0..pool.len())
                .filter(|&i| pool[i].capacity() >= capacity)
                .min_by_key(|&i| pool[i].capacity());
            best.map(|i| pool.swap_remove(i))
        };
        match found {
            Some(mut v) => {
                v.clear();
                v
            }
            None => {
                let mut v = Vec::with_capacity(capacity);
                huge_pages(v.spare_capacity_mut());
                v
            }
        }
    }

    /// How many tables are kept.
    pub fn tables(&self) -> usize {
        self.pool.lock().unwrap_or_else(|e| e.into_inner()).len()
    }

    /// `len` zeros, in a table from [`Spare::empty`].
    pub fn zeroed(&self, len: usize) -> Vec<T> {
        let mut v = self.empty(len);
        v.resize(len, T::default());
        v
    }

    /// Keep `v` for a later [`Spare::zeroed`] (dropped if the kind's budget is full or it
    /// holds nothing).
    pub fn give(&self, v: Vec<T>) {
        if v.capacity() == 0 {
            return;
        }
        let bytes = |v: &Vec<T>| v.capacity() * std::mem::size_of::<T>();
        let mut pool = self.pool.lock().unwrap_or_else(|e| e.into_inner());
        if pool.iter().map(bytes).sum::<usize>() + bytes(&v) <= Self::BYTES {
            pool.push(v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Spare;

    #[test]
    fn spare_tables_come_back_zeroed_and_the_budget_holds() {
        let spare: Spare<f64> = Spare::new();
        let mut a = spare.zeroed(1000);
        a.iter_mut().for_each(|x| *x = 1.5);
        let at = a.as_ptr();
        spare.give(a);
        // A smaller table reuses the kept one, zeroed; a larger one is new.
        let b = spare.zeroed(600);
        assert_eq!((b.as_ptr(), b.len()), (at, 600));
        assert!(b.iter().all(|&x| x.to_bits() == 0));
        let c = spare.zeroed(2000);
        assert_ne!(c.as_ptr(), at);
        spare.give(b);
        spare.give(c);
        // The smallest that fits is handed out first.
        let d = spare.zeroed(900);
        assert_eq!(d.as_ptr(), at);
        // Beyond the budget nothing is kept.
        spare.give(Vec::with_capacity(Spare::<f64>::BYTES / 8 + 1));
        assert!(spare
            .pool
            .lock()
            .unwrap()
            .iter()
            .all(|v| v.capacity() < Spare::<f64>::BYTES / 8));
    }
}
