//! Interruption of a command: SIGINT, SIGTERM or SIGHUP remove the temporaries of this run (the
//! files and folders `pumpcyl-present` is building) and end the command with 128 + the signal,
//! as the shell reports an interrupted command; SIGXFSZ (a file-size limit) is ignored, so the
//! write fails and its error removes the temporary. Only the command line installs this; the
//! libraries leave a host program's signals alone.

use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};

/// At start-up: the thread that waits for the signals, and SIGXFSZ ignored.
pub fn install() {
    // A file-size limit (`ulimit -f`) would end the process by SIGXFSZ in the middle of a write,
    // leaving its temporary behind; ignored, the write fails with EFBIG instead, and the error
    // path removes the temporary and names the file.
    // SAFETY: setting a signal's disposition to SIG_IGN runs no handler code.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
        return;
    };
    std::thread::spawn(move || {
        if let Some(sig) = signals.forever().next() {
            let done = pumpcyl_present::files::remove_temporaries();
            if done.is_empty() {
                eprintln!("error: interrupted; outputs left as they were before this run");
            } else {
                let names: Vec<String> = done.iter().map(|p| p.display().to_string()).collect();
                eprintln!(
                    "error: interrupted; complete and in place: {}; nothing was left half-written",
                    names.join(", ")
                );
            }
            std::process::exit(128 + sig);
        }
    });
}
