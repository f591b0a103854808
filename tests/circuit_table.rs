//! The table "what works on which circuit" (docs/circuits.md#what-works-on-which-circuit) is
//! tested against the commands: a cell that says "refused" must be a one-line refusal (exit 1),
//! any other answer a run that succeeds, for each circuit's column.

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;

/// The table's circuits, in its column order.
const CIRCUITS: [&str; 4] = ["dpm", "dual-pump", "single-pump", "valve"];

/// The cells of the table's row whose first cell starts with `` `command` ``.
fn row(command: &str) -> Vec<String> {
    let doc =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/circuits.md")).unwrap();
    let start = format!("| `{command}`");
    let line = doc
        .lines()
        .find(|l| l.starts_with(&start))
        .unwrap_or_else(|| panic!("docs/circuits.md has no row for `{command}`"));
    let cells: Vec<String> = line.split('|').map(|c| c.trim().to_string()).collect();
    // "| first | dpm | dual-pump | single-pump | valve |" splits into 7 with empty ends
    assert_eq!(cells.len(), 7, "{line}");
    cells[2..6].to_vec()
}

/// Each circuit's run of `args` (with `--set circuit=…` where `set_circuit`) against its cell.
fn check(command: &str, args: impl Fn(&str) -> Vec<String>) {
    let dir = tempfile::tempdir().unwrap();
    for (circuit, cell) in CIRCUITS.iter().zip(row(command)) {
        let a = args(circuit);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        if cell.starts_with("refused") {
            run::refused(dir.path(), &a, &[circuit]);
        } else {
            let out = run::pumpcyl(dir.path(), &a);
            assert!(
                out.status.success(),
                "{command} on {circuit} (docs: {cell}): {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
    }
}

/// `args` on the default rig as `circuit`; the valve at a gain its loop is stable at (a
/// valve's K_p is in full openings per metre, the article's 25 would be an unstable loop).
fn on(circuit: &str, args: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = args.iter().map(|s| s.to_string()).collect();
    v.extend(["--set".to_string(), format!("circuit={circuit}")]);
    if circuit == "valve" {
        v.extend(["--set".to_string(), "kp=0.01".to_string()]);
    }
    v
}

#[test]
fn the_linear_responses_are_where_the_table_says() {
    check("step", |c| on(c, &["step", "--json"]));
}

#[test]
fn the_emulator_is_where_the_table_says() {
    check("emulate", |c| {
        on(
            c,
            &[
                "emulate",
                "--experiment",
                "step",
                "--duration-s",
                "2",
                "--out",
                "e.csv",
                "--force",
            ],
        )
    });
}

#[test]
fn select_is_where_the_table_says() {
    check("select", |c| {
        let circuits = format!("circuits=[\"{c}\"]");
        let rig = format!("rig.circuit={c}");
        [
            "select",
            "--json",
            "--set",
            &rig,
            "--set",
            &circuits,
            "--set",
            "supply_bar=[70.0]",
            "--set",
            "low_pressure_bar=[5.0]",
            "--set",
            "pressurised_bar=[]",
            "--set",
            "precharge_bar=[5.0]",
        ]
        .map(String::from)
        .to_vec()
    });
}

#[test]
fn the_linear_analyses_are_where_the_table_says() {
    for command in [
        &["margins", "--json"][..],
        &["poles", "--json"],
        &["bode"],
        &["model", "--json"],
    ] {
        check("margins", |c| on(c, command));
    }
}

#[test]
fn design_is_where_the_table_says() {
    check("design", |c| on(c, &["design", "--json"]));
}

#[test]
fn the_greybox_export_and_chatter_are_where_the_table_says() {
    check("model --greybox", |c| {
        on(c, &["model", "--greybox", "greybox.m"])
    });
    check("chatter", |c| on(c, &["chatter", "--json"]));
}

#[test]
fn the_table_has_a_row_for_each_command_checked() {
    for command in [
        "step",
        "emulate",
        "select",
        "chatter",
        "margins",
        "design",
        "model --greybox",
    ] {
        assert_eq!(row(command).len(), CIRCUITS.len());
    }
}
