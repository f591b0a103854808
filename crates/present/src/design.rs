//! The design results in words: the verdict's one spelling, the deciding margin, and the
//! robust design's leakage loop as a table (docs/design.md).

use crate::format::fmt_opt;
use crate::table::Table;
use pumpcyl::design::robust::Binding;
use pumpcyl::design::{RobustDesign, Verdict};

/// The verdict as every text output writes it.
pub fn verdict_text(v: Verdict) -> &'static str {
    match v {
        Verdict::Adequate => "ADEQUATE",
        Verdict::Marginal => "MARGINAL",
        Verdict::UseHigherPressure => "USE A CIRCUIT WITH HIGHER PRESSURE",
    }
}

/// The margin that decides a robust gain, in words.
pub fn binding_text(b: Binding) -> &'static str {
    match b {
        Binding::PhaseMargin => "phase margin",
        Binding::GainMargin => "gain margin",
        Binding::Stability => "stability",
    }
}

/// The article's loop done automatically (docs/design.md#robust-design): each step's leakage
/// estimate, the largest Kp there, the margin that binds it, the worst margins over the region
/// and whether the gain holds over the whole region.
pub fn leakage_loop_table(d: &RobustDesign) -> Table {
    let mut t = Table::new(
        "The article's loop done automatically: lower the leakage estimate, design again, and \
         check the gain over the whole region",
        &[
            "step",
            "c12 (m⁵/(N·s))",
            "Kp max",
            "binds",
            "worst GM (dB)",
            "worst PM (deg)",
            "holds over the region",
        ],
    );
    for (i, st) in d.steps.iter().enumerate() {
        let holds = if st.worst_case.meets_targets {
            "yes"
        } else {
            "no"
        };
        t.push(vec![
            format!("{}", i + 1),
            format!("{:.4e}", st.c12_m5_per_ns),
            format!("{:.2}", st.kp_max),
            binding_text(st.deciding.binding).to_string(),
            fmt_opt(st.worst_case.gain_margin_db.value, 2),
            fmt_opt(st.worst_case.phase_margin_deg.value, 1),
            holds.to_string(),
        ]);
    }
    t
}
