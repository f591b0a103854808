//! Interruption of a command: SIGINT, SIGTERM or SIGHUP remove the temporaries of this run (the
//! files and folders `pumpcyl-present` is building) and end the command with 128 + the signal,
//! as the shell reports an interrupted command. Only the command line installs this; the
//! libraries leave a host program's signals alone.

use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};

/// At start-up: the thread that waits for the signals.
pub fn install() {
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
