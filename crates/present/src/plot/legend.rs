//! The legend every figure shares: a box of line samples and labels in one to four columns,
//! placed in the corner of the plot where it hides the fewest curve segments.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::axes::Axis;
use super::error::{plot_err, ReportError};
use super::series::{precise_path, Pieces, Stroke};
use super::{layout, render};

/// Label text size, and line-sample length (px), at scale 1.
const FONT_SIZE: f64 = 15.0;
const SAMPLE_LEN: f64 = 28.0;

/// What a legend row shows before its label.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Sample {
    /// A short line in the row's stroke.
    Line,
    /// A marker: a filled circle of the given radius (px).
    Dot(u32),
    /// A bar: a filled square as high as a row's text.
    Block,
    /// Nothing: the row is a note, starting where the samples do.
    Note,
}

/// One legend row: a sample and a label.
#[derive(Clone)]
pub(super) struct LegendEntry {
    pub(super) label: String,
    /// The stroke of the sample line (colour, width, dash pattern, opacity) or the colour of
    /// its dot.
    pub(super) stroke: Stroke,
    /// What the row shows before its label.
    pub(super) sample: Sample,
}

impl LegendEntry {
    /// The legend row showing `stroke` with `label`.
    pub(super) fn of(stroke: &Stroke, label: &str) -> LegendEntry {
        LegendEntry {
            label: label.to_string(),
            stroke: *stroke,
            sample: Sample::Line,
        }
    }

    /// Whether `other` is the same row: the same label and sample, and for a sample the same
    /// stroke (a note is its label).
    pub(super) fn same_row(&self, other: &LegendEntry) -> bool {
        self.label == other.label
            && self.sample == other.sample
            && (self.sample == Sample::Note || self.stroke == other.stroke)
    }
}

/// The rows of a stack of plots' legends, top plot first, each row kept only in the first
/// legend that has it (docs/formats.md#figures): the plots share their series' names, so a
/// series is named once.
pub(super) fn first_rows(legends: Vec<Vec<LegendEntry>>) -> Vec<Vec<LegendEntry>> {
    let mut shown: Vec<LegendEntry> = Vec::new();
    legends
        .into_iter()
        .map(|rows| {
            let new: Vec<LegendEntry> = (rows.into_iter())
                .filter(|r| !shown.iter().any(|s| s.same_row(r)))
                .collect();
            shown.extend(new.iter().cloned());
            new
        })
        .collect()
}

/// Pixel sizes of the legend box.
pub(super) struct LegendMetrics<'f> {
    font: TextStyle<'f>,
    row_h: i32,
    /// Padding inside the box.
    pad: i32,
    sample_len: i32,
    /// Gap between sample and label.
    sample_gap: i32,
    /// Gap between columns.
    col_gap: i32,
    /// Distance of the box from the plotting-area edges.
    inset: i32,
}

impl LegendMetrics<'static> {
    /// The legend every figure draws, at `scale`: 15-point labels, 28 px line samples.
    pub(super) fn new(scale: f64) -> Self {
        let px = render::px(scale);
        LegendMetrics {
            font: render::text(scale)(FONT_SIZE),
            row_h: px(FONT_SIZE * 1.4),
            pad: px(8.0),
            sample_len: px(SAMPLE_LEN),
            sample_gap: px(8.0),
            col_gap: px(20.0),
            inset: px(6.0),
        }
    }

    /// Width in pixels of each entry's label.
    pub(super) fn label_widths(&self, entries: &[LegendEntry]) -> Vec<i32> {
        let size = self.font.font.get_size();
        entries
            .iter()
            .map(|e| {
                let w = layout::text_width(&e.label, size).ceil() as i32;
                // A note starts where the samples do.
                if e.sample != Sample::Note {
                    w
                } else {
                    (w - self.sample_len - self.sample_gap).max(0)
                }
            })
            .collect()
    }

    /// Height in pixels of the most compact legend of `label_w` with its insets, as a
    /// fraction of a plot `plot_h` px high, if a legend fits in a plot `plot_w` px wide.
    pub(super) fn compact_fraction(
        &self,
        label_w: &[i32],
        (plot_w, plot_h): (i32, i32),
    ) -> Option<f64> {
        compact_legend(label_w, self, plot_w)
            .map(|l| f64::from(l.h + 2 * self.inset) / f64::from(plot_h.max(1)))
    }
}

/// Legend box: columns (entries fill them top to bottom), corner and size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct LegendLayout {
    columns: usize,
    rows: usize,
    /// (right, top): true for the right / top corner.
    corner: (bool, bool),
    w: i32,
    h: i32,
}

/// Legend of `label_w.len()` entries in `columns` columns, unplaced.
fn legend_box(label_w: &[i32], m: &LegendMetrics<'_>, columns: usize) -> LegendLayout {
    let rows = label_w.len().div_ceil(columns.max(1)).max(1);
    let columns = label_w.len().div_ceil(rows).max(1);
    let col_w: i32 = label_w
        .chunks(rows)
        .map(|c| c.iter().copied().max().unwrap_or(0) + m.sample_len + m.sample_gap)
        .sum();
    LegendLayout {
        columns,
        rows,
        corner: (true, true),
        w: col_w + (columns as i32 - 1) * m.col_gap + 2 * m.pad,
        h: rows as i32 * m.row_h + 2 * m.pad - (m.row_h - m.font.font.get_size() as i32).max(0),
    }
}

/// The lowest legend (most columns) that fits in a plot `plot_w` px wide.
fn compact_legend(label_w: &[i32], m: &LegendMetrics<'_>, plot_w: i32) -> Option<LegendLayout> {
    (1..=label_w.len().min(4))
        .rev()
        .map(|c| legend_box(label_w, m, c))
        .find(|l| l.w + 2 * m.inset <= plot_w)
}

/// Legend layout hiding the fewest curve segments of `pieces`, and how many it hides;
/// fewer columns first, then the corners top right, top left, bottom right,
/// bottom left. `(x, y)` are the axes the pieces are drawn on; `plot` is the plotting-area size
/// in pixels.
pub(super) fn place_legend(
    pieces: &[Pieces],
    (x, y): (&Axis, &Axis),
    label_w: &[i32],
    m: &LegendMetrics<'_>,
    (plot_w, plot_h): (i32, i32),
) -> (LegendLayout, usize) {
    let norm = |(a, b): (f64, f64)| (x.fraction(a), y.fraction(b));
    let (pw, ph) = (f64::from(plot_w.max(1)), f64::from(plot_h.max(1)));
    let mut best: Option<(LegendLayout, usize)> = None;
    for columns in 1..=label_w.len().min(4) {
        let mut layout = legend_box(label_w, m, columns);
        if layout.columns != columns || (columns > 1 && layout.w + 2 * m.inset > plot_w) {
            continue;
        }
        // Box as fractions of the plotting area, y upwards.
        let (lw, lh) = (
            f64::from(layout.w + m.inset) / pw,
            f64::from(layout.h + m.inset) / ph,
        );
        for corner in [(true, true), (false, true), (true, false), (false, false)] {
            let x0 = if corner.0 { 1.0 - lw } else { 0.0 };
            let y0 = if corner.1 { 1.0 - lh } else { 0.0 };
            let rect = (x0, y0, x0 + lw, y0 + lh);
            let mut hits = 0;
            for pieces in pieces {
                for line in &pieces.lines {
                    hits += line
                        .windows(2)
                        .filter(|w| segment_hits_rect(norm(w[0]), norm(w[1]), rect))
                        .count();
                }
                hits += pieces
                    .dots
                    .iter()
                    .filter(|&&p| segment_hits_rect(norm(p), norm(p), rect))
                    .count();
            }
            let better = match &best {
                Some((_, h)) => hits < *h,
                None => true,
            };
            if better {
                layout.corner = corner;
                best = Some((layout, hits));
            }
            if hits == 0 {
                return (layout, 0);
            }
        }
    }
    best.unwrap_or_else(|| (legend_box(label_w, m, 1), 0))
}

/// Draw a legend box in the pixel coordinates of the plotting area.
pub(super) fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[LegendEntry],
    label_w: &[i32],
    layout: &LegendLayout,
    m: &LegendMetrics<'_>,
    border_w: u32,
) -> Result<(), ReportError> {
    let (pw, ph) = area.dim_in_pixel();
    let x0 = if layout.corner.0 {
        pw as i32 - m.inset - layout.w
    } else {
        m.inset
    };
    let y0 = if layout.corner.1 {
        m.inset
    } else {
        ph as i32 - m.inset - layout.h
    };
    let corners = [(x0, y0), (x0 + layout.w, y0 + layout.h)];
    render::draw_box(area, corners, render::label_background(), border_w)?;
    let text_style = m.font.pos(Pos::new(HPos::Left, VPos::Center));
    let mut x = x0 + m.pad;
    for (col, widths) in entries.chunks(layout.rows).zip(label_w.chunks(layout.rows)) {
        for (row, e) in col.iter().enumerate() {
            let y = y0 + m.pad + row as i32 * m.row_h + m.font.font.get_size() as i32 / 2;
            let stroke = &e.stroke;
            let (xf, yf) = (f64::from(x), f64::from(y));
            match e.sample {
                Sample::Line => precise_path(
                    area,
                    &[(xf, yf), (xf + f64::from(m.sample_len), yf)],
                    stroke,
                )?,
                Sample::Dot(r) => area
                    .draw(&Circle::new(
                        (x + m.sample_len / 2, y),
                        r,
                        stroke.color.mix(stroke.opacity).filled(),
                    ))
                    .map_err(plot_err)?,
                Sample::Block => {
                    let h = m.font.font.get_size() as i32 / 2;
                    let c = x + m.sample_len / 2;
                    area.draw(&Rectangle::new(
                        [(c - h, y - h), (c + h, y + h)],
                        stroke.color.mix(stroke.opacity).filled(),
                    ))
                    .map_err(plot_err)?
                }
                Sample::Note => {}
            }
            let text_x = match e.sample {
                Sample::Note => x,
                _ => x + m.sample_len + m.sample_gap,
            };
            area.draw(&Text::new(e.label.clone(), (text_x, y), text_style.clone()))
                .map_err(plot_err)?;
        }
        x += widths.iter().copied().max().unwrap_or(0) + m.sample_len + m.sample_gap + m.col_gap;
    }
    Ok(())
}

/// Whether the segment `a`-`b` touches the rectangle `(x0, y0, x1, y1)`
/// (Liang–Barsky clipping).
fn segment_hits_rect(a: (f64, f64), b: (f64, f64), (x0, y0, x1, y1): (f64, f64, f64, f64)) -> bool {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-dx, a.0 - x0),
        (dx, x1 - a.0),
        (-dy, a.1 - y0),
        (dy, y1 - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return false;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
            if t0 > t1 {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::super::axes::linear_axis;
    use super::*;

    #[test]
    fn legend_layout_and_placement() {
        let m = LegendMetrics::new(1.0);
        assert_eq!((m.row_h, m.pad, m.sample_len, m.sample_gap), (21, 8, 28, 8));
        assert_eq!((m.col_gap, m.inset), (20, 6));
        let w = [20, 30, 90, 100];
        let one = legend_box(&w, &m, 1);
        assert_eq!((one.columns, one.rows), (1, 4));
        assert_eq!(one.w, 100 + 36 + 16);
        let two = legend_box(&w, &m, 2);
        assert_eq!((two.columns, two.rows), (2, 2));
        assert_eq!(two.w, 30 + 36 + 100 + 36 + 20 + 16);
        assert!(two.h < one.h);
        // Three columns of four entries collapse to two.
        assert_eq!(legend_box(&w, &m, 3).columns, 2);
        let cols = |plot_w| compact_legend(&w, &m, plot_w).map(|l| l.columns);
        assert_eq!(cols(1000), Some(4));
        assert_eq!(compact_legend(&w, &m, 300), Some(two));
        assert_eq!(cols(200), Some(1));
        assert_eq!(cols(100), None);

        // A curve in the upper right only: the legend goes to the upper left.
        let axis = |lo, hi| linear_axis(lo, hi, 4.0);
        let x = axis(0.0, 1.0);
        let pieces = |t: &[f64], y: &[f64]| Pieces {
            lines: vec![t.iter().copied().zip(y.iter().copied()).collect()],
            dots: Vec::new(),
        };
        let t: Vec<f64> = (0..101).map(|i| f64::from(i) * 0.01).collect();
        let y: Vec<f64> = t
            .iter()
            .map(|&t| if t > 0.5 { 10.0 } else { 0.0 })
            .collect();
        let (layout, hits) = place_legend(
            &[pieces(&t, &y)],
            (&x, &axis(-1.0, 11.0)),
            &[30, 30],
            &m,
            (800, 200),
        );
        assert_eq!(hits, 0);
        assert_eq!(layout.corner, (false, true));
        // Curves everywhere: some hits remain.
        let y: Vec<f64> = t.iter().map(|&t| (200.0 * t).sin()).collect();
        let (_, hits) = place_legend(
            &[pieces(&t, &y)],
            (&x, &axis(-1.05, 1.05)),
            &[30],
            &m,
            (800, 200),
        );
        assert!(hits > 0);
    }

    #[test]
    fn segment_rect() {
        let r = (0.5, 0.5, 1.0, 1.0);
        assert!(segment_hits_rect((0.0, 0.0), (1.0, 1.0), r));
        assert!(!segment_hits_rect((0.0, 0.0), (1.0, 0.4), r));
        assert!(segment_hits_rect((0.7, 0.7), (0.7, 0.7), r));
        assert!(!segment_hits_rect((0.2, 0.7), (0.2, 0.7), r));
    }

    #[test]
    fn label_widths_follow_the_font() {
        let m = LegendMetrics::new(2.0);
        let black = Stroke {
            color: BLACK,
            width: 1,
            pattern: None,
            dot_r: 0,
            opacity: 1.0,
        };
        let e = |l: &str| LegendEntry::of(&black, l);
        let w = m.label_widths(&[e("a"), e("a longer label")]);
        assert!(w[0] > 0 && w[1] > 5 * w[0], "{w:?}");
        assert_eq!(
            w[1],
            layout::text_width("a longer label", 30.0).ceil() as i32
        );
    }
}
