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

from ..core.conventions import attitude_matrix
from ..core.model import Model
from ._batch import COMPILE_MIN, Program, Sym, Tape, chunked, compiled, joint_array, vector_array
from .kinematics import _rotations, joint_axes

__all__ = [
    "InertiaBlocks",
    "angular_momentum",
    "inertia_blocks",
    "kinetic_energy",
    "linear_momentum",
    "system_inertia_matrix",
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


# ------------------------------------------------------------------ compiled kernels
#
# D, D_q, D_qq (and, in freeflyer.mechanics.jacobians, J*) are traced once per model as straight-line scalar
# code (freeflyer.mechanics._batch.Tape) and run on chunks of configurations with the batch axis last. The
# trace is O(B):
#
# * from joint angles (inputs sin q, cos q), body frames are re-chosen so that every joint turns
#   about its local z axis (a constant rotation Q_k with Q_k e_z = u_k), so ⁰T_k = ⁰T_parent P'_k
#   Rz(q_k) and the joint axis in the spacecraft frame is the third column of ⁰T_k; from rotations
#   (inputs ⁰T_k, as ``_blocks`` gets them) the body frames stay and the axis is ⁰T_k u_k;
# * with rho_k the body CMs and pi_l the joints relative to the system CM, the subtree sums
#   S_l = sum m_k, F_l = sum m_k rho_k and J_l = sum (T_k I_k T_k^T + m_k (|rho_k|² 1 - rho_k rho_k^T))
#   give D = J_0 and the column of D_q for joint l (the angular momentum about the system CM of
#   the subtree turning about joint l at unit rate): J_l u_l + F_l x (pi_l x u_l);
# * D_qq as in _blocks_numpy (composite-rigid-body terms minus the kinetic energy of the CM motion).

_SNAP = 1e-15


def _snap(a: np.ndarray) -> np.ndarray:
    """Round entries within 1e-15 of 0 or ±1 to them exactly (so they fold away in the trace)."""
    out = np.array(a, dtype=float)
    out[np.abs(out) < _SNAP] = 0.0
    for v in (1.0, -1.0):
        out[np.abs(out - v) < _SNAP] = v
    return out


def _axis_frame(axis: np.ndarray) -> np.ndarray:
    """A rotation Q with Q e_z = axis: a signed permutation when the axis is a coordinate axis."""
    a = _snap(axis)
    i = int(np.argmax(np.abs(a)))
    if abs(a[i]) == 1.0 and np.count_nonzero(a) == 1:
        z = a
        x = np.eye(3)[(i + 1) % 3]
    else:
        z = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
        x = np.cross(np.eye(3)[int(np.argmin(np.abs(z)))], z)
        x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


Vec = list[Sym]
Mat = list[list[Sym]]


def _matvec(m: Mat | np.ndarray, v: Vec | np.ndarray) -> Vec:
    return [m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2] for i in range(3)]


def _cross(a: Vec, b: Vec) -> Vec:
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _add(a: Vec, b: Vec) -> Vec:
    return [x + y for x, y in zip(a, b, strict=True)]


def _sub(a: Vec, b: Vec) -> Vec:
    return [x - y for x, y in zip(a, b, strict=True)]


def _scale(a: Vec, k: float) -> Vec:
    return [x * k for x in a]


@dataclass
class _Trace:
    """Symbolic quantities of one configuration (spacecraft frame)."""

    tape: Tape
    u: list[Vec]  # joint axes (index k - 1 for body k)
    pi: list[Vec]  # joint positions relative to the system CM
    rho_e: list[Vec]  # end-effector positions relative to the system CM
    d: list[list[Sym]]  # D (3 x 3)
    d_q: list[Vec]  # columns of D_q
    first: list[Vec]  # F_l, subtree first moments about the system CM
    subtree_mass: np.ndarray
    total_mass: float

    def linear_momenta(self) -> list[Vec]:
        """p_l = u_l x (F_l - S_l pi_l): linear momentum of the subtree of joint l turning at unit rate."""
        return [_cross(u, _sub(f, _scale(pi, s))) for u, f, pi, s in zip(self.u, self.first, self.pi, self.subtree_mass[1:], strict=True)]


def _trace(model: Model, eager_offsets: bool, angles: bool = True) -> _Trace:
    """Trace one configuration. Inputs: [sin q, cos q] (``angles``) or the rotations ⁰T_k, k >= 1 (row-major)."""
    tape = Tape(eager_offsets)
    n_b, n = model.n_bodies, model.n_joints
    zero, one = tape.const(0.0), tape.const(1.0)
    rot: list[Mat] = [[[one if i == j else zero for j in range(3)] for i in range(3)]]
    origin: list[Vec] = [[zero, zero, zero]]
    if angles:
        s = [tape.input() for _ in range(n)]
        c = [tape.input() for _ in range(n)]
        q_frames = [np.eye(3)] + [_axis_frame(model.joint_axis[k]) for k in range(1, n_b)]
    else:
        inputs = [[[tape.input() for _ in range(3)] for _ in range(3)] for _ in range(1, n_b)]
        q_frames = [np.eye(3)] * n_b
    for k in range(1, n_b):
        p = int(model.parent[k])
        if angles:
            place = _snap(q_frames[p].T @ model.joint_rotation[k] @ q_frames[k])
            g = [[sum((rot[p][i][m] * place[m, j] for m in range(3)), zero) for j in range(3)] for i in range(3)]
            ck, sk = c[k - 1], s[k - 1]
            rot.append([[g[i][0] * ck + g[i][1] * sk, g[i][1] * ck - g[i][0] * sk, g[i][2]] for i in range(3)])
        else:
            rot.append(inputs[k - 1])
        origin.append(_add(origin[p], _matvec(rot[p], _snap(q_frames[p].T @ model.joint_origin[k]))))
    cms = [_add(origin[k], _matvec(rot[k], _snap(q_frames[k].T @ model.com[k]))) for k in range(n_b)]
    mass, total = model.mass, model.total_mass
    cm = [sum((cms[k][i] * (mass[k] / total) for k in range(n_b)), zero) for i in range(3)]
    rho = [_sub(x, cm) for x in cms]
    # per body: inertia about the system CM, 6 components xx yy zz xy xz yz
    pairs = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
    inertia: list[list[Sym]] = []
    for k in range(n_b):
        local = q_frames[k].T @ model.inertia[k] @ q_frames[k]
        off = local - np.diag(np.diag(local))
        if np.all(np.abs(off) <= _SNAP * np.trace(local)):
            lam, vecs = np.diag(local).copy(), np.eye(3)
        else:
            lam, vecs = np.linalg.eigh(local)
        # T I T^T = base 1 + sum beta_i w_i w_i^T, w_i = T e_i: base a repeated principal moment if any
        # (an axisymmetric body needs one rank-1 term), else the smallest
        close = [i for i in range(3) if sum(abs(lam[i] - lam[j]) <= _SNAP * abs(lam[i]) for j in range(3)) > 1]
        base = float(lam[close[0]] if close else np.min(lam))
        w = [(float(lam[i] - base), _matvec(rot[k], _snap(vecs[:, i]))) for i in range(3) if lam[i] != base]
        r = rho[k]
        sq = [r[0] * r[0], r[1] * r[1], r[2] * r[2]]
        comp = []
        for a, b in pairs:
            term = sum((wi[a] * wi[b] * beta for beta, wi in w), zero)
            if a == b:
                term = term + base + (sq[(a + 1) % 3] + sq[(a + 2) % 3]) * mass[k]
            else:
                term = term - r[a] * r[b] * mass[k]
            comp.append(term)
        inertia.append(comp)
    first = [_scale(rho[k], mass[k]) for k in range(n_b)]
    for k in range(n_b - 1, 0, -1):
        p = int(model.parent[k])
        inertia[p] = [x + y for x, y in zip(inertia[p], inertia[k], strict=True)]
        first[p] = _add(first[p], first[k])
    subtree_mass = model.subtree.astype(float) @ mass

    def full(j: list[Sym]) -> Mat:
        return [[j[0], j[3], j[4]], [j[3], j[1], j[5]], [j[4], j[5], j[2]]]

    u = [_matvec(rot[k], _snap(q_frames[k].T @ model.joint_axis[k])) for k in range(1, n_b)]  # column 2 when angles
    pi = [_sub(origin[k], cm) for k in range(1, n_b)]
    d_q = [_add(_matvec(full(inertia[k]), u[k - 1]), _cross(first[k], _cross(pi[k - 1], u[k - 1]))) for k in range(1, n_b)]
    rho_e = []
    for e in range(model.n_end_effectors):
        k = int(model.end_effector_body[e])
        rho_e.append(_sub(_add(origin[k], _matvec(rot[k], _snap(q_frames[k].T @ model.end_effector_point[e]))), cm))
    return _Trace(tape, u, pi, rho_e, full(inertia[0]), d_q, first[1:], subtree_mass, total)


def _trace_blocks(model: Model, eager_offsets: bool, need_qq: bool) -> tuple[Tape, list[Sym]]:
    """D (9, row-major), D_q (3 x N, row-major) and D_qq (N x N) from the rotations, as traced scalars."""
    t = _trace(model, eager_offsets, angles=False)
    n = model.n_joints
    outputs = [x for row in t.d for x in row] + [t.d_q[l][i] for i in range(3) for l in range(n)]
    if need_qq:
        p = t.linear_momenta()
        d_qq: list[list[Sym]] = [[t.tape.const(0.0)] * n for _ in range(n)]
        for a in range(n):
            for l in range(a, n):
                value = -_dot(p[a], p[l]) / t.total_mass
                if model.subtree[a + 1, l + 1]:  # l in the subtree of a
                    value = value + _dot(t.u[a], _sub(t.d_q[l], _cross(t.pi[a], p[l])))
                d_qq[a][l] = d_qq[l][a] = value
        outputs += [x for row in d_qq for x in row]
    return t.tape, outputs


def _dot(a: Vec, b: Vec) -> Sym:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _pair_inertias(model: Model, rot: np.ndarray) -> np.ndarray:
    """Kernel: D_ij (C, B, B, 3, 3) in the spacecraft frame (the reference form; ``_blocks`` is O(B))."""
    # w[c, k, i] = T_i v_ik; a_ij = T_i v_(i->j) = w[:, j, i]; b_ij = T_j v_(j->i) = w[:, i, j]
    w = _rotate_table(rot, model.bary.point_table)
    b = w
    a = np.swapaxes(w, 1, 2)
    dot = np.sum(a * b, axis=-1)
    out = b[..., :, None] * a[..., None, :]
    idx = np.arange(3)
    out[..., idx, idx] -= dot[..., None]
    out *= model.total_mass
    diag = np.matmul(np.matmul(rot, model.bary.diagonal_inertia), np.swapaxes(rot, -1, -2))
    bodies = np.arange(model.n_bodies)
    out[:, bodies, bodies] = diag
    return out


def _rotate_table(rot: np.ndarray, table: np.ndarray) -> np.ndarray:
    """w[c, p, b] = T_b table[p, b] for rot (C, B, 3, 3) and a barycentric table (P, B, 3): (C, P, B, 3)."""
    r = rot[:, None]
    return r[..., 0] * table[None, :, :, None, 0] + r[..., 1] * table[None, :, :, None, 1] + r[..., 2] * table[None, :, :, None, 2]


def _table_sum(rot: np.ndarray, table: np.ndarray) -> np.ndarray:
    """sum over b of T_b table[p, b] (a barycentric sum, 1992 eq. 4): (C, P, 3), one GEMM over (b, j)."""
    c, n_b = rot.shape[:2]
    lhs = np.swapaxes(rot, 1, 2).reshape(c * 3, n_b * 3)  # [(c, i), (b, j)]
    return (lhs @ table.reshape(table.shape[0], n_b * 3).T).reshape(c, 3, table.shape[0]).swapaxes(1, 2)


def _subtree_sum(model: Model, x: np.ndarray) -> np.ndarray:
    """sum over the bodies k in the subtree of l of x[:, k], for every l: (C, B, ...) -> (C, B, ...), one GEMM."""
    return np.moveaxis(np.tensordot(model.subtree.astype(float), x, axes=([1], [1])), 0, 1)


def _blocks(model: Model, rot: np.ndarray, need_qq: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Kernel: D (C, 3, 3), D_q (C, 3, N), D_qq (C, N, N) or None, spacecraft frame, from ⁰T_k (C, B, 3, 3).

    Compiled (see ``_trace_blocks``) for chunks of at least ``COMPILE_MIN`` configurations, else
    ``_blocks_numpy``; both are the sums of ``_pair_inertias`` (1991 eq. 16) in O(B).
    """
    c = rot.shape[0]
    if c < COMPILE_MIN or model.n_joints == 0:
        return _blocks_numpy(model, rot, need_qq)
    program = compiled(model, ("blocks", need_qq), lambda eager: Program(*_trace_blocks(model, eager, need_qq)))
    assert program is not None
    n = model.n_joints
    inputs = np.ascontiguousarray(rot[:, 1:].reshape(c, -1).T)
    out = np.empty((program.n_outputs, c))
    program(inputs, out)
    out = out.T  # batch first (a view)
    d, d_q = out[:, :9].reshape(c, 3, 3), out[:, 9 : 9 + 3 * n].reshape(c, 3, n)
    return d, d_q, (out[:, 9 + 3 * n :].reshape(c, n, n) if need_qq else None)


def _blocks_numpy(model: Model, rot: np.ndarray, need_qq: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """D, D_q, D_qq (C, ...) from subtree composites in O(B); equal to the sums of ``_pair_inertias``.

    With rho_k the body CMs and pi_l the joints relative to the system CM, J_l the inertia of the
    subtree of joint l about the system CM and F_l its first moment, D = J_0 and the column of D_q
    for joint l is the angular momentum about the system CM of that subtree turning about the
    joint at unit rate: h_l = J_l u_l + F_l x (pi_l x u_l). Its linear momentum is
    p_l = u_l x (F_l - S_l pi_l) (S_l the subtree mass), and with the CM held fixed
    D_qq[m, l] = u_m . (h_l - pi_m x p_l) - p_m . p_l / M   for l in the subtree of m
    (the fixed-base composite-rigid-body term minus the kinetic energy of the CM motion).
    """
    mass = model.mass
    rho = _table_sum(rot, model.bary.point_table)  # (C, B, 3), 1992 eq. 4
    eye = np.eye(3)
    own = np.matmul(np.matmul(rot, model.inertia), np.swapaxes(rot, -1, -2))  # T_k I_k T_k^T
    mr = mass[:, None] * rho
    own += np.sum(mr * rho, axis=-1)[..., None, None] * eye - mr[..., :, None] * rho[..., None, :]
    inertia = _subtree_sum(model, own)  # (C, B, 3, 3)
    first = _subtree_sum(model, mr)  # (C, B, 3)
    d = inertia[:, 0]
    if model.n_joints == 0:
        n0 = rot.shape[0]
        return d, np.zeros((n0, 3, 0)), (np.zeros((n0, 0, 0)) if need_qq else None)
    axes = joint_axes(model, rot)  # (C, N, 3)
    joints = rho[:, 1:] - np.matmul(rot[:, 1:], model.com[1:, :, None])[..., 0]  # pi_l
    first_q = first[:, 1:]
    h = np.matmul(inertia[:, 1:], axes[..., None])[..., 0] + np.cross(first_q, np.cross(joints, axes))
    d_q = np.swapaxes(h, 1, 2)
    if not need_qq:
        return d, d_q, None
    subtree_mass = model.subtree.astype(float)[1:] @ mass
    p = np.cross(axes, first_q - subtree_mass[:, None] * joints)
    a = np.matmul(axes, d_q) - np.matmul(np.cross(axes, joints), np.swapaxes(p, 1, 2))  # a[m, l]
    inboard = model.subtree[1:, 1:]  # [m, l]: l in the subtree of m
    d_qq = np.where(inboard, a, 0.0)
    d_qq += np.swapaxes(np.where(inboard & ~np.eye(model.n_joints, dtype=bool), a, 0.0), 1, 2)
    d_qq -= np.matmul(p, np.swapaxes(p, 1, 2)) / model.total_mass
    return d, d_q, d_qq


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
