//! Stacked time-series panels: one or more panels, each with its own value
//! axis and unit, sharing one time axis in seconds, rendered to SVG or PNG in
//! memory. Used for step responses (position, error, pressures, motor
//! speeds), measured-vs-simulated overlays and model-variant comparisons.
//!
//! The look (fonts, sizes, grid, palette, margins) follows the Bode diagrams
//! of [`super::bode`], so all pumpcyl figures form one family.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::axes::{self, categorical_axis, linear_axis, nice_axis, Axis};
use super::bode::DEFAULT_WIDTH_PX;
use super::error::{plot_err, ReportError};
use super::layout;
use super::legend::{self, LegendEntry, LegendLayout, LegendMetrics, Sample};
use super::overlap::{self, Curve, PanelCurves};
use super::render::{self, header_height};
use super::series::{
    draw_pieces, even_dash, finite_extent, series_color, Dash, Pieces, Polyline, Stroke, PALETTE,
};
use super::stack;

/// Height of the plotting area of one panel in the default (SVG) layout, in
/// pixels; with the gap to the next panel a panel takes 220 px.
pub const PANEL_PLOT_HEIGHT_PX: u32 = 200;

/// Smallest plotting-area height of a panel accepted in a PNG, in pixels.
const MIN_PLOT_HEIGHT_PX: i32 = 40;

/// Line style of a trace. Within one figure each style other than solid should have one
/// meaning, which the legend states (a labelled trace in it, or a note such as
/// "dotted: p2, ω2").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LineStyle {
    /// Continuous line.
    #[default]
    Solid,
    /// Dashes (10 px dash, 6 px gap at the default size).
    Dashed,
    /// Dots (2 px every 5 px at the default size).
    Dotted,
    /// Dash and dot (12 px dash, 4 px gap, 2 px dot, 4 px gap at the default size).
    DashDot,
    /// No line: each point a filled circle (6 px radius at the default size), e.g. to mark a
    /// chosen value on a curve; the legend shows the circle.
    Markers,
    /// No line: each point (x, y) a filled bar [`BAR_WIDTH`] wide centred on x, from 0 to y
    /// (over a category axis, a category's bar); the legend shows a filled square, and the
    /// panel's value axis holds 0. Bars are opaque and drawn in the order of the traces, so a
    /// stacked bar is its running totals drawn tallest first.
    Bars,
}

/// The width of a [`LineStyle::Bars`] bar, in the x axis' unit (on a category axis, of the
/// distance between two categories).
pub const BAR_WIDTH: f64 = 0.6;

/// One curve of a panel: time in seconds and values in the panel's unit.
///
/// `t_s` and `y` are indexed together and must have the same length. Points
/// whose time or value is not finite (NaN, ±inf) are skipped and break the
/// line; a finite point without finite neighbours is drawn as a dot. Time
/// need not be uniformly sampled.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Trace {
    /// Label shown in the legend of the first panel that has the trace's row
    /// (label and style); an empty label keeps the trace out of the legend. A
    /// labelled trace without points is a note in the legend (its label
    /// without a line sample).
    pub label: String,
    /// Sample times, in seconds.
    pub t_s: Vec<f64>,
    /// Values at the sample times, in the unit named by the panel's
    /// [`Panel::y_label`] (e.g. mm, bar, rpm).
    pub y: Vec<f64>,
    /// Line style.
    pub style: LineStyle,
    /// Colour as an index into the colour-blind-safe palette (8 colours,
    /// taken modulo 8: 0 blue, 1 vermillion, 2 bluish green, 3 reddish
    /// purple, 4 ochre, 5 dark purple, 6 black, 7 dark grey). Colours keep
    /// their meaning across the panels of a figure: a label has one colour in
    /// every panel (the first one given for it), and a colour already naming
    /// another label is replaced by the first colour naming none. `None` takes
    /// the first such free colour (for an unlabelled trace: the first colour
    /// not used in the panel).
    ///
    /// A trace of two points at one time with values -inf and +inf is drawn
    /// as a vertical line over the full height of its panel (a time marker).
    pub color: Option<usize>,
}

/// One panel of the figure: a value axis and the traces drawn on it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Panel {
    /// Value-axis description with its unit, e.g. `"Position (mm)"`.
    pub y_label: String,
    /// Curves of the panel, drawn in order (later ones on top). A curve that later ones of
    /// other colours or line styles would hide is drawn wider, in every panel and in the
    /// legend, so that it shows around them (docs/formats.md#figures).
    pub traces: Vec<Trace>,
    /// Names of the categories when the values are categories (a mode, a kind): the k-th name
    /// (k from 1) at the value k, the axis ticked with the names and nothing else; empty for a
    /// numeric axis.
    pub categories: Vec<String>,
}

/// Default figure size in pixels, `(width, height)`, for `panel_count` panels
/// with or without a subtitle: [`DEFAULT_WIDTH_PX`] wide and about 220 px of
/// height per panel plus the title, subtitle and time axis (4 panels with a
/// subtitle: 1000 x 1001). [`panels_svg`] uses this size; it is also a
/// sensible size for [`panels_png`].
pub fn panels_default_size(panel_count: usize, with_subtitle: bool) -> (u32, u32) {
    let n = panel_count.clamp(1, 1000) as f64;
    let h = header_height(1.0, 1, usize::from(with_subtitle)) as f64
        + stack::natural_height(n, f64::from(PANEL_PLOT_HEIGHT_PX));
    (DEFAULT_WIDTH_PX, h.round() as u32)
}

/// Render `panels` stacked vertically (first panel on top), sharing one time
/// axis in seconds (labelled "Time (s)" under the bottom panel only), to an
/// SVG document in memory of [`panels_default_size`] pixels.
///
/// `title` is printed at the top, `subtitle` (smaller, grey) under it, e.g.
/// metrics like "rise 0.62 s, overshoot 4.1 %" or a notice like "emulated
/// data". The time axis spans the union of the finite times of all traces;
/// each panel's value axis spans its finite values with 5 % padding (a
/// constant signal gets ±5 % of its value, or ±1 around 0; a panel with
/// [`Panel::categories`] spans its categories). A panel with labelled traces
/// gets a legend of them (semi-transparent box), leaving out the rows a panel
/// above already shows, so that each series is named once: in the
/// top-right corner if it hides no curve there, else in the first free corner
/// (top left, bottom right, bottom left), using up to 4 columns if one column
/// fits nowhere; if every placement hides a curve, the top of the value axis
/// is raised (legend at most 40 % of the panel height) to make room above
/// the data, and failing that the legend covers the fewest curve segments.
/// Each panel's value-axis description is wrapped onto a second line, then
/// shortened in the middle, to stay within the panel's height.
///
/// # Errors
/// [`ReportError::Empty`] when `panels` is empty or no trace has a point with
/// finite time and value; [`ReportError::Plot`] when a trace's `t_s` and `y`
/// differ in length (the message names the panel and trace), values are too
/// large to scale (beyond about ±1e307) or plotting fails.
pub fn panels_svg(
    title: &str,
    subtitle: Option<&str>,
    panels: &[Panel],
) -> Result<String, ReportError> {
    panels_xy_svg(title, subtitle, "Time (s)", panels)
}

/// As [`panels_svg`] with another shared x axis than time: `x_label` names it with its unit
/// (e.g. "Mean pressure (bar)") and the traces' `t_s` hold the x values.
pub fn panels_xy_svg(
    title: &str,
    subtitle: Option<&str>,
    x_label: &str,
    panels: &[Panel],
) -> Result<String, ReportError> {
    panels_categorical_svg(title, subtitle, (x_label, &[]), panels)
}

/// As [`panels_xy_svg`] over a shared x axis of categories `x.1`, named `x.0`: the traces'
/// `t_s` hold the category numbers, the k-th name (k from 1) at x = k, and the axis is ticked
/// with the names (each shortened in the middle to its share of the width) and nothing else
/// (docs/formats.md#figures). Without categories the axis is numeric, as [`panels_xy_svg`]'s.
pub fn panels_categorical_svg(
    title: &str,
    subtitle: Option<&str>,
    x: (&str, &[String]),
    panels: &[Panel],
) -> Result<String, ReportError> {
    let figure = Figure::prepare(title, subtitle, panels)?.over(x);
    let size = panels_default_size(panels.len(), figure.subtitle.is_some());
    render::to_svg(&figure, size)
}

/// Same figure as [`panels_svg`], rendered to an encoded PNG file (the bytes
/// of the file, RGB, 8 bit), `width` x `height` pixels. Text and line widths
/// scale with the image size relative to [`panels_default_size`]; the panels
/// share the height left by the title and the time axis equally.
///
/// # Errors
/// As [`panels_svg`]; additionally [`ReportError::Plot`] when the size is
/// below 320 x 240 or above 16384 pixels on a side, too low for the number of
/// panels, or PNG encoding fails.
pub fn panels_png(
    title: &str,
    subtitle: Option<&str>,
    panels: &[Panel],
    width: u32,
    height: u32,
) -> Result<Vec<u8>, ReportError> {
    panels_xy_png(title, subtitle, "Time (s)", panels, width, height)
}

/// As [`panels_png`] with another shared x axis (see [`panels_xy_svg`]).
pub fn panels_xy_png(
    title: &str,
    subtitle: Option<&str>,
    x_label: &str,
    panels: &[Panel],
    width: u32,
    height: u32,
) -> Result<Vec<u8>, ReportError> {
    panels_categorical_png(title, subtitle, (x_label, &[]), panels, width, height)
}

/// As [`panels_png`] over a shared x axis of categories (see [`panels_categorical_svg`]).
pub fn panels_categorical_png(
    title: &str,
    subtitle: Option<&str>,
    x: (&str, &[String]),
    panels: &[Panel],
    width: u32,
    height: u32,
) -> Result<Vec<u8>, ReportError> {
    let figure = Figure::prepare(title, subtitle, panels)?.over(x);
    let base = panels_default_size(panels.len(), figure.subtitle.is_some());
    render::to_png(&figure, width, height, base)
}

// ---------------------------------------------------------------------------
// Data preparation
// ---------------------------------------------------------------------------

/// The trace `(t, y)` split into runs of consecutive points with finite time and value.
fn split_pieces(t: &[f64], y: &[f64]) -> Pieces {
    let finite = |(&t, &y): (&f64, &f64)| (t.is_finite() && y.is_finite()).then_some((t, y));
    Pieces::split(t.iter().zip(y).map(finite))
}

/// Range with a non-zero span around the extent `lo..=hi`: unchanged when it
/// has a usable span, else ±5 % of the value (±1 around 0).
fn widen_degenerate(lo: f64, hi: f64) -> (f64, f64) {
    let mag = lo.abs().max(hi.abs());
    let span = hi - lo;
    if span > mag * 1e-9 && span >= 1e-100 {
        return (lo, hi);
    }
    let centre = 0.5 * (lo + hi);
    let half = if 0.05 * mag >= 1e-100 {
        0.05 * mag
    } else {
        1.0
    };
    (centre - half, centre + half)
}

/// Palette index of every trace of every panel (see [`Trace::color`]): one colour per
/// label across the whole figure, and no colour for two labels while a colour is free.
fn assign_colors(panels: &[Panel]) -> Vec<Vec<usize>> {
    let n = PALETTE.len();
    let mut of_label: Vec<(&str, usize)> = Vec::new();
    let mut owner: Vec<Option<&str>> = vec![None; n];
    let labelled = || {
        panels
            .iter()
            .flat_map(|p| &p.traces)
            .filter(|t| !t.label.is_empty() && !t.t_s.is_empty())
    };
    let find = |of: &[(&str, usize)], l: &str| of.iter().find(|e| e.0 == l).map(|e| e.1);
    for t in labelled() {
        if let Some(c) = t.color.map(|c| c % n) {
            if find(&of_label, &t.label).is_none() && owner[c].is_none() {
                owner[c] = Some(&t.label);
                of_label.push((&t.label, c));
            }
        }
    }
    let mut cycle = 0;
    for t in labelled() {
        if find(&of_label, &t.label).is_none() {
            let c = match owner.iter().position(Option::is_none) {
                Some(c) => c,
                None => {
                    // All colours name a label: cycle through the palette.
                    cycle += 1;
                    (cycle - 1) % n
                }
            };
            owner[c] = Some(&t.label);
            of_label.push((&t.label, c));
        }
    }
    panels
        .iter()
        .map(|p| {
            let mut colors: Vec<Option<usize>> = p
                .traces
                .iter()
                .map(|t| {
                    if t.label.is_empty() {
                        t.color.map(|c| c % n)
                    } else {
                        find(&of_label, &t.label)
                    }
                })
                .collect();
            let mut used = vec![false; n];
            for c in colors.iter().flatten() {
                used[*c] = true;
            }
            let mut cycle = 0;
            for c in colors.iter_mut().filter(|c| c.is_none()) {
                let free = used.iter().position(|&u| !u).unwrap_or_else(|| {
                    cycle += 1;
                    (cycle - 1) % n
                });
                used[free] = true;
                *c = Some(free);
            }
            colors.into_iter().map(|c| c.unwrap_or(0)).collect()
        })
        .collect()
}

/// The time of a trace drawn as a vertical line over its panel (see [`Trace`]).
fn rule_time(trace: &Trace) -> Option<f64> {
    match (&trace.t_s[..], &trace.y[..]) {
        ([a, b], [lo, hi])
            if a == b && a.is_finite() && *lo == f64::NEG_INFINITY && *hi == f64::INFINITY =>
        {
            Some(*a)
        }
        _ => None,
    }
}

/// Everything about one panel that does not depend on the image size.
struct PanelData<'a> {
    panel: &'a Panel,
    /// Value range before tick snapping (padded extent), in panel units.
    y_range: (f64, f64),
    pieces: Vec<Pieces>,
    colors: Vec<usize>,
}

/// Everything needed to draw, computed before touching a backend.
struct Figure<'a> {
    title: &'a str,
    subtitle: Option<&'a str>,
    /// Label of the shared x axis, with unit.
    x_label: String,
    /// Names of the x axis's categories (see [`panels_categorical_svg`]); empty: numeric.
    x_categories: Vec<String>,
    /// Shared time range, in s.
    t_range: (f64, f64),
    panels: Vec<PanelData<'a>>,
}

impl<'a> Figure<'a> {
    fn prepare(
        title: &'a str,
        subtitle: Option<&'a str>,
        panels: &'a [Panel],
    ) -> Result<Self, ReportError> {
        if panels.is_empty() {
            return Err(ReportError::Empty("no panels given".into()));
        }
        for p in panels {
            for tr in &p.traces {
                if tr.t_s.len() != tr.y.len() {
                    return Err(ReportError::Plot(format!(
                        "panel '{}', trace '{}': {} times and {} values",
                        p.y_label,
                        tr.label,
                        tr.t_s.len(),
                        tr.y.len()
                    )));
                }
            }
        }
        let all_traces = || panels.iter().flat_map(|p| &p.traces);
        let any_finite = all_traces().any(|tr| {
            tr.t_s
                .iter()
                .zip(&tr.y)
                .any(|(t, y)| t.is_finite() && y.is_finite())
        });
        if !any_finite {
            return Err(ReportError::Empty(
                "no point with a finite time and a finite value".into(),
            ));
        }
        let (t_lo, t_hi) = finite_extent(all_traces().flat_map(|tr| tr.t_s.iter().copied()))
            .expect("a finite point exists");
        let t_range = widen_degenerate(t_lo, t_hi);
        check_span(t_range, "time axis")?;

        let colors = assign_colors(panels);
        let panels = panels
            .iter()
            .zip(colors)
            .map(|(panel, colors)| {
                let bars = panel.traces.iter().any(|tr| tr.style == LineStyle::Bars);
                let y_ext = finite_extent(panel.traces.iter().flat_map(|tr| {
                    tr.t_s
                        .iter()
                        .zip(&tr.y)
                        .filter(|(t, _)| t.is_finite())
                        .map(|(_, &y)| y)
                        .chain(bars.then_some(0.0))
                }));
                let (lo, hi) =
                    widen_degenerate(y_ext.map_or(0.0, |e| e.0), y_ext.map_or(0.0, |e| e.1));
                let pad = 0.05 * (hi - lo);
                let y_range = if panel.categories.is_empty() {
                    (lo - pad, hi + pad)
                } else {
                    (0.5, panel.categories.len() as f64 + 0.5)
                };
                check_span(y_range, &format!("panel '{}'", panel.y_label))?;
                Ok(PanelData {
                    panel,
                    y_range,
                    pieces: panel
                        .traces
                        .iter()
                        .map(|tr| split_pieces(&tr.t_s, &tr.y))
                        .collect(),
                    colors,
                })
            })
            .collect::<Result<Vec<_>, ReportError>>()?;

        Ok(Figure {
            title,
            subtitle: subtitle.filter(|s| !s.trim().is_empty()),
            x_label: "Time (s)".to_string(),
            x_categories: Vec::new(),
            t_range,
            panels,
        })
    }

    /// The figure over the shared x axis named `x.0`, of categories `x.1` when there are any.
    fn over(self, (x_label, categories): (&str, &[String])) -> Self {
        Figure {
            x_label: x_label.to_string(),
            x_categories: categories.to_vec(),
            ..self
        }
    }
}

/// A panel's legend: its rows, their label widths and its box.
type PanelLegend = (Vec<LegendEntry>, Vec<i32>, LegendLayout);

impl render::Draw for Figure<'_> {
    /// Draw the figure on `root`; `scale` multiplies font sizes, line widths
    /// and paddings (1.0 for the default size).
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        scale: f64,
    ) -> Result<(), ReportError> {
        let (width, height) = root.dim_in_pixel();
        let (body, header_h) = render::draw_header(root, self.title, self.subtitle, scale)?;

        // Vertical layout: equal plotting heights.
        let n = self.panels.len();
        let plot_h = stack::plot_height(height as i32 - header_h, n, scale);
        if plot_h < MIN_PLOT_HEIGHT_PX {
            return Err(ReportError::Plot(format!(
                "image height {height} px too small for {n} panels"
            )));
        }
        // Ticks: at most one labelled value per ~36 px of panel height.
        let max_y_intervals = (f64::from(plot_h) / (36.0 * scale)).floor().clamp(2.0, 8.0);
        let mut y_ticks: Vec<Axis> = (self.panels.iter())
            .map(|p| p.value_axis(max_y_intervals))
            .collect();

        // Horizontal layout: the y label area fits the widest tick label and description.
        let y_descs = || self.panels.iter().map(|p| p.panel.y_label.as_str());
        let (_, y_label_area) = stack::y_labels(y_descs(), &y_ticks, plot_h, scale);
        let plot = (
            stack::plot_width(width, y_label_area, scale).max(10),
            plot_h,
        );
        let x_ticks = self.x_axis(plot.0, scale);

        let strokes = self.strokes(&TraceStyles::new(scale), (&x_ticks, &y_ticks), plot);
        let legend_metrics = LegendMetrics::new(scale);
        let rows = (self.panels.iter().zip(&strokes))
            .map(|(data, strokes)| legend_entries(data, strokes))
            .collect();
        let legends: Vec<Option<PanelLegend>> = (legend::first_rows(rows).into_iter())
            .zip(self.panels.iter().zip(y_ticks.iter_mut()))
            .map(|(entries, (data, yt))| {
                let fit = (&legend_metrics, plot, max_y_intervals);
                (!entries.is_empty())
                    .then(|| place_panel_legend(data, entries, (&x_ticks, yt), fit))
            })
            .collect();
        let (y_desc, y_label_area) = stack::y_labels(y_descs(), &y_ticks, plot_h, scale);

        let areas = stack::areas(&body, n, plot_h, scale);
        for (i, data) in self.panels.iter().enumerate() {
            let axes = (x_ticks.clone(), y_ticks[i].clone());
            let descs = (self.x_label.as_str(), &y_desc[i][..]);
            let mut chart = stack::chart(&areas[i], (i, n), axes, descs, y_label_area, scale)?;
            draw_traces(&mut chart, data, &strokes[i], (&x_ticks, &y_ticks[i]))?;
            let border = render::upx(scale)(1.0);
            if let Some((entries, label_w, layout)) = &legends[i] {
                let area = chart.plotting_area().strip_coord_spec();
                legend::draw_legend(&area, entries, label_w, layout, &legend_metrics, border)?;
            }
            axes::frame(root, axes::plot_bounds(chart.plotting_area()), border)?;
        }
        Ok(())
    }
}

/// Least gap (px at scale 1) between the names of neighbouring x categories.
const X_CATEGORY_GAP: f64 = 12.0;

impl Figure<'_> {
    /// The shared x axis over plots `plot_w` px wide: the categories when the figure has them,
    /// each name shortened in the middle to its share of the width, else linear ticks at most
    /// one per 90 px.
    fn x_axis(&self, plot_w: i32, scale: f64) -> Axis {
        if self.x_categories.is_empty() {
            let max_intervals = (f64::from(plot_w) / (90.0 * scale)).floor().clamp(2.0, 8.0);
            return linear_axis(self.t_range.0, self.t_range.1, max_intervals);
        }
        let share = f64::from(plot_w) / self.x_categories.len() as f64 - X_CATEGORY_GAP * scale;
        let size = axes::TICK_LABEL_SIZE * scale;
        let names: Vec<String> = (self.x_categories.iter())
            .map(|c| layout::ellipsize_middle(c, size, share))
            .collect();
        categorical_axis(&names)
    }

    /// The stroke of every trace of every panel: its colour and line style, and the width of
    /// its group (its colour and line style) raised where later curves would hide one of its
    /// curves ([`overlap::width_levels`]), on plots `plot` px wide and high over the axes.
    fn strokes(
        &self,
        styles: &TraceStyles,
        (x, y): (&Axis, &[Axis]),
        plot: (i32, i32),
    ) -> Vec<Vec<Stroke>> {
        let traces =
            || (self.panels.iter()).map(|d| d.panel.traces.iter().map(|t| t.style).zip(&d.colors));
        let mut groups: Vec<(LineStyle, usize)> = Vec::new();
        for (style, &c) in traces().flatten() {
            if !groups.contains(&(style, c)) {
                groups.push((style, c));
            }
        }
        let group = |style, c| groups.iter().position(|g| *g == (style, c)).unwrap_or(0);
        let panels: Vec<PanelCurves<'_>> = (self.panels.iter().zip(y))
            .map(|(d, y)| PanelCurves {
                curves: (d.panel.traces.iter().zip(&d.pieces).zip(&d.colors))
                    .filter(|((t, _), _)| !matches!(t.style, LineStyle::Markers | LineStyle::Bars))
                    .map(|((t, pieces), &c)| Curve {
                        group: group(t.style, c),
                        pieces,
                    })
                    .collect(),
                y,
            })
            .collect();
        let size = (f64::from(plot.0), f64::from(plot.1));
        let tol = f64::from(styles.line_w);
        let levels = overlap::width_levels(&panels, x, size, tol, groups.len());
        traces()
            .map(|p| {
                p.map(|(style, &c)| styles.stroke(c, style, levels[group(style, c)]))
                    .collect()
            })
            .collect()
    }
}

impl PanelData<'_> {
    /// The panel's value axis: its categories when it has them, else 1-2-5 ticks over its
    /// range with at most `max_intervals` intervals.
    fn value_axis(&self, max_intervals: f64) -> Axis {
        if self.panel.categories.is_empty() {
            nice_axis(self.y_range.0, self.y_range.1, max_intervals)
        } else {
            categorical_axis(&self.panel.categories)
        }
    }
}

/// The corner and columns of the legend `entries` of panel `data`: where it hides the fewest
/// curve segments over the axes `(x, yt)`. When every corner hides some, the top of a numeric
/// value axis `yt` is raised until the legend fits above the data (the most compact layout,
/// at most 40 % of the panel); `fit` holds the legend's metrics, the plot's size (px) and the
/// most intervals of a value axis.
fn place_panel_legend(
    data: &PanelData<'_>,
    entries: Vec<LegendEntry>,
    (x, yt): (&Axis, &mut Axis),
    (m, plot, max_y_intervals): (&LegendMetrics<'static>, (i32, i32), f64),
) -> PanelLegend {
    let label_w = m.label_widths(&entries);
    let place = |y: &Axis| legend::place_legend(&data.pieces, (x, y), &label_w, m, plot);
    let (mut layout, hits) = place(yt);
    let frac = m.compact_fraction(&label_w, plot).filter(|f| *f <= 0.4);
    if let (true, true, Some(frac)) = (hits > 0, data.panel.categories.is_empty(), frac) {
        let top = data.y_range.1;
        let mut raised = yt.clone();
        for _ in 0..4 {
            let hi = raised.lo + (top - raised.lo) / (1.0 - frac);
            raised = nice_axis(raised.lo, hi, max_y_intervals);
            let (l, h) = place(&raised);
            if h == 0 {
                *yt = raised;
                layout = l;
                break;
            }
        }
    }
    (entries, label_w, layout)
}

/// Draw the traces of panel `data` with their `strokes` on `chart` over the axes `(x, y)`:
/// lines decimated to what the plot's width shows, markers as circles, time markers as
/// vertical lines over the panel's height.
fn draw_traces<DB: DrawingBackend>(
    chart: &mut axes::Chart<'_, DB>,
    data: &PanelData<'_>,
    strokes: &[Stroke],
    (x, y): (&Axis, &Axis),
) -> Result<(), ReportError> {
    let (pw, _) = chart.plotting_area().dim_in_pixel();
    let bucket_count = (pw as usize).max(1) * 2;
    for ((trace, pieces), stroke) in data.panel.traces.iter().zip(&data.pieces).zip(strokes) {
        if trace.style == LineStyle::Bars {
            draw_bars(chart, &pieces.points(), stroke, y)?;
            continue;
        }
        if trace.style == LineStyle::Markers {
            draw_pieces(chart, [], &pieces.points(), stroke)?;
            continue;
        }
        let rule = rule_time(trace).map(|t| vec![(t, y.lo), (t, y.hi)]);
        let lines = (pieces.lines.iter())
            .map(|line| decimate(line, x.lo, x.hi, bucket_count))
            .chain(rule);
        draw_pieces(chart, lines, &pieces.dots, stroke)?;
    }
    Ok(())
}

/// Draw each of `points` as a filled bar [`BAR_WIDTH`] wide from 0 (or the axis `y`'s nearer
/// end) to its value, in the colour of `stroke`.
fn draw_bars<DB: DrawingBackend>(
    chart: &mut axes::Chart<'_, DB>,
    points: &[(f64, f64)],
    stroke: &Stroke,
    y: &Axis,
) -> Result<(), ReportError> {
    let base = 0.0_f64.clamp(y.lo, y.hi);
    let half = BAR_WIDTH / 2.0;
    let fill = stroke.color.mix(stroke.opacity).filled();
    chart
        .draw_series(points.iter().map(|&(x, v)| {
            Rectangle::new([(x - half, base), (x + half, v.clamp(y.lo, y.hi))], fill)
        }))
        .map_err(plot_err)?;
    Ok(())
}

/// Error unless `lo..hi` is a finite, non-empty range.
fn check_span((lo, hi): (f64, f64), what: &str) -> Result<(), ReportError> {
    if lo.is_finite() && hi.is_finite() && (hi - lo).is_finite() && hi > lo {
        Ok(())
    } else {
        Err(ReportError::Plot(format!(
            "{what}: values too large to scale ({lo:e} .. {hi:e})"
        )))
    }
}

/// Pixel sizes for drawing traces.
struct TraceStyles {
    line_w: u32,
    /// Width added to a line for each level it is raised by ([`overlap::width_levels`]).
    band_w: u32,
    dot_r: u32,
    /// Radius of the circles of [`LineStyle::Markers`].
    marker_r: u32,
    /// The patterns of [`LineStyle::Dashed`], [`LineStyle::Dotted`] and [`LineStyle::DashDot`].
    dash: Dash,
    dot: Dash,
    dash_dot: Dash,
}

impl TraceStyles {
    /// The sizes at `scale`.
    fn new(scale: f64) -> Self {
        let (px, upx) = (render::px(scale), render::upx(scale));
        let (long, short, gap) = (px(12.0).max(3), px(2.0).max(1), px(4.0).max(2));
        TraceStyles {
            line_w: upx(2.0),
            band_w: upx(3.0),
            dot_r: upx(3.0),
            marker_r: upx(6.0),
            dash: even_dash(px(10.0).max(2), px(6.0).max(2)),
            dot: even_dash(short, px(5.0).max(2)),
            dash_dot: [long, gap, short, gap],
        }
    }

    /// The stroke of a trace in palette colour `color` and line style `style`, its width
    /// raised by `level` bands (and then drawn as a see-through band).
    fn stroke(&self, color: usize, style: LineStyle, level: u32) -> Stroke {
        Stroke {
            color: series_color(color),
            width: self.line_w + level * self.band_w,
            pattern: match style {
                LineStyle::Solid | LineStyle::Markers | LineStyle::Bars => None,
                LineStyle::Dashed => Some(self.dash),
                LineStyle::Dotted => Some(self.dot),
                LineStyle::DashDot => Some(self.dash_dot),
            },
            dot_r: if style == LineStyle::Markers {
                self.marker_r
            } else {
                self.dot_r
            },
            opacity: if level > 0 {
                overlap::BAND_OPACITY
            } else {
                1.0
            },
        }
    }
}

/// Reduce a polyline to what can be seen at `buckets` columns across the
/// time range `t_lo..t_hi`: of every run of consecutive points falling in the
/// same column, keep the first, the lowest, the highest and the last (in
/// their original order). Short polylines are returned unchanged.
fn decimate(line: &[(f64, f64)], t_lo: f64, t_hi: f64, buckets: usize) -> Polyline {
    if line.len() <= 4 * buckets || t_hi <= t_lo {
        return line.to_vec();
    }
    let column = |t: f64| ((t - t_lo) / (t_hi - t_lo) * buckets as f64).floor() as i64;
    let mut out = Vec::with_capacity(4 * buckets + 4);
    let mut start = 0;
    while start < line.len() {
        let col = column(line[start].0);
        let mut end = start + 1;
        while end < line.len() && column(line[end].0) == col {
            end += 1;
        }
        let group = &line[start..end];
        let by_value =
            |a: &(usize, &(f64, f64)), b: &(usize, &(f64, f64))| a.1 .1.total_cmp(&b.1 .1);
        let lo = group.iter().enumerate().min_by(by_value).map_or(0, |p| p.0);
        let hi = group.iter().enumerate().max_by(by_value).map_or(0, |p| p.0);
        let mut keep = [0, lo.min(hi), lo.max(hi), group.len() - 1];
        keep.sort_unstable();
        let mut prev = None;
        for k in keep {
            if prev != Some(k) {
                out.push(group[k]);
                prev = Some(k);
            }
        }
        start = end;
    }
    out
}

/// Legend entries of a panel: its traces with a non-empty label, in order, each shown in its
/// stroke (`strokes`, index for index with the traces).
fn legend_entries(data: &PanelData<'_>, strokes: &[Stroke]) -> Vec<LegendEntry> {
    (data.panel.traces.iter().zip(strokes))
        .filter(|(t, _)| !t.label.is_empty())
        .map(|(t, stroke)| {
            let mut e = LegendEntry::of(stroke, &t.label);
            e.sample = match (t.t_s.is_empty(), t.style) {
                (true, _) => Sample::Note,
                (false, LineStyle::Markers) => Sample::Dot(stroke.dot_r),
                (false, LineStyle::Bars) => Sample::Block,
                (false, _) => Sample::Line,
            };
            e
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trace(label: &str, t: &[f64], y: &[f64]) -> Trace {
        Trace {
            label: label.into(),
            t_s: t.to_vec(),
            y: y.to_vec(),
            ..Default::default()
        }
    }

    fn time(n: usize, dt: f64) -> Vec<f64> {
        (0..n).map(|i| i as f64 * dt).collect()
    }

    /// Four panels like a step response.
    fn step_panels() -> Vec<Panel> {
        let t = time(401, 0.01);
        let x: Vec<f64> = t
            .iter()
            .map(|&t| 340.0 + 5.0 * (1.0 - (-3.0 * t).exp() * (1.0 + 3.0 * t)))
            .collect();
        let x_ref: Vec<f64> = t
            .iter()
            .map(|&t| if t < 0.1 { 340.0 } else { 345.0 })
            .collect();
        let err: Vec<f64> = x_ref.iter().zip(&x).map(|(r, x)| r - x).collect();
        let p1: Vec<f64> = t.iter().map(|&t| 4.0 + 0.3 * (-2.0 * t).exp()).collect();
        let p2: Vec<f64> = t.iter().map(|&t| 6.0 - 0.2 * (-2.0 * t).exp()).collect();
        let w: Vec<f64> = t.iter().map(|&t| 900.0 * (-2.0 * t).exp()).collect();
        vec![
            Panel {
                y_label: "Position (mm)".into(),
                traces: vec![trace("x", &t, &x), trace("x_ref", &t, &x_ref)],
                ..Default::default()
            },
            Panel {
                y_label: "Error (mm)".into(),
                traces: vec![trace("", &t, &err)],
                ..Default::default()
            },
            Panel {
                y_label: "Pressure (bar)".into(),
                traces: vec![trace("p1", &t, &p1), trace("p2", &t, &p2)],
                ..Default::default()
            },
            Panel {
                y_label: "Speed (rpm)".into(),
                traces: vec![trace("ω1", &t, &w), trace("ω2", &t, &w)],
                ..Default::default()
            },
        ]
    }

    #[test]
    fn svg_contains_labels() {
        let svg = panels_svg("Step response", Some("rise 0.62 s"), &step_panels()).unwrap();
        assert!(svg.starts_with("<svg"), "{}", &svg[..50]);
        // Every text (ticks, axis descriptions, legend, notes) lies inside the figure.
        assert_eq!(crate::plot::text_overflow(&svg), Vec::<String>::new());
        assert!(svg.trim_end().ends_with("</svg>"));
        for s in [
            "Step response",
            "rise 0.62 s",
            "Position (mm)",
            "Error (mm)",
            "Pressure (bar)",
            "Speed (rpm)",
            "Time (s)",
            "x_ref",
            "p1",
            "p2",
            "ω1",
            "ω2",
        ] {
            assert!(svg.contains(s), "missing {s}");
        }
        // "Time (s)" only once: on the bottom panel.
        assert_eq!(svg.matches("Time (s)").count(), 1);
        let (w, h) = panels_default_size(4, true);
        assert_eq!(w, 1000);
        assert!((950..=1050).contains(&h), "{h}");
        assert!(svg.contains(&format!("width=\"{w}\"")));
        assert!(svg.contains(&format!("height=\"{h}\"")));
    }

    #[test]
    fn png_signature_and_size() {
        let png = panels_png("PNG", None, &step_panels(), 900, 800).unwrap();
        let rgb = render::decode_png(&png, 900, 800);
        // Not a blank image: some dark pixels (text, curves).
        assert!(render::dark_pixels(&rgb) > 1000);
    }

    #[test]
    fn png_bad_size_is_an_error() {
        let p = step_panels();
        for (w, h) in [(0, 600), (100_000, 600), (800, 100)] {
            assert!(matches!(
                panels_png("x", None, &p, w, h),
                Err(ReportError::Plot(_))
            ));
        }
        // Too many panels for the height.
        let many = vec![p[0].clone(); 12];
        assert!(matches!(
            panels_png("x", None, &many, 800, 400),
            Err(ReportError::Plot(_))
        ));
    }

    #[test]
    fn constant_and_non_finite_do_not_panic() {
        let t = time(50, 0.1);
        let mut y: Vec<f64> = t.iter().map(|t| t.sin()).collect();
        y[3] = f64::NAN;
        y[10] = f64::INFINITY;
        y[11] = f64::NEG_INFINITY;
        y[20] = f64::NAN;
        y[22] = f64::NAN; // y[21] is an isolated dot
        let mut t_holes = t.clone();
        t_holes[30] = f64::NAN;
        t_holes[31] = f64::INFINITY;
        let panels = vec![
            Panel {
                y_label: "Constant (bar)".into(),
                traces: vec![trace("", &t, &[4.0; 50])],
                ..Default::default()
            },
            Panel {
                y_label: "Zero (mm)".into(),
                traces: vec![trace("zero", &t, &[0.0; 50])],
                ..Default::default()
            },
            Panel {
                y_label: "Holes".into(),
                traces: vec![
                    trace("holes", &t_holes, &y),
                    trace("nan", &t, &[f64::NAN; 50]),
                ],
                ..Default::default()
            },
            Panel {
                y_label: "Nothing".into(),
                traces: vec![],
                ..Default::default()
            },
            Panel {
                y_label: "Single".into(),
                traces: vec![trace("one", &[1.0], &[2.0])],
                ..Default::default()
            },
        ];
        panels_svg("holes", None, &panels).unwrap();
        panels_png("holes", Some("emulated data"), &panels, 640, 900).unwrap();

        // A single point overall: degenerate time and value ranges.
        let single = [Panel {
            y_label: "p".into(),
            traces: vec![trace("s", &[0.0], &[0.0])],
            ..Default::default()
        }];
        panels_svg("single", None, &single).unwrap();
        panels_png("single", None, &single, 400, 300).unwrap();

        let fig = Figure::prepare("c", None, &panels).unwrap();
        let (lo, hi) = fig.panels[0].y_range;
        assert!(lo < 4.0 && hi > 4.0 && hi - lo < 1.0, "{lo} {hi}");
        let (lo, hi) = fig.panels[1].y_range;
        assert!(lo <= -1.0 && hi >= 1.0, "{lo} {hi}");
        assert_eq!(fig.t_range, (0.0, 4.9));
        assert_eq!(fig.panels[2].pieces[0].dots, vec![(2.1, y[21])]);
    }

    #[test]
    fn huge_values_are_an_error_not_a_panic() {
        let t = [0.0, 1.0];
        let p = [Panel {
            y_label: "big".into(),
            traces: vec![trace("b", &t, &[-1.7e308, 1.7e308])],
            ..Default::default()
        }];
        assert!(matches!(
            panels_svg("x", None, &p),
            Err(ReportError::Plot(_))
        ));
        let p = [Panel {
            y_label: "large".into(),
            traces: vec![trace("b", &t, &[1e20, 3e20])],
            ..Default::default()
        }];
        panels_svg("x", None, &p).unwrap();
    }

    #[test]
    fn empty_input_is_empty_error() {
        assert!(matches!(
            panels_svg("x", None, &[]),
            Err(ReportError::Empty(_))
        ));
        let no_traces = [Panel::default()];
        assert!(matches!(
            panels_svg("x", None, &no_traces),
            Err(ReportError::Empty(_))
        ));
        let all_nan = [Panel {
            y_label: "n".into(),
            traces: vec![trace(
                "n",
                &[0.0, f64::NAN, 2.0],
                &[f64::NAN, 1.0, f64::INFINITY],
            )],
            ..Default::default()
        }];
        let err = panels_svg("x", None, &all_nan).unwrap_err();
        assert!(matches!(err, ReportError::Empty(_)));
        assert!(matches!(
            panels_png("x", None, &all_nan, 640, 480),
            Err(ReportError::Empty(_))
        ));
    }

    #[test]
    fn length_mismatch_is_plot_error_naming_trace() {
        let p = [Panel {
            y_label: "Position (mm)".into(),
            traces: vec![
                trace("ok", &[0.0, 1.0], &[0.0, 1.0]),
                trace("bad one", &[0.0, 1.0], &[0.0]),
            ],
            ..Default::default()
        }];
        let err = panels_svg("x", None, &p).unwrap_err();
        assert!(matches!(err, ReportError::Plot(_)));
        assert!(err.to_string().contains("bad one"), "{err}");
        assert!(matches!(
            panels_png("x", None, &p, 640, 480),
            Err(ReportError::Plot(_))
        ));
    }

    #[test]
    fn colour_assignment() {
        let tr = |label: &str, c: Option<usize>| Trace {
            label: label.into(),
            t_s: vec![0.0],
            y: vec![0.0],
            color: c,
            ..Default::default()
        };
        let panel = |traces: Vec<Trace>| Panel {
            y_label: String::new(),
            traces,
            ..Default::default()
        };
        let one = |traces| assign_colors(&[panel(traces)]).remove(0);
        assert_eq!(
            one(vec![tr("", None), tr("", None), tr("", None)]),
            vec![0, 1, 2]
        );
        // Explicit colours are reserved, taken modulo 8.
        assert_eq!(
            one(vec![
                tr("", None),
                tr("", Some(9)),
                tr("", None),
                tr("", Some(0))
            ]),
            vec![2, 1, 3, 0]
        );
        let many: Vec<Trace> = (0..10).map(|_| tr("", None)).collect();
        assert_eq!(one(many), vec![0, 1, 2, 3, 4, 5, 6, 7, 0, 1]);
        // Across panels: a label keeps its colour, a colour never names two labels.
        let colors = assign_colors(&[
            panel(vec![tr("a", Some(0)), tr("b", Some(2))]),
            panel(vec![tr("b", Some(1)), tr("c", Some(2)), tr("a", None)]),
        ]);
        assert_eq!(colors, vec![vec![0, 2], vec![2, 1, 0]]);
    }

    #[test]
    fn decimation_keeps_extremes() {
        let line: Polyline = (0..10_000)
            .map(|i| {
                (
                    i as f64 * 1e-3,
                    if i == 5_000 { 10.0 } else { (i % 7) as f64 },
                )
            })
            .collect();
        let d = decimate(&line, 0.0, 10.0, 100);
        assert!(d.len() <= 400 && d.len() >= 200, "{}", d.len());
        assert!(d.contains(&(5.0, 10.0)));
        assert_eq!(d.first(), line.first());
        assert_eq!(d.last(), line.last());
        assert!(d.windows(2).all(|w| w[0].0 <= w[1].0));
        let short = &line[..50];
        assert_eq!(decimate(short, 0.0, 10.0, 100), short.to_vec());
    }

    #[test]
    fn bars_stand_on_zero_and_are_as_high_as_their_values() {
        let bars = |label: &str, y: &[f64], color| Trace {
            label: label.into(),
            t_s: vec![1.0, 2.0],
            y: y.to_vec(),
            style: LineStyle::Bars,
            color: Some(color),
        };
        // a stack: the running total drawn first, the lower kind over it
        let panel = Panel {
            y_label: "energy (J)".into(),
            traces: vec![bars("b", &[30.0, 50.0], 1), bars("a", &[20.0, 10.0], 0)],
            ..Default::default()
        };
        let names = ["one".to_string(), "two".to_string()];
        let svg = panels_categorical_svg("t", None, ("x", &names), &[panel]).unwrap();
        // the value axis holds 0 although every value is above it
        assert!(svg.contains(">\n0\n<") || svg.contains(">0<"), "{svg}");
        // four filled bars in the two colours (blue #0072B2, vermillion #D55E00), each as high as
        // its value in the axis' pixels: heights proportional to 30, 50, 20, 10
        let rects: Vec<(String, f64)> = svg
            .split("<rect")
            .skip(1)
            .filter_map(|r| {
                let attr = |k: &str| {
                    let at = r.find(&format!(" {k}=\""))? + k.len() + 3;
                    r[at..].split('"').next().map(str::to_string)
                };
                let fill = attr("fill")?;
                let h: f64 = attr("height")?.parse().ok()?;
                ["#0072B2", "#D55E00"]
                    .contains(&fill.as_str())
                    .then_some((fill, h))
            })
            .collect();
        // the bars, then the legend's two squares
        assert_eq!(rects.len(), 6, "{rects:?}");
        assert_eq!(rects[4].1, rects[5].1, "the legend's squares");
        let (b, a): (Vec<_>, Vec<_>) = rects[..4].iter().partition(|r| r.0 == "#D55E00");
        let unit = b[0].1 / 30.0;
        for (got, want) in [(b[1].1, 50.0), (a[0].1, 20.0), (a[1].1, 10.0)] {
            assert!(
                (got - want * unit).abs() <= 1.5,
                "{got} px for {want} J ({unit} px/J)"
            );
        }
    }
}
