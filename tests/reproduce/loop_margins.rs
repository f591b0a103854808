//! The report's statement of the article's loop margins (docs/analysis.md#sampled-data-margins):
//! summary.json's `design.loop_margins` is `pumpcyl margins --json` on the Table 1 rig, the
//! continuous margins the article's (GM 6.5 dB, PM 34° as it prints them, §3.3), the sampled
//! ones below them by about the 1.5 samples of lag at the crossover, and the report's table
//! holds them.

use super::{pumpcyl_stdout as pumpcyl, reproduced, summary};
use serde_json::Value;

#[test]
fn the_report_states_the_articles_loop_margins_continuous_sampled_and_disk() {
    let s = summary();
    let got = &s["design"]["loop_margins"];
    let m: Value = serde_json::from_slice(&pumpcyl(&["margins".into(), "--json".into()])).unwrap();
    let pairs = [
        ("gain_margin_db", &m["gain_margin_db"]),
        ("phase_margin_deg", &m["phase_margin_deg"]),
        ("disk_margin", &m["disk"]["disk_margin"]),
        ("sampled_gain_margin_db", &m["sampled"]["gain_margin_db"]),
        (
            "sampled_phase_margin_deg",
            &m["sampled"]["phase_margin_deg"],
        ),
        ("sampled_disk_margin", &m["sampled"]["disk"]["disk_margin"]),
        (
            "phase_margin_cost_deg",
            &m["sampled"]["phase_margin_cost_deg"],
        ),
    ];
    for (key, want) in pairs {
        let (g, w) = (got[key].as_f64().unwrap(), want.as_f64().unwrap());
        assert!(
            (g - w).abs() <= 1e-12 * w.abs(),
            "{key}: summary {g}, margins {w}"
        );
    }
    let v = |k: &str| got[k].as_f64().unwrap();
    // the article prints GM 6.5 dB and PM 34 deg for its loop (§3.3)
    assert!((v("gain_margin_db") - 6.5).abs() < 0.1 && (v("phase_margin_deg") - 34.0).abs() < 1.0);
    // a hold and a sample of delay lag 1.5 samples: 1.5 × 10 ms × f_c × 360° at the crossover
    let estimate = 1.5 * 0.01 * m["gain_crossover_hz"].as_f64().unwrap() * 360.0;
    assert!(
        (v("phase_margin_cost_deg") - estimate).abs() < 0.1,
        "{}",
        v("phase_margin_cost_deg")
    );
    assert!(v("sampled_disk_margin") < v("disk_margin"));
    let html = std::fs::read_to_string(reproduced().0.join("report.html")).unwrap();
    for shown in [
        format!("{:.2}", v("sampled_phase_margin_deg")),
        format!("{:.3}", v("disk_margin")),
    ] {
        assert!(html.contains(&shown), "the report lacks {shown}");
    }
}
