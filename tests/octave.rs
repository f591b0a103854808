//! MATLAB and Octave round trips, checked with a real client: GNU Octave and its control
//! package run the files pumpcyl exports (`model --out FILE.m`, `--greybox`, `--out FILE.mat`)
//! and their answers are compared with pumpcyl's own (docs/matlab.md). Without `octave` these
//! tests skip: SKIPPED on the terminal and in the last line of `./test.sh`; with the environment
//! variable `CI` set they fail instead.
//! MAT-file records (written by Octave itself, committed in tests/awkward-inputs/) are also
//! replayed without Octave.

#[path = "common/skip.rs"]
mod skip;

#[path = "common/json.rs"]
mod json;
use json::matrix;

use serde_json::Value;
use std::collections::HashMap;
use std::path::Path;
use std::process::Command;

fn pumpcyl(dir: &Path, args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "pumpcyl {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

fn json(dir: &Path, args: &[&str]) -> Value {
    serde_json::from_str(&pumpcyl(dir, args)).unwrap()
}

/// Whether Octave with the control package is here; if not, the test skips (tests/common/skip.rs:
/// said on the terminal, counted in the last line of `./test.sh`), or fails under CI.
fn have_octave(test: &str) -> bool {
    let ok = Command::new("octave")
        .args(["--no-gui", "--quiet", "--eval", "pkg load control"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        skip::skip(
            test,
            "octave and octave-control",
            "apt-get install octave octave-control",
        );
    }
    ok
}

/// Run an Octave script in `dir` (with the control package loaded); its standard output.
fn octave(dir: &Path, script: &str) -> String {
    let path = dir.join("check_script.m");
    std::fs::write(&path, format!("pkg load control\n{script}\n")).unwrap();
    let out = Command::new("octave")
        .args([
            "--no-gui",
            "--quiet",
            "--no-window-system",
            "check_script.m",
        ])
        .current_dir(dir)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success() && !stdout.contains("error:"),
        "octave failed: {stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// Numbers of the line starting with `key` in Octave's output.
fn numbers(out: &str, key: &str) -> Vec<f64> {
    let line = out
        .lines()
        .find(|l| l.split_whitespace().next() == Some(key))
        .unwrap_or_else(|| panic!("no `{key}` in {out}"));
    line.split_whitespace()
        .skip(1)
        .map(|w| match w {
            "Inf" => f64::INFINITY,
            "-Inf" => f64::NEG_INFINITY,
            "NaN" => f64::NAN,
            w => w.parse().unwrap(),
        })
        .collect()
}

#[test]
fn octave_margin_on_the_exported_open_loop_matches_pumpcyl() {
    if !have_octave("octave_margin_on_the_exported_open_loop_matches_pumpcyl") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let cases: [&[&str]; 4] = [
        &[],
        &["--set", "beta_bar=370"],
        &[
            "--set",
            "kp=40",
            "--set",
            "mass_kg=4898",
            "--set",
            "feedforward=false",
        ],
        &["--set", "motor_model=first_order"],
    ];
    for (i, set) in cases.iter().enumerate() {
        let name = format!("ol{i}");
        let file = format!("{name}.m");
        let mut args = vec!["model", "--out", &file];
        args.extend_from_slice(set);
        pumpcyl(dir.path(), &args);
        let mut args = vec!["margins", "--json"];
        args.extend_from_slice(set);
        let m = json(dir.path(), &args);
        let out = octave(
            dir.path(),
            &format!(
                "[sys, op] = {name}();\n[Gm, Pm, Wcg, Wcp] = margin(sys);\n\
                 printf('margins %.17g %.17g %.17g %.17g\\n', 20*log10(Gm), Pm, Wcg/(2*pi), Wcp/(2*pi));\n\
                 printf('names %s %s %s\\n', sys.stname{{3}}, sys.inname{{1}}, sys.outname{{1}});"
            ),
        );
        let v = numbers(&out, "margins");
        let gm = m["gain_margin_db"].as_f64().unwrap();
        let pm = m["phase_margin_deg"].as_f64().unwrap();
        eprintln!(
            "{set:?}: GM {gm} dB (Octave {}), PM {pm} deg (Octave {})",
            v[0], v[1]
        );
        assert!(
            (v[0] - gm).abs() < 0.01,
            "{set:?}: GM {gm} vs Octave {}",
            v[0]
        );
        assert!(
            (v[1] - pm).abs() < 0.01,
            "{set:?}: PM {pm} vs Octave {}",
            v[1]
        );
        let wpc = m["phase_crossover_hz"].as_f64().unwrap();
        let wgc = m["gain_crossover_hz"].as_f64().unwrap();
        assert!(
            (v[2] / wpc - 1.0).abs() < 1e-4 && (v[3] / wgc - 1.0).abs() < 1e-4,
            "{v:?}"
        );
        assert!(out.contains("names p1 e x"), "{out}");
    }
}

#[test]
fn octave_lsim_on_the_exported_closed_loop_matches_pumpcyl_step() {
    if !have_octave("octave_lsim_on_the_exported_closed_loop_matches_pumpcyl_step") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    for (i, set) in [vec![], vec!["--set", "sum_pressure=false"]]
        .iter()
        .enumerate()
    {
        let (name, step) = (format!("cl{i}"), format!("step{i}.mat"));
        let file = format!("{name}.m");
        let mut args = vec!["model", "--closed-loop", "--out", &file];
        args.extend_from_slice(set);
        pumpcyl(dir.path(), &args);
        let mut args = vec!["step", "--step-mm", "5", "--out", &step];
        args.extend_from_slice(set);
        pumpcyl(dir.path(), &args);
        let out = octave(
            dir.path(),
            &format!(
                "[sys, op] = {name}();\ns = load('{step}');\n\
                 u = (s.x_ref_mm - op.x_ref_m*1e3)*1e-3;\n\
                 y = lsim(sys, u, s.time_s);\n\
                 x = op.x_m*1e3 + 1e3*y(:, 1);\n\
                 p1 = op.p1_Pa/1e5 + y(:, 2)/1e5;\n\
                 w2 = op.w2_rad_per_s*30/pi + y(:, 5)*30/pi;\n\
                 printf('dx %.17g\\n', max(abs(x - s.x_mm)));\n\
                 printf('dp1 %.17g\\n', max(abs(p1 - s.p1_bar)));\n\
                 printf('dw2 %.17g\\n', max(abs(w2 - s.w2_rpm)));\n\
                 printf('swing %.17g\\n', max(s.x_mm) - min(s.x_mm));\n\
                 printf('outputs %s\\n', strjoin(sys.outname', ','));"
            ),
        );
        let [dx, dp1, dw2, swing] = ["dx", "dp1", "dw2", "swing"].map(|k| numbers(&out, k)[0]);
        eprintln!("{set:?}: max |x - x_pumpcyl| = {dx:e} mm, p1 {dp1:e} bar, w2 {dw2:e} rpm");
        assert!(swing > 5.0, "{swing}"); // the step moved the piston
        assert!(
            dx < 1e-6,
            "{set:?}: lsim differs from pumpcyl step by {dx} mm"
        );
        assert!(dp1 < 1e-6 && dw2 < 1e-4, "{set:?}: {dp1} bar, {dw2} rpm");
        assert!(out.contains("outputs x,p1,p2,w1,w2,e"), "{out}");
    }
}

/// c1, c2 from a standstill (default: the rig's own) at a c12, computed by pumpcyl's leakage
/// code, to set on the rig for `model --json`.
fn leakages_at(c12: f64, given: Option<pumpcyl::ident::Standstill>) -> [String; 2] {
    use pumpcyl::{loops, rig::Rig};
    let rig = Rig::default();
    let l = loops::standstill_of(&rig, given)
        .unwrap()
        .leakage(&rig, c12)
        .unwrap();
    [
        format!("c1_m5_per_ns={:?}", l.c1_m5_per_ns),
        format!("c2_m5_per_ns={:?}", l.c2_m5_per_ns),
    ]
}

#[test]
fn octave_greybox_function_matches_model_json() {
    if !have_octave("octave_greybox_function_matches_model_json") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    pumpcyl(dir.path(), &["model", "--greybox", "gb_open.m"]);
    pumpcyl(
        dir.path(),
        &["model", "--closed-loop", "--greybox", "gb_closed.m"],
    );
    let standstill = ["--w1-rpm", "-160", "--w2-rpm", "245", "--p1-bar", "3.95"];
    let args = [&["model", "--greybox", "gb_article.m"], &standstill[..]].concat();
    pumpcyl(dir.path(), &args);
    let [c1, c2] = leakages_at(2e-10, None);
    let other = [
        "--set",
        "beta_bar=100",
        "--set",
        "viscous_friction_ns_per_m=500",
        "--set",
        "c12_m5_per_ns=2e-10",
        "--set",
        &c1,
        "--set",
        &c2,
    ];
    let article = pumpcyl::ident::Standstill {
        w1_rpm: -160.0,
        w2_rpm: 245.0,
        p1_bar: 3.95,
    };
    let [a1, a2] = leakages_at(1.5e-10, Some(article));
    let article_set = ["--set", "c12_m5_per_ns=1.5e-10", "--set", &a1, "--set", &a2];
    let cases: [(&str, &str, Vec<&str>); 5] = [
        ("gb_open", "165, 100, 1.2e-10", vec![]),
        ("gb_closed", "165, 100, 1.2e-10", vec!["--closed-loop"]),
        ("gb_open", "100, 500, 2e-10", other.to_vec()),
        (
            "gb_closed",
            "100, 500, 2e-10",
            [&["--closed-loop"], &other[..]].concat(),
        ),
        ("gb_article", "165, 100, 1.5e-10", article_set.to_vec()),
    ];
    for (func, params, extra) in cases {
        let mut args = vec!["model", "--json"];
        args.extend(extra.iter().copied());
        let m = json(dir.path(), &args);
        let out = octave(
            dir.path(),
            &format!(
                "[A, B, C, D] = {func}({params}, 0);\n\
                 printf('A'); printf(' %.17g', A'); printf('\\n');\n\
                 printf('B'); printf(' %.17g', B'); printf('\\n');\n\
                 printf('C'); printf(' %.17g', C'); printf('\\n');\n\
                 printf('D'); printf(' %.17g', D'); printf('\\n');\n\
                 [Ad, Bd] = {func}({params}, 0.01, 'an optional argument');\n\
                 sd = c2d(ss(A, B, C, D), 0.01, 'zoh');\n\
                 printf('zoh %.17g\\n', max(max(abs([Ad, Bd] - [sd.a, sd.b]))) / max(max(abs([sd.a, sd.b]))));"
            ),
        );
        for key in ["A", "B", "C", "D"] {
            let want: Vec<f64> = matrix(&m[key]).concat();
            let got = numbers(&out, key);
            assert_eq!(got.len(), want.len(), "{func}({params}) {key}");
            let scale = want.iter().fold(0.0f64, |s, v| s.max(v.abs()));
            for (k, (g, w)) in got.iter().zip(&want).enumerate() {
                // rows of A span 1e-7 .. 1e8: compare each entry to its own size
                assert!(
                    (g - w).abs() <= 1e-12 * w.abs() + 1e-15 * scale,
                    "{func}({params}) {key}[{k}]: Octave {g} vs pumpcyl {w}"
                );
            }
        }
        let zoh = numbers(&out, "zoh")[0];
        assert!(zoh < 1e-9, "{func}: Ts > 0 differs from c2d by {zoh}");
    }
}

/// A variable as Octave sees it: rows, columns, and its values (column-major) or its text.
type Loaded = (usize, usize, Result<Vec<f64>, String>);

/// Every variable of a MAT-file as Octave's `load` sees it, by name.
fn octave_load(dir: &Path, file: &str) -> HashMap<String, Loaded> {
    let out = octave(
        dir,
        &format!(
            "s = load('{file}');\nn = fieldnames(s);\nfor i = 1:numel(n)\n  v = s.(n{{i}});\n  \
             if ischar(v)\n    printf('var %s %d %d char %s\\n', n{{i}}, rows(v), columns(v), v);\n  \
             else\n    printf('var %s %d %d num', n{{i}}, rows(v), columns(v));\n    \
             printf(' %.17g', v(:));\n    printf('\\n');\n  end\nend"
        ),
    );
    out.lines()
        .filter_map(|l| l.strip_prefix("var "))
        .map(|l| {
            let mut w = l.splitn(5, ' ');
            let name = w.next().unwrap().to_string();
            let rows = w.next().unwrap().parse().unwrap();
            let cols = w.next().unwrap().parse().unwrap();
            let kind = w.next().unwrap();
            let rest = w.next().unwrap_or("");
            let value = if kind == "char" {
                Err(rest.to_string())
            } else {
                Ok(numbers(&format!("x {rest}"), "x"))
            };
            (name, (rows, cols, value))
        })
        .collect()
}

/// A CSV written by pumpcyl: column name → values.
fn csv_columns(path: &Path) -> HashMap<String, Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let names: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    for l in lines {
        for (c, f) in l.split(',').enumerate() {
            if let Ok(v) = f.parse() {
                cols[c].push(v);
            }
        }
    }
    names.into_iter().zip(cols).collect()
}

/// Equal within `rel` of each value's size.
fn close_rel(a: &[f64], b: &[f64], rel: f64, what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: lengths");
    for (k, (x, y)) in a.iter().zip(b).enumerate() {
        assert!((x - y).abs() <= rel * y.abs(), "{what}[{k}]: {x} vs {y}");
    }
}

fn close(a: &[f64], b: &[f64], tol: f64, what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: lengths");
    for (k, (x, y)) in a.iter().zip(b).enumerate() {
        assert!((x - y).abs() <= tol, "{what}[{k}]: {x} vs {y}");
    }
}

#[test]
fn octave_loads_every_mat_file_pumpcyl_writes() {
    if !have_octave("octave_loads_every_mat_file_pumpcyl_writes") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/article");
    let ident = data.join("identification.csv");
    let ident = ident.to_str().unwrap();

    // model: the matrices of model --json, the names, the operating point
    pumpcyl(d, &["model", "--closed-loop", "--out", "model.mat"]);
    let m = json(d, &["model", "--closed-loop", "--json"]);
    let vars = octave_load(d, "model.mat");
    for key in ["A", "B", "C", "D"] {
        let want = matrix(&m[key]);
        let (r, c, v) = &vars[key];
        assert_eq!((*r, *c), (want.len(), want[0].len()), "{key}");
        let col_major: Vec<f64> = (0..*c)
            .flat_map(|j| want.iter().map(move |row| row[j]))
            .collect();
        // serde_json reads decimals to within an ulp (not exactly): allow 2
        close_rel(v.as_ref().unwrap(), &col_major, 4.5e-16, key);
    }
    assert_eq!(
        vars["state_names"].2,
        Err("x,v,p1,p2,w1,w2,tau1,tau2,z1,z2".into())
    );
    assert_eq!(vars["output_names"].2, Err("x,p1,p2,w1,w2,e".into()));
    assert!((vars["op_x_m"].2.as_ref().unwrap()[0] - 0.345).abs() < 1e-15);

    // bode: the CSV's numbers (6 decimals there), with an overlay
    let compare = ["--compare", "beta_bar=37.8"];
    pumpcyl(d, &[&["bode", "--out", "bode.mat"], &compare[..]].concat());
    pumpcyl(d, &[&["bode", "--out", "bode.csv"], &compare[..]].concat());
    let (vars, csv) = (octave_load(d, "bode.mat"), csv_columns(&d.join("bode.csv")));
    let n = csv["freq_hz"].len();
    for (mat, col) in [
        ("mag_db", "mag_db"),
        ("phase_deg", "phase_deg"),
        ("mag_db_2", "mag_db[beta_bar=37.8]"),
        ("phase_deg_2", "phase_deg[beta_bar=37.8]"),
    ] {
        let (r, c, v) = &vars[mat];
        assert_eq!((*r, *c), (n, 1), "{mat}");
        close(v.as_ref().unwrap(), &csv[col], 1e-6, mat);
    }
    assert!(vars["series_labels"]
        .2
        .as_ref()
        .unwrap_err()
        .contains("2: beta_bar=37.8"));

    // step: signals as the CSV, metrics as --json
    pumpcyl(d, &["step", "--out", "step.mat"]);
    pumpcyl(d, &["step", "--out", "step.csv"]);
    let metrics = json(d, &["step", "--json"])["metrics"].clone();
    let (vars, csv) = (octave_load(d, "step.mat"), csv_columns(&d.join("step.csv")));
    for col in [
        "time_s", "x_ref_mm", "x_mm", "e_mm", "p1_bar", "p2_bar", "w1_rpm", "w2_rpm",
    ] {
        let (r, c, v) = &vars[col];
        assert_eq!((*r, *c), (401, 1), "{col}");
        close(v.as_ref().unwrap(), &csv[col], 1e-6, col);
    }
    for key in [
        "rise_time_s",
        "overshoot_mm",
        "peak_time_s",
        "final_error_mm",
    ] {
        close_rel(
            vars[key].2.as_ref().unwrap(),
            &[metrics[key].as_f64().unwrap()],
            4.5e-16,
            key,
        );
    }
    assert!(vars["settling_time_s"].2.as_ref().unwrap()[0].is_nan()); // null: not settled

    // track: one block per case, metrics per case
    pumpcyl(d, &["track", "--article-cases", "--out", "track.mat"]);
    let cases = json(d, &["track", "--article-cases", "--json"])["cases"].clone();
    let vars = octave_load(d, "track.mat");
    let max_err: Vec<f64> = cases
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["metrics"]["max_error_mm"].as_f64().unwrap())
        .collect();
    close_rel(
        vars["max_error_mm"].2.as_ref().unwrap(),
        &max_err,
        4.5e-16,
        "max_error_mm",
    );
    assert_eq!(vars["freq_hz"].2.as_ref().unwrap(), &[0.1, 0.2, 0.25]);
    assert_eq!(vars["time_s_3"].0, 1201); // 3 periods of 0.25 Hz at 100 Hz
    assert_eq!(vars["x_mm_2"].0, 1501);

    // simulate: the measured record (plain names) and the model (suffix _2), the MSE
    pumpcyl(d, &["simulate", "--data", ident, "--out", "sim.mat"]);
    let mse = json(d, &["simulate", "--data", ident, "--json"])["mse_mm2"]
        .as_f64()
        .unwrap();
    let vars = octave_load(d, "sim.mat");
    close_rel(
        vars["mse_mm2"].2.as_ref().unwrap(),
        &[mse],
        4.5e-16,
        "mse_mm2",
    );
    let rec = pumpcyl::record::Record::read(Path::new(ident)).unwrap();
    assert_eq!(vars["x_mm"].2.as_ref().unwrap(), &rec.x_mm);
    assert_eq!(vars["x_mm_2"].0, rec.len());

    // identify: the answer of result.json, the top list and the landscape
    let exp = format!(
        "[set]\nk_pres_per_bar = 0.22\n[standstill]\nrecord = \"{}\"\n\
         [grid]\nbeta_bar = [150.0, 165.0, 180.0]\nviscous_friction_ns_per_m = [100.0, 300.0]\n\
         c12_m5_per_ns = [1.0e-10, 1.2e-10]\n\
         [refined_grid]\nbeta_bar = [160.0, 170.0]\nviscous_friction_ns_per_m = [300.0]\n\
         c12_m5_per_ns = [1.2e-10]\n\
         [[dataset]]\nfile = \"{ident}\"\nkp = 25.0\nmass_kg = 10593.0\nfit_end_s = 3.7\n",
        data.join("standstill.csv").display()
    );
    std::fs::write(d.join("exp.toml"), exp).unwrap();
    pumpcyl(d, &["identify", "exp.toml", "--no-refine", "--out", "id"]);
    let result: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("id/result.json")).unwrap()).unwrap();
    let vars = octave_load(&d.join("id"), "result.mat");
    for key in [
        "beta_bar",
        "viscous_friction_ns_per_m",
        "c12_m5_per_ns",
        "c1_m5_per_ns",
        "cost_mm2",
    ] {
        close_rel(
            vars[key].2.as_ref().unwrap(),
            &[result[key].as_f64().unwrap()],
            4.5e-16,
            key,
        );
    }
    let top = result["top"].as_array().unwrap();
    assert_eq!((vars["top"].0, vars["top"].1), (top.len(), 4));
    close_rel(
        &vars["top"].2.as_ref().unwrap()[top.len() * 4 - 1..],
        &[top[top.len() - 1]["cost_mm2"].as_f64().unwrap()],
        4.5e-16,
        "top",
    );
    let (r, c, cost) = &vars["landscape_cost_mm2"];
    let landscape = csv_columns(&d.join("id/landscape.csv"));
    assert_eq!((*r, *c), (2, 3)); // c12 rows, beta columns
                                  // landscape.csv lists beta fastest; MATLAB's column-major of (c12 x beta) lists c12 fastest
    let cost = cost.as_ref().unwrap();
    for (k, want) in landscape["cost_mm2"].iter().enumerate() {
        let (i, j) = (k % 3, k / 3);
        let got = cost[i * 2 + j];
        assert!(
            got == *want || (got - want).abs() <= 1e-12 * want.abs(),
            "{k}: {got} vs {want}"
        );
    }
    assert_eq!(vars["fit1_x_mm"].2.as_ref().unwrap(), &rec.x_mm);
}

/// The acceptance check of docs/matlab.md: the same record as CSV and as MAT-files written by
/// GNU Octave (`save -v7`, compressed; `save -v6` with a row vector and a single-precision
/// column) gives the same MSE. Needs no Octave: the files are committed.
#[test]
fn mat_records_replay_like_the_csv() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let d = tempfile::tempdir().unwrap();
    let mse = |file: &Path| {
        json(
            d.path(),
            &["simulate", "--data", file.to_str().unwrap(), "--json"],
        )["mse_mm2"]
            .as_f64()
            .unwrap()
    };
    let csv = mse(&root.join("data/article/identification.csv"));
    assert!(csv > 0.01 && csv < 1.0, "{csv}");
    for f in [
        "identification_octave_v7.mat",
        "identification_octave_v6_row_single.mat",
    ] {
        assert_eq!(mse(&root.join("tests/awkward-inputs").join(f)), csv, "{f}");
    }
    // and a MAT-file pumpcyl wrote itself replays the same
    pumpcyl(
        d.path(),
        &[
            "simulate",
            "--data",
            root.join("data/article/identification.csv")
                .to_str()
                .unwrap(),
            "--out",
            "sim.mat",
        ],
    );
    assert_eq!(mse(&d.path().join("sim.mat")), csv);
    // a MAT-file without a required variable is a one-line error naming it
    let out = Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .args(["simulate", "--data", "m.mat"])
        .current_dir(d.path())
        .output()
        .unwrap();
    assert!(!out.status.success());
    let mut w = pumpcyl_present::matfile::MatWriter::new("test");
    w.column("time_s", &[0.0, 1.0])
        .column("x_ref_mm", &[1.0, 2.0])
        .column("x_m", &[1.0, 2.0]);
    std::fs::write(d.path().join("m.mat"), w.into_bytes()).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .args(["simulate", "--data", "m.mat"])
        .current_dir(d.path())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("m.mat") && err.contains("variable `x_mm`"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}
