//! The emulation request: a record from the nonlinear rig emulator (docs/emulator.md).

use super::{Document, FieldError, Given, Hooks, Request, RigInput};
use crate::emulated::{self, Emulation};
use crate::records::emulated_csv;
use pumpcyl::emulator::article::{Kind, Truth};
use pumpcyl::emulator::{Effects, RunError};
use pumpcyl::limits::{LimitError, Work};
use serde_json::Value;

/// `emulate`: one experiment (a step, a sine, a sweep, a standstill or a drive step) on the rig
/// with the emulator's effects on or off.
#[derive(Debug, Clone)]
pub struct Emulate {
    /// The rig (the emulated article rig unless the user gives one).
    pub rig: RigInput,
    /// Whether the emulator's effects (friction, slip, dead band, ...) are on.
    pub effects: bool,
    /// The experiment and its settings.
    pub record: emulated::Request,
    /// Whether a run beyond the emulator's work limit may run.
    pub allow_long_run: bool,
}

/// A core complaint about a setting of the experiment, named as the request's field: the
/// start of a sine (`start_s`) is the request's `at_s`.
fn field_error(e: pumpcyl::source_files::FieldError) -> anyhow::Error {
    let name = match e.field {
        "start_s" => "at_s",
        other => other,
    };
    FieldError::of_core(e, name, None).into()
}

impl Emulate {
    /// The PLC and the plan of the record, checked, and the run's cost within its limit.
    fn plan(&self) -> anyhow::Result<(pumpcyl::emulator::Plc, Kind)> {
        let plc = self.record.plc().map_err(field_error)?;
        let plan = (self.record.plan(&self.rig.rig, plc.rate_hz)).map_err(field_error)?;
        let duration_s = emulated::duration_s(&plan);
        let rate_hz = plc.rate_hz;
        pumpcyl::limits::check_emulation(duration_s, rate_hz, self.allow_long_run).map_err(
            |e| {
                let long = matches!(e, LimitError::LongRun { .. });
                let error = FieldError::new("duration_s", Given::Number(duration_s), e.to_string())
                    .and("rate_hz", Given::Number(rate_hz));
                if long {
                    error.unless("allow_long_run")
                } else {
                    error
                }
            },
        )?;
        Ok((plc, plan))
    }
}

/// An emulated record.
pub struct EmulateOutcome {
    request: Emulate,
    emulation: Emulation,
}

impl Request for Emulate {
    type Outcome = EmulateOutcome;

    fn work(&self) -> Option<(u64, &'static str)> {
        let (plc, plan) = self.plan().ok()?;
        Some((emulated::steps(&plan, plc.rate_hz), "controller steps"))
    }

    fn run(&self, hooks: Hooks<'_>) -> anyhow::Result<EmulateOutcome> {
        let rig = &self.rig;
        let effects = (Effects::switched(&rig.rig, self.effects))
            .map_err(|e| anyhow::anyhow!("{}: {e}", rig.name))?;
        let (plc, plan) = self.plan()?;
        let truth = Truth {
            rig: rig.rig.clone(),
            effects,
            plc,
        };
        let work = Work {
            allow_long_run: self.allow_long_run,
            progress: hooks.tick,
        };
        // the integrator's work beyond the limit (docs/emulator.md#the-work-limit)
        let emulation = emulated::emulate(&plan, &truth, &work).map_err(|e| match e {
            RunError::Limit(e) => anyhow::Error::from(e),
            RunError::Emulator(e) => anyhow::Error::from(e),
        })?;
        Ok(EmulateOutcome {
            request: self.clone(),
            emulation,
        })
    }
}

impl EmulateOutcome {
    /// The record as CSV (docs/formats.md#record-csv).
    pub fn csv(&self) -> String {
        emulated_csv(&self.emulation.outcome.data)
    }
}

impl Document for EmulateOutcome {
    fn json(&self) -> anyhow::Result<Value> {
        let (rig, kind) = (&self.request.rig, self.request.record.experiment);
        let doc = self.emulation.document(kind, &rig.name, rig.rig.circuit);
        Ok(rig.document(doc))
    }

    fn text(&self) -> anyhow::Result<String> {
        let (rig, kind) = (&self.request.rig, self.request.record.experiment);
        let outcome = &self.emulation.outcome;
        let note =
            (outcome.end_stop.as_ref()).map_or(String::new(), |hit| format!("note: {hit}\n"));
        let energy = (outcome.energy.as_ref()).map_or(String::new(), crate::energy::energy_text);
        Ok(format!(
            "emulated {} on {} (circuit {}), {} samples (emulated data, not a measurement)\n{}\n{energy}{note}",
            kind.name(),
            rig.name,
            rig.rig.circuit.name(),
            outcome.data.len(),
            self.emulation.basis
        ))
    }

    fn warnings(&self) -> &[String] {
        &self.emulation.warnings
    }
}
