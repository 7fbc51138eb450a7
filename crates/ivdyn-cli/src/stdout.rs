//! The summary on stdout, written so that a closed or full stdout (`ivdyn ... | head -1`,
//! `> /dev/full`) never panics and never stops the job: `println!` panics on a failed
//! write, and the notes printed before the work (the robot's chain) would then lose every
//! output file. The first failure is recorded and later lines are dropped; `main` turns it
//! into exit code [`EXIT_STDOUT`] after the job has written its files.

use std::fmt;
use std::io::{self, ErrorKind, Write};
use std::sync::OnceLock;

/// Exit code when the job succeeded but its summary could not be written to stdout
/// (documented in docs/reliability.md and docs/cli.md).
pub const EXIT_STDOUT: u8 = 3;

static FAILED: OnceLock<io::Error> = OnceLock::new();

/// Writes one line to stdout; after the first failure, nothing.
pub fn line(args: fmt::Arguments) {
    if FAILED.get().is_some() {
        return;
    }
    let mut o = io::stdout().lock();
    // stdout is line-buffered: the newline flushes, so a full device fails here
    if let Err(e) = o.write_fmt(args).and_then(|()| o.write_all(b"\n")) {
        let _ = FAILED.set(e);
    }
}

/// Flushes stdout; `Some(message)` when stdout failed at any point. The message is empty
/// for a closed pipe (the reader left on purpose, as `head` does: nothing to report).
pub fn finish() -> Option<String> {
    if FAILED.get().is_none()
        && let Err(e) = io::stdout().lock().flush()
    {
        let _ = FAILED.set(e);
    }
    FAILED.get().map(|e| match e.kind() {
        ErrorKind::BrokenPipe => String::new(),
        _ => format!("ivdyn: error: writing the summary to stdout: {e} (the output files were written)"),
    })
}

/// `println!` that goes through [`line`].
macro_rules! say {
    () => {
        $crate::stdout::line(format_args!(""))
    };
    ($($t:tt)*) => {
        $crate::stdout::line(format_args!($($t)*))
    };
}
pub(crate) use say;
