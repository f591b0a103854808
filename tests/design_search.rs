//! The worst case over the stroke, searched (docs/design.md#the-worst-case-searched): the
//! positions `pumpcyl design --json` names as the least phase and gain margins over the stroke
//! equal a dense scan of `pumpcyl margins --set x0_mm=… --json` at 0.1 mm steps at the designed
//! gain, each position's mass from the rig's `mass_by_position` table interpolated here, to
//! 0.1 mm; on the article's rig and on two rigs of our own (one with a constant mass, one with
//! a table of its own on another cylinder).

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;

use run::json;

/// Steps of the dense scan (mm).
const STEP_MM: f64 = 0.1;

/// A rig of the test: its `--set`s, the design's stroke excursion (mm), and the rig's x0 (mm),
/// mass there (kg) and mass table (x mm, kg) as the sets and the article (§3.3) give them.
struct Case {
    sets: &'static [&'static str],
    stroke_mm: f64,
    x0_mm: f64,
    mass_kg: f64,
    table: &'static [(f64, f64)],
}

const CASES: [Case; 3] = [
    Case {
        sets: &[],
        stroke_mm: 50.0,
        x0_mm: 345.0,
        mass_kg: 10593.0,
        table: &[(295.0, 9958.0), (345.0, 10593.0), (395.0, 12373.0)],
    },
    Case {
        sets: &["mass_by_position=[]", "x0_mm=250", "mass_kg=6000"],
        stroke_mm: 200.0,
        x0_mm: 250.0,
        mass_kg: 6000.0,
        table: &[],
    },
    Case {
        sets: &[
            "piston_diameter_mm=80",
            "rod_diameter_mm=45",
            "stroke_mm=600",
            "x0_mm=300",
            "mass_kg=4000",
            "mass_by_position=[{x_mm=150,mass_kg=3000},{x_mm=300,mass_kg=4000},{x_mm=450,mass_kg=6500}]",
            "viscous_friction_ns_per_m=400",
        ],
        stroke_mm: 150.0,
        x0_mm: 300.0,
        mass_kg: 4000.0,
        table: &[(150.0, 3000.0), (300.0, 4000.0), (450.0, 6500.0)],
    },
];

/// The table's mass at `x` over its mass at `x0`, times the rig's mass at x0, by linear
/// interpolation (the rig's own mass without a table).
fn mass_at(table: &[(f64, f64)], mass_kg: f64, x0: f64, x: f64) -> f64 {
    if table.is_empty() {
        return mass_kg;
    }
    let at = |x: f64| {
        let k = table.iter().position(|p| p.0 >= x).unwrap().max(1);
        let ((xa, ma), (xb, mb)) = (table[k - 1], table[k]);
        ma + (mb - ma) * (x - xa) / (xb - xa)
    };
    mass_kg * at(x) / at(x0)
}

fn set_args(sets: &[&str]) -> Vec<String> {
    sets.iter()
        .flat_map(|s| ["--set".to_string(), s.to_string()])
        .collect()
}

#[test]
fn the_searched_worst_positions_equal_a_dense_scan() {
    let here = std::path::Path::new(".");
    for case in &CASES {
        let sets = set_args(case.sets);
        let stroke = format!("{}", case.stroke_mm);
        let mut args = vec!["design", "--json", "--stroke-mm", stroke.as_str()];
        args.extend(sets.iter().map(String::as_str));
        let d = json(here, &args);
        let kp = d["kp_max"].as_f64().unwrap();
        let (table, x0, mass) = (case.table, case.x0_mm, case.mass_kg);
        let searched = |which: &str| -> f64 {
            let c = d["conditions"].as_array().unwrap().iter();
            let mut c = c.filter(|c| c["searched"] == which);
            c.next().unwrap_or_else(|| panic!("{which}: {d}"))["x_mm"]
                .as_f64()
                .unwrap()
        };
        let (lo, hi) = (x0 - case.stroke_mm, x0 + case.stroke_mm);
        let n = ((hi - lo) / STEP_MM).round() as usize;
        let (mut pm, mut gm) = ((f64::INFINITY, lo), (f64::INFINITY, lo));
        for k in 0..=n {
            let x = lo + (hi - lo) * k as f64 / n as f64;
            let mut a: Vec<String> = ["margins", "--json"].map(String::from).to_vec();
            a.extend(sets.iter().cloned());
            for s in [
                format!("x0_mm={x}"),
                format!("mass_kg={}", mass_at(table, mass, x0, x)),
                format!("kp={kp}"),
                "mass_by_position=[]".to_string(),
            ] {
                a.extend(["--set".to_string(), s]);
            }
            let m = json(here, &a.iter().map(String::as_str).collect::<Vec<_>>());
            assert!(m["closed_loop_stable"].as_bool().unwrap(), "{x}: {m}");
            let v = |k: &str| m[k].as_f64().unwrap_or(f64::INFINITY);
            if v("phase_margin_deg") < pm.0 {
                pm = (v("phase_margin_deg"), x);
            }
            if v("gain_margin_db") < gm.0 {
                gm = (v("gain_margin_db"), x);
            }
        }
        let what = format!("{:?} ± {} mm", case.sets, case.stroke_mm);
        let (x_pm, x_gm) = (searched("phase_margin"), searched("gain_margin"));
        assert!(
            (x_pm - pm.1).abs() <= STEP_MM,
            "{what}: PM searched at {x_pm}, scanned {pm:?}"
        );
        assert!(
            (x_gm - gm.1).abs() <= STEP_MM,
            "{what}: GM searched at {x_gm}, scanned {gm:?}"
        );
    }
}
