"""Shared paths and helpers of the pumpcyl Python tests."""

import ast
import csv
import os
import pathlib
import re

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
ARTICLE = ROOT / "data" / "article"


# Every skipped test is written to the skip log that ./test.sh sums up in its last line
# (`skipped: 5 tests — …`), as the Rust tests do (tests/common/skip.rs): one line
# `test<TAB>tool<TAB>install command`, or `test<TAB>reason<TAB>` for other skips.
SKIP_LOG = pathlib.Path(os.environ.get("PUMPCYL_SKIP_LOG") or ROOT / "target" / "skipped-tests.txt")
_MISSING = re.compile(r"^(?:SKIPPED: )?(?P<tool>.+) is not installed \((?P<install>[^()]+)\)$")


def skip_missing(tool, install):
    """Skip the running test: ``tool`` is missing and ``install`` installs it (under CI the
    callers raise instead). The skip log's hook reads the tool and the command from this text."""
    pytest.skip(f"SKIPPED: {tool} is not installed ({install})")


def _log_skip(nodeid, longrepr):
    reason = longrepr[2] if isinstance(longrepr, tuple) and len(longrepr) == 3 else str(longrepr)
    reason = " ".join(str(reason).split())
    reason = re.sub(r"^Skipped: ", "", reason)
    missing = _MISSING.match(reason)
    if missing:
        tool, install = missing["tool"], missing["install"]
    else:
        tool, install = re.sub(r"^SKIPPED: ", "", reason), ""
    fields = [" ".join(f.split()) for f in (nodeid, tool, install)]
    try:
        with open(SKIP_LOG, "a", encoding="utf-8") as f:
            f.write("\t".join(fields) + "\n")
    except OSError:
        if os.environ.get("PUMPCYL_SKIP_LOG"):
            raise
        # no target/ folder (pytest run by hand): the skip is still in pytest's own report


def pytest_runtest_logreport(report):
    """A skipped test (not an expected failure) goes to the skip log."""
    if report.skipped and not hasattr(report, "wasxfail"):
        _log_skip(report.nodeid, report.longrepr)


def pytest_collectreport(report):
    """A module skipped whole (``pytest.importorskip`` at its top) goes to the skip log."""
    if report.skipped:
        _log_skip(report.nodeid, report.longrepr)


def require_control():
    """python-control, or a visible skip (a failure when CI is set)."""
    try:
        import control  # noqa: F401
    except ImportError:
        if os.environ.get("CI"):
            raise
        skip_missing("python-control", "pip install control")
    import control

    return control


def read_record(name):
    """The columns of an article record as float arrays."""
    with open(ARTICLE / name, newline="") as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def pumpcyl_binary():
    """The command line built by ``cargo test`` (target/debug/pumpcyl), or a visible skip."""
    exe = ROOT / "target" / "debug" / "pumpcyl"
    if not exe.exists():
        if os.environ.get("CI"):
            raise FileNotFoundError(f"{exe} not built (cargo build)")
        pytest.skip(f"SKIPPED: {exe} not built (cargo build)")
    return str(exe)


def pumpcyl_json(command, sets=(), *options, timeout=300):
    """`pumpcyl COMMAND OPTIONS… --set S… --json` by the command line ``cargo test`` built,
    parsed."""
    import json
    import subprocess

    args = [pumpcyl_binary(), command, *options, "--json"]
    for s in sets:
        args += ["--set", s]
    out = subprocess.run(args, capture_output=True, text=True, timeout=timeout, check=True)
    return json.loads(out.stdout)


def stub_fields(name):
    """The annotated fields of the class `name` in the stub python/pumpcyl/_pumpcyl.pyi, in
    order: the keys a result of that kind holds."""
    tree = ast.parse((ROOT / "python" / "pumpcyl" / "_pumpcyl.pyi").read_text())
    cls = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == name)
    return [n.target.id for n in cls.body if isinstance(n, ast.AnnAssign)]
