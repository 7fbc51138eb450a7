#!/usr/bin/env python3
"""How much of a rigid-body look-alike a generated case's motion can tell from the CAD error.

A torque offset, the constant of direction-dependent friction on a moving joint, a torque gain,
an armature and a spring each add a column that the nominal re-fit (the base parameters of the
links before the terminal one, docs/diagnose.md "The nominal re-fit") may span in part: over a
short sweep a constant on a gravity-loaded joint is a change of the links' first moments. For
each true pair of those kinds this gives the part of its torque that the rigid-body columns
leave (least squares over the case's reference motion, every 10th sample, no ridge; a spring's
position column beside a constant on its joint, and a constant beside an offset or the constant
of direction-dependent friction where another true effect on the joint holds one: a spring, an
offset, direction-dependent friction), as an RMS in the joint's torque noise standard
deviations. No method can name from the log what that part does not show.

    from lookalike_identifiability import identifiable_parts
    z = identifiable_parts(root, manifest, case)   # {(effect, joint): noise std}

`score_diagnose_cases.py --identifiability` prints, per kind, the true pairs found against that
part (below 1, 1-2, at least 2 noise std).
"""
import atexit
import contextlib
import io
import os
import shutil
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
import make_cad_cases as mcc  # noqa: E402
import make_diagnose_cases as mdc  # noqa: E402
import ivdyn  # noqa: E402

KINDS = ("torque_offset", "asymmetric_coulomb_friction", "torque_gain", "armature", "joint_spring")
BINS = [(0.0, 1.0), (1.0, 2.0), (2.0, float("inf"))]
_CONFIGS = {}


def reference_motion(robot_name, case):
    """The motion the case's arm tracks: its reference, scaled within the velocity limits as
    the generator simulates it (`mdc.simulate`)."""
    motion = case.get("motion", "narrow")
    key = (robot_name, motion)
    if key not in _CONFIGS:
        mcc.MOTION = motion
        with contextlib.redirect_stdout(io.StringIO()):
            tmp = tempfile.mkdtemp(prefix="ivdyn_ident_")
            atexit.register(shutil.rmtree, tmp, ignore_errors=True)
            _CONFIGS[key] = mcc.cad_config(robot_name, tmp)
        mcc.MOTION = "narrow"
    cfg = _CONFIGS[key]
    t = np.arange(case["samples"]) * mdc.DT
    q, qd, qdd = mdc.reference(cfg, case["seed"], t)
    if cfg.get("check_reference"):
        robot = ivdyn.Robot.from_urdf(cfg["urdf_path"], base=cfg["base"], tip=cfg["tip"])
        with contextlib.redirect_stdout(io.StringIO()):
            q, qd, qdd = mdc.within_velocity_limits(cfg, cfg["urdf_path"], list(robot.joint_names), q, qd, qdd)
    return q, qd, qdd


def _column(e, i, j, q, qdd, tau):
    """Joint `j`'s torque of parameter set `i` of effect `e` (one value per sample)."""
    p = e["parameters"]
    if e["name"] == "torque_offset":
        return np.full(len(q), p["tau0"][i])
    if e["name"] == "asymmetric_coulomb_friction":
        return np.full(len(q), (p["fc_pos"][i] - p["fc_neg"][i]) / 2)
    if e["name"] == "torque_gain":
        return (p["k"][i] - 1.0) * tau[:, j]
    if e["name"] == "armature":
        return p["ia"][i] * qdd[:, j]
    return -p["k"][i] * (q[:, j] - q[:, j].mean())       # joint_spring


def _constant_beside(case, e, jn):
    """Whether a constant look-alike `e` (an offset, a direction-dependent friction's
    constant) shares joint `jn` with another true effect that holds a constant: a spring (its
    `q0` free: `k q0`), an offset, a direction-dependent friction. Only their sum shows."""
    if e["name"] not in ("torque_offset", "asymmetric_coulomb_friction"):
        return False
    holds = ("joint_spring", "torque_offset", "asymmetric_coulomb_friction")
    return any(o is not e and o["name"] in holds and jn in o["joints"] for o in case["effects"])


def identifiable_parts(root, manifest, case):
    """{(effect, joint): RMS of its torque outside the rigid-body columns, in noise std}."""
    robot_name = os.path.basename(os.path.normpath(manifest.get("_dir", root)))
    pairs = [(e, i, jn) for e in case["effects"] if e["name"] in KINDS for i, jn in enumerate(e["joints"])]
    if not pairs:
        return {}
    q, qd, qdd = (x[::10] for x in reference_motion(robot_name, case))
    urdf = case["urdf"] if os.path.isabs(case["urdf"]) else os.path.join(manifest.get("_dir", root), os.path.basename(case["urdf"]))
    robot = ivdyn.Robot.from_urdf(urdf, base=manifest["base"], tip=manifest["tip"])
    n = robot.dof
    y = np.vstack([np.asarray(robot.regressor(q[k], qd[k], qdd[k]))[:, :10 * (n - 1)] for k in range(len(q))])
    u, s, _ = np.linalg.svd(y, full_matrices=False)
    rigid = u[:, : int((s > s[0] * 1e-9).sum())]
    tau = np.asarray(robot.rnea(q, qd, qdd))
    sig = case.get("torque_noise_std") or manifest["torque_noise_std"]
    out = {}
    for e, i, jn in pairs:
        j = manifest["joints"].index(jn)
        col = np.zeros(y.shape[0])
        col[j::n] = _column(e, i, j, q, qdd, tau)
        basis = rigid
        if e["name"] == "joint_spring" or _constant_beside(case, e, jn):
            one = np.zeros(y.shape[0])
            one[j::n] = 1.0
            basis = np.linalg.qr(np.column_stack([rigid, one]))[0]
        left = col - basis @ (basis.T @ col)
        out[(e["name"], jn)] = float(np.sqrt(np.mean(left[j::n] ** 2)) / sig[j])
    return out


def table(rows):
    """Markdown table of (kind, part, status) rows: per kind, found of required per bin."""
    lines = ["| look-alike | part < 1 noise std | 1-2 | >= 2 |", "|---|---|---|---|"]
    for kind in KINDS:
        cells = []
        for lo, hi in BINS:
            sel = [st for k, z, st in rows if k == kind and lo <= z < hi and st != "optional"]
            cells.append(f"{sum(st == 'found' for st in sel)} of {len(sel)}")
        lines.append(f"| {kind} | " + " | ".join(cells) + " |")
    return "\n".join(lines)
