"""The FMUs of pumpcyl.fmu / `pumpcyl fmu` (docs/fmu.md) run by FMPy, the reference FMI tool in
Python, against `pumpcyl emulate` and `pumpcyl step`. The emulator's records are emulated data,
not measurements."""

import csv
import os
import subprocess

import numpy as np
import pytest

import pumpcyl
from conftest import ROOT, pumpcyl_binary


def require_fmpy():
    """FMPy, or a visible skip (a failure when CI is set)."""
    try:
        import fmpy  # noqa: F401
    except ImportError:
        if os.environ.get("CI"):
            raise
        from conftest import skip_missing

        skip_missing("FMPy", "pip install fmpy")  # counted in the last line of ./test.sh
    import fmpy

    return fmpy


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def cli(*args):
    subprocess.run([pumpcyl_binary(), *args], check=True, capture_output=True, text=True)


def run_fmu(fmpy, path, time_s, x_ref_m, **kw):
    """Simulate with FMPy at the record's sample period, the reference given at every sample."""
    signal = np.array(list(zip(time_s, x_ref_m)), dtype=[("time", np.float64), ("x_ref_m", np.float64)])
    h = time_s[1] - time_s[0]
    return fmpy.simulate_fmu(str(path), start_time=0.0, stop_time=time_s[-1], step_size=h,
                             output_interval=h, input=signal, **kw)


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    d = tmp_path_factory.mktemp("fmu")
    emulator = pumpcyl.fmu(None, d / "emulator.fmu")
    linear = pumpcyl.fmu(None, d / "linear.fmu", "linear")
    return d, emulator, linear


def test_both_kinds_validate(fmus):
    fmpy = require_fmpy()
    from fmpy.validation import validate_fmu

    _, emulator, linear = fmus
    assert validate_fmu(str(emulator)) == []
    assert validate_fmu(str(linear)) == []
    md = fmpy.read_model_description(str(emulator))
    units = {u.name for u in md.unitDefinitions}
    names = {v.name: v for v in md.modelVariables}
    for out in ["x_m", "v_m_per_s", "p1_pa", "p2_pa", "p_sum_pa", "omega1_rad_per_s",
                "omega2_rad_per_s", "tau1_nm", "tau2_nm"]:
        assert names[out].causality == "output", out
    assert names["beta_bar"].causality == "parameter" and names["beta_bar"].unit == "bar"
    assert {"m", "Pa", "bar", "rad/s", "N.m"} <= units


@pytest.mark.parametrize("experiment,args", [
    ("step", ["--experiment", "step"]),
    ("sine", ["--experiment", "sine", "--freq-hz", "0.2", "--amplitude-mm", "35"]),
])
def test_the_emulator_fmu_gives_the_records_of_emulate(fmus, experiment, args):
    fmpy = require_fmpy()
    d, emulator, _ = fmus
    record = d / f"{experiment}.csv"
    cli("emulate", *args, "--no-noise", "--out", str(record))
    rec = read_csv(record)
    r = run_fmu(fmpy, emulator, rec["time_s"], rec["x_ref_mm"] * 1e-3)
    assert len(r) == len(rec["time_s"])
    # the record is written to 1e-6 mm and 1e-6 bar
    assert np.max(np.abs(r["x_m"] - rec["x_mm"] * 1e-3)) < 1e-9
    assert np.max(np.abs(r["p1_pa"] - rec["p1_bar"] * 1e5)) < 1.0
    assert np.max(np.abs(r["p2_pa"] - rec["p2_bar"] * 1e5)) < 1.0


def test_the_energy_outputs_in_fmpy_are_emulates_account(tmp_path):
    """An emulator FMU with its energy outputs (docs/fmu.md#energy), run by FMPy through the
    user rig's step: at the end its four outputs are `emulate --energy --json`'s account of the
    same record (sources net, work out, losses, stored change) to 1e-9 of the energy delivered,
    and they close at every output sample."""
    fmpy = require_fmpy()
    from fmpy.validation import validate_fmu

    user = str(ROOT / "tests" / "user-rig.toml")
    fmu, record = tmp_path / "energy.fmu", tmp_path / "step.csv"
    cli("fmu", "--rig", user, "--energy", "--out", str(fmu))
    assert validate_fmu(str(fmu)) == []
    names = {v.name: v for v in fmpy.read_model_description(str(fmu)).modelVariables}
    assert all(names[n].causality == "output" and names[n].unit == "J"
               for n in ["energy_in_j", "work_out_j", "losses_j", "stored_change_j"])
    out = subprocess.run([pumpcyl_binary(), "emulate", "--experiment", "step", "--rig", user,
                          "--no-noise", "--energy", "--json", "--out", str(record)],
                         check=True, capture_output=True, text=True)
    e = __import__("json").loads(out.stdout)["energy"]
    rec = read_csv(record)
    r = run_fmu(fmpy, fmu, rec["time_s"], rec["x_ref_mm"] * 1e-3)
    tol = 1e-9 * e["energy_in_j"]
    assert abs(r["energy_in_j"][-1] - e["energy_in_j"]) <= tol
    assert abs(r["work_out_j"][-1] - e["work_out_j"]) <= tol
    assert abs(r["losses_j"][-1] - sum(e["losses_j"].values())) <= tol
    assert abs(r["stored_change_j"][-1] - e["stored_change_j"]) <= tol
    closing = r["energy_in_j"] - r["work_out_j"] - r["losses_j"] - r["stored_change_j"]
    assert np.max(np.abs(closing)) <= tol
    with pytest.raises(pumpcyl.PumpcylError, match="energy"):
        pumpcyl.fmu(None, tmp_path / "linear.fmu", "linear", energy=True)


@pytest.mark.parametrize("circuit", ["dual-pump", "single-pump"])
def test_the_single_motor_emulator_fmu_gives_the_records_of_emulate(tmp_path, circuit):
    """One motor's variables (no omega2, tau2), the single-pump circuit's mode as an output
    (docs/emulator.md#the-mode-signal), and `pumpcyl emulate`'s record through FMPy."""
    fmpy = require_fmpy()
    from fmpy.validation import validate_fmu

    fmu, record = tmp_path / f"{circuit}.fmu", tmp_path / f"{circuit}.csv"
    cli("fmu", "--set", f"circuit={circuit}", "--out", str(fmu))
    assert validate_fmu(str(fmu)) == []
    names = {v.name: v for v in fmpy.read_model_description(str(fmu)).modelVariables}
    assert "omega2_rad_per_s" not in names and "tau2_nm" not in names
    assert ("mode" in names) == (circuit == "single-pump")
    cli("emulate", "--experiment", "step", "--set", f"circuit={circuit}", "--no-noise",
        "--out", str(record))
    rec = read_csv(record)
    assert "w2_rpm" not in rec
    r = run_fmu(fmpy, fmu, rec["time_s"], rec["x_ref_mm"] * 1e-3)
    assert np.max(np.abs(r["x_m"] - rec["x_mm"] * 1e-3)) < 1e-9
    assert np.max(np.abs(r["p1_pa"] - rec["p1_bar"] * 1e5)) < 1.0
    assert np.max(np.abs(r["omega1_rad_per_s"] * 60 / (2 * np.pi) - rec["w1_rpm"])) < 1e-5
    if circuit == "single-pump":
        assert np.array_equal(r["mode"], rec["mode"])


def test_the_valve_emulator_fmu_gives_the_records_of_emulate(tmp_path):
    """A valve-controlled cylinder's FMU names its spool, not motors: the spool's opening as
    an output, its command as the external controller's input, none of the drives' keys as
    parameters; and it gives `pumpcyl emulate`'s record through FMPy."""
    fmpy = require_fmpy()
    from fmpy.validation import validate_fmu

    sets = ["--set", "circuit=valve", "--set", "beta_bar=5000", "--set", "kp=0.5"]
    fmu, record = tmp_path / "valve.fmu", tmp_path / "valve.csv"
    cli("fmu", *sets, "--out", str(fmu))
    assert validate_fmu(str(fmu)) == []
    names = {v.name: v for v in fmpy.read_model_description(str(fmu)).modelVariables}
    assert "spool_opening" in names and "spool_opening_ref" in names
    assert not [n for n in names if n.startswith(("omega", "tau", "km1", "displacement"))]
    external = tmp_path / "external.fmu"
    cli("fmu", *sets, "--controller", "external", "--out", str(external))
    inputs = [v.name for v in fmpy.read_model_description(str(external)).modelVariables
              if v.causality == "input"]
    assert inputs == ["spool_opening_ref", "f_ext_n"]
    cli("emulate", "--experiment", "step", *sets, "--no-noise", "--out", str(record))
    rec = read_csv(record)
    r = run_fmu(fmpy, fmu, rec["time_s"], rec["x_ref_mm"] * 1e-3)
    assert np.max(np.abs(r["x_m"] - rec["x_mm"] * 1e-3)) < 1e-9
    assert np.max(np.abs(r["p1_pa"] - rec["p1_bar"] * 1e5)) < 1.0
    # the spool moves with the step, within its stops
    assert 0 < np.max(np.abs(r["spool_opening"])) <= 1


USER_RIG = (ROOT / "tests" / "user-rig.toml").read_text()


def test_the_emulator_fmu_follows_the_beta_bar_a_host_sets_on_a_user_rig(tmp_path):
    """docs/emulator.md#what-a-user-rig-gets: the FMU's emulator anchors its gas fraction at the
    beta_bar parameter the host sets, so its step at 100 and 1000 bar differs, and each equals
    `pumpcyl emulate` on the same rig with that beta_bar."""
    fmpy = require_fmpy()
    rig = tmp_path / "my-rig.toml"
    rig.write_text(USER_RIG)
    fmu = tmp_path / "my.fmu"
    cli("fmu", "--model", "emulator", "--rig", str(rig), "--out", str(fmu))
    peaks = []
    for beta in (100.0, 1000.0):
        record = tmp_path / f"step-{beta:g}.csv"
        cli("emulate", "--rig", str(rig), "--set", f"beta_bar={beta}", "--experiment", "step",
            "--no-noise", "--out", str(record))
        rec = read_csv(record)
        r = run_fmu(fmpy, fmu, rec["time_s"], rec["x_ref_mm"] * 1e-3,
                    start_values={"beta_bar": beta})
        assert np.max(np.abs(r["x_m"] - rec["x_mm"] * 1e-3)) < 1e-9, beta
        assert np.max(np.abs(r["p1_pa"] - rec["p1_bar"] * 1e5)) < 1.0, beta
        peaks.append(np.max(np.abs(np.diff(r["p1_pa"]))))
    # a ten times stiffer oil: the pressure moves differently during the step
    assert abs(peaks[0] - peaks[1]) > 0.05 * max(peaks), peaks


def test_the_emulator_fmu_runs_at_the_external_force_a_host_sets_on_a_user_rig(tmp_path):
    """docs/fmu.md#variables, one force: on the user rig written at 0 N, a host that sets the
    parameter external_force_n to 500 N (and leaves the input f_ext_n at its start value, 0)
    gets `pumpcyl emulate` on the rig at 500 N from the first sample, on the DPM and the single
    pump, not a force step at t = 0 from a rest at 0 N."""
    fmpy = require_fmpy()
    for circuit in ("dpm", "single-pump"):
        rig = tmp_path / f"{circuit}.toml"
        # the single pump has one pump: the second displacement is not one of its keys
        keys = [k for k in USER_RIG.splitlines()
                if circuit == "dpm" or not k.startswith("displacement_2")]
        rig.write_text("\n".join(keys) + f'\ncircuit = "{circuit}"\n')
        fmu = tmp_path / f"{circuit}.fmu"
        cli("fmu", "--model", "emulator", "--rig", str(rig), "--out", str(fmu))
        md = fmpy.read_model_description(str(fmu))
        force = next(v for v in md.modelVariables if v.name == "f_ext_n")
        assert float(force.start) == 0.0
        records = {}
        for f in (0.0, 500.0):
            records[f] = tmp_path / f"{circuit}-{f:g}.csv"
            cli("emulate", "--rig", str(rig), "--set", f"external_force_n={f}", "--experiment",
                "step", "--no-noise", "--out", str(records[f]))
        rec, unloaded = read_csv(records[500.0]), read_csv(records[0.0])
        # the two loads rest apart: a run at the wrong force cannot pass
        assert np.max(np.abs(rec["x_mm"] - unloaded["x_mm"])) > 1e-3, circuit
        r = run_fmu(fmpy, fmu, rec["time_s"], rec["x_ref_mm"] * 1e-3,
                    start_values={"external_force_n": 500.0})
        assert np.max(np.abs(r["x_m"] - rec["x_mm"] * 1e-3)) < 1e-9, circuit
        assert np.max(np.abs(r["p1_pa"] - rec["p1_bar"] * 1e5)) < 1.0, circuit
        assert np.max(np.abs(r["p2_pa"] - rec["p2_bar"] * 1e5)) < 1.0, circuit


def test_the_linear_fmu_gives_the_step_response(fmus):
    fmpy = require_fmpy()
    d, _, linear = fmus
    record = d / "linear-step.csv"
    cli("step", "--out", str(record))
    rec = read_csv(record)
    r = run_fmu(fmpy, linear, rec["time_s"], rec["x_ref_mm"] * 1e-3)
    # the record's reference, x0 plus the rest offset and the step, is written to 1e-6 mm:
    # the FMU follows the rounded reference (docs/simulation.md#the-rest-under-load)
    assert np.max(np.abs(r["x_m"] - rec["x_mm"] * 1e-3)) < 2e-9
    assert np.max(np.abs(r["p1_pa"] - rec["p1_bar"] * 1e5)) < 1.0
    assert np.max(np.abs(r["omega1_rad_per_s"] - rec["w1_rpm"] * np.pi / 30)) < 1e-4


def test_two_instances_in_one_process_run_as_two_separate_runs(fmus):
    fmpy = require_fmpy()
    from fmpy.fmi2 import FMU2Slave

    d, emulator, _ = fmus
    md = fmpy.read_model_description(str(emulator))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipped = fmpy.extract(str(emulator))
    masses = [10593.0, 4898.0]
    x0 = 0.340
    alone = [run_fmu(fmpy, emulator, np.arange(0, 1.001, 0.01), np.where(np.arange(0, 1.001, 0.01) < 0.2, x0, x0 + 0.005),
                     start_values={"mass_kg": m})["x_m"] for m in masses]
    slaves = []
    for k, m in enumerate(masses):
        s = FMU2Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName=f"rig{k}")
        s.instantiate()
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.setReal([vr["mass_kg"], vr["x_ref_m"]], [m, x0])
        s.exitInitializationMode()
        slaves.append(s)
    together = [[s.getReal([vr["x_m"]])[0]] for s in slaves]
    for n in range(100):
        t = n * 0.01
        for s, out in zip(slaves, together):
            s.setReal([vr["x_ref_m"]], [x0 if t < 0.2 else x0 + 0.005])
            s.doStep(currentCommunicationPoint=t, communicationStepSize=0.01)
            out.append(s.getReal([vr["x_m"]])[0])
    for s in slaves:
        s.terminate()
        s.freeInstance()
    for a, b in zip(alone, together):
        np.testing.assert_allclose(np.array(b), a, rtol=0, atol=1e-12)
    assert np.max(np.abs(np.array(together[0]) - np.array(together[1]))) > 1e-5


def test_a_nan_parameter_is_an_error_with_a_logged_message(fmus):
    fmpy = require_fmpy()
    _, emulator, _ = fmus
    messages = []

    def logger(component, instance, status, category, message):
        messages.append(message.decode() if isinstance(message, bytes) else str(message))

    with pytest.raises(Exception):
        fmpy.simulate_fmu(str(emulator), stop_time=0.1, step_size=0.01,
                          start_values={"mass_kg": float("nan")}, logger=logger)
    assert any("mass_kg" in m and "finite" in m for m in messages), messages


def test_python_and_the_command_line_write_the_same_fmu(fmus, tmp_path):
    d, emulator, _ = fmus
    cli("fmu", "--out", str(tmp_path / "cli.fmu"))
    import zipfile

    with zipfile.ZipFile(emulator) as a, zipfile.ZipFile(tmp_path / "cli.fmu") as b:
        assert a.read("modelDescription.xml") == b.read("modelDescription.xml")


def test_bad_arguments_are_refused(tmp_path):
    with pytest.raises(pumpcyl.PumpcylError, match="model"):
        pumpcyl.fmu(None, tmp_path / "x.fmu", "quantum")
    with pytest.raises(pumpcyl.PumpcylError, match=r"\.fmu"):
        pumpcyl.fmu(None, tmp_path / "x.zip")
    with pytest.raises(pumpcyl.PumpcylError, match="mass_kg"):
        pumpcyl.fmu(pumpcyl.Rig(mass_kg=1e-30), tmp_path / "x.fmu")
    assert not (tmp_path / "x.fmu").exists()
