//! The bad-input corpus (tests/bad-inputs/cases.toml): every bad file makes pumpcyl exit with
//! status 1 and one line on stderr naming the file, line and field, without a panic, without
//! output on stdout and without leaving a file behind. And the awkward but valid files of
//! tests/awkward-inputs/ are read exactly like their plain form.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn corpus() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/bad-inputs")
}

fn pumpcyl(dir: &Path, args: &[String]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("pumpcyl runs")
}

/// Everything wrong with one failed run, or nothing.
fn judge(out: &Output, out_dir: &Path, expect: &[String]) -> Vec<String> {
    let stderr = String::from_utf8_lossy(&out.stderr);
    let mut faults = Vec::new();
    if out.status.code() != Some(1) {
        faults.push(format!("exit status {:?}, expected 1", out.status.code()));
    }
    if stderr.contains("panicked") {
        faults.push("panicked".into());
    }
    if !out.stdout.is_empty() {
        faults.push(format!("stdout: {}", String::from_utf8_lossy(&out.stdout)));
    }
    if stderr.lines().count() != 1 || !stderr.starts_with("error: ") {
        faults.push("stderr is not one `error: ` line".into());
    }
    for word in expect {
        if !stderr.contains(word.as_str()) {
            faults.push(format!("message lacks `{word}`"));
        }
    }
    let left: Vec<_> = std::fs::read_dir(out_dir).unwrap().flatten().collect();
    if !left.is_empty() {
        faults.push(format!("left {} file(s) in the output folder", left.len()));
    }
    faults
}

#[derive(serde::Deserialize)]
struct Corpus {
    defaults: std::collections::BTreeMap<String, Vec<String>>,
    case: Vec<Case>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Case {
    file: String,
    args: Option<Vec<String>>,
    expect: Vec<String>,
}

/// The command line of a case, placeholders filled in.
fn command_line(corpus: &Corpus, case: &Case, out_dir: &Path) -> Vec<String> {
    let folder = case.file.split('/').next().unwrap();
    let args = case
        .args
        .as_ref()
        .or_else(|| corpus.defaults.get(folder))
        .unwrap_or_else(|| panic!("{}: no args and no default for `{folder}`", case.file));
    args.iter()
        .map(|a| {
            a.replace("{file}", &case.file)
                .replace("{out}", &out_dir.display().to_string())
        })
        .collect()
}

#[test]
fn every_bad_file_gets_one_located_error_and_leaves_nothing_behind() {
    let dir = corpus();
    let text = std::fs::read_to_string(dir.join("cases.toml")).unwrap();
    let corpus: Corpus = toml::from_str(&text).unwrap();
    assert!(corpus.case.len() >= 60, "{} cases", corpus.case.len());
    let mut failures = Vec::new();
    for case in &corpus.case {
        let out_dir = tempfile::tempdir().unwrap();
        let args = command_line(&corpus, case, out_dir.path());
        let out = pumpcyl(&dir, &args);
        let faults = judge(&out, out_dir.path(), &case.expect);
        if !faults.is_empty() {
            failures.push(format!(
                "pumpcyl {}\n  {}\n  stderr: {}",
                args.join(" "),
                faults.join("; "),
                String::from_utf8_lossy(&out.stderr).trim_end()
            ));
        }
    }
    assert!(failures.is_empty(), "\n{}", failures.join("\n"));
}

#[test]
fn every_corpus_file_is_listed_in_the_cases() {
    let dir = corpus();
    let text = std::fs::read_to_string(dir.join("cases.toml")).unwrap();
    let listed: Vec<String> = toml::from_str::<Corpus>(&text)
        .unwrap()
        .case
        .into_iter()
        .map(|c| c.file)
        .collect();
    for folder in ["record", "standstill", "drive", "rig", "ss", "experiment"] {
        for entry in std::fs::read_dir(dir.join(folder)).unwrap().flatten() {
            let file = format!("{folder}/{}", entry.file_name().to_string_lossy());
            assert!(listed.contains(&file), "{file} has no case in cases.toml");
        }
    }
}

/// A bad rig fails every command that reads a rig in the same words, before any output.
#[test]
fn a_bad_rig_stops_every_command_that_reads_one() {
    let dir = corpus();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/article");
    let record = data.join("identification.csv").display().to_string();
    let drive = data.join("drive_step.csv").display().to_string();
    let commands: [&[&str]; 14] = [
        &["rig"],
        &["margins"],
        &["bode", "--out", "{out}/bode.svg"],
        &["poles"],
        &["model", "--json"],
        &["step", "--out", "{out}/step.csv"],
        &["track", "--article-cases", "--out", "{out}/track.png"],
        &["simulate", "--data", &record, "--out", "{out}/sim.csv"],
        &[
            "leakage",
            "--w1-rpm=-135",
            "--w2-rpm=208",
            "--p1-bar=3.5",
            "--c12=1e-10",
        ],
        &["identify-drive", &drive, "--out", "{out}/drive.csv"],
        &["bulk-modulus", "--out", "{out}/bulk.csv"],
        &["design"],
        &["chatter", "--out", "{out}/chatter.csv"],
        &["emulate", "--experiment", "step", "--out", "{out}/step.csv"],
    ];
    let expect = ["rig/negative_mass.toml", "line 2", "key `mass_kg` = -10593"].map(String::from);
    for command in commands {
        let out_dir = tempfile::tempdir().unwrap();
        let mut args: Vec<String> = command
            .iter()
            .map(|a| a.replace("{out}", &out_dir.path().display().to_string()))
            .collect();
        args.extend(["--rig".into(), "rig/negative_mass.toml".into()]);
        let out = pumpcyl(&dir, &args);
        let faults = judge(&out, out_dir.path(), &expect);
        assert!(faults.is_empty(), "pumpcyl {}: {faults:?}", args.join(" "));
    }
}

/// The position MSE `simulate --json` reports for a record.
fn simulated_mse(file: &str) -> f64 {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/awkward-inputs");
    let out = pumpcyl(
        &dir,
        &["simulate", "--data", file, "--json"].map(String::from),
    );
    assert!(
        out.status.success(),
        "{file}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    json["mse_mm2"].as_f64().unwrap()
}

#[test]
fn spreadsheet_exports_replay_exactly_like_the_plain_record() {
    let plain = simulated_mse("clean.csv");
    assert!(plain > 1e-4 && plain < 1.0, "{plain}");
    for file in [
        "crlf_bom.csv",
        "semicolon_decimal_comma.csv",
        "reordered_extra_columns.csv",
    ] {
        assert_eq!(simulated_mse(file), plain, "{file}");
    }
    // shifting the time axis by 1000 s changes the sample spacings in their last bits only
    let shifted = simulated_mse("time_offset.csv");
    assert!(
        (shifted - plain).abs() < 1e-9 * plain,
        "{shifted} vs {plain}"
    );
}

#[test]
fn a_rig_saved_with_crlf_and_a_byte_order_mark_is_the_same_rig() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/awkward-inputs");
    let margins = |args: &[&str]| {
        let mut all = vec!["margins", "--json"];
        all.extend(args);
        let all: Vec<String> = all.iter().map(|s| s.to_string()).collect();
        let out = pumpcyl(&dir, &all);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8(out.stdout).unwrap()
    };
    let from_file = margins(&["--rig", "rig_crlf_bom.toml"]);
    let default = margins(&[]);
    let headline = |s: &str| {
        let v: serde_json::Value = serde_json::from_str(s).unwrap();
        (v["gain_margin_db"].clone(), v["phase_margin_deg"].clone())
    };
    assert_eq!(headline(&from_file), headline(&default));
}
