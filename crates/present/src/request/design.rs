//! The design request: the design method (the article §2.2; docs/design.md) for a rig before
//! it is built, nominal or robust (docs/design.md#robust-design).

use super::{check_confidence, Document, FieldError, Given, Hooks, Request, RigInput};
use crate::design::{design_text, robust_run, robust_text, RobustRequest, RobustRun};
use crate::figures::Chart;
use pumpcyl::design::{check_wave, design_with, DesignError, Targets};
use pumpcyl::ident::Experiment;
use pumpcyl::limits::Work;
use serde_json::Value;

/// `design`: the largest K_p meeting the margin targets over the stroke, the masses and the
/// pressures, with predicted tracking and a verdict; or, with [`Robust`], over the parameters'
/// uncertainty too.
#[derive(Debug, Clone)]
pub struct Design {
    /// The rig (with a robust design from an experiment, the experiment's rig is designed).
    pub rig: RigInput,
    /// The margin targets, the stroke, masses and pressures checked, the waves to track (the
    /// options `target_pm_deg`, `target_gm_db`, `stroke_mm`, `p_mean_bar`, `p_beta_bar`,
    /// `mass_kg`, `waves`).
    pub targets: Targets,
    /// Whether masses × pressures beyond the design's limit may run.
    pub allow_long_run: bool,
    /// The robust design, if asked for.
    pub robust: Option<Robust>,
}

/// The robust design's parameter region: an experiment's records at a confidence, else the
/// stated default region around the rig.
#[derive(Debug, Clone)]
pub struct Robust {
    /// The experiment whose records give the region, loaded.
    pub experiment: Option<Experiment>,
    /// The confidence level of the region, in (0, 1).
    pub confidence: f64,
}

/// A design, nominal or robust.
pub enum DesignOutcome {
    /// The nominal design of the rig named `rig`.
    Nominal {
        /// The rig's name.
        rig: String,
        /// The design.
        design: Box<pumpcyl::design::Design>,
    },
    /// The robust design.
    Robust(Box<RobustRun>),
}

impl Robust {
    /// The region of the records of the experiment `load` reads (`None`: the stated default
    /// region) at `confidence`, checked before the experiment is read.
    ///
    /// # Errors
    /// The confidence outside (0, 1), or the experiment cannot be read.
    pub fn new(
        confidence: f64,
        load: Option<impl FnOnce() -> anyhow::Result<Experiment>>,
    ) -> anyhow::Result<Robust> {
        check_confidence(confidence)?;
        Ok(Robust {
            experiment: load.map(|f| f()).transpose()?,
            confidence,
        })
    }
}

impl Design {
    /// Every list option checked: pressures and masses positive, each wave positive, inside
    /// the stroke and below the tracking's Nyquist frequency, and no wave in a robust design.
    fn check(&self) -> anyhow::Result<()> {
        let item = |i, v| Given::Item(i, Box::new(Given::Number(v)));
        let t = &self.targets;
        for (field, list) in [("p_mean_bar", &t.p_mean_bar), ("mass_kg", &t.mass_kg)] {
            if let Some((i, &v)) =
                (list.iter().enumerate()).find(|(_, v)| !(v.is_finite() && **v > 0.0))
            {
                return Err(FieldError::new(field, item(i, v), "must be > 0").into());
            }
        }
        for (i, &(f, a)) in t.waves.iter().enumerate() {
            let positive = |v: f64| v.is_finite() && v > 0.0;
            let why = match () {
                _ if self.robust.is_some() => Some(
                    "tracking is predicted by the nominal design only; ask for the robust design without waves"
                        .to_string(),
                ),
                _ if !(positive(f) && positive(a)) => {
                    Some("the frequency (Hz) and the amplitude (mm) must be > 0".into())
                }
                _ => check_wave(&self.rig.rig, f, a).err(),
            };
            if let Some(why) = why {
                let given = Given::Item(i, Box::new(Given::Wave(f, a)));
                return Err(FieldError::new("waves", given, why).into());
            }
        }
        if let Some(r) = &self.robust {
            check_confidence(r.confidence)?;
        }
        Ok(())
    }

    /// A design error: work beyond its limit as the core says it (each front end names its
    /// option), any other in the rig `origin` (its mass table, say).
    fn in_rig(e: DesignError, origin: &str) -> anyhow::Error {
        match e {
            DesignError::Limit(l) => l.into(),
            e => anyhow::anyhow!("{origin}: {e}"),
        }
    }

    fn robust(&self, r: &Robust) -> anyhow::Result<DesignOutcome> {
        let request = RobustRequest {
            rig: &self.rig.rig,
            experiment: r.experiment.as_ref(),
            confidence: r.confidence,
            allow_long_run: self.allow_long_run,
        };
        let origin =
            (r.experiment.as_ref()).map_or(self.rig.name.clone(), |e| e.path.display().to_string());
        let run = robust_run(&request, &self.targets).map_err(|e| Design::in_rig(e, &origin))?;
        Ok(DesignOutcome::Robust(Box::new(run)))
    }
}

impl Request for Design {
    type Outcome = DesignOutcome;

    fn work(&self) -> Option<(u64, &'static str)> {
        Some(match self.robust {
            Some(_) => (1, "robust designs"),
            None => (self.targets.conditions() as u64, "conditions"),
        })
    }

    fn run(&self, hooks: Hooks<'_>) -> anyhow::Result<DesignOutcome> {
        self.check()?;
        if let Some(r) = &self.robust {
            let outcome = self.robust(r);
            (hooks.tick)(1);
            return outcome;
        }
        let work = Work {
            allow_long_run: self.allow_long_run,
            progress: hooks.tick,
        };
        let design = design_with(&self.rig.rig, &self.targets, &work)
            .map_err(|e| Design::in_rig(e, &self.rig.name))?;
        Ok(DesignOutcome::Nominal {
            rig: self.rig.name.clone(),
            design: Box::new(design),
        })
    }
}

impl DesignOutcome {
    /// The robust design's figure: the margins over the stroke at the deciding parameter point.
    pub fn robust_chart(&self) -> Option<Chart> {
        match self {
            DesignOutcome::Robust(run) => Some(Chart::robust_margins(&run.design)),
            DesignOutcome::Nominal { .. } => None,
        }
    }
}

impl Document for DesignOutcome {
    fn json(&self) -> anyhow::Result<Value> {
        Ok(match self {
            DesignOutcome::Nominal { design, .. } => serde_json::to_value(design)?,
            DesignOutcome::Robust(run) => run.document(),
        })
    }

    fn text(&self) -> anyhow::Result<String> {
        Ok(match self {
            DesignOutcome::Nominal { rig, design } => design_text(rig, design),
            DesignOutcome::Robust(run) => robust_text(&run.design, run.seconds),
        })
    }
}
