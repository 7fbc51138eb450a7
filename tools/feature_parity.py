#!/usr/bin/env python3
"""Check that `make test`'s wheel can reuse the Rust test build.

`make test` builds the Python extension (crates/ivdyn-py) in the dev profile in the same target
dir as `cargo test`, so that ivdyn-core, ivdyn, nalgebra and the rest compile once. Cargo reuses a
crate only when its feature set is the same in both builds; this script compares them (`cargo
tree`) and names every crate whose features differ, with the features each build enables. The
fix is to enable the missing features on the side that lacks them (see the feature-parity notes
in crates/ivdyn-py/Cargo.toml and crates/ivdyn-lab/Cargo.toml).

    python3 tools/feature_parity.py      # exit 1 and a list when they differ
"""
import re
import subprocess
import sys

LINE = re.compile(r"^(\S+) v(\S+)(?: \([^)]*\))* \[([^\]]*)\]")


def features(args):
    """{(crate, version): features} of one `cargo tree` invocation (first entry per crate)."""
    out = subprocess.run(["cargo", "tree", *args, "--prefix", "none", "-f", "{p} [{f}]"],
                         check=True, capture_output=True, text=True).stdout
    seen = {}
    for line in out.splitlines():
        m = LINE.match(line)
        if m:
            seen.setdefault((m[1], m[2]), set(filter(None, m[3].split(","))))
    return seen


def main():
    test = features(["--workspace", "--exclude", "ivdyn-py", "--exclude", "ivdyn-benches", "-e", "normal,build,dev"])
    wheel = features(["-p", "ivdyn-py", "-e", "normal,build"])
    differ = [(k, test[k], wheel[k]) for k in sorted(test.keys() & wheel.keys()) if test[k] != wheel[k]]
    for (name, ver), t, w in differ:
        print(f"{name} {ver}: only in the test build: {sorted(t - w) or '-'}; "
              f"only in the wheel build: {sorted(w - t) or '-'}")
    if differ:
        print(f"{len(differ)} crate(s) would compile twice in make test (tools/feature_parity.py)")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
