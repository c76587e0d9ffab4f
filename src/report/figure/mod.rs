//! A small vector-figure writer for the report's plots: panels on a grid, linear or
//! logarithmic axes with ticks formatted for people, lines (solid or dashed, one path per
//! curve), bands, points, histogram bars, legends whose swatches match the line styles,
//! and marks where a curve leaves the plotted range. Coordinates are written to 1/100 of a
//! pixel, so straight lines stay straight at any zoom.
//!
//! The SVG names the bundled DejaVu Sans first; [`crate::report::raster`] renders the same
//! file to PNG and PDF with that font embedded, so no system font is needed.

use std::fmt::Write;

mod axis;
mod legend;
pub use axis::*;
use legend::{draw_legend, draw_legend_and_notes, flow, legend_entry, legend_rows, LEGEND_ROW};

/// An sRGB colour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Color(pub u8, pub u8, pub u8);

impl Color {
    fn hex(self) -> String {
        format!("#{:02x}{:02x}{:02x}", self.0, self.1, self.2)
    }
}

pub const BLACK: Color = Color(0, 0, 0);
pub const GREY: Color = Color(120, 120, 120);
pub const LIGHT_GREY: Color = Color(175, 175, 175);

/// The series colours, in order (colour-blind-safe "tab10" start).
pub const COLORS: [Color; 7] = [
    Color(31, 119, 180),
    Color(255, 127, 14),
    Color(44, 160, 44),
    Color(214, 39, 40),
    Color(148, 103, 189),
    Color(140, 86, 75),
    Color(227, 119, 194),
];

/// The series colour `k` (cycling).
pub fn color(k: usize) -> Color {
    COLORS[k % COLORS.len()]
}

/// A line's style: colour, width in pixels and an optional dash pattern (dash, gap).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stroke {
    pub color: Color,
    pub width: f64,
    pub dash: Option<(f64, f64)>,
}

impl Stroke {
    pub fn solid(color: Color, width: f64) -> Stroke {
        Stroke {
            color,
            width,
            dash: None,
        }
    }
    pub fn dashed(color: Color, width: f64, dash: f64, gap: f64) -> Stroke {
        Stroke {
            color,
            width,
            dash: Some((dash, gap)),
        }
    }
    fn attrs(&self) -> String {
        let mut s = format!(
            "fill=\"none\" stroke=\"{}\" stroke-width=\"{}\" stroke-linejoin=\"round\"",
            self.color.hex(),
            self.width
        );
        if let Some((d, g)) = self.dash {
            let _ = write!(s, " stroke-dasharray=\"{d} {g}\"");
        }
        s
    }
}

/// What a panel draws, in data coordinates.
#[derive(Debug, Clone)]
pub enum Mark {
    /// A polyline (non-finite points break it).
    Line { points: Vec<(f64, f64)>, stroke: Stroke },
    /// The region between `lower` and `upper` over `xs`, filled with `color` at `opacity`.
    Band {
        xs: Vec<f64>,
        lower: Vec<f64>,
        upper: Vec<f64>,
        color: Color,
        opacity: f64,
    },
    /// Filled circles of `radius` pixels.
    Points {
        points: Vec<(f64, f64)>,
        color: Color,
        radius: f64,
    },
    /// Vertical segments `(x, y_low, y_high)` (error bars).
    Bars { bars: Vec<(f64, f64, f64)>, stroke: Stroke },
    /// A histogram: bins of equal width from `lo`, heights as given, one filled path.
    Histogram {
        lo: f64,
        width: f64,
        heights: Vec<f64>,
        color: Color,
    },
    /// A horizontal line across the panel at `y`.
    HLine { y: f64, stroke: Stroke },
}

/// A legend entry's swatch.
#[derive(Debug, Clone, Copy)]
pub enum Swatch {
    Line(Stroke),
    /// A line with a point on it (a series drawn with markers).
    LinePoint(Stroke, f64),
    Point(Color, f64),
    /// A filled patch (a band or a histogram).
    Patch(Color, f64),
}

/// Where a panel's legend goes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Corner {
    UpperLeft,
    UpperRight,
    LowerLeft,
    LowerRight,
    /// Centred at the bottom (a log density's tails leave the middle free there).
    LowerMiddle,
    /// Above the plot area, between the title and the frame: never over the data. Entries
    /// flow left to right and wrap; the plot area shrinks by the rows they need.
    Above,
}

/// One panel: a title, two axes, marks, a legend and notes.
#[derive(Debug, Clone)]
pub struct Panel {
    pub title: String,
    pub x: Axis,
    pub y: Axis,
    pub marks: Vec<Mark>,
    pub legend: Vec<(Swatch, String)>,
    pub legend_at: Corner,
    /// Lines of text written in the panel's top-left corner, under the legend if there.
    pub notes: Vec<String>,
    /// Per line mark (by index in `marks`): mark with an arrow where it leaves the range.
    pub mark_exits: bool,
    /// A panel with no axes: its legend (and notes) fill the cell.
    pub legend_only: bool,
}

impl Panel {
    pub fn new(title: impl Into<String>, x: Axis, y: Axis) -> Panel {
        Panel {
            title: title.into(),
            x,
            y,
            marks: Vec::new(),
            legend: Vec::new(),
            legend_at: Corner::UpperLeft,
            notes: Vec::new(),
            mark_exits: false,
            legend_only: false,
        }
    }
    /// A cell holding only a legend.
    pub fn legend_cell(entries: Vec<(Swatch, String)>) -> Panel {
        let mut p = Panel::new("", Axis::linear(0.0, 1.0, ""), Axis::linear(0.0, 1.0, ""));
        p.legend = entries;
        p.legend_only = true;
        p
    }
    pub fn mark(&mut self, m: Mark) -> &mut Panel {
        self.marks.push(m);
        self
    }
    pub fn line(&mut self, points: Vec<(f64, f64)>, stroke: Stroke, label: Option<String>) -> &mut Panel {
        if let Some(l) = label {
            self.legend.push((Swatch::Line(stroke), l));
        }
        self.mark(Mark::Line { points, stroke })
    }
    pub fn entry(&mut self, swatch: Swatch, label: impl Into<String>) -> &mut Panel {
        self.legend.push((swatch, label.into()));
        self
    }
}

/// A row of panels of equal width, `height` pixels tall (`None`: an empty cell).
#[derive(Debug, Clone)]
pub struct Row {
    pub height: f64,
    pub cells: Vec<Option<Panel>>,
}

/// A figure: rows of panels, an optional title above and caption below.
#[derive(Debug, Clone)]
pub struct Figure {
    pub width: f64,
    pub title: Option<String>,
    pub rows: Vec<Row>,
    /// Lines under the figure (what it shows, in words).
    pub caption: Vec<String>,
}

const FONT: &str = "DejaVu Sans, Verdana, Arial, Helvetica, sans-serif";
const LEFT: f64 = 74.0;
const RIGHT: f64 = 16.0;
const TOP: f64 = 28.0;
const BOTTOM: f64 = 44.0;

/// The width in pixels of `text` at `size` (DejaVu Sans's mean advance, a little generous).
fn text_width(text: &str, size: f64) -> f64 {
    text.chars().count() as f64 * size * 0.58
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A coordinate to 1/100 pixel, without trailing zeros.
fn c(v: f64) -> String {
    let s = format!("{v:.2}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.into()
    }
}

fn text(out: &mut String, x: f64, y: f64, size: f64, anchor: &str, extra: &str, s: &str) {
    let _ = writeln!(
        out,
        "<text x=\"{}\" y=\"{}\" font-size=\"{size}\" text-anchor=\"{anchor}\"{extra}>{}</text>",
        c(x),
        c(y),
        escape(s)
    );
}

/// Wrap `s` into lines of about `width` pixels at `size`.
fn wrap(s: &str, width: f64, size: f64) -> Vec<String> {
    let max = (width / (size * 0.58)).max(10.0) as usize;
    let mut lines = vec![String::new()];
    for word in s.split(' ') {
        let last = lines.last_mut().expect("one line");
        if !last.is_empty() && last.chars().count() + 1 + word.chars().count() > max {
            lines.push(word.to_string());
        } else {
            if !last.is_empty() {
                last.push(' ');
            }
            last.push_str(word);
        }
    }
    lines
}

impl Figure {
    pub fn new(width: f64) -> Figure {
        Figure {
            width,
            title: None,
            rows: Vec::new(),
            caption: Vec::new(),
        }
    }

    /// Add a row of panels `height` pixels tall.
    pub fn row(&mut self, height: f64, cells: Vec<Option<Panel>>) -> &mut Figure {
        self.rows.push(Row { height, cells });
        self
    }

    /// Lay out panels `cols` to a row, each `height` tall.
    pub fn grid(&mut self, cols: usize, height: f64, panels: Vec<Panel>) -> &mut Figure {
        let mut it = panels.into_iter().peekable();
        while it.peek().is_some() {
            let mut cells: Vec<Option<Panel>> = it.by_ref().take(cols).map(Some).collect();
            cells.resize_with(cols, || None);
            self.row(height, cells);
        }
        self
    }

    /// The figure as an SVG document.
    pub fn svg(&self) -> String {
        let title_h = if self.title.is_some() { 30.0 } else { 0.0 };
        let caption: Vec<String> = self
            .caption
            .iter()
            .flat_map(|p| wrap(p, self.width - 40.0, 13.0))
            .collect();
        let caption_h = if caption.is_empty() {
            0.0
        } else {
            10.0 + 17.0 * caption.len() as f64
        };
        let body: f64 = self.rows.iter().map(|r| r.height).sum();
        let height = (title_h + body + caption_h).ceil();
        let mut out = String::new();
        let _ = writeln!(
            out,
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{height}\" viewBox=\"0 0 {w} {height}\" \
             font-family=\"{FONT}\">",
            w = self.width
        );
        let _ = writeln!(out, "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>");
        if let Some(t) = &self.title {
            text(
                &mut out,
                self.width / 2.0,
                21.0,
                17.0,
                "middle",
                " font-weight=\"bold\"",
                t,
            );
        }
        let mut y = title_h;
        let mut clip = 0usize;
        for row in &self.rows {
            let n = row.cells.len().max(1) as f64;
            let w = self.width / n;
            // Legends above the plot take the same rows across the row of panels, so the
            // plot areas line up.
            let rows = row
                .cells
                .iter()
                .flatten()
                .map(|p| legend_rows(p, w - LEFT - RIGHT))
                .max()
                .unwrap_or(0);
            for (k, cell) in row.cells.iter().enumerate() {
                if let Some(p) = cell {
                    draw_panel(&mut out, p, (k as f64 * w, y, w, row.height), rows, &mut clip);
                }
            }
            y += row.height;
        }
        for (k, line) in caption.iter().enumerate() {
            text(&mut out, 20.0, y + 20.0 + 17.0 * k as f64, 13.0, "start", "", line);
        }
        out += "</svg>\n";
        out
    }
}

/// Pixel mapping of a panel's plot area.
struct Frame<'a> {
    x: &'a Axis,
    y: &'a Axis,
    left: f64,
    top: f64,
    w: f64,
    h: f64,
}

impl Frame<'_> {
    fn px(&self, v: f64) -> f64 {
        self.left + self.x.frac(v) * self.w
    }
    fn py(&self, v: f64) -> f64 {
        self.top + (1.0 - self.y.frac(v)) * self.h
    }
    /// A value mapped to pixels, with values far outside the range held a little beyond
    /// the frame (the clip hides them; the path keeps its direction).
    fn point(&self, (x, y): (f64, f64)) -> Option<(f64, f64)> {
        if !x.is_finite() || !y.is_finite() || (self.x.log && x <= 0.0) {
            return None;
        }
        let y = if self.y.log && y <= 0.0 { self.y.lo * 1e-3 } else { y };
        let px = self.px(x);
        let py = self.py(y).clamp(self.top - 4.0 * self.h, self.top + 5.0 * self.h);
        Some((px, py))
    }
}

fn path_of(points: impl Iterator<Item = Option<(f64, f64)>>) -> String {
    let mut d = String::new();
    let mut pen = false;
    for p in points {
        match p {
            Some((x, y)) => {
                let _ = write!(d, "{}{} {}", if pen { " L" } else { " M" }, c(x), c(y));
                pen = true;
            }
            None => pen = false,
        }
    }
    d.trim_start().to_string()
}

/// One panel in its cell; `legend_rows`: the rows reserved above the plot for the legend.
fn draw_panel(out: &mut String, p: &Panel, (x0, y0, w, h): (f64, f64, f64, f64), legend_rows: usize, clip: &mut usize) {
    if p.legend_only {
        draw_legend(out, &p.legend, (x0 + 20.0, y0 + 20.0), None);
        return;
    }
    let title_margin = if p.title.is_empty() { 8.0 } else { TOP };
    let pw = w - LEFT - RIGHT;
    let above = if p.legend_at == Corner::Above {
        flow(&p.legend, pw)
    } else {
        Vec::new()
    };
    let top_margin = title_margin + LEGEND_ROW * legend_rows as f64;
    let top = y0 + top_margin;
    let left = x0 + LEFT;
    let bottom_margin = match (p.x.tick_labels, p.x.label.is_empty()) {
        (true, false) => BOTTOM,
        (false, false) | (true, true) => BOTTOM - 18.0,
        (false, true) => 8.0,
    };
    let ph = h - top_margin - bottom_margin;
    for ((swatch, label), &(dx, _, row)) in p.legend.iter().zip(&above) {
        legend_entry(
            out,
            swatch,
            label,
            left + dx - 8.0,
            y0 + title_margin - 5.0 + LEGEND_ROW * row as f64,
        );
    }
    if !p.title.is_empty() {
        let size = if text_width(&p.title, 14.0) > w - 20.0 {
            12.0
        } else {
            14.0
        };
        text(out, x0 + LEFT + pw / 2.0, y0 + 18.0, size, "middle", "", &p.title);
    }
    if !(p.x.drawable() && p.y.drawable()) || pw < 20.0 || ph < 10.0 {
        let msg = format!(
            "not drawn: axis range x [{:.3e}, {:.3e}], y [{:.3e}, {:.3e}] (non-finite or extreme values)",
            p.x.lo, p.x.hi, p.y.lo, p.y.hi
        );
        for (k, line) in wrap(&msg, w - 40.0, 13.0).iter().enumerate() {
            text(out, x0 + 20.0, top + 20.0 + 16.0 * k as f64, 13.0, "start", "", line);
        }
        return;
    }
    let f = Frame {
        x: &p.x,
        y: &p.y,
        left,
        top,
        w: pw,
        h: ph,
    };
    let (ticks, xmaj, ymaj) = draw_grid(out, p, &f);
    let exits = draw_marks(out, p, &f, clip);
    draw_exits(out, &f, &exits);
    // Frame, ticks, labels.
    let _ = writeln!(
        out,
        "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"black\" stroke-width=\"1\"/>",
        c(left),
        c(top),
        c(pw),
        c(ph)
    );
    let _ = writeln!(
        out,
        "<path d=\"{}\" stroke=\"black\" stroke-width=\"1\" fill=\"none\"/>",
        ticks.trim()
    );
    draw_labels(out, p, &f, &xmaj, &ymaj, x0);
    draw_legend_and_notes(out, p, &f);
}

/// A tick's value and its label.
type Ticks = Vec<(f64, String)>;

/// The grid lines of the major ticks; returns the tick marks' path (drawn over the frame)
/// and the labelled ticks.
fn draw_grid(out: &mut String, p: &Panel, f: &Frame) -> (String, Ticks, Ticks) {
    let (left, top, pw, ph) = (f.left, f.top, f.w, f.h);
    let mut grid = String::new();
    let mut ticks = String::new();
    let (xmaj, xmin) = p.x.ticks();
    let (ymaj, ymin) = p.y.ticks();
    let bottom = top + ph;
    for (v, _) in &xmaj {
        let x = f.px(*v);
        let _ = write!(grid, " M{} {} V{}", c(x), c(top), c(bottom));
        let _ = write!(ticks, " M{} {} v5", c(x), c(bottom));
    }
    for v in &xmin {
        let _ = write!(ticks, " M{} {} v3", c(f.px(*v)), c(bottom));
    }
    let (ymaj, ymin) = if p.y.tick_labels {
        (ymaj, ymin)
    } else {
        (Vec::new(), Vec::new())
    };
    for (v, _) in &ymaj {
        let y = f.py(*v);
        let _ = write!(grid, " M{} {} H{}", c(left), c(y), c(left + pw));
        let _ = write!(ticks, " M{} {} h-5", c(left), c(y));
    }
    for v in &ymin {
        let _ = write!(ticks, " M{} {} h-3", c(left), c(f.py(*v)));
    }
    let _ = writeln!(
        out,
        "<path d=\"{}\" stroke=\"#e6e6e6\" stroke-width=\"1\" fill=\"none\"/>",
        grid.trim()
    );
    (ticks, xmaj, ymaj)
}

/// Every mark, clipped to the plot area; returns where clipped curves leave the range
/// (`x`, above, colour).
fn draw_marks(out: &mut String, p: &Panel, f: &Frame, clip: &mut usize) -> Vec<(f64, bool, Color)> {
    let (left, top, pw, ph) = (f.left, f.top, f.w, f.h);
    *clip += 1;
    let id = format!("clip{clip}");
    let _ = writeln!(
        out,
        "<clipPath id=\"{id}\"><rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\"/></clipPath>\n<g clip-path=\"url(#{id})\">",
        c(left),
        c(top),
        c(pw),
        c(ph)
    );
    let mut exits: Vec<(f64, bool, Color)> = Vec::new();
    for m in &p.marks {
        match m {
            Mark::Line { points, stroke } => {
                let d = path_of(points.iter().map(|&q| f.point(q)));
                if !d.is_empty() {
                    let _ = writeln!(out, "<path d=\"{d}\" {}/>", stroke.attrs());
                }
                if p.mark_exits {
                    let above = points.iter().find(|q| q.1 > p.y.hi);
                    let below = points.iter().find(|q| q.1 < p.y.lo);
                    if let Some(q) = above {
                        exits.push((f.px(q.0), true, stroke.color));
                    }
                    if let Some(q) = below {
                        exits.push((f.px(q.0), false, stroke.color));
                    }
                }
            }
            Mark::Band {
                xs,
                lower,
                upper,
                color,
                opacity,
            } => {
                let outline = xs
                    .iter()
                    .zip(upper)
                    .map(|(&x, &y)| f.point((x, y)))
                    .chain(xs.iter().zip(lower).rev().map(|(&x, &y)| f.point((x, y))))
                    .flatten();
                let d = path_of(outline.map(Some));
                if !d.is_empty() {
                    let _ = writeln!(
                        out,
                        "<path d=\"{d} Z\" fill=\"{}\" fill-opacity=\"{opacity}\" stroke=\"none\"/>",
                        color.hex()
                    );
                }
            }
            Mark::Points { points, color, radius } => {
                let _ = write!(out, "<g fill=\"{}\">", color.hex());
                for q in points.iter().filter_map(|&q| f.point(q)) {
                    let _ = write!(out, "<circle cx=\"{}\" cy=\"{}\" r=\"{radius}\"/>", c(q.0), c(q.1));
                }
                out.push_str("</g>\n");
            }
            Mark::Bars { bars, stroke } => {
                let mut d = String::new();
                for &(x, a, b) in bars {
                    if let (Some(p0), Some(p1)) = (f.point((x, a)), f.point((x, b))) {
                        let _ = write!(d, " M{} {} V{}", c(p0.0), c(p0.1), c(p1.1));
                    }
                }
                if !d.is_empty() {
                    let _ = writeln!(out, "<path d=\"{}\" {}/>", d.trim(), stroke.attrs());
                }
            }
            Mark::Histogram {
                lo,
                width,
                heights,
                color,
            } => {
                // One outline of the whole histogram (no seams between bars).
                let base = if p.y.log { p.y.lo } else { 0.0f64.max(p.y.lo) };
                let yb = f.py(base);
                let mut d = format!("M{} {}", c(f.px(*lo)), c(yb));
                for (i, &hgt) in heights.iter().enumerate() {
                    let y = if hgt > base { f.py(hgt.min(p.y.hi)) } else { yb };
                    let _ = write!(d, " V{} H{}", c(y), c(f.px(lo + (i + 1) as f64 * width)));
                }
                let _ = write!(d, " V{} Z", c(yb));
                let _ = writeln!(out, "<path d=\"{d}\" fill=\"{}\" stroke=\"none\"/>", color.hex());
            }
            Mark::HLine { y, stroke } => {
                if y.is_finite() {
                    let py = f.py(*y);
                    let _ = writeln!(
                        out,
                        "<path d=\"M{} {} H{}\" {}/>",
                        c(left),
                        c(py),
                        c(left + pw),
                        stroke.attrs()
                    );
                }
            }
        }
    }
    out.push_str("</g>\n");
    exits
}

/// Arrows where clipped curves leave the range.
fn draw_exits(out: &mut String, f: &Frame, exits: &[(f64, bool, Color)]) {
    let (top, bottom) = (f.top, f.top + f.h);
    for &(x, up, color) in exits {
        let (tip, base) = if up {
            (top + 1.0, top + 11.0)
        } else {
            (bottom - 1.0, bottom - 11.0)
        };
        let _ = writeln!(
            out,
            "<path d=\"M{} {} L{} {} L{} {} Z\" fill=\"{}\"/>",
            c(x),
            c(tip),
            c(x - 6.0),
            c(base),
            c(x + 6.0),
            c(base),
            color.hex()
        );
    }
}

/// Tick labels that do not overlap, and the axis labels.
fn draw_labels(out: &mut String, p: &Panel, f: &Frame, xmaj: &Ticks, ymaj: &Ticks, x0: f64) {
    let (left, top, pw, ph) = (f.left, f.top, f.w, f.h);
    let bottom = top + ph;
    if p.x.tick_labels {
        let mut last_right = f64::NEG_INFINITY;
        for (v, l) in xmaj {
            let x = f.px(*v);
            let half = text_width(l, 12.0) / 2.0;
            if x - half < last_right + 4.0 {
                continue; // would overlap its left neighbour
            }
            last_right = x + half;
            text(out, x, bottom + 18.0, 12.0, "middle", "", l);
        }
    }
    if !p.x.label.is_empty() {
        let ly = bottom + if p.x.tick_labels { 36.0 } else { 18.0 };
        text(out, left + pw / 2.0, ly, 13.0, "middle", "", &p.x.label);
    }
    if p.y.tick_labels {
        let mut last_top = f64::INFINITY;
        for (v, l) in ymaj {
            let y = f.py(*v);
            if y + 6.0 > last_top - 2.0 {
                continue;
            }
            last_top = y - 6.0;
            text(out, left - 8.0, y + 4.0, 12.0, "end", "", l);
        }
    }
    if !p.y.label.is_empty() {
        let size = if text_width(&p.y.label, 13.0) > ph { 11.0 } else { 13.0 };
        let (lx, ly) = (x0 + 14.0, top + ph / 2.0);
        let _ = writeln!(
            out,
            "<text x=\"{}\" y=\"{}\" font-size=\"{size}\" text-anchor=\"middle\" transform=\"rotate(-90 {} {})\">{}</text>",
            c(lx),
            c(ly),
            c(lx),
            c(ly),
            escape(&p.y.label)
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_ticks_are_round_and_clean() {
        let t = linear_ticks(-0.3, 0.31, 6);
        let labels: Vec<&str> = t.iter().map(|x| x.1.as_str()).collect();
        assert_eq!(labels, ["−0.3", "−0.2", "−0.1", "0", "0.1", "0.2", "0.3"]);
        let t = linear_ticks(0.0, 5.0, 6);
        assert_eq!(
            t.iter().map(|x| x.1.as_str()).collect::<Vec<_>>(),
            ["0", "1", "2", "3", "4", "5"]
        );
        let t = linear_ticks(0.0, 3e-5, 6);
        assert_eq!(t[1].1, "10⁻⁵");
        assert_eq!(t[2].1, "2×10⁻⁵");
        assert!(linear_ticks(-1e-17, 1.0, 5)
            .iter()
            .all(|x| !x.1.contains("-0") && !x.1.contains("−0.0")));
    }

    #[test]
    fn reciprocal_units_read_as_written_by_hand() {
        assert_eq!(per("m"), "1/m");
        assert_eq!(per("m/s"), "s/m");
        assert_eq!(per("rad/s^2"), "s²/rad");
        assert_eq!(per("N*m"), "1/(N·m)");
    }

    #[test]
    fn a_category_axis_names_its_positions() {
        let a = Axis::categories(vec!["weak".into(), "increments".into()], "");
        assert_eq!((a.lo, a.hi, a.log), (0.5, 2.5, false));
        let (major, minor) = a.ticks();
        assert_eq!(major, [(1.0, "weak".to_string()), (2.0, "increments".to_string())]);
        assert!(minor.is_empty());
    }

    #[test]
    fn log_ticks_label_decades_and_subdecades() {
        let (major, minor) = log_ticks(0.05, 3.0);
        let labels: Vec<&str> = major.iter().map(|x| x.1.as_str()).collect();
        assert_eq!(labels, ["0.05", "0.1", "0.2", "0.5", "1", "2"]);
        assert!(minor.iter().any(|v| (v - 0.3).abs() < 1e-12));
        let (major, _) = log_ticks(1.0, 1e4);
        assert_eq!(
            major.iter().map(|x| x.1.as_str()).collect::<Vec<_>>(),
            ["1", "10", "100", "1000", "10000"]
        );
        let (major, _) = log_ticks(1e-9, 1e-6);
        assert_eq!(major[0].1, "10⁻⁹");
        // An axis reaching below 0.001 writes every label as a power of ten.
        let (major, _) = log_ticks(5e-6, 1.0);
        let labels: Vec<&str> = major.iter().map(|x| x.1.as_str()).collect();
        assert_eq!(labels, ["10⁻⁵", "10⁻⁴", "10⁻³", "10⁻²", "10⁻¹", "10⁰"]);
        // Under a decade without a power of ten inside.
        let (major, _) = log_ticks(2.5, 9.0);
        assert!(major.len() >= 2);
    }

    #[test]
    fn svg_has_subpixel_coordinates_and_one_path_per_curve() {
        let mut p = Panel::new("t", Axis::linear(0.0, 1.0, "x (m)"), Axis::linear(0.0, 1.0, "y (N)"));
        let pts: Vec<(f64, f64)> = (0..=100)
            .map(|k| (k as f64 / 100.0, (k as f64 / 100.0).powi(2)))
            .collect();
        p.line(pts, Stroke::dashed(COLORS[0], 2.0, 6.0, 3.0), Some("curve".into()));
        let mut f = Figure::new(400.0);
        f.row(300.0, vec![Some(p)]);
        let svg = f.svg();
        assert_eq!(
            svg.matches("stroke-dasharray").count(),
            2,
            "the curve and its legend swatch"
        );
        assert!(svg.contains('.'), "sub-pixel coordinates");
        assert!(!svg.contains("-0.0"));
    }
}
