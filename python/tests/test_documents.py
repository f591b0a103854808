"""Every Python result is the command line's ``--json`` document (python/README.md#results): the
same keys as the document the binary prints, the same keys as the stub's class of that result,
``to_dict()`` plain data equal to the binary's where the inputs are the same, and signals as
numpy arrays. The binary is run from each test (target/debug/pumpcyl)."""

import json
import subprocess

import numpy as np
import pytest

import pumpcyl
from conftest import ARTICLE, ROOT, pumpcyl_binary, stub_fields

# a small two-stage identification of the article's emulated records (45 + 18 candidates)
SMALL_GRIDS = """
[grid]
beta_bar = [145.0, 155.0, 165.0, 175.0, 185.0]
viscous_friction_ns_per_m = [100.0, 200.0, 300.0]
c12_m5_per_ns = [1.0e-10, 1.2e-10, 1.4e-10]

[refined_grid]
beta_bar = [160.0, 165.0, 170.0]
viscous_friction_ns_per_m = [250.0, 300.0]
c12_m5_per_ns = [1.1e-10, 1.2e-10, 1.3e-10]
"""


def cli(*args, cwd=None):
    out = subprocess.run([pumpcyl_binary(), *args], check=True, capture_output=True, text=True,
                         cwd=cwd)
    return json.loads(out.stdout)


def assert_one_document(result, document, stub_class):
    """`result` has the keys of the binary's `document` and of the stub's `stub_class`."""
    assert isinstance(result, pumpcyl.Result)
    assert sorted(result) == sorted(document), stub_class
    assert sorted(stub_fields(stub_class)) == sorted(document), stub_class
    plain = result.to_dict()
    assert sorted(plain) == sorted(document)
    # plain data, as json reads it: it round-trips through JSON unchanged
    assert json.loads(json.dumps(plain)) == plain
    for key in document:
        assert getattr(result, key) is result[key]


@pytest.fixture(scope="module")
def small_experiment(tmp_path_factory):
    folder = tmp_path_factory.mktemp("small")
    text = (ARTICLE / "identify.toml").read_text().replace('grids = "article"', "")
    for record in ("standstill.csv", "identification.csv", "validation.csv"):
        (folder / record).write_bytes((ARTICLE / record).read_bytes())
    path = folder / "identify.toml"
    path.write_text(text + SMALL_GRIDS)
    return path


def test_margins_is_the_document_of_margins_json():
    m = pumpcyl.margins(pumpcyl.Rig())
    doc = cli("margins", "--json")
    assert_one_document(m, doc, "Margins")
    # the same numbers; the loop's description names the rig as each front end knows it
    plain = m.to_dict()
    assert plain.pop("loop").startswith("Rig() (circuit dpm): ")
    assert doc.pop("loop").startswith("default rig (circuit dpm): ")
    assert plain == doc


def test_step_is_the_document_of_step_json_with_numpy_signals():
    s = pumpcyl.step(pumpcyl.Rig())
    doc = cli("step", "--json")
    assert_one_document(s, doc, "Step")
    assert sorted(s.signals) == sorted(doc["signals"]) == sorted(stub_fields("Signals"))
    for name in doc["signals"]:
        assert isinstance(s.signals[name], np.ndarray)
        np.testing.assert_allclose(s.signals[name], doc["signals"][name], rtol=1e-12, atol=1e-12)
    # the same computation on both sides, serialised with round-trip floats: equal to the bit
    assert s.metrics == doc["metrics"]
    # the same run, one document: only the rig's description differs (its repr in Python)
    plain = s.to_dict()
    plain["rig"] = doc["rig"]
    assert {k: v for k, v in plain.items() if k not in ("signals", "metrics")} == \
        {k: v for k, v in doc.items() if k not in ("signals", "metrics")}


def test_track_is_the_document_of_track_json_on_a_rig_that_is_not_the_articles():
    """`track` is one request for both front ends: the user rig's tracking of one sine and of
    the article's three gives the command line's keys and numbers (to the bit: the same
    computation), `rig_defaulted_keys` included, and the stub's fields."""
    user = ROOT / "tests" / "user-rig.toml"
    with pytest.warns(UserWarning, match="does not set"):
        rig = pumpcyl.Rig.from_toml(user)
    for args, call in ((["--freq-hz", "0.3", "--amp-mm", "12", "--periods", "2"],
                        lambda: pumpcyl.track(rig, 0.3, 12.0, periods=2)),
                       (["--article-cases"], lambda: pumpcyl.track(rig))):
        doc = cli("track", "--rig", str(user), *args, "--json")
        t = call()
        # a rig from a file adds `rig_defaulted_keys` to the stub's fields (Result's docstring)
        assert sorted(t) == sorted(doc)
        assert sorted(stub_fields("Tracking")) == sorted(k for k in doc if k != "rig_defaulted_keys")
        assert len(t.cases) == len(doc["cases"]) == (1 if "--freq-hz" in args else 3)
        assert t.rig_defaulted_keys == doc["rig_defaulted_keys"] and len(doc["rig_defaulted_keys"]) > 5
        plain = t.to_dict()
        assert plain.pop("rig") != doc["rig"]  # each front end names the rig as its user wrote it
        doc.pop("rig")
        assert plain == doc
    # the periodic steady state's error is below the sine and the same whatever the periods
    a, b = pumpcyl.track(rig, 0.3, 12.0, periods=1), pumpcyl.track(rig, 0.3, 12.0, periods=4)
    ma, mb = a.cases[0]["metrics"], b.cases[0]["metrics"]
    assert 0.0 < ma["max_error_mm"] < 12.0
    assert abs(ma["max_error_mm"] - mb["max_error_mm"]) < 1e-9


def test_track_and_step_name_a_bad_argument_as_python_writes_it():
    rig = pumpcyl.Rig()
    for call, text in ((lambda: pumpcyl.track(rig, 0.2, 35.0, periods=2.5),
                        "track(periods=2.5): must be a whole number of periods, 1 or more"),
                       (lambda: pumpcyl.track(rig, -0.2, 35.0), "track(freq_hz=-0.2): must be > 0"),
                       (lambda: pumpcyl.track(rig, 0.2, 600.0), "track(amp_mm=600.0): the reference spans"),
                       (lambda: pumpcyl.track(rig, 0.2), "give freq_hz and amp_mm together"),
                       (lambda: pumpcyl.step(rig, 0.0), "step(step_mm=0.0): must be finite and non-zero"),
                       (lambda: pumpcyl.step(rig, 5.0, rate_hz=float("nan")), "step(duration_s=4.0, rate_hz=nan): ")):
        with pytest.raises(pumpcyl.PumpcylError) as e:
            call()
        assert text in str(e.value), str(e.value)
    # the command line names the same options as it spells them
    bad = subprocess.run([pumpcyl_binary(), "track", "--freq-hz", "0.2", "--amp-mm", "35", "--periods", "2.5"],
                         capture_output=True, text=True)
    assert bad.returncode != 0
    assert bad.stderr.strip() == "error: --periods 2.5: must be a whole number of periods, 1 or more"


def test_poles_and_frf_are_the_command_lines_documents_on_a_rig_that_is_not_the_articles(tmp_path):
    """`poles` and `frf` are each one request for both front ends: the same keys and, for the
    same inputs, the same numbers (the model's label names the rig as each front end knows
    it: the file's path or Python's repr)."""
    p = pumpcyl.poles(pumpcyl.Rig())
    doc = cli("poles", "--json")
    assert_one_document(p, doc, "Poles")
    plain = p.to_dict()
    plain.pop("loop"), doc.pop("loop")
    assert plain == doc
    user = ROOT / "tests" / "user-rig.toml"
    record = tmp_path / "multisine.csv"
    subprocess.run([pumpcyl_binary(), "emulate", "--experiment", "multisine", "--rig", str(user),
                    "--no-noise", "--out", str(record)], check=True, capture_output=True)
    doc = cli("frf", str(record), "--rig", str(user), "--json")
    with pytest.warns(UserWarning, match="does not set"):
        rig = pumpcyl.Rig.from_toml(user)
    r = pumpcyl.frf(record, rig=rig)
    assert sorted(r) == sorted(doc) == sorted(stub_fields("FrequencyResponse"))
    plain = r.to_dict()
    assert plain["model"].pop("label") != doc["model"].pop("label")
    assert plain == doc
    assert len(doc["closed_loop"]["points"]) > 10


def test_select_warns_of_a_relief_setting_above_the_cylinder_in_both_front_ends():
    """`select` is one request: a rig whose derived relief setting lets the dual-pump circuit's
    chamber pass the cylinder's rating gives the same `warnings` from the command line (on
    standard error too) and from Python (each also a UserWarning); a rated cylinder gives
    none."""
    out = subprocess.run([pumpcyl_binary(), "select", "--set", "rig.cylinder_rated_pressure_bar=30",
                          "--circuits", "dual-pump", "--json"], check=True, capture_output=True, text=True)
    doc = json.loads(out.stdout)
    assert len(doc["warnings"]) == 1 and "above cylinder_rated_pressure_bar = 30 bar" in doc["warnings"][0]
    assert "warning: " + doc["warnings"][0] in out.stderr
    rig = pumpcyl.Rig(circuit="dual-pump", cylinder_rated_pressure_bar=30.0)
    with pytest.warns(UserWarning, match="above cylinder_rated_pressure_bar = 30 bar"):
        s = pumpcyl.select(rig=rig, circuits=["dual-pump"])
    assert s.warnings == doc["warnings"]
    assert pumpcyl.select(circuits=["dual-pump"]).warnings == []


def test_step_and_simulate_name_the_circuit_as_the_command_line():
    """Every output names the circuit it used: the user rig switched to the dual-pump circuit
    (the article's Figure 1b) gives `circuit` as `step --json` does."""
    user = ROOT / "tests" / "user-rig.toml"
    with pytest.warns(UserWarning, match="does not set"):
        rig = pumpcyl.Rig.from_toml(user).replace(circuit="dual-pump")
    doc = cli("step", "--rig", str(user), "--set", "circuit=dual-pump", "--json")
    assert pumpcyl.step(rig).circuit == doc["circuit"] == "dual-pump"
    t_s = np.arange(0.0, 1.0, 0.01)
    sim = pumpcyl.simulate(rig, t_s, np.full(t_s.shape, 400.0))
    assert sim.circuit == "dual-pump"
    assert pumpcyl.step(pumpcyl.Rig()).circuit == "dpm"


def test_a_rig_from_a_file_lists_the_keys_it_left_out_as_the_command_line(tmp_path):
    """A result of a rig read from a file holds `rig_defaulted_keys`, the keys the file left
    out, as the command line's: step, simulate and emulate alike; a key set since (`replace`,
    `--set`) is not among them, and a rig made from the article's has no list."""
    user = ROOT / "tests" / "user-rig.toml"
    doc = cli("step", "--rig", str(user), "--set", "external_force_n=100", "--json")
    listed = doc["rig_defaulted_keys"]
    assert len(listed) > 5 and "external_force_n" not in user.read_text()
    with pytest.warns(UserWarning, match="does not set"):
        rig = pumpcyl.Rig.from_toml(user)
    assert "external_force_n" in pumpcyl.step(rig).rig_defaulted_keys
    step = pumpcyl.step(rig.replace(external_force_n=100))
    assert step.rig_defaulted_keys == listed and "external_force_n" not in listed
    t_s = np.arange(0.0, 0.5, 0.01)
    sim = pumpcyl.simulate(rig.replace(external_force_n=100), t_s, np.full(t_s.shape, 345.0))
    assert sim.rig_defaulted_keys == listed
    out = tmp_path / "e.csv"
    emulated = cli("emulate", "--experiment", "step", "--rig", str(user), "--set", "external_force_n=100",
                   "--duration-s", "1", "--out", str(out), "--json")
    e = pumpcyl.emulate("step", rig=rig, duration_s=1.0, external_force_n=100)
    assert e.rig_defaulted_keys == emulated["rig_defaulted_keys"] == listed
    for made in (pumpcyl.Rig(), pumpcyl.Rig(external_force_n=100)):
        assert "rig_defaulted_keys" not in pumpcyl.step(made)


def test_simulate_names_the_stubs_fields():
    t_s = np.arange(0.0, 2.0, 0.01)
    sim = pumpcyl.simulate(pumpcyl.Rig(), t_s, np.full(t_s.shape, 345.0))
    assert isinstance(sim, pumpcyl.Result)
    assert sorted(sim) == sorted(stub_fields("Simulation"))
    assert sorted(sim.signals) == sorted(stub_fields("Signals"))
    # from rest at a constant reference the loop stays at rest, off it by the rest offset
    # (docs/simulation.md#the-rest-under-load) that step reports too
    offset = pumpcyl.step(pumpcyl.Rig()).metrics["rest_offset_mm"]
    assert 0.0 < offset < 0.1 and abs(sim.rest_offset_mm - offset) < 1e-12
    np.testing.assert_allclose(sim.signals.x_mm, 345.0 - offset, rtol=0, atol=1e-9)
    assert sim.warnings == [] and sim.over_ratings == []


def test_identify_is_the_document_of_identify_json(small_experiment):
    r = pumpcyl.identify(small_experiment)
    doc = cli("identify", str(small_experiment), "--json")
    assert_one_document(r, doc, "Identification")
    for key in ("beta_bar", "viscous_friction_ns_per_m", "c12_m5_per_ns", "c1_m5_per_ns",
                "c2_m5_per_ns", "cost_mm2"):
        assert r[key] == pytest.approx(doc[key], rel=1e-12), key
    # the best grid point and the top list in one shape: the core's (stage, index) and the
    # grid point's leakages
    assert r.grid_best == pytest.approx(doc["grid_best"], rel=1e-12)
    assert set(r.grid_best) >= {"stage", "index", "c1_m5_per_ns", "c2_m5_per_ns"}
    assert r.top == doc["top"] and {"stage", "index"} <= set(r.top[0])
    assert r.stages == doc["stages"] and r.candidates_evaluated == 45 + 18
    assert r.experiment == doc["experiment"] == str(small_experiment)


def test_advise_is_the_document_of_advise_json_keyed_by_parameter(small_experiment):
    a = pumpcyl.advise(small_experiment)
    doc = cli("advise", str(small_experiment), "--json")
    assert_one_document(a, doc, "Advice")
    names = [w["parameter"] for w in doc["current"]]
    assert sorted(a.best_for) == sorted(names) == sorted(a.ranking_by_parameter)
    assert a.best_for == doc["best_for"]
    for p in names:
        # the best for a parameter heads its ranking, which sorts by its expected log-std
        ranking = a.ranking_by_parameter[p]
        assert ranking[0]["label"] == a.best_for[p]
        assert [c["log_std"] for c in ranking] == sorted(c["log_std"] for c in ranking)


def test_select_is_the_document_of_select_json():
    s = pumpcyl.select()
    doc = cli("select", "--json")
    assert_one_document(s, doc, "Selection")
    kp_max = s.column("options", "kp_max")
    assert isinstance(kp_max, np.ndarray) and len(kp_max) == len(doc["options"])
    np.testing.assert_allclose(kp_max, [o["kp_max"] for o in doc["options"]], rtol=1e-12)


def test_select_on_a_valve_rig_is_the_document_of_select_json(tmp_path):
    """A valve rig selects over its supply pressures, in Python as on the command line."""
    rig = pumpcyl.Rig(circuit="valve", piston_diameter_mm=80.0, rod_diameter_mm=45.0,
                      mass_kg=2500.0, mass_by_position=[], beta_bar=8000.0,
                      valve_null_leakage_lpm=4.0, external_force_n=15000.0, kp=2.0)
    path = tmp_path / "valve.toml"
    path.write_text(rig.to_toml())
    s = pumpcyl.select(rig=rig, supply_bar=[35.0, 70.0])
    doc = cli("select", "--rig", str(path), "--set", "supply_bar=[35.0, 70.0]", "--json")
    assert_one_document(s, doc, "Selection")
    assert [o["circuit"] for o in s["options"]] == ["valve", "valve"]
    assert [o["pressure_level"] for o in s["options"]] == ["supply", "supply"]


def test_design_and_robust_design_are_the_documents_of_design_json():
    d = pumpcyl.design()
    doc = cli("design", "--json")
    assert_one_document(d, doc, "Design")
    assert d == doc
    r = pumpcyl.design(robust=True)
    doc = cli("design", "--robust", "--json")
    assert_one_document(r, doc, "RobustDesign")
    assert r.kp_max == pytest.approx(doc["kp_max"], rel=1e-12)


def test_emulate_is_the_document_of_emulate_json(tmp_path):
    for experiment in ("step", "drive-step"):
        e = pumpcyl.emulate(experiment)
        out = tmp_path / f"{experiment}.csv"
        doc = cli("emulate", "--experiment", experiment, "--out", str(out), "--json")
        assert_one_document(e, doc, "Emulated")
        # the record's columns, as the CSV the command line wrote names them, in its order
        header = out.read_text().splitlines()[0].split(",")
        assert sorted(e.columns) == sorted(doc["columns"]) == sorted(header)
        # the same seed, the same record, bit for bit
        for name in header:
            assert isinstance(e.columns[name], np.ndarray)
            np.testing.assert_array_equal(e.columns[name], doc["columns"][name])
        assert e.samples == doc["samples"] == len(e.columns.time_s)
        assert e.basis == doc["basis"] and e.rig == doc["rig"]


@pytest.mark.parametrize("circuit", ["dual-pump", "single-pump"])
def test_emulate_runs_the_single_motor_circuits_and_names_them(tmp_path, circuit):
    """docs/emulator.md#every-circuit: one motor's column, the single-pump circuit's mode, the
    circuit named, and the same record as `pumpcyl emulate --set circuit=...`."""
    e = pumpcyl.emulate("step", circuit=circuit)
    out = tmp_path / f"{circuit}.csv"
    doc = cli("emulate", "--experiment", "step", "--set", f"circuit={circuit}", "--out",
              str(out), "--json")
    assert_one_document(e, doc, "Emulated")
    assert e.circuit == doc["circuit"] == circuit
    assert "w2_rpm" not in e.columns and "w1_rpm" in e.columns
    assert ("mode" in e.columns) == (circuit == "single-pump")
    for name in out.read_text().splitlines()[0].split(","):
        np.testing.assert_array_equal(e.columns[name], doc["columns"][name])
    assert "accumulator pre-charge" in e.basis


def test_emulate_takes_rig_keys_and_refuses_an_unknown_experiment():
    e = pumpcyl.emulate("step", to_mm=355.0, duration_s=6.0, noise=False, mass_kg=8000.0)
    # the step to 355 mm at 0.5 s, without noise, sampled at the PLC's 100 Hz; the piston
    # follows to within its ringing (the lighter mass damps less)
    assert e.samples == 601 and e.columns.x_ref_mm[-1] == 355.0
    assert abs(np.mean(e.columns.x_mm[-100:]) - 355.0) < 1.0
    assert "mass 8000 kg" in e.basis, e.basis
    with pytest.raises(pumpcyl.PumpcylError, match="emulate\\(experiment='ramp'\\)"):
        pumpcyl.emulate("ramp")
    with pytest.raises(pumpcyl.PumpcylError, match="unknown key"):
        pumpcyl.emulate("step", mass=1.0)


def test_a_result_reads_as_a_mapping_and_shows_its_kind():
    m = pumpcyl.margins(pumpcyl.Rig())
    assert "gain_margin_db" in m and "nothing" not in m
    assert len(m) == len(m.keys()) == len(list(m))
    assert dict(m.items()) == {k: m[k] for k in m}
    assert m.get("nothing", 1.5) == 1.5
    with pytest.raises(KeyError):
        m["nothing"]
    with pytest.raises(AttributeError):
        m.nothing
    assert repr(m).startswith("Margins(") and "gain_margin_db=" in repr(m)
    assert repr(pumpcyl.step(pumpcyl.Rig())).startswith("Step(")


def test_select_and_design_report_progress_as_identify_does():
    for call in (lambda p: pumpcyl.select(progress=p),
                 lambda p: pumpcyl.design(mass_kg=[8000.0, 10593.0], progress=p)):
        seen = []
        call(lambda done, total: seen.append((done, total)))
        total = seen[-1][1]
        assert total > 0 and seen[-1] == (total, total)
        assert all(a[0] <= b[0] for a, b in zip(seen, seen[1:]))


# the small single-pump rig of tests/chatter.rs (50/28 mm, 600 kg, 2 bar pre-charge), as rig
# keys: Python's Rig(**keys) and the command line's --set on the same default rig
SMALL_SINGLE_PUMP = {
    "circuit": "single-pump",
    "piston_diameter_mm": 50.0,
    "rod_diameter_mm": 28.0,
    "stroke_mm": 300.0,
    "x0_mm": 150.0,
    "mass_kg": 600.0,
    "mass_by_position": [],
    "displacement_1_cm3_per_rev": 2.5,
    "accumulator_precharge_bar": 2.0,
    "beta_bar": 120.0,
    "viscous_friction_ns_per_m": 300.0,
    "c12_m5_per_ns": 5.0e-11,
    "c1_m5_per_ns": 2.0e-11,
    "c2_m5_per_ns": 2.0e-11,
    "line_volume_1_dm3": 0.05,
    "line_volume_2_dm3": 0.05,
}


def small_single_pump_sets():
    def toml(v):
        return f'"{v}"' if isinstance(v, str) else json.dumps(v)
    return [f"--set={k}={toml(v)}" for k, v in SMALL_SINGLE_PUMP.items()]


def test_chatter_is_the_document_of_chatter_json():
    """The scan at two forces, below the switching force and at it, with a 0.2 Hz ±35 mm wave:
    the command line's document, number for number; the wave chatters at the switching force
    (more switches in its watched periods than the 4 its reference explains)."""
    rig = pumpcyl.Rig(**SMALL_SINGLE_PUMP)
    f_s = 2.0e5 * np.pi / 4 * 0.028**2
    forces = [-200.0, f_s]
    c = pumpcyl.chatter(rig, forces_n=np.array(forces), waves=[(0.2, 35.0)])
    args = [a for f in forces for a in ("--force-n", repr(f))]
    doc = cli("chatter", *small_single_pump_sets(), *args, "--wave", "0.2:35", "--json")
    assert_one_document(c, doc, "Chatter")
    plain = c.to_dict()
    # the rig as each front end names it: its repr in Python, its options on the command line
    assert plain.pop("rig").startswith("Rig(") and doc.pop("rig").startswith("default rig, ")
    assert plain == doc
    assert c.switching_force_n == pytest.approx(f_s, rel=1e-12)
    assert c.verdict == "chatters" and c.chattering_ranges_n == [[f_s, f_s]]
    below, at = c.forces
    assert below["verdict"] == "quiet" and below["switches"] == 0
    assert at["waves"][0]["switches_explained"] == 4
    assert at["extra_switches"] == at["waves"][0]["switches_after_settling"] - 4 > 0
    # a range, as --from-n --to-n --points
    r = pumpcyl.chatter(rig, from_n=-200.0, to_n=-100.0, points=2)
    assert [f["external_force_n"] for f in r.forces] == [-200.0, -100.0]
    assert r.verdict == "quiet" and r.quiet_ranges_n == [[-200.0, -100.0]]


def test_chatter_answers_a_circuit_without_modes_and_refuses_bad_arguments():
    c = pumpcyl.chatter(pumpcyl.Rig())
    doc = cli("chatter", "--json")
    assert_one_document(c, doc, "Chatter")
    assert c.verdict == doc["verdict"] == "no_modes" and c.forces == []
    assert c.answer == doc["answer"] and "no modes to switch between" in c.answer
    rig = pumpcyl.Rig(**SMALL_SINGLE_PUMP)
    with pytest.raises(pumpcyl.PumpcylError, match=r"^chatter\(forces_n=2000000000\): as an external_force_n, "):
        pumpcyl.chatter(rig, forces_n=[2e9])
    with pytest.raises(pumpcyl.PumpcylError, match=r"^chatter\(waves=.*outside the stroke"):
        pumpcyl.chatter(rig, forces_n=[0.0], waves=[(0.2, 200.0)])
    with pytest.raises(pumpcyl.PumpcylError, match="give both ends of the range"):
        pumpcyl.chatter(rig, from_n=0.0)
    with pytest.raises(pumpcyl.PumpcylError, match=r"allow_long_run=True"):
        pumpcyl.chatter(rig, from_n=0.0, to_n=200.0, points=20000)


def test_emulate_with_energy_is_the_command_lines_energy(tmp_path):
    """`emulate(energy=True)` is `emulate --energy --json` (docs/energy.md#over-a-run): the same
    `energy` object on the user rig (the same request), closing to rounding."""
    user = ROOT / "tests" / "user-rig.toml"
    doc = cli("emulate", "--experiment", "step", "--rig", str(user), "--energy", "--out",
              str(tmp_path / "e.csv"), "--json")
    with pytest.warns(UserWarning, match="does not set"):
        rig = pumpcyl.Rig.from_toml(user)
    e = pumpcyl.emulate("step", rig=rig, energy=True)
    assert e.energy == doc["energy"]
    en = e.energy
    delivered = en["energy_in_j"]
    closing = delivered - en["work_out_j"] - sum(en["losses_j"].values()) - sum(en["stored_j"].values())
    assert delivered > 0 and abs(closing) <= 1e-9 * delivered
    assert "energy" not in pumpcyl.emulate("step", rig=rig)


def test_the_power_columns_recompute_the_cycle_energy():
    """The power columns of `emulate(energy=True)` (docs/formats.md#power-columns), each the mean
    power from its sample to the next, times the sample period and summed with numpy, give every
    entry of the energy account to 1e-9 of the energy delivered, on a rig that is not the
    article's in motion (a dual-pump sine)."""
    user = ROOT / "tests" / "user-rig.toml"
    with pytest.warns(UserWarning, match="does not set"):
        rig = pumpcyl.Rig.from_toml(user)
    e = pumpcyl.emulate("sine", rig=rig, energy=True, duration_s=3.0, circuit="dual-pump")
    c, en = e.columns, e.energy
    period_s = float(np.diff(c["time_s"]).mean())
    joules = {name[:-2]: float(np.sum(np.asarray(v)) * period_s)
              for name, v in c.items() if name.endswith("_w")}
    expected = {"work_out": en["work_out_j"]}
    for role, key in [("source", "sources_j"), ("loss", "losses_j"), ("stored", "stored_j")]:
        expected.update({f"{role}_{k}": j for k, j in en[key].items()})
    assert joules.keys() == expected.keys()
    tol = 1e-9 * en["energy_in_j"]
    for name, j in expected.items():
        assert abs(joules[name] - j) <= tol, (name, joules[name], j)
    cycle = sum(j for name, j in joules.items() if name.startswith("source_"))
    assert abs(cycle - en["energy_in_j"]) <= tol
    assert "source_electrical_w" not in pumpcyl.emulate("step", rig=rig).columns


def test_cycle_is_the_command_lines_cycle(tmp_path):
    """`cycle` is `pumpcyl cycle --json` (docs/energy.md#duty-cycles): the same document on the
    default emulated rig for the article's step cycle and on a profile's file with a force
    column; the power columns are numpy arrays that recompute the cycle's net energy."""
    profile = tmp_path / "profile.csv"
    profile.write_text("time_s,x_ref_mm,external_force_n\n0,345,0\n1,345,300\n3,365,300\n4,365,0\n")
    for cycle, args in [("steps", ["--hold-s", "1", "--step-mm", "5"]), (str(profile), [])]:
        doc = cli("cycle", "--cycle", cycle, *args, "--no-noise", "--json")
        c = pumpcyl.cycle(None, cycle, hold_s=1.0, step_mm=5.0, noise=False)
        assert_one_document(c, doc, "DutyCycle")
        plain = c.to_dict()
        assert plain == doc
        assert isinstance(c.columns["source_electrical_w"], np.ndarray)
        period_s = float(np.diff(c.columns["time_s"]).mean())
        net = sum(float(np.sum(v)) for k, v in c.columns.items() if k.startswith("source_")) * period_s
        assert abs(net - c.summary["net_j"]) <= 1e-9 * c.summary["drawn_j"]
    assert c.summary["work_out_j"] > 0, "the profile's force does work"
    with pytest.raises(pumpcyl.PumpcylError, match=r"cycle\(step_mm=5000.0\)"):
        pumpcyl.cycle(None, "steps", step_mm=5000.0)


def test_select_with_energy_is_the_command_lines(tmp_path):
    """`select(energy=True)` carries `select --energy --json`'s `energy` object
    (docs/select.md#energy): each circuit's duty cycle on the user rig, the cheapest, the
    savings against the valve."""
    app = tmp_path / "app.toml"
    app.write_text(f'rig = "{ROOT / "tests" / "user-rig.toml"}"\nsupply_bar = [70.0, 140.0]\n'
                   "[[wave]]\nfreq_hz = 0.1\namp_mm = 20.0\nmax_error_mm = 30.0\n")
    doc = cli("select", str(app), "--circuits", "dpm,valve", "--energy", "--json")
    s = pumpcyl.select(app, circuits=["dpm", "valve"], energy=True)
    assert s.energy == doc["energy"]
    assert [c["circuit_kind"] for c in s.energy["circuits"]] == ["dpm", "valve"]
    assert s.energy["chosen_saves_vs_valve_j"] > 0
    assert "energy" not in pumpcyl.select(app, circuits=["dpm", "valve"])
