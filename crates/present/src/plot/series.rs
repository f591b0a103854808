//! What the figures draw their data with: the colour-blind-safe palette, a series split into
//! polylines and isolated points, and the stroke (colour, width, dash pattern) it is drawn and
//! shown in the legend with.

use plotters::element::DashedPathElement;
use plotters::prelude::*;

use super::axes::Chart;
use super::error::{plot_err, ReportError};

/// Okabe–Ito colour-blind-friendly palette, in the order series use it
/// (yellow last: it has the least contrast on white).
pub(super) const PALETTE: [RGBColor; 8] = [
    RGBColor(0, 114, 178),   // blue
    RGBColor(213, 94, 0),    // vermillion
    RGBColor(0, 158, 115),   // bluish green
    RGBColor(204, 121, 167), // reddish purple
    RGBColor(230, 159, 0),   // orange
    RGBColor(86, 180, 233),  // sky blue
    RGBColor(0, 0, 0),       // black
    RGBColor(240, 228, 66),  // yellow
];

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

/// How a series is drawn: colour, line width (px), dash pattern (dash, gap in px; `None` for
/// a solid line) and radius (px) of its isolated points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Stroke {
    pub(super) color: RGBColor,
    pub(super) width: u32,
    pub(super) pattern: Option<(i32, i32)>,
    pub(super) dot_r: u32,
}

/// Draw the polylines `lines` and the points `dots` of one series with `stroke`.
pub(super) fn draw_pieces<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    lines: impl IntoIterator<Item = Polyline>,
    dots: &[(f64, f64)],
    stroke: &Stroke,
) -> Result<(), ReportError> {
    let style = stroke.color.stroke_width(stroke.width);
    let lines = lines.into_iter();
    match stroke.pattern {
        None => chart.draw_series(lines.map(|l| PathElement::new(l, style))),
        Some((on, off)) => {
            chart.draw_series(lines.map(|l| DashedPathElement::new(l, on, off, style)))
        }
    }
    .map_err(plot_err)?;
    chart
        .draw_series(
            dots.iter()
                .map(|&p| Circle::new(p, stroke.dot_r, stroke.color.filled())),
        )
        .map_err(plot_err)?;
    Ok(())
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
    fn extent_skips_non_finite_values() {
        assert_eq!(
            finite_extent([3.0, f64::NAN, -1.0, f64::INFINITY, 2.0]),
            Some((-1.0, 3.0))
        );
        assert_eq!(finite_extent([f64::NAN]), None);
        assert_eq!(finite_extent([]), None);
    }
}
