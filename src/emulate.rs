//! `pumpcyl emulate`: records from the nonlinear rig emulator (docs/emulator.md).

use crate::emit::{show, write_atomic};
use crate::RigSource;
use anyhow::{anyhow, Result};
use clap::Args;
use pumpcyl::emulator::article::{self, Emulated};
use pumpcyl::fmu::ModelKind;
use pumpcyl::rig::Rig;
use pumpcyl_present::emulated::{self, ExperimentKind};
use pumpcyl_present::records;
use pumpcyl_present::request::emulate::Emulate;
use pumpcyl_present::request::{FieldError, Request, RigInput};
use rayon::prelude::*;
use std::fmt::Write;
use std::path::{Path, PathBuf};

#[derive(Debug, Args)]
pub struct EmulateArgs {
    /// What the emulated rig does.
    #[arg(long, value_parser = experiment_parser(), required_unless_present = "article_records")]
    experiment: Option<ExperimentKind>,
    /// Write every embedded article record, its README and an identify experiment into DIR
    /// (how data/article/ is made).
    #[arg(long, value_name = "DIR", conflicts_with_all = ["experiment", "out", "rig", "set"])]
    article_records: Option<PathBuf>,
    /// Rig (TOML). Default: the emulated article rig (the article §2.1 with the PLC's sum-pressure gain
    /// 0.22 per bar and the set-point for 4.4 bar mean pressure; see data/article/README.md).
    #[command(flatten)]
    source: RigSource,
    /// Step: reference before the step (mm). Default: x0 − 5 mm.
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    from_mm: Option<f64>,
    /// Step: reference after the step (mm). Default: x0.
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    to_mm: Option<f64>,
    /// Time of the step or the start of the sinusoid (s).
    #[arg(
        long,
        value_name = "S",
        default_value_t = 0.5,
        allow_negative_numbers = true
    )]
    at_s: f64,
    /// Sine or sweep: amplitude (mm) about x0. Default: 20 for a sine, the sweep designer's
    /// for a sweep (`pumpcyl frf --design`).
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    amplitude_mm: Option<f64>,
    /// Sine: frequency (Hz).
    #[arg(
        long,
        value_name = "HZ",
        default_value_t = 0.25,
        allow_negative_numbers = true
    )]
    freq_hz: f64,
    /// Sweeps (chirp, multisine, stepped sine): band, lengths and counts.
    #[command(flatten)]
    sweep: crate::sweep::SweepArgs,
    /// Drive step: which drive (1 or 2).
    #[arg(long, default_value_t = 1)]
    motor: usize,
    /// Drive step: speed after the step (rpm), from rest.
    #[arg(
        long,
        value_name = "RPM",
        default_value_t = 500.0,
        allow_negative_numbers = true
    )]
    to_rpm: f64,
    /// Recorded length (s). Default: 6 s, 1 s for a drive step, two periods for a sine.
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    duration_s: Option<f64>,
    /// Sample rate (Hz). Default: 100 (the PLC), 1000 for a drive step (the drive's scope).
    #[arg(long, value_name = "HZ", allow_negative_numbers = true)]
    rate_hz: Option<f64>,
    /// Run even when --duration-s times --rate-hz exceeds 10^7 controller steps (hours of work),
    /// or when the integrator's work, counted as the run goes, exceeds that of 10^7 calm steps
    /// (drives that saturate or an unstable loop cost thousands of times more a step); a record
    /// is never longer than 5·10^6 samples (its memory).
    #[arg(long)]
    allow_long_run: bool,
    /// Seed of the sensor noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Noise-free, unquantised sensors.
    #[arg(long)]
    no_noise: bool,
    /// Integrate the rig's power account beside its states over the record and print it
    /// (docs/energy.md#over-a-run): what the sources delivered, the work against the load, each
    /// loss and each stored energy's change (J); with --json the `energy` object. The record's
    /// signals are the same either way; it gains the account's power columns, each kind's mean
    /// power to the next sample (W; docs/formats.md#power-columns).
    #[arg(long)]
    energy: bool,
    /// Switch every emulator effect off (the nonlinear model then linearises to the LTI one).
    #[arg(long)]
    no_effects: bool,
    /// Print JSON (experiment, rig, samples, basis, warnings, end_stop and the record's
    /// columns); the record is written to --out all the same.
    #[arg(long, conflicts_with = "article_records")]
    json: bool,
    /// Output record (docs/formats.md#record-csv; a drive step writes time_s, w_ref_rpm, w_rpm).
    #[arg(
        long,
        value_name = "RECORD.csv",
        required_unless_present = "article_records"
    )]
    out: Option<PathBuf>,
}

/// `--experiment`: the names and help of pumpcyl-present's [`ExperimentKind`], defined there
/// once for the command line and Python.
fn experiment_parser() -> impl clap::builder::TypedValueParser<Value = ExperimentKind> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
    let values = ExperimentKind::ALL.map(|k| PossibleValue::new(k.name()).help(k.help()));
    PossibleValuesParser::new(values)
        .map(|name| ExperimentKind::named(&name).expect("a name of ExperimentKind::ALL"))
}

/// `pumpcyl emulate`.
pub fn run(args: &EmulateArgs) -> Result<String> {
    if let Some(dir) = &args.article_records {
        return article_records(dir);
    }
    let kind = args
        .experiment
        .ok_or_else(|| anyhow!("--experiment is needed"))?;
    let out = args
        .out
        .as_ref()
        .ok_or_else(|| anyhow!("--out is needed"))?;
    let rig = load_input(&args.source, !args.no_effects)?;
    let mut record = request(args, kind);
    let rate_hz = (record.plc())
        .map_err(|e| FieldError::of_core(e, "rate_hz", None))?
        .rate_hz;
    record.sweep = sweep(args, kind, &rig.rig, rate_hz)?;
    let request = Emulate {
        rig,
        effects: !args.no_effects,
        record,
        allow_long_run: args.allow_long_run,
    };
    if let Some((steps, _)) = request.work().filter(|(steps, _)| *steps > ANNOUNCED_STEPS) {
        eprintln!("emulating {steps} controller steps at {rate_hz} Hz ...");
    }
    // a failed run names the record it was to write; a refused option, the option
    let outcome = crate::emit::run(&request).map_err(|e| match e.is::<FieldError>() {
        true => e,
        false => e.context(out.display().to_string()),
    })?;
    write_atomic(out, outcome.csv().as_bytes())?;
    if args.json {
        return show(&outcome, true);
    }
    Ok(format!("{}: {}", out.display(), show(&outcome, false)?))
}

/// Controller steps above which an emulation says how many it will take before it starts (a
/// few seconds of work; a progress bar follows them on a terminal).
const ANNOUNCED_STEPS: u64 = 100_000;

/// The library's request of the command's options.
fn request(args: &EmulateArgs, kind: ExperimentKind) -> emulated::Request {
    emulated::Request {
        experiment: kind,
        from_mm: args.from_mm,
        to_mm: args.to_mm,
        at_s: args.at_s,
        amplitude_mm: args.amplitude_mm,
        freq_hz: args.freq_hz,
        motor: args.motor,
        to_rpm: args.to_rpm,
        duration_s: args.duration_s,
        rate_hz: args.rate_hz,
        seed: args.seed,
        noise: !args.no_noise,
        sweep: None,
        energy: args.energy,
    }
}

/// The excitation of a sweep experiment, built from the sweep options on the rig (the sweep
/// designer's defaults, `pumpcyl frf --design`); none for the other experiments. A sweep's
/// length follows from its shape, not from --duration-s.
fn sweep(
    args: &EmulateArgs,
    kind: ExperimentKind,
    rig: &Rig,
    rate_hz: f64,
) -> Result<Option<pumpcyl::frf::Excitation>> {
    use crate::sweep::SweepKind;
    let k = match kind {
        ExperimentKind::Chirp => SweepKind::Chirp,
        ExperimentKind::Multisine => SweepKind::Multisine,
        ExperimentKind::SteppedSine => SweepKind::SteppedSine,
        _ => return Ok(None),
    };
    if args.duration_s.is_some() {
        anyhow::bail!(
            "--duration-s: a sweep's length follows from --sweep-s, --periods and the band"
        );
    }
    let e = crate::sweep::excitation(k, args.amplitude_mm, args.at_s, &args.sweep, (rig, rate_hz))?;
    e.check(rate_hz, rig)
        .map_err(|e| crate::emit::as_option(e, crate::sweep::option_of))?;
    Ok(Some(e))
}

/// The rig: a file, or the emulated article rig, with --set applied.
pub(crate) fn load_rig(source: &RigSource, effects: bool) -> Result<Rig> {
    Ok(load_input(source, effects)?.rig)
}

/// [`load_rig`] as a request takes it: named, with the keys its file left out.
pub(crate) fn load_input(source: &RigSource, effects: bool) -> Result<RigInput> {
    if source.rig.is_some() {
        return source.input();
    }
    let base = pumpcyl::fmu::default_rig(ModelKind::Emulator, effects)?;
    Ok(RigInput {
        rig: base.with_overrides_from("--set", &source.set)?,
        name: source.origin_or("the emulated article rig"),
        defaulted: None,
    })
}

/// Emulate every article record into `dir`, with the README and the identify experiment.
fn article_records(target: &Path) -> Result<String> {
    let folder = crate::emit::out_dir(target)?;
    let dir = folder.path();
    let records = article::records().map_err(|e| anyhow!(e))?;
    let results: Vec<Result<Emulated>> = records
        .par_iter()
        .map(|r| r.run().map_err(|e| anyhow!("{}: {e}", r.file)))
        .collect();
    let mut summary = String::new();
    for (rec, data) in records.iter().zip(results) {
        let data = data?;
        write_atomic(&dir.join(rec.file), records::emulated_csv(&data).as_bytes())?;
        let _ = writeln!(summary, "{}: {}", target.join(rec.file).display(), rec.what);
    }
    write_atomic(
        &dir.join("README.md"),
        records::article_readme(&records).as_bytes(),
    )?;
    write_atomic(
        &dir.join("identify.toml"),
        records::article_identify_experiment().as_bytes(),
    )?;
    let _ = writeln!(
        summary,
        "{}: README.md and identify.toml (emulated data, not measurements)",
        target.display()
    );
    crate::emit::commit(folder, target)?;
    Ok(summary)
}
