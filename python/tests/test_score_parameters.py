"""The scorer's parameter accuracy (`score_diagnose_cases.param_errors`): relative errors of
the parameters of the (effect, joint) pairs named right, and their errors in standard errors
(`param_z`), checked on hand-made effects whose errors are known by construction; and which
true pairs a case must name (`split_truth`)."""
import os
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "python", "tools"))
from score_diagnose_cases import identifiable, named_right, pairs, param_errors, param_z, shown_truth, split_truth  # noqa: E402

TRUTH = [
    {"name": "coulomb_friction", "joints": ["j1", "j3"], "parameters": {"fc": [0.2, 0.4]}},
    {"name": "torque_gain", "joints": ["j2"], "parameters": {"k": [0.95]}},
    {"name": "torque_ripple", "joints": ["j2"], "parameters": {"period": [0.5], "a": [0.3], "b": [0.4]}},
    {"name": "payload", "joints": [], "parameters": {"mass": 2.0, "com": [0.0, 0.0, 0.1], "inertia": [1e-3] * 6}},
]


def test_relative_errors_of_the_pairs_named_right():
    named = [
        # j1 10 % high, j3 5 % low, named in another joint order than the truth
        {"name": "coulomb_friction", "joints": ["j3", "j1"], "parameters": {"fc": [0.38, 0.22]}},
        # k - 1 = -0.04 against -0.05: 20 % off, though k is within 1.1 % of 0.95
        {"name": "torque_gain", "joints": ["j2"], "parameters": {"k": [0.96]}},
        # (a, b) off by (0, 0.05) on an amplitude of 0.5: 10 %
        {"name": "torque_ripple", "joints": ["j2"], "parameters": {"period": [0.5], "a": [0.3], "b": [0.45]}},
        # COM none (not separable on a re-fit): only the mass is scored
        {"name": "payload", "joints": [], "parameters": {"mass": 2.5, "com": None, "inertia": None}},
    ]
    got = {(e, k, round(x, 9)) for e, k, x in param_errors(TRUTH, named)}
    assert got == {
        ("coulomb_friction", "fc", 0.1),
        ("coulomb_friction", "fc", 0.05),
        ("torque_gain", "k - 1", 0.2),
        ("torque_ripple", "period", 0.0),
        ("torque_ripple", "(a, b)", 0.1),
        ("payload", "mass", 0.25),
    }


def test_errors_in_standard_errors_of_the_pairs_named_right():
    named = [
        # j1 0.02 off with std 0.01 (2 std), j3 0.02 off with std 0.04 (half a std)
        {"name": "coulomb_friction", "joints": ["j3", "j1"], "parameters": {"fc": [0.38, 0.22]},
         "parameters_std": {"fc": [0.04, 0.01]}},
        # k 0.01 off with std 0.005
        {"name": "torque_gain", "joints": ["j2"], "parameters": {"k": [0.96]}, "parameters_std": {"k": [0.005]}},
        # the COM by component (0.1 off in z, std 0.05), no inertia: not scored; no std for the period
        {"name": "payload", "joints": [], "parameters": {"mass": 2.5, "com": [0.0, 0.0, 0.2], "inertia": None},
         "parameters_std": {"mass": 0.25, "com": [0.01, 0.01, 0.05], "inertia": None}},
        {"name": "torque_ripple", "joints": ["j2"], "parameters": {"period": [0.5], "a": [0.3], "b": [0.45]},
         "parameters_std": {"period": None, "a": [0.1], "b": [0.1]}},
    ]
    got = sorted((e, k, round(x, 9)) for e, k, x in param_z(TRUTH, named))
    assert got == sorted([
        ("coulomb_friction", "fc", 2.0), ("coulomb_friction", "fc", 0.5), ("torque_gain", "k", 2.0),
        ("payload", "mass", 2.0), ("payload", "com", 0.0), ("payload", "com", 0.0), ("payload", "com", 2.0),
        ("torque_ripple", "a", 0.0), ("torque_ripple", "b", 0.5),
    ])
    # a named effect without standard errors is not scored
    assert param_z(TRUTH, [{k: v for k, v in e.items() if k != "parameters_std"} for e in named]) == []


def test_effects_or_joints_not_named_are_not_scored():
    named = [{"name": "coulomb_friction", "joints": ["j3"], "parameters": {"fc": [0.4]}},
             {"name": "viscous_friction", "joints": ["j1"], "parameters": {"fv": [1.0]}}]
    assert param_errors(TRUTH, named) == [("coulomb_friction", "fc", pytest.approx(0.0))]


def test_a_pair_below_the_noise_may_be_named_or_not():
    # armature on j1 (effect RMS 5 noise std there) and j3 (0.2 noise std: below the noise)
    manifest = {"joints": ["j1", "j2", "j3"]}
    case = {"effects": [{"name": "armature", "joints": ["j1", "j3"], "parameters": {"ia": [0.5, 0.001]}},
                        {"name": "payload", "joints": [], "parameters": {"mass": 1.0}}],
            "torque_noise_std": [0.01, 0.01, 0.02],
            "oracle": {"effect_rms": [0.05, 0.0, 0.004]}}
    required, optional = split_truth(case, manifest)
    assert required == {("armature", "j1"), ("payload", "")}
    assert optional == {("armature", "j3")}
    assert named_right(required, required, optional)
    assert named_right(required | optional, required, optional)
    # a required pair missed, or a pair beyond the truth, is not right
    assert not named_right({("payload", "")} | optional, required, optional)
    assert not named_right(required | {("armature", "j2")}, required, optional)
    # without the noise level or the effects' RMS every true pair is required
    assert split_truth({"effects": case["effects"]}, manifest) == (pairs(case["effects"]), set())


def test_an_offset_beside_a_spring_is_part_of_the_spring():
    # k (q - q0) + tau0 = k (q - (q0 - tau0 / k)): on j2 the offset 0.4 moves the spring's
    # rest position 0.1 by -0.4 / 2 to -0.1; the offset on j3 has no spring beside it
    truth = [{"name": "joint_spring", "joints": ["j1", "j2"], "parameters": {"k": [5.0, 2.0], "q0": [0.3, 0.1]}},
             {"name": "torque_offset", "joints": ["j2", "j3"], "parameters": {"tau0": [0.4, -0.2]}}]
    shown = identifiable(truth)
    assert shown[0]["parameters"]["q0"] == [0.3, pytest.approx(-0.1)]
    assert shown[1] == {"name": "torque_offset", "joints": ["j3"], "parameters": {"tau0": [-0.2]}}
    assert truth[1]["joints"] == ["j2", "j3"]  # the case itself is left as it is
    manifest = {"joints": ["j1", "j2", "j3"]}
    required, optional = split_truth({"effects": truth}, manifest)
    assert required == {("joint_spring", "j1"), ("joint_spring", "j2"), ("torque_offset", "j3")}
    named = [{"name": "joint_spring", "joints": ["j2"], "parameters": {"k": [2.0], "q0": [-0.1]}}]
    assert param_errors(shown, named) == [("joint_spring", "k", 0.0), ("joint_spring", "q0", pytest.approx(0.0))]
    # offsets without springs: nothing to fold
    assert identifiable(truth[1:]) == truth[1:]


def test_a_lookalike_the_log_does_not_show_is_not_required():
    """A direction-dependent friction whose asymmetry the rigid-body columns hold (0.3 noise
    std left) may be named as such or as Coulomb friction; an offset that keeps 1.5 noise std
    is still required; a spring below the noise but not required stays optional only."""
    asym, off = ("asymmetric_coulomb_friction", "j2"), ("torque_offset", "j3")
    required, optional = {asym, off, ("viscous_friction", "j1")}, {("joint_spring", "j4")}
    parts = {asym: 0.3, off: 1.5, ("joint_spring", "j4"): 0.1}
    req, opt = shown_truth(required, optional, parts)
    assert req == {off, ("viscous_friction", "j1")}
    assert opt == {asym, ("coulomb_friction", "j2"), ("joint_spring", "j4")}
    assert named_right({("coulomb_friction", "j2"), off, ("viscous_friction", "j1")}, req, opt)
    assert named_right({asym, off, ("viscous_friction", "j1")}, req, opt)
    assert not named_right({("coulomb_friction", "j2"), ("viscous_friction", "j1")}, req, opt)
    assert not named_right({("coulomb_friction", "j3"), off, ("viscous_friction", "j1")}, req, opt)
