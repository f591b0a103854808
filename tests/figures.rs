//! The figures of `pumpcyl reproduce` read as a user reads them, checked on the SVG text:
//! colours keep their meaning across the panels of a figure, so does each dash pattern (one
//! meaning a pattern, stated in the legend), subtitles never wrap between a number and its
//! unit, every curve shows on white, and curves keep sub-pixel precision. Their layout
//! (docs/formats.md#figures): a category axis is ticked with its names only, a series is named
//! once in a stack of panels, no two texts overlap, and a curve lying under a later one is
//! drawn in another width.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;

/// Every SVG figure of one `pumpcyl reproduce` run, shared by the tests: (name, SVG text).
fn figures() -> &'static [(String, String)] {
    static RUN: OnceLock<Vec<(String, String)>> = OnceLock::new();
    RUN.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let out = run::pumpcyl(
            Path::new("."),
            &["reproduce", "--out", dir.path().to_str().unwrap()],
        );
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let mut svgs = Vec::new();
        for sub in ["figures", "identification"] {
            for path in svg_files(&dir.path().join(sub)) {
                let name = path.file_name().unwrap().to_string_lossy().into_owned();
                svgs.push((name, std::fs::read_to_string(&path).unwrap()));
            }
        }
        // every registered figure, and the identification's landscape and fits beside them
        let figures = svgs.iter().filter(|(name, _)| {
            pumpcyl_present::reproduce::FIGURES
                .iter()
                .any(|f| *name == format!("{}.svg", f.stem))
        });
        assert_eq!(figures.count(), pumpcyl_present::reproduce::FIGURES.len());
        svgs
    })
}

fn svg_files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "svg"))
        .collect();
    files.sort();
    files
}

/// One drawn element of an SVG document, in document order.
#[derive(Debug, Clone, PartialEq)]
enum Element {
    /// A polyline: its stroke colour (`#RRGGBB`), width, dash array (`None`: solid) and points.
    Line {
        stroke: String,
        width: f64,
        dash: Option<String>,
        points: Vec<(f64, f64)>,
    },
    /// A text: its fill colour, content, anchor (`start`, `middle`, `end`), font size and
    /// whether it is rotated (an axis description).
    Text {
        fill: String,
        content: String,
        anchor: String,
        size: f64,
        rotated: bool,
    },
    /// Anything else.
    Other,
}

fn attr<'a>(tag: &'a str, name: &str) -> Option<&'a str> {
    let key = format!(" {name}=\"");
    let at = tag.find(&key)? + key.len();
    tag[at..].split('"').next()
}

/// The elements of `svg` in order (the figures write one tag per element).
fn elements(svg: &str) -> Vec<Element> {
    let mut out = Vec::new();
    let mut rest = svg;
    while let Some(at) = rest.find('<') {
        rest = &rest[at..];
        let end = rest.find('>').map_or(rest.len(), |e| e + 1);
        let tag = &rest[..end];
        if tag.starts_with("<polyline") {
            let points = attr(tag, "points")
                .unwrap_or("")
                .split_whitespace()
                .filter_map(|p| {
                    let (x, y) = p.split_once(',')?;
                    Some((x.parse().ok()?, y.parse().ok()?))
                })
                .collect();
            out.push(Element::Line {
                stroke: attr(tag, "stroke").unwrap_or("").to_uppercase(),
                width: attr(tag, "stroke-width")
                    .and_then(|w| w.parse().ok())
                    .unwrap_or(0.0),
                dash: attr(tag, "stroke-dasharray").map(str::to_string),
                points,
            });
        } else if tag.starts_with("<text") {
            let body = &rest[end..];
            let close = body.find("</text>").unwrap_or(body.len());
            out.push(Element::Text {
                fill: attr(tag, "fill").unwrap_or("").to_uppercase(),
                content: unescape(body[..close].trim()),
                anchor: attr(tag, "text-anchor").unwrap_or("start").to_string(),
                size: attr(tag, "font-size")
                    .and_then(|v| v.parse().ok())
                    .unwrap_or(0.0),
                rotated: attr(tag, "transform").is_some_and(|t| t.starts_with("rotate")),
            });
            rest = &body[close..];
            continue;
        } else if !tag.starts_with("</") {
            out.push(Element::Other);
        }
        rest = &rest[end..];
    }
    out
}

fn unescape(s: &str) -> String {
    s.replace("&apos;", "'")
        .replace("&quot;", "\"")
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&amp;", "&")
}

/// A legend row: its label and its line sample's colour, dash array and width.
struct LegendRow {
    label: String,
    stroke: String,
    dash: Option<String>,
    width: f64,
}

/// Whether `e` followed by `next` is a legend row's line sample (a horizontal line 28 px long
/// directly followed by its label).
fn is_sample(e: &Element, next: Option<&Element>) -> bool {
    matches!(
        (e, next),
        (Element::Line { points, .. }, Some(Element::Text { .. }))
            if points.len() == 2
                && points[0].1 == points[1].1
                && (points[1].0 - points[0].0 - 28.0).abs() < 0.5
    )
}

/// The legend rows of `svg` with a line sample, in order.
fn legend_rows_styled(svg: &str) -> Vec<LegendRow> {
    let els = elements(svg);
    els.windows(2)
        .filter(|w| is_sample(&w[0], w.get(1)))
        .filter_map(|w| match (&w[0], &w[1]) {
            (
                Element::Line {
                    stroke,
                    dash,
                    width,
                    ..
                },
                Element::Text { content, .. },
            ) => Some(LegendRow {
                label: content.clone(),
                stroke: stroke.clone(),
                dash: dash.clone(),
                width: *width,
            }),
            _ => None,
        })
        .collect()
}

/// The legend rows of `svg`: (label, sample colour).
fn legend_rows(svg: &str) -> Vec<(String, String)> {
    legend_rows_styled(svg)
        .into_iter()
        .map(|r| (r.label, r.stroke))
        .collect()
}

/// The word a reader names the dash array `dash` by: "dotted" for dots (2 or 3 px), "dashed"
/// for longer dashes, "dash-dot" for a pattern of a dash and a dot.
fn style_word(dash: &str) -> &'static str {
    let v: Vec<f64> = dash
        .split([' ', ','])
        .filter_map(|d| d.parse().ok())
        .collect();
    match v[..] {
        [a, _, c, _] if a != c => "dash-dot",
        [a, ..] if a <= 3.0 => "dotted",
        _ => "dashed",
    }
}

/// The line styles a legend note of `svg` explains, "dotted: p2, ω2; …": (style word, meaning).
fn style_notes(svg: &str) -> Vec<(String, String)> {
    const WORDS: [&str; 4] = ["solid", "dashed", "dotted", "dash-dot"];
    let mut out = Vec::new();
    for e in elements(svg) {
        let Element::Text { content, .. } = e else {
            continue;
        };
        for part in content.split("; ") {
            if let Some((word, meaning)) = part.split_once(": ") {
                if WORDS.contains(&word) {
                    out.push((word.to_string(), meaning.to_string()));
                }
            }
        }
    }
    out
}

/// Problems with the dash patterns of one figure: a pattern that means two things, or a dashed
/// or dotted curve that the legend of a figure with a legend does not explain. What a curve
/// drawn with a dash array means: the label of the legend row of its colour and dash array, or
/// else the meaning a legend note gives its style word ("dotted: p2, ω2"); what a legend
/// sample means: its label. Solid lines are told apart by their colours (checked by
/// [`legend_colour_problems`]).
fn dash_meaning_problems(svg: &str) -> Vec<String> {
    let els = elements(svg);
    let rows = legend_rows_styled(svg);
    let notes = style_notes(svg);
    let mut meanings: BTreeMap<String, Vec<String>> = BTreeMap::new();
    let mut mean = |dash: &str, what: String| {
        let m = meanings.entry(dash.to_string()).or_default();
        if !m.contains(&what) {
            m.push(what);
        }
    };
    for row in &rows {
        if let Some(d) = &row.dash {
            mean(d, row.label.clone());
        }
    }
    for (i, e) in els.iter().enumerate() {
        let Element::Line {
            stroke,
            dash: Some(dash),
            ..
        } = e
        else {
            continue;
        };
        if is_sample(e, els.get(i + 1)) {
            continue;
        }
        let row = rows
            .iter()
            .find(|r| r.stroke == *stroke && r.dash.as_deref() == Some(dash));
        let note = notes.iter().find(|(w, _)| w == style_word(dash));
        let what = match (row, note) {
            (Some(r), _) => r.label.clone(),
            (None, Some((_, m))) => m.clone(),
            (None, None) => "(no legend entry)".to_string(),
        };
        mean(dash, what);
    }
    let has_legend = !rows.is_empty() || !notes.is_empty();
    meanings
        .into_iter()
        .filter(|(_, m)| m.len() > 1 || (has_legend && m[0] == "(no legend entry)"))
        .map(|(dash, m)| format!("{} \"{dash}\" means {m:?}", style_word(&dash)))
        .collect()
}

/// Problems with the legend colours of one figure: a label shown in two colours, or a colour
/// naming two labels.
fn legend_colour_problems(svg: &str) -> Vec<String> {
    let mut colour_of: BTreeMap<String, String> = BTreeMap::new();
    let mut label_of: BTreeMap<String, String> = BTreeMap::new();
    let mut problems = Vec::new();
    for (label, colour) in legend_rows(svg) {
        match colour_of.get(&label) {
            Some(c) if *c != colour => {
                problems.push(format!("\"{label}\" drawn in {c} and {colour}"))
            }
            _ => {
                colour_of.insert(label.clone(), colour.clone());
            }
        }
        match label_of.get(&colour) {
            Some(l) if *l != label => {
                problems.push(format!("{colour} names \"{l}\" and \"{label}\""))
            }
            _ => {
                label_of.insert(colour, label);
            }
        }
    }
    problems
}

/// Subtitle colour of the figures (grey text under the title).
const SUBTITLE_FILL: &str = "#464646";

/// Units a number must stay with.
const UNITS: [&str; 12] = [
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
    "N·s/m",
    "m⁵/(N·s)",
];

/// Places where a subtitle of `svg` wraps between a number and its unit.
fn split_number_units(svg: &str) -> Vec<String> {
    let lines: Vec<String> = elements(svg)
        .into_iter()
        .filter_map(|e| match e {
            Element::Text { fill, content, .. } if fill == SUBTITLE_FILL => Some(content),
            _ => None,
        })
        .collect();
    lines
        .windows(2)
        .filter(|w| {
            let ends_in_digit = w[0].trim_end().ends_with(|c: char| c.is_ascii_digit());
            let first = w[1].split_whitespace().next().unwrap_or("");
            let first = first.trim_end_matches([',', ';', ')', '.', ':']);
            ends_in_digit && UNITS.contains(&first)
        })
        .map(|w| format!("\"{}\" / \"{}\"", w[0], w[1]))
        .collect()
}

/// WCAG contrast ratio of the colour `#RRGGBB` on white.
fn contrast_on_white(hex: &str) -> f64 {
    let hex = hex.trim_start_matches('#');
    let channel = |i: usize| {
        let v = f64::from(u8::from_str_radix(&hex[i..i + 2], 16).unwrap()) / 255.0;
        if v <= 0.03928 {
            v / 12.92
        } else {
            ((v + 0.055) / 1.055).powf(2.4)
        }
    };
    let l = 0.2126 * channel(0) + 0.7152 * channel(2) + 0.0722 * channel(4);
    1.05 / (l + 0.05)
}

/// Series colours of `svg` (its curves, 2 px wide or more with more than two points, and its
/// legend samples) with less than 3:1 contrast on white.
fn faint_series(svg: &str) -> Vec<String> {
    let curves = elements(svg).into_iter().filter_map(|e| match e {
        Element::Line {
            stroke,
            width,
            points,
            ..
        } if width >= 2.0 && points.len() > 2 => Some(stroke),
        _ => None,
    });
    let samples = legend_rows(svg).into_iter().map(|(_, colour)| colour);
    let mut faint: Vec<String> = curves
        .chain(samples)
        .filter(|c| c.len() == 7 && contrast_on_white(c) < 3.0)
        .collect();
    faint.sort();
    faint.dedup();
    faint
}

#[test]
fn each_legend_label_has_one_colour_and_each_colour_one_label() {
    let mut checked = 0;
    for (name, svg) in figures() {
        let problems = legend_colour_problems(svg);
        assert!(problems.is_empty(), "{name}: {problems:?}");
        checked += usize::from(!legend_rows(svg).is_empty());
    }
    assert!(checked >= 10, "only {checked} figures with a legend found");
    // The checker catches the fault it looks for.
    let bad = "<polyline stroke=\"#0072B2\" stroke-width=\"2\" points=\"10,20 38,20\"/>\n\
               <text fill=\"#000000\">\nx measured\n</text>\n\
               <polyline stroke=\"#0072B2\" stroke-width=\"2\" points=\"10,90 38,90\"/>\n\
               <text fill=\"#000000\">\ne measured\n</text>\n";
    assert_eq!(legend_colour_problems(bad).len(), 1);
}

#[test]
fn each_dash_pattern_has_one_meaning_that_the_legend_states() {
    let mut dashed = 0;
    for (name, svg) in figures() {
        let problems = dash_meaning_problems(svg);
        assert!(problems.is_empty(), "{name}: {problems:?}");
        dashed += elements(svg)
            .iter()
            .filter(
                |e| matches!(e, Element::Line { dash: Some(_), points, .. } if points.len() > 2),
            )
            .count();
    }
    // dashed and dotted curves are drawn as paths with their dash array, so the check sees them
    assert!(dashed >= 20, "only {dashed} dashed or dotted curves found");
    // The checker catches the faults it looks for: dashed for a series and for p2 (the sample
    // of a series and a curve of another colour explained by a note), dotted for a reference
    // gas fraction and a chosen level, a dotted curve in a figure whose legend says nothing
    // of dots.
    let line = |stroke: &str, dash: &str, points: &str| {
        format!("<polyline stroke=\"{stroke}\" stroke-width=\"2\" stroke-dasharray=\"{dash}\" points=\"{points}\"/>\n")
    };
    let text = |t: &str| format!("<text fill=\"#000000\">\n{t}\n</text>\n");
    let sample =
        |stroke: &str, dash: &str, label: &str| line(stroke, dash, "10,20 38,20") + &text(label);
    let curve = "0,0 5,5 9,3";
    let series_and_p2 = sample("#D55E00", "10 6", "model")
        + &line("#D55E00", "10 6", curve)
        + &line("#0072B2", "10 6", curve)
        + &text("solid: p1; dashed: p2");
    assert_eq!(dash_meaning_problems(&series_and_p2).len(), 1);
    let reference_and_chosen = sample("#000000", "2 6", "chosen")
        + &line("#000000", "2 6", "1,0 1,90 ")
        + &line("#0072B2", "2 6", curve)
        + &text("solid: over the range; dotted: at the reference gas fraction");
    assert_eq!(dash_meaning_problems(&reference_and_chosen).len(), 1);
    let unexplained = sample("#0072B2", "", "x") + &line("#D55E00", "2 5", curve);
    let unexplained = unexplained.replace(" stroke-dasharray=\"\"", "");
    assert_eq!(dash_meaning_problems(&unexplained).len(), 1);
    // one meaning a pattern, however many panels state it, passes
    let fine = sample("#595959", "10 6", "end of fit window")
        + &line("#595959", "10 6", "1,0 1,90")
        + &line("#0072B2", "2 5", curve)
        + &line("#D55E00", "2 5", curve)
        + &text("solid: p1, ω1; dotted: p2, ω2")
        + &text("solid: p1, ω1; dotted: p2, ω2");
    assert_eq!(dash_meaning_problems(&fine), Vec::<String>::new());
}

#[test]
fn no_subtitle_line_ends_inside_a_number_and_its_unit() {
    let mut subtitles = 0;
    for (name, svg) in figures() {
        assert_eq!(split_number_units(svg), Vec::<String>::new(), "{name}");
        subtitles += usize::from(svg.contains(SUBTITLE_FILL));
    }
    assert!(subtitles >= 10, "only {subtitles} subtitles found");
    // Long subtitles, wrapped wherever the width falls: the wrap never parts a number from
    // its unit.
    let t: Vec<f64> = (0..50).map(|i| f64::from(i) * 0.1).collect();
    let panel = pumpcyl_present::plot::Panel {
        y_label: "Position (mm)".into(),
        traces: vec![pumpcyl_present::plot::Trace {
            label: "x".into(),
            t_s: t.clone(),
            y: t.iter().map(|t| t.sin()).collect(),
            ..Default::default()
        }],
        ..Default::default()
    };
    for pad in 0..40 {
        let subtitle = format!(
            "{}GM = 6.8 dB @ 0.830 Hz PM = 33.7° @ 0.502 Hz; GM = -3.4 dB @ 0.880 Hz \
             PM = -36.6° @ 1.01 Hz; max |e| 9.66 mm, wave reduction 80.7 % at 4.394 bar \
             and 12.5 s with 4898 kg",
            "a".repeat(pad)
        );
        let svg =
            pumpcyl_present::plot::panels_svg("t", Some(&subtitle), std::slice::from_ref(&panel))
                .unwrap();
        assert_eq!(split_number_units(&svg), Vec::<String>::new(), "pad {pad}");
    }
}

#[test]
fn every_series_colour_shows_on_white() {
    for (name, svg) in figures() {
        assert_eq!(faint_series(svg), Vec::<String>::new(), "{name}");
    }
    assert!(contrast_on_white("#F0E442") < 3.0 && contrast_on_white("#56B4E9") < 3.0);
    assert!((contrast_on_white("#000000") - 21.0).abs() < 1e-9);
}

#[test]
fn curves_are_written_with_sub_pixel_coordinates() {
    for (name, svg) in figures() {
        let coords: Vec<f64> = elements(svg)
            .into_iter()
            .filter_map(|e| match e {
                Element::Line { points, .. } if points.len() > 20 => Some(points),
                _ => None,
            })
            .flatten()
            .flat_map(|(x, y)| [x, y])
            .collect();
        if coords.is_empty() {
            continue; // a heat map: no curve
        }
        let fractional = coords.iter().filter(|v| v.fract() != 0.0).count();
        assert!(
            fractional * 4 > coords.len(),
            "{name}: {fractional} of {} curve coordinates between whole pixels",
            coords.len()
        );
    }
}

#[test]
fn every_text_names_the_embedded_font_first() {
    // the PNGs are drawn in the embedded DejaVu Sans; the SVGs name it first so a viewer that
    // has it, and the report that embeds it, show the same text
    for (name, svg) in figures() {
        let families: Vec<&str> = svg
            .split("<text")
            .skip(1)
            .map(|t| attr(t, "font-family").unwrap_or("(none)"))
            .filter(|f| !f.starts_with("DejaVu Sans,"))
            .collect();
        assert!(svg.contains("<text"), "{name}: no text");
        assert_eq!(families, Vec::<&str>::new(), "{name}");
    }
}

/// `pumpcyl select`'s figure for the article's application with two waves and a rise time:
/// four panels whose wave descriptions are longer than a panel is high.
fn select_svg() -> &'static str {
    static SVG: OnceLock<String> = OnceLock::new();
    SVG.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let waves = "wave=[{ freq_hz = 0.125, amp_mm = 12.5, max_error_mm = 14.0 }, \
                     { freq_hz = 0.225, amp_mm = 17.5, max_error_mm = 10.0 }]";
        let args = [
            "select",
            "--set",
            waves,
            "--set",
            "max_rise_time_s=1.0",
            "--out",
        ];
        let out = run::pumpcyl(
            Path::new("."),
            &[&args[..], &[dir.path().to_str().unwrap()]].concat(),
        );
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        std::fs::read_to_string(dir.path().join("select.svg")).unwrap()
    })
}

/// The reproduce figure `name`.svg.
fn figure(name: &str) -> &'static str {
    let file = format!("{name}.svg");
    let found = figures().iter().find(|(n, _)| *n == file);
    &found.unwrap_or_else(|| panic!("no {file}")).1
}

/// The SVG font size of tick labels: plotters' text size 15 over 1.24.
const TICK_FONT: f64 = 15.0 / 1.24;

/// Whether `e` is a tick label anchored at `anchor` (`end`: a y axis, `middle`: the x axis).
fn tick_label<'a>(e: &'a Element, at: &str) -> Option<&'a str> {
    match e {
        Element::Text {
            content,
            anchor,
            size,
            rotated: false,
            ..
        } if anchor == at && (size - TICK_FONT).abs() < 0.01 => Some(content),
        _ => None,
    }
}

/// The y tick labels of the panel of `svg` whose (rotated) description starts with `desc`:
/// the right-anchored tick labels drawn since the previous panel's description.
fn y_tick_labels(svg: &str, desc: &str) -> Vec<String> {
    let mut run = Vec::new();
    for e in elements(svg) {
        if let Some(t) = tick_label(&e, "end") {
            run.push(t.to_string());
        } else if let Element::Text {
            content,
            rotated: true,
            ..
        } = &e
        {
            if content.starts_with(desc) {
                return run;
            }
            run.clear();
        }
    }
    panic!("no y description {desc:?}")
}

/// The x tick labels of `svg` (centred under the bottom plot).
fn x_tick_labels(svg: &str) -> Vec<String> {
    let els = elements(svg);
    (els.iter())
        .filter_map(|e| tick_label(e, "middle").map(str::to_string))
        .collect()
}

#[test]
fn category_axes_are_ticked_with_the_category_names_only() {
    // the single pump's mode, a category (1 or 2), not a number ticked 1.90 ... 2.10
    let mut modes = y_tick_labels(figure("figure1_circuits_step"), "Single-pump mode");
    modes.sort();
    assert_eq!(modes, ["1", "2"]);
    // the record sets by name, not at x = 0.5 ... 3.5
    assert_eq!(
        x_tick_labels(figure("sweep_beside_steps")),
        ["steps (the article's method)", "sweep", "steps and sweep"]
    );
    // through the library: names at 1..=n on either axis, shortened to their share of the width
    let long = "a record set whose name is far too long for a third of the width of the figure";
    let names: Vec<String> = ["first", long, "third"].map(String::from).into();
    let kinds: Vec<String> = ["off", "on"].map(String::from).into();
    let panel = pumpcyl_present::plot::Panel {
        y_label: "State".into(),
        traces: vec![pumpcyl_present::plot::Trace {
            label: "x".into(),
            t_s: vec![1.0, 2.0, 3.0],
            y: vec![1.0, 2.0, 2.0],
            ..Default::default()
        }],
        categories: kinds,
    };
    let svg = pumpcyl_present::plot::panels_categorical_svg(
        "t",
        None,
        ("set", &names),
        std::slice::from_ref(&panel),
    )
    .unwrap();
    let mut y = y_tick_labels(&svg, "State");
    y.sort();
    assert_eq!(y, ["off", "on"]);
    let x = x_tick_labels(&svg);
    assert_eq!(
        (x.len(), &x[0][..], &x[2][..]),
        (3, "first", "third"),
        "{x:?}"
    );
    assert!(x[1].starts_with("a record") && x[1].contains('…'), "{x:?}");
    assert_eq!(
        pumpcyl_present::plot::text_collisions(&svg),
        Vec::<String>::new()
    );
}

/// Labels named in more than one legend row of `svg`.
fn repeated_legend_labels(svg: &str) -> Vec<String> {
    let mut seen: Vec<String> = Vec::new();
    let mut repeated = Vec::new();
    for row in legend_rows_styled(svg) {
        if seen.contains(&row.label) {
            repeated.push(row.label);
        } else {
            seen.push(row.label);
        }
    }
    repeated
}

#[test]
fn a_stack_of_panels_names_each_series_once() {
    let mut stacks = 0;
    for (name, svg) in figures().iter().map(|(n, s)| (n.as_str(), s.as_str())) {
        assert_eq!(repeated_legend_labels(svg), Vec::<String>::new(), "{name}");
        stacks += usize::from(svg.matches("rotate(270").count() > 2);
    }
    assert!(stacks >= 10, "only {stacks} figures of stacked panels");
    // select's figure: the circuits named once, over four panels that all draw them
    let select = select_svg();
    assert_eq!(repeated_legend_labels(select), Vec::<String>::new());
    let rows = legend_rows_styled(select);
    for circuit in ["low-pressure", "dual-pump", "single-pump"] {
        assert_eq!(rows.iter().filter(|r| r.label == circuit).count(), 1);
    }
}

/// The y descriptions of `svg` as (first line, line count): consecutive rotated texts at one
/// height are the lines of one description.
fn y_descriptions(svg: &str) -> Vec<(String, usize)> {
    let mut out: Vec<(String, usize, String)> = Vec::new();
    for tag in svg.split("<text").skip(1) {
        let Some(centre) = tag.split("rotate(270, ").nth(1) else {
            continue;
        };
        let y = centre
            .split([',', ')'])
            .nth(1)
            .unwrap_or("")
            .trim()
            .to_string();
        let content = tag.split('>').nth(1).unwrap_or("").trim().to_string();
        match out.last_mut() {
            Some(last) if last.2 == y => last.1 += 1,
            _ => out.push((content, 1, y)),
        }
    }
    out.into_iter().map(|(c, n, _)| (c, n)).collect()
}

#[test]
fn no_text_of_a_figure_overlaps_another() {
    for (name, svg) in figures() {
        let c = pumpcyl_present::plot::text_collisions(svg);
        assert_eq!(c, Vec::<String>::new(), "{name}");
    }
    // select's four panels with two long wave descriptions: each wraps beside its own panel
    let select = select_svg();
    assert_eq!(
        pumpcyl_present::plot::text_collisions(select),
        Vec::<String>::new()
    );
    assert_eq!(
        pumpcyl_present::plot::text_overflow(select),
        Vec::<String>::new()
    );
    let descs = y_descriptions(select);
    assert_eq!(descs.len(), 4, "{descs:?}");
    assert!(
        descs.iter().filter(|(_, lines)| *lines == 2).count() >= 2,
        "the wave descriptions are longer than a panel is high: {descs:?}"
    );
    // the checker catches the fault it looks for: two y descriptions running into each other
    let text = |y: f64, t: &str| {
        format!("<text x=\"8\" y=\"{y}\" dy=\"0.76em\" text-anchor=\"middle\" font-size=\"13.7\" transform=\"rotate(270, 8, {y})\">\n{t}\n</text>\n")
    };
    let label = "max |e| (mm), 0.125 Hz ±12.5 mm";
    let svg = format!(
        "<svg width=\"600\" height=\"600\">{}{}</svg>",
        text(175.0, label),
        text(395.0, label)
    );
    assert_eq!(pumpcyl_present::plot::text_collisions(&svg).len(), 1);
}

/// The curves of `svg` with more than `min_points` points: (stroke, width, dash).
fn long_curves(svg: &str, min_points: usize) -> Vec<(String, f64, Option<String>)> {
    (elements(svg).into_iter())
        .filter_map(|e| match e {
            Element::Line {
                stroke,
                width,
                dash,
                points,
            } if points.len() > min_points => Some((stroke, width, dash)),
            _ => None,
        })
        .collect()
}

#[test]
fn a_curve_lying_under_a_later_one_is_drawn_in_another_width_that_the_legend_shows() {
    // the two dual pumps step alike: the matched D2 (vermillion) under the article's (green)
    let svg = figure("figure1_circuits_step");
    let curves = long_curves(svg, 100);
    let width_of = |colour: &str| {
        let c = curves.iter().find(|c| c.0 == colour).expect(colour);
        (c.1, c.2.clone())
    };
    let (matched, article) = (width_of("#D55E00"), width_of("#009E73"));
    assert_ne!(
        matched, article,
        "the matched D2's curve hidden under the article D2's"
    );
    let rows = legend_rows_styled(svg);
    let row = rows
        .iter()
        .find(|r| r.label.starts_with("dual pump, D2 matched"));
    assert_eq!(row.map(|r| r.width), Some(matched.0), "its legend sample");

    // through the library: of two equal curves the first is drawn wider, a third apart is not
    let t: Vec<f64> = (0..200).map(|i| f64::from(i) * 0.05).collect();
    let trace = |label: &str, off: f64| pumpcyl_present::plot::Trace {
        label: label.into(),
        t_s: t.clone(),
        y: t.iter().map(|t| t.sin() + off).collect(),
        ..Default::default()
    };
    let panel = pumpcyl_present::plot::Panel {
        y_label: "Position (mm)".into(),
        traces: vec![trace("a", 0.0), trace("b", 0.0), trace("c", 3.0)],
        ..Default::default()
    };
    let svg = pumpcyl_present::plot::panels_svg("t", None, &[panel]).unwrap();
    let widths: Vec<f64> = long_curves(&svg, 100).iter().map(|c| c.1).collect();
    assert_eq!(widths.len(), 3);
    assert!(
        widths[0] > widths[1] && widths[1] == widths[2],
        "{widths:?}"
    );
    let samples: Vec<f64> = legend_rows_styled(&svg).iter().map(|r| r.width).collect();
    assert_eq!(samples, widths);
}
