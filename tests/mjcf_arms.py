"""The two-arm robot of the MJCF joint-parameter tests (a 500 kg bus, two arms of three joints, written to a file with
each joint's attributes) and the map between its MuJoCo state and freefloat's."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import mujoco  # an oracle: a missing one fails the tests that use it
import numpy as np

import freefloat as ff
from freefloat.io.mujoco_bridge import from_mujoco_state, mujoco_state

ROBOT = """
<mujoco model="{name}">
  <compiler angle="{angle}"/>
  <option gravity="0 0 0" timestep="0.001" integrator="RK4"/>
  <worldbody>
    <body name="bus" pos="0 0 0">
      <freejoint name="root"/>
      <inertial pos="0 0 0" mass="500" diaginertia="60 70 80"/>
      {arms}
    </body>
  </worldbody>
  {actuators}
</mujoco>
"""

ARM = """
      <body name="{p}upper" pos="{x} 0.4 0.5" euler="0 0 {yaw}">
        <joint name="{p}shoulder" type="hinge" axis="0 0 1" {shoulder}/>
        <inertial pos="0.35 0 0" mass="6" diaginertia="0.02 0.25 0.25"/>
        <body name="{p}fore" pos="0.7 0 0">
          <joint name="{p}elbow" type="hinge" axis="0 1 0" {elbow}/>
          <inertial pos="0.3 0 0" mass="4" diaginertia="0.01 0.12 0.12"/>
          <body name="{p}hand" pos="0.6 0 0">
            <joint name="{p}wrist" type="{wrist_type}" axis="1 0 0" {wrist}/>
            <inertial pos="0.05 0 0" mass="1.5" diaginertia="0.004 0.003 0.003"/>
            <site name="{p}tool" pos="0.1 0 0"/>
          </body>
        </body>
      </body>
"""

#: The joints, in the file's order.
JOINTS = [f"{p}{j}" for p in ("a_", "b_") for j in ("shoulder", "elbow", "wrist")]


def write_arms(
    path: Path, joints: Sequence[str], *, wrist_type: str = "hinge", angle: str = "degree", motors: bool = False, name: str = "two_arms"
) -> Path:
    """The file at ``path``: both arms' shoulder, elbow and wrist with the attributes ``joints`` (three strings, the
    same for both arms), the wrist a ``wrist_type`` joint, angles in ``angle`` units; ``motors``: a motor per joint."""
    shoulder, elbow, wrist = joints
    attributes = {"shoulder": shoulder, "elbow": elbow, "wrist": wrist, "wrist_type": wrist_type}
    arms = ARM.format(p="a_", x=0.6, yaw=0.3, **attributes) + ARM.format(p="b_", x=-0.6, yaw=2.8, **attributes)
    actuators = "<actuator>" + "".join(f'<motor joint="{j}" gear="1"/>' for j in JOINTS) + "</actuator>" if motors else ""
    path.write_text(ROBOT.format(name=name, angle=angle, arms=arms, actuators=actuators), encoding="utf-8")
    return path


def order(mj: mujoco.MjModel, model: ff.Model) -> tuple[list[int], list[int]]:
    """MuJoCo's qpos and qvel addresses of ``model``'s joints, in ``model``'s order."""
    return [mj.joint(n).qposadr[0] for n in model.joint_names], [mj.joint(n).dofadr[0] for n in model.joint_names]


def set_state(mj: mujoco.MjModel, data: mujoco.MjData, model: ff.Model, state: ff.State) -> None:
    """MuJoCo's qpos and qvel set to freefloat's ``state`` of ``model``."""
    qadr, vadr = order(mj, model)
    qpos_s, qvel_s = mujoco_state(model, state)
    data.qpos[0:7], data.qvel[0:6] = qpos_s[0:7], qvel_s[0:6]
    data.qpos[qadr], data.qvel[vadr] = qpos_s[7:], qvel_s[6:]


def state_of(mj: mujoco.MjModel, data: mujoco.MjData, model: ff.Model) -> ff.State:
    """freefloat's state of ``model`` from MuJoCo's qpos and qvel."""
    qadr, vadr = order(mj, model)
    return from_mujoco_state(model, np.concatenate([data.qpos[0:7], data.qpos[qadr]]), np.concatenate([data.qvel[0:6], data.qvel[vadr]]))
