//! Step 13, "Valve or pump": the comparison the article is about, computed. Its introduction
//! sets the valve-controlled cylinder's bulk modulus against the pump-controlled one's, its §3.2
//! says a valve-controlled cylinder's resonance is lightly damped, and its §4 that at the
//! identified 165 bar "adequate performance under feedback control would certainly not have
//! been achievable" with a valve. Here the valve-controlled counterpart of the article's rig
//! (docs/circuits.md#the-article-s-rig-with-a-valve) stands beside the article's DPM: the same
//! cylinder, line volumes, mass and friction, a valve sized for the DPM's top speed, β_e from
//! the rig's gas fraction at the valve circuit's own rest, and once more at the DPM's 165 bar.
//!
//! Every number is what a user gets from `pumpcyl poles`, `margins` and `design` on the default
//! rig with the `--set` assignments listed in summary.json (`set`; tests/reproduce/valve.rs
//! runs them).

use super::case::Case;
use super::{printed, variants, Position, Run, Source, Study};
use crate::format::fmt_opt;
use anyhow::{Context, Result};
use pumpcyl::anchor::anchor_bar;
use pumpcyl::bulk::{effective_beta, ARTICLE_READING, BETA_OIL_BAR};
use pumpcyl::circuit::valve::rated_flow_for_velocity_lpm;
use pumpcyl::design::{self, Targets};
use pumpcyl::rig::Rig;
use serde::Serialize;

/// The valve's supply pressure (bar): the introduction's 100 bar, at which it puts a
/// valve-controlled cylinder's β_e at 6300 bar **\[choice\]**.
pub const SUPPLY_BAR: f64 = 100.0;
/// The wave the tracking error is predicted for: the article's 0.2 Hz ±35 mm (its §3.3).
pub const WAVE: (f64, f64) = (0.2, 35.0);
/// The band the hydraulic resonance is looked for in (Hz): the least-damped open-loop pole
/// pair there (the DPM's Figure 14 band widened to hold a stiff valve circuit's).
const BAND_HZ: (f64, f64) = (0.1, 30.0);

/// One circuit of the comparison.
#[derive(Debug, Clone, Serialize)]
pub struct Side {
    /// The circuit in words.
    pub label: String,
    /// Its circuit key.
    pub circuit: String,
    /// The `--set` assignments that make its rig from the default rig (the article's Table 1).
    pub set: Vec<String>,
    /// The mean chamber pressure at rest, where its β_e holds (bar).
    pub p_mean_bar: f64,
    /// Its effective bulk modulus (bar).
    pub beta_e_bar: f64,
    /// The hydraulic resonance: the least-damped open-loop pole pair in the band (Hz).
    pub resonance_hz: Option<f64>,
    /// Its damping ratio.
    pub damping_ratio: Option<f64>,
    /// Merritt's hydraulic natural frequency ω_h/2π = √((β/m)(A₁²/V₁ + A₂²/V₂))/2π (Hz).
    pub merritt_hz: f64,
    /// The largest K_p meeting the article's design margins at the design point (its unit:
    /// what the circuit's law commands per metre).
    pub kp_max: f64,
    /// The velocity-loop gain there (1/s; docs/analysis.md#the-velocity-loop-gain).
    pub kv_max_per_s: Option<f64>,
    /// The predicted maximum error of the 0.2 Hz ±35 mm wave at `kp_max` (mm).
    pub max_error_mm: f64,
}

/// Step 13's numbers (summary.json `valve_or_pump`).
#[derive(Debug, Clone, Serialize)]
pub struct ValveOrPump {
    /// The DPM's top speed the valve is sized for (m/s): pump 1 at its speed limit feeding the
    /// annulus, D₁·n_max/A₂ (docs/circuits.md#matching).
    pub top_speed_m_per_s: f64,
    /// The sized valve's rated flow (L/min per land at its rated drop).
    pub valve_rated_flow_lpm: f64,
    /// The gas fraction every side's β_e comes from (the article's 165 bar at 4.4 bar).
    pub gas_fraction: f64,
    /// The margins of the article's design (PM deg, GM dB) every K_p max meets.
    pub targets: [f64; 2],
    /// The DPM, the valve at its own rest's β_e, the valve at the DPM's.
    pub sides: Vec<Side>,
    /// Each side at its K_p max: its margins and the model's 5 mm step (the figures
    /// `bode_valve_or_pump` and `step_valve_or_pump`).
    pub at_kp_max: Vec<Case>,
}

/// Step 13: the article's DPM and its valve-controlled counterpart side by side.
pub(super) fn valve_or_pump(run: &mut Run) -> Result<ValveOrPump> {
    run.step("Valve or pump: the article's rig with a servo valve instead of its pumps (the article's introduction, §3.2, §4)");
    let article = Rig::default();
    let si = article.si();
    let top = article.displacement_1_cm3_per_rev * 1e-6 * article.pump_max_speed_rpm / 60.0 / si.a2;
    let x = ARTICLE_READING.gas_fraction(BETA_OIL_BAR)?;
    let base = [
        "circuit=valve".to_string(),
        format!("supply_pressure_bar={SUPPLY_BAR}"),
    ];
    let unsized_valve = with(&article, &base)?;
    let flow = rated_flow_for_velocity_lpm(&unsized_valve, top);
    let sized: Vec<String> = [base.to_vec(), vec![format!("valve_rated_flow_lpm={flow}")]].concat();
    let p_valve = anchor_bar(&with(&article, &sized)?);
    let own_beta = effective_beta(x, p_valve, BETA_OIL_BAR);
    let sides = vec![
        side(
            &article,
            "DPM (the article's rig, Table 1)",
            vec![],
            ARTICLE_READING.p_mean_bar,
        )?,
        side(
            &article,
            &format!("valve, {SUPPLY_BAR} bar supply, β_e of the rig's oil at its rest"),
            [sized.clone(), vec![format!("beta_bar={own_beta}")]].concat(),
            p_valve,
        )?,
        side(
            &article,
            &format!("valve, {SUPPLY_BAR} bar supply, β_e 165 bar (the DPM's)"),
            [sized, vec![format!("beta_bar={}", printed::BETA_BAR)]].concat(),
            p_valve,
        )?,
    ];
    let mut out = ValveOrPump {
        top_speed_m_per_s: top,
        valve_rated_flow_lpm: flow,
        gas_fraction: x,
        targets: [printed::PM_DEG, printed::GM_DB],
        sides,
        at_kp_max: Vec::new(),
    };
    report(run, &out);
    out.at_kp_max = figures(run, &article, &out.sides)?;
    Ok(out)
}

/// The Bode diagrams and 5 mm steps of the sides at their K_p max, overlaid.
fn figures(run: &mut Run, article: &Rig, sides: &[Side]) -> Result<Vec<Case>> {
    let rigs = (sides.iter())
        .map(|s| {
            let mut set = s.set.clone();
            set.push(format!("kp={}", s.kp_max));
            Ok((
                format!("{}, K_p {:.4}", s.label, s.kp_max),
                with(article, &set)?,
            ))
        })
        .collect::<Result<Vec<_>>>()?;
    let study = Study {
        stem: "valve_or_pump",
        what: "valve or pump, each at the largest K_p meeting the article's margins",
        rig: "the article's rig (Table 1)",
        position: Position::Absolute,
        bode: Source::Own,
        step: Source::Own,
    };
    variants(run, &study, &rigs)
}

/// The default rig with `sets` applied.
fn with(rig: &Rig, sets: &[String]) -> Result<Rig> {
    rig.with_overrides(sets)
        .with_context(|| format!("the valve-or-pump rig {sets:?}"))
}

/// One side: its rig's resonance, Merritt's frequency, the largest gain meeting the article's
/// margins and the tracking error there.
fn side(article: &Rig, label: &str, set: Vec<String>, p_mean_bar: f64) -> Result<Side> {
    let rig = with(article, &set)?;
    let (resonance_hz, damping_ratio) = super::resonance(&rig, BAND_HZ)?;
    let targets = Targets {
        pm_deg: printed::PM_DEG,
        gm_db: printed::GM_DB,
        ..Targets::default()
    };
    let kp_max = design::kp_max(&rig, &targets)?;
    let at_max = Rig {
        kp: kp_max,
        ..rig.clone()
    };
    let margins = super::margins_of(&at_max)?;
    let tracking = design::predicted_tracking(&at_max, &[WAVE])?;
    Ok(Side {
        label: label.to_string(),
        circuit: rig.circuit.name().to_string(),
        set,
        p_mean_bar,
        beta_e_bar: rig.beta_bar,
        resonance_hz,
        damping_ratio,
        merritt_hz: merritt_hz(&rig),
        kp_max,
        kv_max_per_s: margins.velocity_gain_per_s,
        max_error_mm: tracking[0].max_error_mm,
    })
}

/// Merritt's hydraulic natural frequency (Hz) of `rig`'s cylinder at x0 (Merritt 1967, §5.2).
fn merritt_hz(rig: &Rig) -> f64 {
    let si = rig.si();
    let stiffness = si.beta * (si.a1 * si.a1 / si.v1 + si.a2 * si.a2 / si.v2);
    (stiffness / si.mass).sqrt() / (2.0 * std::f64::consts::PI)
}

/// The section's text, table and comparison rows.
fn report(run: &mut Run, v: &ValveOrPump) {
    run.text(&format!(
        "The article's rig with its pumps replaced by a four-way servo valve (docs/circuits.md#valve): the same cylinder, \
         line volumes, mass and friction; a {SUPPLY_BAR} bar supply; the valve sized to move the unloaded piston at the DPM's \
         top speed, {:.3} m/s (pump 1 at its speed limit), in its slower direction: {:.1} L/min per land at its rated drop \
         (docs/circuits.md#sizing-the-valve). Its β_e comes from the rig's gas fraction {:.4} (165 bar at 4.4 bar) at the \
         valve circuit's own rest, and once more at the DPM's 165 bar, the case of the article's §4. Each K_p max meets the \
         article's design margins (PM {} deg, GM {} dB) at the design point; K_v compares the gains across circuits \
         (docs/analysis.md#the-velocity-loop-gain). Computed on the model, no record is involved.",
        v.top_speed_m_per_s, v.valve_rated_flow_lpm, v.gas_fraction, v.targets[0], v.targets[1]
    ));
    run.table(
        "Valve or pump: the article's rig with its DPM and with a servo valve",
        &HEADER,
        v.sides.iter().map(row).collect(),
    );
    let [dpm, valve, soft] = &v.sides[..] else {
        unreachable!("three sides")
    };
    run.compare_why(
        "introduction / §3.2: the valve circuit's β_e (bar) and its resonance's damping ratio",
        format!(
            "{:.0} bar at {:.1} bar; ζ {}",
            valve.beta_e_bar,
            valve.p_mean_bar,
            fmt_opt(valve.damping_ratio, 3)
        ),
        "above 6000 bar at 100 bar; ζ as low as 0.1 and 0.2",
        "-",
        "the rig's own oil (2.6 % undissolved air) at the valve's mean chamber pressure, about half the supply: stiffer than the DPM's by far, softer than the introduction's 1 % at 100 bar; no leakage across the piston, so less damped than the article's valve circuits",
    );
    run.compare_why(
        "§4: valve at 165 bar, 10,593 kg: K_p max, K_v (1/s), 0.2 Hz ±35 mm max error (mm)",
        format!(
            "{:.4}, K_v {} 1/s, {:.1} mm (DPM: K_v {} 1/s, {:.1} mm)",
            soft.kp_max,
            fmt_opt(soft.kv_max_per_s, 3),
            soft.max_error_mm,
            fmt_opt(dpm.kv_max_per_s, 3),
            dpm.max_error_mm
        ),
        "adequate performance would certainly not have been achievable",
        "-",
        "the article's statement as a number: the same margins admit only a velocity-loop gain a fraction of the DPM's",
    );
}

const HEADER: [&str; 9] = [
    "circuit",
    "p mean (bar)",
    "β_e (bar)",
    "resonance (Hz)",
    "ζ",
    "Merritt ω_h/2π (Hz)",
    "K_p max",
    "K_v (1/s)",
    "0.2 Hz ±35 mm max |e| (mm)",
];

fn row(s: &Side) -> Vec<String> {
    vec![
        s.label.clone(),
        format!("{:.2}", s.p_mean_bar),
        format!("{:.0}", s.beta_e_bar),
        fmt_opt(s.resonance_hz, 3),
        fmt_opt(s.damping_ratio, 4),
        format!("{:.3}", s.merritt_hz),
        format!("{:.4}", s.kp_max),
        fmt_opt(s.kv_max_per_s, 3),
        format!("{:.2}", s.max_error_mm),
    ]
}
