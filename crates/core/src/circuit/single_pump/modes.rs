//! The single-pump circuit's two modes, the force at which it switches between them, and the
//! closed-loop check whether a step makes it switch (docs/circuits.md#its-two-modes).
//!
//! - **Mode 1**: chamber 2 held at p_acc by its open valve, chamber 1 compressible (states x,
//!   v, p1, w, tau, z);
//! - **Mode 2**: chamber 1 held at p_acc, chamber 2 compressible (states x, v, p2, w, tau, z).
//!
//! Each mode is a [`Circuit`] ([`Mode`]): the circuit's own equations without the check valves,
//! with the accumulator chamber's pressure pinned at p_acc and its equation dropped (the open
//! valve's pressure drop neglected), so [`crate::circuit::linearise`] gives its linear model.
//! At rest the force balance p1 A1 − p2 A2 = F_ext with the open chamber at p_acc picks the
//! mode: mode 1 above the switching force p_acc (A1 − A2), mode 2 below it ([`switching`]).

use super::{SinglePump, P1, X};
use crate::circuit::{Circuit, CircuitKind, ControlLaw, OperatingState, Scalar, Signal};
use crate::lti::{LtiError, StateSpace};
use crate::rig::Rig;
use nalgebra::DMatrix;

/// One mode of the single-pump circuit: one chamber held at the accumulator pressure.
#[derive(Debug, Clone, PartialEq)]
pub struct Mode {
    /// The circuit's equations without the check valves.
    full: SinglePump,
    /// The chamber at the accumulator, 0 (mode 2) or 1 (mode 1).
    acc: usize,
}

impl Mode {
    /// The mode of `rig` whose chamber `accumulator_chamber` (1 or 2) is held at the accumulator
    /// pressure: 2 is mode 1, 1 is mode 2.
    ///
    /// # Panics
    /// When `accumulator_chamber` is neither 1 nor 2 (a caller's error, not a user's).
    pub fn new(rig: &Rig, accumulator_chamber: usize) -> Mode {
        assert!(
            matches!(accumulator_chamber, 1 | 2),
            "chamber {accumulator_chamber}: the circuit has chambers 1 and 2"
        );
        Mode {
            full: SinglePump::new(rig).without_check_valves(),
            acc: accumulator_chamber - 1,
        }
    }

    /// The pump's load torque on the motor (N·m) at chamber pressures `p_pa` (Pa gauge),
    /// D1 (p1 − p2) ([`SinglePump::load_torque_nm`]).
    pub fn load_torque_nm(&self, p_pa: [f64; 2]) -> f64 {
        self.full.load_torque_nm(p_pa)
    }

    /// The chamber held at the accumulator pressure (1 or 2).
    pub fn accumulator_chamber(&self) -> usize {
        self.acc + 1
    }

    /// The mode's number: 1 with chamber 2 at the accumulator, 2 with chamber 1.
    pub fn number(&self) -> usize {
        2 - self.acc
    }

    /// Whether this is the mode the rig rests in under its external force
    /// ([`SinglePump::accumulator_chamber_at_rest`]).
    pub fn at_rest(&self) -> bool {
        self.accumulator_chamber() == self.full.accumulator_chamber_at_rest()
    }

    /// The full circuit's state of the mode's state `s`: the accumulator chamber at p_acc.
    pub fn full_state<T: Scalar>(&self, s: &[T]) -> Vec<T> {
        let mut full = s.to_vec();
        full.insert(P1 + self.acc, T::from(self.full.p_acc));
        full
    }

    /// The 2 % settling time (s) of the slowest pole of the mode's closed loop, 4/|Re s|.
    ///
    /// # Errors
    /// A model the eigenvalue solver refuses ([`LtiError`]).
    pub fn settling_time_s(&self) -> Result<f64, LtiError> {
        let poles = self.open_loop()?.closed_loop_poles()?;
        let slowest = poles.iter().map(|p| p.re).fold(f64::NEG_INFINITY, f64::max);
        Ok(4.0 / slowest.abs())
    }

    /// The open loop e → x of the mode's linear model at its operating point: the control
    /// law's feedback on the position opened, the reference gain on the input, the position
    /// out (the loop `margins` analyses, docs/analysis.md).
    ///
    /// # Errors
    /// A model [`StateSpace::new`] refuses (a non-finite entry).
    pub fn open_loop(&self) -> Result<StateSpace, LtiError> {
        let op = self.operating_point();
        let (a, b) = crate::circuit::linearise(self, &op.state, &op.inputs);
        let law = self.control_law();
        let mut kx = law.kx.clone();
        kx.column_mut(X).fill(0.0);
        let n = a.nrows();
        let mut c = DMatrix::zeros(1, n);
        c[(0, X)] = 1.0;
        StateSpace::new(&a + &b * kx, &b * &law.kr, c, DMatrix::zeros(1, 1))
    }
}

/// `v` without its element `i`.
fn without<T: Clone>(v: &[T], i: usize) -> Vec<T> {
    (v.iter().enumerate())
        .filter(|(j, _)| *j != i)
        .map(|(_, x)| x.clone())
        .collect()
}

impl Circuit for Mode {
    fn kind(&self) -> CircuitKind {
        CircuitKind::SinglePump
    }

    fn states(&self) -> Vec<Signal> {
        without(&self.full.states(), P1 + self.acc)
    }

    fn inputs(&self) -> Vec<Signal> {
        self.full.inputs()
    }

    fn rhs<T: Scalar>(&self, s: &[T], u: &[T], dx: &mut [T]) {
        let full = self.full_state(s);
        let mut d = vec![T::from(0.0); full.len()];
        self.full.rhs(&full, u, &mut d);
        for (out, rate) in dx.iter_mut().zip(without(&d, P1 + self.acc)) {
            *out = rate;
        }
    }

    /// At rest at x0 with the accumulator chamber at p_acc and the other from the force
    /// balance (docs/circuits.md#its-two-modes).
    fn operating_point(&self) -> OperatingState {
        let op = self.full.rest_in(self.acc);
        OperatingState {
            state: without(&op.state, P1 + self.acc),
            inputs: op.inputs,
        }
    }

    /// The circuit's P law, ω_ref = K_scale Kp (x_ref − x).
    fn control_law(&self) -> ControlLaw {
        let law = self.full.control_law();
        ControlLaw {
            kx: law.kx.remove_column(P1 + self.acc),
            kr: law.kr,
        }
    }
}

pub use crate::circuit::switching::Switching;


/// The switching force of `rig` as a single-pump circuit, its valve band, the mode at rest for
/// the rig's external force and how far that force is from switching.
pub fn switching(rig: &Rig) -> Switching {
    let c = SinglePump::new(rig);
    let [a1, a2] = c.areas_m2();
    let f_s = c.accumulator_pa() * (a1 - a2);
    let crack = c.checks()[0].valve.crack_pa;
    let band = [f_s - a1 * crack, f_s + a2 * crack];
    let f = c.external_force_n();
    let mode_at_rest = 3 - c.accumulator_chamber_at_rest();
    Switching {
        switching_force_n: f_s,
        valve_band_n: band,
        external_force_n: f,
        mode_at_rest,
        force_from_switching_n: f - f_s,
        acceleration_to_switch_m_per_s2: (f_s - f) / rig.mass_kg,
        within_valve_band: f > band[0] && f < band[1],
    }
}

/// One mode's linear model at its operating point (docs/circuits.md#its-two-modes): what
/// `margins`, `poles`, `bode` and `step` report per mode.
#[derive(Debug, Clone)]
pub struct ModeModel {
    /// The chamber held at the accumulator pressure (1 or 2).
    pub accumulator_chamber: usize,
    /// The mode's number (1: chamber 2 on the accumulator, 2: chamber 1).
    pub mode: usize,
    /// The mode of the rig's operating point at rest ([`Switching::mode_at_rest`]).
    pub at_rest: bool,
    /// The mode's states.
    pub states: Vec<Signal>,
    /// Its operating point.
    pub operating_point: OperatingState,
    /// ∂f/∂x there.
    pub a: DMatrix<f64>,
    /// ∂f/∂u there.
    pub b: DMatrix<f64>,
    /// The open loop e → x ([`Mode::open_loop`]).
    pub open_loop: StateSpace,
}

/// Both modes' linear models of `rig` as a single-pump circuit, mode 1 first.
///
/// # Errors
/// A model [`StateSpace::new`] refuses (a non-finite entry).
pub fn linear_models(rig: &Rig) -> Result<[ModeModel; 2], LtiError> {
    let at_rest = switching(rig).mode_at_rest;
    let model = |chamber: usize| -> Result<ModeModel, LtiError> {
        let m = Mode::new(rig, chamber);
        let op = m.operating_point();
        let (a, b) = crate::circuit::linearise(&m, &op.state, &op.inputs);
        Ok(ModeModel {
            accumulator_chamber: chamber,
            mode: m.number(),
            at_rest: m.number() == at_rest,
            states: m.states(),
            open_loop: m.open_loop()?,
            operating_point: op,
            a,
            b,
        })
    };
    Ok([model(2)?, model(1)?])
}

/// The mode at state `s` of the full equations: 1 when the check valve into chamber 2 is the
/// open one (chamber 2 on the accumulator), 2 when chamber 1's is; when both are open the one
/// opened further; `None` while both are shut (the cylinder locked between the two).
pub fn mode_of(c: &SinglePump, s: &[f64]) -> Option<usize> {
    let [s1, s2] = c.valve_signals_pa(s);
    let crack = c.checks()[0].valve.crack_pa;
    if s1.max(s2) <= crack {
        None
    } else if s2 >= s1 {
        Some(1)
    } else {
        Some(2)
    }
}

/// The mode a record shows at state `s` of the full equations (docs/emulator.md#the-mode-signal):
/// 1 when the check valve into chamber 2 has at least the opening signal of the valve into
/// chamber 1, 2 otherwise — the valve opened further, or, while both are shut, the one nearer
/// to opening. It is [`mode_of`] wherever a valve is open.
pub fn recorded_mode(c: &SinglePump, s: &[f64]) -> usize {
    let [s1, s2] = c.valve_signals_pa(s);
    if s2 >= s1 {
        1
    } else {
        2
    }
}

/// Counts mode switches along a run: a switch is the accumulator connection moving from one
/// chamber to the other; passing through both valves shut on the way counts once, and a valve
/// that shuts and reopens on the same chamber not at all.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SwitchCounter {
    last: Option<usize>,
    /// Switches so far.
    pub switches: usize,
}

impl SwitchCounter {
    /// Starting in `mode` (or undetermined).
    pub fn starting_in(mode: Option<usize>) -> SwitchCounter {
        SwitchCounter {
            last: mode,
            switches: 0,
        }
    }

    /// Take the mode of the next sample; true when it is a switch.
    pub fn observe(&mut self, mode: Option<usize>) -> bool {
        let Some(m) = mode else { return false };
        let switched = self.last.is_some_and(|l| l != m);
        self.switches += usize::from(switched);
        self.last = Some(m);
        switched
    }
}

/// Integrates the equations of `c` (the full circuit or a mode) in closed loop under its
/// control law about the operating point `op`, u = u0 + Kx (x − x_op) + Kr (x_ref(t) − x_op):
/// the article's P law as a continuous controller, ω_ref = ω_ref,0 + K_scale Kp (x_ref − x) (no
/// PLC sampling; ω_ref,0 the command that holds the rest, as in the linear model). From
/// `start` for `seconds`, by classical RK4 in steps of `step_s`, calling `observe(t, state)`
/// after every step; returns the end state.
pub fn closed_loop<C: Circuit>(
    c: &C,
    op: &OperatingState,
    start: &[f64],
    x_ref: impl Fn(f64) -> f64,
    seconds: f64,
    step_s: f64,
    mut observe: impl FnMut(f64, &[f64]),
) -> Vec<f64> {
    let n = start.len();
    let law = c.control_law();
    let f = |t: f64, s: &[f64], out: &mut [f64]| {
        let u: Vec<f64> = (0..op.inputs.len())
            .map(|i| {
                let fb: f64 = (0..n).map(|j| law.kx[(i, j)] * (s[j] - op.state[j])).sum();
                op.inputs[i] + fb + law.kr[(i, 0)] * (x_ref(t) - op.state[X])
            })
            .collect();
        c.rhs(s, &u, out);
    };
    let steps = (seconds / step_s).round().max(0.0) as usize;
    let h = step_s;
    let mut s = start.to_vec();
    let [mut k1, mut k2, mut k3, mut k4, mut tmp] = [(); 5].map(|_| vec![0.0; n]);
    let stage = |s: &[f64], k: &[f64], w: f64, tmp: &mut Vec<f64>| {
        for ((t, a), b) in tmp.iter_mut().zip(s).zip(k) {
            *t = a + w * b;
        }
    };
    for i in 0..steps {
        let t = i as f64 * h;
        f(t, &s, &mut k1);
        stage(&s, &k1, 0.5 * h, &mut tmp);
        f(t + 0.5 * h, &tmp, &mut k2);
        stage(&s, &k2, 0.5 * h, &mut tmp);
        f(t + 0.5 * h, &tmp, &mut k3);
        stage(&s, &k3, h, &mut tmp);
        f(t + h, &tmp, &mut k4);
        for m in 0..n {
            s[m] += h / 6.0 * (k1[m] + 2.0 * k2[m] + 2.0 * k3[m] + k4[m]);
        }
        observe(t + h, &s);
    }
    s
}

/// The closed-loop step check: from rest, a position step, and whether the circuit switches
/// modes (docs/circuits.md#will-it-chatter).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepCheck {
    /// The position step (m).
    pub step_m: f64,
    /// Time held at x0 before the step, for the full equations to find their own rest (s).
    pub hold_s: f64,
    /// Time the run goes on after the step has settled (s), over which a sustained
    /// oscillation is measured.
    pub tail_s: f64,
    /// RK4 step (s).
    pub step_s: f64,
}

/// The longest settling time a check waits for (s): a bound on the run.
pub const MAX_SETTLING_S: f64 = 120.0;

impl StepCheck {
    /// The article's 5 mm step (§3.3), held 2 s at x0 before it, watched for 10 s after it
    /// has settled **\[choice\]**, RK4 in 0.1 ms steps (a tenth of the stiffest time
    /// constant, the current loop's 0.8 ms).
    pub const ARTICLE: StepCheck = StepCheck {
        step_m: 5e-3,
        hold_s: 2.0,
        tail_s: 10.0,
        step_s: 1e-4,
    };

    /// Runs the check on `c` from the operating point of its load: the step has settled at
    /// the 2 % settling time of the slowest closed-loop pole of the mode at rest's linear model,
    /// 4/|Re s| ([`Mode::settling_time_s`]), at most [`MAX_SETTLING_S`].
    ///
    /// # Errors
    /// The mode's linear model cannot be analysed ([`LtiError`]).
    pub fn run(&self, c: &SinglePump) -> Result<StepVerdict, LtiError> {
        let op = c.operating_point();
        let mode = Mode {
            full: c.without_check_valves(),
            acc: c.accumulator_chamber_at_rest() - 1,
        };
        let settle_s = mode.settling_time_s()?.min(MAX_SETTLING_S);
        let x0 = op.state[X];
        let rest = closed_loop(
            c,
            &op,
            &op.state,
            |_| x0,
            self.hold_s,
            self.step_s,
            |_, _| {},
        );
        let mut counter = SwitchCounter::starting_in(mode_of(c, &rest));
        let mut after = None;
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        let target = x0 + self.step_m;
        let seconds = settle_s + self.tail_s;
        let end = closed_loop(
            c,
            &op,
            &rest,
            |_| target,
            seconds,
            self.step_s,
            |t, s| {
                counter.observe(mode_of(c, s));
                if t >= settle_s {
                    after.get_or_insert(counter.switches);
                    lo = lo.min(s[X]);
                    hi = hi.max(s[X]);
                }
            },
        );
        let settled_at = after.unwrap_or(counter.switches);
        let amplitude = 0.5 * (hi - lo);
        Ok(StepVerdict {
            external_force_n: c.external_force_n(),
            settling_time_s: settle_s,
            mode_before: mode_of(c, &rest),
            mode_after: mode_of(c, &end),
            switches: counter.switches,
            switches_after_settling: counter.switches - settled_at,
            amplitude_after_settling_m: amplitude,
            final_error_m: target - end[X],
            settles_without_switching: counter.switches == 0
                && amplitude < SETTLED_FRACTION * self.step_m,
        })
    }
}

/// Half the peak-to-peak position after the settling time, as a fraction of the step, below
/// which the step has settled: 2 %, the settling band **\[choice\]**.
pub const SETTLED_FRACTION: f64 = 0.02;

/// What a [`StepCheck`] found.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct StepVerdict {
    /// The external force (N).
    pub external_force_n: f64,
    /// The settling time of the mode at rest's linear model (s).
    pub settling_time_s: f64,
    /// The mode at rest before the step (`None`: both valves shut).
    pub mode_before: Option<usize>,
    /// The mode at the end of the run.
    pub mode_after: Option<usize>,
    /// Mode switches after the step.
    pub switches: usize,
    /// Mode switches after the settling time.
    pub switches_after_settling: usize,
    /// Half the peak-to-peak position after the settling time (m): the amplitude of any
    /// sustained oscillation.
    pub amplitude_after_settling_m: f64,
    /// Reference less position at the end (m): the P law's steady error.
    pub final_error_m: f64,
    /// No switch after the step, and settled within [`SETTLED_FRACTION`] of the step.
    pub settles_without_switching: bool,
}

/// [`StepCheck::run`] on the circuit `c` (its own equations, [`SinglePump::new`], or the
/// emulator's) at each external force of `forces_n` (N): the scan that gives the range of
/// loads over which the step settles without switching.
///
/// # Errors
/// A mode's linear model cannot be analysed ([`LtiError`]).
pub fn scan_forces(
    c: &SinglePump,
    check: &StepCheck,
    forces_n: &[f64],
) -> Result<Vec<StepVerdict>, LtiError> {
    let mut c = c.clone();
    (forces_n.iter())
        .map(|f| {
            c.set_external_force_n(*f);
            check.run(&c)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rig() -> Rig {
        Rig::default()
            .with_overrides(&["circuit=single-pump".into()])
            .unwrap()
    }

    #[test]
    fn a_switch_is_the_accumulator_moving_to_the_other_chamber() {
        let mut c = SwitchCounter::starting_in(Some(2));
        let seen = [
            Some(2),
            None,
            Some(2),
            Some(1),
            None,
            None,
            Some(2),
            Some(2),
        ];
        let switched: Vec<bool> = seen.iter().map(|m| c.observe(*m)).collect();
        assert_eq!(c.switches, 2);
        assert_eq!(switched.iter().filter(|s| **s).count(), 2);
        assert!(switched[3] && switched[6]);
        // an undetermined start counts nothing until the second mode
        let mut c = SwitchCounter::starting_in(None);
        c.observe(Some(1));
        assert_eq!(c.switches, 0);
    }

    #[test]
    fn the_pilot_decides_the_mode_of_a_state() {
        let rig = rig();
        let c = SinglePump::new(&rig);
        let p_acc = c.accumulator_pa();
        let mut s = c.operating_point().state;
        (s[2], s[3]) = (p_acc, p_acc);
        assert_eq!(mode_of(&c, &s), None);
        // chamber 2 two bar up pilots valve 1 open: chamber 1 on the accumulator, mode 2
        s[3] = p_acc + 2e5;
        assert_eq!(mode_of(&c, &s), Some(2));
        (s[2], s[3]) = (p_acc + 2e5, p_acc);
        assert_eq!(mode_of(&c, &s), Some(1));
        // chamber 2 a cracking pressure below the accumulator, unpiloted: its check opens
        (s[2], s[3]) = (p_acc, p_acc - 0.6e5);
        assert_eq!(mode_of(&c, &s), Some(1));
    }

    /// At no load the full equations rest at mode 2's operating point but for the open valve's
    /// drop: the leakage surplus of chamber 1, −c2 (p2 − p_acc), goes back to the accumulator
    /// through the piloted valve, which needs chamber 1 123 Pa above p_acc
    /// (docs/circuits.md#its-two-modes).
    #[test]
    fn the_full_rest_is_the_modes_to_the_open_valves_drop() {
        let rig = rig();
        let c = SinglePump::new(&rig);
        let op = c.operating_point();
        let mut dx = vec![0.0; op.state.len()];
        c.rhs(&op.state, &op.inputs, &mut dx);
        // every rate zero but chamber 1's, which the valve's missing flow leaves
        for (i, d) in dx.iter().enumerate().filter(|(i, _)| *i != P1) {
            assert!(d.abs() < 1e-9, "state {i}: {d}");
        }
        let si = rig.si();
        let p_acc = c.accumulator_pa();
        let surplus = dx[P1] * si.v1 / si.beta;
        let want = -si.c2 * (op.state[P1 + 1] - p_acc);
        assert!((surplus / want - 1.0).abs() < 1e-9, "{surplus} vs {want}");
        let out = |rise: f64| -c.checks()[0].into_chamber(p_acc + rise, op.state[P1 + 1], p_acc);
        assert!(out(122.0) < surplus && out(124.0) > surplus);
    }

    #[test]
    fn both_modes_come_with_their_models_and_the_one_at_rest_is_marked() {
        let models = linear_models(&rig()).unwrap();
        let got: Vec<(usize, usize, bool)> = (models.iter())
            .map(|m| (m.mode, m.accumulator_chamber, m.at_rest))
            .collect();
        assert_eq!(got, [(1, 2, false), (2, 1, true)]);
        for m in &models {
            let names: Vec<&str> = m.states.iter().map(|s| s.name.as_str()).collect();
            let p = if m.mode == 1 { "p1" } else { "p2" };
            assert_eq!(names, ["x", "v", p, "w", "tau", "z"]);
            assert_eq!((m.a.nrows(), m.b.ncols()), (6, 1));
            // the open loop's A is A less the position feedback, which is absent from A
            assert_eq!(m.open_loop.a, m.a);
        }
    }

    #[test]
    fn the_switching_force_and_its_band() {
        let rig = rig();
        let si = rig.si();
        let s = switching(&rig);
        let f_s = 6.91e5 * (si.a1 - si.a2);
        assert!((s.switching_force_n / f_s - 1.0).abs() < 1e-12);
        assert_eq!((s.mode_at_rest, s.within_valve_band), (2, false));
        assert!((s.acceleration_to_switch_m_per_s2 - f_s / 10593.0).abs() < 1e-12);
        let loaded = Rig {
            external_force_n: 700.0,
            ..rig
        };
        let s = switching(&loaded);
        assert_eq!((s.mode_at_rest, s.within_valve_band), (2, true));
        assert!(s.force_from_switching_n < 0.0 && s.force_from_switching_n > -4.0);
    }
}
