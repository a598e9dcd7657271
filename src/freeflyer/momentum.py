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
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ._batch import chunked, joint_array, vector_array
from .conventions import attitude_matrix
from .kinematics import _rotations, joint_axes
from .model import Model

__all__ = [
    "InertiaBlocks",
    "inertia_blocks",
    "system_inertia_matrix",
    "angular_momentum",
    "linear_momentum",
    "kinetic_energy",
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


def _pair_inertias(model: Model, rot: np.ndarray) -> np.ndarray:
    """Kernel: D_ij (C, B, B, 3, 3) in the spacecraft frame."""
    # w[c, k, i] = T_i v_ik; a_ij = T_i v_(i->j) = w[:, j, i]; b_ij = T_j v_(j->i) = w[:, i, j]
    w = np.einsum("cbij,kbj->ckbi", rot, model.bary.point_table)
    b = w
    a = np.swapaxes(w, 1, 2)
    dot = np.einsum("cijx,cijx->cij", a, b)
    out = model.total_mass * (np.einsum("cijx,cijy->cijxy", b, a) - dot[..., None, None] * np.eye(3))
    diag = np.einsum("cbij,bjk,cblk->cbil", rot, model.bary.diagonal_inertia, rot)
    idx = np.arange(model.n_bodies)
    out[:, idx, idx] = diag
    return out


def _blocks(model: Model, rot: np.ndarray, need_qq: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    pair = _pair_inertias(model, rot)
    sub = model.subtree.astype(float)
    axes = joint_axes(model, rot)  # (C, N, 3)
    # Column sums over i, then subtree sums over j: E_l = sum_i sum_{j in sub(l)} D_ij
    col = pair.sum(axis=1)  # (C, B, 3, 3), sum over i
    col_sub = np.einsum("lj,cjxy->clxy", sub, col)
    d = col_sub[:, 0]
    d_q = np.einsum("clxy,cly->cxl", col_sub[:, 1:], axes)
    if not need_qq:
        return d, d_q, None
    # Y[i, l] = sum_{j in sub(l)} D_ij a_l ; D_qq[m, l] = sum_{i in sub(m)} a_m . Y[i, l]
    y = np.einsum("lj,cijxy,cly->cilx", sub[1:], pair, axes)
    d_qq = np.einsum("mi,cilx,cmx->cml", sub[1:], y, axes)
    return d, d_q, 0.5 * (d_qq + np.swapaxes(d_qq, 1, 2))


def inertia_blocks(model: Model, q: Any) -> InertiaBlocks:
    """D, D_q, D_qq of 1991 eqs. 16-17 (spacecraft frame), batched over q (..., N)."""
    q = joint_array(model, q)
    d, d_q, d_qq = chunked(lambda qq: _blocks(model, _rotations(model, qq)), q, core_ndims=(1,))
    return InertiaBlocks(D=d, D_q=d_q, D_qq=d_qq)


def _hplus(model: Model, q: np.ndarray) -> np.ndarray:
    d, d_q, d_qq = _blocks(model, _rotations(model, q))
    n = model.n_joints
    out = np.zeros((q.shape[0], 6 + n, 6 + n))
    out[:, 0, 0] = out[:, 1, 1] = out[:, 2, 2] = model.total_mass
    out[:, 3:6, 3:6] = d
    out[:, 3:6, 6:] = d_q
    out[:, 6:, 3:6] = np.swapaxes(d_q, 1, 2)
    out[:, 6:, 6:] = d_qq
    return out


def system_inertia_matrix(model: Model, q: Any) -> np.ndarray:
    """H+ of 1991 eq. 15, (..., 6+N, 6+N), for zdot0 = [rdot_cm, omega0, qdot].

    ``T = 1/2 zdot0^T H+ zdot0`` (eq. 14). H+ does not depend on the attitude;
    the CM block ``M 1`` is the same whether rdot_cm is in the inertial or the
    spacecraft frame.
    """
    q = joint_array(model, q)
    return chunked(lambda qq: _hplus(model, qq), q, core_ndims=(1,))


def _velocity(model: Model, velocity: Any) -> np.ndarray:
    return vector_array(velocity, 6 + model.n_joints, "velocity", "zdot0 = [rdot_cm, omega0, qdot]")


def angular_momentum(model: Model, q: Any, velocity: Any, *, attitude: Any = None) -> np.ndarray:
    """Angular momentum about the system CM, (..., 3): 1992 eq. 12, h = T0 (D w0 + D_q qdot).

    In the inertial frame (the spacecraft frame when ``attitude`` is None).
    """
    q = joint_array(model, q)
    v = _velocity(model, velocity)

    def kernel(qq: np.ndarray, vv: np.ndarray) -> np.ndarray:
        d, d_q, _ = _blocks(model, _rotations(model, qq), need_qq=False)
        return np.einsum("cij,cj->ci", d, vv[:, 3:6]) + np.einsum("cij,cj->ci", d_q, vv[:, 6:])

    h0 = chunked(kernel, q, v, core_ndims=(1, 1))
    if attitude is None:
        return h0
    return np.einsum("...ij,...j->...i", attitude_matrix(attitude), h0)


def linear_momentum(model: Model, velocity: Any) -> np.ndarray:
    """Linear momentum M rdot_cm, (..., 3), in the frame of rdot_cm (inertial)."""
    v = _velocity(model, velocity)
    return model.total_mass * v[..., :3]


def kinetic_energy(model: Model, q: Any, velocity: Any) -> np.ndarray:
    """Kinetic energy 1/2 zdot0^T H+ zdot0 (1991 eq. 14), (...)."""
    h = system_inertia_matrix(model, q)
    v = _velocity(model, velocity)
    return 0.5 * np.einsum("...i,...ij,...j->...", v, h, v)
