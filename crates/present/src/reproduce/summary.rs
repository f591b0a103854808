//! summary.json, typed: every number of the workflow under stable keys, with the unit in each
//! key (docs/README.md). The article's printed values stand under `article` beside pumpcyl's,
//! the emulator's truth under `emulator_truth`. Margins are the core's [`Margins`], whole (a
//! `null` margin is infinite: no crossing of that kind).

use pumpcyl::design::robust::{Deciding, LoopStep, WorstCase};
use pumpcyl::design::{Targets, Verdict};
use pumpcyl::ident::{Assessment, Width};
use pumpcyl::lti::Margins;
use pumpcyl::response::TrackMetrics;
use serde::Serialize;

pub use super::case::Case;
pub use super::energy::{CircuitCycle, EnergyStudy, Published};
pub use super::figure1_circuits::{Chatter, CircuitRun, Figure1Circuits, ModeMargins, Wave};
pub use super::valve_or_pump::{Side, ValveOrPump};

/// Every number of the workflow.
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    /// Always true: the records are emulated, not the article's measurements.
    pub emulated_inputs: bool,
    /// The notice that says so.
    pub note: String,
    /// What the emulator used for each embedded record (docs/emulator.md#what-a-user-rig-gets).
    pub emulator: Vec<EmulatorUsed>,
    /// Step 1: the drive gain.
    pub drive: Drive,
    /// Step 2: the leakages from the standstill record.
    pub leakage: Leakage,
    /// Step 2: the identification.
    pub identified: Identified,
    /// The emulated records' operating conditions beside the article's.
    pub record_conditions: Conditions,
    /// The identification step's rise time (the article's Figure 6).
    pub rise_time: RiseTime,
    /// Step 3: the robustness record.
    pub robustness: Robustness,
    /// Step 4: the margins against the mean chamber pressure.
    pub margins: MarginsStudy,
    /// Gas fraction from the identified β at the records' mean pressure.
    pub gas_fraction: f64,
    /// Gas fraction on the article's basis: its β 165 bar at 4.4 bar.
    pub gas_fraction_article_basis: f64,
    /// The article's printed gas fraction.
    pub article_gas_fraction: f64,
    /// The introduction's example: β_e at 100 and 1 bar for a gas fraction of 1 %.
    pub intro_example: IntroExample,
    /// The identification records' mean chamber pressure (bar).
    pub p_mean_bar: f64,
    /// Step 5: the damping studies.
    pub damping: Damping,
    /// Step 6: the stroke study.
    pub stroke: Stroke,
    /// Step 7: the sinusoidal tracking, one entry a wave.
    pub tracking: Vec<Tracking>,
    /// Step 8: the design check (the article §2.2).
    pub design: DesignCheck,
    /// Step 9: how sure the identification is.
    pub how_sure: HowSure,
    /// Step 10: which circuit, before the rig was built and after the identification.
    pub which_circuit: WhichCircuit,
    /// Step 11: the article's Figure 1 circuits on its own application.
    pub figure1_circuits: Figure1Circuits,
    /// Step 12: a sweep beside the steps (pumpcyl's own study, on emulated records).
    pub sweep_beside_steps: SweepBeside,
    /// Step 13: the article's rig with its DPM and with a servo valve (pumpcyl's own study of
    /// the article's introduction, §3.2 and §4).
    pub valve_or_pump: ValveOrPump,
    /// Step 14: the energy of the article's three sines on every circuit of the report
    /// (pumpcyl's own study of the article's introduction; docs/energy.md).
    pub energy: EnergyStudy,
    /// Wall-clock time of the workflow (s).
    pub seconds: f64,
}

/// One embedded record and what the emulator used to make it.
#[derive(Debug, Clone, Serialize)]
pub struct EmulatorUsed {
    /// The record's file name in records/.
    pub record: String,
    /// The emulator's bulk modulus, mass law, limits and defaults, in words.
    pub basis: String,
}

/// The operating conditions of the emulated records beside the article's.
#[derive(Debug, Clone, Serialize)]
pub struct Conditions {
    /// The emulated records' sum-pressure set-point (bar).
    pub p_sum_ref_bar: f64,
    /// The article's (bar).
    pub article_p_sum_ref_bar: f64,
    /// The emulated standstill record's mean motor speeds w1, w2 (rpm).
    pub standstill_w_rpm: [f64; 2],
    /// Its mean chamber 1 pressure (bar).
    pub standstill_p1_bar: f64,
    /// The article's standstill speeds (rpm).
    pub article_standstill_w_rpm: [f64; 2],
    /// The article's standstill p1 (bar).
    pub article_standstill_p1_bar: f64,
    /// p2 from the article's p1 by the force balance (bar).
    pub article_standstill_p2_bar: f64,
    /// The emulated identification step's mean p1, p2 (bar).
    pub step_mean_p_bar: [f64; 2],
    /// The article's (bar).
    pub article_step_mean_p_bar: [f64; 2],
}

/// The 10–90 % rise time of the identification step.
#[derive(Debug, Clone, Serialize)]
pub struct RiseTime {
    /// The LTI model of the default rig, the article's parameters (s).
    pub model_s: Option<f64>,
    /// The LTI model of the identified rig (s).
    pub identified_model_s: Option<f64>,
    /// The emulated record (s).
    pub emulated_s: Option<f64>,
    /// The article's (s).
    pub article_s: f64,
}

/// The article introduction's example of the gas-fraction model.
#[derive(Debug, Clone, Serialize)]
pub struct IntroExample {
    /// The gas fraction (1).
    pub gas_fraction: f64,
    /// β_e at 100 bar (bar).
    pub beta_100bar: f64,
    /// β_e at 1 bar (bar).
    pub beta_1bar: f64,
    /// Their ratio.
    pub ratio: f64,
    /// The article's "about 6300 bar".
    pub article_beta_100bar: f64,
    /// The article's "about 100 bar".
    pub article_beta_1bar: f64,
    /// The article's ratio.
    pub article_ratio: f64,
    /// β_e at 100 bar over the article's identified β (165 bar): its §4 reduction.
    pub forty_fold: f64,
    /// The article's "approximately forty-fold".
    pub article_forty_fold: f64,
}

/// The drive gain from the drive step (the article §2.4.1).
#[derive(Debug, Clone, Serialize)]
pub struct Drive {
    /// Km (N·m·s/rad).
    pub km_nms_per_rad: f64,
    /// Fit error (rpm²).
    pub mse_rpm2: f64,
    /// The article's Km (N·m·s/rad).
    pub article_km_nms_per_rad: f64,
}

/// The standstill point and the leakages it gives at the identified c12.
#[derive(Debug, Clone, Serialize)]
pub struct Leakage {
    /// Motor/pump 1 speed (rpm).
    pub w1_rpm: f64,
    /// Motor/pump 2 speed (rpm).
    pub w2_rpm: f64,
    /// Chamber 1 pressure (bar gauge).
    pub p1_bar: f64,
    /// Chamber 2 pressure from the force balance (bar gauge).
    pub p2_bar: f64,
    /// c1 (m⁵/(N·s)).
    pub c1_m5_per_ns: f64,
    /// c2 (m⁵/(N·s)).
    pub c2_m5_per_ns: f64,
    /// The article's c1 and c2.
    pub article: ChamberLeakages,
}

/// Chamber leakages (m⁵/(N·s)).
#[derive(Debug, Clone, Serialize)]
pub struct ChamberLeakages {
    /// c1 (m⁵/(N·s)).
    pub c1_m5_per_ns: f64,
    /// c2 (m⁵/(N·s)).
    pub c2_m5_per_ns: f64,
}

/// The identified parameters.
#[derive(Debug, Clone, Serialize)]
pub struct Identified {
    /// β (bar).
    pub beta_bar: f64,
    /// b (N·s/m).
    pub viscous_friction_ns_per_m: f64,
    /// c12 (m⁵/(N·s)).
    pub c12_m5_per_ns: f64,
    /// The cost there (mm²).
    pub cost_mm2: f64,
    /// The first grid's best cost and threshold set.
    pub first_grid: FirstGrid,
    /// The refined grid's best point before the local refinement.
    pub grid_only: GridOnly,
    /// Candidates evaluated over both grids.
    pub candidates_evaluated: u64,
    /// What the records were emulated with.
    pub emulator_truth: BetaC12,
    /// The article's printed values.
    pub article: ArticleIdentified,
    /// The leakages at the identified c12.
    pub leakage: Leakage,
}

/// The first grid's answer beside the article's.
#[derive(Debug, Clone, Serialize)]
pub struct FirstGrid {
    /// Its best cost (mm²).
    pub best_cost_mm2: f64,
    /// Candidates below the threshold (0.25 mm²).
    pub below_threshold: u64,
    /// Bounds [lo, hi] of β (bar), b (N·s/m) and c12 (m⁵/(N·s)) over those candidates.
    pub bounds: Option<[[f64; 2]; 3]>,
    /// The article's best cost (mm²).
    pub article_best_cost_mm2: f64,
    /// The article's count below the threshold.
    pub article_below_threshold: u64,
    /// The article's bounds, as `bounds`.
    pub article_bounds: [[f64; 2]; 3],
}

/// The refined grid's best point alone, the article's method (no Nelder–Mead after it).
#[derive(Debug, Clone, Serialize)]
pub struct GridOnly {
    /// β (bar).
    pub beta_bar: f64,
    /// b (N·s/m).
    pub viscous_friction_ns_per_m: f64,
    /// c12 (m⁵/(N·s)).
    pub c12_m5_per_ns: f64,
    /// Its cost (mm²).
    pub cost_mm2: f64,
    /// Whether each parameter lies on its grid axis's lowest or highest value.
    pub on_edge: PerParameter<bool>,
    /// The refined grid's best point on the same records emulated again with the emulator's
    /// effects off, each alone, and all (why the grid misses the truth).
    pub bias: Vec<BiasCase>,
}

/// The refined grid's best point on the fitted records emulated one way.
#[derive(Debug, Clone, Serialize)]
pub struct BiasCase {
    /// How the records were emulated.
    pub records: String,
    /// β (bar).
    pub beta_bar: f64,
    /// b (N·s/m).
    pub viscous_friction_ns_per_m: f64,
    /// c12 (m⁵/(N·s)).
    pub c12_m5_per_ns: f64,
    /// Its cost (mm²).
    pub cost_mm2: f64,
}

/// A bulk modulus and a cross-port leakage.
#[derive(Debug, Clone, Serialize)]
pub struct BetaC12 {
    /// β (bar).
    pub beta_bar: f64,
    /// c12 (m⁵/(N·s)).
    pub c12_m5_per_ns: f64,
}

/// The article's identified values.
#[derive(Debug, Clone, Serialize)]
pub struct ArticleIdentified {
    /// β (bar).
    pub beta_bar: f64,
    /// b (N·s/m).
    pub viscous_friction_ns_per_m: f64,
    /// c12 (m⁵/(N·s)).
    pub c12_m5_per_ns: f64,
    /// Its cost (mm²).
    pub cost_mm2: f64,
}

/// The robustness record's grid answer.
#[derive(Debug, Clone, Serialize)]
pub struct Robustness {
    /// β (bar).
    pub beta_bar: f64,
    /// c12 (m⁵/(N·s)).
    pub c12_m5_per_ns: f64,
    /// Its cost (mm²).
    pub cost_mm2: f64,
    /// The cost at the article's values (mm²).
    pub cost_at_article_values_mm2: f64,
    /// The β the record was emulated with (bar).
    pub emulator_truth_beta_bar: f64,
    /// The article's values.
    pub article: BetaC12,
}

/// The margins against the mean chamber pressure on the article's Table 1 rig (the basis of
/// every number compared with the article's) and on the rig identified from the records.
#[derive(Debug, Clone, Serialize)]
pub struct MarginsStudy {
    /// The rig `default_rig`, `p1bar`, `p_fit` and `p10bar` are on, in words.
    pub rig: String,
    /// The article's Table 1 rig (β 165 bar at 4.4 bar).
    pub default_rig: Margins,
    /// That rig at 1 bar, with the Kp readings of the article's claim there.
    pub p1bar: ArticleAtPressure,
    /// … at the pressure of its β (4.4 bar).
    pub p_fit: AtPressure,
    /// … at 10 bar, with the Kp readings of the article's claim there.
    pub p10bar: ArticleAtPressure,
    /// The same study on the rig identified from the records.
    pub identified_rig: IdentifiedPressures,
    /// The article's extrapolation beside the other models of β(p) fitted to the same 165 bar
    /// at 4.4 bar (docs/bulk-modulus.md#a-family-of-models).
    pub models: Vec<ModelExtrapolation>,
}

/// One model of β(p) through the article's reading: β_e at 1 and 10 bar, and the lowest mean
/// chamber pressure at which the article's loop (Table 1, Kp 25) meets pumpcyl's default
/// targets under it.
#[derive(Debug, Clone, Serialize)]
pub struct ModelExtrapolation {
    /// The model and its parameters.
    #[serde(flatten)]
    pub model: pumpcyl::bulk::BulkModel,
    /// Its gas fraction through 165 bar at 4.4 bar.
    pub gas_fraction: f64,
    /// β_e at 1 bar (bar).
    pub beta_1bar: f64,
    /// β_e at 10 bar (bar).
    pub beta_10bar: f64,
    /// The lowest mean chamber pressure (bar, to 0.01 bar) at which the Table 1 rig at Kp 25
    /// has PM ≥ 34° and GM ≥ 6 dB; `None` where none up to 100 bar does.
    pub lowest_level_bar: Option<f64>,
}

/// The pressure study on the rig identified from the records.
#[derive(Debug, Clone, Serialize)]
pub struct IdentifiedPressures {
    /// The rig, in words.
    pub rig: String,
    /// Its gas fraction, from the identified β at the records' mean pressure (1).
    pub gas_fraction: f64,
    /// Its margins as identified.
    pub nominal: Margins,
    /// At 1 bar.
    pub p1bar: AtPressure,
    /// At the records' mean pressure.
    pub p_mean: AtPressure,
    /// At 10 bar.
    pub p10bar: AtPressure,
}

/// Margins at a mean chamber pressure.
#[derive(Debug, Clone, Serialize)]
pub struct AtPressure {
    /// Mean chamber pressure (bar).
    pub p_bar: f64,
    /// β_e there (bar).
    pub beta_bar: f64,
    /// The margins.
    #[serde(flatten)]
    pub margins: Margins,
}

/// Margins at a mean chamber pressure of the article's Table 1 rig, with the readings of the
/// article's claim there.
#[derive(Debug, Clone, Serialize)]
pub struct ArticleAtPressure {
    /// The margins.
    #[serde(flatten)]
    pub at: AtPressure,
    /// The Kp readings and the article's printed margins.
    #[serde(flatten)]
    pub article: ArticleBasis,
}

/// The Kp that keeps a margin at a pressure, and the article's printed margins there.
#[derive(Debug, Clone, Serialize)]
pub struct ArticleBasis {
    /// The Kp that keeps the 4.4 bar PM (pumpcyl's, 33.5°).
    pub kp_same_pm: f64,
    /// Its change against the rig's Kp (fraction).
    pub kp_change: f64,
    /// The fraction of the rig's Kp that keeps the 4.4 bar GM (the article's reading at 1 bar).
    pub kp_same_gm_ratio: f64,
    /// The Kp that meets the article's printed PM (34°).
    pub kp_article_pm: f64,
    /// Its change against the rig's Kp (fraction; the article's reading at 10 bar).
    pub kp_article_pm_change: f64,
    /// The GM at that Kp (dB).
    pub gain_margin_at_kp_article_pm_db: f64,
    /// The article's printed margins.
    pub article: GmPm,
}

/// A gain and a phase margin as printed.
#[derive(Debug, Clone, Serialize)]
pub struct GmPm {
    /// GM (dB).
    pub gain_margin_db: f64,
    /// PM (deg).
    pub phase_margin_deg: f64,
}

/// A variant of the Figure 14 study with its resonance.
#[derive(Debug, Clone, Serialize)]
pub struct ResonanceCase {
    /// The variant and its margins.
    #[serde(flatten)]
    pub case: Case,
    /// The least-damped open-loop pole pair between 0.1 and 10 Hz (Hz).
    pub resonance_hz: Option<f64>,
    /// Its damping ratio.
    pub damping_ratio: Option<f64>,
}

/// The damping studies.
#[derive(Debug, Clone, Serialize)]
pub struct Damping {
    /// The article's Figure 14, cumulative, on the rig identified from the records.
    pub figure14: Vec<ResonanceCase>,
    /// The first-order motor model.
    pub first_order_motor: Vec<Case>,
    /// The drive feedforward removed.
    pub feedforward_off: Vec<Case>,
    /// The numbers compared with the article's, on its Table 1 rig.
    pub table1_rig: Table1Damping,
}

/// The damping numbers compared with the article's, on its Table 1 rig.
#[derive(Debug, Clone, Serialize)]
pub struct Table1Damping {
    /// The Figure 14 third case's resonance (Hz).
    pub figure14_third_resonance_hz: Option<f64>,
    /// Its damping ratio.
    pub figure14_third_damping_ratio: Option<f64>,
    /// GM with the drive velocity feedforward (dB).
    pub gain_margin_with_feedforward_db: Option<f64>,
    /// GM without it (dB).
    pub gain_margin_without_feedforward_db: Option<f64>,
}

/// The stroke study.
#[derive(Debug, Clone, Serialize)]
pub struct Stroke {
    /// −50, 0 and +50 mm on the identified rig.
    pub cases: Vec<Case>,
    /// The article's margin changes on its basis (the default rig), at −50 and +50 mm.
    pub article_basis: Vec<StrokeBasis>,
    /// Whether one reading gives all four of the article's statements.
    pub article_reproduced: bool,
}

/// The margin changes at a stroke position against the rig at x0.
#[derive(Debug, Clone, Serialize)]
pub struct MarginChange {
    /// PM change (deg).
    pub pm_change_deg: f64,
    /// GM change (dB).
    pub gm_change_db: f64,
}

/// The readings of the article's Figure 15 pumpcyl tries.
#[derive(Debug, Clone, Serialize)]
pub struct StrokeReadings {
    /// Mass and chamber volumes moved together (pumpcyl's stroke study).
    pub mass_and_volumes: MarginChange,
    /// The mass alone, the volumes kept at x0.
    pub mass_alone: MarginChange,
    /// The volumes alone, the mass kept at x0's.
    pub volumes_alone: MarginChange,
}

/// The margin changes at a stroke position on the article's basis (the default rig).
#[derive(Debug, Clone, Serialize)]
pub struct StrokeBasis {
    /// Position from x0 (mm).
    pub dx_mm: f64,
    /// Mass there (kg).
    pub mass_kg: f64,
    /// PM change, mass and volumes moved (deg).
    pub pm_change_deg: f64,
    /// GM change, mass and volumes moved (dB).
    pub gm_change_db: f64,
    /// Every reading tried.
    pub readings: StrokeReadings,
    /// Whether each reading (mass and volumes, mass alone, volumes alone) gives the article's
    /// PM change at its printed precision and its GM statement.
    pub fits: [bool; 3],
    /// Whether pumpcyl's reading (mass and volumes) gives the article's PM change at its printed
    /// precision, each statement on its own.
    pub pm_reproduced: bool,
    /// … and its GM statement.
    pub gm_reproduced: bool,
    /// The article's PM change (deg).
    pub article_pm_change_deg: f64,
    /// The article's GM statement.
    pub article_gm_change: String,
}

/// One wave of the tracking study.
#[derive(Debug, Clone, Serialize)]
pub struct Tracking {
    /// Frequency (Hz).
    pub freq_hz: f64,
    /// Amplitude (mm).
    pub amp_mm: f64,
    /// On the emulated record, over its whole periods after the start-up transient
    /// (`emulated.window`).
    pub emulated: TrackMetrics,
    /// The LTI model in its periodic steady state, on the same samples.
    pub model: TrackMetrics,
    /// How long the identified loop's start-up transient takes to decay below 1 % (s): the
    /// measured periods start after it.
    pub transient_decay_s: f64,
    /// The periods measured, in words (`periods 3–4, t = 21–41 s`).
    pub measured_over: String,
    /// The article's, measured on the real rig (mm).
    pub article_measured_max_error_mm: f64,
    /// The article's wave reduction, measured on the real rig.
    pub article_measured_wave_reduction: f64,
}

/// The design check.
#[derive(Debug, Clone, Serialize)]
pub struct DesignCheck {
    /// Largest Kp at the design point.
    pub kp_max: f64,
    /// Largest Kp at every condition.
    pub kp_max_worst_case: f64,
    /// The verdict.
    pub verdict: Verdict,
    /// Why.
    pub reasons: Vec<String>,
    /// The targets.
    pub targets: Targets,
    /// Largest Kp at every condition with one mass over the whole stroke.
    pub kp_max_worst_case_constant_mass: f64,
    /// The verdict then.
    pub verdict_constant_mass: Verdict,
    /// The article's Kp.
    pub article_kp: f64,
    /// The article's loop (its Table 1 rig at Kp 25) continuous and as its PLC runs it
    /// (docs/analysis.md#sampled-data-margins).
    pub loop_margins: LoopMargins,
}

/// The article's loop's margins, continuous and sampled, and its disk margins
/// (`pumpcyl margins --json` on the Table 1 rig: the same numbers).
#[derive(Debug, Clone, Serialize)]
pub struct LoopMargins {
    /// Gain margin of the continuous loop (dB).
    pub gain_margin_db: Option<f64>,
    /// Phase margin of the continuous loop (deg).
    pub phase_margin_deg: Option<f64>,
    /// Its balanced disk margin α.
    pub disk_margin: f64,
    /// The PLC's rate (Hz) and delay (samples).
    pub plc_rate_hz: f64,
    /// The PLC's computation delay (samples).
    pub plc_delay_samples: usize,
    /// Gain margin of the sampled loop (dB).
    pub sampled_gain_margin_db: Option<f64>,
    /// Phase margin of the sampled loop (deg).
    pub sampled_phase_margin_deg: Option<f64>,
    /// The sampled loop's balanced disk margin α.
    pub sampled_disk_margin: f64,
    /// The phase margin the PLC costs (deg).
    pub phase_margin_cost_deg: Option<f64>,
}

/// One value a parameter, keyed by the parameters' names.
#[derive(Debug, Clone, Serialize)]
pub struct PerParameter<T> {
    /// β.
    pub beta_bar: T,
    /// b.
    pub viscous_friction_ns_per_m: T,
    /// c12.
    pub c12_m5_per_ns: T,
}

impl<T> PerParameter<T> {
    /// The value of parameter `i`, in the order of `pumpcyl::ident::PARAMETERS`.
    pub fn get(&self, i: usize) -> &T {
        [
            &self.beta_bar,
            &self.viscous_friction_ns_per_m,
            &self.c12_m5_per_ns,
        ][i]
    }

    /// `f(index, name)` for each parameter, in the order of `pumpcyl::ident::PARAMETERS`.
    pub fn from_fn(f: impl Fn(usize, &str) -> T) -> Self {
        let [a, b, c] = pumpcyl::ident::PARAMETERS;
        PerParameter {
            beta_bar: f(0, a),
            viscous_friction_ns_per_m: f(1, b),
            c12_m5_per_ns: f(2, c),
        }
    }
}

/// How sure the identification is.
#[derive(Debug, Clone, Serialize)]
pub struct HowSure {
    /// Confidence level of the intervals and the region.
    pub confidence: f64,
    /// The records' noise (mm).
    pub noise_std_mm: f64,
    /// Variance inflation for correlated residuals.
    pub variance_inflation: f64,
    /// The intervals, `null` for a parameter not profiled.
    pub intervals: PerParameter<Option<[f64; 2]>>,
    /// Whether the records bound each parameter.
    pub identifiable: PerParameter<bool>,
    /// Whether each interval holds the emulator's truth.
    pub truth_inside: PerParameter<bool>,
    /// The design over the confidence region.
    pub robust_design: RobustSummary,
    /// The next experiment.
    pub advice: AdviceSummary,
}

/// The robust design's headline.
#[derive(Debug, Clone, Serialize)]
pub struct RobustSummary {
    /// Largest Kp over the region.
    pub kp_max: f64,
    /// Largest Kp at the point estimate.
    pub kp_max_nominal: f64,
    /// What decides it.
    pub deciding: Deciding,
    /// The worst case over the region at `kp_max`.
    pub worst_case: WorstCase,
    /// The article's loop, step by step.
    #[serde(rename = "loop")]
    pub steps: Vec<LoopStep>,
    /// The verdict.
    pub verdict: Verdict,
    /// Why.
    pub reasons: Vec<String>,
}

/// The experiment advice's headline.
#[derive(Debug, Clone, Serialize)]
pub struct AdviceSummary {
    /// The widths today.
    pub current: [Width; 3],
    /// The best candidate for each parameter.
    pub best_for: [String; 3],
    /// The best candidates.
    pub top: Vec<Assessment>,
}

/// Step 10: the article's closing advice (its §4) on its own application
/// (docs/select.md#the-article-s-application).
#[derive(Debug, Clone, Serialize)]
pub struct WhichCircuit {
    /// Over the stated gas-fraction range (the article's 2.64 %, a factor 2 either way).
    pub stated: pumpcyl::select::Selection,
    /// The article's own circuit: low-pressure at the records' mean pressure, Kp 25, over the
    /// stated range.
    pub article_choice: pumpcyl::select::Candidate,
    /// Over the gas-fraction range read off the identification's interval of β.
    pub identified: pumpcyl::select::Selection,
    /// The stated range's lowest meeting level under each model of β(p), the rig's β at the
    /// records' mean pressure read through it (docs/bulk-modulus.md#a-family-of-models).
    pub models: Vec<SelectUnder>,
}

/// `select`'s answer under one model of β(p).
#[derive(Debug, Clone, Serialize)]
pub struct SelectUnder {
    /// The model.
    pub model: pumpcyl::bulk::BulkModel,
    /// Its gas-fraction range [lowest, reference, highest].
    pub gas_fraction: [f64; 3],
    /// The lowest mean chamber pressure (bar) that meets the requirement, bisected between the
    /// levels; `None` where no level meets it.
    pub min_mean_pressure_bar: Option<f64>,
    /// The lowest level that meets (bar), `None` where none does.
    pub min_level_bar: Option<f64>,
}

/// A sweep beside the steps: the intervals of β, b and c12 from each kind of record and both.
#[derive(Debug, Clone, Serialize)]
pub struct SweepBeside {
    /// That the sweep is emulated, as the steps are.
    pub note: String,
    /// The sweep, in words.
    pub sweep: String,
    /// Confidence level of the intervals.
    pub confidence: f64,
    /// From the step records (step 9).
    pub steps: IntervalSet,
    /// From the sweep alone, in the frequency domain.
    pub sweep_alone: IntervalSet,
    /// From the sweep and the steps together.
    pub both: IntervalSet,
}

/// One set of records' answer and intervals.
#[derive(Debug, Clone, Serialize)]
pub struct IntervalSet {
    /// The least-cost point (β bar, b N·s/m, c12 m⁵/(N·s)).
    pub best: PerParameter<f64>,
    /// The intervals, `null` for a parameter not profiled.
    pub intervals: PerParameter<Option<[f64; 2]>>,
    /// Whether the records bound each parameter.
    pub identifiable: PerParameter<bool>,
    /// Whether each interval holds the emulator's truth.
    pub truth_inside: PerParameter<bool>,
}
