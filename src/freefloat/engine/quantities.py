"""Results of one configuration from the recursions of :mod:`.recursions`: J*, J+, H+, forward dynamics, RK4.

Each is a numba kernel with the recursions of :mod:`.recursions` inlined into it, and is itself
inlined into its callers: the serial range kernels of the batch drivers (:mod:`.drivers`), the control laws
(:mod:`.laws`), :func:`~.stepper.rk4_steps` (the stepper that runs one trajectory with a Python controller,
:class:`~.calls.Stepper`) and :func:`~.stepper.state_derivative`. Each takes the scratch views ``s``
(:data:`~.layout.Scratch`), made once per call of its caller: passing the views into a
non-inlined kernel per configuration costs more than the arithmetic of a small tree. RK4 runs its
four stages in a loop so that the derivative is inlined once (compile time).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .cache import kernel
from .layout import ATTITUDE_AT, OMEGA_AT, Q_AT, R_CM_AT, V_CM_AT, dissipated_at, qdot_at, state_length
from .recursions import (
    centroidal_blocks,
    cholesky_solve,
    dissipated_power,
    newton_euler,
    point_from_origin,
    prepare,
    solve3,
    unit_momenta,
)


@kernel(inline="always")
def jstar_one(q: np.ndarray, m: Any, s: Any, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """J* (6E, N) at q of the model ``m`` (:data:`~.layout.Arrays`; 1992 eq. 14, the formula is in :mod:`.recursions`)."""
    nb = m.parent.shape[0]
    ancestor, total_mass, ee_body, ee_point = m.ancestor, m.total_mass, m.ee_body, m.ee_point
    prepare(q, m, s, True)
    pos, axis, mom, cf, g, x, re = s.pos, s.axis, s.mom, s.cf, s.g, s.x, s.re
    unit_momenta(m, axis, mom, cf, s.ci, g, s.h, True)
    centroidal_blocks(m, axis, mom, cf, s.ci, g, s.h, s.a, False)
    solve3(s.a, x)
    per_mass = 1.0 / total_mass  # one division: products below (a division costs about 16 products)
    c0, c1, c2 = cf[0, 0] * per_mass, cf[0, 1] * per_mass, cf[0, 2] * per_mass
    for e in range(ee_body.shape[0]):
        k = ee_body[e]
        point_from_origin(s.rot, pos, k, ee_point, e, re)
        r0, r1, r2 = re[0] - c0, re[1] - c1, re[2] - c2  # rho_E
        for c in range(m.n_joints):  # the spacecraft's turn, per column of q: rho_E x X_c, -X_c
            x0, x1, x2 = x[0, c], x[1, c], x[2, c]
            out[6 * e, c] = r1 * x2 - r2 * x1
            out[6 * e + 1, c] = r2 * x0 - r0 * x2
            out[6 * e + 2, c] = r0 * x1 - r1 * x0
            out[6 * e + 3, c] = -x0
            out[6 * e + 4, c] = -x1
            out[6 * e + 5, c] = -x2
        for l in range(1, nb):  # each joint's own terms, in its column of q (a mimic joint's times its multiplier)
            c = int(m.coordinate[l])
            rl = m.multiplier[l]
            v0, v1, v2 = -g[l, 0] * per_mass, -g[l, 1] * per_mass, -g[l, 2] * per_mass
            if ancestor[l, k]:
                u0, u1, u2 = axis[l, 0], axis[l, 1], axis[l, 2]  # S_l = [u; m] moves r_E at m + u x r_E
                v0 += mom[l, 0] + u1 * re[2] - u2 * re[1]
                v1 += mom[l, 1] + u2 * re[0] - u0 * re[2]
                v2 += mom[l, 2] + u0 * re[1] - u1 * re[0]
                out[6 * e + 3, c] += rl * u0
                out[6 * e + 4, c] += rl * u1
                out[6 * e + 5, c] += rl * u2
            out[6 * e, c] += rl * v0
            out[6 * e + 1, c] += rl * v1
            out[6 * e + 2, c] += rl * v2


@kernel(inline="always")
def point_jacobian_one(
    q: np.ndarray, m: Any, pbody: np.ndarray, ppoint: np.ndarray, s: Any, out: np.ndarray
) -> None:  # pragma: no cover - compiled
    """J+ (P, 6, 6 + N) of points ``ppoint`` (body frames of ``pbody``), spacecraft frame (1991 eqs. 7-10).

    Rows [v_P; w_k] over [rdot_cm, omega0, qdot]: [[1, -[rho_P]x, J12], [0, 1, J22]] with
    J12[:, l] = [l inboard of P] (m_l + u_l x r_P) - g_l / M and J22[:, l] = [l inboard of P] u_l, with
    S_l = [u_l; m_l] the motion axis at O (m_l = p_l x u_l when revolute; u_l = 0, m_l = the axis when prismatic).
    """
    nb = m.parent.shape[0]
    ancestor, total_mass = m.ancestor, m.total_mass
    prepare(q, m, s, False)
    pos, axis, mom, cf, g, rp = s.pos, s.axis, s.mom, s.cf, s.g, s.re
    unit_momenta(m, axis, mom, cf, s.ci, g, s.h, False)
    per_mass = 1.0 / total_mass  # one division: products below (a division costs about 16 products)
    c0, c1, c2 = cf[0, 0] * per_mass, cf[0, 1] * per_mass, cf[0, 2] * per_mass
    for e in range(pbody.shape[0]):
        k = pbody[e]
        point_from_origin(s.rot, pos, k, ppoint, e, rp)
        r0, r1, r2 = rp[0] - c0, rp[1] - c1, rp[2] - c2
        for i in range(6):
            for j in range(6 + m.n_joints):
                out[e, i, j] = 0.0
        for i in range(3):
            out[e, i, i] = 1.0
            out[e, 3 + i, 3 + i] = 1.0
        out[e, 0, 4], out[e, 0, 5] = r2, -r1  # -[rho]x
        out[e, 1, 3], out[e, 1, 5] = -r2, r0
        out[e, 2, 3], out[e, 2, 4] = r1, -r0
        for l in range(1, nb):  # column 6 + coordinate: a mimic joint's terms times its multiplier, in its leader's column
            col = 6 + int(m.coordinate[l])
            rl = m.multiplier[l]
            v0, v1, v2 = -g[l, 0] * per_mass, -g[l, 1] * per_mass, -g[l, 2] * per_mass
            if ancestor[l, k]:
                u0, u1, u2 = axis[l, 0], axis[l, 1], axis[l, 2]  # S_l = [u; m] moves r_P at m + u x r_P
                v0 += mom[l, 0] + u1 * rp[2] - u2 * rp[1]
                v1 += mom[l, 1] + u2 * rp[0] - u0 * rp[2]
                v2 += mom[l, 2] + u0 * rp[1] - u1 * rp[0]
                out[e, 3, col] += rl * u0
                out[e, 4, col] += rl * u1
                out[e, 5, col] += rl * u2
            out[e, 0, col] += rl * v0
            out[e, 1, col] += rl * v1
            out[e, 2, col] += rl * v2


@kernel(inline="always")
def points_one(
    q: np.ndarray, m: Any, pbody: np.ndarray, ppoint: np.ndarray, s: Any, out: np.ndarray
) -> None:  # pragma: no cover - compiled
    """Positions (P, 3) of points (body frames of ``pbody``) relative to the system CM, spacecraft frame."""
    per_mass = 1.0 / m.total_mass
    prepare(q, m, s, False)
    rot, pos, cf = s.rot, s.pos, s.cf
    for e in range(pbody.shape[0]):
        k = pbody[e]
        for i in range(3):
            out[e, i] = (
                pos[k, i] + rot[k, i, 0] * ppoint[e, 0] + rot[k, i, 1] * ppoint[e, 1] + rot[k, i, 2] * ppoint[e, 2] - cf[0, i] * per_mass
            )


@kernel(inline="always")
def point_bias_one(
    q: np.ndarray,
    velocity: np.ndarray,
    m: Any,
    pbody: np.ndarray,
    ppoint: np.ndarray,
    ext_i: np.ndarray,
    ext_f: np.ndarray,
    s: Any,
    out: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """Jdot+ zdot0 of points (P, 6) at q and zdot0 = ``velocity``: [acceleration of the point; angular acceleration of
    its body] at zddot0 = 0 (rddot_cm = 0, d/dt omega0 = 0, qddot = 0), inertial, spacecraft-frame components (1991
    eq. 7 differentiated).

    Newton-Euler's forward pass at O (O held still) gives each body's spatial velocity (w, v) and acceleration
    (al, be) at O; a point p of body k (from O) then accelerates at be + al x p + w x (v + w x p). Holding the system
    CM still instead moves O at the uniform acceleration delta = -(sum of m_k times the CM accelerations) / M: the
    force the backward pass leaves at the spacecraft, without external forces (``ext_i``, ``ext_f``: none, (0, 2) and
    (0, 9)). Every formula holds for prismatic joints (their motion axes are [0; u]).
    """
    n = m.n_joints
    prepare(q, m, s, True)
    none = s.acc  # no joint torques, thrusters or acceleration: zeros (6 + N)
    for i in range(n + 6):
        none[i] = 0.0
    newton_euler(m, s, q, velocity, none, False, none, s.t0, ext_i, ext_f, s.b)
    total_mass = m.total_mass
    per_mass = 1.0 / total_mass
    d0, d1, d2 = -s.ff[0, 0] * per_mass, -s.ff[0, 1] * per_mass, -s.ff[0, 2] * per_mass
    w, v, al, be, pt = s.w, s.v, s.al, s.be, s.re
    for e in range(pbody.shape[0]):
        k = pbody[e]
        point_from_origin(s.rot, s.pos, k, ppoint, e, pt)
        w0, w1, w2 = w[k, 0], w[k, 1], w[k, 2]
        a0, a1, a2 = al[k, 0], al[k, 1], al[k, 2]
        x0 = v[k, 0] + (w1 * pt[2] - w2 * pt[1])  # the point's velocity (O held still)
        x1 = v[k, 1] + (w2 * pt[0] - w0 * pt[2])
        x2 = v[k, 2] + (w0 * pt[1] - w1 * pt[0])
        out[e, 0] = be[k, 0] + (a1 * pt[2] - a2 * pt[1]) + (w1 * x2 - w2 * x1) + d0
        out[e, 1] = be[k, 1] + (a2 * pt[0] - a0 * pt[2]) + (w2 * x0 - w0 * x2) + d1
        out[e, 2] = be[k, 2] + (a0 * pt[1] - a1 * pt[0]) + (w0 * x1 - w1 * x0) + d2
        out[e, 3] = a0
        out[e, 4] = a1
        out[e, 5] = a2


@kernel(inline="always")
def hplus_one(q: np.ndarray, m: Any, s: Any, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """H+ (6 + N, 6 + N) at q, 1991 eq. 15, order [r_cm, omega0, q]."""
    total_mass = m.total_mass
    prepare(q, m, s, True)
    unit_momenta(m, s.axis, s.mom, s.cf, s.ci, s.g, s.h, True)
    centroidal_blocks(m, s.axis, s.mom, s.cf, s.ci, s.g, s.h, s.a, True)
    n = m.n_joints
    for i in range(6 + n):
        for j in range(6 + n):
            out[i, j] = 0.0
    for i in range(3):
        out[i, i] = total_mass
    for i in range(3 + n):
        for j in range(3 + n):
            out[3 + i, 3 + j] = s.a[i, j]


@kernel(inline="always")
def hplus_rate_one(q: np.ndarray, qdot: np.ndarray, m: Any, s: Any, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """dH+/dt (6 + N, 6 + N) at q along the joint rates ``qdot``: sum_l dH+/dq_l qdot_l (H+ depends on q only).

    The derivative of each quantity of :func:`hplus_one` with the spacecraft frame held still (omega0 = 0: H+ is
    in that frame): the bodies move at w_k = sum u_l qdot_l and v_k = sum m_l qdot_l (spatial velocity at O, the
    sums over the joints inboard of k); a motion axis S_l = [u_l; m_l] fixed to body l turns at
    [w_l x u_l; w_l x m_l + v_l x u_l]; a body's first moment about O changes at m_k (v_k + w_k x c_k) and its
    inertia about O at [w]x I_C - I_C [w]x + m_k (2 c.cdot 1 - cdot c^T - c cdot^T) (I_C about its CM, spacecraft
    axes; c its CM and cdot = v_k + w_k x c_k); composite rates add up the tree. Then the product rule on
    g_l, h_l and the blocks D, D_q, D_qq (see :mod:`.recursions`).
    """
    nb = m.parent.shape[0]
    parent, ancestor, per_mass = m.parent, m.ancestor, 1.0 / m.total_mass  # products below, not divisions
    prepare(q, m, s, True)
    axis, mom, cf, ci, g, h = s.axis, s.mom, s.cf, s.ci, s.g, s.h
    unit_momenta(m, axis, mom, cf, ci, g, h, True)
    w, v, fdot, idot = s.w, s.v, s.own_f, s.own_i  # own_f and own_i become the first-moment and inertia rates
    udot, mdot, hdot, gdot = s.al, s.be, s.nf, s.ff
    for i in range(3):
        w[0, i] = 0.0
        v[0, i] = 0.0
    for k in range(1, nb):
        p = parent[k]
        qd = m.multiplier[k] * qdot[int(m.coordinate[k])]
        for i in range(3):
            w[k, i] = w[p, i] + axis[k, i] * qd
            v[k, i] = v[p, i] + mom[k, i] * qd
    rot, pos = s.rot, s.pos
    for k in range(nb):
        mk = m.mass[k]
        c0 = pos[k, 0] + rot[k, 0, 0] * m.com[k, 0] + rot[k, 0, 1] * m.com[k, 1] + rot[k, 0, 2] * m.com[k, 2]
        c1 = pos[k, 1] + rot[k, 1, 0] * m.com[k, 0] + rot[k, 1, 1] * m.com[k, 1] + rot[k, 1, 2] * m.com[k, 2]
        c2 = pos[k, 2] + rot[k, 2, 0] * m.com[k, 0] + rot[k, 2, 1] * m.com[k, 1] + rot[k, 2, 2] * m.com[k, 2]
        w0, w1, w2 = w[k, 0], w[k, 1], w[k, 2]
        d0 = v[k, 0] + (w1 * c2 - w2 * c1)  # cdot
        d1 = v[k, 1] + (w2 * c0 - w0 * c2)
        d2 = v[k, 2] + (w0 * c1 - w1 * c0)
        fdot[k, 0], fdot[k, 1], fdot[k, 2] = mk * d0, mk * d1, mk * d2
        sq = c0 * c0 + c1 * c1 + c2 * c2
        cd = c0 * d0 + c1 * d1 + c2 * d2
        wx, ic, rate = s.t0, s.low, s.a  # 3 x 3 scratch: [w]x, I_C, the rate
        wx[0, 0], wx[0, 1], wx[0, 2] = 0.0, -w2, w1
        wx[1, 0], wx[1, 1], wx[1, 2] = w2, 0.0, -w0
        wx[2, 0], wx[2, 1], wx[2, 2] = -w1, w0, 0.0
        for i in range(3):
            ci_ = c0 if i == 0 else (c1 if i == 1 else c2)
            di = d0 if i == 0 else (d1 if i == 1 else d2)
            for j in range(3):
                cj = c0 if j == 0 else (c1 if j == 1 else c2)
                dj = d0 if j == 0 else (d1 if j == 1 else d2)
                ic[i, j] = idot[k, i, j] - mk * ((sq if i == j else 0.0) - ci_ * cj)  # own_i holds I_O: I_C = I_O - m (|c|^2 1 - c c^T)
                rate[i, j] = mk * ((2.0 * cd if i == j else 0.0) - di * cj - ci_ * dj)
        for i in range(3):
            for j in range(3):
                rate[i, j] += (wx[i, 0] * ic[0, j] + wx[i, 1] * ic[1, j] + wx[i, 2] * ic[2, j]) - (
                    ic[i, 0] * wx[0, j] + ic[i, 1] * wx[1, j] + ic[i, 2] * wx[2, j]
                )
        for i in range(3):
            for j in range(3):
                idot[k, i, j] = rate[i, j]
    for k in range(nb - 1, 0, -1):  # composite rates
        p = parent[k]
        for i in range(3):
            fdot[p, i] += fdot[k, i]
            for j in range(3):
                idot[p, i, j] += idot[k, i, j]
    for l in range(1, nb):
        u0, u1, u2 = axis[l, 0], axis[l, 1], axis[l, 2]
        n0, n1, n2 = mom[l, 0], mom[l, 1], mom[l, 2]
        w0, w1, w2 = w[l, 0], w[l, 1], w[l, 2]
        v0, v1, v2 = v[l, 0], v[l, 1], v[l, 2]
        udot[l, 0], udot[l, 1], udot[l, 2] = w1 * u2 - w2 * u1, w2 * u0 - w0 * u2, w0 * u1 - w1 * u0
        mdot[l, 0] = (w1 * n2 - w2 * n1) + (v1 * u2 - v2 * u1)
        mdot[l, 1] = (w2 * n0 - w0 * n2) + (v2 * u0 - v0 * u2)
        mdot[l, 2] = (w0 * n1 - w1 * n0) + (v0 * u1 - v1 * u0)
        a0, a1, a2 = udot[l, 0], udot[l, 1], udot[l, 2]
        b0, b1, b2 = mdot[l, 0], mdot[l, 1], mdot[l, 2]
        f0, f1, f2 = cf[l, 0], cf[l, 1], cf[l, 2]
        e0, e1, e2 = fdot[l, 0], fdot[l, 1], fdot[l, 2]
        for i in range(3):
            hdot[l, i] = (
                idot[l, i, 0] * u0 + idot[l, i, 1] * u1 + idot[l, i, 2] * u2 + ci[l, i, 0] * a0 + ci[l, i, 1] * a1 + ci[l, i, 2] * a2
            )
        hdot[l, 0] += (e1 * n2 - e2 * n1) + (f1 * b2 - f2 * b1)
        hdot[l, 1] += (e2 * n0 - e0 * n2) + (f2 * b0 - f0 * b2)
        hdot[l, 2] += (e0 * n1 - e1 * n0) + (f0 * b1 - f1 * b0)
        sm = m.subtree_mass[l]
        gdot[l, 0] = sm * b0 - (e1 * u2 - e2 * u1) - (f1 * a2 - f2 * a1)
        gdot[l, 1] = sm * b1 - (e2 * u0 - e0 * u2) - (f2 * a0 - f0 * a2)
        gdot[l, 2] = sm * b2 - (e0 * u1 - e1 * u0) - (f0 * a1 - f1 * a0)
    size = 6 + m.n_joints
    for i in range(size):
        for j in range(size):
            out[i, j] = 0.0
    f0, f1, f2 = cf[0, 0], cf[0, 1], cf[0, 2]
    e0, e1, e2 = fdot[0, 0], fdot[0, 1], fdot[0, 2]
    fe = f0 * e0 + f1 * e1 + f2 * e2
    for i in range(3):
        fi = f0 if i == 0 else (f1 if i == 1 else f2)
        ei = e0 if i == 0 else (e1 if i == 1 else e2)
        for j in range(3):
            fj = f0 if j == 0 else (f1 if j == 1 else f2)
            ej = e0 if j == 0 else (e1 if j == 1 else e2)
            out[3 + i, 3 + j] = idot[0, i, j] + (ei * fj + fi * ej - (2.0 * fe if i == j else 0.0)) * per_mass
    for l in range(1, nb):  # column 6 + coordinate (a mimic joint's terms times its multiplier, in its leader's column)
        col = 6 + int(m.coordinate[l])
        rl = m.multiplier[l]
        gl0, gl1, gl2 = g[l, 0], g[l, 1], g[l, 2]
        q0, q1, q2 = gdot[l, 0], gdot[l, 1], gdot[l, 2]
        out[3, col] += rl * (hdot[l, 0] - ((e1 * gl2 - e2 * gl1) + (f1 * q2 - f2 * q1)) * per_mass)
        out[4, col] += rl * (hdot[l, 1] - ((e2 * gl0 - e0 * gl2) + (f2 * q0 - f0 * q2)) * per_mass)
        out[5, col] += rl * (hdot[l, 2] - ((e0 * gl1 - e1 * gl0) + (f0 * q1 - f1 * q0)) * per_mass)
    for col in range(6, size):
        for r in range(3):
            out[col, 3 + r] = out[3 + r, col]
    for k in range(1, nb):
        for i in range(1, k + 1):
            val = (
                -(
                    gdot[i, 0] * g[k, 0]
                    + gdot[i, 1] * g[k, 1]
                    + gdot[i, 2] * g[k, 2]
                    + g[i, 0] * gdot[k, 0]
                    + g[i, 1] * gdot[k, 1]
                    + g[i, 2] * gdot[k, 2]
                )
                * per_mass
            )
            if ancestor[i, k]:
                val += udot[i, 0] * h[k, 0] + udot[i, 1] * h[k, 1] + udot[i, 2] * h[k, 2]
                val += axis[i, 0] * hdot[k, 0] + axis[i, 1] * hdot[k, 1] + axis[i, 2] * hdot[k, 2]
                val += mdot[i, 0] * g[k, 0] + mdot[i, 1] * g[k, 1] + mdot[i, 2] * g[k, 2]
                val += mom[i, 0] * gdot[k, 0] + mom[i, 1] * gdot[k, 1] + mom[i, 2] * gdot[k, 2]
            col_i = 6 + int(m.coordinate[i])
            col_k = 6 + int(m.coordinate[k])
            val *= m.multiplier[i] * m.multiplier[k]
            out[col_i, col_k] += val
            if i != k:  # M^T Hdot_body M (see centroidal_blocks)
                out[col_k, col_i] += val


@kernel(inline="always")
def inverse_one(
    q: np.ndarray,
    velocity: np.ndarray,
    acceleration: np.ndarray,
    accelerate: bool,
    u: np.ndarray,
    t0: np.ndarray,
    m: Any,
    ext_i: np.ndarray,
    ext_f: np.ndarray,
    s: Any,
    out: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """H+ zddot0 + C+ - Q_u - Q_ext (6 + N) at q, zdot0 = ``velocity`` (1991 eq. 19; ``accelerate`` False: zddot0 = 0,
    then C+ - Q), its first block in the spacecraft frame: M T0^T rddot_cm less the thrusters' and the external forces
    (their sum by :func:`newton_euler`, which writes the rows [omega0, q])."""
    n = m.n_joints
    prepare(q, m, s, True)
    newton_euler(m, s, q, velocity, acceleration, accelerate, u, t0, ext_i, ext_f, out[3:])
    f = s.total  # the external forces, spacecraft frame
    for i in range(3):
        a = t0[0, i] * acceleration[0] + t0[1, i] * acceleration[1] + t0[2, i] * acceleration[2] if accelerate else 0.0
        out[i] = m.total_mass * a - f[i] - u[n + i]


@kernel(inline="always")
def quaternion_matrix(x: np.ndarray, o: int, t0: np.ndarray) -> None:  # pragma: no cover - compiled
    """t0 = the rotation of the unit quaternion [x, y, z, w] = x[o : o + 4] (normalised here)."""
    norm = math.sqrt(x[o] * x[o] + x[o + 1] * x[o + 1] + x[o + 2] * x[o + 2] + x[o + 3] * x[o + 3])
    qx, qy, qz, qw = x[o] / norm, x[o + 1] / norm, x[o + 2] / norm, x[o + 3] / norm
    t0[0, 0] = 1.0 - 2.0 * (qy * qy + qz * qz)
    t0[0, 1] = 2.0 * (qx * qy - qz * qw)
    t0[0, 2] = 2.0 * (qx * qz + qy * qw)
    t0[1, 0] = 2.0 * (qx * qy + qz * qw)
    t0[1, 1] = 1.0 - 2.0 * (qx * qx + qz * qz)
    t0[1, 2] = 2.0 * (qy * qz - qx * qw)
    t0[2, 0] = 2.0 * (qx * qz - qy * qw)
    t0[2, 1] = 2.0 * (qy * qz + qx * qw)
    t0[2, 2] = 1.0 - 2.0 * (qx * qx + qy * qy)


@kernel(inline="always")
def accelerations_one(
    q: np.ndarray,
    velocity: np.ndarray,
    u: np.ndarray,
    t0: np.ndarray,
    m: Any,
    ext_i: np.ndarray,
    ext_f: np.ndarray,
    s: Any,
    out: np.ndarray,
) -> bool:  # pragma: no cover - compiled
    """Forward dynamics: zddot0 (6 + N) = [rddot_cm (inertial), d/dt omega0, qddot]; False if H+ is not positive definite.

    velocity = zdot0 (6 + N); u = [tau, f_S, n_S]; t0 the attitude (inertial <- spacecraft).
    """
    n = m.n_joints
    rows = 3 + n
    total_mass = m.total_mass
    prepare(q, m, s, True)
    unit_momenta(m, s.axis, s.mom, s.cf, s.ci, s.g, s.h, True)
    centroidal_blocks(m, s.axis, s.mom, s.cf, s.ci, s.g, s.h, s.a, True)
    b = s.b
    newton_euler(m, s, q, velocity, velocity, False, u, t0, ext_i, ext_f, b)
    for i in range(rows):
        b[i] = -b[i]
    ok = cholesky_solve(s.a, b, s.low)
    f = s.total  # the external forces, summed by newton_euler
    for i in range(3):
        f[i] += u[n + i]
    per_mass = 1.0 / total_mass
    for i in range(3):
        out[i] = (t0[i, 0] * f[0] + t0[i, 1] * f[1] + t0[i, 2] * f[2]) * per_mass
    for i in range(rows):
        out[3 + i] = b[i]
    return ok


@kernel(inline="always")
def state_derivative_one(
    x: np.ndarray, u: np.ndarray, m: Any, ext_i: np.ndarray, ext_f: np.ndarray, s: Any, dx: np.ndarray, row: int
) -> bool:  # pragma: no cover - compiled
    """dx[row] = d/dt of the flat state x = [r_cm, v_cm, quat [x, y, z, w], omega0, q, qdot] (``core.state_layout``)
    under u = [tau, f_S, n_S].

    dquat/dt = 1/2 quat ⊗ [omega0, 0] (omega0 in the spacecraft frame). False if H+ is not positive definite.
    A state with the trailing slot (the energy the joints' damping and friction have dissipated since the start)
    gets its rate there, the dissipated power (:func:`~.recursions.dissipated_power`): the integrators integrate it
    with the state, to their own accuracy. A state without it computes no power.
    """
    n = m.n_joints
    qd = qdot_at(n)
    t0, vel, acc, q = s.t0, s.vel, s.acc, s.joints
    quaternion_matrix(x, ATTITUDE_AT, t0)
    for i in range(3):
        vel[i] = x[V_CM_AT + i]
        vel[3 + i] = x[OMEGA_AT + i]
    for j in range(n):
        q[j] = x[Q_AT + j]
        vel[6 + j] = x[qd + j]
    ok = accelerations_one(q, vel, u, t0, m, ext_i, ext_f, s, acc)
    a = ATTITUDE_AT
    norm = math.sqrt(x[a] * x[a] + x[a + 1] * x[a + 1] + x[a + 2] * x[a + 2] + x[a + 3] * x[a + 3])
    qx, qy, qz, qw = x[a] / norm, x[a + 1] / norm, x[a + 2] / norm, x[a + 3] / norm
    o0, o1, o2 = x[OMEGA_AT], x[OMEGA_AT + 1], x[OMEGA_AT + 2]
    for i in range(3):
        dx[row, R_CM_AT + i] = x[V_CM_AT + i]
        dx[row, V_CM_AT + i] = acc[i]
        dx[row, OMEGA_AT + i] = acc[3 + i]
    dx[row, a] = 0.5 * (qw * o0 + (qy * o2 - qz * o1))
    dx[row, a + 1] = 0.5 * (qw * o1 + (qz * o0 - qx * o2))
    dx[row, a + 2] = 0.5 * (qw * o2 + (qx * o1 - qy * o0))
    dx[row, a + 3] = -0.5 * (qx * o0 + qy * o1 + qz * o2)
    for j in range(n):
        dx[row, Q_AT + j] = x[qd + j]
        dx[row, qd + j] = acc[6 + j]
    if x.shape[0] > state_length(n):  # the slot of the dissipated energy (a number while tracing: the rollout's state size)
        dx[row, dissipated_at(n)] = dissipated_power(m, x, qd)
    return ok


@kernel(inline="always")
def rk4_step(x: np.ndarray, u: np.ndarray, dt: float, m: Any, ext_i: np.ndarray, ext_f: np.ndarray, s: Any) -> bool:  # pragma: no cover
    """One classical RK4 step of one state x in place (u held), then the quaternion renormalised; False if H+ failed.

    The RK4 of one trajectory (the stepper of a Python-controlled simulation, the generic rollout and the compiled
    single simulations, through :func:`rk4_step_rows`); the specialised rollouts step 64 lanes at once by the same
    formulas, written a second time for rows of lanes (``specialise.lanes._rk4_rows``; tests/mechanics/test_specialise.py
    checks the two paths against each other). The four stages run in one loop so that the derivative is compiled
    (inlined) once; the stage derivatives stay in ``s.k`` (4, S). x may carry the dissipated energy's slot
    (:func:`state_derivative_one`); the stage state is cut to x's size, which says whether it does.
    """
    size = x.shape[0]
    k, y = s.k, s.y[:size]
    ok = True
    for i in range(size):
        y[i] = x[i]
    for stage in range(4):
        ok &= state_derivative_one(y, u, m, ext_i, ext_f, s, k, stage)
        if stage < 3:
            c = dt if stage == 2 else 0.5 * dt
            for i in range(size):
                y[i] = x[i] + c * k[stage, i]
    c = dt / 6.0
    for i in range(size):
        x[i] = x[i] + c * (k[0, i] + 2.0 * k[1, i] + 2.0 * k[2, i] + k[3, i])
    a = ATTITUDE_AT
    norm = math.sqrt(x[a] * x[a] + x[a + 1] * x[a + 1] + x[a + 2] * x[a + 2] + x[a + 3] * x[a + 3])
    for i in range(a, a + 4):
        x[i] = x[i] / norm
    return ok


@kernel(inline="always")
def rk4_step_rows(P: Any, W: np.ndarray, width: int, size: int, nu: int, dt: float) -> None:  # pragma: no cover - compiled
    """:func:`rk4_step` on the rows of one trajectory in the rollout loop's buffer (``specialise.lanes._rollout_blocks``, width 1):
    x at W[2 S + N + 7 ...], u at W[S ...], the ok row at W[2 S + N + 6]; P = (model, ext_i, ext_f, scratch)."""
    m, ext_i, ext_f, s = P
    o_ok = 2 * size + nu
    ok = rk4_step(W[o_ok + 1 : o_ok + 1 + size], W[size : size + nu], dt, m, ext_i, ext_f, s)
    W[o_ok] = 1.0 if ok else 0.0
