"""A rig file describes the whole rig: the keys it leaves out take documented defaults, named in
a warning (docs/formats.md#rig-toml); the article's seesaw mass table stays with the article's
rig. ``design``'s wave errors name the keyword argument ``waves``."""

import re
import warnings

import pytest

import pumpcyl
from conftest import ROOT

# the user rig without its mass table line
MY_RIG = "".join(line for line in (ROOT / "tests" / "user-rig.toml").read_text().splitlines(True)
                 if not line.startswith(("#", "mass_by_position")))


def test_a_rig_file_without_a_mass_table_has_one_mass_and_names_what_it_leaves_out(tmp_path):
    path = tmp_path / "my.toml"
    path.write_text(MY_RIG)
    with pytest.warns(UserWarning) as caught:
        rig = pumpcyl.Rig.from_toml(path)
    assert len(caught) == 1
    note = str(caught[0].message)
    assert note.startswith(f"{path} does not set 35 keys; mass_by_position = [] (one mass over the stroke")
    # each of the other 34 with its default (the article rig's, or the drives' electrical keys'),
    # e.g. the leakages in exponent form
    named = re.findall(r"(\w+) = ", note.split("the others take the article rig's values: ")[1])
    article = pumpcyl.Rig()
    written = [line.split(" = ")[0] for line in MY_RIG.splitlines()]
    # the DPM rig's note names its own keys, not the pump circuits' accumulator and valve keys
    others = ("mass_by_position", "accumulator_precharge_bar", "pilot_ratio", "check_valve_crack_bar",
              "cylinder_rated_pressure_bar")
    expected = [k for k in article.to_dict() if k not in written and k not in others]
    assert sorted(named) == sorted(expected) and len(named) == 34
    assert "c1_m5_per_ns = 5.49e-11" in note and "kff_kg_m2 = 0.0016" in note
    for key in expected:
        assert getattr(rig, key) == getattr(article, key), key
    assert rig.mass_by_position == [] and len(article.mass_by_position) == 3
    # the design checks x0 ± 50 mm = 350 … 450 mm, all at the rig's one mass (the positions it
    # searches between them too)
    d = pumpcyl.design(rig)
    assert [(c["x_mm"], c["mass_kg"]) for c in d["conditions"] if c["searched"] is None] == [
        (350.0, 2500.0), (400.0, 2500.0), (450.0, 2500.0)]
    assert all(c["mass_kg"] == 2500.0 for c in d["conditions"])


def test_a_rig_that_sets_every_key_reads_back_without_a_warning():
    text = pumpcyl.Rig(c12_m5_per_ns=3e-17, external_force_n=-2.5e-5).to_toml()
    assert "c12_m5_per_ns = 3e-17  #" in text and "external_force_n = -2.5e-5  #" in text
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        back = pumpcyl.Rig.from_toml_str(text)
    assert back == pumpcyl.Rig(c12_m5_per_ns=3e-17, external_force_n=-2.5e-5)


@pytest.mark.parametrize(
    "waves, words",
    [
        ([(0.2, 35.0), (80.0, 5.0)], ["design(waves[1]=(80.0, 5.0)): ", "Nyquist frequency 50 Hz"]),
        ([(-1.0, 5.0)], ["design(waves[0]=(-1.0, 5.0)): ", "must be > 0"]),
        ([(1.0, 500.0)], ["design(waves[0]=(1.0, 500.0)): ", "outside the stroke"]),
    ],
)
def test_design_wave_errors_name_the_keyword_argument(waves, words):
    with pytest.raises(pumpcyl.PumpcylError) as e:
        pumpcyl.design(waves=waves)
    message = str(e.value)
    for w in words:
        assert w in message, message
    assert "--wave" not in message and not re.search(r"wave \S+:\S+", message), message


def test_design_refuses_waves_with_robust():
    with pytest.raises(pumpcyl.PumpcylError, match=r"^design\(waves\[0\]=\(0.2, 35.0\)\): tracking is predicted by the nominal design only"):
        pumpcyl.design(waves=[(0.2, 35.0)], robust=True)
