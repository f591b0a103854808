"""The FMUs never hang or crash their host (docs/fmu.md#robustness, docs/fmu.md#limits), run by
FMPy's low-level calls: a call on a freed, unknown or wrong-phase instance, a step beyond the
limit or not a number, a communication point that is not the instance's own time, and a start
time beyond the limit are each fmi2Error with a reason in the log, for all four kinds of FMU;
a step started at 10^6 s gives what one started at 0 gives."""

import ctypes
import zipfile

import numpy as np
import pytest

import pumpcyl
from test_fmu import require_fmpy

KINDS = [("emulator", "article"), ("emulator", "external"), ("linear", "article"),
         ("linear", "external")]
OK, ERROR = 0, 3


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    """Each kind of FMU written once and unpacked once (into pytest's own temporary folder)."""
    d = tmp_path_factory.mktemp("robust")
    out = {}
    for model, controller in KINDS:
        path = pumpcyl.fmu(None, d / f"{model}-{controller}.fmu", model, controller=controller)
        unpacked = d / f"{model}-{controller}"
        with zipfile.ZipFile(path) as z:
            z.extractall(unpacked)
        out[(model, controller)] = (path, unpacked)
    return out


class Slave:
    """One instance through FMPy's low-level calls, its log collected."""

    def __init__(self, fmpy, fmu):
        from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
        from fmpy.logging import addLoggerProxy

        path, unpacked = fmu
        md = fmpy.read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.log = []

        def logger(_env, _name, status, _category, message):
            self.log.append((status, message.decode() if isinstance(message, bytes) else str(message)))

        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = fmi2CallbackLoggerTYPE(logger)
        addLoggerProxy(ctypes.byref(self.callbacks))
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=str(unpacked),
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName="robust")
        self.fmu.instantiate(callbacks=self.callbacks)
        self.handle = self.fmu.component

    def call(self, name, *args, handle=None):
        """fmi2<name> on the instance (or on `handle`): its status."""
        from fmpy.fmi1 import FMICallException

        try:
            return getattr(self.fmu, "fmi2" + name)(self.handle if handle is None else handle, *args)
        except FMICallException as e:
            return e.status

    def start(self, start_s=0.0):
        assert self.call("SetupExperiment", 0, 0.0, start_s, 0, 0.0) == OK
        assert self.call("EnterInitializationMode") == OK
        assert self.call("ExitInitializationMode") == OK

    def x(self):
        v = (ctypes.c_double * 1)()
        vr = (ctypes.c_uint * 1)(self.vr["x_m"])
        return self.call("GetReal", vr, 1, v), v[0]

    def refused(self, what, status, *words):
        """`status` is fmi2Error and the last message holds every word."""
        assert status == ERROR, f"{what}: status {status}"
        assert self.log and self.log[-1][0] == ERROR, f"{what}: nothing logged"
        for w in words:
            assert w in self.log[-1][1], f"{what}: {self.log[-1][1]}"


@pytest.mark.parametrize("kind", KINDS, ids=lambda k: "-".join(k))
def test_freed_unknown_and_wrong_phase_calls_are_logged_errors(fmus, kind):
    fmpy = require_fmpy()
    s = Slave(fmpy, fmus[kind])
    s.refused("a step before initialisation", s.call("DoStep", 0.0, 0.01, 1), "not initialised")
    s.start()
    assert s.call("DoStep", 0.0, 0.01, 1) == OK
    for t, h, words in [(0.01, 1e300, "at most 100"), (0.01, 1e5, "at most 100"),
                        (0.01, float("nan"), "communication step"), (0.01, -0.01, "must be > 0"),
                        (-1.0, 0.01, "the instance is at 0.01 s"), (1e300, 0.01, "the instance is at")]:
        s.refused(f"t {t} h {h}", s.call("DoStep", t, h, 1), *words.split("|"))
    assert s.call("DoStep", 0.01, 0.01, 1) == OK
    assert s.call("Terminate") == OK
    s.refused("a step after terminate", s.call("DoStep", 0.02, 0.01, 1), "terminated")
    status, x = s.x()
    assert status == OK and abs(x - 0.345) < 1e-3, x
    # freed twice, then used: logged errors through the freed instance's logger, no crash
    s.call("FreeInstance")
    s.call("FreeInstance")
    assert "already freed" in s.log[-1][1]
    s.refused("a step after free", s.call("DoStep", 0.02, 0.01, 1), "freed")
    s.refused("a read after free", s.x()[0], "freed")
    s.refused("a reset after free", s.call("Reset"), "freed")
    # a handle never given out
    assert s.call("DoStep", 0.0, 0.01, 1, handle=0xDEAD0) == ERROR


@pytest.mark.parametrize("kind", KINDS, ids=lambda k: "-".join(k))
def test_a_start_time_beyond_the_limit_is_refused(fmus, kind):
    fmpy = require_fmpy()
    s = Slave(fmpy, fmus[kind])
    s.refused("start 1e300", s.call("SetupExperiment", 0, 0.0, 1e300, 0, 0.0), "start time")
    s.start(1e6)
    assert s.call("DoStep", 1e6, 0.01, 1) == OK
    s.call("FreeInstance")


def step_from(fmpy, path, start_s, adding):
    """x (m) over a 5 mm step of the reference at 30 ms, started at `start_s`; the master
    adds the step to its time, or multiplies it out."""
    s = Slave(fmpy, path)
    s.start(start_s)
    x0 = s.x()[1]
    xr = (ctypes.c_uint * 1)(s.vr["x_ref_m"])
    out, t = [], start_s
    for k in range(150):
        assert s.call("SetReal", xr, 1, (ctypes.c_double * 1)(x0 if k < 3 else x0 + 5e-3)) == OK
        t = (t + 0.01 if k else t) if adding else start_s + k * 0.01
        assert s.call("DoStep", t, 0.01, 1) == OK, s.log[-1:]
        out.append(s.x()[1])
    s.call("FreeInstance")
    return np.array(out)


@pytest.mark.parametrize("model", ["emulator", "linear"])
def test_a_step_started_at_a_million_seconds_is_the_step_started_at_zero(fmus, model):
    """docs/fmu.md promises 1e-9 m against `emulate`, whatever the start time."""
    fmpy = require_fmpy()
    path = fmus[(model, "article")]
    at_zero = step_from(fmpy, path, 0.0, True)
    assert np.ptp(at_zero) > 4e-3
    for adding in (True, False):
        late = step_from(fmpy, path, 1e6, adding)
        assert np.max(np.abs(late - at_zero)) < 1e-9, adding


def test_the_emulator_fmu_logs_the_end_stop_it_meets(fmus):
    fmpy = require_fmpy()
    s = Slave(fmpy, fmus[("emulator", "article")])
    s.start()
    xr = (ctypes.c_uint * 1)(s.vr["x_ref_m"])
    s.call("SetReal", xr, 1, (ctypes.c_double * 1)(0.499))
    peak = 0.0
    for k in range(400):
        assert s.call("DoStep", k * 0.01, 0.01, 1) == OK
        peak = max(peak, s.x()[1])
    notes = [m for st, m in s.log if "end stop" in m]
    assert len(notes) == 1 and "extended end stop (x = 500 mm)" in notes[0], s.log
    assert 0.4999 < peak < 0.5005, peak
    s.call("FreeInstance")
