//! What every pass over the samples is made of: an [`Accumulator`] takes the samples one
//! at a time and is finished when the pass is over. The weak form's moments, the noise
//! floor, the Fisher information, every estimator's pieces, the force spectra and the
//! validation's distributions are accumulators; `crate::pipeline::pass` runs a list of
//! them over a sample source (docs/architecture.md, "Stages and passes").
//!
//! A leaf module: it depends on nothing, so every layer can implement it.

/// One stationary sample as a pass hands it over.
#[derive(Debug, Clone, Copy)]
pub struct Sample<'r> {
    /// The trajectory (record) the sample belongs to.
    pub trajectory: u32,
    /// Its time after burn-in (s).
    pub t: f64,
    /// Its coarse jackknife batch (`StationaryData::batch_of`).
    pub batch: usize,
    /// The log's columns.
    pub row: &'r [f64],
}

/// A run of consecutive samples as a pass hands them over: each sample's record, time
/// and batch, and the rows one after another (`width` columns each).
#[derive(Debug, Clone, Copy)]
pub struct Samples<'r> {
    pub heads: &'r [(u32, f64, usize)],
    pub rows: &'r [f64],
    pub width: usize,
}

impl<'r> Samples<'r> {
    /// Samples in the run.
    pub fn len(&self) -> usize {
        self.heads.len()
    }
    pub fn is_empty(&self) -> bool {
        self.heads.is_empty()
    }
    /// Sample `k`.
    #[inline]
    pub fn get(&self, k: usize) -> Sample<'r> {
        let (trajectory, t, batch) = self.heads[k];
        Sample {
            trajectory,
            t,
            batch,
            row: &self.rows[k * self.width..(k + 1) * self.width],
        }
    }
}

/// A computation over the samples of one pass: `push` for every sample, in the source's
/// order (a trajectory's samples in time order), then `finish` once. A pass hands the
/// samples over in runs ([`Accumulator::push_all`]): one call per run, each accumulator's
/// own loop over it. `Send`: the pass
/// driver runs the accumulators of one pass on threads of their own, each over every
/// sample in order.
///
/// What an accumulator needs of a sample is the [`Sample`]: its record, time, batch and
/// columns. What it needs of an earlier pass (the first pass's means and spreads for a
/// grid, the fitted filters for a lattice of fluxes) it takes in its constructor, so it
/// cannot be built before the pass that gives them: that is what orders the passes, and
/// an accumulator whose needs are met by the first pass runs in the first pass
/// (docs/architecture.md, "Stages and passes").
pub trait Accumulator: Send {
    /// One sample.
    fn push(&mut self, sample: &Sample);
    /// A run of samples, in order: by default each in turn; an accumulator that works
    /// column by column takes the run whole.
    fn push_all(&mut self, samples: &Samples) {
        for k in 0..samples.len() {
            self.push(&samples.get(k));
        }
    }
    /// The pass is over: flush what is buffered.
    fn finish(&mut self) {}
    /// Whether `push` does anything with a sample: a pass none of whose accumulators
    /// reads the samples does not read them (`crate::pipeline::pass::run`), and a
    /// simulation whose later passes would read nothing keeps no samples for them.
    fn reads_samples(&self) -> bool {
        true
    }
}

impl<A: Accumulator + ?Sized> Accumulator for Box<A> {
    fn push(&mut self, sample: &Sample) {
        (**self).push(sample)
    }
    fn push_all(&mut self, samples: &Samples) {
        (**self).push_all(samples)
    }
    fn finish(&mut self) {
        (**self).finish()
    }
    fn reads_samples(&self) -> bool {
        (**self).reads_samples()
    }
}

impl<A: Accumulator> Accumulator for Option<A> {
    fn push(&mut self, sample: &Sample) {
        if let Some(a) = self {
            a.push(sample)
        }
    }
    fn push_all(&mut self, samples: &Samples) {
        if let Some(a) = self {
            a.push_all(samples)
        }
    }
    fn finish(&mut self) {
        if let Some(a) = self {
            a.finish()
        }
    }
    fn reads_samples(&self) -> bool {
        self.as_ref().is_some_and(|a| a.reads_samples())
    }
}

impl<A: Accumulator> Accumulator for Vec<A> {
    fn push(&mut self, sample: &Sample) {
        for a in self.iter_mut() {
            a.push(sample)
        }
    }
    fn push_all(&mut self, samples: &Samples) {
        for a in self.iter_mut() {
            a.push_all(samples)
        }
    }
    fn finish(&mut self) {
        for a in self.iter_mut() {
            a.finish()
        }
    }
    fn reads_samples(&self) -> bool {
        self.iter().any(|a| a.reads_samples())
    }
}

/// `dst.copy_from_slice(src)` for the few values of one sample: up to eight are copied as
/// an array of known length (moves the compiler inlines), not by a call to `memcpy` per
/// sample, which cost more than the copy.
#[inline(always)]
pub fn copy_row(dst: &mut [f64], src: &[f64]) {
    #[inline(always)]
    fn fixed<const N: usize>(dst: &mut [f64], src: &[f64]) {
        let d: &mut [f64; N] = dst.try_into().expect("rows of one length");
        let s: &[f64; N] = src.try_into().expect("rows of one length");
        *d = *s;
    }
    match src.len() {
        1 => fixed::<1>(dst, src),
        2 => fixed::<2>(dst, src),
        3 => fixed::<3>(dst, src),
        4 => fixed::<4>(dst, src),
        5 => fixed::<5>(dst, src),
        6 => fixed::<6>(dst, src),
        7 => fixed::<7>(dst, src),
        8 => fixed::<8>(dst, src),
        _ => dst.copy_from_slice(src),
    }
}

/// `v.extend_from_slice(row)` by [`copy_row`].
#[inline(always)]
pub fn append_row(v: &mut Vec<f64>, row: &[f64]) {
    let at = v.len();
    v.resize(at + row.len(), 0.0);
    copy_row(&mut v[at..], row);
}

/// A closure as an accumulator: what feeds another accumulator a row of its own (a
/// subset of the columns, a derived force), or a sum too small for a type of its own.
pub struct Each<F>(pub F);

impl<F: FnMut(&Sample) + Send> Accumulator for Each<F> {
    fn push(&mut self, sample: &Sample) {
        (self.0)(sample)
    }
}
