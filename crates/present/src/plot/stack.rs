//! Plots stacked vertically under the header and sharing one x axis, labelled under the bottom
//! plot only (the Bode diagram's magnitude over phase, the time-series panels): the margins,
//! equal plot heights, and each plot's chart with its axes drawn.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::axes::{self, Axis, Chart};
use super::error::{plot_err, ReportError};
use super::render;

/// Layout at scale 1 (px): margins left, right, above the first and below the last plot, the
/// margin above and below each plot between two plots, and the x label area under the last.
const MARGIN_LEFT: f64 = 8.0;
const MARGIN_RIGHT: f64 = 30.0;
const MARGIN_TOP: f64 = 4.0;
const MARGIN_BOTTOM: f64 = 8.0;
const PLOT_GAP: f64 = 10.0;
const X_LABEL_AREA: f64 = 58.0;

/// Height (px at scale 1) of a stack of `n` plots each `plot_h` px high.
pub(super) fn natural_height(n: f64, plot_h: f64) -> f64 {
    MARGIN_TOP + n * plot_h + (n - 1.0) * 2.0 * PLOT_GAP + X_LABEL_AREA + MARGIN_BOTTOM
}

/// Height (px) of each of `n` plots stacked in a body `body_h` px high, at `scale` (may be
/// small or negative when the body is too low; callers check).
pub(super) fn plot_height(body_h: i32, n: usize, scale: f64) -> i32 {
    let px = render::px(scale);
    let n = n.max(1) as i32;
    (body_h - px(MARGIN_TOP) - (n - 1) * 2 * px(PLOT_GAP) - px(X_LABEL_AREA) - px(MARGIN_BOTTOM))
        / n
}

/// Width (px) of the plots in a figure `width` px wide whose y label area is `y_label_area`.
pub(super) fn plot_width(width: u32, y_label_area: i32, scale: f64) -> i32 {
    let px = render::px(scale);
    width as i32 - px(MARGIN_LEFT) - px(MARGIN_RIGHT) - y_label_area
}

/// The areas of `n` plots each `plot_h` px high in `body`, top to bottom, each holding its plot
/// and margins (and the x label area for the last).
pub(super) fn areas<DB: DrawingBackend>(
    body: &DrawingArea<DB, Shift>,
    n: usize,
    plot_h: i32,
    scale: f64,
) -> Vec<DrawingArea<DB, Shift>> {
    let px = render::px(scale);
    let (m_top, m_gap) = (px(MARGIN_TOP), px(PLOT_GAP));
    let breaks: Vec<i32> = (1..n as i32)
        .map(|k| m_top + k * plot_h + (2 * k - 1) * m_gap)
        .collect();
    body.split_by_breakpoints([] as [i32; 0], breaks)
}

/// The y descriptions `descs` fitted beside plots `plot_h` px high ([`axes::y_desc_lines`]),
/// and the width of the y label area they share with the tick labels of `axes` (the plots
/// line up: every plot gets the area its widest labels and longest description need).
pub(super) fn y_labels<'d, 'a>(
    descs: impl IntoIterator<Item = &'d str>,
    axes: impl IntoIterator<Item = &'a Axis>,
    plot_h: i32,
    scale: f64,
) -> (Vec<Vec<String>>, i32) {
    let lines: Vec<Vec<String>> = descs
        .into_iter()
        .map(|d| axes::y_desc_lines(d, plot_h, scale))
        .collect();
    let most = lines.iter().map(Vec::len).max().unwrap_or(1);
    (lines, axes::y_label_area(axes, most, scale))
}

/// The chart of plot `i` of `n` on `area` (from [`areas`]) over the axes `(x, y)`, its axes
/// drawn with a grid: tick labels, the y description's lines `y_desc` (from [`y_labels`]) and,
/// under the last plot only, the x tick labels and `x_desc`.
pub(super) fn chart<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    (i, n): (usize, usize),
    (x, y): (Axis, Axis),
    (x_desc, y_desc): (&str, &[String]),
    y_label_area: i32,
    scale: f64,
) -> Result<Chart<'a, DB>, ReportError> {
    let px = render::px(scale);
    let (first, last) = (i == 0, i + 1 == n);
    let gap = px(PLOT_GAP);
    let mut chart = ChartBuilder::on(area)
        .margin_left(px(MARGIN_LEFT))
        .margin_right(px(MARGIN_RIGHT))
        .margin_top(if first { px(MARGIN_TOP) } else { gap })
        .margin_bottom(if last { px(MARGIN_BOTTOM) } else { gap })
        .x_label_area_size(if last { px(X_LABEL_AREA) } else { 0 })
        .y_label_area_size(y_label_area)
        .build_cartesian_2d(x, y)
        .map_err(plot_err)?;
    axes::draw_axes(&mut chart, last.then_some(x_desc), true, 0.0, scale)?;
    axes::draw_y_desc(&chart, y_desc, y_label_area, scale)?;
    Ok(chart)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plots_share_the_body_evenly() {
        // Three plots of 200 px: margins 4 + 8, two gaps of 2 x 10, x labels 58.
        let h = natural_height(3.0, 200.0);
        assert_eq!(h, 4.0 + 600.0 + 40.0 + 58.0 + 8.0);
        assert_eq!(plot_height(h as i32, 3, 1.0), 200);
        assert_eq!(plot_height(2 * h as i32, 3, 2.0), 200 * 2);
        assert_eq!(plot_width(1000, 82, 1.0), 1000 - 8 - 30 - 82);
        // The areas tile the body: each break lies a plot and two gaps below the previous.
        let mut svg = String::new();
        let root = SVGBackend::with_string(&mut svg, (1000, h as u32)).into_drawing_area();
        let a = areas(&root, 3, 200, 1.0);
        let tops: Vec<i32> = a.iter().map(|a| a.get_base_pixel().1).collect();
        assert_eq!(tops, vec![0, 4 + 200 + 10, 4 + 200 + 10 + 20 + 200]);
    }
}
