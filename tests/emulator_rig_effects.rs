//! The emulator's pump dead band, slip leakage and Coulomb friction are rig keys, and the
//! one-motor circuits' relief setting is one too (docs/emulator.md#what-a-user-rig-gets,
//! docs/circuits.md#valves): their defaults on a rig that is not the article's, what setting
//! them does to `pumpcyl emulate`'s record, their refusal of bad values, the relief warning of
//! `emulate` and `select`, and the article's rig and records keeping exactly the values they
//! always had.

use pumpcyl::emulator::{article, Effects};
use pumpcyl::rig::Rig;
use std::path::PathBuf;
use std::process::Command;

/// A 50/28 mm single-pump rig with a 2.5 cm³/rev pump on a 64 N·m motor, its leakages of
/// that size (c12 2e-12 m⁵/(N·s), a twentieth of the article rig's slip).
const USER_RIG: &str = "circuit = \"single-pump\"\npiston_diameter_mm = 50.0\n\
    rod_diameter_mm = 28.0\nstroke_mm = 400.0\nx0_mm = 200.0\nmass_kg = 2000.0\n\
    displacement_1_cm3_per_rev = 2.5\nmotor_rated_torque_nm = 64.0\nc12_m5_per_ns = 2e-12\n\
    c1_m5_per_ns = 2e-12\nc2_m5_per_ns = 0.0\nkp = 10.0\n";

fn user_rig() -> Rig {
    Rig::from_toml_str(USER_RIG, "user.toml").unwrap()
}

/// The user rig written to a file of this test's own.
fn user_rig_file(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("emulator-rig-effects");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, USER_RIG).unwrap();
    path
}

/// `pumpcyl ARGS`: its status, stdout and stderr.
fn pumpcyl(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .args(args)
        .output()
        .unwrap();
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    (out.status.success(), text(&out.stdout), text(&out.stderr))
}

/// `pumpcyl emulate --experiment step` of the rig file `rig` into `out`.
fn step_args<'a>(rig: &'a std::path::Path, out: &'a std::path::Path) -> Vec<&'a str> {
    let (rig, out) = (rig.to_str().unwrap(), out.to_str().unwrap());
    vec![
        "emulate",
        "--rig",
        rig,
        "--experiment",
        "step",
        "--out",
        out,
    ]
}

/// `pumpcyl emulate --experiment step` on the user rig with `sets`: the message and the
/// record's position column (mm).
fn emulated_step(name: &str, sets: &[&str]) -> (String, Vec<f64>) {
    let rig = user_rig_file(&format!("{name}.toml"));
    let out = rig.with_extension("csv");
    let mut args = step_args(&rig, &out);
    for s in sets {
        args.extend(["--set", s]);
    }
    let (ok, stdout, stderr) = pumpcyl(&args);
    assert!(ok, "{stderr}");
    let csv = std::fs::read_to_string(&out).unwrap();
    let x = (csv.lines().skip(1))
        .map(|l| l.split(',').nth(2).unwrap().parse().unwrap())
        .collect();
    // the text, then the warnings, which go to standard error (docs/architecture.md#requests)
    (stdout + &stderr, x)
}

#[test]
fn the_default_slip_and_friction_scale_with_the_rig() {
    let rig = user_rig();
    // the article rig's 4e-11 at its c12 1.2e-10, in proportion to this rig's 2e-12
    let slip = 4e-11 * 2e-12 / 1.2e-10;
    assert!(
        (rig.pump_slip() - slip).abs() < 1e-12 * slip,
        "{}",
        rig.pump_slip()
    );
    assert!((rig.pump_slip() - 6.6667e-13).abs() < 1e-17);
    // the article rig's 15 N on 63 + 36 mm of seals, in proportion to 50 + 28 mm
    let friction = 15.0 * 78.0 / 99.0;
    assert!((rig.coulomb_friction() - friction).abs() < 1e-12);
    assert_eq!(rig.pump_dead_band_rpm, 60.0);
    let e = Effects::for_rig(&rig).unwrap();
    assert_eq!(
        (e.slip_m5_per_ns, e.coulomb_n),
        (rig.pump_slip(), rig.coulomb_friction())
    );
    assert!((e.dead_band_rad_s - 60.0 * std::f64::consts::PI / 30.0).abs() < 1e-12);
    // the relief: τ_rated / D1 = 64 N·m · 2π / 2.5 cm³, 1608.5 bar
    let relief_bar = rig.relief_setting_pa(rig.circuit) / 1e5;
    assert!((relief_bar - 64.0 * 2.0 * std::f64::consts::PI / 2.5e-6 / 1e5).abs() < 1e-9);
    assert!((relief_bar - 1608.495).abs() < 1e-3, "{relief_bar}");
}

#[test]
fn the_article_rig_and_records_keep_their_constants() {
    let article = Rig::default();
    assert_eq!(
        (article.pump_slip(), article.coulomb_friction()),
        (4e-11, 15.0)
    );
    let e = Effects::for_rig(&article).unwrap();
    assert_eq!(e.dead_band_rad_s, 60.0 * pumpcyl::units::RAD_S_PER_RPM);
    assert_eq!((e.slip_m5_per_ns, e.coulomb_n), (4e-11, 15.0));
    // the emulated article records: each record's effects are its rig's own, bit for bit
    let effects = article::effects().unwrap();
    assert_eq!(
        (
            effects.dead_band_rad_s,
            effects.slip_m5_per_ns,
            effects.coulomb_n
        ),
        (60.0 * pumpcyl::units::RAD_S_PER_RPM, 4e-11, 15.0)
    );
    for record in article::records().unwrap() {
        let t = &record.truth;
        assert_eq!(t.effects, t.effects.with_rig(&t.rig), "{}", record.file);
    }
}

#[test]
fn emulate_names_the_values_and_setting_them_changes_the_record() {
    let (default_text, default_x) = emulated_step("default", &[]);
    assert!(
        default_text.contains(
            "60 rpm pump dead band (default: the article rig's) with slip 6.667e-13 m^5/(N s) \
             (default: the article rig's 4e-11 x c12 / 1.2e-10) and 11.82 N Coulomb friction \
             (default: the article rig's 15 N x (d1 + d2) / 99 mm)"
        ),
        "{default_text}"
    );
    // the default is the derived value: set explicitly, the record is the same
    let (set_text, set_x) =
        emulated_step("explicit", &["pump_slip_m5_per_ns=6.666666666666667e-13"]);
    assert_eq!(set_x, default_x);
    assert!(set_text.contains("(pump_slip_m5_per_ns)"), "{set_text}");
    // the article-sized slip, 20 times this rig's c12, rests the loop farther from its
    // reference: the pump turning inside its dead band at rest leaks more (measured: 2.604 mm
    // and 3.160 mm beyond the 195 mm reference)
    let (_, article_x) = emulated_step("article-slip", &["pump_slip_m5_per_ns=4e-11"]);
    let offset = |x: &[f64]| x[0] - 195.0;
    assert!(
        (offset(&default_x) - 2.604).abs() < 0.01,
        "{}",
        default_x[0]
    );
    assert!(
        (offset(&article_x) - 3.160).abs() < 0.01,
        "{}",
        article_x[0]
    );
    // friction and dead band set: the record moves
    for (name, set) in [
        ("friction", "coulomb_friction_n=40"),
        ("band", "pump_dead_band_rpm=0"),
    ] {
        let (text, x) = emulated_step(name, &[set]);
        assert_ne!(x, default_x, "{set}");
        assert!(text.contains(set.split('=').next().unwrap()), "{text}");
    }
}

#[test]
fn bad_values_are_refused_in_one_line_naming_the_key() {
    for (key, value, rule) in [
        ("pump_slip_m5_per_ns", "-1e-12", "must be >= 0"),
        ("coulomb_friction_n", "nan", "must be a finite number"),
        ("pump_dead_band_rpm", "-5", "must be >= 0"),
        ("relief_setting_bar", "0", "must be > 0"),
        ("cylinder_rated_pressure_bar", "-1", "must be > 0"),
    ] {
        let e = user_rig()
            .with_overrides_from("--set", &[format!("{key}={value}")])
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with(&format!("--set: key `{key}` = ")) && e.ends_with(rule),
            "{e}"
        );
        assert!(!e.contains('\n'), "{e}");
        let text = format!("{USER_RIG}{key} = {value}\n");
        let e = Rig::from_toml_str(&text, "r.toml").unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("r.toml: line 13, key `{key}` = ")),
            "{e}"
        );
    }
    // the relief and the rating belong to the one-motor circuits
    let e = Rig::from_toml_str("relief_setting_bar = 100.0\n", "dpm.toml")
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("dpm.toml: line 1, key `relief_setting_bar`: the dpm circuit"),
        "{e}"
    );
}

#[test]
fn an_implausible_relief_setting_is_warned_about() {
    let (text, _) = emulated_step("relief", &[]);
    let warning = "warning: relief valves set 1608.5 bar above the accumulator (derived: \
                   motor_rated_torque_nm 64 N m over the displacement; set relief_setting_bar) \
                   let a chamber reach 1615.4 bar, above cylinder_rated_pressure_bar = 250 bar";
    assert!(text.contains(warning), "{text}");
    // a given setting within the rating, or a rating above the chamber's reach: no warning
    let (text, _) = emulated_step("relief-set", &["relief_setting_bar=200"]);
    assert!(!text.contains("warning: relief valves"), "{text}");
    let (text, _) = emulated_step("rated", &["cylinder_rated_pressure_bar=2000"]);
    assert!(!text.contains("warning: relief valves"), "{text}");
    // select names it for the single-pump candidates at their highest pre-charge (5 bar)
    let rig = user_rig_file("select.toml");
    let (ok, stdout, stderr) = pumpcyl(&[
        "select",
        "--rig",
        rig.to_str().unwrap(),
        "--circuits",
        "single-pump",
        "--mode-check",
        "equations",
        "--set",
        "precharge_bar=[5.0]",
    ]);
    assert!(ok, "{stderr}");
    // a warning goes to standard error, as every command's (docs/architecture.md#requests)
    assert!(
        stderr.contains(
            "warning: single-pump circuit: relief valves set 1608.5 bar above the accumulator"
        ) && stderr.contains("let a chamber reach 1613.5 bar"),
        "{stderr}"
    );
    assert!(!stdout.contains("warning:"), "{stdout}");
}

/// A rest whose leakage under the load needs the pump faster than `pump_max_speed_rpm` is
/// refused, naming the speed it needs, instead of emulated at that speed: the speed limit stops
/// acceleration, and a rest has none. The speed named is the one the emulator rests at without
/// its limits (every effect off), and raising the limit lets the same rig run.
#[test]
fn a_rest_beyond_the_pumps_speed_limit_is_refused_naming_the_speed_it_needs() {
    let rig = user_rig_file("speed-limit.toml");
    let out = rig.with_extension("csv");
    let run = |extra: &[&str]| {
        let mut args = step_args(&rig, &out);
        args.extend(["--duration-s", "1", "--set", "external_force_n=30000"]);
        args.extend(extra);
        pumpcyl(&args)
    };
    let (ok, _, err) = run(&["--no-effects", "--no-noise"]);
    assert!(ok, "{err}");
    let csv = std::fs::read_to_string(&out).unwrap();
    let rest_rpm: f64 = csv
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .nth(5)
        .unwrap()
        .parse()
        .unwrap();
    assert!((1000.0..3600.0).contains(&rest_rpm), "{rest_rpm}");
    std::fs::remove_file(&out).unwrap();
    let (ok, _, err) = run(&["--set", "pump_max_speed_rpm=1000"]);
    assert!(!ok && err.trim().lines().count() == 1, "{err}");
    assert!(!out.exists(), "no record is written");
    let needed: f64 = (err
        .split("pumps at ")
        .nth(1)
        .unwrap()
        .split(' ')
        .next()
        .unwrap())
    .parse()
    .unwrap();
    assert!(
        (needed / rest_rpm - 1.0).abs() < 0.01,
        "{needed} vs {rest_rpm}: {err}"
    );
    assert!(
        err.contains("beyond pump_max_speed_rpm = 1000 rpm"),
        "{err}"
    );
    let (ok, _, err) = run(&["--set", "pump_max_speed_rpm=3000"]);
    assert!(ok, "{err}");
}
