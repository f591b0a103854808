//! Every rig key driven through extreme magnitudes (1e-300 … 1e300, either sign): each command
//! finishes within a time bound, exits 0 or 1 (never 101, a panic), and what it prints on
//! success holds no NaN. Values outside the physical ranges must be refused with exit 1.

use proptest::prelude::*;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The numeric keys of the default rig, from `pumpcyl rig --print-default`.
fn numeric_keys() -> Vec<String> {
    let out = Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .args(["rig", "--print-default"])
        .output()
        .unwrap();
    let mut keys: Vec<String> = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .filter_map(|l| l.split_once(" = "))
        .filter(|(_, v)| {
            v.split_whitespace()
                .next()
                .unwrap_or("")
                .parse::<f64>()
                .is_ok()
        })
        .map(|(k, _)| k.trim().to_string())
        .collect();
    keys.push("motor_time_constant_s".into());
    assert!(keys.len() >= 30, "{keys:?}");
    keys
}

/// The commands run on the rig, short settings so that each finishes in well under a second.
const COMMANDS: [&[&str]; 6] = [
    &["margins"],
    &["poles"],
    &["bode", "--points-per-decade", "10"],
    &["step", "--duration-s", "1"],
    &["track", "--freq-hz", "1", "--amp-mm", "5", "--periods", "2"],
    &["design"],
];

/// Run with a time bound; (exit code, stdout, stderr), or a failure naming the hang.
fn run_bounded(args: &[String], bound: Duration) -> Result<(Option<i32>, String, String), String> {
    let mut child = Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            let out = child.wait_with_output().unwrap();
            return Ok((
                out.status.code(),
                String::from_utf8_lossy(&out.stdout).into_owned(),
                String::from_utf8_lossy(&out.stderr).into_owned(),
            ));
        }
        if start.elapsed() > bound {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!("pumpcyl {} ran past {bound:?}", args.join(" ")));
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn extreme_rig_values_end_in_a_result_or_a_clear_error(
        key_pick in 0usize..1000,
        exponent in prop_oneof![-300i32..=300, -12i32..=12],
        negative in any::<bool>(),
        command in 0usize..COMMANDS.len(),
    ) {
        let keys = numeric_keys();
        let key = &keys[key_pick % keys.len()];
        let value = format!("{}1e{exponent}", if negative { "-" } else { "" });
        let mut args: Vec<String> = COMMANDS[command].iter().map(|s| s.to_string()).collect();
        args.extend(["--set".to_string(), format!("{key}={value}")]);
        let (code, stdout, stderr) = run_bounded(&args, Duration::from_secs(30))
            .map_err(TestCaseError::fail)?;
        let shown = format!("pumpcyl {}: exit {code:?}\n{stderr}", args.join(" "));
        prop_assert!(code == Some(0) || code == Some(1), "{}", shown);
        prop_assert!(!stderr.contains("panicked"), "{}", shown);
        if code == Some(1) {
            prop_assert!(stderr.starts_with("error: ") && stderr.lines().count() == 1, "{}", shown);
        } else {
            prop_assert!(!stdout.to_lowercase().contains("nan"), "{}\n{}", shown, stdout);
        }
        // a magnitude beyond 1e100 is outside every physical range (a tiny one may be fine for
        // a key that can be zero)
        if exponent > 100 {
            prop_assert_eq!(code, Some(1), "{}", shown);
            prop_assert!(stderr.contains(key.as_str()), "{}", shown);
        }
    }
}
