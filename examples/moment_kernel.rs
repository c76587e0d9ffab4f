//! Time the raw-moment kernel alone (profiling aid):
//! `cargo run --release --example moment_kernel`.
use fpkbench::ident::moments::RawMoments;
use fpkbench::ident::poly::monomials;
fn main() {
    let n = 4_000_000;
    let mut state = 1u64;
    let rows: Vec<f64> = (0..4 * n)
        .map(|_| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect();
    let wanted: Vec<_> = monomials(4, 6).into_iter().take(158).collect();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    for _ in 0..3 {
        let t = std::time::Instant::now();
        let mut m = RawMoments::with_monomials(4, 6, &wanted);
        pool.install(|| m.add_block(&rows));
        let s = t.elapsed().as_secs_f64();
        println!(
            "{} monomials: {:.3e} samples/s ({:.2} ns per sample-monomial)",
            m.monomials().len() - 1,
            n as f64 / s,
            s / n as f64 / (m.monomials().len() - 1) as f64 * 1e9
        );
    }
}
