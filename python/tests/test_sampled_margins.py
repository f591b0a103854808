"""Sampled-data margins of `pumpcyl margins --json` (its `sampled` object) against python-control
0.10.2: the open loop `pumpcyl model --json` prints, discretised with `c2d(loop, h, 'zoh')` and
delayed by z^-d, its `stability_margins` (docs/analysis.md#sampled-data-margins). Random rigs of
every circuit, each at a random PLC rate and delay, and the article's 100 Hz with one sample.

python-control's polynomial method loses these loops (a valve resonance damped 0.004, poles
decades apart), so it reads the margins off the frequency response on a dense grid up to the
Nyquist frequency, ten times finer within 2 % of pumpcyl's crossing frequencies; its
interpolation finds the crossings itself. The closed loop's stability is python-control's `feedback(L, 1)`'s poles against the
unit circle."""

import random

import numpy as np
import pytest

from conftest import pumpcyl_json, require_control
from test_disk_margins import CIRCUITS, random_sets

RIGS = 25


def plc(r, k):
    """The article's PLC for the first rig of each circuit, a random rate and delay after."""
    if k == 0:
        return 100.0, 1
    return float(r.choice([25.0, 50.0, 100.0, 200.0, 1000.0])), r.randrange(0, 4)


def python_controls(control, loop, h, d, ours):
    """python-control's (gm dB, pm deg, wpc Hz, wgc Hz) of c2d(loop, h) z^-d, and its stability."""
    lz = control.c2d(loop, h, "zoh")
    if d:
        lz = lz * control.tf([1.0], [1.0] + [0.0] * d, h)
    nyquist = np.pi / h
    poles = np.abs(np.linalg.eigvals(loop.A))
    lo = min(poles[poles > 0].min(), 1.0) / 1e3
    near = [2 * np.pi * c["frequency_hz"] * np.linspace(0.98, 1.02, 101) for c in ours["crossings"]]
    omega = np.unique(np.concatenate([np.logspace(np.log10(lo), np.log10(nyquist), 5000), *near]))
    gm, pm, _, wpc, wgc, _ = control.stability_margins(control.frd(lz, omega[omega <= nyquist]))
    closed = control.feedback(lz, 1)
    stable = bool(np.all(np.abs(closed.poles()) < 1.0))
    return 20 * np.log10(gm), pm, wpc / (2 * np.pi), wgc / (2 * np.pi), stable


@pytest.mark.parametrize("circuit", sorted(CIRCUITS))
def test_sampled_margins_equal_python_controls(circuit):
    control = require_control()
    r = random.Random(f"sampled-{circuit}")
    for k in range(RIGS):
        rate, d = plc(r, k)
        sets = random_sets(circuit, r) + [f"plc_rate_hz={rate}", f"plc_delay_samples={d}"]
        model = pumpcyl_json("model", sets)
        loop = control.ss(*(np.array(model[m], dtype=float) for m in "ABCD"))
        ours = pumpcyl_json("margins", sets)["sampled"]
        what = f"{circuit} rig {k} ({' '.join(sets)})"
        gm, pm, wpc, wgc, stable = python_controls(control, loop, 1.0 / rate, d, ours)
        assert ours["closed_loop_stable"] == stable, what
        if np.isfinite(gm):
            assert abs(ours["gain_margin_db"] - gm) <= 0.01, f"{what}: GM {ours['gain_margin_db']} vs {gm}"
            assert abs(ours["phase_crossover_hz"] - wpc) <= 1e-4 * wpc, what
        else:
            assert ours["gain_margin_db"] is None, what
        if np.isfinite(pm):
            assert abs(ours["phase_margin_deg"] - pm) <= 0.01, f"{what}: PM {ours['phase_margin_deg']} vs {pm}"
            assert abs(ours["gain_crossover_hz"] - wgc) <= 1e-4 * wgc, what
        else:
            assert ours["phase_margin_deg"] is None, what


def test_the_plc_costs_the_article_loop_about_three_degrees():
    """The article's loop (Kp 25, 100 Hz, one sample of delay): half a sample of hold and one of
    delay at the 0.51 Hz gain crossover cost 1.5 × 0.01 s × 0.51 Hz × 360° ≈ 2.8° of phase; the
    sampled loop's own crossover moves little, so the cost is that estimate to a tenth of a
    degree, and python-control's margins of the sampled loop are pumpcyl's."""
    m = pumpcyl_json("margins")
    s = m["sampled"]
    estimate = 1.5 * 0.01 * m["gain_crossover_hz"] * 360.0
    assert abs(s["phase_margin_cost_deg"] - estimate) < 0.1, (s["phase_margin_cost_deg"], estimate)
    assert s["phase_margin_cost_deg"] == pytest.approx(m["phase_margin_deg"] - s["phase_margin_deg"])
    assert s["delay_margin_samples"] == pytest.approx(s["delay_margin_s"] * 100.0)


def test_designing_on_the_sampled_loop_costs_what_the_command_line_says():
    """`design(sampled=True)` is `pumpcyl design --sampled --json`; its continuous Kp max is the
    plain design's, and the sampled loop at the sampled Kp max meets the phase-margin target
    where the continuous one has margin to spare."""
    import pumpcyl

    got = pumpcyl.design(sampled=True)
    want = pumpcyl_json("design", [], "--sampled")
    assert got["kp_max"] == want["kp_max"]
    assert got["kp_max_continuous"] == pumpcyl_json("design")["kp_max"]
    assert got["kp_max"] < got["kp_max_continuous"]
    at = pumpcyl_json("margins", [f"kp={got['kp_max']}"])
    assert at["sampled"]["phase_margin_deg"] >= 34.0 - 1e-6
    assert at["sampled"]["phase_margin_deg"] < at["phase_margin_deg"]
    assert "sampled by its PLC at 100" in got["analysed_loop"]


def test_python_margins_carry_the_skew_sampled_margins_and_gang_of_four_of_the_command_line():
    """`margins(rig, skew=…)` is `pumpcyl margins --skew … --json`, its `disk`, `sampled` and
    `gang_of_four` included."""
    import pumpcyl

    rig = pumpcyl.Rig().replace(plc_rate_hz=50.0, plc_delay_samples=2)
    got = pumpcyl.margins(rig, skew=0.5)
    want = pumpcyl_json("margins", ["plc_rate_hz=50", "plc_delay_samples=2"], "--skew", "0.5")
    for key in ["disk", "sampled", "gang_of_four"]:
        assert got[key] == want[key], key
    assert got["disk"]["skew"] == 0.5 and got["sampled"]["plc_delay_samples"] == 2
