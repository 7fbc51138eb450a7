"""ROS 2 bags written by an independent writer (the `rosbags` package: its own CDR
serialiser, mcap and sqlite3 storage, zstd compression) read as logs, from Python and
from the command line.

One simulated log is written as (a) one MCAP file (mcap-ros2-support), the reference, and
as rosbag2 directories: (b) mcap, (c) mcap split in 3 files, (d) sqlite3, (e) sqlite3
split in 3, (f) mcap compressed per file, (g) sqlite3 compressed per file and split in 2,
(h) mcap and (i) sqlite3 compressed per message. The stamps and values are the same in
every file, so every read must be bit-equal to the reference's: the same samples, and the
same identified base parameters (in memory, streamed, and from the CLI).
"""
import json
import os
import subprocess

import numpy as np
import pytest

import ivdyn
from rosbag_writer import T0_NS, stamps_ns, write_bag, write_single_mcap

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
UR5 = os.path.join(ROOT, "fixtures", "ur5.urdf")
CHAIN = dict(base="base_link", tip="tool0")

BAGS = {
    "mcap": dict(storage="mcap"),
    "mcap_split3": dict(storage="mcap", split=3),
    "sqlite3": dict(storage="sqlite3"),
    "sqlite3_split3": dict(storage="sqlite3", split=3),
    "mcap_zstd_file": dict(storage="mcap", compression="file"),
    "sqlite3_zstd_file_split2": dict(storage="sqlite3", compression="file", split=2),
    "mcap_zstd_message": dict(storage="mcap", compression="message"),
    "sqlite3_zstd_message": dict(storage="sqlite3", compression="message"),
}


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    d = tmp_path_factory.mktemp("rosbag2")
    log = ivdyn.simulate(UR5, **CHAIN, duration=4.0, seed=7, noise=0.05)["log"]
    single = d / "single.mcap"
    write_single_mcap(single, log)
    for name, kw in BAGS.items():
        write_bag(d / name, log, **kw)
    return log, single, d


def bases(rep):
    return np.array([b["value"] for b in rep["base"]])


@pytest.mark.parametrize("name", list(BAGS))
def test_bag_reads_as_the_single_file(written, name):
    log, single, d = written
    bag = d / name
    assert bag.is_dir()
    ref = ivdyn.read_joint_states(single, list(log["joint_names"]))
    got = ivdyn.read_joint_states(bag, list(log["joint_names"]))
    for k in ("t", "q", "qd", "tau"):
        np.testing.assert_array_equal(got[k], ref[k], err_msg=k)
    # and what was written: the simulated values exactly, the stamps to the nanosecond
    np.testing.assert_array_equal(got["q"], log["q"])
    np.testing.assert_array_equal(got["tau"], log["tau"])
    s = stamps_ns(log)
    np.testing.assert_allclose(got["t"], (s - s[0]) * 1e-9, rtol=0, atol=1e-15)
    assert s[0] == T0_NS


@pytest.mark.parametrize("name", list(BAGS))
def test_identify_on_a_bag_equals_the_single_file(written, name):
    _, single, d = written
    ref = ivdyn.identify(UR5, single, **CHAIN)
    got = ivdyn.identify(UR5, d / name, **CHAIN)
    assert got["streamed"] is False
    np.testing.assert_array_equal(bases(got), bases(ref))
    # streamed: file after file (split bags), the held-out split from metadata.yaml's count
    ref_s = ivdyn.identify(UR5, single, **CHAIN, stream=True)
    got_s = ivdyn.identify(UR5, d / name, **CHAIN, stream=True)
    assert ref_s["streamed"] is True and got_s["streamed"] is True
    np.testing.assert_array_equal(bases(got_s), bases(ref_s))


@pytest.mark.parametrize("name", ["mcap_split3", "sqlite3", "sqlite3_zstd_file_split2"])
def test_cli_identify_on_a_bag_equals_the_single_file(written, name, ivdyn_bin, tmp_path):
    _, single, d = written

    def run(log, out):
        subprocess.run([ivdyn_bin, "identify", "--urdf", UR5, "--base", "base_link", "--tip", "tool0",
                        "--log", str(log), "--json", str(out), "--quiet"], check=True, capture_output=True)
        with open(out) as f:
            return json.load(f)

    ref = run(single, tmp_path / "single.json")
    got = run(d / name, tmp_path / "bag.json")
    np.testing.assert_array_equal(bases(got), bases(ref))
    np.testing.assert_array_equal(bases(got), bases(ivdyn.identify(UR5, d / name, **CHAIN)))


def test_bag_without_metadata_is_read_in_split_order(written, tmp_path):
    """metadata.yaml lost: the files are taken by their _N index (not their text order)."""
    log, single, d = written
    bag = tmp_path / "copy"
    os.makedirs(bag)
    src = sorted(p for p in os.listdir(d / "mcap_split3") if p.endswith(".mcap"))
    for i, name in zip([2, 9, 10], src):    # text order of the new names: _10, _2, _9
        os.link(d / "mcap_split3" / name, bag / f"rec_{i}.mcap")
    ref = ivdyn.read_joint_states(single, list(log["joint_names"]))
    got = ivdyn.read_joint_states(bag, list(log["joint_names"]))
    np.testing.assert_array_equal(got["q"], ref["q"])
