"""Shared paths and helpers of the pumpcyl Python tests."""

import csv
import os
import pathlib

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
ARTICLE = ROOT / "data" / "article"


def require_control():
    """python-control, or a visible skip (a failure when CI is set)."""
    try:
        import control  # noqa: F401
    except ImportError:
        if os.environ.get("CI"):
            raise
        pytest.skip("SKIPPED: python-control is not installed (pip install control)")
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
