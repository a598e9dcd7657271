"""Jacobians: point J+ (1991 eqs. 7-10), J_q (eq. 21), J_z (eqs. 22-23), J* (1992 eq. 14).

All are batched over q (..., N). Velocities follow the conventions:
zdot0 = [rdot_cm (inertial), omega0 (spacecraft frame), qdot]. With the
attitude at identity (``attitude=None``) the inertial and spacecraft frames
coincide and every matrix is the paper's spacecraft-frame ⁰J.

The linear-velocity part of a point Jacobian is built from barycentric
vectors: with s_l = sum over the bodies i outboard of joint l of T_i v_iP,

    J11 = -[rho_P]x,    J12[:, l] = u_l x s_l,    J22[:, l] = u_l if P is outboard of joint l

which is 1991 eq. 10b evaluated joint by joint (u_l: joint axis, spacecraft frame).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core.conventions import attitude_matrix, euler321_from_matrix, euler321_rate_matrix, quaternion_rate_matrix, skew
from ..core.errors import ShapeError
from ..core.model import Model
from . import _numba_programs
from ._batch import COMPILE_MIN, Program, Sym, Tape, chunked, compiled, joint_array, map_angles
from .kinematics import _rotations
from .momentum import _add, _blocks, _cross, _matvec, _scale, _sub, _trace

__all__ = [
    "actuation_jacobian",
    "end_effector_jacobian",
    "generalized_jacobian",
    "generalized_jacobian_drift",
    "jacobian_determinant",
    "manipulability",
    "point_jacobian",
    "task_jacobian",
]


def _point_terms(model: Model, rot: np.ndarray, tables: np.ndarray, bodies: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Kernel: rho (C, P, 3), J12 (C, P, 3, N), J22 (C, P, 3, N) for P points (spacecraft frame)."""
    sub = model.subtree.astype(float)
    # subtree sums s[c, p, l] = sum_{i in sub(l)} T_i tables[p, i] and the joint axes T_l u_l: one GEMM over (i, j)
    c, n_b = rot.shape[:2]
    n, n_p = model.n_joints, len(tables)
    lhs = np.swapaxes(rot, 1, 2).reshape(c * 3, n_b * 3)  # [(c, x), (i, j)]
    rhs = np.zeros((n_b, 3, n_p * n_b + n))
    rhs[:, :, : n_p * n_b] = np.einsum("li,pij->ijpl", sub, tables).reshape(n_b, 3, n_p * n_b)  # [(i, j), (p, l)]
    rhs[np.arange(1, n_b), :, n_p * n_b + np.arange(n)] = model.joint_axis[1:]  # [(l + 1, j), l]
    both = (lhs @ rhs.reshape(n_b * 3, n_p * n_b + n)).reshape(c, 3, n_p * n_b + n)
    s = both[:, :, : n_p * n_b].reshape(c, 3, n_p, n_b).transpose(0, 2, 3, 1)
    axes = np.swapaxes(both[:, :, n_p * n_b :], 1, 2)  # (C, N, 3)
    rho = s[:, :, 0]
    j12 = np.cross(axes[:, None, :, :], s[:, :, 1:, :], axis=-1)  # (C, P, N, 3)
    outboard = sub[1:, bodies].T  # (P, N): 1 if the point's body is outboard of joint l
    j22 = axes[:, None, :, :] * outboard[None, :, :, None]
    return rho, np.swapaxes(j12, -1, -2), np.swapaxes(j22, -1, -2)


def _assemble(rho: np.ndarray, j12: np.ndarray, j22: np.ndarray, t0: np.ndarray | None) -> np.ndarray:
    """Rows [v; w] over columns [rdot_cm, omega0, qdot] (1991 eq. 10a, then eq. 9)."""
    n = j12.shape[-1]
    out = np.zeros((*rho.shape[:-1], 6, 6 + n))
    out[..., 0:3, 0:3] = np.eye(3)
    out[..., 0:3, 3:6] = -skew(rho)
    out[..., 0:3, 6:] = j12
    out[..., 3:6, 3:6] = np.eye(3)
    out[..., 3:6, 6:] = j22
    if t0 is not None:
        t = t0[..., None, :, :] if t0.ndim > 2 else t0
        out[..., 0:3, 3:] = t @ out[..., 0:3, 3:]
        out[..., 3:6, 3:] = t @ out[..., 3:6, 3:]
    return out


def point_jacobian(model: Model, q: Any, body: str | int, point: Any = None, *, attitude: Any = None) -> np.ndarray:
    """J+_{k,m} of 1991 eqs. 7-10 for a point of a body, (..., 6, 6+N).

    Maps zdot0 to [velocity of the point; angular velocity of the body], both in
    the inertial frame (spacecraft frame when ``attitude`` is None). ``point``
    is in the body frame; default the body's CM (m = CM).
    """
    q = joint_array(model, q)
    k = model.body_index(body)
    p = model.com[k] if point is None else np.asarray(point, dtype=float)
    table = model.bary.point_vectors(model, k, p)[None]
    bodies = np.array([k])

    def kernel(qq: np.ndarray) -> np.ndarray:
        rho, j12, j22 = _point_terms(model, _rotations(model, qq), table, bodies)
        return _assemble(rho[:, 0], j12[:, 0], j22[:, 0], None)

    out = chunked(kernel, q, core_ndims=(1,))
    return out if attitude is None else _rotate_rows(out, attitude)


def _rotate_rows(jac: np.ndarray, attitude: Any) -> np.ndarray:
    t0 = attitude_matrix(attitude)
    out = jac.copy()
    out[..., 0:3, 3:] = t0 @ jac[..., 0:3, 3:]
    out[..., 3:6, 3:] = t0 @ jac[..., 3:6, 3:]
    return out


def end_effector_jacobian(model: Model, q: Any, end_effector: str | int = 0, *, attitude: Any = None) -> np.ndarray:
    """J+ of 1991 eq. 13 for an end effector, (..., 6, 6+N)."""
    e = model.end_effector_index(end_effector)
    return point_jacobian(model, q, int(model.end_effector_body[e]), model.end_effector_point[e], attitude=attitude)


def actuation_jacobian(model: Model, q: Any, *, attitude: Any = None) -> np.ndarray:
    """J_q of 1991 eq. 21, (..., 6+N, 6+N): Q_c = J_q^T [f_S, n_S, tau].

    Maps zdot0 to [velocity of the spacecraft CM, omega0, qdot], all in the
    spacecraft frame, so that the thruster force f_S and torque n_S (at the
    spacecraft CM) are given in the spacecraft frame. Always invertible.
    """
    jac = point_jacobian(model, q, 0)
    n = model.n_joints
    out = np.zeros((*jac.shape[:-2], 6 + n, 6 + n))
    out[..., 0:6, :] = jac
    out[..., 6:, 6:] = np.eye(n)
    if attitude is not None:
        out[..., 0:3, 0:3] = np.swapaxes(attitude_matrix(attitude), -1, -2)
    return out


def task_jacobian(
    model: Model,
    q: Any,
    *,
    attitude: Any = None,
    end_effectors: Any = None,
    orientation: str | None = "euler321",
    spacecraft: bool = True,
) -> np.ndarray:
    """J_z of 1991 eqs. 22-23: zdot1 = J_z zdot0, (..., rows, 6+N).

    z1 stacks, for each end effector in ``end_effectors`` (default all), its
    inertial position and orientation rates, then (``spacecraft=True``) the
    spacecraft CM position and orientation rates. ``orientation`` is
    ``"euler321"`` (3 rows, Θ of 1991 eq. 11; singular at ±90° pitch),
    ``"quaternion"`` (4 rows, [x, y, z, w]) or ``None`` (positions only).
    """
    q = joint_array(model, q)
    if orientation not in ("euler321", "quaternion", None):
        raise ValueError(f"orientation: expected 'euler321', 'quaternion' or None, got {orientation!r}")
    ees = range(model.n_end_effectors) if end_effectors is None else [model.end_effector_index(e) for e in np.atleast_1d(end_effectors)]
    t0 = np.broadcast_to(attitude_matrix(attitude), (*q.shape[:-1], 3, 3))
    rot = body_rot = None
    blocks = []
    targets = [(int(model.end_effector_body[e]), model.end_effector_point[e]) for e in ees]
    if spacecraft:
        targets.append((0, model.com[0]))
    for body, point in targets:
        jac = point_jacobian(model, q, body, point, attitude=t0)
        blocks.append(jac[..., 0:3, :])
        if orientation is None:
            continue
        if rot is None:
            body_rot = np.einsum("...ij,...bjk->...bik", t0, _rotations_batched(model, q))
        rot = body_rot[..., body, :, :]  # type: ignore[index]
        if orientation == "euler321":
            rate = euler321_rate_matrix(euler321_from_matrix(rot))
            blocks.append(np.linalg.solve(rate, jac[..., 3:6, :]))
        else:
            from scipy.spatial.transform import Rotation

            quat = Rotation.from_matrix(rot.reshape(-1, 3, 3)).as_quat().reshape((*rot.shape[:-2], 4))
            blocks.append(quaternion_rate_matrix(quat) @ jac[..., 3:6, :])
    return np.concatenate(blocks, axis=-2)


def _rotations_batched(model: Model, q: np.ndarray) -> np.ndarray:
    return chunked(lambda qq: _rotations(model, qq), q, core_ndims=(1,))


# ------------------------------------------------------------------ compiled J*, det J*, manipulability
#
# J* is traced once per model as straight-line scalar code (see freeflyer.mechanics._batch.Tape and the
# trace of the momentum quantities in freeflyer.mechanics.momentum._trace) and run on chunks of
# configurations with the batch axis last. With X = D^-1 D_q (so omega0 = -X qdot, 1992 eq. 12 at
# zero momentum), column l of J* for an end effector at rho_E (relative to the system CM) is
#     v = u_l x ([l inboard of E] (rho_E - pi_l) - (F_l - S_l pi_l) / M) + rho_E x X_l
#     w = [l inboard of E] u_l - X_l
# (u_l the joint axis, pi_l the joint position, F_l and S_l the first moment and mass of its
# subtree; the second term is the motion of the spacecraft that keeps the CM in place).


def _trace_jstar(model: Model, eager_offsets: bool = False) -> tuple[Tape, list[list[Sym]]]:
    """J* (6E x N) as traced scalars."""
    t = _trace(model, eager_offsets)
    d = t.d
    # X = D^-1 D_q with the adjugate of the symmetric D; block-wise when D_xz = D_yz = 0 exactly (planar
    # systems), so that for those the xx, yy, xy inertia sums are dead code and disappear from the program
    if _is_zero(d[0][2]) and _is_zero(d[1][2]):
        inv_xy = 1.0 / (d[0][0] * d[1][1] - d[0][1] * d[0][1])
        inv_z = 1.0 / d[2][2]
        x = [[(d[1][1] * h[0] - d[0][1] * h[1]) * inv_xy, (d[0][0] * h[1] - d[0][1] * h[0]) * inv_xy, h[2] * inv_z] for h in t.d_q]
    else:
        a00 = d[1][1] * d[2][2] - d[1][2] * d[1][2]
        a01 = d[0][2] * d[1][2] - d[0][1] * d[2][2]
        a02 = d[0][1] * d[1][2] - d[0][2] * d[1][1]
        a11 = d[0][0] * d[2][2] - d[0][2] * d[0][2]
        a12 = d[0][1] * d[0][2] - d[0][0] * d[1][2]
        a22 = d[0][0] * d[1][1] - d[0][1] * d[0][1]
        adj = [[a00, a01, a02], [a01, a11, a12], [a02, a12, a22]]
        inv_det = 1.0 / (d[0][0] * a00 + d[0][1] * a01 + d[0][2] * a02)
        x = [[xi * inv_det for xi in _matvec(adj, col)] for col in t.d_q]
    total = model.total_mass
    rows: list[list[Sym]] = []
    zero = t.tape.const(0.0)
    # drift_l = -(F_l - S_l pi_l) / M; with several end effectors, v = w x rho_E + k_l shares
    # k_l = u_l x ([inboard] (-pi_l) + drift_l) between them (w = [inboard] u_l - X_l, the w row)
    drift = [_scale(_sub(t.first[l], _scale(t.pi[l], t.subtree_mass[l + 1])), -1.0 / total) for l in range(model.n_joints)]
    shared = model.n_end_effectors > 1
    for e in range(model.n_end_effectors):
        body = int(model.end_effector_body[e])
        rho_e = t.rho_e[e]
        cols_v, cols_w = [], []
        for l in range(model.n_joints):
            u, pi = t.u[l], t.pi[l]
            inboard = bool(model.subtree[l + 1, body])
            w_row = _sub(u, x[l]) if inboard else [zero - xi for xi in x[l]]
            if shared:
                cols_v.append(_add(_cross(w_row, rho_e), _cross(u, _sub(drift[l], pi) if inboard else drift[l])))
            else:
                w = _add(_sub(rho_e, pi), drift[l]) if inboard else drift[l]
                cols_v.append(_add(_cross(u, w), _cross(rho_e, x[l])))
            cols_w.append(w_row)
        rows += [[cols_v[l][i] for l in range(model.n_joints)] for i in range(3)]
        rows += [[cols_w[l][i] for l in range(model.n_joints)] for i in range(3)]
    return t.tape, rows


def _is_zero(x: Sym) -> bool:
    return x.reg is None and x.off == 0.0


def _det_minors(m: list[list[Sym]], zero: Sym) -> Sym:
    """Determinant by expansion along rows with memoized minors (no division)."""
    n = len(m)
    memo: dict[tuple[int, ...], Sym] = {}

    def minor(cols: tuple[int, ...]) -> Sym:
        r = n - len(cols)
        if len(cols) == 1:
            return m[r][cols[0]]
        if cols not in memo:
            acc = zero
            for j, col in enumerate(cols):
                term = m[r][col] * minor(cols[:j] + cols[j + 1 :])
                acc = acc - term if j % 2 else acc + term
            memo[cols] = acc
        return memo[cols]

    return minor(tuple(range(n)))


def _det_gram(m: list[list[Sym]], tape: Tape) -> Sym:
    """det of the symmetric positive semidefinite m by LDL^T; pivots <= 0 count as 0 (rank deficient)."""
    n = len(m)
    a = [row[:] for row in m]
    det = tape.const(1.0)
    for k in range(n):
        pivot = a[k][k]
        det = det * tape.positive_part(pivot)
        inv = tape.positive_reciprocal(pivot)
        for i in range(k + 1, n):
            f = a[i][k] * inv
            for j in range(i, n):
                a[i][j] = a[i][j] - f * a[k][j]
                a[j][i] = a[i][j]
    return det


def _singularity_row_indices(model: Model) -> list[int]:
    if not model.is_planar:
        return list(range(6 * model.n_end_effectors))
    return [r for e in range(model.n_end_effectors) for r in (6 * e, 6 * e + 1)]


#: Square J* up to this size get a compiled determinant (expansion by minors); larger use LAPACK.
_MAX_MINOR_DET = 6
#: Gram matrices J* J*^T (or J*^T J*) up to this size get a compiled manipulability (LDL^T); larger use LAPACK.
_MAX_GRAM = 12


def _build(model: Model, which: str, eager_offsets: bool) -> Program | None:
    tape, rows = _trace_jstar(model, eager_offsets)
    if which == "jstar":
        return Program(tape, [x for row in rows for x in row], "jstar")
    rows = [rows[r] for r in _singularity_row_indices(model)]
    n_rows, n_cols = len(rows), model.n_joints
    zero = tape.const(0.0)
    if which == "det":
        if n_rows != n_cols or n_cols > _MAX_MINOR_DET:
            return None
        return Program(tape, [_det_minors(rows, zero)], "det")
    if n_rows <= n_cols:
        gram = [[sum((rows[i][k] * rows[j][k] for k in range(n_cols)), zero) for j in range(n_rows)] for i in range(n_rows)]
    else:
        gram = [[sum((rows[k][i] * rows[k][j] for k in range(n_rows)), zero) for j in range(n_cols)] for i in range(n_cols)]
    return Program(tape, [tape.sqrt(_det_gram(gram, tape))], "manipulability")


def _gj_barycentric(model: Model, qq: np.ndarray) -> np.ndarray:
    """J* (C, 6E, N) from the barycentric sums and a 3x3 solve: the reference for the compiled kernel."""
    rot = _rotations(model, qq)
    d, d_q, _ = _blocks(model, rot, need_qq=False)
    x = np.linalg.solve(d, d_q)  # omega0 = -x qdot   (1992 eq. 12 with zero momentum)
    rho, j12, j22 = _point_terms(model, rot, model.bary.end_effector_table, model.end_effector_body)
    n_e = rho.shape[1]
    out = np.empty((qq.shape[0], n_e, 6, model.n_joints))
    # v = J12 qdot + J11 omega0 = J12 qdot - rho x omega0 = (J12 + rho x X) qdot
    out[:, :, 0:3, :] = j12 + np.cross(rho[:, :, :, None], x[:, None, :, :], axis=2)
    out[:, :, 3:6, :] = j22 - x[:, None]
    return out.reshape(qq.shape[0], 6 * n_e, model.n_joints)


def _gj_kernel(model: Model, qq: np.ndarray) -> np.ndarray:
    """Kernel: J* (C, 6E, N) for flat q (C, N); compiled from COMPILE_MIN configurations (then a batch-last view)."""
    if qq.shape[0] < COMPILE_MIN:
        return _gj_barycentric(model, qq)
    return _compiled_map(model, "jstar", qq, (6 * model.n_end_effectors, model.n_joints))


def _compiled_map(model: Model, which: str, q: np.ndarray, core: tuple[int, ...]) -> np.ndarray:
    """Run a compiled program over q (..., N): (..., *core), a view with the batch axis last in memory."""
    program = compiled(model, which, lambda eager: _build(model, which, eager))
    assert program is not None
    batch = q.shape[:-1]
    flat = q.reshape(int(np.prod(batch, dtype=int)), model.n_joints)
    if flat.shape[0] >= _numba_programs.NUMBA_MIN and _numba_programs.enabled():
        fast = _numba_programs.program(model, which, program)(flat)
        if fast is not None:
            return fast.reshape(batch + core)
    return map_angles(program, flat).T.reshape(batch + core)


def _compile_batch(q: np.ndarray) -> bool:
    """True when q (..., N) is a batch large enough for the compiled kernels."""
    return int(np.prod(q.shape[:-1], dtype=int)) >= COMPILE_MIN


def generalized_jacobian(model: Model, q: Any) -> np.ndarray:
    """The generalized Jacobian ⁰J* of 1992 eq. 14, (..., 6E, N), spacecraft frame.

    Rows [v; w] for each end effector in ``model.end_effector_names`` order:
    end-effector velocities V_E = diag(T0, ..., T0) ⁰J* qdot of a free-floating
    system with zero linear and angular momentum. For nonzero momentum add
    :func:`generalized_jacobian_drift`.
    """
    q = joint_array(model, q)
    if _compile_batch(q):
        return _compiled_map(model, "jstar", q, (6 * model.n_end_effectors, model.n_joints))
    return chunked(lambda qq: _gj_barycentric(model, qq), q, core_ndims=(1,))


def generalized_jacobian_drift(
    model: Model, q: Any, angular_momentum: Any, linear_momentum: Any = None, *, attitude: Any = None
) -> np.ndarray:
    """End-effector velocity (..., 6E) at qdot = 0 due to nonzero system momentum.

    With angular momentum h (about the system CM) and linear momentum p, both
    inertial, V_E = diag(T0) ⁰J* qdot + drift, where per end effector
    drift = [p/M + T0 (w_d x rho_E); T0 w_d] and w_d = D^-1 T0^T h (1992 eq. 12).
    """
    q = joint_array(model, q)
    t0 = attitude_matrix(attitude)
    h = np.asarray(angular_momentum, dtype=float)
    if h.shape[-1:] != (3,):
        raise ShapeError(f"angular_momentum: expected shape (..., 3), got {h.shape}")
    h0 = np.einsum("...ji,...j->...i", t0, h)

    def kernel(qq: np.ndarray, hh: np.ndarray) -> np.ndarray:
        rot = _rotations(model, qq)
        d, _, _ = _blocks(model, rot, need_qq=False)
        wd = np.linalg.solve(d, hh[..., None])[..., 0]
        rho, _, _ = _point_terms(model, rot, model.bary.end_effector_table, model.end_effector_body)
        return np.concatenate([np.cross(wd[:, None, :], rho), np.broadcast_to(wd[:, None, :], rho.shape)], axis=-1)

    drift0 = chunked(kernel, q, h0, core_ndims=(1, 1))  # (..., E, 6)
    drift = np.concatenate(
        [np.einsum("...ij,...ej->...ei", t0, drift0[..., 0:3]), np.einsum("...ij,...ej->...ei", t0, drift0[..., 3:6])], axis=-1
    )
    if linear_momentum is not None:
        p = np.asarray(linear_momentum, dtype=float)
        if p.shape[-1:] != (3,):
            raise ShapeError(f"linear_momentum: expected shape (..., 3), got {p.shape}")
        drift = drift + np.concatenate([p / model.total_mass, np.zeros_like(p)], axis=-1)[..., None, :]
    return drift.reshape((*drift.shape[:-2], -1))


def jacobian_determinant(model: Model, q: Any) -> np.ndarray:
    """det ⁰J*(q) (1992 eq. 17), (...). Zero at dynamic singularities.

    For a planar model J* is taken in the plane: the rows [v_x, v_y] of every
    end effector (2E x N, as in the 1992 paper's examples); otherwise all 6E
    rows. That matrix must be square; for redundant systems use
    :func:`manipulability`.
    """
    q = joint_array(model, q)
    n_rows = len(_singularity_row_indices(model))
    if n_rows != model.n_joints:
        raise ShapeError(
            f"J* has shape {(n_rows, model.n_joints)} here, not square, so it has no determinant; "
            "use ff.manipulability(model, q) (sqrt det J* J*^T) or the smallest singular value"
        )
    if _compile_batch(q) and model.n_joints <= _MAX_MINOR_DET:
        return _compiled_map(model, "det", q, ())
    return np.linalg.det(_singularity_rows(model, generalized_jacobian(model, q)))


def manipulability(model: Model, q: Any) -> np.ndarray:
    """sqrt(det(J* J*^T)) with J* in the plane for planar models (see :func:`jacobian_determinant`), (...)."""
    q = joint_array(model, q)
    if _compile_batch(q) and min(len(_singularity_row_indices(model)), model.n_joints) <= _MAX_GRAM:
        return _compiled_map(model, "manipulability", q, ())
    jac = _singularity_rows(model, generalized_jacobian(model, q))
    if jac.shape[-2] > jac.shape[-1]:
        return np.sqrt(np.abs(np.linalg.det(np.swapaxes(jac, -1, -2) @ jac)))
    return np.sqrt(np.abs(np.linalg.det(jac @ np.swapaxes(jac, -1, -2))))


def _singularity_rows(model: Model, jac: np.ndarray) -> np.ndarray:
    if not model.is_planar:
        return jac
    rows = np.concatenate([[6 * e, 6 * e + 1] for e in range(model.n_end_effectors)])
    return jac[..., rows, :]
