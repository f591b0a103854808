//! The duty-cycle request: a cycle run on the emulated rig with its power account — the
//! energy drawn, returned and lost by kind, the load's work and the efficiency, and each
//! motor's RMS and peak torque and speed against its ratings (docs/energy.md#duty-cycles).

use super::{check_field, Document, FieldError, Given, Hooks, Request, RigInput};
use crate::emulated::{basis, columns_json, energy_json, loop_columns, run_warnings};
use crate::format::fmt_short;
use crate::records::record_csv;
use pumpcyl::circuit::energy::LOSS_KEYS;
use pumpcyl::emulator::cycle::{self, Cycle, CycleEnergy, CycleRun, DriveDuty};
use pumpcyl::emulator::{article, Effects, Plc, RunError, PLC_RATE_HZ, SETTLE_S};
use pumpcyl::limits::Work;
use pumpcyl::source_files::Files;
use serde_json::{json, Value};
use std::path::PathBuf;

/// Which cycle.
#[derive(Debug, Clone, PartialEq)]
pub enum CycleKind {
    /// The article's three sines about the rig's x0 ([`cycle::ARTICLE_SINES`]).
    ArticleSines,
    /// Steps of `amplitude_mm` about x0, each level held `hold_s`.
    Steps {
        /// The step (mm).
        step_mm: f64,
        /// How long each level is held (s).
        hold_s: f64,
    },
    /// An engineer's profile (docs/formats.md#duty-cycle-csv).
    File(PathBuf),
}

impl CycleKind {
    /// The cycle a front end names: `article-sines`, `steps` (of `step_mm`, each level held
    /// `hold_s`), anything else a profile's file.
    pub fn named(name: &str, step_mm: f64, hold_s: f64) -> CycleKind {
        match name {
            "article-sines" => CycleKind::ArticleSines,
            "steps" => CycleKind::Steps { step_mm, hold_s },
            file => CycleKind::File(PathBuf::from(file)),
        }
    }

    /// Its name in documents: `article-sines`, `steps`, or the file.
    pub fn name(&self) -> String {
        match self {
            CycleKind::ArticleSines => "article-sines".into(),
            CycleKind::Steps { .. } => "steps".into(),
            CycleKind::File(path) => path.display().to_string(),
        }
    }
}

/// `cycle`: a duty cycle on the emulated rig, effects on or off, the PLC's noise on or off.
#[derive(Clone)]
pub struct CycleRequest {
    /// The rig.
    pub rig: RigInput,
    /// The cycle.
    pub cycle: CycleKind,
    /// Whether the emulator's effects are on.
    pub effects: bool,
    /// Whether the PLC's sensors are noisy (the article's), with this seed.
    pub noise: bool,
    /// The noise's seed.
    pub seed: u64,
    /// Whether a cycle beyond the emulator's work limit may run.
    pub allow_long_run: bool,
    /// Where a profile's file is read from.
    pub files: &'static dyn Files,
}

impl CycleRequest {
    /// The cycle, checked: a step's size and hold, a file's columns.
    fn cycle(&self) -> anyhow::Result<Cycle> {
        let rig = &self.rig.rig;
        Ok(match &self.cycle {
            CycleKind::ArticleSines => Cycle::article_sines(rig.x0_mm),
            CycleKind::Steps { step_mm, hold_s } => {
                let reach = rig.x0_mm.min(rig.stroke_mm - rig.x0_mm);
                let beyond = format!(
                    "the steps reach beyond the stroke (x0_mm = {} in stroke_mm = {})",
                    rig.x0_mm, rig.stroke_mm
                );
                check_field(
                    "step_mm",
                    *step_mm,
                    step_mm.is_finite(),
                    "must be a finite number",
                )?;
                check_field("step_mm", *step_mm, step_mm.abs() <= reach, &beyond)?;
                let held = *hold_s > 0.0 && *hold_s <= 3600.0;
                check_field("hold_s", *hold_s, held, "must be > 0 s and at most an hour")?;
                Cycle::Steps {
                    centre_mm: rig.x0_mm,
                    amplitude_mm: *step_mm,
                    hold_s: *hold_s,
                }
            }
            CycleKind::File(path) => Cycle::read(self.files, path, rig)?,
        })
    }

    /// The PLC: the article's noisy sensors or ideal ones, the energy account on.
    fn plc(&self) -> Plc {
        let base = match self.noise {
            true => article::plc(self.seed),
            false => Plc::ideal(PLC_RATE_HZ),
        };
        Plc {
            seed: self.seed,
            energy: true,
            ..base
        }
    }
}

/// A duty cycle run.
pub struct CycleOutcome {
    request: CycleRequest,
    cycle: Cycle,
    run: CycleRun,
    energy: CycleEnergy,
    basis: String,
    warnings: Vec<String>,
}

impl Request for CycleRequest {
    type Outcome = CycleOutcome;

    fn work(&self) -> Option<(u64, &'static str)> {
        let duration_s = self.cycle().ok()?.duration_s();
        Some((
            (duration_s * PLC_RATE_HZ).round() as u64 + 1,
            "controller steps",
        ))
    }

    fn run(&self, hooks: Hooks<'_>) -> anyhow::Result<CycleOutcome> {
        let (rig, name) = (&self.rig.rig, &self.rig.name);
        let cycle = self.cycle()?;
        let duration_s = cycle.duration_s();
        pumpcyl::limits::check_emulation(duration_s, PLC_RATE_HZ, self.allow_long_run).map_err(
            |e| {
                let problem = format!("a cycle of {duration_s} s: {e}");
                FieldError::new("cycle", Given::Text(self.cycle.name()), problem)
                    .unless("allow_long_run")
            },
        )?;
        let effects =
            Effects::switched(rig, self.effects).map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
        let dynamics = pumpcyl::emulator::Dynamics::new(rig, effects)
            .map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
        let work = Work {
            allow_long_run: self.allow_long_run,
            progress: hooks.tick,
        };
        let run = cycle::run(rig, &dynamics, &self.plc(), (SETTLE_S, &cycle), &work).map_err(
            |e| match e {
                RunError::Limit(e) => anyhow::Error::from(e),
                RunError::Emulator(e) => anyhow::anyhow!("{name}: {e}"),
            },
        )?;
        let energy = run
            .energy()
            .ok_or_else(|| anyhow::anyhow!("{name}: the cycle ran without its energy account"))?;
        let warnings = cycle_warnings(rig, &run);
        Ok(CycleOutcome {
            request: self.clone(),
            basis: basis(rig, &effects)?,
            cycle,
            run,
            energy,
            warnings,
        })
    }
}

/// The emulated run's warnings (drive ratings, cavitation, the relief setting) and one line for
/// each motor too small for the cycle, naming what it exceeds.
fn cycle_warnings(rig: &pumpcyl::rig::Rig, run: &CycleRun) -> Vec<String> {
    let e = &run.emulation;
    let mut lines = run_warnings(rig, Some(&e.signals), e.cavitation);
    lines.extend(
        run.drives
            .iter()
            .filter(|d| !d.exceeds.is_empty())
            .map(too_small),
    );
    lines
}

/// A motor too small for the cycle, in one line.
fn too_small(d: &DriveDuty) -> String {
    let what: Vec<String> = (d.exceeds.iter())
        .map(|k| match *k {
            "rms_torque" => format!(
                "RMS torque {:.2} N m above its rated {} N m (motor_rated_torque_nm)",
                d.rms_torque_nm,
                fmt_short(d.rated_torque_nm, 4)
            ),
            "peak_torque" => format!(
                "peak torque {:.2} N m at its limit of {} N m (3 x motor_rated_torque_nm)",
                d.peak_torque_nm,
                fmt_short(d.peak_torque_limit_nm, 4)
            ),
            "speed" => format!(
                "peak speed {:.0} rpm above its rated {} rpm (motor_rated_speed_rpm)",
                d.peak_speed_rpm,
                fmt_short(d.rated_speed_rpm, 2)
            ),
            _ => format!(
                "peak speed {:.0} rpm above the pump's {} rpm (pump_max_speed_rpm)",
                d.peak_speed_rpm,
                fmt_short(d.pump_max_speed_rpm, 2)
            ),
        })
        .collect();
    format!(
        "motor {} is too small for this cycle: {}",
        d.motor,
        what.join("; ")
    )
}

impl CycleOutcome {
    /// The record with its power columns (docs/formats.md#power-columns).
    pub fn csv(&self) -> String {
        record_csv(&self.run.emulation.signals)
    }

    /// The cycle's energy in figures.
    pub fn energy(&self) -> &CycleEnergy {
        &self.energy
    }

    /// The run: the record, its account and the drives' duty.
    pub fn run(&self) -> &CycleRun {
        &self.run
    }

    /// The drives' electrical keys at pumpcyl's defaults, which the energies rest on
    /// (docs/energy.md#the-drives); none for a circuit without drives.
    pub fn assumed(&self) -> Value {
        let rig = &self.request.rig.rig;
        if self.run.drives.is_empty() {
            return json!({});
        }
        (LOSS_KEYS.iter())
            .filter(|k| rig.circuit_key(k.name) == k.default)
            .map(|k| (k.name.to_string(), json!(k.default)))
            .collect::<serde_json::Map<_, _>>()
            .into()
    }
}

impl Document for CycleOutcome {
    fn json(&self) -> anyhow::Result<Value> {
        let r = &self.request;
        let doc = json!({
            "rig": r.rig.name,
            "circuit": r.rig.rig.circuit.name(),
            "cycle": {"kind": r.cycle.name(), "duration_s": self.cycle.duration_s()},
            "emulated": "emulated data, not a measurement",
            "effects": r.effects,
            "noise": r.noise,
            "summary": serde_json::to_value(&self.energy)?,
            "energy": self.run.emulation.energy.as_ref().map(energy_json),
            "drives": serde_json::to_value(&self.run.drives)?,
            "defaults_assumed": self.assumed(),
            "basis": self.basis,
            "warnings": self.warnings,
            "columns": columns_json(&loop_columns(&self.run.emulation.signals)),
        });
        Ok(r.rig.document(doc))
    }

    fn text(&self) -> anyhow::Result<String> {
        crate::energy::cycle_text(
            (&self.request.cycle.name(), &self.request.rig.name),
            &self.energy,
            (&self.run, &self.assumed()),
        )
    }

    fn warnings(&self) -> &[String] {
        &self.warnings
    }
}
