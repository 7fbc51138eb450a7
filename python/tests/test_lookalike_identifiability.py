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


def test_a_constant_beside_a_spring_on_its_joint_is_spanned(manifest_case):
    """On the terminal joint a direction-dependent friction's constant keeps its whole size
    alone (the links' columns hold none of it); beside a spring on the same joint, whose
    `k (q - q0)` holds any constant through `q0`, none of it shows. The spring keeps its own
    part either way."""
    m, clean = manifest_case
    case = copy.deepcopy(clean)
    asym = {"name": "asymmetric_coulomb_friction", "joints": ["joint_6"],
            "parameters": {"fc_pos": [0.3], "fc_neg": [0.1]}}
    case["effects"] = [asym]
    sig = case["torque_noise_std"]
    alone = li.identifiable_parts(SET, m, case)[("asymmetric_coulomb_friction", "joint_6")]
    assert alone == pytest.approx(0.1 / sig[5], rel=1e-9)
    spring = {"name": "joint_spring", "joints": ["joint_6"], "parameters": {"k": [2.0], "q0": [0.1]}}
    case["effects"] = [asym, spring]
    z = li.identifiable_parts(SET, m, case)
    assert z[("asymmetric_coulomb_friction", "joint_6")] < 1e-9
    case["effects"] = [spring]
    assert z[("joint_spring", "joint_6")] == pytest.approx(li.identifiable_parts(SET, m, case)[("joint_spring", "joint_6")])


def test_no_lookalike_no_work(manifest_case):
    m, clean = manifest_case
    assert li.identifiable_parts(SET, m, clean) == {}


# `detectable` of diagnosis.json (docs/diagnose.md, "What the log can show") against this
# tool: the same projection, computed by the diagnosis from the log's own (filtered) signals
# and by the tool from the case's reference motion with numpy's SVD.
UNIT = {"torque_offset": {"tau0": [1.0]}, "asymmetric_coulomb_friction": {"fc_pos": [2.0], "fc_neg": [0.0]},
        "joint_spring": {"k": [1.0], "q0": [0.0]}, "armature": {"ia": [1.0]}}


def _detectable(sd, m, case):
    import ivdyn
    urdf = os.path.join(sd, os.path.basename(case["urdf"]))
    robot = ivdyn.Robot.from_urdf(urdf, base=m["base"], tip=m["tip"])
    return ivdyn.diagnose(robot, os.path.join(sd, case["log"]), report=False)["detectable"]


@pytest.mark.parametrize("sd", [SET, os.path.join(ROOT, "fixtures", "diagnose_unseen", "rarm27_7j")])
def test_detectable_is_the_part_beyond_the_links(sd):
    """Per unit parameter, the RMS a look-alike's torque keeps beyond the links (the
    diagnosis' `noise_std sigma / detectable`) is the tool's: exactly where the structure says
    (the terminal joint's offset keeps its whole size, joint 1's armature is a link's axial
    inertia: none shown), within 25 % where both see at least one noise std (the log's motion
    is the reference tracked by the simulated arm, differentiated and filtered: the two arms
    here spread 0.91-1.19)."""
    with open(os.path.join(sd, "cases.json")) as f:
        m = json.load(f)
    m["_dir"] = sd
    case = next(c for c in m["cases"] if not c["effects"])
    det = _detectable(sd, m, case)
    n = len(m["joints"])
    assert det["noise_std"] == 2.0 and len(det["sigma"]) == n
    assert det["torque_offset"][n - 1] == pytest.approx(2.0 * det["sigma"][n - 1], rel=1e-6)
    assert det["armature"][0] is None
    sig = case["torque_noise_std"]
    compared = 0
    for kind, par in UNIT.items():
        size = 2.0 if kind == "asymmetric_coulomb_friction" else 1.0
        for j, jn in enumerate(m["joints"]):
            unit = copy.deepcopy(case)
            unit["effects"] = [{"name": kind, "joints": [jn], "parameters": par}]
            tool = li.identifiable_parts(sd, m, unit)[(kind, jn)] * sig[j]   # N m per unit
            d = det[kind][j]
            ours = 0.0 if d is None else det["noise_std"] * det["sigma"][j] * size / d
            if min(tool, ours) >= sig[j]:
                compared += 1
                assert ours == pytest.approx(tool, rel=0.25), (kind, jn, ours, tool)
            elif tool < 1e-9 * size:
                assert d is None, (kind, jn, d)
    assert compared >= 2 * n
