//! `pumpcyl design --robust`: the design over the uncertainty of the parameters, the stroke
//! and the pressure range (docs/design.md#robust-design), shown as
//! [`pumpcyl_present::design`] formats it.

use anyhow::Result;
use std::path::Path;

use crate::emit::{render_both, write_atomic};
use pumpcyl::design::{DesignError, Targets};
use pumpcyl::rig::Rig;
use pumpcyl_present::design::{robust_run, robust_text, RobustRequest};
use pumpcyl_present::figures::Chart;
use pumpcyl_present::format::json_document;

/// Where the rig and the parameter set of a robust design come from.
pub(super) struct Source<'a> {
    /// The rig (used when there is no experiment).
    pub rig: Rig,
    /// Where the rig came from, in words (the command line's rig options).
    pub origin: String,
    /// The experiment whose records give the region, if any.
    pub experiment: Option<&'a Path>,
    /// Confidence of the region.
    pub confidence: f64,
    /// Whether masses × pressures beyond the design's limit may run (`--allow-long-run`).
    pub allow_long_run: bool,
}

/// Run the robust design and show it: JSON or text; with `out`, a result folder holding
/// result.json and robust-margins.svg/.png, the margins over the stroke at the deciding
/// parameter point.
pub(super) fn run(
    src: &Source,
    targets: &Targets,
    json_out: bool,
    out: Option<&Path>,
) -> Result<String> {
    crate::emit::check_confidence(src.confidence)?;
    let exp = src
        .experiment
        .map(crate::read_files::experiment)
        .transpose()?;
    let request = RobustRequest {
        rig: &src.rig,
        experiment: exp.as_ref(),
        confidence: src.confidence,
        allow_long_run: src.allow_long_run,
    };
    // a design error may lie in the rig (its mass table): say which rig
    let origin = src
        .experiment
        .map_or(src.origin.clone(), |p| p.display().to_string());
    let run = robust_run(&request, targets).map_err(|e| in_rig(e, &origin))?;
    let d = &run.design;
    let document = json_document(&run.document())?;
    if let Some(dir) = out {
        let folder = crate::emit::out_dir(dir)?;
        write_atomic(&folder.path().join("result.json"), document.as_bytes())?;
        // the margins over the stroke at the deciding parameter point
        let chart = Chart::robust_margins(d);
        render_both(&folder.path().join("robust-margins"), &chart)?;
        crate::emit::commit(folder, dir)?;
    }
    if json_out {
        return Ok(document);
    }
    Ok(robust_text(d, run.seconds))
}

/// A design error in the command line's words: work beyond its limit names
/// `--allow-long-run`; any other may lie in the rig (its mass table), so it names the rig.
pub(super) fn in_rig(e: DesignError, origin: &str) -> anyhow::Error {
    match e {
        DesignError::Limit(l) => crate::emit::hinted(l.into()),
        e => anyhow::anyhow!("{origin}: {e}"),
    }
}
