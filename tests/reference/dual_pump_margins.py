"""Reference margins of the single-motor dual-pump circuit (the article's Figure 1b).

Builds the circuit's linear model at rest INDEPENDENTLY of pumpcyl, from its equations as
docs/circuits.md writes them, and prints python-control's stability margins of the open loop
e -> x as JSON. Called by tests/dual_pump.rs with the rig's values (user units) as one JSON
argument; the venv's python-control (target/py-venv, see test.sh) is needed.

States x, v, p1, p2, w, tau, z (full motor model with feedforward):
  m dv/dt     = p1 A1 - p2 A2 - F_ext - b v
  V1/beta dp1 = (D1 + D2) w - A1 v - c1 (p1 - p_acc) - c12 (p1 - p2)
  V2/beta dp2 = -D1 w + A2 v - c2 (p2 - p_acc) + c12 (p1 - p2)
  J dw/dt     = tau - D1 (p1 - p2) - D2 (p1 - p_acc),  J = Jm1 + Jp1 + Jp2
  dtau/dt     = wI (Km (w_ref - w) + (Kff/tff)(w_ref - z) - tau)
  tff dz/dt   = w_ref - z
  w_ref       = K_scale Kp e
At rest every chamber's net flow is zero, so the volumes' dependence on x drops out of the
Jacobian: V1 = VL1 + A1 x0, V2 = VL2 + A2 (x_max - x0).
"""

import json
import math
import sys

import control
import numpy as np


def model(r):
    a1 = math.pi * (r["piston_diameter_mm"] * 1e-3) ** 2 / 4
    a2 = a1 - math.pi * (r["rod_diameter_mm"] * 1e-3) ** 2 / 4
    x0 = r["x0_mm"] * 1e-3
    v1 = r["line_volume_1_dm3"] * 1e-3 + a1 * x0
    v2 = r["line_volume_2_dm3"] * 1e-3 + a2 * (r["stroke_mm"] * 1e-3 - x0)
    per_rad = 1e-6 / (2 * math.pi)
    d1 = r["displacement_1_cm3_per_rev"] * per_rad
    d2 = r["displacement_2_cm3_per_rev"] * per_rad
    j = (r["motor_inertia_1_kg_mm2"] + r["pump_inertia_1_kg_mm2"] + r["pump_inertia_2_kg_mm2"]) * 1e-6
    m, b = r["mass_kg"], r["viscous_friction_ns_per_m"]
    beta = r["beta_bar"] * 1e5
    c1, c2, c12 = r["c1_m5_per_ns"], r["c2_m5_per_ns"], r["c12_m5_per_ns"]
    wi, km = r["current_loop_bandwidth_rad_per_s"], r["km1_nms_per_rad"]
    kf = r["kff_kg_m2"] / r["tau_ff_s"]
    k1, k2 = beta / v1, beta / v2
    A = np.array([
        [0, 1, 0, 0, 0, 0, 0],
        [0, -b / m, a1 / m, -a2 / m, 0, 0, 0],
        [0, -k1 * a1, -k1 * (c1 + c12), k1 * c12, k1 * (d1 + d2), 0, 0],
        [0, k2 * a2, k2 * c12, -k2 * (c2 + c12), -k2 * d1, 0, 0],
        [0, 0, -(d1 + d2) / j, d1 / j, 0, 1 / j, 0],
        [0, 0, 0, 0, -wi * km, -wi, -wi * kf],
        [0, 0, 0, 0, 0, 0, -1 / r["tau_ff_s"]],
    ])
    k = r["k_scale_rad_per_s"] * r["kp"]
    B = k * np.array([[0], [0], [0], [0], [0], [wi * (km + kf)], [1 / r["tau_ff_s"]]])
    C = np.array([[1, 0, 0, 0, 0, 0, 0]])
    return control.ss(A, B, C, 0)


def main():
    rig = json.loads(sys.argv[1])
    gm, pm, _, wpc, wgc, _ = control.stability_margins(model(rig))
    finite = lambda v: None if not np.isfinite(v) else float(v)
    print(json.dumps({
        "gain_margin_db": finite(20 * math.log10(gm)) if np.isfinite(gm) else None,
        "phase_margin_deg": finite(pm),
        "phase_crossover_hz": finite(wpc / (2 * math.pi)),
        "gain_crossover_hz": finite(wgc / (2 * math.pi)),
    }))


if __name__ == "__main__":
    main()
