"""Bridge to MuJoCo (an independent engine) for trajectory cross-checks and benchmarks.

Needs the test extras (``mujoco``), imported only when called. The model is
written as MJCF: the spacecraft body carries a free joint, every other body a
hinge about its joint axis, gravity is zero and there are no geoms (no
contact). Each hinge has a motor actuator (gear 1), so ``data.ctrl`` holds the
joint torques in ``model.joint_names`` order.

MuJoCo's free joint state is qpos = [base origin (world), quaternion w, x, y, z]
and qvel = [base origin velocity (world), angular velocity (base frame)]; see
:func:`mujoco_state` and :func:`from_mujoco_state` for the maps to freefloat's
state (system CM position and velocity, scalar-last quaternion).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from ..core.model import Model
from ..core.state import State
from ..mechanics.jacobians import point_jacobian
from ..mechanics.kinematics import system_cm

__all__ = ["from_mujoco_state", "mujoco_state", "to_mjcf", "to_mujoco"]


_MJCF_JOINT = {"revolute": "hinge", "prismatic": "slide"}


def _fmt(values: Any) -> str:
    return " ".join(repr(float(v)) for v in np.ravel(values))


def _passive_attributes(model: Model, j: int) -> str:
    """MJCF attributes of joint j's rotor inertia, damping, friction and spring (``armature``, ``damping``, ``frictionloss``,
    ``stiffness``, ``springref``; MuJoCo's frictionloss is dry friction, exact at rest, where freefloat's is smooth), only
    where not zero."""
    out = ""
    for attribute, values in (
        ("armature", model.joint_armature),
        ("damping", model.joint_damping),
        ("frictionloss", model.joint_friction),
        ("stiffness", model.joint_stiffness),
        ("springref", model.joint_springref),
    ):
        if values[j] != 0.0:
            out += f' {attribute}="{float(values[j])!r}"'
    return out


def to_mjcf(model: Model, *, timestep: float = 1e-3, integrator: str = "RK4") -> str:
    """MJCF text of ``model`` (free-floating, no gravity, one motor per joint; a mimic joint is a joint of its own held
    to its leader by a joint equality, ``polycoef = "offset multiplier 0 0 0"``, which MuJoCo enforces softly)."""
    own = model.expanded()  # the joint of every body, mimic joints included
    children: dict[int, list[int]] = {k: [] for k in range(model.n_bodies)}
    for k in range(1, model.n_bodies):
        children[int(model.parent[k])].append(k)

    def inertial(k: int) -> str:
        i = model.inertia[k]
        full = [i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2], i[1, 2]]
        return f'<inertial pos="{_fmt(model.com[k])}" mass="{float(model.mass[k])!r}" fullinertia="{_fmt(full)}"/>'

    def body(k: int, indent: str) -> str:
        name = model.body_names[k]
        if k == 0:
            head = f'{indent}<body name="{name}" pos="0 0 0">\n{indent}  <freejoint name="root"/>\n'
        else:
            quat = Rotation.from_matrix(model.joint_rotation[k]).as_quat()  # x y z w
            kind = _MJCF_JOINT[own.joint_type[k - 1]]
            head = (
                f'{indent}<body name="{name}" pos="{_fmt(model.joint_origin[k])}" quat="{_fmt(np.roll(quat, 1))}">\n'
                f'{indent}  <joint name="{own.joint_names[k - 1]}" type="{kind}" axis="{_fmt(model.joint_axis[k])}" limited="false"'
                f"{_passive_attributes(own, k - 1)}/>\n"
            )
        inner = "".join(body(c, indent + "  ") for c in children[k])
        return f"{head}{indent}  {inertial(k)}\n{inner}{indent}</body>\n"

    motors = "".join(f'    <motor name="{j}" joint="{j}" gear="1"/>\n' for j in model.joint_names)
    laws = "".join(
        f'    <joint joint1="{r["joint"]}" joint2="{r["leader"]}" polycoef="{float(r["offset"])!r} {float(r["multiplier"])!r} 0 0 0"/>\n'
        for r in model.mimic
    )
    equality = f"  <equality>\n{laws}  </equality>\n" if laws else ""
    return (
        f'<mujoco model="{model.name}">\n'
        '  <compiler angle="radian" inertiafromgeom="false" autolimits="false"/>\n'
        f'  <option gravity="0 0 0" timestep="{timestep!r}" integrator="{integrator}">\n'
        '    <flag contact="disable" gravity="disable"/>\n'
        "  </option>\n"
        "  <worldbody>\n"
        f"{body(0, '    ')}"
        "  </worldbody>\n"
        f"  <actuator>\n{motors}  </actuator>\n"
        f"{equality}"
        "</mujoco>\n"
    )


def to_mujoco(model: Model, **options: Any) -> Any:
    """A ``mujoco.MjModel`` of ``model`` (see :func:`to_mjcf` for the options)."""
    import mujoco

    return mujoco.MjModel.from_xml_string(to_mjcf(model, **options))


def mujoco_state(model: Model, state: State) -> tuple[np.ndarray, np.ndarray]:
    """(qpos, qvel) of MuJoCo for a freefloat state (unbatched)."""
    s = state.resolve(model)
    t0 = Rotation.from_quat(s.attitude).as_matrix()
    base = s.r_cm - t0 @ system_cm(model, s.q)
    # the spacecraft frame origin is a point of body 0: its velocity is J+ zdot0 (1991 eq. 7)
    base_velocity = point_jacobian(model, s.q, 0, np.zeros(3), attitude=t0)[0:3] @ s.velocity
    qpos = np.concatenate([base, np.roll(s.attitude, 1), model.body_joint_values(s.q)])  # every body's joint (mimic ones too)
    qvel = np.concatenate([base_velocity, s.omega, model.mimic_matrix @ s.qdot])
    return qpos, qvel


def from_mujoco_state(model: Model, qpos: np.ndarray, qvel: np.ndarray) -> State:
    """A freefloat state from MuJoCo's (qpos, qvel) (unbatched)."""
    own = model.expanded()
    columns = np.array([own.joint_names.index(name) for name in model.joint_names], dtype=int)  # the independent joints
    quat = np.roll(np.asarray(qpos[3:7], dtype=float), -1)
    quat = quat / np.linalg.norm(quat)
    q, qdot, omega = np.asarray(qpos)[7 + columns], np.asarray(qvel)[6 + columns], qvel[3:6]
    t0 = Rotation.from_quat(quat).as_matrix()
    # base velocity = rdot_cm + [J+ of the frame origin without its rdot_cm columns] [omega0, qdot]
    jac = point_jacobian(model, q, 0, np.zeros(3), attitude=t0)[0:3, 3:]
    return State(
        q=np.array(q),
        qdot=np.array(qdot),
        omega=np.array(omega),
        attitude=quat,
        r_cm=qpos[0:3] + t0 @ system_cm(model, q),
        v_cm=qvel[0:3] - jac @ np.concatenate([omega, qdot]),
    )
