"""A step that barely damps says so, with its least-damped pole, and a response beyond the
drives' ratings says which (docs/simulation.md#ringing, #drive-ratings), as the command line's
``step --json`` does."""

import json
import subprocess
import warnings

import pytest

import pumpcyl
from conftest import pumpcyl_binary


def cli_step(*sets):
    args = [pumpcyl_binary(), "step", "--json"]
    for s in sets:
        args += ["--set", s]
    return json.loads(subprocess.run(args, check=True, capture_output=True, text=True).stdout)


def test_a_step_with_under_1_db_of_gain_margin_names_its_least_damped_pole():
    s = pumpcyl.step(pumpcyl.Rig(kp=34.0))
    cli = cli_step("kp=34")
    ringing = s.metrics.get("ringing")
    assert ringing is not None
    assert ringing["gain_margin_db"] < 1.0
    assert ringing == pytest.approx(cli["metrics"]["ringing"], rel=1e-12)
    assert 0.0 < ringing["damping_ratio"] < 0.05
    # the article's Kp 25 has margin to spare: no warning
    assert "ringing" not in pumpcyl.step(pumpcyl.Rig()).metrics


def test_a_step_beyond_the_drives_ratings_warns_and_lists_them():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        s = pumpcyl.step(pumpcyl.Rig(motor_rated_speed_rpm=200.0), 5.0)
    assert s.over_ratings, "a 200 rpm rating is exceeded by a 5 mm step"
    assert {o["quantity"] for o in s.over_ratings} == {"motor_speed"}
    assert any("200" in str(w.message) and "rated" in str(w.message) for w in caught)
    assert s.over_ratings == cli_step("motor_rated_speed_rpm=200")["over_ratings"]
