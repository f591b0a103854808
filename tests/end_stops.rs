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
