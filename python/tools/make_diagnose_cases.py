#!/usr/bin/env python3
"""Generate the model-gap diagnosis test data in fixtures/diagnose/ (issue 7, item 6).

MuJoCo (`mujoco` from PyPI) plays the "real robot": it loads fixtures/ur5.urdf (the file has no
<visual>/<collision>; MuJoCo fuses the static root into the world body), contacts and joint
limits are disabled, and each hidden effect is added through MuJoCo's own mechanisms:

    coulomb_friction  joint `frictionloss`, solref_friction (2 ms, 1) (constraint force; stick
                      phases near v = 0)
    viscous_friction  joint `damping`               (integrated implicitly by MuJoCo's Euler)
    armature          joint `armature`              (exact)
    joint_spring      joint `stiffness` + `springref` (exact: tau_spring = k (q - q0))
    payload           a body welded to wrist_3_link (exact rigid body)
    torque_offset     added on the sensor side to the logged effort

`stribeck_friction` is not generated: MuJoCo's joint friction loss has a constant magnitude and
no velocity dependence, so MuJoCo cannot express it with its own mechanisms (see
docs/diagnose-data.md).

Before anything is simulated, MuJoCo's inverse dynamics (`mj_inverse`, qacc given) is checked
against ivdyn's `rnea` on the clean model (and the mass matrices against each other); the script
stops if they differ by more than 1e-10 relative.

The arm follows a sum-of-sinusoids reference per joint at 1 ms steps (semi-implicit Euler) with
a PD tracking controller whose gains are scaled by the nominal mass matrix:
    tau = rnea(q_ref, qd_ref, qdd_ref) + M(q_ref) (kp e + kd ed)
(nominal model = ivdyn on fixtures/ur5.urdf). The logged effort is the applied actuator torque,
as a joint torque sensor would measure it, plus the sensor-side offset (torque_offset case only)
and Gaussian noise; positions are quantised like an encoder; velocity is MuJoCo's joint
velocity (omitted in one case).

Deterministic (numpy default_rng seeds per case, fixed stamps). Run from the repository root:

    .venv/bin/python python/tools/make_diagnose_cases.py [--out DIR] [--duration S]

Default: fixtures/diagnose/, 2 s per case. Writes <case>.mcap, ur5_inertia5.urdf and cases.json.
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
URDF = os.path.join(ROOT, "fixtures", "ur5.urdf")
BASE, TIP = "base_link", "tool0"
DT = 1e-3
T0_NS = 1_700_000_000_000_000_000
# Sensor quanta are powers of two so that the float64 values compress (the logs stay small).
Q_RES = 2.0 ** -18                             # rad, encoder quantum (~1.65e6 counts/rev)
ENCODER_COUNTS = round(2 * math.pi / Q_RES)
TAU_RES = 2.0 ** -14                           # N m, torque sensor quantum (6.1e-5 N m)
QD_RES = 2.0 ** -16                            # rad/s, velocity quantum (1.5e-5 rad/s)
TORQUE_NOISE = [0.15, 0.15, 0.08, 0.03, 0.03, 0.02]  # N m, std per joint (URDF order)
WN, ZETA = 2 * math.pi * 10.0, 0.7             # PD bandwidth (rad/s) and damping ratio
KP, KD = WN * WN, 2 * ZETA * WN
TERMINAL_LINK = "wrist_3_link"
AGREEMENT_TOL = 1e-10

from make_log_fixtures import JOINT_STATE  # noqa: E402  (the one JointState message definition of our Python writers)

# Trajectory centres (rad) per joint; amplitudes are drawn per case.
CENTRES = np.array([0.0, -1.3, 1.2, -1.2, 1.4, 0.0])

# The cases. `effects` uses the diagnosis.json vocabulary of ../shared/DESIGN.md.
PAYLOAD_A = {"mass": 2.0, "com": [0.02, 0.13, -0.01],
             "inertia": [0.0040, 0.0002, 0.0, 0.0030, 0.0, 0.0045]}
PAYLOAD_B = {"mass": 1.2, "com": [-0.015, 0.11, 0.02],
             "inertia": [0.0020, 0.0, 0.0001, 0.0025, 0.0, 0.0018]}
CASES = [
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


# ----------------------------------------------------------------------------- models
def mujoco_model(effects, joint_names):
    """MuJoCo model of fixtures/ur5.urdf with the given effects (sensor-side ones ignored)."""
    spec = mujoco.MjSpec.from_file(URDF)
    joints = {j.name: j for j in spec.joints}
    assert [j.name for j in spec.joints] == joint_names, [j.name for j in spec.joints]
    for e in effects:
        p = e["parameters"]
        for i, jn in enumerate(e["joints"]):
            j = joints[jn]
            if e["name"] == "coulomb_friction":
                j.frictionloss = p["fc"][i]
                # stiffest stable friction constraint at this step (2 dt): the default 0.02 s
                # time constant makes the friction force lag sign changes by tens of ms
                j.solref_friction = [2 * DT, 1.0]
            elif e["name"] == "viscous_friction":
                j.damping = [p["fv"][i], 0.0, 0.0]   # [linear, polynomial terms]
            elif e["name"] == "armature":
                j.armature = p["ia"][i]
            elif e["name"] == "joint_spring":
                j.stiffness = [p["k"][i], 0.0, 0.0]
                j.springref = p["q0"][i]
        if e["name"] == "payload":
            parent = spec.body(TERMINAL_LINK)
            b = parent.add_body(name="payload")
            b.pos = [0.0, 0.0, 0.0]
            b.explicitinertial = True
            b.mass = p["mass"]
            b.ipos = p["com"]
            ixx, ixy, ixz, iyy, iyz, izz = p["inertia"]
            b.fullinertia = [ixx, iyy, izz, ixy, ixz, iyz]   # MuJoCo order
    m = spec.compile()
    m.opt.timestep = DT
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_LIMIT
    return m


def perturbed_urdf(path_out, seed):
    """fixtures/ur5.urdf with every moving link's mass and inertia tensor scaled by 1 +- 5 %
    (random signs); COMs unchanged. Returns {link: factor}."""
    rng = np.random.default_rng(seed)
    tree = ET.parse(URDF)
    factors = {}
    for link in tree.getroot().findall("link"):
        name = link.get("name")
        if name not in ("shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link",
                        "wrist_2_link", "wrist_3_link"):
            continue
        f = 1.0 + 0.05 * float(rng.choice([-1.0, 1.0]))
        factors[name] = f
        inert = link.find("inertial")
        mass = inert.find("mass")
        mass.set("value", repr(float(mass.get("value")) * f))
        it = inert.find("inertia")
        for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"):
            it.set(k, repr(float(it.get(k)) * f))
    tree.write(path_out, encoding="utf-8", xml_declaration=True)
    return factors


def check_agreement(robot, n=200, seed=0):
    """Max relative difference |mj_inverse - rnea| / max(|rnea|_inf, 1) and same for M."""
    m = mujoco_model([], robot.joint_names)
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


# ----------------------------------------------------------------------------- trajectory
def reference(seed, t):
    """Sum of 3 harmonics per joint (base frequency 0.4-0.6 Hz), centred on CENTRES."""
    rng = np.random.default_rng(seed)
    n = len(CENTRES)
    f0 = rng.uniform(0.4, 0.6)
    q = np.tile(CENTRES, (len(t), 1))
    qd = np.zeros_like(q)
    qdd = np.zeros_like(q)
    # amplitudes keep |qd_ref| < 3.1 rad/s (UR5 velocity limits 3.15 / 3.2 rad/s)
    amp_scale = 0.6 * np.array([0.5, 0.35, 0.4, 0.5, 0.5, 0.6])
    for j in range(n):
        for h in (1, 2, 3):
            a = amp_scale[j] * rng.uniform(0.5, 1.0) / h
            w = 2 * math.pi * f0 * h * rng.uniform(0.9, 1.1)
            ph = rng.uniform(0, 2 * math.pi)
            q[:, j] += a * np.sin(w * t + ph)
            qd[:, j] += a * w * np.cos(w * t + ph)
            qdd[:, j] += -a * w * w * np.sin(w * t + ph)
    return q, qd, qdd


def simulate(case, robot_nominal_ctrl, duration):
    names = robot_nominal_ctrl.joint_names
    m = mujoco_model(case["effects"], names)
    d = mujoco.MjData(m)
    T = int(round(duration / DT))
    t = np.arange(T + 1) * DT
    qr, qdr, qddr = reference(case["seed"], t)
    tau_ff = robot_nominal_ctrl.rnea(qr, qdr, qddr)
    Mr = robot_nominal_ctrl.mass_matrix(qr)
    d.qpos[:], d.qvel[:] = qr[0], qdr[0]
    mujoco.mj_forward(m, d)
    q = np.zeros((T + 1, 6)); qd = np.zeros((T + 1, 6)); tau = np.zeros((T, 6))
    friction = np.zeros((T, 6))
    for k in range(T):
        q[k], qd[k] = d.qpos, d.qvel
        e, ed = qr[k] - d.qpos, qdr[k] - d.qvel
        tau[k] = tau_ff[k] + Mr[k] @ (KP * e + KD * ed)
        d.qfrc_applied[:] = tau[k]
        mujoco.mj_step(m, d)
        friction[k] = d.qfrc_constraint       # the friction-loss force of this step (no other constraints)
        if not np.all(np.isfinite(d.qpos)):
            raise RuntimeError(f"{case['name']}: simulation diverged at step {k}")
    q[T], qd[T] = d.qpos, d.qvel
    qdd = np.diff(qd, axis=0) / DT          # realised acceleration of each step (semi-implicit Euler)
    track = np.max(np.abs(q[:T] - qr[:T]))
    return {"t": t[:T], "q": q[:T], "qd": qd[:T], "qdd": qdd, "tau": tau, "friction": friction,
            "tracking_max_err": float(track), "q_ref": qr[:T]}


# ----------------------------------------------------------------------------- effects (oracle)
def effect_torque(effects, names, q, qd, qdd, robot_true):
    """What the true effects add to the nominal rigid-body torque (T, N), evaluated as the
    diagnosis model would: fc sign(qd), fv qd, ia qdd, k (q - q0), tau0, payload rnea."""
    out = np.zeros_like(q)
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
        if e["name"] == "payload":
            out += payload_torque(robot_true, p, q, qd, qdd)
    return out


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
def write_mcap(path, names, t, q, qd, tau):
    with open(path, "wb") as f:
        w = Writer(output=f, chunk_size=256 * 1024, compression=CompressionType.ZSTD)
        js = w.register_msgdef("sensor_msgs/msg/JointState", JOINT_STATE)
        for k in range(len(t)):
            stamp = T0_NS + k * 1_000_000
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


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=os.path.join(ROOT, "fixtures", "diagnose"))
    ap.add_argument("--duration", type=float, default=2.0, help="seconds per case")
    args = ap.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)

    robot = ivdyn.Robot.from_urdf(URDF, base=BASE, tip=TIP)
    names = list(robot.joint_names)
    err_tau, err_m = check_agreement(robot)
    print(f"MuJoCo vs ivdyn on the clean model: tau {err_tau:.2e}, M {err_m:.2e} (max relative, 200 states)")
    if err_tau > AGREEMENT_TOL or err_m > AGREEMENT_TOL:
        sys.exit("MuJoCo and ivdyn disagree on the clean model; not writing anything")

    factors = perturbed_urdf(os.path.join(args.out, "ur5_inertia5.urdf"), seed=5)
    manifest = {
        "generator": "python/tools/make_diagnose_cases.py",
        "versions": {"mujoco": mujoco.__version__, "numpy": np.__version__},
        "robot_urdf": "fixtures/ur5.urdf", "base": BASE, "tip": TIP,
        "terminal_link": TERMINAL_LINK,
        "joints": names,
        "topic": "/joint_states",
        "rate_hz": 1000.0, "dt": DT, "duration_s": args.duration,
        "agreement": {"max_rel_tau": err_tau, "max_rel_mass_matrix": err_m, "states": 200,
                      "tolerance": AGREEMENT_TOL},
        "sensor": {"torque_noise_std": TORQUE_NOISE, "encoder_counts_per_rev": ENCODER_COUNTS,
                   "position_resolution_rad": Q_RES,
                   "torque_resolution_nm": TAU_RES, "velocity_resolution_rad_s": QD_RES,
                   "velocity": "MuJoCo joint velocity rounded to velocity_resolution_rad_s, no noise",
                   "effort": "applied joint torque + torque_offset (that case only) + N(0, torque_noise_std), "
                             "rounded to torque_resolution_nm"},
        "controller": {"law": "tau = rnea_nominal(q_ref, qd_ref, qdd_ref) + M_nominal(q_ref) (kp e + kd ed)",
                       "kp": KP, "kd": KD, "nominal": "fixtures/ur5.urdf"},
        "integrator": "MuJoCo Euler (semi-implicit; joint damping implicit), timestep 1 ms",
        "skipped": {"stribeck_friction": "MuJoCo's joint frictionloss has a constant magnitude; "
                    "MuJoCo has no velocity-dependent (Stribeck) friction mechanism"},
        "cases": [],
    }
    total = 0
    for case in CASES:
        nominal = case.get("nominal")
        sim = simulate(case, robot, args.duration)
        rng = np.random.default_rng(case["seed"] + 1000)
        T = len(sim["t"])
        offset = np.zeros(6)
        for e in case["effects"]:
            if e["name"] == "torque_offset":
                for jn, v in zip(e["joints"], e["parameters"]["tau0"]):
                    offset[names.index(jn)] += v
        noise = rng.standard_normal((T, 6)) * np.array(TORQUE_NOISE)
        tau_meas = sim["tau"] + offset + noise
        tau_meas = np.round(tau_meas / TAU_RES) * TAU_RES
        q_meas = np.round(sim["q"] / Q_RES) * Q_RES
        qd_meas = np.round(sim["qd"] / QD_RES) * QD_RES
        with_vel = case.get("velocity", True)
        log = f"{case['name']}.mcap"
        size = write_mcap(os.path.join(args.out, log), names, sim["t"], q_meas,
                          qd_meas if with_vel else None, tau_meas)
        total += size

        # oracle, on the exact simulated states and realised accelerations
        nominal_robot = robot if nominal is None else ivdyn.Robot.from_urdf(
            os.path.join(args.out, nominal), base=BASE, tip=TIP)
        tau_nom = nominal_robot.rnea(sim["q"], sim["qd"], sim["qdd"])
        eff = effect_torque(case["effects"], names, sim["q"], sim["qd"], sim["qdd"], robot)
        entry = {
            "name": case["name"], "log": log, "bytes": size,
            "urdf": "fixtures/ur5.urdf" if nominal is None else os.path.relpath(os.path.join(args.out, nominal), ROOT),
            "samples": T, "velocity_in_log": with_vel, "seed": case["seed"],
            "noise_seed": case["seed"] + 1000,
            "effects": case["effects"],
            "torque_noise_std": TORQUE_NOISE,
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
        if nominal is not None:
            entry["model_error"] = {"kind": "inertials scaled", "true_urdf": "fixtures/ur5.urdf",
                                    "mass_and_inertia_factor": factors}
        manifest["cases"].append(entry)
        print(f"{case['name']:18s} {T:6d} samples {size:8d} bytes  track {sim['tracking_max_err']:.1e} rad  "
              f"oracle rms {np.round(entry['oracle']['oracle_rms_exact'], 3)}  "
              f"baseline {np.round(entry['oracle']['baseline_rms_exact'], 3)}")
    with open(os.path.join(args.out, "cases.json"), "w") as f:
        json.dump(manifest, f, indent=1)
        f.write("\n")
    print(f"total {total} bytes of logs")
    return 0


if __name__ == "__main__":
    sys.exit(main())
