//! The discrete Fourier transform of the lab excitations (`sim::lab`, whose period is
//! whatever the rig's is): an in-place radix-2 FFT for lengths that are powers of two and
//! Bluestein's chirp-z transform for any length. (The Welch estimates of `ident::spectrum`,
//! a hot loop, use the maintained real-input FFT of `realfft` instead.)
//!
//! Convention: `X[k] = Σ_n x[n] e^{−2πi kn/N}` (forward), no scaling.

use std::f64::consts::PI;

/// In-place radix-2 complex FFT (`re`, `im` of length a power of two).
fn fft(re: &mut [f64], im: &mut [f64]) {
    let n = re.len();
    debug_assert!(n.is_power_of_two() && im.len() == n);
    let mut j = 0;
    for i in 1..n {
        let mut bit = n >> 1;
        while j & bit != 0 {
            j ^= bit;
            bit >>= 1;
        }
        j |= bit;
        if i < j {
            re.swap(i, j);
            im.swap(i, j);
        }
    }
    let mut len = 2;
    while len <= n {
        let ang = -2.0 * PI / len as f64;
        let (wr, wi) = (ang.cos(), ang.sin());
        for start in (0..n).step_by(len) {
            let (mut cr, mut ci) = (1.0, 0.0);
            for k in 0..len / 2 {
                let (a, b) = (start + k, start + k + len / 2);
                let (tr, ti) = (re[b] * cr - im[b] * ci, re[b] * ci + im[b] * cr);
                re[b] = re[a] - tr;
                im[b] = im[a] - ti;
                re[a] += tr;
                im[a] += ti;
                let nr = cr * wr - ci * wi;
                ci = cr * wi + ci * wr;
                cr = nr;
            }
        }
        len <<= 1;
    }
}

/// In-place complex DFT of any length: the radix-2 FFT where the length is a power of
/// two, otherwise Bluestein's algorithm (`kn = (k² + n² − (k−n)²)/2` turns the DFT into
/// a convolution with a chirp, done by three power-of-two FFTs of length ≥ `2N − 1`).
pub fn dft(re: &mut [f64], im: &mut [f64]) {
    let n = re.len();
    assert_eq!(im.len(), n, "real and imaginary parts of one length");
    if n <= 1 {
        return;
    }
    if n.is_power_of_two() {
        return fft(re, im);
    }
    let m = (2 * n - 1).next_power_of_two();
    // The chirp w[j] = e^{−πi j²/N}; j² is reduced mod 2N first so the angle stays exact
    // for long transforms.
    let chirp: Vec<(f64, f64)> = (0..n)
        .map(|j| {
            let q = ((j as u128 * j as u128) % (2 * n as u128)) as f64;
            let a = -PI * q / n as f64;
            (a.cos(), a.sin())
        })
        .collect();
    let (mut ar, mut ai) = (vec![0.0; m], vec![0.0; m]);
    for j in 0..n {
        let (c, s) = chirp[j];
        ar[j] = re[j] * c - im[j] * s;
        ai[j] = re[j] * s + im[j] * c;
    }
    // b[j] = conj(w[j]) for |j| < N, wrapped to the end for negative j.
    let (mut br, mut bi) = (vec![0.0; m], vec![0.0; m]);
    for j in 0..n {
        let (c, s) = chirp[j];
        br[j] = c;
        bi[j] = -s;
        if j > 0 {
            br[m - j] = c;
            bi[m - j] = -s;
        }
    }
    fft(&mut ar, &mut ai);
    fft(&mut br, &mut bi);
    for j in 0..m {
        let (r, i) = (ar[j] * br[j] - ai[j] * bi[j], ar[j] * bi[j] + ai[j] * br[j]);
        // Conjugated, so the forward FFT below computes the inverse (up to 1/m).
        ar[j] = r;
        ai[j] = -i;
    }
    fft(&mut ar, &mut ai);
    let scale = 1.0 / m as f64;
    for k in 0..n {
        let (r, i) = (ar[k] * scale, -ai[k] * scale);
        let (c, s) = chirp[k];
        re[k] = r * c - i * s;
        im[k] = r * s + i * c;
    }
}

/// The real signal `x[n] = Re Σ_k c[k] e^{2πi kn/N}`, `n < N`, of one-sided complex
/// coefficients `c[k] = (re, im)` for `k < c.len() ≤ N/2 + 1`: a sum of cosines on the
/// grid of `N` points per period, by one DFT of length `N`.
pub fn real_signal(c: &[(f64, f64)], n: usize) -> Vec<f64> {
    assert!(c.len() <= n / 2 + 1, "{} coefficients on a grid of {n}", c.len());
    // x[n] = Re Σ c_k e^{+iθ} = Re conj(Σ conj(c_k) e^{−iθ}): a forward DFT of conj(c).
    let (mut re, mut im) = (vec![0.0; n], vec![0.0; n]);
    for (k, &(a, b)) in c.iter().enumerate() {
        re[k] = a;
        im[k] = -b;
    }
    dft(&mut re, &mut im);
    re
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The naive sum, the reference.
    fn naive(re: &[f64], im: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let n = re.len();
        (0..n)
            .map(|k| {
                (0..n).fold((0.0, 0.0), |(sr, si), j| {
                    let a = -2.0 * PI * ((k * j) % n) as f64 / n as f64;
                    (
                        sr + re[j] * a.cos() - im[j] * a.sin(),
                        si + re[j] * a.sin() + im[j] * a.cos(),
                    )
                })
            })
            .unzip()
    }

    #[test]
    fn the_dft_of_any_length_is_the_naive_sum() {
        for n in [1usize, 2, 3, 5, 8, 12, 100, 243, 1000] {
            let re: Vec<f64> = (0..n).map(|j| ((j * 7 + 3) % 11) as f64 - 5.0).collect();
            let im: Vec<f64> = (0..n).map(|j| ((j * 5 + 1) % 13) as f64 * 0.25).collect();
            let (er, ei) = naive(&re, &im);
            let (mut r, mut i) = (re.clone(), im.clone());
            dft(&mut r, &mut i);
            let scale = er.iter().chain(&ei).fold(1.0f64, |a, v| a.max(v.abs()));
            for k in 0..n {
                assert!(
                    (r[k] - er[k]).abs() < 1e-10 * scale && (i[k] - ei[k]).abs() < 1e-10 * scale,
                    "N = {n}, k = {k}: ({}, {}) against ({}, {})",
                    r[k],
                    i[k],
                    er[k],
                    ei[k]
                );
            }
        }
    }

    #[test]
    fn a_real_signal_is_its_sum_of_cosines() {
        let n = 90;
        let c = [(0.5, 0.0), (1.0, 0.0), (0.0, 2.0), (0.3, -0.4)];
        let x = real_signal(&c, n);
        for (j, &v) in x.iter().enumerate() {
            let exact: f64 = c
                .iter()
                .enumerate()
                .map(|(k, &(a, b))| {
                    let t = 2.0 * PI * (k * j) as f64 / n as f64;
                    a * t.cos() - b * t.sin()
                })
                .sum();
            assert!((v - exact).abs() < 1e-12, "sample {j}: {v} against {exact}");
        }
    }
}
