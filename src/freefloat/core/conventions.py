"""Conventions of freefloat, written once.

Units
    SI throughout (m, kg, s, N, N m); angles in radians. Degrees appear only at
    the edges, behind an explicit ``degrees=True`` keyword or a ``--degrees`` flag.

Frames
    ``I``  inertial frame. Its origin is the system CM at t = 0 unless stated.
    ``0``  spacecraft frame, fixed in body 0 (the root of the tree).
    ``k``  body frame of body k, fixed in body k, with its origin on the axis of
           the joint that connects body k to its parent (the URDF link frame).
    Arrays carry their frame as a name suffix where it is not obvious:
    ``_0`` spacecraft frame, ``_I`` inertial frame, ``_k`` body frame.

Attitude
    The spacecraft attitude is the rotation from frame 0 to frame I, ``T0`` in
    the papers: ``x_I = T0 @ x_0``. As a quaternion it is stored **scalar last**,
    ``[x, y, z, w]``, the order of :class:`scipy.spatial.transform.Rotation`
    and of Pinocchio's free-flyer configuration. Anywhere an attitude is
    accepted, a scipy ``Rotation`` is accepted too. Euler angles are the
    3-2-1 (yaw-pitch-roll) sequence of the 1991 paper, eqs. 11-12, returned
    as ``[theta1, theta2, theta3]`` = [roll about x, pitch about y, yaw about z]
    so that the rate map is the paper's ``S`` of eq. 12.

Generalized velocities (1991 eq. 8)
    ``zdot0 = [rdot_cm, omega0, qdot]`` of shape (..., 6 + N):
    ``rdot_cm`` the system CM velocity in the inertial frame, ``omega0`` the
    spacecraft angular velocity in the spacecraft frame (the paper's ⁰ω0),
    ``qdot`` the joint rates in ``model.joint_names`` order. With the attitude
    at identity the inertial and spacecraft frames coincide and every Jacobian
    reduces to the paper's ⁰J.

Joints
    Revolute (``continuous`` is a revolute without limits) and fixed. Fixed
    joints are merged into the parent at build time. The joint angle turns the
    child frame about ``axis`` (a unit vector in the joint frame).

End effectors
    Every leaf body (other than a lone spacecraft) carries one end effector:
    the leaf frame's origin (URDF), or the tip point given in the model file
    (TOML ``end_effector = [x, y, z]``, the end of the last link for the
    papers' systems).

Planar models
    A model is planar when every joint axis is parallel to the spacecraft z
    axis and every CM, joint and end-effector point lies in one plane z = const
    of the spacecraft frame. The planar view keeps (x, y, θz, q): rows and
    columns 0, 1, 5 and 6.. of the 3D quantities.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from .errors import ShapeError
from .numbers import real_array

__all__ = [
    "QUATERNION_ORDER",
    "as_quaternion",
    "attitude_matrix",
    "euler321_from_matrix",
    "euler321_rate_matrix",
    "quaternion_rate_matrix",
    "skew",
]

QUATERNION_ORDER = ("x", "y", "z", "w")
"""Quaternion component order used in every state and file: scalar last, as scipy and Pinocchio."""


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrix ``[v]x`` of (..., 3) vectors, shape (..., 3, 3)."""
    v = np.asarray(v, dtype=float)
    out = np.zeros((*v.shape, 3))
    out[..., 0, 1] = -v[..., 2]
    out[..., 0, 2] = v[..., 1]
    out[..., 1, 0] = v[..., 2]
    out[..., 1, 2] = -v[..., 0]
    out[..., 2, 0] = -v[..., 1]
    out[..., 2, 1] = v[..., 0]
    return out


def _attitude_numbers(attitude: Any) -> np.ndarray:
    try:
        return real_array(attitude, "attitude")
    except TypeError:
        raise TypeError(f"attitude: expected a quaternion [x, y, z, w], a scipy Rotation or a 3x3 matrix, got {attitude!r:.80}") from None


def as_quaternion(attitude: Any) -> np.ndarray:
    """Return an attitude as unit quaternions ``[x, y, z, w]`` (..., 4).

    Accepts a scipy ``Rotation`` or an array of shape (..., 4). A quaternion
    whose norm differs from 1 by more than 1e-6 is an error: normalise it
    yourself if that is what you mean.
    """
    if isinstance(attitude, Rotation):
        return np.asarray(attitude.as_quat(), dtype=float)
    quat = _attitude_numbers(attitude)
    if quat.shape[-1:] != (4,):
        raise ShapeError(f"attitude: expected a quaternion [x, y, z, w] of shape (..., 4), got {quat.shape}")
    if not np.all(np.isfinite(quat)):
        raise ValueError("attitude: quaternion has NaN or infinite entries")
    norm = np.linalg.norm(quat, axis=-1)
    off = np.abs(norm - 1.0)
    if np.any(off > 1e-6):
        worst = float(np.reshape(norm, -1)[np.argmax(np.reshape(off, -1))])
        raise ValueError(
            f"attitude: quaternion norm {worst:.10g} is not 1 (tolerance 1e-6); pass a unit quaternion [x, y, z, w] (scalar last), "
            "e.g. q / np.linalg.norm(q)"
        )
    return quat


def attitude_matrix(attitude: Any) -> np.ndarray:
    """Rotation matrix ``T0`` (frame 0 -> frame I) of an attitude, (..., 3, 3).

    ``None`` means identity. Accepts a ``Rotation``, quaternions (..., 4) or
    rotation matrices (..., 3, 3).
    """
    if attitude is None:
        return np.eye(3)
    if isinstance(attitude, Rotation):
        return np.asarray(attitude.as_matrix(), dtype=float)
    arr = _attitude_numbers(attitude)
    if arr.shape[-2:] == (3, 3):
        return arr
    quat = as_quaternion(arr)
    flat = Rotation.from_quat(quat.reshape(-1, 4)).as_matrix()
    return flat.reshape((*quat.shape[:-1], 3, 3))


def euler321_from_matrix(matrix: np.ndarray) -> np.ndarray:
    """Euler 3-2-1 angles ``[theta1, theta2, theta3]`` (roll, pitch, yaw), (..., 3).

    ``matrix`` rotates body coordinates into the reference frame; the angles
    are the 1991 paper's Θ of eq. 11 (yaw about z, then pitch about y, then
    roll about x).
    """
    matrix = np.asarray(matrix, dtype=float)
    flat = matrix.reshape(-1, 3, 3)
    zyx = Rotation.from_matrix(flat).as_euler("ZYX")  # yaw, pitch, roll
    return zyx[:, ::-1].reshape((*matrix.shape[:-2], 3))


def euler321_rate_matrix(theta: np.ndarray) -> np.ndarray:
    """The matrix ``S(Θ)`` of 1991 eq. 12: ``omega = S(Θ) @ dΘ/dt``, (..., 3, 3).

    ``omega`` is expressed in the reference (outer) frame. ``S`` is singular
    when cos(theta2) = 0 (pitch of ±90°), the representation singularity.
    """
    theta = np.asarray(theta, dtype=float)
    t2, t3 = theta[..., 1], theta[..., 2]
    # omega = yaw_rate*e_z + pitch_rate*Rz e_y + roll_rate*Rz Ry e_x.
    # The paper prints -sin(theta1), cos(theta1) in the second column; the
    # derivation gives theta3 (the yaw) there: a misprint, see docs/paper-notes.md.
    out = np.zeros((*theta.shape[:-1], 3, 3))
    out[..., 0, 0] = np.cos(t2) * np.cos(t3)
    out[..., 1, 0] = np.cos(t2) * np.sin(t3)
    out[..., 2, 0] = -np.sin(t2)
    out[..., 0, 1] = -np.sin(t3)
    out[..., 1, 1] = np.cos(t3)
    out[..., 2, 2] = 1.0
    return out


def quaternion_rate_matrix(quat: np.ndarray) -> np.ndarray:
    """``G(q)`` with ``dq/dt = G(q) @ omega``, omega in the outer frame, (..., 4, 3).

    Quaternion ``[x, y, z, w]`` scalar last; the four-parameter alternative the
    1991 paper mentions after eq. 12, free of representation singularities.
    """
    quat = np.asarray(quat, dtype=float)
    x, y, z, w = (quat[..., i] for i in range(4))
    out = np.empty((*quat.shape[:-1], 4, 3))
    # dq/dt = 1/2 [omega; 0] ⊗ q for omega in the outer (inertial) frame.
    out[..., 0, :] = np.stack([w, z, -y], axis=-1)
    out[..., 1, :] = np.stack([-z, w, x], axis=-1)
    out[..., 2, :] = np.stack([y, -x, w], axis=-1)
    out[..., 3, :] = np.stack([-x, -y, -z], axis=-1)
    return 0.5 * out
