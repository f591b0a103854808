//! Safe output: file and folder writes that never lose a user's data.
//!
//! Every file pumpcyl writes (the command line, the article workflow, the Python package) goes
//! through [`write_atomic`] and every result folder through [`OutDir`], so one place guarantees
//! that a user's data is never lost:
//! - no output lands on a file the caller read: the caller names those files ([`Protected`];
//!   paths compared canonicalised, symlinks resolved);
//! - a file appears whole or not at all (temporary sibling, then a rename), a folder likewise
//!   (built as a temporary sibling, then swapped in); temporaries are removed when an error
//!   abandons them, by a front end's signal handler through [`remove_temporaries`], or by the
//!   next run after a SIGKILL (their names carry the process id);
//! - a result folder keeps every file the user put in it: its marker lists the files pumpcyl
//!   wrote, and a new run replaces only those ([`OutDir`], docs/formats.md#result-folders);
//! - a read-only output file, a file of the user's at a path of a result folder and a non-empty
//!   folder that holds no earlier result are refused unless forced ([`Protected::forcing`]);
//! - files are created with the permissions the user's umask gives any new file (0666 & !umask);
//!   a file written over keeps its permissions, and a symbolic link to a regular file or to a
//!   folder is followed (its target is replaced, the link stays);
//! - a FIFO, a character device or a link to one (`/dev/stdout`, `/dev/null`) cannot be replaced
//!   by a rename and must not be: the bytes are written into it directly; block devices and
//!   sockets are refused.
//!
//! Nothing here installs a signal handler or ends the process: the command line does that.

use anyhow::{Context, Result};
use std::collections::HashSet;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The marker of a pumpcyl temporary in a file or folder name: `.NAME.pumpcyl-tmp-PID-XXXXXX`.
const TMP_TAG: &str = ".pumpcyl-tmp-";

/// The marker file that says a folder is a complete pumpcyl result, which a new run may replace.
const MARKER: &str = ".pumpcyl-output";

/// Temporaries of this run, removed by the signal handler.
static TEMPORARIES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Outputs this run has put in place (files renamed, folders swapped in), recorded under the
/// temporaries' lock, so an interruption can say what is already complete.
static PLACED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn placed() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    PLACED.lock().unwrap_or_else(|e| e.into_inner())
}

fn temporaries() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    TEMPORARIES.lock().unwrap_or_else(|e| e.into_inner())
}

/// Remove every temporary this process is building (files being written, result folders being
/// assembled, scratch folders) and keep new ones from starting: for a front end's signal
/// handler before it ends the process. Returns the outputs this run already put in place,
/// complete (none: every output is as it was before the run).
///
/// The registry's lock is held until the process ends (the guard is leaked), so a commit in
/// progress finishes first and none starts after.
pub fn remove_temporaries() -> Vec<PathBuf> {
    let tmp = temporaries();
    let done = completed(&placed(), &tmp);
    for p in tmp.iter() {
        // a write of another thread may race the first removal; retry
        for _ in 0..20 {
            remove_any(p);
            if !p.exists() {
                break;
            }
        }
    }
    std::mem::forget(tmp);
    done
}

/// The outputs put in place that do not lie inside a temporary still being built (a file
/// written into a result folder is complete only when the folder is).
fn completed(placed: &[PathBuf], building: &[PathBuf]) -> Vec<PathBuf> {
    let building: Vec<PathBuf> = building.iter().map(|t| resolve(t)).collect();
    placed
        .iter()
        .filter(|p| !building.iter().any(|t| p.starts_with(t)))
        .cloned()
        .collect()
}

fn remove_any(p: &Path) {
    if p.is_dir() {
        let _ = std::fs::remove_dir_all(p);
    } else {
        let _ = std::fs::remove_file(p);
    }
}

/// Create a temporary with `create` and register it for removal on interruption; the registry
/// is locked throughout, so a signal handled meanwhile waits and then removes it too.
fn create_tracked<T>(
    create: impl FnOnce() -> std::io::Result<T>,
    path: impl Fn(&T) -> PathBuf,
) -> std::io::Result<T> {
    let mut registry = temporaries();
    let made = create()?;
    registry.push(path(&made));
    Ok(made)
}

fn untrack(p: &Path) {
    temporaries().retain(|q| q != p);
}

/// The canonical form of a path that may not exist yet: its deepest existing ancestor
/// canonicalised (symlinks resolved), the rest appended.
pub fn resolve(path: &Path) -> PathBuf {
    let abs = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir().unwrap_or_default().join(path)
    };
    let mut rest = Vec::new();
    let mut head = abs.as_path();
    loop {
        if let Ok(real) = std::fs::canonicalize(head) {
            return rest.iter().rev().fold(real, |acc, part| acc.join(part));
        }
        match (head.parent(), head.file_name()) {
            (Some(parent), Some(name)) => {
                rest.push(name.to_os_string());
                head = parent;
            }
            _ => return abs,
        }
    }
}

/// The files a run read, which none of its outputs may replace: a front end names them (the
/// command line notes every file the core opens for it); a library call that reads no user file
/// passes [`Protected::none`].
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Protected {
    /// Canonical paths (symlinks resolved).
    paths: Vec<PathBuf>,
    /// Write over what pumpcyl would otherwise leave alone ([`Protected::forcing`]).
    force: bool,
}

impl Protected {
    /// Nothing to protect.
    pub fn none() -> Protected {
        Protected::none_const()
    }

    /// Nothing to protect, in a constant (a front end's registry of the files it reads).
    pub const fn none_const() -> Protected {
        Protected {
            paths: Vec::new(),
            force: false,
        }
    }

    /// With `force`, write over what pumpcyl otherwise refuses to touch (the command line's
    /// `--force`, Python's `force=True`): a read-only output file, a file of the user's at a
    /// path of a result folder, a non-empty folder that holds no earlier result. The inputs
    /// stay protected, and a result folder keeps every other file of the user's either way.
    pub fn forcing(mut self, force: bool) -> Protected {
        self.force = force;
        self
    }

    /// The files `paths`; a path that does not exist (any more) protects nothing.
    pub fn new<P: AsRef<Path>>(paths: impl IntoIterator<Item = P>) -> Protected {
        let mut out = Protected::default();
        for p in paths {
            out.add(p.as_ref());
        }
        out
    }

    /// Protect `path` as well.
    pub fn add(&mut self, path: &Path) {
        if let Ok(real) = std::fs::canonicalize(path) {
            if !self.paths.contains(&real) {
                self.paths.push(real);
            }
        }
    }

    /// Refuse an output at `path` that is, or (for a folder) contains, a protected file.
    pub fn check(&self, path: &Path) -> Result<()> {
        let target = resolve(path);
        for input in &self.paths {
            if *input == target {
                anyhow::bail!(
                    "{}: is an input of this command; writing there would destroy it, choose \
                     another output",
                    path.display()
                );
            }
            if input.starts_with(&target) {
                anyhow::bail!(
                    "{}: holds the input {}, which replacing the folder would destroy; choose \
                     another output folder",
                    path.display(),
                    input.display()
                );
            }
        }
        Ok(())
    }
}

/// The folder of `path` ("." for a bare name).
fn parent_of(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// Remove temporaries of `name` in `dir` left by runs that no longer exist (killed by SIGKILL or
/// a power cut): their names carry the process id.
fn remove_stale(dir: &Path, name: &str) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let prefix = format!(".{name}{TMP_TAG}");
    for entry in entries.flatten() {
        let file = entry.file_name();
        let Some(rest) = file.to_str().and_then(|f| f.strip_prefix(&prefix)) else {
            continue;
        };
        let pid = rest.split('-').next().and_then(|p| p.parse::<u32>().ok());
        if pid.is_some_and(|pid| pid != std::process::id() && !alive(pid)) {
            remove_any(&entry.path());
        }
    }
}

/// Whether process `pid` exists.
fn alive(pid: u32) -> bool {
    let Ok(pid) = libc::pid_t::try_from(pid) else {
        return false;
    };
    // SAFETY: kill with signal 0 only checks for the process; it has no memory effects.
    let r = unsafe { libc::kill(pid, 0) };
    r == 0 || std::io::Error::last_os_error().raw_os_error() == Some(libc::EPERM)
}

/// The name prefix of this run's temporaries for `name`.
fn tmp_prefix(name: &str) -> String {
    format!(".{name}{TMP_TAG}{}-", std::process::id())
}

fn file_name(path: &Path) -> Result<String> {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .with_context(|| format!("{}: not a file name", path.display()))
}

/// Write `bytes` to `path` atomically: a temporary file in the same folder, then a rename, so a
/// failure or an interruption never leaves a half-written output behind. Refuses to write over
/// a `protected` file, and a read-only one (owner's write bit clear) unless forced
/// ([`Protected::forcing`]). A new file gets the permissions of any new file (0666 & !umask), a
/// file written over keeps its own; a symbolic link to a regular file is followed. A FIFO or a
/// character device (or a link to one) is written into directly, since no rename can replace
/// it and none should.
pub fn write_atomic(path: &Path, bytes: &[u8], protected: &Protected) -> Result<()> {
    protected.check(path)?;
    match destination(path)? {
        Destination::Stream => write_stream(path, bytes),
        Destination::File { path: target, mode } => {
            if target != path {
                protected.check(&target)?;
            }
            if mode.is_some_and(|m| m & 0o200 == 0) && !protected.force {
                anyhow::bail!(
                    "{}: is read-only, so pumpcyl leaves it as it is; make it writable, choose \
                     another output, or force the write (--force; force=True in Python)",
                    path.display()
                );
            }
            replace_file(&target, bytes, mode)
        }
    }
}

/// Where the bytes of an output go.
enum Destination {
    /// A FIFO or a character device: written into, never replaced.
    Stream,
    /// A regular file, new or replaced (a link's target), with the mode to keep.
    File { path: PathBuf, mode: Option<u32> },
}

/// What `path` is: a stream, or the regular file (a link's target) to replace and its mode.
fn destination(path: &Path) -> Result<Destination> {
    use std::os::unix::fs::{FileTypeExt, PermissionsExt};
    let shown = path.display();
    let Ok(link) = std::fs::symlink_metadata(path) else {
        return Ok(Destination::File {
            path: path.to_path_buf(),
            mode: None,
        });
    };
    let meta = std::fs::metadata(path)
        .with_context(|| format!("{shown}: is a link to nothing; give a file name"))?;
    let kind = meta.file_type();
    if kind.is_dir() {
        anyhow::bail!("{shown}: is a folder; give a file name");
    }
    if kind.is_fifo() || kind.is_char_device() {
        return Ok(Destination::Stream);
    }
    if !kind.is_file() {
        anyhow::bail!("{shown}: is a block device or a socket, not a file; give a file name");
    }
    let target = if link.file_type().is_symlink() {
        std::fs::canonicalize(path).with_context(|| format!("{shown}: cannot follow the link"))?
    } else {
        path.to_path_buf()
    };
    let mode = Some(meta.permissions().mode() & 0o7777);
    Ok(Destination::File { path: target, mode })
}

/// Write into a FIFO or a character device. A FIFO nobody reads is an error, not a hang: it is
/// opened non-blocking (which fails without a reader), then written blocking.
fn write_stream(path: &Path, bytes: &[u8]) -> Result<()> {
    use std::os::unix::fs::OpenOptionsExt;
    use std::os::unix::io::AsRawFd;
    let shown = path.display();
    let mut file = std::fs::OpenOptions::new()
        .write(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)
        .with_context(|| format!("{shown}: cannot open for writing (a FIFO needs a reader)"))?;
    let fd = file.as_raw_fd();
    // SAFETY: fcntl on a descriptor this function owns; only the O_NONBLOCK flag changes.
    unsafe {
        let flags = libc::fcntl(fd, libc::F_GETFL);
        libc::fcntl(fd, libc::F_SETFL, flags & !libc::O_NONBLOCK);
    }
    file.write_all(bytes)
        .and_then(|_| file.flush())
        .with_context(|| format!("{shown}: write failed"))
}

/// Replace (or create) the regular file `path` by a temporary sibling and a rename, giving it
/// `mode` (an existing file's permissions) or those of any new file.
fn replace_file(path: &Path, bytes: &[u8], mode: Option<u32>) -> Result<()> {
    let dir = parent_of(path);
    let name = file_name(path)?;
    remove_stale(dir, &name);
    use std::os::unix::fs::PermissionsExt;
    let mut tmp = create_tracked(
        || {
            tempfile::Builder::new()
                .prefix(&tmp_prefix(&name))
                .permissions(std::fs::Permissions::from_mode(0o666))
                .tempfile_in(dir)
        },
        |t| t.path().to_path_buf(),
    )
    .with_context(|| {
        format!(
            "{}: cannot create a file in {}",
            path.display(),
            dir.display()
        )
    })?;
    // the file's own error (EFBIG past a size limit), without the temporary's name
    let written = tmp
        .as_file_mut()
        .write_all(bytes)
        .and_then(|_| match mode {
            Some(m) => tmp
                .as_file()
                .set_permissions(std::fs::Permissions::from_mode(m)),
            None => Ok(()),
        })
        .and_then(|_| tmp.as_file().sync_all())
        .with_context(|| format!("{}: write failed", path.display()));
    let tmp_path = tmp.path().to_path_buf();
    let result = written.and_then(|_| {
        let _registry = temporaries();
        tmp.persist(path)
            .map(|_| placed().push(resolve(path)))
            .map_err(|e| e.error)
            .with_context(|| format!("{}: cannot write", path.display()))
    });
    untrack(&tmp_path);
    result
}

/// Create the folder `dir` (and its parents) for outputs written one file at a time; an existing
/// file of that name is named as such.
pub fn ensure_folder(dir: &Path) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        anyhow::bail!(
            "{}: exists and is not a folder; give a folder",
            dir.display()
        );
    }
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))
}

/// A result folder built as a temporary sibling and swapped in whole by [`OutDir::commit`]: at
/// every moment the folder holds the complete previous result or the complete new one, and
/// every file of the user's in it (docs/formats.md#result-folders).
///
/// The marker `.pumpcyl-output` lists the files pumpcyl wrote. A new run replaces those and
/// keeps every other file: a file the user put in the folder, or any file a forged or empty
/// marker does not list. Kept files are hard-linked into the new folder before the swap, so
/// none is ever absent, and one that appears during the run is moved over after it. A file of
/// the user's at a path of the new result is refused, naming it, unless forced
/// ([`Protected::forcing`]). A symbolic link given as the folder is followed: its target is
/// replaced, the link stays.
pub struct OutDir {
    /// The folder as given, for messages.
    shown: PathBuf,
    /// The real folder (a link given as the folder resolved).
    target: PathBuf,
    tmp: PathBuf,
    force: bool,
}

/// What [`OutDir::commit`] did besides putting the result in place.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Committed {
    /// Files of the user's kept in the folder (paths inside it).
    pub kept: Vec<PathBuf>,
    /// Files of the user's a forced write replaced (paths inside it).
    pub replaced: Vec<PathBuf>,
    /// Where the previous folder was left, when a file that appeared in it during the run could
    /// not be moved over.
    pub previous: Option<PathBuf>,
}

impl Committed {
    /// What happened to files pumpcyl did not write, one line each ("kept notes.txt (not
    /// written by pumpcyl)"); none when the folder held only pumpcyl's files.
    pub fn notes(&self) -> Vec<String> {
        let mut out = Vec::new();
        if !self.kept.is_empty() {
            out.push(format!(
                "kept {} (not written by pumpcyl)",
                names(&self.kept)
            ));
        }
        if !self.replaced.is_empty() {
            out.push(format!(
                "replaced {} (not written by pumpcyl; the write was forced)",
                names(&self.replaced)
            ));
        }
        if let Some(p) = &self.previous {
            out.push(format!(
                "the previous folder is left at {}: a file added to it during the run could \
                 not be moved over",
                p.display()
            ));
        }
        out
    }
}

/// The most entries (files and folders) of a result folder examined; a folder with more is
/// not a result folder.
const MAX_ENTRIES: usize = 100_000;

/// The most bytes of a marker read.
const MAX_MARKER_BYTES: u64 = 1 << 20;

/// The most names listed in one message.
const MAX_NAMES: usize = 10;

/// Paths for a message, at most [`MAX_NAMES`] of them.
fn names(paths: &[PathBuf]) -> String {
    let mut out: Vec<String> = paths
        .iter()
        .take(MAX_NAMES)
        .map(|p| p.display().to_string())
        .collect();
    if paths.len() > MAX_NAMES {
        out.push(format!("and {} more", paths.len() - MAX_NAMES));
    }
    out.join(", ")
}

/// The entries of a folder, relative to it, symbolic links not followed; parents come before
/// their children.
#[derive(Debug, Default)]
struct Tree {
    files: Vec<PathBuf>,
    dirs: Vec<PathBuf>,
}

fn tree(root: &Path) -> Result<Tree> {
    let mut out = Tree::default();
    let mut pending = vec![PathBuf::new()];
    let mut count = 0usize;
    while let Some(rel) = pending.pop() {
        let here = root.join(&rel);
        let cannot = || format!("{}: cannot read the folder", here.display());
        for entry in std::fs::read_dir(&here).with_context(cannot)? {
            let entry = entry.with_context(cannot)?;
            count += 1;
            if count > MAX_ENTRIES {
                anyhow::bail!(
                    "{}: holds more than {MAX_ENTRIES} files and folders, too many for a result \
                     folder; give a new or empty one",
                    root.display()
                );
            }
            let path = rel.join(entry.file_name());
            if entry.file_type().with_context(cannot)?.is_dir() {
                out.dirs.push(path.clone());
                pending.push(path);
            } else {
                out.files.push(path);
            }
        }
    }
    Ok(out)
}

/// The files the marker of `dir` lists as pumpcyl's: none without a marker (or with one that
/// is not a regular file), read at most [`MAX_MARKER_BYTES`].
fn listed(dir: &Path) -> HashSet<PathBuf> {
    use std::io::Read;
    let marker = dir.join(MARKER);
    let mut text = Vec::new();
    if std::fs::symlink_metadata(&marker).is_ok_and(|m| m.is_file()) {
        if let Ok(f) = std::fs::File::open(&marker) {
            let _ = f.take(MAX_MARKER_BYTES).read_to_end(&mut text);
        }
    }
    String::from_utf8_lossy(&text)
        .lines()
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(PathBuf::from)
        .collect()
}

/// The marker listing `files`, the files pumpcyl wrote into the folder.
fn marker_text(files: &[PathBuf]) -> String {
    let mut text = String::from(
        "# pumpcyl wrote the files below; a new run replaces them and keeps every other file \
         (docs/formats.md#result-folders)\n",
    );
    for f in files {
        text.push_str(&format!("{}\n", f.display()));
    }
    text
}

/// The folder a path names: a symbolic link is followed (an output goes into its target and
/// the link stays).
fn real_folder(path: &Path) -> Result<PathBuf> {
    // `link/` names the link's target to some calls and the link to others: drop the slash
    let plain: PathBuf = path.components().collect();
    let is_link = std::fs::symlink_metadata(&plain).is_ok_and(|m| m.file_type().is_symlink());
    if !is_link {
        return Ok(plain);
    }
    std::fs::canonicalize(path).with_context(|| {
        format!(
            "{}: is a link to nothing; give a folder or a link to one",
            path.display()
        )
    })
}

impl OutDir {
    /// Start building the folder `target`. Refused when `target` is a file or a folder that
    /// holds a `protected` file, and, unless forced, when it is a non-empty folder that holds no
    /// earlier pumpcyl result.
    pub fn begin(target: &Path, protected: &Protected) -> Result<OutDir> {
        protected.check(target)?;
        let shown = target.display();
        let real = real_folder(target)?;
        if real.exists() && !real.is_dir() {
            anyhow::bail!("{shown}: exists and is not a folder; give a folder");
        }
        let marked = std::fs::symlink_metadata(real.join(MARKER)).is_ok();
        if real.is_dir() && !marked && !protected.force {
            let mut entries = std::fs::read_dir(&real)
                .with_context(|| format!("{shown}: cannot read the folder"))?;
            if entries.next().is_some() {
                anyhow::bail!(
                    "{shown}: folder is not empty and holds no earlier pumpcyl result; give a new \
                     or empty folder, or force the write (--force; force=True in Python) to put \
                     the result beside its files, which are kept"
                );
            }
        }
        let parent = parent_of(&real);
        let name = file_name(&real)?;
        std::fs::create_dir_all(parent)
            .with_context(|| format!("{}: cannot create", parent.display()))?;
        remove_stale(parent, &name);
        use std::os::unix::fs::PermissionsExt;
        let tmp = create_tracked(
            || {
                Ok(tempfile::Builder::new()
                    .prefix(&tmp_prefix(&name))
                    .permissions(std::fs::Permissions::from_mode(0o777))
                    .tempdir_in(parent)?
                    .keep())
            },
            PathBuf::clone,
        )
        .with_context(|| format!("{shown}: cannot create a folder in {}", parent.display()))?;
        Ok(OutDir {
            shown: target.to_path_buf(),
            target: real,
            tmp,
            force: protected.force,
        })
    }

    /// Where to write the files: the temporary folder.
    pub fn path(&self) -> &Path {
        &self.tmp
    }

    /// Create the subfolder `sub` of the temporary folder (under the registry lock, so an
    /// interruption never races it and leaves it behind).
    pub fn create_subfolder(&self, sub: &str) -> Result<()> {
        let _registry = temporaries();
        let path = self.tmp.join(sub);
        std::fs::create_dir(&path).with_context(|| format!("{}: cannot create", path.display()))
    }

    /// Write `bytes` to `rel` inside the folder being built, creating its subfolders (under the
    /// registry lock, as [`OutDir::create_subfolder`]).
    pub fn write(&self, rel: &Path, bytes: &[u8]) -> Result<()> {
        if let Some(parent) = rel.parent().filter(|p| !p.as_os_str().is_empty()) {
            let _registry = temporaries();
            let path = self.tmp.join(parent);
            std::fs::create_dir_all(&path)
                .with_context(|| format!("{}: cannot create", path.display()))?;
        }
        write_atomic(&self.tmp.join(rel), bytes, &Protected::none())
    }

    /// Put the finished folder in place, atomically (an exchange with the old folder on Linux),
    /// with every file of the user's in the old folder kept (see [`OutDir`]).
    pub fn commit(self) -> Result<Committed> {
        let mut written = tree(&self.tmp)?.files;
        written.sort();
        let old_listed = listed(&self.target);
        let mut done = if self.target.is_dir() {
            self.keep_theirs(&old_listed)?
        } else {
            Committed::default()
        };
        std::fs::write(self.tmp.join(MARKER), marker_text(&written))
            .with_context(|| format!("{}: cannot write", self.tmp.display()))?;
        let shown = self.shown.display();
        let guard = temporaries();
        let swapped = if self.target.is_dir() {
            exchange(&self.tmp, &self.target)
        } else {
            std::fs::rename(&self.tmp, &self.target)
        };
        if swapped.is_ok() {
            placed().push(resolve(&self.target));
            let written: HashSet<PathBuf> = written.into_iter().collect();
            done.previous = self.move_late_files(&old_listed, &written);
        }
        drop(guard);
        let result = swapped.with_context(|| format!("{shown}: cannot put the result in place"));
        // after an exchange the temporary name holds the previous result
        remove_any(&self.tmp);
        untrack(&self.tmp);
        result.map(|_| done)
    }

    /// Hard-link every file of the user's in the old folder (every file the marker does not
    /// list) into the new one, with the folders that hold them; refused, naming them, where
    /// the new result has a file of the same path, unless forced.
    fn keep_theirs(&self, listed: &HashSet<PathBuf>) -> Result<Committed> {
        let mut old = tree(&self.target)?;
        old.files.sort();
        let theirs = old
            .files
            .into_iter()
            .filter(|f| !listed.contains(f) && f.as_os_str() != MARKER);
        let (replaced, kept): (Vec<PathBuf>, Vec<PathBuf>) =
            theirs.partition(|f| std::fs::symlink_metadata(self.tmp.join(f)).is_ok());
        if !replaced.is_empty() && !self.force {
            anyhow::bail!(
                "{}: {} not written by pumpcyl, at a path of the new result; move them away or \
                 force the write (--force; force=True in Python)",
                self.shown.display(),
                names(&replaced)
            );
        }
        // the user's folders: those that hold a kept file or no file of pumpcyl's
        let dirs: Vec<&PathBuf> = old
            .dirs
            .iter()
            .filter(|d| {
                kept.iter().any(|f| f.starts_with(d)) || !listed.iter().any(|f| f.starts_with(d))
            })
            .collect();
        let mut created = Vec::new();
        for d in &dirs {
            let new = self.tmp.join(d);
            if !new.is_dir() {
                std::fs::create_dir(&new)
                    .with_context(|| format!("{}: cannot create", new.display()))?;
                created.push(*d);
            }
        }
        for f in &kept {
            std::fs::hard_link(self.target.join(f), self.tmp.join(f)).with_context(|| {
                format!(
                    "{}: cannot keep {} (not written by pumpcyl) in the new result; move it \
                     away or give another folder",
                    self.shown.display(),
                    f.display()
                )
            })?;
        }
        // the folders' permissions last, so that a read-only one could take its files
        for d in created.iter().rev() {
            if let Ok(meta) = std::fs::metadata(self.target.join(d)) {
                let _ = std::fs::set_permissions(self.tmp.join(d), meta.permissions());
            }
        }
        Ok(Committed {
            kept,
            replaced,
            previous: None,
        })
    }

    /// After the swap, move into the new folder every file of the user's that appeared in (or
    /// was replaced in) the previous one during the run; returns where the previous folder was
    /// left when one could not be moved.
    fn move_late_files(
        &self,
        old_listed: &HashSet<PathBuf>,
        written: &HashSet<PathBuf>,
    ) -> Option<PathBuf> {
        let previous = tree(&self.tmp).ok()?;
        let mut stuck = false;
        for f in previous.files {
            if f.as_os_str() == MARKER || old_listed.contains(&f) || written.contains(&f) {
                continue;
            }
            let to = self.target.join(&f);
            let moved = to
                .parent()
                .map_or(Ok(()), std::fs::create_dir_all)
                .and_then(|_| std::fs::rename(self.tmp.join(&f), &to));
            stuck |= moved.is_err();
        }
        if !stuck {
            return None;
        }
        let aside = parent_of(&self.target).join(format!(
            "{}.pumpcyl-previous-{}",
            file_name(&self.target).ok()?,
            std::process::id()
        ));
        std::fs::rename(&self.tmp, &aside).ok()?;
        Some(aside)
    }
}

impl Drop for OutDir {
    /// An abandoned folder (an error before commit) is removed; the target is untouched.
    fn drop(&mut self) {
        if self.tmp.exists() {
            remove_any(&self.tmp);
            untrack(&self.tmp);
        }
    }
}

/// Swap two folders atomically (Linux `renameat2(RENAME_EXCHANGE)`); where the file system
/// cannot, the old folder is moved aside first.
fn exchange(a: &Path, b: &Path) -> std::io::Result<()> {
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::ffi::OsStrExt;
        let ca = std::ffi::CString::new(a.as_os_str().as_bytes())?;
        let cb = std::ffi::CString::new(b.as_os_str().as_bytes())?;
        // SAFETY: two valid NUL-terminated paths; the call touches no memory of ours.
        let r = unsafe {
            libc::renameat2(
                libc::AT_FDCWD,
                ca.as_ptr(),
                libc::AT_FDCWD,
                cb.as_ptr(),
                libc::RENAME_EXCHANGE,
            )
        };
        if r == 0 {
            return Ok(());
        }
    }
    let aside = a.with_extension("old");
    std::fs::rename(b, &aside)?;
    std::fs::rename(a, b)?;
    std::fs::rename(&aside, a)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_folder_swapped_in_is_complete_and_a_file_inside_one_being_built_is_not() {
        let dir = tempfile::tempdir().unwrap();
        let root = resolve(dir.path());
        let building = root.join(".R.pumpcyl-tmp-1-x");
        let placed = vec![
            root.join("R"),
            building.join("result.json"),
            root.join("a.csv"),
        ];
        let done = completed(&placed, &[building]);
        assert_eq!(done, vec![root.join("R"), root.join("a.csv")]);
    }
}
