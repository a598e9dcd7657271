"""Bridges to independent engines (Pinocchio; MuJoCo later) for cross-checks and benchmarks.

These need the test extras (``pip install freefloat[test]``): ``pin`` and
``mujoco`` are imported only when a bridge is called.

Pinocchio's free-flyer state is q = [x, y, z, qx, qy, qz, qw, joints] (base
frame origin, scalar-last quaternion) and v = [v, w, qdot] with v, w in the
base (local) frame at the base origin. freefloat's zdot0 = [rdot_cm (inertial),
omega0 (spacecraft frame), qdot]. With c(q) the system CM in the spacecraft
frame (from the spacecraft frame origin) and J_c = dc/dq:

    rdot_cm = T0 (v + w x c + J_c qdot),   omega0 = w.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core.conventions import as_quaternion, attitude_matrix
from ..core.errors import ModelError
from ..core.model import Model

__all__ = [
    "acceleration_from_pinocchio",
    "pinocchio_acceleration",
    "pinocchio_configuration",
    "pinocchio_root_joint",
    "pinocchio_velocity",
    "to_pinocchio",
    "velocity_from_pinocchio",
]


def pinocchio_root_joint() -> Any:
    """Pinocchio's 6-DOF root joint for a floating base: configuration [position, quaternion xyzw] (nq = 7),
    velocity [v, w] in the base frame (nv = 6)."""
    import pinocchio as pin

    return pin.JointModelFreeFlyer()


def to_pinocchio(model: Model) -> Any:
    """A ``pinocchio.Model`` of ``model`` with a free-flyer root.

    Joint ``k + 1`` moves body ``k`` (joint 1 is the free flyer of the
    spacecraft); every end effector is an ``OP_FRAME`` named as in the model.
    """
    import pinocchio as pin

    if model.has_mimic:
        raise ModelError(
            f"{model.name}.mimic",
            f"to_pinocchio builds independent joints only; {', '.join(r['joint'] for r in model.mimic)} are mimic joints",
            "save the model as URDF (ff.save) and read it with pinocchio.buildModelFromUrdf(path, root_joint, mimic=True)",
        )
    pm = pin.Model()
    pm.name = model.name
    pm.gravity = pin.Motion.Zero()  # in orbit: no gravity field (Pinocchio's default is -9.81 z)
    ids = [pm.addJoint(0, pinocchio_root_joint(), pin.SE3.Identity(), "root_joint")]
    for k in range(model.n_bodies):
        if k > 0:
            placement = pin.SE3(np.array(model.joint_rotation[k]), np.array(model.joint_origin[k]))
            axis = np.array(model.joint_axis[k])
            sliding = model.joint_type[k - 1] == "prismatic"
            joint = pin.JointModelPrismaticUnaligned(axis) if sliding else pin.JointModelRevoluteUnaligned(axis)
            ids.append(pm.addJoint(ids[int(model.parent[k])], joint, placement, model.joint_names[k - 1]))
        inertia = pin.Inertia(float(model.mass[k]), np.array(model.com[k]), np.array(model.inertia[k]))
        pm.appendBodyToJoint(ids[k], inertia, pin.SE3.Identity())
    pm.armature[6:] = np.asarray(model.joint_armature, dtype=float)  # the rotors, on the joint diagonal of the CRBA
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
    """Pinocchio velocity [v_local, w_local, qdot] for freefloat's zdot0 (unbatched)."""
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


def _com_terms(model: Model, pin_model: Any, q: Any, qdot: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """c, J_c and Jdot_c qdot: the system CM seen from the spacecraft frame origin, spacecraft frame.

    Computed by Pinocchio with the base held at rest at the identity, so that
    its world frame is the spacecraft frame: c = data.com, J_c = the joint
    columns of the CM Jacobian, Jdot_c qdot = the CM acceleration at qddot = 0.
    """
    import pinocchio as pin

    data = pin_model.createData()
    q_id = pinocchio_configuration(model, q)
    jcom = pin.jacobianCenterOfMass(pin_model, data, q_id)
    v_rel = np.concatenate([np.zeros(6), qdot])
    pin.centerOfMass(pin_model, data, q_id, v_rel, np.zeros(pin_model.nv))
    return np.array(data.com[0]), np.array(jcom[:, 6:]), np.array(data.acom[0])


def pinocchio_acceleration(model: Model, pin_model: Any, q: Any, velocity: Any, acceleration: Any, attitude: Any = None) -> np.ndarray:
    """Pinocchio acceleration a = d/dt [v_local, w_local, qdot] for freefloat's zdot0, zddot0 (unbatched).

    Differentiating the velocity map rdot_cm = T0 x, x = v_O + w x c + J_c qdot
    (v_O: base origin velocity, base frame; w = omega0; c(q), J_c(q) as in
    :func:`_com_terms`), with dT0/dt = T0 [w]x, dc/dt = J_c qdot and
    d/dt (J_c qdot) = J_c qddot + Jdot_c qdot:

        T0^T rddot_cm = w x x + dv_O/dt + dw/dt x c + w x (J_c qdot) + J_c qddot + Jdot_c qdot

    so dv_O/dt = T0^T rddot_cm - w x (T0^T rdot_cm) - dw/dt x c - w x (J_c qdot)
    - J_c qddot - Jdot_c qdot, while dw/dt = d/dt omega0 and the joint rows are
    qddot. Pinocchio's free-flyer a is exactly (dv_O/dt, dw/dt): the time
    derivative of the local-frame twist coordinates (the classical acceleration
    of the base origin is dv_O/dt + w x v_O).
    """
    velocity = np.asarray(velocity, dtype=float)
    acceleration = np.asarray(acceleration, dtype=float)
    t0 = attitude_matrix(attitude)
    omega, qdot = velocity[3:6], velocity[6:]
    omega_dot, qddot = acceleration[3:6], acceleration[6:]
    c, j_c, jdot_c_qdot = _com_terms(model, pin_model, q, qdot)
    v_dot = (
        t0.T @ acceleration[0:3]
        - np.cross(omega, t0.T @ velocity[0:3])
        - np.cross(omega_dot, c)
        - np.cross(omega, j_c @ qdot)
        - j_c @ qddot
        - jdot_c_qdot
    )
    return np.concatenate([v_dot, omega_dot, qddot])


def velocity_from_pinocchio(model: Model, pin_model: Any, q: Any, pin_velocity: Any, attitude: Any = None) -> np.ndarray:
    """freefloat's zdot0 from Pinocchio's [v_local, w_local, qdot] (unbatched): rdot_cm = T0 (v_O + w x c + J_c qdot)."""
    nu = np.asarray(pin_velocity, dtype=float)
    c, j_c, _ = _com_terms(model, pin_model, q, nu[6:])
    return np.concatenate([attitude_matrix(attitude) @ (nu[0:3] + np.cross(nu[3:6], c) + j_c @ nu[6:]), nu[3:]])


def acceleration_from_pinocchio(
    model: Model, pin_model: Any, q: Any, pin_velocity: Any, pin_acceleration: Any, attitude: Any = None
) -> np.ndarray:
    """freefloat's zddot0 from Pinocchio's velocity and acceleration (unbatched): the inverse of
    :func:`pinocchio_acceleration`, rddot_cm = T0 (w x x + dv_O/dt + dw/dt x c + w x J_c qdot + J_c qddot + Jdot_c qdot)."""
    nu = np.asarray(pin_velocity, dtype=float)
    nu_dot = np.asarray(pin_acceleration, dtype=float)
    omega, qdot = nu[3:6], nu[6:]
    c, j_c, jdot_c_qdot = _com_terms(model, pin_model, q, qdot)
    x = nu[0:3] + np.cross(omega, c) + j_c @ qdot
    r_dd = np.cross(omega, x) + nu_dot[0:3] + np.cross(nu_dot[3:6], c) + np.cross(omega, j_c @ qdot) + j_c @ nu_dot[6:] + jdot_c_qdot
    return np.concatenate([attitude_matrix(attitude) @ r_dd, nu_dot[3:]])
