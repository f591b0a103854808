//! MATLAB and Octave files of the `model` command: the model as a function file (`.m`) or
//! MAT-file and the grey-box model function (docs/matlab.md), written by their extension. The
//! formats, and the MAT-files of signals and Bode data, are in [`pumpcyl_present::matlab`].

use anyhow::Result;
use std::path::Path;

use crate::emit::write_atomic;
use pumpcyl::loops::ModelView;
use pumpcyl_present::matlab;

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
        let text = matlab::ss_function(&function_name(path)?, &matlab::described(view));
        return write_atomic(path, text.as_bytes());
    }
    anyhow::ensure!(
        has_ext(path, "mat"),
        "{}: unknown output format; use one of .m, .mat",
        path.display()
    );
    write_atomic(path, &matlab::model_mat(view))
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
    let standstill =
        pumpcyl::loops::standstill_of(rig, standstill).map_err(|e| anyhow::anyhow!(e))?;
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
