//! Result folders keep what the user put there (docs/formats.md#result-folders): a rerun of
//! every command that writes one keeps every file pumpcyl did not write and says so; a forged
//! or empty marker protects every file it does not list; a file of the user's at a path of the
//! result is refused, named, unless `--force`; a symlinked folder is written through, the link
//! kept. Also: a read-only output file is refused unless `--force`, two outputs at one path are
//! refused before any work, and a file-size limit fails the write without a temporary left.

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;

use run::{pumpcyl, refused};
use std::os::unix::fs::{symlink, PermissionsExt};
use std::path::Path;
use std::process::Output;

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn ok(dir: &Path, args: &[&str]) -> String {
    let out = pumpcyl(dir, args);
    assert!(out.status.success(), "{args:?}: {}", stderr(&out));
    stderr(&out)
}

/// A small identification in `dir`: `data/exp.toml` over the peer record.
fn small_experiment(dir: &Path) {
    let peer = Path::new(env!("CARGO_MANIFEST_DIR")).join("bench/peer/ident.csv");
    std::fs::create_dir_all(dir.join("data")).unwrap();
    std::fs::copy(peer, dir.join("data/ident.csv")).unwrap();
    let text = "[standstill]\nw1_rpm = -160.0\nw2_rpm = 245.0\np1_bar = 3.95\n\
         [grid]\nbeta_bar = [150.0, 165.0]\nviscous_friction_ns_per_m = [100.0]\n\
         c12_m5_per_ns = [1.2e-10]\n\
         [[dataset]]\nfile = \"ident.csv\"\nkp = 25.0\nmass_kg = 10593.0\nfit_end_s = 3.7\n";
    std::fs::write(dir.join("data/exp.toml"), text).unwrap();
}

/// Every command that writes a result folder, into `R`, with a file it always writes there.
const FOLDER_COMMANDS: [(&[&str], &str); 5] = [
    (&["select", "--out", "R"], "result.json"),
    (
        &["identify", "data/exp.toml", "--no-refine", "--out", "R"],
        "result.json",
    ),
    (&["design", "--robust", "--out", "R"], "result.json"),
    (&["emulate", "--article-records", "R"], "identify.toml"),
    (&["reproduce", "--out", "R"], "summary.json"),
];

/// The names the marker of `dir` lists.
fn listed(dir: &Path) -> Vec<String> {
    std::fs::read_to_string(dir.join(".pumpcyl-output"))
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(str::to_string)
        .collect()
}

#[test]
fn a_rerun_of_every_folder_command_keeps_the_users_files_and_says_so() {
    for (args, ours) in FOLDER_COMMANDS {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        small_experiment(d);
        let r = d.join("R");
        ok(d, args);
        assert!(listed(&r).contains(&ours.to_string()), "{args:?}");
        // the user's notes, a folder of theirs, a read-only file and a link
        std::fs::write(r.join("notes.txt"), "mine").unwrap();
        std::fs::create_dir(r.join("mine")).unwrap();
        std::fs::write(r.join("mine/deep.txt"), "deep").unwrap();
        std::fs::create_dir(r.join("empty")).unwrap();
        std::fs::write(r.join("frozen.txt"), "frozen").unwrap();
        std::fs::set_permissions(r.join("frozen.txt"), PermissionsExt::from_mode(0o444)).unwrap();
        symlink("notes.txt", r.join("link.txt")).unwrap();
        // a file an earlier run wrote and this one does not: the marker says it is pumpcyl's
        std::fs::write(r.join("stale.csv"), "old").unwrap();
        let marker = std::fs::read_to_string(r.join(".pumpcyl-output")).unwrap();
        std::fs::write(r.join(".pumpcyl-output"), marker + "stale.csv\n").unwrap();
        let said = ok(d, args);
        assert!(said.contains("kept "), "{args:?}: {said}");
        assert!(said.contains("notes.txt"), "{args:?}: {said}");
        assert!(said.contains("mine/deep.txt"), "{args:?}: {said}");
        assert!(
            said.contains("(not written by pumpcyl)"),
            "{args:?}: {said}"
        );
        assert!(!said.contains("stale.csv"), "{args:?}: {said}");
        let read = |p: &str| std::fs::read_to_string(r.join(p)).unwrap();
        assert_eq!(read("notes.txt"), "mine", "{args:?}");
        assert_eq!(read("mine/deep.txt"), "deep", "{args:?}");
        assert_eq!(read("frozen.txt"), "frozen", "{args:?}");
        assert!(r.join("empty").is_dir(), "{args:?}");
        let mode = std::fs::metadata(r.join("frozen.txt"))
            .unwrap()
            .permissions();
        assert_eq!(mode.mode() & 0o777, 0o444, "{args:?}");
        assert_eq!(
            std::fs::read_link(r.join("link.txt")).unwrap(),
            Path::new("notes.txt")
        );
        assert!(!r.join("stale.csv").exists(), "{args:?}");
        assert!(r.join(ours).is_file(), "{args:?}");
        // the marker lists what pumpcyl wrote, never the user's files
        let names = listed(&r);
        assert!(names.contains(&ours.to_string()), "{args:?}");
        for theirs in ["notes.txt", "mine/deep.txt", "frozen.txt", "link.txt"] {
            assert!(!names.contains(&theirs.to_string()), "{args:?}: {theirs}");
        }
        // nothing of the swap is left beside the folder
        let beside: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains("pumpcyl"))
            .collect();
        assert!(beside.is_empty(), "{args:?}: {beside:?}");
    }
}

#[test]
fn a_users_file_at_a_path_of_the_result_is_refused_by_name_unless_forced() {
    for (args, ours) in FOLDER_COMMANDS {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        small_experiment(d);
        let r = d.join("R");
        // a forged (empty) marker: it lists nothing, so it protects everything
        std::fs::create_dir(&r).unwrap();
        std::fs::write(r.join(".pumpcyl-output"), "").unwrap();
        std::fs::write(r.join(ours), "my own").unwrap();
        std::fs::write(r.join("thesis.tex"), "thesis").unwrap();
        let out = pumpcyl(d, args);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        // identify warns about its small grid first; the error is one line
        let last = err.lines().last().unwrap_or_default();
        assert!(last.starts_with("error: "), "{args:?}: {err}");
        for w in [ours, "not written by pumpcyl", "--force"] {
            assert!(last.contains(w), "{args:?}: message lacks `{w}`: {err}");
        }
        assert_eq!(std::fs::read_to_string(r.join(ours)).unwrap(), "my own");
        assert_eq!(std::fs::read_dir(&r).unwrap().count(), 3, "{args:?}");
        let mut forced = args.to_vec();
        forced.push("--force");
        let said = ok(d, &forced);
        assert!(said.contains("replaced"), "{args:?}: {said}");
        assert!(said.contains(ours), "{args:?}: {said}");
        assert_ne!(std::fs::read_to_string(r.join(ours)).unwrap(), "my own");
        assert_eq!(
            std::fs::read_to_string(r.join("thesis.tex")).unwrap(),
            "thesis"
        );
    }
}

#[test]
fn a_forged_marker_that_lists_nothing_cannot_make_a_run_delete_a_folder_of_other_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir_all(d.join("thesis/chapters")).unwrap();
    std::fs::write(d.join("thesis/chapters/one.tex"), "one").unwrap();
    std::fs::write(d.join("thesis/main.tex"), "main").unwrap();
    std::fs::write(d.join("thesis/.pumpcyl-output"), "# forged\n").unwrap();
    ok(d, &["select", "--out", "thesis"]);
    assert_eq!(
        std::fs::read_to_string(d.join("thesis/chapters/one.tex")).unwrap(),
        "one"
    );
    assert_eq!(
        std::fs::read_to_string(d.join("thesis/main.tex")).unwrap(),
        "main"
    );
    assert!(d.join("thesis/result.json").is_file());
}

#[test]
fn a_non_empty_folder_without_a_result_is_refused_unless_forced_and_then_kept() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("mine")).unwrap();
    std::fs::write(d.join("mine/thesis.tex"), "thesis").unwrap();
    refused(
        d,
        &["select", "--out", "mine"],
        &["mine", "not empty", "--force"],
    );
    assert_eq!(std::fs::read_dir(d.join("mine")).unwrap().count(), 1);
    let said = ok(d, &["select", "--out", "mine", "--force"]);
    assert!(said.contains("kept thesis.tex"), "{said}");
    assert_eq!(
        std::fs::read_to_string(d.join("mine/thesis.tex")).unwrap(),
        "thesis"
    );
    assert!(d.join("mine/result.json").is_file());
}

#[test]
fn a_symlinked_output_folder_is_written_through_and_the_link_stays() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("real")).unwrap();
    symlink("real", d.join("link")).unwrap();
    for link in ["link", "link/", "./link"] {
        ok(d, &["select", "--out", link]);
        let meta = std::fs::symlink_metadata(d.join("link")).unwrap();
        assert!(meta.file_type().is_symlink());
        assert_eq!(
            std::fs::read_link(d.join("link")).unwrap(),
            Path::new("real")
        );
        assert!(d.join("real/result.json").is_file());
        std::fs::write(d.join("real/notes.txt"), "mine").unwrap();
    }
    assert_eq!(
        std::fs::read_to_string(d.join("real/notes.txt")).unwrap(),
        "mine"
    );
    // a link to nothing is refused, and stays
    symlink("nowhere", d.join("dangling")).unwrap();
    refused(
        d,
        &["select", "--out", "dangling"],
        &["dangling", "link to nothing"],
    );
    assert!(std::fs::symlink_metadata(d.join("dangling")).is_ok());
    assert!(!d.join("nowhere").exists());
}

#[test]
fn a_read_only_output_file_is_refused_by_name_unless_forced() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(d, &["step", "--duration-s", "0.5", "--out", "s.csv"]);
    std::fs::set_permissions(d.join("s.csv"), PermissionsExt::from_mode(0o444)).unwrap();
    let before = std::fs::read(d.join("s.csv")).unwrap();
    let again = ["step", "--duration-s", "0.6", "--out", "s.csv"];
    refused(d, &again, &["s.csv", "read-only", "--force"]);
    // through a link to it too
    symlink("s.csv", d.join("alias.csv")).unwrap();
    let by_link = ["step", "--duration-s", "0.6", "--out", "alias.csv"];
    refused(d, &by_link, &["alias.csv", "read-only"]);
    assert_eq!(std::fs::read(d.join("s.csv")).unwrap(), before);
    let mut forced = again.to_vec();
    forced.push("--force");
    ok(d, &forced);
    let after = std::fs::read(d.join("s.csv")).unwrap();
    assert!(
        after.len() > before.len(),
        "0.6 s holds more samples than 0.5 s"
    );
    let mode = std::fs::metadata(d.join("s.csv")).unwrap().permissions();
    assert_eq!(
        mode.mode() & 0o777,
        0o444,
        "a file written over keeps its mode"
    );
}

#[test]
fn two_outputs_at_one_path_are_refused_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    refused(
        d,
        &["model", "--out", "x.m", "--greybox", "x.m"],
        &["x.m", "--out", "--greybox"],
    );
    refused(
        d,
        &["model", "--out", "x.m", "--greybox", "./x.m"],
        &["--out", "--greybox"],
    );
    std::fs::create_dir(d.join("sub")).unwrap();
    symlink("sub", d.join("alias")).unwrap();
    refused(
        d,
        &["model", "--out", "sub/x.m", "--greybox", "alias/x.m"],
        &["--out", "--greybox"],
    );
    assert!(!d.join("x.m").exists());
    assert!(!d.join("sub/x.m").exists());
    // two paths are two outputs
    ok(d, &["model", "--out", "y.m", "--greybox", "z.m"]);
    assert!(d.join("y.m").is_file() && d.join("z.m").is_file());
}

/// Run `pumpcyl ARGS` in `dir` under a file-size limit of 10 blocks (`ulimit -f 10`).
fn limited(dir: &Path, args: &str) -> Output {
    std::process::Command::new("sh")
        .current_dir(dir)
        .arg("-c")
        .arg(format!("ulimit -f 10 && exec \"$0\" {args}"))
        .arg(env!("CARGO_BIN_EXE_pumpcyl"))
        .output()
        .unwrap()
}

#[test]
fn a_file_size_limit_fails_the_write_and_leaves_no_temporary() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (args, name) in [("step --out s.csv", "s.csv"), ("select --out R", "R")] {
        let out = limited(d, args);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{args}: {err}");
        assert_eq!(err.lines().count(), 1, "{args}: {err}");
        assert!(err.contains("File too large"), "{args}: {err}");
        assert!(!d.join(name).exists(), "{args}");
        let left: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        assert!(left.is_empty(), "{args}: {left:?}");
    }
}
