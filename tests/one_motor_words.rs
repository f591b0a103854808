//! The one-motor circuits (the article's Figure 1; docs/circuits.md) have no sum-pressure
//! loop: `margins`, `poles` and `step` on them neither report a loop "as simulated" with it
//! nor name it, where the DPM's outputs do (the article §2.3.3 opens it in the analysed loop).

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;

use run::{json, pumpcyl, refused};

/// The text of `pumpcyl ARGS --set circuit=CIRCUIT`, which must succeed.
fn text(circuit: &str, args: &[&str]) -> String {
    let set = format!("circuit={circuit}");
    let mut all = args.to_vec();
    all.extend(["--set", &set]);
    let out = pumpcyl(std::env::temp_dir().as_path(), &all);
    assert!(
        out.status.success(),
        "{all:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn one_motor_circuits_name_no_sum_pressure_loop_and_the_dpm_does() {
    for circuit in ["single-pump", "dual-pump", "dpm"] {
        let dpm = circuit == "dpm";
        for args in [&["margins"][..], &["poles"], &["step"]] {
            if circuit == "single-pump" && args == ["step"] {
                // a simulated response of the single pump's two modes is refused, saying so
                let dir = std::env::temp_dir();
                let set = ["step", "--set", "circuit=single-pump"];
                refused(&dir, &set, &["single-pump", "docs/circuits.md"]);
                continue;
            }
            let t = text(circuit, args);
            assert_eq!(t.contains("sum-pressure"), dpm, "{circuit} {args:?}:\n{t}");
        }
        let set = format!("circuit={circuit}");
        let dir = std::env::temp_dir();
        let p = json(&dir, &["poles", "--json", "--set", &set]);
        assert_eq!(
            p.get("closed_loop_with_sum_pressure").is_some(),
            dpm,
            "{circuit}: {p}"
        );
        let m = json(&dir, &["margins", "--json", "--set", &set]);
        let simulated = m.get("simulated_closed_loop");
        assert_eq!(
            simulated.is_some_and(|v| !v.is_null()),
            dpm,
            "{circuit}: {m}"
        );
    }
}
