//! Multivariate polynomials over the state variables, exact enough to assemble the
//! generator `𝒜ψ` of a polynomial drift on polynomial test functions.
//!
//! A monomial is a packed exponent vector ([`Exponents`], 8 bits per variable, at most 16
//! variables, exponents ≤ 255: a stiffness power 15 on a degree-4 test function needs 19); a polynomial is a sorted map from monomials to coefficients.

use std::collections::BTreeMap;

/// Packed exponents, 8 bits per variable (variable `j` in bits `8j..8j+8`).
pub type Exponents = u128;

/// Largest number of state variables a monomial can hold.
pub const MAX_VARS: usize = 16;

/// Exponent of variable `j`.
#[inline]
pub fn exponent(e: Exponents, j: usize) -> u32 {
    ((e >> (8 * j)) & 0xff) as u32
}

/// Total degree.
pub fn degree(e: Exponents) -> u32 {
    (0..MAX_VARS).map(|j| exponent(e, j)).sum()
}

/// The monomial `y_j`.
pub fn var(j: usize) -> Exponents {
    1 << (8 * j)
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
                // No carries: callers keep every exponent ≤ 255.
                debug_assert!((0..MAX_VARS).all(|j| exponent(a, j) + exponent(b, j) <= 255));
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
