"""`ivdyn.payload(..., write_urdf=...)` read by MuJoCo (an independent URDF compiler that
refuses impossible inertias: "inertia must have positive eigenvalues", "A + B >= C").

A 2 kg point mass (zero inertia about its COM, on the boundary of the rigid bodies, so the
least-squares inertia comes out impossible in most logs) and a log with no payload at all:
the URDF written must load in MuJoCo, with the payload's mass added to the last body, and
the payload's inertia in the file must be positive definite with strict triangle
inequalities. The report's new sections reach Python.
"""
import os
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest

import ivdyn

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
UR5 = os.path.join(ROOT, "fixtures", "ur5.urdf")
COM = [0.01, -0.02, 0.05]


@pytest.fixture(scope="module")
def ur5():
    return ivdyn.Robot.from_urdf(UR5, base="base_link", tip="tool0")


def payload_inertia(path):
    """Mass and 3 x 3 inertia about the COM of the `ivdyn_payload` link in the file."""
    (link,) = [e for e in ET.parse(path).getroot().findall("link") if e.get("name") == "ivdyn_payload"]
    i = {k: float(v) for k, v in link.find("inertial").find("inertia").attrib.items()}
    m = float(link.find("inertial").find("mass").get("value"))
    return m, np.array([[i["ixx"], i["ixy"], i["ixz"]], [i["ixy"], i["iyy"], i["iyz"]], [i["ixz"], i["iyz"], i["izz"]]])


def last_body(path):
    m = mujoco.MjModel.from_xml_path(str(path))   # raises on an impossible inertia
    return m.body_mass[-1], m.body_inertia[-1]


@pytest.mark.parametrize("mass, seed", [(2.0, 5), (None, 6)])
def test_written_payload_loads_in_mujoco(ur5, tmp_path, mass, seed):
    kw = {} if mass is None else {"payload_mass": mass, "payload_com": COM}
    log = ivdyn.simulate(ur5, duration=10, noise=0.1, seed=seed, **kw)["log"]
    nominal_mass, _ = last_body(UR5)
    for mode in ["link", "merge"]:
        out = tmp_path / f"{mode}.urdf"
        rep = ivdyn.payload(ur5, log, write_urdf=out, payload_as=mode)
        ph = rep["physical"]
        assert rep["identifiable"] and rep["before_check"] is None
        assert ph["violation"]["possible"] and ph["violation"]["min_principal_moment"] > 0
        if mass is not None:
            assert abs(rep["mass"] - mass) < 0.03 * mass
            assert np.linalg.norm(np.subtract(rep["com"], COM)) < 0.01
        else:
            assert 0 <= rep["mass"] < 3 * rep["mass_std"]
            assert any(n.startswith("no payload detected") for n in rep["notes"])
        body_mass, body_inertia = last_body(out)
        # MuJoCo fuses the fixed payload link into the last body (or it was merged)
        assert body_mass == pytest.approx(nominal_mass + rep["mass"], rel=1e-9, abs=1e-12)
        assert np.all(body_inertia > 0)
        if mode == "link":
            m, ic = payload_inertia(out)
            eig = np.linalg.eigvalsh(ic)
            assert m == pytest.approx(rep["mass"], rel=1e-12)
            assert eig.min() > 0 and eig[0] + eig[1] > eig[2], eig
            print(f"{'no payload' if mass is None else 'point mass'}: LS possible {ph['ls_possible']}, "
                  f"LS min eig J {ph['ls_violation']['min_eig_pseudo_inertia']:.2e}, written moments {eig}")


def test_payload_from_fit_has_the_physical_section(ur5):
    """The array-level entry: a point-mass payload fitted on the terminal columns."""
    rng = np.random.default_rng(3)
    T = 400
    Q = rng.uniform(-np.pi, np.pi, (T, 6))
    QD, QDD = rng.uniform(-1, 1, (T, 6)), rng.uniform(-2, 2, (T, 6))
    heavy = ivdyn.Robot.from_urdf(UR5, base="base_link", tip="tool0")
    first = ur5.param_names.index("wrist_3_link.m")
    theta = np.array(ur5.params)
    theta[first:first + 4] += [2.0, 2.0 * COM[0], 2.0 * COM[1], 2.0 * COM[2]]
    c = np.array(COM)
    io = 2.0 * (c @ c * np.eye(3) - np.outer(c, c))   # point mass: inertia about the origin
    theta[first + 4:first + 10] += [io[0, 0], io[0, 1], io[1, 1], io[0, 2], io[1, 2], io[2, 2]]
    heavy.params = theta
    tau = heavy.rnea(Q, QD, QDD) - ur5.rnea(Q, QD, QDD) + 0.05 * rng.normal(size=(T, 6))
    tb = ivdyn.terminal_base(ur5, first_row=0)
    Y = ur5.regressor(Q, QD, QDD)[:, :, first:first + 10]
    fit = ivdyn.fit_ls(tb.select(Y).reshape(-1, tb.base_count), tau.ravel(), names=tb.names)
    p = ivdyn.payload_from_fit(tb, fit, list(range(10)), tb.names)
    assert abs(p["mass"] - 2.0) < 0.03 * 2.0
    assert p["physical"]["violation"]["possible"]
    assert set(p["physical"]) >= {"ls_possible", "ls_params", "mahalanobis2", "p_value", "dof", "violation"}
    assert p["physical"]["dof"] == 10 and 0 <= p["physical"]["p_value"] <= 1
