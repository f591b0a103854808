"""examples/article.py reproduces the article's headline numbers."""

import runpy

from conftest import ROOT


def test_article_example_reproduces_the_headline_numbers(capsys):
    example = runpy.run_path(str(ROOT / "examples" / "article.py"))
    out = example["main"](progress=False)
    m = out["margins"]
    assert abs(m.gain_margin_db - 6.5) < 0.1 and abs(m.phase_margin_deg - 34.0) < 1.0
    assert abs(out["identification"].beta_bar - 165.0) < 10.0  # the emulator's truth
    # beta_e at 1 and 10 bar from the identified beta: the article's 37.8 and 370 bar from 165
    assert abs(out["beta_e"][1.0] - 37.8) < 3.0 and abs(out["beta_e"][10.0] - 370.0) < 25.0
    assert out["pressure_margins"][1.0].phase_margin_deg < m.phase_margin_deg
    assert abs(out["kp_max"] - 25.0) < 1.0
    assert "default rig: GM 6.45 dB" in capsys.readouterr().out
