"""Jacobians: point J+ (1991 eqs. 7-10), J_q (eq. 21), J_z (eqs. 22-23), J* (1992 eq. 14).

All are batched over q (..., N). Velocities follow the conventions:
zdot0 = [rdot_cm (inertial), omega0 (spacecraft frame), qdot]. With the
attitude at identity (``attitude=None``) the inertial and spacecraft frames
coincide and every matrix is the paper's spacecraft-frame ⁰J.

Two algorithms check each other. ``method="recursive"`` (the default, every
batch size) is the engine (:mod:`._configuration`): with p_l the joint positions,
g_l the linear momentum of the subtree of joint l turning at unit rate and M the
total mass, J12[:, l] = [l inboard of P] u_l x (r_P - p_l) - g_l / M. The
``method="barycentric"`` reference builds it from barycentric vectors: with s_l
= sum over the bodies i outboard of joint l of T_i v_iP,

    J11 = -[rho_P]x,    J12[:, l] = u_l x s_l,    J22[:, l] = u_l if P is outboard of joint l

which is 1991 eq. 10b evaluated joint by joint (u_l: joint axis, spacecraft frame).
J* (1992 eq. 14) likewise: the engine's recursion, or J+ and the inertia blocks of
the barycentric sums with omega0 = -D^-1 D_q qdot (1992 eq. 12, zero momentum).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import engine
from ..core.conventions import attitude_matrix, euler321_from_matrix, euler321_rate_matrix, quaternion_rate_matrix, skew
from ..core.errors import ShapeError
from ..core.model import Model
from ..core.numbers import finite_vector, joint_array
from ._batches import chunked, pieces
from ._inputs import body_joints, check_method, check_out_inputs, gather_columns
from .kinematics import _rotations, _slides, body_rotations
from .momentum import _hplus_barycentric, zero_momentum_rate

__all__ = [
    "actuation_jacobian",
    "end_effector_jacobian",
    "generalized_jacobian",
    "generalized_jacobian_drift",
    "jacobian_determinant",
    "jacobian_measure",
    "manipulability",
    "point_jacobian",
    "task_jacobian",
]


def _method(method: str) -> str:
    return check_method(method, "1991 eq. 10, 1992 eq. 14")


def _point_terms(
    model: Model, rot: np.ndarray, tables: np.ndarray, bodies: np.ndarray, q: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Kernel: rho (C, P, 3), J12 (C, P, 3, N), J22 (C, P, 3, N) for P points (spacecraft frame).

    Revolute column l: J12 = u_l x s_l (s_l the barycentric sum over the subtree of joint l),
    J22 = [P outboard of l] u_l. Prismatic column l (docs/theory.md): J12 = (chi_l(P) - mu*_l) u_l,
    J22 = 0, and the sliding offsets enter rho and s; ``q`` is needed then.
    """
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
    outboard = sub[1:, bodies].T  # (P, N): 1 if the point's body is outboard of joint l
    sliding = model.prismatic
    if sliding.any():
        if q is None:
            raise TypeError("_point_terms: q is needed for a model with prismatic joints")
        # offsets of the prismatic joints j whose parent body is in the subtree of l: (C, P, B, 3)
        within = sub[:, model.parent[1:]]  # (B, N): [l, j] = parent of joint j in the subtree of body l
        coef = model.bary.slide_coefficient[:, bodies]  # (N, P)
        s = s + np.einsum("cjx,jp,lj->cplx", _slides(model, rot, q), coef, within)
    rho = s[:, :, 0]
    j12 = np.cross(axes[:, None, :, :], s[:, :, 1:, :], axis=-1)  # (C, P, N, 3)
    j22 = axes[:, None, :, :] * outboard[None, :, :, None]
    if sliding.any():
        j12[:, :, sliding] = axes[:, None, sliding, :] * model.bary.slide_coefficient[sliding][:, bodies].T[None, :, :, None]
        j22[:, :, sliding] = 0.0
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


def point_jacobian(
    model: Model, q: Any, body: str | int, point: Any = None, *, attitude: Any = None, method: str = "recursive"
) -> np.ndarray:
    """J+_{k,m} of 1991 eqs. 7-10 for a point of a body, (..., 6, 6+N).

    Maps zdot0 to [velocity of the point; angular velocity of the body], both in
    the inertial frame (spacecraft frame when ``attitude`` is None). ``point``
    is in the body frame; default the body's CM (m = CM). ``method``: see the
    module docstring.
    """
    q = joint_array(model, q)
    k = model.body_index(body)
    p = model.com[k] if point is None else finite_vector(point, 3, "point", "a point in the body frame, m")
    if _method(method) == "recursive":
        out = engine.point_jacobians(model, q, k, p)[..., 0, :, :]
        return out if attitude is None else _rotate_rows(out, attitude)
    table = model.bary.point_vectors(model, k, p)[None]
    bodies = np.array([k])

    def kernel(qq: np.ndarray) -> np.ndarray:
        body_model, qb = body_joints(model, qq)  # mimic joints: computed as joints, gathered into their leaders' columns
        rho, j12, j22 = _point_terms(body_model, _rotations(body_model, qb), table, bodies, qb)
        return gather_columns(model, _assemble(rho[:, 0], j12[:, 0], j22[:, 0], None), 6)

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
            body_rot = np.einsum("...ij,...bjk->...bik", t0, body_rotations(model, q))
        rot = body_rot[..., body, :, :]  # type: ignore[index]
        if orientation == "euler321":
            rate = euler321_rate_matrix(euler321_from_matrix(rot))
            blocks.append(np.linalg.solve(rate, jac[..., 3:6, :]))
        else:
            from scipy.spatial.transform import Rotation

            quat = Rotation.from_matrix(rot.reshape(-1, 3, 3)).as_quat().reshape((*rot.shape[:-2], 4))
            blocks.append(quaternion_rate_matrix(quat) @ jac[..., 3:6, :])
    return np.concatenate(blocks, axis=-2)


# ------------------------------------------------------------------ J*, det J*, manipulability
def _gj_barycentric(model: Model, qq: np.ndarray) -> np.ndarray:
    """Kernel: J* (C, 6E, N) from the barycentric J+ terms and inertia blocks (1992 eqs. 12-14), the reference."""
    if model.has_mimic:  # J* = J*_body M: computed with the mimic joints as joints, gathered into their leaders' columns
        return gather_columns(model, _gj_barycentric(*body_joints(model, qq)))
    rot = _rotations(model, qq)
    h = _hplus_barycentric(model, qq)
    x = -zero_momentum_rate(h)  # omega0 = -x qdot   (1992 eq. 12 with zero momentum)
    rho, j12, j22 = _point_terms(model, rot, model.bary.end_effector_table, model.end_effector_body, qq)
    n_e = rho.shape[1]
    out = np.empty((qq.shape[0], n_e, 6, model.n_joints))
    # v = J12 qdot + J11 omega0 = J12 qdot - rho x omega0 = (J12 + rho x X) qdot
    out[:, :, 0:3, :] = j12 + np.cross(rho[:, :, :, None], x[:, None, :, :], axis=2)
    out[:, :, 3:6, :] = j22 - x[:, None]
    return out.reshape(qq.shape[0], 6 * n_e, model.n_joints)


def generalized_jacobian(model: Model, q: Any, *, method: str = "recursive", out: np.ndarray | None = None) -> np.ndarray:
    """The generalized Jacobian ⁰J* of 1992 eq. 14, (..., 6E, N), spacecraft frame.

    Rows [v; w] for each end effector in ``model.end_effector_names`` order:
    end-effector velocities V_E = diag(T0, ..., T0) ⁰J* qdot of a free-floating
    system with zero linear and angular momentum. For nonzero momentum add
    :func:`generalized_jacobian_drift`. ``method``: see the module docstring.

    ``out``: an array of the result's shape (..., 6E, N), float64, C-contiguous and writable, sharing no memory with
    ``q``: J* is written into it and it is returned (``method="recursive"`` only), so that a loop of calls of one size
    reuses one array instead of a new one per call.
    """
    method = _method(method)
    check_out_inputs(out, method, q=q)
    q = joint_array(model, q)
    if method == "recursive":
        return engine.generalized_jacobian(model, q, out)
    return chunked(pieces(lambda qq: _gj_barycentric(model, qq), model.n_bodies), q, core_ndims=(1,))


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
    h = finite_vector(angular_momentum, 3, "angular_momentum", "N m s, inertial frame")
    h0 = np.einsum("...ji,...j->...i", t0, h)
    h_plus = engine.inertia_matrix(model, q)
    wd = zero_momentum_rate(h_plus, np.zeros((*h_plus.shape[:-2], model.n_joints)), h0)  # at qdot = 0
    rho = engine.points(model, q, model.end_effector_body, model.end_effector_point)  # (..., E, 3)
    wd_e = np.broadcast_to(wd[..., None, :], np.broadcast_shapes(wd[..., None, :].shape, rho.shape))
    drift0 = np.concatenate([np.cross(wd_e, rho), wd_e], axis=-1)  # (..., E, 6)
    drift = np.concatenate(
        [np.einsum("...ij,...ej->...ei", t0, drift0[..., 0:3]), np.einsum("...ij,...ej->...ei", t0, drift0[..., 3:6])], axis=-1
    )
    if linear_momentum is not None:
        p = finite_vector(linear_momentum, 3, "linear_momentum", "N s, inertial frame")
        drift = drift + np.concatenate([p / model.total_mass, np.zeros_like(p)], axis=-1)[..., None, :]
    return drift.reshape((*drift.shape[:-2], -1))


def _singularity_row_indices(model: Model) -> list[int]:
    if not model.is_planar:
        return list(range(6 * model.n_end_effectors))
    return [r for e in range(model.n_end_effectors) for r in (6 * e, 6 * e + 1)]


def _singularity_rows(model: Model, jac: np.ndarray) -> np.ndarray:
    if not model.is_planar:
        return jac
    return jac[..., _singularity_row_indices(model), :]


def jacobian_determinant(model: Model, q: Any, *, out: np.ndarray | None = None) -> np.ndarray:
    """det ⁰J*(q) (1992 eq. 17), (...). Zero at dynamic singularities.

    For a planar model J* is taken in the plane: the rows [v_x, v_y] of every
    end effector (2E x N, as in the 1992 paper's examples); otherwise all 6E
    rows. That matrix must be square; for redundant systems use
    :func:`manipulability`. ``out``: an array (...) that receives the
    determinants and is returned, as in :func:`generalized_jacobian`.
    """
    check_out_inputs(out, "recursive", q=q)
    q = joint_array(model, q)
    n_rows = len(_singularity_row_indices(model))
    if n_rows != model.n_joints:
        raise ShapeError(
            f"J* has shape {(n_rows, model.n_joints)} here, not square, so it has no determinant; "
            "use ff.manipulability(model, q) (sqrt det J* J*^T) or the smallest singular value"
        )
    return engine.jacobian_measures(model, q, _singularity_row_indices(model), "det", out)


def manipulability(model: Model, q: Any, *, out: np.ndarray | None = None) -> np.ndarray:
    """sqrt(det(J* J*^T)) with J* in the plane for planar models (see :func:`jacobian_determinant`), (...): the product
    of the singular values of those rows. ``out``: an array (...) that receives them and is returned, as in
    :func:`generalized_jacobian`."""
    check_out_inputs(out, "recursive", q=q)
    q = joint_array(model, q)
    return engine.jacobian_measures(model, q, _singularity_row_indices(model), "manipulability", out)


#: The measures of :func:`jacobian_measure`.
JACOBIAN_MEASURES = ("det", "sigma_min", "manipulability", "condition", "sigma_max")


def jacobian_measure(model: Model, q: Any, rows: Any = None, measure: str = "sigma_min", *, out: np.ndarray | None = None) -> np.ndarray:
    """A measure of the rows ``rows`` of ⁰J* (1992 eq. 14) at each configuration, (...).

    ``rows``: distinct indices into the 6E rows of J* ([v; ω] per end effector); None: the rows of
    :func:`jacobian_determinant` (the plane's for a planar model, else all). ``measure``: ``"det"`` (square rows
    only, signed), ``"sigma_min"`` (the smallest singular value), ``"manipulability"`` (the product of the singular
    values, sqrt(det(J Jᵀ))), ``"condition"`` (σ_max / σ_min, inf at a singularity), ``"sigma_max"`` (the largest
    singular value). Computed per configuration inside the engine's kernel (LU with partial pivoting for det; for the
    others a Householder QR, then the largest eigenvalues of R⁻¹R⁻ᵀ and R Rᵀ: as accurate as numpy's det and SVD, σ_min
    within a few ulps of σ_max near a singularity), 64 configurations at a time (SIMD across them): no batch of J* is
    written, so a map of millions of configurations needs memory for the measures only. Batches of 64 or more run on
    the kernels specialised to the model's structure when made (kind ``"measure"`` of
    :func:`~freefloat.mechanics.specialise`; automatic after a few seconds of this work). ``out``: an array (...)
    that receives the measures and is returned, as in :func:`generalized_jacobian`.
    """
    check_out_inputs(out, "recursive", q=q)
    if measure not in JACOBIAN_MEASURES:
        raise ValueError(f"measure: expected one of {', '.join(JACOBIAN_MEASURES)}, got {measure!r}")
    q = joint_array(model, q)
    idx = np.asarray(_singularity_row_indices(model) if rows is None else rows)
    if (
        idx.ndim != 1
        or idx.size == 0
        or not np.issubdtype(idx.dtype, np.integer)
        or idx.min() < 0
        or idx.max() >= 6 * model.n_end_effectors
        or np.unique(idx).size != idx.size
    ):
        raise ValueError(f"rows: expected distinct indices of rows of J* (0 .. {6 * model.n_end_effectors - 1}), got {rows!r}")
    if measure == "det" and idx.size != model.n_joints:
        raise ShapeError(f"measure='det': the chosen rows form a {idx.size} x {model.n_joints} matrix, not square; use 'sigma_min'")
    return engine.jacobian_measures(model, q, idx, measure, out)
