//! Where a circuit's power goes at one instant (docs/energy.md): what its sources deliver
//! (the drives' shaft power, a valve's supply), the work the piston does against the external
//! force, each kind of loss, and the rate at which energy is stored (the load's and the drives'
//! motion, the oil's compression, the accumulator). Each term is read off the same parts and
//! flows as the circuit's equations ([`super::Circuit::rhs`]), so the account closes at every
//! state: sources = work out + losses + stored, to rounding (the tests check it on random
//! states of every circuit).

use super::parts::{Drive, Motor, Piston, Pump, ATMOSPHERE_PA};

/// The power flows of a circuit at one state (W).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Power {
    /// What the sources deliver, each by kind (`electrical`: what the drives' DC bus draws from
    /// the supply, `regenerated`: what it returns, negative; `supply`: a valve's supply pressure
    /// times its flow).
    pub sources_w: Vec<(&'static str, f64)>,
    /// The power the piston delivers against the external force, F_ext·v.
    pub work_out_w: f64,
    /// Each kind of loss.
    pub losses_w: Vec<(&'static str, f64)>,
    /// The rate of each kind of stored energy.
    pub stored_w: Vec<(&'static str, f64)>,
}

impl Power {
    fn add(list: &mut Vec<(&'static str, f64)>, kind: &'static str, w: f64) {
        match list.iter_mut().find(|(k, _)| *k == kind) {
            Some((_, sum)) => *sum += w,
            None => list.push((kind, w)),
        }
    }

    /// Add `w` to the source `kind`.
    pub fn source(&mut self, kind: &'static str, w: f64) {
        Power::add(&mut self.sources_w, kind, w);
    }

    /// Add `w` to the loss `kind`.
    pub fn loss(&mut self, kind: &'static str, w: f64) {
        Power::add(&mut self.losses_w, kind, w);
    }

    /// Add `w` to the stored energy `kind`.
    pub fn store(&mut self, kind: &'static str, w: f64) {
        Power::add(&mut self.stored_w, kind, w);
    }

    /// The sum of a list.
    fn sum(list: &[(&'static str, f64)]) -> f64 {
        list.iter().map(|(_, w)| w).sum()
    }

    /// Sources − work out − losses − stored (W): zero but for rounding.
    pub fn imbalance_w(&self) -> f64 {
        Power::sum(&self.sources_w)
            - self.work_out_w
            - Power::sum(&self.losses_w)
            - Power::sum(&self.stored_w)
    }

    /// The largest magnitude of any term (W), the scale the imbalance is measured against.
    pub fn scale_w(&self) -> f64 {
        (self.sources_w.iter())
            .chain(&self.losses_w)
            .chain(&self.stored_w)
            .map(|(_, w)| w.abs())
            .fold(self.work_out_w.abs(), f64::max)
    }
}

/// A flow `q` (m³/s) through an element from pressure `from` to pressure `to` (Pa): the power
/// it turns into heat, q·(from − to).
pub fn throttled(q: f64, from: f64, to: f64) -> f64 {
    q * (from - to)
}

/// The cylinder's share (docs/energy.md#the-cylinder): of the power the network delivers into
/// its chambers, Σ pᵢ·(net inflow + displacement), what compresses the oil (stored, or lost at
/// the cavitation floor, where the pressure does not fall), and what the piston turns into
/// work against the external force, friction, the end stops and the load's motion. `s` is the
/// state at `[x, v, p1, p2]`, `flows` the chambers' net inflows as the equations take them
/// (the piston's displacement included) and `dv` the piston's acceleration they give.
pub fn cylinder(piston: &Piston, s: [f64; 4], flows: [f64; 2], dv: f64, power: &mut Power) {
    let [x, v, p1, p2] = s;
    for (p, q) in [(p1, flows[0]), (p2, flows[1])] {
        // at the floor a falling pressure stays (parts::Chamber::pressure_rate); both kinds are
        // always listed, so every state's account has the same kinds in the same order
        let at_floor = p <= -ATMOSPHERE_PA && q < 0.0;
        power.store("oil_compression", if at_floor { 0.0 } else { p * q });
        power.loss("cavitation", if at_floor { p * q } else { 0.0 });
    }
    let parts = piston.forces(x, v);
    power.work_out_w += piston.force_ext_n * v;
    power.loss("viscous_friction", parts.viscous_n * v);
    power.loss("coulomb_friction", parts.coulomb_n * v);
    // the stops' spring gives back what it took as the piston leaves them
    power.store("end_stops", -parts.stop_n * v);
    power.store("load_motion", piston.mass_at(x) * dv * v);
}

/// The electrical side of a circuit's drives (docs/energy.md#the-drives): the winding's
/// copper loss R·(τ/k_t)², the drive electronics' efficiency η (the same both ways), and what
/// becomes of the power the drives return: they share one DC bus, so one drive's braking feeds
/// the other's motoring, and of the bus's net braking power the fraction `regeneration` goes
/// back to the supply, the rest into the brake resistor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Electrics {
    /// The winding's resistance R as its copper loss sees it (Ω): R·i², i = τ/k_t.
    pub resistance_ohm: f64,
    /// The torque constant k_t (N·m/A).
    pub torque_constant_nm_per_a: f64,
    /// The drive electronics' efficiency η (0 … 1].
    pub efficiency: f64,
    /// The share of the DC bus's net braking power returned to the supply (0 … 1).
    pub regeneration: f64,
}

/// The drive train's loss keys, declared by every circuit with drives: those of [`Electrics`]
/// (docs/energy.md#the-drives) and the pumps' torque losses (docs/energy.md#the-pumps). The
/// defaults are pumpcyl's choice, the article giving none.
pub const LOSS_KEYS: [super::Key; 6] = [
    super::Key {
        name: "motor_winding_resistance_ohm",
        doc: "ohm, the motor winding's resistance as its copper loss R (tau/k_t)^2 sees it (3 x the phase resistance for k_t per phase current); 0 = no copper loss",
        default: 0.0,
        range: crate::rig::Range::NonNegative(1e3),
    },
    super::Key {
        name: "motor_torque_constant_nm_per_a",
        doc: "N m/A, the motor's torque constant k_t (used with motor_winding_resistance_ohm)",
        default: 1.0,
        range: crate::rig::Range::Positive(1e-4, 1e3),
    },
    super::Key {
        name: "drive_efficiency",
        doc: "-, the drive electronics' efficiency, the same motoring and braking; 1 = lossless",
        default: 1.0,
        range: crate::rig::Range::Positive(0.01, 1.0),
    },
    super::Key {
        name: "drive_regeneration_fraction",
        doc: "-, the share of the drives' common DC bus's net braking power returned to the supply (1: a regenerative supply unit); the rest heats the brake resistor",
        default: 0.0,
        range: crate::rig::Range::NonNegative(1.0),
    },
    super::Key {
        name: "pump_friction_torque_fraction",
        doc: "-, a pump's Coulomb torque loss as a fraction C_f of its ideal torque D |dp|, against the rotation (emulator); 0 = none",
        default: 0.0,
        range: crate::rig::Range::NonNegative(1.0),
    },
    super::Key {
        name: "pump_viscous_torque_nms_per_rad",
        doc: "N·m·s/rad, a pump's viscous torque loss b_p w (emulator); 0 = none",
        default: 0.0,
        range: crate::rig::Range::NonNegative(10.0),
    },
];

impl Electrics {
    /// The electrical side of `rig`'s drives ([`LOSS_KEYS`]).
    pub fn of(rig: &crate::rig::Rig) -> Electrics {
        Electrics {
            resistance_ohm: rig.circuit_key("motor_winding_resistance_ohm"),
            torque_constant_nm_per_a: rig.circuit_key("motor_torque_constant_nm_per_a"),
            efficiency: rig.circuit_key("drive_efficiency"),
            regeneration: rig.circuit_key("drive_regeneration_fraction"),
        }
    }
}

/// One drive at an instant: its parts, its speed ω and torque τ `[w, tau]`, the speed's rate
/// `dw` the equations give and the pumps' torque on it, `load` (N·m).
#[derive(Debug, Clone, Copy)]
pub struct DriveAt<'a> {
    /// The drive.
    pub drive: &'a Drive,
    /// Speed (rad/s) and electromagnetic torque (N·m).
    pub state: [f64; 2],
    /// The speed's rate (rad/s²).
    pub dw: f64,
    /// The pumps' torque on it (N·m).
    pub load: f64,
}

/// The drives' share (docs/energy.md#the-drives): each drive's electromagnetic torque τ times
/// its speed ω is the shaft power, of which the shaft's acceleration stores J·ω·ω̇, the speed
/// limit holds back (τ − load)·ω − J·ω·ω̇ where it stops the acceleration, and the rest,
/// load·ω, drives the pumps. Behind the shaft the winding loses R·(τ/k_t)² and the electronics
/// (1 − η) of what passes them; the drives' DC bus draws its net power from the supply
/// (`electrical`), or returns the `regeneration` share of its net braking (`regenerated`,
/// negative) and burns the rest (`brake_resistor`).
pub fn drives(e: &Electrics, drives: &[DriveAt<'_>], power: &mut Power) {
    for d in drives {
        let [w, tau] = d.state;
        let stored = d.drive.inertia * d.dw * w;
        power.store("drive_motion", stored);
        power.loss("speed_limit", (tau - d.load) * w - stored);
    }
    let shafts: Vec<[f64; 2]> = drives.iter().map(|d| d.state).collect();
    e.bus(&shafts, power);
}

impl Electrics {
    /// What the drives turning at `[w, tau]` each (rad/s, N·m) take from the supply and lose
    /// on the way (docs/energy.md#the-drives): the sources `electrical` and `regenerated` and
    /// the losses `copper`, `drive_electronics` and `brake_resistor`, added to `power`; their
    /// balance is the shafts' Σ τ·ω.
    pub fn bus(&self, shafts: &[[f64; 2]], power: &mut Power) {
        let mut bus = 0.0;
        for &[w, tau] in shafts {
            let copper = self.resistance_ohm * (tau / self.torque_constant_nm_per_a).powi(2);
            let terminals = tau * w + copper;
            let dc = if terminals >= 0.0 {
                terminals / self.efficiency
            } else {
                terminals * self.efficiency
            };
            power.loss("copper", copper);
            power.loss("drive_electronics", dc - terminals);
            bus += dc;
        }
        let braking = (-bus).max(0.0);
        power.source("electrical", bus.max(0.0));
        power.source("regenerated", -braking * self.regeneration);
        power.loss("brake_resistor", braking * (1.0 - self.regeneration));
    }

    /// The power the drives turning at `[w, tau]` each draw from the supply, net of what they
    /// return (W; [`Electrics::bus`]).
    pub fn supply_w(&self, shafts: &[[f64; 2]]) -> f64 {
        let mut power = Power::default();
        self.bus(shafts, &mut power);
        Power::sum(&power.sources_w)
    }
}

/// [`drives`] for a one-motor circuit's motor, its states from `at` in `s` (speed, torque, ...)
/// and their rates in `dx`; a first-order motor has no torque to account (the emulator runs the
/// full model only).
pub fn motor(
    e: &Electrics,
    motor: &Motor,
    (s, dx, at): (&[f64], &[f64], usize),
    load: f64,
    power: &mut Power,
) {
    if let Motor::Full(drive) = motor {
        let at = DriveAt {
            drive,
            state: [s[at], s[at + 1]],
            dw: dx[at],
            load,
        };
        drives(e, &[at], power);
    }
}

/// A pump's share (docs/energy.md#the-pumps): of the shaft power (D·Δp + τ_f)·ω its load
/// torque takes (`coupled`; without the coupling the drive carries no load and the pump's power
/// comes from outside, a source of its own), its friction torque τ_f turns τ_f·ω into heat,
/// and it delivers q·Δp and loses (D·ω − q)·Δp in its dead band and slip. `dp` is outlet
/// minus inlet (Pa); returns the delivered flow q (m³/s).
pub fn pump(pump: &Pump, w: f64, dp: f64, coupled: bool, power: &mut Power) -> f64 {
    let q = pump.flow(w, dp);
    let friction = pump.friction_torque(w, dp) * w;
    if !coupled {
        power.source("uncoupled_pumps", pump.displacement_m3 * w * dp + friction);
    }
    power.loss("pump_friction", friction);
    power.loss(
        "pump_slip_and_dead_band",
        (pump.displacement_m3 * w - q) * dp,
    );
    q
}

/// A leak of conductance `c` (m⁵/(N·s)) from pressure `from` to pressure `to` (Pa): the power it
/// turns into heat, c·(from − to)².
pub fn leak(c: f64, from: f64, to: f64) -> f64 {
    throttled((from - to) * c, from, to)
}

/// The one-motor circuits' leakages `[c1, c2, c12]` (m⁵/(N·s)) from the chambers at `p1`, `p2`
/// to the accumulator line at `pa` and across the piston (Pa), their heat added to `power`;
/// returns what they feed into the accumulator line (m³/s).
pub fn leaks_to_accumulator(
    [c1, c2, c12]: [f64; 3],
    [p1, p2]: [f64; 2],
    pa: f64,
    power: &mut Power,
) -> f64 {
    let heat = leak(c1, p1, pa) + leak(c2, p2, pa) + leak(c12, p1, p2);
    power.loss("leakage", heat);
    (p1 - pa) * c1 + (p2 - pa) * c2
}

/// Energies over a run (J), by the same kinds as [`Power`]: the power account integrated with
/// the states (docs/energy.md#over-a-run).
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize)]
pub struct Energy {
    /// What each source delivered.
    pub sources_j: Vec<(&'static str, f64)>,
    /// The work against the external force.
    pub work_out_j: f64,
    /// Each kind of loss.
    pub losses_j: Vec<(&'static str, f64)>,
    /// The change of each kind of stored energy.
    pub stored_j: Vec<(&'static str, f64)>,
    /// Each drive's ∫ω² dt and ∫τ² dt over the run (rad²/s, N²·m²·s), in the circuit's order of
    /// drives, integrated with the account: the RMS speed and torque of drive sizing
    /// (docs/energy.md#drive-sizing). Not part of the account.
    pub drive_squares: Vec<[f64; 2]>,
    /// Each drive's largest |ω| and |τ| over the run (rad/s, N·m) at the integrator's steps:
    /// drive sizing's peaks. Not part of the account.
    pub drive_peaks: Vec<[f64; 2]>,
}

impl Energy {
    /// Add the power `p` held for `seconds`.
    pub fn add(&mut self, p: &Power, seconds: f64) {
        for (to, from) in [
            (&mut self.sources_j, &p.sources_w),
            (&mut self.losses_j, &p.losses_w),
            (&mut self.stored_j, &p.stored_w),
        ] {
            for &(kind, w) in from {
                Power::add(to, kind, w * seconds);
            }
        }
        self.work_out_j += p.work_out_w * seconds;
    }

    /// Add the energies of `other`.
    pub fn merge(&mut self, other: &Energy) {
        let as_power = Power {
            sources_w: other.sources_j.clone(),
            work_out_w: other.work_out_j,
            losses_w: other.losses_j.clone(),
            stored_w: other.stored_j.clone(),
        };
        self.add(&as_power, 1.0);
        let fold = |to: &mut Vec<[f64; 2]>, from: &[[f64; 2]], f: fn(f64, f64) -> f64| {
            if to.len() < from.len() {
                to.resize(from.len(), [0.0; 2]);
            }
            for (t, f_) in to.iter_mut().zip(from) {
                *t = [f(t[0], f_[0]), f(t[1], f_[1])];
            }
        };
        fold(&mut self.drive_squares, &other.drive_squares, |a, b| a + b);
        fold(&mut self.drive_peaks, &other.drive_peaks, f64::max);
    }

    /// Sources − work out − losses − stored changes (J): zero but for rounding.
    pub fn imbalance_j(&self) -> f64 {
        Power::sum(&self.sources_j)
            - self.work_out_j
            - Power::sum(&self.losses_j)
            - Power::sum(&self.stored_j)
    }

    /// Every entry named by its role and kind, in the order of the lists: `source_<kind>`,
    /// `work_out`, `loss_<kind>`, `stored_<kind>` (J): the names of a record's power columns
    /// (docs/formats.md#power-columns).
    pub fn named(&self) -> Vec<(String, f64)> {
        let of = |role: &str, list: &[(&'static str, f64)]| -> Vec<(String, f64)> {
            list.iter()
                .map(|(k, j)| (format!("{role}_{k}"), *j))
                .collect()
        };
        (of("source", &self.sources_j).into_iter())
            .chain([("work_out".to_string(), self.work_out_j)])
            .chain(of("loss", &self.losses_j))
            .chain(of("stored", &self.stored_j))
            .collect()
    }

    /// The energy of `kind` in any of its lists (J), 0 where absent.
    pub fn of(&self, kind: &str) -> f64 {
        (self.sources_j.iter())
            .chain(&self.losses_j)
            .chain(&self.stored_j)
            .filter(|(k, _)| *k == kind)
            .map(|(_, j)| j)
            .sum()
    }
}

impl Power {
    /// Every term in one list (sources, the work out, losses, stored rates), for a solver that
    /// integrates them as states.
    pub fn flat(&self) -> Vec<f64> {
        self.flat_as(self)
    }

    /// This account's terms in the order of `template`'s kinds ([`Power::flat`]), 0 for a kind
    /// it does not list.
    pub fn flat_as(&self, template: &Power) -> Vec<f64> {
        let of = |list: &[(&'static str, f64)], kind: &str| {
            (list.iter())
                .find(|(k, _)| *k == kind)
                .map_or(0.0, |(_, w)| *w)
        };
        (template
            .sources_w
            .iter()
            .map(|(k, _)| of(&self.sources_w, k)))
        .chain([self.work_out_w])
        .chain(template.losses_w.iter().map(|(k, _)| of(&self.losses_w, k)))
        .chain(template.stored_w.iter().map(|(k, _)| of(&self.stored_w, k)))
        .collect()
    }

    /// The power of this account's kinds with the values `flat` ([`Power::flat`]'s order).
    pub fn with_flat(&self, flat: &[f64]) -> Power {
        let mut it = flat.iter().copied();
        let mut take = |list: &[(&'static str, f64)]| -> Vec<(&'static str, f64)> {
            list.iter()
                .map(|(k, _)| (*k, it.next().unwrap_or(0.0)))
                .collect()
        };
        let sources_w = take(&self.sources_w);
        let work_out_w = take(&[("work", 0.0)])[0].1;
        let losses_w = take(&self.losses_w);
        let stored_w = take(&self.stored_w);
        Power {
            sources_w,
            work_out_w,
            losses_w,
            stored_w,
        }
    }
}
