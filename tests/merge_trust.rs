//! `identify-merge` trusts nothing it is given: shards made with another rig file, other
//! options, a missing stage, an edited top list, an index out of range or an absurd shard count
//! are errors (exit 1, no panic), never a confident wrong answer.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn pumpcyl(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap()
}

/// A two-stage experiment over a committed record, with its own rig file.
fn setup(dir: &Path) {
    let peer = Path::new(env!("CARGO_MANIFEST_DIR")).join("bench/peer/ident.csv");
    std::fs::copy(peer, dir.join("ident.csv")).unwrap();
    std::fs::write(dir.join("rig.toml"), "mass_kg = 10593.0\n").unwrap();
    std::fs::write(
        dir.join("exp.toml"),
        "rig = \"rig.toml\"\n[standstill]\nw1_rpm = -160.0\nw2_rpm = 245.0\np1_bar = 3.95\n\
         [grid]\nbeta_bar = [150.0, 165.0, 180.0]\nviscous_friction_ns_per_m = [100.0]\n\
         c12_m5_per_ns = [1.2e-10]\n\
         [refined_grid]\nbeta_bar = [160.0, 165.0, 170.0]\nviscous_friction_ns_per_m = [100.0]\n\
         c12_m5_per_ns = [1.2e-10]\n\
         [[dataset]]\nfile = \"ident.csv\"\nkp = 25.0\nmass_kg = 10593.0\nfit_end_s = 3.7\n",
    )
    .unwrap();
}

/// [`setup`] with a first grid of 36 candidates, so the shards have real top lists and
/// threshold sets.
fn setup_36(d: &Path) {
    setup(d);
    let exp = std::fs::read_to_string(d.join("exp.toml"))
        .unwrap()
        .replace(
            "[grid]\nbeta_bar = [150.0, 165.0, 180.0]\nviscous_friction_ns_per_m = [100.0]\n\
         c12_m5_per_ns = [1.2e-10]",
            "[grid]\nbeta_bar = [140.0, 150.0, 160.0, 170.0, 180.0, 190.0]\n\
         viscous_friction_ns_per_m = [100.0, 150.0]\nc12_m5_per_ns = [1.1e-10, 1.2e-10, 1.3e-10]",
        );
    std::fs::write(d.join("exp.toml"), exp).unwrap();
}

fn shard(dir: &Path, i: usize, extra: &[&str]) -> PathBuf {
    let s = format!("{i}/2");
    let mut args = vec![
        "identify",
        "exp.toml",
        "--no-refine",
        "--shard",
        &s,
        "--out",
        "parts",
    ];
    args.extend(extra);
    let out = pumpcyl(dir, &args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    dir.join(format!("parts/part-{i}-of-2.json"))
}

/// Merge the two parts; (exit code, stderr).
fn merge(dir: &Path) -> (Option<i32>, String) {
    let out = pumpcyl(
        dir,
        &[
            "identify-merge",
            "parts/part-1-of-2.json",
            "parts/part-2-of-2.json",
            "--json",
        ],
    );
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!err.contains("panicked"), "{err}");
    (out.status.code(), err)
}

fn edit(path: &Path, f: impl FnOnce(&mut Value)) {
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    f(&mut v);
    std::fs::write(path, v.to_string()).unwrap();
}

fn refused(dir: &Path, words: &[&str]) {
    let (code, err) = merge(dir);
    assert_eq!(code, Some(1), "{err}");
    for w in words {
        assert!(err.contains(w), "message lacks `{w}`: {err}");
    }
}

#[test]
fn merge_refuses_what_it_cannot_vouch_for() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    setup(d);
    let p1 = shard(d, 1, &[]);
    shard(d, 2, &[]);
    assert_eq!(merge(d).0, Some(0));
    let good = std::fs::read_to_string(&p1).unwrap();
    let restore = || std::fs::write(&p1, &good).unwrap();

    // an edited top list: a beta of 999 at cost 1e-9
    edit(&p1, |v| {
        let top = &mut v["stages"][0]["summary"]["top"][0];
        top["cost_mm2"] = 1e-9.into();
        top["beta_bar"] = 999.0.into();
    });
    refused(d, &["edited"]);
    restore();
    // the same cost in the top list and the threshold set: only a simulation can tell
    edit(&p1, |v| {
        let s = summary(v);
        s["top"][0]["cost_mm2"] = 1e-9.into();
        s["threshold_members"][0]["cost_mm2"] = 1e-9.into();
    });
    refused(d, &["part-1-of-2.json", "top[0]", "simulated again"]);
    restore();
    edit(&p1, |v| summary(v)["top"][0]["cost_mm2"] = 1e-9.into());
    refused(d, &["part-1-of-2.json", "top[0]", "threshold set's best"]);
    restore();

    // a shard missing a stage
    edit(&p1, |v| {
        v["stages"].as_array_mut().unwrap().pop();
    });
    refused(d, &["1 stage(s)", "has 2"]);
    restore();

    // an index out of range, and an absurd shard count
    edit(&p1, |v| v["shard"] = serde_json::json!([5, 2]));
    refused(d, &["5/2"]);
    restore();
    edit(&p1, |v| {
        v["shard"] = serde_json::json!([1, 1_000_000_000_000_000u64])
    });
    refused(d, &["part-1-of-2.json", "1/1000000000000000", "N <= 1000"]);
    restore();
    assert_eq!(merge(d).0, Some(0));

    // a shard made with other options
    shard(d, 1, &["--threshold-mm2", "0.5"]);
    refused(d, &["threshold_mm2"]);
    shard(d, 1, &[]);
    assert_eq!(merge(d).0, Some(0));

    // the rig file changed after the shards ran
    std::fs::write(d.join("rig.toml"), "mass_kg = 9000.0\n").unwrap();
    refused(d, &["rig", "changed since this shard ran"]);
}

#[test]
fn merge_never_replaces_the_folder_that_holds_its_parts() {
    // the shards written into the folder an earlier result lives in, merged back into it:
    // replacing that folder whole would delete the part files the merge reads
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    setup(d);
    shard(d, 1, &[]);
    shard(d, 2, &[]);
    let out = pumpcyl(
        d,
        &[
            "identify-merge",
            "parts/part-1-of-2.json",
            "parts/part-2-of-2.json",
            "--out",
            "parts",
        ],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("holds the input"), "{err}");
    for i in 1..=2 {
        assert!(d.join(format!("parts/part-{i}-of-2.json")).is_file());
    }
}

/// The answer a merge gives: the best grid point and the top list (the identified parameters).
fn answer(v: &Value) -> (Value, Value) {
    (v["grid_best"].clone(), v["top"].clone())
}

/// Merge the given part files; the JSON answer, or None when refused (exit 1, one line).
fn merged(dir: &Path, parts: &[&str]) -> Option<Value> {
    let mut args = vec!["identify-merge", "--json"];
    args.extend(parts);
    let out = pumpcyl(dir, &args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    match out.status.code() {
        Some(0) => Some(serde_json::from_slice(&out.stdout).unwrap()),
        Some(1) => {
            assert_eq!(err.lines().count(), 1, "{err}");
            None
        }
        code => panic!("exit {code:?}: {err}"),
    }
}

#[test]
fn every_single_edit_of_a_shard_is_refused_or_changes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    setup_36(d);
    let whole = pumpcyl(
        d,
        &[
            "identify",
            "exp.toml",
            "--no-refine",
            "--json",
            "--threshold-mm2",
            "1",
        ],
    );
    assert!(whole.status.success());
    let whole = answer(&serde_json::from_slice(&whole.stdout).unwrap());
    let (p1, p2) = (
        shard(d, 1, &["--threshold-mm2", "1"]),
        shard(d, 2, &["--threshold-mm2", "1"]),
    );
    let parts = ["parts/part-1-of-2.json", "parts/part-2-of-2.json"];
    assert_eq!(merged(d, &parts).map(|v| answer(&v)), Some(whole.clone()));
    let good = std::fs::read_to_string(&p1).unwrap();
    let stage = |v: &mut Value| v["stages"][0]["summary"].clone();
    assert!(stage(&mut serde_json::from_str(&good).unwrap())["threshold_count"].as_u64() > Some(0));

    type Edit = (&'static str, fn(&mut Value));
    let edits: [Edit; 16] = [
        ("best removed", |v| {
            v["stages"][0]["summary"]["top"]
                .as_array_mut()
                .unwrap()
                .remove(0);
        }),
        ("evaluated", |v| {
            v["stages"][0]["summary"]["evaluated"] = 17.into()
        }),
        ("non_finite", |v| {
            v["stages"][0]["summary"]["non_finite"] = 99.into()
        }),
        ("unstable", |v| {
            v["stages"][0]["summary"]["unstable"] = 99.into()
        }),
        ("pruned", |v| {
            v["stages"][0]["summary"]["pruned"] = 99.into()
        }),
        ("slice index", |v| v["shard"] = serde_json::json!([2, 2])),
        ("total", |v| v["shard"] = serde_json::json!([1, 1])),
        ("grid bound", |v| {
            v["stages"][0]["grid"]["beta_bar"][0] = 100.0.into()
        }),
        ("record hash", |v| v["digest"] = "0123456789abcdef".into()),
        ("negative time", |v| v["seconds"] = (-4.96).into()),
        ("top cost", |v| {
            v["stages"][0]["summary"]["top"][0]["cost_mm2"] = 1e-9.into()
        }),
        ("top index", |v| {
            v["stages"][0]["summary"]["top"][0]["index"] = 1.into()
        }),
        ("threshold count", |v| {
            v["stages"][0]["summary"]["threshold_count"] = 1000.into()
        }),
        ("threshold bound", |v| {
            v["stages"][0]["summary"]["threshold_bounds"][0][0] = 1000.0.into()
        }),
        ("member cost", |v| {
            v["stages"][0]["summary"]["threshold_members"][0]["cost_mm2"] = 5.0.into()
        }),
        ("top order", |v| {
            v["stages"][0]["summary"]["top"]
                .as_array_mut()
                .unwrap()
                .swap(0, 1);
        }),
    ];
    for (what, f) in edits {
        edit(&p1, f);
        if let Some(v) = merged(d, &parts) {
            assert_eq!(answer(&v), whole, "edit `{what}` changed the answer");
        }
        std::fs::write(&p1, &good).unwrap();
    }
    // one shard relabelled as the whole run, and a shard given twice with the copy relabelled
    edit(&p1, |v| v["shard"] = serde_json::json!([1, 1]));
    assert_eq!(merged(d, &["parts/part-1-of-2.json"]), None);
    std::fs::write(&p1, &good).unwrap();
    let copy = d.join("parts/copy.json");
    std::fs::copy(&p1, &copy).unwrap();
    edit(&copy, |v| v["shard"] = serde_json::json!([2, 2]));
    assert_eq!(
        merged(d, &["parts/part-1-of-2.json", "parts/copy.json"]),
        None
    );
    drop(p2);
}

/// The first stage's summary of a partial result.
fn summary(v: &mut Value) -> &mut Value {
    &mut v["stages"][0]["summary"]
}

#[test]
fn merge_simulates_again_what_it_reports_and_holds_the_top_list_to_the_members() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    setup_36(d);
    // top lists of 10 of the 18 candidates of each slice, 9 of them below the threshold
    let p1 = shard(d, 1, &["--threshold-mm2", "0.06", "--top", "10"]);
    shard(d, 2, &["--threshold-mm2", "0.06", "--top", "10"]);
    // shard 1 once more with one more place in its top list: its real 11th candidate
    let longer = pumpcyl(
        d,
        &[
            "identify",
            "exp.toml",
            "--no-refine",
            "--shard",
            "1/2",
            "--out",
            "long",
            "--threshold-mm2",
            "0.06",
            "--top",
            "11",
        ],
    );
    assert!(longer.status.success());
    let long: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("long/part-1-of-2.json")).unwrap())
            .unwrap();
    let parts = ["parts/part-1-of-2.json", "parts/part-2-of-2.json"];
    let whole = merged(d, &parts).expect("the honest shards merge");
    let good = std::fs::read_to_string(&p1).unwrap();
    let first: Value = serde_json::from_str(&good).unwrap();
    let s = &first["stages"][0]["summary"];
    assert_eq!(s["top"].as_array().unwrap().len(), 10);
    assert_eq!(s["threshold_count"].as_u64(), Some(9), "{s}");

    let eleventh = long["stages"][0]["summary"]["top"][10].clone();
    type Variant<'a> = (&'a str, Box<dyn Fn(&mut Value) + 'a>, &'a [&'a str]);
    let variants: Vec<Variant> = vec![
        (
            "the best removed, the 11th appended",
            Box::new(|v: &mut Value| {
                let top = summary(v)["top"].as_array_mut().unwrap();
                top.remove(0);
                top.push(eleventh.clone());
            }),
            &["top[0]", "threshold set's best"],
        ),
        (
            "the best removed",
            Box::new(|v: &mut Value| {
                summary(v)["top"].as_array_mut().unwrap().remove(0);
            }),
            &["top list of 9"],
        ),
        (
            "the best's cost raised and moved last",
            Box::new(|v: &mut Value| {
                let top = summary(v)["top"].as_array_mut().unwrap();
                let mut best = top.remove(0);
                best["cost_mm2"] = (top.last().unwrap()["cost_mm2"].as_f64().unwrap() + 1.0).into();
                top.push(best);
            }),
            &["top[0]", "threshold set's best"],
        ),
        (
            "threshold_count raised by one",
            Box::new(|v: &mut Value| {
                let n = summary(v)["threshold_count"].as_u64().unwrap();
                summary(v)["threshold_count"] = (n + 1).into();
            }),
            &["threshold_count", "threshold_members"],
        ),
        (
            "a cost edited at top[3], in order, in the top list and the member list alike",
            Box::new(|v: &mut Value| {
                let top = &summary(v)["top"];
                let mid = (top[2]["cost_mm2"].as_f64().unwrap()
                    + top[3]["cost_mm2"].as_f64().unwrap())
                    / 2.0;
                summary(v)["top"][3]["cost_mm2"] = mid.into();
                summary(v)["threshold_members"][3]["cost_mm2"] = mid.into();
            }),
            &["top[3]", "simulated again"],
        ),
        (
            "a cost edited at top[3] alone",
            Box::new(|v: &mut Value| {
                let top = &summary(v)["top"];
                let mid = (top[2]["cost_mm2"].as_f64().unwrap()
                    + top[3]["cost_mm2"].as_f64().unwrap())
                    / 2.0;
                summary(v)["top"][3]["cost_mm2"] = mid.into();
            }),
            &["top[3]"],
        ),
        (
            "the threshold set's bounds widened",
            Box::new(|v: &mut Value| {
                let lo = summary(v)["threshold_bounds"][0][0].as_f64().unwrap();
                summary(v)["threshold_bounds"][0][0] = (lo - 10.0).into();
            }),
            &["threshold_bounds"],
        ),
    ];
    for (what, change, words) in variants {
        edit(&p1, change);
        let out = pumpcyl(d, &["identify-merge", "--json", parts[0], parts[1]]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "`{what}` was accepted: {err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        for w in words.iter().chain(&["part-1-of-2.json", "stage 1"]) {
            assert!(err.contains(w), "`{what}`: the message lacks `{w}`: {err}");
        }
        std::fs::write(&p1, &good).unwrap();
    }
    assert_eq!(merged(d, &parts).map(|v| answer(&v)), Some(answer(&whole)));
}

#[test]
fn shard_labels_are_bounded_by_the_grids_and_a_documented_maximum() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    setup(d);
    let run = |label: &str| {
        pumpcyl(
            d,
            &[
                "identify",
                "exp.toml",
                "--no-refine",
                "--shard",
                label,
                "--out",
                "labels",
            ],
        )
    };
    // three candidates in each grid: a fourth shard would evaluate nothing
    for (label, words) in [
        ("1/99999999999", ["1/99999999999", "N <= 1000"]),
        ("1/1001", ["1/1001", "N <= 1000"]),
        ("1/4", ["1/4", "3 candidates"]),
    ] {
        let out = run(label);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{label}: {err}");
        for w in words {
            assert!(err.contains(w), "{label}: the message lacks `{w}`: {err}");
        }
    }
    assert!(!d.join("labels").exists());
    assert!(run("3/3").status.success());
    // a label edited after the run: the merge refuses it before it counts the parts
    let p = d.join("labels/part-3-of-3.json");
    edit(&p, |v| {
        v["shard"] = serde_json::json!([1, 99_999_999_999u64])
    });
    let out = pumpcyl(d, &["identify-merge", "labels/part-3-of-3.json"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("part-3-of-3.json") && err.contains("N <= 1000"),
        "{err}"
    );
}
