//! The layout layer every figure shares: text measured with the embedded font's metrics, titles
//! and subtitles fitted to the figure width (wrapped onto a second line, then shortened with an
//! ellipsis in the middle), number formatting with a bounded number of digits, and the check
//! that no text of a finished SVG runs outside its view box.
//!
//! Sizes follow the SVG the figures are rendered from: plotters writes a text style of size `s`
//! as `font-size = s / 1.24`, and one em of that font size is `font-size` pixels.

use std::sync::OnceLock;

use ab_glyph::{Font, FontRef};

use super::font;

/// plotters' ratio between a text style's size and the SVG `font-size` it writes.
pub(super) const PLOTTERS_SIZE_PER_EM: f64 = 1.24;

/// The embedded font, parsed once (it is a valid TrueType file, checked by the font tests).
fn face() -> &'static FontRef<'static> {
    static FACE: OnceLock<FontRef<'static>> = OnceLock::new();
    FACE.get_or_init(|| {
        FontRef::try_from_slice(font::DEJAVU_SANS).expect("the embedded DejaVu Sans parses")
    })
}

/// Horizontal extent and ink top/bottom of `text`, in em (y up: `top` > 0 above the baseline,
/// `bottom` < 0 below it). Advances without kerning, which only narrows text, so the width is
/// never under-estimated.
fn extent_em(text: &str) -> (f64, f64, f64) {
    let f = face();
    let upem = f64::from(f.units_per_em().unwrap_or(2048.0));
    let (mut w, mut top, mut bottom) = (0.0f64, 0.0f64, 0.0f64);
    for c in text.chars() {
        let id = f.glyph_id(c);
        w += f64::from(f.h_advance_unscaled(id));
        if let Some(o) = f.outline(id) {
            // ab_glyph stores the font's y-up bounds as min = (x_min, y_max), max = (x_max, y_min).
            let (a, b) = (f64::from(o.bounds.min.y), f64::from(o.bounds.max.y));
            top = top.max(a.max(b));
            bottom = bottom.min(a.min(b));
        }
    }
    (w / upem, top / upem, bottom / upem)
}

/// Width in pixels of `text` drawn with a plotters text style of size `size` (the size the
/// figures pass to their text styles, before the SVG's 1/1.24).
pub(super) fn text_width(text: &str, size: f64) -> f64 {
    extent_em(text).0 * size / PLOTTERS_SIZE_PER_EM
}

/// `text` shortened in the middle with "…" to at most `max_w` pixels at plotters size `size`
/// (unchanged if it fits; just "…" if nothing else does).
pub(super) fn ellipsize_middle(text: &str, size: f64, max_w: f64) -> String {
    if text_width(text, size) <= max_w {
        return text.to_string();
    }
    let chars: Vec<char> = text.chars().collect();
    let candidate = |keep: usize| -> String {
        let head = keep.div_ceil(2);
        let tail = keep / 2;
        let mut s: String = chars[..head].iter().collect();
        s.push('…');
        s.extend(&chars[chars.len() - tail..]);
        s
    };
    // Largest `keep` that fits, by bisection (the width grows with `keep`).
    let (mut lo, mut hi) = (0usize, chars.len());
    while lo < hi {
        let mid = (lo + hi).div_ceil(2);
        if text_width(&candidate(mid), size) <= max_w {
            lo = mid;
        } else {
            hi = mid - 1;
        }
    }
    candidate(lo)
}

/// `text` laid out in at most `max_lines` lines of at most `max_w` pixels at plotters size
/// `size`: words wrapped greedily, the last line taking all remaining words and shortened with
/// a middle ellipsis if it is still too wide (as is any single word wider than a line).
pub(super) fn fit_lines(text: &str, size: f64, max_w: f64, max_lines: usize) -> Vec<String> {
    let text = text.trim();
    if !text.is_empty() && text_width(text, size) <= max_w {
        // Fits: kept as written (with any runs of spaces the caller chose).
        return vec![text.to_string()];
    }
    let words: Vec<&str> = text.split_whitespace().collect();
    let mut lines = Vec::new();
    let mut i = 0;
    while i < words.len() {
        if lines.len() + 1 >= max_lines.max(1) {
            lines.push(ellipsize_middle(&words[i..].join(" "), size, max_w));
            break;
        }
        let mut line = words[i].to_string();
        i += 1;
        while i < words.len() {
            let longer = format!("{line} {}", words[i]);
            if text_width(&longer, size) > max_w {
                break;
            }
            line = longer;
            i += 1;
        }
        lines.push(ellipsize_middle(&line, size, max_w));
    }
    lines
}

/// Units a number is never parted from when a subtitle wraps.
const UNITS: [&str; 16] = [
    "Hz",
    "deg",
    "°",
    "dB",
    "bar",
    "mm",
    "s",
    "%",
    "kg",
    "rpm",
    "m",
    "N",
    "mm²",
    "N·s/m",
    "rad/s",
    "m⁵/(N·s)",
];

/// `text` wrapped onto at most `max_lines` lines of at most `max_w` pixels at text size
/// `size`, as [`fit_lines`] does, but only at safe points: after "; ", at runs of two or
/// more spaces, after ", " and, only when a piece is still too wide, between words, never
/// between a number and its unit nor around " / ", " @ " or "= ".
pub(super) fn fit_subtitle(text: &str, size: f64, max_w: f64, max_lines: usize) -> Vec<String> {
    let text = text.trim();
    if text.is_empty() || text_width(text, size) <= max_w {
        return fit_lines(text, size, max_w, max_lines);
    }
    // Pieces, each with the separator written before it when it continues a line.
    let mut pieces: Vec<(String, String)> = Vec::new();
    let fits = |p: &str| text_width(p, size) <= max_w;
    for (k, clause) in text.split("; ").enumerate() {
        let clause_sep = if k == 0 { "" } else { "; " };
        let mut parts = clause
            .split("  ")
            .filter(|p| !p.trim().is_empty())
            .enumerate();
        let mut first_sep = clause_sep.to_string();
        for (j, part) in parts.by_ref() {
            let sep = if j == 0 {
                std::mem::take(&mut first_sep)
            } else {
                "      ".to_string()
            };
            let part = part.trim();
            if fits(part) {
                pieces.push((sep, part.to_string()));
                continue;
            }
            for (i, item) in part.split(", ").enumerate() {
                let sep = if i == 0 { sep.clone() } else { ", ".into() };
                if fits(item) {
                    pieces.push((sep, item.to_string()));
                    continue;
                }
                for (w, word) in unbreakable_words(item).into_iter().enumerate() {
                    pieces.push((if w == 0 { sep.clone() } else { " ".into() }, word));
                }
            }
        }
    }
    // The separator "; " and ", " stay at the end of the line they close.
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    let mut i = 0;
    while i < pieces.len() {
        let (sep, piece) = &pieces[i];
        let lead = sep.trim_end();
        if line.is_empty() {
            line = piece.clone();
        } else if fits(&format!("{line}{sep}{piece}")) {
            line = format!("{line}{sep}{piece}");
        } else {
            lines.push(format!("{line}{lead}"));
            line = piece.clone();
            if lines.len() + 1 >= max_lines.max(1) {
                let rest: String = pieces[i + 1..]
                    .iter()
                    .map(|(s, p)| format!("{s}{p}"))
                    .collect();
                lines.push(ellipsize_middle(&format!("{line}{rest}"), size, max_w));
                return lines;
            }
        }
        i += 1;
    }
    if !line.is_empty() {
        lines.push(ellipsize_middle(&line, size, max_w));
    }
    lines
}

/// The words of `text`, a number kept with the unit after it and " / ", " @ ", "= " kept
/// with both neighbours.
fn unbreakable_words(text: &str) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    let mut glue_next = false;
    for w in text.split(' ').filter(|w| !w.is_empty()) {
        let after_number = out
            .last()
            .is_some_and(|p| p.ends_with(|c: char| c.is_ascii_digit()));
        let unit = UNITS
            .iter()
            .any(|u| w.trim_end_matches([',', ';', ')', '.']) == *u);
        let glue_prev = matches!(w, "/" | "@" | "=");
        match out.last_mut() {
            Some(prev) if glue_next || glue_prev || (after_number && unit) => {
                prev.push(' ');
                prev.push_str(w);
            }
            _ => out.push(w.to_string()),
        }
        glue_next = matches!(w, "/" | "@" | "=") || w.ends_with('=');
    }
    out
}

/// `v` with `decimals` decimals, trailing zeros (and a bare ".") removed, never "-0".
pub(super) fn trim_decimal(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    let s = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        &s
    };
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

/// `v` rounded to `digits` significant digits (1..=15) for titles, captions and annotations:
/// plain decimals with trailing zeros removed between 1e-4 and 1e6 ("167", "0.0123", "4.5"),
/// scientific notation outside ("1.23e-7"). Non-finite values print as Rust prints them.
pub fn sig(v: f64, digits: usize) -> String {
    if !v.is_finite() || v == 0.0 {
        return trim_decimal(v, 0);
    }
    let digits = digits.clamp(1, 15);
    let e = v.abs().log10().floor() as i32;
    // Rounding may carry into the next power of ten (9.996 → 10.0).
    let rounded = format!("{:.*e}", digits - 1, v);
    let e = rounded
        .split('e')
        .nth(1)
        .and_then(|x| x.parse::<i32>().ok())
        .unwrap_or(e);
    if (-4..6).contains(&e) {
        trim_decimal(v, (digits as i32 - 1 - e).max(0) as usize)
    } else {
        let (m, x) = rounded.split_once('e').unwrap_or((&rounded, "0"));
        let m = if m.contains('.') {
            m.trim_end_matches('0').trim_end_matches('.')
        } else {
            m
        };
        format!("{m}e{x}")
    }
}

/// A `<text>` element of an SVG document as plotters writes it.
#[derive(Debug, PartialEq)]
struct SvgText {
    content: String,
    x: f64,
    y: f64,
    /// `dy` in pixels.
    dy: f64,
    font_size: f64,
    /// -1 start, 0 middle, 1 end.
    anchor: i8,
    /// Rotation `(degrees, cx, cy)` of a `transform="rotate(a, cx, cy)"`.
    rotate: Option<(f64, f64, f64)>,
}

/// Value of attribute `name` in the attribute list `attrs` of one tag.
fn attr<'a>(attrs: &'a str, name: &str) -> Option<&'a str> {
    let mut rest = attrs;
    while let Some(p) = rest.find(name) {
        let before = rest[..p].chars().last();
        let after = &rest[p + name.len()..];
        if before.is_none_or(|c| c.is_whitespace()) {
            if let Some(v) = after.trim_start().strip_prefix('=') {
                let v = v.trim_start();
                let q = v.chars().next()?;
                let v = &v[q.len_utf8()..];
                return v.find(q).map(|end| &v[..end]);
            }
        }
        rest = after;
    }
    None
}

/// A length in pixels: plain or `px`, or `em`/`ex` of `font_size` (1 ex = 0.5 em, as in resvg).
fn length(s: &str, font_size: f64) -> Option<f64> {
    let s = s.trim();
    if let Some(v) = s.strip_suffix("em") {
        v.trim().parse::<f64>().ok().map(|v| v * font_size)
    } else if let Some(v) = s.strip_suffix("ex") {
        v.trim().parse::<f64>().ok().map(|v| v * font_size / 2.0)
    } else {
        s.trim_end_matches("px").trim().parse().ok()
    }
}

/// The numbers in `s` (separated by commas, spaces or parentheses).
fn numbers(s: &str) -> Vec<f64> {
    s.split(|c: char| c == ',' || c == '(' || c == ')' || c.is_whitespace())
        .filter_map(|t| t.parse().ok())
        .collect()
}

/// XML text content with the five predefined entities decoded.
fn unescape(s: &str) -> String {
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&amp;", "&")
}

/// The view box `(x, y, width, height)` of an SVG document (`viewBox`, else `width`/`height`).
fn view_box(svg: &str) -> Option<(f64, f64, f64, f64)> {
    let start = svg.find("<svg")?;
    let tag = &svg[start..start + svg[start..].find('>')?];
    if let Some(v) = attr(tag, "viewBox") {
        if let [x, y, w, h] = numbers(v)[..] {
            return Some((x, y, w, h));
        }
    }
    Some((
        0.0,
        0.0,
        length(attr(tag, "width")?, 0.0)?,
        length(attr(tag, "height")?, 0.0)?,
    ))
}

/// Every `<text>` element of `svg`.
fn svg_texts(svg: &str) -> Vec<SvgText> {
    let mut out = Vec::new();
    let mut rest = svg;
    while let Some(p) = rest.find("<text") {
        rest = &rest[p + 5..];
        let Some(close) = rest.find('>') else { break };
        let attrs = &rest[..close];
        let body = &rest[close + 1..];
        let Some(end) = body.find("</text>") else {
            break;
        };
        let font_size = attr(attrs, "font-size")
            .and_then(|v| length(v, 0.0))
            .unwrap_or(16.0);
        let num = |name| attr(attrs, name).and_then(|v| length(v, font_size));
        let rotate = attr(attrs, "transform")
            .filter(|t| t.trim_start().starts_with("rotate"))
            .map(numbers)
            .and_then(|n| match n[..] {
                [a] => Some((a, 0.0, 0.0)),
                [a, cx, cy] => Some((a, cx, cy)),
                _ => None,
            });
        out.push(SvgText {
            content: unescape(body[..end].trim()),
            x: num("x").unwrap_or(0.0),
            y: num("y").unwrap_or(0.0),
            dy: num("dy").unwrap_or(0.0),
            font_size,
            anchor: match attr(attrs, "text-anchor") {
                Some("middle") => 0,
                Some("end") => 1,
                _ => -1,
            },
            rotate,
        });
        rest = &body[end..];
    }
    out
}

/// Bounding box `(x0, y0, x1, y1)` in SVG pixels of the ink of `t`.
fn text_box(t: &SvgText) -> (f64, f64, f64, f64) {
    let (w_em, top_em, bottom_em) = extent_em(&t.content);
    let w = w_em * t.font_size;
    let x0 = t.x - w * (f64::from(t.anchor) + 1.0) / 2.0;
    let baseline = t.y + t.dy;
    let corners = [
        (x0, baseline - top_em * t.font_size),
        (x0 + w, baseline - top_em * t.font_size),
        (x0, baseline - bottom_em * t.font_size),
        (x0 + w, baseline - bottom_em * t.font_size),
    ];
    let (sin, cos) = t
        .rotate
        .map_or((0.0, 1.0), |(a, _, _)| a.to_radians().sin_cos());
    let (cx, cy) = t.rotate.map_or((0.0, 0.0), |(_, cx, cy)| (cx, cy));
    corners.iter().fold(
        (
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ),
        |(a, b, c, d), &(x, y)| {
            let (dx, dy) = (x - cx, y - cy);
            let (x, y) = (cx + dx * cos - dy * sin, cy + dx * sin + dy * cos);
            (a.min(x), b.min(y), c.max(x), d.max(y))
        },
    )
}

/// The texts of an SVG document (as the figures write it) whose ink runs outside its view box,
/// each described with its extent, e.g. `"Title" spans x -12.0..652.3, y 14.0..38.1 outside
/// 0..640 x 0..480`. Extents come from the embedded font's advances and glyph outlines, the
/// text's position, `dy`, `text-anchor`, `font-size` and any `rotate(...)` transform; a
/// tolerance of 0.5 px absorbs rounding. An SVG without a size gives one entry saying so.
pub fn text_overflow(svg: &str) -> Vec<String> {
    let Some((vx, vy, vw, vh)) = view_box(svg) else {
        return vec!["the SVG has no viewBox or width/height".to_string()];
    };
    const TOL: f64 = 0.5;
    svg_texts(svg)
        .iter()
        .filter(|t| !t.content.is_empty())
        .filter_map(|t| {
            let (x0, y0, x1, y1) = text_box(t);
            let inside =
                x0 >= vx - TOL && y0 >= vy - TOL && x1 <= vx + vw + TOL && y1 <= vy + vh + TOL;
            (!inside).then(|| {
                format!(
                    "{:?} spans x {x0:.1}..{x1:.1}, y {y0:.1}..{y1:.1} outside {vx}..{} x {vy}..{}",
                    t.content,
                    vx + vw,
                    vy + vh
                )
            })
        })
        .collect()
}

/// The pairs of texts of an SVG document (as the figures write it) whose ink overlaps, each
/// described with the overlap, e.g. `"Phase (deg)" and "-90" overlap by 3.1 x 12.0 px`. Extents
/// as [`text_overflow`] computes them; overlaps of at most 0.5 px either way are tolerated.
pub fn text_collisions(svg: &str) -> Vec<String> {
    const TOL: f64 = 0.5;
    let texts: Vec<(String, (f64, f64, f64, f64))> = (svg_texts(svg).into_iter())
        .filter(|t| !t.content.trim().is_empty())
        .map(|t| {
            let b = text_box(&t);
            (t.content, b)
        })
        .collect();
    let mut out = Vec::new();
    for (i, (a, p)) in texts.iter().enumerate() {
        for (b, q) in &texts[i + 1..] {
            let w = p.2.min(q.2) - p.0.max(q.0);
            let h = p.3.min(q.3) - p.1.max(q.1);
            if w > TOL && h > TOL {
                out.push(format!("{a:?} and {b:?} overlap by {w:.1} x {h:.1} px"));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn svg(body: &str) -> String {
        format!(
            "<svg width=\"640\" height=\"480\" viewBox=\"0 0 640 480\" \
             xmlns=\"http://www.w3.org/2000/svg\">\n{body}\n</svg>"
        )
    }

    /// One text element as plotters writes it.
    fn text(x: f64, y: f64, anchor: &str, size: f64, extra: &str, content: &str) -> String {
        format!(
            "<text x=\"{x}\" y=\"{y}\" dy=\"0.76em\" text-anchor=\"{anchor}\" \
             font-family=\"sans-serif\" font-size=\"{size}\" opacity=\"1\" fill=\"#000000\"{extra}>\n\
             {content}\n</text>"
        )
    }

    #[test]
    fn widths_follow_the_font_advances() {
        // DejaVu Sans: "0" advances 1303/2048 em; 10 of them at font-size 20 (plotters size
        // 24.8) are 127.2 px.
        let w = text_width("0000000000", 24.8);
        assert!((w - 10.0 * 1303.0 / 2048.0 * 20.0).abs() < 1e-9, "{w}");
        assert!(text_width("W", 20.0) > text_width("i", 20.0));
        assert_eq!(text_width("", 20.0), 0.0);
    }

    #[test]
    fn parses_plotters_text() {
        let s = svg(&text(
            10.0,
            20.0,
            "end",
            12.0,
            " transform=\"rotate(270, 10, 20)\"",
            "a &amp; b",
        ));
        let t = svg_texts(&s);
        assert_eq!(
            t,
            vec![SvgText {
                content: "a & b".into(),
                x: 10.0,
                y: 20.0,
                dy: 0.76 * 12.0,
                font_size: 12.0,
                anchor: 1,
                rotate: Some((270.0, 10.0, 20.0)),
            }]
        );
        assert_eq!(view_box(&s), Some((0.0, 0.0, 640.0, 480.0)));
    }

    #[test]
    fn text_inside_is_not_reported() {
        let s = svg(&text(320.0, 10.0, "middle", 19.35, "", "Bode diagram"));
        assert_eq!(text_overflow(&s), Vec::<String>::new());
    }

    #[test]
    fn overflow_left_right_top_bottom_is_reported() {
        let long =
            "A title far too long for a figure only 640 pixels wide, at this font size, truly";
        let cases = [
            text(320.0, 10.0, "middle", 19.35, "", long), // both ends
            text(5.0, 100.0, "end", 12.0, "", "-0.5"),    // left
            text(630.0, 100.0, "start", 12.0, "", "10"),  // right
            text(320.0, -8.0, "middle", 12.0, "", "top"), // top
            text(320.0, 475.0, "middle", 12.0, "", "bottom"), // bottom
        ];
        for c in &cases {
            let o = text_overflow(&svg(c));
            assert_eq!(o.len(), 1, "{c}: {o:?}");
        }
        // Only the overflowing one of several.
        let both = format!(
            "{}{}",
            cases[1],
            text(320.0, 100.0, "start", 12.0, "", "ok")
        );
        let o = text_overflow(&svg(&both));
        assert_eq!(o.len(), 1);
        assert!(o[0].starts_with("\"-0.5\""), "{o:?}");
    }

    #[test]
    fn overlapping_texts_are_reported_once_a_pair() {
        // two y descriptions rotated about points 60 px apart: 100 px long, they overlap
        let rot = |y: f64| {
            let r = format!(" transform=\"rotate(270, 30, {y})\"");
            text(30.0, y, "middle", 14.0, &r, "Position x (mm) ....")
        };
        let o = text_collisions(&svg(&(rot(100.0) + &rot(160.0))));
        assert_eq!(o.len(), 1, "{o:?}");
        assert!(o[0].contains("overlap by"), "{o:?}");
        // 200 px apart they do not; nor do texts side by side
        assert_eq!(text_collisions(&svg(&(rot(100.0) + &rot(300.0)))).len(), 0);
        let side =
            text(100.0, 50.0, "end", 12.0, "", "10") + &text(104.0, 50.0, "start", 12.0, "", "20");
        assert_eq!(text_collisions(&svg(&side)), Vec::<String>::new());
    }

    #[test]
    fn rotated_text_uses_its_rotated_extent() {
        // A y-axis label rotated by 270 degrees about its anchor: about 140 px long, so
        // centred at y = 240 it fits vertically, but centred at y = 40 it runs off the top;
        // unrotated at x = 30 it would run off the left instead.
        let label = "Position x (mm) ....";
        let rot = |y: f64| {
            text(
                30.0,
                y,
                "middle",
                14.0,
                &format!(" transform=\"rotate(270, 30, {y})\""),
                label,
            )
        };
        assert_eq!(text_overflow(&svg(&rot(240.0))), Vec::<String>::new());
        let o = text_overflow(&svg(&rot(40.0)));
        assert_eq!(o.len(), 1, "{o:?}");
        assert!(o[0].contains("y -"), "{o:?}");
        assert_eq!(
            text_overflow(&svg(&text(30.0, 240.0, "middle", 14.0, "", label))).len(),
            1
        );
    }

    #[test]
    fn subtitles_wrap_at_safe_points() {
        let size = 14.0;
        let text = "identified rig: GM = 6.8 dB @ 0.830 Hz      PM = 33.7° @ 0.502 Hz; \
                    c12, c1, c2 / 10: GM = -3.4 dB @ 0.880 Hz      PM = -36.6° @ 1.01 Hz; \
                    c12, c1, c2 / 10, motor coupling removed: GM = -14.8 dB @ 0.837 Hz      PM = -79.8° @ 1.03 Hz";
        let lines = fit_subtitle(text, size, 900.0, 2);
        assert_eq!(lines.len(), 2, "{lines:?}");
        assert!(
            lines[0].ends_with(';') || lines[0].ends_with("Hz"),
            "{lines:?}"
        );
        assert!(
            lines[1].starts_with("c12, c1, c2 / 10") || lines[1].starts_with("PM"),
            "{lines:?}"
        );
        for l in &lines {
            assert!(text_width(l, size) <= 900.0, "{l}");
        }
        assert_eq!(
            unbreakable_words("PM = 33.7° @ 0.502 Hz and 5 mm"),
            vec!["PM = 33.7° @ 0.502 Hz", "and", "5 mm"]
        );
    }

    #[test]
    fn fit_lines_wraps_then_shortens() {
        let size = 24.0;
        let short = "GM = 6 dB      PM = 30°";
        assert_eq!(fit_lines(short, size, 600.0, 2), vec![short.to_string()]);
        let long: String = (0..60).map(|i| format!("w{i} ")).collect();
        let lines = fit_lines(&long, size, 600.0, 2);
        assert_eq!(lines.len(), 2);
        for l in &lines {
            assert!(text_width(l, size) <= 600.0, "{l}");
        }
        assert!(lines[0].starts_with("w0 w1"));
        assert!(
            lines[1].contains('…') && lines[1].ends_with("w59"),
            "{lines:?}"
        );
        // One unbreakable word (a path) keeps both ends.
        let path = "/very/long/directory/name/that/goes/on/and/on/and/on/step_damping.png";
        let one = fit_lines(path, size, 300.0, 1);
        assert_eq!(one.len(), 1);
        assert!(
            one[0].starts_with("/very") && one[0].ends_with(".png"),
            "{one:?}"
        );
        assert!(text_width(&one[0], size) <= 300.0);
        assert!(fit_lines("", size, 300.0, 2).is_empty());
    }

    #[test]
    fn significant_digits() {
        assert_eq!(sig(167.122791980682, 3), "167");
        assert_eq!(sig(167.122791980682, 4), "167.1");
        assert_eq!(sig(0.0123456, 3), "0.0123");
        assert_eq!(sig(9.9996, 3), "10");
        assert_eq!(sig(-2.5, 3), "-2.5");
        assert_eq!(sig(0.0, 3), "0");
        assert_eq!(sig(1.234e-7, 3), "1.23e-7");
        assert_eq!(sig(2.0e9, 3), "2e9");
        assert_eq!(sig(f64::NAN, 3), "NaN");
        assert_eq!(trim_decimal(-0.0001, 2), "0");
        assert_eq!(trim_decimal(2.50, 3), "2.5");
    }
}
