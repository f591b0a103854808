//! A rig's bulk-modulus anchor (docs/bulk-modulus.md#the-anchor): the one mean chamber pressure
//! at which its `beta_bar` holds, and the reading every gas fraction of the rig comes from. Apart
//! from [`crate::bulk`] because it asks the emulator where the rig rests.

use crate::bulk::{BetaReading, ARTICLE_READING};
use crate::rig::Rig;

/// The one pressure at which a rig's `beta_bar` holds (bar gauge; docs/bulk-modulus.md#the-anchor):
/// where the rig rests, as the emulator finds it ([`crate::emulator::beta_anchor_bar`]: the
/// DPM loop's mean chamber pressure at rest at x0, a one-motor circuit's accumulator
/// pre-charge). Every command that reads a gas fraction off `beta_bar` (`design --p-mean-bar`,
/// `bulk-modulus`, `select`, the emulator) reads it here. Where the emulator cannot run the
/// rig (a first-order motor model, a loop without a rest) the circuit's pressure level
/// ([`crate::circuit::pressure_level_bar`]: half the sum-pressure set-point) stands in.
pub fn anchor_bar(rig: &Rig) -> f64 {
    crate::emulator::beta_anchor_bar(rig)
        .ok()
        .filter(|p| p.is_finite() && *p > 0.0)
        .unwrap_or_else(|| crate::circuit::pressure_level_bar(rig))
}

impl BetaReading {
    /// A rig's own reading: its `beta_bar` at its one anchor ([`anchor_bar`]); the article's
    /// identification ([`ARTICLE_READING`]) on the article's rig itself, under any model of
    /// β_e against pressure (the reading is the records', whatever model extrapolates it).
    pub fn of_rig(rig: &Rig) -> BetaReading {
        let article = Rig {
            bulk_modulus_model: rig.bulk_modulus_model,
            polytropic_index: rig.polytropic_index,
            air_dissolution_pressure_bar: rig.air_dissolution_pressure_bar,
            ..Rig::default()
        };
        if *rig == article {
            return ARTICLE_READING;
        }
        BetaReading {
            beta_bar: rig.beta_bar,
            p_mean_bar: anchor_bar(rig),
        }
    }

    /// The reading a rig's gas fraction comes from: the article's identification on the
    /// article's own rig (`article_rig`, the rig no file gave, with the article's circuit, β
    /// and sum-pressure set-point), the rig's own reading ([`BetaReading::of_rig`]) otherwise.
    pub fn for_rig(rig: &Rig, article_rig: bool) -> BetaReading {
        let article = Rig::default();
        if article_rig
            && rig.circuit == article.circuit
            && rig.beta_bar == article.beta_bar
            && rig.p_sum_ref_bar == article.p_sum_ref_bar
        {
            ARTICLE_READING
        } else {
            BetaReading::of_rig(rig)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bulk::{effective_beta, BETA_OIL_BAR};

    /// The article's rig reads as the article's identification (165 bar at 4.4 bar), from a file
    /// too; a rig with another β or set-point reads as its own β at its anchor, where its
    /// emulated loop rests.
    #[test]
    fn a_rig_reads_its_own_beta_unless_it_is_the_article_s() {
        let article = Rig::default();
        assert_eq!(BetaReading::for_rig(&article, true), ARTICLE_READING);
        // the article's rig read from a file is still the article's rig
        assert_eq!(BetaReading::for_rig(&article, false), ARTICLE_READING);
        let mine = Rig {
            beta_bar: 300.0,
            ..Rig::default()
        };
        // another β rests where the article's loop rests (no oil is compressed at rest), below
        // half the 10 bar set-point: the P laws' standing errors turn the leakage pumps
        let r = BetaReading::for_rig(&mine, true);
        let anchor = crate::emulator::beta_anchor_bar(&mine).unwrap();
        assert_eq!((r.beta_bar, r.p_mean_bar), (300.0, anchor));
        assert!((4.0..5.0).contains(&anchor), "{anchor}");
        let x = r.gas_fraction(BETA_OIL_BAR).unwrap();
        assert!((effective_beta(x, anchor, BETA_OIL_BAR) - 300.0).abs() < 1e-9);
        // a one-motor circuit's pressure is its accumulator pre-charge, not the DPM's
        // set-point, and the article's reading (the DPM's records) is not its own
        let dual = Rig {
            circuit: crate::circuit::CircuitKind::DualPump,
            accumulator_precharge_bar: 3.5,
            ..Rig::default()
        };
        let r = BetaReading::for_rig(&dual, true);
        assert_eq!((r.beta_bar, r.p_mean_bar), (165.0, 3.5));
    }
}
