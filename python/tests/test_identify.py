"""identify on arrays equals identify on the same records from files; progress and Ctrl-C."""

import os
import signal
import threading
import time

import pytest

tomllib = pytest.importorskip("tomllib")  # Python >= 3.11 reads the experiment file

import pumpcyl
from conftest import ARTICLE, read_record

SMALL = dict(beta_bar=[145.0, 155.0, 165.0, 175.0, 185.0],
             viscous_friction_ns_per_m=[100.0, 200.0, 300.0],
             c12_m5_per_ns=[1.0e-10, 1.2e-10, 1.4e-10])
REFINED = dict(beta_bar=[160.0, 165.0, 170.0], viscous_friction_ns_per_m=[250.0, 300.0],
               c12_m5_per_ns=[1.1e-10, 1.2e-10, 1.3e-10])


def mean(values):
    """Sequential mean, summed in the library's order, so both sides agree to the last bit."""
    total = 0.0
    for v in values:
        total += float(v)
    return total / len(values)


def from_arrays(**kwargs):
    """The experiment of data/article/identify.toml, given as arrays."""
    still = read_record("standstill.csv")
    standstill = dict(w1_rpm=mean(still["w1_rpm"]), w2_rpm=mean(still["w2_rpm"]),
                      p1_bar=mean(still["p1_bar"]))
    experiment = tomllib.loads((ARTICLE / "identify.toml").read_text())
    datasets = []
    for ds in experiment["dataset"]:
        rec = read_record(ds["file"])
        datasets.append(pumpcyl.Dataset(rec["time_s"], rec["x_ref_mm"], rec["x_mm"], kp=ds["kp"],
                                        mass_kg=ds["mass_kg"], fit_end_s=ds["fit_end_s"],
                                        name=ds["file"]))
    rig = pumpcyl.Rig(**experiment.get("set", {}))  # the experiment file's [set], if any
    return pumpcyl.identify(datasets=datasets, standstill=standstill, rig=rig, **kwargs)


def assert_same(a, b):
    for key in ("beta_bar", "viscous_friction_ns_per_m", "c12_m5_per_ns", "c1_m5_per_ns",
                "c2_m5_per_ns"):
        assert getattr(a, key) == pytest.approx(getattr(b, key), rel=1e-12), key
    assert a.cost_mm2 == pytest.approx(b.cost_mm2, rel=1e-9)
    assert [(t["beta_bar"], t["viscous_friction_ns_per_m"], t["c12_m5_per_ns"]) for t in a.top] \
        == [(t["beta_bar"], t["viscous_friction_ns_per_m"], t["c12_m5_per_ns"]) for t in b.top]
    assert a.candidates_evaluated == b.candidates_evaluated
    # one document either way: the same keys, the experiment file named only when there is one
    assert sorted(a) == sorted(b)
    assert (a.experiment is None) != (b.experiment is None)


def test_arrays_equal_files_on_small_grids():
    kw = dict(grid=SMALL, refined_grid=REFINED)
    files = pumpcyl.identify(str(ARTICLE / "identify.toml"), **kw)
    arrays = from_arrays(**kw)
    assert_same(files, arrays)
    assert files.candidates_evaluated == 45 + 18
    # the emulator's truth is 165 bar (data/article/README.md)
    assert abs(files.beta_bar - 165.0) < 10.0


def test_arrays_equal_files_on_the_article_grids():
    files = pumpcyl.identify(str(ARTICLE / "identify.toml"))
    arrays = from_arrays(grids="article")
    assert_same(files, arrays)
    assert files.candidates_evaluated == 3264 + 3553
    assert abs(files.beta_bar - 165.0) < 10.0
    assert files.c12_m5_per_ns == pytest.approx(1.2e-10, rel=0.1)


def test_progress_callable_sees_every_candidate():
    seen = []
    pumpcyl.identify(str(ARTICLE / "identify.toml"), grid=SMALL, refined_grid=False,
                     progress=lambda done, total: seen.append((done, total)))
    assert seen[-1] == (45, 45)
    assert all(a[0] <= b[0] for a, b in zip(seen, seen[1:]))


def test_progress_true_prints_to_stderr(capsys):
    pumpcyl.identify(str(ARTICLE / "identify.toml"), grid=SMALL, refined_grid=False,
                     progress=True)
    err = capsys.readouterr().err
    assert "identify: 45/45 candidates" in err
    # stderr is captured (not a terminal): whole lines, one per tenth of the work at most
    # (a search this small may end before the first report), never carriage-return redraws
    lines = err.splitlines()
    assert "\r" not in err and 1 <= len(lines) <= 11, lines
    assert all(line.startswith("identify: ") and line.endswith("/45 candidates") for line in lines)


BIG = dict(beta_bar=[float(b) for b in range(50, 1050, 5)],
           viscous_friction_ns_per_m=[float(b) for b in range(50, 550, 25)],
           c12_m5_per_ns=[1e-11 * k for k in range(1, 21)])  # 80 000 candidates


def test_ctrl_c_interrupts_a_long_identification():
    """SIGINT from another thread, as a terminal's Ctrl-C, while the search runs in Rust."""
    huge = dict(beta_bar=list(range(1, 101)), viscous_friction_ns_per_m=list(range(1, 101)),
                c12_m5_per_ns=[1e-12 * k for k in range(1, 101)])  # a million candidates
    running, finished = threading.Event(), threading.Event()

    def ctrl_c():
        if running.wait(60) and not finished.is_set():
            os.kill(os.getpid(), signal.SIGINT)

    pressing = threading.Thread(target=ctrl_c)
    pressing.start()
    start = time.monotonic()
    try:
        with pytest.raises(KeyboardInterrupt):
            pumpcyl.identify(str(ARTICLE / "identify.toml"), grid=huge, refined_grid=False,
                             progress=lambda done, total: done and running.set(),
                             allow_long_run=True)
    finally:
        finished.set()
        running.set()
        pressing.join()
    # stopped within moments of the signal, not after the whole grid
    assert time.monotonic() - start < 10.0


def test_an_error_in_the_progress_callback_stops_the_search():
    def fail(done, total):
        raise RuntimeError(f"stop at {done} of {total}")

    with pytest.raises(RuntimeError, match="of 80000"):
        pumpcyl.identify(str(ARTICLE / "identify.toml"), grid=BIG, refined_grid=False,
                         progress=fail)


def test_identify_errors_name_what_is_wrong():
    rec = read_record("identification.csv")
    ds = pumpcyl.Dataset(rec["time_s"], rec["x_ref_mm"], rec["x_mm"], kp=25, mass_kg=10593,
                         fit_end_s=99.0, name="ident")
    with pytest.raises(pumpcyl.PumpcylError, match=r"dataset `ident`: fit_end_s = 99"):
        pumpcyl.identify(datasets=[ds], standstill=dict(w1_rpm=-160, w2_rpm=245, p1_bar=3.95))
    with pytest.raises(pumpcyl.PumpcylError, match="standstill"):
        pumpcyl.identify(datasets=[ds], standstill=dict(w1_rpm=-160, w2_rpm=245))
    with pytest.raises(pumpcyl.PumpcylError, match="grid"):
        pumpcyl.identify(str(ARTICLE / "identify.toml"), grid=dict(beta_bar=[1.0]))
    with pytest.raises(pumpcyl.PumpcylError, match="x_mm"):
        pumpcyl.Dataset([0.0, 0.1], [1.0, 2.0], [1.0], kp=25, mass_kg=1, fit_end_s=0.1)
    # the same record in metres under the _mm names: refused as the command line refuses it,
    # naming the column and the likely unit
    metres = pumpcyl.Dataset(rec["time_s"], rec["x_ref_mm"] * 1e-3, rec["x_mm"] * 1e-3, kp=25,
                             mass_kg=10593, fit_end_s=rec["time_s"][-1], name="m")
    with pytest.raises(pumpcyl.PumpcylError, match=r"column `x_ref_mm`.*metres"):
        pumpcyl.identify(datasets=[metres], standstill=dict(w1_rpm=-160, w2_rpm=245, p1_bar=3.95))


def test_hours_of_work_are_refused_unless_allowed():
    huge = dict(beta_bar=list(range(1, 101)), viscous_friction_ns_per_m=list(range(1, 101)),
                c12_m5_per_ns=[1e-12 * k for k in range(1, 101)])  # a million candidates
    with pytest.raises(pumpcyl.PumpcylError, match=r"allow_long_run=True"):
        pumpcyl.identify(str(ARTICLE / "identify.toml"), grid=huge, refined_grid=False)
