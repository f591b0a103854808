"""pumpcyl.select against `pumpcyl select --json` (docs/select.md)."""

import json
import subprocess

import numpy as np
import pytest

import pumpcyl
from conftest import ROOT, pumpcyl_binary


def test_select_matches_the_command_line():
    args = ["--set", "low_pressure_bar=[4.0, 8.0, 10.0]", "--set", "pressurised_bar=[20.0]",
            "--circuits", "dpm"]
    cli = json.loads(subprocess.run([pumpcyl_binary(), "select", *args, "--json"],
                                    check=True, capture_output=True, text=True).stdout)
    py = pumpcyl.select(low_pressure_bar=[4.0, 8.0, 10.0], pressurised_bar=[20.0],
                        circuits=["dpm"])
    assert py == cli
    assert np.array_equal(py.column("options", "mean_pressure_bar"), [4.0, 8.0, 10.0, 20.0])
    assert list(py.column("options", "meets")) == [o["meets"] for o in cli["options"]]
    kp_max = py.column("options", "kp_max")
    assert np.allclose(kp_max, [o["kp_max"] for o in cli["options"]], rtol=0, atol=0)


def test_a_rig_and_a_fixed_gain_reach_the_selection():
    rig = pumpcyl.Rig(mass_by_position=[])
    s = pumpcyl.select(rig=rig, kp=20.0, low_pressure_bar=[6.0])
    assert s["options"][0]["kp_max"] == 20.0
    with pytest.raises(ValueError, match="gas_fractoin"):
        pumpcyl.select(gas_fractoin=0.1)


def test_an_experiment_gives_the_gas_fraction_range_as_on_the_command_line():
    exp = str(ROOT / "data" / "article" / "identify.toml")
    args = ["--experiment", exp, "--set", "low_pressure_bar=[5.0]", "--set", "pressurised_bar=[]"]
    cli = json.loads(subprocess.run([pumpcyl_binary(), "select", *args, "--json"],
                                    check=True, capture_output=True, text=True).stdout)
    py = pumpcyl.select(experiment=exp, low_pressure_bar=[5.0], pressurised_bar=[])
    assert py == cli
    lo, hi = py["gas_fraction_from"]["beta_bar"]
    assert lo < 165.0 < hi


def test_select_across_circuits_matches_the_command_line():
    """The one-motor circuits at each pre-charge: the same document from both front ends,
    every circuit named (docs/select.md#circuits)."""
    args = ["--circuits", "dual-pump,single-pump", "--set", "precharge_bar=[3.0, 8.0]"]
    cli = json.loads(subprocess.run([pumpcyl_binary(), "select", *args, "--json"],
                                    check=True, capture_output=True, text=True).stdout)
    py = pumpcyl.select(circuits=["dual-pump", "single-pump"], precharge_bar=[3.0, 8.0])
    assert py == cli
    assert sorted(py) == sorted(cli)
    assert [(o["circuit"], o["circuit_kind"], o["pressure_level"], o["mean_pressure_bar"])
            for o in py["options"]] == [
        ("dual_pump", "dual-pump", "precharge", 3.0),
        ("dual_pump", "dual-pump", "precharge", 8.0),
        ("single_pump", "single-pump", "precharge", 3.0),
        ("single_pump", "single-pump", "precharge", 8.0),
    ]
    with pytest.raises(ValueError, match="circuits"):
        pumpcyl.select(rig=pumpcyl.Rig(circuit="single-pump"), circuits=["dpm"])


def test_the_mode_check_keyword_matches_the_command_line():
    """The single-pump candidates' mode check by name, as ``--mode-check``: the same document
    from both front ends, the emulator's by default, each option's mode-check numbers where it
    ran and None elsewhere (docs/select.md#the-single-pump-circuit)."""
    args = ["--circuits", "dpm,single-pump", "--set", "precharge_bar=[4.0, 8.0]",
            "--set", "low_pressure_bar=[4.0]", "--set", "pressurised_bar=[]"]
    keys = ["mode_switches", "switches_after_settling", "oscillation_amplitude_mm"]
    for check in ["emulator", "equations"]:
        cli = json.loads(subprocess.run(
            [pumpcyl_binary(), "select", *args, "--mode-check", check, "--json"],
            check=True, capture_output=True, text=True).stdout)
        py = pumpcyl.select(circuits=["dpm", "single-pump"], precharge_bar=[4.0, 8.0],
                            low_pressure_bar=[4.0], pressurised_bar=[], mode_check=check)
        assert py == cli
        assert py["mode_check"] == check
        dpm, *single = py["options"]
        assert all(dpm[k] is None for k in keys)
        assert all(o[k] is not None for o in single for k in keys)
        switches = py.column("options", "mode_switches")
        assert np.isnan(switches[0])
        assert list(switches[1:]) == [o["mode_switches"] for o in cli["options"][1:]]
    default = pumpcyl.select(circuits=["single-pump"], precharge_bar=[4.0])
    assert default["mode_check"] == "emulator"
    with pytest.raises(ValueError, match="mode_check.*emulator, equations"):
        pumpcyl.select(mode_check="emulated")
