//! The chatter request: will a single-pump rig's valves switch between its modes on their own,
//! over a range of loads (docs/circuits.md#a-scan-of-the-load; the article §2.1).

use super::{Document, FieldError, Hooks, Request, RigInput};
use crate::chatter::{chatter_chart, chatter_csv, chatter_text, run, runs, Chatter as Scan};
use crate::figures::Chart;
use pumpcyl::emulator::chatter::ScanError;
use pumpcyl::limits::Work;
use serde_json::Value;

/// `chatter`: the rig's emulated 5 mm step, and each wave, at each of a range of external
/// forces; the switches at each, the quiet ranges and a verdict.
#[derive(Debug, Clone)]
pub struct Chatter {
    /// The rig.
    pub rig: RigInput,
    /// The forces and the waves.
    pub scan: crate::chatter::Request,
    /// Whether a scan beyond its limit may run.
    pub allow_long_run: bool,
}

/// The command line's option of a field of the scan where it is not the field's name: the
/// repeated `--force-n` and `--wave`.
fn flag_of(field: &str) -> Option<&'static str> {
    match field {
        "forces_n" => Some("force-n"),
        "waves" => Some("wave"),
        _ => None,
    }
}

/// A chatter scan.
pub struct ChatterOutcome {
    rig: RigInput,
    scan: Scan,
}

impl Request for Chatter {
    type Outcome = ChatterOutcome;

    fn work(&self) -> Option<(u64, &'static str)> {
        Some((runs(&self.scan), "emulated runs"))
    }

    fn run(&self, hooks: Hooks<'_>) -> anyhow::Result<ChatterOutcome> {
        let work = Work {
            allow_long_run: self.allow_long_run,
            progress: hooks.tick,
        };
        let name = &self.rig.name;
        let scan = run(&self.rig.rig, name, &self.scan, &work).map_err(|e| match e {
            ScanError::Request(f) => {
                let (name, flag) = (f.field, flag_of(f.field));
                FieldError::of_core(f, name, flag).into()
            }
            ScanError::Limit(l) => anyhow::Error::from(l),
            e => anyhow::anyhow!("{name}: {e}"),
        })?;
        Ok(ChatterOutcome {
            rig: self.rig.clone(),
            scan,
        })
    }
}

impl ChatterOutcome {
    /// One row a run at a force.
    pub fn csv(&self) -> String {
        chatter_csv(&self.scan)
    }

    /// The switches against the force, the switching force and the valve band marked.
    ///
    /// # Errors
    /// A scan with nothing to draw.
    pub fn chart(&self) -> Result<Chart, String> {
        chatter_chart(&self.scan)
    }
}

impl Document for ChatterOutcome {
    fn json(&self) -> anyhow::Result<Value> {
        Ok(self.rig.document(serde_json::to_value(&self.scan)?))
    }

    fn text(&self) -> anyhow::Result<String> {
        Ok(chatter_text(&self.scan))
    }
}
