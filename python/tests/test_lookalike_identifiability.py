"""python/tools/lookalike_identifiability.py on the wide-motion fixture's random arm
(`fixtures/diagnose_wide/rarm6_6j`), against what the regressor's structure says:
* the terminal joint's torque holds no parameter of the links before it (each link's torque
  acts on the joints inboard of it only), so an offset there keeps all of its size:
  |tau0| / noise std;
* joint 1 turns about the base's fixed axis: a rotor inertia there adds `ia qd_1^2 / 2` to the
  kinetic energy, as link 1's axial inertia does (docs/diagnose.md, "Rotor or link inertia"),
  so the rigid-body columns span an armature on joint 1 whole: nothing left."""
import copy
import json
import os
import sys

import pytest

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")
sys.path.insert(0, os.path.join(ROOT, "python", "tools"))
import lookalike_identifiability as li  # noqa: E402

SET = os.path.join(ROOT, "fixtures", "diagnose_wide", "rarm6_6j")


@pytest.fixture(scope="module")
def manifest_case():
    with open(os.path.join(SET, "cases.json")) as f:
        m = json.load(f)
    m["_dir"] = SET
    return m, next(c for c in m["cases"] if c["name"] == "e30_0fx")


def test_terminal_offset_whole_and_first_armature_spanned(manifest_case):
    m, clean = manifest_case
    case = copy.deepcopy(clean)
    case["effects"] = [
        {"name": "torque_offset", "joints": ["joint_6"], "parameters": {"tau0": [0.05]}},
        {"name": "armature", "joints": ["joint_1"], "parameters": {"ia": [0.2]}},
    ]
    z = li.identifiable_parts(SET, m, case)
    sig = case["torque_noise_std"]
    assert z[("torque_offset", "joint_6")] == pytest.approx(0.05 / sig[5], rel=1e-9)
    assert z[("armature", "joint_1")] < 1e-9      # rounding (ia qdd_1 itself: 19 noise std RMS)


def test_no_lookalike_no_work(manifest_case):
    m, clean = manifest_case
    assert li.identifiable_parts(SET, m, clean) == {}
