//! A 10⁶-row record is read as a stream: the reader's memory is the used columns (8 bytes per
//! value), never the text. This is the only test in its binary, so the peak resident memory of
//! this process's children (getrusage RUSAGE_CHILDREN) is that of the pumpcyl runs below.

use std::io::Write;
use std::path::Path;
use std::process::Command;

const ROWS: usize = 1_000_000;
const COLUMNS: usize = 7;

/// A 10⁶-row, 7-column standstill-like record: constant speeds and pressures, time from 1000 s.
fn write_record(path: &Path) -> u64 {
    let file = std::fs::File::create(path).unwrap();
    let mut w = std::io::BufWriter::new(file);
    writeln!(w, "time_s,x_ref_mm,x_mm,p1_bar,p2_bar,w1_rpm,w2_rpm").unwrap();
    for i in 0..ROWS {
        let t = 1000.0 + i as f64 * 0.01;
        // speeds alternate about their means so the means are exact
        let (w1, w2) = if i % 2 == 0 {
            (-134.0, 207.5)
        } else {
            (-136.0, 208.5)
        };
        writeln!(w, "{t:.2},345.0,344.987,3.500,5.250,{w1:.1},{w2:.1}").unwrap();
    }
    w.flush().unwrap();
    std::fs::metadata(path).unwrap().len()
}

/// Peak resident memory (bytes) of the waited-for children so far.
fn children_max_rss() -> u64 {
    let mut usage = std::mem::MaybeUninit::<libc::rusage>::zeroed();
    // SAFETY: getrusage fills the struct it is given; RUSAGE_CHILDREN is a valid selector.
    let rc = unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, usage.as_mut_ptr()) };
    assert_eq!(rc, 0);
    // SAFETY: initialised by the successful call above (and zeroed before it).
    let kib = unsafe { usage.assume_init() }.ru_maxrss;
    kib as u64 * 1024
}

fn leakage(args: &[&str]) -> serde_json::Value {
    let out = Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .args(["leakage", "--c12", "1.2e-10", "--json"])
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn a_million_row_record_is_streamed_in_the_memory_of_its_columns() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("standstill_1e6.csv");
    let text_bytes = write_record(&path);
    assert!(text_bytes > 40_000_000, "{text_bytes}");

    let from_record = leakage(&["--record", path.to_str().unwrap()]);
    let rss = children_max_rss();
    // the means of the million rows are the point itself
    let from_point = leakage(&["--w1-rpm=-135", "--w2-rpm=207.999999", "--p1-bar=3.5"]);
    let exact = leakage(&["--w1-rpm=-135", "--w2-rpm=208", "--p1-bar=3.5"]);
    for key in ["c1_m5_per_ns", "c2_m5_per_ns"] {
        let (r, e) = (
            from_record[key].as_f64().unwrap(),
            exact[key].as_f64().unwrap(),
        );
        let p = from_point[key].as_f64().unwrap();
        // the tolerance is tight enough to tell a change of 1e-6 rpm in one mean
        let tolerance = 0.1 * (p - e).abs();
        assert!(
            (r - e).abs() <= tolerance,
            "{key}: {r} vs {e} (±{tolerance})"
        );
    }

    // The columns take 56 MB (59 MB with Vec growth to 2^20 entries) and the binary a few MB;
    // holding the text as well, even once, would need 47 MB more than the columns alone.
    let columns_bytes = (ROWS * COLUMNS * 8) as u64;
    assert!(
        rss < columns_bytes + text_bytes,
        "peak RSS {rss} B for {text_bytes} B of text and {columns_bytes} B of columns"
    );
}
