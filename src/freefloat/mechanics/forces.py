"""Generalized forces (1991 eqs. 18 and 21) and their inversion into thruster and joint actuation.

By virtual work Q^T zdot0 is the power of all applied forces, so a force f at
a point P of body k and a couple n on body k (inertial frame) give
J+_{k,P}^T [f; n] (eqs. 7-10), and thruster force f_S, torque n_S (spacecraft
frame, at the spacecraft CM) and joint torques tau give Q_c = J_q^T [f_S; n_S; tau]
(eq. 21). J_q is block triangular with unit diagonal blocks (T0^T on the
first), so J_q^-T is a forward substitution (eq. 30's inversion). Q is
conjugate to zdot0 = [rdot_cm (inertial), omega0 (spacecraft frame), qdot].
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.errors import ShapeError
from ..core.model import Model
from ._inputs import _attitude, _joints, _rotate, _vector, _velocity
from .jacobians import actuation_jacobian, point_jacobian
from .kinematics import body_rotations

__all__ = ["ExternalWrench", "actuation_from_generalized_forces", "generalized_forces"]

_FRAME_CODES = {"inertial": 0, "spacecraft": 1, "body": 2}


_FRAMES = ("inertial", "spacecraft", "body")


# ----------------------------------------------------------------- generalized forces
@dataclass(frozen=True, eq=False)
class ExternalWrench:
    """A force at a point of a body plus a couple on that body (1991 eq. 18's f_{k,m}, n_{k,m}).

    ``point`` is in the body frame of ``body`` (default its frame origin);
    ``force`` and ``torque`` (..., 3) are in ``frame``: ``"inertial"`` (default),
    ``"spacecraft"`` or ``"body"`` (the frame of ``body``). The torque is a pure
    couple; the force acts at the point.
    """

    body: str | int
    force: Any = (0.0, 0.0, 0.0)
    torque: Any = (0.0, 0.0, 0.0)
    point: Any = (0.0, 0.0, 0.0)
    frame: str = "inertial"


def _wrenches(external: Any) -> tuple[ExternalWrench, ...]:
    if external is None:
        return ()
    items = (external,) if isinstance(external, ExternalWrench) else tuple(external)
    for i, w in enumerate(items):
        if not isinstance(w, ExternalWrench):
            raise TypeError(f"external[{i}]: expected an ff.ExternalWrench, got {type(w).__name__}")
        if w.frame not in _FRAMES:
            raise ValueError(f"external[{i}].frame: expected 'inertial', 'spacecraft' or 'body', got {w.frame!r}")
    return items


def _engine_wrenches(model: Model, external: Sequence[ExternalWrench]) -> tuple[np.ndarray, np.ndarray]:
    """External wrenches as the engine takes them: ext_i (W, 2) = [body, frame code], ext_f (..., W, 9) = [point, force, couple]."""
    ext_i = np.zeros((len(external), 2), dtype=np.int64)
    rows = []
    for i, w in enumerate(external):
        ext_i[i] = model.body_index(w.body), _FRAME_CODES[w.frame]
        p = _vector(w.point, 3, f"external[{i}].point", "point in the body frame")
        if p.shape != (3,):
            raise ShapeError(f"external[{i}].point: expected shape (3,), got {p.shape}")
        f = _vector(w.force, 3, f"external[{i}].force", "force, in the wrench's frame")
        n_ = _vector(w.torque, 3, f"external[{i}].torque", "couple, in the wrench's frame")
        rows.append(np.concatenate(np.broadcast_arrays(np.broadcast_to(p, f.shape), f, n_), axis=-1))
    if not rows:
        return ext_i, np.zeros((0, 9))
    batch = np.broadcast_shapes(*(r.shape[:-1] for r in rows))
    return ext_i, np.stack([np.broadcast_to(r, (*batch, 9)) for r in rows], axis=-2)


def _actuation_parts(model: Model, tau: Any, force: Any, torque: Any) -> tuple[np.ndarray | None, ...]:
    """u = [tau (N), f_S (3), n_S (3)] as the engine takes it: its three parts (..., N), (..., 3), (..., 3), each
    checked, None where it is zero (the engine reads them apart: no (..., N + 6) copy is made here)."""
    checks = (
        (tau, model.n_joints, "joint_torque", f"one torque per joint: {', '.join(model.joint_names) or 'none'}"),
        (force, 3, "spacecraft_force", "thruster force at the spacecraft CM, spacecraft frame"),
        (torque, 3, "spacecraft_torque", "thruster torque, spacecraft frame"),
    )
    return tuple(None if value is None else _vector(value, size, name, what) for value, size, name, what in checks)


def _generalized_forces_0(
    model: Model, q: np.ndarray, tau: Any, force: Any, torque: Any, external: Sequence[ExternalWrench], t0: np.ndarray | None
) -> np.ndarray:
    """Q with its first block in the spacecraft frame (Q_0 = J_q0^T u + sum J0^T w0), broadcast shape."""
    n = model.n_joints
    parts: list[np.ndarray] = []
    u_parts: list[np.ndarray] = []
    for value, size, name, what in (
        (force, 3, "spacecraft_force", "thruster force at the spacecraft CM, spacecraft frame"),
        (torque, 3, "spacecraft_torque", "thruster torque, spacecraft frame"),
        (tau, n, "joint_torque", f"one torque per joint: {', '.join(model.joint_names) or 'none'}"),
    ):
        arr = np.zeros(size) if value is None else _vector(value, size, name, what)
        u_parts.append(arr)
    batch = np.broadcast_shapes(q.shape[:-1], *(p.shape[:-1] for p in u_parts))
    u = np.concatenate([np.broadcast_to(p, batch + p.shape[-1:]) for p in u_parts], axis=-1)
    j_q = actuation_jacobian(model, q)  # spacecraft frame: rows [v_S, omega0, qdot]
    total = np.einsum("...ji,...j->...i", j_q, u)
    rot = body_rotations(model, q) if any(w.frame == "body" for w in external) else None
    for i, w in enumerate(external):
        k = model.body_index(w.body)
        f = _vector(w.force, 3, f"external[{i}].force", "force, in the wrench's frame")
        n_ = _vector(w.torque, 3, f"external[{i}].torque", "couple, in the wrench's frame")
        p = _vector(w.point, 3, f"external[{i}].point", "point in the body frame")
        if p.shape != (3,):
            raise ShapeError(f"external[{i}].point: expected shape (3,), got {p.shape}")
        if w.frame == "inertial":
            f, n_ = _rotate(t0, f, inverse=True), _rotate(t0, n_, inverse=True)
        elif w.frame == "body":
            assert rot is not None
            f, n_ = (np.einsum("...ij,...j->...i", rot[..., k, :, :], x) for x in (f, n_))
        jac = point_jacobian(model, q, k, p)  # spacecraft frame ⁰J+
        wrench = np.concatenate(np.broadcast_arrays(f, n_), axis=-1)
        parts.append(np.einsum("...ji,...j->...i", jac, wrench))
    for part in parts:
        total = total + part
    return total


def _to_inertial_first_block(q_0: np.ndarray, t0: np.ndarray | None) -> np.ndarray:
    if t0 is None:
        return q_0
    first = _rotate(t0, q_0[..., 0:3])
    batch = np.broadcast_shapes(q_0.shape[:-1], first.shape[:-1])
    out = np.array(np.broadcast_to(q_0, batch + q_0.shape[-1:]))
    out[..., 0:3] = first
    return out


def generalized_forces(
    model: Model,
    q: Any,
    joint_torque: Any = None,
    spacecraft_force: Any = None,
    spacecraft_torque: Any = None,
    external: Any = (),
    attitude: Any = None,
) -> np.ndarray:
    """Q of 1991 eqs. 18 and 21, (..., 6 + N), conjugate to zdot0 = [rdot_cm, omega0, qdot].

    Q = J_q^T [f_S; n_S; tau] + sum over ``external`` of J+_{k,P}^T [f; n]:
    thruster force ``spacecraft_force`` and torque ``spacecraft_torque`` at the
    spacecraft CM in the spacecraft frame, ``joint_torque`` (..., N), and
    :class:`ExternalWrench` items. Q^T zdot0 is the power of all these forces.
    Rows: [total force (inertial frame; spacecraft frame when ``attitude`` is
    None), moment conjugate to omega0 (spacecraft frame), joint rows].
    None means zero.
    """
    q = _joints(model, q, "q")
    t0 = _attitude(attitude)
    q_0 = _generalized_forces_0(model, q, joint_torque, spacecraft_force, spacecraft_torque, _wrenches(external), t0)
    return _to_inertial_first_block(q_0, t0)


def _actuation_0(
    model: Model, q: np.ndarray, q_0: np.ndarray, out: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(f_S, n_S, tau) = J_q0^-T Q_0 by forward substitution (first block of Q_0 in the spacecraft frame); into
    ``out`` (three arrays of the results' shapes, checked by the caller) when given, which is then returned."""
    j_q = actuation_jacobian(model, q)
    j11, j12, j22 = j_q[..., 0:3, 3:6], j_q[..., 0:3, 6:], j_q[..., 3:6, 6:]
    force = q_0[..., 0:3]
    torque = q_0[..., 3:6] - np.einsum("...ji,...j->...i", j11, force)
    tau = q_0[..., 6:] - np.einsum("...ji,...j->...i", j12, force) - np.einsum("...ji,...j->...i", j22, torque)
    batch = np.broadcast_shapes(force.shape[:-1], torque.shape[:-1], tau.shape[:-1])
    if out is not None:
        for o, x in zip(out, (force, torque, tau), strict=True):
            o[...] = x
        return out
    return tuple(np.broadcast_to(x, batch + x.shape[-1:]).copy() for x in (force, torque, tau))  # type: ignore[return-value]


def actuation_from_generalized_forces(
    model: Model, q: Any, generalized_force: Any, attitude: Any = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(f_S, n_S, tau) with J_q^T [f_S; n_S; tau] = Q: the inversion of 1991 eq. 21 used in eq. 30.

    ``generalized_force`` is Q (..., 6 + N) in the zdot0 coordinates (first
    block inertial; spacecraft frame when ``attitude`` is None). Returns the
    thruster force and torque at the spacecraft CM (spacecraft frame) and the
    joint torques that produce it. J_q is always invertible (block triangular).
    """
    q = _joints(model, q, "q")
    gf = _velocity(model, generalized_force, "generalized_force")
    t0 = _attitude(attitude)
    if t0 is None:
        return _actuation_0(model, q, gf)
    first = _rotate(t0, gf[..., 0:3], inverse=True)
    batch = np.broadcast_shapes(first.shape[:-1], gf.shape[:-1])
    q_0 = np.array(np.broadcast_to(gf, (*batch, gf.shape[-1])))
    q_0[..., 0:3] = first
    return _actuation_0(model, q, q_0)
