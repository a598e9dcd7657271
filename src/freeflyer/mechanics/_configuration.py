"""Results of one configuration from the recursions of :mod:`._recursions`: J*, J+, H+, forward dynamics, RK4.

Each is a numba kernel with the recursions of :mod:`._recursions` inlined into it, called per
configuration by the batch drivers (:mod:`._drivers`) and by the stepper that runs one trajectory
with a Python controller (:class:`~._engine.Stepper`). They are not inlined further: RK4 calls the
derivative four times, and four inlined copies would multiply the compile time.
"""

from __future__ import annotations

import math

import numpy as np

from ._numba_cache import kernel
from ._recursions import (
    centroidal_blocks,
    cholesky_solve,
    newton_euler,
    point_from_origin,
    prepare,
    solve3,
    unit_momenta,
)


@kernel()
def jstar_one(
    q: np.ndarray,
    parent: np.ndarray,
    body: np.ndarray,
    ancestor: np.ndarray,
    total_mass: float,
    ee_body: np.ndarray,
    ee_point: np.ndarray,
    work: np.ndarray,
    out: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """J* (6E, N) at q (1992 eq. 14; the module docstring has the formula)."""
    nb = parent.shape[0]
    n = nb - 1
    rot, pos, axis, mom, _own_f, _own_i, cf, ci, g, h, sp, tail = prepare(q, parent, body, work, True)
    unit_momenta(body, axis, mom, cf, ci, g, h, True)
    a = tail[0 : (3 + n) * (3 + n)].reshape((3 + n, 3 + n))
    centroidal_blocks(body, ancestor, total_mass, axis, mom, cf, ci, g, h, a, False)
    x = tail[(3 + n) * (3 + n) : (3 + n) * (3 + n) + 3 * n].reshape((3, n))
    solve3(a[0:3, 0:3], a[0:3, 3:], x)
    re = sp[6, 0]
    c0, c1, c2 = cf[0, 0] / total_mass, cf[0, 1] / total_mass, cf[0, 2] / total_mass
    for e in range(ee_body.shape[0]):
        k = ee_body[e]
        point_from_origin(rot, pos, k, ee_point[e], re)
        r0, r1, r2 = re[0] - c0, re[1] - c1, re[2] - c2  # rho_E
        for l in range(1, nb):
            x0, x1, x2 = x[0, l - 1], x[1, l - 1], x[2, l - 1]
            v0 = -g[l, 0] / total_mass + (r1 * x2 - r2 * x1)
            v1 = -g[l, 1] / total_mass + (r2 * x0 - r0 * x2)
            v2 = -g[l, 2] / total_mass + (r0 * x1 - r1 * x0)
            w0, w1, w2 = -x0, -x1, -x2
            if ancestor[l, k]:
                u0, u1, u2 = axis[l, 0], axis[l, 1], axis[l, 2]
                d0, d1, d2 = re[0] - pos[l, 0], re[1] - pos[l, 1], re[2] - pos[l, 2]
                v0 += u1 * d2 - u2 * d1
                v1 += u2 * d0 - u0 * d2
                v2 += u0 * d1 - u1 * d0
                w0 += u0
                w1 += u1
                w2 += u2
            out[6 * e, l - 1] = v0
            out[6 * e + 1, l - 1] = v1
            out[6 * e + 2, l - 1] = v2
            out[6 * e + 3, l - 1] = w0
            out[6 * e + 4, l - 1] = w1
            out[6 * e + 5, l - 1] = w2


@kernel()
def point_jacobian_one(
    q: np.ndarray,
    parent: np.ndarray,
    body: np.ndarray,
    ancestor: np.ndarray,
    total_mass: float,
    pbody: np.ndarray,
    ppoint: np.ndarray,
    work: np.ndarray,
    out: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """J+ (P, 6, 6 + N) of points ``ppoint`` (body frames of ``pbody``), spacecraft frame (1991 eqs. 7-10).

    Rows [v_P; w_k] over [rdot_cm, omega0, qdot]: [[1, -[rho_P]x, J12], [0, 1, J22]] with
    J12[:, l] = [l inboard of P] u_l x (r_P - p_l) - g_l / M and J22[:, l] = [l inboard of P] u_l.
    """
    nb = parent.shape[0]
    rot, pos, axis, mom, _own_f, _own_i, cf, ci, g, h, sp, _tail = prepare(q, parent, body, work, False)
    unit_momenta(body, axis, mom, cf, ci, g, h, False)
    rp = sp[6, 0]
    c0, c1, c2 = cf[0, 0] / total_mass, cf[0, 1] / total_mass, cf[0, 2] / total_mass
    for e in range(pbody.shape[0]):
        k = pbody[e]
        point_from_origin(rot, pos, k, ppoint[e], rp)
        r0, r1, r2 = rp[0] - c0, rp[1] - c1, rp[2] - c2
        o = out[e]
        for i in range(6):
            for j in range(6 + nb - 1):
                o[i, j] = 0.0
        for i in range(3):
            o[i, i] = 1.0
            o[3 + i, 3 + i] = 1.0
        o[0, 4], o[0, 5] = r2, -r1  # -[rho]x
        o[1, 3], o[1, 5] = -r2, r0
        o[2, 3], o[2, 4] = r1, -r0
        for l in range(1, nb):
            v0, v1, v2 = -g[l, 0] / total_mass, -g[l, 1] / total_mass, -g[l, 2] / total_mass
            if ancestor[l, k]:
                u0, u1, u2 = axis[l, 0], axis[l, 1], axis[l, 2]
                d0, d1, d2 = rp[0] - pos[l, 0], rp[1] - pos[l, 1], rp[2] - pos[l, 2]
                v0 += u1 * d2 - u2 * d1
                v1 += u2 * d0 - u0 * d2
                v2 += u0 * d1 - u1 * d0
                o[3, 5 + l], o[4, 5 + l], o[5, 5 + l] = u0, u1, u2
            o[0, 5 + l], o[1, 5 + l], o[2, 5 + l] = v0, v1, v2


@kernel()
def points_one(
    q: np.ndarray,
    parent: np.ndarray,
    body: np.ndarray,
    total_mass: float,
    pbody: np.ndarray,
    ppoint: np.ndarray,
    work: np.ndarray,
    out: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """Positions (P, 3) of points (body frames of ``pbody``) relative to the system CM, spacecraft frame."""
    rot, pos, _axis, _mom, _own_f, _own_i, cf, _ci, _g, _h, _sp, _tail = prepare(q, parent, body, work, False)
    for e in range(pbody.shape[0]):
        point_from_origin(rot, pos, pbody[e], ppoint[e], out[e])
        for i in range(3):
            out[e, i] -= cf[0, i] / total_mass


@kernel()
def hplus_one(
    q: np.ndarray, parent: np.ndarray, body: np.ndarray, ancestor: np.ndarray, total_mass: float, work: np.ndarray, out: np.ndarray
) -> None:  # pragma: no cover - compiled
    """H+ (6 + N, 6 + N) at q, 1991 eq. 15, order [r_cm, omega0, q]."""
    nb = parent.shape[0]
    _rot, _pos, axis, mom, _own_f, _own_i, cf, ci, g, h, _sp, _tail = prepare(q, parent, body, work, True)
    unit_momenta(body, axis, mom, cf, ci, g, h, True)
    for i in range(5 + nb):
        for j in range(5 + nb):
            out[i, j] = 0.0
    for i in range(3):
        out[i, i] = total_mass
    centroidal_blocks(body, ancestor, total_mass, axis, mom, cf, ci, g, h, out[3:, 3:], True)


@kernel(inline="always")
def quaternion_matrix(quat: np.ndarray, t0: np.ndarray) -> None:  # pragma: no cover - compiled
    """t0 = the rotation of the unit quaternion [x, y, z, w] (normalised here)."""
    norm = math.sqrt(quat[0] * quat[0] + quat[1] * quat[1] + quat[2] * quat[2] + quat[3] * quat[3])
    x, y, z, w = quat[0] / norm, quat[1] / norm, quat[2] / norm, quat[3] / norm
    t0[0, 0] = 1.0 - 2.0 * (y * y + z * z)
    t0[0, 1] = 2.0 * (x * y - z * w)
    t0[0, 2] = 2.0 * (x * z + y * w)
    t0[1, 0] = 2.0 * (x * y + z * w)
    t0[1, 1] = 1.0 - 2.0 * (x * x + z * z)
    t0[1, 2] = 2.0 * (y * z - x * w)
    t0[2, 0] = 2.0 * (x * z - y * w)
    t0[2, 1] = 2.0 * (y * z + x * w)
    t0[2, 2] = 1.0 - 2.0 * (x * x + y * y)


@kernel()
def accelerations_one(
    q: np.ndarray,
    velocity: np.ndarray,
    u: np.ndarray,
    t0: np.ndarray,
    parent: np.ndarray,
    body: np.ndarray,
    ancestor: np.ndarray,
    total_mass: float,
    ext_i: np.ndarray,
    ext_f: np.ndarray,
    work: np.ndarray,
    out: np.ndarray,
) -> bool:  # pragma: no cover - compiled
    """Forward dynamics: zddot0 (6 + N) = [rddot_cm (inertial), d/dt omega0, qddot]; False if H+ is not positive definite.

    velocity = zdot0 (6 + N); u = [tau, f_S, n_S]; t0 the attitude (inertial <- spacecraft).
    """
    nb = parent.shape[0]
    n = nb - 1
    rot, pos, axis, mom, own_f, own_i, cf, ci, g, h, sp, tail = prepare(q, parent, body, work, True)
    unit_momenta(body, axis, mom, cf, ci, g, h, True)
    m = 3 + n
    a = tail[0 : m * m].reshape((m, m))
    low = tail[m * m : 2 * m * m].reshape((m, m))
    b = tail[2 * m * m : 2 * m * m + m]
    centroidal_blocks(body, ancestor, total_mass, axis, mom, cf, ci, g, h, a, True)
    newton_euler(
        body,
        parent,
        total_mass,
        rot,
        pos,
        axis,
        mom,
        own_f,
        own_i,
        cf,
        sp,
        velocity[3:6],
        velocity[6:],
        velocity[3:6],
        velocity[6:],
        False,
        u,
        t0,
        ext_i,
        ext_f,
        b,
    )
    for i in range(m):
        b[i] = -b[i]
    ok = cholesky_solve(a, b, low)
    f = sp[7, 1]  # the external forces, summed by newton_euler
    for i in range(3):
        f[i] += u[n + i]
    for i in range(3):
        out[i] = (t0[i, 0] * f[0] + t0[i, 1] * f[1] + t0[i, 2] * f[2]) / total_mass
    for i in range(m):
        out[3 + i] = b[i]
    return ok


@kernel()
def state_derivative_one(
    x: np.ndarray,
    u: np.ndarray,
    parent: np.ndarray,
    body: np.ndarray,
    ancestor: np.ndarray,
    total_mass: float,
    ext_i: np.ndarray,
    ext_f: np.ndarray,
    work: np.ndarray,
    dx: np.ndarray,
) -> bool:  # pragma: no cover - compiled
    """d/dt of the flat state x = [r_cm, v_cm, quat [x, y, z, w], omega0, q, qdot] (13 + 2N) under u = [tau, f_S, n_S].

    dquat/dt = 1/2 quat ⊗ [omega0, 0] (omega0 in the spacecraft frame). False if H+ is not positive definite.
    """
    n = parent.shape[0] - 1
    top = work.shape[0] - 9 - 2 * (6 + n)
    t0 = work[top : top + 9].reshape((3, 3))
    vel = work[top + 9 : top + 15 + n]
    acc = work[top + 15 + n : top + 21 + 2 * n]
    quaternion_matrix(x[6:10], t0)
    for i in range(3):
        vel[i] = x[3 + i]
        vel[3 + i] = x[10 + i]
    for j in range(n):
        vel[6 + j] = x[13 + n + j]
    ok = accelerations_one(x[13 : 13 + n], vel, u, t0, parent, body, ancestor, total_mass, ext_i, ext_f, work[:top], acc)
    norm = math.sqrt(x[6] * x[6] + x[7] * x[7] + x[8] * x[8] + x[9] * x[9])
    qx, qy, qz, qw = x[6] / norm, x[7] / norm, x[8] / norm, x[9] / norm
    o0, o1, o2 = x[10], x[11], x[12]
    for i in range(3):
        dx[i] = x[3 + i]
        dx[3 + i] = acc[i]
        dx[10 + i] = acc[3 + i]
    dx[6] = 0.5 * (qw * o0 + (qy * o2 - qz * o1))
    dx[7] = 0.5 * (qw * o1 + (qz * o0 - qx * o2))
    dx[8] = 0.5 * (qw * o2 + (qx * o1 - qy * o0))
    dx[9] = -0.5 * (qx * o0 + qy * o1 + qz * o2)
    for j in range(n):
        dx[13 + j] = x[13 + n + j]
        dx[13 + n + j] = acc[6 + j]
    return ok


@kernel()
def rk4_step(
    x: np.ndarray,
    u: np.ndarray,
    dt: float,
    parent: np.ndarray,
    body: np.ndarray,
    ancestor: np.ndarray,
    total_mass: float,
    ext_i: np.ndarray,
    ext_f: np.ndarray,
    work: np.ndarray,
    stages: np.ndarray,
) -> bool:  # pragma: no cover - compiled
    """One classical RK4 step of x in place (u held), then the quaternion renormalised; False if H+ failed."""
    size = x.shape[0]
    k1, k2, k3, k4, y = stages[0], stages[1], stages[2], stages[3], stages[4]
    ok = state_derivative_one(x, u, parent, body, ancestor, total_mass, ext_i, ext_f, work, k1)
    for i in range(size):
        y[i] = x[i] + 0.5 * dt * k1[i]
    ok &= state_derivative_one(y, u, parent, body, ancestor, total_mass, ext_i, ext_f, work, k2)
    for i in range(size):
        y[i] = x[i] + 0.5 * dt * k2[i]
    ok &= state_derivative_one(y, u, parent, body, ancestor, total_mass, ext_i, ext_f, work, k3)
    for i in range(size):
        y[i] = x[i] + dt * k3[i]
    ok &= state_derivative_one(y, u, parent, body, ancestor, total_mass, ext_i, ext_f, work, k4)
    c = dt / 6.0
    for i in range(size):
        x[i] = x[i] + c * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    norm = math.sqrt(x[6] * x[6] + x[7] * x[7] + x[8] * x[8] + x[9] * x[9])
    for i in range(6, 10):
        x[i] = x[i] / norm
    return ok


@kernel()
def rk4_steps(
    x: np.ndarray,
    u: np.ndarray,
    dt: float,
    nsteps: int,
    parent: np.ndarray,
    body: np.ndarray,
    ancestor: np.ndarray,
    total_mass: float,
    ext_i: np.ndarray,
    ext_f: np.ndarray,
    work: np.ndarray,
    stages: np.ndarray,
) -> int:  # pragma: no cover - compiled
    """``nsteps`` RK4 steps of one state x in place under the held u; returns the steps done (fewer: H+ failed or x not finite)."""
    for step in range(nsteps):
        if not rk4_step(x, u, dt, parent, body, ancestor, total_mass, ext_i, ext_f, work, stages):
            return step
        total = 0.0
        for i in range(x.shape[0]):
            total += x[i]
        if not math.isfinite(total):
            return step + 1
    return nsteps
