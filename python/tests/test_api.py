"""The API of the issue runs as written; rigs, errors and conversions behave."""

import numpy as np
import pytest

import pumpcyl
from conftest import ARTICLE, read_record


def test_the_issue_example_runs_as_written(tmp_path):
    rig = pumpcyl.Rig()
    rig = pumpcyl.Rig(beta_bar=37.8)
    path = tmp_path / "my-rig.toml"
    assert rig.beta_bar == 37.8  # unstable at this beta (the article §3.1): analysed below
    path.write_text(pumpcyl.Rig(beta_bar=170.0).to_toml())
    rig = pumpcyl.Rig.from_toml(str(path))
    rig2 = rig.replace(mass_kg=4898, kp=40)
    assert (rig.beta_bar, rig2.mass_kg, rig2.kp, rig.mass_kg) == (170.0, 4898.0, 40.0, 10593.0)
    assert rig.to_dict()["beta_bar"] == 170.0 and "beta_bar = 170.0" in rig.to_toml()

    m = pumpcyl.margins(rig)
    values = (m.gain_margin_db, m.phase_margin_deg, m.gain_crossover_hz,
              m.phase_crossover_hz, m.delay_margin_s, m.closed_loop_stable, m.crossings)
    assert all(v is not None for v in values) and isinstance(m.crossings, list)

    A, B, C, D = pumpcyl.state_space(rig, loop="open")
    assert A.shape == (10, 10) and B.shape == (10, 1) and C.shape == (1, 10) and D.shape == (1, 1)
    assert A.dtype == np.float64
    A, B, C, D = pumpcyl.state_space(rig, loop="closed")
    f_hz = np.logspace(-2, 2, 50)
    mag_db, phase_deg = pumpcyl.bode(rig, f_hz)
    assert mag_db.shape == phase_deg.shape == f_hz.shape

    t_s = np.arange(0, 2.0, 0.01)
    x_ref_mm = np.where(t_s < 0.5, 345.0, 350.0)
    res = pumpcyl.simulate(rig, t_s, x_ref_mm)
    sig = res.signals
    for a in (sig.x_mm, sig.p1_bar, sig.p2_bar, sig.w1_rpm, sig.w2_rpm):
        assert a.shape == t_s.shape
    s = pumpcyl.step(rig, step_mm=5.0)
    m = s.metrics
    assert m["rise_time_s"] > 0 and m["overshoot_mm"] >= 0
    assert s.signals.x_mm.shape == s.signals.time_s.shape

    small = dict(beta_bar=[150.0, 165.0, 180.0], viscous_friction_ns_per_m=[100.0, 300.0],
                 c12_m5_per_ns=[1.0e-10, 1.2e-10, 1.4e-10])
    r = pumpcyl.identify(str(ARTICLE / "identify.toml"), grid=small, refined_grid=False)
    assert (r.beta_bar, r.viscous_friction_ns_per_m, r.c12_m5_per_ns) is not None
    assert r.cost_mm2 > 0 and len(r.top) > 0

    rec = read_record("identification.csv")
    t_s, x_ref_mm, x_mm = rec["time_s"], rec["x_ref_mm"], rec["x_mm"]
    r = pumpcyl.identify(
        datasets=[pumpcyl.Dataset(t_s, x_ref_mm, x_mm, kp=25, mass_kg=10593, fit_end_s=2.5)],
        standstill=dict(w1_rpm=-160, w2_rpm=245, p1_bar=3.95), rig=rig.replace(beta_bar=165),
        grid=small, refined_grid=False)
    assert 150 <= r.beta_bar <= 180
    x = pumpcyl.gas_fraction(beta_bar=165, p_mean_bar=4.4)
    assert 0 < x < 1
    d = pumpcyl.design(rig.replace(beta_bar=165), target_pm_deg=34)
    assert d["kp_max"] > 0 and d["verdict"] in ("adequate", "marginal", "use_higher_pressure")


def test_replace_leaves_the_original_unchanged():
    rig = pumpcyl.Rig()
    rig2 = rig.replace(mass_kg=4898, kp=40, feedforward=False, motor_model="first_order")
    assert rig.mass_kg == 10593.0 and rig.kp == 25.0 and rig.feedforward is True
    assert rig.motor_model == "full" and rig2.motor_model == "first_order"
    assert rig2.feedforward is False and rig2 != rig and rig == pumpcyl.Rig()
    assert rig.motor_time_constant_s is None
    assert rig2.replace(motor_time_constant_s=0.05).motor_time_constant_s == 0.05
    assert repr(pumpcyl.Rig(beta_bar=37.8)) == "Rig(beta_bar=37.8)"


def test_the_mass_follows_the_stroke_as_the_geometry_ties_them():
    rig = pumpcyl.Rig()
    # the article's seesaw (its §3.3): 9958 kg at x0 - 50 mm, 12 373 kg at x0 + 50 mm
    assert rig.mass_by_position == [
        {"mass_kg": 9958.0, "x_mm": 295.0},
        {"mass_kg": 10593.0, "x_mm": 345.0},
        {"mass_kg": 12373.0, "x_mm": 395.0},
    ]
    d = pumpcyl.design(rig, target_pm_deg=34, target_gm_db=6, stroke_mm=50)
    masses = {round(c["x_mm"]): c["mass_kg"] for c in d["conditions"]}
    assert masses == {295: 9958.0, 345: 10593.0, 395: 12373.0}
    flat = rig.replace(mass_by_position=[])
    assert flat.mass_by_position == []
    d = pumpcyl.design(flat, target_pm_deg=34, target_gm_db=6, stroke_mm=50)
    assert {c["mass_kg"] for c in d["conditions"]} == {10593.0}
    two = rig.replace(mass_by_position=[{"x_mm": 300.0, "mass_kg": 10000.0}, {"x_mm": 400.0, "mass_kg": 12000.0}])
    assert two.mass_by_position[1] == {"mass_kg": 12000.0, "x_mm": 400.0}
    with pytest.raises(ValueError, match="mass_by_position"):
        rig.replace(mass_by_position=[{"x_mm": 300.0, "mass_kg": 10000.0}])


def test_to_toml_round_trips_through_from_toml(tmp_path):
    rig = pumpcyl.Rig(beta_bar=220.0, mass_kg=4898, feedforward=False, c12_m5_per_ns=3.3e-11)
    path = tmp_path / "rig.toml"
    path.write_text(rig.to_toml())
    back = pumpcyl.Rig.from_toml(path)
    assert back == rig and back.to_dict() == rig.to_dict()
    assert pumpcyl.Rig.from_toml_str(rig.to_toml()) == rig


def test_pumpcyl_error_is_a_value_error_with_the_cli_message(tmp_path):
    assert issubclass(pumpcyl.PumpcylError, ValueError)
    with pytest.raises(pumpcyl.PumpcylError) as e:
        pumpcyl.Rig(bogus=1)
    assert str(e.value).startswith("Rig(bogus=1): unknown key `bogus`")
    with pytest.raises(pumpcyl.PumpcylError, match=r"key `mass_kg` = -1: must be > 0"):
        pumpcyl.Rig(mass_kg=-1)
    with pytest.raises(ValueError, match="takes a float"):
        pumpcyl.Rig(beta_bar="abc")
    bad = tmp_path / "r.toml"
    bad.write_text("beta_bar = 165\nmass_kgg = 3\n")
    with pytest.raises(pumpcyl.PumpcylError) as e:
        pumpcyl.Rig.from_toml(bad)
    assert str(bad) in str(e.value) and "line 2" in str(e.value) and "mass_kgg" in str(e.value)
    with pytest.raises(pumpcyl.PumpcylError, match="beta_bar = 0: must be a finite value > 0"):
        pumpcyl.gas_fraction(beta_bar=0, p_mean_bar=4.4)
    with pytest.raises(pumpcyl.PumpcylError, match="sample 1: time must strictly increase"):
        pumpcyl.simulate(pumpcyl.Rig(), np.array([0.0, 0.0, 0.1]), np.full(3, 345.0))
    with pytest.raises(pumpcyl.PumpcylError, match="unstable"):
        pumpcyl.step(pumpcyl.Rig(kp=400))
    with pytest.raises(pumpcyl.PumpcylError, match="f_hz"):
        pumpcyl.bode(pumpcyl.Rig(), np.array([1.0, -1.0]))
    with pytest.raises(pumpcyl.PumpcylError, match="identify.toml"):
        pumpcyl.identify(str(tmp_path / "identify.toml"))
    with pytest.raises(pumpcyl.PumpcylError, match=r"design\(waves\[0\]=\(-1\.0, 3\.0\)\): the frequency \(Hz\) and the amplitude"):
        pumpcyl.design(pumpcyl.Rig(), waves=[(-1, 3)])
    with pytest.raises(AttributeError):
        pumpcyl.Rig().beta


def test_cli_and_python_print_the_same_message(tmp_path):
    """The message of a bad experiment file is the command line's, word for word."""
    import subprocess
    from conftest import ROOT

    exe = ROOT / "target" / "debug" / "pumpcyl"
    if not exe.exists():
        pytest.skip("SKIPPED: target/debug/pumpcyl not built (cargo build)")
    bad = tmp_path / "exp.toml"
    bad.write_text("[standstill]\nw1_rpm = -160.0\nw2_rpm = 245.0\np1_bar = -1\n")
    cli = subprocess.run([str(exe), "identify", str(bad)], capture_output=True, text=True)
    assert cli.returncode != 0
    with pytest.raises(pumpcyl.PumpcylError) as e:
        pumpcyl.identify(str(bad))
    assert cli.stderr.strip() == "error: " + str(e.value)


def test_margins_have_the_fields_of_the_command_lines_json():
    """Python's margins and `pumpcyl margins --json` come from one serialisation: same keys."""
    import json
    import shutil
    import subprocess
    from pathlib import Path

    exe = shutil.which("pumpcyl") or str(Path(__file__).resolve().parents[2] / "target/debug/pumpcyl")
    if not Path(exe).exists():
        pytest.skip("SKIPPED: the pumpcyl binary is not built (cargo build)")
    cli = json.loads(subprocess.run([exe, "margins", "--json"], check=True,
                                    capture_output=True, text=True).stdout)
    m = pumpcyl.margins(pumpcyl.Rig())
    assert sorted(m.to_dict()) == sorted(cli)
    assert m.gain_margin_db == pytest.approx(cli["gain_margin_db"], rel=1e-12)
    assert set(cli) <= set(dir(m))
    # an infinite margin is None in Python, null in the JSON
    assert "loop" in repr(m) and m.closed_loop_stable is True


def test_one_key_under_two_names_is_refused_as_on_the_command_line():
    # accumulator_pressure_bar is another name of accumulator_precharge_bar: both given is a
    # contradiction the rig file and --set refuse too
    with pytest.raises(pumpcyl.PumpcylError, match="name the same key"):
        pumpcyl.Rig(circuit="single-pump", accumulator_precharge_bar=4.0,
                    accumulator_pressure_bar=3.0)
    assert pumpcyl.Rig(circuit="single-pump",
                       accumulator_pressure_bar=3.0).accumulator_precharge_bar == 3.0
