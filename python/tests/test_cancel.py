"""A long request stops when its caller asks (docs/architecture.md#requests): a `progress`
callable that raises ends the work at its next unit, not at its end, and the error reaches the
caller; Ctrl-C (KeyboardInterrupt) takes the same path."""

import pytest

import pumpcyl


class Stop(Exception):
    pass


def test_a_design_stops_at_its_next_condition_when_progress_raises():
    seen = []

    def progress(done, total):
        seen.append((done, total))
        raise Stop()

    masses = [800.0 + 10.0 * k for k in range(40)]
    pressures = [1.0 + 0.25 * k for k in range(40)]
    with pytest.raises(Stop):
        pumpcyl.design(mass_kg=masses, p_mean_bar=pressures, progress=progress,
                       allow_long_run=True)
    total = seen[0][1]
    assert total == 3 * 40 * 40
    # the work stopped long before its end: every report after the first saw it stopping
    assert max(done for done, _ in seen) < total / 2, seen[-3:]


def test_an_uncancelled_design_reports_its_whole_work():
    seen = []
    pumpcyl.design(mass_kg=[900.0, 1000.0], progress=lambda done, total: seen.append((done, total)))
    assert seen[-1] == (6, 6)
