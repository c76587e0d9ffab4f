//! PNG and PDF next to every SVG figure, rendered by `resvg` and `svg2pdf` with the bundled
//! DejaVu Sans (`assets/fonts`, its licence beside it): no system library or font is used,
//! so a figure renders the same on any machine and drops into a paper or a slide.

use resvg::{tiny_skia, usvg};
use std::sync::OnceLock;

/// The font every figure's text is set in.
static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// PNG resolution: pixels per SVG pixel (2: 192 dpi for a 96-dpi SVG).
pub const PNG_SCALE: f32 = 2.0;

fn options() -> &'static usvg::Options<'static> {
    static OPTIONS: OnceLock<usvg::Options<'static>> = OnceLock::new();
    OPTIONS.get_or_init(|| {
        let mut opt = usvg::Options::default();
        let db = opt.fontdb_mut();
        db.load_font_data(FONT.to_vec());
        // Every generic family maps to the one bundled font.
        db.set_sans_serif_family("DejaVu Sans");
        db.set_serif_family("DejaVu Sans");
        db.set_monospace_family("DejaVu Sans");
        opt.font_family = "DejaVu Sans".into();
        opt
    })
}

fn tree(svg: &str) -> Result<usvg::Tree, String> {
    usvg::Tree::from_str(svg, options()).map_err(|e| format!("the SVG does not parse: {e}"))
}

/// The SVG rendered to a PNG at [`PNG_SCALE`] on white.
pub fn png(svg: &str) -> Result<Vec<u8>, String> {
    let tree = tree(svg)?;
    let size = tree.size();
    let (w, h) = (
        (size.width() * PNG_SCALE).ceil() as u32,
        (size.height() * PNG_SCALE).ceil() as u32,
    );
    let mut pixmap = tiny_skia::Pixmap::new(w, h).ok_or_else(|| format!("cannot make a {w}×{h} image"))?;
    pixmap.fill(tiny_skia::Color::WHITE);
    resvg::render(
        &tree,
        tiny_skia::Transform::from_scale(PNG_SCALE, PNG_SCALE),
        &mut pixmap.as_mut(),
    );
    // Opaque (drawn on white): RGB with adaptive filters, a quarter of the RGBA file.
    let rgb: Vec<u8> = pixmap.data().chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(png::Compression::Default);
        enc.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
        let mut writer = enc.write_header().map_err(|e| format!("PNG encoding: {e}"))?;
        writer
            .write_image_data(&rgb)
            .map_err(|e| format!("PNG encoding: {e}"))?;
    }
    Ok(out)
}

/// The SVG as a one-page vector PDF with the font embedded (subset).
pub fn pdf(svg: &str) -> Result<Vec<u8>, String> {
    let tree = tree(svg)?;
    svg2pdf::to_pdf(
        &tree,
        svg2pdf::ConversionOptions::default(),
        svg2pdf::PageOptions::default(),
    )
    .map_err(|e| format!("PDF conversion: {e}"))
}
