//! What the emulator used on a rig, in words: `emulate`, the emulator FMU and `reproduce` each
//! say it where they run the emulator (docs/emulator.md#what-a-user-rig-gets).

use pumpcyl::bulk::effective_beta;
use pumpcyl::emulator::{rest_mean_pressure_bar, Effects, EmulatorError};
use pumpcyl::rig::Rig;
use pumpcyl::units::{readable, RAD_S_PER_RPM};

/// One sentence naming the emulator's bulk modulus (β_e and the pressure where it holds, the gas
/// fraction), its mass law and its limits and defaults on `rig` with `effects`.
///
/// # Errors
/// A rig whose loop cannot rest at x0 (the pressure where β_e holds is its rest's).
pub fn basis(rig: &Rig, effects: &Effects) -> Result<String, EmulatorError> {
    let Some(x) = effects.gas_fraction else {
        return Ok(format!(
            "emulator effects off: beta_e {} bar constant (the rig's beta_bar), mass {} kg \
             constant, no limits, friction only viscous",
            readable(rig.beta_bar),
            readable(rig.mass_kg)
        ));
    };
    let p_mean = rest_mean_pressure_bar(rig)?;
    Ok(format!(
        "emulator: beta_e {:.1} bar at the rig's mean chamber pressure at rest, {:.2} bar \
         (gas fraction X = {:.5}, beta_oil {} bar), beta_e(p) of both chambers' mean pressure; \
         {}; chamber volumes following the piston; torque limited to {} x the rated {} N m, \
         pump speed to {} rpm; pumpcyl's defaults {:.0} rpm pump dead band with slip \
         {:e} m^5/(N s) and {} N Coulomb friction (docs/emulator.md#what-a-user-rig-gets)",
        effective_beta(x, p_mean, effects.beta_oil_bar),
        p_mean,
        x,
        readable(effects.beta_oil_bar),
        mass_law(rig, effects),
        effects
            .peak_torque_factor
            .map_or("no limit".into(), readable),
        readable(rig.motor_rated_torque_nm),
        readable(rig.pump_max_speed_rpm),
        effects.dead_band_rad_s / RAD_S_PER_RPM,
        effects.slip_m5_per_ns,
        readable(effects.coulomb_n)
    ))
}

/// The emulator's mass law on `rig`, in words.
fn mass_law(rig: &Rig, effects: &Effects) -> String {
    let t = &rig.mass_by_position;
    if !effects.stroke_mass || t.len() < 2 {
        return format!("mass {} kg constant over the stroke", readable(rig.mass_kg));
    }
    format!(
        "mass {} kg at x0 following the rig's mass_by_position ({} points, {} to {} mm)",
        readable(rig.mass_kg),
        t.len(),
        readable(t[0].x_mm),
        readable(t[t.len() - 1].x_mm)
    )
}
