//! The figures of the article workflow, registered once: each figure's file stem under
//! `figures/` and the article figure it answers (docs/choices.md#article-figures), in the
//! report's order. The workflow refuses a figure that is not here and checks at its end that
//! it drew every one, in this order; the tests loop over this list instead of counting. Adding
//! a figure is its study and one line here.

use super::Source;

/// A registered figure of the workflow.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Registered {
    /// File name under `figures/`, without extension.
    pub stem: &'static str,
    /// The article figure it answers, or pumpcyl's own study.
    pub source: Source,
}

const fn fig(stem: &'static str, source: Source) -> Registered {
    Registered { stem, source }
}

/// Every figure of the workflow, in the report's order (the identification's landscape and
/// fits are files of its result under `identification/`, not figures of the workflow).
pub const FIGURES: &[Registered] = &[
    fig("drive_step", Source::Article(5)),
    fig("robustness", Source::Article(10)),
    fig("bulk_modulus", Source::Article(12)),
    fig("bode_pressure", Source::Article(13)),
    fig("bode_fig14_damping", Source::Article(14)),
    fig("step_fig14_damping", Source::Extends(14)),
    fig("bode_motor_first_order", Source::Own),
    fig("step_motor_first_order", Source::Own),
    fig("bode_fig11_feedforward", Source::Extends(11)),
    fig("step_fig11_feedforward", Source::Article(11)),
    fig("bode_stroke", Source::Article(15)),
    fig("step_stroke", Source::Extends(15)),
    fig("sine_0p10hz", Source::Article(16)),
    fig("sine_0p20hz", Source::Article(17)),
    fig("sine_0p25hz", Source::Article(18)),
    fig("nyquist", Source::Own),
    fig("gang_of_four", Source::Own),
    fig("profile-beta_bar", Source::Own),
    fig("profile-viscous_friction_ns_per_m", Source::Own),
    fig("profile-c12_m5_per_ns", Source::Own),
    fig("robust-margins", Source::Own),
    fig("which_circuit", Source::Own),
    fig("figure1_circuits_step", Source::Own),
    fig("sweep_beside_steps", Source::Own),
    fig("bode_valve_or_pump", Source::Own),
    fig("step_valve_or_pump", Source::Own),
    fig("energy_per_circuit", Source::Own),
];

/// The registered figure `stem` drawn as the article figure `source`: an error names a
/// figure missing from [`FIGURES`] or drawn as another article figure than registered.
pub(super) fn check(stem: &str, source: Source) -> anyhow::Result<()> {
    let Some(r) = FIGURES.iter().find(|r| r.stem == stem) else {
        anyhow::bail!("figure `{stem}` is not registered in reproduce::FIGURES");
    };
    anyhow::ensure!(
        r.source == source,
        "figure `{stem}` is registered as {:?}, drawn as {source:?}",
        r.source
    );
    Ok(())
}

/// The figures drawn, `stems` in order, are the registered ones in the registry's order.
pub(super) fn check_all<'a>(stems: impl Iterator<Item = &'a str>) -> anyhow::Result<()> {
    let drawn: Vec<&str> = stems.collect();
    let registered: Vec<&str> = FIGURES.iter().map(|r| r.stem).collect();
    anyhow::ensure!(
        drawn == registered,
        "the workflow drew the figures {drawn:?}, the registry lists {registered:?}"
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_figure_outside_the_registry_or_out_of_order_is_refused() {
        assert!(check("drive_step", Source::Article(5)).is_ok());
        let unknown = check("new_study", Source::Own).unwrap_err().to_string();
        assert!(
            unknown.contains("`new_study` is not registered"),
            "{unknown}"
        );
        // registered as the article's Figure 5, not as pumpcyl's own study
        assert!(check("drive_step", Source::Own).is_err());
        let stems = || FIGURES.iter().map(|f| f.stem);
        assert!(check_all(stems()).is_ok());
        assert!(check_all(stems().rev()).is_err());
        assert!(check_all(stems().skip(1)).is_err(), "a figure left out");
    }

    #[test]
    fn stems_are_distinct() {
        let mut stems: Vec<&str> = FIGURES.iter().map(|f| f.stem).collect();
        stems.sort_unstable();
        stems.dedup();
        assert_eq!(stems.len(), FIGURES.len());
    }
}
