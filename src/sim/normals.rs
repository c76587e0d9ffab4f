//! The lanes' standard normals, drawn for all lanes at once: bit for bit the numbers of
//! `rand_distr::StandardNormal` from each lane's own xoshiro256++ generator, but with the
//! lanes' generators stepped side by side as vector arithmetic (docs/simulation.md,
//! "Random numbers").
//!
//! A generator draws its numbers one after another (each step depends on the last), so
//! drawing one lane's normals at a time leaves the core waiting on that chain. The lanes'
//! generators are independent: [`fill`] keeps their states as four arrays over the lanes
//! and steps all of them together, then takes the ziggurat's fast path (one table lookup,
//! one multiplication and one comparison, taken by 98.8 % of draws) for every lane. A lane
//! whose draw falls outside the fast path is drawn again by `rand_distr` itself from the
//! state before that draw (one step undone), so its rejection steps consume the generator exactly as
//! `rand_distr` does. Each lane's sequence of numbers is therefore unchanged; a test
//! checks it against `rand_distr` and `rand`'s `Xoshiro256PlusPlus`. Where the CPU has
//! AVX-512 or AVX2, the same steps are written out in its vector instructions, sixteen or
//! eight lanes at a time (the compiler's own vectorisation of the portable loop left half
//! the work scalar); a test checks each against `rand_distr` on a CPU that has it.

use super::LANES;
use multiversion::multiversion;
use rand::{SeedableRng, TryRng};
use rand_distr::{Distribution, StandardNormal};
use std::convert::Infallible;
use std::sync::LazyLock;

/// xoshiro256++ (Blackman and Vigna), the algorithm and seeding of `rand`'s
/// `Xoshiro256PlusPlus`, with its state open to [`fill`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Xoshiro {
    s: [u64; 4],
}

impl Xoshiro {
    /// The state from a `u64` by SplitMix64, as `rand`'s `seed_from_u64` does.
    pub(crate) fn seed_from_u64(mut state: u64) -> Xoshiro {
        const PHI: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut s = [0; 4];
        for x in &mut s {
            state = state.wrapping_add(PHI);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            *x = z ^ (z >> 31);
        }
        Xoshiro { s }
    }

    #[inline(always)]
    fn step(s: &mut [u64; 4]) -> u64 {
        let out = s[0].wrapping_add(s[3]).rotate_left(23).wrapping_add(s[0]);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        out
    }

    /// The state one step back: the inverse of [`Xoshiro::step`]'s state update.
    fn unstep(n: [u64; 4]) -> [u64; 4] {
        // Forward: c = s2^s0, d = s3^s1, n1 = s1^c, n0 = s0^d, n2 = c^(s1<<17), n3 = rotl(d, 45).
        let d = n[3].rotate_right(45);
        let s0 = n[0] ^ d;
        // n1 ^ n2 = s1 ^ (s1 << 17): undo the shift-xor.
        let x = n[1] ^ n[2];
        let s1 = x ^ (x << 17) ^ (x << 34) ^ (x << 51);
        let c = n[1] ^ s1;
        [s0, s1, c ^ s0, d ^ s1]
    }
}

impl TryRng for Xoshiro {
    type Error = Infallible;
    #[inline]
    fn try_next_u32(&mut self) -> Result<u32, Infallible> {
        Ok((Xoshiro::step(&mut self.s) >> 32) as u32)
    }
    #[inline]
    fn try_next_u64(&mut self) -> Result<u64, Infallible> {
        Ok(Xoshiro::step(&mut self.s))
    }
    fn try_fill_bytes(&mut self, dst: &mut [u8]) -> Result<(), Infallible> {
        for chunk in dst.chunks_mut(8) {
            let bytes = Xoshiro::step(&mut self.s).to_le_bytes();
            chunk.copy_from_slice(&bytes[..chunk.len()]);
        }
        Ok(())
    }
}

impl SeedableRng for Xoshiro {
    type Seed = [u8; 32];
    fn from_seed(seed: [u8; 32]) -> Xoshiro {
        if seed == [0; 32] {
            return Xoshiro::seed_from_u64(0);
        }
        let mut s = [0; 4];
        for (x, b) in s.iter_mut().zip(seed.chunks_exact(8)) {
            *x = u64::from_le_bytes(b.try_into().expect("8 bytes"));
        }
        Xoshiro { s }
    }
    fn seed_from_u64(state: u64) -> Xoshiro {
        Xoshiro::seed_from_u64(state)
    }
}

/// The ziggurat's layer edges `x_k` (k = 0..=256) of `rand_distr`'s normal sampler, read
/// from the sampler itself: a draw whose bits select layer `k` with the smallest positive
/// uniform `u = 2⁻⁵¹` is on the fast path and returns `u · x_k` exactly. `x_256 = 0`.
/// Kept as pairs `[x_k, x_(k+1)]`, the two numbers a draw in layer `k` needs.
static LAYERS: LazyLock<[[f64; 2]; 256]> = LazyLock::new(|| {
    struct Bits(u64);
    impl TryRng for Bits {
        type Error = Infallible;
        fn try_next_u32(&mut self) -> Result<u32, Infallible> {
            Ok((self.0 >> 32) as u32)
        }
        fn try_next_u64(&mut self) -> Result<u64, Infallible> {
            Ok(self.0)
        }
        fn try_fill_bytes(&mut self, _: &mut [u8]) -> Result<(), Infallible> {
            unreachable!("the normal sampler draws whole words")
        }
    }
    let x = |k: usize| match k {
        256 => 0.0,
        _ => Distribution::<f64>::sample(&StandardNormal, &mut Bits(((1 << 51 | 1) << 12) | k as u64)) * 2f64.powi(51),
    };
    std::array::from_fn(|k| [x(k), x(k + 1)])
});

/// The simulator's source of standard normals on its own, for benches: [`LANES`]
/// generators (lane `j` seeded with `seed + j`) drawn side by side.
pub struct LaneNormals {
    rng: [Xoshiro; LANES],
}

impl LaneNormals {
    pub fn new(seed: u64) -> LaneNormals {
        LaneNormals {
            rng: std::array::from_fn(|j| Xoshiro::seed_from_u64(seed.wrapping_add(j as u64))),
        }
    }

    /// The instructions this CPU's draws are written in (chosen at run time): "AVX-512",
    /// "AVX2" or "portable".
    pub fn instructions() -> &'static str {
        match Path::of_this_cpu() {
            #[cfg(target_arch = "x86_64")]
            Path::Avx512 => "AVX-512",
            #[cfg(target_arch = "x86_64")]
            Path::Avx2 => "AVX2",
            Path::Portable => "portable",
        }
    }

    /// `out.len() / LANES` normals per lane into `out[r · LANES + j]` (row `r`, lane `j`):
    /// lane `j`'s numbers are `rand_distr::StandardNormal` from `Xoshiro256PlusPlus`
    /// seeded with `seed + j`.
    pub fn fill(&mut self, out: &mut [f64]) {
        fill(&mut self.rng, out.len() / LANES, out);
    }
}

/// Draws `rows` normals per lane into `out[r · LANES + j]` (row `r`, lane `j`), lane `j`
/// from `rng[j]` in row order: the numbers `StandardNormal.sample(&mut rng[j])` would give.
pub(crate) fn fill(rng: &mut [Xoshiro; LANES], rows: usize, out: &mut [f64]) {
    match Path::of_this_cpu() {
        // SAFETY: `of_this_cpu` chose it because the CPU has AVX-512F.
        #[cfg(target_arch = "x86_64")]
        Path::Avx512 => unsafe { avx512::fill_lanes(rng, rows, out, &LAYERS) },
        // SAFETY: `of_this_cpu` chose it because the CPU has AVX2.
        #[cfg(target_arch = "x86_64")]
        Path::Avx2 => unsafe { avx2::fill_lanes(rng, rows, out, &LAYERS) },
        Path::Portable => fill_lanes(rng, rows, out, &LAYERS),
    }
}

/// Which of [`fill_lanes`]'s versions draws: the widest the CPU runs.
enum Path {
    #[cfg(target_arch = "x86_64")]
    Avx512,
    #[cfg(target_arch = "x86_64")]
    Avx2,
    Portable,
}

impl Path {
    fn of_this_cpu() -> Path {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            return Path::Avx512;
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            return Path::Avx2;
        }
        Path::Portable
    }
}

#[multiversion(targets(
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
    "x86_64+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
))]
fn fill_lanes(rng: &mut [Xoshiro; LANES], rows: usize, out: &mut [f64], layers: &[[f64; 2]; 256]) {
    let mut s: [[u64; LANES]; 4] = by_word(rng);
    let out = &mut out[..rows * LANES];
    let mut edge = [0.0f64; LANES];
    for row in out.chunks_exact_mut(LANES) {
        let [s0, s1, s2, s3] = &mut s;
        for j in 0..LANES {
            let bits = s0[j].wrapping_add(s3[j]).rotate_left(23).wrapping_add(s0[j]);
            let t = s1[j] << 17;
            s2[j] ^= s0[j];
            s3[j] ^= s1[j];
            s1[j] ^= s2[j];
            s0[j] ^= s3[j];
            s2[j] ^= t;
            s3[j] = s3[j].rotate_left(45);
            // rand_distr's fast path: layer i from the low 8 bits, u in [−1, 1) from the
            // high 52 (the float with exponent 1, i.e. in [2, 4), minus 3).
            let [xi, next] = layers[(bits & 0xff) as usize];
            let u = f64::from_bits((bits >> 12) | (1024 << 52)) - 3.0;
            row[j] = u * xi;
            edge[j] = next;
        }
        let mut slow = 0u32;
        for j in 0..LANES {
            // The fast path accepts |x| < x_(i+1) (every draw here is finite).
            slow |= u32::from(row[j].abs() >= edge[j]) << j;
        }
        if slow != 0 {
            slow_path(&mut s, slow, row);
        }
    }
    set_by_word(rng, &s);
}

/// The states of `rng`'s first `N` generators as four arrays over them, one per state word
/// (struct of arrays, so a step is vector arithmetic across lanes).
#[inline(always)]
fn by_word<const N: usize>(rng: &[Xoshiro]) -> [[u64; N]; 4] {
    let mut s = [[0; N]; 4];
    for (j, r) in rng[..N].iter().enumerate() {
        for w in 0..4 {
            s[w][j] = r.s[w];
        }
    }
    s
}

/// [`by_word`] undone: `s`'s states back into `rng`'s first `N` generators.
#[inline(always)]
fn set_by_word<const N: usize>(rng: &mut [Xoshiro], s: &[[u64; N]; 4]) {
    for (j, r) in rng[..N].iter_mut().enumerate() {
        for w in 0..4 {
            r.s[w] = s[w][j];
        }
    }
}

/// [`fill_lanes`] in AVX2 by hand: the same numbers, about 1.3× the rate. Eight lanes at
/// a time go through all the rows, their generators' four state words in eight vector
/// registers (the compiler, given all 32 lanes or eight, keeps the states in memory and
/// draws part of the lanes one by one); a ziggurat layer's two edges are one 16-byte load
/// per lane.
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{by_word, set_by_word, slow_path, Xoshiro, CHUNK, LANES};
    use std::arch::x86_64::*;

    /// Four lanes' generator states, one vector per state word.
    type State = [__m256i; 4];

    #[inline(always)]
    unsafe fn rotl<const L: i32, const R: i32>(x: __m256i) -> __m256i {
        _mm256_or_si256(_mm256_slli_epi64::<L>(x), _mm256_srli_epi64::<R>(x))
    }

    /// One xoshiro256++ step of four lanes: their outputs.
    #[inline(always)]
    unsafe fn step(s: &mut State) -> __m256i {
        let [s0, s1, s2, s3] = *s;
        let out = _mm256_add_epi64(rotl::<23, 41>(_mm256_add_epi64(s0, s3)), s0);
        let t = _mm256_slli_epi64::<17>(s1);
        let s2 = _mm256_xor_si256(s2, s0);
        let s3 = _mm256_xor_si256(s3, s1);
        let s1 = _mm256_xor_si256(s1, s2);
        let s0 = _mm256_xor_si256(s0, s3);
        *s = [s0, s1, _mm256_xor_si256(s2, t), rotl::<45, 19>(s3)];
        out
    }

    /// Four lanes' fast-path draws from their outputs `bits`, and the mask of those outside
    /// the fast path (bit `j` for lane `j`).
    #[inline(always)]
    unsafe fn draw(bits: __m256i, layers: &[[f64; 2]; 256]) -> (__m256d, i32) {
        let mut idx = [0u64; 4];
        _mm256_storeu_si256(
            idx.as_mut_ptr().cast(),
            _mm256_and_si256(bits, _mm256_set1_epi64x(0xff)),
        );
        let pair = |j: usize| _mm_loadu_pd(layers[idx[j] as usize].as_ptr());
        let (a, b) = (_mm256_set_m128d(pair(2), pair(0)), _mm256_set_m128d(pair(3), pair(1)));
        let (xi, next) = (_mm256_unpacklo_pd(a, b), _mm256_unpackhi_pd(a, b));
        let one = _mm256_or_si256(_mm256_srli_epi64::<12>(bits), _mm256_set1_epi64x(1024 << 52));
        let u = _mm256_sub_pd(_mm256_castsi256_pd(one), _mm256_set1_pd(3.0));
        let x = _mm256_mul_pd(u, xi);
        let abs = _mm256_andnot_pd(_mm256_set1_pd(-0.0), x);
        (x, _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_GE_OQ>(abs, next)))
    }

    /// See [`super::fill_lanes`].
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn fill_lanes(
        rng: &mut [Xoshiro; LANES],
        rows: usize,
        out: &mut [f64],
        layers: &[[f64; 2]; 256],
    ) {
        let out = &mut out[..rows * LANES];
        for h0 in (0..LANES).step_by(CHUNK) {
            let mut s: [[u64; CHUNK]; 4] = by_word(&rng[h0..]);
            let mut lo: State = std::array::from_fn(|w| _mm256_loadu_si256(s[w].as_ptr().cast()));
            let mut hi: State = std::array::from_fn(|w| _mm256_loadu_si256(s[w][4..].as_ptr().cast()));
            for row in out.chunks_exact_mut(LANES) {
                let row: &mut [f64; CHUNK] = (&mut row[h0..h0 + CHUNK]).try_into().expect("a chunk");
                let (x0, m0) = draw(step(&mut lo), layers);
                let (x1, m1) = draw(step(&mut hi), layers);
                _mm256_storeu_pd(row.as_mut_ptr(), x0);
                _mm256_storeu_pd(row.as_mut_ptr().add(4), x1);
                let slow = (m0 | m1 << 4) as u32;
                if slow != 0 {
                    for w in 0..4 {
                        _mm256_storeu_si256(s[w].as_mut_ptr().cast(), lo[w]);
                        _mm256_storeu_si256(s[w][4..].as_mut_ptr().cast(), hi[w]);
                    }
                    slow_path(&mut s, slow, row);
                    for w in 0..4 {
                        lo[w] = _mm256_loadu_si256(s[w].as_ptr().cast());
                        hi[w] = _mm256_loadu_si256(s[w][4..].as_ptr().cast());
                    }
                }
            }
            for w in 0..4 {
                _mm256_storeu_si256(s[w].as_mut_ptr().cast(), lo[w]);
                _mm256_storeu_si256(s[w][4..].as_mut_ptr().cast(), hi[w]);
            }
            set_by_word(&mut rng[h0..], &s);
        }
    }
}

/// [`fill_lanes`] in AVX-512 by hand: [`avx2`]'s steps eight lanes to a register, with the
/// rotations in one instruction, a ziggurat layer's two edges gathered for eight lanes at
/// once and the fast path's test a mask. Sixteen lanes at a time go through all the rows
/// (two registers per state word, for two independent chains of steps).
#[cfg(target_arch = "x86_64")]
mod avx512 {
    use super::{by_word, set_by_word, slow_path, Xoshiro, LANES};
    use std::arch::x86_64::*;

    /// Lanes stepped together through all the rows.
    const CHUNK: usize = 16;
    const _: () = assert!(LANES.is_multiple_of(CHUNK));

    /// Eight lanes' generator states, one vector per state word.
    type State = [__m512i; 4];

    /// One xoshiro256++ step of eight lanes: their outputs.
    #[inline(always)]
    unsafe fn step(s: &mut State) -> __m512i {
        let [s0, s1, s2, s3] = *s;
        let out = _mm512_add_epi64(_mm512_rol_epi64::<23>(_mm512_add_epi64(s0, s3)), s0);
        let t = _mm512_slli_epi64::<17>(s1);
        let s2 = _mm512_xor_si512(s2, s0);
        let s3 = _mm512_xor_si512(s3, s1);
        let s1 = _mm512_xor_si512(s1, s2);
        let s0 = _mm512_xor_si512(s0, s3);
        *s = [s0, s1, _mm512_xor_si512(s2, t), _mm512_rol_epi64::<45>(s3)];
        out
    }

    /// Eight lanes' fast-path draws from their outputs `bits`, and the mask of those outside
    /// the fast path (bit `j` for lane `j`). `layers` is the table of layer edges as
    /// `[x_k, x_(k+1)]` pairs, flat: the gathers read its values `2k` and `2k + 1` for
    /// `k < 256`, inside its 512. (Gathered, the edges come 1.2× faster on an Intel Xeon
    /// than loaded pair by pair and shuffled into place as [`super::avx2`] does.)
    #[inline(always)]
    unsafe fn draw(bits: __m512i, layers: *const f64) -> (__m512d, u8) {
        let k = _mm512_slli_epi64::<1>(_mm512_and_si512(bits, _mm512_set1_epi64(0xff)));
        let xi = _mm512_i64gather_pd::<8>(k, layers);
        let next = _mm512_i64gather_pd::<8>(k, layers.add(1));
        let one = _mm512_or_si512(_mm512_srli_epi64::<12>(bits), _mm512_set1_epi64(1024 << 52));
        let u = _mm512_sub_pd(_mm512_castsi512_pd(one), _mm512_set1_pd(3.0));
        let x = _mm512_mul_pd(u, xi);
        (x, _mm512_cmp_pd_mask::<_CMP_GE_OQ>(_mm512_abs_pd(x), next))
    }

    /// See [`super::fill_lanes`].
    ///
    /// # Safety
    /// The CPU must have AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn fill_lanes(
        rng: &mut [Xoshiro; LANES],
        rows: usize,
        out: &mut [f64],
        layers: &[[f64; 2]; 256],
    ) {
        let table = layers.as_ptr().cast::<f64>();
        let out = &mut out[..rows * LANES];
        for h0 in (0..LANES).step_by(CHUNK) {
            let mut s: [[u64; CHUNK]; 4] = by_word(&rng[h0..]);
            let mut lo: State = std::array::from_fn(|w| _mm512_loadu_si512(s[w].as_ptr().cast()));
            let mut hi: State = std::array::from_fn(|w| _mm512_loadu_si512(s[w][8..].as_ptr().cast()));
            for row in out.chunks_exact_mut(LANES) {
                let row: &mut [f64; CHUNK] = (&mut row[h0..h0 + CHUNK]).try_into().expect("a chunk");
                let (x0, m0) = draw(step(&mut lo), table);
                let (x1, m1) = draw(step(&mut hi), table);
                _mm512_storeu_pd(row.as_mut_ptr(), x0);
                _mm512_storeu_pd(row.as_mut_ptr().add(8), x1);
                let slow = u32::from(m0) | u32::from(m1) << 8;
                if slow != 0 {
                    for w in 0..4 {
                        _mm512_storeu_si512(s[w].as_mut_ptr().cast(), lo[w]);
                        _mm512_storeu_si512(s[w][8..].as_mut_ptr().cast(), hi[w]);
                    }
                    slow_path(&mut s, slow, row);
                    for w in 0..4 {
                        lo[w] = _mm512_loadu_si512(s[w].as_ptr().cast());
                        hi[w] = _mm512_loadu_si512(s[w][8..].as_ptr().cast());
                    }
                }
            }
            for w in 0..4 {
                _mm512_storeu_si512(s[w].as_mut_ptr().cast(), lo[w]);
                _mm512_storeu_si512(s[w][8..].as_mut_ptr().cast(), hi[w]);
            }
            set_by_word(&mut rng[h0..], &s);
        }
    }
}

/// Lanes the AVX2 generator steps together through all the rows.
const CHUNK: usize = 8;
const _: () = assert!(LANES.is_multiple_of(CHUNK));

/// The draws of the lanes in `slow` (bit `j` for lane `j` of `row`) that fell outside the
/// ziggurat's fast path, drawn again by `rand_distr` from the state before that draw; `s`
/// holds the `N` lanes' states (one array per state word) and gets the states after.
#[cold]
#[inline(never)]
fn slow_path<const N: usize>(s: &mut [[u64; N]; 4], mut slow: u32, row: &mut [f64]) {
    while slow != 0 {
        let j = slow.trailing_zeros() as usize;
        slow &= slow - 1;
        let mut r = Xoshiro {
            s: Xoshiro::unstep([s[0][j], s[1][j], s[2][j], s[3][j]]),
        };
        row[j] = StandardNormal.sample(&mut r);
        for w in 0..4 {
            s[w][j] = r.s[w];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::Xoshiro256PlusPlus;
    use rand::Rng;

    #[test]
    fn the_generator_is_rands_xoshiro256plusplus() {
        for seed in [0, 1, 2024, u64::MAX] {
            let (mut a, mut b) = (Xoshiro::seed_from_u64(seed), Xoshiro256PlusPlus::seed_from_u64(seed));
            for _ in 0..10_000 {
                assert_eq!(a.next_u64(), b.next_u64());
            }
        }
    }

    #[test]
    fn a_step_undone() {
        let mut r = Xoshiro::seed_from_u64(7);
        for _ in 0..1000 {
            let before = r.s;
            Xoshiro::step(&mut r.s);
            assert_eq!(Xoshiro::unstep(r.s), before);
        }
    }

    /// A generator of the lanes' normals: `fill`'s signature.
    type Fill = fn(&mut [Xoshiro; LANES], usize, &mut [f64]);

    /// The generator this CPU uses ([`fill`]), the portable one and each hand-vectorised one
    /// the CPU can run.
    fn generators() -> Vec<(&'static str, Fill)> {
        let mut all: Vec<(&'static str, Fill)> = vec![
            ("fill", fill),
            ("portable", |rng, rows, out| fill_lanes(rng, rows, out, &LAYERS)),
        ];
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2 (checked just above).
            all.push(("avx2", |rng, rows, out| unsafe {
                avx2::fill_lanes(rng, rows, out, &LAYERS)
            }));
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F (checked just above).
            all.push(("avx512", |rng, rows, out| unsafe {
                avx512::fill_lanes(rng, rows, out, &LAYERS)
            }));
        }
        all
    }

    #[test]
    fn lanes_draw_rand_distrs_normals_bit_for_bit() {
        for (name, fill) in generators() {
            lanes_draw_rand_distrs_normals(name, fill);
        }
    }

    fn lanes_draw_rand_distrs_normals(name: &str, fill: Fill) {
        // Enough rows that every slow path (the wedges and the tail beyond x_1) is taken.
        let rows = 20_000;
        let seeds = |l: usize| 0x5eed ^ (l as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        let mut rng: [Xoshiro; LANES] = std::array::from_fn(|l| Xoshiro::seed_from_u64(seeds(l)));
        let mut out = vec![0.0; rows * LANES];
        // In two calls, as the simulator's blocks do.
        fill(&mut rng, rows / 2, &mut out);
        fill(&mut rng, rows / 2, &mut out[rows / 2 * LANES..]);
        let mut tails = 0;
        for j in 0..LANES {
            let mut reference = Xoshiro256PlusPlus::seed_from_u64(seeds(j));
            for r in 0..rows {
                let z: f64 = StandardNormal.sample(&mut reference);
                assert_eq!(out[r * LANES + j].to_bits(), z.to_bits(), "{name}: lane {j}, row {r}");
                tails += usize::from(z.abs() > LAYERS[1][0]);
            }
            // The state after the run is the reference's.
            assert_eq!(rng[j].next_u64(), reference.next_u64());
        }
        assert!(tails > 10, "{name}: the tail beyond x_1 was drawn {tails} times");
    }
}
