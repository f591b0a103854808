"""Work that would take hours is refused by the core, from Python as from the command line
(pumpcyl::limits): the refusal names ``allow_long_run=True`` and comes before any work."""

import json
import re
import subprocess

import pytest

import pumpcyl
from conftest import pumpcyl_binary

# docs/design.md#targets: 3 stroke positions x masses x pressures, plus the design point, each
# a Kp search of 54 margin analyses; at most 10^5 of them without allowing a long run
ANALYSES_PER_CONDITION = 54
MAX_MARGIN_ANALYSES = 1e5
MAX_SELECT_CASES = 400


def work_of(error):
    """The units of work a refusal states."""
    return float(re.search(r"about (\S+) units of work", str(error)).group(1))


def test_design_refuses_the_masses_the_command_line_refuses():
    masses = [5000.0 + i for i in range(100_000)]
    with pytest.raises(pumpcyl.PumpcylError, match=r"allow_long_run=True") as e:
        pumpcyl.design(mass_kg=masses)
    work = (3 * len(masses) + 1) * ANALYSES_PER_CONDITION
    assert work_of(e.value) == work
    # the first count beyond the limit, as the command line counts it
    first = int((MAX_MARGIN_ANALYSES / ANALYSES_PER_CONDITION - 1) // 3) + 1
    with pytest.raises(pumpcyl.PumpcylError, match=r"mass_kg × p_mean_bar"):
        pumpcyl.design(mass_kg=masses[:first])
    cli = subprocess.run(
        [pumpcyl_binary(), "design", *[a for m in masses[:first] for a in ("--mass-kg", str(m))]],
        capture_output=True,
        text=True,
    )
    assert cli.returncode == 1 and "--allow-long-run" in cli.stderr, cli.stderr
    # and the robust design counts the same work
    with pytest.raises(pumpcyl.PumpcylError, match=r"allow_long_run=True"):
        pumpcyl.design(mass_kg=masses, robust=True)


def test_select_refuses_hours_of_loads_unless_allowed():
    levels = len(pumpcyl.select()["options"])
    assert levels >= 2
    for n in (200, 100_000):
        with pytest.raises(pumpcyl.PumpcylError, match=r"allow_long_run=True") as e:
            pumpcyl.select(mass_kg=[5000.0 + 10 * i for i in range(n)])
        assert work_of(e.value) == n * levels
    # just beyond the limit: refused, and the command line's answer when allowed
    n = MAX_SELECT_CASES // levels + 1
    masses = [5000.0 + 10 * i for i in range(n)]
    with pytest.raises(pumpcyl.PumpcylError, match=r"allow_long_run=True"):
        pumpcyl.select(mass_kg=masses)
    got = pumpcyl.select(mass_kg=masses, allow_long_run=True)
    cli = subprocess.run(
        [pumpcyl_binary(), "select", "--json", "--allow-long-run", "--set",
         "mass_kg=[" + ",".join(str(m) for m in masses) + "]"],
        capture_output=True,
        text=True,
        check=True,
    )
    want = json.loads(cli.stdout)
    assert [o["kp_max"] for o in got["options"]] == [o["kp_max"] for o in want["options"]]
    assert got["min_level_bar"] == want["min_level_bar"]
