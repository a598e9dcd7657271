"""Load a space robot from URDF, inspect its barycentric vectors, and save it as TOML."""

import tempfile
from pathlib import Path

import numpy as np

import freefloat as ff

URDF = """<?xml version="1.0"?>
<robot name="tiny_spacecraft">
  <link name="bus"><inertial><origin xyz="0 0 0"/><mass value="200"/>
    <inertia ixx="20" iyy="25" izz="30" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="upper"><inertial><origin xyz="0.4 0 0"/><mass value="8"/>
    <inertia ixx="0.01" iyy="0.45" izz="0.45" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="fore"><inertial><origin xyz="0.35 0 0"/><mass value="5"/>
    <inertia ixx="0.01" iyy="0.2" izz="0.2" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="tool0"/>
  <joint name="shoulder" type="revolute"><parent link="bus"/><child link="upper"/>
    <origin xyz="0.6 0 0.3" rpy="0 0 0"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="50" velocity="1"/></joint>
  <joint name="elbow" type="continuous"><parent link="upper"/><child link="fore"/>
    <origin xyz="0.8 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/></joint>
  <joint name="flange" type="fixed"><parent link="fore"/><child link="tool0"/>
    <origin xyz="0.7 0 0" rpy="0 0 0"/></joint>
</robot>
"""

with tempfile.TemporaryDirectory() as tmp:
    path = Path(tmp) / "tiny.urdf"
    path.write_text(URDF)
    model = ff.load(path)
    print(model, "| planar:", model.is_planar)
    print(
        "end effector", model.end_effector_names[0], "at", model.end_effector_point[0], "in", model.body_names[model.end_effector_body[0]]
    )
    bv = ff.barycentric_vectors(model)
    for k, name in enumerate(model.body_names):
        print(f"  {name:6s} mu*={bv.outboard_mass_fraction[k]:.4f}  c*={bv.c_star[k].round(4)}  l*={bv.l_star[k].round(4)}")
    print("r_E at q = 0:", ff.end_effector_positions(model, np.zeros(2))[0].round(4))
    saved = ff.save(model, Path(tmp) / "tiny.toml")
    again = ff.load(saved)
    print(
        "TOML round trip equal:", np.allclose(ff.end_effector_positions(again, [0.3, -0.2]), ff.end_effector_positions(model, [0.3, -0.2]))
    )
