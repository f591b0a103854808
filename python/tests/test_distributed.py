"""pumpcyl.distributed on a real dask.distributed LocalCluster of two worker processes
(docs/beyond-one-machine.md): the sharded identification equals the one-process one, also
when a worker is killed in the middle of it; a sweep over 200 rigs equals a loop over them; a
fleet with a corrupt experiment gives that experiment's error in its row and every other row."""

import os
import pathlib
import shutil
import signal
import sys
import threading
import time

import pytest

import pumpcyl
import json
import subprocess

from conftest import ARTICLE, ROOT, pumpcyl_binary, skip_missing

sys.path.insert(0, str(ROOT / "python" / "bench"))
from dask_grid import scaled_article_experiment  # noqa: E402

try:
    import pandas  # noqa: F401
    from distributed import Client, LocalCluster

    import pumpcyl.distributed as pd_
except ImportError:
    if os.environ.get("CI"):
        raise
    skip_missing("dask, distributed and pandas", "pip install dask distributed pandas")

# How the rejected candidates split into pruned and unstable depends on the order in which the
# threads meet them (two one-process runs differ too), and the time is a time: every other
# field of the answer must be equal.
VARYING = {"seconds", "pruned", "unstable"}


def comparable(result):
    return {k: v for k, v in result.to_dict().items() if k not in VARYING}


@pytest.fixture(scope="module")
def client():
    cluster = LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
    )
    with cluster, Client(cluster) as c:
        yield c


def test_a_sharded_identification_equals_the_one_process_one(client):
    experiment = os.path.realpath(ARTICLE / "identify.toml")
    whole = pumpcyl.identify(experiment)
    merged = pd_.identify(experiment, client=client, shards=5)
    assert comparable(merged) == comparable(whole)
    assert merged.candidates_evaluated == 3264 + 3553
    # the article's answer, not only the same one (the article §2.4: about 166 bar)
    assert 160.0 < merged.beta_bar < 172.0


def test_a_relative_path_and_the_default_shards_give_the_same_answer(client, monkeypatch):
    monkeypatch.chdir(ARTICLE)
    merged = pd_.identify("identify.toml", client=client)
    whole = pumpcyl.identify(os.path.realpath(ARTICLE / "identify.toml"))
    assert merged.experiment == os.path.realpath(ARTICLE / "identify.toml")
    assert comparable(merged) == comparable(whole)


def test_shards_no_shard_could_run_are_refused_before_any_runs(client, tmp_path):
    with pytest.raises(pumpcyl.PumpcylError, match=r"shard 1/2000: need 1 <= I <= N <= 1000"):
        pd_.identify(ARTICLE / "identify.toml", client=client, shards=2000)
    # a second grid centred on the first stage's best is not fixed in advance
    centred = tmp_path / "identify.toml"
    centred.write_text((ARTICLE / "identify.toml").read_text().replace('grids = "article"', ""))
    for name in ("standstill.csv", "identification.csv", "validation.csv"):
        shutil.copy(ARTICLE / name, tmp_path / name)
    with pytest.raises(pumpcyl.PumpcylError, match="centred on the first stage's best"):
        pd_.identify(centred, client=client, shards=2)
    # nothing reached the workers
    assert client.run(lambda dask_worker: len(dask_worker.state.tasks)) == {
        addr: 0 for addr in client.nthreads()
    }


def test_a_worker_killed_mid_identification_is_retried_and_the_answer_is_unchanged(
    client, tmp_path
):
    # each of the two shards takes seconds, so the kill lands while one runs
    experiment = scaled_article_experiment(tmp_path, 6)
    whole = pumpcyl.identify(experiment)
    pids = client.run(os.getpid)
    out = {}
    runner = threading.Thread(
        target=lambda: out.update(r=pd_.identify(experiment, client=client, shards=2))
    )
    runner.start()
    victim = None
    deadline = time.monotonic() + 60.0
    while victim is None and time.monotonic() < deadline:
        executing = client.run(lambda dask_worker: dask_worker.state.executing_count)
        busy = [addr for addr, n in executing.items() if n > 0]
        if busy:
            victim = busy[0]
        else:
            time.sleep(0.05)
    assert victim is not None, "no shard ever ran"
    time.sleep(0.2)  # into the shard's search
    os.kill(pids[victim], signal.SIGKILL)
    runner.join(timeout=300.0)
    assert not runner.is_alive()
    assert comparable(out["r"]) == comparable(whole)
    client.wait_for_workers(2, timeout=60.0)
    assert pids[victim] not in client.run(os.getpid).values(), "the worker was not replaced"
    retried = [k for k, n in client.run_on_scheduler(_runs_of_shards).items() if n >= 2]
    assert retried, "no shard was run again: the kill came after the shards"


def _runs_of_shards(dask_scheduler):
    """How often the scheduler gave each shard of a 2-shard run to a worker."""
    runs = {}
    for t in dask_scheduler.transition_log:
        key = str(t.key)
        if key.startswith("pumpcyl-shard-") and "-of-2-" in key and t.finish == "processing":
            runs[key] = runs.get(key, 0) + 1
    return runs


def test_a_sweep_of_200_rigs_equals_a_loop_over_them(client):
    beta_bar = [40.0 + 15.0 * k for k in range(20)]
    mass_kg = [2000.0 + 1000.0 * k for k in range(10)]
    df = pd_.sweep({"beta_bar": beta_bar, "mass_kg": mass_kg}, "margins", client=client)
    assert len(df) == 200
    assert df["error"].isna().all()
    for k, (b, m) in enumerate((b, m) for b in beta_bar for m in mass_kg):
        expected = pumpcyl.margins(pumpcyl.Rig(beta_bar=b, mass_kg=m))
        row = df.iloc[k]
        assert (row["beta_bar"], row["mass_kg"]) == (b, m)
        assert row["result"] == expected.to_dict()
        assert row["phase_margin_deg"] == expected.phase_margin_deg
        assert row["closed_loop_stable"] == expected.closed_loop_stable
    # β lower, the margins lower (the article's §3.3): the sweep's columns are the rigs'
    low, high = df[df.beta_bar == 40.0], df[df.beta_bar == 325.0]
    assert (low.phase_margin_deg.to_numpy() < high.phase_margin_deg.to_numpy()).all()


def test_a_sweep_keeps_a_bad_rig_in_its_row_and_takes_rigs_and_designs(client):
    with pytest.warns(UserWarning, match="does not set"):
        user = pumpcyl.Rig.from_toml(ROOT / "tests" / "user-rig.toml")
    given = [{"beta_bar": -1.0}, user, {"mass_kg": 6000.0}]
    df = pd_.sweep(given, "design", client=client, target_pm_deg=40.0)
    assert len(df) == 3
    with pytest.raises(pumpcyl.PumpcylError) as e:
        pumpcyl.Rig(beta_bar=-1.0)
    assert df["error"][0] == str(e.value)
    assert df["result"][1] == pumpcyl.design(user, target_pm_deg=40.0).to_dict()
    assert df["rig"][1] == "rigs[1]"
    assert df["kp_max"][2] == pumpcyl.design(pumpcyl.Rig(mass_kg=6000.0), target_pm_deg=40.0).kp_max
    assert df["error"][1] is None and df["error"][2] is None
    with pytest.raises(pumpcyl.PumpcylError, match="analysis='bode'"):
        pd_.sweep(given, "bode", client=client)


def test_a_sweep_overrides_the_base_rig_it_is_given_and_labels_rigs_shortly(client, tmp_path):
    # the user rig (80/45 mm, 2500 kg, beta 300 bar; none of the article's values) as the base,
    # by path and as a Rig: its overrides are swept, not the article's rig's
    path = ROOT / "tests" / "user-rig.toml"
    with pytest.warns(UserWarning, match="does not set"):
        user = pumpcyl.Rig.from_toml(path)
    axes = {"mass_kg": [2000.0, 3000.0], "kp": [10.0, 15.0]}
    with pytest.warns(UserWarning, match="does not set"):
        by_path = pd_.sweep(axes, "margins", rig=path, client=client)
    by_rig = pd_.sweep(axes, "margins", rig=user, client=client)
    for df in (by_path, by_rig):
        assert len(df) == 4 and df["error"].isna().all()
        for k, (m, kp) in enumerate((m, kp) for m in axes["mass_kg"] for kp in axes["kp"]):
            row = df.iloc[k]
            assert (row["mass_kg"], row["kp"]) == (m, kp)
            expected = pumpcyl.margins(user.replace(mass_kg=m, kp=kp))
            assert row["result"] == expected.to_dict()
            assert row["gain_margin_db"] == expected.gain_margin_db
    # not the article's rig with the same overrides
    article = pumpcyl.margins(pumpcyl.Rig(mass_kg=2000.0, kp=10.0))
    assert by_rig["gain_margin_db"][0] != article.gain_margin_db
    # a list of Rigs: each labelled by its place and the keys in which the Rigs differ, not
    # by its whole repr; the base does not apply to a Rig of the list
    single = user.replace(circuit="single-pump", external_force_n=500.0)
    rigs = [user, user.replace(mass_kg=3000.0), single]
    df = pd_.sweep(rigs, "margins", rig=pumpcyl.Rig(beta_bar=37.8), client=client)
    assert list(df["rig"]) == ["rigs[0]", "rigs[1]", "rigs[2]"]
    assert list(df["mass_kg"]) == [2500.0, 3000.0, 2500.0]
    assert list(df["circuit"]) == ["dpm", "dpm", "single-pump"]
    assert list(df["external_force_n"]) == [0.0, 0.0, 500.0]
    assert "beta_bar" not in df.columns and "piston_diameter_mm" not in df.columns
    expected = pumpcyl.margins(single)
    assert (df["gain_margin_db"][2], df["phase_margin_deg"][2]) == (
        expected.gain_margin_db, expected.phase_margin_deg)
    with pytest.raises(pumpcyl.PumpcylError, match="sweep\\(rig=3\\)"):
        pd_.sweep(axes, rig=3, client=client)


def _small_experiment(folder, csv_source=ARTICLE / "identification.csv"):
    """The article's experiment with a small grid (fast), its identification record from
    `csv_source`."""
    folder = pathlib.Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for name in ("standstill.csv", "validation.csv"):
        shutil.copy(ARTICLE / name, folder / name)
    shutil.copy(csv_source, folder / "identification.csv")
    text = (ARTICLE / "identify.toml").read_text().replace('grids = "article"', "")
    path = folder / "identify.toml"
    path.write_text(
        text
        + "\n[grid]\nbeta_bar = [120.0, 140.0, 160.0, 180.0, 200.0]\n"
        "viscous_friction_ns_per_m = [100.0, 200.0, 400.0]\n"
        "c12_m5_per_ns = [1e-10, 1.3e-10, 1.6e-10]\n"
        "[refined_grid]\nbeta_bar = [150.0, 160.0, 170.0]\n"
        "viscous_friction_ns_per_m = [100.0, 150.0, 200.0]\n"
        "c12_m5_per_ns = [1.2e-10, 1.3e-10]\n"
    )
    return str(path)


def test_a_fleet_with_a_corrupt_record_gives_its_error_row_and_every_other_row(
    client, tmp_path
):
    good_a = _small_experiment(tmp_path / "a")
    good_b = _small_experiment(tmp_path / "b")
    corrupt = tmp_path / "corrupt.csv"
    lines = (ARTICLE / "identification.csv").read_text().splitlines()
    corrupt.write_text("\n".join(lines[:50] + ["0.5,not-a-number,1.0"] + lines[51:]) + "\n")
    bad = _small_experiment(tmp_path / "bad", corrupt)
    records = {"a": good_a, "bad": bad, "b": good_b}
    df = pd_.identify_many(records, client=client)
    assert list(df["record"]) == ["a", "bad", "b"]
    with pytest.raises(pumpcyl.PumpcylError) as e:
        pumpcyl.identify(bad)
    assert df["error"][1] == str(e.value)
    for k, path in ((0, good_a), (2, good_b)):
        expected = pumpcyl.identify(path, uncertainty=True)
        row = df.iloc[k]
        assert row["error"] is None
        assert row["beta_bar"] == expected.beta_bar
        lo, hi = expected.intervals["beta_bar"]
        assert (row["beta_bar_low"], row["beta_bar_high"]) == (lo, hi)
        assert lo <= row["beta_bar"] <= hi
        assert {k: v for k, v in row["result"].items() if k not in VARYING | {"uncertainty_seconds"}} == {
            k: v for k, v in expected.to_dict().items() if k not in VARYING | {"uncertainty_seconds"}
        }


# ---------------------------------------------------------------------------------------------
# The shards from Python are the command line's (no cluster needed)


def _stage_tops(part):
    """What a partial result says about the grids, without the counts that depend on the
    order the threads meet the candidates (pruned, unstable) and the time."""
    d = json.loads(part)
    assert d.pop("seconds") >= 0.0
    for stage in d["stages"]:
        for k in ("pruned", "unstable", "non_finite"):
            stage["summary"].pop(k)
    return d


def test_a_python_shard_is_the_partial_result_the_command_line_writes(tmp_path):
    experiment = os.path.realpath(ARTICLE / "identify.toml")
    ours = [pumpcyl.identify(experiment, shard=(i, 3)) for i in (1, 2, 3)]
    theirs = []
    for i in (1, 2, 3):
        subprocess.run(
            [pumpcyl_binary(), "identify", experiment, "--shard", f"{i}/3", "--out", str(tmp_path)],
            check=True,
            capture_output=True,
        )
        theirs.append((tmp_path / f"part-{i}-of-3.json").read_text())
    for mine, cli in zip(ours, theirs):
        assert _stage_tops(mine) == _stage_tops(cli)
    # parts from both mixed merge to the one-process answer
    merged = pumpcyl.identify_merge([theirs[1], ours[0], ours[2]])
    assert comparable(merged) == comparable(pumpcyl.identify(experiment))


def test_the_merge_from_python_keeps_the_command_lines_checks():
    experiment = os.path.realpath(ARTICLE / "identify.toml")
    parts = [pumpcyl.identify(experiment, shard=(i, 2)) for i in (1, 2)]
    with pytest.raises(pumpcyl.PumpcylError, match="missing shards"):
        pumpcyl.identify_merge(parts[:1])
    with pytest.raises(pumpcyl.PumpcylError, match="given twice"):
        pumpcyl.identify_merge([parts[0], parts[0]])
    edited = json.loads(parts[1])
    edited["stages"][0]["summary"]["top"][0]["cost_mm2"] *= 0.5
    with pytest.raises(pumpcyl.PumpcylError, match="edited"):
        pumpcyl.identify_merge([parts[0], json.dumps(edited)])
    with pytest.raises(pumpcyl.PumpcylError, match=r"identify_merge\(shards\[1\]\): not a partial"):
        pumpcyl.identify_merge([parts[0], "{}"])


def test_a_shard_needs_the_experiment_files_fixed_grids():
    experiment = ARTICLE / "identify.toml"
    refusals = {
        "grids": dict(grid={"beta_bar": [100.0], "viscous_friction_ns_per_m": [100.0],
                            "c12_m5_per_ns": [1e-10]}),
        "auto-refine": dict(auto_refine=True),
        "merged answer": dict(uncertainty=True),
    }
    for words, kwargs in refusals.items():
        with pytest.raises(pumpcyl.PumpcylError, match=rf"identify\(shard=\(1, 2\)\): .*{words}"):
            pumpcyl.identify(experiment, shard=(1, 2), **kwargs)
    with pytest.raises(pumpcyl.PumpcylError, match="shard 3/2"):
        pumpcyl.identify(experiment, shard=(3, 2))
