//! Skipped tests stay visible: a test whose tool is missing says SKIPPED on the terminal (past
//! the harness's capture), lands in the skip log, fails under CI, and `./test.sh` ends with one
//! line summing the log up (tests/common/skip.rs, python/tests/conftest.py).

#[path = "common/skip.rs"]
mod skip;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const CHILD: &str = "PUMPCYL_SKIPS_TEST_CHILD";

/// This test binary again, running only `test` with `CHILD` set, its skip log `log`.
fn child(test: &str, log: &Path, ci: Option<&str>) -> Output {
    let mut cmd = Command::new(std::env::current_exe().unwrap());
    cmd.args(["--exact", test, "--test-threads=1"])
        .env(CHILD, "1")
        .env("PUMPCYL_SKIP_LOG", log)
        .env_remove("CI");
    if let Some(ci) = ci {
        cmd.env("CI", ci);
    }
    cmd.output().unwrap()
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The last line of `./test.sh` for the skip log `log` (test.sh's own summary function).
fn summary(log: &Path) -> String {
    let out = Command::new("bash")
        .arg(root().join("test.sh"))
        .env("PUMPCYL_SUMMARIZE_SKIPS", log)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn a_missing_tool_is_said_logged_and_summed_up_and_fails_under_ci() {
    if std::env::var_os(CHILD).is_some() {
        // the child: the test of a machine without the tool
        skip::skip("child test", "a tool", "apt-get install a-tool");
        return;
    }
    let me = "a_missing_tool_is_said_logged_and_summed_up_and_fails_under_ci";
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("skipped-tests.txt");

    let out = child(me, &log, None);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    // the harness shows nothing of a passing test's eprintln!: this line went past it
    assert!(
        err.contains("SKIPPED: child test: needs a tool (apt-get install a-tool)"),
        "the skip is not on the terminal: {err}"
    );
    let logged = std::fs::read_to_string(&log).unwrap();
    assert_eq!(logged, "child test\ta tool\tapt-get install a-tool\n");
    assert_eq!(
        summary(&log),
        "skipped: 1 test — 1 needs a tool (apt-get install a-tool)\n"
    );

    // under CI the same test fails, and nothing is logged
    let out = child(me, &log, Some("true"));
    let all = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!out.status.success(), "a skip under CI passed: {all}");
    assert!(
        all.contains("needs a tool, and under CI no test may skip"),
        "{all}"
    );
    assert_eq!(std::fs::read_to_string(&log).unwrap(), logged);
}

#[test]
fn test_sh_ends_with_one_line_of_what_skipped_and_what_installs_it() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("skipped-tests.txt");
    assert_eq!(summary(&log), "skipped: none\n", "no log: nothing skipped");
    std::fs::write(&log, "").unwrap();
    assert_eq!(summary(&log), "skipped: none\n");

    let octave = "octave and octave-control\tapt-get install octave octave-control";
    let lines = [
        format!("octave_a\t{octave}"),
        "report_renders\tchromium\tapt-get install chromium".to_string(),
        format!("octave_b\t{octave}"),
        format!("octave_c\t{octave}"),
        // a test logged twice counts once
        format!("octave_c\t{octave}"),
        format!("octave_d\t{octave}"),
        "python/tests/test_fmu.py::test_x\tFMPy\tpip install fmpy".to_string(),
        // a skip for another reason than a missing tool (pytest.skip elsewhere)
        "python/tests/test_api.py::test_y\ttarget/debug/pumpcyl not built (cargo build)\t"
            .to_string(),
    ];
    std::fs::write(&log, lines.join("\n") + "\n").unwrap();
    assert_eq!(
        summary(&log),
        "skipped: 7 tests — 4 need octave and octave-control (apt-get install octave \
         octave-control), 1 needs FMPy (pip install fmpy), 1 needs chromium (apt-get install \
         chromium), 1 because target/debug/pumpcyl not built (cargo build)\n"
    );
}

/// The tests that need a tool skip through tests/common/skip.rs, never with a message the
/// harness swallows; test.sh prints the summary last; pytest logs its skips.
#[test]
fn no_test_skips_silently() {
    for entry in std::fs::read_dir(root().join("tests")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "rs") || path.ends_with("skips.rs") {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        // `eprintln!("SKIPPED: …")`, `println!(\n "skipped …")`
        let lower = text.to_lowercase();
        for (at, _) in lower.match_indices("println!(") {
            let said = lower[at + "println!(".len()..].trim_start();
            assert!(
                !said.starts_with("\"skip"),
                "{}:{}: a skip said with a print the harness hides; call skip::skip \
                 (tests/common/skip.rs)",
                path.display(),
                lower[..at].lines().count()
            );
        }
    }
    for file in ["tests/octave.rs", "tests/reproduce.rs"] {
        let text = std::fs::read_to_string(root().join(file)).unwrap();
        assert!(
            text.contains("skip::skip("),
            "{file} skips without skip::skip"
        );
    }
    let test_sh = std::fs::read_to_string(root().join("test.sh")).unwrap();
    assert!(
        test_sh.contains("export PUMPCYL_SKIP_LOG=")
            && test_sh.lines().any(|l| l.starts_with("trap ")
                && l.contains("skip_summary \"$PUMPCYL_SKIP_LOG\"")
                && l.ends_with(" EXIT")),
        "test.sh must log the skips and print their summary as its last line"
    );
    let conftest = std::fs::read_to_string(root().join("python/tests/conftest.py")).unwrap();
    assert!(
        conftest.contains("def pytest_runtest_logreport(") && conftest.contains("PUMPCYL_SKIP_LOG"),
        "python/tests/conftest.py must log pytest's skips"
    );
}
