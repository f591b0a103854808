//! Command-line output: the format chosen by a file's extension, charts rendered to files, and
//! standard output. The safe file and folder writes are the library's
//! [`pumpcyl_present::files`].

use anyhow::{Context, Result};
use pumpcyl_present::figures::Chart;
pub use pumpcyl_present::files::ensure_folder;
use pumpcyl_present::files::{self, Committed, OutDir, Protected};
use std::io::Write;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

/// `--force`: write over what pumpcyl otherwise leaves alone ([`Protected::forcing`]).
static FORCE: AtomicBool = AtomicBool::new(false);

/// Set `--force` for this command, before any output.
pub fn set_force(force: bool) {
    FORCE.store(force, Ordering::Relaxed);
}

/// What no output of this command may destroy: its inputs, and (unless `--force`) read-only
/// files and files of the user's in a result folder.
pub fn protected() -> Protected {
    crate::read_files::protected().forcing(FORCE.load(Ordering::Relaxed))
}

/// Write `bytes` to `path` whole or not at all, never over an input of this command.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    files::write_atomic(path, bytes, &protected())
}

/// Start the result folder `dir`, built aside and swapped in whole, never over (or around) an
/// input of this command.
pub fn out_dir(dir: &Path) -> Result<OutDir> {
    OutDir::begin(dir, &protected())
}

/// Put the result folder `dir` in place and say on standard error what happened to the files
/// in it that pumpcyl did not write.
pub fn commit(folder: OutDir, dir: &Path) -> Result<()> {
    tell_kept(&folder.commit()?, dir);
    Ok(())
}

/// Say on standard error what a result folder's commit did with the user's files (control
/// characters of their names escaped, so each note stays one line).
pub fn tell_kept(done: &Committed, dir: &Path) {
    for note in done.notes() {
        eprintln!(
            "note: {}",
            format!("{}: {note}", dir.display()).escape_debug()
        );
    }
}

/// The options that name an output (a file or a result folder), in every command.
const OUTPUT_OPTIONS: [&str; 3] = ["out", "greybox", "article_records"];

/// Refuse two outputs of one command at one path (`model --out x.m --greybox x.m`), before any
/// work: the second would replace the first.
pub fn check_distinct_outputs(matches: &clap::ArgMatches) -> Result<()> {
    let Some((_, sub)) = matches.subcommand() else {
        return Ok(());
    };
    let mut seen: Vec<(std::path::PathBuf, &str)> = Vec::new();
    for option in OUTPUT_OPTIONS {
        let Ok(Some(path)) = sub.try_get_one::<std::path::PathBuf>(option) else {
            continue;
        };
        let real = files::resolve(path);
        if let Some((_, first)) = seen.iter().find(|(p, _)| *p == real) {
            anyhow::bail!(
                "{}: named by --{} and --{}; one file cannot hold both outputs, give two paths",
                path.display(),
                first.replace('_', "-"),
                option.replace('_', "-")
            );
        }
        seen.push((real, option));
    }
    Ok(())
}

/// A library error in the command line's words: the commands and options that act on it,
/// where the libraries say it in neutral terms.
pub fn hinted(e: anyhow::Error) -> anyhow::Error {
    use pumpcyl::ident::IdentError;
    use pumpcyl::limits::LimitError;
    use pumpcyl::lti::LtiError;
    use pumpcyl::rig::RigError;
    let long_run = matches!(e.downcast_ref(), Some(LimitError::LongRun { .. }))
        || matches!(
            e.downcast_ref(),
            Some(IdentError::Limit(LimitError::LongRun { .. }))
        );
    let hint = match (e.downcast_ref::<LtiError>(), e.downcast_ref::<RigError>()) {
        _ if long_run => " (--allow-long-run)",
        (Some(LtiError::Unstable { .. }), _) => "; `pumpcyl margins` and `pumpcyl poles` show why",
        (Some(LtiError::AboveNyquist { .. }), _) => " (--rate-hz)",
        (_, Some(RigError::Empty { .. })) => {
            "; omit --rig for the article's rig, or start from `pumpcyl rig --print-default`"
        }
        _ => return e,
    };
    anyhow::anyhow!("{e:#}{hint}")
}

/// A progress bar of candidates on stderr when it is a terminal; silent otherwise.
pub fn progress_bar(total: u64) -> indicatif::ProgressBar {
    progress_bar_of(total, "candidates")
}

/// A progress bar of `total` `unit` on stderr when it is a terminal (the size shown from the
/// start); silent otherwise.
pub fn progress_bar_of(total: u64, unit: &str) -> indicatif::ProgressBar {
    if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        let bar = indicatif::ProgressBar::new(total);
        bar.set_style(
            indicatif::ProgressStyle::with_template(&format!(
                "{{bar:40}} {{pos}}/{{len}} {unit} {{per_sec}} eta {{eta}}"
            ))
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar
    } else {
        indicatif::ProgressBar::hidden()
    }
}

/// Run `request`: a progress bar on a terminal over the work it reports, its errors with the
/// command line's hints ([`hinted`]).
pub fn run<R: pumpcyl_present::request::Request>(request: &R) -> Result<R::Outcome> {
    let bar = (request.work()).map(|(total, unit)| progress_bar_of(total, unit));
    let tick = |n| {
        if let Some(bar) = &bar {
            bar.inc(n);
        }
        true
    };
    let outcome = request.run(pumpcyl_present::request::Hooks { tick: &tick });
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    outcome.map_err(hinted)
}

/// A request's outcome as the command line shows it: its warnings on standard error, then its
/// JSON document (`json`) or its text.
pub fn show(outcome: &impl pumpcyl_present::request::Document, json: bool) -> Result<String> {
    for w in outcome.warnings() {
        eprintln!("warning: {w}");
    }
    if json {
        return Ok(pumpcyl_present::format::json_document(&outcome.json()?)?);
    }
    outcome.text()
}

/// A core complaint about a named field (`freq_hz = 50: …`), the field shown as the option that
/// sets it (`--freq-hz 50: …`); `option_of` maps a field to its option name.
pub fn as_option(
    e: pumpcyl::source_files::FieldError,
    option_of: fn(&str) -> &str,
) -> anyhow::Error {
    let rest = e.message.strip_prefix(e.field).unwrap_or(&e.message);
    let rest = rest.strip_prefix(" =").unwrap_or(rest);
    anyhow::anyhow!("--{}{rest}", option_of(e.field))
}

/// The output format chosen by a file's extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Comma-separated values.
    Csv,
    /// Scalable vector graphics.
    Svg,
    /// Portable network graphics.
    Png,
    /// MAT-file, level 5 (MATLAB, GNU Octave; docs/matlab.md).
    Mat,
}

/// Format from the extension of `path`, among `allowed`.
pub fn format_of(path: &Path, allowed: &[Format]) -> Result<Format> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let format = match ext.as_deref() {
        Some("csv") => Some(Format::Csv),
        Some("svg") => Some(Format::Svg),
        Some("png") => Some(Format::Png),
        Some("mat") => Some(Format::Mat),
        _ => None,
    };
    match format {
        Some(f) if allowed.contains(&f) => Ok(f),
        _ => {
            let names: Vec<String> = allowed
                .iter()
                .map(|f| format!(".{}", format!("{f:?}").to_lowercase()))
                .collect();
            anyhow::bail!(
                "{}: unknown output format; use one of {}",
                path.display(),
                names.join(", ")
            )
        }
    }
}

/// Render a chart to SVG or PNG by the extension of `path`, written atomically (never over an
/// input of this command).
pub fn render(path: &Path, chart: &Chart) -> Result<()> {
    let bytes = match format_of(path, &[Format::Svg, Format::Png])? {
        Format::Png => chart.png()?,
        _ => chart.svg()?.into_bytes(),
    };
    write_atomic(path, &bytes)
}

/// Render a chart as `stem`.svg and `stem`.png, each atomically.
pub fn render_both(stem: &Path, chart: &Chart) -> Result<()> {
    render(&stem.with_extension("svg"), chart)?;
    render(&stem.with_extension("png"), chart)
}

/// Print the result to standard output. A closed standard output or a broken pipe is an error:
/// the result did not reach the user.
pub fn emit(text: &str) -> Result<()> {
    if !stdout_open() {
        anyhow::bail!("cannot write to standard output: it is closed");
    }
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())
        .and_then(|_| out.flush())
        .context("cannot write to standard output")
}

/// Whether descriptor 1 was closed when the process started, recorded before the Rust runtime
/// reopens a closed descriptor on `/dev/null` (which would make it look open): glibc runs the
/// functions of `.init_array` before `main`, and Rust's runtime starts in `main`.
#[cfg(target_os = "linux")]
static STDOUT_CLOSED_AT_START: std::sync::atomic::AtomicBool =
    std::sync::atomic::AtomicBool::new(false);

#[cfg(target_os = "linux")]
#[used]
#[link_section = ".init_array"]
static RECORD_STDOUT: extern "C" fn() = record_stdout;

#[cfg(target_os = "linux")]
extern "C" fn record_stdout() {
    // SAFETY: fcntl only queries descriptor 1.
    let closed = unsafe { libc::fcntl(1, libc::F_GETFL) } == -1;
    STDOUT_CLOSED_AT_START.store(closed, std::sync::atomic::Ordering::Relaxed);
}

/// Whether standard output was open when the program started: on Linux as recorded before the
/// runtime started, so `/dev/null` opened for reading and writing (Python's
/// `subprocess.DEVNULL`) is an ordinary output.
#[cfg(target_os = "linux")]
fn stdout_open() -> bool {
    !STDOUT_CLOSED_AT_START.load(std::sync::atomic::Ordering::Relaxed)
}

/// Whether standard output was open when the program started. The Rust runtime reopens a closed
/// descriptor 1 on `/dev/null` for reading and writing, which a shell redirection (`>/dev/null`,
/// write-only) never does; that combination is taken as "closed by the caller".
#[cfg(not(target_os = "linux"))]
fn stdout_open() -> bool {
    // SAFETY: fcntl and fstat only query descriptor 1; `st` is a plain struct they fill.
    unsafe {
        let flags = libc::fcntl(1, libc::F_GETFL);
        if flags == -1 {
            return false;
        }
        let mut st: libc::stat = std::mem::zeroed();
        let mut null: libc::stat = std::mem::zeroed();
        let dev_null = c"/dev/null";
        let is_null = libc::fstat(1, &mut st) == 0
            && libc::stat(dev_null.as_ptr(), &mut null) == 0
            && st.st_rdev == null.st_rdev
            && (st.st_mode & libc::S_IFMT) == libc::S_IFCHR;
        !(is_null && flags & libc::O_ACCMODE == libc::O_RDWR)
    }
}
