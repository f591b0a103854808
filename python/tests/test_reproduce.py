"""pumpcyl.reproduce: the article workflow from Python, its summary against independent values
(the emulator's truth, pumpcyl.margins on the default rig) and the folder it writes."""

import json
import os
import signal
import time

import pytest

import pumpcyl
from conftest import stub_fields


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("reproduce") / "out"
    return out, pumpcyl.reproduce(str(out))


def test_the_summary_recovers_the_emulators_truth(run):
    _, s = run
    assert s["emulated_inputs"] is True
    # the records were emulated with beta_e = 165 bar and c12 = 1.2e-10 m⁵/(N·s)
    assert abs(s["identified"]["beta_bar"] - 165.0) <= 10.0
    lo, hi = s["how_sure"]["intervals"]["beta_bar"]
    assert lo <= 165.0 <= hi
    lo, hi = s["how_sure"]["intervals"]["c12_m5_per_ns"]
    assert lo <= 1.2e-10 <= hi
    assert s["how_sure"]["identifiable"]["viscous_friction_ns_per_m"] is False
    robust = s["how_sure"]["robust_design"]
    assert 0 < robust["kp_max"] <= robust["kp_max_nominal"]


def test_the_default_rig_margins_are_those_of_pumpcyl_margins(run):
    _, s = run
    m = pumpcyl.margins(pumpcyl.Rig())
    default = s["margins"]["default_rig"]
    assert default["gain_margin_db"] == pytest.approx(m.gain_margin_db, abs=1e-9)
    assert default["phase_margin_deg"] == pytest.approx(m.phase_margin_deg, abs=1e-9)
    assert m.gain_margin_db == pytest.approx(6.45, abs=0.05)


def test_the_folder_holds_the_returned_summary_and_the_report(run):
    out, s = run
    written = json.loads((out / "summary.json").read_text())
    assert written == s
    # one document: the file's keys, the result's and the stub's
    assert isinstance(s, pumpcyl.Result)
    assert sorted(s) == sorted(written) == sorted(stub_fields("Summary"))
    assert "How sure are we" in (out / "report.html").read_text()
    assert (out / "figures" / "robust-margins.png").stat().st_size > 10_000


def test_without_a_folder_nothing_is_written(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    s = pumpcyl.reproduce(progress=True)
    assert s["design"]["kp_max"] > 0
    assert list(tmp_path.iterdir()) == []


def _ctrl_c():
    """Send this process SIGINT and give Python's handler the moment it needs to run."""
    os.kill(os.getpid(), signal.SIGINT)
    time.sleep(2.0)


def test_ctrl_c_raises_keyboard_interrupt_before_and_after_reproduce(tmp_path):
    # the package installs no signal handler of its own: Python's stays in charge, so Ctrl-C
    # is a KeyboardInterrupt before a call, after one (the workflow wrote a folder), and the
    # interpreter goes on
    with pytest.raises(KeyboardInterrupt):
        _ctrl_c()
    out = tmp_path / "out"
    s = pumpcyl.reproduce(str(out))
    assert (out / "summary.json").is_file() and s["emulated_inputs"] is True
    with pytest.raises(KeyboardInterrupt):
        _ctrl_c()
    assert pumpcyl.margins(pumpcyl.Rig()).closed_loop_stable
