//! Multivariate polynomials over the state variables, exact enough to assemble the
//! generator `𝒜ψ` of a polynomial drift on polynomial test functions.
//!
//! A monomial is a packed exponent vector ([`Exponents`], 5 bits per variable, at most 25
//! variables, exponents ≤ [`MAX_EXPONENT`]: a stiffness power 15 on a degree-16 test function
//! needs 30); a polynomial is a sorted map from monomials to coefficients.

use multiversion::multiversion;
use std::collections::BTreeMap;

/// Packed exponents, 5 bits per variable (variable `j` in bits `5j..5j+5`).
pub type Exponents = u128;

/// Bits per variable in [`Exponents`].
const BITS: usize = 5;

/// Largest number of state variables a monomial can hold.
pub const MAX_VARS: usize = 128 / BITS;

/// Largest exponent of one variable in a monomial.
pub const MAX_EXPONENT: u32 = (1 << BITS) - 1;

/// Exponent of variable `j`.
#[inline]
pub fn exponent(e: Exponents, j: usize) -> u32 {
    ((e >> (BITS * j)) & MAX_EXPONENT as u128) as u32
}

/// Total degree.
pub fn degree(e: Exponents) -> u32 {
    (0..MAX_VARS).map(|j| exponent(e, j)).sum()
}

/// The monomial `y_j`.
pub fn var(j: usize) -> Exponents {
    1 << (BITS * j)
}

/// A polynomial `Σ c_β y^β`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Poly {
    pub terms: BTreeMap<Exponents, f64>,
}

impl Poly {
    pub fn zero() -> Poly {
        Poly::default()
    }
    pub fn constant(c: f64) -> Poly {
        Poly::monomial(0, c)
    }
    pub fn monomial(e: Exponents, c: f64) -> Poly {
        let mut p = Poly::zero();
        p.add_term(e, c);
        p
    }
    /// `Σ_j coef_j y_j`.
    pub fn linear(coefs: &[(usize, f64)]) -> Poly {
        let mut p = Poly::zero();
        for &(j, c) in coefs {
            p.add_term(var(j), c);
        }
        p
    }
    pub fn add_term(&mut self, e: Exponents, c: f64) {
        if c != 0.0 {
            *self.terms.entry(e).or_insert(0.0) += c;
        }
    }
    pub fn add(&mut self, other: &Poly, scale: f64) {
        for (&e, &c) in &other.terms {
            self.add_term(e, scale * c);
        }
    }
    pub fn mul(&self, other: &Poly) -> Poly {
        let mut p = Poly::zero();
        for (&a, &ca) in &self.terms {
            for (&b, &cb) in &other.terms {
                // No carries: callers keep every exponent ≤ MAX_EXPONENT.
                debug_assert!((0..MAX_VARS).all(|j| exponent(a, j) + exponent(b, j) <= MAX_EXPONENT));
                p.add_term(a + b, ca * cb);
            }
        }
        p
    }
    pub fn pow(&self, n: u32) -> Poly {
        let mut p = Poly::constant(1.0);
        for _ in 0..n {
            p = p.mul(self);
        }
        p
    }
    /// `∂/∂y_j`.
    pub fn derivative(&self, j: usize) -> Poly {
        let mut p = Poly::zero();
        for (&e, &c) in &self.terms {
            let k = exponent(e, j);
            if k > 0 {
                p.add_term(e - var(j), c * k as f64);
            }
        }
        p
    }
    pub fn degree(&self) -> u32 {
        self.terms.keys().map(|&e| degree(e)).max().unwrap_or(0)
    }
    /// Value at `y`.
    pub fn eval(&self, y: &[f64]) -> f64 {
        self.terms
            .iter()
            .map(|(&e, &c)| {
                let mut m = 1.0;
                for (j, &x) in y.iter().enumerate() {
                    let p = exponent(e, j);
                    if p > 0 {
                        m *= powi(x, p);
                    }
                }
                c * m
            })
            .sum()
    }
    /// `E[p(Y)]` from raw moments `E[Y^β]`.
    pub fn expectation(&self, moment: impl Fn(Exponents) -> f64) -> f64 {
        self.terms.iter().map(|(&e, &c)| c * moment(e)).sum()
    }
}

/// Polynomials compiled for evaluation in per-sample loops: every distinct power of a
/// variable once, every distinct monomial once as a product of those powers, then each
/// polynomial as a sum over its monomials. The values are those of [`Poly::eval`], bit for
/// bit (the same products and sums in the same order).
#[derive(Debug, Clone)]
pub struct Compiled {
    /// Distinct (variable, power) factors.
    powers: Vec<(usize, u32)>,
    /// Per monomial `k`, its factors (indices into `powers`) are
    /// `factors[monomial_ends[k − 1]..monomial_ends[k]]`, by variable.
    factors: Vec<usize>,
    monomial_ends: Vec<usize>,
    /// Per polynomial `i`, its terms (coefficient, monomial) are
    /// `terms[poly_ends[i − 1]..poly_ends[i]]`, in [`Poly::terms`] order.
    terms: Vec<(f64, usize)>,
    poly_ends: Vec<usize>,
    power_values: Vec<f64>,
    monomial_values: Vec<f64>,
    /// Scratch of [`Compiled::eval_block`]: per power, then per monomial, a value per lane.
    block_values: Vec<f64>,
}

impl Compiled {
    pub fn new<'a>(polys: impl IntoIterator<Item = &'a Poly>) -> Compiled {
        let mut keys: Vec<Exponents> = Vec::new();
        let (mut terms, mut poly_ends) = (Vec::new(), Vec::new());
        for p in polys {
            for (&e, &c) in &p.terms {
                let k = keys.iter().position(|&x| x == e).unwrap_or_else(|| {
                    keys.push(e);
                    keys.len() - 1
                });
                terms.push((c, k));
            }
            poly_ends.push(terms.len());
        }
        let (mut powers, mut factors, mut monomial_ends) = (Vec::new(), Vec::new(), Vec::new());
        for &e in &keys {
            for j in (0..MAX_VARS).filter(|&j| exponent(e, j) > 0) {
                let f = (j, exponent(e, j));
                let at = powers.iter().position(|&x| x == f).unwrap_or_else(|| {
                    powers.push(f);
                    powers.len() - 1
                });
                factors.push(at);
            }
            monomial_ends.push(factors.len());
        }
        Compiled {
            power_values: vec![0.0; powers.len()],
            monomial_values: vec![0.0; keys.len()],
            block_values: Vec::new(),
            powers,
            factors,
            monomial_ends,
            terms,
            poly_ends,
        }
    }

    /// Number of polynomials.
    pub fn len(&self) -> usize {
        self.poly_ends.len()
    }

    pub fn is_empty(&self) -> bool {
        self.poly_ends.is_empty()
    }

    /// Every polynomial at `y`, into `out` (one value per polynomial).
    #[inline]
    pub fn eval(&mut self, y: &[f64], out: &mut [f64]) {
        for (v, &(j, p)) in self.power_values.iter_mut().zip(&self.powers) {
            *v = powi(y[j], p);
        }
        let mut from = 0;
        for (v, &end) in self.monomial_values.iter_mut().zip(&self.monomial_ends) {
            *v = self.factors[from..end].iter().map(|&f| self.power_values[f]).product();
            from = end;
        }
        let values = &self.monomial_values;
        let mut from = 0;
        for (o, &end) in out.iter_mut().zip(&self.poly_ends) {
            *o = self.terms[from..end].iter().map(|&(c, k)| c * values[k]).sum::<f64>();
            from = end;
        }
    }
}

impl Compiled {
    /// Every polynomial at `lanes` states at once, the same numbers as [`Compiled::eval`]
    /// bit for bit: `ys[j * lanes + l]` is variable `j` of state `l`, and polynomial `i` at
    /// state `l` goes to `out[i * lanes + l]`. Each step runs along the lanes, which the
    /// compiler vectorises (per sample, [`Compiled::eval`] is bound by its indexing).
    pub fn eval_block(&mut self, ys: &[f64], lanes: usize, out: &mut [f64]) {
        let need = (self.powers.len() + self.monomial_ends.len()) * lanes;
        if self.block_values.len() < need {
            self.block_values.resize(need, 0.0);
        }
        let mut values = std::mem::take(&mut self.block_values);
        eval_lanes(self, ys, lanes, &mut values[..need], out);
        self.block_values = values;
    }
}

/// [`Compiled::eval_block`]'s steps into `values` (the powers' lanes, then the
/// monomials'), compiled for the widest vector unit the CPU has: the same operations in
/// the same order on every CPU, so the same bits.
#[multiversion(targets(
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
    "x86_64+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
))]
fn eval_lanes(c: &Compiled, ys: &[f64], lanes: usize, values: &mut [f64], out: &mut [f64]) {
    let (pv, mv) = values.split_at_mut(c.powers.len() * lanes);
    for (v, &(j, p)) in pv.chunks_exact_mut(lanes).zip(&c.powers) {
        for (v, &x) in v.iter_mut().zip(&ys[j * lanes..(j + 1) * lanes]) {
            *v = powi(x, p);
        }
    }
    let mut from = 0;
    for (v, &end) in mv.chunks_exact_mut(lanes).zip(&c.monomial_ends) {
        // `Iterator::product` of the factors: 1 times each in turn.
        v.fill(1.0);
        for &f in &c.factors[from..end] {
            for (v, &x) in v.iter_mut().zip(&pv[f * lanes..(f + 1) * lanes]) {
                *v *= x;
            }
        }
        from = end;
    }
    let mut from = 0;
    for (o, &end) in out.chunks_exact_mut(lanes).zip(&c.poly_ends) {
        // `Iterator::sum` of the terms: from −0, each in turn.
        o.fill(-0.0);
        for &(coefficient, k) in &c.terms[from..end] {
            for (o, &m) in o.iter_mut().zip(&mv[k * lanes..(k + 1) * lanes]) {
                *o += coefficient * m;
            }
        }
        from = end;
    }
}

/// `x^p` by repeated squaring, as `f64::powi` computes it (the same products in the same
/// order, so the same bits), inlined: evaluations sit in per-sample loops.
#[inline]
pub(crate) fn powi(mut x: f64, mut p: u32) -> f64 {
    let mut r = 1.0;
    loop {
        if p & 1 == 1 {
            r *= x;
        }
        p /= 2;
        if p == 0 {
            return r;
        }
        x *= x;
    }
}

/// Every monomial in `vars` variables of total degree `1..=max_degree`, by degree then
/// lexicographically.
pub fn monomials(vars: usize, max_degree: u32) -> Vec<Exponents> {
    let mut out: Vec<Exponents> = vec![0];
    let mut frontier: Vec<Exponents> = vec![0];
    for _ in 0..max_degree {
        let mut next = Vec::new();
        for &e in &frontier {
            // Raise variables at or after the last one raised, so each monomial appears once.
            let last = (0..vars).rev().find(|&j| exponent(e, j) > 0).unwrap_or(0);
            for j in last..vars {
                next.push(e + var(j));
            }
        }
        out.extend(&next);
        frontier = next;
    }
    out.remove(0);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compiled_polynomials_evaluate_as_poly_eval() {
        let (a, b) = (
            Poly::linear(&[(0, 1.5), (2, -2.0)]),
            Poly::monomial(var(1) * 3 + var(2), 0.25),
        );
        let c = a.mul(&b).pow(2);
        let polys = [a, b, c, Poly::zero(), Poly::constant(3.0)];
        let mut compiled = Compiled::new(&polys);
        let mut out = [0.0; 5];
        let states = [[0.3, -1.2, 2.5], [-0.7, 0.0, 1e3], [-0.0, 2.0, -0.0], [0.0, -0.0, 0.0]];
        for y in states {
            compiled.eval(&y, &mut out);
            for (o, p) in out.iter().zip(&polys) {
                assert_eq!(o.to_bits(), p.eval(&y).to_bits());
            }
        }
        // A block of the states, variable-major; the same bits per lane.
        let lanes = states.len();
        let ys: Vec<f64> = (0..3).flat_map(|j| states.iter().map(move |y| y[j])).collect();
        let mut block = vec![f64::NAN; polys.len() * lanes];
        compiled.eval_block(&ys, lanes, &mut block);
        for (l, y) in states.iter().enumerate() {
            for (i, p) in polys.iter().enumerate() {
                assert_eq!(
                    block[i * lanes + l].to_bits(),
                    p.eval(y).to_bits(),
                    "lane {l}, polynomial {i}"
                );
            }
        }
    }
}
