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
