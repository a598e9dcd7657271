"""Bridges to independent engines (Pinocchio; MuJoCo later) for cross-checks and benchmarks.

These need the test extras (``pip install freeflyer[test]``): ``pin`` and
``mujoco`` are imported only when a bridge is called.

Pinocchio's free-flyer state is q = [x, y, z, qx, qy, qz, qw, joints] (base
frame origin, scalar-last quaternion) and v = [v, w, qdot] with v, w in the
base (local) frame at the base origin. freeflyer's zdot0 = [rdot_cm (inertial),
omega0 (spacecraft frame), qdot]. With c(q) the system CM in the spacecraft
frame (from the spacecraft frame origin) and J_c = dc/dq:

    rdot_cm = T0 (v + w x c + J_c qdot),   omega0 = w.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .conventions import as_quaternion, attitude_matrix
from .model import Model

__all__ = ["to_pinocchio", "pinocchio_configuration", "pinocchio_velocity"]


def to_pinocchio(model: Model) -> Any:
    """A ``pinocchio.Model`` of ``model`` with a free-flyer root.

    Joint ``k + 1`` moves body ``k`` (joint 1 is the free flyer of the
    spacecraft); every end effector is an ``OP_FRAME`` named as in the model.
    """
    import pinocchio as pin

    pm = pin.Model()
    pm.name = model.name
    ids = [pm.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "root_joint")]
    for k in range(model.n_bodies):
        if k > 0:
            placement = pin.SE3(np.array(model.joint_rotation[k]), np.array(model.joint_origin[k]))
            joint = pin.JointModelRevoluteUnaligned(np.array(model.joint_axis[k]))
            ids.append(pm.addJoint(ids[int(model.parent[k])], joint, placement, model.joint_names[k - 1]))
        inertia = pin.Inertia(float(model.mass[k]), np.array(model.com[k]), np.array(model.inertia[k]))
        pm.appendBodyToJoint(ids[k], inertia, pin.SE3.Identity())
    for e, name in enumerate(model.end_effector_names):
        k = int(model.end_effector_body[e])
        frame = pin.Frame(name, ids[k], pin.SE3(np.eye(3), np.array(model.end_effector_point[e])), pin.FrameType.OP_FRAME)
        pm.addFrame(frame, False)
    return pm


def pinocchio_configuration(model: Model, q: Any, attitude: Any = None, base_position: Any = None) -> np.ndarray:
    """Pinocchio configuration [base position, quaternion xyzw, q] (unbatched)."""
    quat = np.array([0.0, 0.0, 0.0, 1.0]) if attitude is None else as_quaternion(attitude)
    base = np.zeros(3) if base_position is None else np.asarray(base_position, dtype=float)
    return np.concatenate([base, quat, np.asarray(q, dtype=float)])


def pinocchio_velocity(model: Model, pin_model: Any, q: Any, velocity: Any, attitude: Any = None) -> np.ndarray:
    """Pinocchio velocity [v_local, w_local, qdot] for freeflyer's zdot0 (unbatched)."""
    import pinocchio as pin

    velocity = np.asarray(velocity, dtype=float)
    t0 = attitude_matrix(attitude)
    n = model.n_joints
    data = pin_model.createData()
    # CM position and its joint Jacobian with the base at rest at identity
    q_id = pinocchio_configuration(model, q)
    jcom = pin.jacobianCenterOfMass(pin_model, data, q_id)  # (3, 6+N) world = spacecraft frame here
    c = data.com[0]
    omega0, qdot = velocity[3:6], velocity[6:]
    v_local = t0.T @ velocity[0:3] - np.cross(omega0, c) - jcom[:, 6:] @ qdot
    return np.concatenate([v_local, omega0, qdot])[: 6 + n]
