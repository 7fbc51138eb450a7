# pytest fixtures shared by python/tests and python/tests_io: the `ivdyn` command-line
# binary. (At the repository root, not in python/: a conftest there would put python/ on
# sys.path and shadow the installed ivdyn package with its source folder.)
import os
import shutil
import subprocess

import pytest

ROOT = os.path.dirname(os.path.abspath(__file__))


def ivdyn_exe():
    """The `ivdyn` binary: $IVDYN_BIN (`make test` passes the one its Rust test build
    made), else target/debug/ivdyn, built with cargo when missing."""
    exe = os.environ.get("IVDYN_BIN") or os.path.join(ROOT, "target", "debug", "ivdyn")
    if not os.path.exists(exe):
        cargo = shutil.which("cargo")
        assert cargo is not None, "cargo must be on PATH to build the ivdyn binary"
        subprocess.run([cargo, "build", "-q", "-p", "ivdyn-cli", "--bin", "ivdyn"], cwd=ROOT, check=True)
        exe = os.path.join(ROOT, "target", "debug", "ivdyn")
    return exe


@pytest.fixture(scope="session")
def ivdyn_bin():
    return ivdyn_exe()
