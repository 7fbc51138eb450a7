//! Smoke test of the `ivdyn` binary.
use crate::util;

#[test]
fn cli_help_lists_commands() {
    let out = util::ivdyn(&["--help"]);
    assert!(out.status.success());
    let s = String::from_utf8_lossy(&out.stdout);
    for c in ["identify", "payload", "simulate"] {
        assert!(s.contains(c), "{s}");
    }
}
