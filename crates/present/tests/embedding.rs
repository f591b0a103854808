//! The libraries embedded in a program with signal handling of its own: running the article
//! workflow and writing its folder installs no handler, so the program's own SIGINT handler
//! sees a later Ctrl-C and the process goes on (the command line alone ends a run on SIGINT).

use pumpcyl_present::reproduce::{reproduce, ReproduceOptions};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

#[test]
fn a_host_programs_sigint_handler_sees_ctrl_c_after_the_workflow() {
    let seen = Arc::new(AtomicBool::new(false));
    signal_hook::flag::register(signal_hook::consts::SIGINT, Arc::clone(&seen)).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let r = reproduce(&ReproduceOptions::default()).unwrap();
    r.write(&dir.path().join("out")).unwrap();
    assert!(dir.path().join("out/summary.json").is_file());
    // SAFETY: raise only delivers a signal to this process, whose handler sets a flag.
    assert_eq!(unsafe { libc::raise(libc::SIGINT) }, 0);
    // the handler runs before raise returns for a signal sent to the calling thread; allow a
    // moment for delivery to another thread all the same
    for _ in 0..100 {
        if seen.load(Ordering::SeqCst) {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    assert!(
        seen.load(Ordering::SeqCst),
        "the host's SIGINT handler did not run"
    );
    // still here: nothing in the libraries ended the process
}
