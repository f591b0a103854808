//! Two-panel Bode diagrams (magnitude in dB over phase in degrees, shared
//! logarithmic frequency axis in Hz), rendered to SVG or PNG in memory.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::axes::{self, log_axis, snapped_axis, steps_125, Axis, Chart};
use super::error::{plot_err, ReportError};
use super::font;
use super::legend::{self, LegendEntry, LegendMetrics};
use super::render;
use super::series::{draw_pieces, finite_extent, runs, series_color, Pieces, Polyline, Stroke};
use super::stack;

/// Default figure width in pixels (used for SVG output; a sensible PNG size).
pub const DEFAULT_WIDTH_PX: u32 = 1000;
/// Default figure height in pixels (used for SVG output; a sensible PNG size).
pub const DEFAULT_HEIGHT_PX: u32 = 750;

/// Lowest magnitude shown, relative to the largest finite magnitude, in dB.
/// Deeper notches and roll-offs are clipped at the bottom of the panel.
const MAG_WINDOW_DB: f64 = 200.0;

/// Where the magnitude crosses 0 dB, the panel shows at most this far above and below it (dB),
/// so the crossover region, where the margins are read, is readable rather than squeezed by the
/// low-frequency gain and the high-frequency roll-off (clipped at the panel's edges); the gain
/// margins drawn stay inside.
const CROSSOVER_WINDOW_DB: f64 = 60.0;

/// Lowest phase shown, relative to the largest finite phase, in degrees.
const PHASE_WINDOW_DEG: f64 = 720.0;

/// Colour of reference lines (0 dB, -180 deg) and crossover markers.
const REF_COLOR: RGBColor = RGBColor(70, 70, 70);

/// One curve of a Bode diagram.
///
/// The three vectors are indexed together and must have the same length.
/// Points whose frequency is not finite and positive, or whose magnitude
/// (phase) is not finite, are skipped in the magnitude (phase) panel and
/// break the line there.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BodeSeries {
    /// Label shown in the legend (the legend is drawn when there is more than
    /// one series).
    pub label: String,
    /// Frequencies in Hz, strictly increasing, > 0.
    pub freq_hz: Vec<f64>,
    /// Magnitude at each frequency, in dB (20·log10 |G|).
    pub mag_db: Vec<f64>,
    /// Phase at each frequency, in degrees, already unwrapped by the caller.
    pub phase_deg: Vec<f64>,
}

/// Optional markers: the stability margins found, drawn on the plot.
///
/// Crossover frequencies are drawn as dotted vertical lines in both panels when one series is
/// marked; with several, the lines would crowd the crossover region (two a series within a
/// fraction of an octave), so the margin bars in each series' colour and the values under the
/// title mark them.
/// The gain margin is drawn as a bar from -GM dB up to 0 dB at the phase
/// crossover, the phase margin as a bar from -180 deg up to -180 + PM deg at
/// the gain crossover (shifted by the multiple of 360 deg that matches the
/// first series' unwrapped phase there), and both values are printed under
/// the title. Non-finite or non-positive frequencies and NaN margins are
/// ignored.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BodeMarkers {
    /// Gain crossover frequency (|L| = 0 dB), in Hz.
    pub gain_crossover_hz: Option<f64>,
    /// Phase crossover frequency (phase = -180 deg), in Hz.
    pub phase_crossover_hz: Option<f64>,
    /// Gain margin, in dB (positive when the loop is stable); may be infinite.
    pub gain_margin_db: Option<f64>,
    /// Phase margin, in degrees (positive when the loop is stable).
    pub phase_margin_deg: Option<f64>,
}

/// Render a two-panel Bode diagram (magnitude in dB on top, phase in degrees
/// below, shared logarithmic frequency axis in Hz) to an SVG document in
/// memory, [`DEFAULT_WIDTH_PX`] x [`DEFAULT_HEIGHT_PX`] pixels.
///
/// `title` is printed at the top. Each series gets its own colour; a legend
/// with the series labels is drawn when there is more than one series. Series
/// after the first are drawn dashed, dotted or dash-dotted (and so is their legend sample),
/// so overlapping curves stay distinguishable without colour.
///
/// `markers[i]` (stability margins) belongs to `series[i]` and is drawn in that
/// series' colour (crossover lines, GM and PM bars); the margins of every marked
/// series are summarised under the title. A `None` entry, or a series beyond the
/// end of `markers`, is not marked (`&[]` marks none).
///
/// # Errors
/// [`ReportError::Empty`] when `series` is empty or holds no finite point;
/// [`ReportError::Plot`] when a series' vectors differ in length or plotting
/// fails.
pub fn bode_svg(
    title: &str,
    series: &[BodeSeries],
    markers: &[Option<BodeMarkers>],
) -> Result<String, ReportError> {
    let figure = Figure::prepare(title, series, markers)?;
    render::to_svg(&figure, (DEFAULT_WIDTH_PX, DEFAULT_HEIGHT_PX))
}

/// Same figure as [`bode_svg`], rendered to an encoded PNG file (the bytes of
/// the file, RGB, 8 bit), `width` x `height` pixels. Text and line widths
/// scale with the image size relative to 1000 x 750.
///
/// # Errors
/// As [`bode_svg`]; additionally [`ReportError::Plot`] when the size is below
/// 320 x 240 or above 16384 pixels on a side, or PNG encoding fails.
pub fn bode_png(
    title: &str,
    series: &[BodeSeries],
    markers: &[Option<BodeMarkers>],
    width: u32,
    height: u32,
) -> Result<Vec<u8>, ReportError> {
    let figure = Figure::prepare(title, series, markers)?;
    render::to_png(
        &figure,
        width,
        height,
        (DEFAULT_WIDTH_PX, DEFAULT_HEIGHT_PX),
    )
}

// ---------------------------------------------------------------------------
// Axes
// ---------------------------------------------------------------------------

/// Plot width (px at scale 1) the frequency ticks are chosen for before the layout is known.
const NOMINAL_PLOT_W: f64 = 880.0;
/// Smallest distance (px at scale 1) between two labelled frequency ticks.
const FREQ_TICK_GAP: f64 = 60.0;

/// Logarithmic frequency axis (Hz) over `lo..hi` drawn `len_px` pixels long at `scale`; a
/// single frequency gets a small band around it.
fn freq_axis(lo: f64, hi: f64, len_px: f64, scale: f64) -> Axis {
    let (lo, hi) = if hi / lo < 1.0 + 1e-9 {
        (lo / 1.5, hi * 1.5)
    } else {
        (lo, hi)
    };
    log_axis(lo, hi, len_px, FREQ_TICK_GAP * scale)
}

/// Candidate (major, minor) steps for phase in degrees, ascending; multiples
/// of 45 and 90 deg once the span is large enough.
fn phase_steps() -> Vec<(f64, f64)> {
    let mut steps = vec![
        (0.1, 0.05),
        (0.2, 0.1),
        (0.5, 0.1),
        (1.0, 0.5),
        (2.0, 1.0),
        (5.0, 1.0),
        (10.0, 5.0),
        (15.0, 5.0),
        (45.0, 15.0),
        (90.0, 30.0),
        (180.0, 45.0),
        (360.0, 90.0),
    ];
    let mut s = 720.0;
    while s < 1e9 {
        steps.push((s, s / 4.0));
        s *= 2.0;
    }
    steps
}

/// Value range of one panel: data extent `(lo, hi)` padded by 5 % on each
/// side, widened to include `reference` when that at most doubles the span,
/// then snapped to ticks.
fn value_ticks(
    lo: f64,
    hi: f64,
    reference: Option<f64>,
    steps: &[(f64, f64)],
    max_major: f64,
    pad_min: f64,
) -> Axis {
    let (mut lo, mut hi) = (lo, hi);
    if let Some(r) = reference {
        let span = (hi - lo).max(pad_min);
        if r < lo && lo - r <= span {
            lo = r;
        } else if r > hi && r - hi <= span {
            hi = r;
        }
    }
    let pad = ((hi - lo) * 0.05).max(pad_min * 0.05);
    snapped_axis(lo - pad, hi + pad, steps, max_major)
}

/// Frequency for annotations, 3 significant digits: "0.0123", "4.56", "123".
fn format_freq_hz(f: f64) -> String {
    if !f.is_finite() || f <= 0.0 {
        return format!("{f}");
    }
    let e = f.log10().floor() as i32;
    if (-4..6).contains(&e) {
        format!("{:.*}", (2 - e).max(0) as usize, f)
    } else {
        format!("{f:.2e}")
    }
}

fn format_signed(v: f64, unit: &str) -> String {
    if v.is_infinite() {
        if v > 0.0 {
            format!("∞ {unit}")
        } else {
            format!("-∞ {unit}")
        }
    } else {
        format!("{v:.1} {unit}")
    }
}

// ---------------------------------------------------------------------------
// Data preparation
// ---------------------------------------------------------------------------

/// Split `(freq, value)` into polylines: points with a non-finite or
/// non-positive frequency or a non-finite value break the line; segments are
/// clipped to `lo..=hi` on the value axis (interpolating in log frequency).
fn clip_pieces(freq: &[f64], value: &[f64], lo: f64, hi: f64) -> Pieces {
    let mut pieces = Pieces::default();
    // Runs of (log10 f, value).
    let points = freq
        .iter()
        .zip(value)
        .map(|(&f, &v)| valid(f, v).then(|| (f.log10(), v)));
    for run in runs(points) {
        clip_run(&run, lo, hi, &mut pieces);
    }
    pieces
}

fn clip_run(run: &[(f64, f64)], lo: f64, hi: f64, out: &mut Pieces) {
    let to_data = |(lf, v): (f64, f64)| (10f64.powf(lf), v);
    match run {
        [] => {}
        [p] => {
            if p.1 >= lo && p.1 <= hi {
                out.dots.push(to_data(*p));
            }
        }
        _ => {
            let mut current: Polyline = Vec::new();
            let mut flush = |current: &mut Polyline| {
                if current.len() >= 2 {
                    out.lines.push(std::mem::take(current));
                } else {
                    current.clear();
                }
            };
            for w in run.windows(2) {
                let (a, b) = (w[0], w[1]);
                let (mut t0, mut t1) = (0.0f64, 1.0f64);
                let dv = b.1 - a.1;
                if dv == 0.0 {
                    if a.1 < lo || a.1 > hi {
                        flush(&mut current);
                        continue;
                    }
                } else {
                    let ta = (lo - a.1) / dv;
                    let tb = (hi - a.1) / dv;
                    t0 = t0.max(ta.min(tb));
                    t1 = t1.min(ta.max(tb));
                    if t0 > t1 {
                        flush(&mut current);
                        continue;
                    }
                }
                let lerp = |t: f64| {
                    if t == 0.0 {
                        a
                    } else if t == 1.0 {
                        b
                    } else {
                        (a.0 + t * (b.0 - a.0), (a.1 + t * dv).clamp(lo, hi))
                    }
                };
                if current.is_empty() || t0 > 0.0 {
                    flush(&mut current);
                    current.push(to_data(lerp(t0)));
                }
                current.push(to_data(lerp(t1)));
                if t1 < 1.0 {
                    flush(&mut current);
                }
            }
            flush(&mut current);
        }
    }
}

/// Value of `(freq, value)` at frequency `f`, interpolated linearly in log
/// frequency between the two finite neighbours.
fn interpolate_at(freq: &[f64], value: &[f64], f: f64) -> Option<f64> {
    let lf = f.log10();
    freq.iter()
        .zip(value)
        .zip(freq.iter().zip(value).skip(1))
        .find_map(|((&fa, &va), (&fb, &vb))| {
            let ok = [fa, va, fb, vb].iter().all(|x| x.is_finite()) && fa > 0.0 && fb > 0.0;
            if !ok {
                return None;
            }
            let (la, lb) = (fa.log10(), fb.log10());
            let (l0, l1) = if la <= lb { (la, lb) } else { (lb, la) };
            if lf < l0 || lf > l1 {
                return None;
            }
            if lb == la {
                return Some(va);
            }
            Some(va + (lf - la) / (lb - la) * (vb - va))
        })
}

/// Whether a point at frequency `f` (Hz) with value `v` can be drawn.
fn valid(f: f64, v: f64) -> bool {
    f.is_finite() && f > 0.0 && v.is_finite()
}

/// Finite min/max of the values `value(s)` of the series' points with a valid frequency.
fn extent(series: &[BodeSeries], value: impl Fn(&BodeSeries) -> &[f64]) -> Option<(f64, f64)> {
    let points = series.iter().flat_map(|s| {
        s.freq_hz
            .iter()
            .zip(value(s))
            .filter(|(&f, &v)| valid(f, v))
    });
    finite_extent(points.map(|(_, &v)| v))
}

/// Everything needed to draw, computed before touching a backend.
struct Figure<'a> {
    title: &'a str,
    series: &'a [BodeSeries],
    x: Axis,
    mag: Axis,
    phase: Axis,
    /// Phase reference line (-180 deg, or another odd multiple of 180 deg).
    phase_ref: f64,
    mag_pieces: Vec<Pieces>,
    phase_pieces: Vec<Pieces>,
    /// Margin markers of the series that have them.
    marks: Vec<Marks>,
    /// Margin summary printed under the title.
    summary: Option<String>,
}

/// The stability-margin markers of one series, in that series' colour.
struct Marks {
    /// Index of the series.
    series: usize,
    /// Gain margin bar: (phase crossover Hz, from dB, to dB).
    gm_bar: Option<(f64, f64, f64)>,
    /// Phase margin bar: (gain crossover Hz, from deg, to deg).
    pm_bar: Option<(f64, f64, f64)>,
    /// Crossover frequencies (Hz) inside the frequency range.
    crossovers: Vec<f64>,
    /// "GM = … @ … Hz      PM = … @ … Hz", if any margin or crossover is known.
    summary: Option<String>,
}

impl Marks {
    /// The markers `m` of series number `i` (`s`) on the axes `x`, `mag`, `phase`.
    fn new(i: usize, s: &BodeSeries, m: &BodeMarkers, x: &Axis, mag: &Axis, phase: &Axis) -> Self {
        let gm = m.gain_margin_db.filter(|g| !g.is_nan());
        let pm = m.phase_margin_deg.filter(|p| p.is_finite());
        let f_pc = valid_freq(m.phase_crossover_hz);
        let f_gc = valid_freq(m.gain_crossover_hz);
        let gm_bar = match (f_pc, gm) {
            (Some(f), Some(g)) if g.is_finite() && x.contains(f) && g != 0.0 => {
                let lo = (-g).clamp(mag.lo, mag.hi);
                let hi = 0.0f64.clamp(mag.lo, mag.hi);
                (lo != hi).then_some((f, lo, hi))
            }
            _ => None,
        };
        let pm_bar = match (f_gc, pm) {
            (Some(f), Some(p)) if x.contains(f) && p != 0.0 => {
                // -180 deg shifted by the multiple of 360 deg that matches
                // the unwrapped phase of the series at the crossover.
                let base = interpolate_at(&s.freq_hz, &s.phase_deg, f)
                    .map(|ph| ((ph - p + 180.0) / 360.0).round() * 360.0 - 180.0)
                    .unwrap_or(-180.0);
                let lo = base.clamp(phase.lo, phase.hi);
                let hi = (base + p).clamp(phase.lo, phase.hi);
                (lo != hi).then_some((f, lo, hi))
            }
            _ => None,
        };
        let mut crossovers: Vec<f64> = [f_gc, f_pc]
            .into_iter()
            .flatten()
            .filter(|&f| x.contains(f))
            .collect();
        crossovers.dedup();

        let mut parts = Vec::new();
        match (gm, f_pc) {
            (Some(g), Some(f)) => parts.push(format!(
                "GM = {} @ {} Hz",
                format_signed(g, "dB"),
                format_freq_hz(f)
            )),
            (Some(g), None) => parts.push(format!("GM = {}", format_signed(g, "dB"))),
            (None, Some(f)) => parts.push(format!("phase crossover @ {} Hz", format_freq_hz(f))),
            (None, None) => {}
        }
        match (pm, f_gc) {
            (Some(p), Some(f)) => parts.push(format!("PM = {p:.1}° @ {} Hz", format_freq_hz(f))),
            (Some(p), None) => parts.push(format!("PM = {p:.1}°")),
            (None, Some(f)) => parts.push(format!("gain crossover @ {} Hz", format_freq_hz(f))),
            (None, None) => {}
        }
        Marks {
            series: i,
            gm_bar,
            pm_bar,
            crossovers,
            summary: (!parts.is_empty()).then(|| parts.join("      ")),
        }
    }
}

fn valid_freq(f: Option<f64>) -> Option<f64> {
    f.filter(|f| f.is_finite() && *f > 0.0)
}

impl<'a> Figure<'a> {
    fn prepare(
        title: &'a str,
        series: &'a [BodeSeries],
        markers: &[Option<BodeMarkers>],
    ) -> Result<Self, ReportError> {
        if series.is_empty() {
            return Err(ReportError::Empty("no series given".into()));
        }
        for s in series {
            if s.freq_hz.len() != s.mag_db.len() || s.freq_hz.len() != s.phase_deg.len() {
                return Err(ReportError::Plot(format!(
                    "series '{}': {} frequencies, {} magnitudes and {} phases",
                    s.label,
                    s.freq_hz.len(),
                    s.mag_db.len(),
                    s.phase_deg.len()
                )));
            }
        }

        // Frequency extent over points with at least one finite value.
        let f_ext = finite_extent(series.iter().flat_map(|s| {
            let points = s.freq_hz.iter().zip(&s.mag_db).zip(&s.phase_deg);
            points
                .filter(|((&f, &m), &p)| valid(f, m) || valid(f, p))
                .map(|((&f, _), _)| f)
        }));
        let Some((f_lo, f_hi)) = f_ext else {
            return Err(ReportError::Empty(
                "no point with a finite positive frequency and a finite magnitude or phase".into(),
            ));
        };
        let x = freq_axis(f_lo, f_hi, NOMINAL_PLOT_W, 1.0);

        let mag_ext = extent(series, |s| &s.mag_db);
        let phase_ext = extent(series, |s| &s.phase_deg);

        // Magnitude: clamp to MAG_WINDOW_DB below the maximum; include 0 dB; where the curves
        // cross 0 dB, to CROSSOVER_WINDOW_DB about it, widened to hold every gain-margin bar.
        let (m_lo, m_hi) = mag_ext.unwrap_or((-20.0, 20.0));
        let m_lo = m_lo.max(m_hi - MAG_WINDOW_DB);
        let (m_lo, m_hi) = if m_lo < 0.0 && m_hi > 0.0 {
            let gm = markers
                .iter()
                .flatten()
                .filter_map(|m| m.gain_margin_db)
                .filter(|g| g.is_finite())
                .fold(0.0_f64, |a, g| a.max(g.abs()));
            let window = CROSSOVER_WINDOW_DB.max(gm + 10.0);
            (m_lo.max(-window), m_hi.min(window))
        } else {
            (m_lo, m_hi)
        };
        let steps = steps_125((m_hi - m_lo).max(10.0), 8.0);
        let mag = value_ticks(m_lo, m_hi, Some(0.0), &steps, 8.0, 10.0);

        // Phase: clamp to PHASE_WINDOW_DEG below the maximum (long delays
        // would squash everything else); include the -180 deg reference, or
        // the odd multiple of 180 deg nearest the data when the caller's
        // unwrapping put the phase elsewhere.
        let (p_lo, p_hi) = phase_ext.unwrap_or((-180.0, 0.0));
        let p_lo = p_lo.max(p_hi - PHASE_WINDOW_DEG);
        let phase_ref = if (p_lo..=p_hi).contains(&-180.0) {
            -180.0
        } else {
            let mid = 0.5 * (p_lo + p_hi);
            ((mid + 180.0) / 360.0).round() * 360.0 - 180.0
        };
        let phase = value_ticks(p_lo, p_hi, Some(phase_ref), &phase_steps(), 9.0, 20.0);

        let mag_pieces = series
            .iter()
            .map(|s| clip_pieces(&s.freq_hz, &s.mag_db, mag.lo, mag.hi))
            .collect();
        let phase_pieces = series
            .iter()
            .map(|s| clip_pieces(&s.freq_hz, &s.phase_deg, phase.lo, phase.hi))
            .collect();

        let marks: Vec<Marks> = series
            .iter()
            .zip(markers)
            .enumerate()
            .filter_map(|(i, (s, m))| m.as_ref().map(|m| Marks::new(i, s, m, &x, &mag, &phase)))
            .collect();
        let summary = match &marks[..] {
            [] => None,
            [only] if series.len() == 1 => only.summary.clone(),
            _ => {
                let parts: Vec<String> = marks
                    .iter()
                    .filter_map(|m| {
                        let text = m.summary.as_ref()?;
                        Some(format!("{}: {text}", series[m.series].label))
                    })
                    .collect();
                (!parts.is_empty()).then(|| parts.join("; "))
            }
        };

        Ok(Figure {
            title,
            series,
            x,
            mag,
            phase,
            phase_ref,
            mag_pieces,
            phase_pieces,
            marks,
            summary,
        })
    }
}

/// What differs between the two panels of a Bode diagram.
struct PanelSpec<'p> {
    /// Value axis, its description and the solid grey reference value on it (0 dB, -180 deg).
    y: &'p Axis,
    y_desc: &'p [String],
    reference: f64,
    /// Drawable pieces of each series on this panel.
    pieces: &'p [Pieces],
    /// The margin bar of a series' markers on this panel, and its label.
    bar: fn(&Marks) -> Option<(f64, f64, f64)>,
    bar_label: &'static str,
}

impl Figure<'_> {
    /// Draw panel `i` (0 magnitude, 1 phase) on `area` over the frequency axis `x`: axes,
    /// reference line, crossover lines, curves, margin bars, on the magnitude panel the legend,
    /// and the frame.
    fn draw_panel<DB: DrawingBackend>(
        &self,
        (root, area): (&DrawingArea<DB, Shift>, &DrawingArea<DB, Shift>),
        (i, x, y_label_area): (usize, &Axis, i32),
        spec: &PanelSpec<'_>,
        scale: f64,
    ) -> Result<(), ReportError> {
        let y = spec.y;
        let descs = ("Frequency (Hz)", spec.y_desc);
        let axes = (x.clone(), y.clone());
        let mut chart = stack::chart(area, (i, 2), axes, descs, y_label_area, scale)?;
        reference_line(&mut chart, spec.reference, scale)?;
        crossover_lines(&mut chart, &self.marks, (y.lo, y.hi), scale)?;
        // Later series first, so the first series (the one the markers
        // refer to) is drawn on top.
        let strokes: Vec<Stroke> = (0..self.series.len())
            .map(|i| series_stroke(i, scale))
            .collect();
        for (pieces, stroke) in spec.pieces.iter().zip(&strokes).rev() {
            draw_pieces(&mut chart, pieces.lines.clone(), &pieces.dots, stroke)?;
        }
        // Only the first marked series' bars are labelled, so close bars never overprint
        // their labels; the colours and the summary tell the others apart.
        for (k, m) in self.marks.iter().enumerate() {
            if let Some((f, lo, hi)) = (spec.bar)(m) {
                let label = if k == 0 { spec.bar_label } else { "" };
                margin_bar(
                    &mut chart,
                    f,
                    (lo, hi),
                    y,
                    (label, series_color(m.series)),
                    scale,
                )?;
            }
        }
        let upx = render::upx(scale);
        if i == 0 && self.series.len() > 1 {
            // The legend in the corner of the magnitude panel hiding the fewest curve segments.
            let entries: Vec<_> = self
                .series
                .iter()
                .zip(&strokes)
                .map(|(s, stroke)| LegendEntry::of(stroke, &s.label))
                .collect();
            let m = LegendMetrics::new(scale);
            let label_w = m.label_widths(&entries);
            let (pw, ph) = chart.plotting_area().dim_in_pixel();
            let plot = (pw as i32, ph as i32);
            let (layout, _) = legend::place_legend(spec.pieces, (x, y), &label_w, &m, plot);
            let area = chart.plotting_area().strip_coord_spec();
            legend::draw_legend(&area, &entries, &label_w, &layout, &m, upx(1.0))?;
        }
        axes::frame(root, axes::plot_bounds(chart.plotting_area()), upx(1.0))
    }
}

impl render::Draw for Figure<'_> {
    /// Draw the figure on `root`; `scale` multiplies font sizes, line widths
    /// and paddings (1.0 for 1000 x 750 px).
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        scale: f64,
    ) -> Result<(), ReportError> {
        // Header: title and margin summary.
        let (body, header_h) =
            render::draw_header(root, self.title, self.summary.as_deref(), scale)?;

        // Two plots of equal height sharing the frequency axis.
        let (width, height) = root.dim_in_pixel();
        let plot_h = stack::plot_height(height as i32 - header_h, 2, scale).max(10);
        let descs = ["Magnitude (dB)", "Phase (deg)"];
        let (y_desc, y_label_area) =
            stack::y_labels(descs, [&self.mag, &self.phase], plot_h, scale);
        let plot_w = stack::plot_width(width, y_label_area, scale);
        let x = freq_axis(self.x.lo, self.x.hi, f64::from(plot_w.max(10)), scale);
        let areas = stack::areas(&body, 2, plot_h, scale);
        let panels = [
            PanelSpec {
                y: &self.mag,
                y_desc: &y_desc[0],
                reference: 0.0,
                pieces: &self.mag_pieces,
                bar: |m| m.gm_bar,
                bar_label: "GM",
            },
            PanelSpec {
                y: &self.phase,
                y_desc: &y_desc[1],
                reference: self.phase_ref,
                pieces: &self.phase_pieces,
                bar: |m| m.pm_bar,
                bar_label: "PM",
            },
        ];
        for (i, (spec, area)) in panels.iter().zip(&areas).enumerate() {
            self.draw_panel((root, area), (i, &x, y_label_area), spec, scale)?;
        }
        Ok(())
    }
}

/// Thin solid grey horizontal reference line at `y` across `chart` (0 dB, -180 deg), if in
/// range. Solid, as the axis it marks is: the dash patterns tell the series apart.
fn reference_line<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    y: f64,
    scale: f64,
) -> Result<(), ReportError> {
    let (x_axis, y_axis) = (chart.x_range(), chart.y_range());
    if !(y_axis.start..=y_axis.end).contains(&y) {
        return Ok(());
    }
    let style = REF_COLOR.stroke_width(render::upx(scale)(1.0));
    let ends = vec![(x_axis.start, y), (x_axis.end, y)];
    chart
        .draw_series(std::iter::once(PathElement::new(ends, style)))
        .map_err(plot_err)?;
    Ok(())
}

/// Thin solid vertical lines at the crossover frequencies of the marked series, in its
/// colour, spanning the panel's value range `(lo, hi)`; none when several series are marked.
/// Solid, so that no dash pattern means both a series and a crossover.
fn crossover_lines<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    marks: &[Marks],
    (lo, hi): (f64, f64),
    scale: f64,
) -> Result<(), ReportError> {
    if marks.len() > 1 {
        return Ok(());
    }
    for m in marks {
        let style = series_color(m.series)
            .mix(0.9)
            .stroke_width(render::upx(scale)(1.0));
        let lines = m
            .crossovers
            .iter()
            .map(|&f| PathElement::new(vec![(f, lo), (f, hi)], style));
        chart.draw_series(lines).map_err(plot_err)?;
    }
    Ok(())
}

/// Thick vertical bar at `f` Hz between `a` and `b` (panel units) showing a
/// stability margin, labelled `label` to the left of its lower end, just
/// below it (above it when too close to the bottom of the panel). Left of the
/// crossover the curve lies above the lower end of the bar, so the label does
/// not sit on the curve the markers refer to.
fn margin_bar<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    f: f64,
    (a, b): (f64, f64),
    panel: &Axis,
    (label, color): (&'static str, RGBColor),
    scale: f64,
) -> Result<(), ReportError> {
    let px = render::px(scale);
    let font_size = 16.0 * scale;
    let lower = a.min(b);
    chart
        .draw_series(std::iter::once(PathElement::new(
            [(f, a), (f, b)],
            color.stroke_width((3.0 * scale).round().max(2.0) as u32),
        )))
        .map_err(plot_err)?;
    if label.is_empty() {
        return Ok(());
    }
    let (_, plot_h) = chart.plotting_area().dim_in_pixel();
    let below_px = (lower - panel.lo) / (panel.hi - panel.lo) * f64::from(plot_h);
    let (dy, vpos) = if below_px > 26.0 * scale {
        (px(7.0), VPos::Top)
    } else {
        (-px(7.0), VPos::Bottom)
    };
    let style = TextStyle::from((font::FAMILY, font_size).into_font())
        .color(&color)
        .pos(Pos::new(HPos::Right, vpos));
    chart
        .draw_series(std::iter::once(
            EmptyElement::at((f, lower)) + Text::new(label, (-px(6.0), dy), style),
        ))
        .map_err(plot_err)?;
    Ok(())
}

/// Stroke of series number `i` at `scale`: its palette colour, 2 px wide, the first series
/// solid, the others dashed, dotted, long-dashed, short-dashed and three dash-dot patterns in
/// turn (one pattern a series, as one colour a series, up to the palette's eight), so that
/// curves lying on top of each other stay distinguishable without colour.
fn series_stroke(i: usize, scale: f64) -> Stroke {
    const PATTERNS: [[f64; 4]; 7] = [
        [12.0, 6.0, 12.0, 6.0],
        [3.0, 4.0, 3.0, 4.0],
        [22.0, 6.0, 22.0, 6.0],
        [7.0, 3.0, 7.0, 3.0],
        [12.0, 4.0, 2.0, 4.0],
        [22.0, 4.0, 2.0, 4.0],
        [7.0, 3.0, 2.0, 3.0],
    ];
    let (px, upx) = (render::px(scale), render::upx(scale));
    Stroke {
        color: series_color(i),
        width: upx(2.0).max(2),
        pattern: (i > 0).then(|| PATTERNS[(i - 1) % PATTERNS.len()].map(|d| px(d).max(1))),
        dot_r: upx(3.0),
        opacity: 1.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// L(s) = k / (s (s/10 + 1) (s/100 + 1)), s = j 2 pi f, as a Bode series.
    fn loop_series(label: &str, k: f64, n: usize) -> BodeSeries {
        let mut s = BodeSeries {
            label: label.into(),
            ..Default::default()
        };
        let mut prev: Option<f64> = None;
        for i in 0..n {
            let f = 10f64.powf(-2.0 + 5.0 * i as f64 / (n - 1) as f64);
            let w = 2.0 * std::f64::consts::PI * f;
            // |L| and arg L, computed per factor.
            let mag =
                k / (w * (1.0 + (w / 10.0).powi(2)).sqrt() * (1.0 + (w / 100.0).powi(2)).sqrt());
            let ph = -90.0 - (w / 10.0).atan().to_degrees() - (w / 100.0).atan().to_degrees();
            if let Some(p) = prev {
                assert!((ph - p).abs() < 180.0);
            }
            prev = Some(ph);
            s.freq_hz.push(f);
            s.mag_db.push(20.0 * mag.log10());
            s.phase_deg.push(ph);
        }
        s
    }

    fn markers() -> BodeMarkers {
        BodeMarkers {
            gain_crossover_hz: Some(1.0),
            phase_crossover_hz: Some(5.0),
            gain_margin_db: Some(12.3),
            phase_margin_deg: Some(40.0),
        }
    }

    #[test]
    fn svg_single_series() {
        let svg = bode_svg("Open loop", &[loop_series("L1", 20.0, 200)], &[]).unwrap();
        assert!(svg.starts_with("<svg"), "{}", &svg[..50]);
        assert!(svg.trim_end().ends_with("</svg>"));
        for label in [
            "Magnitude (dB)",
            "Phase (deg)",
            "Frequency (Hz)",
            "Open loop",
        ] {
            assert!(svg.contains(label), "missing {label}");
        }
    }

    #[test]
    fn svg_multi_series_has_legend_and_markers() {
        let series = [
            loop_series("K = 20 &lt", 20.0, 300),
            loop_series("K = 60", 60.0, 300),
            loop_series("K = 200", 200.0, 300),
        ];
        let svg = bode_svg("Loops", &series, &[Some(markers())]).unwrap();
        assert!(svg.starts_with("<svg"));
        // Labels are XML-escaped.
        assert!(svg.contains("K = 20 &amp;lt"));
        assert!(svg.contains("K = 60"));
        assert!(svg.contains("K = 200"));
        assert!(svg.contains("GM = 12.3 dB @ 5.00 Hz"));
        assert!(svg.contains("PM = 40.0° @ 1.00 Hz"));
    }

    #[test]
    fn compare_keeps_each_series_markers_in_its_colour_and_dashes() {
        let series = [loop_series("a", 20.0, 300), loop_series("b", 60.0, 300)];
        let other = BodeMarkers {
            gain_margin_db: Some(3.5),
            phase_crossover_hz: Some(8.0),
            phase_margin_deg: Some(20.0),
            gain_crossover_hz: Some(2.0),
        };
        let svg = bode_svg("Compare", &series, &[Some(markers()), Some(other)]).unwrap();
        assert_eq!(crate::plot::text_overflow(&svg), Vec::<String>::new());
        // Both series' margins are summarised under the title, each named.
        let text: String = svg.split_whitespace().collect::<Vec<_>>().join(" ");
        assert!(text.contains("a: GM = 12.3 dB @ 5.00 Hz"), "{text}");
        assert!(text.contains("b: GM = 3.5 dB @ 8.00 Hz"));
        // GM and PM bars in each series' colour, labelled for the first series only (close
        // bars would overprint their labels).
        let labels = |colour: &str, l: &str| {
            svg.split("<text")
                .filter(|t| {
                    t.contains(&format!("fill=\"{colour}\"")) && t.contains(&format!(">\n{l}\n"))
                })
                .count()
        };
        for l in ["GM", "PM"] {
            assert_eq!(labels("#0072B2", l), 1, "{l} of a");
            assert_eq!(labels("#D55E00", l), 0, "{l} of b");
            let bars = |colour: &str| {
                svg.lines()
                    .filter(|t| t.contains(&format!("stroke=\"{colour}\" stroke-width=\"3\"")))
                    .count()
            };
            assert_eq!((bars("#0072B2"), bars("#D55E00")), (2, 2), "GM and PM bars");
        }
        // The second series is dashed, the first solid: each curve is one path whose dash
        // pattern the SVG states, and so does its legend sample.
        let patterns = |colour: &str| {
            let mut p: Vec<&str> = svg
                .lines()
                .filter(|l| l.starts_with("<polyline") && l.contains("stroke-width=\"2\""))
                .filter(|l| l.contains(&format!("stroke=\"{colour}\"")))
                .map(|l| {
                    l.split("stroke-dasharray=\"")
                        .nth(1)
                        .map_or("solid", |d| d.split('"').next().unwrap())
                })
                .collect();
            p.sort_unstable();
            p.dedup();
            p
        };
        assert_eq!(patterns("#0072B2"), ["solid"]);
        assert_eq!(patterns("#D55E00"), ["12 6"]);
        // Markers for the first series only mark the first series only.
        let old = bode_svg("Compare", &series, &[Some(markers())]).unwrap();
        assert!(old.contains("GM = 12.3 dB @ 5.00 Hz") && !old.contains("3.5 dB"));
        // Crossover verticals (thin solid lines in the series' colour) for one marked series,
        // two crossovers on each panel, none when several are marked: they would crowd the
        // crossover region.
        let verticals = |svg: &str| {
            svg.lines()
                .filter(|l| l.starts_with("<polyline") && l.contains("opacity=\"0.9\""))
                .count()
        };
        assert_eq!(verticals(&old), 4);
        assert_eq!(verticals(&svg), 0);
    }

    #[test]
    fn png_signature_and_size() {
        let png = bode_png(
            "PNG",
            &[loop_series("a", 20.0, 150), loop_series("b", 60.0, 150)],
            &[Some(markers())],
            800,
            600,
        )
        .unwrap();
        let rgb = render::decode_png(&png, 800, 600);
        // Not a blank image: some dark pixels (text, curves).
        assert!(render::dark_pixels(&rgb) > 1000);
    }

    #[test]
    fn long_title_stays_inside_a_small_figure() {
        // 300 characters with spaces, and one unbreakable path, on a 640 px wide figure.
        let words: String = (0..43).map(|i| format!("word{i:02} ")).collect();
        let title: String = words.chars().take(300).collect();
        assert_eq!(title.chars().count(), 300);
        let path = format!("/data/{}/step_damping.csv", "x".repeat(280));
        let s = [loop_series("a", 20.0, 80), loop_series("b", 60.0, 80)];
        for t in [title.as_str(), path.as_str()] {
            let fig = Figure::prepare(t, &s, &[Some(markers()), None]).unwrap();
            let svg = render::to_svg(&fig, (640, 480)).unwrap();
            assert_eq!(crate::plot::text_overflow(&svg), Vec::<String>::new());
            // The header keeps both ends of the text, shortened in the middle.
            assert!(svg.contains('…'));
            assert!(svg.contains(if t == path {
                "step_damping.csv"
            } else {
                "word42"
            }));
        }
        // The unshortened title on one line would overflow: the check can fail.
        let svg = format!(
            "<svg viewBox=\"0 0 640 480\"><text x=\"320\" y=\"14\" dy=\"0.76em\" \
             text-anchor=\"middle\" font-size=\"19.35\">{title}</text></svg>"
        );
        assert_eq!(crate::plot::text_overflow(&svg).len(), 1);
    }

    #[test]
    fn png_bad_size_is_an_error() {
        let s = [loop_series("a", 20.0, 50)];
        assert!(matches!(
            bode_png("x", &s, &[], 0, 600),
            Err(ReportError::Plot(_))
        ));
        assert!(matches!(
            bode_png("x", &s, &[], 100_000, 600),
            Err(ReportError::Plot(_))
        ));
    }

    #[test]
    fn empty_input_is_empty_error() {
        assert!(matches!(
            bode_svg("x", &[], &[]),
            Err(ReportError::Empty(_))
        ));
        let empty = BodeSeries {
            label: "e".into(),
            ..Default::default()
        };
        assert!(matches!(
            bode_svg("x", std::slice::from_ref(&empty), &[]),
            Err(ReportError::Empty(_))
        ));
        assert!(matches!(
            bode_png("x", &[empty], &[], 640, 480),
            Err(ReportError::Empty(_))
        ));
        let all_nan = BodeSeries {
            label: "n".into(),
            freq_hz: vec![1.0, 2.0, f64::NAN],
            mag_db: vec![f64::NAN, f64::INFINITY, 1.0],
            phase_deg: vec![f64::NAN, f64::NEG_INFINITY, 1.0],
        };
        let err = bode_svg("x", &[all_nan], &[]).unwrap_err();
        assert!(matches!(err, ReportError::Empty(_)));
        assert!(err.to_string().starts_with("plot: no data to draw: "));
    }

    #[test]
    fn length_mismatch_is_plot_error() {
        let bad = BodeSeries {
            label: "bad".into(),
            freq_hz: vec![1.0, 2.0],
            mag_db: vec![0.0],
            phase_deg: vec![0.0, 1.0],
        };
        assert!(matches!(
            bode_svg("x", &[bad], &[]),
            Err(ReportError::Plot(_))
        ));
    }

    #[test]
    fn nan_and_inf_do_not_panic() {
        let mut s = loop_series("holes", 20.0, 100);
        s.mag_db[10] = f64::NAN;
        s.mag_db[11] = f64::INFINITY;
        s.phase_deg[50] = f64::NAN;
        s.freq_hz[70] = f64::NAN;
        s.freq_hz[71] = -1.0;
        s.mag_db[90] = f64::NEG_INFINITY;
        let odd_markers = BodeMarkers {
            gain_crossover_hz: Some(f64::NAN),
            phase_crossover_hz: Some(-3.0),
            gain_margin_db: Some(f64::INFINITY),
            phase_margin_deg: Some(f64::NAN),
        };
        let other = loop_series("other", 60.0, 100);
        let series = [s, other];
        let svg = bode_svg("holes", &series, &[Some(odd_markers)]).unwrap();
        assert!(svg.contains("GM = ∞ dB"));
        bode_png("holes", &series, &[Some(markers())], 640, 480).unwrap();

        // Only magnitude finite, single points, constant data, one frequency.
        let lonely = BodeSeries {
            label: "lonely".into(),
            freq_hz: vec![1.0, 2.0, 3.0],
            mag_db: vec![5.0, f64::NAN, 5.0],
            phase_deg: vec![f64::NAN; 3],
        };
        bode_svg("lonely", &[lonely], &[Some(markers())]).unwrap();
        let single = BodeSeries {
            label: "single".into(),
            freq_hz: vec![3.0],
            mag_db: vec![-1.0],
            phase_deg: vec![-10.0],
        };
        bode_png("single", &[single], &[], 640, 480).unwrap();
    }

    #[test]
    fn huge_dynamic_range_is_clamped() {
        let f: Vec<f64> = (0..100).map(|i| 10f64.powf(i as f64 / 20.0)).collect();
        let s = BodeSeries {
            label: "steep".into(),
            mag_db: (0..100).map(|i| 150.0 - 4.5 * i as f64).collect(),
            phase_deg: vec![-90.0; 100],
            freq_hz: f,
        };
        // it crosses 0 dB: the panel shows the crossover region, the rest clipped
        let fig = Figure::prepare("t", std::slice::from_ref(&s), &[None]).unwrap();
        assert!(
            fig.mag.lo >= -CROSSOVER_WINDOW_DB - 25.0 && fig.mag.hi <= CROSSOVER_WINDOW_DB + 25.0,
            "{:?}",
            fig.mag
        );
        assert!(fig.mag.lo < 0.0 && fig.mag.hi > 0.0);
        for line in &fig.mag_pieces[0].lines {
            assert!(line
                .iter()
                .all(|&(_, v)| v >= fig.mag.lo && v <= fig.mag.hi));
        }
        bode_svg("steep", std::slice::from_ref(&s), &[]).unwrap();
        // a gain margin beyond the window widens it to hold the bar
        let deep = BodeMarkers {
            gain_margin_db: Some(90.0),
            ..BodeMarkers::default()
        };
        let gentle = BodeSeries {
            label: "gentle".into(),
            mag_db: (0..100).map(|i| 50.0 - 3.0 * i as f64).collect(),
            ..s.clone()
        };
        let fig = Figure::prepare("t", std::slice::from_ref(&gentle), &[Some(deep)]).unwrap();
        assert!(fig.mag.lo <= -90.0, "{:?}", fig.mag);
        let fig = Figure::prepare("t", std::slice::from_ref(&gentle), &[None]).unwrap();
        assert!(fig.mag.lo >= -CROSSOVER_WINDOW_DB - 25.0, "{:?}", fig.mag);
        // a magnitude that never reaches 0 dB keeps MAG_WINDOW_DB below its maximum
        let high = BodeSeries {
            label: "high".into(),
            mag_db: s.mag_db.iter().map(|m| m + 400.0).collect(),
            ..s
        };
        let fig = Figure::prepare("t", std::slice::from_ref(&high), &[None]).unwrap();
        assert!(fig.mag.hi >= 550.0, "{:?}", fig.mag);
        assert!(fig.mag.lo >= 550.0 - MAG_WINDOW_DB - 25.0, "{:?}", fig.mag);
    }

    #[test]
    fn clipping_breaks_lines() {
        let f = [1.0, 10.0, 100.0, 1000.0];
        let v = [0.0, 20.0, 0.0, f64::NAN];
        let p = clip_pieces(&f, &v, -5.0, 10.0);
        assert_eq!(p.lines.len(), 2);
        assert_eq!(p.lines[0].len(), 2);
        assert!((p.lines[0][1].1 - 10.0).abs() < 1e-12);
        assert!((p.lines[0][1].0 - 10f64.sqrt()).abs() < 1e-9);
        assert!((p.lines[1][0].1 - 10.0).abs() < 1e-12);
        let p = clip_pieces(&[1.0, 2.0, 3.0], &[1.0, f64::NAN, 2.0], 0.0, 3.0);
        assert!(p.lines.is_empty());
        assert_eq!(p.dots, vec![(1.0, 1.0), (3.0, 2.0)]);
    }

    #[test]
    fn ticks() {
        let t = freq_axis(0.01, 1000.0, NOMINAL_PLOT_W, 1.0);
        assert_eq!(t.major.len(), 6);
        assert_eq!(t.labels[0], "0.01");
        assert_eq!(t.labels[5], "1000");
        let t = freq_axis(2.0, 8.0, NOMINAL_PLOT_W, 1.0);
        assert!(t.major.len() >= 2);
        // A single frequency gets a band around it.
        let t = freq_axis(5.0, 5.0, NOMINAL_PLOT_W, 1.0);
        assert!(t.lo < 5.0 && t.hi > 5.0 && t.major.len() >= 2, "{t:?}");
        let p = value_ticks(-250.0, -90.0, Some(-180.0), &phase_steps(), 9.0, 20.0);
        assert!(p.major.iter().all(|v| v % 45.0 == 0.0), "{p:?}");
        assert!(p.lo <= -250.0 && p.hi >= -90.0);
        let m = value_ticks(-80.0, 40.0, Some(0.0), &steps_125(120.0, 8.0), 8.0, 10.0);
        assert!(m.major.contains(&0.0));
        assert_eq!(format_freq_hz(4.5678), "4.57");
        assert_eq!(format_freq_hz(0.012345), "0.0123");
        assert_eq!(format_freq_hz(1234.4), "1234");
    }

    #[test]
    fn interpolation() {
        let f = [1.0, 10.0, 100.0];
        let v = [0.0, -20.0, f64::NAN];
        assert!((interpolate_at(&f, &v, 10f64.sqrt()).unwrap() + 10.0).abs() < 1e-9);
        assert_eq!(interpolate_at(&f, &v, 50.0), None);
        assert_eq!(interpolate_at(&f, &v, 0.5), None);
    }
}
