//! Progress of the long steps: the [`Progress`] trait that front ends implement (the
//! command line draws bars, Python calls a callback) and the [`Stage`] guard the library
//! opens around each step.

use std::sync::Arc;

// ---------------------------------------------------------------------------------------
// Progress reporting
// ---------------------------------------------------------------------------------------

/// Receives progress of the long steps (the command line draws bars with it).
pub trait Progress: Send + Sync {
    /// A step starts, `total` units of work (0: unknown).
    fn begin(&self, stage: &str, total: u64);
    /// `n` more units done.
    fn advance(&self, n: u64);
    /// The step is over.
    fn end(&self);
}

/// Shared progress sink.
pub type ProgressSink = Option<Arc<dyn Progress>>;

/// A step in progress: `begin` on creation, `end` when dropped.
pub struct Stage<'a>(&'a ProgressSink);
impl<'a> Stage<'a> {
    /// Starts step `name` of `total` units (0: unknown) on `p`.
    pub fn begin(p: &'a ProgressSink, name: &str, total: u64) -> Self {
        if let Some(p) = p {
            p.begin(name, total);
        }
        Stage(p)
    }
    /// `n` more units done.
    pub fn advance(&self, n: u64) {
        if let Some(p) = self.0 {
            p.advance(n);
        }
    }
}
impl Drop for Stage<'_> {
    fn drop(&mut self) {
        if let Some(p) = self.0 {
            p.end();
        }
    }
}
