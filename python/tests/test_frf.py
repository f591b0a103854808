"""pumpcyl.frf against scipy.signal's csd/welch on the same record, and
pumpcyl.identify(..., method="frequency"), from an experiment file or from datasets (a sweep
with a step: the combined fit), against the command line's document
(docs/identification.md#grey-box-fit-to-a-frequency-response)."""

import json
import subprocess

import numpy as np
import pytest

import pumpcyl
from conftest import ARTICLE, pumpcyl_binary

signal = pytest.importorskip("scipy.signal")


def write_record(path, t, r, x):
    """A record CSV with every digit (repr), so both sides read the same numbers."""
    with open(path, "w") as f:
        f.write("time_s,x_ref_mm,x_mm\n")
        for row in zip(t, r, x):
            f.write(",".join(repr(float(v)) for v in row) + "\n")


def test_frf_of_a_chirp_equals_scipy_csd_and_welch(tmp_path):
    # one logarithmic chirp (not periodic in the record: Welch's estimate) through the linear
    # loop of the article's rig, with noise on the position
    rig = pumpcyl.Rig()
    rate_hz, sweep_s, f0, f1 = 100.0, 300.0, 0.05, 3.0
    t = np.arange(int(sweep_s * rate_hz) + 1) / rate_hz
    k = np.log(f1 / f0) / sweep_s
    r = rig.x0_mm + 5.0 * np.sin(2 * np.pi * f0 * (np.exp(k * t) - 1.0) / k)
    x = pumpcyl.simulate(rig, t, r).signals.x_mm
    x = x + 0.05 * (np.random.default_rng(7).random(len(x)) - 0.5)
    path = tmp_path / "chirp.csv"
    write_record(path, t, r, x)
    with pytest.warns(UserWarning, match="coherence below the usable"):
        res = pumpcyl.frf(path, rig=rig).to_dict()
    assert res["method"] == "welch-hann"
    # no periods to leave out of a broadband record (docs/identification.md, transient periods)
    assert res["periods_discarded"] == 0
    n = res["segment_samples"]
    kw = dict(fs=rate_hz, window="hann", nperseg=n, noverlap=n // 2, detrend="constant")
    f, prx = signal.csd(r, x, **kw)
    _, prr = signal.welch(r, **kw)
    _, pxx = signal.welch(x, **kw)
    h = prx / prr
    coherence = np.abs(prx) ** 2 / (prr * pxx)
    points = res["closed_loop"]["points"]
    assert len(points) > 50 and any(p["coherence"] < 0.99 for p in points)
    for p in points:
        b = int(round(p["freq_hz"] / (f[1] - f[0])))
        assert abs(f[b] - p["freq_hz"]) < 1e-9 * p["freq_hz"]
        assert abs(complex(p["re"], p["im"]) - h[b]) <= 1e-6 * abs(h[b]), p["freq_hz"]
        assert abs(p["coherence"] - coherence[b]) <= 1e-6, p["freq_hz"]
    assert len(res["model"]["magnitude_db"]) == len(points)


@pytest.fixture(scope="module")
def sweep_experiment(tmp_path_factory):
    """An emulated multisine and standstill of a rig with β 180 bar, b 2500 N·s/m, c12 1.5e-10
    (every effect off, sensor noise on) and the experiment that lists them."""
    d = tmp_path_factory.mktemp("sweep")
    truth = ["--set", "beta_bar=180", "--set", "viscous_friction_ns_per_m=2500",
             "--set", "c12_m5_per_ns=1.5e-10", "--no-effects"]
    exe = pumpcyl_binary()
    for args in (["--experiment", "multisine", "--out", "sweep.csv"],
                 ["--experiment", "step", "--out", "step.csv"],
                 ["--experiment", "standstill", "--duration-s", "2", "--out", "standstill.csv"]):
        subprocess.run([exe, "emulate", *args, *truth], cwd=d, check=True, capture_output=True)
    sweep = '[[dataset]]\nfile = "sweep.csv"\nkp = 25.0\nmass_kg = 10593.0\n'
    step = ('[[dataset]]\nfile = "step.csv"\nkp = 25.0\nmass_kg = 10593.0\nfit_end_s = 4.0\n'
            'kind = "step"\n')
    head = '[standstill]\nrecord = "standstill.csv"\n\n'
    (d / "exp.toml").write_text(head + sweep)
    (d / "both.toml").write_text('method = "frequency"\n' + head + sweep + "\n" + step)
    return d


def read_csv(path):
    """A record's columns by name."""
    data = np.genfromtxt(path, delimiter=",", names=True)
    return {name: data[name] for name in data.dtype.names}


def sequential_mean(values):
    """The mean summed in the library's order, so both sides agree to the last bit."""
    total = 0.0
    for v in values:
        total += float(v)
    return total / len(values)


def test_identify_from_datasets_in_the_frequency_domain_gives_the_files_document(
        sweep_experiment):
    # the experiment file's sweep and step records given as arrays with the same keys: the
    # sweep told apart by its reference, the step by kind and fit_end_s (the combined fit)
    d = sweep_experiment
    still = read_csv(d / "standstill.csv")
    standstill = {k: sequential_mean(still[k]) for k in ("w1_rpm", "w2_rpm", "p1_bar")}
    sweep, step = read_csv(d / "sweep.csv"), read_csv(d / "step.csv")
    datasets = [
        pumpcyl.Dataset(sweep["time_s"], sweep["x_ref_mm"], sweep["x_mm"], kp=25.0,
                        mass_kg=10593.0, name="sweep.csv"),
        pumpcyl.Dataset(step["time_s"], step["x_ref_mm"], step["x_mm"], kp=25.0,
                        mass_kg=10593.0, fit_end_s=4.0, kind="step", name="step.csv"),
    ]
    with pytest.warns(UserWarning, match="on the edge of the grid"):
        res = pumpcyl.identify(datasets=datasets, standstill=standstill,
                               method="frequency").to_dict()
    out = subprocess.run([pumpcyl_binary(), "identify", "both.toml", "--uncertainty", "--json"],
                         cwd=d, check=True, capture_output=True, text=True).stdout
    cli = json.loads(out)
    assert set(res) == set(cli)
    assert res["step_datasets"] == cli["step_datasets"] == ["step.csv"]
    assert res["step_noise_var_mm2"] == pytest.approx(cli["step_noise_var_mm2"], rel=1e-9)
    for key in ("beta_bar", "viscous_friction_ns_per_m", "c12_m5_per_ns"):
        assert res[key] == pytest.approx(cli[key], rel=1e-9)
        assert res["intervals"][key] == pytest.approx(cli["intervals"][key], rel=1e-9)
        assert res["identifiable"][key] is True
    # a sweep given as a step record, and a step alone, are refused naming the dataset
    with pytest.raises(pumpcyl.PumpcylError, match='Dataset "sweep.csv".*fit_end_s'):
        pumpcyl.identify(datasets=datasets[:1], standstill=standstill)
    with pytest.raises(pumpcyl.PumpcylError, match="at least one sweep record"):
        pumpcyl.identify(datasets=datasets[1:], standstill=standstill, method="frequency")
    # a described sweep takes the [dataset.sweep] keys, and no other
    with pytest.raises(pumpcyl.PumpcylError, match="unknown field `bogus`"):
        pumpcyl.Dataset(sweep["time_s"], sweep["x_ref_mm"], sweep["x_mm"], kp=25.0,
                        mass_kg=10593.0, sweep=dict(kind="multisine", bogus=1.0))
    described = pumpcyl.Dataset(sweep["time_s"], sweep["x_ref_mm"], sweep["x_mm"], kp=25.0,
                                mass_kg=10593.0, sweep=dict(kind="multisine", at_s=2.0))
    with pytest.raises(pumpcyl.PumpcylError, match="is not the multisine described"):
        pumpcyl.identify(datasets=[described], standstill=standstill, method="frequency")


def test_identify_in_the_frequency_domain_gives_the_command_lines_document(sweep_experiment):
    d = sweep_experiment
    with pytest.warns(UserWarning, match="on the edge of the grid"):
        res = pumpcyl.identify(d / "exp.toml", method="frequency").to_dict()
    out = subprocess.run([pumpcyl_binary(), "identify", "exp.toml", "--frequency",
                          "--uncertainty", "--json"], cwd=d, check=True, capture_output=True,
                         text=True).stdout
    cli = json.loads(out)
    assert set(res) == set(cli)
    for key in ("beta_bar", "viscous_friction_ns_per_m", "c12_m5_per_ns"):
        assert res[key] == pytest.approx(cli[key], rel=1e-9)
        assert res["intervals"][key] == pytest.approx(cli["intervals"][key], rel=1e-9)
        assert res["identifiable"][key] is True
    assert res["beta_bar"] == pytest.approx(180.0, rel=0.03)
    assert res["c12_m5_per_ns"] == pytest.approx(1.5e-10, rel=0.03)
    assert res["viscous_friction_ns_per_m"] == pytest.approx(2500.0, rel=0.2)


def test_a_method_not_named_and_a_frequency_fit_without_records_are_refused(
        sweep_experiment):
    with pytest.raises(pumpcyl.PumpcylError, match='method="freq": give "time" or "frequency"'):
        pumpcyl.identify(sweep_experiment / "exp.toml", method="freq")
    with pytest.raises(pumpcyl.PumpcylError, match="at least one Dataset"):
        pumpcyl.identify(datasets=[], standstill=dict(w1_rpm=0, w2_rpm=0, p1_bar=4),
                         method="frequency")


def test_advise_weighs_sweep_candidates_at_a_budget_as_the_command_line(tmp_path):
    # a [[sweep]] candidate beside a step, each counted as often as it fits in 120 s
    cands = tmp_path / "c.toml"
    cands.write_text('[[sweep]]\nkind = "multisine"\nkp = 25.0\namplitude_mm = 8.0\n'
                     'from_hz = 0.4\nto_hz = 1.5\nperiods = 6\n\n'
                     '[[step]]\nstep_mm = 5.0\nkp = 25.0\n')
    exp = ARTICLE / "identify.toml"
    res = pumpcyl.advise(exp, candidates=cands, budget_s=120.0).to_dict()
    out = subprocess.run([pumpcyl_binary(), "advise", str(exp), "--candidates", str(cands),
                          "--budget-s", "120", "--json"], check=True, capture_output=True,
                         text=True).stdout
    cli = json.loads(out)
    assert res["budget_s"] == cli["budget_s"] == 120.0
    assert [c["label"] for c in res["candidates"]] == [c["label"] for c in cli["candidates"]]
    by_label = {c["label"]: c for c in res["candidates"]}
    assert by_label.keys() == {c["label"] for c in cli["candidates"]}
    for c in cli["candidates"]:
        mine = by_label[c["label"]]
        assert mine["repeats"] == pytest.approx(120.0 / c["duration_s"], rel=1e-12)
        assert mine["score"] == pytest.approx(c["score"], rel=1e-9)
    with pytest.raises(pumpcyl.PumpcylError, match="budget_s = 0"):
        pumpcyl.advise(exp, candidates=cands, budget_s=0.0)
