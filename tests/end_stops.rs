//! The emulator's end stops (docs/emulator.md#end-stops): the piston stays inside its cylinder,
//! `pumpcyl emulate` says when a record met an end, and a loop whose rest lies outside the
//! stroke is refused instead of recorded.

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;

/// The recorded positions (mm) of a record written by `pumpcyl emulate`.
fn positions(path: &std::path::Path) -> Vec<f64> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = header.iter().position(|h| *h == "x_mm").unwrap();
    lines
        .map(|l| l.split(',').nth(col).unwrap().parse().unwrap())
        .collect()
}

/// `pumpcyl emulate ARGS --no-noise --out e.csv`: its standard output and recorded positions.
fn emulate(args: &[&str]) -> (String, Vec<f64>) {
    let dir = tempfile::tempdir().unwrap();
    let mut all = vec!["emulate", "--no-noise", "--out", "e.csv"];
    all.extend_from_slice(args);
    let out = run::pumpcyl(dir.path(), &all);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let x = positions(&dir.path().join("e.csv"));
    (String::from_utf8(out.stdout).unwrap(), x)
}

#[test]
fn a_step_that_overshoots_an_end_is_held_by_its_stop_and_says_so() {
    // the article rig's stroke is 500 mm; the steps overshoot by tens of millimetres
    for (to_mm, end, lo, hi) in [
        ("499", "extended end stop (x = 500 mm)", 499.0, 500.5),
        ("1", "retracted end stop (x = 0 mm)", -0.5, 1.0),
    ] {
        let (stdout, x) = emulate(&["--experiment", "step", "--from-mm", "345", "--to-mm", to_mm]);
        let far = if lo < 0.0 {
            x.iter().cloned().fold(f64::INFINITY, f64::min)
        } else {
            x.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
        };
        // reaches the end, pressed into the stop by no more than half a millimetre
        assert!(far >= lo && far <= hi, "to {to_mm} mm: reached {far} mm");
        let notes: Vec<&str> = stdout.lines().filter(|l| l.starts_with("note:")).collect();
        assert_eq!(notes.len(), 1, "{stdout}");
        assert!(notes[0].contains(end), "{stdout}");
    }
}

#[test]
fn a_record_inside_the_stroke_has_no_note() {
    let (stdout, x) = emulate(&["--experiment", "step"]);
    assert!(!stdout.contains("end stop"), "{stdout}");
    // the article's 5 mm step to x0 = 345 mm, 50 % overshoot at most
    let peak = x.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    assert!(peak > 345.0 && peak < 348.0, "{peak}");
}

#[test]
fn a_loop_whose_rest_is_outside_the_stroke_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    // a position gain too small for the leakage: at rest the error would be metres
    for (kp, experiment, rest) in [
        ("kp=1e-6", "step", "x = -1373"),
        ("kp=1e-3", "step", "x = -10"),
        ("kp=1e-4", "standstill", "x = -13"),
    ] {
        run::refused(
            dir.path(),
            &[
                "emulate",
                "--experiment",
                experiment,
                "--set",
                kp,
                "--out",
                "e.csv",
            ],
            &["cannot rest", rest, "outside the stroke 0…500 mm"],
        );
        assert!(!dir.path().join("e.csv").exists());
    }
}

/// The warnings of `pumpcyl ARGS`, from its standard error, and of its JSON document.
fn linear_warnings(args: &[&str]) -> (Vec<String>, Vec<String>) {
    let dir = tempfile::tempdir().unwrap();
    let out = run::pumpcyl(dir.path(), args);
    assert!(out.status.success(), "{args:?}");
    let stderr: Vec<String> = String::from_utf8_lossy(&out.stderr)
        .lines()
        .filter_map(|l| l.strip_prefix("warning: ").map(str::to_owned))
        .collect();
    let mut json_args = args.to_vec();
    json_args.push("--json");
    let doc = run::json(dir.path(), &json_args);
    let in_json = doc["warnings"].as_array().map_or(vec![], |a| {
        a.iter().map(|w| w.as_str().unwrap().to_owned()).collect()
    });
    (stderr, in_json)
}

#[test]
fn a_linear_prediction_beyond_the_stroke_warns_in_text_and_json() {
    // the article's loop overshoots a step by half: 154 mm from x0 = 345 mm peaks near 577 mm
    let (text, json) = linear_warnings(&["step", "--step-mm", "154"]);
    assert_eq!(text.len(), 1, "{text:?}");
    assert!(
        text[0].contains("reaches 576.") && text[0].contains("outside the stroke 0…500 mm"),
        "{text:?}"
    );
    assert!(json.iter().any(|w| *w == text[0]), "{json:?}");
    // a wave whose lag carries the prediction past the end
    let (text, json) = linear_warnings(&["track", "--freq-hz", "0.2", "--amp-mm", "150"]);
    assert!(
        text.len() == 1 && text[0].contains("outside the stroke"),
        "{text:?}"
    );
    assert_eq!(json, text);
    // inside the stroke: no warning
    for args in [
        &["step", "--step-mm", "5"][..],
        &["track", "--freq-hz", "0.2", "--amp-mm", "35"][..],
    ] {
        let (text, json) = linear_warnings(args);
        assert!(text.is_empty() && json.is_empty(), "{args:?}: {text:?}");
    }
}

#[test]
fn simulate_warns_of_a_prediction_beyond_the_stroke() {
    let dir = tempfile::tempdir().unwrap();
    let mut csv = String::from("time_s,x_ref_mm,x_mm\n");
    for k in 0..300 {
        let t = k as f64 * 0.01;
        let r = if t < 0.5 { 345.0 } else { 499.0 };
        csv.push_str(&format!("{t:.2},{r},{r}\n"));
    }
    std::fs::write(dir.path().join("big.csv"), csv).unwrap();
    let out = run::pumpcyl(dir.path(), &["simulate", "--data", "big.csv"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("warning: the predicted position reaches 5") && err.contains("0…500 mm"),
        "{err}"
    );
}
