//! The files this command reads. The command line runs one command per process, so this
//! registry is that command's: every file the core opens for it goes through [`files`], which
//! notes it, and every output goes through [`protected`], so no output of the command replaces
//! one of its inputs (`pumpcyl_present::files::Protected`).

use pumpcyl::input::{Disk, Files};
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
