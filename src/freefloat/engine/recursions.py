"""The fast path of the physics, written once: O(N) tree recursions as numba kernels.

Every public call of :mod:`freefloat.mechanics` and :mod:`freefloat.simulation` that computes
forward kinematics, point Jacobians (J+, 1991 eqs. 7-10), the generalized Jacobian (J*, 1992
eq. 14), the inertia matrix (H+, 1991 eq. 15), the nonlinear forces (C+, 1991 eq. 19), forward and
inverse dynamics or an RK4 step ends here, at every batch size. The papers' barycentric closed
forms (``method="barycentric"`` of the public calls) are the other, independent algorithm that checks it.

The model enters as plain arrays (:class:`~.layout.Tree`), so each kernel is compiled once for all models
and kept on disk (:mod:`freefloat.engine.cache`): a new model or a payload variant
compiles nothing. sin and cos are the C library's (``math.sin``, ``math.cos``).

Formulation (docs/dynamics.md). Everything is in the spacecraft frame 0 with vectors measured
from the spacecraft frame origin O, so composite (subtree) quantities add without transforms:

* kinematics: joint k turns body k about its axis u_k (Rodrigues: the joint placement P_k times
  1 + sin q K + (1 - cos q) K^2), ⁰T_k = ⁰T_parent P_k R(q_k); p_k the joint position, and the
  motion axis of joint k at O is S_k = [u_k; p_k x u_k]. A prismatic joint slides instead:
  ⁰T_k = ⁰T_parent P_k, p_k = p_parent + ⁰T_parent (t_k + q_k P_k u_k) and S_k = [0; u_k]; below,
  "u_l" and "p_l x u_l" stand for the angular and linear parts of S_l, so every formula covers both;
* mass properties at O: per body the mass m_k, first moment m_k c_k and inertia about O; their
  subtree sums (composite bodies) S_k, F_k, I_k;
* momenta of a unit joint rate: the subtree of joint l turning about its axis at unit rate has
  linear momentum g_l = S_l (p_l x u_l) - F_l x u_l and angular momentum about O
  h_l = I_l u_l + F_l x (p_l x u_l);
* H+ (1991 eq. 15) by composite rigid bodies, then the system CM eliminated:
  D = I_0 - (|F_0|^2 1 - F_0 F_0^T) / M (the system inertia about the CM),
  D_q[:, l] = h_l - c x g_l (c = F_0 / M the system CM), and
  D_qq[i, l] = u_i . h_l + (p_i x u_i) . g_l - g_i . g_l / M (the first two terms only when joint
  i is an ancestor of, or is, joint l);
* J* (1992 eq. 14): omega0 = -X qdot with X = D^-1 D_q (zero angular momentum, 1992 eq. 12), and
  for an end effector at r_E (rho_E = r_E - c), column l is
  v = [l inboard of E] (p_l x u_l + u_l x r_E) - g_l / M + rho_E x X_l,  w = [l inboard of E] u_l - X_l;
* C+ and the generalized forces (1991 eqs. 18-21) by Newton-Euler at O with the base's linear
  velocity and acceleration set to zero, then the uniform acceleration delta = -f_O / M that
  removes the base force (the omega0 and q rows do not change under it; docs/dynamics.md §4);
* forward dynamics: [[D, D_q], [D_q^T, D_qq]] [d/dt omega0; qddot] = -(C+ - Q) by Cholesky, and
  M rddot_cm = the total external force (inertial).
* mimic joints: joint k's value is r_k q[c_k] + o_k and its rate r_k qdot[c_k] (``m.multiplier``,
  ``m.coordinate``, ``m.offset``: r = 1, o = 0 and c_k = k - 1 for an independent joint); every term of
  joint k lands in column (row) c_k times r_k, so H+ = T^T H_body T, J* = J*_body M and the joint rows
  are M^T (rows of the body joints), with M the (B - 1) x N map (``Model.mimic_matrix``).

This module holds the recursions of one configuration; :mod:`.quantities` combines them into
J*, J+, H+, forward dynamics and RK4; :mod:`.drivers` loops them over batches; :mod:`.calls`
is the Python side. These kernels are inlined (``inline="always"``) into each one-configuration
kernel of :mod:`.quantities`: faster than calls that pass array views.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .cache import kernel

#: The joint speed (rad/s, m/s) over which Coulomb friction builds up: the friction torque of a joint is
#: -F tanh(qdot / FRICTION_SPEED) (F = ``Model.joint_friction``), 76 % of F at this speed and 99.9 % at 4 times it.
#: A smooth model: a joint at rest under a torque below F creeps at a speed below FRICTION_SPEED instead of sticking.
FRICTION_SPEED = 0.01


@kernel(inline="always")
def passive_resistance(m: Any, k: int, qd: float) -> float:  # pragma: no cover - compiled
    """The torque (force) with which body joint k's viscous damping and smooth Coulomb friction resist its rate ``qd``
    (its own, or a mimic joint's: multiplier times its leader's): d_k qd + F_k tanh(qd / FRICTION_SPEED); the joint feels
    minus this (``mechanics.passive_torque`` is the numpy reference)."""
    tau = m.damping[k] * qd
    if m.friction[k] > 0.0:  # (a zero friction is folded away by the specialiser: see layout.Field.fold_zeros)
        tau += m.friction[k] * math.tanh(qd / FRICTION_SPEED)
    return tau


@kernel(inline="always")
def passive_spring(m: Any, k: int, value: float) -> float:  # pragma: no cover - compiled
    """The torque (force) of body joint k's spring at its joint value ``value`` (its own, or a mimic joint's: multiplier
    times its leader's plus offset): K_k (value - springref_k); the joint feels minus this, a conservative torque (its
    potential 1/2 K_k (value - springref_k)^2: ``mechanics.spring_energy``; ``mechanics.passive_torque`` is the numpy
    reference). A zero stiffness is folded away by the specialiser (layout.Field.fold_zeros)."""
    return m.stiffness[k] * (value - m.springref[k])


@kernel(inline="always")
def dissipated_power(m: Any, qdot: np.ndarray, o: int) -> float:  # pragma: no cover - compiled
    """The power (W) the joints' damping and friction dissipate at the joint rates ``qdot[o : o + N]``:
    sum over the body joints k of qd_k (d_k qd_k + F_k tanh(qd_k / FRICTION_SPEED)) >= 0 (:func:`passive_resistance`),
    qd_k = multiplier_k qdot[o + coordinate_k]. The integrators integrate it with the state (its trailing slot:
    :func:`~.quantities.state_derivative_one`)."""
    power = 0.0
    for k in range(1, m.parent.shape[0]):
        qd = m.multiplier[k] * qdot[o + int(m.coordinate[k])]
        power += qd * passive_resistance(m, k, qd)
    return power


# ----------------------------------------------------------------- kinematics
@kernel(inline="always")
def kinematics(
    q: np.ndarray, m: Any, rot: np.ndarray, pos: np.ndarray, axis: np.ndarray, mom: np.ndarray
) -> None:  # pragma: no cover - compiled
    """Body rotations ⁰T_k, joint positions p_k (from O) and the motion axes of the joints at O.

    ``axis`` and ``mom`` are the angular and linear parts of joint k's motion axis at O (spacecraft
    frame): [u_k; p_k x u_k] for a revolute joint, [0; u_k] for a prismatic one. Every recursion
    below uses only these two, so it holds for both joint types unchanged.
    """
    parent = m.parent
    nb = parent.shape[0]
    for i in range(3):
        for j in range(3):
            rot[0, i, j] = 1.0 if i == j else 0.0
        pos[0, i] = 0.0
        axis[0, i] = 0.0
        mom[0, i] = 0.0
    for k in range(1, nb):
        p = parent[k]
        slide = m.prismatic[k] != 0.0
        qk = m.multiplier[k] * q[int(m.coordinate[k])] + m.offset[k]  # its own q, or a mimic joint's law
        if slide:  # prismatic: no turn (P1 = P2 = 0); the body frame origin moves q along the axis
            s = 0.0
            c = 0.0
            d = qk
        else:
            s = math.sin(qk)
            c = 1.0 - math.cos(qk)
            d = 0.0
        l00 = m.place[k, 0, 0] + s * m.place_k[k, 0, 0] + c * m.place_k2[k, 0, 0]
        l01 = m.place[k, 0, 1] + s * m.place_k[k, 0, 1] + c * m.place_k2[k, 0, 1]
        l02 = m.place[k, 0, 2] + s * m.place_k[k, 0, 2] + c * m.place_k2[k, 0, 2]
        l10 = m.place[k, 1, 0] + s * m.place_k[k, 1, 0] + c * m.place_k2[k, 1, 0]
        l11 = m.place[k, 1, 1] + s * m.place_k[k, 1, 1] + c * m.place_k2[k, 1, 1]
        l12 = m.place[k, 1, 2] + s * m.place_k[k, 1, 2] + c * m.place_k2[k, 1, 2]
        l20 = m.place[k, 2, 0] + s * m.place_k[k, 2, 0] + c * m.place_k2[k, 2, 0]
        l21 = m.place[k, 2, 1] + s * m.place_k[k, 2, 1] + c * m.place_k2[k, 2, 1]
        l22 = m.place[k, 2, 2] + s * m.place_k[k, 2, 2] + c * m.place_k2[k, 2, 2]
        for i in range(3):
            r0 = rot[p, i, 0]
            r1 = rot[p, i, 1]
            r2 = rot[p, i, 2]
            rot[k, i, 0] = r0 * l00 + r1 * l10 + r2 * l20
            rot[k, i, 1] = r0 * l01 + r1 * l11 + r2 * l21
            rot[k, i, 2] = r0 * l02 + r1 * l12 + r2 * l22
            a = r0 * m.axis[k, 0] + r1 * m.axis[k, 1] + r2 * m.axis[k, 2]
            pos[k, i] = pos[p, i] + r0 * m.origin[k, 0] + r1 * m.origin[k, 1] + r2 * m.origin[k, 2] + d * a
            axis[k, i] = a
        if slide:  # motion axis [0; u]: no angular part, linear part u at every point
            for i in range(3):
                mom[k, i] = axis[k, i]
                axis[k, i] = 0.0
        else:  # motion axis [u; p x u]
            mom[k, 0] = pos[k, 1] * axis[k, 2] - pos[k, 2] * axis[k, 1]
            mom[k, 1] = pos[k, 2] * axis[k, 0] - pos[k, 0] * axis[k, 2]
            mom[k, 2] = pos[k, 0] * axis[k, 1] - pos[k, 1] * axis[k, 0]


@kernel(inline="always")
def point_from_origin(
    rot: np.ndarray, pos: np.ndarray, k: int, points: np.ndarray, e: int, out: np.ndarray
) -> None:  # pragma: no cover - compiled
    """out = p_k + ⁰T_k points[e]: a point of body k (body frame) measured from O, spacecraft frame."""
    for i in range(3):
        out[i] = pos[k, i] + rot[k, i, 0] * points[e, 0] + rot[k, i, 1] * points[e, 1] + rot[k, i, 2] * points[e, 2]


@kernel(inline="always")
def mass_properties(
    m: Any,
    rot: np.ndarray,
    pos: np.ndarray,
    own_f: np.ndarray,
    own_i: np.ndarray,
    cf: np.ndarray,
    ci: np.ndarray,
    inertia: bool,
) -> None:  # pragma: no cover - compiled
    """First moments (and, with ``inertia``, inertias) about O of every body and of every subtree."""
    parent = m.parent
    nb = parent.shape[0]
    for k in range(nb):
        mk = m.mass[k]
        c0 = pos[k, 0] + rot[k, 0, 0] * m.com[k, 0] + rot[k, 0, 1] * m.com[k, 1] + rot[k, 0, 2] * m.com[k, 2]
        c1 = pos[k, 1] + rot[k, 1, 0] * m.com[k, 0] + rot[k, 1, 1] * m.com[k, 1] + rot[k, 1, 2] * m.com[k, 2]
        c2 = pos[k, 2] + rot[k, 2, 0] * m.com[k, 0] + rot[k, 2, 1] * m.com[k, 1] + rot[k, 2, 2] * m.com[k, 2]
        own_f[k, 0] = cf[k, 0] = mk * c0
        own_f[k, 1] = cf[k, 1] = mk * c1
        own_f[k, 2] = cf[k, 2] = mk * c2
        if inertia:
            sq = c0 * c0 + c1 * c1 + c2 * c2
            for i in range(3):
                # row i of T I, then its products with the rows of T
                a0 = rot[k, i, 0] * m.inertia[k, 0, 0] + rot[k, i, 1] * m.inertia[k, 1, 0] + rot[k, i, 2] * m.inertia[k, 2, 0]
                a1 = rot[k, i, 0] * m.inertia[k, 0, 1] + rot[k, i, 1] * m.inertia[k, 1, 1] + rot[k, i, 2] * m.inertia[k, 2, 1]
                a2 = rot[k, i, 0] * m.inertia[k, 0, 2] + rot[k, i, 1] * m.inertia[k, 1, 2] + rot[k, i, 2] * m.inertia[k, 2, 2]
                ci_ = c0 if i == 0 else (c1 if i == 1 else c2)
                for j in range(i, 3):
                    cj = c0 if j == 0 else (c1 if j == 1 else c2)
                    v = a0 * rot[k, j, 0] + a1 * rot[k, j, 1] + a2 * rot[k, j, 2] - mk * ci_ * cj
                    if i == j:
                        v += mk * sq
                    own_i[k, i, j] = v
                    own_i[k, j, i] = v
                    ci[k, i, j] = v
                    ci[k, j, i] = v
    for k in range(nb - 1, 0, -1):
        p = parent[k]
        for i in range(3):
            cf[p, i] += cf[k, i]
        if inertia:
            for i in range(3):
                for j in range(3):
                    ci[p, i, j] += ci[k, i, j]


@kernel(inline="always")
def unit_momenta(
    m: Any, axis: np.ndarray, mom: np.ndarray, cf: np.ndarray, ci: np.ndarray, g: np.ndarray, h: np.ndarray, angular: bool
) -> None:  # pragma: no cover - compiled
    """g_l, h_l: linear and angular (about O) momentum of the subtree of joint l turning at unit rate."""
    nb = m.parent.shape[0]
    for k in range(1, nb):
        s = m.subtree_mass[k]
        u0, u1, u2 = axis[k, 0], axis[k, 1], axis[k, 2]
        w0, w1, w2 = mom[k, 0], mom[k, 1], mom[k, 2]
        f0, f1, f2 = cf[k, 0], cf[k, 1], cf[k, 2]
        g[k, 0] = s * w0 - (f1 * u2 - f2 * u1)
        g[k, 1] = s * w1 - (f2 * u0 - f0 * u2)
        g[k, 2] = s * w2 - (f0 * u1 - f1 * u0)
        if angular:
            for i in range(3):
                h[k, i] = ci[k, i, 0] * u0 + ci[k, i, 1] * u1 + ci[k, i, 2] * u2
            h[k, 0] += f1 * w2 - f2 * w1
            h[k, 1] += f2 * w0 - f0 * w2
            h[k, 2] += f0 * w1 - f1 * w0


@kernel(inline="always")
def centroidal_blocks(
    m: Any,
    axis: np.ndarray,
    mom: np.ndarray,
    cf: np.ndarray,
    ci: np.ndarray,
    g: np.ndarray,
    h: np.ndarray,
    a: np.ndarray,
    joint_block: bool,
) -> None:  # pragma: no cover - compiled
    """The [omega0, q] block of H+ into a ((3 + N) x (3 + N)): D, D_q (and D_qq with ``joint_block``)."""
    nb = m.parent.shape[0]
    ancestor = m.ancestor
    per_mass = 1.0 / m.total_mass  # one division: a product per entry (a division costs about 16 products)
    f0, f1, f2 = cf[0, 0], cf[0, 1], cf[0, 2]
    sq = f0 * f0 + f1 * f1 + f2 * f2
    n = m.n_joints
    for i in range(3):
        for j in range(3):
            a[i, j] = ci[0, i, j] + (cf[0, i] * cf[0, j] - (sq if i == j else 0.0)) * per_mass
    for c in range(n):  # the columns of q gather their joints' terms (a mimic joint's, times its multiplier)
        for r in range(3):
            a[r, 3 + c] = 0.0
    for k in range(1, nb):
        col = 3 + int(m.coordinate[k])
        rk = m.multiplier[k]
        a[0, col] += rk * (h[k, 0] - (f1 * g[k, 2] - f2 * g[k, 1]) * per_mass)
        a[1, col] += rk * (h[k, 1] - (f2 * g[k, 0] - f0 * g[k, 2]) * per_mass)
        a[2, col] += rk * (h[k, 2] - (f0 * g[k, 1] - f1 * g[k, 0]) * per_mass)
    for c in range(n):
        for r in range(3):
            a[3 + c, r] = a[r, 3 + c]
    if joint_block:
        # D_qq[i, k] of the joints of bodies i <= k: u_i . h_k + (p_i x u_i) . g_k (i is k or inboard of it) - g_i . g_k / M
        plain = n == nb - 1  # no mimic joint: joint k is column k - 1, stored directly (the common case keeps its speed)
        if not plain:
            for c in range(n):
                for d in range(n):
                    a[3 + c, 3 + d] = 0.0
        for k in range(1, nb):
            ck = 2 + k if plain else 3 + int(m.coordinate[k])
            rk = m.multiplier[k]
            for i in range(1, k + 1):
                v = -(g[i, 0] * g[k, 0] + g[i, 1] * g[k, 1] + g[i, 2] * g[k, 2]) * per_mass
                if ancestor[i, k]:
                    v += axis[i, 0] * h[k, 0] + axis[i, 1] * h[k, 1] + axis[i, 2] * h[k, 2]
                    v += mom[i, 0] * g[k, 0] + mom[i, 1] * g[k, 1] + mom[i, 2] * g[k, 2]
                if plain:
                    a[2 + i, ck] = v
                    a[ck, 2 + i] = v
                else:  # H+ = M^T H_body M: (i, k) and (k, i), each times both multipliers (twice on a shared diagonal)
                    col_i = 3 + int(m.coordinate[i])
                    v *= m.multiplier[i] * rk
                    a[col_i, ck] += v
                    if i != k:
                        a[ck, col_i] += v
            a[ck, ck] += rk * rk * m.armature[k]  # the rotor's inertia, felt by its joint alone (times r^2 through the law)


@kernel(inline="always")
def solve3(d: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """out (3, n) = D^-1 D_q for D = d[0:3, 0:3] (symmetric positive definite) and D_q = d[0:3, 3:] (adjugate)."""
    a00 = d[1, 1] * d[2, 2] - d[1, 2] * d[1, 2]
    a01 = d[0, 2] * d[1, 2] - d[0, 1] * d[2, 2]
    a02 = d[0, 1] * d[1, 2] - d[0, 2] * d[1, 1]
    a11 = d[0, 0] * d[2, 2] - d[0, 2] * d[0, 2]
    a12 = d[0, 1] * d[0, 2] - d[0, 0] * d[1, 2]
    a22 = d[0, 0] * d[1, 1] - d[0, 1] * d[0, 1]
    inv = 1.0 / (d[0, 0] * a00 + d[0, 1] * a01 + d[0, 2] * a02)
    for l in range(out.shape[1]):
        x, y, z = d[0, 3 + l], d[1, 3 + l], d[2, 3 + l]
        out[0, l] = (a00 * x + a01 * y + a02 * z) * inv
        out[1, l] = (a01 * x + a11 * y + a12 * z) * inv
        out[2, l] = (a02 * x + a12 * y + a22 * z) * inv


@kernel(inline="always")
def cholesky_solve(a: np.ndarray, b: np.ndarray, low: np.ndarray) -> bool:  # pragma: no cover - compiled
    """Solve a x = b in place in b (a symmetric positive definite, untouched); False if a is not.

    ``low`` gets L (a = L L^T) below its diagonal and 1 / L_jj on it: one division per column, products elsewhere
    (a division costs about 16 products: n (n + 3) / 2 of them were most of a small solve)."""
    n = b.shape[0]
    for j in range(n):
        d = a[j, j]
        for k in range(j):
            d -= low[j, k] * low[j, k]
        if not d > 0.0:
            return False
        inv = 1.0 / math.sqrt(d)
        low[j, j] = inv
        for i in range(j + 1, n):
            s = a[i, j]
            for k in range(j):
                s -= low[i, k] * low[j, k]
            low[i, j] = s * inv
    for i in range(n):
        s = b[i]
        for k in range(i):
            s -= low[i, k] * b[k]
        b[i] = s * low[i, i]
    for i in range(n - 1, -1, -1):
        s = b[i]
        for k in range(i + 1, n):
            s -= low[k, i] * b[k]
        b[i] = s * low[i, i]
    return True


# ----------------------------------------------------------------- Newton-Euler at O
@kernel(inline="always")
def newton_euler(
    m: Any,
    s: Any,
    q: np.ndarray,
    vel: np.ndarray,
    acc: np.ndarray,
    accelerate: bool,
    u: np.ndarray,
    t0: np.ndarray,
    ext_i: np.ndarray,
    ext_f: np.ndarray,
    out: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """Rows [omega0, q] of H+ zddot0 + C+ - Q (1991 eq. 19) into out (3 + N).

    ``accelerate`` False: zddot0 = 0 (then this is C+ - Q). u = [tau (N), f_S (3), n_S (3)]
    (thrusters at the spacecraft CM, spacecraft frame); external wrenches ext_i (W, 2) = [body,
    frame (0 inertial, 1 spacecraft, 2 body)], ext_f (W, 9) = [point (body frame), force, couple];
    t0 = the attitude T0 (3x3, inertial <- spacecraft; used for inertial-frame wrenches); vel =
    zdot0 and acc = zddot0 (6 + N; rdot_cm and rddot_cm are not used); q the joint coordinates (N: the joints'
    springs, :func:`passive_spring`). Needs :func:`prepare` with inertias in ``s``; leaves the sum of the external forces
    (spacecraft frame) in ``s.total``.
    """
    parent, total_mass = m.parent, m.total_mass
    nb = parent.shape[0]
    n = m.n_joints
    rot, pos, axis, mom, own_f, own_i, cf = s.rot, s.pos, s.axis, s.mom, s.own_f, s.own_i, s.cf
    w, v, al, be, nf, ff = s.w, s.v, s.al, s.be, s.nf, s.ff
    for i in range(3):
        w[0, i] = vel[3 + i]
        v[0, i] = 0.0
        al[0, i] = acc[3 + i] if accelerate else 0.0
        be[0, i] = 0.0
    for k in range(1, nb):
        p = parent[k]
        rk = m.multiplier[k]
        qd = rk * vel[6 + int(m.coordinate[k])]  # its own rate, or a mimic joint's: multiplier times its leader's
        qdd = rk * acc[6 + int(m.coordinate[k])] if accelerate else 0.0
        su0, su1, su2 = axis[k, 0] * qd, axis[k, 1] * qd, axis[k, 2] * qd
        sw0, sw1, sw2 = mom[k, 0] * qd, mom[k, 1] * qd, mom[k, 2] * qd
        w[k, 0] = w[p, 0] + su0
        w[k, 1] = w[p, 1] + su1
        w[k, 2] = w[p, 2] + su2
        v[k, 0] = v[p, 0] + sw0
        v[k, 1] = v[p, 1] + sw1
        v[k, 2] = v[p, 2] + sw2
        wk0, wk1, wk2 = w[k, 0], w[k, 1], w[k, 2]
        vk0, vk1, vk2 = v[k, 0], v[k, 1], v[k, 2]
        al[k, 0] = al[p, 0] + (wk1 * su2 - wk2 * su1) + axis[k, 0] * qdd
        al[k, 1] = al[p, 1] + (wk2 * su0 - wk0 * su2) + axis[k, 1] * qdd
        al[k, 2] = al[p, 2] + (wk0 * su1 - wk1 * su0) + axis[k, 2] * qdd
        be[k, 0] = be[p, 0] + (wk1 * sw2 - wk2 * sw1) + (vk1 * su2 - vk2 * su1) + mom[k, 0] * qdd
        be[k, 1] = be[p, 1] + (wk2 * sw0 - wk0 * sw2) + (vk2 * su0 - vk0 * su2) + mom[k, 1] * qdd
        be[k, 2] = be[p, 2] + (wk0 * sw1 - wk1 * sw0) + (vk0 * su1 - vk1 * su0) + mom[k, 2] * qdd
    for k in range(nb):  # f_k = I_k a_k + V_k x* I_k V_k, spatial inertia of body k at O
        mk = m.mass[k]
        h0, h1, h2 = own_f[k, 0], own_f[k, 1], own_f[k, 2]
        w0, w1, w2 = w[k, 0], w[k, 1], w[k, 2]
        v0, v1, v2 = v[k, 0], v[k, 1], v[k, 2]
        a0, a1, a2 = al[k, 0], al[k, 1], al[k, 2]
        b0, b1, b2 = be[k, 0], be[k, 1], be[k, 2]
        an0 = own_i[k, 0, 0] * w0 + own_i[k, 0, 1] * w1 + own_i[k, 0, 2] * w2 + (h1 * v2 - h2 * v1)
        an1 = own_i[k, 1, 0] * w0 + own_i[k, 1, 1] * w1 + own_i[k, 1, 2] * w2 + (h2 * v0 - h0 * v2)
        an2 = own_i[k, 2, 0] * w0 + own_i[k, 2, 1] * w1 + own_i[k, 2, 2] * w2 + (h0 * v1 - h1 * v0)
        li0 = mk * v0 - (h1 * w2 - h2 * w1)
        li1 = mk * v1 - (h2 * w0 - h0 * w2)
        li2 = mk * v2 - (h0 * w1 - h1 * w0)
        for i in range(3):
            nf[k, i] = own_i[k, i, 0] * a0 + own_i[k, i, 1] * a1 + own_i[k, i, 2] * a2
        nf[k, 0] += (h1 * b2 - h2 * b1) + (w1 * an2 - w2 * an1) + (v1 * li2 - v2 * li1)
        nf[k, 1] += (h2 * b0 - h0 * b2) + (w2 * an0 - w0 * an2) + (v2 * li0 - v0 * li2)
        nf[k, 2] += (h0 * b1 - h1 * b0) + (w0 * an1 - w1 * an0) + (v0 * li1 - v1 * li0)
        ff[k, 0] = mk * b0 - (h1 * a2 - h2 * a1) + (w1 * li2 - w2 * li1)
        ff[k, 1] = mk * b1 - (h2 * a0 - h0 * a2) + (w2 * li0 - w0 * li2)
        ff[k, 2] = mk * b2 - (h0 * a1 - h1 * a0) + (w0 * li1 - w1 * li0)
    # thrusters: force f_S at the spacecraft CM and couple n_S, spacecraft frame
    fs0, fs1, fs2 = u[n], u[n + 1], u[n + 2]
    c0, c1, c2 = m.com[0, 0], m.com[0, 1], m.com[0, 2]
    nf[0, 0] -= u[n + 3] + (c1 * fs2 - c2 * fs1)
    nf[0, 1] -= u[n + 4] + (c2 * fs0 - c0 * fs2)
    nf[0, 2] -= u[n + 5] + (c0 * fs1 - c1 * fs0)
    ff[0, 0] -= fs0
    ff[0, 1] -= fs1
    ff[0, 2] -= fs2
    pt, fo, no = s.pt, s.fo, s.no
    total = s.total  # the sum of the external forces, spacecraft frame (for the CM row)
    for i in range(3):
        total[i] = 0.0
    for e in range(ext_i.shape[0]):
        k = ext_i[e, 0]
        frame = ext_i[e, 1]
        for i in range(3):
            pt[i] = pos[k, i] + rot[k, i, 0] * ext_f[e, 0] + rot[k, i, 1] * ext_f[e, 1] + rot[k, i, 2] * ext_f[e, 2]
        for i in range(3):
            if frame == 0:  # inertial: T0^T x
                fo[i] = t0[0, i] * ext_f[e, 3] + t0[1, i] * ext_f[e, 4] + t0[2, i] * ext_f[e, 5]
                no[i] = t0[0, i] * ext_f[e, 6] + t0[1, i] * ext_f[e, 7] + t0[2, i] * ext_f[e, 8]
            elif frame == 2:  # body k: T_k x
                fo[i] = rot[k, i, 0] * ext_f[e, 3] + rot[k, i, 1] * ext_f[e, 4] + rot[k, i, 2] * ext_f[e, 5]
                no[i] = rot[k, i, 0] * ext_f[e, 6] + rot[k, i, 1] * ext_f[e, 7] + rot[k, i, 2] * ext_f[e, 8]
            else:
                fo[i] = ext_f[e, 3 + i]
                no[i] = ext_f[e, 6 + i]
        nf[k, 0] -= no[0] + (pt[1] * fo[2] - pt[2] * fo[1])
        nf[k, 1] -= no[1] + (pt[2] * fo[0] - pt[0] * fo[2])
        nf[k, 2] -= no[2] + (pt[0] * fo[1] - pt[1] * fo[0])
        for i in range(3):
            ff[k, i] -= fo[i]
            total[i] += fo[i]
    for k in range(nb - 1, 0, -1):
        p = parent[k]
        for i in range(3):
            nf[p, i] += nf[k, i]
            ff[p, i] += ff[k, i]
    per_mass = 1.0 / total_mass
    d0, d1, d2 = -ff[0, 0] * per_mass, -ff[0, 1] * per_mass, -ff[0, 2] * per_mass
    out[0] = nf[0, 0] + (cf[0, 1] * d2 - cf[0, 2] * d1)
    out[1] = nf[0, 1] + (cf[0, 2] * d0 - cf[0, 0] * d2)
    out[2] = nf[0, 2] + (cf[0, 0] * d1 - cf[0, 1] * d0)
    for c in range(n):
        out[3 + c] = 0.0
    for k in range(1, nb):
        s = m.subtree_mass[k]
        t0_ = nf[k, 0] + (cf[k, 1] * d2 - cf[k, 2] * d1)
        t1_ = nf[k, 1] + (cf[k, 2] * d0 - cf[k, 0] * d2)
        t2_ = nf[k, 2] + (cf[k, 0] * d1 - cf[k, 1] * d0)
        row = axis[k, 0] * t0_ + axis[k, 1] * t1_ + axis[k, 2] * t2_
        row += mom[k, 0] * (ff[k, 0] + s * d0) + mom[k, 1] * (ff[k, 1] + s * d1) + mom[k, 2] * (ff[k, 2] + s * d2)
        # the joint's own dynamics: its rotor (armature), viscous damping, smooth Coulomb friction and spring (passive torques)
        rk = m.multiplier[k]
        c = int(m.coordinate[k])
        row += passive_resistance(m, k, rk * vel[6 + c])
        row += passive_spring(m, k, rk * q[c] + m.offset[k])
        if accelerate:
            row += m.armature[k] * rk * acc[6 + c]
        out[3 + c] += rk * row  # a mimic joint's row acts on its leader through the law (virtual work)
    for c in range(n):
        out[3 + c] -= u[c]


# ----------------------------------------------------------------- one configuration
@kernel(inline="always")
def prepare(q: np.ndarray, m: Any, s: Any, inertia: bool) -> None:  # pragma: no cover - compiled
    """Kinematics and mass properties at q into the scratch ``s`` (the model ``m``: :data:`~.layout.Arrays`)."""
    kinematics(q, m, s.rot, s.pos, s.axis, s.mom)
    mass_properties(m, s.rot, s.pos, s.own_f, s.own_i, s.cf, s.ci, inertia)
