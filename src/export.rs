//! MATLAB and Octave outputs of the commands: the model as a function file (`.m`) or MAT-file,
//! the grey-box model function, and MAT-files of signals, Bode data and identification results
//! (docs/matlab.md). The formats are in [`pumpcyl_present::matlab`] and [`pumpcyl::matfile`].

use anyhow::Result;
use std::path::Path;

use crate::emit::write_atomic;
use pumpcyl::loops::ModelView;
use pumpcyl::matfile::{var_name, MatWriter};
use pumpcyl::response::Signals;
use pumpcyl_present::matlab::{self, Described};

/// The function name a `.m` file must carry: its stem, if MATLAB accepts it.
fn function_name(path: &Path) -> Result<String> {
    let stem = path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or_default();
    anyhow::ensure!(
        matlab::is_function_name(stem),
        "{}: MATLAB calls a function file by its name, so `{stem}` must be a MATLAB name (a \
         letter, then letters, digits or _, at most 63)",
        path.display()
    );
    Ok(stem.to_string())
}

/// Whether a path ends in `.ext` (any case).
pub fn has_ext(path: &Path, ext: &str) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case(ext))
}

/// `model --out FILE.m|FILE.mat`.
pub fn write_model(path: &Path, view: &ModelView) -> Result<()> {
    if has_ext(path, "m") {
        let described = Described {
            sys: &view.sys,
            states: &view.states,
            inputs: view.inputs.clone(),
            outputs: view.outputs.clone(),
            title: view.title.clone(),
            operating_point: view.operating_point.clone(),
        };
        let text = matlab::ss_function(&function_name(path)?, &described);
        return write_atomic(path, text.as_bytes());
    }
    anyhow::ensure!(
        has_ext(path, "mat"),
        "{}: unknown output format; use one of .m, .mat",
        path.display()
    );
    let mut w = MatWriter::new(&view.title);
    for (name, m) in [
        ("A", &view.sys.a),
        ("B", &view.sys.b),
        ("C", &view.sys.c),
        ("D", &view.sys.d),
    ] {
        w.matrix(name, m.nrows(), m.ncols(), m.as_slice());
    }
    let join = |v: Vec<&str>| v.join(",");
    w.text(
        "state_names",
        &join(view.states.iter().map(|s| s.name.as_str()).collect()),
    )
    .text(
        "state_units",
        &join(view.states.iter().map(|s| s.unit.as_str()).collect()),
    )
    .text(
        "input_names",
        &join(view.inputs.iter().map(|s| s.name.as_str()).collect()),
    )
    .text(
        "output_names",
        &join(view.outputs.iter().map(|s| s.name.as_str()).collect()),
    )
    .text("description", &view.title);
    for (name, v, _) in &view.operating_point {
        w.scalar(&format!("op_{name}"), *v);
    }
    write_atomic(path, &w.into_bytes())
}

/// `model --greybox FILE.m`.
pub fn write_greybox(
    path: &Path,
    view: &ModelView,
    standstill: Option<pumpcyl::ident::Standstill>,
) -> Result<()> {
    anyhow::ensure!(
        has_ext(path, "m"),
        "{}: the grey-box model is a MATLAB function file: name it NAME.m",
        path.display()
    );
    let Some((rig, which)) = &view.rig else {
        anyhow::bail!("--greybox needs a rig (its parameters are the rig's), not --ss");
    };
    let standstill = pumpcyl::loops::standstill_of(rig, standstill);
    // the standstill must give usable leakages (positive pressures) for the rig
    standstill.leakage(rig, rig.c12_m5_per_ns)?;
    let text = matlab::greybox_function(
        &function_name(path)?,
        rig,
        *which,
        standstill,
        &view.title,
        &view.outputs,
        &view.inputs,
    );
    write_atomic(path, text.as_bytes())
}

/// Signals as MAT variables named as the CSV columns (`time_s`, `x_ref_mm`, `x_mm`, `e_mm`,
/// `p1_bar`, `p2_bar`, `w1_rpm`, `w2_rpm`): the first block (the measured record if there is
/// one) with plain names, block k ≥ 2 with the suffix `_k`; `series_labels` names the blocks.
pub fn signals_mat(w: &mut MatWriter, series: &[(String, &Signals)], measured: Option<&Signals>) {
    let mut blocks: Vec<(String, &Signals)> = Vec::new();
    if let Some(m) = measured {
        blocks.push(("measured".into(), m));
    }
    blocks.extend(series.iter().map(|(l, s)| (l.clone(), *s)));
    let mut labels = Vec::new();
    for (k, (label, s)) in blocks.iter().enumerate() {
        let suffix = if k == 0 {
            String::new()
        } else {
            format!("_{}", k + 1)
        };
        labels.push(format!("{}: {label}", k + 1));
        for (name, v) in s.named() {
            if !v.is_empty() {
                w.column(&format!("{name}{suffix}"), v);
            }
        }
    }
    w.text("series_labels", &labels.join("; "));
}

/// Write a MAT-file of signals and named scalars (`None` is NaN: not reached, not settled).
pub fn write_signals_mat(
    path: &Path,
    description: &str,
    series: &[(String, &Signals)],
    measured: Option<&Signals>,
    scalars: &[(&str, Vec<Option<f64>>)],
) -> Result<()> {
    let mut w = MatWriter::new(description);
    signals_mat(&mut w, series, measured);
    for (name, values) in scalars {
        let v: Vec<f64> = values.iter().map(|x| x.unwrap_or(f64::NAN)).collect();
        w.column(&var_name(name), &v);
    }
    write_atomic(path, &w.into_bytes())
}

/// `bode --out FILE.mat`: `freq_hz`, and `mag_db`, `phase_deg` (suffixed `_k` for overlay k ≥ 2),
/// `series_labels`.
pub fn write_bode_mat(path: &Path, series: &[pumpcyl_present::plot::BodeSeries]) -> Result<()> {
    let mut w = MatWriter::new("Bode diagram of the position open loop");
    w.column("freq_hz", &series[0].freq_hz);
    let mut labels = Vec::new();
    for (k, s) in series.iter().enumerate() {
        let suffix = if k == 0 {
            String::new()
        } else {
            format!("_{}", k + 1)
        };
        labels.push(format!("{}: {}", k + 1, s.label));
        w.column(&format!("mag_db{suffix}"), &s.mag_db)
            .column(&format!("phase_deg{suffix}"), &s.phase_deg);
    }
    w.text("series_labels", &labels.join("; "));
    write_atomic(path, &w.into_bytes())
}
