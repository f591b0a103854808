//! The emulated stand-ins for the article's records (docs/emulator.md#the-emulated-article-records). The article's measurements are
//! not public, so these records come from the nonlinear emulator with a known truth:
//! the default rig (the article's Section 2.3.4) with every emulator effect on
//! ([`Effects::article`]), β_e(p) from the gas fraction that gives 165 bar at 4.4 bar (the
//! article's constant gas-fraction model), and a 100 Hz PLC with sensor noise. The PLC's sum-pressure gain is the
//! default rig's 0.22 per bar (0.15 below 10 t), so the records replay on the default rig.

use super::experiment::{DriveSignals, DriveStep, Experiment};
use super::EmulatorError;
use super::{equilibrium, Dynamics, Effects, Plc};
use crate::bulk::effective_beta;
use crate::response::Signals;
use crate::rig::Rig;
use crate::units::PA_PER_BAR;

/// The sum-pressure gain for masses of 10 t and more (1/bar): the default rig's, the article's
/// "22" read as percent of full command per bar.
pub const K_PRES_HEAVY_PER_BAR: f64 = 0.22;
/// … and below 10 t (1/bar): the article's "(15)".
pub const K_PRES_LIGHT_PER_BAR: f64 = 0.15;

/// The sum-pressure gain the article uses for a load of `mass_kg` (1/bar).
pub fn k_pres_for_mass(mass_kg: f64) -> f64 {
    if mass_kg >= 10_000.0 {
        K_PRES_HEAVY_PER_BAR
    } else {
        K_PRES_LIGHT_PER_BAR
    }
}
/// The bulk modulus (bar) the gas fraction is fitted to, at [`P_FIT_BAR`] (docs/bulk-modulus.md#fitting-the-gas-fraction).
pub const BETA_FIT_BAR: f64 = 165.0;
/// Mean chamber pressure of the fit (bar): the article's identification records.
pub const P_FIT_BAR: f64 = 4.4;
/// The bulk modulus of the robustness record at its operating pressure (bar, docs/emulator.md#the-emulated-article-records).
pub const BETA_ROBUSTNESS_BAR: f64 = 220.0;

/// The rig, emulator effects and PLC a record is emulated with.
#[derive(Debug, Clone, PartialEq)]
pub struct Truth {
    /// The rig (its `beta_bar` is β_e at the operating pressure, for reference: the emulator
    /// takes β from the gas fraction).
    pub rig: Rig,
    /// The emulator's effects.
    pub effects: Effects,
    /// The PLC.
    pub plc: Plc,
}

/// What a record is of.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kind {
    /// The closed position loop.
    Loop(Experiment),
    /// One drive, decoupled from its pump.
    Drive(DriveStep),
}

/// One embedded record: its file name, what it shows and how it was made.
#[derive(Debug, Clone, PartialEq)]
pub struct ArticleRecord {
    /// File name in the records folder.
    pub file: &'static str,
    /// One line on what it is.
    pub what: &'static str,
    /// The experiment.
    pub kind: Kind,
    /// The truth it was emulated with.
    pub truth: Truth,
}

/// An emulated record's signals.
#[derive(Debug, Clone, PartialEq)]
pub enum Emulated {
    /// Record of the closed loop (docs/formats.md#record-csv).
    Loop(Signals),
    /// Drive record (docs/formats.md#drive-record-csv).
    Drive(DriveSignals),
}

impl Emulated {
    /// Number of samples.
    pub fn len(&self) -> usize {
        match self {
            Emulated::Loop(s) => s.time_s.len(),
            Emulated::Drive(d) => d.time_s.len(),
        }
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The record as CSV.
    pub fn csv(&self) -> String {
        match self {
            Emulated::Loop(s) => s.record_csv(),
            Emulated::Drive(d) => d.csv(),
        }
    }
}

impl Kind {
    /// Emulate this experiment with a truth.
    pub fn run(&self, t: &Truth) -> Result<Emulated, EmulatorError> {
        Ok(match self {
            Kind::Loop(e) => Emulated::Loop(e.run(&t.rig, t.effects, &t.plc)?),
            Kind::Drive(d) => Emulated::Drive(d.run(&t.rig, t.effects, &t.plc)?),
        })
    }
}

impl ArticleRecord {
    /// Emulate the record.
    pub fn run(&self) -> Result<Emulated, EmulatorError> {
        self.kind.run(&self.truth)
    }
}

/// The article rig's PLC: 100 Hz, position noise 5 µm with 1 µm resolution, pressure noise
/// 0.01 bar, speed noise 1 rpm.
pub fn plc(seed: u64) -> Plc {
    Plc {
        rate_hz: 100.0,
        noise_x_mm: 0.005,
        quant_x_mm: 0.001,
        noise_p_bar: 0.01,
        noise_w_rpm: 1.0,
        seed,
    }
}

/// Most set-point corrections [`rig`] makes.
const SET_POINT_STEPS: usize = 30;

/// The emulated rig for a position gain and mass, its sum-pressure set-point chosen so the
/// mean chamber pressure at x0 is `p_mean_bar` (the P sum-pressure loop's droop included).
pub fn rig(kp: f64, mass_kg: f64, p_mean_bar: f64, effects: Effects) -> Result<Rig, EmulatorError> {
    let k_pres = k_pres_for_mass(mass_kg);
    let gas = effects
        .gas_fraction
        .ok_or("the article truth needs a gas fraction")?;
    let mut rig = Rig {
        kp,
        mass_kg,
        k_pres_per_bar: k_pres,
        p_sum_ref_bar: 2.0 * p_mean_bar,
        beta_bar: effective_beta(gas, p_mean_bar, effects.beta_oil_bar),
        ..Rig::default()
    };
    // the P sum-pressure loop droops: move the set-point until the rest's sum is 2 p_mean
    // (a contraction by the droop's fraction, about a tenth per step here)
    for _ in 0..SET_POINT_STEPS {
        let d = Dynamics::new(&rig, effects)?;
        let x = equilibrium(&rig, &d, rig.x0_mm)?;
        let sum: f64 = d.at.pressures.iter().map(|&i| x[i]).sum();
        let miss = 2.0 * p_mean_bar - sum / PA_PER_BAR;
        if miss.abs() < 1e-9 * p_mean_bar {
            return Ok(rig);
        }
        rig.p_sum_ref_bar += miss;
    }
    Err(EmulatorError(format!(
        "no sum-pressure set-point gives {p_mean_bar} bar mean pressure at rest in {SET_POINT_STEPS} steps"
    )))
}

/// The emulated article records' effects: [`Effects::article`] at β 165 bar and 4.4 bar.
pub fn effects() -> Result<Effects, EmulatorError> {
    Effects::article(BETA_FIT_BAR, P_FIT_BAR)
}

/// The emulator's own rig (what `pumpcyl emulate` and the emulator FMU run without a rig
/// file): the article's, Kp 25, 10 593 kg, every effect on, the set-point for β 165 bar at
/// 4.4 bar mean pressure (data/article/README.md).
pub fn default_rig() -> Result<Rig, EmulatorError> {
    rig(25.0, 10_593.0, P_FIT_BAR, effects()?)
}

/// The mean chamber pressure (bar) at which the gas-fraction model gives `beta_bar`.
pub fn pressure_for_beta(effects: &Effects, beta_bar: f64) -> Result<f64, EmulatorError> {
    let x = effects.gas_fraction.ok_or("no gas fraction")?;
    let denom = 1.0 / beta_bar - (1.0 - x) / effects.beta_oil_bar;
    if denom <= 0.0 {
        return Err(EmulatorError(format!(
            "beta {beta_bar} bar is beyond the oil's own"
        )));
    }
    Ok(x / denom)
}

/// Every embedded record, in the order `reproduce` uses them.
pub fn records() -> Result<Vec<ArticleRecord>, EmulatorError> {
    let effects = effects()?;
    // the robustness record: more undissolved air (after a long shutdown, the article's
    // Results), so β_e is 220 bar at the same operating pressure
    let robust_effects = Effects::article(BETA_ROBUSTNESS_BAR, P_FIT_BAR)?;
    let heavy = |kp: f64| rig(kp, 10_593.0, P_FIT_BAR, effects);
    let truth = |rig: Rig, seed: u64| Truth {
        rig,
        effects,
        plc: plc(seed),
    };
    let step = Experiment::Step {
        from_mm: 340.0,
        to_mm: 345.0,
        at_s: STEP_AT_S,
        duration_s: 6.5,
    };
    let mut out = vec![
        ArticleRecord {
            file: "identification.csv",
            what: "5 mm step 340 -> 345 mm, Kp = 25, m = 10 593 kg (the article §2.4 identification set)",
            kind: Kind::Loop(step),
            truth: truth(heavy(25.0)?, 1),
        },
        ArticleRecord {
            file: "validation.csv",
            what: "the same step with Kp = 20 (the article §2.4 validation set)",
            kind: Kind::Loop(step),
            truth: truth(heavy(20.0)?, 2),
        },
        ArticleRecord {
            file: "robustness.csv",
            what: "the same step with m = 4898 kg, Kp = 40, another day's gas fraction: beta_e 220 bar at the operating pressure",
            kind: Kind::Loop(step),
            truth: Truth {
                rig: rig(40.0, 4_898.0, P_FIT_BAR, robust_effects)?,
                effects: robust_effects,
                plc: plc(3),
            },
        },
        ArticleRecord {
            file: "drive_step.csv",
            what: "drive 1 alone, feedforward off, speed step 0 -> 500 rpm, drive scope at 1 kHz (the article §2.4.1)",
            kind: Kind::Drive(DriveStep {
                motor: 1,
                from_rpm: 0.0,
                to_rpm: 500.0,
                at_s: 0.1,
                duration_s: 1.0,
            }),
            truth: Truth {
                plc: Plc {
                    rate_hz: 1000.0,
                    ..plc(4)
                },
                ..truth(heavy(25.0)?, 4)
            },
        },
        ArticleRecord {
            file: "standstill.csv",
            what: "reference held at 345 mm for 10 s, Kp = 25: the pumps feed the leakage (the article §2.4)",
            kind: Kind::Loop(Experiment::Standstill {
                x_mm: 345.0,
                duration_s: 10.0,
            }),
            truth: truth(heavy(25.0)?, 5),
        },
    ];
    let sines = [
        ("sine_0.10hz_50mm.csv", 0.1, 50.0, 6),
        ("sine_0.20hz_35mm.csv", 0.2, 35.0, 7),
        ("sine_0.25hz_20mm.csv", 0.25, 20.0, 8),
    ];
    for (file, f, a, seed) in sines {
        out.push(ArticleRecord {
            file,
            what: "sinusoidal tracking about 345 mm, Kp = 25, after 1 s at rest: 20 s of wave for the start-up transient (below 1 % after about 11 s), then two more whole periods (docs/simulation.md#tracking-metrics)",
            kind: Kind::Loop(Experiment::Sine {
                centre_mm: 345.0,
                amplitude_mm: a,
                freq_hz: f,
                start_s: SINE_START_S,
                duration_s: SINE_START_S + f64::from(sine_periods(f)) / f,
            }),
            truth: truth(heavy(25.0)?, seed),
        });
    }
    Ok(out)
}

/// When the wave starts in the sine records (s), after the rig rests at x0.
pub const SINE_START_S: f64 = 1.0;
/// How much of each sine record's wave is left to its start-up transient (s): the closed loop
/// of the truth decays below 1 % in about 11 s (its slowest pair near −0.41 ± 4.0j rad/s), so
/// an identification that finds a somewhat slower loop still has two whole periods after it.
pub const SINE_SETTLE_S: f64 = 20.0;

/// The whole periods of a sine record of `freq_hz`: those that fit in [`SINE_SETTLE_S`], at
/// least, then two more to measure (docs/simulation.md#tracking-metrics).
pub fn sine_periods(freq_hz: f64) -> u32 {
    // less a hair, so a product such as 20 × 0.1 that rounds up does not count one more
    (SINE_SETTLE_S * freq_hz - 1e-9).ceil() as u32 + 2
}

/// The README of the records folder: what is emulated, with which truth, and how to remake it.
pub fn readme(records: &[ArticleRecord]) -> String {
    use std::fmt::Write;
    let mut s = String::from(
        "# Emulated stand-ins for the article's records\n\n\
         **These records are emulated, not measured.** The measurements of Gøytil, Hansen & \
         Tvilde (Actuators 2025, 14(8), 366) are not public. pumpcyl's nonlinear rig emulator \
         (`src/emulator`) made these files from the known truth below, so that `pumpcyl \
         reproduce` has realistic data to run the article's method on, and the tests can check \
         that the identification recovers that truth.\n\n\
         Regenerate them (deterministic: the noise is seeded):\n\n    \
         cargo run --release -- emulate --article-records data/article\n\n\
         ## Records\n\n\
         | file | what | Kp (1/m) | m (kg) | K_pres (1/bar) | p_sum_ref (bar) | beta_e at the mean pressure (bar) | seed |\n\
         |---|---|---|---|---|---|---|---|\n",
    );
    for r in records {
        let rig = &r.truth.rig;
        let _ = writeln!(
            s,
            "| `{}` | {} | {} | {} | {} | {:.3} | {:.1} | {} |",
            r.file,
            r.what,
            rig.kp,
            rig.mass_kg,
            rig.k_pres_per_bar,
            rig.p_sum_ref_bar,
            rig.beta_bar,
            r.truth.plc.seed
        );
    }
    let e = records
        .first()
        .map(|r| r.truth.effects)
        .unwrap_or_else(Effects::none);
    let rig = Rig::default();
    let _ = write!(
        s,
        "\n## The truth\n\n\
         The default rig (the article's Section 2.3.4; `pumpcyl rig --print-default`): c12 = {c12:.2e}, c1 = {c1:.3e}, \
         c2 = {c2:.3e} m⁵/(N·s), b = {b} N·s/m, Km = {km} N·m·s/rad, with these emulator effects:\n\n\
         - chamber volumes following the piston; the effective mass against stroke \
         (9958 kg at -50 mm, 12 373 kg at +50 mm, scaled to the record's mass: the article §2.1);\n\
         - the bulk modulus of both chambers from their mean pressure (p1 + p2)/2 by the constant gas-fraction model \
         of the article, X = {x:.5} (beta_e = {bf} bar at {pf} bar, beta_oil = {oil} bar); \
         the robustness record has more undissolved air, X = {xr:.5} (beta_e = {br} bar at {pf} bar, \
         as after a long shutdown); the table above gives beta_e at each record's mean chamber \
         pressure, the value identification should find;\n\
         - cavitation at -1 bar gauge; motor torque limited to {tq}x the rated {rated} N m; pump speed \
         limit {pmax} rpm;\n\
         - pump low-speed behaviour: below {db:.0} rpm a pump's flow fades out and a slip leakage of \
         up to {slip:.1e} m⁵/(N·s) across its ports sets in;\n\
         - Coulomb friction {fc} N on the piston;\n\
         - the PLC at 100 Hz (the drive step: the drive's own scope at 1 kHz), commands held between \
         samples, position noise 5 um (1 um resolution), pressure noise 0.01 bar, speed noise 1 rpm.\n\n\
         The PLC's sum-pressure gain is the default rig's {kh} per bar ({kl} below 10 t), the \
         article's 22 (15) read as percent of full command per bar, so every record replays on the \
         default rig with its own Kp and mass:\n\n    \
         cargo run --release -- simulate --experiment data/article/identify.toml --dataset 1\n\n\
         `identify.toml` runs the article's identification (Section 2.4) on `identification.csv` \
         and `validation.csv`, with c1 and c2 from `standstill.csv`, fitting up to {w25} s after the \
         step for Kp = 25 and {w20} s for Kp = 20 (the article's Section 2.4 and Figure 6; the pumps' \
         low-speed dead band takes over after that):\n\n    \
         cargo run --release -- identify data/article/identify.toml\n",
        c12 = rig.c12_m5_per_ns,
        c1 = rig.c1_m5_per_ns,
        c2 = rig.c2_m5_per_ns,
        b = rig.viscous_friction_ns_per_m,
        km = rig.km1_nms_per_rad,
        x = e.gas_fraction.unwrap_or(0.0),
        xr = records
            .iter()
            .find(|r| r.file == "robustness.csv")
            .and_then(|r| r.truth.effects.gas_fraction)
            .unwrap_or(f64::NAN),
        br = BETA_ROBUSTNESS_BAR,
        w25 = FIT_WINDOW_KP25_S,
        w20 = FIT_WINDOW_KP20_S,
        bf = BETA_FIT_BAR,
        pf = P_FIT_BAR,
        oil = e.beta_oil_bar,
        tq = e.peak_torque_factor.unwrap_or(f64::INFINITY),
        rated = rig.motor_rated_torque_nm,
        pmax = rig.pump_max_speed_rpm,
        db = e.dead_band_rad_s / crate::units::RAD_S_PER_RPM,
        slip = e.slip_m5_per_ns,
        fc = e.coulomb_n,
        kh = K_PRES_HEAVY_PER_BAR,
        kl = K_PRES_LIGHT_PER_BAR,
    );
    s
}

/// Time of the step in the step records (s).
pub const STEP_AT_S: f64 = 0.5;
/// Fit window after the step for Kp = 25 (s): the article's non-LTI region starts 2.2 s after
/// the step (its Figure 6 steps at t = 1 s and draws the line at t = 3.2 s).
pub const FIT_WINDOW_KP25_S: f64 = 2.2;
/// Fit window after the step for Kp = 20 (s): 1.9 s after the step (the article's Section 2.4).
pub const FIT_WINDOW_KP20_S: f64 = 1.9;

/// The fit window after the step for a position gain (s): the article's 1.9 s for Kp = 20 and
/// below, its 2.2 s for Kp = 25 and above (the article gives no window for the Kp = 40
/// robustness record; it gets the Kp = 25 one) **\[choice\]**.
pub fn fit_window_s(kp: f64) -> f64 {
    if kp <= 20.0 {
        FIT_WINDOW_KP20_S
    } else {
        FIT_WINDOW_KP25_S
    }
}

/// The `identify` experiment for the emulated identification and validation records.
pub fn identify_experiment() -> String {
    let end = |kp: f64| STEP_AT_S + fit_window_s(kp);
    format!(
        "# The article's identification (Section 2.4) on the emulated records of this folder\n\
         # (README.md). Made by `pumpcyl emulate --article-records`. The records were made with\n\
         # the default rig's sum-pressure gain, so no [set] is needed.\n\n\
         # The article's two grids (3264 + 3553 candidates, the article's §2.4); without this line the first\n\
         # grid would be centred on the rig's values and the second on the first stage's best.\n\
         grids = \"article\"\n\n\
         [standstill]\n\
         record = \"standstill.csv\"   # c1, c2 from its mean speeds and pressure (Section 2.4)\n\n\
         [[dataset]]\n\
         file = \"identification.csv\"\n\
         kp = 25.0\n\
         mass_kg = 10593.0\n\
         fit_end_s = {e25}   # {at} s at rest + {w25} s after the step (the article's Figure 6)\n\n\
         [[dataset]]\n\
         file = \"validation.csv\"\n\
         kp = 20.0\n\
         mass_kg = 10593.0\n\
         fit_end_s = {e20}   # {at} s at rest + {w20} s after the step (the article's Section 2.4)\n",
        at = STEP_AT_S,
        w25 = FIT_WINDOW_KP25_S,
        w20 = FIT_WINDOW_KP20_S,
        e25 = end(25.0),
        e20 = end(20.0),
    )
}

/// The records folder as shipped (`data/article/`), compiled into the binary so `reproduce`
/// runs from anywhere: (file name, contents).
pub const EMBEDDED: [(&str, &str); 10] = [
    (
        "README.md",
        include_str!("../../../../data/article/README.md"),
    ),
    (
        "identify.toml",
        include_str!("../../../../data/article/identify.toml"),
    ),
    (
        "identification.csv",
        include_str!("../../../../data/article/identification.csv"),
    ),
    (
        "validation.csv",
        include_str!("../../../../data/article/validation.csv"),
    ),
    (
        "robustness.csv",
        include_str!("../../../../data/article/robustness.csv"),
    ),
    (
        "drive_step.csv",
        include_str!("../../../../data/article/drive_step.csv"),
    ),
    (
        "standstill.csv",
        include_str!("../../../../data/article/standstill.csv"),
    ),
    (
        "sine_0.10hz_50mm.csv",
        include_str!("../../../../data/article/sine_0.10hz_50mm.csv"),
    ),
    (
        "sine_0.20hz_35mm.csv",
        include_str!("../../../../data/article/sine_0.20hz_35mm.csv"),
    ),
    (
        "sine_0.25hz_20mm.csv",
        include_str!("../../../../data/article/sine_0.25hz_20mm.csv"),
    ),
];

/// The folder the embedded records stand for in file names and messages: `records/` (as in the
/// result folder of the article workflow).
pub const FOLDER: &str = "records";

/// The embedded records ([`EMBEDDED`]) as files under [`FOLDER`], for the readers that take
/// [`Files`](crate::input::Files): `Experiment::load_in(&Embedded, "records/identify.toml")`
/// reads the identification experiment and its records from memory.
#[derive(Debug, Clone, Copy, Default)]
pub struct Embedded;

impl crate::input::Files for Embedded {
    fn open(&self, path: &std::path::Path) -> std::io::Result<Box<dyn std::io::Read + Send + '_>> {
        EMBEDDED
            .iter()
            .find(|(name, _)| std::path::Path::new(FOLDER).join(name) == path)
            .map(|(_, text)| Box::new(text.as_bytes()) as Box<dyn std::io::Read + Send>)
            .ok_or_else(|| {
                std::io::Error::new(
                    std::io::ErrorKind::NotFound,
                    "not one of the embedded article records",
                )
            })
    }
}
