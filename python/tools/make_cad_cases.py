#!/usr/bin/env python3
"""Generate the "diagnosis from a CAD model" case set (issue 15, item 5): MuJoCo logs of four
arms whose nominal URDF has inertial errors of 5, 15 or 30 %, with none, one, two or three
hidden effects, plus a seeded split that sets a third of the cases aside as a held-out set.

Everything about the simulation (MuJoCo mechanisms of each effect, controller, sensor noise and
quantisation, the mj_inverse-vs-rnea agreement check, the oracle) is that of
make_diagnose_cases.py, which this script imports; what it adds:

* two arms the diagnosis was never tuned on, derived from example-robot-data (the `pin` wheel):
  UR3 (ur_description/urdf/ur3_robot.urdf) and the TALOS left arm (talos_data/robots/
  talos_left_arm.urdf: arm_left_1_link is its fixed root, 6 joints arm_left_2..7; the wrist
  force sensor and gripper are dropped), beside the UR5 and Panda of the fixtures. The arms
  reserved for the project's external evaluation are not used.
* the nominal model a user would have: every moving link's mass, inertia tensor (about the
  COM) and COM vector scaled by independent factors 1 +- U(L/2, L) (random signs), L = the
  case's error level. A mass and COM error is not a uniform scale of the link's 10
  inertial parameters: no per-link scale factor reproduces it exactly.
* effects drawn per case (seeded): kinds without repetition from coulomb_friction,
  viscous_friction, armature, torque_offset, joint_spring, payload and (unless `--no-drives`)
  the effects of real drives (asymmetric_coulomb_friction, smooth_coulomb_friction,
  load_dependent_friction, torque_gain, torque_ripple, time_delay: make_diagnose_cases.py says
  how each is injected), on 1-3 joints each, sized so that each adds 5-15 noise standard
  deviations of RMS torque on its joint along the reference motion (armature: 30-80 % of the
  nominal inertia on the joint, as reflected rotor inertias are; payload: a part of 0.5-2 kg
  depending on the arm; a gain within 0.8-1.2 and a delay of at most 20 ms, on joints whose torque
  allows that size).
* `split.json`: a seeded permutation of all case ids ("robot/case"); every third is held out.
  Tune on "tune"; run "heldout" once, at the end (python/tools/score_diagnose_cases.py).

* `--set random`: the same 12 cases per arm on randomly generated serial arms (random_arm.py:
  DH-like kinematics, 6 and 7 joints alternating, inertials within physical bounds), written
  as URDF (ivdyn; the nominal models derive from it) and MJCF (MuJoCo simulates it; the
  agreement check compares the two), torque noise 0.5 % of each joint's RMS torque, payloads
  of 5-15 % of the arm's mass, and a sensor variant per case (sensor_variants.py: jittered
  stamps with re-published samples, float32, no velocity, motor current; the options the
  log needs are the case's `diagnose_args`). `--duration 20:60` draws each case's length.

Writes OUT/<robot>/{<case>.mcap, <case>_nominal.urdf, cases.json} (cases.json in the format of
make_diagnose_cases.py, URDF paths absolute; each case also has `oracle.oracle_rms_true_model`:
what the true effects leave with the *true* rigid-body model) and OUT/split.json.

    .venv/bin/python python/tools/make_cad_cases.py --out /tmp/cad_cases [--duration 2]
    .venv/bin/python python/tools/make_cad_cases.py --out fixtures/diagnose_cad --only ur5/e15_0fx,...
    .venv/bin/python python/tools/make_cad_cases.py --set random --out /tmp/random_cases [--arms 6] [--duration 20:60]
    .venv/bin/python python/tools/make_cad_cases.py --set random --everywhere coulomb_friction,viscous_friction ...

`--everywhere KINDS`: those kinds go on every joint of the arm (a real arm's friction is on all
its joints), each joint's size drawn as above.
"""
import argparse
import json
import os
import sys
import xml.etree.ElementTree as ET

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import make_diagnose_cases as mdc  # noqa: E402
import random_arm  # noqa: E402
import sensor_variants  # noqa: E402
import ivdyn  # noqa: E402

LEVELS = [0.05, 0.15, 0.30]
KINDS = ["coulomb_friction", "viscous_friction", "armature", "torque_offset", "joint_spring", "payload"]
# the effects of real drives (issue 15 item 2), drawn beside the others (`--no-drives`: without)
DRIVE_KINDS = ["asymmetric_coulomb_friction", "smooth_coulomb_friction", "load_dependent_friction", "torque_gain",
               "torque_ripple", "time_delay"]
# drawn only when `--kinds` names them (the default draws stay those of the committed fixtures)
EXTRA_KINDS = ["stribeck_friction"]
RIPPLE_N = [4, 6, 8, 12, 16]
DEFAULT_RIPPLE_N = list(RIPPLE_N)   # the diagnosis's own grid (`--ripple-n` draws from others)
# kinds drawn on every joint instead of 1-3 (`--everywhere`): a real arm's friction is on all
# of its joints (issue 15: viscous friction on all 7 joints named on 3 of them)
EVERYWHERE_KINDS = ["coulomb_friction", "viscous_friction", "armature", "asymmetric_coulomb_friction",
                    "smooth_coulomb_friction", "load_dependent_friction"]
EVERYWHERE = set()
SPLIT_SEED = 15


def erd_robots():
    """example-robot-data's robots/ folder (installed with `pin` under site-packages/cmeel.prefix)."""
    import sysconfig
    path = os.path.join(sysconfig.get_paths()["purelib"], "cmeel.prefix", "share", "example-robot-data", "robots")
    if not os.path.isdir(path):
        raise SystemExit(f"example-robot-data not found at {path} (pip install pin)")
    return path


def chain_urdf(src, keep_links, path_out):
    """`src` with only `keep_links` and the joints between them, without visual / collision /
    transmission / gazebo elements, every <dynamics> zeroed (the hidden effects are the truth)."""
    tree = ET.parse(src)
    root = tree.getroot()
    for el in list(root):
        if el.tag == "link" and el.get("name") not in keep_links:
            root.remove(el)
        elif el.tag == "joint" and (el.find("parent").get("link") not in keep_links
                                    or el.find("child").get("link") not in keep_links):
            root.remove(el)
        elif el.tag not in ("link", "joint"):
            root.remove(el)
    for link in root.findall("link"):
        for tag in ("visual", "collision"):
            for el in link.findall(tag):
                link.remove(el)
    mdc.zero_dynamics(root)
    tree.write(path_out, encoding="utf-8", xml_declaration=True)


UR_LINKS = ["world", "base_link", "base", "shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link",
            "wrist_2_link", "wrist_3_link", "ee_link", "tool0"]
TALOS_LINKS = [f"arm_left_{i}_link" for i in range(1, 8)]

# Amplitudes: the sum of 3 harmonics reaches 1.83 amp_scale in position and ~12 amp_scale in
# velocity; chosen inside 90 % of the URDF velocity limits and 0.2 rad of the joint limits
# (checked by mdc.check_reference).
CAD_ROBOTS = {
    "ur5": dict(mdc.ROBOTS["ur5"], payload_mass=(1.0, 2.0)),
    "panda": dict(mdc.ROBOTS["panda"], payload_mass=(0.5, 1.0)),
    "ur3": {
        "erd": "ur_description/urdf/ur3_robot.urdf", "keep": UR_LINKS, "urdf": "ur3_arm.urdf",
        "base": "base_link", "tip": "tool0", "terminal_link": "wrist_3_link",
        "torque_noise": [0.08, 0.08, 0.05, 0.02, 0.02, 0.015],
        "centres": [0.0, -1.3, 1.2, -1.2, 1.4, 0.0],
        "amp_scale": np.array([0.15, 0.15, 0.22, 0.22, 0.22, 0.22]),
        "acc_limits": None, "check_reference": True,
        "moving_links": ["shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link", "wrist_2_link",
                         "wrist_3_link"],
        "payload_mass": (0.5, 1.5),
    },
    "talos_arm": {
        "erd": "talos_data/robots/talos_left_arm.urdf", "keep": TALOS_LINKS, "urdf": "talos_arm.urdf",
        "base": "arm_left_1_link", "tip": "arm_left_7_link", "terminal_link": "arm_left_7_link",
        "torque_noise": [0.1, 0.1, 0.05, 0.03, 0.02, 0.02],
        "centres": [1.2, 0.0, -1.2, 0.0, 0.0, 0.0],
        "amp_scale": np.array([0.25, 0.3, 0.3, 0.13, 0.12, 0.12]),
        "acc_limits": None, "check_reference": True,
        "moving_links": TALOS_LINKS[1:],
        "payload_mass": (0.5, 1.0),
    },
}


# The random arms (`--set random`): name -> (joints, seed); 6 and 7 joints alternate. Every set
# so far drew from the first 12 (`--first-arm 0`); the next ones are arms nobody has seen. Seeds
# are the index, so widening the range leaves every earlier arm as it was.
RANDOM_ARMS = {f"rarm{i}_{6 + i % 2}j": (6 + i % 2, 15000 + i) for i in range(128)}
NOISE_SHARE, NOISE_FLOOR = 0.005, 0.01   # torque noise std: 0.5 % of the joint's RMS torque, >= 0.01 N m


def random_config(name, out, joints_seed=None):
    """A random arm's settings (random_arm.py; `joints_seed` = (joints, seed), default the
    one RANDOM_ARMS gives `name`): its URDF and MJCF written into `out`, the
    reference motion's centres and amplitudes drawn from its seed, the torque noise std of
    each joint NOISE_SHARE of its RMS rigid-body torque along a reference motion (at least
    NOISE_FLOOR), payloads of 5-15 % of the arm's mass."""
    n, seed = joints_seed or RANDOM_ARMS[name]
    os.makedirs(out, exist_ok=True)
    arm = random_arm.draw_arm(n, seed)
    cfg = {"name": name, "out": out, "base": "base_link", "tip": f"link_{n}", "terminal_link": f"link_{n}",
           "urdf_path": os.path.join(out, "arm.urdf"), "mjcf_path": os.path.join(out, "arm_mujoco.xml"),
           "moving_links": [f"link_{i}" for i in range(1, n + 1)], "acc_limits": None, "check_reference": True,
           "random_arm": {"joints": n, "seed": seed, "kinematics_a_alpha_d": [list(k) for k in arm["kinematics"]]}}
    random_arm.write_urdf(arm, cfg["urdf_path"])
    random_arm.write_mjcf(arm, cfg["mjcf_path"])
    rng = np.random.default_rng(seed + 1)
    cfg["centres"] = [float(v) for v in rng.uniform(-1.0, 1.0, n)]
    cfg["amp_scale"] = rng.uniform(0.1, 0.2, n)
    with_motion(cfg)
    robot = ivdyn.Robot.from_urdf(cfg["urdf_path"], base=cfg["base"], tip=cfg["tip"])
    t = np.arange(int(round(2.0 / mdc.DT))) * mdc.DT
    tau = robot.rnea(*mdc.reference(cfg, seed, t))
    cfg["torque_noise"] = [float(max(NOISE_FLOOR, round(NOISE_SHARE * v, 3))) for v in mdc.rms(tau)]
    total = sum(lk["mass"] for lk in arm["links"])
    cfg["payload_mass"] = (0.05 * total, 0.15 * total)
    return cfg


# `--motion wide`: each joint's amplitude this many times the default's at this base frequency
# range (Hz): the same speeds, a third of the accelerations, three times the angles (about 1-2
# rad peak to peak instead of 0.4-0.7), as an identification trajectory sweeps its poses.
WIDE_AMPLITUDE, WIDE_F0 = 3.0, (0.13, 0.2)
MOTION = "narrow"


def with_motion(cfg):
    """`cfg` with the reference of `MOTION` (module constant set by `--motion`)."""
    if MOTION == "wide":
        cfg.update(amp_scale=WIDE_AMPLITUDE * np.asarray(cfg["amp_scale"]), f0_range=WIDE_F0)
    return cfg


def cad_config(name, out):
    """The robot's settings with `urdf_path` (its clean URDF, written into `out` if derived)."""
    os.makedirs(out, exist_ok=True)
    if name in RANDOM_ARMS:
        return random_config(name, out)
    if name in ("ur5", "panda"):
        cfg = mdc.robot_config(name, out)
        cfg.update(payload_mass=CAD_ROBOTS[name]["payload_mass"])
        return cfg
    cfg = dict(CAD_ROBOTS[name], name=name, out=out)
    cfg["urdf_path"] = os.path.join(out, cfg["urdf"])
    chain_urdf(os.path.join(erd_robots(), cfg["erd"]), cfg["keep"], cfg["urdf_path"])
    return cfg


def nominal_urdf(cfg, path_out, level, rng):
    """The clean URDF with each moving link's mass, inertia tensor and COM scaled by independent
    factors 1 +- U(level/2, level). Returns {link: [mass, inertia, com] factors}."""
    def draw():
        return tuple(1.0 + float(rng.choice([-1.0, 1.0]) * rng.uniform(level / 2, level)) for _ in range(3))
    return {k: list(v) for k, v in mdc.scale_inertials(cfg, path_out, draw).items()}


def drive_parameters(kind, js, k, sig, q, qd, tau, rng):
    """Parameters of a real-drive effect on joints `js`, each `k[i]` noise std of RMS torque
    (`tau`: the rigid-body torque along the reference motion); None when no joint allows it."""
    rms_of = lambda x: np.sqrt(np.mean(x ** 2, axis=0))  # noqa: E731
    size = [float(k[i] * sig[j]) for i, j in enumerate(js)]
    if kind == "asymmetric_coulomb_friction":
        a = [float(rng.choice([-1, 1]) * rng.uniform(0.4, 0.7)) for _ in js]
        return {"fc_pos": [s * (1 + x) for s, x in zip(size, a)], "fc_neg": [s * (1 - x) for s, x in zip(size, a)]}
    if kind == "smooth_coulomb_friction":
        return {"fc": size, "vs": [float(rng.uniform(0.2, 0.4) * rms_of(qd)[j]) for j in js]}
    if kind == "stribeck_friction":
        # static friction fc + fs of 1.5-2 fc, falling to fc within 5-15 % of the joint's RMS speed
        fc = [s * float(rng.uniform(0.6, 0.8)) for s in size]
        return {"fc": fc, "fs": [c * float(rng.uniform(0.5, 1.0)) for c in fc],
                "vs": [float(rng.uniform(0.05, 0.15) * rms_of(qd)[j]) for j in js]}
    if kind == "load_dependent_friction":
        return {"mu": [s / float(rms_of(tau)[j]) for s, j in zip(size, js)]}
    if kind == "torque_gain":
        return {"k": [1.0 + float(rng.choice([-1, 1])) * s / float(rms_of(tau)[j]) for s, j in zip(size, js)]}
    if kind == "torque_ripple":
        ph = rng.uniform(0, 2 * np.pi, len(js))
        amp = [np.sqrt(2) * s for s in size]
        return {"period": [float(2 * np.pi / rng.choice(RIPPLE_N)) for _ in js],
                "a": [float(a * np.cos(p)) for a, p in zip(amp, ph)], "b": [float(a * np.sin(p)) for a, p in zip(amp, ph)]}
    dtau = np.gradient(tau, mdc.DT, axis=0)
    return {"delay_s": [s / float(rms_of(dtau)[j]) for s, j in zip(size, js)]}


def drive_joints(kind, n, sig, tau, rng):
    """The joints a drive effect of 5-15 noise std fits on: a gain within 0.8-1.2 needs a
    rigid-body torque of at least 75 noise std RMS; a load-dependent friction with `mu` at most
    0.5 (a drive's `1 - efficiency`; until 2026-12-07 unbounded: 12 of 95 drawn on rarm76-111
    had 0.53-2.4, every one on a terminal joint carrying a few noise std of load, a friction
    above the load it follows) at least 30; a delay of at most 20 ms a torque rate of at least
    750 noise std per second."""
    rms_of = lambda x: np.sqrt(np.mean(x ** 2, axis=0))  # noqa: E731
    if kind == "torque_gain":
        ok = [j for j in range(n) if rms_of(tau)[j] >= 75 * sig[j]]
    elif kind == "load_dependent_friction":
        ok = [j for j in range(n) if rms_of(tau)[j] >= 30 * sig[j]]
    elif kind == "time_delay":
        ok = [j for j in range(n) if rms_of(np.gradient(tau, mdc.DT, axis=0))[j] >= 750 * sig[j]]
    else:
        ok = list(range(n))
    if not ok:
        return []
    return sorted(int(j) for j in rng.choice(ok, size=min(len(ok), int(rng.integers(1, 4))), replace=False))


def merge_levels(effects):
    """`effects` with a Coulomb friction drawn on a joint that also has a direction-dependent
    or Stribeck friction folded into that one's levels (`fc_pos`, `fc_neg` or `fc` + the
    Coulomb `fc`): the friction-loss levels add up in the simulation (make_diagnose_cases.
    load_friction), and the sum is that one friction, which no log can split in two. The
    draws (and every case without such a pair) are unchanged."""
    coulomb = next((e for e in effects if e["name"] == "coulomb_friction"), None)
    if coulomb is None:
        return effects
    for e in effects:
        if e["name"] not in ("asymmetric_coulomb_friction", "stribeck_friction"):
            continue
        for i, jn in enumerate(e["joints"]):
            if jn not in coulomb["joints"]:
                continue
            k = coulomb["joints"].index(jn)
            fc = coulomb["parameters"]["fc"].pop(k)
            coulomb["joints"].pop(k)
            for key in ("fc_pos", "fc_neg") if e["name"] == "asymmetric_coulomb_friction" else ("fc",):
                e["parameters"][key][i] += fc
    return [e for e in effects if e is not coulomb or coulomb["joints"]]


def draw_effects(cfg, robot, names, seed, count, rng, kinds=KINDS):
    """`count` effects of distinct kinds on random joints, sized on the reference motion."""
    t = np.arange(int(round(2.0 / mdc.DT))) * mdc.DT
    q, qd, qdd = mdc.reference(cfg, seed, t)
    sig = np.array(cfg["torque_noise"])
    m_diag = np.mean([np.diag(robot.mass_matrix(q[k])) for k in range(0, len(t), 50)], axis=0)
    n = len(names)
    effects = []
    for kind in rng.choice(kinds, size=count, replace=False):
        if kind in DRIVE_KINDS or kind in EXTRA_KINDS:
            tau = robot.rnea(q, qd, qdd)
            js = drive_joints(kind, n, sig, tau, rng)
            if kind in EVERYWHERE:
                js = list(range(n))
            if js:
                p = drive_parameters(kind, js, rng.uniform(5.0, 15.0, len(js)), sig, q, qd, tau, rng)
                effects.append({"name": str(kind), "joints": [names[j] for j in js], "parameters": p})
            continue
        if kind == "payload":
            lo, hi = cfg["payload_mass"]
            m = float(rng.uniform(lo, hi))
            com = [float(v) for v in rng.uniform(-0.04, 0.04, 3)]
            com[int(rng.integers(3))] = float(rng.choice([-1, 1]) * rng.uniform(0.06, 0.14))
            r2 = m * 0.03 ** 2
            effects.append({"name": "payload", "joints": [],
                            "parameters": {"mass": m, "com": com,
                                           "inertia": [1.2 * r2, 0.0, 0.0, 1.0 * r2, 0.0, 0.8 * r2]}})
            continue
        js = sorted(int(j) for j in rng.choice(n, size=int(rng.integers(1, 4)), replace=False))
        if kind in EVERYWHERE:
            js = list(range(n))
        k = rng.uniform(5.0, 15.0, len(js))
        rms_of = lambda x: np.sqrt(np.mean(x ** 2, axis=0))  # noqa: E731
        if kind == "coulomb_friction":
            p = {"fc": [float(k[i] * sig[j]) for i, j in enumerate(js)]}
        elif kind == "viscous_friction":
            p = {"fv": [float(k[i] * sig[j] / rms_of(qd)[j]) for i, j in enumerate(js)]}
        elif kind == "armature":
            p = {"ia": [float(rng.uniform(0.3, 0.8) * m_diag[j]) for j in js]}
        elif kind == "torque_offset":
            p = {"tau0": [float(rng.choice([-1, 1]) * k[i] * sig[j]) for i, j in enumerate(js)]}
        else:
            qs = np.std(q, axis=0)
            p = {"k": [float(k[i] * sig[j] / qs[j]) for i, j in enumerate(js)],
                 "q0": [float(cfg["centres"][j] + rng.uniform(-0.3, 0.3)) for j in js]}
        effects.append({"name": str(kind), "joints": [names[j] for j in js], "parameters": p})
    return effects


def rel(path):
    """`path` relative to the repository root when inside it (fixtures), else absolute."""
    r = os.path.relpath(path, mdc.ROOT)
    return path if r.startswith("..") else r


def robot_cases(name, out, duration, seed0, only=None, kinds=KINDS):
    """Simulates every case of one arm into OUT/<name>/ and writes its cases.json; with
    `only` (ids "robot/case"), just those (the others are drawn all the same, so a case
    is the same whichever are written). `duration`: seconds, or (lo, hi) to draw each case's
    length from its own seed. A random arm's cases get sensor variants (sensor_variants.py)."""
    out_r = os.path.join(out, name)
    cfg = cad_config(name, out_r)
    robot = ivdyn.Robot.from_urdf(cfg["urdf_path"], base=cfg["base"], tip=cfg["tip"])
    names = list(robot.joint_names)
    assert robot.link_names[-1] == cfg["terminal_link"], robot.link_names
    err_tau, err_m = mdc.check_agreement(robot, cfg=cfg)
    print(f"{name}: MuJoCo vs ivdyn on the clean model: tau {err_tau:.2e}, M {err_m:.2e}")
    if err_tau > mdc.AGREEMENT_TOL or err_m > mdc.AGREEMENT_TOL:
        sys.exit(f"{name}: MuJoCo and ivdyn disagree on the clean model; not writing anything")
    manifest = {"generator": "python/tools/make_cad_cases.py", "robot_urdf": rel(cfg["urdf_path"]),
                "base": cfg["base"], "tip": cfg["tip"], "terminal_link": cfg["terminal_link"], "joints": names,
                "topic": "/joint_states", "duration_s": duration, "cases": []}
    if "mjcf_path" in cfg:
        manifest.update(mujoco_model=rel(cfg["mjcf_path"]), random_arm=cfg["random_arm"],
                        agreement={"max_rel_tau": err_tau, "max_rel_mass_matrix": err_m, "states": 200},
                        torque_noise_std=cfg["torque_noise"])
    rng = np.random.default_rng(seed0)
    for li, level in enumerate(LEVELS):
        for count in range(4):
            seed = seed0 + 10 * li + count
            case = {"name": f"e{int(round(100 * level)):02d}_{count}fx", "seed": seed}
            case["effects"] = merge_levels(draw_effects(cfg, robot, names, seed, count, rng, kinds))
            nominal = os.path.join(out_r, f"{case['name']}_nominal.urdf")
            factors = nominal_urdf(cfg, nominal, level, rng)
            if only is not None and f"{name}/{case['name']}" not in only:
                os.remove(nominal)
                continue
            entry = write_case(cfg, robot, case, nominal, case_duration(duration, seed))
            full = {k: entry.pop(k) for k in ENTRY_KEYS}
            full["model_error"] = {"kind": "mass, inertia and COM scaled per link", "level": level,
                                   "true_urdf": rel(cfg["urdf_path"]), "mass_inertia_com_factor": factors}
            full.update(entry)
            manifest["cases"].append(full)
            print(f"  {case['name']}: {[(e['name'], e['joints']) for e in case['effects']]}"
                  + (f" sensor {entry['sensor']}" if "sensor" in entry else ""))
    with open(os.path.join(out_r, "cases.json"), "w") as f:
        json.dump(manifest, f, indent=1)
    return [f"{name}/{c['name']}" for c in manifest["cases"]]


# the first keys of a case in cases.json, in this order (then model_error, oracle, the rest)
ENTRY_KEYS = ["name", "log", "bytes", "urdf", "samples", "velocity_in_log", "seed", "effects", "torque_noise_std"]


def case_duration(duration, seed):
    """A fixed duration, or one drawn from U(lo, hi) s (whole seconds) with the case's seed."""
    if not isinstance(duration, tuple):
        return duration
    return float(np.random.default_rng(seed + 3000).integers(duration[0], duration[1] + 1))


def write_case(cfg, robot, case, nominal, duration):
    """Simulates and logs one case (its log next to `nominal`); returns its cases.json entry
    (without `model_error`). Random arms: the sensor variant from the seed + 2000 stream."""
    names = list(robot.joint_names)
    out_r = os.path.dirname(nominal)
    srng = np.random.default_rng(case["seed"] + 2000) if "mjcf_path" in cfg else None
    sensor = sensor_variants.draw(len(names), srng) if srng is not None else None
    times = sensor_variants.stamps(sensor, duration, mdc.DT, srng) if sensor else None
    sim, q_meas, qd_meas, tau_meas, noise = mdc.measured(cfg, case, robot, duration, times=times)
    ex = sim.get("log_states", sim)     # exact states at the log's stamps
    log = f"{case['name']}.mcap"
    eff = mdc.effect_torque(case["effects"], names, ex["q"], ex["qd"], ex["qdd"], robot, ex["t"])
    tau_true = robot.rnea(ex["q"], ex["qd"], ex["qdd"])
    tau_nom = ivdyn.Robot.from_urdf(nominal, base=cfg["base"], tip=cfg["tip"]).rnea(ex["q"], ex["qd"], ex["qdd"])
    oracle = {"effect_rms": mdc.rms(eff), "baseline_rms_exact": mdc.rms(tau_meas - tau_nom),
              "oracle_rms_exact": mdc.rms(tau_meas - tau_nom - eff),
              "oracle_rms_true_model": mdc.rms(tau_meas - tau_true - eff)}
    entry = {"name": case["name"], "log": log, "urdf": rel(nominal), "samples": len(ex["t"]),
             "velocity_in_log": True, "seed": case["seed"], "effects": case["effects"], "torque_noise_std": noise,
             "oracle": oracle}
    if mdc.FRICTION_SOLREF != "stiff":
        entry["friction_solref"] = mdc.FRICTION_SOLREF
    if mdc.STRIBECK != "constraint":
        entry["stribeck"] = mdc.STRIBECK
    if MOTION != "narrow":
        entry["motion"] = MOTION
    if RIPPLE_N != DEFAULT_RIPPLE_N:
        entry["ripple_n"] = list(RIPPLE_N)
    stamps_ns = None
    if sensor is not None:
        q_meas, qd_meas, tau_meas, repeats = sensor_variants.finish(sensor, ex["t"], q_meas, qd_meas, tau_meas, srng)
        stamps_ns = np.round(ex["t"] * 1e9).astype(np.int64)
        entry.update(velocity_in_log=sensor["velocity"], duration_s=duration,
                     diagnose_args=sensor_variants.diagnose_args(sensor), sensor=dict(sensor, republished=repeats))
        oracle["note"] = "exact states at the log's stamps, before re-publishing"
    entry["bytes"] = mdc.write_mcap(os.path.join(out_r, log), names, ex["t"], q_meas, qd_meas, tau_meas,
                                    stamps_ns=stamps_ns)
    return entry


def write_split(ids, out):
    """The split, fixed before any diagnosis runs: every third id of a seeded permutation is
    held out. Writes OUT/split.json."""
    perm = [ids[i] for i in np.random.default_rng(SPLIT_SEED).permutation(len(ids))]
    split = {"seed": SPLIT_SEED, "tune": sorted(perm[i] for i in range(len(perm)) if i % 3 != 2),
             "heldout": sorted(perm[i] for i in range(len(perm)) if i % 3 == 2)}
    with open(os.path.join(out, "split.json"), "w") as f:
        json.dump(split, f, indent=1)
    print(f"{len(ids)} cases: {len(split['tune'])} to tune on, {len(split['heldout'])} held out")


def parse_duration(text):
    """`--duration`: seconds, or LO:HI (whole seconds, drawn per case)."""
    if ":" in text:
        lo, hi = (int(v) for v in text.split(":"))
        return (lo, hi)
    return float(text)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="/tmp/cad_cases")
    ap.add_argument("--set", choices=["cad", "random"], default="cad", help="the four arms of the CAD set, or "
                    "randomly generated arms (random_arm.py) with sensor variants (sensor_variants.py)")
    ap.add_argument("--arms", type=int, default=6, help="--set random: how many arms (6 and 7 joints alternate; "
                    f"at most {len(RANDOM_ARMS)} with --first-arm)")
    ap.add_argument("--first-arm", type=int, default=0, help="--set random: the index of the first arm "
                    "(rarm<index>_...; 12 and beyond: arms no set before 2026-12-06 drew)")
    ap.add_argument("--duration", type=parse_duration, default=2.0, help="seconds per case, or LO:HI to draw "
                    "each case's length (whole seconds) from its seed, e.g. 20:60")
    ap.add_argument("--only", default=None, help="comma list of ids robot/case to write (default: all, "
                    "with split.json); fixtures/diagnose_cad holds a few cases of the tuning part")
    ap.add_argument("--no-drives", action="store_true", help="only the basic effect kinds (the set of the "
                    "first slices of issue 15, as it was drawn before the effects of real drives)")
    ap.add_argument("--friction-solref", choices=["stiff", "mujoco"], default="stiff", help="solref of the "
                    "friction-loss constraints: (2 dt, 1), the stiffest stable one, or MuJoCo's soft default "
                    "(0.02 s, 1), which makes Coulomb friction creep near zero velocity")
    ap.add_argument("--stribeck", choices=["constraint", "applied"], default="constraint", help="Stribeck "
                    "friction as the joint's frictionloss set every step (stick phases) or as an applied force "
                    "-(fc + fs exp(-(qd/vs)^2)) sign(qd) (no stick phase)")
    ap.add_argument("--kinds", default="", help="comma list of the kinds to draw from instead of the default "
                    f"(with {', '.join(EXTRA_KINDS)}, which the default leaves out)")
    ap.add_argument("--everywhere", default="", help="comma list of kinds drawn on every joint instead of 1-3 "
                    f"(of {', '.join(EVERYWHERE_KINDS)}); the draws of the other effects change with it")
    ap.add_argument("--ripple-n", default="", help="comma list of the ripple harmonics n (period 2 pi / n) "
                    f"to draw from instead of {RIPPLE_N} (the diagnosis's own grid): periods it was not tuned on")
    ap.add_argument("--motion", choices=["narrow", "wide"], default="narrow", help="--set random: the "
                    "reference's sweep: 0.4-0.6 Hz harmonics over 0.4-0.7 rad, or three times the angles at a "
                    "third of the frequency (same speeds; identification-like poses)")
    args = ap.parse_args(argv)
    global MOTION
    MOTION = args.motion
    if MOTION != "narrow" and args.set != "random":
        ap.error("--motion wide is for --set random (the CAD arms' amplitudes are set within their limits)")
    mdc.FRICTION_SOLREF = args.friction_solref
    mdc.STRIBECK = args.stribeck
    if args.ripple_n:
        try:
            RIPPLE_N[:] = [float(v) for v in args.ripple_n.split(",")]
        except ValueError:
            ap.error(f"--ripple-n: {args.ripple_n!r} is not a comma list of numbers")
        if not all(v > 0 for v in RIPPLE_N):
            ap.error(f"--ripple-n: harmonics must be positive, got {RIPPLE_N}")
    EVERYWHERE.clear()
    EVERYWHERE.update(k for k in args.everywhere.split(",") if k)
    if not EVERYWHERE <= set(EVERYWHERE_KINDS):
        ap.error(f"--everywhere: {sorted(EVERYWHERE - set(EVERYWHERE_KINDS))} not among {EVERYWHERE_KINDS}")
    kinds = KINDS if args.no_drives else KINDS + DRIVE_KINDS
    if args.kinds:
        kinds = args.kinds.split(",")
        unknown = sorted(set(kinds) - set(KINDS + DRIVE_KINDS + EXTRA_KINDS))
        if unknown:
            ap.error(f"--kinds: {unknown} not among {KINDS + DRIVE_KINDS + EXTRA_KINDS}")
    if args.set == "cad":
        arms = [(name, 1500 + 100 * i) for i, name in enumerate(["ur5", "panda", "ur3", "talos_arm"])]
    else:
        if args.first_arm < 0 or args.first_arm + args.arms > len(RANDOM_ARMS):
            ap.error(f"--first-arm {args.first_arm} --arms {args.arms}: the arms are rarm0 to rarm{len(RANDOM_ARMS) - 1}")
        arms = [(name, 5000 + 100 * i) for i, name in enumerate(RANDOM_ARMS)
                if args.first_arm <= i < args.first_arm + args.arms]
    ids = []
    only = None if args.only is None else set(args.only.split(","))
    for name, seed0 in arms:
        if only is None or any(x.startswith(name + "/") for x in only):
            ids += robot_cases(name, args.out, args.duration, seed0, only, kinds)
    if only is None:
        write_split(ids, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
