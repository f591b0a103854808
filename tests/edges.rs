//! Answers at the edge of a search range and implausible inputs are refused or flagged, naming
//! the value: never an answer with exit 0 that is only the bound of a scan.

use std::path::Path;

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;
use run::{pumpcyl, refused};

/// An emulated drive step record in `dir`, rewritten row by row by `row` (t, w_ref, w).
fn drive_record(dir: &Path, name: &str, row: impl Fn(&str, &str, f64) -> String) {
    let out = pumpcyl(
        dir,
        &["emulate", "--experiment", "drive-step", "--out", "d.csv"],
    );
    assert!(out.status.success());
    let text = std::fs::read_to_string(dir.join("d.csv")).unwrap();
    let mut lines = text.lines();
    let mut s = format!("{}\n", lines.next().unwrap());
    for l in lines {
        let f: Vec<&str> = l.split(',').collect();
        s += &row(f[0], f[1], f[2].parse().unwrap());
        s.push('\n');
    }
    std::fs::write(dir.join(name), s).unwrap();
}

#[test]
fn identify_drive_refuses_records_that_do_not_determine_km() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // the honest record is identified (the emulated rig's Km is 0.026 N·m·s/rad)
    let out = pumpcyl(
        d,
        &["emulate", "--experiment", "drive-step", "--out", "ok.csv"],
    );
    assert!(out.status.success());
    let out = pumpcyl(d, &["identify-drive", "ok.csv", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let km = v["km_nms_per_rad"].as_f64().unwrap();
    assert!((km - 0.026).abs() < 0.002, "Km {km}");
    // a motor that never moves
    drive_record(d, "still.csv", |t, r, _| format!("{t},{r},0"));
    refused(
        d,
        &["identify-drive", "still.csv"],
        &["w_rpm", "does not move"],
    );
    // a response a thousand times too small: the best fit is the scan's lower bound
    drive_record(d, "tiny.csv", |t, r, w| {
        format!("{t},{r},{}", w * 1e-3 + 0.3)
    });
    refused(
        d,
        &["identify-drive", "tiny.csv"],
        &["edge of the range", "Km"],
    );
    // two samples
    std::fs::write(
        d.join("two.csv"),
        "time_s,w_ref_rpm,w_rpm\n0,0,0\n0.001,100,0\n",
    )
    .unwrap();
    refused(
        d,
        &["identify-drive", "two.csv"],
        &["1 samples after the step", "at least 10"],
    );
}

#[test]
fn emulate_refuses_a_record_no_reader_accepts() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for kind in ["step", "drive-step"] {
        let args = [
            "emulate",
            "--experiment",
            kind,
            "--rate-hz",
            "1e-3",
            "--out",
            "r.csv",
        ];
        refused(d, &args, &["--rate-hz", "at least 2"]);
        assert!(!d.join("r.csv").exists());
    }
}

#[test]
fn replays_outside_the_stroke_or_in_metres_are_refused_or_flagged() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = pumpcyl(d, &["emulate", "--experiment", "step", "--out", "mm.csv"]);
    assert!(out.status.success());
    let text = std::fs::read_to_string(d.join("mm.csv")).unwrap();
    let scaled = |f: f64| {
        let mut lines = text.lines();
        let mut s = format!("{}\n", lines.next().unwrap());
        for l in lines {
            let v: Vec<String> = l
                .split(',')
                .enumerate()
                .map(|(i, x)| {
                    let x: f64 = x.parse().unwrap();
                    if i == 1 || i == 2 {
                        format!("{}", x * f)
                    } else {
                        x.to_string()
                    }
                })
                .collect();
            s += &(v.join(",") + "\n");
        }
        s
    };
    // a 5000 mm reference on a 500 mm cylinder
    std::fs::write(d.join("far.csv"), scaled(15.0)).unwrap();
    refused(
        d,
        &["simulate", "--data", "far.csv"],
        &["far.csv", "x_ref_mm", "stroke"],
    );
    // the same record in metres under _mm names: refused, naming the column and the unit
    std::fs::write(d.join("m.csv"), scaled(1e-3)).unwrap();
    refused(
        d,
        &["simulate", "--data", "m.csv"],
        &["m.csv", "column `x_ref_mm`", "metres"],
    );
}

#[test]
fn design_refuses_a_wave_that_track_refuses() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    refused(
        d,
        &["design", "--wave", "0.2:1e9"],
        &["wave 0.2:1000000000", "stroke"],
    );
    refused(d, &["design", "--wave", "60:5"], &["wave 60:5", "Nyquist"]);
    let out = pumpcyl(d, &["design", "--wave", "0.2:35"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
