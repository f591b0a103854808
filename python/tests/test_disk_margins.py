"""Disk margins and sensitivity peaks of `pumpcyl margins --json` against python-control's
`disk_margins` (0.10.2) on the open loop `pumpcyl model --json` prints, for 100 random rigs of
every circuit (docs/analysis.md#disk-margins): the balanced disk (skew 0) with its gain and
phase margins, the skew 0.5 (`--skew 0.5`), and the skews 1 and −1, whose disk margins are
1/M_s and 1/M_t.

python-control evaluates on the frequencies it is given: a log grid over the loop's span with
pumpcyl's peak frequencies added. pumpcyl's peak must be the grid's (no grid point above it) and
its value python-control's there, to 1e-6."""

import random

import numpy as np
import pytest

from conftest import pumpcyl_json, require_control

RIGS = 100
CIRCUITS = {
    "dpm": [],
    "dual-pump": ["circuit=dual-pump"],
    "single-pump": ["circuit=single-pump", "accumulator_precharge_bar=4"],
    "valve": ["circuit=valve", "supply_pressure_bar=100", "beta_bar=1500"],
}


def random_sets(circuit, r):
    """A random rig of `circuit`: gain, load, stiffness, friction and position drawn about the
    article's, the valve's gain in its own unit."""
    kp = r.uniform(0.02, 0.4) if circuit == "valve" else r.uniform(3.0, 40.0)
    sets = [
        f"kp={kp}",
        f"mass_kg={r.uniform(500.0, 15000.0)}",
        "mass_by_position=[]",
        f"viscous_friction_ns_per_m={r.uniform(50.0, 3000.0)}",
        f"x0_mm={r.uniform(100.0, 400.0)}",
    ]
    if circuit != "valve":
        sets.append(f"beta_bar={r.uniform(60.0, 1200.0)}")
    return CIRCUITS[circuit] + sets


def close(got, want, what, rel=1e-6):
    assert abs(got - want) <= rel * abs(want), f"{what}: pumpcyl {got}, python-control {want}"


@pytest.mark.parametrize("circuit", sorted(CIRCUITS))
def test_disk_margins_equal_python_controls(circuit):
    control = require_control()
    r = random.Random(f"disk-{circuit}")
    for k in range(RIGS):
        sets = random_sets(circuit, r)
        model = pumpcyl_json("model", sets)
        loop = control.ss(*(np.array(model[m], dtype=float) for m in "ABCD"))
        m = pumpcyl_json("margins", sets)
        peaks = [m["disk"], m["sensitivity_peak"], m["complementary_sensitivity_peak"]]
        poles = np.abs(np.linalg.eigvals(loop.A))
        poles = poles[poles > 0]
        lo, hi = min(poles.min(), 1.0) / 1e3, max(poles.max(), 1.0) * 1e3
        extra = [2 * np.pi * p["frequency_hz"] for p in peaks if p["frequency_hz"] is not None]
        omega = np.sort(np.concatenate([np.logspace(np.log10(lo), np.log10(hi), 3000), extra]))
        what = f"{circuit} rig {k} ({' '.join(sets)})"
        dm, dgm, dpm = control.disk_margins(loop, omega, skew=0.0)
        close(m["disk"]["disk_margin"], dm, what + " disk margin")
        if m["disk"]["gain_margin_db"] is not None:
            close(m["disk"]["gain_margin_db"], dgm, what + " disk gain margin")
        if m["disk"]["phase_margin_deg"] is not None:
            close(m["disk"]["phase_margin_deg"], dpm, what + " disk phase margin")
        skewed = pumpcyl_json("margins", sets, "--skew", "0.5")["disk"]
        omega = np.sort(np.append(omega, 2 * np.pi * (skewed["frequency_hz"] or 1.0)))
        dm, dgm, dpm = control.disk_margins(loop, omega, skew=0.5)
        close(skewed["disk_margin"], dm, what + " disk margin of skew 0.5")
        if skewed["gain_margin_db"] is not None:
            close(skewed["gain_margin_db"], dgm, what + " disk gain margin of skew 0.5")
        if skewed["phase_margin_deg"] is not None:
            close(skewed["phase_margin_deg"], dpm, what + " disk phase margin of skew 0.5")
        for skew, peak in [(1.0, "sensitivity_peak"), (-1.0, "complementary_sensitivity_peak")]:
            # returnall: its worst-case summary fails where every phase margin is NaN (skew ±1)
            dm, _, _ = control.disk_margins(loop, omega, skew=skew, returnall=True)
            close(1.0 / m[peak]["value"], dm.min(), f"{what} skew {skew}")


@pytest.mark.parametrize("circuit", sorted(CIRCUITS))
def test_the_gang_of_four_peaks_are_python_controls(circuit):
    """PS = P/(1 + PC) and CS = C/(1 + PC) with C = Kp and P = L/Kp, from python-control's
    `feedback`: pumpcyl's peaks are their magnitudes at pumpcyl's frequencies (to 1e-6) and no
    point of a dense grid lies above them."""
    control = require_control()
    r = random.Random(f"gang-{circuit}")
    for k in range(20):
        sets = random_sets(circuit, r)
        model = pumpcyl_json("model", sets)
        loop = control.ss(*(np.array(model[m], dtype=float) for m in "ABCD"))
        gang = pumpcyl_json("margins", sets)["gang_of_four"]
        kp = gang["controller_gain_per_m"]
        plant = loop * (1.0 / kp)
        what = f"{circuit} rig {k} ({' '.join(sets)})"
        for key, sys in [
            ("load_sensitivity_peak_m", control.feedback(plant, kp)),
            ("noise_sensitivity_peak_per_m", control.feedback(control.ss([], [], [], kp), plant)),
        ]:
            peak = gang[key]
            w = 2 * np.pi * peak["frequency_hz"]
            close(peak["value"], abs(sys(1j * w)), f"{what} {key}")
            poles = np.abs(np.linalg.eigvals(loop.A))
            poles = poles[poles > 0]
            grid = np.logspace(np.log10(poles.min() / 1e3), np.log10(poles.max() * 1e3), 4000)
            top = np.abs(sys(1j * grid)).max()
            assert top <= peak["value"] * (1 + 1e-6), f"{what} {key}: grid {top} above {peak['value']}"
