//! The files this command reads. The command line runs one command per process, so this
//! registry is that command's: every file the core opens for it goes through [`files`], which
//! notes it, and every output goes through [`protected`], so no output of the command replaces
//! one of its inputs (`pumpcyl_present::files::Protected`).

use pumpcyl::ident::{Experiment, RigDefaults};
use pumpcyl::source_files::{Disk, Files};
use pumpcyl_present::files::Protected;
use std::io::Read;
use std::path::Path;
use std::sync::Mutex;

/// [`Disk`], noting every file opened.
struct Noting {
    read: Mutex<Protected>,
}

impl Files for Noting {
    fn open(&self, path: &Path) -> std::io::Result<Box<dyn Read + Send + '_>> {
        let file = Disk.open(path)?;
        self.read
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .add(path);
        Ok(file)
    }
}

static INPUTS: Noting = Noting {
    read: Mutex::new(Protected::none_const()),
};

/// Where the command's inputs are read from: the file system, each file noted.
pub fn files() -> &'static dyn Files {
    &INPUTS
}

/// The files read so far, which no output may replace.
pub fn protected() -> Protected {
    INPUTS
        .read
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .clone()
}

static RIG_DEFAULTS: Mutex<Option<RigDefaults>> = Mutex::new(None);

/// Note what the command's rig file left out (docs/formats.md#rig-toml): the first file read is
/// the one [`rig_defaults_note`] reports (a request's document lists the keys itself,
/// `pumpcyl_present::request::RigInput`).
fn note(defaults: RigDefaults) {
    let mut noted = RIG_DEFAULTS.lock().unwrap_or_else(|e| e.into_inner());
    if noted.is_none() {
        *noted = Some(defaults);
    }
}

/// Note that the rig file `name` left out the keys of `file` (but those in `except`, set by
/// `--set`).
pub fn note_rig_defaults(file: &pumpcyl::rig::RigFile, name: &str, except: &[&str]) {
    let keys = file.defaulted.iter().copied();
    note(RigDefaults {
        note: file.note(name, except),
        keys: keys.filter(|k| !except.contains(k)).collect(),
    });
}

/// An experiment file read as the command line reads it: the left-out keys of the rig file it
/// names, if any, noted.
pub fn experiment(path: &Path) -> anyhow::Result<Experiment> {
    experiment_as(path, None)
}

/// [`experiment`] fitted by `method` instead of the file's `method` when given.
pub fn experiment_as(
    path: &Path,
    method: Option<pumpcyl::ident::Method>,
) -> anyhow::Result<Experiment> {
    let exp = Experiment::load_as(files(), path, method)?;
    if exp.file.rig.is_some() {
        note(exp.rig_defaults.clone());
    }
    Ok(exp)
}

/// The line naming the keys the command's rig file left out and their values, if it left out
/// any; the command line prints it when the command succeeds (a failure reports only its error).
pub fn rig_defaults_note() -> Option<String> {
    let noted = RIG_DEFAULTS.lock().unwrap_or_else(|e| e.into_inner());
    noted.as_ref().and_then(|d| d.note.clone())
}
