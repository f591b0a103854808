"""pumpcyl against python-control on the matrices from state_space: margins, Bode, step."""

import numpy as np
import pytest

import pumpcyl
from conftest import require_control


def test_article_gain_margin_and_python_control_margin_agree():
    control = require_control()
    rig = pumpcyl.Rig()
    m = pumpcyl.margins(rig)
    # the article's rig: GM 6.5 dB, PM 34 deg (article Section 4); pumpcyl resolves 6.45
    assert abs(m.gain_margin_db - 6.45) <= 0.05
    assert m.closed_loop_stable
    gm, pm, wcg, wcp = control.margin(pumpcyl.to_control(rig))
    assert abs(20 * np.log10(gm) - m.gain_margin_db) <= 0.01
    assert abs(pm - m.phase_margin_deg) <= 0.01
    assert abs(wcg / (2 * np.pi) - m.phase_crossover_hz) <= 1e-3 * m.phase_crossover_hz
    assert abs(wcp / (2 * np.pi) - m.gain_crossover_hz) <= 1e-3 * m.gain_crossover_hz


@pytest.mark.parametrize("overrides", [{}, {"beta_bar": 37.8}, {"mass_kg": 4898, "kp": 40},
                                       {"feedforward": False}, {"motor_model": "first_order"}])
def test_margins_agree_on_variants(overrides):
    control = require_control()
    rig = pumpcyl.Rig(**overrides)
    m = pumpcyl.margins(rig)
    gm, pm, _, _ = control.margin(pumpcyl.to_control(rig))
    assert abs(20 * np.log10(gm) - m.gain_margin_db) <= 0.01, overrides
    assert abs(pm - m.phase_margin_deg) <= 0.01, overrides


@pytest.mark.parametrize("loop", ["open", "closed"])
def test_bode_matches_python_control_frequency_response(loop):
    control = require_control()
    rig = pumpcyl.Rig()
    f_hz = np.logspace(-2, 2.5, 400)
    mag_db, phase_deg = pumpcyl.bode(rig, f_hz, loop)
    resp = control.frequency_response(pumpcyl.to_control(rig, loop), 2 * np.pi * f_hz)
    ref_db = 20 * np.log10(np.abs(np.squeeze(resp.magnitude)))
    ref_deg = np.degrees(np.squeeze(resp.phase))
    np.testing.assert_allclose(mag_db, ref_db, atol=1e-6)
    # unwrapped phases may differ by whole turns only
    wrapped = (phase_deg - ref_deg + 180.0) % 360.0 - 180.0
    np.testing.assert_allclose(wrapped, 0.0, atol=1e-4)


@pytest.mark.parametrize("overrides", [{}, {"kp": 20.0}, {"sum_pressure": False}])
def test_step_matches_python_control_zoh(overrides):
    control = require_control()
    rig = pumpcyl.Rig(**overrides)
    s = pumpcyl.step(rig, step_mm=5.0, duration_s=4.0, rate_hz=100.0)
    A, B, C, D = pumpcyl.state_space(rig, "closed")
    sysd = control.c2d(control.ss(A, B, C, D), 0.01, "zoh")
    u = np.full(s.time_s.shape, 5e-3)  # the step in m, from t = 0, held between samples
    resp = control.forced_response(sysd, s.time_s, u)
    x_mm = rig.x0_mm + 1e3 * np.squeeze(resp.outputs)
    np.testing.assert_allclose(s.x_mm, x_mm, rtol=0, atol=1e-6)
    np.testing.assert_allclose(s.e_mm, 5.0 + rig.x0_mm - x_mm, rtol=0, atol=1e-6)


def test_simulate_matches_python_control_zoh_on_a_nonuniform_free_signal():
    control = require_control()
    rig = pumpcyl.Rig()
    t_s = np.arange(0, 3.0, 0.005)
    x_ref_mm = 340.0 + 10.0 * np.sin(2 * np.pi * 0.7 * t_s) + (t_s > 1.0) * 3.0
    res = pumpcyl.simulate(rig, t_s, x_ref_mm)
    A, B, C, D = pumpcyl.state_space(rig, "closed")
    sysd = control.c2d(control.ss(A, B, C, D), 0.005, "zoh")
    resp = control.forced_response(sysd, t_s, (x_ref_mm - x_ref_mm[0]) * 1e-3)
    np.testing.assert_allclose(res.x_mm, x_ref_mm[0] + 1e3 * np.squeeze(resp.outputs),
                               rtol=0, atol=1e-6)
