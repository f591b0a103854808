"""The package speaks Python: errors name the Python argument (and the key of a dict argument)
on one line, wrong types and values are refused instead of taken, defaults show in help() and
the stubs, results read well at the prompt, and python-control gets named signals."""

import ast
import inspect
import json
import math
import re
import subprocess
import warnings

import numpy as np
import pytest

import pumpcyl
from conftest import ARTICLE, ROOT, pumpcyl_binary, require_control

STANDSTILL = dict(w1_rpm=-160.0, w2_rpm=245.0, p1_bar=3.95)


def message(call):
    """The PumpcylError message of ``call()``, checked to be one line."""
    with pytest.raises(pumpcyl.PumpcylError) as e:
        call()
    text = str(e.value)
    assert "\n" not in text, text
    return text


def a_dataset():
    rec = np.linspace(0.0, 1.0, 11)
    return pumpcyl.Dataset(rec, rec + 345.0, rec + 345.0, kp=25, mass_kg=10593, fit_end_s=1.0)


# --- errors name Python arguments ------------------------------------------------------------


def test_a_rig_value_out_of_range_names_the_python_argument():
    text = message(lambda: pumpcyl.Rig(beta_bar=float("nan")))
    assert text.startswith("Rig(beta_bar=nan): ") and "must be a finite number" in text
    assert "--set" not in text
    text = message(lambda: pumpcyl.Rig().replace(mass_kg=-1))
    assert text.startswith("Rig.replace(mass_kg=-1): ") and "must be > 0" in text
    # a rule that ties keys together names the arguments given
    text = message(lambda: pumpcyl.Rig(piston_diameter_mm=10))
    assert text.startswith("Rig(piston_diameter_mm=10): ") and "rod_diameter_mm" in text


def test_a_select_argument_out_of_range_names_the_python_argument():
    text = message(lambda: pumpcyl.select(target_pm_deg=float("nan")))
    assert text.startswith("select(target_pm_deg=nan): key `target_pm_deg`: ") and "finite" in text
    text = message(lambda: pumpcyl.select(gas_fractoin=0.1))
    assert text.startswith("select(gas_fractoin=0.1): unknown key `gas_fractoin`")
    text = message(lambda: pumpcyl.select(low_pressure_bar="4"))
    assert text.startswith("select(low_pressure_bar='4'): key `low_pressure_bar` takes a")
    text = message(lambda: pumpcyl.select(low_pressure_bar=[], pressurised_bar=[],
                                          precharge_bar=[]))
    # the keys that list the levels of the circuits asked for (all three by default)
    assert text.startswith("select(low_pressure_bar=[], pressurised_bar=[], precharge_bar=[]): "
                           "key `low_pressure_bar / pressurised_bar / precharge_bar`: "
                           "no pressure level")
    assert "KEY=VALUE" not in text and "--set" not in text


def test_identify_without_records_names_both_arguments():
    text = message(lambda: pumpcyl.identify())
    assert "`experiment`" in text and "`datasets" in text and "neither" in text
    text = message(lambda: pumpcyl.identify(ARTICLE / "identify.toml", datasets=[a_dataset()]))
    assert "`experiment`" in text and "`datasets`" in text and "not both" in text


def test_bode_takes_a_single_frequency():
    rig = pumpcyl.Rig()
    mag_db, phase_deg = pumpcyl.bode(rig, 1.0)
    ref_db, ref_deg = pumpcyl.bode(rig, [1.0])
    assert mag_db.shape == phase_deg.shape == (1,)
    assert mag_db[0] == ref_db[0] and phase_deg[0] == ref_deg[0]


def test_an_array_argument_of_the_wrong_shape_is_named():
    text = message(lambda: pumpcyl.bode(pumpcyl.Rig(), [[1.0, 2.0]]))
    assert text.startswith("bode(f_hz=") and "1-D" in text and "dimensionality" not in text
    text = message(lambda: pumpcyl.simulate(pumpcyl.Rig(), 0.0, [345.0]))
    assert text.startswith("simulate(t_s=0.0)") and "1-D" in text


def test_an_error_in_a_dict_argument_names_the_key():
    bad = dict(STANDSTILL, w1_rpm="x")
    text = message(lambda: pumpcyl.identify(datasets=[a_dataset()], standstill=bad))
    assert text.startswith("identify(standstill['w1_rpm']='x'): ")
    assert "line" not in text and "column" not in text
    grid = dict(beta_bar=[160.0, "a"], viscous_friction_ns_per_m=[100.0],
                c12_m5_per_ns=[1.2e-10])
    text = message(lambda: pumpcyl.identify(ARTICLE / "identify.toml", grid=grid))
    assert text.startswith("identify(grid['beta_bar']=[160.0, 'a']): ")
    text = message(lambda: pumpcyl.identify(datasets=[a_dataset()],
                                            standstill=dict(STANDSTILL, p1_barr=1.0)))
    assert "standstill=" in text and "did you mean `p1_bar`?" in text


def test_messages_are_one_line():
    # serde's messages end "...\nin `key`" and come through on one line
    assert "motor_model" in message(lambda: pumpcyl.Rig(motor_model="second_order"))
    assert "mass_kg" in message(lambda: pumpcyl.Rig(mass_by_position=[{"x_mm": 300.0}]))


# --- no silent acceptance --------------------------------------------------------------------


def test_effective_beta_refuses_values_outside_their_range():
    assert "effective_beta(p_bar=nan)" in message(lambda: pumpcyl.effective_beta(0.026, math.nan))
    assert "effective_beta(x=1.5)" in message(lambda: pumpcyl.effective_beta(1.5, 4.4))
    assert "beta_oil_bar" in message(lambda: pumpcyl.effective_beta(0.026, 4.4, beta_oil_bar=0))
    assert pumpcyl.effective_beta(0.026, 4.4) == pytest.approx(167.6, abs=0.1)


def test_a_rig_key_refuses_a_value_of_another_type():
    assert "mass_kg" in message(lambda: pumpcyl.Rig(mass_kg="4898"))
    # in the Python call's words, as a value out of range is
    assert message(lambda: pumpcyl.Rig(mass_kg="4898")).startswith("Rig(mass_kg='4898'): ")
    assert message(lambda: pumpcyl.Rig().replace(feedforward=1.0)).startswith(
        "Rig.replace(feedforward=1.0): "
    )
    assert "mass_kg" in message(lambda: pumpcyl.Rig(mass_kg=True))
    assert "feedforward" in message(lambda: pumpcyl.Rig(feedforward=1.0))
    assert "mass_kg" in message(lambda: pumpcyl.Rig(mass_kg=object()))
    # numbers stay numbers, numpy's too
    for mass in (4898, 4898.0, np.float64(4898), np.int64(4898)):
        assert pumpcyl.Rig(mass_kg=mass).mass_kg == 4898.0
    assert pumpcyl.Rig(motor_model="first_order").motor_model == "first_order"


def test_a_step_given_in_metres_warns():
    rig = pumpcyl.Rig()
    with pytest.warns(UserWarning, match=r"5 µm is unusual; step_mm is in millimetres"):
        pumpcyl.step(rig, step_mm=0.005, duration_s=0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pumpcyl.step(rig, step_mm=0.05, duration_s=0.5)  # the threshold itself is fine
        pumpcyl.step(rig, step_mm=-5.0, duration_s=0.5)
    assert "0.05 mm" in pumpcyl.step.__doc__


# --- defaults, help and stubs ----------------------------------------------------------------


def test_no_signature_shows_an_ellipsis_for_a_default():
    for name in pumpcyl.__all__:
        f = getattr(pumpcyl, name)
        if inspect.isclass(f):
            continue
        for p in inspect.signature(f).parameters.values():
            assert p.default is not Ellipsis, f"{name}({p.name}=...)"
    d = inspect.signature(pumpcyl.design).parameters
    assert d["target_pm_deg"].default == 34.0 and d["p_mean_bar"].default == ()


def test_the_stubs_write_the_real_defaults():
    tree = ast.parse((ROOT / "python" / "pumpcyl" / "_pumpcyl.pyi").read_text())
    checked = 0
    for node in tree.body:
        if not isinstance(node, ast.FunctionDef):
            continue
        args = node.args.args + node.args.kwonlyargs
        defaults = [None] * (len(node.args.args) - len(node.args.defaults))
        defaults += node.args.defaults + node.args.kw_defaults
        runtime = inspect.signature(getattr(pumpcyl._pumpcyl, node.name)).parameters
        for arg, default in zip(args, defaults):
            if default is None:
                continue
            value = ast.literal_eval(default)
            assert value is not Ellipsis, f"{node.name}({arg.arg}=...)"
            assert value == runtime[arg.arg].default, f"{node.name}({arg.arg})"
            checked += 1
    assert checked > 30


def test_design_defaults_are_the_command_lines():
    exe = pumpcyl_binary()
    help_text = subprocess.run([exe, "design", "--help"], capture_output=True, text=True,
                               check=True).stdout
    cli = {flag.replace("-", "_"): float(value)
           for flag, value in re.findall(r"--([a-z-]+) <[A-Z_]+>.*\[default: ([^\]]+)\]",
                                         help_text)}
    params = inspect.signature(pumpcyl.design).parameters
    assert set(cli) == {"target_pm_deg", "target_gm_db", "stroke_mm", "confidence"}
    assert {k: params[k].default for k in cli} == cli
    # beta's anchor has no number for a default: the rig's own (docs/bulk-modulus.md#the-anchor)
    assert params["p_beta_bar"].default is None
    assert "Default: the rig's own anchor" in help_text
    out = subprocess.run([exe, "design", "--json"], capture_output=True, text=True, check=True)
    assert pumpcyl.design() == json.loads(out.stdout)


def test_a_rig_lists_its_keys_with_units():
    rig = pumpcyl.Rig(beta_bar=170)
    names = dir(rig)
    for key in list(rig.to_dict()) + ["motor_time_constant_s"]:
        assert key in names
    assert "replace" in names and "to_toml" in names
    assert rig.beta_bar == 170.0 and rig.mass_kg == pumpcyl.Rig().mass_kg
    with pytest.raises(AttributeError):
        rig.beta_bar = 1.0
    assert "beta_bar: bar, effective bulk modulus" in pumpcyl.Rig.__doc__
    assert "mass_kg: kg," in pumpcyl.Rig.__doc__


# --- readable results ------------------------------------------------------------------------


def assert_readable(text, kind, *fields):
    assert text.startswith(kind + "(") and text.endswith(")")
    assert len(text.splitlines()) <= 5, text
    for field in fields:
        assert field in text, (field, text)


def test_results_have_a_readable_repr():
    rig = pumpcyl.Rig()
    assert_readable(repr(pumpcyl.margins(rig)), "Margins", "gain_margin_db=6.452",
                    "phase_margin_deg=33.51", "crossings=<list of 2>")
    s = pumpcyl.step(rig, duration_s=4.0)
    assert_readable(repr(s), "Step", "step_mm=5", "metrics=<dict of", "signals=<Result of 8>")
    assert_readable(repr(s.signals), "Signals", "x_mm=<ndarray of 401>")
    sim = pumpcyl.simulate(rig, s.signals.time_s, s.signals.x_ref_mm)
    assert_readable(repr(sim), "Simulation", "signals=<Result of 8>")
    assert_readable(repr(sim.signals), "Signals", "time_s=<ndarray of 401>",
                    "p1_bar=<ndarray of 401>")
    grid = dict(beta_bar=[160.0, 170.0], viscous_friction_ns_per_m=[100.0],
                c12_m5_per_ns=[1.2e-10])
    r = pumpcyl.identify(ARTICLE / "identify.toml", grid=grid, refined_grid=False,
                         local_refinement=False)
    assert_readable(repr(r), "Identification", "beta_bar=160", "c12_m5_per_ns=1.2e-10",
                    "cost_mm2=", "candidates_evaluated=2", "grid_best=<dict of 8>")
    # the fields that do not fit in five lines are named, each an attribute
    also = repr(r).rsplit("… also ", 1)[1].rstrip(")").split(", ")
    assert "top" in also and all(hasattr(r, name) for name in also)


def test_to_control_names_states_input_and_output():
    require_control()
    rig = pumpcyl.Rig()
    states = ["x", "v", "p1", "p2", "w1", "w2", "tau1", "tau2", "z1", "z2"]
    open_loop = pumpcyl.to_control(rig)
    assert open_loop.state_labels == states
    assert open_loop.input_labels == ["e"] and open_loop.output_labels == ["x"]
    closed = pumpcyl.to_control(rig, "closed")
    assert closed.input_labels == ["x_ref"] and closed.output_labels == ["x"]
    first_order = pumpcyl.to_control(pumpcyl.Rig(motor_model="first_order"))
    assert first_order.state_labels == states[:6]


def test_advise_ranks_the_candidates_by_parameter_name():
    a = pumpcyl.advise(ARTICLE / "identify.toml")
    parameters = [w["parameter"] for w in a["current"]]
    assert sorted(a["ranking_by_parameter"]) == sorted(parameters) == sorted(a["best_for"])
    for i, p in enumerate(parameters):
        ranking = a["ranking_by_parameter"][p]
        assert len(ranking) == len(a["candidates"])
        assert ranking[0]["label"] == a["best_for"][p]
        log_std = [r["log_std"] for r in ranking]
        assert log_std == sorted(log_std)
        by_label = {c["label"]: c["widths"][i] for c in a["candidates"]}
        assert all(r["interval"] == by_label[r["label"]]["interval"] for r in ranking)
