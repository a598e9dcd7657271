"""Inertia blocks, the system inertia matrix H+, momentum and kinetic energy.

1991 eqs. 14-17 and 1992 eq. 12, written with barycentric vectors and
generalized to trees. For bodies i and j the 3x3 block that couples their
angular velocities in the kinetic energy ``T = 1/2 sum_ij w_i^T D_ij w_j`` is

    D_ii = T_i (I_i + sum_k m_k (|v_ik|^2 1 - v_ik v_ik^T)) T_i^T
    D_ij = -M ((a . b) 1 - b a^T),  a = T_i v_(i->j),  b = T_j v_(j->i)   (i != j)

where v_(i->j) is body i's barycentric vector pointing towards body j (r* if j
is outboard of i, l* otherwise). For a chain this is exactly 1991 eq. 17; the
tree form follows from sum_k m_k v_ik = 0 (derivation in docs/theory.md).
With w_i = w_0 + F_i qdot (1991 eq. 5), F_i the axes of the joints between
the spacecraft and body i:

    D    = sum_ij D_ij                       (1991 eq. 16a)
    D_q  = sum_ij D_ij F_j                   (1991 eq. 16b)
    D_qq = sum_ij F_i^T D_ij F_j             (1991 eq. 16b printed: sum_j F_j^T D_j F_j,
                                              not symmetric; see docs/paper-notes.md)

Two algorithms, each written once, check each other: ``method="recursive"`` (the default) is
the engine's composite-rigid-body recursion at the spacecraft frame origin
(:mod:`._recursions`, every batch size); ``method="barycentric"`` sums the pair inertias
D_ij of eqs. 16-17 exactly as printed (O(B^2), the readable reference).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import engine
from ..core.conventions import attitude_matrix
from ..core.errors import ShapeError
from ..core.model import Model
from ..core.numbers import joint_array, vector_array
from ..core.wheels import wheel_arrays
from ._batches import chunked, pieces
from ._inputs import body_joints, check_method, check_out_inputs, gather_square
from .kinematics import _rotations, _slides, joint_axes

__all__ = [
    "InertiaBlocks",
    "angular_momentum",
    "free_floating_joint_inertia",
    "inertia_blocks",
    "kinetic_energy",
    "linear_momentum",
    "system_inertia_matrix",
    "wheel_momentum",
    "wheel_spin_momentum",
    "zero_momentum_rate",
]


@dataclass(frozen=True)
class InertiaBlocks:
    """The blocks of H+ (1991 eq. 15), spacecraft frame.

    D (..., 3, 3): system inertia about the system CM; D_q (..., 3, N): coupling
    of joint rates into angular momentum; D_qq (..., N, N): joint-space block.
    """

    D: np.ndarray
    D_q: np.ndarray
    D_qq: np.ndarray


# ------------------------------------------------------------------ the barycentric reference (1991 eqs. 16-17)
def _pair_inertias(model: Model, rot: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
    """Kernel: the pair inertias D_ij (C, B, B, 3, 3) of 1991 eq. 17, spacecraft frame.

    With prismatic joints the barycentric vectors are taken at ``q`` (docs/theory.md) and the
    diagonal blocks are summed there instead of read from the table made at build time.
    """
    # w[c, k, i] = T_i v_ik; a_ij = T_i v_(i->j) = w[:, j, i]; b_ij = T_j v_(j->i) = w[:, i, j]
    w = _rotated_tables(model, rot, q)
    b = w
    a = np.swapaxes(w, 1, 2)
    dot = np.sum(a * b, axis=-1)
    out = b[..., :, None] * a[..., None, :]
    idx = np.arange(3)
    out[..., idx, idx] -= dot[..., None]
    out *= model.total_mass
    if model.has_prismatic:
        mass = model.mass
        sq = np.einsum("k,ckix,ckix->ci", mass, w, w)
        own = np.matmul(np.matmul(rot, model.inertia), np.swapaxes(rot, -1, -2))
        diag = own + sq[..., None, None] * np.eye(3) - np.einsum("k,ckix,ckiy->cixy", mass, w, w)
    else:
        diag = np.matmul(np.matmul(rot, model.bary.diagonal_inertia), np.swapaxes(rot, -1, -2))
    bodies = np.arange(model.n_bodies)
    out[:, bodies, bodies] = diag
    return out


def _rotated_tables(model: Model, rot: np.ndarray, q: np.ndarray | None) -> np.ndarray:
    """w[c, k, i] = T_i v_ik(q) (C, B, B, 3): the barycentric vectors of the body CMs, spacecraft frame, at q."""
    w = _rotate_table(rot, model.bary.point_table)
    if model.has_prismatic:
        if q is None:
            raise TypeError("_rotated_tables: q is needed for a model with prismatic joints")
        slides = _slides(model, rot, q)  # (C, N, 3)
        parents = model.parent[1:]
        for j in np.flatnonzero(model.prismatic):
            w[:, :, parents[j]] += slides[:, j, None, :] * model.bary.slide_coefficient[j][None, :, None]
    return w


def _rotate_table(rot: np.ndarray, table: np.ndarray) -> np.ndarray:
    """w[c, p, b] = T_b table[p, b] for rot (C, B, 3, 3) and a barycentric table (P, B, 3): (C, P, B, 3)."""
    r = rot[:, None]
    return r[..., 0] * table[None, :, :, None, 0] + r[..., 1] * table[None, :, :, None, 1] + r[..., 2] * table[None, :, :, None, 2]


def _hplus_barycentric(model: Model, q: np.ndarray) -> np.ndarray:
    """Kernel: H+ (C, 6 + N, 6 + N) from the pair inertias, 1991 eq. 16 as printed (D_qq symmetrised, docs/paper-notes.md).

    D = sum_ij D_ij, D_q = sum_ij D_ij F_j, D_qq = sum_ij F_i^T D_ij F_j with F_j (3, N) the axes
    (spacecraft frame) of the joints between the spacecraft and body j, zero elsewhere (1991 eq. 5).

    Prismatic joints (docs/theory.md): they turn nothing (zero columns of F_j), and the sliding
    rate of joint l moves the CM of body k, relative to the system CM, by (chi_l(k) - mu*_l) u_l.
    That adds to the kinetic energy the cross terms omega_i . (Y_il x u_l) qdot_l with
    Y_il = sum_k m_k (chi_l(k) - mu*_l) T_i v_ik, and (sum_k m_k c_jk c_lk) u_j . u_l qdot_j qdot_l.
    Mimic joints: H+ = T^T H+_body T with T = diag(1, Model.mimic_matrix) (:func:`~._inputs.gather_square`).
    """
    if model.has_mimic:
        return gather_square(model, _hplus_barycentric(*body_joints(model, q)), 6)
    rot = _rotations(model, q)
    sliding = model.prismatic
    pair = _pair_inertias(model, rot, q)  # (C, B, B, 3, 3)
    n = model.n_joints
    axes = joint_axes(model, rot)  # (C, N, 3), turning or sliding
    f = np.einsum("lj,clx->cjxl", model.subtree[1:].astype(float) * ~sliding[:, None], axes)  # F_j (C, B, 3, N)
    out = np.zeros((q.shape[0], 6 + n, 6 + n))
    out[:, 0, 0] = out[:, 1, 1] = out[:, 2, 2] = model.total_mass
    out[:, 3:6, 3:6] = pair.sum(axis=(1, 2))
    d_q = np.einsum("cijxy,cjyl->cxl", pair, f)
    out[:, 3:6, 6:] = d_q
    out[:, 6:, 3:6] = np.swapaxes(d_q, 1, 2)
    out[:, 6:, 6:] = np.einsum("cixk,cijxy,cjyl->ckl", f, pair, f)
    if sliding.any():
        coef = model.bary.slide_coefficient  # (N, K): chi_l(k) - mu*_l, zero rows for revolute joints
        y = np.einsum("k,lk,ckix->cilx", model.mass, coef, _rotated_tables(model, rot, q))  # Y_il (C, B, N, 3)
        cross = np.cross(y, axes[:, None, :, :])  # Y_il x u_l (C, B, N, 3)
        g = np.concatenate([np.broadcast_to(np.eye(3), (*f.shape[:2], 3, 3)), f], axis=-1)  # G_i = [1, F_i]
        col = np.einsum("cixk,cilx->ckl", g, cross)  # (C, 3 + N, N): d T / d(omega-part) d qdot_l
        block = out[:, 3:, 3:]
        block[:, :, 3:] += col
        block[:, 3:, :] += np.swapaxes(col, 1, 2)
        energy = np.einsum("k,jk,lk->jl", model.mass, coef, coef)
        block[:, 3:, 3:] += energy[None] * np.einsum("cjx,clx->cjl", axes, axes)
    out[:, 6:, 6:] += np.diag(model.joint_armature)  # each joint's rotor inertia (Model.joint_armature), its diagonal alone
    return out


def _method(method: str) -> str:
    return check_method(method, "1991 eq. 16")


def system_inertia_matrix(model: Model, q: Any, *, method: str = "recursive", out: np.ndarray | None = None) -> np.ndarray:
    """H+ of 1991 eq. 15, (..., 6+N, 6+N), for zdot0 = [rdot_cm, omega0, qdot].

    ``T = 1/2 zdot0^T H+ zdot0`` (eq. 14). H+ does not depend on the attitude;
    the CM block ``M 1`` is the same whether rdot_cm is in the inertial or the
    spacecraft frame. ``method="recursive"`` (default): composite rigid bodies
    (the engine); ``method="barycentric"``: the pair-inertia sums of eq. 16.

    ``out``: an array of the result's shape (..., 6+N, 6+N), float64, C-contiguous and writable, sharing no memory
    with ``q``: H+ is written into it and it is returned (``method="recursive"`` only), so that a loop of calls of one
    size reuses one array instead of a new one per call.
    """
    method = _method(method)
    check_out_inputs(out, method, q=q)
    q = joint_array(model, q)
    if method == "recursive":
        return engine.inertia_matrix(model, q, out)
    return chunked(pieces(lambda qq: _hplus_barycentric(model, qq), model.n_bodies), q, core_ndims=(1,))


def inertia_blocks(model: Model, q: Any, *, method: str = "recursive") -> InertiaBlocks:
    """D, D_q, D_qq of 1991 eqs. 16-17 (spacecraft frame), batched over q (..., N); views of H+."""
    h = system_inertia_matrix(model, q, method=method)
    return InertiaBlocks(D=h[..., 3:6, 3:6], D_q=h[..., 3:6, 6:], D_qq=h[..., 6:, 6:])


def zero_momentum_rate(h_plus: np.ndarray, qdot: np.ndarray | None = None, h0: np.ndarray | None = None) -> np.ndarray:
    """The spacecraft rate of a free-floating system, from H+: the one home of 1992 eq. 12.

    The angular momentum about the system CM, spacecraft frame, is h0 = D omega0 + D_q qdot, so
    omega0 = D^-1 (h0 - D_q qdot) (spacecraft frame, rad/s). ``h_plus``: H+ (..., 6 + N, 6 + N) (1991 eq. 15);
    ``qdot``: joint rates (..., N) giving (..., 3), or K columns of them (..., N, K) giving (..., 3, K); None: the
    map itself, -D^-1 D_q (..., 3, N) (omega0 = map qdot at zero momentum); ``h0``: (..., 3), None for zero
    momentum.
    """
    d = h_plus[..., 3:6, 3:6]
    d_q = h_plus[..., 3:6, 6:]
    if qdot is None:
        if h0 is not None:
            raise ValueError("zero_momentum_rate: h0 needs qdot")
        return -np.linalg.solve(d, d_q)
    qd = np.asarray(qdot, dtype=float)
    column = qd.ndim == h_plus.ndim - 1  # (..., N): one rate vector
    rhs = -(d_q @ (qd[..., None] if column else qd))
    if h0 is not None:
        rhs = rhs + np.asarray(h0, dtype=float)[..., :, None]
    out = np.linalg.solve(d, rhs)
    return out[..., 0] if column else out


def free_floating_joint_inertia(model: Model, q: Any, *, method: str = "recursive") -> np.ndarray:
    """Joint-space inertia with the spacecraft free, (..., N, N): D_qq - D_q^T D^-1 D_q.

    The Schur complement of H+ (1991 eqs. 15-17) on its joint block: the inertia
    that joint torques meet when the spacecraft floats (zero momentum, the
    generalized inertia matrix of the free-floating system). Its diagonal entry i
    is joint i's effective inertia (kg m^2) with the other joints held. ``method``: H+'s, as in
    :func:`system_inertia_matrix`.
    """
    h = system_inertia_matrix(model, q, method=method)
    return h[..., 6:, 6:] + np.swapaxes(h[..., 3:6, 6:], -1, -2) @ zero_momentum_rate(h)


def _velocity(model: Model, velocity: Any) -> np.ndarray:
    return vector_array(velocity, 6 + model.n_joints, "velocity", "zdot0 = [rdot_cm, omega0, qdot]")


def angular_momentum(model: Model, q: Any, velocity: Any, *, attitude: Any = None, wheel_speed: Any = None) -> np.ndarray:
    """Angular momentum about the system CM, (..., 3): 1992 eq. 12, h = T0 (D w0 + D_q qdot).

    In the inertial frame (the spacecraft frame when ``attitude`` is None). With reaction wheels
    (``model.wheels``), ``wheel_speed`` (..., W), rad/s relative to the spacecraft, adds their spin
    :func:`wheel_momentum` (H+ holds the wheels locked: None means they do not turn relative to it).
    """
    v = _velocity(model, velocity)
    h = system_inertia_matrix(model, q)
    h0 = np.einsum("...ij,...j->...i", h[..., 3:6, 3:], v[..., 3:])
    if wheel_speed is not None:
        h0 = h0 + wheel_momentum(model, wheel_speed)
    if attitude is None:
        return h0
    return np.einsum("...ij,...j->...i", attitude_matrix(attitude), h0)


def linear_momentum(model: Model, velocity: Any) -> np.ndarray:
    """Linear momentum M rdot_cm, (..., 3), in the frame of rdot_cm (inertial)."""
    v = _velocity(model, velocity)
    return model.total_mass * v[..., :3]


def kinetic_energy(model: Model, q: Any, velocity: Any, *, wheel_speed: Any = None) -> np.ndarray:
    """Kinetic energy 1/2 zdot0^T H+ zdot0 (1991 eq. 14), (...). With reaction wheels, ``wheel_speed`` (..., W) adds
    their spin relative to the spacecraft: sum_i Js_i ((a_i . omega0) Omega_i + Omega_i^2 / 2) (H+ holds them locked)."""
    h = system_inertia_matrix(model, q)
    v = _velocity(model, velocity)
    energy = 0.5 * np.einsum("...i,...ij,...j->...", v, h, v)
    if wheel_speed is None:
        return energy
    speed = _wheel_speeds(model, wheel_speed)
    axes, js = wheel_arrays(model)
    along = v[..., 3:6] @ axes.T  # a_i . omega0
    return energy + np.sum(js * (along * speed + 0.5 * speed**2), axis=-1)


def _wheel_speeds(model: Model, wheel_speed: Any) -> np.ndarray:
    speed = np.asarray(wheel_speed, dtype=float)
    if speed.ndim == 0 or speed.shape[-1] != model.n_wheels:
        names = ", ".join(w.name for w in model.wheels) or "none"
        raise ShapeError(f"wheel_speed: expected shape (..., {model.n_wheels}), one speed per reaction wheel ({names}), got {speed.shape}")
    return speed


def wheel_momentum(model: Model, wheel_speed: Any) -> np.ndarray:
    """The reaction wheels' angular momentum relative to the spacecraft, sum_i Js_i Omega_i a_i (..., 3), N m s,
    spacecraft frame, for wheel speeds ``wheel_speed`` (..., W) relative to the spacecraft (:mod:`freefloat.core.wheels`).
    The model's H+ holds the wheels locked; the total angular momentum is its own plus this."""
    axes, js = wheel_arrays(model)
    return _wheel_speeds(model, wheel_speed) @ (js[:, None] * axes)


def wheel_spin_momentum(model: Model, wheel_speed: Any, omega: Any) -> np.ndarray:
    """Each rotor's own spin momentum about its axis, Js_i (Omega_i + a_i . omega0) (..., W), N m s, for wheel speeds
    (..., W) relative to the spacecraft and spacecraft rates omega0 (..., 3), spacecraft frame: what a free rotor keeps."""
    axes, js = wheel_arrays(model)
    return js * (_wheel_speeds(model, wheel_speed) + np.asarray(omega, dtype=float) @ axes.T)
