//! The rig's tables for the checks: a linear (or hardening) oscillator driven by a
//! multisine, an Ornstein–Uhlenbeck or a Kanai–Tajimi force, integrated by a small
//! stepper of the tests' own and written as a lab's CSV would be (nothing of fpkbench's
//! simulator is in them).

use std::collections::BTreeMap;
use std::fmt::Write;
use std::sync::{Arc, Mutex, OnceLock};

/// A linear oscillator, m = 1, k1 = (2π·5 Hz)², c1 = 2·0.05·ω (5 % damping).
pub(super) const K1: f64 = 100.0 * std::f64::consts::PI * std::f64::consts::PI;
pub(super) const C1: f64 = std::f64::consts::PI;
/// The integration step and the sample interval, s.
pub(super) const STEP: f64 = 5e-4;
pub(super) const SAMPLE: f64 = 5e-3;

/// SplitMix64's uniform numbers in [0, 1).
pub(super) struct Uniform(pub(super) u64);

impl Uniform {
    pub(super) fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    pub(super) fn normal(&mut self) -> f64 {
        let (u1, u2) = (self.next().max(1e-300), self.next());
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

/// The oscillator driven by `force(step)`, semi-implicit Euler at STEP, `records` records
/// of `length` s after a 20 s transient, sampled every SAMPLE: a CSV of record, t, x, v,
/// a (from the equation of motion at the sample) and p.
pub(super) fn rig_table(records: usize, length: f64, force: impl FnMut(usize) -> f64) -> String {
    hardening_rig_table(records, length, 0.0, false, force)
}

/// [`rig_table`] with a hardening spring `K1 x + k3 x³`. With `verlet`, stepped by velocity
/// Verlet (the damping implicit in the second kick), so that the sampled velocity is the
/// displacement's rate of change to `O((ωh)²)`, as a right model's data are; else by the
/// semi-implicit step, which moves the displacement by the new velocity, so the sampled
/// velocity lags that rate by a step (a tenth of a sample): a sensor's lag the model lacks.
pub(super) fn hardening_rig_table(
    records: usize,
    length: f64,
    k3: f64,
    verlet: bool,
    mut force: impl FnMut(usize) -> f64,
) -> String {
    let mut csv = String::from("record,t,x,v,a,p\n");
    let per_sample = (SAMPLE / STEP).round() as usize;
    let (transient, samples) = ((20.0 / STEP) as usize, (length / SAMPLE) as usize);
    let spring = |x: f64| K1 * x + k3 * x * x * x;
    for r in 0..records {
        let base = r * (transient + samples * per_sample);
        let (mut x, mut v) = (0.0, 0.0);
        let mut p = if verlet { force(base) } else { 0.0 };
        for n in 0..transient + samples * per_sample {
            if !verlet {
                p = force(base + n);
            }
            if n >= transient && (n - transient) % per_sample == 0 {
                let t = (n - transient) as f64 * STEP;
                let a = p - C1 * v - spring(x);
                writeln!(csv, "{r},{t},{x:e},{v:e},{a:e},{p:e}").unwrap();
            }
            if verlet {
                let half = v + 0.5 * STEP * (p - C1 * v - spring(x));
                x += STEP * half;
                p = force(base + n + 1);
                v = (half + 0.5 * STEP * (p - spring(x))) / (1.0 + 0.5 * STEP * C1);
            } else {
                v += STEP * (p - C1 * v - spring(x));
                x += STEP * v;
            }
        }
    }
    csv
}

/// The rig under a random-phase multisine of `lines` lines `f0` Hz apart, flat in
/// amplitude, a new realisation per record (8 records of 60 s). Made once per test run
/// for each `(lines, f0, seed)`: several tests read the same table.
pub(super) fn multisine_table(lines: usize, f0: f64, seed: u64) -> String {
    type Made = Mutex<BTreeMap<(usize, u64, u64), Arc<OnceLock<String>>>>;
    static MADE: Made = Mutex::new(BTreeMap::new());
    let cell = MADE
        .lock()
        .unwrap()
        .entry((lines, f0.to_bits(), seed))
        .or_default()
        .clone();
    cell.get_or_init(|| rig_table(8, 60.0, multisine(lines, f0, seed)))
        .clone()
}

/// The force of [`multisine_table`] at each step: per record, one period (`1/f0` s) of
/// its sum of cosines, repeated.
pub(super) fn multisine(lines: usize, f0: f64, seed: u64) -> impl FnMut(usize) -> f64 {
    let mut u = Uniform(seed);
    let mut period = Vec::new();
    let mut record = usize::MAX;
    let per_record = ((20.0 + 60.0) / STEP) as usize;
    let steps = (1.0 / (f0 * STEP)).round() as usize;
    assert!(
        (steps as f64 * f0 * STEP - 1.0).abs() < 1e-9,
        "a period of {f0} Hz is not whole steps"
    );
    let amplitude = 4.0 * (200.0 / lines as f64).sqrt();
    move |n| {
        if n / per_record != record {
            record = n / per_record;
            let phases: Vec<f64> = (0..lines).map(|_| 2.0 * std::f64::consts::PI * u.next()).collect();
            period = (0..steps)
                .map(|m| {
                    let t = m as f64 * STEP;
                    (0..lines)
                        .map(|k| (2.0 * std::f64::consts::PI * f0 * (k + 1) as f64 * t + phases[k]).cos())
                        .sum::<f64>()
                        * amplitude
                })
                .collect();
        }
        period[n % per_record % steps]
    }
}

/// The rig under an Ornstein–Uhlenbeck force, `dP = −B P dt + A dW` exact in each step,
/// A = 200, B = 20 1/s (near the mode's 31 rad/s).
pub(super) fn ou_table() -> String {
    let (a, b) = (200.0, 20.0);
    let phi: f64 = (-b * STEP).exp();
    let sd = a * ((1.0 - phi * phi) / (2.0 * b)).sqrt();
    let mut u = Uniform(11);
    let mut p = 0.0;
    rig_table(8, 60.0, |_| {
        p = phi * p + sd * u.normal();
        p
    })
}

/// The rig under a Kanai–Tajimi force: white noise of intensity 6.6 through a ground of
/// Ω = 20 rad/s and ζ = 0.3 (`ÿ + 2ζΩẏ + Ω²y = −w`, the force `2ζΩẏ + Ω²y`), semi-implicit
/// Euler at the rig's step; its density peaks below the mode and falls as ω⁻² above.
pub(super) fn kanai_tajimi_table() -> String {
    let (omega, zeta, sigma) = (20.0, 0.3, 6.6);
    let mut u = Uniform(13);
    let (mut y, mut dy) = (0.0, 0.0);
    rig_table(8, 60.0, |_| {
        dy += -STEP * (2.0 * zeta * omega * dy + omega * omega * y) - sigma * STEP.sqrt() * u.normal();
        y += STEP * dy;
        2.0 * zeta * omega * dy + omega * omega * y
    })
}
