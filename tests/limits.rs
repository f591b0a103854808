//! Limits are checked before memory is taken (docs/formats.md#limits): an input that never ends
//! is stopped at its documented size while it is read, and sizes derived from arguments are
//! computed and refused, naming the option, before anything is allocated.

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;
use run::refused;

#[test]
fn inputs_that_never_end_are_stopped_at_their_limit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::os::unix::fs::symlink("/dev/zero", d.join("zero.mat")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", d.join("zero.csv")).unwrap();
    // a MAT-file's header is checked first: no endian indicator in its 128 bytes
    refused(
        d,
        &["simulate", "--data", "zero.mat"],
        &["zero.mat", "not a level-5 MAT-file"],
    );
    refused(
        d,
        &["identify-merge", "/dev/zero"],
        &["/dev/zero", "64 MiB"],
    );
    refused(d, &["simulate", "--data", "zero.csv"], &["zero.csv"]);
}

#[test]
fn sizes_from_arguments_are_refused_before_any_allocation() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 4.9·10⁷ samples of eight signals once took 9 GB (an allocation abort on smaller machines)
    let step = ["step", "--rate-hz", "1e6", "--duration-s", "49"];
    refused(d, &step, &["--duration-s", "--rate-hz", "limit of 5e6"]);
    let png = [
        "step",
        "--rate-hz",
        "1e6",
        "--duration-s",
        "49",
        "--out",
        "s.png",
    ];
    refused(d, &png, &["--rate-hz", "limit of 5e6"]);
    assert!(!d.join("s.png").exists());
    let track = [
        "track",
        "--freq-hz",
        "0.1",
        "--amp-mm",
        "5",
        "--rate-hz",
        "4e6",
    ];
    refused(d, &track, &["--rate-hz", "limit of 5e6"]);
}

#[test]
fn long_runs_and_large_models_are_refused_unless_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 2·10⁶ table rows took minutes, 300 × 300 design conditions most of an hour
    refused(
        d,
        &["bulk-modulus", "--points", "2000000"],
        &["--points", "--allow-long-run"],
    );
    let mut design = vec!["design".to_string()];
    for i in 0..300 {
        design.extend(["--mass-kg".into(), format!("{}", 1000 + i)]);
        design.extend(["--p-mean-bar".into(), format!("{}", 1.0 + i as f64 / 100.0)]);
    }
    let design: Vec<&str> = design.iter().map(String::as_str).collect();
    refused(d, &design, &["mass_kg × p_mean_bar", "--allow-long-run"]);
    // the robust design counts the same conditions, in the core as the nominal one does
    let robust = [&design[..], &["--robust"]].concat();
    refused(d, &robust, &["mass_kg × p_mean_bar", "--allow-long-run"]);
    // a state-space model of 501 states
    let n = 501;
    let row = |k: usize| format!("[{}]", (0..k).map(|_| "0").collect::<Vec<_>>().join(","));
    let a: Vec<String> = (0..n).map(|_| row(n)).collect();
    let b: Vec<String> = (0..n).map(|_| "[1]".to_string()).collect();
    let json = format!(
        "{{\"A\":[{}],\"B\":[{}],\"C\":[{}],\"D\":[[0]]}}",
        a.join(","),
        b.join(","),
        row(n)
    );
    std::fs::write(d.join("big.json"), json).unwrap();
    refused(
        d,
        &["margins", "--ss", "big.json"],
        &["big.json", "501 states", "limit of 500"],
    );
    // a Bode diagram of 4.8·10⁷ points (3 GB): refused from its arguments
    let bode = [
        "bode",
        "--from-hz",
        "1e-6",
        "--to-hz",
        "1e6",
        "--points-per-decade",
        "4000000",
    ];
    refused(d, &bode, &["--points-per-decade", "limit of 5e7 values"]);
}

/// `--set mass_kg=[…]` of `n` loads from 5000 kg in steps of 10 kg.
fn loads(n: usize) -> String {
    let m: Vec<String> = (0..n).map(|i| format!("{}", 5000 + 10 * i)).collect();
    format!("mass_kg=[{}]", m.join(","))
}

#[test]
fn select_refuses_hours_of_loads_unless_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // the article's application: its pressure levels, each a case per load
    let levels = run::json(d, &["select", "--json"])["options"]
        .as_array()
        .unwrap()
        .len();
    assert!(levels >= 2, "{levels}");
    // 200 loads ran for a minute without a word, 10^5 (in an application file) would run
    // for days
    let words = |n: usize| {
        [
            "mass_kg loads × pressure levels".to_string(),
            format!("about {} units", n * levels),
            "4e2".into(),
            "--allow-long-run".into(),
        ]
    };
    let set = loads(200);
    let w = words(200);
    refused(
        d,
        &["select", "--set", &set],
        &w.each_ref().map(String::as_str),
    );
    std::fs::write(d.join("app.toml"), loads(100_000)).unwrap();
    let w = words(100_000);
    refused(
        d,
        &["select", "app.toml"],
        &w.each_ref().map(String::as_str),
    );
    // just beyond the limit of 400 cases: refused, and run when allowed
    let n = 400 / levels + 1;
    let set = loads(n);
    refused(d, &["select", "--set", &set], &["--allow-long-run"]);
    let allowed = run::json(d, &["select", "--set", &set, "--allow-long-run", "--json"]);
    assert_eq!(allowed["options"].as_array().unwrap().len(), levels);
}

#[test]
fn a_long_run_never_lifts_the_memory_limit_of_an_emulated_record() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for extra in [&[][..], &["--allow-long-run"][..]] {
        let mut args = vec![
            "emulate",
            "--experiment",
            "step",
            "--duration-s",
            "1e9",
            "--out",
            "r.csv",
        ];
        args.extend(extra);
        refused(d, &args, &["--duration-s", "--rate-hz", "limit of 5e6"]);
        assert!(!d.join("r.csv").exists());
    }
    // 5·10⁶ samples at the PLC's 100 Hz: 50 000 s; one sample more is refused before any work
    let args = [
        "emulate",
        "--experiment",
        "standstill",
        "--duration-s",
        "50000",
        "--out",
        "r.csv",
    ];
    refused(d, &args, &["5000001 points", "limit of 5e6"]);
}

/// `pumpcyl ARGS` in `dir` under a CPU-time limit of `seconds` (`ulimit -t`): a guard, so a run
/// the work limit fails to stop ends the test instead of running for hours; the test asserts
/// on the run's own refusal, never on a time.
fn pumpcyl_guarded(dir: &std::path::Path, seconds: u32, args: &[&str]) -> std::process::Output {
    std::process::Command::new("sh")
        .current_dir(dir)
        .arg("-c")
        .arg(format!("ulimit -t {seconds}; exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_pumpcyl"))
        .args(args)
        .output()
        .unwrap()
}

/// The emulator's work limit counts its integrator's work (docs/emulator.md#the-work-limit): on
/// the tests' user rig (80/45 mm, 2500 kg, β 300 bar; none of the article's values) at
/// Kp 1000 the drives saturate and a controller step costs the integrator tens of thousands of
/// evaluations; 20 000 s of it (2·10⁶ controller steps, within the steps' own limit, hours of
/// computing) is stopped with the --allow-long-run message after 256 steps, writing nothing,
/// while 2 s of it and 600 s of the calm rig run.
#[test]
fn an_emulation_whose_steps_cost_thousands_of_calm_ones_is_stopped_by_its_work() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rig = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/user-rig.toml");
    let emulate = |extra: &[&str], out: &str| {
        let mut args = vec![
            "emulate",
            "--rig",
            rig,
            "--experiment",
            "step",
            "--out",
            out,
        ];
        args.extend(extra);
        pumpcyl_guarded(d, 120, &args)
    };
    let long = emulate(&["--set", "kp=1000", "--duration-s", "20000"], "long.csv");
    let err = String::from_utf8_lossy(&long.stderr);
    assert_eq!(long.status.code(), Some(1), "{err}");
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(lines.len(), 1, "{err}");
    let e = lines[0];
    for word in [
        "long.csv: the emulator's integrator over 20000.00 s",
        "projected from its rate over t = 1.28-2.56 s",
        "a calm loop's at most 500",
        "more than the 5e9",
        "(--allow-long-run)",
    ] {
        assert!(e.contains(word), "lacks `{word}`: {e}");
    }
    // the rate it names: tens of thousands of evaluations a controller step
    let rate: f64 = e
        .split("right-hand-side evaluations; ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|r| r.parse().ok())
        .unwrap_or_else(|| panic!("no rate in {e}"));
    assert!(rate > 10_000.0, "{rate}: {e}");
    assert!(!d.join("long.csv").exists());
    // the same rig for 2 s, and the calm rig for 600 s, run
    for (extra, out) in [
        (&["--set", "kp=1000", "--duration-s", "2"][..], "short.csv"),
        (&["--duration-s", "600"], "calm.csv"),
    ] {
        let o = emulate(extra, out);
        assert!(
            o.status.success(),
            "{out}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(d.join(out).exists(), "{out}");
    }
}

/// `select`'s work counts its waves and its single-pump mode checks (docs/select.md#work), on
/// the tests' user rig (80/45 mm, 2500 kg, β 300 bar): 1000 [[wave]]s on its 13 DPM levels
/// are 446 cases, not 13, and 400 waves on two single-pump pre-charges, 28.6 cases, are
/// 6.8·10⁹ evaluations of emulated mode checks (11 candidates with the bisection, each the
/// step's 11 s and 400 × 31 s of wave at 100 Hz, 500 a calm step): both refused before any
/// work with the --allow-long-run message, where three waves run.
#[test]
fn select_counts_its_waves_and_its_mode_checks_in_its_work() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let user = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/user-rig.toml"))
        .unwrap();
    // the user rig as a single pump: one pump, so no second displacement
    let single: String = (user.lines())
        .filter(|l| !l.starts_with("displacement_2"))
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(d.join("dpm.toml"), &user).unwrap();
    std::fs::write(
        d.join("sp.toml"),
        format!("{single}circuit = \"single-pump\"\n"),
    )
    .unwrap();
    let app = |name: &str, rig: &str, head: &str, waves: usize| {
        let mut text = format!("rig = \"{rig}\"\n{head}");
        for k in 0..waves {
            // distinct waves, each 0.2 Hz (31 s of emulated mode check)
            let amp = 10.0 + 0.001 * k as f64;
            text += &format!("\n[[wave]]\nfreq_hz = 0.2\namp_mm = {amp}\nmax_error_mm = 30.0\n");
        }
        std::fs::write(d.join(name), text).unwrap();
    };
    app("dpm-waves.toml", "dpm.toml", "circuits = [\"dpm\"]\n", 1000);
    let single_pump = "circuits = [\"single-pump\"]\nprecharge_bar = [3.0, 6.0]\n";
    app("sp-waves.toml", "sp.toml", single_pump, 400);
    app("sp-three.toml", "sp.toml", single_pump, 3);
    let refused = |file: &str, words: &[&str]| {
        let out = pumpcyl_guarded(d, 60, &["select", file]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{file}: {err}");
        assert_eq!(err.lines().count(), 1, "{file}: {err}");
        for w in words {
            assert!(err.contains(w), "{file}: lacks `{w}`: {err}");
        }
    };
    refused(
        "dpm-waves.toml",
        &[
            "each [[wave]] beyond the first adds 1/30 of a case, 1000 waves",
            "about 446 units of work, more than the 4e2",
            "(--allow-long-run)",
        ],
    );
    refused(
        "sp-waves.toml",
        &[
            "the single-pump mode checks",
            "about 6.82605e9 units of work, more than the 5e9",
            "(--allow-long-run)",
        ],
    );
    let out = pumpcyl_guarded(d, 60, &["select", "sp-three.toml", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["options"].as_array().unwrap().len(), 2);
}
