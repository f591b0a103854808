"""examples/article.ipynb runs from top to bottom and reaches the article's numbers: every code
cell executed in order in one namespace, as Jupyter's "Run all" would (matplotlib draws off
screen)."""

import json
import os

import pytest

from conftest import ROOT, require_control

NOTEBOOK = ROOT / "examples" / "article.ipynb"


def notebook():
    nb = json.loads(NOTEBOOK.read_text(encoding="utf-8"))
    assert nb["nbformat"] == 4
    return nb


def test_the_notebook_is_stored_without_outputs():
    for cell in notebook()["cells"]:
        if cell["cell_type"] == "code":
            assert cell["outputs"] == [] and cell["execution_count"] is None, cell["source"][:2]


def test_the_notebook_runs_and_reaches_the_article_numbers(monkeypatch, capsys):
    require_control()
    pytest.importorskip("matplotlib", reason="SKIPPED: matplotlib (python-control's dependency)")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.chdir(NOTEBOOK.parent)
    import matplotlib

    matplotlib.use("Agg")
    ns = {"__name__": "__main__"}
    for i, cell in enumerate(notebook()["cells"]):
        if cell["cell_type"] == "code":
            exec(compile("".join(cell["source"]), f"{NOTEBOOK.name} cell {i}", "exec"), ns)
    # the article's margins, and python-control's on the same loop
    assert abs(ns["m"].gain_margin_db - 6.45) < 0.05
    assert abs(ns["gm_db_control"] - ns["m"].gain_margin_db) < 0.01
    # Figure 14: each cumulative step loses gain margin
    gms = [__import__("pumpcyl").margins(r).gain_margin_db for r in ns["cases"].values()]
    assert gms[0] > gms[1] > gms[2]
    # identification recovers the emulator's truth (165 bar, 1.2e-10)
    assert abs(ns["r"].beta_bar - 165.0) < 10.0
    assert abs(ns["r"].c12_m5_per_ns / 1.2e-10 - 1.0) < 0.1
    # beta_e at 1 bar: the article's 37.8 bar, and the loop unstable there
    assert abs(ns["beta_e"][0] - 37.8) < 3.0 and ns["gm_db"][0] < 0.0
    assert abs(ns["d"]["kp_max"] - 25.0) < 1.0
    # the robust design's point estimate is the identification's answer, so its nominal Kp is
    # the one designed on the identified rig; over the confidence region it is no bolder
    assert ns["robust"]["kp_max_nominal"] == pytest.approx(ns["d"]["kp_max"], rel=1e-6)
    assert ns["robust"]["kp_max"] < ns["robust"]["kp_max_nominal"]
    assert ns["summary"]["identified"]["beta_bar"] == pytest.approx(ns["r"].beta_bar, rel=1e-9)
    out = capsys.readouterr().out
    assert "python-control: GM 6.45 dB" in out and "the record that narrows b most" in out
