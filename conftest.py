# pytest fixtures shared by python/tests and python/tests_io: the `ivdyn` command-line
# binary. (At the repository root, not in python/: a conftest there would put python/ on
# sys.path and shadow the installed ivdyn package with its source folder.)
import os
import shutil
import subprocess

import pytest

ROOT = os.path.dirname(os.path.abspath(__file__))

# Ray starts its workers at nice 15; `make test` runs the Python suites beside the Rust
# tests, which then take nearly all of both cores from them: the synthetic fleet's Ray run
# took 80-120 s beside two busy processes (17 s alone), 28-40 s with its workers at nice 0.
# Every runtime the tests start (ray.init reads this when it launches the raylet) gets it.
os.environ.setdefault("RAY_worker_niceness", "0")


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


_RAY_DIRS = []


def ray_temp_dir():
    """A short private directory for a Ray runtime's session files, removed when the session
    (or xdist worker) finishes (`pytest_sessionfinish`)."""
    import tempfile

    tmp = tempfile.mkdtemp(prefix="ivr", dir="/tmp")
    _RAY_DIRS.append(tmp)
    return tmp


def pytest_sessionfinish(session, exitstatus):
    """Shut down the runtime this process started and remove its session files (xdist
    workers end without running exit hooks, which left them in /tmp)."""
    if _RAY_DIRS:
        import ray

        if ray.is_initialized():
            ray.shutdown()
        for d in _RAY_DIRS:
            shutil.rmtree(d, ignore_errors=True)


@pytest.fixture(scope="session")
def ray_dir():
    """`ray_temp_dir` for tests that start a Ray runtime of their own."""
    return ray_temp_dir


@pytest.fixture(scope="module")
def ray_runtime():
    """A local Ray runtime of 2 CPUs in a short private directory (Ray's socket paths must
    stay under ~107 characters; two xdist workers must not share a session), started when
    none is running and left running for the next module: each xdist worker process starts
    at most one (`make test` gives each file to one worker, --dist loadfile; Ray shuts it
    down at exit). A test that needs a runtime of its own shuts this one down first."""
    import ray

    if not ray.is_initialized():
        ray.init(num_cpus=2, include_dashboard=False, _temp_dir=ray_temp_dir(), log_to_driver=False)
    return ray


# `make test` skips nothing: a test that would skip (a missing package, a missing binary)
# fails instead, with the reason, so that a suite never passes with a part of it unrun.
@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    rep = outcome.get_result()
    if rep.skipped and not hasattr(rep, "wasxfail"):
        rep.outcome = "failed"
        rep.longrepr = f"skipped, and this suite skips nothing: {rep.longrepr}"
