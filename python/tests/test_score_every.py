"""The scorer's slower-logger view (`score_diagnose_cases.every_nth`): every N-th message of a
generated bag, once the messages the generator re-published are gone, written as CSV, reads back
as exactly those samples of the original (read independently), a motor current as the CSV's
current column with the options that turn it into torque kept."""
import json
import os
import sys

import numpy as np

import ivdyn

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "python", "tools"))
from score_diagnose_cases import every_nth  # noqa: E402


def _case(robot_dir, name):
    with open(os.path.join(robot_dir, "cases.json")) as f:
        m = json.load(f)
    m["_dir"] = robot_dir
    return m, next(c for c in m["cases"] if c["name"] == name)


def test_every_third_fresh_sample_of_a_jittered_log_without_velocity(tmp_path):
    m, case = _case(os.path.join(ROOT, "fixtures", "diagnose_unseen", "rarm27_7j"), "e30_0fx")
    path, args = every_nth(m, case, str(tmp_path), 3)
    assert args == []
    full = ivdyn.read_joint_states(os.path.join(m["_dir"], case["log"]), m["joints"])
    slow = ivdyn.read_joint_states(path, m["joints"])
    assert full["qd"] is None and slow["qd"] is None
    # the generator's count of re-published messages (sensor_variants.py) leaves this many
    fresh = case["samples"] - case["sensor"]["republished"]
    assert len(full["t"]) == case["samples"] and len(slow["t"]) == (fresh + 2) // 3
    # each kept sample is one of the log's, in order, and none repeats the message before it
    rows = np.searchsorted(full["t"], slow["t"])
    np.testing.assert_array_equal(full["t"][rows], slow["t"])
    assert np.all(np.diff(rows) >= 3)
    np.testing.assert_array_equal(slow["q"], full["q"][rows])
    np.testing.assert_array_equal(slow["tau"], full["tau"][rows])
    assert not np.any(np.all(full["q"][rows[1:]] == full["q"][rows[1:] - 1], axis=1))


def test_a_motor_current_stays_a_current(tmp_path):
    m, case = _case(os.path.join(ROOT, "fixtures", "diagnose_random", "rarm0_6j"), "e05_3fx")
    path, args = every_nth(m, case, str(tmp_path), 4)
    assert "--current-topic" not in args
    assert args[args.index("--effort") + 1] == "current"
    assert args[args.index("--torque-constant") + 1] == "9.701,6.971,3.043,8.722,1.064,4.632"
    full = ivdyn.read_joint_states(os.path.join(m["_dir"], case["log"]), m["joints"])
    slow = ivdyn.read_joint_states(path, m["joints"])
    assert slow["tau"] is None
    np.testing.assert_array_equal(slow["current"], full["tau"][::4])
    np.testing.assert_array_equal(slow["qd"], full["qd"][::4])
