//! The report's tables, built once and rendered twice: as aligned columns for the
//! terminal ([`Table::text`]) and as a markdown pipe table for `report.md`
//! ([`Table::markdown`], which `report.html` is made from). A table says what its columns
//! hold; the renderers decide the layout. A column may be left out of the terminal's
//! rendering, or carry a shorter title there, to keep a table within
//! [`super::text::WIDTH`] columns; its cells are the same in both.

/// How a column's cells line up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Align {
    /// Text: names, units, intervals.
    Left,
    /// Numbers.
    Right,
    /// Marks: yes or a dash.
    Center,
}

/// One column: its title, alignment and how the terminal shows it.
#[derive(Debug, Clone)]
pub struct Column {
    title: String,
    /// The title on the terminal, where it differs.
    short: Option<String>,
    align: Align,
    /// The terminal's least width (a table whose columns keep their place as rows change).
    min_width: usize,
    /// Where the column is shown.
    shown: Shown,
}

/// Where a column is shown: both renderings, or one of them (a pair of columns on the
/// page folded into one on the terminal).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Shown {
    Both,
    Page,
    Terminal,
}

/// A table: columns and rows of cells, one cell per column.
#[derive(Debug, Clone, Default)]
pub struct Table {
    columns: Vec<Column>,
    rows: Vec<Vec<String>>,
}

impl Table {
    /// A table of no columns yet.
    pub fn new() -> Table {
        Table::default()
    }

    /// A column of text.
    pub fn left(mut self, title: impl Into<String>) -> Table {
        self.columns.push(Column {
            title: title.into(),
            short: None,
            align: Align::Left,
            min_width: 0,
            shown: Shown::Both,
        });
        self
    }

    /// A column of numbers.
    pub fn right(mut self, title: impl Into<String>) -> Table {
        self.columns.push(Column {
            title: title.into(),
            short: None,
            align: Align::Right,
            min_width: 0,
            shown: Shown::Both,
        });
        self
    }

    /// A column of marks, centred.
    pub fn center(mut self, title: impl Into<String>) -> Table {
        self.columns.push(Column {
            title: title.into(),
            short: None,
            align: Align::Center,
            min_width: 0,
            shown: Shown::Both,
        });
        self
    }

    /// The last column's title on the terminal.
    pub fn short(mut self, title: impl Into<String>) -> Table {
        self.last().short = Some(title.into());
        self
    }

    /// The last column at least `width` characters wide on the terminal.
    pub fn min_width(mut self, width: usize) -> Table {
        self.last().min_width = width;
        self
    }

    /// The last column in `report.md` only (the terminal's table stays narrow).
    pub fn page_only(mut self) -> Table {
        self.last().shown = Shown::Page;
        self
    }

    /// The last column on the terminal only (what the page shows in columns of its own).
    pub fn terminal_only(mut self) -> Table {
        self.last().shown = Shown::Terminal;
        self
    }

    fn last(&mut self) -> &mut Column {
        self.columns.last_mut().expect("a column is declared first")
    }

    /// One row: a cell per column.
    pub fn row<S: Into<String>>(&mut self, cells: impl IntoIterator<Item = S>) {
        let row: Vec<String> = cells.into_iter().map(Into::into).collect();
        assert_eq!(row.len(), self.columns.len(), "one cell per column");
        self.rows.push(row);
    }

    /// The markdown pipe table: the page's columns, titles in full, numbers right-aligned.
    pub fn markdown(&self) -> String {
        let shown: Vec<usize> = (0..self.columns.len())
            .filter(|&k| self.columns[k].shown != Shown::Terminal)
            .collect();
        let line = |cell: &dyn Fn(usize) -> String| {
            let mut s = String::from("|");
            for &k in &shown {
                s += " ";
                s += &cell(k);
                s += " |";
            }
            s + "\n"
        };
        let mut s = line(&|k| self.columns[k].title.clone());
        s += "|";
        for &k in &shown {
            s += match self.columns[k].align {
                Align::Left => "---|",
                Align::Right => "---:|",
                Align::Center => ":---:|",
            };
        }
        s += "\n";
        for row in &self.rows {
            s += &line(&|k| row[k].clone());
        }
        s
    }

    /// The terminal's table: the columns it shows, padded to a common width per column, a
    /// rule of dashes under the titles.
    pub fn text(&self) -> String {
        let shown: Vec<usize> = (0..self.columns.len())
            .filter(|&k| self.columns[k].shown != Shown::Page)
            .collect();
        let title = |c: &Column| c.short.clone().unwrap_or_else(|| c.title.clone());
        let widths: Vec<usize> = shown
            .iter()
            .map(|&k| {
                let c = &self.columns[k];
                self.rows
                    .iter()
                    .map(|r| r[k].chars().count())
                    .chain([title(c).chars().count(), c.min_width])
                    .max()
                    .unwrap_or(0)
            })
            .collect();
        let line = |cell: &dyn Fn(usize) -> String| {
            let mut s = String::from("|");
            for (&k, &w) in shown.iter().zip(&widths) {
                let text = cell(k);
                let pad = " ".repeat(w.saturating_sub(text.chars().count()));
                s += &match self.columns[k].align {
                    Align::Left => format!(" {text}{pad} |"),
                    Align::Right => format!(" {pad}{text} |"),
                    Align::Center => {
                        let (before, after) = pad.split_at(pad.len() / 2);
                        format!(" {before}{text}{after} |")
                    }
                };
            }
            s + "\n"
        };
        let mut s = line(&|k| title(&self.columns[k]));
        s += "|";
        for w in &widths {
            s += &"-".repeat(w + 2);
            s += "|";
        }
        s += "\n";
        for row in &self.rows {
            s += &line(&|k| row[k].clone());
        }
        s
    }
}

/// The validation's comparison of data and re-simulated model, one row per response.
pub(crate) fn validation(v: &super::Validation) -> Table {
    let mut t = Table::new()
        .left("response")
        .min_width(10)
        .right("data std")
        .min_width(10)
        .right("model std")
        .page_only()
        .right("difference ± s.e.")
        .short("diff ± s.e.")
        .min_width(16)
        .right("data kurtosis")
        .page_only()
        .right("model kurtosis")
        .page_only()
        .right("kurt d/m")
        .terminal_only()
        .right("spectrum RMS ln ratio (averaging alone)")
        .short("spec rms ln")
        .min_width(13)
        .right("peak ω data / model (rad/s)")
        .short("peak ω d/m")
        .min_width(13);
    for row in &v.rows {
        let (spec, peak) = row.spectrum.as_ref().map_or(("–".into(), "–".into()), |c| {
            (
                format!("{:.3} ({:.3})", c.rms_log_difference, c.averaging_alone),
                format!("{:.3} / {:.3}", c.data_peak_rad_s, c.model_peak_rad_s),
            )
        });
        t.row([
            row.variable.clone(),
            format!("{:.5}", row.data_std),
            format!("{:.5}", row.model_std),
            row.std_difference(),
            format!("{:.3}", row.data_kurtosis),
            format!("{:.3}", row.model_kurtosis),
            format!("{:.3}/{:.3}", row.data_kurtosis, row.model_kurtosis),
            spec,
            peak,
        ]);
    }
    t
}

/// The integrator's bias on every estimate of every method; a ratio to the standard
/// error above a quarter in bold.
pub(crate) fn integrator_bias(b: &super::IntegratorBias) -> Table {
    let mut t = Table::new()
        .left("method")
        .left("parameter")
        .right("estimate")
        .right("bias")
        .right("std. error")
        .right("bias / s.e.");
    for m in &b.methods {
        for p in &m.parameters {
            let ratio = format!("{:.2}", p.bias / p.std_error);
            t.row([
                m.method.to_string(),
                p.name.to_string(),
                format!("{:.6e}", p.estimate),
                format!("{:.3e}", p.bias),
                format!("{:.3e}", p.std_error),
                if p.exceeds { format!("**{ratio}**") } else { ratio },
            ]);
        }
    }
    t
}

/// One method's estimates: unit, true value, estimate, standard error, the Cramér–Rao
/// bound where one applies, 95 % interval, whether it differs from 0, and the error.
pub(crate) fn estimates(m: &super::MethodReport, motion: crate::scenario::Motion) -> Table {
    use super::text::{fixed, fmt_err};
    let bound = m.parameters.iter().any(|p| p.cramer_rao_std.is_some());
    let mut t = Table::new()
        .left("parameter")
        .left("unit")
        .right("true")
        .right("estimate")
        .right("std. error");
    if bound {
        t = t.right("CR bound");
    }
    t = t.left("95 % interval").left("differs from 0").right("error");
    for p in &m.parameters {
        let d = super::text::decimals(p.std_error);
        let mut cells = vec![
            format!("`{}`", p.name),
            super::plot::iteration::parameter_unit(&p.name, motion),
            if p.true_value.is_finite() {
                format!("{:.4}", p.true_value)
            } else {
                "—".into()
            },
            fixed(p.estimate, d),
            fixed(p.std_error, d),
        ];
        if bound {
            cells.push(p.cramer_rao_std.map_or("—".into(), |b| fixed(b, d)));
        }
        cells.push(
            p.ci95
                .map_or("—".into(), |[lo, hi]| format!("[{}, {}]", fixed(lo, d), fixed(hi, d))),
        );
        cells.push(
            match p.differs_from_zero {
                Some(true) => "yes",
                Some(false) => "no",
                None => "—",
            }
            .into(),
        );
        cells.push(fmt_err(p.rel_error));
        t.row(cells);
    }
    t
}

/// Methods side by side: per parameter its unit, true value, and each method's estimate ±
/// standard error (° where its 95 % interval holds 0) and error.
pub(crate) fn side_by_side(methods: &[&super::MethodReport], motion: crate::scenario::Motion) -> Table {
    use super::text::{fmt_err, fmt_estimate, EST_W};
    let mut t = Table::new()
        .left("parameter")
        .min_width(18)
        .left("unit")
        .min_width(10)
        .right("true")
        .min_width(10);
    for m in methods {
        t = t
            .left(format!("{} ± std. error", m.method))
            .min_width(EST_W)
            .right("error")
            .min_width(9);
    }
    let Some(first) = methods.iter().find(|m| !m.parameters.is_empty()) else {
        return t;
    };
    for (k, p) in first.parameters.iter().enumerate() {
        let truth = methods
            .iter()
            .find_map(|m| m.parameters.get(k))
            .map_or(f64::NAN, |p| p.true_value);
        let mut cells = vec![
            p.name.to_string(),
            super::plot::iteration::parameter_unit(&p.name, motion),
            if truth.is_finite() {
                format!("{truth:.4}")
            } else {
                "—".into()
            },
        ];
        for m in methods {
            match m.parameters.get(k) {
                Some(p) => cells.extend([fmt_estimate(p), fmt_err(p.rel_error)]),
                None => cells.extend(["—".to_string(), "—".to_string()]),
            }
        }
        t.row(cells);
    }
    t
}

/// One method's characteristics: the curve's error and the range it was judged over.
pub(crate) fn curves(m: &super::MethodReport) -> Table {
    let mut t = Table::new()
        .left("characteristic")
        .right("relative L2 error (observed density)")
        .left("observed range");
    for c in &m.curves {
        t.row([
            format!("{} {}", c.link, c.kind),
            super::text::fmt_err(c.rel_l2_error),
            format!("[{:.4}, {:.4}]", c.range[0], c.range[1]),
        ]);
    }
    t
}

/// The sensors' noise per channel: estimate, its standard error, its share of the signal,
/// what was simulated and what was taken out.
pub(crate) fn sensor_noise(n: &super::SensorNoiseReport) -> Table {
    let mut t = Table::new()
        .left("channel")
        .right("noise std")
        .right("±")
        .right("of the signal's std")
        .right("simulated")
        .right("taken out");
    for c in &n.channels {
        t.row([
            c.column.clone(),
            format!("{:.4e}", c.std),
            format!("{:.1e}", c.std_se),
            format!(
                "{:.2} %{}",
                100.0 * c.std / c.signal_std,
                if c.above_ceiling {
                    " (above the spectrum's ceiling: not estimable)"
                } else if c.detected {
                    ""
                } else {
                    " (none detected)"
                }
            ),
            c.simulated_std.map_or("—".to_string(), |v| format!("{v:.4e}")),
            if c.corrected_std > 0.0 {
                format!("{:.4e}", c.corrected_std)
            } else {
                "—".to_string()
            },
        ]);
    }
    t
}

/// The filtered excitations: the filter used, the spectral fit and the truth.
pub(crate) fn filters(r: &super::Report) -> Table {
    let mut t = Table::new().left("excitation").left("used");
    for title in ["A", "B", "fitted A", "fitted B", "true A", "true B"] {
        t = t.right(title);
    }
    for f in &r.filters {
        t.row(
            [f.excitation.clone(), f.used.to_string()]
                .into_iter()
                .chain([f.a, f.b, f.fitted_a, f.fitted_b, f.true_a, f.true_b].map(|x| format!("{x:.4}"))),
        );
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    fn example() -> Table {
        let mut t = Table::new()
            .left("parameter")
            .min_width(12)
            .right("estimate")
            .right("spectrum RMS ln ratio")
            .short("spec")
            .right("page")
            .page_only()
            .left("t")
            .terminal_only();
        t.row(["k1[ground-m1]", "1.50", "0.1", "x", "u"]);
        t.row(["c1", "-12.25", "0.25", "y", "v"]);
        t
    }

    #[test]
    fn markdown_has_every_column_and_its_alignment() {
        assert_eq!(
            example().markdown(),
            "| parameter | estimate | spectrum RMS ln ratio | page |\n|---|---:|---:|---:|\n\
             | k1[ground-m1] | 1.50 | 0.1 | x |\n| c1 | -12.25 | 0.25 | y |\n"
        );
    }

    #[test]
    fn the_terminal_aligns_the_columns_it_shows_under_their_short_titles() {
        assert_eq!(
            example().text(),
            "| parameter     | estimate | spec | t |\n|---------------|----------|------|---|\n\
             | k1[ground-m1] |     1.50 |  0.1 | u |\n| c1            |   -12.25 | 0.25 | v |\n"
        );
    }

    #[test]
    fn a_least_width_holds_when_the_cells_are_narrower() {
        let mut t = Table::new().left("a").min_width(4).right("b").min_width(3);
        t.row(["x", "1"]);
        assert_eq!(t.text(), "| a    |   b |\n|------|-----|\n| x    |   1 |\n");
    }

    #[test]
    #[should_panic(expected = "one cell per column")]
    fn a_row_of_the_wrong_length_is_a_bug() {
        Table::new().left("a").row(["x", "y"]);
    }
}
