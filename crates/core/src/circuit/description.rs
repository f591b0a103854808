//! What a circuit module says about itself (docs/architecture.md#circuits): its
//! [`Description`] (name, words, drives, the keys only it has, where its pressure level and
//! bulk modulus are anchored) and its forms behind the [`Module`] trait (its linear models, its
//! emulated form, the checks of its rest). The list of circuits in `circuit/mod.rs` is the
//! only place that names them all: [`CircuitKind`], [`AnyCircuit`] and [`Emulated`] are made
//! from it by the `circuits!` macro, and everything else asks a circuit's description or its
//! module's forms, never which circuit it is.

use super::stops::Stops;
use super::switching::Switching;
use super::{Circuit, CircuitKind, ControlLaw, Effects};
use crate::rig::Rig;

/// Where a circuit's pressure level (and so the pressure its `beta_bar` is read at) comes
/// from (docs/circuits.md, docs/emulator.md#every-circuit).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Level {
    /// The rig key that sets it: `p_sum_ref_bar`, `accumulator_precharge_bar`.
    pub key: &'static str,
    /// It in words: `the rig's mean chamber pressure at rest`, `the accumulator pre-charge`.
    pub words: &'static str,
    /// Whether the emulator's bulk modulus is anchored at the emulated loop's own mean chamber
    /// pressure at rest (the DPM's, whose sum-pressure loop holds it) rather than at the
    /// level itself (an accumulator's pre-charge).
    pub at_emulated_rest: bool,
}

impl Level {
    /// A one-motor circuit's: its accumulator's pre-charge.
    pub const ACCUMULATOR: Level = Level {
        key: "accumulator_precharge_bar",
        words: "the accumulator pre-charge",
        at_emulated_rest: false,
    };
}

/// How a `select` candidate's pressure level is set (docs/select.md#circuits).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PressureLevel {
    /// The DPM's mean chamber pressure at the article's low levels (its 1 to 10 bar), half the
    /// sum-pressure set-point.
    LowPressure,
    /// The DPM's mean chamber pressure raised to tens of bar (the pressurised dual-prime-mover
    /// circuit of the article's references 5 and 10).
    Pressurised,
    /// The accumulator's pre-charge `accumulator_precharge_bar` of a one-motor circuit.
    Precharge,
    /// A valve-controlled cylinder's supply pressure (its [`Level::key`]); its β_e is read at
    /// the mean chamber pressure its valve holds at rest from that supply.
    Supply,
}

impl PressureLevel {
    /// The `select` application key that lists the levels of this kind.
    pub fn levels_key(self) -> &'static str {
        match self {
            PressureLevel::LowPressure => "low_pressure_bar",
            PressureLevel::Pressurised => "pressurised_bar",
            PressureLevel::Precharge => "precharge_bar",
            PressureLevel::Supply => "supply_bar",
        }
    }
}

/// A variant of a circuit that `select` offers as a candidate: how its pressure level is set
/// and its names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Variant {
    /// How its pressure level is set.
    pub level: PressureLevel,
    /// It in words: `low-pressure`, `dual-pump`.
    pub name: &'static str,
    /// Its JSON key: `low_pressure`, `dual_pump`.
    pub key: &'static str,
}

/// A rig key that its circuit's module alone declares (docs/architecture.md#keys-a-circuit-declares):
/// its name (the unit in it), its meaning, the value a rig that leaves it out takes and its
/// allowed range. A rig holds its value in [`Rig::circuit_keys`]; every front end, the
/// commented TOML, `--set`, the FMU's parameters and Python's `Rig` list it from here.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Key {
    /// The TOML key, its unit in its name: `supply_pressure_bar`.
    pub name: &'static str,
    /// Its unit and meaning, as the commented TOML writes them.
    pub doc: &'static str,
    /// The value a rig that leaves it out takes, in its unit.
    pub default: f64,
    /// Its allowed range, in its unit.
    pub range: crate::rig::Range,
}

/// The rig keys of a circuit's first drive and pump, their leakages and the drives' law: keys
/// of every circuit with drives, and of no circuit without (a valve-controlled cylinder's file
/// that writes them is refused, and its notes do not list them as defaulted). The second
/// drive's and pump's keys are the own keys of the circuits that have them.
pub const DRIVE_KEYS: &[&str] = &[
    "motor_inertia_1_kg_mm2",
    "pump_inertia_1_kg_mm2",
    "displacement_1_cm3_per_rev",
    "current_loop_bandwidth_rad_per_s",
    "km1_nms_per_rad",
    "kff_kg_m2",
    "tau_ff_s",
    "k_scale_rad_per_s",
    "motor_time_constant_s",
    "motor_rated_torque_nm",
    "motor_rated_speed_rpm",
    "pump_max_speed_rpm",
    "c12_m5_per_ns",
    "c1_m5_per_ns",
    "c2_m5_per_ns",
    "pump_dead_band_rpm",
    "pump_slip_m5_per_ns",
    "feedforward",
    "motor_coupling",
    "motor_model",
];

/// The keys `a` then `b` as one list: a circuit's own keys after keys it shares with others
/// (the drives' [`super::energy::LOSS_KEYS`]). `N` must be their number.
pub const fn joined<const N: usize>(a: &[Key], b: &[Key]) -> [Key; N] {
    assert!(a.len() + b.len() == N, "N is the number of keys joined");
    let mut out = [a[0]; N];
    let mut i = 0;
    while i < N {
        out[i] = if i < a.len() { a[i] } else { b[i - a.len()] };
        i += 1;
    }
    out
}

/// A circuit in the words and numbers every part of pumpcyl outside its module asks for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Description {
    /// The name in rig files and every output: `dpm`, `dual-pump`, `single-pump`.
    pub name: &'static str,
    /// The circuit as an FMU's description names it, e.g. `dual-prime-mover`.
    pub fmu_words: &'static str,
    /// The article's controller on it, in words (an FMU's description).
    pub controller_words: &'static str,
    /// How many drives (motors) the PLC commands.
    pub drives: usize,
    /// How many servo valves the PLC commands (their spools).
    pub servo_valves: usize,
    /// How many pumps it has (what a rig of it can be rebuilt as: docs/select.md#circuits).
    pub pumps: usize,
    /// The variants `select` offers of it, in order.
    pub variants: &'static [Variant],
    /// Whether its controller has a sum-pressure loop beside the position loop (the DPM's,
    /// the article §2.3.3).
    pub sum_pressure_loop: bool,
    /// Where its pressure level comes from.
    pub level: Level,
    /// The valves its emulated form has, in words (`None`: none).
    pub valves: Option<&'static str>,
    /// The rig keys that only some circuits have and this one does (docs/circuits.md).
    pub own_keys: &'static [&'static str],
    /// The rig keys its module declares, with units, defaults and ranges (held in
    /// [`Rig::circuit_keys`], not as fields of the rig).
    pub keys: &'static [Key],
    /// Why it has no modes to switch between, in one line (`None`: it has modes, the
    /// single-pump circuit's: docs/circuits.md#its-two-modes).
    pub no_modes: Option<&'static str>,
}

impl Description {
    /// How many commands the PLC sends: one per drive and one per servo valve, the inputs of
    /// its equations in order.
    pub const fn commands(&self) -> usize {
        self.drives + self.servo_valves
    }
}

/// A linear form of a circuit, what [`AnyCircuit`](super::AnyCircuit) holds: its equations without effects, the
/// control law at its operating point, what its drives carry and its name in words.
pub trait LinearForm: Circuit + Clone + std::fmt::Debug {
    /// The control law at the operating point, with the sum-pressure loop where
    /// `sum_pressure` and the circuit has one.
    fn law(&self, sum_pressure: bool) -> ControlLaw;
    /// The load torques of the pumps on motors 1 and 2 (N·m) at the chamber pressures (Pa
    /// gauge), what the drives' ratings are checked against (0 for a motor it lacks).
    fn load_torques_nm(&self, p_pa: [f64; 2]) -> [f64; 2];
    /// The circuit in words, as every analysis names it.
    fn describe(&self) -> String;
    /// The mode this linear model is, for a circuit with modes.
    fn mode(&self) -> Option<usize> {
        None
    }
    /// The leakages c1, c2 that hold a standstill for a cross-port leakage `c12`
    /// (docs/identification.md#leakage-from-standstill); `None` where the circuit's standstill
    /// does not determine them.
    fn standstill_leakage(
        &self,
        _rig: &Rig,
        _s: &super::dpm::Standstill,
        _c12: f64,
    ) -> Option<Result<super::dpm::Leakage, String>> {
        None
    }
    /// Why a standstill at the chamber pressures `p_pa` (Pa gauge) is not leakage alone (a
    /// valve open feeds it, docs/circuits.md#identification-where-a-valve-is-open).
    ///
    /// # Errors
    /// That reason, in one line.
    fn standstill_valves_shut(&self, _p_pa: [f64; 2]) -> Result<(), String> {
        Ok(())
    }
    /// Where a valve of its rest is open, the chamber, its pressure, the accumulator's (bar
    /// gauge) and the valve's flow (m³/s) (docs/circuits.md#valves).
    fn valve_open_at_rest(&self) -> Option<(usize, f64, f64, f64)> {
        None
    }
}

/// The emulated form of a circuit, what [`Emulated`](super::Emulated) holds: its equations with the chosen
/// effects, its end stops, its rest and its PLC law in absolute terms.
pub trait EmulatedForm: Circuit + Clone + std::fmt::Debug {
    /// Number of states.
    fn order(&self) -> usize;
    /// Change the external force on the piston (N); the operating point stays the rig's.
    fn set_force_n(&mut self, f_n: f64);
    /// The end stops, if they act.
    fn end_stops(&self) -> Option<Stops>;
    /// The same circuit without the limits a Newton step at rest may cross.
    fn free(&self) -> Self;
    /// Bulk modulus (Pa) of the chambers at a mean gauge pressure (Pa).
    fn beta_at_pa(&self, p_gauge: f64) -> f64;
    /// The rest at x0 as a state and the speed commands that hold it (0 for a drive the
    /// circuit does not have).
    fn rest_with_commands(&self) -> (Vec<f64>, [f64; 2]);
    /// The speed commands (rad/s) of its PLC law for the reference `r_mm`, the measured
    /// position `x_mm` (mm) and pressures `p_bar` (bar gauge), in absolute terms.
    fn commands(&self, rig: &Rig, r_mm: f64, x_mm: f64, p_bar: &[f64]) -> [f64; 2];
    /// Its mode at state `s`, for a circuit with modes.
    fn mode_at(&self, _s: &[f64]) -> Option<usize> {
        None
    }
    /// Where its power goes at state `s` under commands `u` (docs/energy.md): its sources, the
    /// work against the external force, each loss and each stored energy's rate, read off the
    /// same parts as its equations, so they close to rounding.
    fn power(&self, s: &[f64], u: &[f64]) -> super::energy::Power;
}

/// A circuit module: its description and its forms. Implemented once, by the module's
/// `Module`, and listed once in `circuit/mod.rs`.
pub trait Module {
    /// What the circuit is.
    const DESCRIPTION: Description;
    /// Its linear form.
    type Linear: LinearForm;
    /// Its emulated form.
    type Emulated: EmulatedForm;

    /// The linear model at rest (a circuit with modes: the mode its rest is in), what a
    /// plant holds.
    fn linear(rig: &Rig) -> Self::Linear;

    /// Every linear model its loop runs in, the one at rest ([`Module::linear`]) first.
    fn linear_modes(rig: &Rig) -> Vec<Self::Linear> {
        vec![Self::linear(rig)]
    }

    /// Its emulated form with the chosen effects.
    ///
    /// # Errors
    /// A rig whose rest the circuit cannot determine.
    fn emulated(rig: &Rig, effects: Effects) -> Result<Self::Emulated, String>;

    /// The check of its rest a rig must pass: the key, its value and the rule it breaks.
    ///
    /// # Errors
    /// A rig whose circuit cannot rest as its keys say.
    fn validate_rest(_rig: &Rig) -> Result<(), (&'static str, f64, String)> {
        Ok(())
    }

    /// Where it switches between modes (docs/circuits.md#the-switching-force), or why it
    /// has none.
    ///
    /// # Errors
    /// Its [`Description::no_modes`] for a circuit without modes.
    fn mode_switching(_rig: &Rig) -> Result<Switching, &'static str> {
        Err(Self::DESCRIPTION
            .no_modes
            .unwrap_or("the circuit has no modes"))
    }

    /// The mean chamber pressure (bar gauge) it holds at rest, the level its `beta_bar` is
    /// read at.
    fn pressure_level_bar(rig: &Rig) -> f64;

    /// This circuit (`kind`) built on the cylinder, load and fluid of `rig`, whichever circuit
    /// `rig` is (docs/select.md#circuits): the same rig with its circuit changed, unless the
    /// module needs more (a servo valve replacing pumps is sized for them).
    fn built_on(rig: &Rig, kind: CircuitKind) -> Rig {
        Rig {
            circuit: kind,
            ..rig.clone()
        }
    }

    /// The pumps' displacement (m³/rad) its relief valves' derived setting loads the motor
    /// with (docs/circuits.md#valves).
    fn relief_displacement_m3_per_rad(rig: &Rig) -> f64 {
        rig.si().d[0]
    }

    /// The band (bar gauge) a chamber pressure keeps to for its linear model to hold, each
    /// edge with what sets it (docs/identification.md#designing-the-sweep).
    fn pressure_band_bar(rig: &Rig) -> [(f64, &'static str); 2];

    /// A one-motor circuit at rest, every valve as its equations have it
    /// (docs/select.md#cost).
    ///
    /// # Errors
    /// A circuit with more than one drive, or whose rest is undetermined.
    fn one_motor_rest(rig: &Rig) -> Result<OneMotorRest, String> {
        Err(format!(
            "the {} circuit has {} drives, not one",
            rig.circuit.name(),
            Self::DESCRIPTION.drives
        ))
    }

    /// A circuit fed from a constant-pressure supply at rest (docs/select.md#cost).
    ///
    /// # Errors
    /// A circuit without a supply, or whose rest is undetermined.
    fn supply_rest(rig: &Rig) -> Result<SupplyRest, String> {
        Err(format!("the {} circuit has no supply", rig.circuit.name()))
    }
}

/// A circuit fed from a constant-pressure supply at rest: its chamber pressures and the power
/// the supply delivers there, all of it lost as heat (docs/select.md#cost).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SupplyRest {
    /// The chamber pressures (Pa gauge).
    pub p_pa: [f64; 2],
    /// The flow the supply delivers at rest (m³/s).
    pub flow_m3_s: f64,
    /// The power it delivers, (p_s − p_t)·Q (W).
    pub power_w: f64,
}

/// A one-motor circuit at rest: its chamber pressures, its shaft's speed and the torque its
/// pumps load the motor with there, what the drive carries to feed the leakage
/// (docs/select.md#cost).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OneMotorRest {
    /// The chamber pressures (Pa gauge).
    pub p_pa: [f64; 2],
    /// The shaft speed (rad/s).
    pub w_rad_per_s: f64,
    /// The pumps' load torque on the motor (N·m).
    pub torque_nm: f64,
}

/// The rest of a one-motor circuit `c` at its operating point, its pumps' load torque at the
/// chamber pressures `torque_nm(p_pa)`.
pub(crate) fn one_motor_rest_of<C: Circuit>(
    c: &C,
    torque_nm: impl Fn([f64; 2]) -> f64,
) -> OneMotorRest {
    use super::Role;
    let op = c.operating_point();
    let p = c.states_of(Role::Pressure);
    let w = c.state_of(Role::MotorSpeed).expect("a circuit has a shaft");
    let p_pa = [op.state[p[0]], op.state[p[1]]];
    OneMotorRest {
        p_pa,
        w_rad_per_s: op.state[w],
        torque_nm: torque_nm(p_pa),
    }
}

/// The list of circuits, once: `circuits! { /// doc; Variant: module, ... }` declares each
/// module (`pub mod module;`) and makes [`CircuitKind`], [`AnyCircuit`] and [`Emulated`] of
/// their `module::Module`s, with every call dispatched to the circuit's own.
macro_rules! circuits {
    ($($(#[$doc:meta])* $variant:ident: $module:ident),+ $(,)?) => {
        $(pub mod $module;)+

        /// Which hydraulic circuit a rig is (the rig key `circuit`).
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
        #[serde(rename_all = "kebab-case")]
        pub enum CircuitKind {
            $($(#[$doc])* $variant),+
        }

        impl CircuitKind {
            /// Every circuit pumpcyl models, in the order of the list.
            pub const ALL: [CircuitKind; [$(stringify!($variant)),+].len()] =
                [$(CircuitKind::$variant),+];

            /// What the circuit is ([`Description`]).
            pub fn description(self) -> &'static Description {
                match self {
                    $(CircuitKind::$variant => &<$module::Module as Module>::DESCRIPTION),+
                }
            }

            /// The linear model of `rig` at rest ([`Module::linear`]).
            pub fn linear(self, rig: &$crate::rig::Rig) -> AnyCircuit {
                match self {
                    $(CircuitKind::$variant =>
                        AnyCircuit::$variant(<$module::Module as Module>::linear(rig))),+
                }
            }

            /// Every linear model the loop of `rig` runs in, the one at rest first.
            pub fn linear_modes(self, rig: &$crate::rig::Rig) -> Vec<AnyCircuit> {
                match self {
                    $(CircuitKind::$variant => <$module::Module as Module>::linear_modes(rig)
                        .into_iter()
                        .map(AnyCircuit::$variant)
                        .collect()),+
                }
            }

            /// The emulated circuit of `rig` with the chosen effects.
            ///
            /// # Errors
            /// A rig whose rest the circuit cannot determine.
            pub fn emulated(self, rig: &$crate::rig::Rig, effects: Effects) -> Result<Emulated, String> {
                match self {
                    $(CircuitKind::$variant =>
                        <$module::Module as Module>::emulated(rig, effects).map(Emulated::$variant)),+
                }
            }

            /// [`Module::validate_rest`] of the circuit.
            ///
            /// # Errors
            /// As the circuit's own.
            pub fn validate_rest(self, rig: &$crate::rig::Rig) -> Result<(), (&'static str, f64, String)> {
                match self {
                    $(CircuitKind::$variant => <$module::Module as Module>::validate_rest(rig)),+
                }
            }

            /// [`Module::mode_switching`] of the circuit.
            ///
            /// # Errors
            /// Why a circuit without modes has none.
            pub fn mode_switching(self, rig: &$crate::rig::Rig) -> Result<Switching, &'static str> {
                match self {
                    $(CircuitKind::$variant => <$module::Module as Module>::mode_switching(rig)),+
                }
            }

            /// [`Module::pressure_level_bar`] of the circuit.
            pub fn pressure_level_bar(self, rig: &$crate::rig::Rig) -> f64 {
                match self {
                    $(CircuitKind::$variant => <$module::Module as Module>::pressure_level_bar(rig)),+
                }
            }

            /// [`Module::built_on`] of the circuit.
            pub fn built_on(self, rig: &$crate::rig::Rig) -> $crate::rig::Rig {
                match self {
                    $(CircuitKind::$variant => <$module::Module as Module>::built_on(rig, self)),+
                }
            }

            /// [`Module::relief_displacement_m3_per_rad`] of the circuit.
            pub fn relief_displacement_m3_per_rad(self, rig: &$crate::rig::Rig) -> f64 {
                match self {
                    $(CircuitKind::$variant =>
                        <$module::Module as Module>::relief_displacement_m3_per_rad(rig)),+
                }
            }

            /// [`Module::one_motor_rest`] of the circuit.
            ///
            /// # Errors
            /// As the circuit's own.
            pub fn one_motor_rest(self, rig: &$crate::rig::Rig) -> Result<OneMotorRest, String> {
                match self {
                    $(CircuitKind::$variant => <$module::Module as Module>::one_motor_rest(rig)),+
                }
            }

            /// [`Module::supply_rest`] of the circuit.
            ///
            /// # Errors
            /// As the circuit's own.
            pub fn supply_rest(self, rig: &$crate::rig::Rig) -> Result<SupplyRest, String> {
                match self {
                    $(CircuitKind::$variant => <$module::Module as Module>::supply_rest(rig)),+
                }
            }

            /// Whether the circuit has modes to switch between ([`Description::no_modes`]).
            pub fn has_modes(self) -> bool {
                self.description().no_modes.is_none()
            }

            /// [`Module::pressure_band_bar`] of the circuit.
            pub fn pressure_band_bar(self, rig: &$crate::rig::Rig) -> [(f64, &'static str); 2] {
                match self {
                    $(CircuitKind::$variant => <$module::Module as Module>::pressure_band_bar(rig)),+
                }
            }
        }

        /// A linear model of any circuit: what [`crate::model::Plant`] holds.
        #[derive(Debug, Clone)]
        pub enum AnyCircuit {
            $($(#[$doc])* $variant(<$module::Module as Module>::Linear)),+
        }

        /// The emulated form of a rig's circuit.
        #[derive(Debug, Clone)]
        pub enum Emulated {
            $($(#[$doc])* $variant(<$module::Module as Module>::Emulated)),+
        }

        impl AnyCircuit {
            /// The control law at the operating point with the sum-pressure loop where
            /// `sum_pressure` (the article's P law alone otherwise; a circuit without that
            /// loop ignores it).
            pub fn law(&self, sum_pressure: bool) -> ControlLaw {
                match self { $(AnyCircuit::$variant(c) => $crate::circuit::LinearForm::law(c, sum_pressure)),+ }
            }

            /// The load torques of the pumps on motors 1 and 2 (N·m) at the chamber
            /// pressures `p_pa` (Pa gauge), what the drives' ratings are checked against; the
            /// single motor of a one-motor circuit is motor 1.
            pub fn load_torques_nm(&self, p_pa: [f64; 2]) -> [f64; 2] {
                match self { $(AnyCircuit::$variant(c) => $crate::circuit::LinearForm::load_torques_nm(c, p_pa)),+ }
            }

            /// The circuit in words, as every analysis names it: `dpm`, `dual-pump`, or
            /// `single-pump, mode M (chamber K at the accumulator pressure), the mode at
            /// rest` (`the other mode` for the mode the rig does not rest in).
            pub fn describe(&self) -> String {
                match self { $(AnyCircuit::$variant(c) => $crate::circuit::LinearForm::describe(c)),+ }
            }

            /// The mode this linear model is (the single-pump circuit's 1 or 2); `None` for a
            /// circuit without modes.
            pub fn mode(&self) -> Option<usize> {
                match self { $(AnyCircuit::$variant(c) => $crate::circuit::LinearForm::mode(c)),+ }
            }

            /// [`LinearForm::standstill_leakage`] of the circuit inside.
            pub fn standstill_leakage(
                &self,
                rig: &$crate::rig::Rig,
                s: &$crate::circuit::dpm::Standstill,
                c12: f64,
            ) -> Option<Result<$crate::circuit::dpm::Leakage, String>> {
                match self { $(AnyCircuit::$variant(c) => $crate::circuit::LinearForm::standstill_leakage(c, rig, s, c12)),+ }
            }

            /// [`LinearForm::standstill_valves_shut`] of the circuit inside.
            ///
            /// # Errors
            /// As the circuit's own.
            pub fn standstill_valves_shut(&self, p_pa: [f64; 2]) -> Result<(), String> {
                match self { $(AnyCircuit::$variant(c) => $crate::circuit::LinearForm::standstill_valves_shut(c, p_pa)),+ }
            }

            /// [`LinearForm::valve_open_at_rest`] of the circuit inside.
            pub fn valve_open_at_rest(&self) -> Option<(usize, f64, f64, f64)> {
                match self { $(AnyCircuit::$variant(c) => $crate::circuit::LinearForm::valve_open_at_rest(c)),+ }
            }
        }

        impl Emulated {
            /// Number of states.
            pub fn order(&self) -> usize {
                match self { $(Emulated::$variant(c) => $crate::circuit::EmulatedForm::order(c)),+ }
            }

            /// How many commands the PLC sends ([`Description::commands`]).
            pub fn commands(&self) -> usize {
                self.kind().description().commands()
            }

            /// Change the external force on the piston (N); the operating point stays the
            /// rig's.
            pub fn set_external_force_n(&mut self, f_n: f64) {
                match self { $(Emulated::$variant(c) => $crate::circuit::EmulatedForm::set_force_n(c, f_n)),+ }
            }

            /// The end stops, if they act.
            pub fn stops(&self) -> Option<Stops> {
                match self { $(Emulated::$variant(c) => $crate::circuit::EmulatedForm::end_stops(c)),+ }
            }

            /// The same circuit without the limits a Newton step at rest may cross (torque
            /// and speed limits, end stops).
            pub fn without_limits(&self) -> Emulated {
                match self { $(Emulated::$variant(c) => Emulated::$variant(c.free())),+ }
            }

            /// Bulk modulus (Pa) of the chambers at a mean gauge pressure (Pa).
            pub fn beta_pa(&self, p_gauge: f64) -> f64 {
                match self { $(Emulated::$variant(c) => $crate::circuit::EmulatedForm::beta_at_pa(c, p_gauge)),+ }
            }

            /// The circuit's rest at x0 as a state, with the motors carrying the pumps' load,
            /// and the commands that hold it, one per input ([`Emulated::commands`]) and 0 for
            /// one the circuit does not have: where the emulator's search for its loop's rest
            /// starts.
            pub fn rest_state(&self) -> (Vec<f64>, [f64; 2]) {
                match self { $(Emulated::$variant(c) => $crate::circuit::EmulatedForm::rest_with_commands(c)),+ }
            }

            /// The speed commands (rad/s) of the circuit's PLC law for the reference `r_mm`,
            /// the measured position `x_mm` (mm) and pressures `p_bar` (bar gauge, in the
            /// order of the pressure states), in absolute terms (0 for a drive it lacks).
            pub fn plc_commands(&self, rig: &$crate::rig::Rig, r_mm: f64, x_mm: f64, p_bar: &[f64]) -> [f64; 2] {
                match self { $(Emulated::$variant(c) => $crate::circuit::EmulatedForm::commands(c, rig, r_mm, x_mm, p_bar)),+ }
            }

            /// The circuit's mode at state `s` (the single-pump circuit's 1 with chamber 2 on
            /// the accumulator, 2 with chamber 1); `None` for a circuit without modes.
            pub fn mode(&self, s: &[f64]) -> Option<usize> {
                match self { $(Emulated::$variant(c) => $crate::circuit::EmulatedForm::mode_at(c, s)),+ }
            }

            /// Where the circuit's power goes at state `s` under commands `u`
            /// ([`EmulatedForm::power`], docs/energy.md).
            pub fn power(&self, s: &[f64], u: &[f64]) -> $crate::circuit::energy::Power {
                match self { $(Emulated::$variant(c) => $crate::circuit::EmulatedForm::power(c, s, u)),+ }
            }
        }

        delegate_circuit!(AnyCircuit { $($variant),+ });
        delegate_circuit!(Emulated { $($variant),+ });
    };
}
