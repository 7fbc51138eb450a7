"""`ivdyn identify --write-urdf` read by Pinocchio (the independent URDF parser and RNEA).

Runs the `ivdyn` binary: simulate a UR5 log, identify it with --consistent, write the URDF,
its side file and the parameter file. Then Pinocchio's rnea on the written URDF must equal
Pinocchio's rnea on the original URDF whose link inertias are set from the parameter file
(standard parameters, Pinocchio's dynamic-parameter order), and the URDF <dynamics> and the
side file must carry the parameter file's friction, armature and offsets.
"""
import json
import os
import subprocess
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
UR5 = os.path.join(ROOT, "fixtures", "ur5.urdf")


def ivdyn(exe, *args):
    subprocess.run([exe, *args, "--quiet"], cwd=ROOT, check=True, stdout=subprocess.DEVNULL)


@pytest.fixture(scope="module")
def written(tmp_path_factory, ivdyn_bin):
    d = tmp_path_factory.mktemp("wb")
    log, out, params = d / "log.mcap", d / "out.urdf", d / "params.json"
    chain = ["--urdf", UR5, "--base", "base_link", "--tip", "tool0"]
    ivdyn(ivdyn_bin, "simulate", *chain, "--duration", "10", "--rate", "200", "--fc", "2,2,1.5,0.6,0.6,0.4",
          "--fv", "0.8,0.8,0.5,0.2,0.2,0.1", "--noise", "0.05", "--out", str(log))
    ivdyn(ivdyn_bin, "identify", *chain, "--log", str(log), "--consistent", "--write-urdf", str(out),
          "--out-params", str(params))
    with open(params) as f:
        p = json.load(f)
    with open(str(out) + ".json") as f:
        side = json.load(f)
    return out, p, side


def test_pinocchio_rnea_on_written_urdf(written):
    out, p, _ = written
    mw = pin.buildModelFromUrdf(str(out))
    mo = pin.buildModelFromUrdf(UR5)
    joints = p["joints"]
    theta = np.array(p["theta"])
    for k, name in enumerate(joints):
        jid = mo.getJointId(name)
        assert mw.getJointId(name) == jid
        mo.inertias[jid] = pin.Inertia.FromDynamicParameters(theta[10 * k:10 * k + 10])
    dw, do = mw.createData(), mo.createData()
    rng = np.random.default_rng(5)
    worst = 0.0
    for _ in range(50):
        q = rng.uniform(-3, 3, mo.nq)
        v = rng.uniform(-2, 2, mo.nv)
        a = rng.uniform(-5, 5, mo.nv)
        tw = pin.rnea(mw, dw, q, v, a)
        to = pin.rnea(mo, do, q, v, a)
        worst = max(worst, np.abs(tw - to).max())
    assert worst < 1e-9, worst


def test_dynamics_and_side_file_carry_the_drive_parameters(written):
    out, p, side = written
    n = len(p["joints"])
    theta = np.array(p["theta"])
    drive = theta[10 * n:].reshape(n, 4)  # fc, fv, ia, tau0
    root = ET.parse(out).getroot()
    for k, name in enumerate(p["joints"]):
        (j,) = [e for e in root.findall("joint") if e.get("name") == name]
        dyn = j.find("dynamics")
        assert float(dyn.get("friction")) == drive[k, 0]
        assert float(dyn.get("damping")) == drive[k, 1]
    assert side["format"] == "ivdyn-urdf-side/1"
    assert side["joints"] == p["joints"]
    assert side["armature"] == list(drive[:, 2])
    assert side["tau0"] == list(drive[:, 3])
    # consistent parameters: every link's pseudo-inertia positive definite
    for k in range(n):
        pi = theta[10 * k:10 * k + 10]
        io = np.array([[pi[4], pi[5], pi[7]], [pi[5], pi[6], pi[8]], [pi[7], pi[8], pi[9]]])
        J = np.zeros((4, 4))
        J[:3, :3] = 0.5 * np.trace(io) * np.eye(3) - io
        J[:3, 3] = J[3, :3] = pi[1:4]
        J[3, 3] = pi[0]
        assert np.linalg.eigvalsh(J).min() > 0
    assert (drive[:, :3] >= 0).all()
