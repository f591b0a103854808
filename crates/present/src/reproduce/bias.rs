//! Why the identification of the emulated records misses the emulator's truth although the
//! truth is a point of the article's refined grid (§2.4.4): the same records emulated again
//! with the emulator's effects switched off, then each effect alone, each set identified on
//! the refined grid as the article does (no local refinement). The effect whose records move
//! the grid optimum is the one that biases the identification (docs/emulator.md#the-dynamics).

use super::{summary, Run};
use anyhow::{anyhow, Result};
use pumpcyl::emulator::article::{self, ArticleRecord, Emulated};
use pumpcyl::emulator::{Effects, Plc};
use pumpcyl::ident::{Candidate, Grid, Options, Prepared, Problem, Request};
use pumpcyl::record::Record;
use rayon::prelude::*;

/// The records the identification fits (the article §2.4.4): identification and validation.
const FITTED: [&str; 2] = ["identification.csv", "validation.csv"];

/// One way of emulating the records: its name and what it changes from no effect and ideal
/// sensors at the PLC's rate.
struct Variant {
    name: &'static str,
    set: fn(&mut Effects, &mut Plc, &Effects, &Plc),
}

/// The variants: no effect with the PLC ten times faster (the LTI model's own response, up to
/// the sampling), no effect at the PLC's 100 Hz, the Coulomb friction alone, every effect but
/// the Coulomb friction. The embedded records (every effect) are the identification's own.
const VARIANTS: [Variant; 4] = [
    Variant {
        name: "no effect, ideal sensors, PLC at 1 kHz (recorded at 100 Hz)",
        set: |_, p, _, _| p.rate_hz = 1000.0,
    },
    Variant {
        name: "no effect, ideal sensors, PLC at 100 Hz",
        set: |_, _, _, _| {},
    },
    Variant {
        name: "only the 15 N Coulomb friction (PLC at 100 Hz)",
        set: |e, _, all, _| e.coulomb_n = all.coulomb_n,
    },
    Variant {
        name: "every effect but the Coulomb friction (PLC at 100 Hz, sensor noise)",
        set: |e, p, all_e, all_p| {
            *e = Effects {
                coulomb_n: 0.0,
                ..*all_e
            };
            *p = *all_p;
        },
    },
];

/// The emulated fitted records of `variant`, each as the CSV a user would read.
fn emulate(records: &[ArticleRecord], variant: &Variant) -> Result<Vec<Record>> {
    FITTED
        .iter()
        .map(|file| {
            let r = records
                .iter()
                .find(|r| r.file == *file)
                .ok_or_else(|| anyhow!("no embedded record {file}"))?;
            let mut truth = r.truth.clone();
            let (all_e, all_p) = (truth.effects, truth.plc);
            truth.effects = Effects::none();
            truth.plc = Plc {
                seed: all_p.seed,
                ..Plc::ideal(all_p.rate_hz)
            };
            (variant.set)(&mut truth.effects, &mut truth.plc, &all_e, &all_p);
            let s = match r.kind.run(&truth)? {
                Emulated::Loop(s) => s,
                Emulated::Drive(_) => return Err(anyhow!("{file} is not a loop record")),
            };
            // recorded at the embedded record's rate whatever the PLC's, as a faster PLC's
            // scope would keep every k-th sample
            let k = (truth.plc.rate_hz / all_p.rate_hz).round().max(1.0) as usize;
            let every: Vec<usize> = (0..s.time_s.len()).step_by(k).collect();
            let csv = crate::records::record_csv(&s.samples(&every));
            Ok(Record::parse(csv.as_bytes(), file)?)
        })
        .collect()
}

/// The refined grid's best point (the article's method, no local refinement) on the records of
/// `variant`, with the experiment's datasets and standstill point.
fn grid_best(problem: &Problem, records: Vec<Record>) -> Result<(Candidate, f64)> {
    let datasets = problem
        .datasets
        .iter()
        .zip(records)
        .map(|(ds, rec)| {
            let spec = pumpcyl::ident::DatasetSpec {
                file: ds.name.clone(),
                kp: ds.rig.kp,
                mass_kg: ds.rig.mass_kg,
                fit_end_s: ds.fit_end_s,
            };
            Prepared::new(&spec, rec, &ds.rig)
        })
        .collect::<Result<Vec<_>, _>>()?;
    let problem = Problem {
        datasets,
        standstill: problem.standstill,
    };
    let opts = Options {
        auto_refine: false,
        local_refinement: false,
        threshold_mm2: 0.25,
        top_n: 1,
    };
    let id = Request::new(&problem, (Grid::article_refined(), None), opts).run(&|_| true)?;
    let best = id.best();
    Ok((best.candidate, best.cost_mm2))
}

/// The study: the refined grid's optimum on the fitted records emulated with each variant,
/// beside `embedded`, the optimum (and its cost) on the embedded records; `problem` is the
/// identification's (its datasets in the order of [`FITTED`]), `truth` the emulator's. Returns
/// the cases and one line naming the variants that land where the embedded records do.
pub(super) fn bias(
    run: &mut Run,
    problem: &Problem,
    embedded: (Candidate, f64),
    truth: &Candidate,
) -> Result<(Vec<summary::BiasCase>, String)> {
    let records = article::records()?;
    let names: Vec<&str> = problem.datasets.iter().map(|d| d.name.as_str()).collect();
    if names != FITTED {
        return Err(anyhow!("the identification fits {names:?}, not {FITTED:?}"));
    }
    let case = |records: &str, (c, cost): (Candidate, f64)| summary::BiasCase {
        records: records.to_string(),
        beta_bar: c.beta_bar,
        viscous_friction_ns_per_m: c.viscous_friction_ns_per_m,
        c12_m5_per_ns: c.c12_m5_per_ns,
        cost_mm2: cost,
    };
    let mut cases = VARIANTS
        .par_iter()
        .map(|v| Ok(case(v.name, grid_best(problem, emulate(&records, v)?)?)))
        .collect::<Result<Vec<_>>>()?;
    cases.push(case("every effect (the embedded records)", embedded));
    let point = |c: &summary::BiasCase| {
        format!(
            "β {:.0} bar, b {:.0} N·s/m, c12 {:.2e}",
            c.beta_bar, c.viscous_friction_ns_per_m, c.c12_m5_per_ns
        )
    };
    let same = |c: &summary::BiasCase, d: &summary::BiasCase| point(c) == point(d);
    let (last, variants) = cases.split_last().ok_or_else(|| anyhow!("no case"))?;
    let movers: Vec<&str> = variants
        .iter()
        .filter(|c| same(c, last))
        .map(|c| c.records.as_str())
        .collect();
    let why = format!(
        "the truth ({}) is a grid point, yet the grid lands on {}; records emulated again land there with {}",
        point(&case("", (*truth, 0.0))),
        point(last),
        if movers.is_empty() {
            "none of the variants below".to_string()
        } else {
            movers.join("; ")
        }
    );
    let rows = cases
        .iter()
        .map(|c| {
            vec![
                c.records.clone(),
                format!("{:.0}", c.beta_bar),
                format!("{:.0}", c.viscous_friction_ns_per_m),
                format!("{:.2e}", c.c12_m5_per_ns),
                format!("{:.4}", c.cost_mm2),
            ]
        })
        .collect();
    run.table(
        &format!(
            "Why the grid misses the truth ({}, itself a point of the refined grid): the refined grid's best point, as the article takes it, on the two fitted records emulated again with the emulator's effects switched off, then some of them on",
            point(&case("", (*truth, 0.0)))
        ),
        &["records emulated with", "β (bar)", "b (N·s/m)", "c12 (m⁵/(N·s))", "cost (mm²)"],
        rows,
    );
    Ok((cases, why))
}
