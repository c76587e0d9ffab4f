//! Simulator throughput against the random-number bound, parallel scaling, and the cost
//! of logging. Run: `cargo bench --bench simulate` (add `-- --quick` for a cheap pass).
//!
//! After criterion's own figures, a summary prints the ratios the targets are stated in,
//! all measured in this one run:
//! - trajectory-steps/s per core ÷ (raw normal rate ÷ normals per step), target ≥ 0.8; the
//!   raw rate is the fastest of three patterns of one generator per lane: round-robin, in
//!   runs of one generator, and the lanes' generators side by side (the simulator's own);
//! - 2-thread ÷ 1-thread throughput, target ≥ 1.8, next to the same ratio for raw normal
//!   generation (what this machine's two cores give to perfectly parallel work);
//! - time with an MCAP log every 10th step ÷ time without logging, target ≤ 1.25, with the
//!   sampling's own share; next to it, what writing these samples costs at all (their bare
//!   payload bytes copied once and written by a writer thread, no MCAP, on disk and in
//!   RAM), a floor for any file of these bytes (the kernel taking them from a ready buffer,
//!   the simulation's time added), and the same with zstd chunks next to a floor for any
//!   zstd-compressed log: zstd alone on the samples' bare payload bytes;
//! - log bytes per sample.
//!
//! The machine is shared (a virtual machine's cores), so every ratio compares the fastest
//! of many interleaved repetitions of each side: contention only ever adds time.

use criterion::{Criterion, Throughput};
use fpkbench::io::log::{Compression, LogWriter};
use fpkbench::model::Model;
use fpkbench::sim::{simulate, Discard, LaneNormals, SampleBatch, SampleSink, LANES};
use fpkbench::Scenario;
use rand::rngs::Xoshiro256PlusPlus;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use std::hint::black_box;
use std::io::Write;
use std::path::Path;
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::time::Instant;

/// Keeps each instant's payload bytes (time and values, little-endian f64) as a log would
/// carry them, without any framing.
#[derive(Default)]
struct Payload(Vec<u8>);
impl SampleSink for Payload {
    fn write(&mut self, b: SampleBatch) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
        for k in 0..b.instants() {
            self.0.extend_from_slice(&b.time[k].to_le_bytes());
            for v in b.instant(k) {
                self.0.extend_from_slice(&v.to_le_bytes());
            }
        }
        Ok(())
    }
}

/// A reference for what any log of these samples costs in a file: each instant's bare
/// payload bytes (time and values, little-endian f64) copied once into a 1 MiB buffer on a
/// writer thread and written with plain `write`s to `<path>.partial`, renamed to `path` at
/// the end, as the log is — no framing, no index, no checksum. Batches go back to the
/// simulator.
struct BareFile {
    tx: Option<SyncSender<SampleBatch>>,
    spent: Receiver<SampleBatch>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl BareFile {
    fn create(path: &Path) -> BareFile {
        let (tx, rx) = sync_channel::<SampleBatch>(2);
        let (spent_tx, spent) = sync_channel::<SampleBatch>(2);
        let (tmp, dest) = (path.with_extension("partial"), path.to_path_buf());
        let thread = std::thread::spawn(move || {
            let mut file = std::fs::File::create(&tmp).unwrap();
            let mut buf: Vec<u8> = Vec::with_capacity(1 << 20);
            for b in rx {
                for k in 0..b.instants() {
                    buf.extend_from_slice(&b.time[k].to_le_bytes());
                    for v in b.instant(k) {
                        buf.extend_from_slice(&v.to_le_bytes());
                    }
                    if buf.len() >= (1 << 20) - 8 * b.instant(k).len() - 8 {
                        file.write_all(&buf).unwrap();
                        buf.clear();
                    }
                }
                let _ = spent_tx.try_send(b);
            }
            file.write_all(&buf).unwrap();
            drop(file);
            std::fs::rename(&tmp, &dest).unwrap();
        });
        BareFile {
            tx: Some(tx),
            spent,
            thread: Some(thread),
        }
    }
    fn finish(mut self) {
        drop(self.tx.take());
        self.thread.take().unwrap().join().unwrap();
    }
}

impl SampleSink for BareFile {
    fn write(&mut self, b: SampleBatch) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
        self.tx.as_ref().unwrap().send(b).unwrap();
        Ok(())
    }
    fn recycle(&mut self) -> Option<SampleBatch> {
        self.spent.try_recv().ok()
    }
}

/// Seconds zstd at `level` takes to compress `bytes` in 1 MiB pieces (the order of an MCAP
/// chunk), and the compressed size.
fn zstd_seconds(bytes: &[u8], level: i32) -> (f64, usize) {
    let mut out = 0;
    let t = fastest(
        3,
        &mut [&mut || {
            out = bytes
                .chunks(1 << 20)
                .map(|c| zstd::bulk::compress(c, level).unwrap().len())
                .sum();
        }],
    )[0];
    (t, out)
}

/// duffing2dof with `trajectories`, a record of `record` s, sampled every `every` steps,
/// by the semi-implicit scheme at 1 ms: one force evaluation and one normal per mass a
/// step, the rate the random-number bound is about (Heun's cost: `benches/schemes.rs`).
fn scenario(trajectories: usize, record: f64, every: usize) -> Scenario {
    let src = std::fs::read_to_string("scenarios/duffing2dof.toml").unwrap();
    let mut s = Scenario::parse(&src, "duffing2dof.toml", "duffing2dof").unwrap();
    s.simulation.scheme = fpkbench::scenario::Scheme::SemiImplicit;
    s.simulation.dt = 1e-3;
    s.simulation.trajectories = trajectories;
    s.simulation.record_length = record;
    s.simulation.burn_in = 0.0;
    s.simulation.sample_interval = every as f64 * s.simulation.dt;
    s
}

fn steps(s: &Scenario) -> u64 {
    let sim = &s.simulation;
    (sim.trajectories.div_ceil(LANES) * LANES * sim.samples_per_trajectory() * sim.steps_per_sample()) as u64
}

/// `n` normals from one generator per lane, drawn round-robin over the lanes (one normal
/// per generator in turn).
fn normals(n: usize) -> f64 {
    let mut rng: Vec<Xoshiro256PlusPlus> = (0..LANES as u64).map(Xoshiro256PlusPlus::seed_from_u64).collect();
    let mut acc = [0.0f64; LANES];
    for _ in 0..n / LANES {
        for (j, r) in rng.iter_mut().enumerate() {
            let z: f64 = StandardNormal.sample(r);
            acc[j] += z;
        }
    }
    black_box(acc).iter().sum()
}

/// `n` normals from one generator per lane, drawn in runs of 64 per generator into a
/// 16 KiB buffer (the simulator's pattern: the generator's state stays in registers).
fn normals_in_runs(n: usize) -> f64 {
    let mut rng: Vec<Xoshiro256PlusPlus> = (0..LANES as u64).map(Xoshiro256PlusPlus::seed_from_u64).collect();
    let mut buf = vec![0.0f64; 64 * LANES];
    let mut acc = 0.0;
    for _ in 0..n / buf.len() {
        for (j, r) in rng.iter_mut().enumerate() {
            for z in buf[j..].iter_mut().step_by(LANES) {
                *z = StandardNormal.sample(r);
            }
        }
        acc += black_box(&buf)[0];
    }
    acc
}

/// `n` normals from one generator per lane, the lanes' generators stepped side by side
/// (the simulator's own generator, `LaneNormals`), 64 per lane into a 16 KiB buffer.
fn normals_side_by_side(n: usize) -> f64 {
    let mut lanes = LaneNormals::new(0);
    let mut buf = vec![0.0f64; 64 * LANES];
    let mut acc = 0.0;
    for _ in 0..n / buf.len() {
        lanes.fill(&mut buf);
        acc += black_box(&buf)[0];
    }
    acc
}

fn run(s: &Scenario, threads: usize, sink: &mut (dyn SampleSink + Send)) {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    let m = Model::new(s);
    pool.install(|| simulate(&m, &s.simulation, sink, &|_| {})).unwrap();
}

fn seconds<F: FnMut()>(mut f: F) -> f64 {
    let t = Instant::now();
    f();
    t.elapsed().as_secs_f64()
}

/// The fastest of `reps` repetitions of each job, the jobs interleaved round by round.
fn fastest(reps: usize, jobs: &mut [&mut dyn FnMut()]) -> Vec<f64> {
    fastest_tidied(reps, jobs, &mut || {})
}

/// [`fastest`], with `tidy` run after every job, untimed (removing the files it wrote, so
/// no job pays for deleting or replacing an earlier job's file).
fn fastest_tidied(reps: usize, jobs: &mut [&mut dyn FnMut()], tidy: &mut dyn FnMut()) -> Vec<f64> {
    for job in jobs.iter_mut() {
        job();
        tidy();
    }
    let mut best = vec![f64::INFINITY; jobs.len()];
    for _ in 0..reps {
        for (b, job) in best.iter_mut().zip(jobs.iter_mut()) {
            *b = b.min(seconds(&mut **job));
            tidy();
        }
    }
    best
}

fn main() {
    // One full lane group per thread for the per-core figure.
    let one = scenario(LANES, 100.0, 100);
    let two = scenario(2 * LANES, 100.0, 100);
    criterion_benches(&one, &two);
    generation(&one, &two).print();
    logging();
}

/// The criterion benches: the random-number bound and the simulator on one and two threads.
fn criterion_benches(one: &Scenario, two: &Scenario) {
    let mut c = Criterion::default().sample_size(10).configure_from_args();
    let mut g = c.benchmark_group("random-number bound");
    g.throughput(Throughput::Elements(1 << 22));
    g.bench_function("standard normals, one Xoshiro256++ per lane", |b| {
        b.iter(|| normals(1 << 22))
    });
    g.finish();

    let mut g = c.benchmark_group("simulator duffing2dof");
    g.throughput(Throughput::Elements(steps(one)));
    g.bench_function("1 thread, one lane group", |b| {
        b.iter(|| run(one, 1, &mut Discard::default()))
    });
    g.throughput(Throughput::Elements(steps(two)));
    g.bench_function("2 threads, two lane groups", |b| {
        b.iter(|| run(two, 2, &mut Discard::default()))
    });
    g.finish();
    c.final_summary();
}

/// The simulator's rates against the raw random-number rate, measured in one run.
struct Generation {
    n: usize,
    t_rr: f64,
    t_runs: f64,
    t_side: f64,
    normals_per_step: f64,
    bound: f64,
    rate1: f64,
    rate2: f64,
    ceiling2: f64,
}

fn generation(one: &Scenario, two: &Scenario) -> Generation {
    let n = 1 << 23;
    let pool2 = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
    let [t_rr, t_runs, t_side, t_runs2, t1, t2]: [f64; 6] = fastest(
        15,
        &mut [
            &mut || {
                black_box(normals(n));
            },
            &mut || {
                black_box(normals_in_runs(n));
            },
            &mut || {
                black_box(normals_side_by_side(n));
            },
            &mut || {
                pool2.install(|| rayon::join(|| black_box(normals_in_runs(n)), || black_box(normals_in_runs(n))));
            },
            &mut || run(one, 1, &mut Discard::default()),
            &mut || run(two, 2, &mut Discard::default()),
        ],
    )
    .try_into()
    .unwrap();
    // The bound is the fastest raw generation pattern.
    let normal_rate = n as f64 / t_rr.min(t_runs).min(t_side);
    let normals_per_step = 2.0; // one per white excitation
    let bound = normal_rate / normals_per_step;
    let rate1 = steps(one) as f64 / t1;
    let rate2 = steps(two) as f64 / t2;
    let ceiling2 = 2.0 * t_runs / t_runs2;

    Generation {
        n,
        t_rr,
        t_runs,
        t_side,
        normals_per_step,
        bound,
        rate1,
        rate2,
        ceiling2,
    }
}

impl Generation {
    fn print(&self) {
        let Generation {
            n,
            t_rr,
            t_runs,
            t_side,
            normals_per_step,
            bound,
            rate1,
            rate2,
            ceiling2,
        } = *self;
        println!("\n== ratios measured in this run (duffing2dof, dt = 1e-3) ==");
        println!(
            "raw normals, one generator/lane  {:>9.3e} /s round-robin, {:.3e} /s in runs per core",
            n as f64 / t_rr,
            n as f64 / t_runs
        );
        println!(
            "raw normals, lanes side by side  {:>9.3e} /s per core = {:.2}x in runs (the simulator's generator, {})",
            n as f64 / t_side,
            t_runs / t_side,
            LaneNormals::instructions()
        );
        println!(
            "random-number bound             {:>10.3e} steps/s per core ({normals_per_step} normals per step)",
            bound
        );
        println!(
            "simulator, 1 thread             {:>10.3e} steps/s  = {:.2} of the bound (target >= 0.8)",
            rate1,
            rate1 / bound
        );
        println!(
            "simulator, 2 threads            {:>10.3e} steps/s  = {:.2}x one thread (target >= 1.8; \
             raw normals on 2 threads: {:.2}x)",
            rate2,
            rate2 / rate1,
            ceiling2
        );
    }
}

/// Logging's cost against the unlogged run, and its floors, measured in one run.
fn logging() {
    // Long enough (0.07 s on two cores) that a log's fixed costs (the file, the writer thread)
    // do not dominate.
    let quiet = scenario(2 * LANES, 300.0, 100_000); // one sample at the end: no logging to speak of
    let logged = scenario(2 * LANES, 300.0, 10);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bench.mcap");
    // The same log in RAM (tmpfs), where there is one: what the filesystem's writeback costs.
    let shm = std::path::Path::new("/dev/shm");
    let ram = shm.is_dir().then(|| tempfile::tempdir_in(shm).unwrap());
    let ram_path = ram.as_ref().map_or(path.clone(), |d| d.path().join("bench.mcap"));
    let m = Model::new(&logged);
    let mut bytes = 0;
    let mut zstd_bytes = 0;
    let log = |p: &std::path::Path, threads: usize, c: Compression| {
        let mut w = LogWriter::create_with(p, &logged, &m, c).unwrap();
        run(&logged, threads, &mut w);
        w.finish().unwrap().bytes
    };
    let bare = |p: &Path| {
        let mut w = BareFile::create(p);
        run(&logged, 2, &mut w);
        w.finish();
    };
    let (bare_path, bare_ram_path) = (path.with_file_name("bare.bin"), ram_path.with_file_name("bare.bin"));
    // The default scenario's sampling, every 100th step.
    let sparse = scenario(2 * LANES, 300.0, 100);
    let m_sparse = Model::new(&sparse);
    let log_sparse = || {
        let mut w = LogWriter::create(&path, &sparse, &m_sparse).unwrap();
        run(&sparse, 2, &mut w);
        black_box(w.finish().unwrap());
    };
    let [t_quiet, t_sampled, t_logged, t_ram, t_zstd, t_quiet1, t_logged1, t_ram1, t_bare, t_bare_ram, t_sparse]: [f64;
        11] = fastest_tidied(
        7,
        &mut [
            &mut || run(&quiet, 2, &mut Discard::default()),
            &mut || run(&logged, 2, &mut Discard::default()),
            &mut || bytes = log(&path, 2, Compression::None),
            &mut || {
                black_box(log(&ram_path, 2, Compression::None));
            },
            &mut || zstd_bytes = log(&path, 2, Compression::Zstd),
            &mut || run(&quiet, 1, &mut Discard::default()),
            &mut || {
                black_box(log(&path, 1, Compression::None));
            },
            &mut || {
                black_box(log(&ram_path, 1, Compression::None));
            },
            &mut || bare(&bare_path),
            &mut || bare(&bare_ram_path),
            &mut || log_sparse(),
        ],
        &mut || {
            for p in [&path, &ram_path, &bare_path, &bare_ram_path] {
                let _ = std::fs::remove_file(p);
            }
        },
    )
    .try_into()
    .unwrap();
    let samples = (logged.simulation.trajectories * logged.simulation.samples_per_trajectory()) as f64;

    let (t_kernel, t_kernel_ram) = kernel_seconds(bytes, &path, &ram_path);
    // Both cores already simulate (and sample) for `t_sampled`; the kernel's work can at
    // best be shared between them.
    let kernel_floor = |t: f64| (t_sampled + t / 2.0) / t_quiet;

    let writer_rate = writer_rate(&logged, &path, &m);
    // A floor for any zstd-compressed log of these samples: compressing just their payload
    // bytes, with no framing, no index and no file.
    let mut payload = Payload::default();
    run(&logged, 2, &mut payload);
    let (z1, z1_bytes) = zstd_seconds(&payload.0, 1);
    let (z5, _) = zstd_seconds(&payload.0, -5);

    println!(
        "MCAP log every 10th step        {:>10.3} s vs {:.3} s unlogged = {:.2}x (target <= 1.25), \
         2 simulating threads",
        t_logged,
        t_quiet,
        t_logged / t_quiet
    );
    println!(
        "  the log in RAM (tmpfs)         {:>9.3} s = {:.2}x (no filesystem writeback)",
        t_ram,
        t_ram / t_quiet
    );
    println!(
        "  sampling alone                 {:>9.3} s = {:.2}x (samples taken, then discarded)",
        t_sampled,
        t_sampled / t_quiet
    );
    println!(
        "  1 simulating thread, the writer on the other core: {:.3} s vs {:.3} s = {:.2}x on disk, \
         {:.2}x in RAM",
        t_logged1,
        t_quiet1,
        t_logged1 / t_quiet1,
        t_ram1 / t_quiet1
    );
    println!(
        "  reference: the bare payload copied once and written by a writer thread (no MCAP, no \
         framing): {:.2}x on disk, {:.2}x in RAM",
        t_bare / t_quiet,
        t_bare_ram / t_quiet
    );
    println!(
        "  floor: the kernel taking the log's {:.0} MB from a ready buffer (1 MiB writes, one core, \
         no simulation): {:.3} s = {:.1} GB/s on disk, {:.3} s = {:.1} GB/s in RAM; with two \
         simulating cores the ratio is at least (sampling + that / 2) / unlogged = {:.2}x on \
         disk, {:.2}x in RAM",
        bytes as f64 / 1e6,
        t_kernel,
        bytes as f64 / t_kernel / 1e9,
        t_kernel_ram,
        bytes as f64 / t_kernel_ram / 1e9,
        kernel_floor(t_kernel),
        kernel_floor(t_kernel_ram)
    );
    println!(
        "MCAP log every 100th step       {:>10.3} s = {:.2}x (the default scenario's sampling)",
        t_sparse,
        t_sparse / t_quiet
    );
    println!(
        "MCAP log with zstd chunks       {:>10.3} s = {:.2}x ({:.1} bytes/sample)",
        t_zstd,
        t_zstd / t_quiet,
        zstd_bytes as f64 / samples
    );
    println!(
        "  floor: zstd alone on the bare payload ({:.0} B/sample), one core: level 1 {:.3} s \
         ({:.0} B/sample out), level -5 {:.3} s; with two simulating cores the ratio is at least \
         1 + that / (2 x {:.3} s) = {:.2}x at level 1, {:.2}x at level -5",
        payload.0.len() as f64 / samples,
        z1,
        z1_bytes as f64 / samples,
        z5,
        t_quiet,
        1.0 + z1 / (2.0 * t_quiet),
        1.0 + z5 / (2.0 * t_quiet)
    );
    println!(
        "MCAP writer alone               {:>10.3e} samples/s ({:.0} ns per sample)",
        writer_rate,
        1e9 / writer_rate
    );
    println!(
        "log size                        {:>10.1} bytes/sample ({} samples)",
        bytes as f64 / samples,
        samples
    );
}

/// A floor for any file of `bytes` bytes: the kernel taking them from a ready buffer, in
/// plain 1 MiB writes on one core, with no simulation running; on disk and in RAM (s).
fn kernel_seconds(bytes: u64, path: &Path, ram_path: &Path) -> (f64, f64) {
    let ready: Vec<u8> = (0..1 << 20).map(|i| (i * 131 % 251) as u8).collect();
    let write_bytes = |p: &Path| {
        let tmp = p.with_extension("partial");
        let mut file = std::fs::File::create(&tmp).unwrap();
        let mut left = bytes as usize;
        while left > 0 {
            let n = left.min(ready.len());
            file.write_all(&ready[..n]).unwrap();
            left -= n;
        }
        drop(file);
        std::fs::rename(&tmp, p).unwrap();
    };
    let (raw_path, raw_ram_path) = (path.with_file_name("raw.bin"), ram_path.with_file_name("raw.bin"));
    let [t_kernel, t_kernel_ram]: [f64; 2] = fastest_tidied(
        7,
        &mut [&mut || write_bytes(&raw_path), &mut || write_bytes(&raw_ram_path)],
        &mut || {
            for p in [&raw_path, &raw_ram_path] {
                let _ = std::fs::remove_file(p);
            }
        },
    )
    .try_into()
    .unwrap();
    (t_kernel, t_kernel_ram)
}

/// The writer alone, fed pre-made batches shaped like `logged`'s (samples/s).
fn writer_rate(logged: &Scenario, path: &Path, m: &Model) -> f64 {
    let (trajectories, instants) = (logged.simulation.trajectories, 1024);
    let batch = SampleBatch {
        columns: 8,
        trajectories,
        time: (0..instants).map(|k| k as f64 * 0.01).collect(),
        values: (0..instants * 8 * trajectories)
            .map(|i| ((i as f64) * 0.618).sin())
            .collect(),
    };
    let writer_secs = fastest(
        3,
        &mut [&mut || {
            let mut w = LogWriter::create(path, logged, m).unwrap();
            for _ in 0..8 {
                w.write(batch.clone()).unwrap();
            }
            w.finish().unwrap();
        }],
    )[0];
    (8 * batch.len()) as f64 / writer_secs
}
