"""Robust design from Python (docs/design.md#robust-design): the same answer as the command
line, below the nominal design, and one-line errors."""

import json
import subprocess

import pytest

import pumpcyl
from conftest import ROOT


def test_robust_design_matches_the_command_line():
    d = pumpcyl.design(pumpcyl.Rig(), target_pm_deg=34, robust=True)
    # the nominal design is the article's Kp = 25 within 1; the robust one is lower
    assert abs(d["kp_max_nominal"] - 25.0) < 1.0
    assert 0 < d["kp_max"] < d["kp_max_nominal"]
    assert d["region"]["source"] == "stated_default"
    assert d["deciding"]["binding"] in ("gain_margin", "phase_margin")
    assert d["deciding"]["at"]["x_mm"] in (295.0, 395.0)
    assert len(d["steps"]) == 6
    exe = ROOT / "target" / "debug" / "pumpcyl"
    if not exe.exists():
        pytest.skip(f"SKIPPED: {exe} not built (cargo build)")
    out = subprocess.run(
        [str(exe), "design", "--robust", "--target-pm-deg", "34", "--json"],
        capture_output=True, text=True, check=True,
    )
    cli = json.loads(out.stdout)
    assert cli["kp_max"] == pytest.approx(d["kp_max"], rel=1e-12)
    assert cli["deciding"] == d["deciding"]


def test_robust_design_errors(tmp_path):
    with pytest.raises(pumpcyl.PumpcylError, match=r"design\(confidence=1.5\): must lie strictly"):
        pumpcyl.design(robust=True, experiment=str(tmp_path / "e.toml"), confidence=1.5)
    with pytest.raises(pumpcyl.PumpcylError, match="e.toml: cannot read"):
        pumpcyl.design(robust=True, experiment=str(tmp_path / "e.toml"))
    with pytest.raises(pumpcyl.PumpcylError, match="needs robust=True"):
        pumpcyl.design(experiment=str(tmp_path / "e.toml"))
    with pytest.raises(pumpcyl.PumpcylError, match="give either the file or rig"):
        pumpcyl.design(pumpcyl.Rig(), robust=True, experiment=str(tmp_path / "e.toml"))
