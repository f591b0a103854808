//! Figures of pumpcyl's results, assembled from the plotting primitives of [`crate::plot`]:
//! the four-panel signal figure (position, control error, pressures, motor speeds; the
//! article's Figure 6 layout), the drive step (the article §2.4.1), β_e and the margins against
//! pressure (docs/bulk-modulus.md), Bode overlays and the identification cost landscape.
//!
//! Each is a [`Chart`], rendered in memory as SVG ([`Chart::svg`]) or PNG ([`Chart::png`]);
//! writing the bytes is the caller's job (the command line, [`crate::reproduce`]).

use crate::plot::{
    self, BodeMarkers, BodeSeries, HeatMap, LineStyle, Marker, Panel, ReportError, Trace,
};
use pumpcyl::bulk::Row;
use pumpcyl::design::robust::StrokeCurve;
use pumpcyl::design::RobustDesign;
use pumpcyl::ident::{DriveFit, DriveRecord, Profile, Uncertainty, PARAMETERS};
use pumpcyl::lti::Margins;
use pumpcyl::response::Signals;

/// What a [`Chart`] draws.
#[derive(Debug, Clone)]
pub enum Plot {
    /// Panels stacked over one time axis (s).
    Time(Vec<Panel>),
    /// Panels stacked over one x axis named `x_label` (with its unit).
    Xy {
        /// The x axis label, unit included.
        x_label: String,
        /// The panels, first on top.
        panels: Vec<Panel>,
    },
    /// Panels stacked over one x axis of categories (docs/formats.md#figures): the traces' x
    /// values are category numbers, the k-th of `categories` (k from 1) at x = k.
    Categories {
        /// The x axis label.
        x_label: String,
        /// The names of the categories, ticked on the x axis.
        categories: Vec<String>,
        /// The panels, first on top.
        panels: Vec<Panel>,
    },
    /// A Bode diagram of one or more series, each with its margin markers when given.
    Bode {
        /// The overlaid series.
        series: Vec<BodeSeries>,
        /// Crossings and margins to mark: `markers[i]` belongs to `series[i]` (missing or
        /// `None` entries are not marked).
        markers: Vec<Option<BodeMarkers>>,
    },
    /// A cost heat map with labelled markers.
    HeatMap {
        /// The map.
        map: HeatMap,
        /// Points to mark.
        markers: Vec<Marker>,
    },
}

/// A figure: its title, an optional subtitle and what it plots.
#[derive(Debug, Clone)]
pub struct Chart {
    /// The title printed at the top.
    pub title: String,
    /// A smaller line under the title (metrics, a notice).
    pub subtitle: Option<String>,
    /// What is drawn.
    pub plot: Plot,
}

/// PNG sizes (px) of each kind of plot: the sizes pumpcyl has always written.
const TIME_PNG: (u32, u32) = (1500, 1500);
const XY_PNG: (u32, u32) = (1500, 1200);
const BODE_PNG: (u32, u32) = (1500, 1125);
const HEATMAP_PNG: (u32, u32) = (1350, 1050);

impl Chart {
    /// The figure as an SVG document.
    ///
    /// # Errors
    /// As the [`crate::plot`] function it calls: nothing finite to draw, or plotting fails.
    pub fn svg(&self) -> Result<String, ReportError> {
        let (title, sub) = (self.title.as_str(), self.subtitle.as_deref());
        match &self.plot {
            Plot::Time(panels) => plot::panels_svg(title, sub, panels),
            Plot::Xy { x_label, panels } => plot::panels_xy_svg(title, sub, x_label, panels),
            Plot::Categories {
                x_label,
                categories,
                panels,
            } => plot::panels_categorical_svg(title, sub, (x_label, categories), panels),
            Plot::Bode { series, markers } => plot::bode_svg(title, series, markers),
            Plot::HeatMap { map, markers } => plot::heatmap_svg(title, sub, map, markers),
        }
    }

    /// The figure as a PNG file.
    ///
    /// # Errors
    /// As [`Chart::svg`].
    pub fn png(&self) -> Result<Vec<u8>, ReportError> {
        let (title, sub) = (self.title.as_str(), self.subtitle.as_deref());
        match &self.plot {
            Plot::Time(panels) => plot::panels_png(title, sub, panels, TIME_PNG.0, TIME_PNG.1),
            Plot::Xy { x_label, panels } => {
                plot::panels_xy_png(title, sub, x_label, panels, XY_PNG.0, XY_PNG.1)
            }
            Plot::Categories {
                x_label,
                categories,
                panels,
            } => {
                let x = (x_label.as_str(), &categories[..]);
                plot::panels_categorical_png(title, sub, x, panels, XY_PNG.0, XY_PNG.1)
            }
            Plot::Bode { series, markers } => {
                plot::bode_png(title, series, markers, BODE_PNG.0, BODE_PNG.1)
            }
            Plot::HeatMap { map, markers } => {
                plot::heatmap_png(title, sub, map, markers, HEATMAP_PNG.0, HEATMAP_PNG.1)
            }
        }
    }

    /// Panels over time.
    pub fn time(title: &str, subtitle: Option<&str>, panels: Vec<Panel>) -> Chart {
        Chart {
            title: title.to_string(),
            subtitle: subtitle.map(str::to_string),
            plot: Plot::Time(panels),
        }
    }

    /// Position and reference, control error, pressures, motor speeds of simulated `series`
    /// (labelled) and a `measured` record; with `fit_end_s` (s), a dashed vertical line on every
    /// panel marks the end of the fit window (as the article's Figure 6 does).
    pub fn signals(
        title: &str,
        subtitle: Option<&str>,
        series: &[(String, &Signals)],
        measured: Option<&Signals>,
        fit_end_s: Option<f64>,
    ) -> Chart {
        Chart::signals_of(
            title,
            subtitle,
            series,
            measured.map(|m| ("measured", m)),
            fit_end_s,
        )
    }

    /// As [`Chart::signals`], the record named `record.0` in the legend (e.g. "emulated").
    pub fn signals_of(
        title: &str,
        subtitle: Option<&str>,
        series: &[(String, &Signals)],
        record: Option<(&str, &Signals)>,
        fit_end_s: Option<f64>,
    ) -> Chart {
        let mut panels = four_panels_named(series, record);
        if let Some(t) = fit_end_s {
            mark_fit_end(&mut panels, t);
        }
        Chart::time(title, subtitle, panels)
    }

    /// The chart with every trace labelled `from` labelled `to` instead.
    pub fn relabel(mut self, from: &str, to: &str) -> Chart {
        if let Plot::Time(panels) | Plot::Xy { panels, .. } | Plot::Categories { panels, .. } =
            &mut self.plot
        {
            for t in panels.iter_mut().flat_map(|p| &mut p.traces) {
                if t.label == from {
                    t.label = to.to_string();
                }
            }
        }
        self
    }

    /// A drive step record (the article §2.4.1): reference, measured speed and the identified
    /// model's speed (rpm).
    pub fn drive_step(rec: &DriveRecord, fit: &DriveFit) -> Chart {
        let t = &rec.time_s;
        let panels = vec![Panel {
            y_label: "Motor speed (rpm)".into(),
            traces: vec![
                trace("reference", t, &rec.w_ref_rpm, LineStyle::Dashed, Some(6)),
                trace("measured", t, &rec.w_rpm, LineStyle::Solid, Some(0)),
                trace(
                    &format!("model, Km = {:.4}", fit.km_nms_per_rad),
                    t,
                    &fit.w_sim_rpm,
                    LineStyle::Solid,
                    Some(1),
                ),
            ],
            ..Default::default()
        }];
        let subtitle = format!("fit RMS error {:.2} rpm", fit.mse_rpm2.sqrt());
        Chart::time(
            &format!("Drive step: {}", crate::format::shown_name(&rec.file)),
            Some(&subtitle),
            panels,
        )
    }

    /// β_e, gain margin and phase margin against mean chamber pressure (docs/bulk-modulus.md);
    /// `fit` is (β bar, at mean pressure bar, β_oil bar) the gas fraction `x` of `model` came
    /// from; the subtitle names the model.
    pub fn bulk_modulus(
        fit: (f64, f64, f64),
        (model, x): (pumpcyl::bulk::BulkModel, f64),
        rows: &[Row],
    ) -> Chart {
        let p: Vec<f64> = rows.iter().map(|r| r.p_bar).collect();
        let line = |label: &str, y: Vec<f64>, color: usize| {
            trace(label, &p, &y, LineStyle::Solid, Some(color))
        };
        let nan = |v: Option<f64>| v.unwrap_or(f64::NAN);
        let panels = vec![
            Panel {
                y_label: "Effective bulk modulus (bar)".into(),
                traces: vec![line("β_e", rows.iter().map(|r| r.beta_bar).collect(), 0)],
                ..Default::default()
            },
            Panel {
                y_label: "Gain margin (dB)".into(),
                traces: vec![
                    line(
                        "GM",
                        rows.iter().map(|r| nan(r.gain_margin_db)).collect(),
                        1,
                    ),
                    line("stability limit", vec![0.0; p.len()], 6),
                ],
                ..Default::default()
            },
            Panel {
                y_label: "Phase margin (deg)".into(),
                traces: vec![
                    line(
                        "PM",
                        rows.iter().map(|r| nan(r.phase_margin_deg)).collect(),
                        2,
                    ),
                    line("stability limit", vec![0.0; p.len()], 6),
                ],
                ..Default::default()
            },
        ];
        Chart {
            title: "Effective bulk modulus and margins against mean chamber pressure".into(),
            subtitle: Some(format!(
                "{} model: gas fraction X = {x:.4} from {} bar at {} bar (β_oil {} bar); below 0 dB / 0 deg the loop is unstable",
                model.described(),
                plot::sig(fit.0, 4),
                plot::sig(fit.1, 4),
                plot::sig(fit.2, 4)
            )),
            plot: Plot::Xy {
                x_label: "Mean chamber pressure (bar)".into(),
                panels,
            },
        }
    }

    /// A Bode diagram of `series`, each marked with its crossings and margins `markers[i]`
    /// when given (in the series' colour, summarised under the title).
    pub fn bode(title: &str, series: Vec<BodeSeries>, markers: Vec<Option<BodeMarkers>>) -> Chart {
        Chart {
            title: title.to_string(),
            subtitle: None,
            plot: Plot::Bode { series, markers },
        }
    }
}

impl Chart {
    /// The likelihood profile `p` of an uncertainty analysis (docs/identification.md,
    /// "Uncertainty"): ΔSSE/σ² against the parameter, with the χ²₁ threshold dashed; points
    /// above three times the threshold are left out so that the region near the interval stays
    /// readable.
    pub fn profile(u: &Uncertainty, p: &Profile) -> Chart {
        let i = parameter_index(p.parameter);
        let shown: Vec<_> = p
            .points
            .iter()
            .filter(|q| q.statistic <= 3.0 * u.threshold)
            .collect();
        let x: Vec<f64> = shown.iter().map(|q| q.value).collect();
        let y: Vec<f64> = shown.iter().map(|q| q.statistic).collect();
        let threshold = vec![u.threshold; x.len()];
        let panels = vec![Panel {
            y_label: "ΔSSE / σ²".into(),
            traces: vec![
                trace("profile", &x, &y, LineStyle::Solid, Some(0)),
                trace(
                    &format!("χ²₁({})", u.confidence),
                    &x,
                    &threshold,
                    LineStyle::Dashed,
                    Some(6),
                ),
            ],
            ..Default::default()
        }];
        let end = |k: usize| {
            let v = parameter_value(i, p.interval[k]);
            if p.crossed[k] {
                v
            } else {
                format!("{v} (search bound)")
            }
        };
        let verdict = if p.identifiable {
            ""
        } else {
            ", not identifiable from these records"
        };
        let subtitle = format!(
            "{:.0} % interval {} .. {} {}{verdict}; noise σ {:.4} mm",
            100.0 * u.confidence,
            end(0),
            end(1),
            PARAMETER_UNITS[i],
            u.noise_std_mm
        );
        Chart {
            title: format!("Likelihood profile of {}", PARAMETER_NAMES[i]),
            subtitle: Some(subtitle),
            plot: Plot::Xy {
                x_label: PARAMETER_AXES[i].into(),
                panels,
            },
        }
    }

    /// The margins of a robust design (docs/design.md#robust-design) over the stroke at the
    /// deciding parameter point and the robust Kp: PM and GM, one line per mass and pressure,
    /// the targets dashed.
    pub fn robust_margins(d: &RobustDesign) -> Chart {
        let xs = d.stroke_curves.first().map_or(&[][..], |c| &c.x_mm[..]);
        let span = match (xs.first(), xs.last()) {
            (Some(&a), Some(&b)) => vec![a, b],
            _ => Vec::new(),
        };
        let panel = |y_label: &str, target: f64, pick: fn(&StrokeCurve) -> &Vec<Option<f64>>| {
            let mut traces: Vec<Trace> = d
                .stroke_curves
                .iter()
                .enumerate()
                .map(|(i, c)| {
                    let (x, y): (Vec<f64>, Vec<f64>) = c
                        .x_mm
                        .iter()
                        .zip(pick(c))
                        .filter_map(|(&x, v)| v.map(|v| (x, v)))
                        .unzip();
                    let p = c
                        .p_mean_bar
                        .map_or(String::new(), |p| format!(", p {p:.2} bar"));
                    trace(
                        &format!("m {} kg{p}", c.mass_kg),
                        &x,
                        &y,
                        LineStyle::Solid,
                        Some(i),
                    )
                })
                .collect();
            traces.push(trace(
                "target",
                &span,
                &vec![target; span.len()],
                LineStyle::Dashed,
                Some(6),
            ));
            Panel {
                y_label: y_label.into(),
                traces,
                ..Default::default()
            }
        };
        let at = &d.deciding.at;
        Chart {
            title: format!("Margins over the stroke at Kp = {:.2} (robust)", d.kp_max),
            subtitle: Some(format!(
                "deciding parameters: β {:.1} bar, b {:.0} N·s/m, c12 {:.3e} m⁵/(N·s)",
                at.beta_bar, at.viscous_friction_ns_per_m, at.c12_m5_per_ns
            )),
            plot: Plot::Xy {
                x_label: "Piston position x (mm)".into(),
                panels: vec![
                    panel("Phase margin (deg)", d.targets.pm_deg, |c| {
                        &c.phase_margin_deg
                    }),
                    panel("Gain margin (dB)", d.targets.gm_db, |c| &c.gain_margin_db),
                ],
            },
        }
    }
}

/// The margin markers of a Bode diagram for the margins `m` of its loop.
pub fn bode_markers(m: &Margins) -> BodeMarkers {
    BodeMarkers {
        gain_crossover_hz: m.gain_crossover_hz,
        phase_crossover_hz: m.phase_crossover_hz,
        gain_margin_db: m.gain_margin_db,
        phase_margin_deg: m.phase_margin_deg,
    }
}

/// Units of the identified parameters, in the order of [`PARAMETERS`].
pub const PARAMETER_UNITS: [&str; 3] = ["bar", "N·s/m", "m⁵/(N·s)"];

/// Names of the identified parameters for titles, in the order of [`PARAMETERS`].
pub const PARAMETER_NAMES: [&str; 3] = [
    "the bulk modulus β",
    "the viscous friction b",
    "the cross-port leakage c12",
];

/// Axis labels of the identified parameters, in the order of [`PARAMETERS`].
pub const PARAMETER_AXES: [&str; 3] = [
    "Bulk modulus β (bar)",
    "Viscous friction b (N·s/m)",
    "Cross-port leakage c12 (m⁵/(N·s))",
];

/// Index of a parameter name in [`PARAMETERS`] (0 for an unknown name).
pub fn parameter_index(name: &str) -> usize {
    PARAMETERS.iter().position(|&p| p == name).unwrap_or(0)
}

/// A value of parameter `i` of [`PARAMETERS`] as text: β and b with one decimal, c12 in
/// scientific notation with four.
pub fn parameter_value(i: usize, v: f64) -> String {
    if i == 2 {
        format!("{v:.4e}")
    } else {
        format!("{v:.1}")
    }
}

/// `s` about its own operating point: reference and position minus `x0_mm` (mm), so responses
/// at different strokes overlay (the other signals unchanged).
pub fn about_operating_point(s: &Signals, x0_mm: f64) -> Signals {
    let shift = |v: &[f64]| v.iter().map(|x| x - x0_mm).collect();
    Signals {
        x_ref_mm: shift(&s.x_ref_mm),
        x_mm: shift(&s.x_mm),
        ..s.clone()
    }
}

/// A trace of `y` against `t`.
pub fn trace(label: &str, t: &[f64], y: &[f64], style: LineStyle, color: Option<usize>) -> Trace {
    Trace {
        label: label.to_string(),
        t_s: t.to_vec(),
        y: y.to_vec(),
        style,
        color,
    }
}

/// The style of the second chamber's pressure and the second motor's speed in the signal
/// figures, and the legend note saying so (the same in the pressure and speed panels: one
/// meaning).
const SECOND_CHAMBER: LineStyle = LineStyle::Dotted;
const CHAMBER_NOTE: &str = "solid: p1, ω1; dotted: p2, ω2";

/// A dashed dark grey vertical line at `t_s` over the full height of every panel, labelled
/// once.
fn mark_fit_end(panels: &mut [Panel], t_s: f64) {
    for (i, panel) in panels.iter_mut().enumerate() {
        let label = if i == 0 { "end of fit window" } else { "" };
        panel.traces.push(trace(
            label,
            &[t_s, t_s],
            &[f64::NEG_INFINITY, f64::INFINITY],
            LineStyle::Dashed,
            Some(7),
        ));
    }
}

/// Position and reference, control error, pressures, motor speeds; the measured record (if any)
/// first, simulated series after it, every series solid and told apart by its colour alone,
/// the same in every panel, and named once, in the legend of the position panel; the reference
/// is solid black. In the pressure and speed panels the first chamber (motor) is drawn solid
/// and the second dotted, as one note in both panels says, so that within the figure dotted
/// means p2 and ω2 only and dashed the end of the fit window only ([`Chart::signals`]).
/// The record is named `record.0`.
fn four_panels_named(
    series: &[(String, &Signals)],
    record: Option<(&str, &Signals)>,
) -> Vec<Panel> {
    let mut panels: Vec<Panel> = [
        "Position (mm)",
        "Control error (mm)",
        "Pressure (bar)",
        "Motor speed (rpm)",
    ]
    .iter()
    .map(|l| Panel {
        y_label: l.to_string(),
        traces: Vec::new(),
        ..Default::default()
    })
    .collect();
    let Some(first) = record.map(|r| r.1).or(series.first().map(|s| s.1)) else {
        return panels;
    };
    panels[0].traces.push(trace(
        "x_ref",
        &first.time_s,
        &first.x_ref_mm,
        LineStyle::Solid,
        Some(6),
    ));
    let mut add = |label: &str, s: &Signals, color: usize| {
        let t = &s.time_s;
        let mut push = |panel: usize, name: &str, y: &[f64], style: LineStyle| {
            if !y.is_empty() {
                panels[panel]
                    .traces
                    .push(trace(name, t, y, style, Some(color)));
            }
        };
        let x_label = if label.is_empty() { "x" } else { label };
        push(0, x_label, &s.x_mm, LineStyle::Solid);
        push(1, "", &s.e_mm, LineStyle::Solid);
        push(2, "", &s.p1_bar, LineStyle::Solid);
        push(2, "", &s.p2_bar, SECOND_CHAMBER);
        push(3, "", &s.w1_rpm, LineStyle::Solid);
        push(3, "", &s.w2_rpm, SECOND_CHAMBER);
    };
    if let Some((name, m)) = record {
        add(name, m, 0);
    }
    let offset = usize::from(record.is_some());
    for (i, (label, s)) in series.iter().enumerate() {
        let label = if series.len() == 1 && record.is_none() {
            ""
        } else {
            label.as_str()
        };
        add(label, s, i + offset);
    }
    for panel in &mut panels[2..] {
        if !panel.traces.is_empty() {
            panel
                .traces
                .push(trace(CHAMBER_NOTE, &[], &[], LineStyle::Solid, None));
        }
    }
    panels
}

#[cfg(test)]
mod tests {
    use super::*;
    use pumpcyl::response::{step, Baseline};
    use pumpcyl::rig::Rig;

    #[test]
    fn steps_at_different_strokes_start_together_about_their_operating_points() {
        let starts: Vec<(f64, f64)> = [-50.0, 0.0, 50.0]
            .iter()
            .map(|dx| {
                let rig = Rig {
                    x0_mm: Rig::default().x0_mm + dx,
                    ..Rig::default()
                };
                let s = step(&rig, 5.0, 0.5, 100.0).unwrap();
                let base = Baseline::of_rig(&rig);
                let about = about_operating_point(&s, base.x_mm);
                // the reference stands off the position by the loop's rest offset
                let offset = base.x_ref_mm - base.x_mm;
                assert!(about
                    .x_ref_mm
                    .iter()
                    .all(|r| (r - 5.0 - offset).abs() < 1e-9));
                assert_eq!(about.p1_bar, s.p1_bar, "only the position moves");
                (s.x_mm[0], about.x_mm[0])
            })
            .collect();
        // absolute positions 50 mm apart; about x0 all at rest at 0
        assert!((starts[2].0 - starts[0].0 - 100.0).abs() < 1e-6);
        assert!(starts.iter().all(|s| s.1.abs() < 1e-6), "{starts:?}");
    }

    #[test]
    fn a_fit_window_is_marked_on_every_panel_and_labelled_once() {
        let s = step(&Rig::default(), 5.0, 1.0, 100.0).unwrap();
        let chart = Chart::signals("t", None, &[("model".into(), &s)], Some(&s), Some(0.5));
        let Plot::Time(panels) = &chart.plot else {
            panic!("a time plot")
        };
        assert_eq!(panels.len(), 4);
        let marks: Vec<&Trace> = panels
            .iter()
            .filter_map(|p| p.traces.last())
            .filter(|t| t.style == LineStyle::Dashed && t.t_s == [0.5, 0.5])
            .collect();
        assert_eq!(marks.len(), 4);
        assert_eq!(
            marks.iter().filter(|t| !t.label.is_empty()).count(),
            1,
            "one legend entry"
        );
    }
}
