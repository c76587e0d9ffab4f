//! Which systems have a stationary density, and which unknowns data can separate: the
//! physics the method assumes (docs/theory.md §1, the paper's dissipativity (3.4)),
//! decided from the system's structure alone. The reasons are typed; `scenario::validate`
//! maps each onto the place in the file that causes it.

use super::{Characteristic as Kind, Term};
use crate::scenario::{End, IdentifyLink, Link, Mass};
use std::collections::BTreeMap;

/// Why a system has no stationary density.
#[derive(Debug, Clone, PartialEq)]
pub enum NotStationary {
    /// Mass `mass` is joined to the ground by no spring: its displacement wanders.
    NoSpringPath { mass: usize },
    /// No link dissipates energy.
    NoDamping,
    /// The characteristic of link `link`'s pair of ends has its leading term `term` even,
    /// or odd with a negative coefficient, and no other pair of the same or a higher degree
    /// bounds the motion it stretches.
    Unbounded {
        link: usize,
        kind: Kind,
        term: Term,
        coefficient: f64,
    },
}

impl NotStationary {
    /// The physics, in words, for the system of `masses` and `links`.
    pub fn describe(&self, masses: &[Mass], links: &[Link]) -> String {
        match *self {
            NotStationary::NoSpringPath { mass } => format!(
                "mass {:?} has no spring path to ground: its displacement wanders without bound and has no \
                 stationary density, which the method assumes. Add a stiffness to a link that connects it",
                masses[mass].name
            ),
            NotStationary::NoDamping => "no link has a damping: the excitation's energy is never dissipated, the \
                                         response grows without bound and has no stationary density. Add a damping \
                                         to some link"
                .into(),
            NotStationary::Unbounded {
                link,
                kind,
                term,
                coefficient,
            } => {
                let why = match kind {
                    Kind::Stiffness => {
                        "the potential is unbounded below, so the response escapes and has no stationary density"
                    }
                    Kind::Damping => {
                        "C(w)·w is negative at large speeds, so energy is pumped in and the response has no \
                         stationary density"
                    }
                };
                let how = if let Term::Hinge(a) = term {
                    format!(
                        "its leading term, the {}, acts on the side {} 0 only and nothing bounds the other",
                        term.describe(),
                        if a.get() > 0.0 { ">" } else { "<" }
                    )
                } else if coefficient == 0.0 {
                    format!(
                        "its leading {} has the coefficient 0, and nothing holds it",
                        term.describe()
                    )
                } else if !term.is_odd() {
                    format!("its highest {} is even", term.describe())
                } else {
                    format!(
                        "its highest {} has a negative coefficient {coefficient}",
                        term.describe()
                    )
                };
                format!(
                    "the {} between the ends of link {:?}: {how}: {why}, which the method assumes. The leading \
                     term must push back on both sides: an odd power, or abs<p>, sign, gap or tanh, with a positive \
                     coefficient",
                    kind.name(),
                    links[link].name
                )
            }
        }
    }
}

/// Whether the system of `masses` and `links` has a stationary density: every mass joined
/// to the ground by springs, some damping, and every pair of ends' combined characteristic
/// with an odd highest power of positive coefficient where nothing else bounds it (3.4).
/// `unknown(l)` says whether link `l`'s stiffness and damping are to be identified without
/// values (a model file), whose signs the data will tell.
pub fn stationary(
    masses: &[Mass],
    links: &[Link],
    unknown: impl Fn(usize) -> (bool, bool),
) -> Result<(), NotStationary> {
    let node = |e: End| match e {
        End::Ground => 0,
        End::Mass(i) => i + 1,
    };
    // Spring paths to ground, by union-find over the nodes.
    let mut parent: Vec<usize> = (0..=masses.len()).collect();
    fn root(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let mut pairs: Vec<((usize, usize), Vec<usize>)> = Vec::new();
    for (l, link) in links.iter().enumerate() {
        let (a, b) = (node(link.ends[0]), node(link.ends[1]));
        let key = (a.min(b), a.max(b));
        match pairs.iter_mut().find(|p| p.0 == key) {
            Some(p) => p.1.push(l),
            None => pairs.push((key, vec![l])),
        }
    }
    for (key, ls) in &pairs {
        if ls.iter().all(|&l| links[l].stiffness.is_empty() && !unknown(l).0) {
            continue;
        }
        let (ra, rb) = (root(&mut parent, key.0), root(&mut parent, key.1));
        parent[ra] = rb;
    }
    for i in 0..masses.len() {
        if root(&mut parent, i + 1) != root(&mut parent, 0) {
            return Err(NotStationary::NoSpringPath { mass: i });
        }
    }
    if (0..links.len()).all(|l| links[l].damping.is_empty() && !unknown(l).1) {
        return Err(NotStationary::NoDamping);
    }
    // Per pair of ends: its geometry `g` (x_a − x_b over the masses) and, per kind, the
    // highest power of its combined characteristic.
    let n = masses.len();
    let geometry = |key: (usize, usize)| -> Vec<f64> {
        let mut g = vec![0.0; n];
        for (node, sign) in [(key.0, -1.0), (key.1, 1.0)] {
            if node > 0 {
                g[node - 1] += sign;
            }
        }
        g
    };
    for (pi, (key, ls)) in pairs.iter().enumerate() {
        for kind in [Kind::Stiffness, Kind::Damping] {
            let poly_of = |l: usize| match kind {
                Kind::Stiffness => &links[l].stiffness,
                Kind::Damping => &links[l].damping,
            };
            let unknown_kind = |l: usize| match kind {
                Kind::Stiffness => unknown(l).0,
                Kind::Damping => unknown(l).1,
            };
            if ls.iter().any(|&l| unknown_kind(l)) {
                continue;
            }
            // The pair's combined characteristic in the orientation of its first link (a
            // link turned round contributes −F(−u)), far out on each side `s`: per growth,
            // the factor of |z|^growth it tends to. The leading behaviour must restore
            // (stiffness) or dissipate (damping) on both sides: `s · factor > 0`.
            let first = links[ls[0]].ends;
            for s in [1.0, -1.0] {
                let mut sum: BTreeMap<u32, (f64, Term, f64)> = BTreeMap::new();
                for &l in ls {
                    let same = links[l].ends == first;
                    for &(t, c) in &poly_of(l).terms {
                        let far = if same {
                            c * t.far(s).coefficient
                        } else {
                            -c * t.far(-s).coefficient
                        };
                        let entry = sum
                            .entry(t.far(if same { s } else { -s }).growth)
                            .or_insert((0.0, t, c));
                        entry.0 += far;
                        if far != 0.0 {
                            (entry.1, entry.2) = (t, c);
                        }
                    }
                }
                let (p, factor, term, c) = match sum.iter().rev().find(|t| t.1 .0 != 0.0) {
                    Some((&p, &(factor, term, c))) => (p, factor, term, c),
                    // Nothing far out on this side: a spring that lets go (a one-sided hinge)
                    // lets the mass escape; a damper that acts one way still dissipates.
                    None if kind == Kind::Stiffness && !sum.is_empty() => {
                        let (&p, &(_, term, c)) = sum.iter().next_back().expect("not empty");
                        (p, 0.0, term, c)
                    }
                    None => continue,
                };
                if s * factor > 0.0 {
                    continue;
                }
                // The bad side decides when some motion stretches this pair and no other pair
                // whose characteristic grows as fast or faster (sufficient; in a tree of springs
                // always so). Otherwise those may bound it, and the system stands.
                let others: Vec<Vec<f64>> = pairs
                    .iter()
                    .enumerate()
                    .filter(|&(pj, (_, lm))| {
                        pj != pi && lm.iter().map(|&l| poly_of(l).growth()).max().unwrap_or(0) >= p
                    })
                    .map(|(_, (k, _))| geometry(*k))
                    .collect();
                if in_span(&geometry(*key), &others) {
                    continue;
                }
                let link = *ls.iter().rev().find(|&&l| poly_of(l).growth() == p).unwrap_or(&ls[0]);
                return Err(NotStationary::Unbounded {
                    link,
                    kind,
                    term,
                    coefficient: c,
                });
            }
        }
    }
    Ok(())
}

/// Whether `v` is a linear combination of `rows` (Gram–Schmidt; small integer vectors).
fn in_span(v: &[f64], rows: &[Vec<f64>]) -> bool {
    let mut basis: Vec<Vec<f64>> = Vec::new();
    let reduce = |x: &mut Vec<f64>, basis: &[Vec<f64>]| {
        for b in basis {
            let d: f64 = x.iter().zip(b).map(|(a, b)| a * b).sum();
            x.iter_mut().zip(b).for_each(|(a, b)| *a -= d * b);
        }
    };
    for r in rows {
        let mut x = r.clone();
        reduce(&mut x, &basis);
        let norm = x.iter().map(|a| a * a).sum::<f64>().sqrt();
        if norm > 1e-9 {
            basis.push(x.iter().map(|a| a / norm).collect());
        }
    }
    let mut x = v.to_vec();
    reduce(&mut x, &basis);
    x.iter().map(|a| a * a).sum::<f64>().sqrt() < 1e-9
}

/// Two links whose unknowns no data can separate: links between the same two ends
/// (parallel springs or dampers) whose unknown coefficients share a term only ever act
/// as their sum.
#[derive(Debug, Clone, PartialEq)]
pub struct Inseparable {
    pub links: [usize; 2],
    pub kind: Kind,
    pub term: Term,
}

impl Inseparable {
    pub fn describe(&self, links: &[Link]) -> String {
        format!(
            "links {:?} and {:?} join the same two ends and both have an unknown {} coefficient of {}: only \
             their sum acts, so no data can separate them. Identify one of them (declare the other known in \
             [identify.links]) or merge them into one link",
            links[self.links[0]].name,
            links[self.links[1]].name,
            self.kind.name(),
            self.term.describe()
        )
    }
}

/// Whether the unknowns of `a` and `b` (two links' `[identify.links]`) can be separated.
pub fn separable(links: &[Link], a: &IdentifyLink, b: &IdentifyLink) -> Result<(), Inseparable> {
    let (la, lb) = (&links[a.link], &links[b.link]);
    let parallel = la.ends == lb.ends || la.ends == [lb.ends[1], lb.ends[0]];
    if !parallel || a.link == b.link {
        return Ok(());
    }
    let common = |x: &Option<Vec<Term>>, y: &Option<Vec<Term>>| {
        x.iter()
            .flatten()
            .find(|p| y.iter().flatten().any(|q| q == *p))
            .copied()
    };
    let (kind, term) = match (common(&a.stiffness, &b.stiffness), common(&a.damping, &b.damping)) {
        (Some(p), _) => (Kind::Stiffness, p),
        (None, Some(p)) => (Kind::Damping, p),
        (None, None) => return Ok(()),
    };
    Err(Inseparable {
        links: [a.link, b.link],
        kind,
        term,
    })
}

/// Ten times the slowest modal decay time estimated per mass from its own links
/// (`2m / Σc1`), at least 20 s: enough to forget the zero initial state.
pub fn default_burn_in(masses: &[Mass], links: &[Link]) -> f64 {
    let mut worst: f64 = 0.0;
    for (i, m) in masses.iter().enumerate() {
        let c: f64 = links
            .iter()
            .filter(|l| l.ends.contains(&End::Mass(i)))
            .map(|l| l.damping.coefficient(Term::Power(1)).abs())
            .sum();
        let tau = if c > 0.0 { 2.0 * m.value / c } else { 100.0 };
        worst = worst.max(tau);
    }
    (10.0 * worst).max(20.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::Curve;

    fn mass(name: &str) -> Mass {
        Mass {
            name: name.into(),
            value: 1.0,
            valued: true,
        }
    }

    fn link(a: End, b: End, k: &[(u32, f64)], c: &[(u32, f64)]) -> Link {
        Link {
            name: format!("{a:?}-{b:?}"),
            ends: [a, b],
            stiffness: Curve::powers(k),
            damping: Curve::powers(c),
            hysteresis: None,
        }
    }

    const KNOWN: fn(usize) -> (bool, bool) = |_| (false, false);

    #[test]
    fn the_reasons_a_system_has_no_stationary_density() {
        let (g, m1, m2) = (End::Ground, End::Mass(0), End::Mass(1));
        let masses = [mass("m1"), mass("m2")];
        let chain =
            |k2: &[(u32, f64)], c1: &[(u32, f64)]| vec![link(g, m1, &[(1, 1.0), (3, 1.0)], c1), link(m1, m2, k2, &[])];
        // A Duffing chain: admissible.
        assert_eq!(stationary(&masses, &chain(&[(1, 1.0)], &[(1, 0.5)]), KNOWN), Ok(()));
        // m2 hangs on a damper only.
        let l = vec![link(g, m1, &[(1, 1.0)], &[(1, 0.5)]), link(m1, m2, &[], &[(1, 0.1)])];
        assert_eq!(
            stationary(&masses, &l, KNOWN),
            Err(NotStationary::NoSpringPath { mass: 1 })
        );
        // Nothing dissipates.
        assert_eq!(
            stationary(&masses, &chain(&[(1, 1.0)], &[]), KNOWN),
            Err(NotStationary::NoDamping)
        );
        // The coupling's leading power even, then odd with a negative coefficient.
        for (k2, power, coefficient) in [(vec![(1, 1.0), (2, 1.0)], 2, 1.0), (vec![(1, 1.0), (3, -2.0)], 3, -2.0)] {
            let term = Term::Power(power);
            assert_eq!(
                stationary(&masses, &chain(&k2, &[(1, 0.5)]), KNOWN),
                Err(NotStationary::Unbounded {
                    link: 1,
                    kind: Kind::Stiffness,
                    term,
                    coefficient
                })
            );
        }
        // A softening cubic between m1 and m2 bounded by a stiffer spring on the same
        // motion (a loop: m2 also to the ground with a quintic): admissible.
        let mut l = chain(&[(1, 1.0), (3, -2.0)], &[(1, 0.5)]);
        l.push(link(g, m2, &[(1, 1.0), (5, 1.0)], &[]));
        l[0].stiffness.terms.push((Term::Power(5), 1.0));
        assert_eq!(stationary(&masses, &l, KNOWN), Ok(()));
        // In a model file an unknown characteristic's sign is the data's to tell.
        let l = chain(&[(1, 1.0), (2, 1.0)], &[(1, 0.5)]);
        assert_eq!(stationary(&masses, &l, |i| (i == 1, false)), Ok(()));
    }

    #[test]
    fn parallel_links_with_a_common_unknown_power_cannot_be_separated() {
        let (g, m1) = (End::Ground, End::Mass(0));
        let links = [link(g, m1, &[(1, 1.0)], &[(1, 0.5)]), link(m1, g, &[(3, 1.0)], &[])];
        let powers = |ps: &[u32]| (!ps.is_empty()).then(|| ps.iter().map(|&p| Term::Power(p)).collect());
        let id = |link, k: &[u32], c: &[u32]| IdentifyLink {
            link,
            stiffness: powers(k),
            damping: powers(c),
        };
        assert_eq!(separable(&links, &id(0, &[1], &[1]), &id(1, &[3], &[])), Ok(()));
        let e = separable(&links, &id(0, &[1, 3], &[]), &id(1, &[3], &[])).unwrap_err();
        assert_eq!((e.kind, e.term), (Kind::Stiffness, Term::Power(3)));
        assert!(e.describe(&links).contains("only their sum acts"));
    }
}
