//! Where each requirement of a design or a circuit selection comes from, in words: a number the
//! article prints, or a choice of pumpcyl's with its reason (docs/design.md#targets,
//! docs/select.md#the-article-s-application). The article sets low margins as its design guide
//! (§2.2) and reports PM ≈ 34° and GM ≈ 6.5 dB at Kp 25 (§3.3); it sets no gain-margin target,
//! no tracking-error requirement and no range of undissolved air.

use pumpcyl::design::Targets;
use pumpcyl::select::{Application, WaveRequirement};

/// The margin targets `pm_deg`, `gm_db` over x0 ± `stroke_mm`, each with its origin: the
/// defaults ([`Targets::default`]) say which rests on the article and which is pumpcyl's
/// choice; another value is the user's.
pub fn targets(pm_deg: f64, gm_db: f64, stroke_mm: f64) -> String {
    let d = Targets::default();
    let pm = if pm_deg == d.pm_deg {
        format!(
            "PM ≥ {pm_deg} deg (the phase margin the article's design reaches at Kp 25, §3.3, kept as a floor; \
             its design guide asks only for low margins, PM < 40°, at the worst-case point, §2.2)"
        )
    } else {
        format!("PM ≥ {pm_deg} deg (as given)")
    };
    let gm = if gm_db == d.gm_db {
        format!(
            "GM ≥ {gm_db} dB (pumpcyl's choice: the loop gain may double before the loop goes unstable; \
             the article sets no gain-margin target, its design reaches 6.5 dB, §3.3)"
        )
    } else {
        format!("GM ≥ {gm_db} dB (as given)")
    };
    let stroke = if stroke_mm == d.stroke_mm {
        format!("over x0 ± {stroke_mm} mm (the stroke the article checks, §3.3 and Figure 15)")
    } else {
        format!("over x0 ± {stroke_mm} mm (as given)")
    };
    format!("{pm}, {gm}, {stroke}")
}

/// A wave to track within an error, with its origin: the default is pumpcyl's choice on the
/// article's wave.
pub fn wave(w: &WaveRequirement) -> String {
    let text = format!(
        "the {} Hz ±{} mm wave within {} mm",
        w.freq_hz, w.amp_mm, w.max_error_mm
    );
    let default = Application::default();
    if default.wave.first() == Some(w) {
        format!(
            "{text} (pumpcyl's choice, a wave reduction of {:.0} % on the wave of the article's Figure 17: \
             the article sets no tracking requirement; it measured 11.8 mm there and calls its wave \
             reductions \"quite decent\", §3.4)",
            100.0 * (1.0 - w.max_error_mm / w.amp_mm)
        )
    } else {
        format!("{text} (as given)")
    }
}

/// The gas-fraction range of `app` with its origin: the default factor 2 either way is
/// pumpcyl's choice.
pub fn gas_fraction_range(app: &Application) -> String {
    let text = format!(
        "the gas fraction {:.4} ({:.4} … {:.4})",
        app.gas_fraction, app.gas_fraction_min, app.gas_fraction_max
    );
    let default = Application::default();
    let same = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
    if same(app.gas_fraction, default.gas_fraction)
        && same(app.gas_fraction_min, default.gas_fraction_min)
        && same(app.gas_fraction_max, default.gas_fraction_max)
    {
        format!(
            "{text}, a factor 2 either way of the article's 2.64 % (pumpcyl's choice: the article gives \
             no range, only that the amount of undissolved air \"is going to vary\" and is \"highly \
             uncertain\", §4; its own robustness record needs β_e 220 bar where the identification \
             found 165 bar, its Figure 10)"
        )
    } else {
        format!("{text} (as given)")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_say_which_number_is_the_article_s() {
        let t = Targets::default();
        let s = targets(t.pm_deg, t.gm_db, t.stroke_mm);
        assert!(s.contains("§3.3") && s.contains("pumpcyl's choice"), "{s}");
        assert!(!s.contains("the article's targets"), "{s}");
        assert!(targets(40.0, 8.0, 20.0).matches("as given").count() == 3);
        let app = Application::default();
        assert!(wave(&app.wave[0]).contains("60 %"));
        assert!(gas_fraction_range(&app).contains("pumpcyl's choice"));
        let other = Application {
            gas_fraction_max: 0.06,
            ..Application::default()
        };
        assert!(gas_fraction_range(&other).ends_with("(as given)"));
    }
}
