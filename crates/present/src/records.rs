//! Records as files (docs/formats.md#record-csv): the one CSV writer of the presentation layer
//! and its one number format, a closed-loop record and a drive record as CSV, and the emulated
//! article records' folder (its records, README and identify experiment; docs/emulator.md#the-emulated-article-records).

use pumpcyl::emulator::article::{
    fit_window_s, ArticleRecord, Emulated, BETA_FIT_BAR, BETA_ROBUSTNESS_BAR, FIT_WINDOW_KP20_S,
    FIT_WINDOW_KP25_S, K_PRES_HEAVY_PER_BAR, K_PRES_LIGHT_PER_BAR, P_FIT_BAR, STEP_AT_S,
};
use pumpcyl::emulator::{DriveSignals, Effects};
use pumpcyl::response::Signals;
use pumpcyl::rig::Rig;

/// A number as every CSV file shows it: six decimals (the records' resolution: 1 µm in mm,
/// 0.1 Pa in bar, 0.001 rpm).
pub fn csv_number(v: f64) -> String {
    format!("{v:.6}")
}

/// CSV text: a header row, then the rows, written by the `csv` crate (a cell holding a comma, a
/// quote or a line break is quoted, so a label is written as given), lines ended by `\n`.
pub fn csv_text<R, C>(header: &[C], rows: impl IntoIterator<Item = R>) -> String
where
    R: IntoIterator<Item = C>,
    C: AsRef<[u8]>,
{
    let mut w = csv::WriterBuilder::new()
        .flexible(false)
        .from_writer(Vec::new());
    // writing to memory cannot fail, and every row has the header's length (the callers build
    // them so): an error here is a bug in this crate
    w.write_record(header).expect("CSV into memory");
    for row in rows {
        w.write_record(row)
            .expect("CSV rows of the header's length");
    }
    let bytes = w.into_inner().expect("CSV into memory");
    String::from_utf8(bytes).expect("CSV of UTF-8 cells")
}

/// A power column's number (docs/formats.md#power-columns): every digit the value holds (the
/// shortest text that reads back as the same number), so the columns sum to the run's
/// energies as exactly as they were integrated.
pub fn csv_exact(v: f64) -> String {
    format!("{v:e}")
}

/// Signals as a record (docs/formats.md#record-csv): CSV with a header row and the columns of
/// [`Signals::record_columns`], the power columns at full precision ([`csv_exact`]).
pub fn record_csv(s: &Signals) -> String {
    let columns = s.record_columns();
    let names: Vec<String> = columns.iter().map(|(c, _)| (*c).to_string()).collect();
    let exact: Vec<bool> = (columns.iter())
        .map(|(c, _)| s.power_w.iter().any(|(p, _)| p == c))
        .collect();
    let rows = (0..s.time_s.len()).map(|k| {
        (columns.iter().zip(&exact)).map(move |((_, v), &exact)| match exact {
            true => csv_exact(v[k]),
            false => csv_number(v[k]),
        })
    });
    csv_text(&names, rows)
}

/// A drive record (docs/formats.md#drive-record-csv): `time_s`, `w_ref_rpm`, `w_rpm`.
pub fn drive_record_csv(d: &DriveSignals) -> String {
    let rows =
        (0..d.time_s.len()).map(|k| [d.time_s[k], d.w_ref_rpm[k], d.w_rpm[k]].map(csv_number));
    csv_text(&["time_s", "w_ref_rpm", "w_rpm"].map(String::from), rows)
}

/// An emulated record as CSV: a closed-loop record or a drive record.
pub fn emulated_csv(e: &Emulated) -> String {
    match e {
        Emulated::Loop(s) => record_csv(s),
        Emulated::Drive(d) => drive_record_csv(d),
    }
}

/// The README of the records folder: what is emulated, with which truth, and how to remake it.
pub fn article_readme(records: &[ArticleRecord]) -> String {
    use std::fmt::Write;
    let mut s = String::from(
        "# Emulated stand-ins for the article's records\n\n\
         **These records are emulated, not measured.** The measurements of Gøytil, Hansen & \
         Tvilde (Actuators 2025, 14(8), 366) are not public. pumpcyl's nonlinear rig emulator \
         (`src/emulator`) made these files from the known truth below, so that `pumpcyl \
         reproduce` has realistic data to run the article's method on, and the tests can check \
         that the identification recovers that truth.\n\n\
         Regenerate them (deterministic: the noise is seeded):\n\n    \
         cargo run --release -- emulate --article-records data/article\n\n\
         ## Records\n\n\
         | file | what | Kp (1/m) | m (kg) | K_pres (1/bar) | p_sum_ref (bar) | beta_e at the mean pressure (bar) | seed |\n\
         |---|---|---|---|---|---|---|---|\n",
    );
    for r in records {
        let rig = &r.truth.rig;
        let _ = writeln!(
            s,
            "| `{}` | {} | {} | {} | {} | {:.3} | {:.1} | {} |",
            r.file,
            r.what,
            rig.kp,
            rig.mass_kg,
            rig.k_pres_per_bar,
            rig.p_sum_ref_bar,
            rig.beta_bar,
            r.truth.plc.seed
        );
    }
    let e = records
        .first()
        .map(|r| r.truth.effects)
        .unwrap_or_else(Effects::none);
    let rig = Rig::default();
    let _ = write!(
        s,
        "\n## The truth\n\n\
         The default rig (the article's Section 2.3.4; `pumpcyl rig --print-default`): c12 = {c12:.2e}, c1 = {c1:.3e}, \
         c2 = {c2:.3e} m⁵/(N·s), b = {b} N·s/m, Km = {km} N·m·s/rad, with these emulator effects:\n\n\
         - chamber volumes following the piston; the effective mass against stroke \
         (9958 kg at -50 mm, 12 373 kg at +50 mm, scaled to the record's mass: the article §2.1);\n\
         - the bulk modulus of both chambers from their mean pressure (p1 + p2)/2 by the constant gas-fraction model \
         of the article, X = {x:.5} (beta_e = {bf} bar at {pf} bar, beta_oil = {oil} bar); \
         the robustness record has more undissolved air, X = {xr:.5} (beta_e = {br} bar at {pf} bar, \
         as after a long shutdown); the table above gives beta_e at each record's mean chamber \
         pressure, the value identification should find;\n\
         - cavitation at -1 bar gauge; motor torque limited to {tq}x the rated {rated} N m; pump speed \
         limit {pmax} rpm;\n\
         - pump low-speed behaviour: below {db:.0} rpm a pump's flow fades out and a slip leakage of \
         up to {slip:.1e} m⁵/(N·s) across its ports sets in;\n\
         - Coulomb friction {fc} N on the piston;\n\
         - the PLC at 100 Hz (the drive step: the drive's own scope at 1 kHz), commands held between \
         samples, position noise 5 um (1 um resolution), pressure noise 0.01 bar, speed noise 1 rpm.\n\n\
         The PLC's sum-pressure gain is the default rig's {kh} per bar ({kl} below 10 t), the \
         article's 22 (15) read as percent of full command per bar, so every record replays on the \
         default rig with its own Kp and mass:\n\n    \
         cargo run --release -- simulate --experiment data/article/identify.toml --dataset 1\n\n\
         `identify.toml` runs the article's identification (Section 2.4) on `identification.csv` \
         and `validation.csv`, with c1 and c2 from `standstill.csv`, fitting up to {w25} s after the \
         step for Kp = 25 and {w20} s for Kp = 20 (the article's Section 2.4 and Figure 6; the pumps' \
         low-speed dead band takes over after that):\n\n    \
         cargo run --release -- identify data/article/identify.toml\n",
        c12 = rig.c12_m5_per_ns,
        c1 = rig.c1_m5_per_ns,
        c2 = rig.c2_m5_per_ns,
        b = rig.viscous_friction_ns_per_m,
        km = rig.km1_nms_per_rad,
        x = e.gas_fraction.unwrap_or(0.0),
        xr = records
            .iter()
            .find(|r| r.file == "robustness.csv")
            .and_then(|r| r.truth.effects.gas_fraction)
            .unwrap_or(f64::NAN),
        br = BETA_ROBUSTNESS_BAR,
        w25 = FIT_WINDOW_KP25_S,
        w20 = FIT_WINDOW_KP20_S,
        bf = BETA_FIT_BAR,
        pf = P_FIT_BAR,
        oil = e.beta_oil_bar,
        tq = e.peak_torque_factor.unwrap_or(f64::INFINITY),
        rated = rig.motor_rated_torque_nm,
        pmax = rig.pump_max_speed_rpm,
        db = e.dead_band_rad_s / pumpcyl::units::RAD_S_PER_RPM,
        slip = e.slip_m5_per_ns,
        fc = e.coulomb_n,
        kh = K_PRES_HEAVY_PER_BAR,
        kl = K_PRES_LIGHT_PER_BAR,
    );
    s
}

/// The `identify` experiment for the emulated identification and validation records.
pub fn article_identify_experiment() -> String {
    let end = |kp: f64| STEP_AT_S + fit_window_s(kp);
    format!(
        "# The article's identification (Section 2.4) on the emulated records of this folder\n\
         # (README.md). Made by `pumpcyl emulate --article-records`. The records were made with\n\
         # the default rig's sum-pressure gain, so no [set] is needed.\n\n\
         # The article's two grids (3264 + 3553 candidates, the article's §2.4); without this line the first\n\
         # grid would be centred on the rig's values and the second on the first stage's best.\n\
         grids = \"article\"\n\n\
         [standstill]\n\
         record = \"standstill.csv\"   # c1, c2 from its mean speeds and pressure (Section 2.4)\n\n\
         [[dataset]]\n\
         file = \"identification.csv\"\n\
         kp = 25.0\n\
         mass_kg = 10593.0\n\
         fit_end_s = {e25}   # {at} s at rest + {w25} s after the step (the article's Figure 6)\n\n\
         [[dataset]]\n\
         file = \"validation.csv\"\n\
         kp = 20.0\n\
         mass_kg = 10593.0\n\
         fit_end_s = {e20}   # {at} s at rest + {w20} s after the step (the article's Section 2.4)\n",
        at = STEP_AT_S,
        w25 = FIT_WINDOW_KP25_S,
        w20 = FIT_WINDOW_KP20_S,
        e25 = end(25.0),
        e20 = end(20.0),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use pumpcyl::emulator::article;

    fn shipped(file: &str) -> String {
        let path = format!("{}/../../data/article/{file}", env!("CARGO_MANIFEST_DIR"));
        std::fs::read_to_string(path).unwrap()
    }

    #[test]
    fn the_records_readme_and_experiment_match_the_truth_in_the_code() {
        // data/article/ is regenerated by `pumpcyl emulate --article-records`; its README states
        // the truth, so it must say what the code does
        let records = article::records().unwrap();
        assert_eq!(shipped("README.md"), article_readme(&records));
        assert_eq!(shipped("identify.toml"), article_identify_experiment());
    }

    #[test]
    fn a_record_has_its_columns_and_six_decimals() {
        let s = Signals {
            time_s: vec![0.0, 0.01],
            x_ref_mm: vec![1.0, 1.0],
            x_mm: vec![0.5, -1.0 / 3.0],
            e_mm: vec![0.5, 4.0 / 3.0],
            p1_bar: vec![4.4, 4.5],
            p2_bar: vec![4.0, 4.1],
            w1_rpm: vec![-2.0e-7, 1500.0],
            ..Signals::default()
        };
        assert_eq!(
            record_csv(&s),
            "time_s,x_ref_mm,x_mm,p1_bar,p2_bar,w1_rpm\n\
             0.000000,1.000000,0.500000,4.400000,4.000000,-0.000000\n\
             0.010000,1.000000,-0.333333,4.500000,4.100000,1500.000000\n"
        );
        let d = DriveSignals {
            time_s: vec![0.0],
            w_ref_rpm: vec![100.0],
            w_rpm: vec![99.1234567],
        };
        assert_eq!(
            drive_record_csv(&d),
            "time_s,w_ref_rpm,w_rpm\n0.000000,100.000000,99.123457\n"
        );
    }

    #[test]
    fn a_cell_with_a_comma_or_a_quote_is_quoted() {
        let text = csv_text(&["a", "b[kp=30,beta_bar=50]"], [["1", "say \"hi\""]]);
        assert_eq!(text, "a,\"b[kp=30,beta_bar=50]\"\n1,\"say \"\"hi\"\"\"\n");
        let read: Vec<Vec<String>> = csv::Reader::from_reader(text.as_bytes())
            .records()
            .map(|r| r.unwrap().iter().map(String::from).collect())
            .collect();
        assert_eq!(read, [["1", "say \"hi\""]]);
    }
}
