//! Strong form from kernel estimates of the density *and of its probability fluxes*: the
//! default `strong` estimator (docs/methods.md, "The strong form's density").
//!
//! The paper's residual (3.8) in a point `y` is
//! `−Σ_j ∂(g_j f)/∂y_j + ½ Σ Q_im ∂²f/∂v_i∂v_m` with the drift's parts `g_j` (the free
//! drift `v` of each displacement, the known and the unit forces of each velocity). The
//! plain procedure (module [`super::strong_histogram`], `--density histogram`) estimates `f` by a
//! histogram and multiplies by `g_j` at the cell centre. Here every product `g_j f` is
//! estimated *itself*, by the same Gaussian kernel smoothing as `f`:
//!
//! `(g f)^(y) = (1/N) Σ_n G_s(y − Y_n) g(Y_n)`,
//!
//! and the derivatives are those of the kernel. Smoothing is a convolution, and a
//! convolution commutes with the derivatives of (3.8): the expected residual is
//! `G_s * (FPK residual of f) = 0` at the true coefficients, whatever the width `s`. The
//! width trades variance only, never bias — unlike smoothing the density and then
//! multiplying by the drift (which flattens a cubic spring) and unlike the histogram's
//! differences (a bias of order bin²). Equivalently, the residual in node `y_k` is the
//! stationary identity `E[L φ_k(Y)] = 0` of the generator `L` with the Gaussian bump
//! `φ_k = G_s(y_k − ·)` as test function.
//!
//! Computation, in constant memory over the samples: one streaming pass spreads each
//! sample's value of every flux (1, `g_j(Y)`) over the `2^d` nodes of its lattice cell with
//! linear weights (a convolution with a tent of one node spacing, the same for every flux,
//! hence no bias either; adding each sample to its nearest node instead, a box, measured
//! worse: `sdof_duffing` seeds 2 and 4 gave 2.7 % and 2.6 % against 1.7 % and 1.1 %); the
//! kernel's derivatives are then applied as separable filters on the lattice (samples are
//! gathered in a bounded buffer and spread in the order of their cells, for the caches;
//! each filter pass runs over whole lines of nodes). Nodes are
//! `h = min(s, 0.5 std)` apart: the sampled kernel's aliasing is then
//! `exp(−2π² s²/h²) ≈ 3·10⁻⁹` of the signal (times `(2π s/h)²` for the second
//! derivative), and the lattice resolves the density itself (nodes 1.25 std apart biased
//! `k3` of `sdof_duffing` by 19 %). Residual rows are the nodes within the box of
//! `span_std` whose kernel holds at least `min_count` effective samples; the lattice
//! reaches [`MARGIN`] std beyond the box, and a kernel that reaches further sees no
//! samples there (the report counts the samples outside the lattice).

use super::poly::{Compiled, Poly};
use super::{prefetch, Arenas, IdentError, Pieces, Problem};
use multiversion::multiversion;
use rayon::prelude::*;
use std::sync::Arc;

/// Settings of the kernel estimate; [`KernelOptions::auto`] gives the defaults.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct KernelOptions {
    /// Kernel width `s` in standard deviations of each state variable.
    pub smoothing: f64,
    /// Half-width of the box of residual nodes, in standard deviations around the mean.
    pub span_std: f64,
    /// Effective samples under a node's kernel, `N f̂(y_k) (2√π s)^d`, below which the node
    /// is not a residual row.
    pub min_count: f64,
}

/// Node spacing in kernel widths (see the module docs: aliasing `≈ 3·10⁻⁹`; at 1.25 the
/// sampled second derivative biased `c1` of the exact SDOF density by 5·10⁻³).
pub const SPACING: f64 = 1.0;

/// Largest node spacing in standard deviations: the lattice must also resolve the
/// density itself (the aliasing of the binned fluxes; measured on `sdof_duffing`, where
/// nodes 1.25 std apart biased `k3` by 19 %, docs/methods.md).
pub const MAX_SPACING: f64 = 0.5;

/// The lattice reaches this many standard deviations beyond the box of residual nodes
/// (or the kernel's cut, if nearer): a node's kernel may reach past the lattice, where a
/// stationary response holds almost no samples (the report counts those outside).
pub const MARGIN: f64 = 1.5;

/// The kernel is cut at this many widths (`exp(−12.5) ≈ 4·10⁻⁶` of its peak; at 4 widths
/// the exact SDOF density's `k3` was off by 10⁻³).
pub const CUT: f64 = 5.0;

/// Memory of the lattice's fluxes (one `f64` per node and flux) beyond which the estimate
/// is refused as not applicable.
pub const MAX_BYTES: usize = 256 << 20;

/// Memory for the jackknife groups' fluxes (`f32`), beyond which fewer groups are kept.
pub const GROUP_BUDGET: usize = 128 << 20;

/// Most jackknife groups: each costs a filtering of the lattice.
pub const MAX_GROUPS: usize = 16;

/// Nodes per parallel work item of the filters.
const CHUNK: usize = 4096;

/// Fewest jackknife groups worth keeping.
pub const MIN_GROUPS: usize = 8;

impl KernelOptions {
    /// The default: a width of `1.3 · (N/10⁵)^(−1/5)` standard deviations for `N` samples
    /// (measured: the best width on `sdof_duffing` and `sparse2dof` at 10⁵ samples, on
    /// `duffing2dof` at 3.2·10⁶; docs/methods.md), residual nodes within ±4.5 std in 2-D,
    /// ±3.5 in 3-D, ±3 beyond.
    pub fn auto(dim: usize, samples: u64) -> KernelOptions {
        let smoothing = 1.3 * (samples.max(1) as f64 / 1e5).powf(-0.2);
        KernelOptions {
            smoothing,
            span_std: match dim {
                0..=2 => 4.5,
                3 => 3.5,
                _ => 3.0,
            },
            min_count: 10.0,
        }
    }
}

/// Where each of the residual's pieces comes from: a flux channel (0 is the density) and
/// the sign it enters with. Parts equal up to sign share one channel: a link between two
/// masses gives them opposite unit forces, and a mass's free drift `v` is minus the unit
/// force of a linear damper to the ground on it (duffing2dof: 14 channels become 10). The
/// values are exact negations of each other, so sharing changes no result by a bit, and
/// saves the spreading and the lattices' memory of the duplicates.
#[derive(Debug, Clone)]
struct Channels {
    polys: Vec<Poly>,
    /// `(direction, channel, sign)` of each free-drift part.
    free: Vec<(usize, usize, f64)>,
    /// Per mass: the known force's channel and sign (`None`: zero).
    known: Vec<Option<(usize, f64)>>,
    /// Per mass and coefficient: the unit force's channel and sign (`None`: zero).
    unit: Vec<Vec<Option<(usize, f64)>>>,
}

impl Channels {
    fn new(problem: &Problem) -> Channels {
        let mut polys = vec![Poly::constant(1.0)];
        let mut add = |p: &Poly| {
            if p.terms.is_empty() {
                return None;
            }
            let negated = |q: &Poly| {
                q.terms.len() == p.terms.len()
                    && q.terms.iter().zip(&p.terms).all(|((a, x), (b, y))| a == b && *x == -*y)
            };
            for (c, q) in polys.iter().enumerate() {
                if q == p {
                    return Some((c, 1.0));
                }
                if negated(q) {
                    return Some((c, -1.0));
                }
            }
            polys.push(p.clone());
            Some((polys.len() - 1, 1.0))
        };
        let free = problem
            .free_drift
            .iter()
            .filter_map(|(j, g)| add(g).map(|(c, sign)| (*j, c, sign)))
            .collect();
        let known = problem.known_force.iter().map(&mut add).collect();
        let unit = (0..problem.n)
            .map(|i| problem.unit_force.iter().map(|u| add(&u[i])).collect())
            .collect();
        Channels {
            polys,
            free,
            known,
            unit,
        }
    }
    fn len(&self) -> usize {
        self.polys.len()
    }
}

/// Per jackknife group, its share of the fluxes.
#[derive(Debug, Clone)]
struct Groups {
    of_batch: Vec<usize>,
    fluxes: Vec<Vec<f32>>,
    total: Vec<u64>,
    arenas: Arc<Arenas>,
}

impl Drop for Groups {
    fn drop(&mut self) {
        for g in self.fluxes.drain(..) {
            self.arenas.groups.give(g);
        }
    }
}

/// The linearly binned fluxes of a record on a lattice over the state.
#[derive(Debug, Clone)]
pub struct FluxLattice {
    pub dim: usize,
    pub options: KernelOptions,
    /// Nodes per dimension.
    pub nodes: usize,
    /// First node, spacing and kernel width per dimension.
    pub lo: Vec<f64>,
    pub h: Vec<f64>,
    pub s: Vec<f64>,
    /// Kernel taps either side of the centre.
    taps: usize,
    /// Residual nodes lie within this many nodes of the centre in every dimension.
    row_half: usize,
    columns: Vec<usize>,
    stride: Vec<usize>,
    /// Nodes in all (`nodes^dim`).
    cells: usize,
    channels: Channels,
    /// Node-major: `fluxes[node · channels + channel]`. With jackknife groups, the sum of
    /// theirs (formed by [`FluxLattice::finish`]).
    fluxes: Vec<f64>,
    pub inside: u64,
    pub total: u64,
    groups: Option<Groups>,
    /// Every sample pushed is spread (and the groups summed): [`FluxLattice::finish`].
    finished: bool,
    /// Samples inside the lattice not yet spread: `(group · cells + first node of the cell)
    /// << 20 | entry` (the jackknife group is in the key) and per entry the state (`dim`
    /// values).
    pending_keys: Vec<u64>,
    pending_y: Vec<f64>,
    /// The fluxes but the density (channels `1..`), compiled.
    compiled: Compiled,
    /// Where the lattices come from and go back to.
    arenas: Arc<Arenas>,
    /// The terms without a polynomial form, valued from each sample's link motion and
    /// appended to its state before the fluxes are evaluated (`None` without any).
    atoms: Option<(crate::model::Model, Vec<super::Atom>)>,
}

/// Samples gathered before they are spread over the lattice in the order of their cells
/// (see [`FluxLattice::push_in`]): 23 MB for a 4-D state. At most `1 << ENTRY_BITS`.
const PENDING: usize = 1 << 19;

/// Bits of a pending sample's key that number it.
const ENTRY_BITS: u32 = 20;
const _: () = assert!(PENDING <= 1 << ENTRY_BITS);

/// Samples whose fluxes [`FluxLattice::spread`] evaluates together.
const SPREAD_RUN: usize = 64;

/// `to += k · from`, element by element (a filter's tap along a line of nodes; never
/// contracted into fused multiply–adds, so every CPU gives the same sums).
#[multiversion(targets(
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
    "x86_64+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
))]
fn add_scaled(to: &mut [f64], k: f64, from: &[f64]) {
    for (x, y) in to.iter_mut().zip(from) {
        *x += k * y;
    }
}

/// Where a sample's fluxes go: the record's lattice, or (when groups are kept) its
/// jackknife group's, whose sum is the record's.
enum Target<'a> {
    Record(&'a mut [f64]),
    Group(&'a mut [f32]),
}

impl Target<'_> {
    fn reborrow(&mut self) -> Target<'_> {
        match self {
            Target::Record(f) => Target::Record(f),
            Target::Group(g) => Target::Group(g),
        }
    }
}

/// The samples [`FluxLattice::push_in`] gathered, sorted by their keys, with what their
/// fluxes and cells are found from.
struct Gathered<'a> {
    keys: &'a [u64],
    /// Per entry the state, then the atoms' values (`vars` values).
    y: &'a [f64],
    vars: usize,
    /// Channels per node.
    width: usize,
    compiled: &'a Compiled,
    lo: &'a [f64],
    h: &'a [f64],
    stride: &'a [usize],
}

impl Gathered<'_> {
    /// The samples of `keys[range]` spread into `into` in that order: their fluxes
    /// evaluated a run at a time (variable-major states, then channel-major values:
    /// `Compiled::eval_block`), then each spread in turn.
    fn spread(&self, range: std::ops::Range<usize>, mut into: Target) {
        let (d, vars, width) = (self.lo.len(), self.vars, self.width);
        let keys = &self.keys[range];
        let mut ys = vec![0.0; vars * SPREAD_RUN];
        let mut block = vec![0.0; width * SPREAD_RUN];
        let mut values = vec![1.0; width];
        let mut corner = vec![(0, 0.0); d];
        let mut nodes = vec![(0, 0.0); 1 << d];
        // Its own copy: evaluation keeps scratch.
        let mut compiled = self.compiled.clone();
        // The states are gathered in the order of the cells, far from the order they came
        // in: the next run's are asked for while this one is spread.
        let entry_of = |key: u64| (key & ((1 << ENTRY_BITS) - 1)) as usize;
        for &key in keys.iter().take(SPREAD_RUN) {
            prefetch(&self.y[entry_of(key) * vars]);
        }
        for (r, run) in keys.chunks(SPREAD_RUN).enumerate() {
            let lanes = run.len();
            for &key in keys.iter().skip((r + 1) * SPREAD_RUN).take(SPREAD_RUN) {
                prefetch(&self.y[entry_of(key) * vars]);
            }
            for (l, &key) in run.iter().enumerate() {
                let entry = entry_of(key);
                for j in 0..vars {
                    ys[j * lanes + l] = self.y[entry * vars + j];
                }
            }
            compiled.eval_block(&ys[..vars * lanes], lanes, &mut block[lanes..width * lanes]);
            for l in 0..lanes {
                for j in 0..d {
                    let u = (ys[j * lanes + l] - self.lo[j]) / self.h[j];
                    let i = u as usize;
                    corner[j] = (i * self.stride[j], u - i as f64);
                }
                for (c, v) in values.iter_mut().enumerate().skip(1) {
                    *v = block[c * lanes + l];
                }
                spread_sample(&corner, self.stride, &values, &mut nodes, into.reborrow());
            }
        }
    }
}

/// One sample's fluxes `values` over the `2^d` nodes of its cell (`corner`: per dimension
/// the cell's flat offset and the position in it) with linear weights. `nodes` (`2^d`
/// long) is scratch for the nodes' offsets and weights, formed dimension by dimension: node
/// `mask` (bit `j` set: the upper node along `j`) gets the weight `Π_j (t_j or 1 − t_j)`,
/// multiplied in the order of the dimensions.
#[multiversion(targets(
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
    "x86_64+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
))]
fn spread_sample(corner: &[(usize, f64)], stride: &[usize], values: &[f64], nodes: &mut [(usize, f64)], into: Target) {
    let width = values.len();
    nodes[0] = (0, 1.0);
    for (j, &(base, t)) in corner.iter().enumerate() {
        let (lower, upper) = nodes[..2 << j].split_at_mut(1 << j);
        for (lo, up) in lower.iter_mut().zip(upper) {
            let (at, w) = *lo;
            *lo = (at + base, w * (1.0 - t));
            *up = (at + base + stride[j], w * t);
        }
    }
    match into {
        Target::Record(fluxes) => {
            for &(at, w) in &nodes[..1 << corner.len()] {
                for (c, v) in fluxes[at * width..(at + 1) * width].iter_mut().zip(values) {
                    *c += w * v;
                }
            }
        }
        Target::Group(g) => {
            for &(at, w) in &nodes[..1 << corner.len()] {
                for (c, v) in g[at * width..(at + 1) * width].iter_mut().zip(values) {
                    *c += (w * v) as f32;
                }
            }
        }
    }
}

/// The two lattices a separable filter passes between ([`FluxLattice::filter`]), kept
/// from one filter to the next.
struct Scratch<'a> {
    cur: Vec<f64>,
    next: Vec<f64>,
    arenas: &'a Arenas,
}

impl Scratch<'_> {
    /// For filters of `len` values at most.
    fn new(len: usize, arenas: &Arenas) -> Scratch<'_> {
        Scratch {
            cur: arenas.lattices.zeroed(len),
            next: arenas.lattices.zeroed(len),
            arenas,
        }
    }
}

impl Drop for Scratch<'_> {
    fn drop(&mut self) {
        self.arenas.lattices.give(std::mem::take(&mut self.cur));
        self.arenas.lattices.give(std::mem::take(&mut self.next));
    }
}

impl Drop for FluxLattice {
    fn drop(&mut self) {
        self.arenas.lattices.give(std::mem::take(&mut self.fluxes));
    }
}

impl FluxLattice {
    /// A lattice for `problem` over mean ± (span + [`MARGIN`]) std of each state variable
    /// (from the record's `mean` and `std`), keeping `batches` batches' shares in jackknife groups
    /// when they fit in [`GROUP_BUDGET`].
    pub fn new(
        problem: &Problem,
        mean: &[f64],
        std: &[f64],
        options: KernelOptions,
        batches: usize,
        arenas: &Arc<Arenas>,
    ) -> Result<FluxLattice, IdentError> {
        let d = problem.density_dim();
        let h_std = (options.smoothing * SPACING).min(MAX_SPACING);
        let taps = (CUT * options.smoothing / h_std).ceil() as usize;
        let half_width = (options.span_std + CUT * options.smoothing).min(options.span_std + MARGIN);
        let nodes = 2 * (half_width / h_std).ceil() as usize + 1;
        let row_half = ((options.span_std / h_std) + 1e-9).floor() as usize;
        let cells = (nodes as f64).powi(d as i32);
        let channels = Channels::new(problem);
        let bytes = cells * channels.len() as f64 * 8.0;
        if bytes > MAX_BYTES as f64 {
            return Err(IdentError::NotApplicable(format!(
                "a {d}-dimensional lattice of {nodes} nodes per dimension has {cells:.1e} nodes, {:.1e} bytes for its {} \
                 fluxes (limit {MAX_BYTES:.1e}): the strong form does not scale to this state; use the weak form",
                bytes,
                channels.len()
            )));
        }
        let cells = cells as usize;
        let half = (nodes / 2) as f64;
        let (mut lo, mut h, mut s) = (Vec::new(), Vec::new(), Vec::new());
        for j in 0..d {
            let sd = std[j].max(1e-300);
            h.push(h_std * sd);
            s.push(options.smoothing * sd);
            lo.push(mean[j] - half * h_std * sd);
        }
        let mut stride = vec![1; d];
        for j in 1..d {
            stride[j] = stride[j - 1] * nodes;
        }
        let width = channels.len();
        let per_group = cells * width * std::mem::size_of::<f32>();
        let count = (GROUP_BUDGET / per_group.max(1)).min(batches).min(MAX_GROUPS);
        let groups = (count >= MIN_GROUPS).then(|| Groups {
            of_batch: (0..batches).map(|b| b * count / batches).collect(),
            fluxes: (0..count).map(|_| arenas.groups.zeroed(cells * width)).collect(),
            total: vec![0; count],
            arenas: arenas.clone(),
        });
        let fluxes = arenas.lattices.zeroed(cells * width);
        Ok(FluxLattice {
            dim: d,
            options,
            nodes,
            lo,
            h,
            s,
            taps,
            row_half,
            columns: problem.columns.clone(),
            stride,
            cells,
            fluxes,
            inside: 0,
            total: 0,
            groups,
            finished: true,
            pending_keys: Vec::with_capacity(PENDING),
            pending_y: Vec::with_capacity(PENDING * (d + problem.atoms.len())),
            compiled: Compiled::new(&channels.polys[1..]),
            arenas: arenas.clone(),
            channels,
            atoms: (!problem.atoms.is_empty()).then(|| (problem.model.clone(), problem.atoms.clone())),
        })
    }

    /// A lattice holding the fluxes of an exact density `f` (reference tests): each node
    /// gets `g(y) f(y) h^d`, what the binned samples hold on average up to the tent's
    /// smoothing. No jackknife groups.
    pub fn from_density(
        problem: &Problem,
        mean: &[f64],
        std: &[f64],
        options: KernelOptions,
        f: impl Fn(&[f64]) -> f64,
    ) -> Result<FluxLattice, IdentError> {
        assert!(problem.atoms.is_empty(), "an exact density over the state has no atoms");
        let mut l = FluxLattice::new(problem, mean, std, options, 0, &Arc::default())?;
        let width = l.channels.len();
        let volume: f64 = l.h.iter().product();
        let mut y = vec![0.0; l.dim];
        for node in 0..l.fluxes.len() / width {
            let mut rest = node;
            for j in 0..l.dim {
                y[j] = l.lo[j] + (rest % l.nodes) as f64 * l.h[j];
                rest /= l.nodes;
            }
            let mass = f(&y) * volume;
            for (c, p) in l.channels.polys.iter().enumerate() {
                l.fluxes[node * width + c] = mass * p.eval(&y);
            }
        }
        // Effective samples under a kernel are relative to a large record.
        l.total = 1_000_000;
        l.inside = l.total;
        for x in &mut l.fluxes {
            *x *= l.total as f64;
        }
        Ok(l)
    }

    /// Add one sample of batch `batch` (`row`: the log's columns); [`FluxLattice::finish`]
    /// after the last.
    ///
    /// A sample's fluxes go to the `2^d` nodes of its cell, and consecutive samples of a
    /// record (many trajectories interleaved) land all over a lattice far larger than the
    /// caches, so spreading each at once waits on memory for every cell. Samples are
    /// gathered instead and spread `PENDING` at a time in the order of their cells: the
    /// lattice is then swept once per batch of samples, neighbours share cache lines.
    pub fn push_in(&mut self, batch: usize, row: &[f64]) {
        self.total += 1;
        self.finished = false;
        let group = self.groups.as_mut().map_or(0, |g| {
            let k = g.of_batch[batch];
            g.total[k] += 1;
            k
        });
        let mut first = 0;
        for j in 0..self.dim {
            let yj = row[self.columns[j]];
            let u = (yj - self.lo[j]) / self.h[j];
            if !(u >= 0.0 && u < (self.nodes - 1) as f64) {
                return;
            }
            first += u as usize * self.stride[j];
        }
        self.inside += 1;
        let entry = self.pending_keys.len();
        let slot = (group * self.cells + first) as u64;
        self.pending_keys.push(slot << ENTRY_BITS | entry as u64);
        self.pending_y.extend(self.columns.iter().map(|&c| row[c]));
        if let Some((model, atoms)) = &self.atoms {
            self.pending_y.extend(atoms.iter().map(|a| a.value(model, row)));
        }
        if entry + 1 == PENDING {
            self.spread();
        }
    }

    /// Spread the samples still gathered and, with jackknife groups, sum theirs into the
    /// record's; call after the last [`FluxLattice::push_in`].
    pub fn finish(&mut self) {
        self.finished = true;
        self.spread();
        if let Some(g) = &self.groups {
            self.fluxes.par_iter_mut().enumerate().for_each(|(i, f)| {
                *f = g.fluxes.iter().map(|k| k[i] as f64).sum();
            });
        }
    }

    /// Spread the gathered samples group by group in the order of their cells (ties in the
    /// order they came, so the sums do not depend on anything but the samples' order).
    /// With jackknife groups a sample goes into its group's lattice only (the record's is
    /// their sum): one group's lattice at a time is swept, small enough for the cache, and
    /// each sample is written once. The groups' lattices are disjoint, so the groups are
    /// spread in parallel, each in the same order as alone: the sums do not depend on the
    /// thread count.
    fn spread(&mut self) {
        let mut keys = std::mem::take(&mut self.pending_keys);
        // The keys are distinct (each holds its entry), so any sort gives the same order.
        keys.par_sort_unstable();
        let gathered = Gathered {
            keys: &keys,
            y: &self.pending_y,
            vars: self.dim + self.atoms.as_ref().map_or(0, |a| a.1.len()),
            width: self.channels.len(),
            compiled: &self.compiled,
            lo: &self.lo,
            h: &self.h,
            stride: &self.stride,
        };
        match self.groups.as_mut() {
            Some(g) => {
                let cells = self.cells;
                g.fluxes.par_iter_mut().enumerate().for_each(|(k, lattice)| {
                    let first = keys.partition_point(|&key| ((key >> ENTRY_BITS) as usize) < k * cells);
                    let end = keys.partition_point(|&key| ((key >> ENTRY_BITS) as usize) < (k + 1) * cells);
                    gathered.spread(first..end, Target::Group(lattice));
                });
            }
            None => gathered.spread(0..keys.len(), Target::Record(&mut self.fluxes)),
        }
        keys.clear();
        self.pending_keys = keys;
        self.pending_y.clear();
    }

    /// The sampled kernel `G_s`, its first and its second derivative along dimension `j`
    /// (taps `−taps..=taps`, node `m` at offset `m h`).
    fn kernels(&self, j: usize) -> [Vec<f64>; 3] {
        let (h, s) = (self.h[j], self.s[j]);
        let norm = 1.0 / ((2.0 * std::f64::consts::PI).sqrt() * s);
        let t = |m: isize| m as f64 * h;
        let g = |m: isize| norm * (-t(m) * t(m) / (2.0 * s * s)).exp();
        let r = -(self.taps as isize)..=self.taps as isize;
        [
            r.clone().map(g).collect(),
            r.clone().map(|m| -t(m) / (s * s) * g(m)).collect(),
            r.map(|m| (t(m) * t(m) / s.powi(4) - 1.0 / (s * s)) * g(m)).collect(),
        ]
    }

    /// Apply a separable filter (`order[j]`: 0 smooth, 1 first, 2 second derivative along
    /// dimension `j`) to the channels `which` of `fluxes`; the result holds `which.len()`
    /// values per node of `at` (in that order; nodes inside the box of residual nodes), or
    /// per node of the lattice without `at` (then valid inside that box only). The pass along dimension `j`
    /// works only where later passes read: nodes inside the box in dimensions `0..=j`.
    ///
    /// `scratch` holds the passes' two lattices between calls: a filter per direction and
    /// replicate would otherwise take (and the kernel zero) fresh pages for each. Its old
    /// contents are never read: every pass writes the nodes the next one reads.
    fn filter(
        &self,
        fluxes: &[f64],
        which: &[usize],
        order: &[usize],
        at: Option<&[usize]>,
        scratch: &mut Scratch,
    ) -> Vec<f64> {
        let width = self.channels.len();
        let w = which.len();
        let cells = fluxes.len() / width;
        let Scratch { cur, next, .. } = scratch;
        cur.clear();
        for node in 0..cells {
            cur.extend(which.iter().map(|&c| fluxes[node * width + c]));
        }
        next.resize(cells * w, 0.0);
        let taps = self.taps as isize;
        let nb = self.nodes as isize;
        let centre = self.nodes / 2;
        let (lo, hi) = (centre.saturating_sub(self.row_half), centre + self.row_half);
        for j in 0..self.dim {
            let kernel = &self.kernels(j)[order[j]];
            // Whole lines along dimension 0 at a time: for each tap, one scaled vector
            // added over the line's nodes inside the box (per node the taps in ascending
            // order, each source node on the lattice; the last pass too, then read at the
            // residual nodes, which lie in the box: reading them one by one, `taps` nodes a
            // stride apart each, waited on memory).
            let line = self.nodes * w;
            let st = self.stride[j] as isize;
            next.par_chunks_mut(line).enumerate().for_each(|(l, out)| {
                let first = l * self.nodes;
                if !(1..=j).all(|k| (lo..=hi).contains(&(first / self.stride[k] % self.nodes))) {
                    return;
                }
                let run = &mut out[lo * w..(hi + 1) * w];
                run.fill(0.0);
                let i = (first / self.stride[j] % self.nodes) as isize;
                for m in -taps..=taps {
                    let k = kernel[(m + taps) as usize];
                    // Nodes of the run whose source node `node − m·stride_j` is on the lattice.
                    let (a, b) = if j == 0 {
                        ((lo as isize).max(m), (hi as isize).min(nb - 1 + m))
                    } else if i - m >= 0 && i - m < nb {
                        (lo as isize, hi as isize)
                    } else {
                        continue;
                    };
                    if a > b {
                        continue;
                    }
                    let from = (first as isize + a - m * st) as usize * w;
                    let len = (b - a + 1) as usize * w;
                    let to = (a as usize - lo) * w;
                    add_scaled(&mut run[to..to + len], k, &cur[from..from + len]);
                }
            });
            std::mem::swap(cur, next);
        }
        match at {
            Some(at) => {
                let mut out = vec![0.0; at.len() * w];
                out.par_chunks_mut(CHUNK * w).enumerate().for_each(|(chunk, out)| {
                    for (local, o) in out.chunks_exact_mut(w).enumerate() {
                        let node = at[chunk * CHUNK + local];
                        o.copy_from_slice(&cur[node * w..(node + 1) * w]);
                    }
                });
                out
            }
            None => std::mem::take(cur),
        }
    }

    /// The residual rows: nodes within `span_std` of the mean whose kernel holds at least
    /// `min_count` effective samples.
    fn rows(&self, scratch: &mut Scratch) -> Vec<usize> {
        let density = self.filter(&self.fluxes, &[0], &vec![0; self.dim], None, scratch);
        let volume: f64 = self.s.iter().map(|s| 2.0 * std::f64::consts::PI.sqrt() * s).product();
        let scale = volume; // N f̂ (2√π s)^d with f̂ = density / N
        let centre = self.nodes / 2;
        let (lo, hi) = (centre.saturating_sub(self.row_half), centre + self.row_half);
        let rows = (0..density.len())
            .filter(|&node| {
                let mut rest = node;
                for _ in 0..self.dim {
                    let i = rest % self.nodes;
                    rest /= self.nodes;
                    if i < lo || i > hi {
                        return false;
                    }
                }
                density[node] * scale >= self.options.min_count
            })
            .collect();
        scratch.cur = density;
        rows
    }

    /// The residual's pieces at `rows` from `fluxes` (the whole record's, or a jackknife
    /// replicate's) holding `total` samples.
    fn pieces_of(
        &self,
        problem: &Problem,
        fluxes: &[f64],
        total: f64,
        rows: &[usize],
        scratch: &mut Scratch,
    ) -> Pieces {
        let (n, rc, d) = (problem.n, problem.coefficient_count(), self.dim);
        let ch = &self.channels;
        let mut pc = Pieces::new(rows.len(), n, rc);
        // Per direction, the first derivative of every flux that is differentiated along it.
        let mut dirs: Vec<(usize, Vec<usize>)> = Vec::new();
        let mut need = |j: usize, c: usize| match dirs.iter_mut().find(|(k, _)| *k == j) {
            Some((_, cs)) if !cs.contains(&c) => cs.push(c),
            Some(_) => {}
            None => dirs.push((j, vec![c])),
        };
        for &(j, c, _) in &ch.free {
            need(j, c);
        }
        for i in 0..n {
            let j = problem.noise_var[i];
            for (c, _) in ch.known[i].iter().chain(ch.unit[i].iter().flatten()) {
                need(j, *c);
            }
        }
        let scale = 1.0 / total;
        for (j, cs) in &dirs {
            let order: Vec<usize> = (0..d).map(|k| usize::from(k == *j)).collect();
            let out = self.filter(fluxes, cs, &order, Some(rows), scratch);
            let at = |row: usize, (c, sign): (usize, f64)| {
                let q = cs.iter().position(|&x| x == c).expect("requested");
                -(sign * out[row * cs.len() + q]) * scale
            };
            for row in 0..rows.len() {
                for &(jj, c, sign) in &ch.free {
                    if jj == *j {
                        pc.t0[row] += at(row, (c, sign));
                    }
                }
                for i in (0..n).filter(|&i| problem.noise_var[i] == *j) {
                    if let Some(c) = ch.known[i] {
                        pc.a[row * n + i] = at(row, c);
                    }
                    for r in 0..rc {
                        if let Some(c) = ch.unit[i][r] {
                            pc.b[(row * n + i) * rc + r] = at(row, c);
                        }
                    }
                }
            }
        }
        // Second derivatives of the density along the noisy velocities.
        let cross = problem.white.iter().any(|(t, _, _)| t.len() > 1);
        for i in 0..n {
            for m in 0..n {
                if m != i && !cross || m < i {
                    continue;
                }
                let (ji, jm) = (problem.noise_var[i], problem.noise_var[m]);
                let mut order = vec![0; d];
                order[ji] += 1;
                order[jm] += 1;
                let out = self.filter(fluxes, &[0], &order, Some(rows), scratch);
                for row in 0..rows.len() {
                    let v = out[row] * scale;
                    pc.c[(row * n + i) * n + m] = v;
                    pc.c[(row * n + m) * n + i] = v;
                }
            }
        }
        pc
    }

    /// The pieces of the whole record; `each` of every jackknife replicate's pieces (all but
    /// one group), in the groups' order; and the number of residual rows. The replicates
    /// are built and handed to `each` on as many threads as there are, each thread with one
    /// replicate's fluxes and pieces at a time: no replicate's pieces wait for the others
    /// (16 replicates of duffing2dof's lattice held together were 60 MB).
    pub fn pieces<R: Send>(&self, problem: &Problem, each: impl Fn(Pieces) -> R + Sync) -> (Pieces, Vec<R>, usize) {
        assert!(self.finished, "FluxLattice::finish was not called");
        let (rows, total) = {
            let mut scratch = Scratch::new(self.fluxes.len(), &self.arenas);
            let rows = self.rows(&mut scratch);
            let total = self.pieces_of(problem, &self.fluxes, self.inside.max(1) as f64, &rows, &mut scratch);
            (rows, total)
        };
        let replicates = match &self.groups {
            None => Vec::new(),
            Some(g) => {
                let kept: Vec<usize> = (0..g.total.len()).filter(|&k| g.total[k] > 0).collect();
                kept.par_iter()
                    .map_init(
                        || ReplicateBuffers {
                            scratch: Scratch::new(self.fluxes.len(), &self.arenas),
                            fluxes: self.arenas.lattices.zeroed(self.fluxes.len()),
                        },
                        |b, &k| {
                            b.fluxes.clear();
                            b.fluxes
                                .extend(self.fluxes.iter().zip(&g.fluxes[k]).map(|(a, b)| a - *b as f64));
                            let inside = self.inside as f64 * (1.0 - g.total[k] as f64 / self.total.max(1) as f64);
                            each(self.pieces_of(problem, &b.fluxes, inside.max(1.0), &rows, &mut b.scratch))
                        },
                    )
                    .collect()
            }
        };
        let count = rows.len();
        (total, replicates, count)
    }
}

/// One thread's buffers for the jackknife replicates: the filters' scratch and the
/// replicate's fluxes, given back to the arenas when the thread is done.
struct ReplicateBuffers<'a> {
    scratch: Scratch<'a>,
    fluxes: Vec<f64>,
}

impl Drop for ReplicateBuffers<'_> {
    fn drop(&mut self) {
        self.scratch.arenas.lattices.give(std::mem::take(&mut self.fluxes));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_equal_up_to_sign_share_a_channel_and_give_back_each_part_exactly() {
        let src = std::fs::read_to_string("scenarios/duffing2dof.toml").unwrap();
        let scenario = crate::Scenario::parse(&src, "duffing2dof.toml", "duffing2dof").unwrap();
        let problem = Problem::new(&scenario).unwrap();
        let ch = Channels::new(&problem);
        // The density, v1, v2, and the unit forces but the two of the link between the
        // masses on m2 (minus theirs on m1) and the linear dampers to the ground (−v).
        assert_eq!(ch.len(), 10);
        let signed = |(c, sign): (usize, f64)| {
            let mut p = Poly::zero();
            p.add(&ch.polys[c], sign);
            p
        };
        for (k, (j, g)) in problem.free_drift.iter().enumerate() {
            let (jj, c, sign) = ch.free[k];
            assert_eq!((jj, &signed((c, sign))), (*j, g));
        }
        let mut shared = 0;
        for i in 0..problem.n {
            for (r, unit) in problem.unit_force.iter().enumerate() {
                match ch.unit[i][r] {
                    None => assert!(unit[i].terms.is_empty()),
                    Some(at) => {
                        assert_eq!(signed(at), unit[i], "mass {i}, unknown {r}");
                        shared += usize::from(at.1 < 0.0);
                    }
                }
            }
        }
        assert_eq!(shared, 4, "two by the coupling link, two by the linear dampers");
    }
}
