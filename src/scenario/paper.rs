//! Detection of the paper's two-mass structure (4.3), the one the section-4 procedure is
//! defined for; a scenario of another shape is refused with what is missing.

use super::{End, Excitation, IdentifyLink, Link, Mass, PaperStructure};
use crate::model::Term;

/// Find the paper's structure (4.3) for the iterative procedure of section 4, or say what
/// is missing.
pub(crate) fn paper_structure(
    masses: &[Mass],
    links: &[Link],
    excitations: &[Excitation],
    id_links: &[IdentifyLink],
    unknown_masses: &[usize],
    unknown_intensities: &[usize],
    unknown_corners: &[usize],
) -> Result<PaperStructure, String> {
    let need = "the iterative procedure (paper section 4) is defined for its two-mass structure (4.3): \
                a free mass tied only by a linear spring k1 (no damper; identify stiffness = [1]) to a \
                driven mass, which is tied to the ground by K2, C2 (identified) and driven by the one \
                measured force; any unmeasured disturbances";
    let fail = |what: &str| Err(format!("{what}; {need}"));
    if masses.len() != 2 {
        return fail(&format!("the scenario has {} masses", masses.len()));
    }
    let measured: Vec<usize> = (0..excitations.len()).filter(|&e| excitations[e].measured).collect();
    let [measured] = measured[..] else {
        return fail(&format!("the scenario has {} measured excitations", measured.len()));
    };
    let [driven] = excitations[measured].acts_on[..] else {
        return fail(&format!(
            "the measured excitation {:?} acts on several masses",
            excitations[measured].name
        ));
    };
    let free = 1 - driven;
    if links.len() != 2 {
        return fail(&format!("the scenario has {} links", links.len()));
    }
    let coupling = links
        .iter()
        .position(|l| l.ends.contains(&End::Mass(free)) && l.ends.contains(&End::Mass(driven)));
    let ground = links.iter().position(|l| l.ends == [End::Mass(driven), End::Ground]);
    let (Some(coupling), Some(ground)) = (coupling, ground) else {
        return fail(&format!(
            "the links must join {} to {} and {} to the ground",
            masses[free].name, masses[driven].name, masses[driven].name
        ));
    };
    if !links[coupling].damping.is_empty() {
        return fail(&format!("link {:?} has a damper", links[coupling].name));
    }
    let id = |l: usize| id_links.iter().find(|x| x.link == l);
    match id(coupling) {
        Some(IdentifyLink {
            stiffness: Some(p),
            damping: None,
            ..
        }) if p == &[Term::Power(1)] => {}
        _ => {
            return fail(&format!(
                "[identify.links.{}] must be {{ stiffness = [1] }}",
                links[coupling].name
            ))
        }
    }
    match id(ground) {
        Some(IdentifyLink { stiffness, damping, .. }) if stiffness.is_some() || damping.is_some() => {}
        _ => {
            return fail(&format!(
                "[identify.links.{}] must list K2 and/or C2 powers",
                links[ground].name
            ))
        }
    }
    if !unknown_masses.is_empty() || !unknown_intensities.is_empty() || !unknown_corners.is_empty() {
        return fail("masses, intensities and corners must be known");
    }
    Ok(PaperStructure {
        free,
        driven,
        coupling,
        ground,
        measured,
    })
}
