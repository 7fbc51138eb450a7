//! SIGINT and SIGTERM: the staged outputs of the running job are removed
//! ([`ivdyn::output::remove_staged`]) before the process exits with 128 + the signal (130,
//! 143, as a shell reports a command it stopped), so a stopped command leaves no hidden
//! file and none of its new outputs. The library installs no handler; this binary does.

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
            ivdyn::output::remove_staged();
            std::process::exit(128 + sig);
        }
    });
}

/// No signals to watch.
#[cfg(not(unix))]
pub fn install() {}
