//! What every figure shares: rendering a prepared figure to SVG text or PNG bytes, and the
//! header (title and subtitle) above the plots.

use plotters::coord::Shift;
use plotters::prelude::*;

use std::sync::{Arc, OnceLock};

use resvg::{tiny_skia, usvg};

use super::error::{plot_err, ReportError};
use super::{font, layout};

/// Smallest accepted PNG size in pixels (below it the labels cannot fit).
const MIN_WIDTH_PX: u32 = 320;
const MIN_HEIGHT_PX: u32 = 240;
/// Largest accepted PNG side in pixels (keeps the RGB buffer reasonable).
const MAX_SIDE_PX: u32 = 16_384;

/// A figure ready to draw on any plotters backend; `scale` multiplies text and line sizes.
pub(super) trait Draw {
    /// Draw onto `root`.
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        scale: f64,
    ) -> Result<(), ReportError>;
}

/// Render to an SVG document of `size` pixels at scale 1.
pub(super) fn to_svg(figure: &impl Draw, size: (u32, u32)) -> Result<String, ReportError> {
    svg_at_scale(figure, size, 1.0)
}

/// Render to an SVG document of `size` pixels, text and line sizes multiplied by `scale`.
fn svg_at_scale(figure: &impl Draw, size: (u32, u32), scale: f64) -> Result<String, ReportError> {
    font::ensure_registered()?;
    super::precise::reset();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        figure.draw(&root, scale)?;
        root.present().map_err(plot_err)?;
    }
    Ok(name_embedded_font(&super::precise::substitute(svg)))
}

/// `svg` with its text naming the embedded face first (`DejaVu Sans, sans-serif`), so a
/// viewer with DejaVu Sans, and the report that embeds it (crates/present/src/html.rs), show
/// the SVG in the font of the PNG; plotters writes only the generic family.
fn name_embedded_font(svg: &str) -> String {
    svg.replace(
        &format!("font-family=\"{}\"", font::FAMILY),
        &format!(
            "font-family=\"{}, {}\"",
            font::EMBEDDED_FAMILY,
            font::FAMILY
        ),
    )
}

/// The font database resvg draws text with: only the embedded DejaVu Sans (no system fonts),
/// also serving the generic `sans-serif` family the SVG names.
fn font_db() -> Arc<usvg::fontdb::Database> {
    static DB: OnceLock<Arc<usvg::fontdb::Database>> = OnceLock::new();
    DB.get_or_init(|| {
        let mut db = usvg::fontdb::Database::new();
        db.load_font_data(font::DEJAVU_SANS.to_vec());
        db.set_sans_serif_family(font::EMBEDDED_FAMILY);
        Arc::new(db)
    })
    .clone()
}

/// Render to PNG bytes of `width` × `height` pixels: the figure drawn as an SVG of that size,
/// text and lines scaled by the image's size relative to the figure's natural size `base`,
/// rasterised by resvg with anti-aliasing on a white background. PNG and SVG therefore show
/// the same drawing.
pub(super) fn to_png(
    figure: &impl Draw,
    width: u32,
    height: u32,
    base: (u32, u32),
) -> Result<Vec<u8>, ReportError> {
    if !(MIN_WIDTH_PX..=MAX_SIDE_PX).contains(&width)
        || !(MIN_HEIGHT_PX..=MAX_SIDE_PX).contains(&height)
    {
        return Err(ReportError::Plot(format!(
            "image size {width} x {height} px out of range \
             ({MIN_WIDTH_PX}..={MAX_SIDE_PX} x {MIN_HEIGHT_PX}..={MAX_SIDE_PX})"
        )));
    }
    let scale = (f64::from(width) / f64::from(base.0))
        .min(f64::from(height) / f64::from(base.1))
        .clamp(0.4, 8.0);
    let svg = svg_at_scale(figure, (width, height), scale)?;
    rasterise(&svg, width, height)
}

/// Rasterise the SVG document `svg` of `width` × `height` pixels onto a white image of that
/// size and encode it as PNG.
fn rasterise(svg: &str, width: u32, height: u32) -> Result<Vec<u8>, ReportError> {
    let options = usvg::Options {
        font_family: font::EMBEDDED_FAMILY.to_string(),
        fontdb: font_db(),
        ..usvg::Options::default()
    };
    let tree = usvg::Tree::from_str(svg, &options).map_err(plot_err)?;
    let mut pixmap = tiny_skia::Pixmap::new(width, height)
        .ok_or_else(|| ReportError::Plot(format!("no {width} x {height} px image")))?;
    pixmap.fill(tiny_skia::Color::WHITE);
    resvg::render(
        &tree,
        tiny_skia::Transform::identity(),
        &mut pixmap.as_mut(),
    );
    encode_png(&pixmap).map_err(|e| ReportError::Plot(format!("PNG encoding: {e}")))
}

/// PNG bytes of an opaque `pixmap` (drawn on white, so every alpha is 255 and the premultiplied
/// colours are the colours): 8-bit RGB, rows filtered by `Up`, deflated at level 1. The pixels
/// are those of tiny-skia's own RGBA encoder at the default level, at a sixth of the time
/// (20 figures of 1500 × 1125 px: 69 ms instead of 441 ms) for files about a third larger. A
/// pixmap with any transparency keeps tiny-skia's encoder.
fn encode_png(pixmap: &tiny_skia::Pixmap) -> Result<Vec<u8>, png::EncodingError> {
    let rgba = pixmap.data();
    if rgba.chunks_exact(4).any(|p| p[3] != u8::MAX) {
        return pixmap.encode_png();
    }
    let rgb: Vec<u8> = rgba
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    let mut out = Vec::with_capacity(rgb.len() / 8);
    let mut encoder = png::Encoder::new(&mut out, pixmap.width(), pixmap.height());
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_deflate_compression(png::DeflateCompression::Level(1));
    encoder.set_filter(png::Filter::Up);
    encoder.write_header()?.write_image_data(&rgb)?;
    Ok(out)
}

/// Subtitle colour shared by the figures.
pub(super) const SUBTITLE_COLOR: RGBColor = RGBColor(70, 70, 70);
/// Header layout at scale 1 (px): title top margin, title size, gap, subtitle size, gap.
pub(super) const TITLE_TOP: f64 = 14.0;
pub(super) const TITLE_SIZE: f64 = 24.0;
pub(super) const TITLE_GAP: f64 = 10.0;
pub(super) const SUBTITLE_SIZE: f64 = 17.0;
pub(super) const SUBTITLE_GAP: f64 = 6.0;

/// A length of `v` pixels at scale 1, scaled and rounded.
pub(super) fn px(scale: f64) -> impl Fn(f64) -> i32 {
    move |v| (v * scale).round() as i32
}

/// A line width of `v` pixels at scale 1, scaled, rounded and at least 1.
pub(super) fn upx(scale: f64) -> impl Fn(f64) -> u32 {
    move |v| (v * scale).round().max(1.0) as u32
}

/// Black text of `size` points at scale 1 in the bundled font, scaled.
pub(super) fn text(scale: f64) -> impl Fn(f64) -> TextStyle<'static> {
    move |size| TextStyle::from((font::FAMILY, size * scale).into_font()).color(&BLACK)
}

/// Horizontal padding (px at scale 1) between the figure edge and the longest header line.
const HEADER_PAD: f64 = 12.0;
/// Most lines a title and a subtitle may take; longer ones are shortened in the middle.
const HEADER_MAX_LINES: usize = 2;
const SUBTITLE_MAX_LINES: usize = 3;

/// Height (px) of the title block with `title_lines` title and `subtitle_lines` subtitle lines.
pub(super) fn header_height(scale: f64, title_lines: usize, subtitle_lines: usize) -> i32 {
    let px = px(scale);
    let mut h = px(TITLE_TOP) + title_lines.max(1) as i32 * px(TITLE_SIZE) + px(TITLE_GAP);
    if subtitle_lines > 0 {
        h += subtitle_lines as i32 * px(SUBTITLE_SIZE) + px(SUBTITLE_GAP);
    }
    h
}

/// Fill the figure white and draw the centred title and optional grey subtitle, wrapped at safe points onto at most two (title) or three (subtitle) lines and
/// shortened in the middle beyond that so that it never runs outside the figure; returns the
/// area below them and the header's height (px).
pub(super) fn draw_header<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    subtitle: Option<&str>,
    scale: f64,
) -> Result<(DrawingArea<DB, Shift>, i32), ReportError> {
    use plotters::style::text_anchor::{HPos, Pos, VPos};
    let (px, text) = (px(scale), text(scale));
    let width = root.dim_in_pixel().0;
    let max_w = f64::from(width) - 2.0 * f64::from(px(HEADER_PAD));
    let fit =
        |s: &str, size: f64, lines: usize| layout::fit_subtitle(s, size * scale, max_w, lines);
    let title_lines = fit(title, TITLE_SIZE, HEADER_MAX_LINES);
    let subtitle_lines =
        subtitle.map_or_else(Vec::new, |s| fit(s, SUBTITLE_SIZE, SUBTITLE_MAX_LINES));
    let header_h = header_height(scale, title_lines.len(), subtitle_lines.len());
    let sub_top = header_height(scale, title_lines.len(), 0) - px(2.0);
    root.fill(&WHITE).map_err(plot_err)?;
    let (header, body) = root.split_vertically(header_h);
    let centre = (width / 2) as i32;
    let top = Pos::new(HPos::Center, VPos::Top);
    for (k, line) in title_lines.into_iter().enumerate() {
        let y = px(TITLE_TOP) + k as i32 * px(TITLE_SIZE);
        header
            .draw(&Text::new(line, (centre, y), text(TITLE_SIZE).pos(top)))
            .map_err(plot_err)?;
    }
    for (k, line) in subtitle_lines.into_iter().enumerate() {
        let y = sub_top + k as i32 * px(SUBTITLE_SIZE);
        let style = text(SUBTITLE_SIZE).color(&SUBTITLE_COLOR).pos(top);
        header
            .draw(&Text::new(line, (centre, y), style))
            .map_err(plot_err)?;
    }
    Ok((body, header_h))
}

/// A box over the pixel `corners` of `area`, filled with `fill` and edged in grey `border_w`
/// px wide: legends, labels over a plot and colour swatches.
pub(super) fn draw_box<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    corners: [(i32, i32); 2],
    fill: ShapeStyle,
    border_w: u32,
) -> Result<(), ReportError> {
    area.draw(&Rectangle::new(corners, fill))
        .map_err(plot_err)?;
    area.draw(&Rectangle::new(
        corners,
        BLACK.mix(0.45).stroke_width(border_w),
    ))
    .map_err(plot_err)
}

/// The fill of boxes drawn over a plot (legends, labels): white, slightly see-through.
pub(super) fn label_background() -> ShapeStyle {
    WHITE.mix(0.88).filled()
}

/// Test support: check PNG bytes (signature, IHDR size, decodable at that size) and return the
/// decoded RGB image.
#[cfg(test)]
pub(super) fn decode_png(png: &[u8], width: u32, height: u32) -> image::RgbImage {
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    // IHDR: width and height, big endian, at bytes 16..24.
    assert_eq!(u32::from_be_bytes(png[16..20].try_into().unwrap()), width);
    assert_eq!(u32::from_be_bytes(png[20..24].try_into().unwrap()), height);
    let img = image::load_from_memory_with_format(png, image::ImageFormat::Png).unwrap();
    assert_eq!((img.width(), img.height()), (width, height));
    img.to_rgb8()
}

/// Test support: the number of dark pixels (text, curves) of an image.
#[cfg(test)]
pub(super) fn dark_pixels(rgb: &image::RgbImage) -> usize {
    rgb.pixels()
        .filter(|p| p.0.iter().all(|&c| c < 100))
        .count()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An anti-aliased drawing on white: curves, a translucent fill and text.
    fn drawing(width: u32, height: u32, background: bool) -> tiny_skia::Pixmap {
        let svg = format!(
            r##"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}">
                <path d="M 5 90 C 40 -20 80 140 150 20" stroke="#1f77b4" stroke-width="2.5" fill="none"/>
                <circle cx="60" cy="50" r="30" fill="#d62728" fill-opacity="0.35"/>
                <text x="12" y="110" font-size="17" font-family="sans-serif">Bode 6.45 dB</text>
            </svg>"##
        );
        let options = usvg::Options {
            fontdb: font_db(),
            ..usvg::Options::default()
        };
        let tree = usvg::Tree::from_str(&svg, &options).unwrap();
        let mut pixmap = tiny_skia::Pixmap::new(width, height).unwrap();
        if background {
            pixmap.fill(tiny_skia::Color::WHITE);
        }
        resvg::render(
            &tree,
            tiny_skia::Transform::identity(),
            &mut pixmap.as_mut(),
        );
        pixmap
    }

    fn decoded(png: &[u8]) -> image::RgbaImage {
        image::load_from_memory_with_format(png, image::ImageFormat::Png)
            .unwrap()
            .to_rgba8()
    }

    /// The figures' encoder gives the pixels of tiny-skia's own encoder, in RGB for an opaque
    /// image and in RGBA (tiny-skia's) for one with transparency.
    #[test]
    fn png_pixels_equal_tiny_skias() {
        for background in [true, false] {
            let pixmap = drawing(160, 120, background);
            let ours = encode_png(&pixmap).unwrap();
            let reference = decoded(&pixmap.encode_png().unwrap());
            let drawn = reference.pixels().filter(|p| p.0 != [255; 4]).count();
            assert!(drawn > 1000, "{drawn} pixels drawn");
            assert_eq!(decoded(&ours), reference);
            // colour type byte of IHDR: 2 = RGB, 6 = RGBA
            assert_eq!(ours[25], if background { 2 } else { 6 });
        }
    }
}
