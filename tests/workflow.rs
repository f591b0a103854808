//! The article workflow as a library call (`pumpcyl_present::reproduce`), without the command line: its
//! numbers against independent references (the emulator's truth, the margins `lti` computes on
//! the default rig), its figures, its progress callbacks, and the folder it writes against the
//! one `pumpcyl reproduce` writes.

#[path = "common/tree.rs"]
mod tree;

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;

use pumpcyl::rig::Rig;
use pumpcyl_present::reproduce::{reproduce, ReproduceOptions, Reproduction, FIGURES, STEPS};
use std::collections::BTreeSet;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock};
use tree::files;

/// One run shared by the tests of this file, with the steps and candidate counts it reported.
struct Run {
    result: Reproduction,
    steps: Vec<(usize, usize, String)>,
    candidates: u64,
    totals: BTreeSet<u64>,
}

fn run() -> &'static Run {
    static RUN: OnceLock<Run> = OnceLock::new();
    RUN.get_or_init(|| {
        let steps = Mutex::new(Vec::new());
        let candidates = AtomicU64::new(0);
        let totals = Mutex::new(BTreeSet::new());
        let on_step = |k: usize, n: usize, what: &str| {
            steps.lock().unwrap().push((k, n, what.to_string()));
        };
        let on_candidates = |n: u64, total: u64| {
            candidates.fetch_add(n, Ordering::Relaxed);
            totals.lock().unwrap().insert(total);
            true
        };
        let result = reproduce(&ReproduceOptions {
            on_step: Some(&on_step),
            on_candidates: Some(&on_candidates),
        })
        .unwrap();
        Run {
            result,
            steps: steps.into_inner().unwrap(),
            candidates: candidates.into_inner(),
            totals: totals.into_inner().unwrap(),
        }
    })
}

#[test]
fn the_identified_rig_recovers_the_emulators_truth() {
    let r = &run().result;
    // the emulated records were made with beta_e = 165 bar at their mean pressure and
    // c12 = 1.2e-10 m⁵/(N·s) (data/article/README.md)
    let beta = r.identified.beta_bar;
    assert!((beta - 165.0).abs() <= 10.0, "beta {beta} bar");
    let c12 = r.identified.c12_m5_per_ns / 1.2e-10;
    assert!((1.0 / 1.5..=1.5).contains(&c12), "c12 ratio {c12}");
    assert!(
        (r.km_nms_per_rad / 0.026 - 1.0).abs() < 0.02,
        "{}",
        r.km_nms_per_rad
    );
    // the typed numbers are summary.json's
    let s = serde_json::to_value(&r.summary).unwrap();
    assert_eq!(s["identified"]["beta_bar"].as_f64(), Some(beta));
    assert_eq!(
        s["identified"]["c12_m5_per_ns"].as_f64(),
        Some(r.identified.c12_m5_per_ns)
    );
    assert_eq!(s["identified"]["cost_mm2"].as_f64(), Some(r.cost_mm2));
    assert_eq!(
        s["drive"]["km_nms_per_rad"].as_f64(),
        Some(r.km_nms_per_rad)
    );
    assert_eq!(s["design"]["kp_max"].as_f64(), Some(r.design_kp));
    // the gas fraction follows from beta at the mean pressure: X ≈ p/beta
    assert!((r.gas_fraction - r.p_mean_bar / beta).abs() < 0.001);
    // the design method gives the article's Kp = 25 within ±1 (the article §2.2)
    assert!((r.design_kp - 25.0).abs() <= 1.0, "{}", r.design_kp);
}

#[test]
fn the_default_rig_margins_are_those_lti_computes() {
    let r = &run().result;
    let m = pumpcyl::lti::margins(&pumpcyl::model::Plant::new(&Rig::default()).open_loop(false))
        .unwrap();
    assert_eq!(r.default_margins, m);
    let gm = r.default_margins.gain_margin_db.unwrap();
    assert!((gm - 6.45).abs() <= 0.05, "GM {gm} dB");
    let identified =
        pumpcyl::lti::margins(&pumpcyl::model::Plant::new(&r.identified).open_loop(false)).unwrap();
    assert_eq!(r.identified_margins, identified);
    // the comparison carries the article's printed 6.5 dB beside pumpcyl's
    let row = r
        .comparison
        .iter()
        .find(|row| row.quantity == "GM, the article's Table 1 rig (dB)")
        .unwrap();
    assert_eq!(row.article, "6.5");
    assert_eq!(row.pumpcyl, format!("{gm:.2}"));
}

#[test]
fn progress_reports_every_step_and_every_candidate() {
    let run = run();
    let ks: Vec<usize> = run.steps.iter().map(|s| s.0).collect();
    assert_eq!(ks, (1..=STEPS).collect::<Vec<_>>());
    assert!(run.steps.iter().all(|s| s.1 == STEPS));
    // one total: both grids of the identification, every candidate reported once
    assert_eq!(run.totals.len(), 1, "{:?}", run.totals);
    let total = *run.totals.iter().next().unwrap();
    assert_eq!(run.candidates, total);
    let stages = run.result.summary.identified.candidates_evaluated;
    assert!(stages <= total && stages > total / 2, "{stages} of {total}");
    // each step heads its section of the report
    for (k, _, what) in &run.steps {
        let heading = format!("{k}. {what}");
        assert!(run
            .result
            .blocks
            .iter()
            .any(|b| matches!(b, pumpcyl_present::html::Block::Heading(h) if *h == heading)));
    }
}

#[test]
fn every_figure_is_rendered_in_memory() {
    let r = &run().result;
    // the registered figures, each once, in the registry's order
    let stems: Vec<&str> = r.figures.iter().map(|f| f.stem.as_str()).collect();
    let registered: Vec<&str> = FIGURES.iter().map(|f| f.stem).collect();
    assert_eq!(stems, registered);
    let distinct: BTreeSet<&str> = stems.iter().copied().collect();
    assert_eq!(distinct.len(), FIGURES.len(), "stems are distinct");
    for f in &r.figures {
        assert!(
            f.svg.contains("<svg") && f.svg.trim_end().ends_with("</svg>"),
            "{}",
            f.stem
        );
        // a figure, not an empty page (a dashed line is one path: the likelihood profiles,
        // a few curves, are about 7 kB)
        assert!(f.svg.len() > 5_000, "{}: {} bytes", f.stem, f.svg.len());
        assert!(
            f.png.starts_with(b"\x89PNG\r\n\x1a\n") && f.png.len() > 10_000,
            "{}: not a PNG",
            f.stem
        );
        assert!(!f.caption.is_empty());
    }
    // the stroke steps are drawn about their own operating points
    let stroke = r.figures.iter().find(|f| f.stem == "step_stroke").unwrap();
    assert!(stroke.svg.contains("x − x0"), "axis names the shift");
    let html = r.report_html();
    assert_eq!(
        html.matches("<figure>").count(),
        FIGURES.len() + 3,
        "and the landscape and two fits"
    );
}

#[test]
fn stopping_the_search_stops_the_workflow_and_leaves_no_scratch_folder() {
    let stop = |_: u64, _: u64| false;
    let err = reproduce(&ReproduceOptions {
        on_step: None,
        on_candidates: Some(&stop),
    })
    .unwrap_err();
    assert!(err.to_string().contains("interrupted"), "{err}");
    let own = format!(".scratch.pumpcyl-tmp-{}-", std::process::id());
    let left: Vec<String> = std::fs::read_dir(std::env::temp_dir())
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(&own))
        .collect();
    // the shared run may hold its own scratch folder only while it runs
    assert!(left.len() <= 1, "{left:?}");
}

#[test]
fn write_makes_the_folder_the_command_line_makes() {
    let r = &run().result;
    let tmp = tempfile::tempdir().unwrap();
    let (lib, cli) = (tmp.path().join("lib"), tmp.path().join("cli"));
    r.write(&lib).unwrap();
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .args(["reproduce", "--out", cli.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(status.status.success());
    assert_eq!(files(&lib), files(&cli));
    // the same bytes where nothing depends on the run's time
    for f in ["records/identification.csv", "identification/landscape.csv"] {
        assert_eq!(
            std::fs::read(lib.join(f)).unwrap(),
            std::fs::read(cli.join(f)).unwrap(),
            "{f}"
        );
    }
    let read = |d: &Path| -> serde_json::Value {
        let mut v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("summary.json")).unwrap())
                .unwrap();
        v["seconds"] = serde_json::Value::Null;
        v["identified"]["seconds"] = serde_json::Value::Null;
        v
    };
    assert_eq!(read(&lib), read(&cli));
    // as written, then read back (the same float parsing on both sides)
    let written: serde_json::Value =
        serde_json::from_str(&serde_json::to_string(&r.summary).unwrap()).unwrap();
    assert_eq!(read(&lib)["identified"], {
        let mut v = written["identified"].clone();
        v["seconds"] = serde_json::Value::Null;
        v
    });
    // a second write replaces the earlier result; a folder of other files is refused untouched
    r.write(&lib).unwrap();
    let other = tmp.path().join("other");
    std::fs::create_dir(&other).unwrap();
    std::fs::write(other.join("notes.txt"), "mine").unwrap();
    let err = r.write(&other).unwrap_err();
    assert!(err.to_string().contains("not empty"), "{err}");
    assert_eq!(
        std::fs::read_to_string(other.join("notes.txt")).unwrap(),
        "mine"
    );
}

#[test]
fn how_sure_holds_the_truth_and_designs_below_the_point_estimate() {
    let r = &run().result;
    let c = &r.certainty;
    // the 95 % intervals hold the truth the records were emulated with (data/article/README.md)
    let beta = c.uncertainty.profile("beta_bar").unwrap();
    assert!(beta.identifiable);
    assert!(
        beta.interval[0] <= 165.0 && 165.0 <= beta.interval[1],
        "{:?}",
        beta.interval
    );
    let c12 = c.uncertainty.profile("c12_m5_per_ns").unwrap();
    assert!(c12.identifiable);
    assert!(
        c12.interval[0] <= 1.2e-10 && 1.2e-10 <= c12.interval[1],
        "{:?}",
        c12.interval
    );
    // the estimate lies inside its own interval, and b is not bounded by steps alone
    assert!(beta.interval[0] <= r.identified.beta_bar && r.identified.beta_bar <= beta.interval[1]);
    assert!(
        !c.uncertainty
            .profile("viscous_friction_ns_per_m")
            .unwrap()
            .identifiable
    );
    // a design that must hold over the region is never above the point design, and the worst
    // case at its gain meets the default targets (PM 34 deg, GM 6 dB) within the tolerances
    let d = &c.robust;
    assert!(
        d.kp_max > 0.0 && d.kp_max <= d.kp_max_nominal,
        "{} {}",
        d.kp_max,
        d.kp_max_nominal
    );
    assert!(d.worst_case.meets_targets);
    let gm = d.worst_case.gain_margin_db.value.unwrap();
    let pm = d.worst_case.phase_margin_deg.value.unwrap();
    assert!(gm >= 6.0 - 0.01 && pm >= 34.0 - 0.05, "GM {gm} PM {pm}");
    // the nominal design is the margins' own bisection at the identified rig
    let targets = pumpcyl::design::Targets::default();
    let kp = pumpcyl::design::kp_max(&r.identified, &targets).unwrap();
    assert!(
        (kp - d.kp_max_nominal).abs() < 1e-6 * kp,
        "{kp} {}",
        d.kp_max_nominal
    );
    // the advice: no candidate record widens an interval, and one is named for b
    let a = &c.advice;
    assert!(!a.best_for[1].is_empty());
    for cand in &a.candidates {
        assert!(
            cand.improvement.iter().all(|&f| f >= 1.0 - 1e-9),
            "{}",
            cand.label
        );
    }
    // summary.json carries the same
    let summary = serde_json::to_value(&r.summary).unwrap();
    let s = &summary["how_sure"];
    assert_eq!(s["robust_design"]["kp_max"].as_f64(), Some(d.kp_max));
    assert_eq!(s["truth_inside"]["beta_bar"], serde_json::json!(true));
    assert!(r.figures.iter().any(|f| f.stem == "robust-margins"));
    assert_eq!(
        r.figures
            .iter()
            .filter(|f| f.stem.starts_with("profile-"))
            .count(),
        3
    );
}

#[test]
fn which_circuit_answers_the_articles_advice_before_and_after_the_identification() {
    let r = &run().result;
    let w = &r.summary.which_circuit;
    let records = pumpcyl::emulator::article::records().unwrap();
    let truth_x = records[0].truth.effects.gas_fraction.unwrap();
    // the identified gas-fraction range holds the air the records were emulated with, and
    // lies inside the stated factor-2 range
    let [lo, _, hi] = w.identified.gas_fraction;
    assert!(lo <= truth_x && truth_x <= hi, "{lo} {truth_x} {hi}");
    assert!(w.stated.gas_fraction[0] <= lo && hi <= w.stated.gas_fraction[2]);
    // a narrower range never needs a higher pressure
    let stated = w.stated.min_mean_pressure_bar.expect("a level meets it");
    let identified = w
        .identified
        .min_mean_pressure_bar
        .expect("a level meets it");
    assert!(identified <= stated, "{identified} > {stated}");
    // the article's own circuit: its gain, at the records' mean pressure; it meets the
    // requirement exactly when its gain is within the largest that holds over the range
    let a = &w.article_choice;
    assert_eq!(a.kp_max, 25.0);
    assert!((a.mean_pressure_bar - r.p_mean_bar).abs() < 1e-12);
    assert!(a.kp_max_range > 0.0 && a.kp_max_range <= a.kp_max_reference);
    if a.kp_max_range < 25.0 {
        assert!(!a.meets);
    }
    // the largest Kp over the range at the lowest level meeting it is the design's own worst
    // case at the softest β_e there
    let c = w.stated.at_min_mean_pressure.as_ref().unwrap();
    assert!(c.meets && c.mean_pressure_bar == stated);
    let app = pumpcyl::select::Application::default();
    let soft = pumpcyl::rig::Rig {
        beta_bar: c.beta_e_bar[0],
        p_sum_ref_bar: 2.0 * stated,
        ..app.rig.clone()
    };
    let kp = pumpcyl::design::kp_max_worst_case(&soft, &app.requirement().targets).unwrap();
    assert!(c.kp_max <= kp + 1e-9, "{} > {kp}", c.kp_max);
    assert!(r.figures.iter().any(|f| f.stem == "which_circuit"));
}

#[test]
fn the_robust_design_of_design_and_of_reproduce_agree() {
    // the same records, the same targets (the article's) and the same pressures (those the
    // records span): one answer, whichever front end asks
    let r = &run().result;
    let exp = concat!(env!("CARGO_MANIFEST_DIR"), "/data/article/identify.toml");
    let v = run::json(
        Path::new("."),
        &["design", "--robust", "--experiment", exp, "--json"],
    );
    let kp = v["kp_max"].as_f64().unwrap();
    assert!(
        (kp - r.certainty.robust.kp_max).abs() < 1e-9 * kp,
        "design --robust {kp}, reproduce {}",
        r.certainty.robust.kp_max
    );
    assert_eq!(v["targets"]["p_mean_bar"].as_array().unwrap().len(), 3);
}

#[test]
fn the_terminal_comparison_fits_120_columns_with_its_notes_below() {
    let r = &run().result;
    let text = pumpcyl_present::reproduce::comparison_text(&r.comparison, 120);
    let widest = text.lines().map(|l| l.chars().count()).max().unwrap();
    assert!(widest <= 120, "{widest} columns:\n{text}");
    // every explanation is a numbered note, whole once its wrapped lines are joined
    let flat: String = text.split_whitespace().collect::<Vec<_>>().join(" ");
    let whys: Vec<&str> = r
        .comparison
        .iter()
        .map(|c| c.why.as_str())
        .filter(|w| !w.is_empty())
        .collect();
    assert!(!whys.is_empty());
    for (k, why) in whys.iter().enumerate() {
        let joined = why.split_whitespace().collect::<Vec<_>>().join(" ");
        assert!(
            flat.contains(&format!("[{}] {joined}", k + 1)),
            "note {}: {why}",
            k + 1
        );
    }
}

#[test]
fn a_variant_whose_step_diverges_is_named_in_the_legend_with_its_pole() {
    let r = &run().result;
    let summary = serde_json::to_value(&r.summary).unwrap();
    for (study, stem) in [
        ("figure14", "step_fig14_damping"),
        ("first_order_motor", "step_motor_first_order"),
    ] {
        let svg = &r.figures.iter().find(|f| f.stem == stem).unwrap().svg;
        assert!(
            !svg.contains("not shown"),
            "{stem}: the title lists no left-out variants"
        );
        let cases = summary["damping"][study].as_array().unwrap();
        let unstable: Vec<&str> = cases
            .iter()
            .filter(|c| c["step_closed_loop_stable"] == false)
            .map(|c| c["case"].as_str().unwrap())
            .collect();
        assert!(!unstable.is_empty(), "{study}");
        for case in unstable {
            let note = format!("{case}: unstable (pole +");
            assert!(svg.contains(&note), "{stem} lacks the legend entry {note}");
            // and its curve is drawn, over the short window until it diverges
            assert!(
                svg.contains("diverging: drawn until |x − x0| &gt; 15 mm")
                    || svg.contains("diverging: drawn until |x − x0| > 15 mm"),
                "{stem}"
            );
        }
        // the stable curve is named by its case, not "x"
        assert!(svg.contains(">\nidentified rig\n<"), "{stem}");
    }
}

#[test]
fn a_sweep_bounds_b_where_the_steps_cannot_and_both_together_narrow_every_interval() {
    let v = serde_json::to_value(&run().result.summary.sweep_beside_steps).unwrap();
    let truth = [165.0, 100.0, 1.2e-10];
    let keys = ["beta_bar", "viscous_friction_ns_per_m", "c12_m5_per_ns"];
    let width = |set: &str, k: &str| {
        let i = &v[set]["intervals"][k];
        i[1].as_f64().unwrap() - i[0].as_f64().unwrap()
    };
    // the steps cannot bound b (step 9); the sweep, alone or with them, bounds all three
    assert_eq!(
        v["steps"]["identifiable"]["viscous_friction_ns_per_m"],
        false
    );
    for (k, t) in keys.iter().zip(truth) {
        for set in ["sweep_alone", "both"] {
            assert_eq!(v[set]["identifiable"][k], true, "{set} {k}");
        }
        // information adds: the two kinds of record together are narrower than either
        let both = width("both", k);
        assert!(
            both <= width("sweep_alone", k) && both <= width("steps", k),
            "{k}"
        );
        if *k != "viscous_friction_ns_per_m" {
            for set in ["steps", "sweep_alone", "both"] {
                assert_eq!(v[set]["truth_inside"][k], true, "{set} {k} ({t})");
            }
        }
    }
    // the sweep's b is the resonance's effective damping: the emulator's Coulomb friction and
    // dead band damp it beyond the 100 N·s/m of viscous friction, never below it
    let lo = v["sweep_alone"]["intervals"]["viscous_friction_ns_per_m"][0]
        .as_f64()
        .unwrap();
    assert!(lo > truth[1], "{lo}");
    assert!(run()
        .result
        .figures
        .iter()
        .any(|f| f.stem == "sweep_beside_steps"));
}
