from typing import Any, Optional

from ._pumpcyl import (
    Loop,
    Advice as Advice,
    Chatter as Chatter,
    Dataset as Dataset,
    Design as Design,
    DutyCycle as DutyCycle,
    Emulated as Emulated,
    Identification as Identification,
    IdentificationUncertainty as IdentificationUncertainty,
    Margins as Margins,
    Poles as Poles,
    PumpcylError as PumpcylError,
    Result as Result,
    RobustDesign as RobustDesign,
    Rig as Rig,
    Selection as Selection,
    Signals as Signals,
    Simulation as Simulation,
    Tracking as Tracking,
    FrequencyResponse as FrequencyResponse,
    Step as Step,
    Summary as Summary,
    advise as advise,
    bode as bode,
    chatter as chatter,
    cycle as cycle,
    design as design,
    emulate as emulate,
    fmu as fmu,
    select as select,
    effective_beta as effective_beta,
    gas_fraction as gas_fraction,
    frf as frf,
    identify as identify,
    identify_merge as identify_merge,
    margins as margins,
    poles as poles,
    reproduce as reproduce,
    simulate as simulate,
    state_space as state_space,
    step as step,
    track as track,
)

__version__: str

def to_control(rig: Rig, loop: Loop = "open", *, sum_pressure_closed: Optional[bool] = None) -> Any:
    """The loop as a ``control.StateSpace`` (needs python-control); see ``state_space``.
    States x, v, p1, p2, w1, w2 (then tau1, tau2, z1, z2 where the model has them), input
    ``e`` (open loop) or ``x_ref`` (closed loop) and output ``x`` are named as in the MATLAB
    export."""
