//! Heat maps of a cost landscape on a rectangular grid, e.g. the
//! identification grid search (mean squared position error over bulk modulus
//! × cross-port leakage), with a colour bar, rendered to SVG or PNG in memory.
//!
//! Each grid point is drawn as a cell whose edges lie midway between
//! neighbouring axis values (in log space on a logarithmic axis), so
//! non-uniform grids tile without gaps. Cells are coloured by log10(cost) with
//! the perceptual viridis colour map (dark purple = low cost, yellow = high);
//! the lowest cell is outlined in white unless a marker (usually the optimum)
//! lies in it, and non-finite costs (unstable or failed candidates) are drawn
//! in light grey. The look (fonts, sizes, margins)
//! follows [`super::timeseries`] and [`super::bode`].

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::axes::{self, fitted_linear_axis, log_axis, Axis, AXIS_DESC_SIZE, TICK_LABEL_SIZE};
use super::error::{plot_err, ReportError};
use super::render::{self, SUBTITLE_COLOR};
use super::{font, layout};

/// Default heat-map width in pixels (used for SVG output; a sensible PNG
/// size).
pub const HEATMAP_WIDTH_PX: u32 = 900;
/// Default heat-map height in pixels (used for SVG output; a sensible PNG
/// size).
pub const HEATMAP_HEIGHT_PX: u32 = 700;

/// Colour of cells whose cost is not finite.
const MISSING_COLOR: RGBColor = RGBColor(212, 212, 212);
/// Text of the note explaining [`MISSING_COLOR`].
const MISSING_NOTE: &str = "grey: unstable/failed";

// Layout at scale 1 (900 x 700 px), in pixels; the shared values are those of
// the time-series figures.
const MARGIN_LEFT: f64 = 8.0;
const MARGIN_TOP: f64 = 4.0;
const MARGIN_BOTTOM: f64 = 8.0;
const MARGIN_RIGHT: f64 = 12.0;
const X_LABEL_AREA: f64 = 58.0;
const NOTE_SIZE: f64 = 14.0;
const MARKER_LABEL_SIZE: f64 = 15.0;
/// Length of major tick marks; minor ticks (log axes) are shorter.
const TICK_SIZE: f64 = 5.0;
const MINOR_TICK_SIZE: f64 = 3.0;
/// Gap between the map and the colour bar, and the colour bar's width.
const BAR_GAP: f64 = 28.0;
const BAR_WIDTH: f64 = 22.0;
/// Smallest distance between two tick labels on a vertical axis.
const MIN_Y_LABEL_GAP: f64 = 28.0;
/// Smallest free space between two tick labels on the horizontal axis.
const MIN_X_LABEL_SPACE: f64 = 18.0;
/// Half length of the arms of a marker cross.
const MARKER_ARM: f64 = 9.0;
/// Smallest plotting-area side accepted, in pixels.
const MIN_PLOT_PX: i32 = 40;

/// Viridis (matplotlib, CC0), sampled at 33 evenly spaced points from the
/// low (dark purple) to the high (yellow) end; interpolated linearly.
const VIRIDIS: [[u8; 3]; 33] = [
    [68, 1, 84],
    [71, 13, 96],
    [72, 24, 106],
    [72, 35, 116],
    [71, 45, 123],
    [69, 55, 129],
    [66, 64, 134],
    [62, 73, 137],
    [59, 82, 139],
    [55, 91, 141],
    [51, 99, 141],
    [47, 107, 142],
    [44, 114, 142],
    [41, 122, 142],
    [38, 130, 142],
    [35, 137, 142],
    [33, 145, 140],
    [31, 151, 139],
    [31, 159, 136],
    [33, 166, 133],
    [39, 173, 129],
    [49, 181, 123],
    [61, 188, 116],
    [76, 194, 108],
    [92, 200, 99],
    [110, 206, 88],
    [129, 211, 77],
    [149, 216, 64],
    [170, 220, 50],
    [192, 223, 37],
    [213, 226, 26],
    [234, 229, 26],
    [253, 231, 37],
];

/// A cost map on a rectangular grid: `cost[iy * x.len() + ix]` is the cost at
/// `(x[ix], y[iy])`.
///
/// Axis values must be finite and strictly increasing, but need not be
/// uniformly spaced. Costs may be +inf or NaN (unstable or failed
/// candidates); those cells are drawn in light grey.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct HeatMap {
    /// Grid values along the horizontal axis (linear scale), e.g. bulk
    /// modulus in bar.
    pub x: Vec<f64>,
    /// Grid values along the vertical axis, e.g. cross-port leakage
    /// coefficient in m⁵/(N·s); all > 0 when [`HeatMap::y_log`] is set.
    pub y: Vec<f64>,
    /// Cost at each grid point, row by row (`x.len()` values per row of
    /// constant `y`); length `x.len() * y.len()`.
    pub cost: Vec<f64>,
    /// Horizontal axis description with its unit, e.g. `"β (bar)"`.
    pub x_label: String,
    /// Vertical axis description with its unit, e.g. `"c12 (m⁵/(N·s))"`.
    pub y_label: String,
    /// Logarithmic vertical axis (ticks at powers of ten; cell edges at the
    /// geometric means of neighbouring values).
    pub y_log: bool,
    /// Colour-bar description with the cost unit, e.g. `"cost (mm²)"`.
    pub cost_label: String,
}

/// A point marked on the map (e.g. the optimum): a white-edged cross with its
/// label next to it.
#[derive(Debug, Clone, PartialEq)]
pub struct Marker {
    /// Horizontal position, in the unit of [`HeatMap::x`].
    pub x: f64,
    /// Vertical position, in the unit of [`HeatMap::y`].
    pub y: f64,
    /// Text next to the cross; an empty label draws the cross only.
    pub label: String,
}

/// Render a cost heat map to an SVG document in memory,
/// [`HEATMAP_WIDTH_PX`] x [`HEATMAP_HEIGHT_PX`] pixels.
///
/// `title` is printed at the top, `subtitle` (smaller, grey) under it. Cells
/// are coloured by log10(cost) with the viridis colour map over the range of
/// the finite positive costs; the colour bar on the right is labelled in cost
/// units and described by [`HeatMap::cost_label`]. Costs ≤ 0 get the lowest
/// colour; a map of equal costs is drawn in the middle colour of a colour bar
/// spanning half a decade either side. The cell with the lowest finite cost is
/// outlined in white unless a marker lies in it. Non-finite costs are drawn in light grey and explained
/// by the note "grey: unstable/failed" under the colour bar. Markers outside
/// the map or with non-finite coordinates are not drawn.
///
/// # Errors
/// [`ReportError::Empty`] when `x` or `y` is empty or no cost is finite;
/// [`ReportError::Plot`] when `cost` does not hold `x.len() * y.len()`
/// values, axis values are not finite and strictly increasing (or not
/// positive on a log axis), are too large or too close to scale, or plotting
/// fails.
pub fn heatmap_svg(
    title: &str,
    subtitle: Option<&str>,
    map: &HeatMap,
    markers: &[Marker],
) -> Result<String, ReportError> {
    let figure = Figure::prepare(title, subtitle, map, markers)?;
    render::to_svg(&figure, (HEATMAP_WIDTH_PX, HEATMAP_HEIGHT_PX))
}

/// Same figure as [`heatmap_svg`], rendered to an encoded PNG file (the bytes
/// of the file, RGB, 8 bit), `width` x `height` pixels. Text and line widths
/// scale with the image size relative to 900 x 700.
///
/// # Errors
/// As [`heatmap_svg`]; additionally [`ReportError::Plot`] when the size is
/// below 320 x 240 or above 16384 pixels on a side, leaves no room for the
/// map, or PNG encoding fails.
pub fn heatmap_png(
    title: &str,
    subtitle: Option<&str>,
    map: &HeatMap,
    markers: &[Marker],
    width: u32,
    height: u32,
) -> Result<Vec<u8>, ReportError> {
    let figure = Figure::prepare(title, subtitle, map, markers)?;
    render::to_png(
        &figure,
        width,
        height,
        (HEATMAP_WIDTH_PX, HEATMAP_HEIGHT_PX),
    )
}

// ---------------------------------------------------------------------------
// Colours
// ---------------------------------------------------------------------------

/// Viridis colour at `t` in 0..=1 (clamped; NaN gives the low end).
fn viridis(t: f64) -> RGBColor {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let last = VIRIDIS.len() - 1;
    let pos = t * last as f64;
    let i = (pos.floor() as usize).min(last - 1);
    let f = pos - i as f64;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    let mix = |k: usize| (f64::from(a[k]) + f * (f64::from(b[k]) - f64::from(a[k]))).round() as u8;
    RGBColor(mix(0), mix(1), mix(2))
}

/// Logarithmic colour scale over the costs `lo..=hi` (both > 0, `lo < hi`).
#[derive(Debug, Clone, Copy, PartialEq)]
struct ColourScale {
    lo: f64,
    hi: f64,
}

impl ColourScale {
    /// Scale over the finite positive values of `cost`; a single value (or
    /// none) gets half a decade either side.
    fn for_costs(cost: &[f64]) -> Self {
        let (mut lo, mut hi) = cost
            .iter()
            .copied()
            .filter(|c| c.is_finite() && *c > 0.0)
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), c| {
                (lo.min(c), hi.max(c))
            });
        if hi == 0.0 {
            (lo, hi) = (1.0, 1.0);
        }
        if hi / lo < 1.0 + 1e-9 {
            let half_decade = 10f64.sqrt();
            lo /= half_decade;
            hi *= half_decade;
        }
        ColourScale { lo, hi }
    }

    /// Position of `cost` along the colour map (0 = low end), or `None` when
    /// the cost is not finite. Costs ≤ 0 map to the low end.
    fn position(&self, cost: f64) -> Option<f64> {
        if !cost.is_finite() {
            return None;
        }
        if cost <= 0.0 {
            return Some(0.0);
        }
        let (l0, l1) = (self.lo.log10(), self.hi.log10());
        Some(((cost.log10() - l0) / (l1 - l0)).clamp(0.0, 1.0))
    }

    fn colour(&self, cost: f64) -> RGBColor {
        self.position(cost).map_or(MISSING_COLOR, viridis)
    }
}

// ---------------------------------------------------------------------------
// Axes
// ---------------------------------------------------------------------------

/// Cell edges of the grid values `v` (strictly increasing): midway between
/// neighbours (in log10 space when `log`), the outer cells as wide as their
/// inner neighbours; a single value gets ±5 % (±0.5 at 0), or ±0.25 decade
/// on a log axis.
fn cell_edges(v: &[f64], log: bool) -> Vec<f64> {
    let t: Vec<f64> = if log {
        v.iter().map(|x| x.log10()).collect()
    } else {
        v.to_vec()
    };
    let n = t.len();
    let mut e = Vec::with_capacity(n + 1);
    if n == 1 {
        let half = if log {
            0.25
        } else if t[0] != 0.0 {
            0.05 * t[0].abs()
        } else {
            0.5
        };
        e.extend([t[0] - half, t[0] + half]);
    } else {
        e.push(t[0] - 0.5 * (t[1] - t[0]));
        e.extend(t.windows(2).map(|w| 0.5 * (w[0] + w[1])));
        e.push(t[n - 1] + 0.5 * (t[n - 1] - t[n - 2]));
    }
    if log {
        e.iter().map(|x| 10f64.powf(*x)).collect()
    } else {
        e
    }
}

/// Error unless `v` is non-empty, finite, strictly increasing (and positive
/// when `log`), with usable cell edges.
fn check_axis(v: &[f64], log: bool, name: &str) -> Result<Vec<f64>, ReportError> {
    if v.iter().any(|x| !x.is_finite()) || v.windows(2).any(|w| w[1] <= w[0]) {
        return Err(ReportError::Plot(format!(
            "{name} values must be finite and strictly increasing"
        )));
    }
    if log && v.first().is_some_and(|&x| x <= 0.0) {
        return Err(ReportError::Plot(format!(
            "{name} values must be positive on a logarithmic axis"
        )));
    }
    let e = cell_edges(v, log);
    let (lo, hi) = (e[0], e[e.len() - 1]);
    let span = if log {
        hi.log10() - lo.log10()
    } else {
        hi - lo
    };
    let usable = e.iter().all(|x| x.is_finite())
        && e.windows(2).all(|w| w[1] > w[0])
        && span.is_finite()
        && span > 0.0
        && (log && lo > 0.0 || !log && span >= 1e-200);
    if usable {
        Ok(e)
    } else {
        Err(ReportError::Plot(format!(
            "{name} values too large or too close to scale ({:e} .. {:e})",
            v[0],
            v[v.len() - 1]
        )))
    }
}

// ---------------------------------------------------------------------------
// Figure
// ---------------------------------------------------------------------------

/// Everything needed to draw, computed before touching a backend.
struct Figure<'a> {
    title: &'a str,
    subtitle: Option<&'a str>,
    map: &'a HeatMap,
    x_edges: Vec<f64>,
    y_edges: Vec<f64>,
    colours: ColourScale,
    /// Index into `map.cost` of the lowest finite cost, when that cell is to
    /// be outlined (no marker lies in it).
    best: Option<usize>,
    /// Whether some cost is not finite (the grey note is shown).
    has_missing: bool,
    /// Markers inside the map.
    markers: Vec<&'a Marker>,
}

impl<'a> Figure<'a> {
    fn prepare(
        title: &'a str,
        subtitle: Option<&'a str>,
        map: &'a HeatMap,
        markers: &'a [Marker],
    ) -> Result<Self, ReportError> {
        if map.x.is_empty() || map.y.is_empty() {
            return Err(ReportError::Empty(format!(
                "heat map with {} x values and {} y values",
                map.x.len(),
                map.y.len()
            )));
        }
        let cells = map.x.len().checked_mul(map.y.len());
        if cells != Some(map.cost.len()) {
            return Err(ReportError::Plot(format!(
                "heat map: {} costs for {} x values × {} y values",
                map.cost.len(),
                map.x.len(),
                map.y.len()
            )));
        }
        let x_edges = check_axis(&map.x, false, "x")?;
        let y_edges = check_axis(&map.y, map.y_log, "y")?;
        let best = map
            .cost
            .iter()
            .enumerate()
            .filter(|(_, c)| c.is_finite())
            .min_by(|a, b| a.1.total_cmp(b.1))
            .map(|(i, _)| i)
            .ok_or_else(|| ReportError::Empty("no finite cost in the heat map".into()))?;
        let (x_lo, x_hi) = (x_edges[0], x_edges[x_edges.len() - 1]);
        let (y_lo, y_hi) = (y_edges[0], y_edges[y_edges.len() - 1]);
        let markers: Vec<&Marker> = markers
            .iter()
            .filter(|m| m.x >= x_lo && m.x <= x_hi && m.y >= y_lo && m.y <= y_hi)
            .collect();
        let nx = map.x.len();
        let (bx, by) = (best % nx, best / nx);
        let marked = markers.iter().any(|m| {
            (x_edges[bx]..=x_edges[bx + 1]).contains(&m.x)
                && (y_edges[by]..=y_edges[by + 1]).contains(&m.y)
        });
        Ok(Figure {
            title,
            subtitle: subtitle.filter(|s| !s.trim().is_empty()),
            map,
            colours: ColourScale::for_costs(&map.cost),
            best: (!marked).then_some(best),
            has_missing: map.cost.iter().any(|c| !c.is_finite()),
            markers,
            x_edges,
            y_edges,
        })
    }

    /// Draw one marker (white-edged cross) at pixel `(cx, cy)` and its label
    /// in a white box, placed up-right of the cross unless that leaves the
    /// plotting area `(left, right, top, bottom)`.
    fn draw_marker<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        marker: &Marker,
        (cx, cy): (i32, i32),
        (left, right, top, bottom): (i32, i32, i32, i32),
        scale: f64,
    ) -> Result<(), ReportError> {
        let px = render::px(scale);
        let upx = render::upx(scale);
        let arm = px(MARKER_ARM).max(3);
        let edge = px(1.5).max(1);
        for (a, style) in [
            (arm + edge, WHITE.stroke_width(upx(5.0))),
            (arm, BLACK.stroke_width(upx(2.0))),
        ] {
            for path in [[(cx - a, cy), (cx + a, cy)], [(cx, cy - a), (cx, cy + a)]] {
                root.draw(&PathElement::new(path, style))
                    .map_err(plot_err)?;
            }
        }
        if marker.label.is_empty() {
            return Ok(());
        }
        let style = TextStyle::from((font::FAMILY, MARKER_LABEL_SIZE * scale).into_font())
            .color(&BLACK)
            .pos(Pos::new(HPos::Left, VPos::Top));
        let tw = layout::text_width(&marker.label, MARKER_LABEL_SIZE * scale).ceil() as i32;
        let th = px(MARKER_LABEL_SIZE);
        let pad = px(4.0);
        let (bw, bh) = (tw + 2 * pad, th + 2 * pad);
        let gap = arm + px(4.0);
        let mut x0 = cx + gap;
        if x0 + bw > right {
            x0 = cx - gap - bw;
        }
        let mut y0 = cy - gap - bh;
        if y0 < top {
            y0 = cy + gap;
        }
        let x0 = x0.min(right - bw).max(left);
        let y0 = y0.min(bottom - bh).max(top);
        let corners = [(x0, y0), (x0 + bw, y0 + bh)];
        render::draw_box(root, corners, render::label_background(), upx(1.0))?;
        root.draw(&Text::new(
            marker.label.clone(),
            (x0 + pad, y0 + pad),
            style,
        ))
        .map_err(plot_err)?;
        Ok(())
    }
}

/// Short black tick marks `width` px wide at the minor ticks of the vertical `axis` drawn
/// over the pixel rows `top..=bottom`, from column `x` to `x + len`.
fn minor_ticks<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    axis: &Axis,
    (top, bottom): (i32, i32),
    (x, len): (i32, i32),
    width: u32,
) -> Result<(), ReportError> {
    for &v in &axis.minor {
        let y = axis.map(&v, (bottom, top));
        root.draw(&PathElement::new(
            [(x, y), (x + len, y)],
            BLACK.stroke_width(width),
        ))
        .map_err(plot_err)?;
    }
    Ok(())
}

impl render::Draw for Figure<'_> {
    /// Draw the figure on `root`; `scale` multiplies font sizes, line widths
    /// and paddings (1.0 for 900 x 700 px).
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        scale: f64,
    ) -> Result<(), ReportError> {
        let px = render::px(scale);
        let upx = render::upx(scale);
        let text = render::text(scale);
        // Width (px) of `s` at text size `size` (scale 1).
        let text_width = |s: &str, size: f64| layout::text_width(s, size * scale).ceil() as i32;

        let (width, height) = root.dim_in_pixel();
        let (width, height) = (width as i32, height as i32);

        // Header: title and subtitle.
        let (body, header_h) = render::draw_header(root, self.title, self.subtitle, scale)?;

        // Vertical layout.
        let (m_top, m_bottom, x_label_area) = (px(MARGIN_TOP), px(MARGIN_BOTTOM), px(X_LABEL_AREA));
        let plot_h = height - header_h - m_top - x_label_area - m_bottom;
        if plot_h < MIN_PLOT_PX {
            return Err(ReportError::Plot(format!(
                "image height {height} px too small for the heat map"
            )));
        }
        let min_y_gap = MIN_Y_LABEL_GAP * scale;
        let (y_lo, y_hi) = (self.y_edges[0], self.y_edges[self.y_edges.len() - 1]);
        let y_axis = if self.map.y_log {
            log_axis(y_lo, y_hi, f64::from(plot_h), min_y_gap)
        } else {
            fitted_linear_axis(y_lo, y_hi, f64::from(plot_h), min_y_gap, &|_| 0.0)
        };
        let bar_axis = log_axis(
            self.colours.lo,
            self.colours.hi,
            f64::from(plot_h),
            min_y_gap,
        );

        // Horizontal layout: label areas fit the widest tick labels.
        let y_desc = axes::y_desc_lines(&self.map.y_label, plot_h, scale);
        let y_label_area = axes::y_label_area([&y_axis], y_desc.len(), scale);
        let widest_bar = bar_axis.widest_label(TICK_LABEL_SIZE * scale).ceil() as i32;
        let mut bar_label_area = 2 * px(TICK_SIZE) + widest_bar + px(8.0);
        if !self.map.cost_label.is_empty() {
            bar_label_area += px(6.0) + px(AXIS_DESC_SIZE * 1.2);
        }
        let (m_left, m_right, bar_gap, bar_w) = (
            px(MARGIN_LEFT),
            px(MARGIN_RIGHT),
            px(BAR_GAP),
            px(BAR_WIDTH).max(4),
        );
        let plot_w = width - m_left - y_label_area - bar_gap - bar_w - bar_label_area - m_right;
        if plot_w < MIN_PLOT_PX {
            return Err(ReportError::Plot(format!(
                "image width {width} px too small for the heat map"
            )));
        }
        let (x_lo, x_hi) = (self.x_edges[0], self.x_edges[self.x_edges.len() - 1]);
        let measure = |s: &str| f64::from(text_width(s, TICK_LABEL_SIZE));
        let x_axis = fitted_linear_axis(
            x_lo,
            x_hi,
            f64::from(plot_w),
            MIN_X_LABEL_SPACE * scale,
            &measure,
        );

        let (map_area, bar_area) =
            body.split_horizontally(m_left + y_label_area + plot_w + bar_gap);

        // --- Map -----------------------------------------------------------
        let mut chart = ChartBuilder::on(&map_area)
            .margin_left(m_left)
            .margin_right(bar_gap)
            .margin_top(m_top)
            .margin_bottom(m_bottom)
            .x_label_area_size(x_label_area)
            .y_label_area_size(y_label_area)
            .build_cartesian_2d(x_axis.clone(), y_axis.clone())
            .map_err(plot_err)?;
        let x_desc = Some(self.map.x_label.as_str());
        axes::draw_axes(&mut chart, x_desc, false, TICK_SIZE, scale)?;
        axes::draw_y_desc(&chart, &y_desc, y_label_area, scale)?;

        let nx = self.map.x.len();
        let cells = self.map.cost.iter().enumerate().map(|(i, &c)| {
            let (ix, iy) = (i % nx, i / nx);
            Rectangle::new(
                [
                    (self.x_edges[ix], self.y_edges[iy]),
                    (self.x_edges[ix + 1], self.y_edges[iy + 1]),
                ],
                self.colours.colour(c).filled(),
            )
        });
        chart.draw_series(cells).map_err(plot_err)?;

        // Outline of the lowest cell.
        if let Some(best) = self.best {
            let (bx, by) = (best % nx, best / nx);
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [
                        (self.x_edges[bx], self.y_edges[by]),
                        (self.x_edges[bx + 1], self.y_edges[by + 1]),
                    ],
                    WHITE.stroke_width(upx(1.5)),
                )))
                .map_err(plot_err)?;
        }

        // Frame and minor ticks of a log y axis.
        let bounds = axes::plot_bounds(chart.plotting_area());
        let (left, right, top, bottom) = bounds;
        axes::frame(root, bounds, upx(1.0))?;
        if y_axis.log {
            minor_ticks(
                root,
                &y_axis,
                (top, bottom),
                (left, -px(MINOR_TICK_SIZE)),
                upx(1.0),
            )?;
        }

        for m in &self.markers {
            let at = chart.backend_coord(&(m.x, m.y));
            self.draw_marker(root, m, at, (left, right, top, bottom), scale)?;
        }

        // --- Colour bar ------------------------------------------------------
        let mut bar = ChartBuilder::on(&bar_area)
            .margin_left(0)
            .margin_right(m_right)
            .margin_top(m_top)
            .margin_bottom(m_bottom + x_label_area)
            .x_label_area_size(0)
            .y_label_area_size(0)
            .right_y_label_area_size(bar_label_area)
            .build_cartesian_2d(0.0..1.0, bar_axis.clone())
            .map_err(plot_err)?;
        {
            let mut mesh = bar.configure_mesh();
            mesh.disable_mesh()
                .disable_x_axis()
                .axis_desc_style(text(AXIS_DESC_SIZE))
                .label_style(text(TICK_LABEL_SIZE))
                .set_all_tick_mark_size(px(TICK_SIZE));
            if !self.map.cost_label.is_empty() {
                mesh.y_desc(self.map.cost_label.clone());
            }
            mesh.draw().map_err(plot_err)?;
        }
        let bar_bounds = axes::plot_bounds(bar.plotting_area());
        let (b_left, b_right, b_top, b_bottom) = bar_bounds;
        // One rectangle per run of pixel rows of equal colour.
        let rows = (b_bottom - b_top + 1).max(1);
        let row_colour = |r: i32| viridis(1.0 - (f64::from(r) + 0.5) / f64::from(rows));
        let mut start = 0;
        while start < rows {
            let colour = row_colour(start);
            let mut end = start + 1;
            while end < rows && row_colour(end) == colour {
                end += 1;
            }
            root.draw(&Rectangle::new(
                [(b_left, b_top + start), (b_right + 1, b_top + end)],
                colour.filled(),
            ))
            .map_err(plot_err)?;
            start = end;
        }
        let at = (b_right, px(MINOR_TICK_SIZE));
        minor_ticks(root, &bar_axis, (b_top, b_bottom), at, upx(1.0))?;
        axes::frame(root, bar_bounds, upx(1.0))?;

        // Note on grey cells, bottom right, level with the x description.
        if self.has_missing {
            let style = text(NOTE_SIZE).color(&SUBTITLE_COLOR);
            let note_w = text_width(MISSING_NOTE, NOTE_SIZE);
            let sw = px(NOTE_SIZE * 0.9).max(4);
            let y_mid = bottom + x_label_area - px(AXIS_DESC_SIZE * 0.6);
            let text_right = width - m_right;
            let sw_right = text_right - note_w - px(6.0);
            let corners = [(sw_right - sw, y_mid - sw / 2), (sw_right, y_mid + sw / 2)];
            render::draw_box(root, corners, MISSING_COLOR.filled(), upx(1.0))?;
            root.draw(&Text::new(
                MISSING_NOTE,
                (text_right, y_mid),
                style.pos(Pos::new(HPos::Right, VPos::Center)),
            ))
            .map_err(plot_err)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A landscape like the identification grid search: β (bar) on a
    /// non-uniform grid, c12 log-spaced, a valley at (165 bar, 1.2e-10) and
    /// unstable candidates at low β and high leakage.
    fn landscape() -> HeatMap {
        let mut x: Vec<f64> = (1..=10).map(|i| 25.0 * f64::from(i)).collect();
        x.extend([300.0, 400.0, 500.0, 600.0, 800.0, 1000.0]);
        let y: Vec<f64> = (0..17)
            .map(|i| 10f64.powf(-13.0 + 4.0 * f64::from(i) / 16.0))
            .collect();
        let mut cost = Vec::new();
        for &c12 in &y {
            for &beta in &x {
                let unstable = beta <= 50.0 && c12 >= 1e-10;
                cost.push(if unstable {
                    f64::INFINITY
                } else {
                    0.03 + 5.0 * (beta / 165.0f64).ln().powi(2)
                        + 2.0 * (c12 / 1.2e-10f64).log10().powi(2)
                });
            }
        }
        HeatMap {
            x,
            y,
            cost,
            x_label: "Bulk modulus β (bar)".into(),
            y_label: "Leakage c12 (m⁵/(N·s))".into(),
            y_log: true,
            cost_label: "cost (mm²)".into(),
        }
    }

    /// Contents of the `<text>` elements of an SVG document, trimmed.
    fn texts(svg: &str) -> Vec<String> {
        svg.split("<text")
            .skip(1)
            .filter_map(|t| {
                let start = t.find('>')? + 1;
                let end = t.find("</text>")?;
                Some(t[start..end].trim().to_string())
            })
            .collect()
    }

    fn optimum() -> Vec<Marker> {
        vec![Marker {
            x: 165.0,
            y: 1.2e-10,
            label: "optimum".into(),
        }]
    }

    #[test]
    fn svg_contains_labels() {
        let svg = heatmap_svg(
            "Identification cost",
            Some("best friction"),
            &landscape(),
            &optimum(),
        )
        .unwrap();
        assert!(svg.starts_with("<svg"), "{}", &svg[..50]);
        // Every text (ticks, axis descriptions, legend, notes) lies inside the figure.
        assert_eq!(crate::plot::text_overflow(&svg), Vec::<String>::new());
        assert!(svg.trim_end().ends_with("</svg>"));
        for s in [
            "Identification cost",
            "best friction",
            "Bulk modulus β (bar)",
            "Leakage c12 (m⁵/(N·s))",
            "cost (mm²)",
            "optimum",
            "grey: unstable/failed",
        ] {
            assert!(svg.contains(s), "missing {s}");
        }
        // Tick labels: powers of ten on the leakage axis, cost units on the
        // colour bar, β on the x axis.
        let t = texts(&svg);
        for s in [
            "10⁻¹³",
            "10⁻¹²",
            "10⁻¹⁰",
            "10⁻⁹",
            "0.1",
            "1",
            "10",
            "200",
            "1000",
        ] {
            assert!(t.iter().any(|l| l == s), "missing tick label {s} in {t:?}");
        }
        assert!(svg.contains(&format!("width=\"{HEATMAP_WIDTH_PX}\"")));
        assert!(svg.contains(&format!("height=\"{HEATMAP_HEIGHT_PX}\"")));
        // Every cell is a rectangle in the SVG.
        assert!(svg.matches("<rect").count() >= 16 * 17);
    }

    #[test]
    fn no_grey_note_without_missing_cells() {
        let mut map = landscape();
        for c in &mut map.cost {
            if !c.is_finite() {
                *c = 50.0;
            }
        }
        let svg = heatmap_svg("t", None, &map, &[]).unwrap();
        assert!(!svg.contains(MISSING_NOTE));
    }

    #[test]
    fn png_signature_and_size() {
        let png = heatmap_png("PNG", None, &landscape(), &optimum(), 800, 600).unwrap();
        let rgb = render::decode_png(&png, 800, 600);
        // The darkest viridis colour (the valley) and grey cells are present.
        let near = |p: &image::Rgb<u8>, c: RGBColor| {
            (i32::from(p.0[0]) - i32::from(c.0)).abs() <= 8
                && (i32::from(p.0[1]) - i32::from(c.1)).abs() <= 8
                && (i32::from(p.0[2]) - i32::from(c.2)).abs() <= 8
        };
        assert!(rgb.pixels().filter(|p| near(p, viridis(0.0))).count() > 100);
        assert!(rgb.pixels().filter(|p| near(p, MISSING_COLOR)).count() > 100);
        assert!(rgb.pixels().filter(|p| near(p, viridis(1.0))).count() > 100);
    }

    #[test]
    fn png_bad_size_is_an_error() {
        let map = landscape();
        for (w, h) in [(0, 600), (100_000, 600), (800, 100)] {
            assert!(matches!(
                heatmap_png("x", None, &map, &[], w, h),
                Err(ReportError::Plot(_))
            ));
        }
        heatmap_png("small", Some("smallest size"), &map, &optimum(), 320, 240).unwrap();
        heatmap_png("large", None, &map, &optimum(), 2400, 1800).unwrap();
    }

    #[test]
    fn non_finite_and_degenerate_maps_do_not_panic() {
        let mut map = landscape();
        map.cost[0] = f64::NAN;
        map.cost[5] = f64::NEG_INFINITY;
        map.cost[7] = 0.0;
        map.cost[8] = -3.0;
        let odd_markers = vec![
            Marker {
                x: f64::NAN,
                y: 1e-11,
                label: "nan".into(),
            },
            Marker {
                x: 5000.0,
                y: 1e-11,
                label: "outside".into(),
            },
            Marker {
                x: 1000.0,
                y: 1e-9,
                label: "corner".into(),
            },
            Marker {
                x: 25.0,
                y: 1e-13,
                label: String::new(),
            },
        ];
        let svg = heatmap_svg("holes", None, &map, &odd_markers).unwrap();
        assert!(svg.contains("corner"));
        assert!(!svg.contains("outside"));
        heatmap_png("holes", None, &map, &odd_markers, 640, 480).unwrap();

        // One cell, linear and log.
        let one = HeatMap {
            x: vec![165.0],
            y: vec![1.2e-10],
            cost: vec![0.5],
            ..Default::default()
        };
        heatmap_svg("one", None, &one, &optimum()).unwrap();
        heatmap_png("one", None, &one, &optimum(), 400, 300).unwrap();
        let one_log = HeatMap {
            y_log: true,
            ..one.clone()
        };
        heatmap_svg("one", None, &one_log, &optimum()).unwrap();
        let zero = HeatMap {
            x: vec![0.0],
            y: vec![0.0],
            cost: vec![0.0],
            ..Default::default()
        };
        heatmap_svg("zero", None, &zero, &[]).unwrap();

        // One row, all costs equal, some missing.
        let row = HeatMap {
            x: vec![100.0, 200.0, 400.0],
            y: vec![1e-10],
            cost: vec![2.0, 2.0, f64::INFINITY],
            y_log: true,
            ..Default::default()
        };
        let svg = heatmap_svg("row", Some(""), &row, &[]).unwrap();
        assert!(svg.contains(MISSING_NOTE));
        heatmap_png("row", None, &row, &[], 640, 480).unwrap();

        // One column, linear y with tiny values, huge cost range.
        let column = HeatMap {
            x: vec![165.0],
            y: (0..9).map(|i| 0.8e-10 + 0.2e-10 * f64::from(i)).collect(),
            cost: (0..9).map(|i| 10f64.powi(3 * i - 12)).collect(),
            ..Default::default()
        };
        let svg = heatmap_svg("column", None, &column, &[]).unwrap();
        assert!(svg.contains("×10⁻¹⁰"), "linear tiny labels");
        heatmap_png("column", None, &column, &[], 900, 700).unwrap();
    }

    #[test]
    fn bad_input_is_an_error() {
        let good = landscape();
        assert!(matches!(
            heatmap_svg("x", None, &HeatMap::default(), &[]),
            Err(ReportError::Empty(_))
        ));
        let mismatch = HeatMap {
            cost: good.cost[1..].to_vec(),
            ..good.clone()
        };
        let err = heatmap_svg("x", None, &mismatch, &[]).unwrap_err();
        assert!(matches!(err, ReportError::Plot(_)), "{err}");
        assert!(matches!(
            heatmap_png("x", None, &mismatch, &[], 640, 480),
            Err(ReportError::Plot(_))
        ));
        let no_x = HeatMap {
            x: vec![],
            cost: vec![],
            ..good.clone()
        };
        assert!(matches!(
            heatmap_svg("x", None, &no_x, &[]),
            Err(ReportError::Empty(_))
        ));
        let all_nan = HeatMap {
            cost: vec![f64::NAN; good.cost.len()],
            ..good.clone()
        };
        assert!(matches!(
            heatmap_svg("x", None, &all_nan, &[]),
            Err(ReportError::Empty(_))
        ));
        let mut unsorted = good.clone();
        unsorted.x.swap(0, 1);
        assert!(matches!(
            heatmap_svg("x", None, &unsorted, &[]),
            Err(ReportError::Plot(_))
        ));
        let mut repeated = good.clone();
        repeated.x[1] = repeated.x[0];
        assert!(matches!(
            heatmap_svg("x", None, &repeated, &[]),
            Err(ReportError::Plot(_))
        ));
        let mut nan_axis = good.clone();
        nan_axis.y[3] = f64::NAN;
        assert!(matches!(
            heatmap_svg("x", None, &nan_axis, &[]),
            Err(ReportError::Plot(_))
        ));
        let non_positive_log = HeatMap {
            x: vec![1.0, 2.0],
            y: vec![0.0, 1.0],
            cost: vec![1.0; 4],
            y_log: true,
            ..Default::default()
        };
        assert!(matches!(
            heatmap_svg("x", None, &non_positive_log, &[]),
            Err(ReportError::Plot(_))
        ));
        let huge = HeatMap {
            x: vec![-1.7e308, 1.7e308],
            y: vec![1.0],
            cost: vec![1.0, 2.0],
            ..Default::default()
        };
        assert!(matches!(
            heatmap_svg("x", None, &huge, &[]),
            Err(ReportError::Plot(_))
        ));
    }

    #[test]
    fn cell_edges_tile_non_uniform_grids() {
        let e = cell_edges(&[25.0, 50.0, 100.0], false);
        assert_eq!(e, vec![12.5, 37.5, 75.0, 125.0]);
        let e = cell_edges(&[1e-12, 1e-11, 1e-9], true);
        let expect = [10f64.powf(-12.5), 10f64.powf(-11.5), 1e-10, 1e-8];
        for (a, b) in e.iter().zip(expect) {
            assert!((a / b - 1.0).abs() < 1e-9, "{e:?}");
        }
        assert_eq!(cell_edges(&[200.0], false), vec![190.0, 210.0]);
        assert_eq!(cell_edges(&[0.0], false), vec![-0.5, 0.5]);
    }

    #[test]
    fn colour_scale() {
        assert_eq!(viridis(0.0), RGBColor(68, 1, 84));
        assert_eq!(viridis(1.0), RGBColor(253, 231, 37));
        assert_eq!(viridis(f64::NAN), viridis(0.0));
        assert_eq!(viridis(0.5), RGBColor(33, 145, 140));
        let s = ColourScale::for_costs(&[0.01, f64::INFINITY, 1.0, 100.0, -1.0, f64::NAN]);
        assert_eq!((s.lo, s.hi), (0.01, 100.0));
        assert_eq!(s.position(1.0), Some(0.5));
        assert_eq!(s.position(0.0), Some(0.0));
        assert_eq!(s.position(f64::NAN), None);
        assert_eq!(s.colour(f64::INFINITY), MISSING_COLOR);
        let flat = ColourScale::for_costs(&[2.0, 2.0]);
        assert!((flat.position(2.0).unwrap() - 0.5).abs() < 1e-9);
        let none = ColourScale::for_costs(&[0.0, f64::NAN]);
        assert!(none.lo > 0.0 && none.hi > none.lo);
    }
}
