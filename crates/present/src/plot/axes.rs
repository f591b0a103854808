//! The axes every figure shares: one axis type for linear and logarithmic scales with explicit
//! major (labelled) and minor ticks, the tick choice (1-2-5 steps on linear axes; decades,
//! 1-2-5 or 1..9 multiples on log axes, thinned to keep labels apart), one tick-label format
//! ("0.05", "2000", "10⁻¹³", "2×10⁻¹¹", "1.2×10⁻¹⁰"), and the plot chrome drawn around the data
//! (text sizes, grid, label areas sized to the labels, the frame).

use std::ops::Range;

use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, ValueFormatter};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::error::{plot_err, ReportError};
use super::{layout, render};

/// A linear or logarithmic plotters axis over `lo..hi` with explicit labelled (major) ticks,
/// drawn with a bold grid line or a tick mark, and unlabelled (minor) ticks, drawn light.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Axis {
    pub(super) lo: f64,
    pub(super) hi: f64,
    pub(super) log: bool,
    pub(super) major: Vec<f64>,
    /// Labels of `major`, index for index.
    pub(super) labels: Vec<String>,
    pub(super) minor: Vec<f64>,
}

impl Axis {
    /// Position of `v` along the axis: 0 at `lo`, 1 at `hi` (clamped to
    /// -1..=2 so that pixel positions stay small).
    pub(super) fn fraction(&self, v: f64) -> f64 {
        let f = if self.log {
            if v > 0.0 {
                (v.log10() - self.lo.log10()) / (self.hi.log10() - self.lo.log10())
            } else {
                -1.0
            }
        } else {
            (v - self.lo) / (self.hi - self.lo)
        };
        if f.is_nan() {
            0.0
        } else {
            f.clamp(-1.0, 2.0)
        }
    }

    /// Whether `v` lies in `lo..=hi`.
    pub(super) fn contains(&self, v: f64) -> bool {
        v >= self.lo && v <= self.hi
    }

    /// Width in pixels of the widest tick label at plotters text size `size`.
    pub(super) fn widest_label(&self, size: f64) -> f64 {
        self.labels
            .iter()
            .map(|l| layout::text_width(l, size))
            .fold(0.0, f64::max)
    }
}

impl Ranged for Axis {
    type FormatOption = NoDefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let f = self.fraction(*value);
        (f64::from(limit.0) + f * f64::from(limit.1 - limit.0)).round() as i32
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.minor.clone()
        } else {
            self.major.clone()
        }
    }

    fn range(&self) -> Range<f64> {
        self.lo..self.hi
    }
}

impl ValueFormatter<f64> for Axis {
    fn format(value: &f64) -> String {
        format!("{value}")
    }

    fn format_ext(&self, value: &f64) -> String {
        self.major
            .iter()
            .position(|m| m == value)
            .map_or_else(|| Self::format(value), |i| self.labels[i].clone())
    }
}

/// Exponent in Unicode superscript digits: -13 → "⁻¹³".
fn superscript(e: i32) -> String {
    const DIGITS: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    e.to_string()
        .chars()
        .map(|c| c.to_digit(10).map_or('⁻', |d| DIGITS[d as usize]))
        .collect()
}

/// `v` with `decimals` decimals, without a "-0".
pub(super) fn fixed(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

/// Decimals needed to write multiples of `step` (a 1-2-5 × 10^k value).
fn decimals_for(step: f64) -> usize {
    (-(step.log10() + 1e-9).floor()).clamp(0.0, 12.0) as usize
}

/// Label of the log tick `m` × 10^`d` (`m` in 1..=9): plain decimals between
/// 0.001 and 90000, else "10⁻¹³" or "2×10⁻¹³".
pub(super) fn log_label(m: u32, d: i32) -> String {
    if (-3..=4).contains(&d) {
        fixed(
            f64::from(m) * 10f64.powi(d),
            d.min(0).unsigned_abs() as usize,
        )
    } else if m == 1 {
        format!("10{}", superscript(d))
    } else {
        format!("{m}×10{}", superscript(d))
    }
}

/// Labels of linear ticks `values` spaced by `step`: plain decimals when the
/// largest magnitude lies in 0.001..100000, else mantissas with a common
/// power of ten ("0.8×10⁻¹⁰", "1.0×10⁻¹⁰", ...).
fn linear_labels(values: &[f64], step: f64) -> Vec<String> {
    let max_abs = values.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    if max_abs == 0.0 || (1e-3..1e5).contains(&max_abs) {
        let decimals = decimals_for(step);
        return values.iter().map(|&v| fixed(v, decimals)).collect();
    }
    let e = max_abs.log10().floor() as i32;
    let p = 10f64.powi(e);
    let decimals = decimals_for(step / p);
    values
        .iter()
        .map(|&v| {
            let m = fixed(v / p, decimals);
            if m.chars().all(|c| c == '0' || c == '.') {
                "0".to_string()
            } else {
                format!("{m}×10{}", superscript(e))
            }
        })
        .collect()
}

/// Linear axis over `lo..hi` snapped outward to the minor step (so the data fill the plot; the
/// edges need not carry a label), its (major, minor) step the first of `steps` (ascending) giving
/// at most `max_intervals` major intervals, else the last.
pub(super) fn snapped_axis(lo: f64, hi: f64, steps: &[(f64, f64)], max_intervals: f64) -> Axis {
    let span = hi - lo;
    let &(step, minor_step) = steps
        .iter()
        .find(|(s, _)| span / s <= max_intervals)
        .unwrap_or_else(|| steps.last().expect("non-empty step table"));
    let per = ((step / minor_step).round() as i64).max(1);
    let j0 = (lo / minor_step - 1e-9).floor() as i64;
    let j1 = (hi / minor_step + 1e-9).ceil() as i64;
    let (mut major, mut minor) = (Vec::new(), Vec::new());
    for j in j0..=j1 {
        let v = j as f64 * minor_step;
        if j.rem_euclid(per) == 0 {
            major.push(v);
        } else {
            minor.push(v);
        }
    }
    Axis {
        lo: j0 as f64 * minor_step,
        hi: j1 as f64 * minor_step,
        log: false,
        labels: linear_labels(&major, step),
        major,
        minor,
    }
}

/// Linear axis over `lo..hi` with 1-2-5 steps, at most `max_intervals` major intervals,
/// snapped outward as [`snapped_axis`].
pub(super) fn nice_axis(lo: f64, hi: f64, max_intervals: f64) -> Axis {
    snapped_axis(lo, hi, &steps_125(hi - lo, max_intervals), max_intervals)
}

/// Linear axis spanning exactly `lo..hi` with 1-2-5 steps and at most `max_intervals` major
/// intervals (the ticks inside the range are kept).
pub(super) fn linear_axis(lo: f64, hi: f64, max_intervals: f64) -> Axis {
    let mut a = nice_axis(lo, hi, max_intervals);
    let tol = 1e-9 * (hi - lo);
    let inside = |v: f64| v >= lo - tol && v <= hi + tol;
    let (major, labels) = a
        .major
        .iter()
        .zip(&a.labels)
        .filter(|(v, _)| inside(**v))
        .map(|(v, l)| (*v, l.clone()))
        .unzip();
    a.minor.retain(|v| inside(*v));
    Axis {
        lo,
        hi,
        major,
        labels,
        ..a
    }
}

/// Candidate (major, minor) 1-2-5 × 10^k steps for `span`, ascending, starting at the smallest
/// giving at most `max_intervals` major intervals.
pub(super) fn steps_125(span: f64, max_intervals: f64) -> Vec<(f64, f64)> {
    let min_step = span / max_intervals;
    let d0 = min_step.log10().floor() as i32 - 1;
    let steps: Vec<(f64, f64)> = (d0..=d0 + 2)
        .flat_map(|d| {
            let p = 10f64.powi(d);
            [(p, p / 2.0), (2.0 * p, p), (5.0 * p, p)]
        })
        .filter(|&(s, _)| s >= min_step * (1.0 - 1e-9))
        .collect();
    if steps.is_empty() {
        vec![(min_step, min_step / 2.0)]
    } else {
        steps
    }
}

/// Axis of categories: the k-th of `names` (k from 1) at k, ticked with the names and nothing
/// else, spanning 0.5 ..= n + 0.5 so that every category lies half a step inside the plot.
pub(super) fn categorical_axis(names: &[String]) -> Axis {
    Axis {
        lo: 0.5,
        hi: names.len() as f64 + 0.5,
        log: false,
        major: (1..=names.len()).map(|k| k as f64).collect(),
        labels: names.to_vec(),
        minor: Vec::new(),
    }
}

/// Linear axis over `lo..hi` whose labels keep at least `min_gap` pixels
/// apart along `len_px` pixels; `label_len` gives a label's extent along the
/// axis (0 for a vertical axis, where `min_gap` alone applies).
pub(super) fn fitted_linear_axis(
    lo: f64,
    hi: f64,
    len_px: f64,
    min_gap: f64,
    label_len: &dyn Fn(&str) -> f64,
) -> Axis {
    let mut axis = linear_axis(lo, hi, 2.0);
    for n in (2..=8).rev() {
        let candidate = linear_axis(lo, hi, f64::from(n));
        let spacing = match candidate.major.as_slice() {
            [a, b, ..] => (b - a) / (hi - lo) * len_px,
            _ => f64::INFINITY,
        };
        let longest = candidate
            .labels
            .iter()
            .map(|l| label_len(l))
            .fold(0.0, f64::max);
        if spacing >= longest + min_gap {
            axis = candidate;
            break;
        }
    }
    axis
}

/// Logarithmic axis over `lo..hi` (> 0) drawn `len_px` pixels long, labels
/// at least `min_gap` pixels apart: powers of ten when the range holds three
/// or more (every n-th when crowded, minor ticks at 2..9), else 1-2-5 or
/// 1..9 multiples, else linear ticks.
pub(super) fn log_axis(lo: f64, hi: f64, len_px: f64, min_gap: f64) -> Axis {
    let px_per_decade = len_px / (hi.log10() - lo.log10());
    let tol = 1e-9;
    let inside = |v: f64| v >= lo * (1.0 - tol) && v <= hi * (1.0 + tol);
    let d0 = lo.log10().floor() as i32;
    let d1 = hi.log10().ceil() as i32;
    // (value, label, exponent) of m × 10^d for m in `mults`, in range.
    let multiples = |mults: &[u32]| -> Vec<(f64, String, i32)> {
        (d0..=d1)
            .flat_map(|d| {
                mults
                    .iter()
                    .map(move |&m| (f64::from(m) * 10f64.powi(d), log_label(m, d), d))
            })
            .filter(|t| inside(t.0))
            .collect()
    };
    let make = |major: Vec<(f64, String, i32)>, minor: Vec<(f64, String, i32)>| Axis {
        lo,
        hi,
        log: true,
        major: major.iter().map(|t| t.0).collect(),
        labels: major.into_iter().map(|t| t.1).collect(),
        minor: minor.into_iter().map(|t| t.0).collect(),
    };
    let min_spacing = |ticks: &[(f64, String, i32)]| -> f64 {
        ticks
            .windows(2)
            .map(|w| (w[1].0 / w[0].0).log10() * px_per_decade)
            .fold(f64::INFINITY, f64::min)
    };

    let decades = multiples(&[1]);
    if decades.len() >= 3 {
        let n = (min_gap / px_per_decade).ceil().max(1.0) as i32;
        if n == 1 {
            return make(decades, multiples(&[2, 3, 4, 5, 6, 7, 8, 9]));
        }
        let (major, minor) = decades.into_iter().partition(|t| t.2.rem_euclid(n) == 0);
        return make(major, minor);
    }
    for (set, rest) in [
        (&[1, 2, 5][..], &[3, 4, 6, 7, 8, 9][..]),
        (&[1, 2, 3, 4, 5, 6, 7, 8, 9][..], &[][..]),
    ] {
        let major = multiples(set);
        if major.len() >= 2 && min_spacing(&major) >= min_gap {
            return make(major, multiples(rest));
        }
    }
    if decades.len() == 2 {
        return make(decades, multiples(&[2, 3, 4, 5, 6, 7, 8, 9]));
    }
    // Less than a 1-2-3 step wide: linear ticks on the log scale.
    let max_intervals = (len_px / min_gap).floor().clamp(2.0, 8.0);
    Axis {
        log: true,
        ..linear_axis(lo, hi, max_intervals)
    }
}

// ---------------------------------------------------------------------------
// Plot chrome
// ---------------------------------------------------------------------------

/// Text size of tick labels, and of axis descriptions, at scale 1.
pub(super) const TICK_LABEL_SIZE: f64 = 15.0;
pub(super) const AXIS_DESC_SIZE: f64 = 17.0;
/// Smallest y label area at scale 1 (px): room for the rotated description and short labels.
const MIN_Y_LABEL_AREA: f64 = 82.0;
/// Room at scale 1 (px) beside the widest y tick label for the tick, the gap and the rotated
/// description.
const Y_DESC_ROOM: f64 = 52.0;

/// A chart whose both axes are [`Axis`].
pub(super) type Chart<'b, DB> = ChartContext<'b, DB, Cartesian2d<Axis, Axis>>;

/// Most lines a y description takes beside its plot; a longer one is shortened in the middle.
const Y_DESC_MAX_LINES: usize = 2;

/// The y description `desc` fitted beside a plot `plot_h` px high, at `scale`: one line when it
/// fits the plot's height, else wrapped at safe points (never between a number and its unit,
/// as [`layout::fit_subtitle`] wraps) onto at most [`Y_DESC_MAX_LINES`] lines, shortened in the
/// middle beyond. Drawn rotated, a line runs along the plot's height and so never reaches into
/// the label area of a plot stacked above or below.
pub(super) fn y_desc_lines(desc: &str, plot_h: i32, scale: f64) -> Vec<String> {
    let max_len = f64::from(plot_h.max(1));
    layout::fit_subtitle(desc, AXIS_DESC_SIZE * scale, max_len, Y_DESC_MAX_LINES)
}

/// Width (px) of the y label area for the tick labels of `axes` and a y description of
/// `desc_lines` lines, at `scale`: the widest tick label measured, each line beyond the first
/// adding a line height.
pub(super) fn y_label_area<'a>(
    axes: impl IntoIterator<Item = &'a Axis>,
    desc_lines: usize,
    scale: f64,
) -> i32 {
    let widest = axes
        .into_iter()
        .map(|a| a.widest_label(TICK_LABEL_SIZE * scale).ceil())
        .fold(0.0, f64::max);
    let px = render::px(scale);
    let more = desc_lines.saturating_sub(1) as f64 * AXIS_DESC_SIZE;
    px(MIN_Y_LABEL_AREA + more).max(widest as i32 + px(Y_DESC_ROOM + more))
}

/// Draw the axes of `chart`: tick labels, the x description `x_desc` when given, and either a
/// grid (bold lines at major, light at minor ticks) or, without one, tick marks of `tick_px`
/// pixels at scale 1. The y description is drawn by [`draw_y_desc`].
pub(super) fn draw_axes<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    x_desc: Option<&str>,
    grid: bool,
    tick_px: f64,
    scale: f64,
) -> Result<(), ReportError> {
    let text = render::text(scale);
    let upx = render::upx(scale);
    let mut mesh = chart.configure_mesh();
    mesh.axis_desc_style(text(AXIS_DESC_SIZE))
        .label_style(text(TICK_LABEL_SIZE))
        .y_label_offset(0);
    if grid {
        mesh.bold_line_style(BLACK.mix(0.22).stroke_width(upx(1.0)))
            .light_line_style(BLACK.mix(0.08).stroke_width(upx(1.0)));
    } else {
        mesh.disable_mesh()
            .set_all_tick_mark_size(render::px(scale)(tick_px));
    }
    if let Some(d) = x_desc.filter(|d| !d.is_empty()) {
        mesh.x_desc(d);
    }
    mesh.draw().map_err(plot_err)
}

/// Draw the y description `lines` (from [`y_desc_lines`]) of `chart` rotated in its y label
/// area `y_label_area` px wide: the first line at the area's left edge, each next one a line
/// height to the right, all centred on the plot's height; the tick labels keep to the area's
/// right part, which [`y_label_area`] sized to leave the lines room.
pub(super) fn draw_y_desc<DB: DrawingBackend>(
    chart: &Chart<'_, DB>,
    lines: &[String],
    y_label_area: i32,
    scale: f64,
) -> Result<(), ReportError> {
    let plot = chart.plotting_area().strip_coord_spec();
    let mid = plot.dim_in_pixel().1 as i32 / 2;
    let style = render::text(scale)(AXIS_DESC_SIZE)
        .transform(FontTransform::Rotate270)
        .pos(Pos::new(HPos::Center, VPos::Top));
    let line_h = render::px(scale)(AXIS_DESC_SIZE);
    for (j, line) in lines.iter().enumerate() {
        let x = -y_label_area + j as i32 * line_h;
        plot.draw_text(line, &style, (x, mid)).map_err(plot_err)?;
    }
    Ok(())
}

/// Pixel bounds `(left, right, top, bottom)` of the plotting area of `area`.
pub(super) fn plot_bounds<DB: DrawingBackend, CT: CoordTranslate>(
    area: &DrawingArea<DB, CT>,
) -> (i32, i32, i32, i32) {
    let (xr, yr) = area.get_pixel_range();
    (xr.start, xr.end - 1, yr.start, yr.end - 1)
}

/// A thin black frame of `width` px along the pixel bounds `(left, right, top, bottom)`.
pub(super) fn frame<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    (left, right, top, bottom): (i32, i32, i32, i32),
    width: u32,
) -> Result<(), ReportError> {
    root.draw(&PathElement::new(
        [
            (left, top),
            (right, top),
            (right, bottom),
            (left, bottom),
            (left, top),
        ],
        BLACK.stroke_width(width),
    ))
    .map_err(plot_err)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels() {
        assert_eq!(superscript(-13), "⁻¹³");
        assert_eq!(log_label(1, -13), "10⁻¹³");
        assert_eq!(log_label(2, -11), "2×10⁻¹¹");
        assert_eq!(log_label(5, -2), "0.05");
        assert_eq!(log_label(1, 0), "1");
        assert_eq!(log_label(2, 3), "2000");
        assert_eq!(log_label(1, 6), "10⁶");
        assert_eq!(
            linear_labels(&[0.8e-10, 1.0e-10, 1.2e-10], 0.2e-10),
            vec!["0.8×10⁻¹⁰", "1.0×10⁻¹⁰", "1.2×10⁻¹⁰"]
        );
        assert_eq!(
            linear_labels(&[-0.5, 0.0, 0.5], 0.5),
            vec!["-0.5", "0.0", "0.5"]
        );
        assert_eq!(linear_labels(&[200.0, 400.0], 200.0), vec!["200", "400"]);

        // Five decades on 500 px: powers of ten only, minor ticks between.
        let a = log_axis(10f64.powf(-13.125), 10f64.powf(-8.875), 500.0, 28.0);
        assert_eq!(a.labels, vec!["10⁻¹³", "10⁻¹²", "10⁻¹¹", "10⁻¹⁰", "10⁻⁹"]);
        assert_eq!(a.minor.len(), 2 + 4 * 8); // 8e-14, 9e-14, then 2..9 × 10^d
                                              // Crowded: every other decade.
        let a = log_axis(1e-20, 1e20, 300.0, 28.0);
        assert!(a.labels.len() <= 11 && a.labels.contains(&"1".to_string()));
        // Few decades: 1-2-5.
        let a = log_axis(0.03, 5.0, 500.0, 28.0);
        assert_eq!(a.labels, vec!["0.05", "0.1", "0.2", "0.5", "1", "2", "5"]);
        // Narrow: 1..9 multiples, then linear ticks.
        let a = log_axis(2.5, 4.5, 500.0, 28.0);
        assert_eq!(a.labels, vec!["3", "4"]);
        let a = log_axis(1.01, 1.05, 500.0, 28.0);
        assert!(a.log && a.major.len() >= 2, "{a:?}");

        let x = linear_axis(12.5, 1100.0, 8.0);
        assert_eq!(x.major.first(), Some(&200.0));
        assert!(x.major.iter().all(|v| *v >= x.lo && *v <= x.hi));
    }

    #[test]
    fn snapped_and_exact_linear_axes() {
        // Time axis: exactly the data, 0.5 s steps for 3.97 s with at most 8 intervals.
        let t = linear_axis(0.0, 3.97, 8.0);
        assert_eq!((t.lo, t.hi), (0.0, 3.97));
        assert_eq!(t.major, vec![0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5]);
        assert_eq!(t.labels[1], "0.5");
        assert_eq!(t.labels.len(), t.major.len());
        // Value axis: snapped outward to the minor step, 3 to 6 labels.
        let y = nice_axis(339.8, 345.5, 5.0);
        assert!(y.lo <= 339.8 && y.hi >= 345.5);
        assert!(y.major.len() >= 3 && y.major.len() <= 6, "{y:?}");
        // A custom step table (multiples of 45 deg) is honoured.
        let steps = [(10.0, 5.0), (45.0, 15.0), (90.0, 30.0)];
        let p = snapped_axis(-250.0, -90.0, &steps, 4.0);
        assert!(p.major.iter().all(|v| v % 45.0 == 0.0), "{p:?}");
        assert_eq!(p.labels[0], format!("{}", p.major[0]));
        // No "-0" label.
        assert_eq!(
            nice_axis(-1.0, 1.0, 4.0).labels,
            vec!["-1.0", "-0.5", "0.0", "0.5", "1.0"]
        );
    }

    #[test]
    fn y_descriptions_fit_the_plot_height() {
        let d = "max |e| (mm), 0.125 Hz ±12.5 mm";
        assert_eq!(y_desc_lines(d, 400, 1.0), vec![d]);
        // wrapped after the comma, the numbers kept with their units
        let lines = y_desc_lines(d, 150, 1.0);
        assert_eq!(lines, vec!["max |e| (mm),", "0.125 Hz ±12.5 mm"]);
        for l in &lines {
            assert!(layout::text_width(l, AXIS_DESC_SIZE) <= 150.0, "{l}");
        }
        // too long even for two lines: shortened in the middle
        let short = y_desc_lines(d, 60, 1.0);
        assert!(short.len() == 2 && short[1].contains('…'), "{short:?}");
        assert!(y_desc_lines("", 100, 1.0).is_empty());
    }

    #[test]
    fn categories_sit_at_whole_numbers() {
        let a = categorical_axis(&["off".to_string(), "on".to_string()]);
        assert_eq!((a.lo, a.hi, &a.major[..]), (0.5, 2.5, &[1.0, 2.0][..]));
        assert_eq!(a.labels, ["off", "on"]);
        assert!(a.minor.is_empty());
    }

    #[test]
    fn y_label_area_fits_the_widest_label() {
        let narrow = linear_axis(0.0, 1.0, 4.0);
        assert_eq!(y_label_area([&narrow], 1, 1.0), 82);
        let wide = Axis {
            labels: vec!["-123456.789".into()],
            ..narrow.clone()
        };
        let w = layout::text_width("-123456.789", TICK_LABEL_SIZE);
        assert_eq!(y_label_area([&narrow, &wide], 1, 1.0), w.ceil() as i32 + 52);
        assert_eq!(y_label_area([&narrow], 1, 2.0), 164);
        // a second line of the description adds a line height
        assert_eq!(
            y_label_area([&narrow, &wide], 2, 1.0),
            w.ceil() as i32 + 52 + 17
        );
        assert_eq!(y_label_area([&narrow], 2, 1.0), 82 + 17);
    }
}
