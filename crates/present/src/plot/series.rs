//! What the figures draw their data with: the colour-blind-safe palette, a series split into
//! polylines and isolated points, and the stroke (colour, width, dash pattern) it is drawn and
//! shown in the legend with.

use plotters::prelude::*;

use super::axes::Chart;
use super::error::{plot_err, ReportError};
use super::precise;

/// Colour-blind-friendly palette after Okabe–Ito, in the order series use it. Every colour
/// has a contrast ratio of at least 3:1 on white (WCAG), so lines stay visible: the light
/// orange, sky blue and yellow of Okabe–Ito are replaced by ochre, dark purple and dark grey.
pub(super) const PALETTE: [RGBColor; 8] = [
    RGBColor(0, 114, 178),   // blue
    RGBColor(213, 94, 0),    // vermillion
    RGBColor(0, 158, 115),   // bluish green
    RGBColor(204, 121, 167), // reddish purple
    RGBColor(170, 102, 0),   // ochre
    RGBColor(123, 50, 148),  // dark purple
    RGBColor(0, 0, 0),       // black
    RGBColor(89, 89, 89),    // dark grey
];

/// WCAG contrast ratio of `c` on white (1 for white, 21 for black).
#[cfg(test)]
pub(super) fn contrast_on_white(c: RGBColor) -> f64 {
    let lin = |v: u8| {
        let v = f64::from(v) / 255.0;
        if v <= 0.03928 {
            v / 12.92
        } else {
            ((v + 0.055) / 1.055).powf(2.4)
        }
    };
    let l = 0.2126 * lin(c.0) + 0.7152 * lin(c.1) + 0.0722 * lin(c.2);
    1.05 / (l + 0.05)
}

/// Colour of series number `i`, cycling through the palette.
pub(super) fn series_color(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// A polyline in data coordinates.
pub(super) type Polyline = Vec<(f64, f64)>;

/// Drawable pieces of one series: the runs of consecutive drawable points and the isolated
/// points (no drawable neighbour), drawn as dots.
#[derive(Debug, Default, Clone, PartialEq)]
pub(super) struct Pieces {
    pub(super) lines: Vec<Polyline>,
    pub(super) dots: Vec<(f64, f64)>,
}

impl Pieces {
    /// Every point of the pieces, the lines' then the lone dots'.
    pub(super) fn points(&self) -> Vec<(f64, f64)> {
        (self.lines.iter().flatten())
            .chain(&self.dots)
            .copied()
            .collect()
    }
}

/// A dash pattern in px: dash, gap, dash, gap (a plain dashed or dotted line repeats its first
/// pair; a dash-dot line does not).
pub(super) type Dash = [i32; 4];

/// The dash pattern of `on` px dashes and `off` px gaps.
pub(super) fn even_dash(on: i32, off: i32) -> Dash {
    [on, off, on, off]
}

/// How a series is drawn: colour, line width (px), dash pattern (`None` for a solid line),
/// radius (px) of its isolated points and the lines' opacity (1 opaque; less for a band drawn
/// around curves on top of it, docs/formats.md#figures).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Stroke {
    pub(super) color: RGBColor,
    pub(super) width: u32,
    pub(super) pattern: Option<Dash>,
    pub(super) dot_r: u32,
    pub(super) opacity: f64,
}

/// Draw the polylines `lines` and the points `dots` of one series with `stroke`. The lines
/// are written with sub-pixel coordinates, a dashed one as one path with its dash pattern (see
/// [`precise_path`]), so that the SVG states the style every curve is drawn in.
pub(super) fn draw_pieces<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    lines: impl IntoIterator<Item = Polyline>,
    dots: &[(f64, f64)],
    stroke: &Stroke,
) -> Result<(), ReportError> {
    let spec = chart.as_coord_spec();
    let (xa, ya) = (spec.x_spec().clone(), spec.y_spec().clone());
    let (x0, y0) = chart.backend_coord(&(xa.lo, ya.lo));
    let (x1, y1) = chart.backend_coord(&(xa.hi, ya.hi));
    let to_px = |(x, y): (f64, f64)| {
        (
            f64::from(x0) + xa.fraction(x) * f64::from(x1 - x0),
            f64::from(y0) + ya.fraction(y) * f64::from(y1 - y0),
        )
    };
    let area = chart.plotting_area().strip_coord_spec();
    let (ox, oy) = area.get_base_pixel();
    for line in lines {
        let pts: Vec<(f64, f64)> = line
            .into_iter()
            .map(|p| {
                let (x, y) = to_px(p);
                (x - f64::from(ox), y - f64::from(oy))
            })
            .collect();
        precise_path(&area, &pts, stroke)?;
    }
    chart
        .draw_series(
            dots.iter()
                .map(|&p| Circle::new(p, stroke.dot_r, stroke.color.mix(stroke.opacity).filled())),
        )
        .map_err(plot_err)?;
    Ok(())
}

/// Draw the polyline `pts` (pixels relative to `area`, sub-pixel) with `stroke`, dashed as
/// one path with `stroke-dasharray`. Plotters writes whole pixels only, so a placeholder is
/// drawn in its place and [`precise::substitute`] writes the path into the finished SVG
/// document with two decimals.
pub(super) fn precise_path<DB: DrawingBackend, CT: plotters::coord::CoordTranslate>(
    area: &DrawingArea<DB, CT>,
    pts: &[(f64, f64)],
    stroke: &Stroke,
) -> Result<(), ReportError> {
    use std::fmt::Write;
    if pts.len() < 2 {
        return Ok(());
    }
    let area = area.strip_coord_spec();
    let (ox, oy) = area.get_base_pixel();
    let mut points = String::new();
    for &(x, y) in pts {
        let (x, y) = (x + f64::from(ox), y + f64::from(oy));
        write!(
            points,
            "{},{} ",
            precise::short_decimal(x),
            precise::short_decimal(y)
        )
        .ok();
    }
    let c = stroke.color;
    let dash = stroke.pattern.map_or(String::new(), |d| {
        format!(" stroke-dasharray=\"{}\"", dash_array(d))
    });
    let element = format!(
        "<polyline fill=\"none\" opacity=\"{}\" stroke=\"#{:02X}{:02X}{:02X}\" stroke-width=\"{}\"{dash} points=\"{}\"/>",
        stroke.opacity,
        c.0,
        c.1,
        c.2,
        stroke.width,
        points.trim_end()
    );
    let style = TextStyle::from((super::font::FAMILY, 1.0).into_font());
    area.draw(&Text::new(precise::hold(element), (0, 0), style))
        .map_err(plot_err)
}

/// The SVG `stroke-dasharray` of `d`: two numbers when its second pair repeats the first.
fn dash_array(d: Dash) -> String {
    if d[..2] == d[2..] {
        format!("{} {}", d[0], d[1])
    } else {
        format!("{} {} {} {}", d[0], d[1], d[2], d[3])
    }
}

/// The runs of consecutive `Some` points of `points` (a `None` ends a run), in order.
pub(super) fn runs(points: impl IntoIterator<Item = Option<(f64, f64)>>) -> Vec<Polyline> {
    let mut out = Vec::new();
    let mut run = Polyline::new();
    for p in points.into_iter().chain(std::iter::once(None)) {
        match p {
            Some(p) => run.push(p),
            None if !run.is_empty() => out.push(std::mem::take(&mut run)),
            None => {}
        }
    }
    out
}

impl Pieces {
    /// The runs of consecutive `Some` points of `points` as polylines, runs of one point as dots.
    pub(super) fn split(points: impl IntoIterator<Item = Option<(f64, f64)>>) -> Self {
        let mut pieces = Pieces::default();
        for run in runs(points) {
            match run[..] {
                [p] => pieces.dots.push(p),
                _ => pieces.lines.push(run),
            }
        }
        pieces
    }
}

/// Smallest and largest finite value of `values`, or `None` when none is finite.
pub(super) fn finite_extent(values: impl IntoIterator<Item = f64>) -> Option<(f64, f64)> {
    values
        .into_iter()
        .filter(|v| v.is_finite())
        .fold(None, |acc, v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_split_at_gaps_and_lone_points_become_dots() {
        let p = |x: f64| Some((x, 2.0 * x));
        let pts = [
            p(0.0),
            p(1.0),
            None,
            p(2.0),
            None,
            None,
            p(3.0),
            p(4.0),
            p(5.0),
        ];
        assert_eq!(runs(pts).len(), 3);
        let pieces = Pieces::split(pts);
        assert_eq!(
            pieces.lines,
            vec![
                vec![(0.0, 0.0), (1.0, 2.0)],
                vec![(3.0, 6.0), (4.0, 8.0), (5.0, 10.0)]
            ]
        );
        assert_eq!(pieces.dots, vec![(2.0, 4.0)]);
        assert_eq!(Pieces::split([None, None]), Pieces::default());
    }

    #[test]
    fn every_palette_colour_shows_on_white() {
        for c in PALETTE {
            assert!(contrast_on_white(c) >= 3.0, "{c:?}");
        }
        assert!(contrast_on_white(RGBColor(240, 228, 66)) < 3.0, "yellow");
        assert!((contrast_on_white(RGBColor(0, 0, 0)) - 21.0).abs() < 1e-9);
        assert_eq!(precise::short_decimal(12.345_6), "12.35");
        assert_eq!(precise::short_decimal(3.0), "3");
    }

    #[test]
    fn dash_arrays_repeat_a_pair_once() {
        assert_eq!(dash_array(even_dash(10, 6)), "10 6");
        assert_eq!(dash_array([12, 4, 2, 4]), "12 4 2 4");
    }

    #[test]
    fn extent_skips_non_finite_values() {
        assert_eq!(
            finite_extent([3.0, f64::NAN, -1.0, f64::INFINITY, 2.0]),
            Some((-1.0, 3.0))
        );
        assert_eq!(finite_extent([f64::NAN]), None);
        assert_eq!(finite_extent([]), None);
    }
}
