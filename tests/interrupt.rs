//! `reproduce --out DIR` interrupted at random moments by SIGINT and SIGKILL: DIR always holds a
//! complete result (the previous or the new one), an interrupted run leaves no temporaries (a
//! SIGKILLed one's are removed by the next run).

#[path = "common/tree.rs"]
mod tree;

use std::collections::BTreeSet;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use tree::files;

/// The faults of `dir` as a complete result with the files of `reference`.
fn incomplete(dir: &Path, reference: &BTreeSet<String>) -> Option<String> {
    if !dir.is_dir() {
        return Some("the folder is missing".into());
    }
    let now = files(dir);
    if &now != reference {
        return Some(format!(
            "files differ: missing {:?}, extra {:?}",
            reference.difference(&now).collect::<Vec<_>>(),
            now.difference(reference).collect::<Vec<_>>()
        ));
    }
    let summary = std::fs::read_to_string(dir.join("summary.json")).unwrap();
    let Ok(v) = serde_json::from_str::<serde_json::Value>(&summary) else {
        return Some("summary.json is not JSON".into());
    };
    if !v["seconds"].is_number() {
        return Some("summary.json lacks seconds".into());
    }
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    (!html.trim_end().ends_with("</html>")).then(|| "report.html is cut short".into())
}

fn temporaries(parent: &Path) -> Vec<String> {
    std::fs::read_dir(parent)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("pumpcyl-tmp"))
        .collect()
}

fn reproduce(dir: &Path) -> std::process::Child {
    Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .args(["reproduce", "--out", dir.to_str().unwrap()])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap()
}

/// Interrupt `reproduce` ten times into one result folder at moments log-uniform from 20 ms
/// to past the end of a run (dense where the folder is set up, and reaching the final swap),
/// alternately with SIGINT and SIGKILL: after each, the folder holds the complete old or new
/// result, and a SIGINTed run leaves none of its temporaries.
fn interrupts(seed: u64) {
    let parent = tempfile::tempdir().unwrap();
    let dir = parent.path().join("rep");
    let start = Instant::now();
    assert!(reproduce(&dir).wait().unwrap().success());
    let full = start.elapsed().as_secs_f64();
    let reference = files(&dir);
    assert!(reference.contains("summary.json") && reference.len() > 10);
    let mut seed = seed;
    let mut uniform = || {
        seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let (lo, hi) = (0.02f64, 1.05 * full);
    for i in 0..10 {
        let at = lo * (hi / lo).powf(uniform());
        let signal = if i % 2 == 0 {
            libc::SIGINT
        } else {
            libc::SIGKILL
        };
        let mut child = reproduce(&dir);
        std::thread::sleep(Duration::from_secs_f64(at));
        // SAFETY: signalling our own child by its id.
        unsafe { libc::kill(child.id() as libc::pid_t, signal) };
        let status = child.wait().unwrap();
        let pid = child.id();
        if let Some(fault) = incomplete(&dir, &reference) {
            panic!("interrupt {i} (signal {signal} at {at:.2} s, {status}): {fault}");
        }
        // a SIGINTed run removes its own temporaries (a SIGKILLed one's wait for the next
        // run that reaches the output folder; their names carry the process id)
        if signal == libc::SIGINT {
            let own = format!("pumpcyl-tmp-{pid}-");
            let left: Vec<String> = temporaries(parent.path())
                .into_iter()
                .filter(|n| n.contains(&own))
                .collect();
            assert!(left.is_empty(), "SIGINT at {at:.2} s left {left:?}");
        }
    }
    // the next complete run removes what SIGKILLed runs left behind
    assert!(reproduce(&dir).wait().unwrap().success());
    assert_eq!(incomplete(&dir, &reference), None);
    assert_eq!(temporaries(parent.path()), Vec::<String>::new());
}

// Two series of interrupts with their own moments, run side by side (the harness's threads).

#[test]
fn an_interrupted_reproduce_leaves_the_complete_old_or_new_result() {
    interrupts(0x9E37_79B9_7F4A_7C15);
}

#[test]
fn an_interrupted_reproduce_leaves_the_complete_old_or_new_result_again() {
    interrupts(0xD1B5_4A32_D192_ED03);
}
