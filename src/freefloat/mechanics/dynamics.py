"""Equations of motion of a space robot: 1991 eqs. 18-21, forward and inverse dynamics.

    H+(q) zddot0 + C+(q, omega0, qdot) = Q                          (1991 eq. 19)

in the coordinates zdot0 = [rdot_cm (inertial), omega0 (spacecraft frame), qdot]
(1991 eq. 8). H+ is :func:`freefloat.system_inertia_matrix` (eq. 15); this
module adds C+ and the dynamics calls.

Derivation of C+ (the paper gives eq. 19 "without proof"; docs/dynamics.md has
it in full). The configuration is (r_cm, T0, q) and the Lagrangian is the
kinetic energy (no gravity, rigid bodies):

    L = 1/2 M |rdot_cm|^2 + 1/2 y^T A(q) y,   y = [omega0; qdot],   A = [[D, D_q], [D_q^T, D_qq]]

omega0 is a quasi-velocity (no coordinate has it as derivative), so
Lagrange's equations hold for r_cm and q only; for the attitude the
Boltzmann-Hamel (here: Euler-Poincare) equation of a body-frame angular
velocity holds. A does not depend on T0 and omega0 does not depend on q, so
all Hamel coefficients vanish except those of SO(3) itself:

    M rddot_cm                              = Q_r      (inertial frame)
    d/dt (dL/d omega0) + omega0 x dL/d omega0 = Q_w      (spacecraft frame)
    d/dt (dL/d qdot) - dL/dq                = Q_q

with dL/d omega0 = h = D omega0 + D_q qdot, the angular momentum about the
system CM in the spacecraft frame (1992 eq. 12). Hence

    C+ = Adot y - 1/2 d/dq (y^T A y) + [omega0 x h; 0],   C+_r = 0,

Adot = sum_l dA/dq_l qdot_l, the time derivatives of D, D_q, D_qq
(:func:`system_inertia_matrix_rate`). Writing A = sum_ij G_i^T D_ij G_j with
omega_i = G_i y (1991 eq. 5) and the barycentric pair inertias
D_ij = M [a_ij]x [b_ij]x (i != j), a_ij = T_i v_(i->j), b_ij = T_j v_(j->i)
(1991 eq. 17), the three terms collapse body by body into

    C+ = sum_i G_i^T psi_i,   psi_i = D_ii alpha_i + omega_i x D_ii omega_i - M sum_(j != i) a_ij x bddot_ij

alpha_i = the angular acceleration of body i at zddot0 = 0 (spacecraft
frame), bddot_ij = alpha_j x b_ij + omega_j x (omega_j x b_ij) the
acceleration of the barycentric vector b_ij. psi_i is Euler's equation of the
barycentric body i (augmented inertia D_ii) plus the coupling through the
barycentric vectors; this is the ``method="barycentric"`` closed form. The
``method="recursive"`` route is an O(N) Newton-Euler recursion on the tree
(the engine, :mod:`freefloat.engine.recursions`), the default.

Generalized forces Q (1991 eqs. 18 and 21) and their inversion into thruster
and joint actuation live in :mod:`freefloat.mechanics.forces`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg

from .. import engine
from ..core.errors import ShapeError, SingularConfigurationError
from ..core.model import Model
from ..engine import FRICTION_SPEED
from ._batches import chunked, pieces
from ._inputs import (
    _attitude,
    _joints,
    _rotate,
    _vector,
    _velocity,
    body_joints,
    body_velocity,
    check_method,
    check_out_inputs,
    gather_columns,
    gather_square,
    revolute_only,
)
from .forces import _actuation_0, _actuation_parts, _engine_wrenches, _generalized_forces_0, _wrenches
from .jacobians import actuation_jacobian
from .kinematics import _rotations, _slides
from .momentum import system_inertia_matrix
from .springs import spring_torque

__all__ = [
    "dissipative_torque",
    "forward_dynamics",
    "inverse_dynamics",
    "nonlinear_forces",
    "passive_torque",
    "point_bias_acceleration",
    "spacecraft_fixed_dynamics",
    "system_inertia_matrix_rate",
]


def _method(method: str) -> str:
    return check_method(method, "the closed form of 1991 eq. 19")


# ----------------------------------------------------------------- tree motion (spacecraft frame)
@dataclass(frozen=True)
class _Motion:
    """Angular motion of every body at one state, spacecraft-frame components, flat batch C.

    axis (C, B, 3): joint axis of body k (row 0 zero); omega (C, B, 3): absolute
    angular velocity omega_k = omega0 + F_k qdot (1991 eq. 5); omega_rel: F_k qdot;
    alpha: absolute angular acceleration of body k at zddot0 = 0 (the bias),
    inertial derivative, spacecraft-frame components; kappa: the same relative
    to the spacecraft, sum of (F_j qdot) x (u_j qdot) over the joints j above k.
    """

    rot: np.ndarray
    axis: np.ndarray
    omega: np.ndarray
    omega_rel: np.ndarray
    alpha: np.ndarray
    kappa: np.ndarray


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b over the last axis (length 3), broadcasting."""
    return np.stack(
        [
            a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
            a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
            a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0],
        ],
        axis=-1,
    )


def _motion(model: Model, q: np.ndarray, omega0: np.ndarray, qdot: np.ndarray) -> _Motion:
    rot = _rotations(model, q)
    batch, n = q.shape[0], model.n_bodies
    axis = np.zeros((batch, n, 3))  # turning axes: zero for prismatic joints, which turn nothing
    axis[:, 1:] = np.einsum("ckij,kj->cki", rot[:, 1:], model.joint_axis[1:] * ~model.prismatic[:, None])
    rate = axis.copy()
    rate[:, 1:] *= qdot[:, :, None]  # u_k qdot_k
    sub = model.subtree.astype(float)  # sub[l, i]: body i is outboard of (or is) body l
    omega_rel = np.einsum("li,clx->cix", sub, rate)
    # d/dt (u_l qdot_l) at qddot = 0 is (F_l qdot) x (u_l qdot_l) in the spacecraft frame
    kappa = np.einsum("li,clx->cix", sub, _cross(omega_rel, rate))
    alpha = kappa + _cross(omega0[:, None, :], omega_rel)
    return _Motion(rot, axis, omega0[:, None, :] + omega_rel, omega_rel, alpha, kappa)


def _tree_transpose(model: Model, axis: np.ndarray, psi: np.ndarray) -> np.ndarray:
    """sum_i G_i^T psi_i, (C, 3 + N): [sum_i psi_i; u_l . sum_(i outboard of l) psi_i] (G_i = [1, F_i])."""
    sub = model.subtree[1:].astype(float)
    out = np.empty((*psi.shape[:1], 3 + model.n_joints))
    out[:, 0:3] = psi.sum(axis=1)
    out[:, 3:] = np.einsum("clx,clx->cl", axis[:, 1:], np.einsum("li,cix->clx", sub, psi))
    return out


def _pair_vectors(model: Model, rot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """a_ij = T_i v_(i->j) and b_ij = T_j v_(j->i), (C, B, B, 3), zero on the diagonal (spacecraft frame)."""
    w = np.einsum("cbij,kbj->ckbi", rot, model.bary.point_table)  # w[c, k, i] = T_i v_ik
    idx = np.arange(model.n_bodies)
    w[:, idx, idx] = 0.0
    return np.swapaxes(w, 1, 2), w


def _diagonal_inertias(model: Model, rot: np.ndarray) -> np.ndarray:
    """D_ii = T_i (I_i + sum_k m_k (|v_ik|^2 1 - v_ik v_ik^T)) T_i^T, (C, B, 3, 3), 1991 eq. 17."""
    return np.einsum("cbij,bjk,cblk->cbil", rot, model.bary.diagonal_inertia, rot)


# ----------------------------------------------------------------- C+ (barycentric closed form)
def _c_plus_barycentric(model: Model, q: np.ndarray, velocity: np.ndarray) -> np.ndarray:
    """Kernel: C+ (C, 6 + N) for flat q (C, N), velocity (C, 6 + N)."""
    if model.has_mimic:  # C+ = T^T C+_body at the body joints' values and rates
        body_model, qb = body_joints(model, q)
        return gather_columns(model, _c_plus_barycentric(body_model, qb, body_velocity(model, velocity)), 6)
    mo = _motion(model, q, velocity[:, 3:6], velocity[:, 6:])
    a, b = _pair_vectors(model, mo.rot)
    d_ii = _diagonal_inertias(model, mo.rot)
    w_j, alpha_j = mo.omega[:, None, :, :], mo.alpha[:, None, :, :]
    b_acc = _cross(alpha_j, b) + _cross(w_j, _cross(w_j, b))  # bddot_ij
    psi = (
        np.einsum("cbij,cbj->cbi", d_ii, mo.alpha)
        + _cross(mo.omega, np.einsum("cbij,cbj->cbi", d_ii, mo.omega))
        - model.total_mass * _cross(a, b_acc).sum(axis=2)
    )
    out = np.zeros((q.shape[0], 6 + model.n_joints))
    out[:, 3:] = _tree_transpose(model, mo.axis, psi)
    return out


def nonlinear_forces(model: Model, q: Any, velocity: Any, *, method: str = "recursive", out: np.ndarray | None = None) -> np.ndarray:
    """C+ of 1991 eq. 19, (..., 6 + N): H+ zddot0 + C+ = Q.

    ``velocity`` is zdot0 = [rdot_cm (inertial), omega0 (spacecraft frame),
    qdot]. The rows are [0 (the CM moves as a particle: M rddot_cm = total
    force), spacecraft-frame omega0 row, joint rows]; C+ does not depend on
    the attitude or on rdot_cm. ``method="recursive"`` (default) is the
    engine's O(N) Newton-Euler recursion (:mod:`._recursions`);
    ``method="barycentric"`` is the closed form of the module docstring
    (quasi-Lagrangian, barycentric vectors). Both give the same numbers.

    ``out``: an array of the result's shape (..., 6 + N), float64, C-contiguous and writable, sharing no memory with
    the inputs: C+ is written into it and it is returned (``method="recursive"`` only), so that a loop of calls of
    one size reuses one array instead of a new one per call.
    """
    method = _method(method)
    check_out_inputs(out, method, q=q, velocity=velocity)
    q = _joints(model, q, "q")
    v = _velocity(model, velocity)
    if method == "recursive":  # the engine counts passive torques in Q
        return engine.residual_rows(model.without_passive(), q, v, out=out)
    revolute_only(model, "nonlinear_forces(method='barycentric') (1991 eqs. 18-21)")
    kernel = _c_plus_barycentric
    return chunked(pieces(lambda qq, vv: kernel(model, qq, vv), model.n_bodies), q, v, core_ndims=(1, 1))


# ----------------------------------------------------------------- dH+/dt
def _cross_matrix(v: np.ndarray) -> np.ndarray:
    out = np.zeros((*v.shape, 3))
    out[..., 0, 1], out[..., 0, 2], out[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    return out - np.swapaxes(out, -1, -2)


def _hplus_rate(model: Model, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
    """Kernel: dH+/dt (C, 6 + N, 6 + N) along qdot."""
    if model.has_mimic:
        body_model, qb = body_joints(model, q)
        return gather_square(model, _hplus_rate(body_model, qb, qdot @ model.mimic_matrix.T), 6)
    batch, n, nb = q.shape[0], model.n_joints, model.n_bodies
    mo = _motion(model, q, np.zeros((batch, 3)), qdot)
    a, b = _pair_vectors(model, mo.rot)
    wr_i, wr_j = mo.omega_rel[:, :, None, :], mo.omega_rel[:, None, :, :]
    ax, bx = _cross_matrix(a), _cross_matrix(b)
    pair = model.total_mass * ax @ bx  # D_ij = M [a]x [b]x
    pair_dot = model.total_mass * (_cross_matrix(_cross(wr_i, a)) @ bx + ax @ _cross_matrix(_cross(wr_j, b)))
    d_ii = _diagonal_inertias(model, mo.rot)
    wx = _cross_matrix(mo.omega_rel)
    idx = np.arange(nb)
    pair[:, idx, idx] = d_ii
    pair_dot[:, idx, idx] = wx @ d_ii - d_ii @ wx
    # G_j = [1, F_j] (C, B, 3, 3 + N) and its rate [0, Fdot_j]
    sub = model.subtree[1:].astype(float)  # (N, B): sub[l, j]
    g = np.zeros((batch, nb, 3, 3 + n))
    g[:, :, :, 0:3] = np.eye(3)
    g[:, :, :, 3:] = np.einsum("lj,clx->cjxl", sub, mo.axis[:, 1:])
    g_dot = np.zeros_like(g)
    g_dot[:, :, :, 3:] = np.einsum("lj,clx->cjxl", sub, _cross(mo.omega_rel[:, 1:], mo.axis[:, 1:]))
    x = np.einsum("cijxy,cjyk->cixk", pair, g)  # X_i = sum_j D_ij G_j
    s = np.einsum("cixk,cixl->ckl", g_dot, x)
    mid = np.einsum("cixk,cijxy,cjyl->ckl", g, pair_dot, g)
    out = np.zeros((batch, 6 + n, 6 + n))
    out[:, 3:, 3:] = s + np.swapaxes(s, 1, 2) + mid
    return out


def system_inertia_matrix_rate(model: Model, q: Any, qdot: Any, *, method: str = "recursive") -> np.ndarray:
    """dH+/dt along the joint rates ``qdot``, (..., 6 + N, 6 + N): the rates of D, D_q, D_qq.

    H+ (1991 eq. 15) depends on q only, so dH+/dt = sum_l dH+/dq_l qdot_l (spacecraft frame). Used by the
    closed form of C+ and by momentum checks: d/dt h = Ddot omega0 + D omega0dot + D_q,dot qdot + D_q qddot.
    ``method="recursive"`` (default): the engine differentiates its composite-body recursion (any joints);
    ``"barycentric"``: each pair inertia D_ij turns with its bodies (spacecraft frame), d/dt of a body-fixed
    vector v_i being (F_i qdot) x v_i (revolute joints only).
    """
    how = _method(method)
    q = _joints(model, q, "q")
    qd = _joints(model, qdot, "qdot")
    if how == "recursive":
        return engine.inertia_matrix_rate(model, q, qd)
    revolute_only(model, "system_inertia_matrix_rate(method='barycentric')")
    return chunked(pieces(lambda qq, vv: _hplus_rate(model, qq, vv), model.n_bodies), q, qd, core_ndims=(1, 1))


# ----------------------------------------------------------------- bias acceleration of a point
def _linear_bias(model: Model, mo: _Motion, q: np.ndarray, velocity: np.ndarray, tables: np.ndarray, bodies: np.ndarray) -> np.ndarray:
    """Kernel: the linear part of Jdot+ zdot0 of P points (C, P, 3), spacecraft-frame components.

    With x = T0^T (Rdot_P - rdot_cm) = sum_i omega_i x w_i + s (w_i = T_i v_iP(q); s the sliding
    of prismatic joints, docs/theory.md), the acceleration at zddot0 = 0 is T0 (omega0 x x + xdot):
    xdot = sum_i (kappa_i x w_i + omega_i x (omega_rel,i x w_i + sigma_i)) + sdot, where sigma_i is
    the sliding of the joints whose parent is body i and sdot = sum_c coef_cP omega_rel,p(c) x qdot_c u_c.
    """
    omega0 = velocity[:, 3:6]
    w = np.einsum("cbij,pbj->cpbi", mo.rot, tables)  # T_i v_iP (C, P, B, 3)
    x = _cross(mo.omega[:, None], w).sum(axis=2)
    terms = _cross(mo.kappa[:, None], w) + _cross(mo.omega[:, None], _cross(mo.omega_rel[:, None], w))
    if model.has_prismatic:
        coef = model.bary.slide_coefficient[:, bodies]  # (N, P)
        parents = model.parent[1:]
        rates = _slides(model, mo.rot, velocity[:, 6:])  # qdot_c u_c (C, N, 3)
        offsets = _slides(model, mo.rot, q)  # q_c u_c
        scatter = np.zeros((model.n_joints, model.n_bodies))
        scatter[np.arange(model.n_joints), parents] = 1.0  # joint c -> its parent body
        w = w + np.einsum("cjx,jp,jb->cpbx", offsets, coef, scatter)  # the barycentric vectors at q
        x = _cross(mo.omega[:, None], w).sum(axis=2) + np.einsum("cjx,jp->cpx", rates, coef)
        sigma = np.einsum("cjx,jp,jb->cpbx", rates, coef, scatter)
        terms = _cross(mo.kappa[:, None], w) + _cross(mo.omega[:, None], _cross(mo.omega_rel[:, None], w) + sigma)
        s_dot = np.einsum("jp,cjx->cpx", coef, _cross(mo.omega_rel[:, parents], rates))
        return _cross(omega0[:, None], x) + terms.sum(axis=2) + s_dot
    return _cross(omega0[:, None], x) + terms.sum(axis=2)


def _point_bias(model: Model, q: np.ndarray, velocity: np.ndarray, body: int, table: np.ndarray) -> np.ndarray:
    """Kernel: Jdot+ zdot0 of a point (C, 6), spacecraft-frame components."""
    if model.has_mimic:  # positions and rates of the body joints: no columns to gather
        body_model, qb = body_joints(model, q)
        return _point_bias(body_model, qb, body_velocity(model, velocity), body, table)
    mo = _motion(model, q, velocity[:, 3:6], velocity[:, 6:])
    lin = _linear_bias(model, mo, q, velocity, table[None], np.array([body]))[:, 0]
    return np.concatenate([lin, mo.alpha[:, body]], axis=1)


def point_bias_acceleration(
    model: Model, q: Any, velocity: Any, body: str | int, point: Any = None, *, attitude: Any = None, method: str = "recursive"
) -> np.ndarray:
    """Jdot+_{k,m} zdot0: acceleration of a point and angular acceleration of its body at zddot0 = 0, (..., 6).

    The time derivative of 1991 eq. 7: [Rddot_P; omegadot_k] = J+ zddot0 +
    Jdot+ zdot0. ``point`` is in the body frame (default the body CM); the
    result is inertial (spacecraft frame when ``attitude`` is None).
    ``method="recursive"`` (default): the engine's Newton-Euler forward pass
    (velocities and accelerations at the spacecraft origin with zddot0 = 0, then the
    uniform acceleration that holds the system CM still); ``"barycentric"``: with
    rho_P = sum_i T_i v_iP (eqs. 1-4) and omega_i = omega0 + F_i qdot (eq. 5),
    Rdot_P = rdot_cm + T0 sum_i omega_i x T_i v_iP, differentiated at constant zdot0.
    """
    how = _method(method)
    q = _joints(model, q, "q")
    v = _velocity(model, velocity)
    k = model.body_index(body)
    p = model.com[k] if point is None else _vector(point, 3, "point", "a point in the body frame")
    if p.shape != (3,):
        raise ShapeError(f"point: expected shape (3,), got {p.shape}")
    if how == "recursive":
        out = engine.point_biases(model, q, v, [k], p[None])[..., 0, :]
    else:
        table = model.bary.point_vectors(model, k, p)
        out = chunked(lambda qq, vv: _point_bias(model, qq, vv, k, table), q, v, core_ndims=(1, 1))
    t0 = _attitude(attitude)
    if t0 is None:
        return out
    return np.concatenate([_rotate(t0, out[..., 0:3]), _rotate(t0, out[..., 3:6])], axis=-1)


# ----------------------------------------------------------------- forward / inverse dynamics
def _cholesky_solve(matrix: np.ndarray, rhs: np.ndarray, what: str) -> np.ndarray:
    """Solve matrix x = rhs for symmetric positive definite matrices (..., n, n), broadcasting rhs (..., n)."""
    try:
        low = np.linalg.cholesky(matrix)
    except np.linalg.LinAlgError:
        det = float(np.min(np.linalg.det(matrix)))
        raise SingularConfigurationError(what, det, "the mass properties are not physical") from None
    batch = np.broadcast_shapes(low.shape[:-2], rhs.shape[:-1])
    if not batch:  # one system: LAPACK's triangular solves
        return scipy.linalg.cho_solve((low, True), rhs)
    low = np.broadcast_to(low, batch + low.shape[-2:])
    y = np.array(np.broadcast_to(rhs, batch + rhs.shape[-1:]), dtype=float)
    n = y.shape[-1]
    for i in range(n):  # L y = rhs
        y[..., i] = (y[..., i] - np.einsum("...j,...j->...", low[..., i, :i], y[..., :i])) / low[..., i, i]
    for i in reversed(range(n)):  # L^T x = y
        y[..., i] = (y[..., i] - np.einsum("...j,...j->...", low[..., i + 1 :, i], y[..., i + 1 :])) / low[..., i, i]
    return y


def forward_dynamics(
    model: Model,
    q: Any,
    velocity: Any,
    joint_torque: Any = None,
    spacecraft_force: Any = None,
    spacecraft_torque: Any = None,
    attitude: Any = None,
    *,
    external: Any = (),
    method: str = "recursive",
    out: np.ndarray | None = None,
) -> np.ndarray:
    """zddot0 = [rddot_cm (inertial), d/dt omega0 (spacecraft frame), qddot], (..., 6 + N).

    Solves 1991 eq. 19, H+ zddot0 = Q - C+. Free-flying: thruster
    ``spacecraft_force`` / ``spacecraft_torque`` (spacecraft frame, at the
    spacecraft CM); free-floating: leave them None (zero). ``external``: extra
    :class:`ExternalWrench` items. ``attitude`` None = identity (then rddot_cm
    is in the spacecraft frame). ``method="recursive"`` (default): the engine,
    H+ by composite rigid bodies and C+ - Q by Newton-Euler, one Cholesky
    solve, at every batch size; ``method="barycentric"``: the barycentric H+
    (1991 eq. 16) and closed-form C+ with a Cholesky solve.

    ``out``: an array of the result's shape (..., 6 + N), float64, C-contiguous and writable, sharing no memory with
    the inputs: zddot0 is written into it and it is returned (``method="recursive"`` only; after a
    SingularConfigurationError its content is undefined), so that a loop of calls of one size reuses one array
    instead of a new one per call.
    """
    method = _method(method)
    given = {"q": q, "velocity": velocity, "joint_torque": joint_torque, "spacecraft_force": spacecraft_force}
    check_out_inputs(out, method, **given, spacecraft_torque=spacecraft_torque, attitude=attitude, external=external)
    q = _joints(model, q, "q")
    v = _velocity(model, velocity)
    t0 = _attitude(attitude)
    if method == "recursive":
        u = _actuation_parts(model, joint_torque, spacecraft_force, spacecraft_torque)
        acc, ok = engine.accelerations(model, q, v, u, t0, _engine_wrenches(model, _wrenches(external)), out)
        if not np.all(ok):
            h = system_inertia_matrix(model, q)[..., 3:, 3:]
            raise SingularConfigurationError("H+ (1991 eq. 15)", float(np.min(np.linalg.det(h))), "the mass properties are not physical")
        return acc
    q_0 = _generalized_forces_0(model, q, joint_torque, spacecraft_force, spacecraft_torque, _wrenches(external), t0)
    if model.has_passive or model.has_springs:
        q_0 = _plus_joint_rows(q_0, passive_torque(model, v[..., 6:], q))
    batch = np.broadcast_shapes(q.shape[:-1], v.shape[:-1], q_0.shape[:-1])
    out = np.empty((*batch, 6 + model.n_joints))
    out[..., 0:3] = _rotate(t0, q_0[..., 0:3]) / model.total_mass
    h = system_inertia_matrix(model, q, method="barycentric")[..., 3:, 3:]
    c = nonlinear_forces(model, q, v, method="barycentric")
    out[..., 3:] = _cholesky_solve(h, q_0[..., 3:] - c[..., 3:], "H+ (1991 eq. 15)")
    return out


def inverse_dynamics(
    model: Model,
    q: Any,
    velocity: Any,
    acceleration: Any,
    attitude: Any = None,
    *,
    external: Any = (),
    method: str = "recursive",
    out: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(spacecraft_force, spacecraft_torque, joint_torque) that produce ``acceleration``.

    ``acceleration`` is zddot0 = [rddot_cm (inertial), d/dt omega0 (spacecraft
    frame), qddot]; the thruster force and torque act at the spacecraft CM and
    are returned in the spacecraft frame, with the joint torques (..., N):
    J_q^-T (H+ zddot0 + C+ - Q_external), 1991 eqs. 19, 21 and 30.
    ``method="recursive"`` (default) evaluates H+ zddot0 + C+ - Q_external by the
    engine's Newton-Euler recursion, the wrenches included (as forward dynamics);
    ``method="barycentric"`` from the barycentric H+ and C+ and Q_external by
    :func:`~freefloat.generalized_forces`.

    ``out``: a tuple of three arrays of the results' shapes, (..., 3), (..., 3) and (..., N), each float64,
    C-contiguous and writable, sharing no memory with the inputs or with each other: the force, torque and joint
    torques are written into them and the tuple is returned (``method="recursive"`` only), so that a loop of calls
    of one size reuses them instead of new arrays per call.
    """
    method = _method(method)
    given = {"q": q, "velocity": velocity, "acceleration": acceleration, "attitude": attitude, "external": external}
    outs = _output_triple(out, method, given)
    q = _joints(model, q, "q")
    v = _velocity(model, velocity)
    acc = _velocity(model, acceleration, "acceleration")
    t0 = _attitude(attitude)
    wrenches = _wrenches(external)
    if method == "recursive":  # the engine: H+ zddot0 + C+ - Q_ext, the passive torques and the wrenches counted in Q
        ext = _engine_wrenches(model, wrenches)
        if outs is not None:  # checked before the work: the batch of every input, the attitude's and the wrenches' too
            shapes = (q.shape[:-1], v.shape[:-1], acc.shape[:-1], () if t0 is None else t0.shape[:-2], ext[1].shape[:-2])
            batch = np.broadcast_shapes(*shapes)
            for i, (o, width) in enumerate(zip(outs, (3, 3, model.n_joints), strict=True)):
                engine.check_out(o, (*batch, width), f"out[{i}] ({_OUT_NAMES[i]})")
        rows = engine.residual_rows(model, q, v, acc, None, t0, ext)
        return _actuation_0(model, q, rows, outs)
    rows = (
        np.einsum("...ij,...j->...i", system_inertia_matrix(model, q, method="barycentric")[..., 3:, 3:], acc[..., 3:])
        + nonlinear_forces(model, q, v, method="barycentric")[..., 3:]
    )
    # H+ zddot0 + C+ with its first block (M rddot_cm) in the spacecraft frame
    first = model.total_mass * _rotate(t0, acc[..., 0:3], inverse=True)
    batch = np.broadcast_shapes(first.shape[:-1], rows.shape[:-1])
    total = np.concatenate([np.broadcast_to(first, (*batch, 3)), np.broadcast_to(rows, batch + rows.shape[-1:])], axis=-1)
    if wrenches:
        total = total - _generalized_forces_0(model, q, None, None, None, wrenches, t0)
    if model.has_passive or model.has_springs:
        total = _plus_joint_rows(total, -passive_torque(model, v[..., 6:], q))
    return _actuation_0(model, q, total)


#: The results of :func:`inverse_dynamics`, in the order of its ``out`` tuple.
_OUT_NAMES = ("spacecraft_force", "spacecraft_torque", "joint_torque")


def _output_triple(out: Any, method: str, given: dict[str, Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """:func:`inverse_dynamics`'s ``out``: None, or a tuple of three arrays that share no memory with the inputs
    ``given`` or with each other (their shapes and layout: ``engine.check_out``)."""
    if out is None:
        return None
    check_out_inputs(out, method)  # a method that takes no out: refused as a whole
    if not (isinstance(out, tuple) and len(out) == 3):
        got = f"a {type(out).__name__} of {len(out)}" if isinstance(out, tuple | list) else type(out).__name__
        raise TypeError(
            f"out: expected a tuple of three arrays ({', '.join(_OUT_NAMES)}: shapes (..., 3), (..., 3), (..., N)), "
            f"got {got}; pass such a tuple or call without out"
        )
    for i, o in enumerate(out):
        earlier = {f"out[{j}] ({_OUT_NAMES[j]})": out[j] for j in range(i)}
        check_out_inputs(o, method, f"out[{i}] ({_OUT_NAMES[i]})", **given, **earlier)
    return out


def _plus_joint_rows(total: np.ndarray, joint_rows: np.ndarray) -> np.ndarray:
    """total (..., 6 + N) plus ``joint_rows`` (..., N) on its joint rows, broadcast."""
    return total + np.concatenate([np.zeros((*joint_rows.shape[:-1], 6)), joint_rows], axis=-1)


def passive_torque(model: Model, qdot: Any, q: Any = None) -> np.ndarray:
    """The joints' passive torques (..., N) at the joint rates ``qdot`` (N m, N for a prismatic joint): viscous damping
    -d qdot and smooth Coulomb friction -F tanh(qdot / v_s), with d = ``model.joint_damping``, F = ``model.joint_friction``
    and v_s = :data:`FRICTION_SPEED` (0.01 rad/s or m/s), and the joints' springs -K (q - q_ref) at the joint values
    ``q`` (:func:`~.springs.spring_torque`; ``q`` is needed when a joint has one: ``model.has_springs``). The reference
    form in numpy; the engine adds the same torques in its Newton-Euler rows (``engine.recursions.newton_euler``). They
    are internal: they change no momentum."""
    resisted = dissipative_torque(model, qdot)
    if not model.has_springs:
        return resisted
    if q is None:
        raise ValueError(f"q: {model.name!r} has joint springs (joint_stiffness), whose torque needs the joint values q; pass q")
    return resisted + spring_torque(model, q)


def dissipative_torque(model: Model, qdot: Any) -> np.ndarray:
    """The joints' damping and friction torques (..., N) at the joint rates ``qdot``: the part of :func:`passive_torque`
    that dissipates energy (its power, -sum torque qdot >= 0, is ``Trajectory.dissipated_energy``'s rate)."""
    qd = _joints(model, qdot, "qdot")
    if model.has_mimic:  # each mimic joint's own torque, at its rate, acts on its leader through the law
        body = model.expanded()
        qb = qd @ model.mimic_matrix.T
        return gather_columns(model, -(body.joint_damping * qb + body.joint_friction * np.tanh(qb / FRICTION_SPEED)))
    return -(model.joint_damping * qd + model.joint_friction * np.tanh(qd / FRICTION_SPEED))


def spacecraft_fixed_dynamics(
    model: Model, q: Any, qdot: Any, joint_torque: Any = None, attitude: Any = None, *, external: Any = ()
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The arm with the spacecraft held fixed: (qddot (..., N), spacecraft_force, spacecraft_torque).

    The spacecraft CM and attitude do not move (omega0 = 0, spacecraft CM at
    rest, zero accelerations); the manipulator is then a fixed-base arm. In
    the coordinates x = J_q zdot0 = [v_S, omega0, qdot] (1991 eq. 21) the
    held motion is zdot0 = K qdot, K = J_q^-1 [0; 0; 1], and

        K^T H+ K qddot = tau - K^T (H+ zddot_b + C+ - Q_ext),   zddot_b = [-Jdot_S zdot0; 0; 0]

    The returned force and torque (spacecraft frame, at the spacecraft CM) are
    what thrusters must apply to hold the spacecraft; ``external`` wrenches
    are included, ``attitude`` matters only for inertial-frame wrenches.
    """
    q = _joints(model, q, "q")
    qd = _joints(model, qdot, "qdot")
    t0 = _attitude(attitude)
    n = model.n_joints
    j_q = actuation_jacobian(model, q)
    k_mat = np.zeros((*j_q.shape[:-2], 6 + n, n))
    k_mat[..., 0:3, :] = -j_q[..., 0:3, 6:]
    k_mat[..., 6:, :] = np.eye(n)
    z = np.einsum("...ij,...j->...i", k_mat, qd)  # rdot_cm in the spacecraft frame
    bias = point_bias_acceleration(model, q, z, 0)[..., 0:3]
    z_dd_b = np.zeros((*bias.shape[:-1], 6 + n))
    z_dd_b[..., 0:3] = -bias
    h = system_inertia_matrix(model, q)
    rest = np.einsum("...ij,...j->...i", h, z_dd_b) + nonlinear_forces(model, q, z)
    wrenches = _wrenches(external)
    if wrenches:
        rest = rest - _generalized_forces_0(model, q, None, None, None, wrenches, t0)
    tau = np.zeros(n) if joint_torque is None else _vector(joint_torque, n, "joint_torque", "one torque per joint")
    h_fixed = np.einsum("...ji,...jk,...kl->...il", k_mat, h, k_mat)
    rhs = tau - np.einsum("...ji,...j->...i", k_mat, rest)
    qdd = _cholesky_solve(h_fixed, rhs, "the fixed-base mass matrix K^T H+ K")
    total = rest + np.einsum("...ij,...jk,...k->...i", h, k_mat, qdd)
    force, torque, _ = _actuation_0(model, q, total)
    batch = np.broadcast_shapes(qdd.shape[:-1], force.shape[:-1])
    return (
        np.broadcast_to(qdd, (*batch, n)).copy(),
        np.broadcast_to(force, (*batch, 3)).copy(),
        np.broadcast_to(torque, (*batch, 3)).copy(),
    )
