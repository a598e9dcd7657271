"""Small model files for tests that need a file on disk (written into a temporary folder)."""

from __future__ import annotations

from pathlib import Path

FLAWED_URDF = """<?xml version="1.0"?>
<robot name="flawed">
  <link name="bus"><inertial><origin xyz="0 0 0"/><mass value="500"/>
    <inertia ixx="80" iyy="90" izz="60" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l1"><inertial><origin xyz="0.3 0 0"/><mass value="10"/>
    <inertia ixx="0.1" iyy="0.5" izz="0.5" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l2"><inertial><origin xyz="0.2 0 0"/><mass value="5"/>
    <inertia ixx="0.1" iyy="0.1" izz="0.5" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="tool"/>
  <joint name="q1" type="revolute"><parent link="bus"/><child link="l1"/><origin xyz="0.5 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="10" velocity="1"/></joint>
  <joint name="s2" type="prismatic"><parent link="l1"/><child link="l2"/><origin xyz="0.6 0 0"/><axis xyz="1 0 0"/>
    <limit lower="-0.2" upper="0.3" effort="10" velocity="1"/></joint>
  <joint name="tool_mount" type="fixed"><parent link="l2"/><child link="tool"/><origin xyz="0.4 0 0"/></joint>
</robot>
"""


def flawed_urdf(directory: Path) -> Path:
    """A spacecraft with a revolute and a prismatic joint, a tool frame, and link l2's inertia breaking the triangle inequality."""
    path = Path(directory) / "flawed.urdf"
    path.write_text(FLAWED_URDF, encoding="utf-8")
    return path


#: An MJCF arm that uses what MJCF allows and URDF does not: a hinge away from its body's origin, a
#: slide joint, a welded body, sites, an inertia frame given by a quaternion (tests/io/test_mjcf.py).
HAND_WRITTEN = """<mujoco model="offset_arm">
  <compiler angle="radian" autolimits="true"/>
  <option gravity="0 0 0"/>
  <worldbody>
    <body name="bus">
      <freejoint name="root"/>
      <inertial pos="0.05 -0.02 0.1" mass="400" diaginertia="60 70 50" quat="0.9 0.1 0.3 0.2"/>
      <body name="camera_mast" pos="0 -0.8 0.3">
        <inertial pos="0 0 0.2" mass="4" diaginertia="0.05 0.05 0.01"/>
        <site name="camera"/>
      </body>
      <body name="upper" pos="0.6 0 0.2" quat="0.96 0 0.28 0">
        <joint name="shoulder" type="hinge" pos="0.1 0.05 -0.05" axis="0 0.6 0.8" range="-2 2"/>
        <inertial pos="0.4 0 0" mass="12" fullinertia="0.05 0.9 0.9 0.01 0 0.02"/>
        <body name="slider" pos="0.8 0 0">
          <joint name="extend" type="slide" axis="1 0.1 0" range="-0.2 0.3"/>
          <inertial pos="0.3 0.02 0" mass="6" diaginertia="0.02 0.3 0.3"/>
          <body name="wrist" pos="0.6 0 0" euler="0.3 -0.2 0.1">
            <joint name="wrist" type="hinge" pos="0.05 0 0" axis="1 0 0"/>
            <inertial pos="0.1 0 0.01" mass="2" diaginertia="0.01 0.012 0.015"/>
            <body name="tool_plate" pos="0.2 0 0">
              <inertial pos="0.02 0 0" mass="0.5" diaginertia="0.001 0.001 0.0015"/>
              <site name="grip" pos="0.05 0.01 0"/>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
