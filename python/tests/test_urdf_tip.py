"""The loader's tip rules against Pinocchio on tests/data/arm7_hand.urdf (7 joints, a flange,
a hand and two finger joints beyond it, side branches on link3 and link5).

- ``tip="flange"``: the chain ends at the flange; Pinocchio's model of the same URDF with
  the hand, tcp and fingers removed from the file (and the side joint locked) has the same
  mass matrix and gravity torques.
- ``fuse_beyond_tip=True``: Pinocchio's reduced model of the whole file with the side and
  finger joints locked at 0 (``buildReducedModel``) has the same ones.
"""
import os
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import ivdyn

import pinocchio as pin

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
URDF = os.path.join(ROOT, "tests", "data", "arm7_hand.urdf")
BEYOND = {"hand", "tcp", "left_finger", "right_finger"}


def pin_model(path, locked):
    full = pin.buildModelFromUrdf(path)
    return pin.buildReducedModel(full, [full.getJointId(j) for j in locked], pin.neutral(full))


def truncated_urdf(tmp_path):
    """The URDF text with the links below the flange and their joints removed."""
    tree = ET.parse(URDF)
    root = tree.getroot()
    for el in list(root):
        if el.tag == "link" and el.get("name") in BEYOND:
            root.remove(el)
        if el.tag == "joint" and el.find("child").get("link") in BEYOND:
            root.remove(el)
    out = tmp_path / "arm7_to_flange.urdf"
    tree.write(out)
    return str(out)


def compare(robot, model, seed):
    assert [model.names[i] for i in range(1, model.njoints)] == robot.joint_names
    data = model.createData()
    rng = np.random.default_rng(seed)
    q = rng.uniform(-2.5, 2.5, (20, robot.dof))
    m_ivdyn = robot.mass_matrix(q)
    g_ivdyn = robot.gravity(q)
    for k in range(len(q)):
        m_pin = pin.crba(model, data, q[k])
        m_pin = np.triu(m_pin) + np.triu(m_pin, 1).T
        g_pin = pin.computeGeneralizedGravity(model, data, q[k])
        assert np.allclose(m_ivdyn[k], m_pin, rtol=1e-12, atol=1e-12), k
        assert np.allclose(g_ivdyn[k], g_pin, rtol=1e-12, atol=1e-12), k


def test_tip_at_the_flange_is_the_urdf_cut_at_the_flange(tmp_path):
    robot = ivdyn.Robot.from_urdf(URDF, tip="flange")
    assert set(robot.dropped_links) == BEYOND
    assert robot.locked_joints == ["cable_joint"]
    compare(robot, pin_model(truncated_urdf(tmp_path), ["cable_joint"]), 1)


def test_fuse_beyond_tip_is_pinocchios_reduced_model():
    robot = ivdyn.Robot.from_urdf(URDF, tip="flange", fuse_beyond_tip=True)
    assert robot.dropped_links == []
    assert ("hand", "link7") in robot.fused_links
    compare(robot, pin_model(URDF, ["cable_joint", "finger_joint1", "finger_joint2"]), 2)


def test_the_hand_mass_moves_between_the_two():
    cut = ivdyn.Robot.from_urdf(URDF, tip="flange")
    fused = ivdyn.Robot.from_urdf(URDF, tip="flange", fuse_beyond_tip=True)
    root = ET.parse(URDF).getroot()
    mass = {l.get("name"): float(l.find("inertial/mass").get("value"))
            for l in root.findall("link") if l.find("inertial") is not None}
    hand = sum(mass.get(name, 0.0) for name in BEYOND)
    m_cut, m_fused = cut.params[10 * 6], fused.params[10 * 6]
    assert m_cut == pytest.approx(mass["link7"] + mass["flange"], abs=1e-12)
    assert m_fused - m_cut == pytest.approx(hand, abs=1e-12)


def test_pipeline_takes_the_option_with_a_urdf_path(tmp_path):
    out = ivdyn.simulate(URDF, tmp_path / "a.csv", tip="flange", fuse_beyond_tip=True, duration=1.0)
    assert out["samples"] > 0
    with pytest.raises(ValueError, match="fuse_beyond_tip"):
        ivdyn.simulate(ivdyn.Robot.from_urdf(URDF, tip="flange"), tip="flange", fuse_beyond_tip=True)


def test_a_cad_export_loads_as_pinocchio_reads_it(tmp_path):
    """A `<texture />` without a file name (CAD exporters write it; urdfdom and Pinocchio read
    it, urdf-rs alone refuses it) in a visual of every link: the same dynamics as Pinocchio's
    model of that file. A link whose inertia no body has is named in ``notes``."""
    text = open(truncated_urdf(tmp_path)).read()
    tex = '<visual><geometry><box size="0.1 0.1 0.1"/></geometry><material name="m"><texture /></material></visual>'
    textured = tmp_path / "textured.urdf"
    textured.write_text(text.replace("</inertial>", "</inertial>" + tex))
    robot = ivdyn.Robot.from_urdf(str(textured), tip="flange")
    assert not any("no rigid body" in n for n in robot.notes), robot.notes
    compare(robot, pin_model(str(textured), ["cable_joint"]), 3)
    old = 'ixx="0.015" ixy="0.002" ixz="0.001" iyy="0.013" iyz="-0.001" izz="0.008"'
    assert old in text
    broken = tmp_path / "broken.urdf"
    broken.write_text(text.replace(old, 'ixx="-0.015" ixy="0" ixz="0" iyy="0.013" iyz="0" izz="0.008"'))
    notes = ivdyn.Robot.from_urdf(str(broken), tip="flange").notes
    assert any(n.startswith("link 'link3' is no rigid body") for n in notes), notes
