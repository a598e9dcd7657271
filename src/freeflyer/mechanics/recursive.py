"""O(N) recursive dynamics on the tree: Newton-Euler (RNEA) and articulated bodies (ABA).

Featherstone's algorithms (Rigid Body Dynamics Algorithms, 2008, ch. 5 and
7, floating base ch. 9) with the spacecraft as the floating base, written in
body coordinates: spatial vectors [angular; linear] at the body frame origin
(on the joint axis), accelerations are spatial (d/dt of the body-coordinate
twist), no gravity. They check the barycentric closed forms of
:mod:`freeflyer.dynamics` and map into the coordinates zdot0 = [rdot_cm
(inertial), omega0 (spacecraft frame), qdot] of 1991 eq. 8.

Mapping. With the spacecraft frame origin O moving at v_O (spacecraft frame)
and c the system CM measured from O, rdot_cm = T0 (v_O + omega0 x c + J_c
qdot). Power balance gives the generalized forces in zdot0 coordinates from
the Newton-Euler base wrench (n_O, f_O) at O and joint torques tau:

    Q = [T0 f_O;  n_O - c x f_O;  tau - J_c^T f_O]

Shifting the base's linear acceleration by delta adds the same acceleration
delta to every point (a fictitious uniform gravity), which changes f_O by M
delta, n_O by M c x delta and tau_l by u_l . (mu_l x delta) with mu_l the
first mass moment of the subtree of joint l about the joint: exactly the
change of the terms c x f_O and J_c^T f_O. So the omega0 and q rows do not
depend on the base's linear velocity or acceleration (Galilean invariance and
this uniform-acceleration invariance). The recursion therefore runs with v_O
= 0 and zero base linear acceleration, then removes the resulting f_O with
delta = -f_O / M; the omega0 and q rows are then read directly as n_O and
tau. The CM row is M rddot_cm (the CM moves as a particle).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core.model import Model
from ._batch import chunked
from .kinematics import body_rotations

__all__ = ["aba", "rnea_generalized_forces"]


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b over the last axis with broadcasting (np.cross without its axis bookkeeping, for small arrays)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def _local(model: Model, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotations T_k (spacecraft frame, C, B, 3, 3) and E_k = T_k^T T_parent (parent -> body coordinates)."""
    rot = body_rotations(model, q)
    e = np.empty_like(rot)
    e[:, 0] = np.eye(3)
    parent = model.parent
    for k in range(1, model.n_bodies):
        e[:, k] = np.swapaxes(rot[:, k], 1, 2) @ rot[:, parent[k]]
    return rot, e


def _mv(m: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.einsum("cij,cj->ci", m, v)


def _mtv(m: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.einsum("cji,cj->ci", m, v)


def _velocities(model: Model, e: np.ndarray, omega0: np.ndarray, qdot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Body twists (w_k, v_k) in body coordinates with v_O = 0 (C, B, 3) each."""
    batch, n = omega0.shape[0], model.n_bodies
    w = np.zeros((batch, n, 3))
    v = np.zeros((batch, n, 3))
    w[:, 0] = omega0
    for k in range(1, n):
        p = model.parent[k]
        r = model.joint_origin[k]
        w[:, k] = _mv(e[:, k], w[:, p]) + model.joint_axis[k] * qdot[:, k - 1, None]
        v[:, k] = _mv(e[:, k], v[:, p] + _cross(w[:, p], r))
    return w, v


def _body_force(model: Model, k: int, w: np.ndarray, v: np.ndarray, alpha: np.ndarray, acc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Newton-Euler force of body k at its frame origin: I a + v x* I v, as (n, f)."""
    m, c, inertia = model.mass[k], model.com[k], model.inertia[k]
    p = m * (v + _cross(w, c))  # linear momentum
    ang = w @ inertia.T + _cross(c, p)  # angular momentum about the origin
    f_lin = m * (acc + _cross(alpha, c))
    n_ang = alpha @ inertia.T + _cross(c, f_lin)
    return n_ang + _cross(w, ang) + _cross(v, p), f_lin + _cross(w, p)


def _rnea(model: Model, q: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray) -> np.ndarray:
    """Kernel: rows [omega0, q] of H+ zddot0 + C+ (C, 3 + N) by Newton-Euler."""
    batch, nb = q.shape[0], model.n_bodies
    rot, e = _local(model, q)
    qd, qdd = velocity[:, 6:], acceleration[:, 6:]
    w, v = _velocities(model, e, velocity[:, 3:6], qd)
    alpha = np.zeros((batch, nb, 3))
    acc = np.zeros((batch, nb, 3))  # spatial linear acceleration of the body origin
    alpha[:, 0] = acceleration[:, 3:6]
    force_n = np.zeros((batch, nb, 3))
    force_f = np.zeros((batch, nb, 3))
    force_n[:, 0], force_f[:, 0] = _body_force(model, 0, w[:, 0], v[:, 0], alpha[:, 0], acc[:, 0])
    for k in range(1, nb):  # outward: a_k = X_k a_p + S qddot + v_k x S qdot
        p = model.parent[k]
        r, s = model.joint_origin[k], model.joint_axis[k]
        sq = s * qd[:, k - 1, None]
        alpha[:, k] = _mv(e[:, k], alpha[:, p]) + s * qdd[:, k - 1, None] + _cross(w[:, k], sq)
        acc[:, k] = _mv(e[:, k], acc[:, p] + _cross(alpha[:, p], r)) + _cross(v[:, k], sq)
        force_n[:, k], force_f[:, k] = _body_force(model, k, w[:, k], v[:, k], alpha[:, k], acc[:, k])
    moment = model.mass[None, :, None] * model.com[None, :, :] * np.ones((batch, 1, 1))  # first mass moments
    subtree_mass = model.bary.outboard_mass_fraction * model.total_mass
    for k in range(nb - 1, 0, -1):  # inward: f_p += X_k^T f_k
        p = model.parent[k]
        r = model.joint_origin[k]
        f_back = _mtv(e[:, k], force_f[:, k])
        force_f[:, p] += f_back
        force_n[:, p] += _mtv(e[:, k], force_n[:, k]) + _cross(r, f_back)
        moment[:, p] += _mtv(e[:, k], moment[:, k]) + subtree_mass[k] * r
    delta0 = -force_f[:, 0] / model.total_mass  # uniform acceleration that zeroes the base force
    delta = np.einsum("ckji,cj->cki", rot, delta0)  # in body coordinates
    torque = force_n + _cross(moment, delta)
    out = np.empty((batch, 3 + model.n_joints))
    out[:, 0:3] = torque[:, 0]
    out[:, 3:] = np.einsum("ckx,kx->ck", torque[:, 1:], model.joint_axis[1:])
    return out


def rnea_generalized_forces(model: Model, q: Any, velocity: Any, acceleration: Any) -> np.ndarray:
    """Rows [omega0, q] of H+ zddot0 + C+ (1991 eq. 19), (..., 3 + N), by recursive Newton-Euler.

    ``velocity`` and ``acceleration`` are zdot0 and zddot0 (..., 6 + N); their
    first blocks (rdot_cm, rddot_cm) do not enter these rows. The omega0 row is
    in the spacecraft frame. No input checks: use :func:`freeflyer.inverse_dynamics`.
    """
    q, v, a = (np.asarray(x, dtype=float) for x in (q, velocity, acceleration))
    return chunked(lambda qq, vv, aa: _rnea(model, qq, vv, aa), q, v, a, core_ndims=(1, 1, 1))


# ----------------------------------------------------------------- articulated-body algorithm
def _spatial_inertia(model: Model, k: int) -> np.ndarray:
    """6x6 spatial inertia of body k at its frame origin, [angular; linear] ordering."""
    m, c = model.mass[k], model.com[k]
    cx = np.array([[0.0, -c[2], c[1]], [c[2], 0.0, -c[0]], [-c[1], c[0], 0.0]])
    out = np.zeros((6, 6))
    out[0:3, 0:3] = model.inertia[k] + m * cx @ cx.T
    out[0:3, 3:6] = m * cx
    out[3:6, 0:3] = m * cx.T
    out[3:6, 3:6] = m * np.eye(3)
    return out


def _transforms(model: Model, e: np.ndarray) -> np.ndarray:
    """Plucker motion transforms X_k (parent -> body k coordinates), (C, B, 6, 6)."""
    batch, nb = e.shape[0], model.n_bodies
    x = np.zeros((batch, nb, 6, 6))
    for k in range(nb):
        r = model.joint_origin[k]
        rx = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
        x[:, k, 0:3, 0:3] = e[:, k]
        x[:, k, 3:6, 3:6] = e[:, k]
        x[:, k, 3:6, 0:3] = -e[:, k] @ rx
    return x


def _aba(model: Model, q: np.ndarray, velocity: np.ndarray, force: np.ndarray, torque: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Kernel: [d/dt omega0, qddot] (C, 3 + N) from thruster wrench (at the spacecraft CM) and joint torques."""
    batch, nb = q.shape[0], model.n_bodies
    _, e = _local(model, q)
    qd = velocity[:, 6:]
    w, v = _velocities(model, e, velocity[:, 3:6], qd)
    xf = _transforms(model, e)
    inertia = np.stack([_spatial_inertia(model, k) for k in range(nb)])
    art = np.broadcast_to(inertia, (batch, nb, 6, 6)).copy()  # articulated inertias
    bias = np.zeros((batch, nb, 6))  # articulated bias forces
    twist = np.concatenate([w, v], axis=-1)
    for k in range(nb):
        n_k, f_k = _body_force(model, k, w[:, k], v[:, k], np.zeros((batch, 3)), np.zeros((batch, 3)))
        bias[:, k] = np.concatenate([n_k, f_k], axis=-1)
    # thrusters: f_S at the spacecraft CM -> wrench at the spacecraft frame origin
    bias[:, 0, 0:3] -= torque + _cross(model.com[0], force)
    bias[:, 0, 3:6] -= force
    s_all = np.concatenate([model.joint_axis, np.zeros((nb, 3))], axis=-1)  # S_k = [u_k; 0]
    cvec = np.zeros((batch, nb, 6))
    big_u = np.zeros((batch, nb, 6))
    d = np.ones((batch, nb))
    small_u = np.zeros((batch, nb))
    for k in range(1, nb):
        sq = s_all[k, 0:3] * qd[:, k - 1, None]
        cvec[:, k] = np.concatenate([_cross(w[:, k], sq), _cross(twist[:, k, 3:6], sq)], axis=-1)
    for k in range(nb - 1, 0, -1):
        p = model.parent[k]
        s = s_all[k]
        big_u[:, k] = art[:, k] @ s
        d[:, k] = big_u[:, k] @ s
        small_u[:, k] = tau[:, k - 1] - bias[:, k] @ s
        ia = art[:, k] - np.einsum("ci,cj->cij", big_u[:, k], big_u[:, k]) / d[:, k, None, None]
        pa = bias[:, k] + _mv(ia, cvec[:, k]) + big_u[:, k] * (small_u[:, k] / d[:, k])[:, None]
        art[:, p] += np.swapaxes(xf[:, k], 1, 2) @ ia @ xf[:, k]
        bias[:, p] += _mtv(xf[:, k], pa)
    acc = np.zeros((batch, nb, 6))
    acc[:, 0] = -np.linalg.solve(art[:, 0], bias[:, 0][..., None])[..., 0]
    qdd = np.zeros((batch, model.n_joints))
    for k in range(1, nb):
        p = model.parent[k]
        a_k = _mv(xf[:, k], acc[:, p]) + cvec[:, k]
        qdd[:, k - 1] = (small_u[:, k] - np.einsum("ci,ci->c", big_u[:, k], a_k)) / d[:, k]
        acc[:, k] = a_k + s_all[k] * qdd[:, k - 1, None]
    return np.concatenate([acc[:, 0, 0:3], qdd], axis=-1)


def aba(model: Model, q: Any, velocity: Any, spacecraft_force: Any, spacecraft_torque: Any, joint_torque: Any) -> np.ndarray:
    """[d/dt omega0 (spacecraft frame), qddot], (..., 3 + N), by the articulated-body algorithm.

    Featherstone's floating-base ABA with the spacecraft as the base; the
    thruster force and torque act at the spacecraft CM, spacecraft frame.
    The base runs with v_O = 0 (Galilean invariance: omega0dot and qddot do
    not depend on it); rddot_cm is simply the total force over M. No input
    checks: use :func:`freeflyer.forward_dynamics` with ``method="recursive"``.
    """
    arrays = [np.asarray(x, dtype=float) for x in (q, velocity, spacecraft_force, spacecraft_torque, joint_torque)]
    return chunked(lambda *a: _aba(model, *a), *arrays, core_ndims=(1, 1, 1, 1, 1))
