//! Structure selection in the reports (docs/selection.md): the terminal's lines and
//! report.md's section — what was selected from which candidates, the runners-up, the
//! inclusion over bootstrap resamples and the elimination path; and a term's profiled
//! position (`[identify.profile]`, docs/scenario.md "Terms").

use super::table::Table;
use super::{ProfileReport, SelectionReport};

/// The profile's headline: the position chosen, its interval, the truth where known.
fn profile_headline(p: &ProfileReport) -> String {
    let truth = match p.truth {
        Some(t) => format!("; true {t} ({:+.2} %)", 100.0 * (p.chosen / t - 1.0)),
        None => String::new(),
    };
    let refined = match p.refined {
        Some(_) => ", refined to the vertex of the parabola through the least J and its neighbours",
        None => "",
    };
    format!(
        "profile: {} chosen as {} (95 % interval {}..{}{truth}) by the weak form's J over {} positions{refined}; \
         dispersion {:.1}; {:.2} s",
        p.parameter,
        p.chosen_parameter,
        p.interval.0,
        p.interval.1,
        p.points.len(),
        p.dispersion,
        p.seconds
    )
}

/// The terminal's lines of a profile: the headline and `J − J_min` per position.
pub fn profile_lines(p: &ProfileReport) -> Vec<String> {
    let j_min = p.points.iter().filter_map(|x| x.j).fold(f64::INFINITY, f64::min);
    let mut out = vec![profile_headline(p)];
    let cells: Vec<String> = p
        .points
        .iter()
        .map(|x| {
            // A position as the term's name writes it: 0.15, or 3.333333333e18.
            let at = match (1e-4..1e6).contains(&x.position.abs()) || x.position == 0.0 {
                true => format!("{}", x.position),
                false => format!("{:e}", x.position),
            };
            match x.j {
                Some(j) => format!("{at}: {:.1}", j - j_min),
                None => format!("{at}: refused"),
            }
        })
        .collect();
    out.push(format!("  J − J_min by position: {}", cells.join(", ")));
    out
}

/// report.md's section of a profile: the table of `J` per position.
pub fn profile_section(p: &ProfileReport) -> String {
    let j_min = p.points.iter().filter_map(|x| x.j).fold(f64::INFINITY, f64::min);
    let mut table = Table::new()
        .right("position")
        .right("J")
        .right("J − J_min")
        .right("dof");
    for x in &p.points {
        table.row(match x.j {
            Some(j) => [
                x.position.to_string(),
                format!("{j:.1}"),
                format!("{:.1}", j - j_min),
                x.dof.to_string(),
            ],
            None => [
                x.position.to_string(),
                format!("refused: {}", x.refused.as_deref().unwrap_or("")),
                String::new(),
                String::new(),
            ],
        });
    }
    format!("## Profile\n\n{}\n\n{}\n", profile_headline(p), table.markdown())
}

/// The candidates with an inclusion frequency strictly between 0 and 1, or at odds with
/// the selection: where the bootstrap resamples disagree.
fn unsettled(r: &SelectionReport) -> Vec<(String, f64)> {
    let s = &r.selection;
    (s.candidates.iter().zip(&s.selected).zip(&s.inclusion))
        .filter(|((_, &sel), &f)| (f > 0.0 && f < 1.0) || (f == 1.0) != sel)
        .map(|((n, _), &f)| (n.to_string(), f))
        .collect()
}

fn how(r: &SelectionReport) -> String {
    let s = &r.selection;
    format!(
        "{} of {} candidates by {} over {} weak-form equations (penalty ln N = {:.2} per term, \
         dispersion {:.1}); {:.2} s",
        s.selected.iter().filter(|&&x| x).count(),
        s.candidates.len(),
        s.criterion_name,
        s.equations,
        s.penalty,
        s.dispersion,
        r.seconds
    )
}

/// The baseline's outcome in one sentence.
fn baseline(r: &SelectionReport) -> String {
    let s = &r.selection;
    let t = &s.thresholded;
    let kept: Vec<String> = (s.candidates.iter().zip(&t.selected))
        .filter(|(_, &k)| k)
        .map(|(n, _)| n.to_string())
        .collect();
    let differs = t.selected != s.selected;
    format!(
        "baseline STLSQ (threshold {:.2e} by leave-one-batch-out cross-validation): {} terms{}{}",
        t.threshold,
        kept.len(),
        if differs {
            format!(": {}", kept.join(" "))
        } else {
            ", the same as selected".to_string()
        },
        if t.admissible {
            ""
        } else {
            " (no stationary density at its estimates)"
        }
    )
}

/// What the jackknife confirmation did, in one sentence.
fn confirmation(r: &SelectionReport) -> String {
    let s = &r.selection;
    if s.confirmation.is_empty() {
        return "every selected term and link confirmed by the jackknife (Wald statistic ≥ its terms × ln N)".into();
    }
    let list: Vec<String> = (s.confirmation.iter())
        .map(|u| {
            let names: Vec<String> = u.terms.iter().map(|n| n.to_string()).collect();
            format!("{} (Wald {:.1} < {:.1})", names.join(" + "), u.wald, u.penalty)
        })
        .collect();
    format!(
        "the jackknife did not confirm the criterion's {}: {}",
        if list.len() == 1 { "term" } else { "terms" },
        list.join(", ")
    )
}

/// The terminal's lines.
pub fn selection_lines(r: &SelectionReport) -> Vec<String> {
    let s = &r.selection;
    let names = |want: bool| -> Vec<String> {
        (s.candidates.iter().zip(&s.selected))
            .filter(|(_, &x)| x == want)
            .map(|(n, _)| n.to_string())
            .collect()
    };
    let mut out = vec![format!("structure selection: {}", how(r))];
    out.push(format!("  selected: {}", names(true).join(" ")));
    let dropped = names(false);
    if !dropped.is_empty() {
        out.push(format!("  dropped:  {}", dropped.join(" ")));
    }
    if !s.runners_up.is_empty() {
        let ru: Vec<String> = s
            .runners_up
            .iter()
            .map(|x| format!("{} ({:+.1})", x.change, x.criterion - s.criterion_choice))
            .collect();
        out.push(format!(
            "  runners-up (criterion against the criterion's choice): {}",
            ru.join(", ")
        ));
    }
    out.push(format!("  {}", confirmation(r)));
    out.push(format!("  {}", baseline(r)));
    let u = unsettled(r);
    out.push(if u.is_empty() {
        format!(
            "  every one of {} bootstrap resamples of the batches selects the same terms",
            s.replicates
        )
    } else {
        let list: Vec<String> = u.iter().map(|(n, f)| format!("{n} {:.0} %", 100.0 * f)).collect();
        format!(
            "  resamples that disagree (share of {} bootstrap resamples selecting the term; under \
             80 % a share overstates the chance the term is real, docs/selection.md): {}",
            s.replicates,
            list.join(", ")
        )
    });
    out
}

/// report.md's section.
/// `image` is the registry's paragraph of the selection figure (`figures::image`).
pub fn selection_section(r: &SelectionReport, image: &str) -> String {
    let s = &r.selection;
    let mut out = format!(
        "## Structure selection\n\n{}. Every method below identified the selected model; the row \
         `weak [declared terms]` is the model as `[identify.links]` declares it, on the same \
         samples (docs/selection.md).\n\n{image}",
        how(r)
    );
    out += &format!(
        "Confirmation: {}.\n\nThe {}; its model is the row `weak [STLSQ selection]`.\n\n",
        confirmation(r),
        baseline(r)
    );
    let replicates = format!("selected by the {} bootstrap resamples", s.replicates);
    let mut table = Table::new()
        .left("candidate")
        .center("selected")
        .right(replicates)
        .center("STLSQ");
    let mark = |yes: bool| if yes { "yes" } else { "—" }.to_string();
    for (((n, &sel), &f), &t) in s
        .candidates
        .iter()
        .zip(&s.selected)
        .zip(&s.inclusion)
        .zip(&s.thresholded.selected)
    {
        table.row([n.to_string(), mark(sel), format!("{:.0} %", 100.0 * f), mark(t)]);
    }
    out += &table.markdown();
    if !s.runners_up.is_empty() {
        let mut table = Table::new()
            .left("runner-up")
            .right("terms")
            .right("criterion")
            .right("against the criterion's choice");
        table.row([
            "(the criterion's choice)".to_string(),
            s.criterion_choice_terms.to_string(),
            format!("{:.1}", s.criterion_choice),
            "0".into(),
        ]);
        for x in &s.runners_up {
            table.row([
                x.change.to_string(),
                x.terms.to_string(),
                format!("{:.1}", x.criterion),
                format!("{:+.1}", x.criterion - s.criterion_choice),
            ]);
        }
        out += "\n";
        out += &table.markdown();
    }
    out += "\nBackward elimination (each step drops the term whose loss raises J least while \
            every leading term stays odd; a model whose leading coefficient is not positive, or \
            that has no stationary density, cannot be selected):\n\n";
    let mut table = Table::new()
        .right("terms")
        .left("dropped")
        .right("J")
        .right("criterion");
    for st in &s.path {
        table.row([
            st.terms.to_string(),
            st.dropped
                .as_ref()
                .map_or("(all candidates)".to_string(), |d| d.to_string()),
            format!("{:.1}", st.j),
            if st.admissible {
                format!("{:.1}", st.criterion)
            } else {
                "not admissible".to_string()
            },
        ]);
    }
    out += &table.markdown();
    out + "\n"
}
