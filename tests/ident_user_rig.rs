//! `identify` and `advise` on a user's rig that shares no value with the article's
//! (docs/identification.md#the-two-grids): the grids follow the rig and the first stage's best,
//! a best on a grid's edge is a warning in the text and the JSON, a parameter the records cannot
//! bound (b from steps) is said to be so, and the article's experiment keeps its grids.

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;

use run::{json, pumpcyl, refused};
use std::path::Path;

/// A rig of its own: 80/45 mm, 2500 kg, 8 cm³/rev, β 300 bar, 800 mm stroke.
const RIG: &str = "piston_diameter_mm = 80.0\nrod_diameter_mm = 45.0\nstroke_mm = 800.0\n\
    x0_mm = 400.0\nmass_kg = 2500.0\nmass_by_position = []\ndisplacement_1_cm3_per_rev = 8.0\n\
    displacement_2_cm3_per_rev = 5.0\nbeta_bar = 300.0\nkp = 15.0\n\
    viscous_friction_ns_per_m = 250.0\nc12_m5_per_ns = 2.0e-10\nline_volume_1_dm3 = 0.2\n\
    line_volume_2_dm3 = 0.2\n";

/// The experiment's datasets: 5 mm steps at Kp 15 and 10 on the user rig.
const DATASETS: &str = "[standstill]\nrecord = \"standstill.csv\"\n\n\
    [[dataset]]\nfile = \"step15.csv\"\nkp = 15.0\nmass_kg = 2500.0\nfit_end_s = 3.0\n\n\
    [[dataset]]\nfile = \"step10.csv\"\nkp = 10.0\nmass_kg = 2500.0\nfit_end_s = 3.0\n";

/// Write the rig, its emulated records (every emulator effect off, so the records follow the
/// rig's β of 300 bar exactly; sensor noise on) and an experiment with `extra` on top.
fn user_rig(dir: &Path, extra: &str) {
    std::fs::write(dir.join("rig.toml"), RIG).unwrap();
    let step = |kp: &str, out: &str| {
        let set = format!("kp={kp}");
        let args = [
            "emulate",
            "--experiment",
            "step",
            "--rig",
            "rig.toml",
            "--set",
            &set,
            "--no-effects",
            "--from-mm",
            "395",
            "--to-mm",
            "400",
            "--duration-s",
            "4",
            "--out",
            out,
        ];
        assert!(pumpcyl(dir, &args).status.success(), "{out}");
    };
    step("15", "step15.csv");
    step("10", "step10.csv");
    let args = [
        "emulate",
        "--experiment",
        "standstill",
        "--rig",
        "rig.toml",
        "--no-effects",
        "--duration-s",
        "2",
        "--out",
        "standstill.csv",
    ];
    assert!(pumpcyl(dir, &args).status.success());
    let text = format!("rig = \"rig.toml\"\n{extra}\n{DATASETS}");
    std::fs::write(dir.join("exp.toml"), text).unwrap();
}

/// [lo, hi] of a stage grid's axis in the JSON.
fn span(v: &serde_json::Value, stage: usize, axis: &str) -> [f64; 2] {
    let a = &v["stage_grids"][stage][axis];
    [a[0].as_f64().unwrap(), a[1].as_f64().unwrap()]
}

#[test]
fn the_grids_follow_the_rig_and_the_first_stage_and_b_is_said_not_identifiable() {
    let dir = tempfile::tempdir().unwrap();
    user_rig(dir.path(), "");
    let v = json(dir.path(), &["identify", "exp.toml", "--json"]);
    // the first grid centred on the rig's 300 bar (÷/× 8), not the article's 25 … 1000 bar
    let [lo, hi] = span(&v, 0, "beta_bar");
    assert!(
        (lo - 37.5).abs() < 1e-9 && (hi - 2400.0).abs() < 1e-9,
        "{lo} {hi}"
    );
    // the second centred on the first stage's best: β of the records inside it, not 130 … 220
    let [lo2, hi2] = span(&v, 1, "beta_bar");
    assert!(lo2 > 220.0 && lo2 < 300.0 && hi2 > 300.0, "{lo2} {hi2}");
    let beta = v["beta_bar"].as_f64().unwrap();
    assert!((beta / 300.0 - 1.0).abs() < 0.03, "beta {beta}");
    // b is not bounded by steps: said so, with the reason; β and c12 are
    assert_eq!(v["identifiable"]["viscous_friction_ns_per_m"], false, "{v}");
    assert_eq!(v["identifiable"]["beta_bar"], true, "{v}");
    assert_eq!(v["identifiable"]["c12_m5_per_ns"], true, "{v}");
    let why = v["not_identifiable"]["viscous_friction_ns_per_m"]
        .as_str()
        .unwrap();
    assert!(why.contains("decade"), "{why}");
    assert!(v["rig"].as_str().unwrap().contains("rig.toml"));
    // the text prints the verdict instead of a value that looks like a result
    let out = pumpcyl(dir.path(), &["identify", "exp.toml"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("b: not identifiable from these records ("),
        "{text}"
    );
    let refined = text.lines().find(|l| l.contains("refined (N-M)")).unwrap();
    assert!(refined.contains("b      n/a N·s/m"), "{refined}");
    assert!(
        text.contains("centred on the rig's values: beta_bar 300"),
        "{text}"
    );
}

#[test]
fn a_best_on_the_edge_of_any_stage_is_a_warning_in_the_text_and_the_json() {
    let dir = tempfile::tempdir().unwrap();
    // a first grid entirely below the records' β of 300 bar
    let grid = "[grid]\nbeta_bar = [100.0, 150.0, 200.0]\nviscous_friction_ns_per_m = [250.0]\n\
        c12_m5_per_ns = [2.0e-10]\n";
    user_rig(dir.path(), grid);
    let v = json(
        dir.path(),
        &["identify", "exp.toml", "--json", "--no-refine"],
    );
    let warnings: Vec<&str> = v["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap())
        .collect();
    // stage 1's best, 200 bar, is its top edge; stage 2 (centred there, 150 … 266.7 bar) ends
    // on its own top edge as well
    assert!(
        warnings.iter().any(|w| w
            .starts_with("the best grid point has beta_bar = 200 on the edge of the stage 1 grid")
            && w.contains("the grid of stage 2 reaches beyond it")),
        "{warnings:?}"
    );
    assert!(
        warnings.iter().any(|w| w.starts_with(
            "the best grid point has beta_bar = 266.7 on the edge of the stage 2 grid"
        ) && w.contains("the optimum may lie outside it")),
        "{warnings:?}"
    );
    let [lo2, hi2] = span(&v, 1, "beta_bar");
    assert!(
        (lo2 - 150.0).abs() < 1e-9 && (hi2 - 800.0 / 3.0).abs() < 1e-9,
        "{lo2} {hi2}"
    );
    let out = pumpcyl(dir.path(), &["identify", "exp.toml", "--no-refine"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains(
            "  warning: the best grid point has beta_bar = 266.7 on the edge of the stage 2"
        ),
        "{text}"
    );
}

/// A best grid point on the edge of the last grid is no warning when the local refinement's
/// answer lies inside the grid's range: the optimum is inside (without the refinement it is
/// a warning, as it must be).
#[test]
fn an_edge_of_the_last_grid_is_no_warning_when_the_polished_answer_lies_inside() {
    let dir = tempfile::tempdir().unwrap();
    // the second grid's two β values, 250 and 305 bar: its best is its top edge, while the
    // records' β of 300 bar lies inside it
    let grid = "[grid]\nbeta_bar = [200.0, 300.0, 400.0]\nviscous_friction_ns_per_m = [250.0]\n\
        c12_m5_per_ns = [2.0e-10]\n\n[refined_grid]\nbeta_bar = [250.0, 305.0]\n\
        viscous_friction_ns_per_m = [250.0]\nc12_m5_per_ns = [2.0e-10]\n";
    user_rig(dir.path(), grid);
    let last_edge = |v: &serde_json::Value| {
        (v["warnings"].as_array().unwrap().iter()).any(|w| {
            w.as_str()
                .unwrap()
                .contains("on the edge of the stage 2 grid")
        })
    };
    let unpolished = json(
        dir.path(),
        &["identify", "exp.toml", "--json", "--no-refine"],
    );
    assert!(last_edge(&unpolished), "{}", unpolished["warnings"]);
    let v = json(dir.path(), &["identify", "exp.toml", "--json"]);
    let beta = v["beta_bar"].as_f64().unwrap();
    assert!(
        180.0 < beta && beta < 320.0 && (beta / 300.0 - 1.0).abs() < 0.03,
        "{beta}"
    );
    assert!(!last_edge(&v), "{}", v["warnings"]);
}

#[test]
fn a_zero_rig_value_without_a_range_and_a_centred_shard_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    user_rig(dir.path(), "[set]\nviscous_friction_ns_per_m = 0.0\n");
    refused(
        dir.path(),
        &["identify", "exp.toml"],
        &["exp.toml", "viscous_friction_ns_per_m", "[ranges]"],
    );
    // with a range for b it runs: the first grid spans the range
    let ranged = std::fs::read_to_string(dir.path().join("exp.toml"))
        .unwrap()
        .replace(
            "[set]",
            "[ranges]\nviscous_friction_ns_per_m = [10.0, 1000.0]\n\n[set]",
        );
    std::fs::write(dir.path().join("exp.toml"), ranged).unwrap();
    let v = json(
        dir.path(),
        &["identify", "exp.toml", "--json", "--no-refine"],
    );
    assert_eq!(span(&v, 0, "viscous_friction_ns_per_m"), [10.0, 1000.0]);
    refused(
        dir.path(),
        &["identify", "exp.toml", "--shard", "1/2", "--out", "parts"],
        &["shard", "centred on the first stage's best", "refined_grid"],
    );
}

#[test]
fn the_article_experiment_keeps_the_article_grids() {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/article/identify.toml");
    let dir = tempfile::tempdir().unwrap();
    let v = json(
        dir.path(),
        &["identify", file.to_str().unwrap(), "--json", "--no-refine"],
    );
    assert_eq!(
        v["stage_grids"][0]["beta_bar"],
        serde_json::json!([25.0, 1000.0, 16])
    );
    assert_eq!(
        v["stage_grids"][1]["beta_bar"],
        serde_json::json!([130.0, 220.0, 19])
    );
    assert_eq!(v["candidates_evaluated"], 3264 + 3553);
    assert!(v["rig"].as_str().unwrap().contains("article's rig"));
}

#[test]
fn advise_on_a_user_rig_says_where_it_linearised_and_gives_no_ratio_of_unbounded_widths() {
    let dir = tempfile::tempdir().unwrap();
    user_rig(dir.path(), "");
    let out = pumpcyl(dir.path(), &["advise", "exp.toml"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("linearised at beta"), "{text}");
    assert!(
        text.contains("polished from identify's answer beta"),
        "{text}"
    );
    assert!(!text.contains("unbounded -> unbounded"), "{text}");
    let v = json(dir.path(), &["advise", "exp.toml", "--json"]);
    let point = v["point"]["beta_bar"].as_f64().unwrap();
    let identified = v["identified"]["beta_bar"].as_f64().unwrap();
    assert!((point / 300.0 - 1.0).abs() < 0.03 && (identified / 300.0 - 1.0).abs() < 0.03);
    // the steps leave b at its search bound: linearised there (b = 1 N·s/m, no friction) no
    // record could show b; the model is linearised at the rig's 250 N·s/m instead, said so,
    // and a sweep is then expected to bound b
    assert_eq!(
        v["point_from_rig"],
        serde_json::json!(["viscous_friction_ns_per_m"])
    );
    assert_eq!(v["point"]["viscous_friction_ns_per_m"], 250.0);
    assert!(
        text.contains("b: identify's estimate sits at its search bound"),
        "{text}"
    );
    assert_eq!(v["current"][1]["interval"], serde_json::Value::Null);
    let best_b = v["best_for"]["viscous_friction_ns_per_m"].as_str().unwrap();
    let bounded = (v["candidates"].as_array().unwrap().iter())
        .find(|c| c["label"] == best_b)
        .map(|c| c["widths"][1]["relative_width"].as_f64().unwrap())
        .unwrap();
    assert!(
        best_b.contains("multisine") && bounded < 0.1,
        "{best_b}: {bounded}"
    );
    // the candidates' gains are the records' 15 and 10 and 0.6, 1.4 times 15: the rig's own,
    // never the article's 25 or 35
    let labels: Vec<&str> = (v["candidates"].as_array().unwrap().iter())
        .map(|c| c["label"].as_str().unwrap())
        .chain(
            v["skipped"]
                .as_array()
                .unwrap()
                .iter()
                .map(|s| s.as_str().unwrap()),
        )
        .collect();
    assert!(labels.len() >= 40, "{labels:?}");
    for gain in ["Kp 9,", "Kp 10,", "Kp 15,", "Kp 21,"] {
        assert!(
            labels.iter().any(|l| l.contains(gain)),
            "{gain}: {labels:?}"
        );
    }
    let theirs = |l: &&&str| {
        ["Kp 9,", "Kp 10,", "Kp 15,", "Kp 21,"]
            .iter()
            .any(|g| l.contains(g))
    };
    assert!(labels.iter().all(|l| theirs(&l)), "{labels:?}");
}

/// `design --robust --experiment` on steps that cannot bound b (the usual case): the polished
/// answer wanders along the flat b below the profile's search range, and the region is widened
/// to hold it (docs/design.md#robust-design) instead of stopping on the region's invariant; β's
/// interval holds the records' 300 bar.
#[test]
fn a_robust_design_on_steps_that_cannot_bound_b_answers() {
    let dir = tempfile::tempdir().unwrap();
    user_rig(dir.path(), "");
    let v = json(
        dir.path(),
        &["design", "--robust", "--experiment", "exp.toml", "--json"],
    );
    let r = &v["region"];
    assert_eq!(
        r["identifiable"],
        serde_json::json!([true, false, true]),
        "{r}"
    );
    let within = |key: &str, x: f64| {
        let [lo, hi] = [0, 1].map(|k| r[key][k].as_f64().unwrap());
        lo <= x && x <= hi
    };
    let b = r["nominal"]["viscous_friction_ns_per_m"].as_f64().unwrap();
    assert!(within("viscous_friction_ns_per_m", b), "{r}");
    assert!(within("beta_bar", 300.0), "{r}");
    assert!(v["kp_max"].as_f64().unwrap() > 0.0, "{v}");
}
