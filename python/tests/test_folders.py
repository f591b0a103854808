"""Result folders from Python keep what the user put there (docs/formats.md#result-folders):
pumpcyl.reproduce(out) run again keeps every file it did not write and warns naming them; a file
of the user's at a path of the result is refused unless force=True; a read-only FMU file is
refused unless force=True."""

import json
import os
import stat
import warnings

import pytest

import pumpcyl


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    out = tmp_path_factory.mktemp("folders") / "out"
    pumpcyl.reproduce(str(out))
    return out


def test_a_rerun_keeps_the_users_files_and_warns_naming_them(folder):
    (folder / "notes.txt").write_text("mine")
    (folder / "figures" / "my-sketch.txt").write_text("sketch")
    (folder / "mine").mkdir()
    (folder / "mine" / "deep.txt").write_text("deep")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        s = pumpcyl.reproduce(folder)
    said = " ".join(str(w.message) for w in caught)
    for name in ["notes.txt", "figures/my-sketch.txt", "mine/deep.txt"]:
        assert name in said, said
    assert "not written by pumpcyl" in said
    assert (folder / "notes.txt").read_text() == "mine"
    assert (folder / "figures" / "my-sketch.txt").read_text() == "sketch"
    assert (folder / "mine" / "deep.txt").read_text() == "deep"
    assert json.loads((folder / "summary.json").read_text()) == s
    listed = (folder / ".pumpcyl-output").read_text().splitlines()
    assert "summary.json" in listed and "notes.txt" not in listed


def test_a_users_file_at_a_path_of_the_result_is_refused_unless_forced(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    # an empty marker lists nothing: every file in the folder is the user's
    (out / ".pumpcyl-output").write_text("")
    (out / "summary.json").write_text("my own")
    (out / "thesis.tex").write_text("thesis")
    with pytest.raises(pumpcyl.PumpcylError, match="summary.json.*not written by pumpcyl"):
        pumpcyl.reproduce(str(out))
    assert (out / "summary.json").read_text() == "my own"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        s = pumpcyl.reproduce(str(out), force=True)
    assert any("replaced summary.json" in str(w.message) for w in caught)
    assert json.loads((out / "summary.json").read_text()) == s
    assert (out / "thesis.tex").read_text() == "thesis"


def test_a_read_only_fmu_file_is_refused_unless_forced(tmp_path):
    path = tmp_path / "rig.fmu"
    pumpcyl.fmu(None, path, "linear")
    os.chmod(path, 0o444)
    before = path.read_bytes()
    with pytest.raises(pumpcyl.PumpcylError, match="rig.fmu.*read-only"):
        pumpcyl.fmu(None, path, "linear", controller="external")
    assert path.read_bytes() == before
    pumpcyl.fmu(None, path, "linear", controller="external", force=True)
    assert path.read_bytes() != before
    assert stat.S_IMODE(path.stat().st_mode) == 0o444
