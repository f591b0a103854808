//! One rig variant of a study in summary.json: apart from [`super::summary`] so that the
//! studies that make cases and the summary that holds them depend on it, not on each other.

use pumpcyl::lti::Margins;
use pumpcyl::response::StepMetrics;
use serde::Serialize;

/// One rig variant of a study: its margins (sum-pressure loop open) and whether its step
/// (sum-pressure loop closed) is stable.
#[derive(Debug, Clone, Serialize)]
pub struct Case {
    /// The variant.
    pub case: String,
    /// The margins.
    #[serde(flatten)]
    pub margins: Margins,
    /// Whether the closed loop with the sum-pressure loop is stable (its step is drawn).
    pub step_closed_loop_stable: bool,
    /// The 5 mm step's metrics with the sum-pressure loop closed; `null` when that loop is
    /// unstable.
    pub step: Option<StepMetrics>,
}
