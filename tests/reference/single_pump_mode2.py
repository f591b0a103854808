"""Reference margins of the single-pump circuit's mode 2 (the article's Figure 1a).

Builds mode 2's linear model at rest INDEPENDENTLY of pumpcyl, from the circuit's equations as
docs/circuits.md writes them with chamber 1 held at the accumulator pressure, and prints
python-control's stability margins of the open loop e -> x as JSON. Called by
tests/single_pump.rs with the rig's values (user units) as one JSON argument; the venv's
python-control (target/py-venv, see test.sh) is needed.

States x, v, p2, w, tau, z (full motor model with feedforward); chamber 1 at p_acc:
  m dv/dt     = p_acc A1 - p2 A2 - F_ext - b v
  V2/beta dp2 = -D1 w + A2 v - c2 (p2 - p_acc) + c12 (p_acc - p2)
  J dw/dt     = tau - D1 (p_acc - p2),  J = Jm1 + Jp1
  dtau/dt     = wI (Km (w_ref - w) + (Kff/tff)(w_ref - z) - tau)
  tff dz/dt   = w_ref - z
  w_ref       = K_scale Kp e
The volume is that at x0: V2 = VL2 + A2 (x_max - x0). The equations are linear in the states,
so the operating point (p2 from the force balance) does not enter the model.
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
    v2 = r["line_volume_2_dm3"] * 1e-3 + a2 * (r["stroke_mm"] * 1e-3 - x0)
    d1 = r["displacement_1_cm3_per_rev"] * 1e-6 / (2 * math.pi)
    j = (r["motor_inertia_1_kg_mm2"] + r["pump_inertia_1_kg_mm2"]) * 1e-6
    m, b = r["mass_kg"], r["viscous_friction_ns_per_m"]
    k2 = r["beta_bar"] * 1e5 / v2
    c2, c12 = r["c2_m5_per_ns"], r["c12_m5_per_ns"]
    wi, km = r["current_loop_bandwidth_rad_per_s"], r["km1_nms_per_rad"]
    tff = r["tau_ff_s"]
    kf = r["kff_kg_m2"] / tff
    A = np.array([
        [0, 1, 0, 0, 0, 0],
        [0, -b / m, -a2 / m, 0, 0, 0],
        [0, k2 * a2, -k2 * (c2 + c12), -k2 * d1, 0, 0],
        [0, 0, d1 / j, 0, 1 / j, 0],
        [0, 0, 0, -wi * km, -wi, -wi * kf],
        [0, 0, 0, 0, 0, -1 / tff],
    ])
    k = r["k_scale_rad_per_s"] * r["kp"]
    B = k * np.array([[0], [0], [0], [0], [wi * (km + kf)], [1 / tff]])
    C = np.array([[1, 0, 0, 0, 0, 0]])
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
