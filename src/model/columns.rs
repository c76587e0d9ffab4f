//! The log's column layout: the one place that knows where a mass's displacement,
//! velocity and acceleration and an excitation's force sit in a sample, what the columns
//! are called and in which units they are measured.
//!
//! A sample has `3n + e` values for `n` masses and `e` excitations: `x_<mass>`,
//! `v_<mass>`, `a_<mass>` for every mass in order, then `p_<excitation>` for every
//! excitation (`docs/log-format.md`).

use crate::scenario::Motion;

/// The physical quantity of a column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    Displacement,
    Velocity,
    Acceleration,
    Force,
}

impl Quantity {
    /// The column name's prefix: `x`, `v`, `a` or `p`.
    pub fn symbol(self) -> char {
        match self {
            Quantity::Displacement => 'x',
            Quantity::Velocity => 'v',
            Quantity::Acceleration => 'a',
            Quantity::Force => 'p',
        }
    }

    /// Its unit for translational or rotational coordinates.
    pub fn unit(self, motion: Motion) -> &'static str {
        let u = motion.units();
        match self {
            Quantity::Displacement => u[0],
            Quantity::Velocity => u[1],
            Quantity::Acceleration => u[2],
            Quantity::Force => u[3],
        }
    }

    /// The column name of this quantity of the mass or excitation `owner`, e.g. `x_m1`.
    pub fn column_name(self, owner: &str) -> String {
        format!("{}_{owner}", self.symbol())
    }
}

/// Where each value of a sample sits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Columns {
    masses: usize,
    excitations: usize,
}

impl Columns {
    pub fn new(masses: usize, excitations: usize) -> Columns {
        Columns { masses, excitations }
    }
    /// Values per sample.
    pub fn len(&self) -> usize {
        3 * self.masses + self.excitations
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Column of the displacement of mass `i`.
    pub fn x(&self, i: usize) -> usize {
        3 * i
    }
    /// Column of the velocity of mass `i`.
    pub fn v(&self, i: usize) -> usize {
        3 * i + 1
    }
    /// Column of the acceleration of mass `i`.
    pub fn a(&self, i: usize) -> usize {
        3 * i + 2
    }
    /// The columns of `x`, `v` and `a` of mass `i`, which are contiguous.
    pub fn kinematics(&self, i: usize) -> std::ops::Range<usize> {
        self.x(i)..self.a(i) + 1
    }
    /// Column of quantity `q` of mass `i` (displacement, velocity or acceleration).
    pub fn of_mass(&self, q: Quantity, i: usize) -> usize {
        match q {
            Quantity::Displacement => self.x(i),
            Quantity::Velocity => self.v(i),
            Quantity::Acceleration => self.a(i),
            Quantity::Force => panic!("a force belongs to an excitation, not to a mass"),
        }
    }
    /// Column of the force of excitation `e`.
    pub fn force(&self, e: usize) -> usize {
        3 * self.masses + e
    }
    /// What column `c` holds: the quantity and the mass (or, for a force, the excitation)
    /// it belongs to.
    pub fn at(&self, c: usize) -> (Quantity, usize) {
        if c < 3 * self.masses {
            let q = [Quantity::Displacement, Quantity::Velocity, Quantity::Acceleration][c % 3];
            (q, c / 3)
        } else {
            assert!(c < self.len(), "column {c} of {}", self.len());
            (Quantity::Force, c - 3 * self.masses)
        }
    }
    /// Every column's name, in order, given the masses' and excitations' names.
    pub fn names(&self, masses: &[String], excitations: &[String]) -> Vec<String> {
        debug_assert_eq!((masses.len(), excitations.len()), (self.masses, self.excitations));
        let mut c = Vec::with_capacity(self.len());
        for m in masses {
            for q in [Quantity::Displacement, Quantity::Velocity, Quantity::Acceleration] {
                c.push(q.column_name(m));
            }
        }
        for e in excitations {
            c.push(Quantity::Force.column_name(e));
        }
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_column_says_what_it_holds() {
        let c = Columns::new(3, 2);
        for i in 0..3 {
            for q in [Quantity::Displacement, Quantity::Velocity, Quantity::Acceleration] {
                assert_eq!(c.at(c.of_mass(q, i)), (q, i));
            }
        }
        for e in 0..2 {
            assert_eq!(c.at(c.force(e)), (Quantity::Force, e));
        }
    }
}
