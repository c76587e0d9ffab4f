//! Legends: framed in a corner of the plot area, or flowing in rows above it
//! ([`Corner::Above`]), each entry's swatch drawn in its curve's own style; and the
//! panel's notes.

use super::{c, text, text_width, Corner, Frame, Panel, Swatch};
use std::fmt::Write;

/// The rows a panel's legend takes above its plot area (0 unless [`Corner::Above`]).
pub(super) fn legend_rows(p: &Panel, width: f64) -> usize {
    if p.legend_at != Corner::Above || p.legend_only {
        return 0;
    }
    flow(&p.legend, width).iter().map(|e| e.2 + 1).max().unwrap_or(0)
}

/// The legend in its corner and the notes below it.
pub(super) fn draw_legend_and_notes(out: &mut String, p: &Panel, f: &Frame) {
    let (left, top, pw, ph) = (f.left, f.top, f.w, f.h);
    let bottom = top + ph;
    let lw = legend_width(&p.legend);
    let lh = 20.0 * p.legend.len() as f64 + 8.0;
    let at = match p.legend_at {
        Corner::Above | Corner::UpperLeft => (left + 8.0, top + 8.0),
        Corner::UpperRight => (left + pw - lw - 8.0, top + 8.0),
        Corner::LowerLeft => (left + 8.0, bottom - lh - 8.0),
        Corner::LowerRight => (left + pw - lw - 8.0, bottom - lh - 8.0),
        Corner::LowerMiddle => (left + (pw - lw) / 2.0, bottom - lh - 8.0),
    };
    if !p.legend.is_empty() && p.legend_at != Corner::Above {
        draw_legend(out, &p.legend, at, Some((lw, lh)));
    }
    if !p.notes.is_empty() {
        let ny = if p.legend.is_empty()
            || matches!(
                p.legend_at,
                Corner::LowerLeft | Corner::LowerRight | Corner::LowerMiddle | Corner::Above
            ) {
            top + 18.0
        } else {
            top + lh + 26.0
        };
        for (k, n) in p.notes.iter().enumerate() {
            text(
                out,
                left + 10.0,
                ny + 16.0 * k as f64,
                12.0,
                "start",
                " fill=\"#333333\"",
                n,
            );
        }
    }
}

fn legend_width(entries: &[(Swatch, String)]) -> f64 {
    entries.iter().map(|(_, l)| text_width(l, 12.0)).fold(0.0, f64::max) + 50.0
}

/// A legend at `(x, y)`: swatch then label per entry; framed when `frame` gives its size.
pub(super) fn draw_legend(
    out: &mut String,
    entries: &[(Swatch, String)],
    (x, y): (f64, f64),
    frame: Option<(f64, f64)>,
) {
    if let Some((w, h)) = frame {
        let _ = writeln!(
            out,
            "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"white\" fill-opacity=\"0.88\" stroke=\"#555555\" stroke-width=\"0.8\"/>",
            c(x),
            c(y),
            c(w),
            c(h)
        );
    }
    for (k, (swatch, label)) in entries.iter().enumerate() {
        legend_entry(out, swatch, label, x, y + 20.0 * k as f64);
    }
}

/// The height of one row of a legend above the plot area.
pub(super) const LEGEND_ROW: f64 = 18.0;

/// Where each entry of a legend above the plot area goes, flowing left to right within
/// `width` pixels: (x offset, width, row).
pub(super) fn flow(entries: &[(Swatch, String)], width: f64) -> Vec<(f64, f64, usize)> {
    let mut out = Vec::with_capacity(entries.len());
    let (mut x, mut row) = (0.0, 0);
    for (_, label) in entries {
        let w = text_width(label, 12.0) + 56.0;
        if x > 0.0 && x + w > width {
            x = 0.0;
            row += 1;
        }
        out.push((x, w, row));
        x += w;
    }
    out
}

/// One legend entry whose box starts at `(x, y)`: the swatch in the curve's own style, then
/// the label.
pub(super) fn legend_entry(out: &mut String, swatch: &Swatch, label: &str, x: f64, y: f64) {
    let cy = y + 14.0;
    let (sx0, sx1) = (x + 8.0, x + 38.0);
    match swatch {
        Swatch::Line(s) => {
            let _ = writeln!(out, "<path d=\"M{} {} H{}\" {}/>", c(sx0), c(cy), c(sx1), s.attrs());
        }
        Swatch::LinePoint(s, r) => {
            let _ = writeln!(out, "<path d=\"M{} {} H{}\" {}/>", c(sx0), c(cy), c(sx1), s.attrs());
            let _ = writeln!(
                out,
                "<circle cx=\"{}\" cy=\"{}\" r=\"{r}\" fill=\"{}\"/>",
                c((sx0 + sx1) / 2.0),
                c(cy),
                s.color.hex()
            );
        }
        Swatch::Point(col, r) => {
            let _ = writeln!(
                out,
                "<circle cx=\"{}\" cy=\"{}\" r=\"{r}\" fill=\"{}\"/>",
                c((sx0 + sx1) / 2.0),
                c(cy),
                col.hex()
            );
        }
        Swatch::Patch(col, opacity) => {
            let _ = writeln!(
                out,
                "<rect x=\"{}\" y=\"{}\" width=\"30\" height=\"10\" fill=\"{}\" fill-opacity=\"{opacity}\"/>",
                c(sx0),
                c(cy - 5.0),
                col.hex()
            );
        }
    }
    text(out, sx1 + 8.0, cy + 4.0, 12.0, "start", "", label);
}
