"""pumpcyl.advise on the article's records equals `pumpcyl advise --json`, and bad candidates
raise PumpcylError with the file, line and key."""

import subprocess

import pytest

import pumpcyl
from conftest import ARTICLE, ROOT, pumpcyl_binary


def test_advise_ranks_the_candidates_and_names_the_best_for_b(tmp_path):
    a = pumpcyl.advise(ARTICLE / "identify.toml")
    assert a["confidence"] == 0.95
    names = [w["parameter"] for w in a["current"]]
    assert names == ["beta_bar", "viscous_friction_ns_per_m", "c12_m5_per_ns"]
    scores = [c["score"] for c in a["candidates"]]
    assert scores == sorted(scores)
    # adding a record never widens an interval
    for c in a["candidates"]:
        for w, now in zip(c["widths"], a["current"]):
            assert w["log_std"] <= now["log_std"] * (1 + 1e-9)
    # the best for b is the candidate with the least b log-std
    best_b = min(a["candidates"], key=lambda c: c["widths"][1]["log_std"])
    assert a["best_for"]["viscous_friction_ns_per_m"] == best_b["label"]
    # the current beta interval contains the emulator's 165 bar (docs/identification.md)
    lo, hi = a["current"][0]["interval"]
    assert lo < 165.0 < hi


def test_bad_candidates_raise_one_line_errors(tmp_path):
    bad = tmp_path / "c.toml"
    bad.write_text("[[sine]]\nfreq_hz = 0.5\namp_mm = -1.0\nkp = 25.0\n")
    with pytest.raises(pumpcyl.PumpcylError, match=r"c\.toml: line 3.*amp_mm"):
        pumpcyl.advise(ARTICLE / "identify.toml", candidates=bad)
    with pytest.raises(pumpcyl.PumpcylError, match="confidence"):
        pumpcyl.advise(ARTICLE / "identify.toml", confidence=1.5)


def test_a_sweep_only_experiment_raises_pumpcyl_error_with_or_without_candidates(tmp_path):
    # an emulated multisine and standstill of the tests' user rig (80/45 mm, 2500 kg, Kp 15),
    # fitted in the frequency domain: the advice weighs candidates against step records, so
    # it refuses in one line, never a PanicException
    rig = ROOT / "tests" / "user-rig.toml"
    exe = pumpcyl_binary()
    for args in (["--experiment", "multisine", "--out", "sweep.csv"],
                 ["--experiment", "standstill", "--duration-s", "2", "--out", "standstill.csv"]):
        subprocess.run([exe, "emulate", "--rig", str(rig), "--no-effects", *args], cwd=tmp_path,
                       check=True, capture_output=True)
    exp = tmp_path / "exp.toml"
    exp.write_text(f'rig = "{rig}"\nmethod = "frequency"\n[standstill]\n'
                   'record = "standstill.csv"\n\n[[dataset]]\nfile = "sweep.csv"\nkp = 15.0\n'
                   'mass_kg = 2500.0\n')
    empty = tmp_path / "empty.toml"
    empty.write_text("")
    for candidates in (empty, None):
        with pytest.raises(pumpcyl.PumpcylError, match="no step record") as e:
            pumpcyl.advise(exp, candidates=candidates)
        assert "\n" not in str(e.value) and "all sweeps" in str(e.value)
