//! The excitations labs use (docs/excitations.md): a random-phase multisine, band-limited
//! Gaussian noise and Kanai–Tajimi shaped noise, described by their parameters and their
//! exact spectra, and a recorded signal (a table's column, the rig's own input).
//! `sim::lab` generates their realisations and drives a model with them.

use std::f64::consts::PI;
use std::ops::Range;
use std::path::PathBuf;
use std::sync::Arc;

/// The excitations labs use (docs/excitations.md); frequencies in Hz, levels in the
/// force's unit.
#[derive(Debug, Clone, PartialEq)]
pub enum Signal {
    /// A random-phase multisine: amplitudes on the lines `k / period` inside `band` (every
    /// line, or the odd ones), equal or following `shape`, total RMS `rms`, repeating every
    /// `period` s; a new realisation of the phases per trajectory.
    Multisine {
        /// RMS of the whole signal.
        rms: f64,
        /// The band of the lines, Hz.
        band: (f64, f64),
        /// The period, s.
        period: f64,
        /// Only the odd lines.
        odd: bool,
        /// The lines' relative amplitudes over frequency (`None`: all equal).
        shape: Option<Shape>,
    },
    /// Gaussian noise: white noise of two-sided density `σ²/2π` through a Butterworth
    /// filter of order `order`, a low-pass at `band.1` when `band.0` is 0, else a band-pass.
    BandLimited {
        /// The white noise's intensity before the filter.
        sigma: f64,
        /// The pass band, Hz (a low-pass when it starts at 0).
        band: (f64, f64),
        /// The Butterworth order, 1–16.
        order: u32,
    },
    /// Gaussian noise through a Kanai–Tajimi filter (a ground of natural angular frequency
    /// `omega_g` rad/s and damping ratio `zeta_g` over white noise of density `σ²/2π`).
    KanaiTajimi {
        /// The white noise's intensity.
        sigma: f64,
        /// The ground's natural angular frequency, rad/s.
        omega_g: f64,
        /// The ground's damping ratio.
        zeta_g: f64,
    },
    /// A measured signal (`kind = "recorded"`): a table's column, band-limited between its
    /// samples; every trajectory is driven by its own stretch of it, one after the other.
    Recorded(Arc<Recorded>),
}

/// A recorded signal: where it is written, and — once [`crate::Scenario::read_recordings`]
/// has read it — its samples.
#[derive(Debug, Clone, PartialEq)]
pub struct Recorded {
    /// The table, as the scenario writes it (relative to the scenario file).
    pub file: PathBuf,
    /// The column holding the signal.
    pub column: String,
    /// The table's time column, if its spacing gives the sample interval.
    pub time: Option<String>,
    /// The recording's sample interval, s (given, or from the time column once read).
    pub interval: Option<f64>,
    /// The factor on every sample (the force per unit of the column: an amplifier's gain).
    pub scale: f64,
    /// The column's samples as written (empty until read).
    pub samples: Vec<f64>,
    /// Where `file` is written in the scenario's text, for errors found when reading it.
    pub at: Range<usize>,
}

impl Recorded {
    /// The recording's length, s (0 until read).
    pub fn duration(&self) -> f64 {
        match self.interval {
            Some(h) if self.samples.len() > 1 => (self.samples.len() - 1) as f64 * h,
            _ => 0.0,
        }
    }

    /// Why `trajectories` stretches of `span` s each do not fit in the recording, if
    /// they do not (every trajectory is driven by its own stretch, one after the other).
    pub fn too_short(&self, trajectories: usize, span: f64) -> Option<String> {
        let need = trajectories as f64 * span;
        let have = self.duration();
        (need > have * (1.0 + 1e-9)).then(|| {
            format!(
                "the recording {:?} of {} holds {have} s ({} samples at {} s); {trajectories} trajectory \
                 stretch(es) of {span} s (burn-in and record) need {need} s: shorten the record or the \
                 burn-in, or use fewer trajectories",
                self.column,
                self.file.display(),
                self.samples.len(),
                self.interval.unwrap_or(f64::NAN),
            )
        })
    }
}

/// A multisine's relative amplitude over frequency (`amplitude = [[Hz, a], …]`): the
/// points' amplitudes interpolated linearly in frequency between them, the first's and
/// the last's held beyond (docs/excitations.md).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shape {
    points: [(f64, f64); Shape::MAX],
    len: usize,
}

impl Shape {
    /// Most points a shape holds.
    pub const MAX: usize = 8;

    /// The shape through `points` (Hz ascending, amplitudes ≥ 0, at most [`Shape::MAX`];
    /// checked by the scenario's validation).
    pub fn new(points: &[(f64, f64)]) -> Shape {
        let mut s = Shape {
            points: [(0.0, 0.0); Shape::MAX],
            len: points.len().min(Shape::MAX),
        };
        s.points[..s.len].copy_from_slice(&points[..s.len]);
        s
    }

    /// The relative amplitude at `f` Hz.
    pub fn at(&self, f: f64) -> f64 {
        let p = &self.points[..self.len];
        match p.iter().position(|&(x, _)| x >= f) {
            None => p.last().map_or(1.0, |q| q.1),
            Some(0) => p[0].1,
            Some(j) => {
                let ((x0, a0), (x1, a1)) = (p[j - 1], p[j]);
                a0 + (a1 - a0) * (f - x0) / (x1 - x0)
            }
        }
    }
}

impl Signal {
    /// The signal's name in a scenario (`kind = "…"`).
    pub fn kind(&self) -> &'static str {
        match self {
            Signal::Multisine { .. } => "multisine",
            Signal::BandLimited { .. } => "band-limited",
            Signal::KanaiTajimi { .. } => "kanai-tajimi",
            Signal::Recorded(_) => "recorded",
        }
    }

    /// The multisine's lines: `(k, amplitude)`, the `k`-th harmonic of `1/period` (Hz) with
    /// its cosine amplitude — equal for every line, or in proportion to the shape at
    /// `k/period` — with `Σ amplitude²/2 = rms²`. Empty for the noises, and for a band that
    /// holds no line of the period's grid (or where the shape is zero on every line).
    pub fn lines(&self) -> Vec<(usize, f64)> {
        let Signal::Multisine {
            rms,
            band,
            period,
            odd,
            shape,
        } = *self
        else {
            return Vec::new();
        };
        let first = ((band.0 * period - 1e-9).ceil() as usize).max(1);
        let last = (band.1 * period + 1e-9).floor() as usize;
        let relative = |k: usize| shape.map_or(1.0, |s| s.at(k as f64 / period));
        let ks: Vec<(usize, f64)> = (first..=last)
            .filter(|k| !odd || k % 2 == 1)
            .map(|k| (k, relative(k)))
            .filter(|&(_, a)| a > 0.0)
            .collect();
        let power: f64 = ks.iter().map(|&(_, a)| a * a / 2.0).sum();
        if power <= 0.0 {
            return Vec::new();
        }
        let scale = rms / power.sqrt();
        ks.into_iter().map(|(k, a)| (k, a * scale)).collect()
    }

    /// The two-sided spectral density at angular frequency `omega` (rad/s), per rad/s, of
    /// a noise (`∫ S dω` over all `ω` is its variance); `None` for the multisine, whose
    /// spectrum is its lines, and for a recording, whose spectrum is what it is.
    pub fn density(&self, omega: f64) -> Option<f64> {
        let w = omega.abs();
        match *self {
            Signal::Multisine { .. } | Signal::Recorded(_) => None,
            Signal::BandLimited { sigma, band, order } => {
                Some(sigma * sigma / (2.0 * PI) * butterworth_gain2(band, order, w))
            }
            Signal::KanaiTajimi { sigma, omega_g, zeta_g } => {
                let (g2, c) = (omega_g * omega_g, 2.0 * zeta_g * omega_g * w);
                let gain = (g2 * g2 + c * c) / ((g2 - w * w).powi(2) + c * c);
                Some(sigma * sigma / (2.0 * PI) * gain)
            }
        }
    }

    /// The standard deviation, in closed form: a multisine's `rms`; for the noises the
    /// integral of the density (a Butterworth band of width `B` rad/s passes
    /// `B·(π/2n)/sin(π/2n)` on each side; Kanai–Tajimi's is `π S₀ ω_g (1 + 4ζ_g²)/(2ζ_g)`);
    /// a recording's RMS over its samples (NaN until read).
    pub fn rms(&self) -> f64 {
        match *self {
            Signal::Recorded(ref r) => {
                let n = r.samples.len() as f64;
                r.scale * (r.samples.iter().map(|v| v * v).sum::<f64>() / n).sqrt()
            }
            Signal::Multisine { rms, .. } => rms,
            Signal::BandLimited { sigma, band, order } => {
                let width = 2.0 * PI * (band.1 - band.0);
                let x = PI / (2.0 * order as f64);
                (sigma * sigma / (2.0 * PI) * 2.0 * width * x / x.sin()).sqrt()
            }
            Signal::KanaiTajimi { sigma, omega_g, zeta_g } => {
                let s0 = sigma * sigma / (2.0 * PI);
                (PI * s0 * omega_g * (1.0 + 4.0 * zeta_g * zeta_g) / (2.0 * zeta_g)).sqrt()
            }
        }
    }

    /// The same signal `k` times as strong.
    pub fn scaled(&self, k: f64) -> Signal {
        let mut s = self.clone();
        match &mut s {
            Signal::Multisine { rms, .. } => *rms *= k,
            Signal::BandLimited { sigma, .. } | Signal::KanaiTajimi { sigma, .. } => *sigma *= k,
            Signal::Recorded(r) => Arc::make_mut(r).scale *= k,
        }
        s
    }
}

/// `|H(iω)|²` of a Butterworth filter of order `n` over `band` (Hz): a low-pass at `band.1`
/// when `band.0` is 0, else the band-pass made from it by `s → (s² + ω₀²)/(s B)`.
fn butterworth_gain2(band: (f64, f64), n: u32, w: f64) -> f64 {
    let (lo, hi) = (2.0 * PI * band.0, 2.0 * PI * band.1);
    let x = if lo == 0.0 {
        w / hi
    } else if w == 0.0 {
        return 0.0;
    } else {
        (w * w - lo * hi) / (w * (hi - lo))
    };
    1.0 / (1.0 + x.abs().powi(2 * n as i32))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed-form variances against the density integrated numerically.
    #[test]
    fn the_closed_form_variances_are_the_densities_integrals() {
        let signals = [
            Signal::BandLimited {
                sigma: 1.3,
                band: (0.0, 3.0),
                order: 2,
            },
            Signal::BandLimited {
                sigma: 0.7,
                band: (0.0, 5.0),
                order: 6,
            },
            Signal::BandLimited {
                sigma: 1.0,
                band: (1.0, 4.0),
                order: 1,
            },
            Signal::BandLimited {
                sigma: 2.0,
                band: (2.0, 2.5),
                order: 4,
            },
            Signal::KanaiTajimi {
                sigma: 1.0,
                omega_g: 15.6,
                zeta_g: 0.6,
            },
            Signal::KanaiTajimi {
                sigma: 0.5,
                omega_g: 5.0,
                zeta_g: 0.2,
            },
        ];
        for s in signals {
            // ∫ over ω ≥ 0 on a substituted grid ω = tan(θ)·c, which reaches the tails.
            let c = 2.0 * PI * 3.0;
            let n = 400_000;
            let integral: f64 = (0..n)
                .map(|i| {
                    let th = (i as f64 + 0.5) / n as f64 * PI / 2.0;
                    s.density(c * th.tan()).unwrap() * c / th.cos().powi(2) * (PI / 2.0 / n as f64)
                })
                .sum();
            let exact = s.rms().powi(2);
            assert!(
                (2.0 * integral - exact).abs() < 1e-4 * exact,
                "{s:?}: ∫S = {} against the closed form {exact}",
                2.0 * integral
            );
        }
    }

    #[test]
    fn a_multisine_has_its_lines_and_level() {
        let s = Signal::Multisine {
            rms: 0.5,
            band: (1.0, 3.0),
            period: 2.0,
            odd: false,
            shape: None,
        };
        let lines = s.lines();
        assert_eq!(lines.iter().map(|l| l.0).collect::<Vec<_>>(), [2, 3, 4, 5, 6]);
        let power: f64 = lines.iter().map(|l| l.1 * l.1 / 2.0).sum();
        assert!((power - 0.25).abs() < 1e-12);
        let odd = Signal::Multisine {
            rms: 0.5,
            band: (0.0, 3.0),
            period: 2.0,
            odd: true,
            shape: None,
        };
        assert_eq!(odd.lines().iter().map(|l| l.0).collect::<Vec<_>>(), [1, 3, 5]);
        assert!(odd.density(1.0).is_none());
    }

    /// A shaped multisine: each line's amplitude in proportion to the shape at its
    /// frequency (linear between the points, held beyond them), the whole at its RMS.
    #[test]
    fn a_shaped_multisine_follows_its_amplitude_over_the_band() {
        let shape = Shape::new(&[(1.0, 1.0), (3.0, 0.5)]);
        assert_eq!(shape.at(0.2), 1.0);
        assert!((shape.at(2.0) - 0.75).abs() < 1e-15);
        assert_eq!(shape.at(9.0), 0.5);
        let s = Signal::Multisine {
            rms: 0.5,
            band: (0.5, 4.0),
            period: 2.0,
            odd: false,
            shape: Some(shape),
        };
        let lines = s.lines();
        assert_eq!(lines.iter().map(|l| l.0).collect::<Vec<_>>(), [1, 2, 3, 4, 5, 6, 7, 8]);
        let power: f64 = lines.iter().map(|l| l.1 * l.1 / 2.0).sum();
        assert!((power - 0.25).abs() < 1e-12);
        // k = 4 at 2 Hz (0.75) against k = 1 at 0.5 Hz (1, held) and k = 8 at 4 Hz (0.5).
        let a = |k: usize| lines.iter().find(|l| l.0 == k).unwrap().1;
        assert!((a(4) / a(1) - 0.75).abs() < 1e-12 && (a(8) / a(1) - 0.5).abs() < 1e-12);
        // A shape that is zero over the band leaves no line.
        let silent = Signal::Multisine {
            rms: 0.5,
            band: (0.5, 4.0),
            period: 2.0,
            odd: false,
            shape: Some(Shape::new(&[(0.0, 0.0), (10.0, 0.0)])),
        };
        assert!(silent.lines().is_empty());
    }
}
