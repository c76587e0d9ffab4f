//! Where samples go: the batch of one block of sampling instants, the [`SampleSink`] trait
//! the MCAP writer implements, and small in-memory sinks for tests and examples.

/// Samples of every trajectory at consecutive sampling instants (one block of a run).
///
/// Per instant the values are column-major, as the log's messages carry them: for each
/// column (see [`crate::model::Columns`]) one value per trajectory, so trajectory `j`'s value of column `c`
/// at instant `k` is `values[(k * columns + c) * trajectories + j]`.
#[derive(Debug, Clone, Default)]
pub struct SampleBatch {
    /// Values per sample (see [`crate::model::Columns`]).
    pub columns: usize,
    /// Trajectories per instant (all of the run's, in order).
    pub trajectories: usize,
    /// Time after burn-in of each instant, s.
    pub time: Vec<f64>,
    /// `instants × columns × trajectories` values.
    pub values: Vec<f64>,
}

impl SampleBatch {
    /// Sampling instants in the batch.
    pub fn instants(&self) -> usize {
        self.time.len()
    }
    /// Samples in the batch (instants × trajectories).
    pub fn len(&self) -> usize {
        self.time.len() * self.trajectories
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Instant `k`'s values: `columns` runs of `trajectories` values.
    pub fn instant(&self, k: usize) -> &[f64] {
        let n = self.columns * self.trajectories;
        &self.values[k * n..(k + 1) * n]
    }
    /// Every sample as `f(trajectory, t, values)`, in (time, trajectory) order.
    pub fn for_each_sample(&self, mut f: impl FnMut(u32, f64, &[f64])) {
        let mut row = vec![0.0; self.columns];
        for (k, &t) in self.time.iter().enumerate() {
            let instant = self.instant(k);
            for j in 0..self.trajectories {
                for (c, r) in row.iter_mut().enumerate() {
                    *r = instant[c * self.trajectories + j];
                }
                f(j as u32, t, &row);
            }
        }
    }
}

/// Where samples go.
pub trait SampleSink {
    fn write(&mut self, batch: SampleBatch) -> Result<(), Box<dyn std::error::Error + Send + Sync>>;
    /// A batch the sink is done with, for the simulator to fill again instead of allocating
    /// (and first touching) a new one.
    fn recycle(&mut self) -> Option<SampleBatch> {
        None
    }
}

/// A sink that calls `f(trajectory, t, values)` for every sample, in order.
pub struct ForEach<F: FnMut(u32, f64, &[f64])>(pub F);

impl<F: FnMut(u32, f64, &[f64])> SampleSink for ForEach<F> {
    fn write(&mut self, batch: SampleBatch) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
        batch.for_each_sample(&mut self.0);
        Ok(())
    }
}

/// Drops the samples, handing each batch back to be refilled (as the log writer does): the
/// simulator's own cost, in benches.
#[derive(Default)]
pub struct Discard(Option<SampleBatch>);
impl SampleSink for Discard {
    fn write(&mut self, b: SampleBatch) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
        self.0 = Some(std::hint::black_box(b));
        Ok(())
    }
    fn recycle(&mut self) -> Option<SampleBatch> {
        self.0.take()
    }
}

/// A sink that keeps every sample in memory (tests and small runs).
#[derive(Debug, Default)]
pub struct Collect {
    pub batches: Vec<SampleBatch>,
}

impl SampleSink for Collect {
    fn write(&mut self, batch: SampleBatch) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
        self.batches.push(batch);
        Ok(())
    }
}

/// A sink that accumulates, per column, the sum and the matrix of cross products in
/// constant memory: means and covariances of the stationary response.
#[derive(Debug, Clone)]
pub struct Moments {
    pub count: u64,
    pub sum: Vec<f64>,
    /// Row-major `columns × columns`.
    pub cross: Vec<f64>,
}

impl Moments {
    pub fn new(columns: usize) -> Moments {
        Moments {
            count: 0,
            sum: vec![0.0; columns],
            cross: vec![0.0; columns * columns],
        }
    }
    pub fn mean(&self, i: usize) -> f64 {
        self.sum[i] / self.count as f64
    }
    pub fn covariance(&self, i: usize, j: usize) -> f64 {
        let n = self.sum.len();
        self.cross[i * n + j] / self.count as f64 - self.mean(i) * self.mean(j)
    }
}

impl SampleSink for Moments {
    fn write(&mut self, batch: SampleBatch) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
        let n = self.sum.len();
        batch.for_each_sample(|_, _, row| {
            for i in 0..n {
                self.sum[i] += row[i];
                for j in 0..n {
                    self.cross[i * n + j] += row[i] * row[j];
                }
            }
        });
        self.count += batch.len() as u64;
        Ok(())
    }
}
