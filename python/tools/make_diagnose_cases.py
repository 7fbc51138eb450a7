#!/usr/bin/env python3
"""Generate the model-gap diagnosis test data in fixtures/diagnose/ (UR5) and
fixtures/diagnose_panda/ (Franka Panda) (issue 7, item 6).

MuJoCo (`mujoco` from PyPI) plays the "real robot": it loads the robot's URDF (fixtures/ur5.urdf,
or for the Panda fixtures/panda.urdf without its fingers and with zero joint damping, written as
panda_arm.urdf; neither file has <visual>/<collision>; MuJoCo fuses the static root into the
world body), contacts and joint limits are disabled, and each hidden effect is added through
MuJoCo's own mechanisms:

    coulomb_friction  joint `frictionloss`, solref_friction (2 ms, 1) (constraint force; stick
                      phases near v = 0)
    viscous_friction  joint `damping`               (integrated implicitly by MuJoCo's Euler)
    armature          joint `armature`              (exact)
    joint_spring      joint `stiffness` + `springref` (exact: tau_spring = k (q - q0))
    payload           a body welded to the terminal link (exact rigid body)
    torque_offset     added on the sensor side to the logged effort

The effects of real drives (issue 15; set `--robot ur5_drives`, fixtures/diagnose_drives/, and the
CAD sets of make_cad_cases.py), each with MuJoCo's own mechanism where it has one, otherwise as a
generalized force computed each step by its own formula (`qfrc_applied`, explicit in the state of
the step), or as a sensor model applied to the recorded torque:

    asymmetric_coulomb_friction  joint `frictionloss` = (fc_pos + fc_neg) / 2 (constraint force)
                      plus the applied force -(fc_pos - fc_neg) / 2 min(1, |qd| / 1e-3 rad/s)
                      (the direction-dependent part: a constant while the joint moves)
    smooth_coulomb_friction  applied force -fc tanh(qd / vs)
    load_dependent_friction  joint `frictionloss` set before every step to mu |tau_load|, the
                      joint's rigid-body torque from MuJoCo's own `mj_rne` at the step's state
                      and the previous step's acceleration (constraint force)
    torque_ripple     applied force -(a sin(2 pi q / period) + b cos(2 pi q / period)) (cogging)
    torque_gain       sensor: the logged effort is k x the applied joint torque
    time_delay        sensor: the logged effort of sample k is the applied joint torque at
                      t_k - delay_s (linear interpolation; the first sample's before the log)

    stribeck_friction  joint `frictionloss` set before every step to fc + fs exp(-(qd/vs)^2) at
                      the step's velocity (constraint force: stick phases hold up to fc + fs,
                      the static friction; the level falls to fc as the joint speeds up); with
                      `STRIBECK = "applied"` (make_cad_cases.py --stribeck applied) the applied
                      force -(fc + fs exp(-(qd/vs)^2)) sign(qd) instead

Friction-loss levels of several kinds on one joint add up (`load_friction`: the model's Coulomb
and direction-dependent levels plus the ones set every step); until 2026-12-07 each kind set the
level alone, and a Coulomb friction beside a load-dependent, Stribeck or direction-dependent one
on the same joint was in the case's truth but not in its simulation.

The UR5 and Panda fixtures of this script have no Stribeck friction (their manifests say so);
make_cad_cases.py draws it with `--kinds`.

Before anything is simulated, MuJoCo's inverse dynamics (`mj_inverse`, qacc given) is checked
against ivdyn's `rnea` on the clean model (and the mass matrices against each other); the script
stops if they differ by more than 1e-10 relative.

The arm follows a sum-of-sinusoids reference per joint at 1 ms steps (semi-implicit Euler) with
a PD tracking controller whose gains are scaled by the nominal mass matrix:
    tau = rnea(q_ref, qd_ref, qdd_ref) + M(q_ref) (kp e + kd ed)
(nominal model = ivdyn on the robot's clean URDF). The logged effort is the applied actuator torque,
as a joint torque sensor would measure it, plus the sensor-side offset (torque_offset case only)
and Gaussian noise; positions are quantised like an encoder; velocity is MuJoCo's joint
velocity (omitted in one case).

Deterministic (numpy default_rng seeds per case, fixed stamps). Run from the repository root:

    .venv/bin/python python/tools/make_diagnose_cases.py [--robot ur5|panda] [--out DIR] [--duration S]

Default: --robot ur5, fixtures/diagnose/ (panda: fixtures/diagnose_panda/), 2 s per case. Writes
<case>.mcap, the 5 %-off nominal URDF (ur5_inertia5.urdf / panda_inertia5.urdf), for the Panda
panda_arm.urdf, and cases.json. The UR5 output is byte-identical to what this script wrote
before the Panda was added.
"""
import argparse
import json
import math
import os
import sys
import xml.etree.ElementTree as ET

import numpy as np
import mujoco
from mcap.writer import CompressionType
from mcap_ros2.writer import Writer

import ivdyn

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
DT = 1e-3                                      # default step = log period (1 kHz)
T0_NS = 1_700_000_000_000_000_000
# Sensor quanta are powers of two so that the float64 values compress (the logs stay small).
Q_RES = 2.0 ** -18                             # rad, encoder quantum (~1.65e6 counts/rev)
ENCODER_COUNTS = round(2 * math.pi / Q_RES)
TAU_RES = 2.0 ** -14                           # N m, torque sensor quantum (6.1e-5 N m)
QD_RES = 2.0 ** -16                            # rad/s, velocity quantum (1.5e-5 rad/s)
WN, ZETA = 2 * math.pi * 10.0, 0.7             # PD bandwidth (rad/s) and damping ratio
KP, KD = WN * WN, 2 * ZETA * WN
AGREEMENT_TOL = 1e-10

from make_log_fixtures import JOINT_STATE  # noqa: E402  (the one JointState message definition of our Python writers)

# ----------------------------------------------------------------------------- UR5 cases
# `effects` uses the diagnosis.json vocabulary of ../shared/DESIGN.md.
PAYLOAD_A = {"mass": 2.0, "com": [0.02, 0.13, -0.01],
             "inertia": [0.0040, 0.0002, 0.0, 0.0030, 0.0, 0.0045]}
PAYLOAD_B = {"mass": 1.2, "com": [-0.015, 0.11, 0.02],
             "inertia": [0.0020, 0.0, 0.0001, 0.0025, 0.0, 0.0018]}
UR5_CASES = [
    {"name": "clean_a", "seed": 101, "effects": []},
    {"name": "clean_b", "seed": 102, "effects": []},
    {"name": "coulomb", "seed": 103, "effects": [
        {"name": "coulomb_friction", "joints": ["shoulder_lift_joint", "elbow_joint", "wrist_1_joint"],
         "parameters": {"fc": [4.0, 2.5, 0.8]}}]},
    {"name": "viscous", "seed": 104, "effects": [
        {"name": "viscous_friction", "joints": ["shoulder_pan_joint", "elbow_joint", "wrist_2_joint"],
         "parameters": {"fv": [5.0, 3.0, 0.6]}}]},
    {"name": "armature", "seed": 105, "effects": [
        {"name": "armature", "joints": ["shoulder_pan_joint", "wrist_1_joint", "wrist_3_joint"],
         "parameters": {"ia": [0.5, 0.15, 0.05]}}]},
    {"name": "payload", "seed": 106, "effects": [
        {"name": "payload", "joints": [], "parameters": PAYLOAD_A}]},
    {"name": "torque_offset", "seed": 107, "effects": [
        {"name": "torque_offset", "joints": ["shoulder_lift_joint", "wrist_1_joint", "wrist_3_joint"],
         "parameters": {"tau0": [1.5, -0.5, 0.2]}}]},
    {"name": "joint_spring", "seed": 108, "effects": [
        {"name": "joint_spring", "joints": ["shoulder_lift_joint", "wrist_2_joint"],
         "parameters": {"k": [30.0, 2.0], "q0": [-1.0, 0.0]}}]},
    {"name": "viscous_payload", "seed": 109, "effects": [
        {"name": "viscous_friction", "joints": ["shoulder_lift_joint", "wrist_1_joint"],
         "parameters": {"fv": [4.0, 0.5]}},
        {"name": "payload", "joints": [], "parameters": PAYLOAD_B}]},
    {"name": "coulomb_novel", "seed": 110, "velocity": False, "effects": [
        {"name": "coulomb_friction", "joints": ["elbow_joint", "wrist_2_joint"],
         "parameters": {"fc": [2.0, 0.6]}}]},
    {"name": "inertia5_coulomb", "seed": 111, "nominal": "ur5_inertia5.urdf", "effects": [
        {"name": "coulomb_friction", "joints": ["shoulder_lift_joint", "elbow_joint"],
         "parameters": {"fc": [3.0, 2.0]}}]},
]

# ----------------------------------------------------------------------------- Panda cases
# Joints and magnitudes differ from the UR5 set; magnitudes are of the order reported for the
# Panda (friction ~0.5-2 N m, viscous ~0.2-1 N m s/rad, reflected rotor inertia ~0.05-0.3 kg m^2,
# a gripped part of ~1 kg). Payload frame: panda_link7 (ivdyn's terminal link, flange at
# z = 0.107 m, hand fused into it); the COM sits in the gripper, off the flange axis.
P = "panda_joint"
PANDA_PAYLOAD = {"mass": 1.0, "com": [0.03, -0.02, 0.19],
                 "inertia": [0.0025, 0.0001, 0.0, 0.0020, -0.0002, 0.0012]}
PANDA_CASES = [
    {"name": "clean_a", "seed": 201, "effects": []},
    {"name": "clean_b", "seed": 202, "effects": []},
    {"name": "coulomb", "seed": 203, "effects": [
        {"name": "coulomb_friction", "joints": [P + "1", P + "4", P + "6"],
         "parameters": {"fc": [1.5, 1.0, 0.5]}}]},
    {"name": "viscous", "seed": 204, "effects": [
        {"name": "viscous_friction", "joints": [P + "2", P + "5", P + "7"],
         "parameters": {"fv": [0.8, 0.3, 0.2]}}]},
    {"name": "armature", "seed": 205, "effects": [
        {"name": "armature", "joints": [P + "2", P + "4", P + "6"],
         "parameters": {"ia": [0.3, 0.15, 0.05]}}]},
    {"name": "payload", "seed": 206, "effects": [
        {"name": "payload", "joints": [], "parameters": PANDA_PAYLOAD}]},
    {"name": "torque_offset", "seed": 207, "effects": [
        {"name": "torque_offset", "joints": [P + "3", P + "5", P + "7"],
         "parameters": {"tau0": [0.6, -0.3, 0.2]}}]},
    {"name": "joint_spring", "seed": 208, "effects": [
        {"name": "joint_spring", "joints": [P + "3", P + "6"],
         "parameters": {"k": [12.0, 6.0], "q0": [0.3, 1.2]}}]},
    # Coulomb and viscous friction together on the same joints, as on real arms
    {"name": "coulomb_viscous", "seed": 209, "effects": [
        {"name": "coulomb_friction", "joints": [P + "2", P + "6"],
         "parameters": {"fc": [1.2, 0.6]}},
        {"name": "viscous_friction", "joints": [P + "2", P + "6"],
         "parameters": {"fv": [0.6, 0.3]}}]},
    # 500 Hz: simulated, controlled and logged at 2 ms steps
    {"name": "armature_500hz", "seed": 210, "rate_hz": 500.0, "effects": [
        {"name": "armature", "joints": [P + "1", P + "5"],
         "parameters": {"ia": [0.25, 0.06]}}]},
    {"name": "viscous_novel", "seed": 211, "velocity": False, "effects": [
        {"name": "viscous_friction", "joints": [P + "1", P + "6"],
         "parameters": {"fv": [0.5, 0.25]}}]},
    {"name": "inertia5_offset", "seed": 212, "nominal": "panda_inertia5.urdf", "effects": [
        {"name": "torque_offset", "joints": [P + "2", P + "6"],
         "parameters": {"tau0": [0.8, -0.25]}}]},
    {"name": "noise2x_coulomb", "seed": 213, "noise_scale": 2.0, "effects": [
        {"name": "coulomb_friction", "joints": [P + "3", P + "7"],
         "parameters": {"fc": [0.8, 0.3]}}]},
]

# ----------------------------------------------------------------------------- UR5, drives
# The effects of real drives (issue 15), one per case on two joints, each 5-15 noise std of RMS
# torque on its joints along the motion (UR5 noise: 0.15, 0.15, 0.08, 0.03, 0.03, 0.02 N m).
DRIVE_CASES = [
    {"name": "asymmetric_coulomb", "seed": 301, "effects": [
        {"name": "asymmetric_coulomb_friction", "joints": ["shoulder_lift_joint", "elbow_joint"],
         "parameters": {"fc_pos": [4.0, 1.2], "fc_neg": [2.5, 2.0]}}]},
    {"name": "smooth_coulomb", "seed": 302, "effects": [
        {"name": "smooth_coulomb_friction", "joints": ["elbow_joint", "wrist_1_joint"],
         "parameters": {"fc": [2.0, 0.6], "vs": [0.25, 0.3]}}]},
    {"name": "load_dependent", "seed": 303, "effects": [
        {"name": "load_dependent_friction", "joints": ["shoulder_lift_joint", "elbow_joint"],
         "parameters": {"mu": [0.05, 0.08]}}]},
    {"name": "torque_gain", "seed": 304, "effects": [
        {"name": "torque_gain", "joints": ["shoulder_lift_joint", "elbow_joint"],
         "parameters": {"k": [0.85, 1.15]}}]},
    {"name": "torque_ripple", "seed": 305, "effects": [
        {"name": "torque_ripple", "joints": ["shoulder_pan_joint", "wrist_1_joint"],
         "parameters": {"period": [2 * math.pi / 8, 2 * math.pi / 8], "a": [0.8, 0.15], "b": [0.6, -0.2]}}]},
    {"name": "time_delay", "seed": 306, "effects": [
        {"name": "time_delay", "joints": ["shoulder_lift_joint", "elbow_joint"],
         "parameters": {"delay_s": [0.015, 0.012]}}]},
]

# ----------------------------------------------------------------------------- robots
ROBOTS = {
    "ur5": {
        "source_urdf": "fixtures/ur5.urdf",
        "urdf": None,                          # used as is
        "base": "base_link", "tip": "tool0", "terminal_link": "wrist_3_link",
        "out": os.path.join(ROOT, "fixtures", "diagnose"),
        "torque_noise": [0.15, 0.15, 0.08, 0.03, 0.03, 0.02],   # N m, std per joint (URDF order)
        # Trajectory centres (rad) per joint; amplitudes are drawn per case.
        "centres": [0.0, -1.3, 1.2, -1.2, 1.4, 0.0],
        # amplitudes keep |qd_ref| < 3.1 rad/s (UR5 velocity limits 3.15 / 3.2 rad/s)
        "amp_scale": 0.6 * np.array([0.5, 0.35, 0.4, 0.5, 0.5, 0.6]),
        "acc_limits": None,
        "check_reference": False,              # the UR5 set predates the check (|qd_ref| up to 3.1 rad/s)
        "perturbed": "ur5_inertia5.urdf",
        "moving_links": ["shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link",
                         "wrist_2_link", "wrist_3_link"],
        "cases": UR5_CASES,
    },
    "panda": {
        "source_urdf": "fixtures/panda.urdf",
        "urdf": "panda_arm.urdf",              # derived by panda_arm_urdf()
        "base": "panda_link0", "tip": "panda_hand", "terminal_link": "panda_link7",
        "out": os.path.join(ROOT, "fixtures", "diagnose_panda"),
        "torque_noise": [0.1, 0.1, 0.1, 0.1, 0.03, 0.03, 0.02],
        # inside the joint limits (j4 in [-3.07, -0.07], j6 in [-0.02, 3.75]), near the
        # usual working pose, >= 0.9 rad from every limit including the motion
        "centres": [0.3, -0.4, -0.3, -2.0, 0.4, 1.9, 0.7],
        # amplitudes keep |qd_ref| below 90 % of the velocity limits (2.175 rad/s joints 1-4,
        # 2.61 rad/s joints 5-7; checked) and |qdd_ref| below acc_limits
        "amp_scale": np.array([0.19, 0.10, 0.11, 0.15, 0.19, 0.21, 0.28]),
        # Franka Control Interface documentation, joint acceleration limits (rad/s^2)
        "acc_limits": [15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0],
        "check_reference": True,
        "perturbed": "panda_inertia5.urdf",
        "moving_links": ["panda_link1", "panda_link2", "panda_link3", "panda_link4", "panda_link5",
                         "panda_link6", "panda_link7", "panda_hand"],
        "cases": PANDA_CASES,
    },
}
ROBOTS["ur5_drives"] = dict(ROBOTS["ur5"], out=os.path.join(ROOT, "fixtures", "diagnose_drives"),
                            cases=DRIVE_CASES, check_reference=False)


def panda_arm_urdf(path_out):
    """fixtures/panda.urdf without the two finger links and joints (the arm ends at the hand),
    with every `<dynamics>` set to damping = friction = 0 (the file has damping 0.003 and
    non-standard attributes; the nominal model carries no drive terms, as for the UR5, so
    that the hidden effects listed in cases.json are the whole truth)."""
    tree = ET.parse(os.path.join(ROOT, "fixtures", "panda.urdf"))
    root = tree.getroot()
    fingers = {"panda_leftfinger", "panda_rightfinger"}
    for link in list(root.findall("link")):
        if link.get("name") in fingers:
            root.remove(link)
    for joint in list(root.findall("joint")):
        if joint.find("child").get("link") in fingers:
            root.remove(joint)
    zero_dynamics(root)
    tree.write(path_out, encoding="utf-8", xml_declaration=True)


def zero_dynamics(root):
    """Every joint's <dynamics> set to damping = friction = 0 (the nominal model carries no
    drive terms: the hidden effects of cases.json are the whole truth)."""
    for joint in root.findall("joint"):
        dyn = joint.find("dynamics")
        if dyn is not None:
            dyn.attrib.clear()
            dyn.set("damping", "0.0")
            dyn.set("friction", "0.0")


# ----------------------------------------------------------------------------- models
# The friction-loss constraint's solref: "stiff" = (2 dt, 1), the stiffest stable one at this
# step; "mujoco" = MuJoCo's own default (0.02 s, 1), left untouched. With the default's 0.02 s
# time constant the constraint is soft: below full slip it opposes ~90 % of the joint's net
# torque and a joint creeps at |f| < fc, so on light joints the force reaches fc only above a
# few tenths of a rad/s (make_cad_cases.py --friction-solref).
FRICTION_SOLREF = "stiff"
# how Stribeck friction is injected: "constraint" (the joint's frictionloss set every step, stick
# phases held up to fc + fs) or "applied" (-(fc + fs exp(-(qd/vs)^2)) sign(qd) as an applied
# force, no stick phase: the formula a person without MuJoCo's constraint would write)
STRIBECK = "constraint"


def friction_solref(joint, dt):
    if FRICTION_SOLREF == "stiff":
        joint.solref_friction = [2 * dt, 1.0]


def mujoco_model(cfg, effects, joint_names, dt=DT):
    """MuJoCo model of the robot's clean URDF (or its own MJCF, `cfg["mjcf_path"]`, when it has
    one: the random arms) with the given effects (sensor-side ones ignored)."""
    spec = mujoco.MjSpec.from_file(cfg.get("mjcf_path") or cfg["urdf_path"])
    joints = {j.name: j for j in spec.joints}
    assert [j.name for j in spec.joints] == joint_names, [j.name for j in spec.joints]
    for j in spec.joints:   # the clean model has no passive joint terms
        assert j.frictionloss == 0 and j.armature == 0 and j.stiffness[0] == 0 and j.damping[0] == 0, j.name
    for e in effects:
        p = e["parameters"]
        for i, jn in enumerate(e["joints"]):
            j = joints[jn]
            # friction-loss levels of several kinds on one joint add up (the clean model has none)
            if e["name"] == "coulomb_friction":
                j.frictionloss += p["fc"][i]
                friction_solref(j, dt)
            elif e["name"] == "viscous_friction":
                j.damping = [p["fv"][i], 0.0, 0.0]   # [linear, polynomial terms]
            elif e["name"] == "armature":
                j.armature = p["ia"][i]
            elif e["name"] == "joint_spring":
                j.stiffness = [p["k"][i], 0.0, 0.0]
                j.springref = p["q0"][i]
            elif e["name"] == "asymmetric_coulomb_friction":
                j.frictionloss += 0.5 * (p["fc_pos"][i] + p["fc_neg"][i])
                friction_solref(j, dt)
            elif e["name"] == "load_dependent_friction" or (e["name"] == "stribeck_friction"
                                                              and STRIBECK == "constraint"):
                friction_solref(j, dt)   # frictionloss itself is set every step
        if e["name"] == "payload":
            parent = spec.body(cfg["terminal_link"])
            b = parent.add_body(name="payload")
            b.pos = [0.0, 0.0, 0.0]
            b.explicitinertial = True
            b.mass = p["mass"]
            b.ipos = p["com"]
            ixx, ixy, ixz, iyy, iyz, izz = p["inertia"]
            b.fullinertia = [ixx, iyy, izz, ixy, ixz, iyz]   # MuJoCo order
    m = spec.compile()
    m.opt.timestep = dt
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_LIMIT
    return m


def perturbed_urdf(cfg, path_out, seed):
    """The clean URDF with every moving link's mass and inertia tensor scaled by 1 +- 5 %
    (random signs, drawn in file order); COMs unchanged. Returns {link: factor}."""
    rng = np.random.default_rng(seed)

    def draw():
        f = 1.0 + 0.05 * float(rng.choice([-1.0, 1.0]))
        return f, f, 1.0
    factors = scale_inertials(cfg, path_out, draw)
    return {name: f[0] for name, f in factors.items()}


def scale_inertials(cfg, path_out, draw):
    """The clean URDF with each moving link's mass, inertia tensor (about the COM) and COM
    scaled by the factors `draw()` returns for it, in file order (a COM factor of 1 leaves the
    COM as written). Returns {link: (mass, inertia, com) factors}."""
    tree = ET.parse(cfg["urdf_path"])
    factors = {}
    for link in tree.getroot().findall("link"):
        name = link.get("name")
        if name not in cfg["moving_links"]:
            continue
        fm, fi, fc = factors[name] = draw()
        inert = link.find("inertial")
        mass = inert.find("mass")
        mass.set("value", repr(float(mass.get("value")) * fm))
        it = inert.find("inertia")
        for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"):
            it.set(k, repr(float(it.get(k)) * fi))
        origin = inert.find("origin")
        if fc != 1.0 and origin is not None and origin.get("xyz"):
            origin.set("xyz", " ".join(repr(float(v) * fc) for v in origin.get("xyz").split()))
    tree.write(path_out, encoding="utf-8", xml_declaration=True)
    return factors


def check_agreement(robot, n=200, seed=0, cfg=None):
    """Max relative difference |mj_inverse - rnea| / max(|rnea|_inf, 1) and same for M."""
    cfg = cfg if cfg is not None else robot_config("ur5")
    m = mujoco_model(cfg, [], robot.joint_names)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(seed)
    worst_tau = worst_m = 0.0
    M = np.zeros((m.nv, m.nv))
    for _ in range(n):
        q = rng.uniform(-math.pi, math.pi, m.nq)
        qd = rng.uniform(-3, 3, m.nv)
        qdd = rng.uniform(-10, 10, m.nv)
        d.qpos[:], d.qvel[:], d.qacc[:] = q, qd, qdd
        mujoco.mj_inverse(m, d)
        ti = robot.rnea(q, qd, qdd)
        worst_tau = max(worst_tau, np.max(np.abs(d.qfrc_inverse - ti)) / max(np.max(np.abs(ti)), 1.0))
        mujoco.mj_fullM(m, d, M)
        Mi = robot.mass_matrix(q)
        worst_m = max(worst_m, np.max(np.abs(M - Mi)) / max(np.max(np.abs(Mi)), 1.0))
    return worst_tau, worst_m


def robot_config(name, out=None):
    """The robot's settings with `urdf_path` (the clean URDF MuJoCo and ivdyn load) and `out`.
    For a derived URDF (Panda) the file is written into `out` first."""
    cfg = dict(ROBOTS[name])
    cfg["name"] = name
    if out is not None:
        cfg["out"] = out
    if cfg["urdf"] is None:
        cfg["urdf_path"] = os.path.join(ROOT, cfg["source_urdf"])
    else:
        cfg["urdf_path"] = os.path.join(cfg["out"], cfg["urdf"])
        if not os.path.exists(cfg["urdf_path"]) or out is not None:
            os.makedirs(cfg["out"], exist_ok=True)
            panda_arm_urdf(cfg["urdf_path"])
    return cfg


# ----------------------------------------------------------------------------- trajectory
def reference(cfg, seed, t):
    """Sum of 3 harmonics per joint (base frequency 0.4-0.6 Hz, or `cfg["f0_range"]`), centred on
    the robot's centres."""
    centres = np.array(cfg["centres"])
    rng = np.random.default_rng(seed)
    n = len(centres)
    f0 = rng.uniform(*cfg.get("f0_range", (0.4, 0.6)))
    q = np.tile(centres, (len(t), 1))
    qd = np.zeros_like(q)
    qdd = np.zeros_like(q)
    amp_scale = cfg["amp_scale"]
    for j in range(n):
        for h in (1, 2, 3):
            a = amp_scale[j] * rng.uniform(0.5, 1.0) / h
            w = 2 * math.pi * f0 * h * rng.uniform(0.9, 1.1)
            ph = rng.uniform(0, 2 * math.pi)
            q[:, j] += a * np.sin(w * t + ph)
            qd[:, j] += a * w * np.cos(w * t + ph)
            qdd[:, j] += -a * w * w * np.sin(w * t + ph)
    return q, qd, qdd


def within_velocity_limits(cfg, robot_urdf, names, qr, qdr, qddr):
    """The reference with each joint's motion about its centre scaled down where its speed
    passes 90 % of the URDF velocity limit (to 89 %; others unchanged): over a long log the
    three harmonics, whose frequencies are not exact multiples, line up to the sum of their
    peak speeds, which a 2 s log does not reach. Prints what it scaled."""
    tree = ET.parse(robot_urdf)
    limits = {j.get("name"): j.find("limit") for j in tree.getroot().findall("joint")}
    centres = np.array(cfg["centres"])
    qr, qdr, qddr = qr.copy(), qdr.copy(), qddr.copy()
    for i, jn in enumerate(names):
        lim = limits.get(jn)
        peak = np.abs(qdr[:, i]).max()
        if lim is None or lim.get("velocity") is None or peak <= 0.9 * float(lim.get("velocity")):
            continue
        k = 0.89 * float(lim.get("velocity")) / peak
        qr[:, i] = centres[i] + k * (qr[:, i] - centres[i])
        qdr[:, i] *= k
        qddr[:, i] *= k
        print(f"    {jn}: reference scaled by {k:.3f} (peak speed {peak:.2f} rad/s, limit {lim.get('velocity')})")
    return qr, qdr, qddr


def check_reference(cfg, robot_urdf, case, qr, qdr, qddr):
    """Refuses a reference outside 90 % of the URDF velocity limits, closer than 0.2 rad to a
    joint limit, or above the robot's acceleration limits (when known)."""
    tree = ET.parse(robot_urdf)
    limits = {j.get("name"): j.find("limit") for j in tree.getroot().findall("joint")}
    for i, jn in enumerate(case["joint_names"]):
        lim = limits[jn]
        if lim is None:
            continue
        lo, hi, vmax = float(lim.get("lower")), float(lim.get("upper")), float(lim.get("velocity"))
        if qr[:, i].min() < lo + 0.2 or qr[:, i].max() > hi - 0.2:
            raise RuntimeError(f"{case['name']}: {jn} reference [{qr[:, i].min():.2f}, {qr[:, i].max():.2f}] "
                               f"within 0.2 rad of its limits [{lo}, {hi}]")
        if np.abs(qdr[:, i]).max() > 0.9 * vmax:
            raise RuntimeError(f"{case['name']}: {jn} |qd_ref| {np.abs(qdr[:, i]).max():.2f} > 90 % of {vmax} rad/s")
        if cfg["acc_limits"] is not None and np.abs(qddr[:, i]).max() > cfg["acc_limits"][i]:
            raise RuntimeError(f"{case['name']}: {jn} |qdd_ref| {np.abs(qddr[:, i]).max():.2f} > "
                               f"{cfg['acc_limits'][i]} rad/s^2")


def drive_force(effects, names, q, qd):
    """The generalized force (N m per joint) the applied-force drive effects exert at the state
    (q, qd): the passive force on the joint, opposite to the torque the drive must add."""
    f = np.zeros(len(names))
    for e in effects:
        p = e["parameters"]
        for i, jn in enumerate(e["joints"]):
            j = names.index(jn)
            if e["name"] == "asymmetric_coulomb_friction":
                f[j] -= 0.5 * (p["fc_pos"][i] - p["fc_neg"][i]) * min(1.0, abs(qd[j]) / 1e-3)
            elif e["name"] == "smooth_coulomb_friction":
                f[j] -= p["fc"][i] * math.tanh(qd[j] / p["vs"][i])
            elif e["name"] == "stribeck_friction" and STRIBECK == "applied":
                level = p["fc"][i] + p["fs"][i] * math.exp(-(qd[j] / p["vs"][i]) ** 2)
                f[j] -= level * float(np.sign(qd[j]))
            elif e["name"] == "torque_ripple":
                w = 2 * math.pi / p["period"][i]
                f[j] -= p["a"][i] * math.sin(w * q[j]) + p["b"][i] * math.cos(w * q[j])
    return f


def load_friction(m, d, effects, names, static):
    """Sets the `frictionloss` of each joint with a load-dependent or Stribeck friction to its
    static level `static` (the model's Coulomb and direction-dependent friction there) plus
    mu |tau_load| (MuJoCo's rigid-body torque `mj_rne` at the current state and the previous
    step's acceleration) and fc + fs exp(-(qd / vs)^2) at the current velocity: the kinds add
    up. (Until 2026-12-07 each set the level alone, and the Coulomb or direction-dependent
    friction of the same joint was left out of the simulation though in the case's truth.)"""
    level = {}
    for e in effects:
        if e["name"] == "stribeck_friction" and STRIBECK == "constraint":
            p = e["parameters"]
            for i, jn in enumerate(e["joints"]):
                j = names.index(jn)
                level[j] = level.get(j, 0.0) + p["fc"][i] + p["fs"][i] * math.exp(-(d.qvel[j] / p["vs"][i]) ** 2)
    lf = [(names.index(jn), p_mu) for e in effects if e["name"] == "load_dependent_friction"
          for jn, p_mu in zip(e["joints"], e["parameters"]["mu"])]
    if lf:
        load = np.zeros(m.nv)
        mujoco.mj_rne(m, d, 1, load)
        for j, mu in lf:
            level[j] = level.get(j, 0.0) + mu * abs(load[j])
    for j, v in level.items():
        m.dof_frictionloss[j] = static[j] + v


def simulate(cfg, case, robot_nominal_ctrl, duration, dt=DT):
    names = robot_nominal_ctrl.joint_names
    n = len(names)
    m = mujoco_model(cfg, case["effects"], names, dt)
    static = m.dof_frictionloss.copy()   # Coulomb and direction-dependent levels (`load_friction`)
    d = mujoco.MjData(m)
    T = int(round(duration / dt))
    t = np.arange(T + 1) * dt
    qr, qdr, qddr = reference(cfg, case["seed"], t)
    if cfg["check_reference"]:   # refuse a reference the real arm could not follow
        qr, qdr, qddr = within_velocity_limits(cfg, cfg["urdf_path"], names, qr, qdr, qddr)
        check_reference(cfg, cfg["urdf_path"], dict(case, joint_names=names), qr, qdr, qddr)
    tau_ff = robot_nominal_ctrl.rnea(qr, qdr, qddr)
    Mr = robot_nominal_ctrl.mass_matrix(qr)
    d.qpos[:], d.qvel[:] = qr[0], qdr[0]
    mujoco.mj_forward(m, d)
    q = np.zeros((T + 1, n)); qd = np.zeros((T + 1, n)); tau = np.zeros((T, n))
    friction = np.zeros((T, n))
    for k in range(T):
        q[k], qd[k] = d.qpos, d.qvel
        e, ed = qr[k] - d.qpos, qdr[k] - d.qvel
        tau[k] = tau_ff[k] + Mr[k] @ (KP * e + KD * ed)
        d.qfrc_applied[:] = tau[k] + drive_force(case["effects"], names, d.qpos, d.qvel)
        load_friction(m, d, case["effects"], names, static)
        mujoco.mj_step(m, d)
        friction[k] = d.qfrc_constraint       # the friction-loss force of this step (no other constraints)
        if not np.all(np.isfinite(d.qpos)):
            raise RuntimeError(f"{case['name']}: simulation diverged at step {k}")
    q[T], qd[T] = d.qpos, d.qvel
    qdd = np.diff(qd, axis=0) / dt          # realised acceleration of each step (semi-implicit Euler)
    track = np.max(np.abs(q[:T] - qr[:T]))
    return {"t": t[:T], "q": q[:T], "qd": qd[:T], "qdd": qdd, "tau": tau, "friction": friction,
            "tracking_max_err": float(track), "q_ref": qr[:T], "qd_ref": qdr[:T], "qdd_ref": qddr[:T]}


def measured(cfg, case, robot, duration, dt=DT, times=None):
    """A case simulated, then measured: (sim, q, qd, tau, torque noise std per joint), with
    the sensor-side torque offset, Gaussian torque noise (seed + 1000) and the encoder,
    velocity and torque quantisation of the manifest. With `times` (seconds from the start,
    a jittered log's stamps), the sensors sample there: positions and velocities linearly
    interpolated between the steps, the torque the one applied (and seen) during the step;
    `sim["log_states"]` then holds the exact states at those stamps (t, q, qd, qdd)."""
    names = robot.joint_names
    n = len(names)
    sim = simulate(cfg, case, robot, duration, dt)
    seen = sensor_model(case["effects"], names, sim["t"], sim["tau"])
    q, qd = sim["q"], sim["qd"]
    if times is not None:
        sim["log_states"] = resample(sim, times, dt)
        q, qd = sim["log_states"]["q"], sim["log_states"]["qd"]
        seen = seen[step_of(times, dt, len(sim["t"]))]
    rng = np.random.default_rng(case["seed"] + 1000)
    T = len(q)
    offset = np.zeros(n)
    for e in case["effects"]:
        if e["name"] == "torque_offset":
            for jn, v in zip(e["joints"], e["parameters"]["tau0"]):
                offset[names.index(jn)] += v
    noise_std = cfg["torque_noise"]
    case_noise = noise_std if "noise_scale" not in case else [case["noise_scale"] * s for s in noise_std]
    noise = rng.standard_normal((T, n)) * np.array(case_noise)
    tau_meas = seen + offset + noise
    tau_meas = np.round(tau_meas / TAU_RES) * TAU_RES
    q_meas = np.round(q / Q_RES) * Q_RES
    qd_meas = np.round(qd / QD_RES) * QD_RES
    return sim, q_meas, qd_meas, tau_meas, case_noise


def step_of(times, dt, steps):
    """The simulation step each instant falls in (its state at the start, its torque held)."""
    return np.clip(np.floor(np.asarray(times) / dt + 1e-9).astype(int), 0, steps - 1)


def resample(sim, times, dt):
    """The exact simulated states at `times`: q and qd linearly interpolated between steps,
    qdd (constant over a semi-implicit Euler step) that of the step."""
    def interp(x):
        return np.stack([np.interp(times, sim["t"], x[:, j]) for j in range(x.shape[1])], axis=1)
    return {"t": np.asarray(times), "q": interp(sim["q"]), "qd": interp(sim["qd"]),
            "qdd": sim["qdd"][step_of(times, dt, len(sim["t"]))]}


def sensor_model(effects, names, t, tau):
    """The torque sensor's view of the applied torque: gain (`torque_gain`) and lag (`time_delay`,
    linear interpolation in time, the first sample held before the log)."""
    out = np.array(tau, dtype=float)
    for e in effects:
        p = e["parameters"]
        for i, jn in enumerate(e["joints"]):
            j = names.index(jn)
            if e["name"] == "torque_gain":
                out[:, j] *= p["k"][i]
            elif e["name"] == "time_delay":
                out[:, j] = np.interp(t - p["delay_s"][i], t, out[:, j])
    return out


# ----------------------------------------------------------------------------- effects (oracle)
def effect_torque(effects, names, q, qd, qdd, robot_true, t=None):
    """What the true effects add to the nominal rigid-body torque (T, N), evaluated as the
    diagnosis model would: fc sign(qd), fv qd, ia qdd, k (q - q0), tau0, payload rnea, and the
    drive effects (the sensor's gain and lag applied to the true torque, stamps `t`)."""
    out = np.zeros_like(q)
    rigid = robot_true.rnea(q, qd, qdd)
    for e in effects:
        p = e["parameters"]
        for i, jn in enumerate(e["joints"]):
            j = names.index(jn)
            if e["name"] == "coulomb_friction":
                out[:, j] += p["fc"][i] * np.sign(qd[:, j])
            elif e["name"] == "viscous_friction":
                out[:, j] += p["fv"][i] * qd[:, j]
            elif e["name"] == "armature":
                out[:, j] += p["ia"][i] * qdd[:, j]
            elif e["name"] == "joint_spring":
                out[:, j] += p["k"][i] * (q[:, j] - p["q0"][i])
            elif e["name"] == "torque_offset":
                out[:, j] += p["tau0"][i]
            elif e["name"] == "asymmetric_coulomb_friction":
                out[:, j] += np.where(qd[:, j] > 0, p["fc_pos"][i], np.where(qd[:, j] < 0, -p["fc_neg"][i], 0.0))
            elif e["name"] == "smooth_coulomb_friction":
                out[:, j] += p["fc"][i] * np.tanh(qd[:, j] / p["vs"][i])
            elif e["name"] == "load_dependent_friction":
                out[:, j] += p["mu"][i] * np.abs(rigid[:, j]) * np.sign(qd[:, j])
            elif e["name"] == "stribeck_friction":
                level = p["fc"][i] + p["fs"][i] * np.exp(-(qd[:, j] / p["vs"][i]) ** 2)
                out[:, j] += level * np.sign(qd[:, j])
            elif e["name"] == "torque_ripple":
                w = 2 * math.pi / p["period"][i]
                out[:, j] += p["a"][i] * np.sin(w * q[:, j]) + p["b"][i] * np.cos(w * q[:, j])
        if e["name"] == "payload":
            out += payload_torque(robot_true, p, q, qd, qdd)
    # the sensor effects act on the whole true torque (rigid body + the effects above)
    true = rigid + out
    seen = sensor_model(effects, names, t if t is not None else np.arange(len(q)) * DT, true)
    return out + (seen - true)


def payload_torque(robot, p, q, qd, qdd):
    """rnea of the robot with the payload added to the terminal link minus rnea without it."""
    r2 = robot.copy()
    theta = r2.params
    names = r2.param_names
    link = robot.link_names[-1]
    m = p["mass"]; c = np.array(p["com"])
    ixx, ixy, ixz, iyy, iyz, izz = p["inertia"]
    Ic = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    Io = Ic + m * (np.dot(c, c) * np.eye(3) - np.outer(c, c))   # about the link origin
    add = {"m": m, "m*cx": m * c[0], "m*cy": m * c[1], "m*cz": m * c[2],
           "Ixx": Io[0, 0], "Ixy": Io[0, 1], "Ixz": Io[0, 2], "Iyy": Io[1, 1], "Iyz": Io[1, 2],
           "Izz": Io[2, 2]}
    for k, v in add.items():
        theta[names.index(f"{link}.{k}")] += v
    r2.params = theta
    return r2.rnea(q, qd, qdd) - robot.rnea(q, qd, qdd)


# ----------------------------------------------------------------------------- writing
def write_mcap(path, names, t, q, qd, tau, dt=DT, stamps_ns=None):
    """A JointState MCAP log; stamps k dt apart, or `stamps_ns` (from the log's start) when
    given (a jittered log)."""
    step_ns = int(round(dt * 1e9))
    with open(path, "wb") as f:
        w = Writer(output=f, chunk_size=256 * 1024, compression=CompressionType.ZSTD)
        js = w.register_msgdef("sensor_msgs/msg/JointState", JOINT_STATE)
        for k in range(len(t)):
            stamp = T0_NS + (k * step_ns if stamps_ns is None else int(stamps_ns[k]))
            sec, nsec = divmod(stamp, 1_000_000_000)
            msg = {"header": {"stamp": {"sec": sec, "nanosec": nsec}, "frame_id": ""},
                   "name": names,
                   "position": [float(v) for v in q[k]],
                   "velocity": [] if qd is None else [float(v) for v in qd[k]],
                   "effort": [float(v) for v in tau[k]]}
            w.write_message("/joint_states", js, msg, log_time=stamp, publish_time=stamp, sequence=k)
        w.finish()
    return os.path.getsize(path)


def rms(x):
    return [float(v) for v in np.sqrt(np.mean(np.asarray(x) ** 2, axis=0))]


def _manifest(cfg, robot_urdf, names, duration, agreement, panda):
    """The cases.json header: generator, versions, sensors, controller, integrator."""
    err_tau, err_m = agreement
    base, tip = cfg["base"], cfg["tip"]
    noise_std = cfg["torque_noise"]
    manifest = {
        "generator": "python/tools/make_diagnose_cases.py",
        "versions": {"mujoco": mujoco.__version__, "numpy": np.__version__},
        "robot_urdf": robot_urdf, "base": base, "tip": tip,
        "terminal_link": cfg["terminal_link"],
        "joints": names,
        "topic": "/joint_states",
        "rate_hz": 1000.0, "dt": DT, "duration_s": duration,
        "agreement": {"max_rel_tau": err_tau, "max_rel_mass_matrix": err_m, "states": 200,
                      "tolerance": AGREEMENT_TOL},
        "sensor": {"torque_noise_std": noise_std, "encoder_counts_per_rev": ENCODER_COUNTS,
                   "position_resolution_rad": Q_RES,
                   "torque_resolution_nm": TAU_RES, "velocity_resolution_rad_s": QD_RES,
                   "velocity": "MuJoCo joint velocity rounded to velocity_resolution_rad_s, no noise",
                   "effort": "applied joint torque + torque_offset (that case only) + N(0, torque_noise_std), "
                             "rounded to torque_resolution_nm"},
        "controller": {"law": "tau = rnea_nominal(q_ref, qd_ref, qdd_ref) + M_nominal(q_ref) (kp e + kd ed)",
                       "kp": KP, "kd": KD, "nominal": robot_urdf},
        "integrator": "MuJoCo Euler (semi-implicit; joint damping implicit), timestep 1 ms",
        "skipped": {"stribeck_friction": "MuJoCo's joint frictionloss has a constant magnitude; "
                    "MuJoCo has no velocity-dependent (Stribeck) friction mechanism"},
        "cases": [],
    }
    if panda:
        manifest["source_urdf"] = cfg["source_urdf"]
        manifest["source_changes"] = ("finger links and joints (panda_leftfinger, panda_rightfinger) removed; "
                                      "every <dynamics> set to damping 0, friction 0 (was damping 0.003)")
        manifest["integrator"] = ("MuJoCo Euler (semi-implicit; joint damping implicit), timestep = the case's "
                                  "dt (1 ms; 2 ms in the 500 Hz case)")
        manifest["rate_hz_note"] = ("rate_hz / dt are the default; a case with its own rate_hz / dt was "
                                    "simulated, controlled and logged at that rate")
        manifest["acc_limits_rad_s2"] = cfg["acc_limits"]
    return manifest


def _case_entry(case, cfg, robot, measurement, written, robot_urdf, out, factors, panda):
    """The case's cases.json entry: its log, effects, sensors and the oracle's RMS."""
    sim, tau_meas, case_noise = measurement
    log, size = written
    names = list(robot.joint_names)
    nominal = case.get("nominal")
    # oracle, on the exact simulated states and realised accelerations
    nominal_robot = robot if nominal is None else ivdyn.Robot.from_urdf(
        os.path.join(out, nominal), base=cfg["base"], tip=cfg["tip"])
    tau_nom = nominal_robot.rnea(sim["q"], sim["qd"], sim["qdd"])
    eff = effect_torque(case["effects"], names, sim["q"], sim["qd"], sim["qdd"], robot, sim["t"])
    entry = {
        "name": case["name"], "log": log, "bytes": size,
        "urdf": robot_urdf if nominal is None else os.path.relpath(os.path.join(out, nominal), ROOT),
        "samples": len(sim["t"]), "velocity_in_log": case.get("velocity", True), "seed": case["seed"],
        "noise_seed": case["seed"] + 1000,
        "effects": case["effects"],
        "torque_noise_std": case_noise,
        "tracking_max_err_rad": sim["tracking_max_err"],
        "velocity_reversals": [int(v) for v in np.sum(np.diff(np.sign(sim["qd"]), axis=0) != 0, axis=0)],
        "q_range": [[float(a), float(b)] for a, b in zip(sim["q"].min(0), sim["q"].max(0))],
        "oracle": {
            "adds": "tau_true = rnea_nominal(q, qd, qdd) + effects(q, qd, qdd): coulomb fc sign(qd), "
                    "viscous fv qd, armature ia qdd, joint_spring k (q - q0), torque_offset tau0, "
                    "payload rnea(payload body on terminal link)",
            "effect_rms": rms(eff),
            "baseline_rms_exact": rms(tau_meas - tau_nom),
            "oracle_rms_exact": rms(tau_meas - tau_nom - eff),
            "note": "RMS per joint (N m) with the exact simulated q, qd and realised qdd "
                    "(qdd[k] = (qd[k+1] - qd[k]) / dt, semi-implicit Euler); a diagnosis that "
                    "differentiates the logged q / qd gets slightly more. MuJoCo's implicit damping "
                    "makes the viscous torque fv qd[k+1] = fv (qd[k] + dt qdd[k]) exactly; "
                    "frictionloss is a constraint force, |f| < fc in stick phases",
        },
    }
    if panda:
        entry["rate_hz"] = case.get("rate_hz", 1000.0)
        entry["dt"] = DT if "rate_hz" not in case else 1.0 / case["rate_hz"]
        entry["qd_ref_max"] = [float(v) for v in np.abs(sim["qd_ref"]).max(0)]
        entry["qdd_ref_max"] = [float(v) for v in np.abs(sim["qdd_ref"]).max(0)]
    if nominal is not None:
        entry["model_error"] = {"kind": "inertials scaled", "true_urdf": robot_urdf,
                                "mass_and_inertia_factor": factors}
    return entry


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--robot", choices=sorted(ROBOTS), default="ur5")
    ap.add_argument("--out", default=None, help="output directory (default fixtures/diagnose for ur5, "
                    "fixtures/diagnose_panda for panda)")
    ap.add_argument("--duration", type=float, default=2.0, help="seconds per case")
    args = ap.parse_args(argv)
    cfg = robot_config(args.robot)
    out = args.out if args.out is not None else cfg["out"]
    os.makedirs(out, exist_ok=True)
    cfg = robot_config(args.robot, out)
    panda = args.robot == "panda"
    base, tip = cfg["base"], cfg["tip"]
    # the clean URDF as named in cases.json (path from the repository root)
    robot_urdf = cfg["source_urdf"] if cfg["urdf"] is None else os.path.relpath(cfg["urdf_path"], ROOT)

    robot = ivdyn.Robot.from_urdf(cfg["urdf_path"], base=base, tip=tip)
    names = list(robot.joint_names)
    assert robot.link_names[-1] == cfg["terminal_link"], robot.link_names
    err_tau, err_m = check_agreement(robot, cfg=cfg)
    print(f"MuJoCo vs ivdyn on the clean model: tau {err_tau:.2e}, M {err_m:.2e} (max relative, 200 states)")
    if err_tau > AGREEMENT_TOL or err_m > AGREEMENT_TOL:
        sys.exit("MuJoCo and ivdyn disagree on the clean model; not writing anything")

    factors = perturbed_urdf(cfg, os.path.join(out, cfg["perturbed"]), seed=5)
    manifest = _manifest(cfg, robot_urdf, names, args.duration, (err_tau, err_m), panda)
    total = 0
    for case in cfg["cases"]:
        dt = DT if "rate_hz" not in case else 1.0 / case["rate_hz"]
        sim, q_meas, qd_meas, tau_meas, case_noise = measured(cfg, case, robot, args.duration, dt)
        T = len(sim["t"])
        with_vel = case.get("velocity", True)
        log = f"{case['name']}.mcap"
        size = write_mcap(os.path.join(out, log), names, sim["t"], q_meas,
                          qd_meas if with_vel else None, tau_meas, dt)
        total += size
        entry = _case_entry(case, cfg, robot, (sim, tau_meas, case_noise), (log, size), robot_urdf, out,
                            factors, panda)
        manifest["cases"].append(entry)
        print(f"{case['name']:18s} {T:6d} samples {size:8d} bytes  track {sim['tracking_max_err']:.1e} rad  "
              f"oracle rms {np.round(entry['oracle']['oracle_rms_exact'], 3)}  "
              f"baseline {np.round(entry['oracle']['baseline_rms_exact'], 3)}")
    with open(os.path.join(out, "cases.json"), "w") as f:
        json.dump(manifest, f, indent=1)
        f.write("\n")
    print(f"total {total} bytes of logs")
    return 0


if __name__ == "__main__":
    sys.exit(main())
