//! The loop a command analyses or exports: a rig's position loop, opened as the article opens
//! it (§2.3.3; docs/analysis.md#the-loop-that-is-analysed), or a loop transfer L(s) read from a
//! JSON state-space model (docs/formats.md); and its view for display and export.

use crate::circuit::Role;
use crate::ident::Standstill;
use crate::lti::{LtiError, ModelJson, StateInfo, StateSpace};
use crate::model::Plant;
use crate::rig::Rig;

/// A named signal (input or output) with its SI unit.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Port {
    /// Name, e.g. `x_ref`.
    pub name: String,
    /// SI unit, e.g. `m`.
    pub unit: String,
    /// What it is, in words.
    pub meaning: String,
}

impl Port {
    /// A port from its name, unit and meaning.
    pub fn new(name: &str, unit: &str, meaning: &str) -> Port {
        Port {
            name: name.into(),
            unit: unit.into(),
            meaning: meaning.into(),
        }
    }
}

/// Which loop a grey-box function returns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GreyLoop {
    /// The open loop, position error e (m) → x (m); the sum-pressure loop closed inside or not.
    Open {
        /// Sum-pressure loop closed inside.
        sum_pressure: bool,
    },
    /// The closed loop x_ref (m) → x, p1, p2, w1, w2, e (SI), as `pumpcyl step` simulates it.
    Closed {
        /// Sum-pressure loop closed.
        sum_pressure: bool,
    },
}

/// The loop matrices of a rig for a grey-box loop choice.
pub fn grey_loop(rig: &Rig, which: GreyLoop) -> StateSpace {
    let plant = Plant::new(rig);
    match which {
        GreyLoop::Open { sum_pressure } => plant.open_loop(sum_pressure),
        GreyLoop::Closed { sum_pressure } => plant.closed_loop_outputs(sum_pressure),
    }
}

/// The standstill the grey-box function takes c1 and c2 from: given, or the rig's own operating
/// point (whose speeds feed exactly the rig's leakages, so the rig's c1 and c2 come back).
/// Refused for a circuit other than the DPM: the grey-box model is of the DPM's equations.
pub fn standstill_of(rig: &Rig, given: Option<Standstill>) -> Result<Standstill, String> {
    crate::circuit::require_dpm(rig, "the grey-box model")?;
    let own = || Plant::new(rig).dpm().map(|d| d.standstill());
    Ok(given.or_else(own).expect("required above"))
}

/// The loop to analyse, with a description for the output.
#[derive(Debug, Clone)]
pub struct Loop {
    /// L(s): input the position error (m), output x (m) for a rig.
    pub open_loop: StateSpace,
    /// State names and units.
    pub states: Vec<StateInfo>,
    /// The rig, when the model comes from one.
    pub rig: Option<Rig>,
    /// What was analysed, in words.
    pub description: String,
    /// Whether the sum-pressure loop is closed inside `open_loop` (a rig's loop only).
    pub sum_pressure_closed: bool,
}

/// The closed loop as `pumpcyl step` simulates it (position and sum-pressure loops closed),
/// where it differs from the closed loop the margins are read on (the sum-pressure loop open,
/// the article §2.3.3; docs/analysis.md#the-loop-that-is-analysed): its stability and its
/// rightmost pole.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SimulatedLoop {
    /// Stability from the eigenvalues of the full closed loop.
    pub stability: crate::lti::Stability,
    /// The rightmost pole: real part (1/s) and imaginary part (rad/s, ≥ 0).
    pub rightmost_pole: [f64; 2],
    /// Its frequency |p|/2π (Hz).
    pub rightmost_pole_hz: f64,
}

/// A loop as shown or exported (the `model` command, MATLAB/Octave files, MAT-files): matrices,
/// names and the loop it is.
pub struct ModelView {
    /// The matrices (SI).
    pub sys: StateSpace,
    /// State names and units.
    pub states: Vec<StateInfo>,
    /// Inputs.
    pub inputs: Vec<Port>,
    /// Outputs.
    pub outputs: Vec<Port>,
    /// What it is.
    pub title: String,
    /// The operating point (name, value, unit); empty for a JSON model.
    pub operating_point: Vec<(String, f64, String)>,
    /// The rig and the grey-box loop choice, when the model comes from a rig.
    pub rig: Option<(Rig, GreyLoop)>,
}

impl Loop {
    /// The position loop of `rig` (where it came from: `origin`) with the position feedback
    /// removed, the sum-pressure loop closed inside it or not.
    pub fn of_rig(rig: Rig, origin: &str, sum_pressure_closed: bool) -> Loop {
        let plant = Plant::new(&rig);
        let sp = match (rig.circuit.has_sum_pressure_loop(), sum_pressure_closed) {
            (true, true) => ", sum-pressure loop closed",
            (true, false) => ", sum-pressure loop open",
            (false, _) => "",
        };
        Loop {
            open_loop: plant.open_loop(sum_pressure_closed),
            states: plant.states(),
            description: format!(
                "{origin} (circuit {}): open loop x_ref -> x, position feedback removed{sp}",
                plant.circuit().describe()
            ),
            rig: Some(rig),
            sum_pressure_closed,
        }
    }

    /// The rig whose loop as simulated differs from the analysed one: its circuit has a
    /// sum-pressure loop, the rig turns it on, and the analysed loop opens it.
    pub fn simulated_rig(&self) -> Option<&Rig> {
        self.rig.as_ref().filter(|r| {
            r.sum_pressure && r.circuit.has_sum_pressure_loop() && !self.sum_pressure_closed
        })
    }

    /// The loop as simulated, where it differs from the analysed one: a rig whose
    /// sum-pressure loop is on but open in the analysed loop. `None` otherwise (a JSON model, a
    /// rig without the sum-pressure loop, or the loop analysed with it closed).
    pub fn simulated(&self) -> Result<Option<SimulatedLoop>, LtiError> {
        let Some(rig) = self.simulated_rig() else {
            return Ok(None);
        };
        let full = Plant::new(rig).closed_loop(true);
        let (poles, stability) = crate::lti::poles_and_stability(&full.a)?;
        let p = poles
            .iter()
            .copied()
            .max_by(|a, b| a.re.total_cmp(&b.re))
            .unwrap_or_default();
        Ok(Some(SimulatedLoop {
            stability,
            rightmost_pole: [p.re, p.im.abs()],
            rightmost_pole_hz: p.norm() / (2.0 * std::f64::consts::PI),
        }))
    }

    /// A loop transfer L(s) from the JSON model `text` of the file `name`; the error (without
    /// the name) locates the line and key.
    pub fn from_json(text: &str, name: &str) -> Result<Loop, crate::source_files::InputError> {
        let (open_loop, states) = ModelJson::parse(text)?;
        Ok(Loop {
            open_loop,
            states,
            rig: None,
            description: format!("{name}: loop transfer L(s) from JSON"),
            sum_pressure_closed: false,
        })
    }

    /// The open loop (as analysed) or, with `closed`, the closed loop as `step` simulates it: input
    /// x_ref, outputs x, p1, p2, w1, w2 and e. For a JSON model the closed loop is unity feedback.
    /// `sum_pressure_closed` records how the open loop was built (for the grey-box function).
    pub fn view(&self, closed: bool, sum_pressure_closed: bool) -> Result<ModelView, LtiError> {
        let lp = self;
        let Some(rig) = &lp.rig else {
            let (sys, title, inp, out) = if closed {
                (
                    lp.open_loop.unity_feedback()?,
                    format!("{} with unity feedback", lp.description),
                    Port::new("r", "-", "reference"),
                    Port::new("y", "-", "output"),
                )
            } else {
                (
                    lp.open_loop.clone(),
                    lp.description.clone(),
                    Port::new("u", "-", "loop input"),
                    Port::new("y", "-", "loop output"),
                )
            };
            return Ok(ModelView {
                sys,
                states: lp.states.clone(),
                inputs: vec![inp],
                outputs: vec![out],
                title,
                operating_point: Vec::new(),
                rig: None,
            });
        };
        let plant = Plant::new(rig);
        // the closed loop as `step` runs it rests with the reference off the piston by the
        // rest offset (docs/simulation.md#the-rest-under-load): its deviations are about that
        // rest, the open loop's about the operating point
        let rest = plant.rest(rig.sum_pressure).filter(|_| closed);
        let state = rest
            .as_ref()
            .map_or_else(|| plant.operating_point().state, |r| r.state.clone());
        let outputs = plant.outputs();
        let reference = rest.as_ref().map(|r| {
            let x_ref_m = state[plant.position()] + r.offset_m;
            ("x_ref_m".to_string(), x_ref_m, "m".to_string())
        });
        let operating_point = (outputs.iter())
            .filter_map(|o| {
                let gauge = if o.role == Some(Role::Pressure) {
                    " (gauge)"
                } else {
                    ""
                };
                let name = format!("{}_{}", o.name, o.unit.replace('/', "_per_"));
                Some((name, state[o.state?], format!("{}{gauge}", o.unit)))
            })
            .chain(reference)
            .collect();
        let signal_names: Vec<&str> = outputs.iter().map(|o| o.name.as_str()).collect();
        let (which, inputs, outputs, title) = if closed {
            let sp = if rig.sum_pressure { "closed" } else { "open" };
            (
                GreyLoop::Closed {
                    sum_pressure: rig.sum_pressure,
                },
                vec![Port::new("x_ref", "m", "position reference")],
                (outputs.iter())
                    .map(|o| Port::new(&o.name, &o.unit, &o.meaning))
                    .collect(),
                format!(
                    "{}: closed loop x_ref -> {}, sum-pressure loop {sp} (as pumpcyl \
                     step simulates it)",
                    lp.description
                        .split(": open loop")
                        .next()
                        .unwrap_or(&lp.description),
                    signal_names.join(", ")
                ),
            )
        } else {
            (
                GreyLoop::Open {
                    sum_pressure: sum_pressure_closed,
                },
                vec![Port::new("e", "m", "position error")],
                vec![Port::new("x", "m", "piston position")],
                lp.description.clone(),
            )
        };
        Ok(ModelView {
            sys: grey_loop(rig, which),
            states: plant.states(),
            inputs,
            outputs,
            title,
            operating_point,
            rig: Some((rig.clone(), which)),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_exported_open_loop_is_the_loop_analysed() {
        for sum_pressure_closed in [false, true] {
            let lp = Loop::of_rig(Rig::default(), "default rig", sum_pressure_closed);
            let view = lp.view(false, sum_pressure_closed).unwrap();
            let freqs = [0.1, 1.0, 10.0];
            let a = crate::lti::bode(&lp.open_loop, &freqs).unwrap();
            let b = crate::lti::bode(&view.sys, &freqs).unwrap();
            for k in 0..freqs.len() {
                assert!(
                    (a.mag_db[k] - b.mag_db[k]).abs() < 1e-9,
                    "{sum_pressure_closed}"
                );
            }
            assert_eq!(view.operating_point.len(), 5);
        }
        let closed = Loop::of_rig(Rig::default(), "r", false)
            .view(true, false)
            .unwrap();
        assert_eq!((closed.inputs.len(), closed.outputs.len()), (1, 6));
    }

    #[test]
    fn a_json_loop_closes_by_unity_feedback() {
        // L(s) = 2/(s + 1): closed loop 2/(s + 3), DC gain 2/3
        let lp = Loop::from_json(
            r#"{"A": [[-1]], "B": [[1]], "C": [[2]], "D": [[0]]}"#,
            "l.json",
        )
        .unwrap();
        let view = lp.view(true, false).unwrap();
        assert!((view.sys.a[(0, 0)] + 3.0).abs() < 1e-12);
        let dc = -view.sys.c[(0, 0)] * view.sys.b[(0, 0)] / view.sys.a[(0, 0)];
        assert!((dc - 2.0 / 3.0).abs() < 1e-12, "{dc}");
        assert!(view.operating_point.is_empty() && view.rig.is_none());
    }
}
