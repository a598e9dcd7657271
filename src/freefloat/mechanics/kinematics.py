"""Forward kinematics in the spacecraft frame, recursive and barycentric.

Every function takes joint angles ``q`` of shape (..., N) and broadcasts over
the leading axes; positions are in the spacecraft frame 0. Two independent
routes give positions relative to the system CM: ``method="recursive"`` (the
default), the engine's forward recursion and the mass-weighted mean
(:mod:`._recursions`, every batch size), and ``method="barycentric"``, the sums
of barycentric vectors of 1992 eqs. 4 and 10 (numpy, the readable reference).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import engine
from ..core.conventions import attitude_matrix
from ..core.model import Model
from ..core.numbers import finite_vector, joint_array
from ._batches import chunked
from ._inputs import body_joints, check_method

__all__ = [
    "body_cm_positions",
    "body_rotations",
    "end_effector_positions",
    "end_effector_rotations",
    "forward_kinematics",
    "joint_axes",
    "point_positions",
    "spacecraft_box",
    "spacecraft_box_size",
    "stick_figure",
    "system_cm",
]


def _rotations(model: Model, q: np.ndarray) -> np.ndarray:
    """⁰T_k (C, B, 3, 3) for flat q (C, N) in numpy, for the barycentric reference: Rodrigues, one parent product per body."""
    batch = q.shape[0]
    n = model.n_bodies
    out = np.empty((batch, n, 3, 3))
    out[:, 0] = np.eye(3)
    if n == 1:
        return out
    k_axis = model.rotation_basis
    s = np.sin(q)[:, :, None, None]
    c = 1.0 - np.cos(q)[:, :, None, None]
    local = k_axis[0] + s * k_axis[1] + c * k_axis[2]  # (C, N, 3, 3)
    parent = model.parent
    for k in range(1, n):
        p = parent[k]
        out[:, k] = local[:, k - 1] if p == 0 else np.matmul(out[:, p], local[:, k - 1])
    return out


def _slides(model: Model, rot: np.ndarray, q: np.ndarray) -> np.ndarray:
    """q_j T_parent a_j (C, N, 3): the sliding of each prismatic joint j, spacecraft frame (zero rows for revolute).

    With these, a barycentric vector of body p = parent(j) is v_pk(0) T_p-rotated plus
    q_j (chi_j(k) - mu*_j) T_p a_j (:mod:`freefloat.core.barycentric`, docs/theory.md).
    """
    parents = model.parent[1:]
    return np.einsum("cjxy,jy->cjx", rot[:, parents], model.bary.slide_axis) * q[:, :, None]


def _slide_offsets(model: Model, rot: np.ndarray, q: np.ndarray, bodies: np.ndarray) -> np.ndarray:
    """Sum over prismatic joints of q_j (chi_j(k) - mu*_j) T_p a_j for points on ``bodies`` (P,): (C, P, 3)."""
    return np.einsum("cjx,jp->cpx", _slides(model, rot, q), model.bary.slide_coefficient[:, bodies])


def body_rotations(model: Model, q: Any) -> np.ndarray:
    """Orientation ⁰T_k of every body frame in the spacecraft frame, (..., B, 3, 3).

    1991 eq. 6's ⁰T_k: ``x_0 = T_k @ x_k``. Row 0 is the identity.
    """
    return forward_kinematics(model, q)[0]


def forward_kinematics(model: Model, q: Any) -> tuple[np.ndarray, np.ndarray]:
    """Plain recursive forward kinematics: (⁰T_k (..., B, 3, 3), origin of body frame k (..., B, 3)).

    Origins are measured from the spacecraft frame origin, in the spacecraft frame.
    """
    return engine.frames(model, joint_array(model, q))


def joint_axes(model: Model, rotations: np.ndarray) -> np.ndarray:
    """Joint axes in the spacecraft frame, ⁰T_k u_k, (..., B - 1, 3): one row per body's joint (N rows without mimic
    joints; ``model.body_joint_names`` order with them), from ``body_rotations`` (turning or sliding axes)."""
    return np.einsum("...kij,kj->...ki", rotations[..., 1:, :, :], model.joint_axis[1:])


def system_cm(model: Model, q: Any) -> np.ndarray:
    """System CM measured from the spacecraft frame origin, spacecraft frame, (..., 3)."""
    return -engine.points(model, joint_array(model, q), 0, (0.0, 0.0, 0.0))[..., 0, :]


def _method(method: str) -> str:
    return check_method(method, "1992 eq. 4")


def body_cm_positions(model: Model, q: Any, *, method: str = "recursive") -> np.ndarray:
    """rho_k: every body CM relative to the system CM, spacecraft frame, (..., B, 3).

    ``method="recursive"`` (default): forward recursion minus the system CM (the
    engine); ``method="barycentric"``: one barycentric vector per body summed
    (1992 eq. 4). Both give the same numbers; each checks the other.
    """
    q = joint_array(model, q)
    if _method(method) == "recursive":
        return engine.points(model, q, np.arange(model.n_bodies), model.com)
    table = model.bary.point_table
    bodies = np.arange(model.n_bodies)
    return chunked(lambda qq: _barycentric_sum(model, qq, table, bodies), q, core_ndims=(1,))


def _barycentric_sum(model: Model, q: np.ndarray, table: np.ndarray, bodies: np.ndarray) -> np.ndarray:
    """rho_P = sum_i T_i v_iP(q) (1992 eq. 4, with the sliding of prismatic joints) for a table (P, B, 3): (C, P, 3)."""
    model, q = body_joints(model, q)  # mimic joints: their values through the law
    rot = _rotations(model, q)
    out = np.einsum("cbij,pbj->cpi", rot, table)
    if model.has_prismatic:
        out += _slide_offsets(model, rot, q, bodies)
    return out


def end_effector_positions(model: Model, q: Any, *, attitude: Any = None, method: str = "recursive") -> np.ndarray:
    """r_E of every end effector relative to the system CM, (..., E, 3).

    In the spacecraft frame; with ``attitude`` (quaternion [x, y, z, w],
    Rotation or 3x3) rotated into the inertial frame. ``method="barycentric"``
    evaluates 1992 eq. 10 as a barycentric sum instead of the engine's recursion.
    """
    q = joint_array(model, q)
    if _method(method) == "recursive":
        r_e = engine.points(model, q, model.end_effector_body, model.end_effector_point)
    else:
        table = model.bary.end_effector_table
        r_e = chunked(lambda qq: _barycentric_sum(model, qq, table, model.end_effector_body), q, core_ndims=(1,))
    if attitude is None:
        return r_e
    return np.einsum("...ij,...ej->...ei", attitude_matrix(attitude), r_e)


def end_effector_rotations(model: Model, q: Any) -> np.ndarray:
    """Orientation of every end-effector (leaf body) frame in the spacecraft frame, (..., E, 3, 3)."""
    return body_rotations(model, q)[..., model.end_effector_body, :, :]


def point_positions(model: Model, q: Any, body: str | int, point: Any = (0.0, 0.0, 0.0), *, method: str = "recursive") -> np.ndarray:
    """Any point of any body relative to the system CM, spacecraft frame, (..., 3).

    ``point`` is in the body frame. ``method="barycentric"``: 1991 eqs. 1-3, a
    sum of barycentric vectors; default the engine's recursion.
    """
    k = model.body_index(body)
    p = finite_vector(point, 3, "point", "a point in the body frame, m")
    q = joint_array(model, q)
    if _method(method) == "recursive":
        return engine.points(model, q, k, p)[..., 0, :]
    table = model.bary.point_vectors(model, k, p)[None]
    return chunked(lambda qq: _barycentric_sum(model, qq, table, np.array([k]))[:, 0], q, core_ndims=(1,))


def stick_figure(model: Model, q: Any, *, attitude: Any = None) -> np.ndarray:
    """Line segments that draw the system as a stick figure, relative to the system CM, (..., B - 1 + E, 2, 3).

    One segment per link, from its parent's joint (from the spacecraft CM
    for the first link of each arm) to its own joint, then one per end
    effector, from its body's joint to the end-effector point. In the
    spacecraft frame; with ``attitude`` (quaternion [x, y, z, w], Rotation or
    3x3) rotated into the inertial frame. Add the system CM position r_cm to
    place it in the inertial frame.
    """
    q = joint_array(model, q)
    rot, pos = forward_kinematics(model, q)
    spacecraft_cm = pos[..., 0, :] + np.einsum("...ij,j->...i", rot[..., 0, :, :], model.com[0])
    starts, ends = [], []
    for k in range(1, model.n_bodies):
        p = int(model.parent[k])
        starts.append(spacecraft_cm if p == 0 else pos[..., p, :])
        ends.append(pos[..., k, :])
    for e, body in enumerate(model.end_effector_body):
        starts.append(pos[..., body, :])
        ends.append(pos[..., body, :] + np.einsum("...ij,j->...i", rot[..., body, :, :], model.end_effector_point[e]))
    seg = np.stack([np.stack(starts, axis=-2), np.stack(ends, axis=-2)], axis=-2) - system_cm(model, q)[..., None, None, :]
    if attitude is None:
        return seg
    return np.einsum("...ij,...sej->...sei", attitude_matrix(attitude), seg)


def spacecraft_box_size(model: Model) -> tuple[np.ndarray, np.ndarray]:
    """Edge lengths (3,) m and axes (3, 3) (columns, spacecraft frame) of the spacecraft bus drawn in figures.

    The uniform box with the spacecraft's mass m and inertia about its CM: with principal moments
    I_1, I_2, I_3 along the principal axes, edge a_i = sqrt(6 (I_j + I_k - I_i) / m) (from
    I_i = m (a_j² + a_k²) / 12). A diagonal inertia keeps the spacecraft axes; otherwise box axis i is the
    principal axis nearest spacecraft axis i (where these differ, pointing the same way). The
    papers' spacecraft (1991: 40 kg, 6.667 kg m²; 1992: 400 kg, 66.67 kg m²) are 1 m cubes.
    """
    inertia = 0.5 * (model.inertia[0] + model.inertia[0].T)
    off = inertia - np.diag(np.diag(inertia))
    if np.max(np.abs(off)) <= 1e-12 * max(float(np.max(np.abs(inertia))), 1e-300):
        moments, axes = np.diag(inertia).copy(), np.eye(3)
    else:
        moments, axes = np.linalg.eigh(inertia)
        order = np.argmax(np.abs(axes), axis=1)  # box axis i nearest spacecraft axis i, where that is a permutation
        if np.unique(order).size == 3:
            moments, axes = moments[order], axes[:, order] * np.sign(axes[np.arange(3), order])
    size = np.sqrt(np.maximum(6.0 * (moments.sum() - 2.0 * moments) / float(model.mass[0]), 0.0))
    return size, axes


def spacecraft_box(model: Model, q: Any, *, attitude: Any = None) -> np.ndarray:
    """Corners of the spacecraft bus (:func:`spacecraft_box_size`, centred on the spacecraft CM), relative to the
    system CM, (..., 8, 3).

    Corner k lies at the spacecraft CM + sum_i ±a_i/2 along box axis i, the sign of axis i
    being + where bit i of k is set. Frames as in :func:`stick_figure`: the spacecraft frame,
    or with ``attitude`` (quaternion [x, y, z, w], Rotation or 3x3) the inertial frame; add
    the system CM position r_cm to place it in the inertial frame.
    """
    q = joint_array(model, q)
    size, axes = spacecraft_box_size(model)
    signs = np.array([[1.0 if k >> i & 1 else -1.0 for i in range(3)] for k in range(8)])
    local = model.com[0] + (signs * (0.5 * size)) @ axes.T  # (8, 3) in the spacecraft frame, from its origin
    rot, pos = forward_kinematics(model, q)
    corners = pos[..., 0, None, :] + np.einsum("...ij,kj->...ki", rot[..., 0, :, :], local) - system_cm(model, q)[..., None, :]
    if attitude is None:
        return corners
    return np.einsum("...ij,...kj->...ki", attitude_matrix(attitude), corners)
