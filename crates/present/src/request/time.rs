//! The time-domain requests: `step` and `track` (docs/simulation.md), each on the nominal rig
//! and on every variant it is compared with.

use super::{check_field, Document, FieldError, Given, Hooks, Request, RigInput};
use crate::documents::{rating_warning_lines, step_document, with_warnings};
use crate::figures::Chart;
use crate::time::{
    series, signals_csv, simulate_json, simulate_mat, simulate_series, simulate_subtitle,
    simulate_text, simulate_title, step_mat, step_subtitle, step_text, step_title, track_chart,
    track_json, track_mat, track_series, track_text, Run, Runs, StepSetup, Unstable,
};
use anyhow::Context as _;
use pumpcyl::lti::LtiError;
use pumpcyl::record::Record;
use pumpcyl::response::{self, Baseline, Signals, StepMetrics, TrackMetrics, ARTICLE_SINE_CASES};
use pumpcyl::rig::Rig;
use serde_json::Value;

/// Below this step size (mm) a step warns: a step that small is probably metres given as
/// millimetres.
pub const STEP_WARN_BELOW_MM: f64 = 0.05;

/// The nominal rig and each variant of `compare` (`KEY=VALUE[,KEY=VALUE...]` on top of the
/// rig), labelled.
fn variants(rig: &Rig, compare: &[String]) -> anyhow::Result<Vec<(String, Rig)>> {
    let mut out = vec![("nominal".to_string(), rig.clone())];
    for c in compare {
        let overrides: Vec<String> = c.split(',').map(|s| s.trim().to_string()).collect();
        let v = rig
            .with_overrides_from("--set", &overrides)
            .map_err(|e| FieldError::new("compare", Given::Text(c.clone()), e.to_string()))?;
        out.push((c.clone(), v));
    }
    Ok(out)
}

/// Run `f` (signals and metrics) on the nominal rig and on each variant of `compare`, each
/// run's signals checked against its rig's drive ratings
/// ([`response::signals_over_ratings`]). An unstable nominal rig is an error; an unstable
/// variant is set aside with its reason (its response would only grow).
fn run_variants<M>(
    rig: &RigInput,
    compare: &[String],
    mut f: impl FnMut(&Rig) -> Result<(Signals, M), LtiError>,
) -> anyhow::Result<Runs<M>> {
    let mut runs = Runs {
        done: Vec::new(),
        unstable: Vec::new(),
    };
    for (label, r) in variants(&rig.rig, compare)? {
        match f(&r) {
            Ok((signals, metrics)) => runs.done.push(Run {
                label,
                over_ratings: response::signals_over_ratings(&r, &signals),
                signals,
                metrics,
            }),
            Err(e @ LtiError::Unstable { .. }) if label != "nominal" => {
                runs.unstable.push(Unstable {
                    label,
                    reason: e.to_string(),
                });
            }
            Err(e) => return Err(anyhow::Error::new(e).context(which(&rig.name, &label))),
        }
    }
    Ok(runs)
}

/// The rig and variant a run belongs to, for messages.
fn which(name: &str, label: &str) -> String {
    match label {
        "nominal" => name.to_string(),
        variant => format!("{name} with compare {variant}"),
    }
}

/// Check a run of `duration_s` (set by the fields `set_by`) sampled at `rate_hz` before any
/// work, as the core checks every record ([`pumpcyl::limits::check_samples`]).
fn check_timing(
    duration_s: f64,
    set_by: Vec<(&'static str, Given)>,
    rate_hz: f64,
) -> anyhow::Result<()> {
    pumpcyl::limits::check_samples(duration_s, rate_hz).map_err(|e| {
        let error = FieldError {
            fields: Vec::new(),
            problem: e.to_string(),
            unless: None,
        };
        (set_by
            .into_iter()
            .chain([("rate_hz", Given::Number(rate_hz))]))
        .fold(error, |error, (field, value)| error.and(field, value))
    })?;
    Ok(())
}

/// Refuse a reference from `lo_mm` to `hi_mm` that leaves the rig's stroke
/// ([`Rig::check_reference`]), naming the field `field` = `value` that set it.
fn check_in_stroke(
    rig: &Rig,
    field: &'static str,
    value: f64,
    lo_mm: f64,
    hi_mm: f64,
) -> anyhow::Result<()> {
    rig.check_reference(lo_mm, hi_mm)
        .map_err(|e| FieldError::new(field, Given::Number(value), e.to_string()))?;
    Ok(())
}

/// Every run whose predicted position leaves the stroke of `rig`
/// ([`response::stroke_excursion`]), each named by its run when there are several.
fn stroke_warnings<M>(rig: &Rig, runs: &Runs<M>) -> Vec<String> {
    let several = runs.done.len() > 1;
    (runs.done.iter())
        .filter_map(|run| {
            let e = response::stroke_excursion(rig, &run.signals)?;
            Some(if several {
                format!("{}: {e}", run.label)
            } else {
                e.to_string()
            })
        })
        .collect()
}

/// `step`: the closed-loop response to a position step from the operating point x0
/// (docs/simulation.md#step-metrics), on the rig and on each variant compared.
#[derive(Debug, Clone)]
pub struct Step {
    /// The rig.
    pub rig: RigInput,
    /// Step size (mm), from x0.
    pub step_mm: f64,
    /// Simulated duration (s).
    pub duration_s: f64,
    /// Sample rate (Hz) of the reference and the output.
    pub rate_hz: f64,
    /// Variants, each `KEY=VALUE[,KEY=VALUE...]` on top of the rig.
    pub compare: Vec<String>,
}

/// The runs of a step.
pub struct StepOutcome {
    request: Step,
    runs: Runs<StepMetrics>,
    warnings: Vec<String>,
}

impl Step {
    fn check(&self, rig: &Rig) -> anyhow::Result<()> {
        let duration = vec![("duration_s", Given::Number(self.duration_s))];
        check_timing(self.duration_s, duration, self.rate_hz)?;
        let ok = self.step_mm.is_finite() && self.step_mm != 0.0;
        check_field("step_mm", self.step_mm, ok, "must be finite and non-zero")?;
        let (x0, end) = (rig.x0_mm, rig.x0_mm + self.step_mm);
        check_in_stroke(rig, "step_mm", self.step_mm, x0.min(end), x0.max(end))
    }

    /// A step smaller than [`STEP_WARN_BELOW_MM`], in words.
    fn size_warning(&self) -> Option<String> {
        (self.step_mm.abs() < STEP_WARN_BELOW_MM).then(|| {
            format!(
                "step_mm = {}: a step of {} µm is unusual; step_mm is in millimetres",
                self.step_mm,
                self.step_mm * 1000.0
            )
        })
    }
}

impl Request for Step {
    type Outcome = StepOutcome;

    fn run(&self, _: Hooks<'_>) -> anyhow::Result<StepOutcome> {
        let rig = &self.rig;
        self.check(&rig.rig)?;
        let runs = run_variants(rig, &self.compare, |r| {
            let s = response::step(r, self.step_mm, self.duration_s, self.rate_hz)?;
            let m = response::step_report(r, &s, self.step_mm)?;
            Ok((s, m))
        })?;
        let warnings = (self.size_warning().into_iter())
            .chain(stroke_warnings(&rig.rig, &runs))
            .collect();
        Ok(StepOutcome {
            request: self.clone(),
            runs,
            warnings,
        })
    }
}

impl StepOutcome {
    /// A line per drive rating the nominal run exceeds (docs/simulation.md#drive-ratings).
    pub fn rating_warnings(&self) -> Vec<String> {
        rating_warning_lines("step", &self.runs.done[0].over_ratings)
    }

    fn setup(&self) -> StepSetup<'_> {
        StepSetup {
            rig: &self.request.rig.name,
            circuit: self.request.rig.rig.circuit,
            step_mm: self.request.step_mm,
            duration_s: self.request.duration_s,
            rate_hz: self.request.rate_hz,
        }
    }

    fn title(&self) -> String {
        step_title(&self.setup(), self.request.rig.rig.x0_mm)
    }

    /// The signals of every run as CSV.
    pub fn csv(&self) -> String {
        signals_csv(&series(&self.runs.done), None)
    }

    /// The signals and metrics of every run as a MAT-file.
    pub fn mat(&self) -> Vec<u8> {
        step_mat(&self.title(), &self.runs.done)
    }

    /// The four-panel figure of every run.
    pub fn chart(&self) -> Chart {
        let subtitle = step_subtitle(&self.runs.done[0].metrics);
        let series = series(&self.runs.done);
        Chart::signals(&self.title(), Some(&subtitle), &series, None, None)
    }
}

impl Document for StepOutcome {
    fn json(&self) -> anyhow::Result<Value> {
        let doc = step_document(&self.setup(), &self.runs, &self.warnings);
        Ok(self.request.rig.document(doc))
    }

    fn text(&self) -> anyhow::Result<String> {
        Ok(step_text(&self.setup(), &self.runs))
    }

    fn warnings(&self) -> &[String] {
        &self.warnings
    }
}

/// `track`: sinusoidal tracking about x0 (docs/simulation.md#tracking-metrics), the metrics of
/// the periodic steady state, on the rig and on each variant compared.
#[derive(Debug, Clone)]
pub struct Track {
    /// The rig.
    pub rig: RigInput,
    /// The sines, each (frequency in Hz, amplitude in mm); empty: the article's three
    /// ([`ARTICLE_SINE_CASES`]).
    pub waves: Vec<(f64, f64)>,
    /// Whole periods simulated (1 or more).
    pub periods: f64,
    /// Sample rate (Hz).
    pub rate_hz: f64,
    /// Variants, each `KEY=VALUE[,KEY=VALUE...]` on top of the rig.
    pub compare: Vec<String>,
}

/// The runs of a tracking request.
pub struct TrackOutcome {
    request: Track,
    runs: Runs<TrackMetrics>,
    warnings: Vec<String>,
}

impl Track {
    /// The sines run: the request's, or the article's three.
    fn cases(&self) -> Vec<(f64, f64)> {
        if self.waves.is_empty() {
            ARTICLE_SINE_CASES.to_vec()
        } else {
            self.waves.clone()
        }
    }

    /// The periods, checked: whole, 1 or more.
    fn check(&self, rig: &Rig) -> anyhow::Result<u32> {
        let p = self.periods;
        let whole = (1.0..=f64::from(u32::MAX)).contains(&p) && p.fract() == 0.0;
        check_field(
            "periods",
            p,
            whole,
            "must be a whole number of periods, 1 or more",
        )?;
        for (f, a) in self.cases() {
            check_field("freq_hz", f, f > 0.0 && f.is_finite(), "must be > 0")?;
            check_field("amp_mm", a, a > 0.0 && a.is_finite(), "must be > 0")?;
            let set_by = vec![("periods", Given::Number(p)), ("freq_hz", Given::Number(f))];
            check_timing(p / f, set_by, self.rate_hz)?;
            check_in_stroke(rig, "amp_mm", a, rig.x0_mm - a, rig.x0_mm + a)?;
        }
        Ok(p as u32) // whole and within u32, checked above
    }
}

impl Request for Track {
    type Outcome = TrackOutcome;

    fn run(&self, _: Hooks<'_>) -> anyhow::Result<TrackOutcome> {
        let rig = &self.rig;
        let periods = self.check(&rig.rig)?;
        let mut runs = Runs {
            done: Vec::new(),
            unstable: Vec::new(),
        };
        for (f, a) in self.cases() {
            let case = run_variants(rig, &self.compare, |r| {
                response::track(r, f, a, periods, self.rate_hz)
            })
            .with_context(|| format!("{f} Hz ±{a} mm"))?;
            runs.done.extend(case.done);
            // a variant's closed loop is unstable or not whatever the sine
            runs.unstable = case.unstable;
        }
        let warnings = stroke_warnings(&rig.rig, &runs);
        Ok(TrackOutcome {
            request: self.clone(),
            runs,
            warnings,
        })
    }
}

impl TrackOutcome {
    /// A line per drive rating a run exceeds, the run named by its sine
    /// (docs/simulation.md#drive-ratings).
    pub fn rating_warnings(&self) -> Vec<String> {
        (self.runs.done.iter())
            .flat_map(|r| {
                let m = &r.metrics;
                let what = format!("{} Hz ±{} mm {}", m.freq_hz, m.amp_mm, r.label);
                rating_warning_lines(&what, &r.over_ratings)
            })
            .collect()
    }

    /// The signals of every run as CSV.
    pub fn csv(&self) -> String {
        signals_csv(&track_series(&self.runs.done), None)
    }

    /// The signals and metrics of every run as a MAT-file.
    pub fn mat(&self) -> Vec<u8> {
        track_mat(&self.runs.done)
    }

    /// The tracking figure.
    pub fn chart(&self) -> Chart {
        track_chart(&self.runs.done)
    }
}

impl Document for TrackOutcome {
    fn json(&self) -> anyhow::Result<Value> {
        let doc = track_json(
            &self.request.rig.name,
            self.request.rig.rig.circuit,
            &self.runs,
        );
        Ok(self
            .request
            .rig
            .document(with_warnings(doc, &self.warnings)))
    }

    fn text(&self) -> anyhow::Result<String> {
        Ok(track_text(
            &self.request.rig.name,
            self.request.rig.rig.circuit,
            &self.runs,
        ))
    }

    fn warnings(&self) -> &[String] {
        &self.warnings
    }
}

/// `simulate`: a record replayed through the model from its own rest (docs/simulation.md),
/// the position MSE over its fit window, on the rig and on each variant compared.
#[derive(Debug, Clone)]
pub struct Replay {
    /// The rig.
    pub rig: RigInput,
    /// The record (time, reference and measured position; pressures and speeds if recorded).
    pub record: Record,
    /// The end of the fit window (s) on the record's time axis; `None`: the whole record.
    pub fit_end_s: Option<f64>,
    /// Whether the rig is an experiment dataset's own conditions, which the text then names.
    pub own_conditions: bool,
    /// Variants, each `KEY=VALUE[,KEY=VALUE...]` on top of the rig.
    pub compare: Vec<String>,
}

/// The runs of a replay.
pub struct ReplayOutcome {
    request: Replay,
    window_end_s: f64,
    runs: Runs<f64>,
    warnings: Vec<String>,
}

impl Replay {
    /// The end of the fit window, checked within the record.
    fn window_end(&self) -> anyhow::Result<f64> {
        let rec = &self.record;
        let (t0, t1) = (rec.time_s[0], rec.time_s[rec.len() - 1]);
        let Some(t) = self.fit_end_s else {
            return Ok(t1);
        };
        let ok = t.is_finite() && t > t0 && t <= t1;
        check_field(
            "fit_end_s",
            t,
            ok,
            &format!("lies outside the record ({t0} … {t1} s)"),
        )
        .with_context(|| rec.file.clone())?;
        Ok(t)
    }
}

impl Request for Replay {
    type Outcome = ReplayOutcome;

    fn run(&self, _: Hooks<'_>) -> anyhow::Result<ReplayOutcome> {
        let rig = &self.rig;
        let rec = &self.record;
        rec.check_units(rig.rig.stroke_mm)?;
        let (lo, hi) = rec.reference_range_mm();
        rig.rig
            .check_reference(lo, hi)
            .map_err(|e| anyhow::anyhow!("{}: x_ref_mm: {e}", rec.file))?;
        let window_end_s = self.window_end()?;
        let runs = run_variants(rig, &self.compare, |r| {
            let base = Baseline::of_record(rec, r);
            let s = response::simulate(r, &rec.time_s, &rec.x_ref_mm, &base)?;
            let mse = response::position_mse_until(&rec.time_s, &s.x_mm, &rec.x_mm, window_end_s);
            Ok((s, mse))
        })?;
        let warnings = stroke_warnings(&rig.rig, &runs);
        Ok(ReplayOutcome {
            request: self.clone(),
            window_end_s,
            runs,
            warnings,
        })
    }
}

impl ReplayOutcome {
    fn replay(&self) -> crate::time::Replay<'_> {
        crate::time::Replay {
            record: &self.request.record,
            rig: &self.request.rig.name,
            circuit: self.request.rig.rig.circuit,
            own_conditions: self.request.own_conditions,
            fit_end_s: self.window_end_s,
        }
    }

    fn measured(&self) -> Signals {
        Signals::of_record(&self.request.record)
    }

    /// The measured record and the signals of every run as CSV.
    pub fn csv(&self) -> String {
        signals_csv(&simulate_series(&self.runs.done), Some(&self.measured()))
    }

    /// The measured record, the signals and the MSE of every run as a MAT-file.
    pub fn mat(&self) -> Vec<u8> {
        simulate_mat(&self.replay(), &self.runs.done, &self.measured())
    }

    /// The figure of every run over the measured record, the fit window's end marked when given.
    pub fn chart(&self) -> Chart {
        let replay = self.replay();
        let series = simulate_series(&self.runs.done);
        let subtitle = simulate_subtitle(&replay, self.runs.done[0].metrics);
        let mark = self.request.fit_end_s;
        let measured = self.measured();
        Chart::signals(
            &simulate_title(&replay),
            Some(&subtitle),
            &series,
            Some(&measured),
            mark,
        )
    }
}

impl Document for ReplayOutcome {
    fn json(&self) -> anyhow::Result<Value> {
        let doc = simulate_json(&self.replay(), &self.runs);
        Ok(self
            .request
            .rig
            .document(with_warnings(doc, &self.warnings)))
    }

    fn text(&self) -> anyhow::Result<String> {
        Ok(simulate_text(&self.replay(), &self.runs))
    }

    fn warnings(&self) -> &[String] {
        &self.warnings
    }
}
