"""The robots used by the tests and fixtures: how each is loaded (base, tip, locked
joints), in the reference and in Pinocchio."""
from __future__ import annotations

import os
import tempfile

from . import model as rm

# A small hand-written arm exercising the URDF loader: a fixed root joint world ->
# base_link (identity), 5 movable joints (revolute, continuous, prismatic, revolute,
# revolute) with non-axis-aligned unit axes, origins with nonzero rpy, inertial origins
# with rpy and full inertia tensors, a fixed joint in the middle of the chain
# (link2 -> link2b), a fixed tool link after the tip joint, and a side branch
# (side_link hanging off link2 by a revolute joint, locked at q = 0).
TEST_ARM_URDF = """<?xml version="1.0"?>
<robot name="test_arm">
  <link name="world"/>
  <joint name="world_joint" type="fixed">
    <parent link="world"/>
    <child link="base_link"/>
    <origin xyz="0 0 0" rpy="0 0 0"/>
  </joint>
  <link name="base_link">
    <inertial>
      <origin xyz="0.01 0.02 0.05" rpy="0 0 0"/>
      <mass value="3.0"/>
      <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.03"/>
    </inertial>
  </link>
  <joint name="j1" type="revolute">
    <parent link="base_link"/>
    <child link="link1"/>
    <origin xyz="0.01 -0.02 0.15" rpy="0.1 -0.2 0.3"/>
    <axis xyz="0 0 1"/>
    <limit lower="-2.5" upper="2.5" effort="50" velocity="2"/>
  </joint>
  <link name="link1">
    <inertial>
      <origin xyz="0.02 0.01 0.08" rpy="0.3 0.1 -0.2"/>
      <mass value="2.1"/>
      <inertia ixx="0.012" ixy="0.0011" ixz="-0.0007" iyy="0.010" iyz="0.0009" izz="0.007"/>
    </inertial>
  </link>
  <joint name="j2" type="continuous">
    <parent link="link1"/>
    <child link="link2"/>
    <origin xyz="0.03 0.05 0.12" rpy="-0.4 0.25 0.6"/>
    <axis xyz="0.6 0 0.8"/>
  </joint>
  <link name="link2">
    <inertial>
      <origin xyz="0.15 -0.01 0.03" rpy="-0.2 0.4 0.1"/>
      <mass value="1.7"/>
      <inertia ixx="0.004" ixy="-0.0006" ixz="0.0004" iyy="0.021" iyz="0.0003" izz="0.019"/>
    </inertial>
  </link>
  <joint name="side_joint" type="revolute">
    <parent link="link2"/>
    <child link="side_link"/>
    <origin xyz="0.05 0.04 -0.02" rpy="0.5 0 -0.3"/>
    <axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="5" velocity="1"/>
  </joint>
  <link name="side_link">
    <inertial>
      <origin xyz="0.0 0.03 0.01" rpy="0.2 -0.1 0.4"/>
      <mass value="0.4"/>
      <inertia ixx="0.0009" ixy="0.0001" ixz="0.00005" iyy="0.0007" iyz="-0.00008" izz="0.0006"/>
    </inertial>
  </link>
  <joint name="mid_fixed" type="fixed">
    <parent link="link2"/>
    <child link="link2b"/>
    <origin xyz="0.3 0.01 -0.02" rpy="0.2 -0.3 0.15"/>
  </joint>
  <link name="link2b">
    <inertial>
      <origin xyz="0.02 0.0 0.01" rpy="0 0.3 0"/>
      <mass value="0.6"/>
      <inertia ixx="0.0011" ixy="0.0002" ixz="-0.0001" iyy="0.0013" iyz="0.00015" izz="0.0009"/>
    </inertial>
  </link>
  <joint name="j3" type="prismatic">
    <parent link="link2b"/>
    <child link="link3"/>
    <origin xyz="0.04 -0.03 0.02" rpy="0.35 0.2 -0.45"/>
    <axis xyz="0.48 0.6 0.64"/>
    <limit lower="-0.1" upper="0.2" effort="100" velocity="0.5"/>
  </joint>
  <link name="link3">
    <inertial>
      <origin xyz="0.05 0.02 -0.01" rpy="0.15 0.05 -0.25"/>
      <mass value="1.1"/>
      <inertia ixx="0.006" ixy="0.0005" ixz="0.0003" iyy="0.005" iyz="-0.0004" izz="0.004"/>
    </inertial>
  </link>
  <joint name="j4" type="revolute">
    <parent link="link3"/>
    <child link="link4"/>
    <origin xyz="0.12 0.0 0.03" rpy="-0.15 0.35 0.2"/>
    <axis xyz="0.36 -0.48 0.8"/>
    <limit lower="-2.0" upper="1.5" effort="20" velocity="3"/>
  </joint>
  <link name="link4">
    <inertial>
      <origin xyz="0.01 0.06 0.02" rpy="-0.3 0.2 0.5"/>
      <mass value="0.8"/>
      <inertia ixx="0.0025" ixy="-0.0003" ixz="0.0002" iyy="0.0018" iyz="0.0001" izz="0.0022"/>
    </inertial>
  </link>
  <joint name="j5" type="revolute">
    <parent link="link4"/>
    <child link="link5"/>
    <origin xyz="0.0 0.09 0.01" rpy="0.25 -0.1 0.05"/>
    <axis xyz="1 0 0"/>
    <limit lower="-3.0" upper="3.0" effort="10" velocity="3"/>
  </joint>
  <link name="link5">
    <inertial>
      <origin xyz="0.03 0.0 0.015" rpy="0.1 0.2 0.3"/>
      <mass value="0.35"/>
      <inertia ixx="0.0004" ixy="0.00003" ixz="-0.00002" iyy="0.0005" iyz="0.00004" izz="0.0003"/>
    </inertial>
  </link>
  <joint name="tool_joint" type="fixed">
    <parent link="link5"/>
    <child link="tool"/>
    <origin xyz="0.06 0.01 0.0" rpy="0 1.2 -0.3"/>
  </joint>
  <link name="tool">
    <inertial>
      <origin xyz="0.0 0.01 0.04" rpy="0.4 0 0.2"/>
      <mass value="0.3"/>
      <inertia ixx="0.0003" ixy="0.00002" ixz="0.00001" iyy="0.0002" iyz="-0.00003" izz="0.00025"/>
    </inertial>
  </link>
</robot>
"""

# name -> how the chain is chosen. Pinocchio always loads the whole URDF (its model
# starts at the URDF root) and then locks `locked` at its neutral configuration.
SPECS = {
    "ur5": dict(kind="urdf", file="ur5.urdf", base="base_link", tip="tool0", locked=[], seed=1),
    "panda7": dict(kind="urdf", file="panda.urdf", base="panda_link0", tip="panda_hand",
                   locked=["panda_finger_joint1", "panda_finger_joint2"], seed=2),
    "paper": dict(kind="dh", seed=3),
    "test_arm": dict(kind="urdf", file="test_arm.urdf", base="base_link", tip="tool",
                     locked=["side_joint"], seed=4),
}


def urdf_source(name):
    """Path of the original example-robot-data URDF of ur5 / panda7."""
    from .pinref import erd_urdf

    return erd_urdf({"ur5": "ur5", "panda7": "panda"}[name])


def build(name, urdf_path=None):
    """(reference ChainModel, Pinocchio Model) of a robot; drive params are zero.
    urdf_path overrides the URDF (e.g. the stripped copies in fixtures/)."""
    from . import pinref

    spec = SPECS[name]
    if spec["kind"] == "dh":
        return rm.paper_robot(), pinref.paper_model()
    if urdf_path is None and name == "test_arm":
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "test_arm.urdf")
            with open(path, "w") as f:
                f.write(TEST_ARM_URDF)
            return build(name, path)
    path = urdf_path or urdf_source(name)
    ref = rm.from_urdf(path, base=spec["base"], tip=spec["tip"])
    if sorted(ref.locked_joints) != sorted(spec["locked"]):
        raise AssertionError(f"{name}: reference locked {ref.locked_joints}, "
                             f"expected {spec['locked']}")
    return ref, pinref.urdf_model(path, spec["locked"])
