//! Every statement of stability names its loop, and the command line does not contradict
//! itself: `margins` reads stability on the analysed loop (sum-pressure loop open, the article
//! §2.3.3) and also states the loop as simulated (sum-pressure loop closed), the one `step`
//! runs and `poles` lists (docs/analysis.md#the-loop-that-is-analysed).

use serde_json::Value;
use std::path::Path;

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;

/// `pumpcyl ARGS` (successful) as JSON.
fn json(args: &[&str]) -> Value {
    run::json(Path::new("."), args)
}

#[test]
fn margins_states_the_simulated_loop_that_step_refuses() {
    let set = ["--set", "motor_model=first_order"];
    let m = json(&["margins", set[0], set[1], "--json"]);
    // the analysed loop is stable, the simulated one is not
    assert_eq!(m["closed_loop_stable"], true);
    let sim = &m["simulated_closed_loop"];
    assert_eq!(sim["stability"], "unstable");
    // its pole is the rightmost of the poles `poles` lists for the loop as simulated
    let poles = json(&["poles", set[0], set[1], "--json"]);
    let rightmost = poles["closed_loop_with_sum_pressure"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| (p["re"].as_f64().unwrap(), p["im"].as_f64().unwrap().abs()))
        .fold(
            (f64::NEG_INFINITY, 0.0),
            |a, p| if p.0 > a.0 { p } else { a },
        );
    let pole = sim["rightmost_pole"].as_array().unwrap();
    assert!((pole[0].as_f64().unwrap() - rightmost.0).abs() < 1e-9);
    assert!((pole[1].as_f64().unwrap() - rightmost.1).abs() < 1e-9);
    assert!(rightmost.0 > 0.0);
    // the text says so on its own line, with the pole `step` names when it refuses
    let text = run::pumpcyl(Path::new("."), &["margins", set[0], set[1]]);
    let text = String::from_utf8_lossy(&text.stdout).to_string();
    let line = text
        .lines()
        .find(|l| l.contains("as simulated"))
        .expect(&text);
    assert!(
        line.contains("UNSTABLE") && line.contains(&format!("{:+.4}", rightmost.0)),
        "{line}"
    );
    assert!(text.contains("sum-pressure loop open"), "{text}");
    run::refused(
        Path::new("."),
        &["step", set[0], set[1]],
        &[&format!("{:+.4}", rightmost.0)],
    );
}

#[test]
fn the_simulated_loop_is_stated_only_where_it_differs() {
    let m = json(&["margins", "--json"]);
    assert_eq!(m["simulated_closed_loop"]["stability"], "stable");
    // analysed with the sum-pressure loop closed, the analysed loop is the simulated one
    let m = json(&["margins", "--sum-pressure-closed", "--json"]);
    assert!(m.get("simulated_closed_loop").is_none(), "{m}");
    let m = json(&["margins", "--set", "sum_pressure=false", "--json"]);
    assert!(m.get("simulated_closed_loop").is_none(), "{m}");
}
