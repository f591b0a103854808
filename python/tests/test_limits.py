"""Work that would take hours is refused by the core, from Python as from the command line
(pumpcyl::limits): the refusal names ``allow_long_run=True`` and comes before any work."""

import json
import re
import subprocess

import pytest

import pumpcyl
from conftest import ROOT, pumpcyl_binary

# docs/design.md#targets: 3 stroke positions x masses x pressures, plus the design point, each
# a Kp search of 54 margin analyses, and for each mass and pressure the search over the stroke
# (docs/design.md#the-worst-case-searched: 41 scanned positions, two golden sections of 42,
# and the two conditions it adds); at most 10^5 of them without allowing a long run
ANALYSES_PER_CONDITION = 54
ANALYSES_PER_SEARCH = 41 + 2 * 42 + 2 * ANALYSES_PER_CONDITION
MAX_MARGIN_ANALYSES = 1e5
MAX_SELECT_CASES = 400


def work_of(error):
    """The units of work a refusal states."""
    return float(re.search(r"about (\S+) units of work", str(error)).group(1))


def test_design_refuses_the_masses_the_command_line_refuses():
    masses = [5000.0 + i for i in range(100_000)]
    with pytest.raises(pumpcyl.PumpcylError, match=r"allow_long_run=True") as e:
        pumpcyl.design(mass_kg=masses)
    per_mass = 3 * ANALYSES_PER_CONDITION + ANALYSES_PER_SEARCH
    work = len(masses) * per_mass + ANALYSES_PER_CONDITION
    assert work_of(e.value) == work
    # the first count beyond the limit, as the command line counts it
    first = int((MAX_MARGIN_ANALYSES - ANALYSES_PER_CONDITION) // per_mass) + 1
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


def test_emulate_is_stopped_by_its_integrators_work_as_the_command_line_is(tmp_path):
    """docs/emulator.md#the-work-limit: 20 000 s of the user rig at Kp 1000 (the drives
    saturate; 2e6 controller steps, within the steps' limit) is stopped by the integrator's work
    after 256 steps, naming allow_long_run=True; 2 s of it runs. In a child process under a CPU
    limit, so a run the limit fails to stop ends the test instead of running for hours."""
    import sys
    import textwrap

    code = textwrap.dedent(f"""
        import pumpcyl
        rig = pumpcyl.Rig.from_toml({str(ROOT / "tests" / "user-rig.toml")!r})
        short = pumpcyl.emulate("step", rig, duration_s=2.0, kp=1000.0)
        assert short["samples"] == 201, short["samples"]
        try:
            pumpcyl.emulate("step", rig, duration_s=20000.0, kp=1000.0)
        except pumpcyl.PumpcylError as e:
            print(e)
        """)
    run = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        preexec_fn=lambda: __import__("resource").setrlimit(
            __import__("resource").RLIMIT_CPU, (120, 120)),
    )
    assert run.returncode == 0, run.stderr
    message = run.stdout.strip()
    assert "projected from its rate over t = 1.28-2.56 s" in message, message
    assert "more than the 5e9" in message and message.endswith("(allow_long_run=True)"), message
    assert "\n" not in message


def test_select_counts_its_waves_as_the_command_line_does(tmp_path):
    """docs/select.md#work: 1000 waves on the user rig's 13 DPM levels are 446 cases (each wave
    beyond the first 1/30 of a case), refused naming allow_long_run=True; three run."""
    def app(waves):
        text = f'rig = "{ROOT / "tests" / "user-rig.toml"}"\ncircuits = ["dpm"]\n'
        for k in range(waves):
            text += f"\n[[wave]]\nfreq_hz = 0.2\namp_mm = {10.0 + 0.001 * k}\nmax_error_mm = 30.0\n"
        path = tmp_path / f"app-{waves}.toml"
        path.write_text(text)
        return path

    with pytest.raises(pumpcyl.PumpcylError, match=r"allow_long_run=True") as e:
        pumpcyl.select(app(1000))
    assert "each [[wave]] beyond the first adds 1/30 of a case, 1000 waves" in str(e.value)
    assert work_of(e.value) == 446
    assert len(pumpcyl.select(app(3))["options"]) == 13
