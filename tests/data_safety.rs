//! No command loses a user's data: an output never lands on an input (symlinks resolved, also
//! for a file inside an output folder), output files get the umask's permissions, a result that
//! cannot reach standard output is an error, and an output folder is never a stray file or a
//! folder of other files.

use std::os::unix::fs::{symlink, PermissionsExt};
use std::path::Path;
use std::process::{Command, Output, Stdio};

fn pumpcyl(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("pumpcyl runs")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A folder holding an emulated step record `v.csv`; returns it and the record's bytes.
fn with_record() -> (tempfile::TempDir, Vec<u8>) {
    let dir = tempfile::tempdir().unwrap();
    let out = pumpcyl(
        dir.path(),
        &["emulate", "--experiment", "step", "--out", "v.csv"],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let bytes = std::fs::read(dir.path().join("v.csv")).unwrap();
    (dir, bytes)
}

fn refused_keeping(dir: &Path, args: &[&str], kept: &Path, bytes: &[u8], words: &[&str]) {
    let out = pumpcyl(dir, args);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
    for w in words {
        assert!(err.contains(w), "{args:?}: message lacks `{w}`: {err}");
    }
    assert_eq!(
        std::fs::read(kept).unwrap(),
        bytes,
        "{args:?} changed the input"
    );
}

#[test]
fn an_output_equal_to_an_input_is_refused_and_the_input_kept() {
    let (dir, bytes) = with_record();
    let d = dir.path();
    let v = d.join("v.csv");
    refused_keeping(
        d,
        &["simulate", "--data", "v.csv", "--out", "v.csv"],
        &v,
        &bytes,
        &["v.csv", "is an input"],
    );
    // the same file by another spelling and through a symlink
    symlink(&v, d.join("link.csv")).unwrap();
    std::fs::create_dir(d.join("sub")).unwrap();
    refused_keeping(
        d,
        &["simulate", "--data", "link.csv", "--out", "sub/../v.csv"],
        &v,
        &bytes,
        &["is an input"],
    );
    refused_keeping(
        d,
        &["simulate", "--data", "v.csv", "--out", "link.csv"],
        &v,
        &bytes,
        &["is an input"],
    );
}

/// A small identification in `dir`: `exp.toml` over a record copied to `dir/data/DATASET`.
fn small_experiment(dir: &Path, dataset: &str) {
    let peer = Path::new(env!("CARGO_MANIFEST_DIR")).join("bench/peer/ident.csv");
    std::fs::create_dir_all(dir.join("data")).unwrap();
    std::fs::copy(peer, dir.join("data").join(dataset)).unwrap();
    let text = format!(
        "[standstill]\nw1_rpm = -160.0\nw2_rpm = 245.0\np1_bar = 3.95\n\
         [grid]\nbeta_bar = [150.0, 165.0]\nviscous_friction_ns_per_m = [100.0]\n\
         c12_m5_per_ns = [1.2e-10]\n\
         [[dataset]]\nfile = \"{dataset}\"\nkp = 25.0\nmass_kg = 10593.0\nfit_end_s = 3.7\n"
    );
    std::fs::write(dir.join("data/exp.toml"), text).unwrap();
}

#[test]
fn an_output_folder_holding_an_input_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // a dataset that happens to be called like an output of identify
    small_experiment(d, "landscape.csv");
    let kept = d.join("data/landscape.csv");
    let bytes = std::fs::read(&kept).unwrap();
    refused_keeping(
        d,
        &["identify", "data/exp.toml", "--out", "data"],
        &kept,
        &bytes,
        &["data", "holds the input"],
    );
    // the same through a symlink to the folder
    symlink(d.join("data"), d.join("alias")).unwrap();
    refused_keeping(
        d,
        &["identify", "data/exp.toml", "--out", "alias"],
        &kept,
        &bytes,
        &["holds the input"],
    );
}

#[test]
fn output_files_and_folders_respect_the_umask() {
    for (umask, file_mode, dir_mode) in [(0o022, 0o644, 0o755), (0o077, 0o600, 0o700)] {
        let dir = tempfile::tempdir().unwrap();
        small_experiment(dir.path(), "ident.csv");
        let out = Command::new("sh")
            .current_dir(dir.path())
            .arg("-c")
            .arg(format!(
                "umask {umask:03o} && \"$0\" step --duration-s 0.5 --out s.csv && \"$0\" identify \
                 data/exp.toml --no-refine --out res",
            ))
            .arg(env!("CARGO_BIN_EXE_pumpcyl"))
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", stderr(&out));
        let mode = |p: &str| {
            std::fs::metadata(dir.path().join(p))
                .unwrap()
                .permissions()
                .mode()
                & 0o777
        };
        assert_eq!(mode("s.csv"), file_mode, "umask {umask:03o}");
        assert_eq!(mode("res/result.json"), file_mode, "umask {umask:03o}");
        assert_eq!(mode("res"), dir_mode, "umask {umask:03o}");
    }
}

#[test]
fn a_result_that_cannot_reach_standard_output_is_an_error() {
    // standard output closed by the caller
    let out = Command::new("sh")
        .arg("-c")
        .arg("\"$0\" margins >&-")
        .arg(env!("CARGO_BIN_EXE_pumpcyl"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(stderr(&out).contains("standard output"), "{}", stderr(&out));
    // a pipe closed before the (large) result is written
    let mut child = Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .args(["bode", "--points-per-decade", "20000"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(stderr(&out).contains("standard output"), "{}", stderr(&out));
    // a redirection to /dev/null is an ordinary output
    let out = Command::new("sh")
        .arg("-c")
        .arg("\"$0\" margins >/dev/null")
        .arg(env!("CARGO_BIN_EXE_pumpcyl"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    // and so is /dev/null opened for reading and writing, as Python's subprocess.DEVNULL does
    let null = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open("/dev/null")
        .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .arg("margins")
        .stdout(null)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
}

#[test]
fn an_output_folder_is_never_a_file_or_a_folder_of_other_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    small_experiment(d, "ident.csv");
    let identify = |out: &str| {
        pumpcyl(
            d,
            &["identify", "data/exp.toml", "--no-refine", "--out", out],
        )
    };
    std::fs::write(d.join("notes.txt"), "mine").unwrap();
    let out = identify("notes.txt");
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("notes.txt: exists and is not a folder"),
        "{}",
        stderr(&out)
    );
    std::fs::create_dir(d.join("mine")).unwrap();
    std::fs::write(d.join("mine/thesis.tex"), "mine").unwrap();
    let out = identify("mine");
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("not empty"), "{}", stderr(&out));
    assert_eq!(std::fs::read_dir(d.join("mine")).unwrap().count(), 1);
    // an earlier result is replaced, a file left in it by hand kept (tests/folders.rs)
    assert!(identify("res").status.success());
    std::fs::write(d.join("res/stale.csv"), "old").unwrap();
    assert!(identify("res").status.success());
    assert!(d.join("res/stale.csv").exists());
    assert!(d.join("res/result.json").exists());
    let names: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        names.iter().all(|n| !n.contains("pumpcyl-tmp")),
        "temporaries left: {names:?}"
    );
}

#[test]
fn special_files_are_written_into_never_replaced() {
    use std::os::unix::fs::FileTypeExt;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // a FIFO with a reader gets the CSV and stays a FIFO
    let fifo = d.join("pipe.csv");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    // the reading end is open before pumpcyl starts (a reader thread may not have reached its
    // open yet, and a FIFO without a reader is refused); the CSV fits the pipe's buffer
    let mut reader = {
        use std::os::unix::fs::OpenOptionsExt;
        std::fs::OpenOptions::new()
            .read(true)
            .custom_flags(libc::O_NONBLOCK)
            .open(&fifo)
            .unwrap()
    };
    let out = pumpcyl(d, &["bode", "--out", "pipe.csv"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let mut text = String::new();
    std::io::Read::read_to_string(&mut reader, &mut text).unwrap();
    drop(reader);
    assert!(text.starts_with("freq_hz,mag_db,phase_deg\n"), "{text}");
    assert!(std::fs::symlink_metadata(&fifo)
        .unwrap()
        .file_type()
        .is_fifo());
    // a FIFO nobody reads is an error, not a hang
    let out = pumpcyl(d, &["bode", "--out", "pipe.csv"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("FIFO needs a reader"),
        "{}",
        stderr(&out)
    );
    // a link to a character device, as /dev/stdout is: written through, the link kept
    symlink("/dev/null", d.join("null.csv")).unwrap();
    let out = pumpcyl(d, &["bode", "--out", "null.csv"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let meta = std::fs::symlink_metadata(d.join("null.csv")).unwrap();
    assert!(meta.file_type().is_symlink());
    assert!(std::fs::metadata("/dev/null")
        .unwrap()
        .file_type()
        .is_char_device());
}

#[test]
fn a_file_written_over_keeps_its_mode_and_a_link_its_target() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let real = d.join("real.csv");
    std::fs::write(&real, "old").unwrap();
    std::fs::set_permissions(&real, std::fs::Permissions::from_mode(0o600)).unwrap();
    symlink("real.csv", d.join("link.csv")).unwrap();
    let out = pumpcyl(d, &["bode", "--out", "link.csv"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let link = std::fs::symlink_metadata(d.join("link.csv")).unwrap();
    assert!(link.file_type().is_symlink(), "the link was replaced");
    let text = std::fs::read_to_string(&real).unwrap();
    assert!(text.starts_with("freq_hz"), "{text}");
    let mode = std::fs::metadata(&real).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, 0o600);
}
