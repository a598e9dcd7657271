"""The Python side of every engine call: the fast path of the physics, called with batches of any shape.

Each call takes a model and arrays with any leading batch shape (broadcast against each other), flattens them, runs
one batch driver of :mod:`.drivers` (in the calling thread for small batches, on numba's threads for large ones: the
same compiled kernel) and gives the batch shape back. J*, the measures of J*, H+, forward and inverse dynamics batches
and rollouts (with or without external wrenches) take the kernels specialised to the model's structure (and the
wrenches' layout) instead when :func:`~freefloat.mechanics.specialise` or the automatic specialisation made them
(:mod:`.specialise.build`; the same recursions, traced). Inputs are checked by the public functions that call these;
here they are only made contiguous float64. The calls whose result is one large array take ``out``: the caller's array
of the result's shape (float64, C-contiguous, writable; :func:`~.buffers.check_out`), which they fill and return
instead of a new one.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from ..core.state_layout import state_length
from . import drivers as _drivers
from . import gate, stepper
from . import laws as _laws
from .buffers import new_output, owned
from .folders import compile_seconds
from .layout import Tree, tree, work_size
from .measures import MEASURE_CODES
from .specialise import build as _specialise
from .specialise.lanes import LANES, feed

__all__ = [
    "NO_WRENCHES",
    "Stepper",
    "accelerations",
    "frames",
    "generalized_jacobian",
    "inertia_matrix",
    "inertia_matrix_rate",
    "jacobian_measures",
    "law_rollout",
    "point_biases",
    "point_jacobians",
    "points",
    "residual_rows",
    "rk4_batch",
    "rollout",
    "specialised_rollouts",
    "state_derivative",
]

#: No external wrenches: (ext_i (0, 2), ext_f (0, 9)).
NO_WRENCHES: tuple[np.ndarray, np.ndarray] = (np.zeros((0, 2), dtype=np.int64), np.zeros((0, 9)))


#: Batches of J* at least this large use the specialised kernels of the model's structure, when made.
_SPECIALISED_MIN = 64
#: Rollouts of at least this many trajectories use them (a lane block computes 64; about 8 pay for it).
_SPECIALISED_ROLLOUTS_MIN = 8


def _flat(arr: np.ndarray, batch: tuple[int, ...], core: tuple[int, ...]) -> np.ndarray:
    """arr broadcast to batch + core, as a C-contiguous, writable float64 (C, *core) array."""
    size = math.prod(map(int, batch))
    target = batch + core
    arr = np.asarray(arr)
    return owned(arr if arr.shape == target else np.broadcast_to(arr, target)).reshape((size, *core))


def _batch(*arrays: tuple[np.ndarray, int]) -> tuple[int, ...]:
    """The broadcast batch shape of arrays given with their number of core axes."""
    return np.broadcast_shapes(*(a.shape[: a.ndim - core] for a, core in arrays))


def _wrench_data(ext: tuple[np.ndarray, np.ndarray], batch: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    ext_i, ext_f = ext
    return owned(ext_i, np.int64), _flat(ext_f, batch, ext_f.shape[-2:])


def frames(model: Any, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(⁰T_k (..., B, 3, 3), body frame origins from O (..., B, 3)), spacecraft frame."""
    t = tree(model)
    batch = q.shape[:-1]
    flat = _flat(q, batch, (t.n_joints,))
    n_b = t.parent.shape[0]
    rot = new_output((flat.shape[0], n_b, 3, 3))
    pos = new_output((flat.shape[0], n_b, 3))
    _drivers.frames_batch(flat.shape[0], t, _drivers.FramesCall(q=flat, rot=rot, pos=pos))
    return rot.reshape((*batch, n_b, 3, 3)), pos.reshape((*batch, n_b, 3))


def _point_data(bodies: Any, pts: Any) -> tuple[np.ndarray, np.ndarray]:
    b = owned(np.atleast_1d(np.asarray(bodies, dtype=np.int64)), np.int64)
    p = owned(np.asarray(pts, dtype=np.float64).reshape(-1, 3))
    return b, p


def points(model: Any, q: np.ndarray, bodies: Any, pts: Any) -> np.ndarray:
    """Points ``pts`` (P, 3, body frames of ``bodies``) relative to the system CM, spacecraft frame, (..., P, 3)."""
    t = tree(model)
    b, p = _point_data(bodies, pts)
    batch = q.shape[:-1]
    flat = _flat(q, batch, (t.n_joints,))
    out = new_output((flat.shape[0], b.shape[0], 3))
    _drivers.points_batch(flat.shape[0], t, _drivers.PointsCall(q=flat, bodies=b, points=p, out=out))
    return out.reshape((*batch, b.shape[0], 3))


def point_jacobians(model: Any, q: np.ndarray, bodies: Any, pts: Any) -> np.ndarray:
    """J+ of points ``pts`` of ``bodies``, (..., P, 6, 6 + N), spacecraft frame (1991 eqs. 7-10)."""
    t = tree(model)
    b, p = _point_data(bodies, pts)
    batch = q.shape[:-1]
    flat = _flat(q, batch, (t.n_joints,))
    out = new_output((flat.shape[0], b.shape[0], 6, 6 + t.n_joints))
    _drivers.point_jacobian_batch(flat.shape[0], t, _drivers.PointsCall(q=flat, bodies=b, points=p, out=out))
    return out.reshape((*batch, b.shape[0], 6, 6 + t.n_joints))


def point_biases(model: Any, q: np.ndarray, velocity: np.ndarray, bodies: Any, pts: Any) -> np.ndarray:
    """Jdot+ zdot0 of points ``pts`` (P, 3, body frames of ``bodies``) at q and zdot0 = ``velocity`` (..., 6 + N):
    [point acceleration; body angular acceleration] at zddot0 = 0, spacecraft frame, (..., P, 6)."""
    t = tree(model)
    b, p = _point_data(bodies, pts)
    batch = _batch((q, 1), (velocity, 1))
    qf = _flat(q, batch, (t.n_joints,))
    vf = _flat(velocity, batch, (6 + t.n_joints,))
    out = new_output((qf.shape[0], b.shape[0], 6))
    ext_i, ext_f = NO_WRENCHES
    _drivers.point_bias_batch(qf.shape[0], t, _drivers.PointBiasCall(q=qf, v=vf, bodies=b, points=p, ext_i=ext_i, ext=ext_f, out=out))
    return out.reshape((*batch, b.shape[0], 6))


def generalized_jacobian(model: Any, q: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """J* (..., 6E, N), spacecraft frame (1992 eq. 14); into ``out`` when given (then returned)."""
    t = tree(model)
    batch = q.shape[:-1]
    rows = 6 * t.ee_body.shape[0]
    result = new_output((*batch, rows, t.n_joints), out=out)
    flat = _flat(q, batch, (t.n_joints,))
    size = flat.shape[0]
    if not _specialised_map(t, "jstar", (flat,), result.reshape((size, rows * t.n_joints))):
        call = _drivers.MapCall(q=flat, out=result.reshape((size, rows, t.n_joints)))
        _timed(t, "jstar", size, _drivers.jstar_batch, size, t, call)
    return result


def jacobian_measures(model: Any, q: np.ndarray, rows: Any, measure: str, out: np.ndarray | None = None) -> np.ndarray:
    """A measure (``"det"``, ``"sigma_min"``, ``"manipulability"``, ``"condition"``) of the rows ``rows`` of J* at
    each configuration, (...): computed in the kernel a lane block of configurations at a time, no J* batch written
    (the specialised kernel of the model's structure, kind "measure", when made; the rows must be distinct: they are
    reduced in place, in the block's buffer); into
    ``out`` (...) when given (then returned)."""
    t = tree(model)
    batch = q.shape[:-1]
    result = new_output(batch, out=out)
    flat = _flat(q, batch, (t.n_joints,))
    r = owned(np.atleast_1d(np.asarray(rows, dtype=np.int64)), np.int64)
    code = MEASURE_CODES[measure]
    out = result.reshape((flat.shape[0],))
    fast = _specialise.find(t, "measure") if flat.shape[0] >= _SPECIALISED_MIN else None
    if fast is not None:
        _specialise.measured(fast, t, flat, r, code, out)
    else:
        blocks = -(-flat.shape[0] // LANES)  # the generic measure's rows are lane blocks too
        _timed(t, "measure", flat.shape[0], _drivers.measure_batch, blocks, t, _drivers.MeasureCall(q=flat, rows=r, kind=code, out=out))
    return result


def _specialised_map(t: Tree, kind: str, parts: Any, out: np.ndarray, wrenches: _specialise.Layout = ()) -> bool:
    """Run the specialised kernel of the map ``kind`` when made for ``t``'s structure (and the external wrenches'
    layout ``wrenches``) and the batch is large enough: ``parts`` its inputs (:func:`_part` each; or a function making
    them), ``out`` (C, outputs); False when it did not run."""
    size = out.shape[0]
    fast = _specialise.find(t, kind, wrenches) if size >= _SPECIALISED_MIN else None
    if fast is None:
        return False
    _specialise.mapped(fast, t, tuple(parts() if callable(parts) else parts), out.reshape((size, -1)))
    return True


def _part(arr: np.ndarray | None, batch: tuple[int, ...], width: int) -> np.ndarray:
    """An input of a specialised map (:func:`~.specialise.build.map_parts`): ``arr`` (..., width) as the rows (C, width) of
    the batch ``batch``, or as one row (1, width) that every configuration shares (None: zeros); C-contiguous,
    writable float64, a copy only when needed (the kernel reads each row into its lanes: no broadcast copy)."""
    if arr is None:
        return np.zeros((1, width))
    arr = np.asarray(arr)
    if arr.shape[:-1] != batch and arr.size == width:
        return owned(arr).reshape((1, width))
    return _flat(arr, batch, (width,))


def _timed(t: Tree, kind: str, counted: int, driver: Any, *args: Any, wrenches: _specialise.Layout = ()) -> None:
    """``driver(*args)`` on the generic kernels; its time is counted towards specialising ``kind`` (for the external
    wrenches' layout ``wrenches``) when ``counted`` (the batch size) is at least the specialised kernels' minimum."""
    start = time.perf_counter()
    with _specialise.sharing():  # a background compile running: leave it a core
        driver(*args)
    if counted >= _SPECIALISED_MIN and driver.compiled:  # work they would take (not a first compile)
        _specialise.account(t, kind, time.perf_counter() - start, wrenches)


def inertia_matrix(model: Any, q: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """H+ (..., 6 + N, 6 + N), order [r_cm, omega0, q] (1991 eq. 15); into ``out`` when given (then returned)."""
    t = tree(model)
    batch = q.shape[:-1]
    size = 6 + t.n_joints
    result = new_output((*batch, size, size), out=out)
    flat = _flat(q, batch, (t.n_joints,))
    c = flat.shape[0]
    if not _specialised_map(t, "hplus", (flat,), result.reshape((c, size * size))):
        _timed(t, "hplus", c, _drivers.hplus_batch, c, t, _drivers.MapCall(q=flat, out=result.reshape((c, size, size))))
    return result


def inertia_matrix_rate(model: Any, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
    """dH+/dt along the joint rates qdot, (..., 6 + N, 6 + N), order [r_cm, omega0, q]."""
    t = tree(model)
    batch = _batch((q, 1), (qdot, 1))
    qf = _flat(q, batch, (t.n_joints,))
    vf = _flat(qdot, batch, (t.n_joints,))
    size = 6 + t.n_joints
    out = new_output((qf.shape[0], size, size))
    _drivers.hplus_rate_batch(qf.shape[0], t, _drivers.HplusRateCall(q=qf, qdot=vf, out=out))
    return out.reshape((*batch, size, size))


#: An actuation u = [tau (N), f_S (3), n_S (3)]: an array (..., N + 6), or its three parts (each None: zero), or None (zero).
Actuation = np.ndarray | tuple[np.ndarray | None, ...] | None


def _actuation(u: Actuation, t: Tree, batch: tuple[int, ...]) -> np.ndarray:
    """u = [tau (N), f_S (3), n_S (3)] flat (C, N + 6); None is zero."""
    size = math.prod(map(int, batch))
    if u is None:
        return np.zeros((size, t.n_joints + 6))
    if isinstance(u, tuple):
        out = np.zeros((size, t.n_joints + 6))
        at = 0
        for part, width in zip(u, (t.n_joints, 3, 3), strict=True):
            if part is not None:
                out[:, at : at + width] = np.broadcast_to(part, (*batch, width)).reshape((size, width))
            at += width
        return out
    return _flat(u, batch, (t.n_joints + 6,))


def _split_actuation(u: Actuation, n: int) -> tuple[np.ndarray | None, ...]:
    """The three parts (tau, f_S, n_S) of the actuation ``u`` (None: zero)."""
    if u is None:
        return (None, None, None)
    if isinstance(u, tuple):
        return u
    return (u[..., :n], u[..., n : n + 3], u[..., n + 3 :])


def _attitude_rows(t0: np.ndarray | None) -> np.ndarray:
    """The attitude T0 (..., 3, 3) as rows (..., 9), row-major; None: the identity."""
    return np.eye(3).reshape(9) if t0 is None else np.asarray(t0).reshape((*np.shape(t0)[:-2], 9))


def _attitudes(t0: np.ndarray | None, batch: tuple[int, ...]) -> np.ndarray:
    return _flat(np.eye(3) if t0 is None else t0, batch, (3, 3))


def _dynamics_batch(
    q: np.ndarray, velocity: np.ndarray, u: Actuation, t0: np.ndarray | None, ext: tuple[np.ndarray, np.ndarray], *extra: np.ndarray
) -> tuple[int, ...]:
    """The broadcast batch shape of a dynamics call's inputs."""
    parts = [] if u is None else [p for p in (u if isinstance(u, tuple) else (u,)) if p is not None]
    return _batch(
        (q, 1), (velocity, 1), (ext[1], 2), *((e, 1) for e in extra), *((p, 1) for p in parts), *(() if t0 is None else ((t0, 2),))
    )


def _dynamics_inputs(
    t: Tree,
    q: np.ndarray,
    velocity: np.ndarray,
    u: Actuation,
    t0: np.ndarray | None,
    ext: tuple[np.ndarray, np.ndarray],
    *extra: np.ndarray,
) -> tuple[tuple[int, ...], list[np.ndarray]]:
    """The broadcast batch shape and the flat inputs [q, velocity, *extra (6 + N each), u, t0, ext_i, ext_f] of a dynamics driver."""
    n = t.n_joints
    batch = _dynamics_batch(q, velocity, u, t0, ext, *extra)
    flat = [_flat(q, batch, (n,)), _flat(velocity, batch, (6 + n,)), *(_flat(e, batch, (6 + n,)) for e in extra)]
    return batch, [*flat, _actuation(u, t, batch), _attitudes(t0, batch), *_wrench_data(ext, batch)]


def residual_rows(
    model: Any,
    q: np.ndarray,
    velocity: np.ndarray,
    acceleration: np.ndarray | None = None,
    u: np.ndarray | None = None,
    t0: np.ndarray | None = None,
    ext: tuple[np.ndarray, np.ndarray] = NO_WRENCHES,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """H+ zddot0 + C+ - Q (..., 6 + N) by Newton-Euler (1991 eq. 19), its first block in the spacecraft frame:
    M T0^T rddot_cm less the thrusters' and the external forces.

    ``acceleration`` None: zddot0 = 0 (then C+ - Q; C+ alone with no ``u`` and no ``ext``: its first block is zero);
    ``u`` = [tau, f_S, n_S] (None: zero); ``t0`` the attitude (..., 3, 3) (None: the identity) for rddot_cm and
    inertial-frame wrenches; ``ext`` = (ext_i, ext_f (..., W, 9)). Into ``out`` (..., 6 + N) when given (then returned).
    """
    t = tree(model)
    n = t.n_joints
    acc_in = np.zeros(6 + n) if acceleration is None else acceleration
    wrenches = _specialise.layout(ext[0])
    batch = _dynamics_batch(q, velocity, u, t0, ext, acc_in)
    result = new_output((*batch, 6 + n), out=out)
    out = result.reshape((math.prod(map(int, batch)), 6 + n))

    def parts() -> list[np.ndarray]:  # the specialised kernel's inputs: q, zdot0, zddot0, u, T0 and with wrenches ext_f
        rows = [_part(q, batch, n), _part(velocity, batch, 6 + n), _part(acceleration, batch, 6 + n), _part(u, batch, n + 6)]
        rows.append(_part(_attitude_rows(t0), batch, 9))
        if wrenches:
            w = 9 * len(wrenches)
            rows.append(_part(ext[1].reshape((*ext[1].shape[:-2], w)), batch, w))
        return rows

    if not _specialised_map(t, "inverse", parts, out, wrenches):
        _, (qf, vf, af, uf, t0f, ext_i, ext_f) = _dynamics_inputs(t, q, velocity, u, t0, ext, acc_in)
        size = qf.shape[0]
        _timed(
            t,
            "inverse",
            size,
            _drivers.inverse_batch,
            size,
            t,
            _drivers.InverseCall(q=qf, v=vf, acc=af, u=uf, t0=t0f, ext_i=ext_i, ext=ext_f, accelerate=acceleration is not None, out=out),
            wrenches=wrenches,
        )
    return result


def accelerations(
    model: Any,
    q: np.ndarray,
    velocity: np.ndarray,
    u: Actuation = None,
    t0: np.ndarray | None = None,
    ext: tuple[np.ndarray, np.ndarray] = NO_WRENCHES,
    out: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Forward dynamics: (zddot0 (..., 6 + N) = [rddot_cm inertial, d/dt omega0, qddot], ok (...) False where H+ failed);
    zddot0 into ``out`` when given (then returned; the specialised kernel writes its rows with the guards' flag, copied
    from there)."""
    t = tree(model)
    n = t.n_joints
    wrenches = _specialise.layout(ext[0])
    batch = _dynamics_batch(q, velocity, u, t0, ext)
    if out is not None:
        new_output((*batch, 6 + n), out=out)  # checked before the work
    size = math.prod(map(int, batch))
    both = new_output((size, 7 + n))  # zddot0 and the guards' flag

    def parts() -> list[np.ndarray]:  # the specialised kernel's inputs: q, zdot0, tau, f_S, n_S, T0 and with wrenches ext_f
        rows = [_part(q, batch, n), _part(velocity, batch, 6 + n)]
        rows += [_part(p, batch, w) for p, w in zip(_split_actuation(u, n), (n, 3, 3), strict=True)]
        rows.append(_part(_attitude_rows(t0), batch, 9))
        if wrenches:
            w = 9 * len(wrenches)
            rows.append(_part(ext[1].reshape((*ext[1].shape[:-2], w)), batch, w))
        return rows

    if _specialised_map(t, "forward", parts, both, wrenches):
        ok = (both[:, 6 + n] != 0.0).reshape(batch)
        if out is None:
            return both[:, : 6 + n].reshape((*batch, 6 + n)), ok
        out.reshape((size, 6 + n))[...] = both[:, : 6 + n]
        return out, ok
    batch, (qf, vf, uf, t0f, ext_i, ext_f) = _dynamics_inputs(t, q, velocity, u, t0, ext)
    result = new_output((*batch, 6 + n), out=out)
    out = result.reshape((size, 6 + n))
    ok = np.empty(size, dtype=np.bool_)
    _timed(
        t,
        "forward",
        size,
        _drivers.forward_batch,
        qf.shape[0],
        t,
        _drivers.ForwardCall(q=qf, v=vf, u=uf, t0=t0f, ext_i=ext_i, ext=ext_f, out=out, ok=ok),
        wrenches=wrenches,
    )
    return result, ok.reshape(batch)


def state_derivative(
    model: Any, x: np.ndarray, u: np.ndarray | None = None, ext: tuple[np.ndarray, np.ndarray] = NO_WRENCHES
) -> tuple[np.ndarray, np.ndarray]:
    """d/dt of flat states x (..., S) = [r_cm, v_cm, quat xyzw, omega0, q, qdot] (``core.state_layout``); (dx, ok). States
    with the dissipated energy's slot carry it last: its rate is the power the joints' damping and friction dissipate."""
    t = tree(model)
    size = state_length(t.n_joints, x.shape[-1] == state_length(t.n_joints, True))
    batch = _batch((x, 1), (ext[1], 2), *(() if u is None else ((u, 1),)))
    xf = _flat(x, batch, (size,))
    ext_i, ext_f = _wrench_data(ext, batch)
    out = np.empty_like(xf)
    ok = np.empty(xf.shape[0], dtype=np.bool_)
    call = _drivers.DerivativeCall(x=xf, u=_actuation(u, t, batch), ext_i=ext_i, ext=ext_f, out=out, ok=ok)
    _drivers.derivative_batch(xf.shape[0], t, call)
    return out.reshape((*batch, size)), ok.reshape(batch)


def _records(n: int, x0: np.ndarray, steps: int, stride: int) -> tuple[np.ndarray, ...]:
    """The outputs of a rollout of the states x0 (K, S) recorded at step 0, every ``stride`` steps and the last:
    (states (T, K, S), u (T, K, N + 6), saturated (T, K), steps done (K))."""
    k = x0.shape[0]
    rows = 1 + sum(1 for i in range(1, steps + 1) if i % stride == 0 or i == steps)
    return (
        new_output((rows, k, x0.shape[1])),
        new_output((rows, k, n + 6)),
        np.empty((rows, k), dtype=np.bool_),
        np.empty(k, dtype=np.int64),
    )


def rollout(
    model: Any,
    x0: np.ndarray,
    dt: float,
    steps: int,
    hold: int,
    stride: int,
    gains: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    feedforward: np.ndarray,
    limit: np.ndarray,
    ext: tuple[np.ndarray, np.ndarray] = NO_WRENCHES,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Fixed-step RK4 of the states x0 (K, S) with a joint PD in the loop, all compiled, trajectories on threads.

    gains = (kp, kd, q_ref, qdot_ref), each (K, N); u = feedforward[k] + kp (q_ref - q) + kd (qdot_ref - qdot)
    at sample k (every ``hold`` steps; ``feedforward`` (S, K, W), W = N joint torques or N + 6 with
    the thrusters, its last sample held), clipped to +-limit (N + 6). Records at step 0, every
    ``stride`` steps and the last: (states (T, K, S), u (T, K, N + 6), saturated (T, K), steps done (K)).
    S: the flat state (``core.state_layout``), with or without the energy the joints' damping and friction dissipate in
    its last slot (integrated with the state: :func:`~.quantities.state_derivative_one`). The specialised kernels of a
    model with damping or friction integrate it always (:attr:`~.layout.Tree.state_size`): states without the slot run
    there with one added (and dropped).
    """
    t = tree(model)
    n = t.n_joints
    k = x0.shape[0]
    xs, us, sat, done = _records(n, x0, steps, stride)
    kp, kd, qref, vref = (owned(np.broadcast_to(g, (k, n))) for g in gains)
    ext_i, ext_f = _wrench_data(ext, (k,))
    wrenches = _specialise.layout(ext_i)
    timing = (float(dt), int(steps), int(hold), int(stride))
    if specialised_rollouts(model, k, ext):
        fast = _specialise.find(t, "rollout", wrenches)
        assert fast is not None
        size, given = fast.STATE, x0.shape[1]  # the module's flat state (with the dissipated energy or without), the caller's
        bare = state_length(n)
        x_in = x0 if given == size else np.concatenate([x0[:, :bare], np.zeros((k, size - bare))], axis=1)
        x_out = xs if given == size else new_output((xs.shape[0], k, size))
        args = (owned(x_in), *timing, (kp, kd, qref, vref, feed(feedforward)), owned(limit), x_out, us, sat, done)
        _specialise.rollout(fast, t, *args, ext_f.reshape(k, 9 * len(wrenches)))  # each trajectory's wrenches (K, 9W)
        if x_out is not xs:  # the states as given: the energy's slot dropped, or added (zero: the model dissipates nothing)
            common = min(size, given)
            xs[..., :common] = x_out[..., :common]
            xs[..., common:] = 0.0
        return xs, us, sat, done
    start = time.perf_counter()
    dt_, steps_, hold_, stride_ = timing
    call = _drivers.RolloutCall(
        x0=owned(x0),
        dt=dt_,
        steps=steps_,
        hold=hold_,
        stride=stride_,
        kp=kp,
        kd=kd,
        qref=qref,
        vref=vref,
        ff=feed(feedforward),
        lim=owned(limit),
        ext_i=ext_i,
        ext=ext_f,
        xs=xs,
        us=us,
        sat=sat,
        done=done,
    )
    _drivers.rollout_batch(k, t, call)
    if k >= _SPECIALISED_ROLLOUTS_MIN and _drivers.rollout_batch.compiled:  # work they would take
        _specialise.account(t, "rollout", time.perf_counter() - start, wrenches)
    return xs, us, sat, done


def law_rollout(
    model: Any,
    plant: np.ndarray | None,
    x0: np.ndarray,
    dt: float,
    steps: int,
    hold: int,
    stride: int,
    law: Any,
    limit: np.ndarray,
    ext: tuple[np.ndarray, np.ndarray] = NO_WRENCHES,
    pd: tuple[np.ndarray, ...] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Fixed-step RK4 of the states x0 (K, S) with the control law ``law`` (:data:`~.laws.Law`) in the loop, or (law
    None) the joint PD ``pd`` = (kp, kd, q_ref, qdot_ref (K, N), feedforward (S, K, W)) as in :func:`rollout`; all
    compiled, trajectories on threads: :func:`rollout`'s loop and records, on the generic kernels, with the plant's mass
    properties ``plant`` (1 or K rows of floats of ``model``'s structure: payload variants per trajectory)."""
    t = tree(model)
    n = t.n_joints
    k = x0.shape[0]
    xs, us, sat, done = _records(n, x0, steps, stride)
    ext_i, ext_f = _wrench_data(ext, (k,))
    timing = (float(dt), int(steps), int(hold), int(stride))
    plant = t.floats[None] if plant is None else plant
    if law is None:
        assert pd is not None
        C = ((*(owned(np.broadcast_to(g, (k, n))) for g in pd[:4]), feed(pd[4])), _no_law(t))
    else:
        zero = np.zeros((1, n))
        C = ((zero, zero, zero, zero, feed(np.zeros((1, 1, n)))), law)  # no joint PD: the law
    dt_, steps_, hold_, stride_ = timing
    call = _drivers.LawRolloutCall(
        x0=owned(x0),
        dt=dt_,
        steps=steps_,
        hold=hold_,
        stride=stride_,
        control=C,
        lim=owned(limit),
        plant_ints=owned(t.ints, np.int64),
        plant=owned(plant),
        ext_i=ext_i,
        ext=ext_f,
        xs=xs,
        us=us,
        sat=sat,
        done=done,
    )
    _drivers.law_rollout_batch(k, t, call)
    return xs, us, sat, done


@functools.cache
def _no_law(t: Tree) -> Any:
    """The empty control law of a rollout with the joint PD (the generic rollout's controller is either)."""
    return _laws.make_law(t.ints, t.floats[None])


def specialised_rollouts(model: Any, batch: int, ext: tuple[np.ndarray, np.ndarray] = NO_WRENCHES) -> bool:
    """True when :func:`rollout` of ``batch`` trajectories under the wrenches ``ext`` runs the specialised kernels
    (made for the model's structure and the wrenches' layout, at least 8 trajectories)."""
    if batch < _SPECIALISED_ROLLOUTS_MIN:
        return False
    return _specialise.find(tree(model), "rollout", _specialise.layout(ext[0])) is not None


def rk4_batch(
    model: Any, x: np.ndarray, u: np.ndarray, dt: float, steps: int, ext: tuple[np.ndarray, np.ndarray] = NO_WRENCHES
) -> np.ndarray:
    """``steps`` RK4 steps of the flat states x (K, S) under u (K, N + 6) held; the new states (NaN rows where a step failed)."""
    n = tree(model).n_joints
    zero = np.zeros((x.shape[0], n))
    xs, _, _, _ = rollout(model, x, dt, steps, steps, steps, (zero, zero, zero, zero), u[None], np.full(n + 6, np.inf), ext)
    return xs[-1]


class Stepper:
    """One trajectory stepped from Python (a controller in the loop): scratch space kept between calls.

    ``rk4(x, u, dt, steps)`` advances the flat state x (``core.state_layout``: with or without the energy the joints'
    damping and friction have dissipated last: :func:`~.quantities.state_derivative_one`; float64, contiguous) in place by
    ``steps`` RK4 steps with u held, in one compiled call, and returns ``steps``; or k < steps when
    H+ was not positive definite in step k; or -(k + 1) when x became non-finite in step k. (A
    partial of the kernel: a controller every step makes this call the hot path.)
    :meth:`derivative` is d/dt x for adaptive integrators.
    """

    def __init__(self, model: Any, ext: tuple[np.ndarray, np.ndarray] = NO_WRENCHES) -> None:
        self.tree = t = tree(model)
        self.size = state_length(t.n_joints)
        ext_i = np.asarray(ext[0], dtype=np.int64).reshape(-1, 2)
        ext_f = np.asarray(ext[1], dtype=np.float64).reshape(-1, 9)
        header = [ext_i.shape[0], 0, 0]  # W, WATCH, REASON (see stepper.unpack)
        self._header = t.ints.shape[0]
        self.ints = np.concatenate([t.ints, header, ext_i.ravel()]).astype(np.int64)
        work = np.empty(work_size(t.n_bodies, t.ee_body.shape[0]))
        self._watch_at = t.floats.shape[0] + ext_f.size
        watch = np.full(1 + 3 * t.n_joints, np.inf)
        watch[1 : 1 + t.n_joints] = -np.inf
        self.floats = np.concatenate([t.floats, ext_f.ravel(), watch, work])
        self.rk4: Callable[[np.ndarray, np.ndarray, float, int], int] = functools.partial(stepper.rk4_steps, self.ints, self.floats)

    def watch(self, rate: float = np.inf, lower: Any = None, upper: Any = None, joint_rates: Any = None) -> None:
        """Make :attr:`rk4` stop after a step that leaves a joint rate (or sqrt(3) |omega0_i|) above ``rate`` (the
        joints' own bounds ``joint_rates`` (N,) when given) or a joint outside [lower, upper]; :attr:`reason` then says
        which (1 rate, 2 limit, 3 both)."""
        n = self.tree.n_joints
        w = self.floats[self._watch_at : self._watch_at + 1 + 3 * n]
        w[0] = rate
        w[1 : 1 + n] = -np.inf if lower is None else lower
        w[1 + n : 1 + 2 * n] = np.inf if upper is None else upper
        w[1 + 2 * n :] = rate if joint_rates is None else joint_rates
        self.ints[self._header + 1] = int(np.isfinite(w).any())

    @property
    def reason(self) -> int:
        """Why the last :attr:`rk4` call stopped early under :meth:`watch` (0: it did not): :attr:`ints` [:attr:`reason_at`]."""
        return int(self.ints[self.reason_at])

    #: :attr:`reason` when :attr:`rk4` refused u before stepping (an entry not finite, or beyond MAX_EFFORT); 1 and 2 are
    #: :meth:`watch`'s.
    REFUSED = stepper.REFUSED

    @property
    def reason_at(self) -> int:
        """Where in :attr:`ints` the kernel leaves :attr:`reason` (a loop that steps every few microseconds reads it there)."""
        return self._header + 2

    def ready(self, kind: str) -> bool:
        """Whether :attr:`rk4` (``kind`` ``"rk4"``) or :meth:`derivative` (``"derivative"``) runs without compiling: its
        kernel compiled in this process or loaded now from the cache (:func:`.gate.ready`; never compiles)."""
        x = np.zeros(self.size)
        u = np.zeros(self.tree.n_joints + 6)
        if kind == "rk4":
            return gate.ready(stepper.rk4_steps, (self.ints, self.floats, x, u, 0.0, 0))
        return gate.ready(stepper.state_derivative, (self.ints, self.floats, x, u, x))

    def compile_seconds(self, kind: str) -> float | None:
        """About how long the kernel of :attr:`rk4` (``kind`` ``"rk4"``) or :meth:`derivative` (``"derivative"``) takes
        to compile (s: measured when the portable kernels were built, :func:`.folders.compile_seconds`), None if not
        known."""
        return compile_seconds("rk4_steps" if kind == "rk4" else "state_derivative")

    def derivative(self, x: np.ndarray, u: np.ndarray, out: np.ndarray) -> bool:
        """out = d/dt x under u; False if H+ is not positive definite."""
        return bool(stepper.state_derivative(self.ints, self.floats, x, u, out))
