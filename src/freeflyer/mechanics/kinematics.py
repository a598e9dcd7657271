"""Forward kinematics in the spacecraft frame, plain and barycentric.

Every function takes joint angles ``q`` of shape (..., N) and broadcasts over
the leading axes; positions are in the spacecraft frame 0. Two independent
routes give positions relative to the system CM: the barycentric sums of 1992
eqs. 4 and 10 (used everywhere in freeflyer) and plain recursive forward
kinematics followed by the mass-weighted mean (used to check them).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core.conventions import attitude_matrix
from ..core.model import Model
from ._batch import chunked, joint_array, sincos

__all__ = [
    "body_cm_positions",
    "body_rotations",
    "end_effector_positions",
    "end_effector_rotations",
    "forward_kinematics",
    "joint_axes",
    "point_positions",
    "system_cm",
]


def _rotations(model: Model, q: np.ndarray) -> np.ndarray:
    """Kernel: ⁰T_k (C, B, 3, 3) for flat q (C, N). Rodrigues, one parent product per body."""
    batch = q.shape[0]
    n = model.n_bodies
    out = np.empty((batch, n, 3, 3))
    out[:, 0] = np.eye(3)
    if n == 1:
        return out
    k_axis = model.rotation_basis
    sin, cos = np.empty_like(q), np.empty_like(q)
    sincos(q, sin, cos)
    s = sin[:, :, None, None]
    c = 1.0 - cos[:, :, None, None]
    local = k_axis[0] + s * k_axis[1] + c * k_axis[2]  # (C, N, 3, 3)
    parent = model.parent
    for k in range(1, n):
        p = parent[k]
        out[:, k] = local[:, k - 1] if p == 0 else np.matmul(out[:, p], local[:, k - 1])
    return out


def body_rotations(model: Model, q: Any) -> np.ndarray:
    """Orientation ⁰T_k of every body frame in the spacecraft frame, (..., B, 3, 3).

    1991 eq. 6's ⁰T_k: ``x_0 = T_k @ x_k``. Row 0 is the identity.
    """
    q = joint_array(model, q)
    return chunked(lambda qq: _rotations(model, qq), q, core_ndims=(1,))


def _frames(model: Model, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    rot = _rotations(model, q)
    pos = np.zeros((*rot.shape[:2], 3))
    for k in range(1, model.n_bodies):
        p = model.parent[k]
        pos[:, k] = pos[:, p] + rot[:, p] @ model.joint_origin[k]
    return rot, pos


def forward_kinematics(model: Model, q: Any) -> tuple[np.ndarray, np.ndarray]:
    """Plain recursive forward kinematics: (⁰T_k (..., B, 3, 3), origin of body frame k (..., B, 3)).

    Origins are measured from the spacecraft frame origin, in the spacecraft frame.
    """
    q = joint_array(model, q)
    return chunked(lambda qq: _frames(model, qq), q, core_ndims=(1,))


def joint_axes(model: Model, rotations: np.ndarray) -> np.ndarray:
    """Joint axes in the spacecraft frame, ⁰T_k u_k, (..., N, 3), from ``body_rotations``."""
    return np.einsum("...kij,kj->...ki", rotations[..., 1:, :, :], model.joint_axis[1:])


def system_cm(model: Model, q: Any) -> np.ndarray:
    """System CM measured from the spacecraft frame origin, spacecraft frame, (..., 3)."""
    rot, pos = forward_kinematics(model, q)
    cms = pos + np.einsum("...kij,kj->...ki", rot, model.com)
    return np.einsum("k,...ki->...i", model.mass, cms) / model.total_mass


def body_cm_positions(model: Model, q: Any, *, method: str = "barycentric") -> np.ndarray:
    """rho_k: every body CM relative to the system CM, spacecraft frame, (..., B, 3).

    ``method="barycentric"`` sums one barycentric vector per body (1992 eq. 4);
    ``method="recursive"`` uses plain forward kinematics minus the system CM.
    Both give the same numbers; the second exists to check the first.
    """
    q = joint_array(model, q)
    if method == "barycentric":
        table = model.bary.point_table
        return chunked(lambda qq: np.einsum("cbij,kbj->cki", _rotations(model, qq), table), q, core_ndims=(1,))
    if method == "recursive":
        rot, pos = forward_kinematics(model, q)
        cms = pos + np.einsum("...kij,kj->...ki", rot, model.com)
        return cms - (np.einsum("k,...ki->...i", model.mass, cms) / model.total_mass)[..., None, :]
    raise ValueError(f"method: expected 'barycentric' or 'recursive', got {method!r}")


def end_effector_positions(model: Model, q: Any, *, attitude: Any = None, method: str = "barycentric") -> np.ndarray:
    """r_E of every end effector relative to the system CM, (..., E, 3).

    1992 eq. 10 as a barycentric sum, in the spacecraft frame; with ``attitude``
    (quaternion [x, y, z, w], Rotation or 3x3) rotated into the inertial frame.
    ``method="recursive"`` uses plain forward kinematics instead (a check).
    """
    q = joint_array(model, q)
    if method == "barycentric":
        table = model.bary.end_effector_table
        r_e = chunked(lambda qq: np.einsum("cbij,ebj->cei", _rotations(model, qq), table), q, core_ndims=(1,))
    elif method == "recursive":
        rot, pos = forward_kinematics(model, q)
        body = model.end_effector_body
        tips = pos[..., body, :] + np.einsum("...eij,ej->...ei", rot[..., body, :, :], model.end_effector_point)
        r_e = tips - system_cm(model, q)[..., None, :]
    else:
        raise ValueError(f"method: expected 'barycentric' or 'recursive', got {method!r}")
    if attitude is None:
        return r_e
    return np.einsum("...ij,...ej->...ei", attitude_matrix(attitude), r_e)


def end_effector_rotations(model: Model, q: Any) -> np.ndarray:
    """Orientation of every end-effector (leaf body) frame in the spacecraft frame, (..., E, 3, 3)."""
    return body_rotations(model, q)[..., model.end_effector_body, :, :]


def point_positions(model: Model, q: Any, body: str | int, point: Any = (0.0, 0.0, 0.0)) -> np.ndarray:
    """Any point of any body relative to the system CM, spacecraft frame, (..., 3).

    ``point`` is in the body frame. 1991 eqs. 1-3: a sum of barycentric vectors.
    """
    k = model.body_index(body)
    table = model.bary.point_vectors(model, k, np.asarray(point, dtype=float))
    return np.einsum("...bij,bj->...i", body_rotations(model, q), table)
