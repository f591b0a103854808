"""pumpcyl: model, analyse, identify and design pump-controlled hydraulic cylinders.

The Python face of the pumpcyl Rust library: the 10-state linear model of the dual-prime-mover
cylinder of Gøytil, Hansen & Tvilde, "Effective Bulk Modulus in Low-Pressure Pump-Controlled
Hydraulic Cylinders", Actuators 2025, 14(8), 366, with exact margins, Bode, zero-order-hold
simulation, grid identification of the bulk modulus, the gas-fraction model and the design
method. numpy arrays in and out; units are part of every name (``beta_bar``, ``f_hz``,
``x_mm``). Every result is a :class:`Result`: the document the command line prints with
``--json``, each key an attribute and an item, signals as numpy arrays, the whole as plain data
with ``to_dict()``. Errors raise :class:`PumpcylError`, a ``ValueError`` carrying the command line's
one-line message; a bad argument is named with the value given
(``Rig(beta_bar=nan): ...``, ``identify(standstill['w1_rpm']='x'): ...``).
"""

from ._pumpcyl import (
    Dataset,
    PumpcylError,
    Result,
    Rig,
    _loop_names,
    advise,
    bode,
    chatter,
    cycle,
    design,
    emulate,
    fmu,
    frf,
    select,
    effective_beta,
    gas_fraction,
    identify,
    identify_merge,
    margins,
    poles,
    reproduce,
    simulate,
    state_space,
    step,
    track,
)

__version__ = "0.1.0"

__all__ = [
    "Dataset",
    "PumpcylError",
    "Result",
    "Rig",
    "advise",
    "bode",
    "chatter",
    "cycle",
    "design",
    "emulate",
    "fmu",
    "select",
    "effective_beta",
    "gas_fraction",
    "frf",
    "identify",
    "identify_merge",
    "margins",
    "poles",
    "reproduce",
    "simulate",
    "state_space",
    "step",
    "to_control",
    "track",
]


def to_control(rig, loop="open", *, sum_pressure_closed=None):
    """The loop of ``rig`` as a ``control.StateSpace`` (python-control must be installed).

    Same loops and units as :func:`state_space`: ``loop="open"`` is the article's open loop
    (the article §2.3.3; input the position error ``e`` in m, output ``x`` in m), ``loop="closed"`` the
    closed loop ``x_ref`` -> ``x`` (m). States, input and output are named as the MATLAB export
    names them: x, v, p1, p2, w1, w2, then tau1, tau2 and z1, z2 where the rig's model has them.
    """
    try:
        import control
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError(
            "pumpcyl.to_control needs python-control: pip install control"
        ) from e
    states, inputs, outputs = _loop_names(rig, loop)
    return control.ss(
        *state_space(rig, loop, sum_pressure_closed=sum_pressure_closed),
        states=states,
        inputs=inputs,
        outputs=outputs,
    )
