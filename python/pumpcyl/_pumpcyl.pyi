"""Type stubs of the compiled pumpcyl module. Units are part of every name; SI in matrices."""

from os import PathLike
from typing import Any, Callable, Dict, Iterator, List, Literal, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
ArrayLike = Union[Sequence[float], FloatArray]
Loop = Literal["open", "closed"]

class PumpcylError(ValueError):
    """Bad input or a numerical failure, with the command line's one-line message."""

class Rig:
    """A rig description: the article's rig with overrides, or a TOML file.

    Immutable: :meth:`replace` returns a new rig. Every TOML key is a read-only attribute with
    its unit in its name (``rig.beta_bar`` in bar, ``rig.mass_kg`` in kg), listed by ``dir``;
    ``help(Rig)`` and ``pumpcyl rig`` give each key's unit and meaning. A value of the wrong
    type (a str or bool for a number, a number for a bool) or out of range raises
    :class:`PumpcylError` naming the key.
    """

    def __init__(self, **overrides: Union[float, bool, str]) -> None:
        """The article's rig with keyword overrides, same keys as the TOML."""
    @staticmethod
    def from_toml(path: Union[str, PathLike[str]]) -> Rig:
        """Read a rig TOML file. Absent keys take the article's values, except
        ``mass_by_position``, ``[]`` (one mass over the stroke); a ``UserWarning`` names them
        and the values they take (docs/formats.md#rig-toml)."""
    @staticmethod
    def from_toml_str(text: str, name: str = "<string>") -> Rig:
        """Parse rig TOML text; ``name`` stands for the file in messages. Absent keys as in
        :meth:`from_toml`, named in a ``UserWarning`` and in the ``rig_defaulted_keys`` of the
        results of this rig."""
    def replace(self, **overrides: Union[float, bool, str]) -> Rig:
        """A new rig with the overrides applied; this one is unchanged."""
    def to_dict(self) -> Dict[str, Union[float, bool, str]]:
        """Every key and value (units in the key names)."""
    def to_toml(self) -> str:
        """Commented TOML (what ``pumpcyl rig`` prints), readable by :meth:`from_toml`."""
    def __dir__(self) -> List[str]:
        """The methods and every key."""
    # circuit (docs/circuits.md): the other circuit's keys may not be set
    circuit: Literal["dpm", "dual-pump", "single-pump"]
    # geometry
    piston_diameter_mm: float
    rod_diameter_mm: float
    line_volume_1_dm3: float
    line_volume_2_dm3: float
    stroke_mm: float
    x0_mm: float
    # motors, pumps and drives
    motor_inertia_1_kg_mm2: float
    motor_inertia_2_kg_mm2: float
    pump_inertia_1_kg_mm2: float
    pump_inertia_2_kg_mm2: float
    displacement_1_cm3_per_rev: float
    displacement_2_cm3_per_rev: float
    current_loop_bandwidth_rad_per_s: float
    km1_nms_per_rad: float
    km2_nms_per_rad: float
    kff_kg_m2: float
    tau_ff_s: float
    k_scale_rad_per_s: float
    motor_time_constant_s: Optional[float]
    motor_rated_torque_nm: float
    motor_rated_speed_rpm: float
    pump_max_speed_rpm: float
    # load and hydraulics
    mass_kg: float
    # the mass at each stroke position: [{"x_mm": 295.0, "mass_kg": 9958.0}, ...]; [] = constant
    mass_by_position: List[Dict[str, float]]
    external_force_n: float
    beta_bar: float
    viscous_friction_ns_per_m: float
    c12_m5_per_ns: float
    # dual- and single-pump circuits only (accumulator_pressure_bar in a file is the same key)
    accumulator_precharge_bar: float
    # single-pump circuit only: its pilot-operated check valves
    pilot_ratio: float
    check_valve_crack_bar: float
    c1_m5_per_ns: float
    c2_m5_per_ns: float
    # emulator effects (docs/emulator.md); None = derived from the rig
    pump_dead_band_rpm: float
    pump_slip_m5_per_ns: Optional[float]
    coulomb_friction_n: Optional[float]
    # dual- and single-pump circuits only: their relief valves and cylinder rating
    relief_setting_bar: Optional[float]
    cylinder_rated_pressure_bar: float
    # controller
    kp: float
    p_sum_ref_bar: float
    k_pres_per_bar: float
    k_beta: float
    # model variants
    feedforward: bool
    motor_coupling: bool
    sum_pressure: bool
    motor_model: Literal["full", "first_order"]

class Result:
    """A result: the document the command line prints with ``--json`` (the presentation layer
    builds it once for both), each key an attribute and an item (``r.beta_bar``,
    ``r["beta_bar"]``), a run's signals as numpy arrays (a ``Result`` themselves:
    ``r.signals.x_mm``). ``to_dict()`` is the whole as plain data, equal to ``json.loads`` of
    the command line's document; a ``Result`` equals such a dict. The classes below name the
    fields of each kind of result (for type checkers; at run time each is a ``Result``). A
    result with a ``rig`` field whose rig was read from a file (:meth:`Rig.from_toml`, an
    experiment's rig file) also holds ``rig_defaulted_keys``, the keys that file left out (those
    set since by :meth:`Rig.replace` apart), as the command line's does
    (docs/formats.md#rig-toml)."""

    def __getattr__(self, name: str) -> Any: ...
    def __getitem__(self, key: str) -> Any: ...
    def __contains__(self, key: object) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def __len__(self) -> int: ...
    def keys(self) -> List[str]: ...
    def values(self) -> List[Any]: ...
    def items(self) -> List[Tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...
    def to_dict(self) -> Dict[str, Any]:
        """The whole result as plain data (dicts, lists, floats, None), as ``json.loads``
        reads the command line's ``--json`` document."""
    def column(self, key: str, field: str) -> FloatArray:
        """``field`` of every object in the list ``key`` as floats (None as NaN):
        ``select().column("options", "kp_max")``."""
    def __eq__(self, other: object) -> bool: ...
    def __repr__(self) -> str:
        """The kind and the fields (units in their names); lists and arrays by their length."""

class Margins(Result):
    """Margins of the open loop (the article §2.3.3): ``pumpcyl margins --json``. A ``None``
    margin is infinite (no crossing of that kind). On a single-pump rig it also holds
    ``modes`` (one dict per mode: ``mode``, ``accumulator_chamber`` (1 or 2, the chamber held at
    the accumulator pressure), ``at_rest``, ``loop`` and every margin field below) beside
    ``switching_force_n``, ``valve_band_n``, ``external_force_n``, ``mode_at_rest``,
    ``force_from_switching_n``, ``acceleration_to_switch_m_per_s2`` and ``within_valve_band``
    (docs/circuits.md#modes-in-margins-and-poles)."""

    loop: str
    """The loop analysed, in words."""
    gain_margin_db: Optional[float]
    """Headline gain margin (dB); ``None`` without a phase crossing (infinite)."""
    phase_margin_deg: Optional[float]
    """Headline phase margin (deg); ``None`` without a gain crossing (infinite)."""
    gain_crossover_hz: Optional[float]
    """Frequency of the headline phase margin (Hz)."""
    phase_crossover_hz: Optional[float]
    """Frequency of the headline gain margin (Hz)."""
    delay_margin_s: Optional[float]
    """Smallest delay margin (s); ``None`` without a gain crossing (infinite)."""
    closed_loop_stable: bool
    """Closed-loop asymptotic stability proven from the closed-loop eigenvalues."""
    closed_loop_stability: str
    """"stable", "unstable", or "undecided" (a pole within rounding of the imaginary axis)."""
    crossings: List[Dict[str, Any]]
    """Every crossing by increasing frequency: kind ("gain"/"phase"), frequency_hz,
    magnitude_db, phase_deg, margin (deg at a gain crossing, dB at a phase crossing),
    delay_margin_s, margin_error_bound (the error of margin, in its unit, that the model's
    conditioning allows in double precision: docs/analysis.md#conditioning)."""
    integrators: int
    """Poles at the origin."""
    velocity_gain_per_s: Optional[float]
    """The velocity-loop gain Kv (1/s): lim s*L(s) as s -> 0, the piston's steady velocity per
    metre of error, comparable across circuits (docs/analysis.md#the-velocity-loop-gain);
    ``None`` unless the loop has exactly one integrator."""
    ill_conditioned: bool
    """The model's conditioning does not resolve a headline margin to 0.01 dB / 0.01 deg
    (its crossing's margin_error_bound is larger)."""
    disk: Dict[str, Any]
    """The disk margin of the skew asked for (docs/analysis.md#disk-margins): skew (0 balanced), disk_margin (alpha),
    gain_margin_db and phase_margin_deg (``None`` infinite) and frequency_hz of the worst case
    (``None`` at infinite frequency), as python-control's ``disk_margins``."""
    sensitivity_peak: Dict[str, Any]
    """M_s = max |S|: value and frequency_hz (the disk margin of skew 1 is 1/M_s)."""
    complementary_sensitivity_peak: Dict[str, Any]
    """M_t = max |T|: value and frequency_hz (the disk margin of skew -1 is 1/M_t)."""
    gang_of_four: Optional[Dict[str, Any]]
    """The gang of four with the rig's Kp as the controller (docs/analysis.md#the-gang-of-four):
    ``controller_gain_per_m``, ``sensitivity_peak``, ``complementary_sensitivity_peak``,
    ``load_sensitivity_peak_m`` (max |PS|, m per unit of command) and
    ``noise_sensitivity_peak_per_m`` (max |CS|), each ``value`` and ``frequency_hz``; ``None``
    for a state-space model."""
    sampled: Optional[Dict[str, Any]]
    """The loop as the rig's PLC closes it, sampled with a zero-order hold at ``plc_rate_hz``
    and delayed ``plc_delay_samples`` (docs/analysis.md#sampled-data-margins): every margin
    field above of the sampled loop, ``delay_margin_samples``, ``phase_margin_cost_deg`` and
    ``gain_margin_cost_db`` (continuous less sampled)."""
    simulated_closed_loop: Optional[Dict[str, Any]]
    """Only where it differs from the loop ``closed_loop_stability`` is read on (the rig's
    sum-pressure loop on but open in the analysed loop): the closed loop as ``step`` simulates
    it, with ``stability``, ``rightmost_pole`` ([re 1/s, im rad/s]) and ``rightmost_pole_hz``."""

class Poles(Result):
    """Poles of the position loop: ``pumpcyl poles --json``. Each pole a dict ``re``
    (1/s), ``im`` (rad/s), ``natural_freq_hz``, ``damping`` (``None`` at the origin). On a
    single-pump rig also ``modes`` (one dict per mode: ``mode``, ``accumulator_chamber``,
    ``at_rest``, ``loop`` and the pole fields below) beside the switching fields of
    :class:`Margins` (docs/circuits.md#modes-in-margins-and-poles)."""

    loop: str
    """The loop analysed, in words."""
    open_loop: List[Dict[str, Any]]
    """The eigenvalues of the analysed loop transfer L(s)."""
    open_loop_stable: bool
    """The open loop is provably asymptotically stable."""
    open_loop_stability: str
    """"stable", "unstable", "integrator" or "undecided"."""
    closed_loop: List[Dict[str, Any]]
    """The poles of unity position feedback around L(s)."""
    closed_loop_stable: bool
    """The closed loop is provably asymptotically stable."""
    closed_loop_stability: str
    """"stable", "unstable", "integrator" or "undecided"."""
    closed_loop_with_sum_pressure: Optional[List[Dict[str, Any]]]
    """Only where the rig's sum-pressure loop is on but open in the analysed loop: the closed
    loop as ``step`` simulates it (with ``closed_loop_with_sum_pressure_stable`` and
    ``closed_loop_with_sum_pressure_stability``)."""
    closed_loop_with_sum_pressure_stable: Optional[bool]
    closed_loop_with_sum_pressure_stability: Optional[str]

class Signals(Result):
    """Signals in user units, one numpy value per sample."""

    time_s: FloatArray
    x_ref_mm: FloatArray
    x_mm: FloatArray
    e_mm: FloatArray
    """Control error x_ref - x (mm)."""
    p1_bar: FloatArray
    """Chamber 1 pressure (bar gauge)."""
    p2_bar: FloatArray
    """Chamber 2 pressure (bar gauge)."""
    w1_rpm: FloatArray
    """Motor 1 speed (rpm)."""
    w2_rpm: FloatArray
    """Motor 2 speed (rpm)."""

class Simulation(Result):
    """A closed-loop simulation of :func:`simulate` (the command line's ``simulate`` replays a
    record file instead)."""

    rig: str
    """The rig simulated (its ``repr``)."""
    circuit: Literal["dpm", "dual-pump", "single-pump"]
    """The rig's circuit (docs/circuits.md)."""
    signals: Signals
    rest_offset_mm: float
    """The loop's standing error x_ref - x at rest (mm; docs/simulation.md#the-rest-under-load):
    the run starts at rest under ``x_ref_mm[0]``, the piston this far off it."""
    over_ratings: List[Dict[str, Any]]
    """The drive ratings the response exceeds (docs/simulation.md#drive-ratings)."""
    warnings: List[str]
    """The predicted position leaving the stroke, if it does (docs/emulator.md#end-stops)."""

class Step(Result):
    """A step response (docs/simulation.md#step-metrics): ``pumpcyl step --json``."""

    rig: str
    """The rig simulated, in words (its ``repr`` from Python)."""
    circuit: Literal["dpm", "dual-pump", "single-pump"]
    """The rig's circuit (docs/circuits.md)."""
    step_mm: float
    metrics: Dict[str, Any]
    """step_mm, rise_time_s (None if it never reaches 90 %), overshoot_mm, overshoot_pct,
    peak_time_s, settling_time_s (None if still outside the 2 % band at the end),
    steady_state_error_mm, final_error_mm, and ``ringing`` (gain_margin_db, natural_freq_hz,
    damping_ratio) only when the gain margin is under 1 dB (docs/simulation.md#ringing)."""
    over_ratings: List[Dict[str, Any]]
    """The drive ratings the response exceeds (docs/simulation.md#drive-ratings); each also
    warns (UserWarning)."""
    signals: Signals
    warnings: List[str]
    """The predicted position leaving the stroke, if it does (docs/emulator.md#end-stops)."""

class FrequencyResponse(Result):
    """A frequency response estimated from a sweep record
    (docs/identification.md#frequency-response-from-a-sweep): ``pumpcyl frf RECORD.csv --json``."""

    file: str
    """The record."""
    method: str
    """How it was estimated: the periods of a periodic sweep averaged, or Welch's segments."""
    rate_hz: float
    segment_samples: int
    segments: int
    periods_discarded: int
    """Periods discarded at the start while the loop settles."""
    pooled_lines: int
    averages: float
    """Independent averages behind each estimate."""
    usable_coherence: float
    """The coherence below which a frequency is not used."""
    lowest_frequency_hz: float
    lowest_frequency_reason: str
    closed_loop: Dict[str, Any]
    """x/x_ref: ``points`` (``freq_hz``, ``re``, ``im``, ``magnitude_db``, ``phase_deg``,
    ``coherence``, ``relative_error``, ``band_db``, ``band_deg``)."""
    plant: Optional[Dict[str, Any]]
    """The plant, where the record holds what it needs."""
    distortion: Optional[Dict[str, Any]]
    warnings: List[str]
    """Each also warns (UserWarning)."""
    confidence: float
    """The band's confidence level."""
    band_reference: str
    """Where the band's formula comes from."""
    model: Optional[Dict[str, Any]]
    """The rig's model beside the estimate: ``label``, ``magnitude_db``, ``phase_deg``."""

class Tracking(Result):
    """Sinusoidal tracking (docs/simulation.md#tracking-metrics): ``pumpcyl track --json``."""

    rig: str
    """The rig simulated, in words (its ``repr`` from Python)."""
    circuit: Literal["dpm", "dual-pump", "single-pump", "valve"]
    """The rig's circuit (docs/circuits.md)."""
    cases: List[Dict[str, Any]]
    """One per sine: ``label``, ``metrics`` (freq_hz, amp_mm, max_error_mm, rms_error_mm,
    wave_reduction, rest_offset_mm and ``window``, the periods measured: the periodic steady
    state) and ``over_ratings`` (the drive ratings the run exceeds; each also warns)."""
    warnings: List[str]
    """The predicted position leaving the stroke, if it does (docs/emulator.md#end-stops)."""

class Identification(Result):
    """The answer of :func:`identify`: ``pumpcyl identify --json`` (and result.json)."""

    beta_bar: float
    """Effective bulk modulus (bar)."""
    viscous_friction_ns_per_m: float
    """Viscous friction (N·s/m)."""
    c12_m5_per_ns: float
    """Cross-port leakage (m⁵/(N·s))."""
    c1_m5_per_ns: float
    c2_m5_per_ns: float
    cost_mm2: float
    """Mean over the datasets of the position MSE (mm^2)."""
    stage: int
    """The stage the answer comes from (1, 2; 0 for the local refinement)."""
    index: int
    """Its index in that stage's grid."""
    candidates_evaluated: int
    seconds: float
    refined: bool
    """Whether the local refinement improved on the best grid point."""
    grid_best: Dict[str, Any]
    """The best grid point: beta_bar, viscous_friction_ns_per_m, c12_m5_per_ns, cost_mm2,
    stage, index, and the c1_m5_per_ns, c2_m5_per_ns holding the standstill point there."""
    non_finite: int
    unstable: int
    pruned: int
    stages: List[Dict[str, Any]]
    """Each stage: candidates, evaluated, threshold_mm2, threshold_count, threshold_bounds."""
    top: List[Dict[str, Any]]
    """The best candidates of all stages, best first (as grid_best without the leakages)."""
    experiment: Optional[str]
    """The experiment file; None for ``datasets``."""
    rig: str
    grids: str
    """Where the two grids come from, in words."""
    stage_grids: List[Dict[str, List[float]]]
    """Each stage's grid: [lo, hi, count] per parameter."""
    warnings: List[str]
    identifiable: Dict[str, bool]
    """Per parameter, whether the records bound it (absent when the noise cannot be estimated)."""
    not_identifiable: Dict[str, str]
    """Why, for the parameters the records do not bound."""
    at_search_bound: Dict[str, bool]
    """Per parameter, whether the answer sits at a search bound: the search's limit, not an
    estimate (docs/identification.md)."""

class IdentificationUncertainty(Identification):
    """The fields ``identify(..., uncertainty=True)`` adds (docs/identification.md,
    "Uncertainty")."""

    intervals: Dict[str, List[float]]
    """Per parameter, its profile-likelihood interval [low, high] at ``confidence``."""
    confidence: float
    noise_std_mm: float
    chi2_threshold: float
    samples: int
    residual_autocorrelation: float
    variance_inflation: float
    inflation_by_parameter: Dict[str, float]
    sse_offset_free_mm2: float
    profiles: Dict[str, List[Dict[str, float]]]
    uncertainty_seconds: float

class Advice(Result):
    """Experiment advice: ``pumpcyl advise --json``."""

    point: Dict[str, float]
    point_from_rig: List[str]
    """The parameters whose estimate sat at its search bound: the model is linearised at the
    rig file's value instead, and their current widths are unbounded."""
    identified: Dict[str, float]
    noise_std_mm: float
    variance_inflation: float
    model_error_factor: Dict[str, float]
    """Per parameter name, the factor on its variance for the model error the records'
    disagreement shows (applied to the current widths and every candidate's)."""
    confidence: float
    budget_s: Optional[float]
    """The recording time every candidate is weighed at (s), or None: each candidate one
    record (each candidate's ``duration_s`` and ``repeats`` say what it cost)."""
    z: float
    current: List[Dict[str, Any]]
    candidates: List[Dict[str, Any]]
    skipped: List[str]
    best_for: Dict[str, str]
    """Per parameter name, the label of the candidate that narrows its interval most."""
    ranking_by_parameter: Dict[str, List[Dict[str, Any]]]
    """Per parameter name, the candidates best first: label, log_std, interval, width,
    relative_width."""
    pressure_levels: Optional[Dict[str, Any]]
    """The family of beta(p) models fitted to the experiment's pressure level and the
    ``levels`` given (identified, fits, model, band, next_level), or None for an experiment
    fitted in the frequency domain (docs/bulk-modulus.md#several-pressure-levels)."""
    experiment: str
    seconds: float

class Selection(Result):
    """Which circuit at which pressure level: ``pumpcyl select --json``. Each option names its
    circuit as ``circuit`` (``low_pressure``, ``pressurised``, ``dual_pump``, ``single_pump``,
    ``valve``), ``circuit_kind`` (``dpm``, ``dual-pump``, ``single-pump``, ``valve``) and
    ``pressure_level`` (``low_pressure``, ``pressurised``, ``precharge``, ``supply``;
    docs/select.md#circuits), with ``kp_max`` and its velocity-loop gain ``kv_max_per_s`` (1/s,
    docs/analysis.md#the-velocity-loop-gain)."""

    options: List[Dict[str, Any]]
    min_mean_pressure_bar: Optional[float]
    min_level_bar: Optional[float]
    min_mean_pressure_bracket_bar: Optional[List[float]]
    at_min_mean_pressure: Optional[Dict[str, Any]]
    chosen: Optional[Dict[str, Any]]
    chosen_circuit: Optional[str]
    """The circuit of the answer (``dpm``, ``dual-pump``, ``single-pump``, ``valve``); ``None``
    when no level meets the requirement."""
    verdict: str
    reasons: List[str]
    gas_fraction: Any
    gas_fraction_from: Dict[str, Any]
    rig: Dict[str, Any]
    mode_check: str
    """The single-pump candidates' mode check: ``emulator`` or ``equations``
    (docs/select.md#the-single-pump-circuit)."""
    warnings: List[str]
    """A relief setting that lets a one-motor circuit's chamber go above the cylinder's rating
    (docs/circuits.md#valves); each also warns (UserWarning)."""

class Chatter(Result):
    """Will it chatter: ``pumpcyl chatter --json`` (docs/circuits.md#a-scan-of-the-load)."""

    rig: str
    circuit: str
    """The rig's circuit: "dpm", "dual-pump" or "single-pump" (docs/circuits.md)."""
    verdict: str
    """``chatters``, ``quiet``, or ``no_modes`` for a circuit without modes."""
    answer: str
    """The answer in one line: where it chatters and why, where it is quiet; or why the
    circuit has no modes."""
    switching_force_n: Optional[float]
    valve_band_n: Optional[List[float]]
    external_force_n: float
    mode_at_rest: Optional[int]
    step_mm: float
    waves: List[Dict[str, Any]]
    forces: List[Dict[str, Any]]
    """Each scanned force, increasing: external_force_n, mode_at_start, verdict (``quiet``,
    ``switches``, ``chatters``), switches, switches_after_settling, switches_explained,
    extra_switches, step and waves (each run's numbers)."""
    quiet_ranges_n: List[List[float]]
    chattering_ranges_n: List[List[float]]
    basis: Optional[str]
    """What the emulator used, in words (docs/emulator.md#what-a-user-rig-gets)."""

class Design(Result):
    """The design method (the article §2.2): ``pumpcyl design --json``."""

    analysed_loop: str
    """The loop the gains are designed on: the circuit and, for the single-pump circuit, the
    mode at rest (docs/circuits.md#its-two-modes)."""
    targets: Dict[str, Any]
    kp_max: float
    kp_max_continuous: Optional[float]
    """With ``sampled=True``: the largest Kp at the design point of the continuous loop, to
    tell what the PLC costs (docs/analysis.md#sampled-data-margins); ``None`` otherwise."""
    kv_max_per_s: Optional[float]
    """The velocity-loop gain Kv (1/s) at ``kp_max``: the piston's steady velocity per metre
    of error, comparable across circuits (docs/analysis.md#the-velocity-loop-gain)."""
    kp_max_worst_case: float
    worst_case: Dict[str, Any]
    conditions: List[Dict[str, Any]]
    """Each checked condition: x_mm, mode (the single-pump circuit's 1 or 2, both checked;
    ``None`` for a circuit without modes), mass_kg, p_mean_bar, beta_bar, the margins at
    ``kp_max`` and the condition's own kp_max."""
    kp_recommended: float
    tracking_kp: float
    tracking_kv_per_s: Optional[float]
    """The velocity-loop gain Kv (1/s) at ``tracking_kp``."""
    tracking: List[Dict[str, Any]]
    rest_offset_mm: Optional[float]
    """The loop's standing error x_ref - x at rest at ``tracking_kp`` (mm;
    docs/simulation.md#the-rest-under-load); ``None`` where the loop has no rest."""
    verdict: str
    reasons: List[str]

class RobustDesign(Result):
    """The robust design (docs/design.md#robust-design): ``pumpcyl design --robust --json``."""

    kp_max: float
    kp_max_nominal: float
    deciding: Dict[str, Any]
    worst_case: Dict[str, Any]
    worst_case_nominal: Dict[str, Any]
    loop_answer: Any
    options: Dict[str, Any]
    steps: List[Dict[str, Any]]
    stroke_curves: Any
    region: Dict[str, Any]
    targets: Dict[str, Any]
    verdict: str
    reasons: List[str]
    seconds: float
    identification_seconds: float

class Summary(Result):
    """The article workflow's summary.json (as ``pumpcyl reproduce`` writes it)."""

    emulated_inputs: bool
    note: str
    emulator: Dict[str, Any]
    drive: Dict[str, Any]
    leakage: Dict[str, Any]
    identified: Dict[str, Any]
    record_conditions: Any
    rise_time: Dict[str, Any]
    robustness: Any
    margins: Dict[str, Any]
    gas_fraction: Any
    gas_fraction_article_basis: Any
    article_gas_fraction: Any
    intro_example: Dict[str, Any]
    p_mean_bar: Any
    damping: Any
    stroke: Any
    tracking: Any
    design: Dict[str, Any]
    how_sure: Dict[str, Any]
    which_circuit: Dict[str, Any]
    figure1_circuits: Dict[str, Any]
    sweep_beside_steps: Dict[str, Any]
    valve_or_pump: Dict[str, Any]
    """Step 13: the article's rig with its DPM and with a servo valve sized for the DPM's top
    speed (docs/circuits.md#the-article-s-rig-with-a-valve): top_speed_m_per_s,
    valve_rated_flow_lpm, gas_fraction, targets [PM deg, GM dB], and sides, each with label,
    circuit, set, p_mean_bar, beta_e_bar, resonance_hz, damping_ratio, merritt_hz, kp_max,
    kv_max_per_s and max_error_mm (0.2 Hz, 35 mm); at_kp_max, each side's margins and model
    step at its kp_max (the figures bode_valve_or_pump and step_valve_or_pump)."""
    energy: Dict[str, Any]
    """Step 14: the article's three sines on every circuit of the report with its power account
    (docs/energy.md#in-the-report): cycle, noise, circuits (each with label, circuit, set,
    summary, losses_j, max_error_mm, drives, defaults_assumed, warnings),
    dpm_saves_vs_valve_fraction and published (the figure energy_per_circuit)."""
    seconds: float

class DutyCycle(Result):
    """A duty cycle on the emulated rig: ``pumpcyl cycle --json`` (docs/energy.md#duty-cycles)."""

    rig: str
    circuit: str
    """The rig's circuit: "dpm", "dual-pump", "single-pump" or "valve" (docs/circuits.md)."""
    cycle: Dict[str, Any]
    """``kind`` ("article-sines", "steps" or the profile's file) and ``duration_s``."""
    emulated: str
    effects: bool
    noise: bool
    summary: Dict[str, float]
    """``duration_s``, ``drawn_j``, ``regenerated_j``, ``net_j``, ``work_out_j``,
    ``load_work_j``, ``losses_j``, ``stored_change_j``, ``efficiency``, ``mean_power_w``,
    ``peak_power_w``."""
    energy: Dict[str, Any]
    """The account by kind, as ``emulate(energy=True)``'s (docs/energy.md#over-a-run)."""
    drives: List[Dict[str, Any]]
    """Each motor: ``rms_torque_nm``, ``peak_torque_nm``, ``rms_speed_rpm``,
    ``peak_speed_rpm`` against ``rated_torque_nm``, ``peak_torque_limit_nm``,
    ``rated_speed_rpm``, ``pump_max_speed_rpm``; ``exceeds`` names what it is too small for."""
    defaults_assumed: Dict[str, float]
    """The drives' electrical keys at pumpcyl's defaults, which the energies rest on."""
    basis: str
    warnings: List[str]
    columns: Result
    """The record with its power columns (docs/formats.md#power-columns)."""

class Emulated(Result):
    """An emulated record: ``pumpcyl emulate --json``."""

    experiment: str
    rig: str
    circuit: str
    """The rig's circuit: "dpm", "dual-pump" or "single-pump" (docs/circuits.md)."""
    samples: int
    basis: str
    """What the emulator used on the rig, in words (docs/emulator.md#what-a-user-rig-gets)."""
    warnings: List[str]
    end_stop: Optional[str]
    """The first end stop the piston met, if any (docs/emulator.md#end-stops)."""
    columns: Result
    """The record's columns as numpy arrays, named as its CSV names them
    (docs/formats.md#record-csv; a drive step: time_s, w_ref_rpm, w_rpm)."""

class Dataset:
    """One record to fit: time (s), reference and measured position (mm), with the keys of an
    experiment file's ``[[dataset]]``: the experiment's position gain Kp (normalised command
    per metre), mass (kg), the fit-window end (s) a step record needs, and ``kind``
    (``"step"`` or ``"sweep"``; absent, ``method="frequency"`` tells them by the reference);
    ``sweep``: the sweep that made the record, a dict of the ``[dataset.sweep]`` keys
    (``kind``, ``amplitude_mm``, ``from_hz``, ``to_hz``, ``at_s``, ``periods``, ``lines``,
    ``levels``, ``sweep_s``, ``settle_periods``), checked against the reference."""

    def __init__(
        self,
        t_s: ArrayLike,
        x_ref_mm: ArrayLike,
        x_mm: ArrayLike,
        *,
        kp: float,
        mass_kg: float,
        fit_end_s: Optional[float] = None,
        kind: Optional[Literal["step", "sweep"]] = None,
        sweep: Optional[Dict[str, Any]] = None,
        name: str = "dataset",
    ) -> None: ...

def margins(rig: Rig, *, sum_pressure_closed: bool = False, skew: float = 0.0) -> Margins:
    """Gain, phase and delay margins of the position loop (the article §2.3.3), every crossing,
    closed-loop stability, the disk margin of skew ``skew`` with M_s and M_t, and the same of
    the loop as the rig's PLC samples it (``sampled``)."""

def poles(rig: Rig, *, sum_pressure_closed: bool = False) -> Poles:
    """The poles of the position loop, open and closed (and as simulated where the
    sum-pressure loop is on), with natural frequency and damping: ``pumpcyl poles --json``."""

def state_space(
    rig: Rig, loop: Loop = "open", *, sum_pressure_closed: Optional[bool] = None
) -> Tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """(A, B, C, D), SI units. ``loop="open"``: input the position error (m), output x (m),
    sum-pressure loop open unless ``sum_pressure_closed``; ``loop="closed"``: x_ref (m) -> x
    (m), sum-pressure loop as the rig's ``sum_pressure`` key unless given."""

def bode(
    rig: Rig,
    f_hz: Union[float, ArrayLike],
    loop: Loop = "open",
    *,
    sum_pressure_closed: Optional[bool] = None,
) -> Tuple[FloatArray, FloatArray]:
    """Magnitude (dB) and unwrapped phase (deg) at ``f_hz`` (Hz, positive, increasing; a
    single frequency gives arrays of one value)."""

def _loop_names(rig: Rig, loop: Loop = "open") -> Tuple[List[str], List[str], List[str]]:
    """Names of the states, inputs and outputs of ``state_space(rig, loop)``, as the MATLAB
    export names them (for :func:`pumpcyl.to_control`)."""

def simulate(rig: Rig, t_s: ArrayLike, x_ref_mm: ArrayLike) -> Simulation:
    """Closed loop driven by ``x_ref_mm`` (mm) sampled at ``t_s`` (s) and held between
    samples (exact zero-order hold), from rest at x = x_ref_mm[0]; ``.signals`` holds them."""

def step(
    rig: Rig, step_mm: float = 5.0, *, duration_s: float = 4.0, rate_hz: float = 100.0
) -> Step:
    """Response to a position step of ``step_mm`` (mm) from x0, sampled at ``rate_hz`` (Hz)
    for ``duration_s`` (s), as ``pumpcyl step --json``. A step smaller than 0.05 mm in size warns (``UserWarning``):
    ``step_mm`` is in millimetres, not metres."""

def track(
    rig: Rig,
    freq_hz: Optional[float] = None,
    amp_mm: Optional[float] = None,
    *,
    periods: float = 3.0,
    rate_hz: float = 100.0,
) -> Tracking:
    """Tracking of a sine of ``freq_hz`` (Hz) and ``amp_mm`` (mm) about x0, or of the
    article's three sines when both are ``None``, over ``periods`` whole periods sampled at
    ``rate_hz`` (Hz): the metrics of the periodic steady state, as ``pumpcyl track --json``."""

GridDict = Dict[str, Sequence[float]]

def identify(
    experiment: Optional[Union[str, PathLike[str]]] = None,
    *,
    datasets: Optional[Sequence[Dataset]] = None,
    standstill: Optional[Dict[str, float]] = None,
    rig: Optional[Rig] = None,
    grids: Optional[Literal["article"]] = None,
    grid: Optional[GridDict] = None,
    refined_grid: Optional[Union[GridDict, Literal[False]]] = None,
    auto_refine: Optional[bool] = None,
    local_refinement: Optional[bool] = None,
    threshold_mm2: Optional[float] = None,
    top: int = 20,
    progress: Union[None, bool, Callable[[int, int], None]] = None,
    allow_long_run: bool = False,
    shard: Optional[Tuple[int, int]] = None,
    uncertainty: bool = False,
    confidence: float = 0.95,
    method: Optional[Literal["time", "frequency"]] = None,
) -> Union[Identification, str]:
    """Grid identification of beta (bar), b (N·s/m) and c12 (m⁵/(N·s)) (the article §2.4.4)
    from an experiment TOML file, or from ``datasets`` with ``standstill=dict(w1_rpm=...,
    w2_rpm=..., p1_bar=...)`` and ``rig``. Grids are dicts {beta_bar,
    viscous_friction_ns_per_m, c12_m5_per_ns} of lists (default: the file's; for ``datasets``
    the first centred on the rig's values, the second on the first stage's best;
    ``grids="article"`` the article's two, as the file key);
    ``refined_grid=False`` skips the second stage. Releases the GIL; Ctrl-C stops it;
    ``progress=True`` prints progress on stderr (redrawn on a terminal; a line per tenth of
    the work in a pipe or a notebook), a callable gets (done, total).

    ``shard=(i, n)`` evaluates only slice i of n of the experiment file's grids and returns
    the partial result as JSON text, what ``pumpcyl identify --shard i/n`` writes
    (docs/identification.md#sharding), for :func:`identify_merge`; it needs an experiment file
    with fixed grids and no grid arguments. ``uncertainty=True`` adds the profile-likelihood
    intervals at ``confidence`` as ``pumpcyl identify --uncertainty --json`` does:
    the fields of :class:`IdentificationUncertainty`. ``method="frequency"`` (or the file's
    ``method = "frequency"``) fits the sweep records (the file's, or ``datasets``, as its
    ``[[dataset]]`` entries) by their frequency response, with any step records beside them,
    and adds the ``intervals`` at ``confidence``: the keys of
    ``pumpcyl identify --frequency --uncertainty --json``."""

def identify_merge(shards: Sequence[str]) -> Identification:
    """Merge the partial results of ``identify(experiment, shard=(i, n))``, i = 1..n, in any
    order, into the identification of one unsharded run, as ``pumpcyl identify-merge --json``
    with its checks: refused when a shard is missing or twice, from another run or options, or
    edited. The experiment file is read again from the path the shards name. Releases the
    GIL."""

def frf(
    record: Union[str, PathLike[str]],
    *,
    rig: Optional[Rig] = None,
    segment_s: Optional[float] = None,
) -> FrequencyResponse:
    """Closed-loop frequency response x/x_ref of a sweep record with its coherence and 95 %
    band at each frequency (``closed_loop.points``: ``freq_hz``, ``re``, ``im``,
    ``magnitude_db``, ``phase_deg``, ``coherence``, ``relative_error``, ``band_db``,
    ``band_deg``) and ``rig``'s model beside it (default: the article's rig), as
    ``pumpcyl frf RECORD.csv --json``. A periodic sweep found in the record is averaged over
    its periods; anything else by Welch's method (``segment_s``: its segment length, s)."""

def emulate(
    experiment: Literal["step", "sine", "drive-step", "standstill"],
    rig: Optional[Rig] = None,
    *,
    from_mm: Optional[float] = None,
    to_mm: Optional[float] = None,
    at_s: float = 0.5,
    amplitude_mm: float = 20.0,
    freq_hz: float = 0.25,
    motor: int = 1,
    to_rpm: float = 500.0,
    duration_s: Optional[float] = None,
    rate_hz: Optional[float] = None,
    seed: int = 1,
    noise: bool = True,
    effects: bool = True,
    allow_long_run: bool = False,
    energy: bool = False,
    **overrides: Union[float, bool, str],
) -> Emulated:
    """A record from the nonlinear rig emulator (docs/emulator.md), as ``pumpcyl emulate
    --json``: the experiment and its settings as the command line's options, ``rig=None`` the
    emulator's own rig, keyword ``overrides`` its keys (as ``--set``); the record's columns as
    numpy arrays in ``.columns`` and what the emulator used in ``.basis``. ``energy=True``
    adds ``energy``: the power account integrated over the record (``energy_in_j``,
    ``sources_j``, ``work_out_j``, ``losses_j``, ``stored_j``, ``stored_change_j``,
    ``imbalance_j``; docs/energy.md#over-a-run), as ``--energy``; the record is the same."""

def advise(
    experiment: Union[str, PathLike[str]],
    *,
    confidence: float = 0.95,
    candidates: Optional[Union[str, PathLike[str]]] = None,
    budget_s: Optional[float] = None,
    levels: Optional[Sequence[Union[str, PathLike[str]]]] = None,
) -> Advice:
    """Experiment advice: identify the experiment's records, then rank candidate further
    records (steps, sinusoids, gains; the TOML file ``candidates`` or the defaults) by the
    expected interval widths of beta, b and c12, as ``pumpcyl advise --json``: ``best_for``
    and ``ranking_by_parameter`` are keyed by parameter name. ``levels``, experiments at
    other pressure levels, join the experiment's own in ``pressure_levels`` (``advise
    --level``)."""

def reproduce(
    out: Optional[Union[str, PathLike[str]]] = None,
    *,
    progress: bool = False,
    force: bool = False,
) -> Summary:
    """The article's workflow on the embedded EMULATED records (as ``pumpcyl reproduce``):
    with ``out``, the result folder (report.html, summary.json, figures/, records/,
    identification/) written whole or not at all; returns summary.json as a ``Result``. Ctrl-C
    raises KeyboardInterrupt; ``progress=True`` prints each step on stderr. Files of yours in
    ``out`` are kept (a warning names them); ``force=True`` writes over one at a path of the
    result, or into a non-empty folder that holds no earlier result
    (docs/formats.md#result-folders)."""

def gas_fraction(beta_bar: float, p_mean_bar: float, *, beta_oil_bar: float = 17000.0) -> float:
    """Gas fraction X giving ``beta_bar`` (bar) at mean pressure ``p_mean_bar`` (bar)
    (the article §3.1)."""

def effective_beta(x: float, p_bar: float, *, beta_oil_bar: float = 17000.0) -> float:
    """Effective bulk modulus (bar) at mean pressure ``p_bar`` (bar) for gas fraction ``x``
    (0 to 1); a value outside its range (a NaN too) raises :class:`PumpcylError` naming it."""

def select(
    application: Optional[Union[str, PathLike[str]]] = None,
    *,
    rig: Optional[Rig] = None,
    circuits: Sequence[str] = (),
    kp: Optional[float] = None,
    mode_check: str = "emulator",
    experiment: Optional[Union[str, PathLike[str]]] = None,
    confidence: float = 0.95,
    allow_long_run: bool = False,
    energy: bool = False,
    progress: Union[None, bool, Callable[[int, int], None]] = None,
    **overrides: Any,
) -> Selection:
    """Which circuit, at which pressure level (docs/select.md): the application file (None =
    the article's application) with application keys as keyword overrides and ``rig``
    replacing its rig (as ``--rig``: the gas fraction and the loads the application leaves out
    follow it, docs/select.md#the-rig-and-the-gas-fraction); ``kp`` fixes the gain;
    ``experiment`` (an experiment TOML file) gives the gas-fraction range from its records'
    interval of beta at ``confidence``. As ``pumpcyl select --json``; a numpy array over the
    options with ``column("options", "kp_max")`` (``standing_loss_w`` NaN where a candidate
    cavitates). ``progress`` as for :func:`identify`, over the load × level cases. The
    circuits tried are the keyword ``circuits`` (e.g. ``circuits=["dpm", "single-pump"]``, as
    ``--circuits``; absent: every circuit the rig's components allow), the one-motor circuits at
    each pre-charge of ``precharge_bar``, the valve circuit at each supply of ``supply_bar``
    (docs/select.md#circuits). ``mode_check`` names the
    single-pump candidates' mode check, as ``--mode-check``: ``"emulator"`` (the emulated step
    and waves, the default) or ``"equations"`` (docs/select.md#the-single-pump-circuit); each
    option's ``mode_switches``, ``switches_after_settling`` and ``oscillation_amplitude_mm``
    are its numbers (``None`` where it did not run). ``energy=True`` (``--energy``) adds
    ``energy``: each circuit that meets run through the application's waves on the emulated
    rig, the cheapest, and what the chosen circuit costs against it and saves against the valve
    (docs/select.md#energy)."""
    ...

def chatter(
    rig: Rig,
    *,
    forces_n: Optional[Sequence[float]] = None,
    from_n: Optional[float] = None,
    to_n: Optional[float] = None,
    points: Optional[int] = None,
    waves: Sequence[Tuple[float, float]] = (),
    allow_long_run: bool = False,
    progress: Union[None, bool, Callable[[int, int], None]] = None,
) -> Chatter:
    """Will it chatter (docs/circuits.md#a-scan-of-the-load): the single-pump rig's emulated
    5 mm step and each of ``waves`` ((freq_hz, amp_mm) about x0) at each external force, as
    ``pumpcyl chatter --json``: ``verdict``, ``answer``, ``switching_force_n``,
    ``valve_band_n``, ``forces`` (switches, those after settling, those the references explain,
    the extra ones), ``quiet_ranges_n``, ``chattering_ranges_n``. The forces: ``forces_n``, or
    ``points`` evenly from ``from_n`` to ``to_n``, or by default 13 about the switching force.
    A circuit without modes answers ``no_modes`` and runs nothing. Beyond 10^7 emulated
    controller steps only with ``allow_long_run=True``; ``progress`` as for :func:`identify`."""
    ...

def cycle(
    rig: Optional[Rig] = None,
    cycle: str = "article-sines",
    *,
    step_mm: float = 20.0,
    hold_s: float = 2.0,
    seed: int = 1,
    noise: bool = True,
    effects: bool = True,
    allow_long_run: bool = False,
    progress: Union[None, bool, Callable[[int, int], None]] = None,
) -> DutyCycle:
    """A duty cycle on the emulated rig (docs/energy.md#duty-cycles), as ``pumpcyl cycle
    --json``: ``cycle`` "article-sines", "steps" (``step_mm`` about x0, each level held
    ``hold_s``) or a profile's file (``time_s``, ``x_ref_mm``, optionally
    ``external_force_n``). The energy drawn, returned and lost by kind, the load's work and the
    efficiency, each motor against its ratings, and the record with its power columns."""
    ...

def fmu(
    rig: Optional[Rig],
    path: Union[str, PathLike[str]],
    model: str = "emulator",
    *,
    controller: str = "article",
    effects: bool = True,
    energy: bool = False,
    force: bool = False,
) -> PathLike[str]:
    """Write the rig emulator (``model="emulator"``) or the linear model (``"linear"``) as an
    FMU (FMI 2.0 Co-Simulation, Linux x86-64; docs/fmu.md), as ``pumpcyl fmu`` does;
    ``energy=True`` adds the emulator's energy outputs (docs/fmu.md#energy).
    ``controller="article"``: the input is the position reference ``x_ref_m``;
    ``"external"``: the motor speed commands are the inputs. ``rig=None`` takes the emulator's
    own rig or the article's (linear). A read-only file at ``path`` is refused unless
    ``force=True``. Returns ``path``."""
    ...

def design(
    rig: Optional[Rig] = None,
    *,
    target_pm_deg: float = 34.0,
    target_gm_db: float = 6.0,
    stroke_mm: float = 50.0,
    p_mean_bar: Sequence[float] = (),
    p_beta_bar: Optional[float] = None,
    mass_kg: Sequence[float] = (),
    waves: Sequence[Tuple[float, float]] = (),
    robust: bool = False,
    experiment: Optional[Union[str, PathLike[str]]] = None,
    confidence: float = 0.95,
    allow_long_run: bool = False,
    progress: Union[None, bool, Callable[[int, int], None]] = None,
    sampled: bool = False,
) -> Union[Design, RobustDesign]:
    """The design method (the article §2.2): kp_max, kp_max_worst_case, worst_case,
    conditions, tracking (each wave's periodic steady state: max_error_mm, rms_error_mm,
    wave_reduction and ``window``, whose ``steady_state`` is True), verdict, reasons (as
    ``pumpcyl design --json``, whose defaults these
    are: PM 34 deg (the phase margin the article reaches at Kp 25, §3.3) and GM 6 dB (pumpcyl's
    choice; docs/design.md#targets), x0 +/- 50 mm, beta holding at ``p_beta_bar`` (None: the
    rig's own anchor, where its loop rests, docs/bulk-modulus.md#the-anchor; the article's
    4.4 bar on its rig); no
    ``p_mean_bar`` (bar) or ``mass_kg`` (kg): the rig's beta and mass only; ``waves``:
    (freq_hz, amp_mm) pairs to track). ``robust=True``:
    the robust design over the confidence region of ``experiment``'s records, or the stated
    default uncertainty around ``rig`` (as ``pumpcyl design --robust --json``): kp_max,
    kp_max_nominal, deciding, worst_case, steps, region, verdict, reasons. ``progress`` as for
    :func:`identify`, over the nominal design's conditions."""
