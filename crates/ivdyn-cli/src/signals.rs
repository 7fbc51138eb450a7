//! SIGINT and SIGTERM: the staged outputs of the running job are removed
//! ([`ivdyn::output::remove_staged`]) before the process exits with 128 + the signal (130,
//! 143, as a shell reports a command it stopped), so a stopped command leaves no hidden
//! file and none of its new outputs. The library installs no handler; this binary does.

use std::sync::atomic::{AtomicBool, Ordering};

/// Set once a signal is being handled: the job's own error (its staged files vanish
/// under it) must not race the handler's exit code.
static STOPPING: AtomicBool = AtomicBool::new(false);

/// Whether a signal is being handled; then `main` waits for the handler to exit.
pub fn stopping() -> bool {
    STOPPING.load(Ordering::SeqCst)
}

/// Starts a thread that waits for SIGINT or SIGTERM (the signals are then no longer
/// fatal by themselves: the thread cleans up, then exits).
#[cfg(unix)]
pub fn install() {
    use signal_hook::consts::{SIGINT, SIGTERM};
    use signal_hook::iterator::Signals;
    let mut signals = match Signals::new([SIGINT, SIGTERM]) {
        Ok(s) => s,
        Err(e) => {
            // the default action (stop at once) stays: staged files may then be left
            eprintln!("ivdyn: warning: cannot watch SIGINT/SIGTERM ({e}); a stopped run may leave .ivdyn-* folders");
            return;
        }
    };
    std::thread::spawn(move || {
        if let Some(sig) = signals.forever().next() {
            STOPPING.store(true, Ordering::SeqCst);
            ivdyn::output::remove_staged();
            std::process::exit(128 + sig);
        }
    });
}

/// No signals to watch.
#[cfg(not(unix))]
pub fn install() {}
