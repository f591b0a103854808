"""The valve-controlled cylinder against a model written here from its equations alone
(Merritt, Hydraulic Control Systems, 1967, §5.2 and §6.2; docs/circuits.md#valve): the
four-way valve's turbulent lands linearised by hand, the cylinder, the spool, the P law on the
spool; python-control's margins of that loop against pumpcyl's, on rigs that are not the
article's."""

import numpy as np
import pytest

import pumpcyl
from conftest import require_control

LPM = 1e-3 / 60.0
BAR = 1e5


def rest(k, ps, pt, u0, a1, a2, f):
    """Spool opening and chamber pressures at rest without the cylinder's leakage: each
    chamber's lands balance, the pressures hold the force (closed form)."""
    kk = (f + a2 * ps - a1 * pt) / (a1 * ps - a2 * pt - f)
    r = np.sqrt(kk)
    return u0 * (r - 1) / (r + 1), (kk * ps + pt) / (kk + 1), (ps + kk * pt) / (kk + 1)


def loop(rig, control):
    """The open loop K_p x/s_ref of the rig, its matrices written from the equations."""
    d = rig.to_dict()
    a1 = np.pi * (d["piston_diameter_mm"] * 1e-3) ** 2 / 4
    a2 = a1 - np.pi * (d["rod_diameter_mm"] * 1e-3) ** 2 / 4
    x0 = d["x0_mm"] * 1e-3
    v1 = d["line_volume_1_dm3"] * 1e-3 + a1 * x0
    v2 = d["line_volume_2_dm3"] * 1e-3 + a2 * (d["stroke_mm"] * 1e-3 - x0)
    beta, m, b = d["beta_bar"] * BAR, d["mass_kg"], d["viscous_friction_ns_per_m"]
    ps, pt = d["supply_pressure_bar"] * BAR, d["tank_pressure_bar"] * BAR
    kv = d["valve_rated_flow_lpm"] * LPM / np.sqrt(d["valve_rated_drop_bar"] * BAR)
    u0 = d["valve_null_leakage_lpm"] * LPM / (2 * kv * np.sqrt(ps / 2))
    rb = d["valve_flow_ratio_b_to_a"]
    w = 2 * np.pi * d["valve_natural_frequency_hz"]
    z = d["valve_damping"]
    s, p1, p2 = rest(kv, ps, pt, u0, a1, a2, d["external_force_n"])
    dq1_ds = kv * (np.sqrt(ps - p1) + np.sqrt(p1 - pt))
    dq1_dp1 = -kv * ((u0 + s) / (2 * np.sqrt(ps - p1)) + (u0 - s) / (2 * np.sqrt(p1 - pt)))
    dq2_ds = -rb * kv * (np.sqrt(ps - p2) + np.sqrt(p2 - pt))
    dq2_dp2 = -rb * kv * ((u0 - s) / (2 * np.sqrt(ps - p2)) + (u0 + s) / (2 * np.sqrt(p2 - pt)))
    k1, k2 = beta / v1, beta / v2
    # states x, v, p1, p2, s, s_dot
    a = np.zeros((6, 6))
    a[0, 1] = 1
    a[1, 1], a[1, 2], a[1, 3] = -b / m, a1 / m, -a2 / m
    a[2, 1], a[2, 2], a[2, 4] = -k1 * a1, k1 * dq1_dp1, k1 * dq1_ds
    a[3, 1], a[3, 3], a[3, 4] = k2 * a2, k2 * dq2_dp2, k2 * dq2_ds
    a[4, 5] = 1
    a[5, 4], a[5, 5] = -w * w, -2 * z * w
    bm = np.zeros((6, 1))
    bm[5, 0] = w * w
    c = np.zeros((1, 6))
    c[0, 0] = d["kp"]
    return control.ss(a, bm, c, 0)


# each at a gain its loop is stable at: a valve's velocity gain is K_p times the piston speed of
# a full opening, so its K_p is far below the pump circuits' (docs/circuits.md#valve)
RIGS = [
    # a 50/28 mm cylinder at 160 bar, a 10 L/min valve, 800 kg
    dict(piston_diameter_mm=50, rod_diameter_mm=28, stroke_mm=300, x0_mm=120, mass_kg=800,
         beta_bar=7000, supply_pressure_bar=160, valve_rated_flow_lpm=10, kp=8,
         line_volume_1_dm3=0.05, line_volume_2_dm3=0.08, viscous_friction_ns_per_m=2000),
    # the article's cylinder on a 40 L/min valve at 70 bar with a load and a slow spool
    dict(beta_bar=5000, supply_pressure_bar=70, valve_rated_flow_lpm=40, external_force_n=8000,
         valve_natural_frequency_hz=25, valve_damping=0.5, kp=1),
    # a big 100/56 mm cylinder, tank back-pressure, unequal ports, much null leakage
    dict(piston_diameter_mm=100, rod_diameter_mm=56, stroke_mm=800, x0_mm=500, mass_kg=6000,
         beta_bar=9000, supply_pressure_bar=210, tank_pressure_bar=3, valve_rated_flow_lpm=80,
         valve_flow_ratio_b_to_a=0.6, valve_null_leakage_lpm=2.0, kp=0.8,
         external_force_n=-20000),
]


@pytest.mark.parametrize("keys", RIGS)
def test_margins_equal_a_model_written_from_the_equations(keys):
    control = require_control()
    rig = pumpcyl.Rig(circuit="valve", mass_by_position=[], **keys)
    m = pumpcyl.margins(rig)
    assert m.closed_loop_stable, keys
    gm, pm, _, _ = control.margin(loop(rig, control))
    assert abs(20 * np.log10(gm) - m.gain_margin_db) <= 0.05, (keys, gm, m.gain_margin_db)
    assert abs(pm - m.phase_margin_deg) <= 0.05, (keys, pm, m.phase_margin_deg)
    # the velocity-loop gain: lim s L(s), python-control's L at s = 1e-7 rad/s (the loop's other
    # poles lie decades above), and design's K_v at its K_p max scales with the gain
    s = 1e-7
    kv = (s * control.evalfr(loop(rig, control), s)).real
    assert abs(m.velocity_gain_per_s - kv) <= 1e-4 * kv, (keys, m.velocity_gain_per_s, kv)
    d = pumpcyl.design(rig)
    assert abs(d.kv_max_per_s / d.kp_max - kv / keys["kp"]) <= 1e-4 * kv / keys["kp"]


def test_a_valve_rig_reads_and_writes_its_keys():
    rig = pumpcyl.Rig(circuit="valve", supply_pressure_bar=140.0)
    assert rig.supply_pressure_bar == 140.0
    assert rig.valve_damping == 0.7
    back = pumpcyl.Rig.from_toml_str(rig.to_toml(), "v.toml")
    assert back.to_dict() == rig.to_dict()
    with pytest.raises(pumpcyl.PumpcylError, match="the dpm circuit has no such key"):
        pumpcyl.Rig(supply_pressure_bar=140.0)
