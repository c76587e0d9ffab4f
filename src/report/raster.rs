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
    // Opaque (drawn on white): RGB with adaptive filters, a quarter of the RGBA file. The
    // rows go to the encoder one at a time, so no RGB copy of the whole image is held
    // beside the pixmap (a 4-mass model's characteristics: 54 MB of 127). Fast deflate:
    // on the default run's three figures it writes them in 0.30–0.35 s instead of
    // 0.49–0.52 s, for files 1.5× as large (1.29 MB against 0.85 MB).
    let mut out = Vec::new();
    {
        let fail = |e: &dyn std::fmt::Display| format!("PNG encoding: {e}");
        let mut enc = png::Encoder::new(&mut out, w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(png::Compression::Fast);
        enc.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
        let mut writer = enc.write_header().map_err(|e| fail(&e))?;
        let mut stream = writer.stream_writer_with_size(1 << 18).map_err(|e| fail(&e))?;
        let mut row = Vec::with_capacity(3 * w as usize);
        for line in pixmap.data().chunks_exact(4 * w as usize) {
            row.clear();
            row.extend(line.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]));
            std::io::Write::write_all(&mut stream, &row).map_err(|e| fail(&e))?;
        }
        stream.finish().map_err(|e| fail(&e))?;
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The PNG, written a row at a time, decodes to the rendered image: every pixel's colour
    /// as drawn on white, rows in order (a figure taller than wide, shapes at its top and
    /// bottom, so a row out of place shows).
    #[test]
    fn the_png_holds_the_rendered_pixels_row_by_row() {
        let svg = r##"<svg xmlns="http://www.w3.org/2000/svg" width="60" height="90">
            <rect x="5" y="3" width="20" height="10" fill="#1f77b4"/>
            <circle cx="40" cy="70" r="12" fill="#ff7f0e"/>
            <line x1="0" y1="89" x2="59" y2="45" stroke="#000" stroke-width="1.5"/></svg>"##;
        let bytes = png(svg).unwrap();
        let mut reader = png::Decoder::new(&bytes[..]).read_info().unwrap();
        let mut decoded = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut decoded).unwrap();
        let (w, h) = (60 * PNG_SCALE as u32, 90 * PNG_SCALE as u32);
        assert_eq!((info.width, info.height, info.color_type), (w, h, png::ColorType::Rgb));
        let mut pixmap = tiny_skia::Pixmap::new(w, h).unwrap();
        pixmap.fill(tiny_skia::Color::WHITE);
        resvg::render(
            &tree(svg).unwrap(),
            tiny_skia::Transform::from_scale(PNG_SCALE, PNG_SCALE),
            &mut pixmap.as_mut(),
        );
        let expected: Vec<u8> = pixmap.data().chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
        assert_eq!(decoded[..info.buffer_size()], expected[..]);
        // Both shapes are there: the blue rectangle near the top, the orange disc low down.
        let at = |x: u32, y: u32| &expected[3 * (y * w + x) as usize..3 * (y * w + x) as usize + 3];
        assert_eq!(at(30, 16), [0x1f, 0x77, 0xb4]);
        assert_eq!(at(80, 140), [0xff, 0x7f, 0x0e]);
    }
}
