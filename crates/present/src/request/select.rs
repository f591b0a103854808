//! The selection request: which circuit, at which pressure level (docs/select.md; the
//! article §4).

use super::{Document, FieldError, Given, Hooks, Request};
use crate::figures::Chart;
use crate::select::{selection_chart, selection_csv, selection_text};
use pumpcyl::circuit::CircuitKind;
use pumpcyl::emulator::RunError;
use pumpcyl::ident::Experiment;
use pumpcyl::limits::Work;
use pumpcyl::rig::Rig;
use pumpcyl::select::energy::{self, SelectionEnergy};
use pumpcyl::select::{Application, BetaEvidence, ModeCheckKind, SelectError, Selection};
use serde_json::Value;

/// `select`: each candidate circuit and pressure level of an application over the undissolved
/// air's range, and the lowest level that meets its requirement.
#[derive(Debug, Clone)]
pub struct Select {
    /// The application, its file's keys, rig and overrides applied.
    pub application: Application,
    /// Where the application came from, in words (a file, or the article's).
    pub origin: String,
    /// The circuits to try, by name; empty: the application's.
    pub circuits: Vec<String>,
    /// The single-pump candidates' mode check: `emulator` or `equations`.
    pub mode_check: String,
    /// A fixed position gain (1/m) instead of the largest at each candidate.
    pub kp: Option<f64>,
    /// An identification whose records' interval of β gives the gas-fraction range.
    pub evidence: Option<Evidence>,
    /// Whether work beyond the selection's limit may run.
    pub allow_long_run: bool,
    /// Whether each circuit that meets is run through the application's duty cycle for its
    /// energy (docs/select.md#energy).
    pub energy: bool,
}

/// An experiment whose records' interval of β, at a confidence, gives the gas-fraction range
/// (docs/select.md#from-an-identification).
#[derive(Debug, Clone)]
pub struct Evidence {
    /// The experiment, loaded.
    pub experiment: Experiment,
    /// The interval's confidence level, in (0, 1).
    pub confidence: f64,
}

impl Evidence {
    /// The evidence of the experiment `load` reads, at `confidence`, checked before it is read.
    ///
    /// # Errors
    /// The confidence outside (0, 1), or the experiment cannot be read.
    pub fn new(
        confidence: f64,
        load: impl FnOnce() -> anyhow::Result<Experiment>,
    ) -> anyhow::Result<Evidence> {
        super::check_confidence(confidence)?;
        Ok(Evidence {
            experiment: load()?,
            confidence,
        })
    }
}

/// A selection with the application it was made for.
pub struct SelectOutcome {
    origin: String,
    application: Application,
    selection: Selection,
    energy: Option<SelectionEnergy>,
    warnings: Vec<String>,
}

impl Select {
    /// The application as selected: the circuits asked for, the evidence's gas-fraction range.
    ///
    /// # Errors
    /// An unknown circuit, one the rig cannot be, or evidence that cannot be read.
    pub fn application(&self) -> anyhow::Result<Application> {
        let mut app = self.with_circuits()?;
        if let Some(e) = &self.evidence {
            let evidence = BetaEvidence::of_records(&e.experiment, e.confidence)?;
            app = (app.with_evidence(&evidence))
                .map_err(|err| anyhow::anyhow!("{}: {err}", e.experiment.path.display()))?;
        }
        Ok(app)
    }

    /// The application with the circuits asked for.
    fn with_circuits(&self) -> anyhow::Result<Application> {
        if self.circuits.is_empty() {
            return Ok(self.application.clone());
        }
        let kinds = (self.circuits.iter())
            .map(|name| circuit_named(name.trim()))
            .collect::<anyhow::Result<Vec<_>>>()?;
        let given = Given::Text(self.circuits.join(","));
        let app = (self.application.with_circuits(&kinds))
            .map_err(|e| FieldError::new("circuits", given, e.to_string()))?;
        Ok(app)
    }

    fn mode_check(&self) -> anyhow::Result<ModeCheckKind> {
        let name = self.mode_check.trim();
        ModeCheckKind::from_name(name)
            .map_err(|e| FieldError::new("mode_check", Given::Text(name.into()), e).into())
    }
}

/// The circuit named `name`, or an error listing the names.
fn circuit_named(name: &str) -> anyhow::Result<CircuitKind> {
    CircuitKind::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = CircuitKind::ALL.iter().map(|k| k.name()).collect();
        let problem = format!("no such circuit ({})", names.join(", "));
        FieldError::new("circuits", Given::Text(name.into()), problem).into()
    })
}

/// The relief warnings of the one-motor circuits `app` tries, each at its highest accumulator
/// pre-charge (docs/circuits.md#valves): a relief setting, given or derived, that lets a
/// chamber go above the rig's cylinder rating.
fn relief_warnings(app: &Application) -> Vec<String> {
    let precharge_bar = (app.precharge_bar.iter().copied())
        .reduce(f64::max)
        .unwrap_or(app.rig.accumulator_precharge_bar);
    (app.circuits.iter())
        .filter(|kind| kind.description().valves.is_some())
        .filter_map(|&circuit| {
            let rig = Rig {
                circuit,
                accumulator_precharge_bar: precharge_bar,
                ..app.rig.clone()
            };
            let w = pumpcyl::circuit::valves::relief_warning(&rig)?;
            Some(format!("{} circuit: {w}", circuit.name()))
        })
        .collect()
}

impl Request for Select {
    type Outcome = SelectOutcome;

    fn work(&self) -> Option<(u64, &'static str)> {
        let app = self.with_circuits().ok()?;
        Some((app.cases() as u64, "load × level cases"))
    }

    fn run(&self, hooks: Hooks<'_>) -> anyhow::Result<SelectOutcome> {
        let check = self.mode_check()?;
        let app = self.application()?;
        let work = Work {
            allow_long_run: self.allow_long_run,
            progress: hooks.tick,
        };
        let selection =
            (app.select_checked(self.kp, &work, check.check())).map_err(|e| match e {
                SelectError::Limit(l) => anyhow::Error::from(l),
                e => e.into(),
            })?;
        let energy = match self.energy {
            true => Some(selection_energy(&app, &selection, &work)?),
            false => None,
        };
        Ok(SelectOutcome {
            origin: self.origin.clone(),
            warnings: relief_warnings(&app),
            application: app,
            selection,
            energy,
        })
    }
}

impl SelectOutcome {
    /// The selection's figure: the largest K_p and the tracking-error band against the level.
    pub fn chart(&self) -> Chart {
        selection_chart(&self.application, &self.selection)
    }

    /// One row a candidate (docs/select.md#options-csv).
    pub fn csv(&self) -> String {
        selection_csv(&self.selection)
    }
}

/// Each circuit of `selection` that meets, through the application's duty cycle.
fn selection_energy(
    app: &Application,
    selection: &Selection,
    work: &Work,
) -> anyhow::Result<SelectionEnergy> {
    let req = app.requirement();
    // the cycles' controller steps are not the bar's cases: asked only whether to go on
    let go_on = |_steps: u64| (work.progress)(0);
    let quiet = Work {
        allow_long_run: work.allow_long_run,
        progress: &go_on,
    };
    energy::of_selection(&app.rig, &req, selection, &quiet).map_err(|e| match e {
        RunError::Limit(l) => anyhow::Error::from(l),
        RunError::Emulator(e) => anyhow::anyhow!("the duty cycle of a candidate: {e}"),
    })
}

impl Document for SelectOutcome {
    fn json(&self) -> anyhow::Result<Value> {
        let mut doc = serde_json::to_value(&self.selection)?;
        if let Some(e) = &self.energy {
            doc["energy"] = serde_json::to_value(e)?;
        }
        Ok(crate::documents::with_warnings(doc, &self.warnings))
    }

    fn text(&self) -> anyhow::Result<String> {
        let text = selection_text(&self.origin, &self.application, &self.selection);
        Ok(match &self.energy {
            Some(e) => text + &crate::energy::selection_energy_text(e),
            None => text,
        })
    }

    fn warnings(&self) -> &[String] {
        &self.warnings
    }
}
