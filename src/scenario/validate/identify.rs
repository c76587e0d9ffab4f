//! `[identify]` and `[accept]`: methods, the unknowns, comparison models, the section-4
//! procedure and the regression gates, every error located by file, line, column and key.

use super::*;
use crate::model::admissible;

/// Why two links' unknowns can never be told apart, if they cannot
/// ([`admissible::separable`]).
pub(crate) fn inseparable(links: &[Link], a: &IdentifyLink, b: &IdentifyLink) -> Option<String> {
    admissible::separable(links, a, b).err().map(|why| why.describe(links))
}

/// `[identify]`: methods, the unknowns, comparison models and the section-4 procedure.
pub(crate) fn check_identify(
    loc: &Locator,
    raw: &RawScenario,
    masses: &[Mass],
    links: &[Link],
    excitations: &[Excitation],
) -> Result<Identify, ScenarioError> {
    let ident = raw.identify.as_ref();
    let methods = check_methods(loc, ident.and_then(|i| i.methods.as_ref()))?;
    let id_links = match ident.and_then(|i| i.links.as_ref()) {
        Some(map) => identify_links(loc, links, map, "identify.links")?,
        None => links
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let ps = |p: &Curve| (!p.is_empty()).then(|| p.terms.iter().map(|t| t.0).collect());
                IdentifyLink {
                    link: i,
                    stiffness: ps(&l.stiffness),
                    damping: ps(&l.damping),
                }
            })
            .collect::<Vec<_>>(),
    };
    let compare = compare_models(loc, links, ident)?;
    let filtered = |list: Option<&Vec<Spanned<String>>>, key: &str| -> Result<Vec<usize>, ScenarioError> {
        let mut out = Vec::new();
        for e in list.into_iter().flatten() {
            let k = excitation_index(loc, excitations, e, key)?;
            if !matches!(excitations[k].process, Process::Filtered { .. }) {
                return Err(loc.at(
                    e.span(),
                    key,
                    format!(
                        "excitation {:?} is white: only filtered excitations have A and B",
                        e.get_ref()
                    ),
                ));
            }
            out.push(k);
        }
        Ok(out)
    };
    let known_filters = filtered(ident.and_then(|i| i.known_filters.as_ref()), "identify.known_filters")?;
    let unknown_corners = filtered(
        ident.and_then(|i| i.unknown_corners.as_ref()),
        "identify.unknown_corners",
    )?;
    let mut equivalent_white = Vec::new();
    for e in ident.and_then(|i| i.equivalent_white.as_ref()).into_iter().flatten() {
        let key = "identify.equivalent_white";
        let k = excitation_index(loc, excitations, e, key)?;
        let x = &excitations[k];
        let why = if !matches!(x.process, Process::White { .. } | Process::Lab(_)) {
            Some(
                "is filtered: its spectrum is fitted by (3.20); an equivalent white noise is declared kind = \"white\"",
            )
        } else if !x.measured {
            Some("is not measured: its level can only be read from a measured force's spectrum")
        } else if equivalent_white.contains(&k) {
            Some("is listed twice")
        } else {
            None
        };
        if let Some(why) = why {
            return Err(loc.at(e.span(), key, format!("excitation {:?} {why}", e.get_ref())));
        }
        equivalent_white.push(k);
    }
    let choose_force_model = chosen_models(
        loc,
        ident,
        excitations,
        &[
            (&equivalent_white, "identify.equivalent_white"),
            (&known_filters, "identify.known_filters"),
            (&unknown_corners, "identify.unknown_corners"),
        ],
    )?;
    // A lab signal is known to the identifier by its measured samples alone: it is read as
    // its equivalent white noise unless its model is to be chosen.
    for (k, x) in excitations.iter().enumerate() {
        if matches!(x.process, Process::Lab(_)) && !equivalent_white.contains(&k) && !choose_force_model.contains(&k) {
            equivalent_white.push(k);
        }
    }
    let mut unknown_masses = Vec::new();
    for m in ident.and_then(|i| i.unknown_masses.as_ref()).into_iter().flatten() {
        let End::Mass(k) = mass_index(loc, masses, m, "identify.unknown_masses", false)? else {
            unreachable!()
        };
        unknown_masses.push(k);
    }
    let unknown_intensities = ident
        .and_then(|i| i.unknown_intensities.as_ref())
        .into_iter()
        .flatten()
        .map(|e| excitation_index(loc, excitations, e, "identify.unknown_intensities"))
        .collect::<Result<Vec<_>, _>>()?;
    let disturbance = match ident.and_then(|i| i.disturbance.as_ref()) {
        None => None,
        Some(d) if !equivalent_white.is_empty() || !choose_force_model.is_empty() => {
            return Err(loc.at(
                d.span(),
                "identify.disturbance",
                "the iterative procedure needs every measured force's model before its first step: give the \
                 models of the forces listed in identify.equivalent_white or identify.choose_force_model",
            ))
        }
        Some(d) => Some(check_disturbance(loc, d, || {
            paper_structure(
                masses,
                links,
                excitations,
                &id_links,
                &unknown_masses,
                &unknown_intensities,
                &unknown_corners,
            )
        })?),
    };
    let identify = Identify {
        methods,
        links: id_links,
        unknown_masses,
        unknown_intensities,
        known_filters,
        unknown_corners,
        equivalent_white,
        choose_force_model,
        compare,
        disturbance,
        sensor_noise: ident
            .and_then(|i| i.sensor_noise.as_ref())
            .map_or(NoiseHandling::default(), |v| *v.get_ref()),
        select: None,
        profile: None,
    };
    let mut identify = identify;
    if let Some(sel) = ident.and_then(|i| i.select.as_ref()) {
        identify.select = Some(check_select(loc, sel, links, excitations, &identify)?);
    }
    if let Some(p) = ident.and_then(|i| i.profile.as_ref()) {
        identify.profile = Some(check_profile(loc, p, links, &identify)?);
    }
    Ok(identify)
}

/// `[identify.profile]`: an unknown coefficient whose term has a position, a range of
/// positions the term may take, and how many to try.
fn check_profile(
    loc: &Locator,
    raw: &Spanned<RawProfile>,
    links: &[Link],
    identify: &Identify,
) -> Result<Profile, ScenarioError> {
    let r = raw.get_ref();
    let key = "identify.profile.parameter";
    let name = r.parameter.get_ref();
    let at = |e: String| loc.at(r.parameter.span(), key, e);
    let Ok(crate::model::ParameterName::Coefficient { kind, term, link }) = name.parse() else {
        return Err(at(format!(
            "{name:?} is not a coefficient's name: name the unknown whose term's position is profiled, e.g. \
             \"kgap(0.1)[m1-m2]\""
        )));
    };
    if term.position().is_none() {
        return Err(at(format!(
            "{} has no position to profile: profile a gap(…), tanh(…) or hinge(…) term",
            term.describe()
        )));
    }
    let l = links
        .iter()
        .position(|x| x.name == link)
        .ok_or_else(|| at(format!("unknown link {link:?}")))?;
    let listed = identify.links.iter().find(|x| x.link == l).and_then(|x| match kind {
        Characteristic::Stiffness => x.stiffness.as_ref(),
        Characteristic::Damping => x.damping.as_ref(),
    });
    if !listed.is_some_and(|ts| ts.contains(&term)) {
        return Err(at(format!(
            "{name} is not an unknown: list {term} in [identify.links.{link}] {}",
            kind.name()
        )));
    }
    if identify.select.is_some() || identify.disturbance.is_some() {
        return Err(loc.at(
            raw.span(),
            "identify.profile",
            "a profile runs with the ordinary identification of a given structure, not with [identify.select] or \
             [identify.disturbance]",
        ));
    }
    let Some(range) = &r.range else {
        return Err(loc.at(
            raw.span(),
            "identify.profile.range",
            "missing: give the positions to try as range = [lowest, highest]",
        ));
    };
    let bad_range = |why: String| loc.at(range.span(), "identify.profile.range", why);
    let &[a, b] = range.get_ref().as_slice() else {
        return Err(bad_range("give the range as [lowest, highest]".into()));
    };
    if a >= b || term.at_position(a).is_none() || term.at_position(b).is_none() {
        return Err(bad_range(format!(
            "[{a}, {b}] is not a range of positions of the {}: lowest < highest, both finite{}",
            term.describe(),
            match term {
                Term::Hinge(_) => ", non-zero and on the knot's side of 0",
                _ => " and positive",
            }
        )));
    }
    let points = match &r.points {
        None => 21,
        Some(p) => match *p.get_ref() {
            n @ 3..=201 => n as usize,
            n => return Err(loc.at(p.span(), "identify.profile.points", format!("{n}: between 3 and 201"))),
        },
    };
    Ok(Profile {
        link: l,
        kind,
        term,
        range: (a, b),
        points,
    })
}

/// `[identify.select]`: the candidate terms given for every link; selection chooses among
/// spring and damper terms of a white-noise or known-filter problem only.
fn check_select(
    loc: &Locator,
    sel: &Spanned<RawSelect>,
    links: &[Link],
    excitations: &[Excitation],
    identify: &Identify,
) -> Result<Select, ScenarioError> {
    let raw = sel.get_ref();
    let select = Select {
        stiffness: terms(loc, &raw.stiffness, "identify.select.stiffness")?,
        damping: terms(loc, &raw.damping, "identify.select.damping")?,
    };
    if let Some(why) = identify.select_unsupported(excitations) {
        return Err(loc.at(sel.span(), "identify.select", why));
    }
    let candidates = select.candidates(links, &identify.links);
    for (i, a) in candidates.iter().enumerate() {
        if let Some(why) = candidates[..i].iter().find_map(|b| inseparable(links, b, a)) {
            return Err(loc.at(sel.span(), "identify.select", why));
        }
    }
    Ok(select)
}

/// `[identify] methods`: weak when left out; not empty, no method twice.
fn check_methods(loc: &Locator, methods: Option<&Spanned<Vec<Method>>>) -> Result<Vec<Method>, ScenarioError> {
    match methods {
        None => Ok(vec![Method::Weak]),
        Some(m) if m.get_ref().is_empty() => Err(loc.at(
            m.span(),
            "identify.methods",
            "empty: name at least one method (weak, strong, strong-marginals), or leave the key \
             out for weak",
        )),
        Some(m) => {
            let mut seen = Vec::new();
            for &x in m.get_ref() {
                if seen.contains(&x) {
                    return Err(loc.at(m.span(), "identify.methods", format!("{:?} is listed twice", x.name())));
                }
                seen.push(x);
            }
            Ok(seen)
        }
    }
}

/// `[identify.compare.NAME]`: each alternative model's links, each identifying a term.
fn compare_models(
    loc: &Locator,
    links: &[Link],
    ident: Option<&RawIdentify>,
) -> Result<Vec<(String, Vec<IdentifyLink>)>, ScenarioError> {
    let mut compare = Vec::new();
    for (name, c) in ident.and_then(|i| i.compare.as_ref()).into_iter().flatten() {
        let key = format!("identify.compare.{name}.links");
        let alternative = identify_links(loc, links, &c.get_ref().links, &key)?;
        let no_terms = |t: &Option<Vec<_>>| t.as_ref().is_none_or(Vec::is_empty);
        if alternative
            .iter()
            .all(|l| no_terms(&l.stiffness) && no_terms(&l.damping))
        {
            return Err(loc.at(
                c.span(),
                &key,
                "an alternative model identifies no term: give it at least one link with the powers or terms \
                 to identify (e.g. links.ground-m1 = { stiffness = [1] }), or leave the alternative out",
            ));
        }
        compare.push((name.clone(), alternative));
    }
    Ok(compare)
}

/// The links of `[identify.links]` (or a comparison's, under `prefix`) with the terms to
/// identify on each, in the scenario's link order; no two that the data cannot separate.
fn identify_links(
    loc: &Locator,
    links: &[Link],
    map: &BTreeMap<String, Spanned<RawIdentifyLink>>,
    prefix: &str,
) -> Result<Vec<IdentifyLink>, ScenarioError> {
    let mut out = Vec::new();
    for (lname, spec) in map {
        let key = format!("{prefix}.{lname}");
        let link = links.iter().position(|l| &l.name == lname).ok_or_else(|| {
            let names: Vec<_> = links.iter().map(|l| l.name.as_str()).collect();
            loc.at(
                spec.span(),
                &key,
                format!("unknown link {lname:?}: links are {}", names.join(", ")),
            )
        })?;
        let sp = spec.get_ref();
        let id = IdentifyLink {
            link,
            stiffness: terms(loc, &sp.stiffness, &format!("{key}.stiffness"))?,
            damping: terms(loc, &sp.damping, &format!("{key}.damping"))?,
        };
        if let Some(why) = out.iter().find_map(|o| inseparable(links, o, &id)) {
            return Err(loc.at(spec.span(), &key, why));
        }
        out.push(id);
    }
    out.sort_by_key(|l| l.link);
    Ok(out)
}

/// The index of the excitation named by `e` under `key`.
fn excitation_index(
    loc: &Locator,
    excitations: &[Excitation],
    e: &Spanned<String>,
    key: &str,
) -> Result<usize, ScenarioError> {
    excitations.iter().position(|x| &x.name == e.get_ref()).ok_or_else(|| {
        let names: Vec<_> = excitations.iter().map(|x| x.name.as_str()).collect();
        loc.at(
            e.span(),
            key,
            format!(
                "unknown excitation {:?}: excitations are {}",
                e.get_ref(),
                names.join(", ")
            ),
        )
    })
}

/// `[identify.disturbance]`: the section-4 procedure's stopping rules and sweep levels,
/// and the paper's structure (4.3) found by `structure`.
pub(crate) fn check_disturbance(
    loc: &Locator,
    d: &Spanned<RawDisturbance>,
    structure: impl FnOnce() -> Result<PaperStructure, String>,
) -> Result<Disturbance, ScenarioError> {
    let raw_d = d.get_ref();
    let max_steps = match &raw_d.max_steps {
        None => 10,
        Some(v) if (1..=1000).contains(v.get_ref()) => *v.get_ref() as usize,
        Some(v) => {
            return Err(loc.at(
                v.span(),
                "identify.disturbance.max_steps",
                format!("must be a whole number 1..=1000, got {}", v.get_ref()),
            ))
        }
    };
    let tolerance = match &raw_d.tolerance {
        None => 1e-3,
        Some(v) => finite_positive(
            loc,
            v,
            "identify.disturbance.tolerance",
            "largest relative change of any coefficient in the last step, e.g. 1e-3",
        )?,
    };
    let sweep = match &raw_d.sweep {
        None => vec![0.0, 0.25, 0.5, 1.0, 2.0],
        Some(list) => {
            let mut out = Vec::new();
            for v in list.get_ref() {
                let x = *v.get_ref();
                if !(x.is_finite() && x >= 0.0) {
                    return Err(loc.at(
                        v.span(),
                        "identify.disturbance.sweep",
                        format!("levels are finite numbers >= 0 (std of the disturbance over std of the measured force), got {x}"),
                    ));
                }
                out.push(x);
            }
            if out.is_empty() {
                return Err(loc.at(
                    list.span(),
                    "identify.disturbance.sweep",
                    "empty: give the levels, e.g. [0, 0.25, 0.5, 1, 2]",
                ));
            }
            out
        }
    };
    let structure = structure().map_err(|m| loc.at(d.span(), "identify.disturbance", m))?;
    Ok(Disturbance {
        max_steps,
        tolerance,
        sweep,
        structure,
    })
}

/// `[accept]`: the worst relative error allowed, overall and per method.
pub(crate) fn check_accept(loc: &Locator, raw: &RawScenario, identify: &Identify) -> Result<Accept, ScenarioError> {
    let mut accept = Accept {
        worst_rel_error: 0.05,
        methods: BTreeMap::new(),
        calibrated: false,
    };
    if let Some(a) = &raw.accept {
        if let Some(w) = &a.worst_rel_error {
            accept.worst_rel_error = finite_positive(loc, w, "accept.worst_rel_error", "relative error, e.g. 0.03")?;
            accept.calibrated = true;
        }
        let allowed: Vec<String> = ReportMethod::gated(identify.disturbance.is_some())
            .iter()
            .map(ReportMethod::name)
            .collect();
        for (m, v) in a.methods.iter().flatten() {
            let key = format!("accept.methods.{m}");
            if !allowed.contains(m) {
                let why = match m.parse::<crate::scenario::Method>() {
                    Ok(_) => format!("{m:?} is reported for comparison, never gated"),
                    Err(_) => format!("unknown method {m:?}"),
                };
                return Err(loc.at(
                    v.span(),
                    &key,
                    format!("{why}: the gated methods are {}", allowed.join(", ")),
                ));
            }
            accept
                .methods
                .insert(m.clone(), finite_positive(loc, v, &key, "relative error")?);
        }
    }
    Ok(accept)
}

/// The forces whose model the identifier chooses from their spectra
/// (`[identify] choose_force_model`): measured, listed once, and in none of the lists
/// `elsewhere` that give its model another way. In a model file it is declared white (no
/// `sigma` needed); in a simulation its declared process is the truth, which the
/// identifier does not read.
fn chosen_models(
    loc: &Locator,
    ident: Option<&super::super::raw::RawIdentify>,
    excitations: &[Excitation],
    elsewhere: &[(&[usize], &str)],
) -> Result<Vec<usize>, ScenarioError> {
    let key = "identify.choose_force_model";
    let mut out = Vec::new();
    for e in ident.and_then(|i| i.choose_force_model.as_ref()).into_iter().flatten() {
        let k = excitation_index(loc, excitations, e, key)?;
        let other = elsewhere.iter().find(|(list, _)| list.contains(&k));
        let why = if !excitations[k].measured {
            "is not measured: a force's model can only be chosen from its measured spectrum".to_string()
        } else if let Some((_, list)) = other {
            format!("is also in {list}, which gives its model: list it in one of the two")
        } else if out.contains(&k) {
            "is listed twice".to_string()
        } else {
            out.push(k);
            continue;
        };
        return Err(loc.at(e.span(), key, format!("excitation {:?} {why}", e.get_ref())));
    }
    Ok(out)
}

/// An equivalent white force's level, or a force whose model is chosen, is read from its
/// measured column: a model file must map `p_<excitation>`.
pub(crate) fn check_equivalent_white_columns(
    loc: &Locator,
    raw: &RawScenario,
    identify: &Identify,
    excitations: &[Excitation],
    data: Option<&DataMapping>,
) -> Result<(), ScenarioError> {
    let Some(data) = data else { return Ok(()) };
    let listed = |key: fn(&super::super::raw::RawIdentify) -> Option<&Vec<Spanned<String>>>| {
        raw.identify.as_ref().and_then(key).into_iter().flatten()
    };
    let written = identify
        .equivalent_white
        .iter()
        .zip(listed(|i| i.equivalent_white.as_ref()))
        .map(|(e, w)| (e, w, "identify.equivalent_white"))
        .chain(
            identify
                .choose_force_model
                .iter()
                .zip(listed(|i| i.choose_force_model.as_ref()))
                .map(|(e, w)| (e, w, "identify.choose_force_model")),
        );
    for (&e, written, key) in written {
        let column = format!("p_{}", excitations[e].name);
        if !data.columns.iter().any(|(c, _)| *c == column) {
            return Err(loc.at(
                written.span(),
                key,
                format!(
                    "the model of {:?} is read from its measured force: map `{column}` in [data.columns]",
                    excitations[e].name
                ),
            ));
        }
    }
    Ok(())
}
