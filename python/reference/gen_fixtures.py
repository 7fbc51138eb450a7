#!/usr/bin/env python3
"""Regenerate fixtures/ (deterministic). Run from the repo root:

    .venv/bin/python python/reference/gen_fixtures.py

Writes fixtures/{ur5,panda,test_arm}.urdf, fixtures/dyn_{ur5,panda7,paper,test_arm}.json
and fixtures/MANIFEST.md. Every Pinocchio quantity is checked against the NumPy
reference (relative error <= 1e-10) before anything is written.
"""
from __future__ import annotations

import json
import math
import os
import sys
import xml.etree.ElementTree as ET

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import pinocchio as pin  # noqa: E402

from ivdyn_ref import dynamics as dy  # noqa: E402
from ivdyn_ref import model as rm  # noqa: E402
from ivdyn_ref import pinref, robots  # noqa: E402
from ivdyn_ref.pinref import rel_err  # noqa: E402

ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
OUT = os.path.join(ROOT, "fixtures")
TOL = 1e-10
N_SAMPLES = 16
GENERATOR = "python/reference/gen_fixtures.py"


# ------------------------------------------------------------------ URDF copies
def strip_urdf(src, dst):
    """Copy a URDF without its <visual> and <collision> elements (comments kept)."""
    parser = ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))
    tree = ET.parse(src, parser)
    for parent in tree.iter():
        for child in list(parent):
            if child.tag in ("visual", "collision"):
                parent.remove(child)
    ET.indent(tree, space="  ")
    tree.write(dst, encoding="utf-8", xml_declaration=True)
    with open(dst, "a") as f:
        f.write("\n")


# ------------------------------------------------------------------ JSON writer
def _num(x):
    if isinstance(x, (int, np.integer)):
        return str(int(x))
    x = float(x)
    if not math.isfinite(x):
        raise ValueError("non-finite value in fixture")
    return repr(x)  # shortest round-trip repr (<= 17 significant digits)


def _is_num(x):
    return isinstance(x, (float, int, np.floating, np.integer)) and not isinstance(x, bool)


def to_json(obj, ind=0):
    sp = "  " * ind
    if isinstance(obj, np.ndarray):
        obj = obj.tolist()
    if isinstance(obj, dict):
        items = [f'{sp}  {json.dumps(k)}: {to_json(v, ind + 1)}' for k, v in obj.items()]
        return "{\n" + ",\n".join(items) + "\n" + sp + "}"
    if isinstance(obj, (list, tuple)):
        obj = [o.tolist() if isinstance(o, np.ndarray) else o for o in obj]
        if all(_is_num(o) for o in obj):
            return "[" + ", ".join(_num(o) for o in obj) + "]"
        if all(isinstance(o, str) for o in obj):
            return "[" + ", ".join(json.dumps(o) for o in obj) + "]"
        if all(isinstance(o, (list, tuple)) and all(_is_num(e) for e in o) for o in obj):
            rows = [f"{sp}  " + to_json(o) for o in obj]
            return "[\n" + ",\n".join(rows) + "\n" + sp + "]"
        rows = [f"{sp}  " + to_json(o, ind + 1) for o in obj]
        return "[\n" + ",\n".join(rows) + "\n" + sp + "]"
    if _is_num(obj):
        return _num(obj)
    return json.dumps(obj)


# ------------------------------------------------------------------ samples
def limits(ref):
    lo, hi = ref.limits()
    return (np.where(np.isfinite(lo), lo, -math.pi), np.where(np.isfinite(hi), hi, math.pi))


def make_fixture(name, ref, pm, seed, errs):
    spec = robots.SPECS[name]
    n = ref.n
    rng = np.random.default_rng(seed)
    if name == "paper":
        drive = ref.drive.copy()  # fc = Table 2's F, fv = ia = tau0 = 0
    else:
        drive = np.column_stack([rng.uniform(0.1, 2.0, n), rng.uniform(0.01, 0.5, n),
                                 rng.uniform(0.0, 0.1, n), rng.uniform(-0.5, 0.5, n)])
    theta = np.concatenate([ref.links.ravel(), drive.ravel()])
    theta_rigid = np.concatenate([ref.links.ravel(), np.zeros(4 * n)])
    pinref.joint_ids(pm, ref.joint_names)
    ev = pinref.PinEval(pm)
    pa = pm.copy()
    pa.armature[:] = drive[:, 2]
    ev_arm = pinref.PinEval(pa)
    lo, hi = limits(ref)

    def check(key, actual, expected):
        e = rel_err(actual, expected)
        errs.setdefault(name, {})
        errs[name][key] = max(errs[name].get(key, 0.0), e)
        if not e <= TOL:
            raise AssertionError(f"{name}: {key} reference vs Pinocchio rel. error {e:.3e}")

    samples = []
    for _ in range(N_SAMPLES):
        q = rng.uniform(lo, hi)
        qd = rng.uniform(-2.0, 2.0, n)
        qd[rng.uniform(size=n) < 0.1] = 0.0
        qdd = rng.uniform(-2.0, 2.0, n)
        tau_fd = rng.uniform(-5.0, 5.0, n)

        tau_rigid = ev.rnea(q, qd, qdd)
        Y_rigid = ev.regressor(q, qd, qdd)
        M_rigid = ev.crba(q)
        g = ev.gravity(q)
        qdd_fd_rigid = ev.aba(q, qd, tau_fd)
        ke = ev.kinetic_energy(q, qd)
        pe = ev.potential_energy(q)

        tau = dy.rnea(ref, q, qd, qdd, theta)
        Y = dy.regressor(ref, q, qd, qdd)
        M = dy.mass_matrix(ref, q, theta)
        qdd_fd = dy.forward_dynamics(ref, q, qd, tau_fd, theta)

        check("tau_rigid", dy.rnea(ref, q, qd, qdd, theta_rigid), tau_rigid)
        check("Y_rigid", Y[:, :10 * n], Y_rigid)
        check("M_rigid", dy.mass_matrix(ref, q, theta_rigid), M_rigid)
        check("g", dy.gravity_torque(ref, q, theta), g)
        check("qdd_fd_rigid", dy.forward_dynamics(ref, q, qd, tau_fd, theta_rigid), qdd_fd_rigid)
        check("kinetic_energy", dy.kinetic_energy(ref, q, qd, theta), ke)
        check("potential_energy", dy.potential_energy(ref, q, theta), pe)
        # drive terms: internal identities and Pinocchio's armature
        check("Y@theta=tau", Y @ theta, tau)
        check("rnea(qdd_fd)=tau_fd", dy.rnea(ref, q, qd, qdd_fd, theta), tau_fd)
        check("M (pin armature)", M, ev_arm.crba(q))
        if not np.linalg.eigvalsh(M).min() > 0:
            raise AssertionError(f"{name}: M not positive definite")

        samples.append({
            "q": q, "qd": qd, "qdd": qdd, "tau_rigid": tau_rigid, "tau": tau,
            "Y_rigid": Y_rigid, "Y": Y, "M_rigid": M_rigid, "M": M, "g": g,
            "tau_fd": tau_fd, "qdd_fd": qdd_fd, "qdd_fd_rigid": qdd_fd_rigid,
            "kinetic_energy": ke, "potential_energy": pe,
        })

    if spec["kind"] == "dh":
        mdesc = {"kind": "dh", "dh": [{"a": a, "d": d, "alpha": al}
                                      for a, d, al in rm.paper_dh_rows()]}
    else:
        mdesc = {"kind": "urdf", "file": spec["file"], "base": spec["base"], "tip": spec["tip"],
                 "locked_joints": spec["locked"]}
    return {
        "name": name, "generator": GENERATOR, "seed": seed,
        "versions": {"pinocchio": pin.__version__, "numpy": np.__version__},
        "model": mdesc, "joint_names": ref.joint_names, "gravity": list(ref.gravity),
        "theta": theta, "samples": samples,
    }


# ------------------------------------------------------------------ manifest
MANIFEST = """# fixtures/

Generated by one command from the repo root (deterministic, no network):

    .venv/bin/python {generator}

Versions: pinocchio {pin}, numpy {np}. Seeds (numpy `default_rng`): {seeds}.
Do not edit by hand; change the generator and rerun.

## Files
| file | what |
|---|---|
| `ur5.urdf` | example-robot-data 6.0.0 `ur_description/urdf/ur5_robot.urdf`, `<visual>`/`<collision>` removed |
| `panda.urdf` | example-robot-data 6.0.0 `panda_description/urdf/panda.urdf`, `<visual>`/`<collision>` removed |
| `test_arm.urdf` | hand-written 5-DoF arm exercising the URDF loader (see below) |
| `dyn_ur5.json` | UR5: base `base_link`, tip `tool0`, nothing locked, random drive params |
| `dyn_panda7.json` | Panda arm: base `panda_link0`, tip `panda_hand`, `panda_finger_joint1/2` locked at 0 (fingers fused into link 7), random drive params |
| `dyn_paper.json` | the paper's robot (Table 1 DH, Table 2 inertias), drive = [F_i, 0, 0, 0] |
| `dyn_test_arm.json` | test arm: base `base_link`, tip `tool`, `side_joint` locked at 0, random drive params |

`test_arm.urdf`: root `world` -- fixed identity `world_joint` --> `base_link`; movable joints
j1 (revolute, z), j2 (continuous, axis (0.6, 0, 0.8)), j3 (prismatic, axis (0.48, 0.6, 0.64)),
j4 (revolute, axis (0.36, -0.48, 0.8)), j5 (revolute, x); a fixed joint `mid_fixed`
(link2 -> link2b) between j2 and j3; a fixed `tool_joint` (link5 -> tool) after j5; a side
branch `side_joint` (revolute) link2 -> side_link, locked at 0. All joint origins and
inertial origins have nonzero rpy; inertia tensors are full.

## JSON schema (`dyn_*.json`)
Top level: `name`, `generator`, `seed`, `versions` {{pinocchio, numpy}}, `model`
(`{{"kind": "urdf", "file", "base", "tip", "locked_joints"}}` or `{{"kind": "dh", "dh": [{{"a", "d",
"alpha" (rad)}}]}}`), `joint_names`, `gravity`, `theta` (14 N), `samples` (16 each).
Per sample (vectors length N, matrices as lists of rows):

| key | meaning | source |
|---|---|---|
| `q`, `qd`, `qdd` | state; q uniform in the joint limits (±pi if continuous/unlimited), qd, qdd uniform in [-2, 2], ~10 % of qd entries exactly 0.0 | rng |
| `tau_rigid` | rigid-body inverse dynamics (no drive terms) | Pinocchio `rnea` |
| `tau` | `tau_rigid + fc sign(qd) + fv qd + ia qdd + tau0` | reference |
| `Y_rigid` | N x 10N rigid regressor | Pinocchio `computeJointTorqueRegressor` |
| `Y` | N x 14N full regressor, `Y @ theta == tau` | reference |
| `M_rigid` | mass matrix, rigid | Pinocchio `crba` (upper triangle symmetrised) |
| `M` | `M_rigid + diag(ia)` | reference |
| `g` | gravity torque `rnea(q, 0, 0)` | Pinocchio `computeGeneralizedGravity` |
| `tau_fd` | random torque in [-5, 5] | rng |
| `qdd_fd` | `M^-1 (tau_fd - h(q, qd) - fc sign(qd) - fv qd - tau0)`, M with armature | reference |
| `qdd_fd_rigid` | forward dynamics of `tau_fd` with all drive params zero | Pinocchio `aba` |
| `kinetic_energy`, `potential_energy` | rigid (no armature term); `V = -sum m_i g . c_i` | Pinocchio |

Every Pinocchio value was checked against the NumPy reference before writing; the
reference-only values (`tau`, `Y`, `M`, `qdd_fd`) were checked by identities
(`Y @ theta == tau`, `rnea(q, qd, qdd_fd) == tau_fd`) and `M` against Pinocchio with
`model.armature = ia`. Max relative error (|diff| / max(|expected|, 1)) over the 16 samples:

{errtable}

## Conventions (the Rust core follows the same)
- Serial chain of N one-DoF joints (revolute or prismatic), fixed base. Link i's frame is
  joint i's frame (URDF child link frame of joint i = Pinocchio's joint frame i). Joint i:
  `T = origin_i * Motion(axis_i, q_i)`, origin = (xyz, rpy) with R = Rz(y) Ry(p) Rx(r),
  unit axis in link i's frame through link i's origin.
- Fixed joints are fused (child inertia added to the parent, origins composed into the next
  movable joint's origin). Links hanging off the chain are fused into their chain ancestor
  with their movable joints locked at q = 0 (Pinocchio: `buildReducedModel` at
  `pin.neutral`). Links above the base, and links fused into the base, are ignored.
- Gravity in the base frame: (0, 0, -9.81) m/s^2.
- Link parameters (10 per link, about the link ORIGIN, link coordinates, Pinocchio order):
  `[m, m cx, m cy, m cz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]`.
- Drive parameters per joint `[fc, fv, ia, tau0]`:
  `tau_i = rnea_rigid_i + fc_i sign(qd_i) + fv_i qd_i + ia_i qdd_i + tau0_i`, sign(0) = 0.
- `theta = [link_1 (10) .. link_N (10), drive_1 (4) .. drive_N (4)]`, length 14 N.
- `Y` columns: first 10 N = rigid part (same as Pinocchio's regressor), then for joint i the
  columns 10N+4i .. 10N+4i+3 are `[sign(qd_i), qd_i, qdd_i, 1]` on row i only.
- `M = M_rigid + diag(ia)`; forward dynamics solves `M qdd = tau - h - fc sign(qd) - fv qd - tau0`
  with `h = rnea_rigid(q, qd, 0)`.
- Only joint-space quantities are stored, so Pinocchio's [linear; angular] spatial order
  does not matter. `q` is one number per joint (Pinocchio's continuous joints use
  (cos q, sin q) internally; converted).
- Paper's robot: standard DH `T_{{i-1,i}} = Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i)`; joint i is
  revolute about z of its joint frame, with origin `X_{{i-1}} = Tz(d_{{i-1}}) Tx(a_{{i-1}})
  Rx(alpha_{{i-1}})` (identity for joint 1). Table 2's COM s_i and inertia (about the COM, DH
  frame i = joint frame i * X_i) are moved into joint frame i: COM' = X_i s_i, I' = Rx(alpha_i) I
  Rx(alpha_i)^T. Drive: fc = Table 2's F, fv = ia = tau0 = 0. Since cos(pi/2) is not exactly
  0 in floating point, some of its `theta` entries are ~1e-18 instead of 0 (same in Pinocchio).

## Pinocchio notes (pin 4.1)
- Its model starts at the URDF root (`world` for ur5.urdf and test_arm.urdf). Fixed joints
  become frames, and the inertia of every link rigidly attached to the root (`world`,
  `base_link`, UR5's `base`) goes to the universe body, so it plays no part in the dynamics.
  That matches "links above / fused into the base are ignored". `world_joint` is the identity
  in both files, so the base frame = Pinocchio's world frame and gravity needs no rotation.
- `model.armature` IS included by `rnea`, `crba` and `aba`. The fixtures' Pinocchio values
  were computed with armature 0; `M` was checked against `crba` with `armature = ia`.
- URDF `<dynamics damping/friction>` go into `model.damping` / `model.friction` but are not
  used by `rnea` / `aba` (the Panda URDF has damping 0.003).
- `buildModelFromUrdf(path)` defaults to `mimic=False`: `panda_finger_joint2` is an ordinary
  joint there, and both finger joints are locked at 0 by `buildReducedModel`.
- Continuous joints have nq = 2, (cos q, sin q) (`JointModelRevoluteUnboundedUnaligned` for
  j2 of the test arm). Axis-aligned revolute joints become RX/RY/RZ, others
  `RevoluteUnaligned` / `PrismaticUnaligned`. Joint-space outputs have nv = N.
"""


def main():
    os.makedirs(OUT, exist_ok=True)
    strip_urdf(pinref.erd_urdf("ur5"), os.path.join(OUT, "ur5.urdf"))
    strip_urdf(pinref.erd_urdf("panda"), os.path.join(OUT, "panda.urdf"))
    with open(os.path.join(OUT, "test_arm.urdf"), "w") as f:
        f.write(robots.TEST_ARM_URDF)

    errs = {}
    written = []
    for name, spec in robots.SPECS.items():
        if spec["kind"] == "urdf":
            path = os.path.join(OUT, spec["file"])
            ref, pm = robots.build(name, path)
            # the stripped copy must load exactly like the original
            ref0, _ = robots.build(name)
            assert np.array_equal(ref.links, ref0.links), name
        else:
            ref, pm = robots.build(name)
        fx = make_fixture(name, ref, pm, spec["seed"], errs)
        fn = os.path.join(OUT, f"dyn_{name}.json")
        with open(fn, "w") as f:
            f.write(to_json(fx) + "\n")
        # must parse back to the same numbers
        with open(fn) as f:
            back = json.load(f)
        assert np.array_equal(np.array(back["theta"]), fx["theta"])
        assert np.array_equal(np.array(back["samples"][3]["Y"]), fx["samples"][3]["Y"])
        written.append(fn)

    keys = list(next(iter(errs.values())).keys())
    errtable = "| quantity | " + " | ".join(errs) + " |\n|---|" + "---|" * len(errs) + "\n"
    for k in keys:
        errtable += f"| {k} | " + " | ".join(f"{errs[r][k]:.1e}" for r in errs) + " |\n"
    seeds = ", ".join(f"{n} {s['seed']}" for n, s in robots.SPECS.items())
    with open(os.path.join(OUT, "MANIFEST.md"), "w") as f:
        f.write(MANIFEST.format(generator=GENERATOR, pin=pin.__version__, np=np.__version__,
                                seeds=seeds, errtable=errtable.rstrip("\n")))
    print(errtable)
    total = 0
    for fn in sorted(os.listdir(OUT)):
        sz = os.path.getsize(os.path.join(OUT, fn))
        total += sz
        print(f"{sz:>9}  fixtures/{fn}")
    print(f"{total:>9}  total")
    if total > 2_000_000:
        raise SystemExit("fixtures exceed 2 MB")


if __name__ == "__main__":
    main()
