//! The emulator's cavitation floor (docs/emulator.md#cavitation): `pumpcyl emulate` warns,
//! in its text and its JSON `warnings`, when a chamber of the record reaches −1 bar gauge,
//! where the emulator holds it and the linear model no longer describes the record.

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;

use std::path::Path;

/// The first (time, chamber) of a noise-free record whose recorded pressure is within 1 mbar of
/// the floor, read from its CSV: the reference the warning is checked against.
fn first_at_floor(path: &Path) -> Option<(f64, usize)> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (t, p1, p2) = (col("time_s"), col("p1_bar"), col("p2_bar"));
    lines.find_map(|l| {
        let v: Vec<f64> = l.split(',').map(|c| c.parse().unwrap()).collect();
        let chamber = [p1, p2].iter().position(|&k| v[k] <= -1.0 + 1e-3)?;
        Some((v[t], chamber + 1))
    })
}

/// `pumpcyl emulate --experiment step --no-noise --out e.csv ARGS` in `dir` with `--json`:
/// its warnings; and without it, its standard error (the record of both the same).
fn emulate_step(dir: &Path, args: &[&str]) -> (Vec<String>, String) {
    let mut all = vec![
        "emulate",
        "--experiment",
        "step",
        "--no-noise",
        "--out",
        "e.csv",
    ];
    all.extend_from_slice(args);
    // the text run after the JSON one, which checks that it succeeds
    let v = run::json(dir, &[&all[..], &["--json"]].concat());
    let warnings = (v["warnings"].as_array().unwrap().iter())
        .map(|w| w.as_str().unwrap().to_string())
        .collect();
    // the text run's warnings go to standard error (docs/architecture.md#requests)
    let text = String::from_utf8(run::pumpcyl(dir, &all).stderr).unwrap();
    (warnings, text)
}

#[test]
fn a_step_that_drives_a_chamber_to_the_cavitation_floor_warns_when_and_which() {
    // a 100 mm step on the article rig: the rod side (chamber 2) empties faster than its pump
    // refills it and falls from its 4.5 bar rest to the floor within 0.1 s of the step
    let dir = tempfile::tempdir().unwrap();
    let (warnings, text) = emulate_step(dir.path(), &["--from-mm", "300", "--to-mm", "400"]);
    let (t, chamber) = first_at_floor(&dir.path().join("e.csv")).expect("the record reaches it");
    assert_eq!((chamber, t), (2, 0.6), "the record's own pressures");
    let want =
        format!("chamber {chamber} reached the cavitation floor (-1 bar gauge) at t = {t:.2} s");
    let w: Vec<&String> = warnings
        .iter()
        .filter(|w| w.contains("cavitation floor"))
        .collect();
    assert_eq!(w.len(), 1, "{warnings:?}");
    assert!(w[0].contains(&want), "{}", w[0]);
    let line = format!("warning: emulated: {want}");
    assert!(text.lines().any(|l| l.starts_with(&line)), "{text}");
}

#[test]
fn a_step_whose_chambers_stay_above_the_floor_does_not_warn() {
    // the article's 5 mm step: the chambers stay above 2.6 bar
    let dir = tempfile::tempdir().unwrap();
    let (warnings, text) = emulate_step(dir.path(), &[]);
    assert_eq!(first_at_floor(&dir.path().join("e.csv")), None);
    assert!(
        !warnings.iter().any(|w| w.contains("cavitation")),
        "{warnings:?}"
    );
    assert!(!text.contains("cavitation"), "{text}");
}
