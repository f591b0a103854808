//! Curves hidden under curves drawn after them (docs/formats.md#figures): a curve whose points
//! nearly all lie within a line width of later curves of its panel cannot be seen, so its
//! group (one colour and line style, drawn alike in every panel and named once in the legend)
//! is drawn wider: it shows as a band on both sides of the curve on top, and its legend sample
//! has the band's width.

use super::axes::Axis;
use super::series::Pieces;

/// Share of a curve's points under later curves from which it counts as hidden.
const HIDDEN_SHARE: f64 = 0.9;
/// Most width levels a group is raised by (a curve hidden under a hidden curve is raised once
/// more, so that it shows around the band of the one on top).
pub(super) const MAX_LEVEL: u32 = 3;
/// Opacity of a raised curve: a see-through band, so that a curve of its own colour drawn on
/// top of it (its best case on its worst, a dashed line on a solid one) still shows.
pub(super) const BAND_OPACITY: f64 = 0.5;
/// Most points of a curve tested (every n-th beyond).
const MAX_TESTED: usize = 4000;

/// One curve of a panel: its group's index and its pieces.
pub(super) struct Curve<'a> {
    pub(super) group: usize,
    pub(super) pieces: &'a Pieces,
}

/// A panel as the check sees it: its curves in drawing order over the value axis `y`.
pub(super) struct PanelCurves<'a> {
    pub(super) curves: Vec<Curve<'a>>,
    pub(super) y: &'a Axis,
}

/// A curve in pixels: its polylines and isolated points.
struct PxCurve {
    group: usize,
    lines: Vec<Vec<(f64, f64)>>,
    dots: Vec<(f64, f64)>,
}

/// The width level of each of `groups` groups: 0 unless a curve of the group is hidden under
/// later curves of other groups in its panel, else one more than the highest level among
/// those groups, at most [`MAX_LEVEL`]. A curve is hidden when at least [`HIDDEN_SHARE`] of its
/// points lie within `tol_px` of a later curve, on plots `size` px wide and high over the x
/// axis `x`.
pub(super) fn width_levels(
    panels: &[PanelCurves<'_>],
    x: &Axis,
    size: (f64, f64),
    tol_px: f64,
    groups: usize,
) -> Vec<u32> {
    let mut hidden: Vec<(usize, Vec<usize>)> = Vec::new();
    for panel in panels {
        let curves = in_pixels(panel, x, size);
        for (i, c) in curves.iter().enumerate() {
            let later: Vec<&PxCurve> = curves[i + 1..]
                .iter()
                .filter(|l| l.group != c.group)
                .collect();
            if let Some(by) = hidden_by(c, &later, tol_px) {
                hidden.push((c.group, by));
            }
        }
    }
    let mut level = vec![0; groups];
    // Each pass settles one more level of curves hidden under hidden curves.
    for _ in 0..MAX_LEVEL {
        for (g, by) in &hidden {
            let above = by.iter().map(|&b| level[b] + 1).max().unwrap_or(0);
            level[*g] = level[*g].max(above.min(MAX_LEVEL));
        }
    }
    level
}

/// The curves of `panel` in pixels from the plot's lower left corner.
fn in_pixels(panel: &PanelCurves<'_>, x: &Axis, (w, h): (f64, f64)) -> Vec<PxCurve> {
    let px = |&(a, b): &(f64, f64)| (x.fraction(a) * w, panel.y.fraction(b) * h);
    (panel.curves.iter())
        .map(|c| PxCurve {
            group: c.group,
            lines: (c.pieces.lines.iter())
                .map(|l| l.iter().map(px).collect())
                .collect(),
            dots: c.pieces.dots.iter().map(px).collect(),
        })
        .collect()
}

/// The groups of the curves of `later` that hide `curve`, each that passes over any of its
/// points (`None` when it shows).
fn hidden_by(curve: &PxCurve, later: &[&PxCurve], tol_px: f64) -> Option<Vec<usize>> {
    let points: Vec<(f64, f64)> = (curve.lines.iter().flatten())
        .chain(&curve.dots)
        .copied()
        .collect();
    if points.is_empty() || later.is_empty() {
        return None;
    }
    let stride = points.len().div_ceil(MAX_TESTED).max(1);
    let (mut tested, mut covered) = (0usize, 0usize);
    let mut by = Vec::new();
    for &p in points.iter().step_by(stride) {
        tested += 1;
        let over = (later.iter()).filter(|l| l.lines.iter().any(|line| near_line(line, p, tol_px)));
        let mut any = false;
        for l in over {
            any = true;
            if !by.contains(&l.group) {
                by.push(l.group);
            }
        }
        covered += usize::from(any);
    }
    (covered as f64 >= HIDDEN_SHARE * tested as f64).then_some(by)
}

/// Whether `p` lies within `tol` of the polyline `line`. Segments are searched by their x
/// range when the polyline runs left to right, else all of them.
fn near_line(line: &[(f64, f64)], p: (f64, f64), tol: f64) -> bool {
    let segments = line.windows(2);
    if !line.windows(2).all(|w| w[0].0 <= w[1].0) {
        return segments.into_iter().any(|s| segment_distance(s, p) <= tol);
    }
    let first = line.partition_point(|q| q.0 < p.0 - tol).saturating_sub(1);
    line[first..]
        .windows(2)
        .take_while(|s| s[0].0 <= p.0 + tol)
        .any(|s| segment_distance(s, p) <= tol)
}

/// Distance of `p` from the segment `s[0]`–`s[1]`.
fn segment_distance(s: &[(f64, f64)], p: (f64, f64)) -> f64 {
    let ((ax, ay), (bx, by)) = (s[0], s[1]);
    let (dx, dy) = (bx - ax, by - ay);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((p.0 - ax) * dx + (p.1 - ay) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p.0 - ax - t * dx).hypot(p.1 - ay - t * dy)
}

#[cfg(test)]
mod tests {
    use super::super::axes::linear_axis;
    use super::*;

    fn pieces(f: impl Fn(f64) -> f64) -> Pieces {
        Pieces {
            lines: vec![(0..=100).map(|i| (f64::from(i), f(f64::from(i)))).collect()],
            dots: Vec::new(),
        }
    }

    #[test]
    fn a_curve_under_a_later_one_is_raised_and_one_beside_it_is_not() {
        let (x, y) = (linear_axis(0.0, 100.0, 4.0), linear_axis(-10.0, 10.0, 4.0));
        let a = pieces(|t| (t / 10.0).sin());
        let near = pieces(|t| (t / 10.0).sin() + 0.01);
        let apart = pieces(|t| (t / 10.0).sin() + 5.0);
        let levels = |curves: Vec<Curve<'_>>, groups| {
            let panel = PanelCurves { curves, y: &y };
            width_levels(&[panel], &x, (800.0, 200.0), 2.0, groups)
        };
        let curve = |group, pieces| Curve { group, pieces };
        // hidden under the later curve; the later one shows
        assert_eq!(levels(vec![curve(0, &a), curve(1, &near)], 2), vec![1, 0]);
        // drawn last, nothing hides it
        assert_eq!(levels(vec![curve(1, &near), curve(0, &a)], 2), vec![0, 1]);
        // 5 units apart on a 20-unit, 200 px axis: 50 px apart
        assert_eq!(levels(vec![curve(0, &a), curve(1, &apart)], 2), vec![0, 0]);
        // three on top of one another: a band around a band around the top curve
        let c = [curve(0, &a), curve(1, &near), curve(2, &a)];
        assert_eq!(levels(c.into(), 3), vec![2, 1, 0]);
        // a curve of the same group on top is the same drawing: nothing to raise
        assert_eq!(levels(vec![curve(0, &a), curve(0, &near)], 1), vec![0]);
    }

    #[test]
    fn distance_to_segments() {
        let s = [(0.0, 0.0), (10.0, 0.0)];
        assert_eq!(segment_distance(&s, (5.0, 3.0)), 3.0);
        assert_eq!(segment_distance(&s, (13.0, 4.0)), 5.0);
        // a vertical line is near the points along it
        let v = [(5.0, 0.0), (5.0, 100.0)];
        assert!(near_line(&v, (5.5, 50.0), 1.0) && !near_line(&v, (8.0, 50.0), 1.0));
        // a polyline running back and forth is searched whole
        let zigzag = [(0.0, 0.0), (10.0, 10.0), (0.0, 20.0)];
        assert!(near_line(&zigzag, (5.0, 15.0), 0.5));
    }
}
