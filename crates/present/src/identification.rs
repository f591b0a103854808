//! The files of an identification (docs/identification.md): `result.json`, the cost landscape
//! over β × c12 at the best b (`landscape.csv`, `.svg`, `.png`), one fit figure per dataset
//! (`fit-K.svg`, `.png`, the article's Figure 6 layout) and `result.mat`, built in memory.

use crate::figures::{Chart, Plot, PARAMETER_AXES};
use crate::matfile::MatWriter;
use crate::plot::{HeatMap, Marker};
use crate::records::{csv_number, csv_text};
use anyhow::Result;
use pumpcyl::ident::search_bound_at;
use pumpcyl::ident::{
    candidate_values, identifiability, Candidate, DriveFit, DriveRecord, Experiment,
    Identifiability, Identification, Leakage, Problem, Scored, Standstill, Uncertainty,
};
use pumpcyl::response::Signals;
use pumpcyl::rig::Rig;
use serde_json::{json, Value};
use std::fmt::Write as _;

/// The JSON of one scored candidate: the core type's serde form (β, b, c12, cost, and the
/// `stage` and grid `index` it came from), with the leakages when given.
fn scored_json(s: &Scored, leak: Option<&Leakage>) -> Result<Value> {
    let mut v = serde_json::to_value(s)?;
    if let Some(l) = leak {
        v["c1_m5_per_ns"] = json!(l.c1_m5_per_ns);
        v["c2_m5_per_ns"] = json!(l.c2_m5_per_ns);
    }
    Ok(v)
}

/// Where the problem of an identification came from, as its document names it: the experiment
/// file (`None` for records given directly, as Python's `datasets`), the rig in words and the
/// grids in words.
#[derive(Debug, Clone)]
pub struct Origin {
    /// The experiment file, as given.
    pub experiment: Option<String>,
    /// Where the rig comes from, in words.
    pub rig: String,
    /// Where the two grids come from, in words.
    pub grids: String,
}

impl Origin {
    /// The origin of an experiment file's problem.
    pub fn of_experiment(exp: &Experiment) -> Origin {
        Origin {
            experiment: Some(exp.path.display().to_string()),
            rig: rig_origin(exp),
            grids: exp.grids_origin.clone(),
        }
    }
}

/// The JSON of an identification of an experiment file (written as result.json), `seconds`
/// the time it took (s).
pub fn identification_json(exp: &Experiment, id: &Identification, seconds: f64) -> Result<Value> {
    let origin = Origin::of_experiment(exp);
    identification_document(&exp.problem, &exp.rig, &origin, id, seconds)
}

/// An identification and where it came from: what its document is made of, whichever front
/// end ran it.
pub struct Found<'a> {
    /// The problem it solved.
    pub problem: &'a Problem,
    /// The rig its leakages are computed on.
    pub rig: &'a Rig,
    /// Where the problem came from.
    pub origin: &'a Origin,
    /// The answer.
    pub id: &'a Identification,
    /// The time it took (s).
    pub seconds: f64,
    /// Its profile-likelihood uncertainty with the seconds that took, when analysed.
    pub uncertainty: Option<&'a (Uncertainty, f64)>,
    /// The keys its rig file left out, for a rig read from a file (docs/formats.md#rig-toml).
    pub defaulted: Option<&'a [&'static str]>,
}

impl<'a> Found<'a> {
    /// The identification `id` of the experiment file `exp` (its origin `origin`, made by
    /// [`Origin::of_experiment`]), without an uncertainty analysis.
    pub fn of_experiment(
        exp: &'a Experiment,
        origin: &'a Origin,
        id: &'a Identification,
        seconds: f64,
    ) -> Found<'a> {
        Found {
            problem: &exp.problem,
            rig: &exp.rig,
            origin,
            id,
            seconds,
            uncertainty: None,
            defaulted: exp.rig_defaulted_keys(),
        }
    }
}

/// The document of an identification as `pumpcyl identify --json`, its result.json and
/// Python's `identify` give it ([`identification_document`] with the verdicts of which
/// parameters the records bound, the uncertainty when analysed and the keys the rig file left
/// out), and the verdicts, which the text report shows too. One function for every front end.
pub fn identification_report(f: &Found) -> Result<(Value, Option<[Identifiability; 3]>)> {
    let mut v = identification_document(f.problem, f.rig, f.origin, f.id, f.seconds)?;
    let verdicts = verdicts(f.problem, f.id, f.uncertainty.map(|(u, _)| u));
    if let Some(d) = &verdicts {
        add_identifiability_json(&mut v, d);
    }
    if let Some((u, seconds)) = f.uncertainty {
        crate::uncertainty::add_uncertainty_json(&mut v, u, *seconds);
    }
    let v = crate::documents::with_rig_defaulted_keys(v, f.defaulted);
    Ok((v, verdicts))
}

/// The one document of an identification, whoever asked for it (`pumpcyl identify --json`,
/// result.json, Python's `identify`): the answer with its leakages, the counts, the best grid
/// point with its leakages, each stage, the top list, where the problem came from and the
/// warnings. `seconds` is the time it took (s).
pub fn identification_document(
    problem: &Problem,
    rig: &Rig,
    origin: &Origin,
    id: &Identification,
    seconds: f64,
) -> Result<Value> {
    let best = id.best();
    let grid_leak = problem
        .standstill
        .leakage(rig, id.grid_best.candidate.c12_m5_per_ns)?;
    let mut v = scored_json(best, Some(&id.leakage))?;
    v["candidates_evaluated"] = json!(id.evaluated());
    v["seconds"] = json!(seconds);
    v["refined"] = json!(id.refined.is_some());
    v["grid_best"] = scored_json(&id.grid_best, Some(&grid_leak))?;
    v["non_finite"] = json!(id.stages.iter().map(|s| s.summary.non_finite).sum::<u64>());
    v["unstable"] = json!(id.stages.iter().map(|s| s.summary.unstable).sum::<u64>());
    v["pruned"] = json!(id.stages.iter().map(|s| s.summary.pruned).sum::<u64>());
    v["stages"] = id
        .stages
        .iter()
        .map(|s| {
            json!({
                "candidates": s.grid.len(), "evaluated": s.summary.evaluated,
                "threshold_mm2": s.summary.threshold_mm2, "threshold_count": s.summary.threshold_count,
                "threshold_bounds": s.summary.threshold_bounds.map(|b| json!({
                    "beta_bar": b[0], "viscous_friction_ns_per_m": b[1], "c12_m5_per_ns": b[2]})),
            })
        })
        .collect();
    v["top"] = id
        .top
        .iter()
        .map(|s| scored_json(s, None))
        .collect::<Result<_>>()?;
    v["experiment"] = json!(origin.experiment);
    v["rig"] = json!(origin.rig);
    v["grids"] = json!(origin.grids);
    v["stage_grids"] = id
        .stages
        .iter()
        .map(|s| {
            json!({
                "beta_bar": axis_span(&s.grid.beta_bar),
                "viscous_friction_ns_per_m": axis_span(&s.grid.viscous_friction_ns_per_m),
                "c12_m5_per_ns": axis_span(&s.grid.c12_m5_per_ns),
            })
        })
        .collect();
    v["warnings"] = json!(id.warnings());
    crate::uncertainty::add_search_bound_json(&mut v, &best.candidate);
    Ok(v)
}

/// Which parameters the records bound: from the profiles of an uncertainty analysis when one
/// ran, else by the quick check of [`identifiability`] at 95 %; `None` when the noise cannot
/// be estimated (records without noise fitted exactly).
pub fn verdicts(
    problem: &Problem,
    id: &Identification,
    uncertainty: Option<&Uncertainty>,
) -> Option<[Identifiability; 3]> {
    match uncertainty {
        Some(u) if u.profiles.len() == 3 => Some(std::array::from_fn(|i| {
            Identifiability::of_profile(&u.profiles[i], u.confidence)
        })),
        _ => identifiability(problem, &id.best().candidate, 0.95).ok(),
    }
    .map(|v| {
        let values = candidate_values(&id.best().candidate);
        v.map(|d| {
            let i = crate::figures::parameter_index(d.parameter);
            d.checked_at(values[i])
        })
    })
}

/// [lo, hi, count] of a grid axis.
fn axis_span(axis: &[f64]) -> Value {
    let (lo, hi) = axis
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
            (l.min(x), h.max(x))
        });
    json!([lo, hi, axis.len()])
}

/// Which rig the experiment uses, in words: its file, or the article's when it names none.
fn rig_origin(exp: &Experiment) -> String {
    match &exp.file.rig {
        Some(r) => r.clone(),
        None => "the article's rig (the experiment names no `rig`)".into(),
    }
}

/// Add the identifiability verdicts (`identifiable`: per parameter true/false;
/// `not_identifiable`: per parameter the reason, for those the records do not bound) to an
/// identification's JSON.
pub fn add_identifiability_json(v: &mut Value, verdicts: &[Identifiability; 3]) {
    let mut ok = serde_json::Map::new();
    let mut not = serde_json::Map::new();
    for d in verdicts {
        ok.insert(d.parameter.into(), json!(d.identifiable));
        if let Some(r) = &d.reason {
            not.insert(d.parameter.into(), json!(r));
        }
    }
    v["identifiable"] = ok.into();
    v["not_identifiable"] = not.into();
}

/// The identification cost over β × c12 at one b.
#[derive(Debug, Clone, PartialEq)]
pub struct Landscape {
    /// β values (bar).
    pub beta_bar: Vec<f64>,
    /// c12 values (m⁵/(N·s)).
    pub c12_m5_per_ns: Vec<f64>,
    /// The b they share (N·s/m).
    pub viscous_friction_ns_per_m: f64,
    /// Cost (mm²), β varying fastest; +∞ for unstable or non-finite candidates.
    pub cost_mm2: Vec<f64>,
}

impl Landscape {
    /// The cost over β × c12 at the best grid point's b, on the stage grid that holds it.
    pub fn of(exp: &Experiment, id: &Identification) -> Landscape {
        use rayon::prelude::*;
        let best = id.grid_best;
        let grid = &id.stages[(best.stage.max(1) - 1) as usize].grid;
        let b = best.candidate.viscous_friction_ns_per_m;
        let (xs, ys) = (&grid.beta_bar, &grid.c12_m5_per_ns);
        let mut cost = vec![f64::INFINITY; xs.len() * ys.len()];
        cost.par_iter_mut().enumerate().for_each(|(k, c)| {
            let cand = Candidate {
                beta_bar: xs[k % xs.len()],
                viscous_friction_ns_per_m: b,
                c12_m5_per_ns: ys[k / xs.len()],
            };
            let v = exp.problem.cost(&cand);
            *c = if v.is_finite() && exp.problem.is_stable(&cand) {
                v
            } else {
                f64::INFINITY
            };
        });
        Landscape {
            beta_bar: xs.clone(),
            c12_m5_per_ns: ys.clone(),
            viscous_friction_ns_per_m: b,
            cost_mm2: cost,
        }
    }

    /// The landscape as CSV: `beta_bar,viscous_friction_ns_per_m,c12_m5_per_ns,cost_mm2`.
    pub fn csv(&self) -> String {
        let (xs, ys, b) = (
            &self.beta_bar,
            &self.c12_m5_per_ns,
            self.viscous_friction_ns_per_m,
        );
        let mut csv = String::from("beta_bar,viscous_friction_ns_per_m,c12_m5_per_ns,cost_mm2\n");
        for (k, c) in self.cost_mm2.iter().enumerate() {
            let _ = writeln!(csv, "{},{b},{:e},{c}", xs[k % xs.len()], ys[k / xs.len()]);
        }
        csv
    }

    /// The heat map of the landscape with the best grid point `best` marked; c12 on a log axis
    /// when the grid is geometric.
    pub fn chart(&self, best: &Candidate) -> Chart {
        let ys = &self.c12_m5_per_ns;
        let map = HeatMap {
            x: self.beta_bar.clone(),
            y: ys.clone(),
            cost: self.cost_mm2.clone(),
            x_label: PARAMETER_AXES[0].into(),
            y_label: PARAMETER_AXES[2].into(),
            y_log: ys.len() > 2
                && ys[2] / ys[1] > 1.0 + 1e-9
                && (ys[2] / ys[1] - ys[1] / ys[0]).abs() < 1e-6,
            cost_label: "cost (mm²)".into(),
        };
        let marker = Marker {
            x: best.beta_bar,
            y: best.c12_m5_per_ns,
            label: "best grid point".into(),
        };
        Chart {
            title: "Identification cost landscape".into(),
            subtitle: Some(format!(
                "b = {} N·s/m (best grid point)",
                self.viscous_friction_ns_per_m
            )),
            plot: Plot::HeatMap {
                map,
                markers: vec![marker],
            },
        }
    }
}

/// A dataset's fit: its name, the measured record's signals and the identified model's.
pub struct Fit {
    /// The dataset's name.
    pub name: String,
    /// The measured (or emulated) record.
    pub measured: Signals,
    /// The identified model on the same reference.
    pub model: Signals,
}

/// result.mat: the answer (`beta_bar`, `viscous_friction_ns_per_m`, `c12_m5_per_ns`,
/// `c1_m5_per_ns`, `c2_m5_per_ns`, `cost_mm2`), the top list (`top`: one row per candidate,
/// columns β, b, c12, cost), the landscape (`landscape_beta_bar`, `landscape_c12_m5_per_ns`,
/// `landscape_cost_mm2` with one row per c12 and one column per β) and the fits
/// (`fitK_dataset`, `fitK_time_s`, `fitK_x_ref_mm`, `fitK_x_mm` measured and `fitK_sim_x_mm`
/// simulated, for dataset K).
pub fn identification_mat(id: &Identification, landscape: &Landscape, fits: &[Fit]) -> Vec<u8> {
    let best = id.best();
    let mut w = MatWriter::new("pumpcyl identification");
    w.scalar("beta_bar", best.candidate.beta_bar)
        .scalar(
            "viscous_friction_ns_per_m",
            best.candidate.viscous_friction_ns_per_m,
        )
        .scalar("c12_m5_per_ns", best.candidate.c12_m5_per_ns)
        .scalar("c1_m5_per_ns", id.leakage.c1_m5_per_ns)
        .scalar("c2_m5_per_ns", id.leakage.c2_m5_per_ns)
        .scalar("cost_mm2", best.cost_mm2);
    let top: Vec<Vec<f64>> = id
        .top
        .iter()
        .map(|s| {
            vec![
                s.candidate.beta_bar,
                s.candidate.viscous_friction_ns_per_m,
                s.candidate.c12_m5_per_ns,
                s.cost_mm2,
            ]
        })
        .collect();
    if top.is_empty() {
        w.matrix("top", 0, 4, &[]);
    } else {
        w.rows("top", &top);
    }
    w.text(
        "top_columns",
        "beta_bar,viscous_friction_ns_per_m,c12_m5_per_ns,cost_mm2",
    )
    .column("landscape_beta_bar", &landscape.beta_bar)
    .column("landscape_c12_m5_per_ns", &landscape.c12_m5_per_ns)
    .scalar(
        "landscape_viscous_friction_ns_per_m",
        landscape.viscous_friction_ns_per_m,
    );
    // one row per c12, one column per β, as surf(beta, c12, cost) and imagesc expect: element
    // (j, i) is cost[j·nβ + i], written column by column.
    let (nb, nc) = (landscape.beta_bar.len(), landscape.c12_m5_per_ns.len());
    let transposed: Vec<f64> = (0..nb)
        .flat_map(|i| (0..nc).map(move |j| (i, j)))
        .map(|(i, j)| landscape.cost_mm2[j * nb + i])
        .collect();
    w.matrix("landscape_cost_mm2", nc, nb, &transposed);
    for (k, fit) in fits.iter().enumerate() {
        w.text(&format!("fit{}_dataset", k + 1), &fit.name);
        for (col, v) in [
            ("time_s", &fit.measured.time_s),
            ("x_ref_mm", &fit.measured.x_ref_mm),
            ("x_mm", &fit.measured.x_mm),
            ("sim_x_mm", &fit.model.x_mm),
        ] {
            w.column(&format!("fit{}_{col}", k + 1), v);
        }
    }
    w.into_bytes()
}

/// The fit figure of dataset `i` (0-based): the identified model against the record, the fit
/// window's end marked.
pub fn fit_chart(exp: &Experiment, id: &Identification, i: usize, fit: &Fit) -> Chart {
    let ds = &exp.problem.datasets[i];
    let best = &id.best().candidate;
    let subtitle = format!(
        "{}: Kp {}, m {} kg, fit window to {} s; cost {:.4} mm²",
        ds.name,
        ds.rig.kp,
        ds.rig.mass_kg,
        ds.fit_end_s,
        exp.problem.dataset_mse(best, ds)
    );
    // "record", not "measured": the records may be emulated (`pumpcyl reproduce` fits the
    // emulator's), and the figure's caption says which
    Chart::signals_of(
        &format!("Identified model against {}", ds.name),
        Some(&subtitle),
        &[("model".to_string(), &fit.model)],
        Some(("record", &fit.measured)),
        Some(ds.fit_end_s),
    )
}

/// Every file of an identification's result folder, in memory: (file name, contents), with
/// `v` the JSON of [`identification_json`]. The names: result.json, landscape.csv,
/// landscape.svg, landscape.png, fit-K.svg and fit-K.png for dataset K, result.mat.
pub fn files(exp: &Experiment, id: &Identification, v: &Value) -> Result<Vec<(String, Vec<u8>)>> {
    let mut out = vec![(
        "result.json".to_string(),
        (serde_json::to_string_pretty(v)? + "\n").into_bytes(),
    )];
    let landscape = Landscape::of(exp, id);
    let chart = landscape.chart(&id.grid_best.candidate);
    out.push(("landscape.csv".into(), landscape.csv().into_bytes()));
    out.push(("landscape.svg".into(), chart.svg()?.into_bytes()));
    out.push(("landscape.png".into(), chart.png()?));
    let mut fits = Vec::new();
    for (i, ds) in exp.problem.datasets.iter().enumerate() {
        let fit = Fit {
            name: ds.name.clone(),
            measured: Signals::of_record(&ds.record),
            model: exp.problem.simulate(&id.best().candidate, ds)?,
        };
        let chart = fit_chart(exp, id, i, &fit);
        out.push((format!("fit-{}.svg", i + 1), chart.svg()?.into_bytes()));
        out.push((format!("fit-{}.png", i + 1), chart.png()?));
        fits.push(fit);
    }
    out.push((
        "result.mat".into(),
        identification_mat(id, &landscape, &fits),
    ));
    Ok(out)
}

/// The text of an identification: the run's size and time (`seconds`), the rig and grids it
/// used, the best grid point, the refined point, the leakages, each stage's threshold set, the
/// warnings and the top candidates. A parameter `verdicts` finds not identifiable shows as
/// such instead of its value in the answer's lines.
pub fn identification_text(
    exp: &Experiment,
    id: &Identification,
    seconds: f64,
    verdicts: Option<&[Identifiability; 3]>,
) -> String {
    let mut s = String::new();
    let sizes: Vec<String> = id
        .stages
        .iter()
        .map(|st| st.grid.len().to_string())
        .collect();
    let (nf, us): (u64, u64) = id.stages.iter().fold((0, 0), |(a, b), st| {
        (a + st.summary.non_finite, b + st.summary.unstable)
    });
    let _ = writeln!(
        s,
        "{}: {} datasets, {} candidates ({}) in {seconds:.3} s; {nf} non-finite, {us} rejected as unstable",
        exp.path.display(),
        exp.problem.datasets.len(),
        id.evaluated(),
        sizes.join(" + ")
    );
    let _ = writeln!(s, "  rig              {}", rig_origin(exp));
    let _ = writeln!(s, "  grids            {}", exp.grids_origin);
    let hidden: [bool; 3] = std::array::from_fn(|i| verdicts.is_some_and(|v| !v[i].identifiable));
    s.push_str(&scored_line("best grid point", &id.grid_best, hidden));
    match &id.refined {
        Some(r) => s.push_str(&scored_line("refined (N-M)", r, hidden)),
        None => s.push_str("  refined (N-M)    off, or no improvement on the grid\n"),
    }
    for d in verdicts.into_iter().flatten() {
        if let Some(r) = &d.reason {
            let _ = writeln!(
                s,
                "  {}: not identifiable from these records ({r})",
                short_name(d.parameter)
            );
        }
    }
    let _ = writeln!(
        s,
        "  leakages         c1 {:.4e}, c2 {:.4e} m⁵/(N·s) (standstill p2 = {:.3} bar)",
        id.leakage.c1_m5_per_ns, id.leakage.c2_m5_per_ns, id.leakage.p2_bar
    );
    for (i, st) in id.stages.iter().enumerate() {
        let bounds = st.summary.threshold_bounds.map_or("-".to_string(), |b| {
            format!(
                "beta {:.0}..{:.0} bar, b {:.0}..{:.0} N·s/m, c12 {:.2e}..{:.2e}",
                b[0][0], b[0][1], b[1][0], b[1][1], b[2][0], b[2][1]
            )
        });
        let _ = writeln!(
            s,
            "  stage {} threshold set (cost < {} mm²): {} candidates; {bounds}",
            i + 1,
            st.summary.threshold_mm2,
            st.summary.threshold_count
        );
    }
    for w in id.warnings() {
        let _ = writeln!(s, "  warning: {w}");
    }
    let _ = writeln!(s, "top {}:", id.top.len());
    for (k, c) in id.top.iter().enumerate() {
        s.push_str(&scored_line(&format!("{:>2}", k + 1), c, [false; 3]));
    }
    s
}

/// The short name of a parameter in text: beta, b, c12.
pub(crate) fn short_name(parameter: &str) -> &'static str {
    match parameter {
        "beta_bar" => "beta",
        "viscous_friction_ns_per_m" => "b",
        _ => "c12",
    }
}

/// One candidate and its cost as a text line; a `hidden` parameter (not identifiable) shows
/// as `n/a` instead of its value.
fn scored_line(label: &str, c: &Scored, hidden: [bool; 3]) -> String {
    let values = candidate_values(&c.candidate);
    let show = |i: usize, text: String| {
        if hidden[i] && search_bound_at(i, values[i]).is_none() {
            format!("{:>8} {}", "n/a", crate::figures::PARAMETER_UNITS[i])
        } else {
            crate::uncertainty::estimate_text(i, values[i], text)
        }
    };
    format!(
        "  {label:<16} beta {}  b {}  c12 {}  cost {:.5} mm²\n",
        show(0, format!("{:>8.2} bar", c.candidate.beta_bar)),
        show(
            1,
            format!("{:>8.1} N·s/m", c.candidate.viscous_friction_ns_per_m)
        ),
        show(2, format!("{:.4e} m⁵/(N·s)", c.candidate.c12_m5_per_ns)),
        c.cost_mm2
    )
}

/// The standstill leakages (the article §2.4) as text: the standstill `s` and its leakages `l`.
pub fn leakage_text(s: &Standstill, l: &Leakage) -> String {
    format!(
        "standstill (the article §2.4): w1 {:.1} rpm, w2 {:.1} rpm, p1 {:.3} bar\n  p2 (force balance)  {:.3} bar\n  \
         c12                 {:.4e} m⁵/(N·s)\n  c1                  {:.4e} m⁵/(N·s)\n  c2                  {:.4e} m⁵/(N·s)\n",
        s.w1_rpm, s.w2_rpm, s.p1_bar, l.p2_bar, l.c12_m5_per_ns, l.c1_m5_per_ns, l.c2_m5_per_ns
    )
}

/// The drive's identified damping as JSON: the record's name, the motor (1 or 2), Km
/// (N·m·s/rad), the fit's MSE (rpm²) and the rotor inertia used (kg·m²).
pub fn drive_json(rec: &DriveRecord, motor: u8, fit: &DriveFit, inertia_kg_m2: f64) -> Value {
    json!({
        "file": rec.file, "motor": motor, "km_nms_per_rad": fit.km_nms_per_rad,
        "mse_rpm2": fit.mse_rpm2, "rotor_inertia_kg_m2": inertia_kg_m2,
    })
}

/// The drive's identified damping as text, with the rotor inertia (kg·m²) and the current
/// loop's bandwidth (rad/s) it was fitted with.
pub fn drive_text(
    rec: &DriveRecord,
    motor: u8,
    fit: &DriveFit,
    inertia_kg_m2: f64,
    current_loop_rad_per_s: f64,
) -> String {
    format!(
        "{}: motor {} (Jm = {:.3e} kg·m², current loop {} rad/s, feedforward off)\n  Km  {:.5} N·m·s/rad\n  fit MSE {:.3} rpm² (RMS {:.2} rpm)\n",
        rec.file,
        motor,
        inertia_kg_m2,
        current_loop_rad_per_s,
        fit.km_nms_per_rad,
        fit.mse_rpm2,
        fit.mse_rpm2.sqrt()
    )
}

/// The drive step record beside the fitted model as CSV: time (s), speed reference, measured
/// and simulated speed (rpm), in the records' number format ([`csv_number`]).
pub fn drive_csv(rec: &DriveRecord, fit: &DriveFit) -> String {
    let header = ["time_s", "w_ref_rpm", "w_rpm", "w_sim_rpm"].map(String::from);
    let rows = (0..rec.time_s.len()).map(|k| {
        [
            rec.time_s[k],
            rec.w_ref_rpm[k],
            rec.w_rpm[k],
            fit.w_sim_rpm[k],
        ]
        .map(csv_number)
    });
    csv_text(&header, rows)
}
