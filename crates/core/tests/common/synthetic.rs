//! Identification problems built from records simulated by the LTI model of the default rig
//! with known β, b, c12 and seeded Gaussian position noise: the article's 5 mm step
//! (340 → 345 mm at t = 0.5 s) with Kp = 25 (fit window 2.2 s after the step) and Kp = 20
//! (1.9 s), m = 10 593 kg (docs/identification.md, "The fit windows").
// shared by several test and bench binaries, each using a part of it
#![allow(dead_code)]

use pumpcyl::ident::{Candidate, DatasetSpec, Prepared, Problem, Standstill};
use pumpcyl::record::Record;
use pumpcyl::response::{simulate, Baseline};
use pumpcyl::rig::Rig;

/// Seeded Gaussian noise (xorshift + Box–Muller), no external crates.
pub struct Noise(u64);

impl Noise {
    /// A generator whose state is the seed scrambled by SplitMix64, so that small or similar
    /// seeds give unrelated sequences from the first draw on.
    pub fn new(seed: u64) -> Noise {
        let mut z = seed.wrapping_add(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        Noise((z ^ (z >> 31)).max(1))
    }

    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    /// A standard normal draw.
    pub fn gauss(&mut self) -> f64 {
        let (u1, u2) = (self.uniform().max(1e-300), self.uniform());
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

/// The article's standstill point.
pub const STANDSTILL: Standstill = Standstill {
    w1_rpm: -160.0,
    w2_rpm: 245.0,
    p1_bar: 3.95,
};

/// The article's truth: β = 165 bar, b = 100 N·s/m, c12 = 1.2·10⁻¹⁰ m⁵/(N·s).
pub const TRUTH: Candidate = Candidate {
    beta_bar: 165.0,
    viscous_friction_ns_per_m: 100.0,
    c12_m5_per_ns: 1.2e-10,
};

/// The (Kp, fit window end in s) of the article's identification and validation sets.
pub const DATASETS: [(f64, f64); 2] = [(25.0, 2.7), (20.0, 2.4)];

/// The default rig at gain `kp` with `truth`'s β, b, c12 and the c1, c2 that hold the
/// article's standstill point with that c12.
pub fn truth_rig(truth: &Candidate, kp: f64) -> Rig {
    let base = Rig {
        kp,
        ..Rig::default()
    };
    let l = STANDSTILL.leakage(&base, truth.c12_m5_per_ns).unwrap();
    Rig {
        beta_bar: truth.beta_bar,
        viscous_friction_ns_per_m: truth.viscous_friction_ns_per_m,
        c12_m5_per_ns: truth.c12_m5_per_ns,
        c1_m5_per_ns: l.c1_m5_per_ns,
        c2_m5_per_ns: l.c2_m5_per_ns,
        ..base
    }
}

/// A record of `samples` samples at 100 Hz of the step simulated with `truth` and gain `kp`,
/// noise σ = `noise_mm`.
pub fn record(
    truth: &Candidate,
    kp: f64,
    noise_mm: f64,
    noise: &mut Noise,
    samples: usize,
) -> Record {
    let rig = truth_rig(truth, kp);
    let time_s: Vec<f64> = (0..samples).map(|k| k as f64 * 0.01).collect();
    let x_ref_mm: Vec<f64> = time_s
        .iter()
        .map(|&t| if t < 0.5 { 340.0 } else { 345.0 })
        .collect();
    let mut b = Baseline::of_rig(&rig);
    b.x_ref_mm = 340.0;
    b.x_mm = 340.0;
    let s = simulate(&rig, &time_s, &x_ref_mm, &b).unwrap();
    let x_mm = s
        .x_mm
        .iter()
        .map(|x| x + noise_mm * noise.gauss())
        .collect();
    Record {
        file: format!("simulated-kp{kp}.csv"),
        time_s,
        x_ref_mm,
        x_mm,
        ..Record::default()
    }
}

/// The problem of the first `count` datasets of [`DATASETS`], simulated with `truth` and
/// fresh noise of σ = `noise_mm` from `seed`.
pub fn problem(truth: &Candidate, noise_mm: f64, seed: u64, count: usize) -> Problem {
    let mut noise = Noise::new(seed);
    let datasets = DATASETS[..count]
        .iter()
        .map(|&(kp, fit_end_s)| {
            let spec = DatasetSpec {
                file: format!("simulated-kp{kp}.csv"),
                kp,
                mass_kg: 10593.0,
                fit_end_s,
            };
            Prepared::new(
                &spec,
                record(truth, kp, noise_mm, &mut noise, 301),
                &Rig::default(),
            )
            .unwrap()
        })
        .collect();
    Problem {
        datasets,
        standstill: STANDSTILL,
    }
}

/// A record as CSV (`time_s,x_ref_mm,x_mm`).
pub fn csv(rec: &Record) -> String {
    let mut s = String::from("time_s,x_ref_mm,x_mm\n");
    for k in 0..rec.len() {
        s += &format!(
            "{:.2},{},{:.6}\n",
            rec.time_s[k], rec.x_ref_mm[k], rec.x_mm[k]
        );
    }
    s
}

/// Write the simulated records and an experiment with small grids; returns its path.
pub fn experiment_file(dir: &std::path::Path, noise_mm: f64) -> String {
    let mut noise = Noise::new(21);
    let mut text = String::from(
        "[standstill]\nw1_rpm = -160.0\nw2_rpm = 245.0\np1_bar = 3.95\n\
         [grid]\nbeta_bar = [120.0, 200.0]\nviscous_friction_ns_per_m = [50.0, 300.0]\n\
         c12_m5_per_ns = [0.8e-10, 1.6e-10]\n\
         [refined_grid]\nbeta_bar = [150.0, 180.0]\nviscous_friction_ns_per_m = [150.0]\n\
         c12_m5_per_ns = [1.0e-10, 1.4e-10]\n",
    );
    for (kp, fit_end_s) in DATASETS {
        let rec = record(&TRUTH, kp, noise_mm, &mut noise, 301);
        let name = format!("kp{kp}.csv");
        std::fs::write(dir.join(&name), csv(&rec)).unwrap();
        text += &format!(
            "[[dataset]]\nfile = \"{name}\"\nkp = {kp}\nmass_kg = 10593.0\nfit_end_s = {fit_end_s}\n"
        );
    }
    let path = dir.join("exp.toml");
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}
