"""The control laws of the built-in controllers as numba kernels (1991 eqs. 22-30, the detumbling law).

The compiled simulation loops (the rollout loop of :mod:`.specialise.lanes`, bound by :mod:`.drivers` with
:func:`law_control`) run :func:`law_one`, compiled once per machine and kept on disk (:mod:`.cache`); nothing else
calls it. The controllers' ``__call__`` (:mod:`freefloat.control`) is the numpy form of the same laws, the reference
``tests/control/test_compiled.py`` checks :func:`law_one` against. A controller is described to it by a :data:`Law`
(arrays only, so every controller and every model share one compiled kernel): the task z1 (eq. 22), the gains, the
desired motion and the controller's own model, each parameter with a leading axis of 1 (shared) or B (one row per
trajectory of a rollout).

The laws, at a state x = [r_cm, v_cm, quat, omega0, q, qdot]:

* transposed Jacobian (eq. 29): Q_c = J_zᵀ (K_p e + K_d ė) (+ the null-space damping);
* operational space (eq. 27): Q_c = J_zᵀ {H~ (K_p e + K_d ė + z̈_des) + C~}, H~ = (J_z H+⁻¹ J_zᵀ)⁻¹ damped near a
  singular J_z, J̄ = H+⁻¹ J_zᵀ H~, C~ = J̄ᵀ C+ − H~ J̇_z ż0 (module docstring of :mod:`freefloat.control.controllers`);
* detumbling (eq. 27 with J_z = 1): Q_c = H+ z̈0,des + C+, z̈0,des = −k ż0 (+ K_att e_att on the ω0 rows);

then [f_S; n_S; τ] = J_q⁻ᵀ Q_c (eq. 30) by forward substitution on J_q (eq. 21, the spacecraft CM's J+), the
spacecraft torque sent to the reaction wheels (``torque_by="wheels"``: u = −A⁺ (n_S + ω0 × h_w), :func:`wheel_routing`) and
the force to nobody (``force_by="none"``), the controller's own actuator limits, the simulation's, and the wheels' torque
and speed limits (:func:`wheel_limits`). J+, J̇+ ż0, H+ and C+ are the engine's (:mod:`.quantities`); the singular-value
ratio of J_z is the engine's measure (:func:`~.measures.jacobian_measure_lanes`).
"""

from __future__ import annotations

import math
from collections import namedtuple
from typing import Any

import numpy as np

from .cache import kernel
from .layout import ATTITUDE_AT, BODY_FIELDS, OMEGA_AT, Q_AT, R_CM_AT, V_CM_AT, arrays, qdot_at, state_length
from .measures import jacobian_measure_lanes, measure_work
from .quantities import hplus_one, inverse_one, point_bias_one, point_jacobian_one, quaternion_matrix
from .specialise.lanes import joint_pd

__all__ = [
    "DETUMBLE",
    "LAW_FIELDS",
    "OPERATIONAL_SPACE",
    "PROFILES",
    "TRANSPOSED_JACOBIAN",
    "Law",
    "law_control",
    "law_one",
    "make_law",
    "time_scaling",
]

#: The laws, by code (:attr:`Law.setup` [0]).
TRANSPOSED_JACOBIAN, OPERATIONAL_SPACE, DETUMBLE = 1, 2, 3
#: The time scalings of a straight line (:class:`freefloat.control.desired.StraightLine`), by code; -1: a set point.
PROFILES = ("linear", "cubic", "minimum_jerk")

#: A controller as arrays. K is 1 (shared by every trajectory) or B (one row per trajectory), field by field.
LAW_FIELDS = (
    (
        "setup",
        "(7,) int: law code, planar (0/1), quaternion orientations (0/1), force (detumble: 0/1), profile (-1: a set point), "
        "torque by the reaction wheels (0/1), no thruster force (0/1)",
    ),
    ("items", "(I, 2) int: each task item's kind (0 position, 1 orientation) and body"),
    ("points", "(I, 3): each position item's point, its body's frame"),
    ("ints", "the controller model's ints (layout.Tree.ints)"),
    ("floats", "(K, F): the controller model's floats, without passive torques (payload variants per trajectory)"),
    ("kp", "(K, d, d): K_p"),
    ("kd", "(K, d, d): K_d"),
    ("start", "(K, size): z1,des of a set point, or the start of a straight line"),
    ("goal", "(K, size): the goal of a straight line (a set point: = start)"),
    ("zdot", "(K, d): ż1,des of a set point (0 unless the desired motion gave it)"),
    ("zddot", "(K, d): z̈1,des of a set point"),
    ("timing", "(2,): a straight line's duration and start time"),
    ("settings", "(2,): singular_tolerance, null_space_damping"),
    ("limits", "(N + 6,): the controller's own actuator limits on [tau, f_S, n_S] (inf: none)"),
    ("rate_gain", "(K, 6 + N): the detumbling rate gains k (1/s)"),
    ("attitude", "(K, 3, 3): the detumbling's commanded attitude (spacecraft -> inertial)"),
    ("attitude_gain", "(K,): its gain (1/s^2; 0: rates only)"),
    ("lowest", "(K,): written by the loops: the smallest σ_min/σ_max of J_z met at a sample (for the warning after the run)"),
    ("wheel_momentum", "(K, W, 3): Js_i a_i of the controller model's reaction wheels (h_w = Σ Ω_i Js_i a_i, spacecraft frame)"),
    ("wheel_inverse", "(W, 3): A⁺, the pseudo-inverse of the wheels' spin axes A = [a_1 ... a_W] (3, W)"),
    ("wheel_limits", "(K, 2, W): the simulated model's wheel limits [max_torque; max_speed] (N m, rad/s; inf: none)"),
    ("wheel_slot", "(samples,) int: the row of wheel_flags that controller sample k writes (-1: no recorded output holds it)"),
    ("wheel_flags", "(K, R, 2W) bool, written by the loops: [torque saturated (W), speed saturated (W)] at the samples recorded"),
)
Law = namedtuple("Law", [name for name, _ in LAW_FIELDS])  # type: ignore[misc]


@kernel(inline="always")
def _row(a: np.ndarray, b: int) -> int:  # pragma: no cover - compiled
    """The row of a per-trajectory parameter for trajectory b: b when it has one row per trajectory, else 0."""
    return b if a.shape[0] > 1 else 0


@kernel(inline="always")
def time_scaling(profile: int, tau: float) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """(s, ds/dτ, d²s/dτ²) of the time scaling ``profile`` (:data:`PROFILES`) at τ = t / duration, clipped to [0, 1]."""
    tau = min(max(tau, 0.0), 1.0)
    if profile == 0:
        return tau, (1.0 if 0.0 <= tau < 1.0 else 0.0), 0.0
    if profile == 1:
        return 3 * tau**2 - 2 * tau**3, 6 * tau - 6 * tau**2, 6 - 12 * tau
    return (
        10 * tau**3 - 15 * tau**4 + 6 * tau**5,
        30 * tau**2 - 60 * tau**3 + 30 * tau**4,
        60 * tau - 180 * tau**2 + 120 * tau**3,
    )


@kernel(inline="always")
def _wrap(angle: float) -> float:  # pragma: no cover - compiled
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


@kernel(inline="always")
def _quaternion_of(r: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """out = the unit quaternion [x, y, z, w] of the rotation matrix r (scipy's ``Rotation.from_matrix`` method)."""
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    choice = 3
    best = trace
    for i in range(3):
        if r[i, i] > best:
            best = r[i, i]
            choice = i
    if choice != 3:
        i = choice
        j = (i + 1) % 3
        k = (j + 1) % 3
        out[i] = 1.0 - trace + 2.0 * r[i, i]
        out[j] = r[j, i] + r[i, j]
        out[k] = r[k, i] + r[i, k]
        out[3] = r[k, j] - r[j, k]
    else:
        out[0] = r[2, 1] - r[1, 2]
        out[1] = r[0, 2] - r[2, 0]
        out[2] = r[1, 0] - r[0, 1]
        out[3] = 1.0 + trace
    norm = math.sqrt(out[0] * out[0] + out[1] * out[1] + out[2] * out[2] + out[3] * out[3])
    for i in range(4):
        out[i] /= norm


@kernel(inline="always")
def _compose(a: np.ndarray, b: np.ndarray, inverse_b: bool, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """out = a ⊗ b (or a ⊗ b⁻¹), quaternions [x, y, z, w]; the rotation b, then a."""
    s = -1.0 if inverse_b else 1.0
    bx, by, bz, bw = s * b[0], s * b[1], s * b[2], b[3]
    ax, ay, az, aw = a[0], a[1], a[2], a[3]
    out[0] = aw * bx + ax * bw + ay * bz - az * by
    out[1] = aw * by - ax * bz + ay * bw + az * bx
    out[2] = aw * bz + ax * by - ay * bx + az * bw
    out[3] = aw * bw - ax * bx - ay * by - az * bz


@kernel(inline="always")
def _rotation_vector(quat: np.ndarray, out: np.ndarray, o: int) -> None:  # pragma: no cover - compiled
    """out[o : o + 3] = the rotation vector of the unit quaternion ``quat`` (angle in [0, π])."""
    sign = -1.0 if quat[3] < 0.0 else 1.0
    x, y, z, w = sign * quat[0], sign * quat[1], sign * quat[2], sign * quat[3]
    norm = math.sqrt(x * x + y * y + z * z)
    angle = 2.0 * math.atan2(norm, w)
    scale = 2.0 + angle * angle / 12.0 + 7.0 * angle**4 / 2880.0 if angle <= 1e-3 else angle / math.sin(0.5 * angle)
    out[o], out[o + 1], out[o + 2] = scale * x, scale * y, scale * z


@kernel(inline="always")
def _solve3(a: np.ndarray, b: np.ndarray) -> None:  # pragma: no cover - compiled
    """b = a⁻¹ b for a 3 x 3 a (the Euler rate matrix S, 1991 eq. 12), b (3, K), by Cramer's rule."""
    c00 = a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]
    c01 = a[1, 2] * a[2, 0] - a[1, 0] * a[2, 2]
    c02 = a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]
    det = a[0, 0] * c00 + a[0, 1] * c01 + a[0, 2] * c02
    inv = np.empty((3, 3))
    inv[0, 0], inv[1, 0], inv[2, 0] = c00 / det, c01 / det, c02 / det
    inv[0, 1] = (a[0, 2] * a[2, 1] - a[0, 1] * a[2, 2]) / det
    inv[1, 1] = (a[0, 0] * a[2, 2] - a[0, 2] * a[2, 0]) / det
    inv[2, 1] = (a[0, 1] * a[2, 0] - a[0, 0] * a[2, 1]) / det
    inv[0, 2] = (a[0, 1] * a[1, 2] - a[0, 2] * a[1, 1]) / det
    inv[1, 2] = (a[0, 2] * a[1, 0] - a[0, 0] * a[1, 2]) / det
    inv[2, 2] = (a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]) / det
    for c in range(b.shape[1]):
        b0, b1, b2 = b[0, c], b[1, c], b[2, c]
        for i in range(3):
            b[i, c] = inv[i, 0] * b0 + inv[i, 1] * b1 + inv[i, 2] * b2


@kernel()
def task_one(
    L: Any,
    count: int,
    m: Any,
    s: Any,
    x: np.ndarray,
    t0: np.ndarray,
    bias_wanted: bool,
    z: np.ndarray,
    jac: np.ndarray,
    bias: np.ndarray,
    jq: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """z1 (size), J_z (dim, 6 + N) and, when ``bias_wanted``, J̇_z ż0 (dim) of the first ``count`` items of the task in
    ``L`` at the flat state x (attitude matrix t0), inertial frame (:mod:`freefloat.control.tasks` has the layout): J+
    and J̇+ ż0 of each item's point from the engine (1991 eqs. 7-10), turned into the inertial frame; Euler 3-2-1 rates
    through S(Θ) (eq. 12). jq (6, 6 + N): J+ of the spacecraft CM, spacecraft frame (the top of J_q, eq. 21).

    Not inlined (nor are :func:`dynamics_one`, :func:`closeness` and :func:`law_one`): each is compiled on its own,
    once, which keeps the compile of a loop with a law in it short."""
    n = m.n_joints
    planar = L.setup[1] != 0
    quaternions = L.setup[2] != 0
    items = L.items
    bodies = np.empty(count + 1, dtype=np.int64)
    where = np.zeros((count + 1, 3))
    for p in range(count):
        bodies[p] = items[p, 1]
        for i in range(3):
            where[p, i] = L.points[p, i]
    bodies[count] = 0
    for i in range(3):
        where[count, i] = m.com[0, i]
    jp = np.empty((count + 1, 6, 6 + n))
    point_jacobian_one(x[Q_AT : Q_AT + n], m, bodies, where, s, jp)  # spacecraft frame; leaves ⁰T_k and the CM in s
    for i in range(6):
        for c in range(6 + n):
            jq[i, c] = jp[count, i, c]
    rot, pos, cf = s.rot, s.pos, s.cf
    rho = np.empty((count, 3))
    per_mass = 1.0 / m.total_mass  # one division, as in the engine's recursions
    for p in range(count):
        k = bodies[p]
        for i in range(3):
            rho[p, i] = (
                pos[k, i] + rot[k, i, 0] * where[p, 0] + rot[k, i, 1] * where[p, 1] + rot[k, i, 2] * where[p, 2] - cf[0, i] * per_mass
            )
    r_body = np.empty((count, 3, 3))
    for p in range(count):
        k = bodies[p]
        for i in range(3):
            for j in range(3):
                r_body[p, i, j] = t0[i, 0] * rot[k, 0, j] + t0[i, 1] * rot[k, 1, j] + t0[i, 2] * rot[k, 2, j]
    pb = np.zeros((count + 1, 6))
    vel = np.empty(6 + n)
    for i in range(3):
        vel[i] = x[V_CM_AT + i]
        vel[3 + i] = x[OMEGA_AT + i]
    for j in range(n):
        vel[6 + j] = x[qdot_at(n) + j]
    if bias_wanted and count > 0:
        point_bias_one(x[Q_AT : Q_AT + n], vel, m, bodies[:count], where[:count], np.zeros((0, 2), dtype=np.int64), np.zeros((0, 9)), s, pb)
    zi = 0
    vi = 0
    cols = 6 + n
    block = np.empty((3, cols))
    acc = np.empty(3)
    for p in range(count):
        for i in range(3):  # the item's rows into the inertial frame: the r_cm columns are inertial already
            for c in range(cols):
                if items[p, 0] == 0 and c < 3:
                    block[i, c] = jp[p, i, c]
                else:
                    o = 0 if items[p, 0] == 0 else 3
                    block[i, c] = t0[i, 0] * jp[p, o, c] + t0[i, 1] * jp[p, o + 1, c] + t0[i, 2] * jp[p, o + 2, c]
            o = 0 if items[p, 0] == 0 else 3
            acc[i] = t0[i, 0] * pb[p, o] + t0[i, 1] * pb[p, o + 1] + t0[i, 2] * pb[p, o + 2]
        if items[p, 0] == 0:  # a position: r_cm + T0 rho
            rows = 2 if planar else 3
            for i in range(rows):
                z[zi + i] = x[R_CM_AT + i] + t0[i, 0] * rho[p, 0] + t0[i, 1] * rho[p, 1] + t0[i, 2] * rho[p, 2]
                for c in range(cols):
                    jac[vi + i, c] = block[i, c]
                bias[vi + i] = acc[i]
            zi += rows
            vi += rows
        elif planar:  # the yaw θ
            z[zi] = math.atan2(r_body[p, 1, 0], r_body[p, 0, 0])
            for c in range(cols):
                jac[vi, c] = block[2, c]
            bias[vi] = acc[2]
            zi += 1
            vi += 1
        elif quaternions:  # [x, y, z, w]; rates: the inertial ω
            _quaternion_of(r_body[p], z[zi : zi + 4])
            for i in range(3):
                for c in range(cols):
                    jac[vi + i, c] = block[i, c]
                bias[vi + i] = acc[i]
            zi += 4
            vi += 3
        else:  # Euler 3-2-1 Θ = [roll, pitch, yaw] (eq. 11): dΘ/dt = S⁻¹ ω, J̇ ż0 = S⁻¹ (ω̇ at z̈0 = 0 − Ṡ dΘ/dt)
            r = r_body[p]
            pitch = -math.asin(min(1.0, max(-1.0, r[2, 0])))
            roll = math.atan2(r[2, 1], r[2, 2])
            yaw = math.atan2(r[1, 0], r[0, 0])
            z[zi], z[zi + 1], z[zi + 2] = roll, pitch, yaw
            c2, s2, c3, s3 = math.cos(pitch), math.sin(pitch), math.cos(yaw), math.sin(yaw)
            smat = np.zeros((3, 3))
            smat[0, 0], smat[1, 0], smat[2, 0] = c2 * c3, c2 * s3, -s2
            smat[0, 1], smat[1, 1] = -s3, c3
            smat[2, 2] = 1.0
            _solve3(smat, block)
            rates = np.empty((3, 1))
            for i in range(3):
                total = 0.0
                for c in range(cols):
                    total += block[i, c] * vel[c]
                rates[i, 0] = total
            d2, d3 = rates[1, 0], rates[2, 0]
            sdot = np.zeros((3, 3))
            sdot[0, 0] = -s2 * c3 * d2 - c2 * s3 * d3
            sdot[1, 0] = -s2 * s3 * d2 + c2 * c3 * d3
            sdot[2, 0] = -c2 * d2
            sdot[0, 1] = -c3 * d3
            sdot[1, 1] = -s3 * d3
            rhs = np.empty((3, 1))
            for i in range(3):
                rhs[i, 0] = acc[i] - (sdot[i, 0] * rates[0, 0] + sdot[i, 1] * rates[1, 0] + sdot[i, 2] * rates[2, 0])
            _solve3(smat, rhs)
            for i in range(3):
                for c in range(cols):
                    jac[vi + i, c] = block[i, c]
                bias[vi + i] = rhs[i, 0]
            zi += 3
            vi += 3


#: The kinds of task items by their rows (:func:`item_rows`).
POSITION, ANGLES, QUATERNION = 0, 1, 2


@kernel(inline="always")
def item_rows(L: Any, p: int) -> tuple[int, int, int]:  # pragma: no cover - compiled
    """(rows of z, rows of ż, kind) of item p of the task in ``L``: a position (2 planar, else 3), angles (θ planar;
    Euler 3-2-1) or a quaternion (4 rows of z, 3 of ż)."""
    planar = L.setup[1] != 0
    if L.items[p, 0] == 0:
        rows = 2 if planar else 3
        return rows, rows, POSITION
    if planar:
        return 1, 1, ANGLES
    if L.setup[2] != 0:
        return 4, 3, QUATERNION
    return 3, 3, ANGLES


@kernel(inline="always")
def task_error(L: Any, desired: np.ndarray, actual: np.ndarray, e: np.ndarray) -> None:  # pragma: no cover - compiled
    """e = z1,des ⊖ z1 (1991 eq. 26): differences; angles wrapped to [−π, π); quaternions 2 sign(w_e) vec(q_des ⊗ q⁻¹)."""
    zi = 0
    vi = 0
    qe = np.empty(4)
    for p in range(L.items.shape[0]):
        nz, nv, kind = item_rows(L, p)
        if kind == QUATERNION:
            _compose(desired[zi : zi + 4], actual[zi : zi + 4], True, qe)
            sign = -1.0 if qe[3] < 0.0 else 1.0
            norm = math.sqrt(qe[0] * qe[0] + qe[1] * qe[1] + qe[2] * qe[2] + qe[3] * qe[3])
            for i in range(3):
                e[vi + i] = 2.0 * sign * qe[i] / norm
        else:
            for i in range(nz):
                diff = desired[zi + i] - actual[zi + i]
                e[vi + i] = diff if kind == POSITION else _wrap(diff)
        zi += nz
        vi += nv


@kernel(inline="always")
def desired_one(L: Any, b: int, t: float, z: np.ndarray, zdot: np.ndarray, zddot: np.ndarray) -> None:  # pragma: no cover - compiled
    """z1,des, ż1,des, z̈1,des at time t: a set point (with the rates it was given), or a straight line from start to goal
    with its time scaling (positions and angles linear, angles along the wrapped difference, quaternions by slerp)."""
    profile = L.setup[4]
    start, goal = L.start[_row(L.start, b)], L.goal[_row(L.goal, b)]
    if profile < 0:
        for i in range(z.shape[0]):
            z[i] = start[i]
        r1, r2 = _row(L.zdot, b), _row(L.zddot, b)
        for i in range(zdot.shape[0]):
            zdot[i] = L.zdot[r1, i]
            zddot[i] = L.zddot[r2, i]
        return
    duration, start_time = L.timing[0], L.timing[1]
    sc, ds, dds = time_scaling(profile, (t - start_time) / duration)
    direction = zdot  # the straight line's direction in ż coordinates, scaled below
    task_error(L, goal, start, direction)
    zi = 0
    vi = 0
    turn = np.empty(4)
    for p in range(L.items.shape[0]):
        nz, nv, kind = item_rows(L, p)
        if kind != QUATERNION:
            for i in range(nz):
                z[zi + i] = start[zi + i] + sc * direction[vi + i]
        else:  # slerp: exp(s φ) q_start, φ the inertial rotation vector from start to goal
            _compose(goal[zi : zi + 4], start[zi : zi + 4], True, turn)
            _rotation_vector(turn, direction, vi)
            angle = sc * math.sqrt(direction[vi] ** 2 + direction[vi + 1] ** 2 + direction[vi + 2] ** 2)
            half = 0.5 * angle
            k = 0.5 * sc * (1.0 - half * half / 6.0) if half < 1e-8 else math.sin(half) * sc / angle
            for i in range(3):
                turn[i] = k * direction[vi + i]
            turn[3] = math.cos(half)
            norm = math.sqrt(start[zi] ** 2 + start[zi + 1] ** 2 + start[zi + 2] ** 2 + start[zi + 3] ** 2)
            unit = np.empty(4)
            for i in range(4):
                unit[i] = start[zi + i] / norm
            _compose(turn, unit, False, z[zi : zi + 4])
        zi += nz
        vi += nv
    for i in range(zdot.shape[0]):
        zddot[i] = direction[i] * dds / duration**2
        zdot[i] = direction[i] * ds / duration


@kernel()
def damped_inverse(a: np.ndarray, closeness: float, tolerance: float) -> np.ndarray:  # pragma: no cover - compiled
    """(J_z H+⁻¹ J_zᵀ)⁻¹ damped near a singular J_z: 1/a_i -> a_i / (a_i² + λ²), λ² = (1 − (r/ε)²)(ε a_max)² when r < ε."""
    vals, vecs = np.linalg.eigh(a)
    dim = a.shape[0]
    out = np.zeros((dim, dim))
    a_max = max(vals[dim - 1], 0.0)
    if a_max <= 0.0:
        return out
    lam2 = (1.0 - (closeness / tolerance) ** 2) * (tolerance * a_max) ** 2 if closeness < tolerance else 0.0
    inv = np.empty(dim)
    for i in range(dim):
        v = max(vals[i], 0.0)
        if lam2 > 0.0:
            inv[i] = v / (v * v + lam2) if v > 0.0 else 0.0
        else:
            inv[i] = 1.0 / v if v > 0.0 else math.inf
    for i in range(dim):
        for j in range(dim):
            total = 0.0
            for k in range(dim):
                total += vecs[i, k] * inv[k] * vecs[j, k]
            out[i, j] = total
    return out


@kernel()
def closeness(jac: np.ndarray) -> float:  # pragma: no cover - compiled
    """σ_min/σ_max of J_z (0 when it has more rows than columns), by the engine's singular values."""
    rows, cols = jac.shape
    if rows > cols:
        return 0.0
    work = np.empty(rows * cols + measure_work(cols))
    for r in range(rows):
        for c in range(cols):
            work[r * cols + c] = jac[r, c]
    out = np.empty(1)
    chosen = np.arange(rows)
    jacobian_measure_lanes(work, 0, 1, cols, chosen, 3, work[rows * cols :], out, 0, 1)  # the condition number
    return 1.0 / out[0] if out[0] > 0.0 else 0.0


@kernel()
def dynamics_one(q: np.ndarray, vel: np.ndarray, t0: np.ndarray, m: Any, s: Any, h: np.ndarray, c: np.ndarray) -> None:  # pragma: no cover
    """H+ (1991 eq. 15) and C+ (eq. 19; no passive torques in ``m``: the laws' model has none) at q and ż0 = ``vel``."""
    hplus_one(q, m, s, h)
    zero = np.zeros(vel.shape[0])
    inverse_one(q, vel, zero, False, zero, t0, m, np.zeros((0, 2), dtype=np.int64), np.zeros((0, 9)), s, c)


@kernel()
def law_one(
    L: Any, b: int, t: float, x: np.ndarray, s: Any, u: np.ndarray, e: np.ndarray, edot: np.ndarray, qc: np.ndarray
) -> float:  # pragma: no cover - compiled
    """The actuation u = [τ, f_S, n_S] (N + 6; spacecraft frame, before the controller's limits) of the law ``L`` for
    trajectory b at time t and the flat state x; e, ė (dim; the detumbling: unused) and Q_c (6 + N, first block
    inertial) written too. Returns σ_min/σ_max of J_z (the detumbling: 1). ``s``: the engine's scratch views."""
    m = arrays(L.ints, L.floats[_row(L.floats, b)])
    n = m.n_joints
    cols = 6 + n
    code = L.setup[0]
    t0 = np.empty((3, 3))
    quaternion_matrix(x, ATTITUDE_AT, t0)
    q = x[Q_AT : Q_AT + n].copy()
    vel = np.empty(cols)
    for i in range(3):
        vel[i] = x[V_CM_AT + i]
        vel[3 + i] = x[OMEGA_AT + i]
    for j in range(n):
        vel[6 + j] = x[qdot_at(n) + j]
    ratio = 1.0
    dim = e.shape[0]
    jq = np.empty((6, cols))  # J+ of the spacecraft CM: the top rows of J_q (eq. 21)
    # the task (none for the detumbling: J_q only); one call site, so that task_one is compiled once, for one signature
    tasked = code != DETUMBLE
    size, rows = (L.start.shape[1], dim) if tasked else (0, 0)
    z, jac, bias = np.empty(size), np.empty((rows, cols)), np.empty(rows)
    task_one(L, L.items.shape[0] if tasked else 0, m, s, x, t0, code == OPERATIONAL_SPACE, z, jac, bias, jq)
    if not tasked:
        acc = np.empty(cols)
        k_row = _row(L.rate_gain, b)
        for i in range(cols):
            acc[i] = -L.rate_gain[k_row, i] * vel[i]
        a_row = _row(L.attitude_gain, b)
        if L.attitude_gain[a_row] > 0.0:  # ω̇0 += K_att e, e the rotation vector of T0ᵀ T0,des
            target = L.attitude[_row(L.attitude, b)]
            rel = np.empty((3, 3))
            for i in range(3):
                for j in range(3):
                    rel[i, j] = t0[0, i] * target[0, j] + t0[1, i] * target[1, j] + t0[2, i] * target[2, j]
            quat = np.empty(4)
            _quaternion_of(rel, quat)
            err = np.empty(3)
            _rotation_vector(quat, err, 0)
            for i in range(3):
                acc[3 + i] += L.attitude_gain[a_row] * err[i]
        if L.setup[3] == 0:
            for i in range(3):
                acc[i] = 0.0
        h = np.empty((cols, cols))
        dynamics_one(q, vel, t0, m, s, h, qc)  # H+, and C+ into Q_c
        for i in range(cols):
            total = 0.0
            for j in range(cols):
                total += h[i, j] * acc[j]
            qc[i] += total
        if L.setup[3] == 0:
            for i in range(3):
                qc[i] = 0.0  # C+ has no r_cm rows: the CM is left alone
    else:
        zd, zdd, zddd = np.empty(size), np.empty(dim), np.empty(dim)
        desired_one(L, b, t, zd, zdd, zddd)
        task_error(L, zd, z, e)
        for i in range(dim):
            total = 0.0
            for c in range(cols):
                total += jac[i, c] * vel[c]
            edot[i] = zdd[i] - total
        kp, kd = L.kp[_row(L.kp, b)], L.kd[_row(L.kd, b)]
        command = np.empty(dim)
        for i in range(dim):
            total = zddd[i] if code == OPERATIONAL_SPACE else 0.0
            for j in range(dim):
                total += kp[i, j] * e[j] + kd[i, j] * edot[j]
            command[i] = total
        ratio = closeness(jac)
        tolerance, damping = L.settings[0], L.settings[1]
        if code == TRANSPOSED_JACOBIAN:
            for c in range(cols):
                total = 0.0
                for i in range(dim):
                    total += jac[i, c] * command[i]
                qc[c] = total
            if damping > 0.0:  # − d (ż0 − J_z⁺ J_z ż0), J_z⁺ cut at rcond = the singular tolerance
                task_part = np.linalg.pinv(jac, rcond=tolerance) @ (jac @ vel)
                for c in range(cols):
                    qc[c] -= damping * (vel[c] - task_part[c])
        else:
            h, c_plus = np.empty((cols, cols)), np.empty(cols)
            dynamics_one(q, vel, t0, m, s, h, c_plus)
            h_inv_jt = np.linalg.solve(h, np.ascontiguousarray(jac.T))
            h_tilde = damped_inverse(jac @ h_inv_jt, ratio, tolerance)
            j_bar = h_inv_jt @ h_tilde
            c_tilde = j_bar.T @ c_plus - h_tilde @ bias
            force = jac.T @ (h_tilde @ command + c_tilde)
            for c in range(cols):
                qc[c] = force[c]
            if damping > 0.0:  # − d (1 − J_zᵀ J̄ᵀ) ż0: no disturbance of the task (eq. 27)
                task_part = jac.T @ (j_bar.T @ vel)
                for c in range(cols):
                    qc[c] -= damping * (vel[c] - task_part[c])
    # eq. 30: [f_S; n_S; τ] = J_q⁻ᵀ Q_c, J_q = [J+ of the spacecraft CM (spacecraft frame); 0 1] (eq. 21)
    q0 = np.empty(cols)
    for i in range(3):
        q0[i] = t0[0, i] * qc[0] + t0[1, i] * qc[1] + t0[2, i] * qc[2]  # Q's first block into the spacecraft frame
    for i in range(3, cols):
        q0[i] = qc[i]
    for i in range(3):  # f_S, then n_S = Q_ω − J11ᵀ f_S
        u[n + i] = q0[i]
    for i in range(3):
        total = q0[3 + i]
        for j in range(3):
            total -= jq[j, 3 + i] * u[n + j]
        u[n + 3 + i] = total
    for c in range(n):  # τ = Q_q − J12ᵀ f_S − J22ᵀ n_S
        total = q0[6 + c]
        for j in range(3):
            total -= jq[j, 6 + c] * u[n + j] + jq[3 + j, 6 + c] * u[n + 3 + j]
        u[c] = total
    return ratio


@kernel(inline="always")
def wheel_routing(L: Any, b: int, omega: np.ndarray, speed: np.ndarray, u: np.ndarray, wheel: np.ndarray) -> None:  # pragma: no cover
    """The actuation u = [τ, f_S, n_S] (N + 6) of a law routed as its controller says (setup [5], [6]): with the torque by
    the reaction wheels, their motor torques wheel (W,) = −A⁺ (n_S + ω0 × h_w), h_w = Σ_i Ω_i Js_i a_i (``speed`` Ω (W,)
    relative to the spacecraft, ``omega`` ω0 (3,), spacecraft frame), and n_S = 0; with no thruster force, f_S = 0. The
    numpy form, the reference ``tests/simulation/test_wheel_rollouts.py`` checks this one against:
    :func:`freefloat.control.wheels.wheel_torques` and ``route_actuation``."""
    n = u.shape[0] - 6
    if L.setup[5] != 0:
        spin = L.wheel_momentum[_row(L.wheel_momentum, b)]
        h = np.zeros(3)
        for i in range(wheel.shape[0]):
            for j in range(3):
                h[j] += speed[i] * spin[i, j]
        d0 = u[n + 3] + (omega[1] * h[2] - omega[2] * h[1])
        d1 = u[n + 4] + (omega[2] * h[0] - omega[0] * h[2])
        d2 = u[n + 5] + (omega[0] * h[1] - omega[1] * h[0])
        inv = L.wheel_inverse
        for i in range(wheel.shape[0]):
            wheel[i] = -d0 * inv[i, 0] + -d1 * inv[i, 1] + -d2 * inv[i, 2]
        for i in range(3):
            u[n + 3 + i] = 0.0
    if L.setup[6] != 0:
        for i in range(3):
            u[n + i] = 0.0


@kernel(inline="always")
def wheel_limits(limits: np.ndarray, speed: np.ndarray, wheel: np.ndarray, flags: np.ndarray) -> bool:  # pragma: no cover
    """The motor torques the wheels apply for the commands ``wheel`` (W,), in place, at the speeds ``speed`` (W,), rad/s,
    as Basilisk's reaction-wheel model: a command beyond max_torque (``limits[0]``) clipped to it; a wheel at or beyond
    max_speed (``limits[1]``) given no torque that would spin it faster (zero). flags (2W,) = [torque saturated, speed
    saturated]; True if any. The numpy form: ``freefloat.simulation._wheels.limit_wheel_torque``."""
    w = wheel.shape[0]
    limited = False
    for i in range(w):
        command = wheel[i]
        applied = min(max(command, -limits[0, i]), limits[0, i])
        clipped = applied != command
        stopped = abs(speed[i]) >= limits[1, i] and applied * speed[i] > 0.0
        wheel[i] = 0.0 if stopped else applied
        flags[i] = clipped
        flags[w + i] = stopped
        limited = limited or clipped or stopped
    return limited


@kernel(inline="always")
def law_control(
    C: Any, P: Any, sample: int, t: float, b: int, lim: np.ndarray, x: np.ndarray, x0: int, u: np.ndarray, u0: int, step: int
) -> bool:  # pragma: no cover - compiled
    """The controller of the generic rollout loop (``specialise.lanes._rollout_blocks``, one lane wide: ``step`` 1), C = (the
    joint PD's arrays, a :data:`Law`): the joint PD (:func:`~.specialise.lanes.joint_pd`) when the law's code is 0, else
    :func:`law_one` at the state x[x0 ...] of trajectory b at time t, routed (:func:`wheel_routing`), clipped to the
    controller's own limits, then to the simulation's +-lim (True if any component was: as ``ActuatorLimits.apply`` of
    the controller, then of the simulation), the wheels' torques to their limits (:func:`wheel_limits`; True if one
    acted, and its flags written to ``wheel_flags`` when an output records this sample), written to u[u0 ...]; P = (plant
    model, ext_i, ext_f, scratch).

    The plant may hold W reaction wheels as its last joints (:func:`freefloat.core.wheels.wheel_joint_model`): its state
    [r_cm, v_cm, quat, ω0, q (N), wheel angles (W), q̇ (N), wheel speeds (W)] and its u [τ (N), wheel torques (W), f_S,
    n_S], lim alike; the law sees the controller's state [.., q, q̇] of its N joints."""
    L = C[1]
    if L.setup[0] == 0:
        return joint_pd(C[0], P, sample, t, b, lim, x, x0, u, u0, step)
    s = P[3]
    n = L.ints[2]
    w = P[0].n_joints - n  # the plant's reaction wheels
    dim = L.kp.shape[1]
    e, edot, qc = np.empty(dim), np.empty(dim), np.empty(6 + n)
    xc = np.empty(state_length(n))  # the controller's flat state: the plant's without the wheel angles and speeds
    for i in range(Q_AT + n):
        xc[i] = x[x0 + i]
    rates = x0 + qdot_at(n + w)  # the plant's rates: the joints', then the wheels'
    for j in range(n):
        xc[qdot_at(n) + j] = x[rates + j]
    speed = x[rates + n : rates + n + w]
    out = np.empty(n + 6)
    ratio = law_one(L, b, t, xc, s, out, e, edot, qc)
    seen = _row(L.lowest, b)
    L.lowest[seen] = min(L.lowest[seen], ratio)
    wheel = np.zeros(w)
    wheel_routing(L, b, xc[OMEGA_AT : OMEGA_AT + 3], speed, out, wheel)
    sat = False
    for j in range(n + 6):
        out[j] = min(max(out[j], -L.limits[j]), L.limits[j])  # the controller's own limits (no flag: an extra of its output)
        k = j if j < n else j + w  # its entry of the plant's lim
        if out[j] > lim[k]:
            out[j] = lim[k]
            sat = True
        elif out[j] < -lim[k]:
            out[j] = -lim[k]
            sat = True
    if w > 0:
        flags = np.zeros(2 * w, dtype=np.bool_)
        sat = wheel_limits(L.wheel_limits[_row(L.wheel_limits, b)], speed, wheel, flags) or sat
        slot = L.wheel_slot[sample] if sample < L.wheel_slot.shape[0] else -1
        if slot >= 0:
            record = L.wheel_flags[_row(L.wheel_flags, b), slot]
            for i in range(2 * w):
                record[i] = flags[i]
    for j in range(n):
        u[u0 + j] = out[j]
    for i in range(w):
        u[u0 + n + i] = wheel[i]
    for j in range(6):
        u[u0 + n + w + j] = out[n + j]
    return sat


def make_law(ints: np.ndarray, floats: np.ndarray, **given: Any) -> Any:
    """A :data:`Law` of the given fields (arrays), the others empty; every array C-contiguous, writable and of one
    dtype and rank per field, so that one compiled kernel serves every controller. ``ints``, ``floats``: the
    controller model's buffers (floats (K, F)). Without fields: no law (code 0: the joint PD of the rollouts)."""
    n = int(ints[2])
    fields: dict[str, Any] = {
        "setup": np.array([0, 0, 0, 1, -1, 0, 0]),
        "items": np.zeros((1, 2)),
        "points": np.zeros((1, 3)),
        "ints": ints,
        "floats": floats,
        "kp": np.zeros((1, 1, 1)),
        "kd": np.zeros((1, 1, 1)),
        "start": np.zeros((1, 1)),
        "goal": np.zeros((1, 1)),
        "zdot": np.zeros((1, 1)),
        "zddot": np.zeros((1, 1)),
        "timing": np.zeros(2),
        "settings": np.zeros(2),
        "limits": np.full(n + 6, np.inf),
        "rate_gain": np.zeros((1, 1)),
        "attitude": np.eye(3)[None],
        "attitude_gain": np.zeros(1),
        "lowest": np.ones(1),
        "wheel_momentum": np.zeros((1, 0, 3)),
        "wheel_inverse": np.zeros((0, 3)),
        "wheel_limits": np.zeros((1, 2, 0)),
        "wheel_slot": np.zeros(0),
        "wheel_flags": np.zeros((1, 0, 0)),
        **given,
    }
    kinds = {"setup": np.int64, "items": np.int64, "ints": np.int64, "wheel_slot": np.int64, "wheel_flags": np.bool_}
    names: list[str] = [name for name, _ in LAW_FIELDS]
    return Law(**{name: np.array(fields[name], dtype=kinds.get(name, np.float64)) for name in names})


def same_structure(a: Any, b: Any) -> bool:
    """Whether two models' :class:`~.layout.Tree` have one structure (the same ints and "structure" fields: payload
    variants of one robot), so that one compiled law or loop runs both with per-trajectory mass properties."""
    if a.ints.shape != b.ints.shape or not np.array_equal(a.ints, b.ints):
        return False
    return all(np.array_equal(a.fields[f.name], b.fields[f.name]) for f in BODY_FIELDS if f.role == "structure")


def actuator_bounds(limits: Any, n: int, wheels: int = 0) -> np.ndarray:
    """An ``ActuatorLimits`` (or None) as the (N + W + 6,) bounds of [tau (N), wheel torques (W), f_S, n_S] that the
    loops clip to (inf: none; the W reaction wheels have their own limits, :func:`wheel_limits`); its own checks first
    (the errors of ``ActuatorLimits.apply``)."""
    out = np.full(n + wheels + 6, np.inf)
    if limits is None:
        return out
    limits.apply(np.zeros(n), np.zeros(3), np.zeros(3))
    for sl, value in (
        (slice(0, n), limits.joint_torque),
        (slice(n + wheels, n + wheels + 3), limits.spacecraft_force),
        (slice(n + wheels + 3, n + wheels + 6), limits.spacecraft_torque),
    ):
        if value is not None:
            out[sl] = np.broadcast_to(np.asarray(value, dtype=float), out[sl].shape)
    return out
