"""Batch drivers of the engine: each one-configuration kernel, looped over a batch, in one thread or on several.

A driver is made from one *row* kernel, ``row(i, m, s, a)``: the work of row i of a batch, given the
model ``m`` (:data:`~._tree.Arrays`), the scratch views ``s`` (:data:`~._recursions.Scratch`) and
the call's arrays ``a`` (a tuple: inputs, outputs and scalars). :func:`driver` makes from it, by
binding it into the template written once below (:func:`_serial_template`), one range kernel over the rows
``[start, stop)`` of a batch (one scratch buffer per range); :class:`Batched` runs it on the whole batch, or from
:attr:`Batched.PARALLEL_MIN` rows on one contiguous range per thread at once (:func:`~._threads.run_kernel`: numba's
threads call the kernel's machine code; no threaded twin is compiled). A new batched quantity is one row kernel and one line
``driver(...)``.

The template is bound by copying its code with the row kernel as a global (not a closure), so
numba's on-disk cache keeps one entry per driver (keyed by the driver's name) across processes.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..core.numbers import MAX_EFFORT
from ._configuration import (
    accelerations_one,
    hplus_one,
    hplus_rate_one,
    inverse_one,
    jacobian_measure_lanes,
    jstar_one,
    measure_work,
    point_bias_one,
    point_jacobian_one,
    points_one,
    rk4_step,
    rk4_step_rows,
    state_derivative_one,
)
from ._lanes import LANES, rollout_loop
from ._laws import law_control
from ._numba_cache import bind, floats_view, ints_view, kernel
from ._recursions import kinematics, scratch
from ._threads import compiled_count, range_count, run_kernel, run_ranges, threads_for
from ._tree import Tree, arrays, buffer_lengths, work_size

__all__ = [
    "Batched",
    "derivative_batch",
    "driver",
    "forward_batch",
    "frames_batch",
    "hplus_batch",
    "hplus_rate_batch",
    "inverse_batch",
    "jstar_batch",
    "law_rollout_batch",
    "limit_spans",
    "limit_spans_batch",
    "measure_batch",
    "point_bias_batch",
    "point_jacobian_batch",
    "points_batch",
    "rollout_batch",
]


# ----------------------------------------------------------------- the template, written once
def _serial_template(ints: np.ndarray, floats: np.ndarray, work: np.ndarray, start: int, stop: int, *a: Any) -> None:  # pragma: no cover
    """ROW over the rows start..stop of a batch of the model in (ints, floats); ``work`` one scratch buffer."""
    m = arrays(ints, floats)
    s = scratch(work, m.parent.shape[0], m.ee_body.shape[0], m.n_joints)
    for i in range(start, stop):
        ROW(i, m, s, a)  # type: ignore[name-defined]  # noqa: F821 (bound by driver())


class Batched:
    """A driver: the range kernel on the whole batch in the calling thread, or from :attr:`PARALLEL_MIN` rows on one
    contiguous range per thread (numba's thread count of the calling thread), each with its own scratch buffer."""

    #: Batches at least this large run on several threads (when numba has more than one). Handing the ranges to numba's
    #: threads costs 1-3 us (:func:`~._threads.run_kernel`); a call of 2 threads against 1 on the 2-core VM, in us
    #: (measured): J* of the 1992 system 32 rows 34 / 30, 64 41 / 41, 128 50 / 56, 256 69 / 88; of the 7-DOF arm 64
    #: 45 / 54, 256 88 / 137; H+ of the 7-DOF arm 64 54 / 58, 256 115 / 159; forward dynamics of the 1992 system 32
    #: 133 / 136, 64 146 / 151, 256 195 / 237. (On a pool's threads, woken at each call, it cost 50-120 us.)
    PARALLEL_MIN = 64
    #: Whether the last call compiled nothing (its kernel, and the parallel loop that calls it on threads, were compiled
    #: or loaded already): its time was work, not compiling.
    compiled = False

    def __init__(self, serial: Any, parallel_min: int | None = None) -> None:
        self.serial = serial
        if parallel_min is not None:
            self.PARALLEL_MIN = parallel_min

    def __call__(self, size: int, t: Tree, *a: Any) -> None:
        """Run on ``size`` rows of the model ``t`` with the call's arrays ``a``; the scratch buffers are made here.

        The kernels make views of their scratch without reference counting (cheaper), so the
        buffers must outlive the call: they are arguments, held by this frame.
        """
        length = work_size(t.n_bodies, t.ee_body.shape[0])
        before = (len(self.serial.overloads), compiled_count())
        parts = threads_for(size, self.PARALLEL_MIN)
        work = np.empty((range_count(size, parts), length))
        run_kernel(self.serial, (t.ints, t.floats), work, a, size, parts)
        self.compiled = before[0] > 0 and before == (len(self.serial.overloads), compiled_count())


def driver(name: str, row: Any, *, parallel_min: int | None = None) -> Batched:
    """The driver of the row kernel ``row``: its range kernel, compiled once, named ``<name>_serial`` in the cache."""
    return Batched(kernel()(bind(_serial_template, f"{name}_serial", ROW=row)), parallel_min)


# ----------------------------------------------------------------- one trajectory stepped from Python (the Stepper)
#: The rollout loop of _lanes, one trajectory at a time, stepped by the engine's RK4 step (bound as a global: inlined),
#: with the joint PD in it; and the same loop with a control law of _laws (or the joint PD) in it.
_rollout_blocks = rollout_loop(rk4_step_rows, "generic")
_law_rollout_blocks = rollout_loop(rk4_step_rows, "law", law_control)


#: REASON of :func:`rk4_steps` when it refused u (an entry not finite, or beyond MAX_EFFORT); 1 and 2 are :func:`watched`'s.
REFUSED = 4


@kernel(inline="always")
def unpack(ints: np.ndarray, floats: np.ndarray) -> Any:  # pragma: no cover - compiled
    """The model, its external wrenches and the scratch of one trajectory from the two buffers of
    :func:`~._engine.Stepper` (fewer arguments: numba unboxes each array argument at ~0.1 us a call).

    ints = [the model's ints (:func:`~._tree.arrays`), W, WATCH, REASON, ext_i (W x 2)];
    floats = [the model's floats, ext_f (W x 9), watch (1 + 3N), work (work_size(B, E))].
    WATCH 1: :func:`rk4_steps` watches the state (see there); REASON: why it stopped early (ints[o + 2]).
    """
    m = arrays(ints, floats)
    o, f = buffer_lengths(ints)
    nb = m.parent.shape[0]
    if ints.shape[0] < o + 3 or ints[o] < 0:
        raise ValueError("freefloat: the stepper's buffers have no valid header")
    nw = ints[o]
    n = m.n_joints
    if ints.shape[0] < o + 3 + 2 * nw or floats.shape[0] < f + 9 * nw + 1 + 3 * n:
        raise ValueError("freefloat: the stepper's buffers are shorter than their header says")
    header = ints_view(ints, o, 3)  # views without reference counting or bounds checks: the caller holds both buffers
    ext_i = ints_view(ints, o + 3, (nw, 2))
    ext_f = floats_view(floats, f, (nw, 9))
    f += 9 * nw
    watch = floats_view(floats, f, 1 + 3 * n)
    f += 1 + 3 * n
    work = floats_view(floats, f, floats.shape[0] - f)  # (scratch checks its length)
    return m, ext_i, ext_f, watch, header, scratch(work, nb, m.ee_body.shape[0], n)


@kernel(inline="always")
def watched(x: np.ndarray, watch: np.ndarray) -> int:  # pragma: no cover - compiled
    """Why x needs a look from Python (0: it does not): 1 a rate above its bound (sqrt(3) times a spacecraft rate
    component, a bound on |omega0|, above watch[0]; joint j's rate above watch[1 + 2N + j]: a reaction wheel's bound is
    not a robot joint's), 2 a joint beyond [watch[1 + j], watch[1 + N + j]], 3 both."""
    n = (watch.shape[0] - 1) // 3
    fast = watch[0]
    reason = 0
    for i in range(3):
        if 1.7320508075688772 * abs(x[10 + i]) > fast:
            reason = 1
    for j in range(n):
        if abs(x[13 + n + j]) > watch[1 + 2 * n + j]:
            reason = 1
    for j in range(n):
        v = x[13 + j]
        if v < watch[1 + j] or v > watch[1 + n + j]:
            reason |= 2
            break
    return reason


@kernel()
def rk4_steps(
    ints: np.ndarray, floats: np.ndarray, x: np.ndarray, u: np.ndarray, dt: float, nsteps: int
) -> int:  # pragma: no cover - compiled
    """``nsteps`` RK4 steps of one state x in place under the held u (the model in the buffers of :func:`unpack`).

    Returns ``nsteps``; or k < nsteps when H+ was not positive definite in step k (k steps done);
    or -(k + 1) when x became non-finite in step k (k + 1 steps done). When the buffers say WATCH,
    it also stops after the step k whose state needs a look (:func:`watched`: a fast rate, a joint
    beyond a limit), returns k + 1 and leaves the reason in REASON (0 otherwise). Before any step it checks u:
    an entry that is not finite or beyond :data:`~freefloat.core.numbers.MAX_EFFORT` makes it return 0 with REASON 4
    (the controller's output, checked here rather than in Python at every step of a simulation).
    """
    m, ext_i, ext_f, watch, header, s = unpack(ints, floats)
    header[2] = 0
    for i in range(u.shape[0]):
        if not abs(u[i]) <= MAX_EFFORT:  # NaN too
            header[2] = REFUSED
            return 0
    for step in range(nsteps):
        if not rk4_step(x, u, dt, m, ext_i, ext_f, s):
            return step
        total = 0.0
        for i in range(x.shape[0]):
            total += x[i]
        if not math.isfinite(total):
            return -(step + 1)
        if header[1] != 0:
            reason = watched(x, watch)
            if reason != 0:
                header[2] = reason
                return step + 1
    return nsteps


@kernel()
def state_derivative(
    ints: np.ndarray, floats: np.ndarray, x: np.ndarray, u: np.ndarray, dx: np.ndarray
) -> bool:  # pragma: no cover - compiled
    """:func:`state_derivative_one` from Python (the model in the buffers of :func:`unpack`)."""
    m, ext_i, ext_f, _, _, s = unpack(ints, floats)
    return state_derivative_one(x, u, m, ext_i, ext_f, s, dx.reshape((1, dx.shape[0])), 0)


# ----------------------------------------------------------------- the rows
@kernel(inline="always")
def _frames_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """a = (Q (C, N), ROT (C, B, 3, 3), POS (C, B, 3)): ⁰T_k and the body frame origins (from O) of row i."""
    Q, ROT, POS = a
    kinematics(Q[i], m, ROT[i], POS[i], s.axis, s.mom)


@kernel(inline="always")
def _points_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """a = (Q, bodies (P,), points (P, 3), OUT (C, P, 3)): points relative to the system CM."""
    Q, pbody, ppoint, OUT = a
    points_one(Q[i], m, pbody, ppoint, s, OUT[i])


@kernel(inline="always")
def _point_jacobian_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """a = (Q, bodies (P,), points (P, 3), OUT (C, P, 6, 6 + N)): J+ of points."""
    Q, pbody, ppoint, OUT = a
    point_jacobian_one(Q[i], m, pbody, ppoint, s, OUT[i])


@kernel(inline="always")
def _point_bias_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """a = (Q, V, bodies (P,), points (P, 3), ext_i (0, 2), ext_f (0, 9), OUT (C, P, 6)): Jdot+ zdot0 of points."""
    Q, V, pbody, ppoint, ext_i, ext_f, OUT = a
    point_bias_one(Q[i], V[i], m, pbody, ppoint, ext_i, ext_f, s, OUT[i])


@kernel(inline="always")
def _jstar_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """a = (Q, OUT (C, 6E, N)): J*."""
    Q, OUT = a
    jstar_one(Q[i], m, s, OUT[i])


@kernel(inline="always")
def _measure_row(b: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """a = (Q, rows (K,), kind, OUT (C,)): a measure of the rows ``rows`` of J* for the configurations of lane block b
    (:data:`~._lanes.LANES` of them, fewer in the last block): their J* one by one into the rows of a block buffer, then
    the measure of the whole block at once (SIMD across it, as in the specialised kernels); no J* batch written."""
    Q, rows, kind, OUT = a
    c0 = b * LANES
    width = min(LANES, Q.shape[0] - c0)
    n = Q.shape[1]
    size = s.jac.shape[0] * n
    W = np.empty((size + measure_work(n)) * width)
    for l in range(width):
        jstar_one(Q[c0 + l], m, s, s.jac)
        for r in range(s.jac.shape[0]):
            for c in range(n):
                W[(r * n + c) * width + l] = s.jac[r, c]
    jacobian_measure_lanes(W, 0, width, n, rows, kind, W[size * width :], OUT, c0, width)


@kernel(inline="always")
def _hplus_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """a = (Q, OUT (C, 6 + N, 6 + N)): H+."""
    Q, OUT = a
    hplus_one(Q[i], m, s, OUT[i])


@kernel(inline="always")
def _hplus_rate_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """a = (Q, QD, OUT (C, 6 + N, 6 + N)): dH+/dt along the joint rates QD[i]."""
    Q, QD, OUT = a
    hplus_rate_one(Q[i], QD[i], m, s, OUT[i])


@kernel(inline="always")
def _inverse_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """a = (Q, V, A, U, T0, ext_i, EXT, accelerate, OUT (C, 6 + N)): H+ zddot0 + C+ - Q_u - Q_ext, its first block in the
    spacecraft frame (accelerate False: zddot0 = 0)."""
    Q, V, A, U, T0, ext_i, EXT, accelerate, OUT = a
    inverse_one(Q[i], V[i], A[i], accelerate, U[i], T0[i], m, ext_i, EXT[i], s, OUT[i])


@kernel(inline="always")
def _forward_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """a = (Q, V, U, T0, ext_i, EXT, OUT (C, 6 + N), OK (C,)): zddot0; OK[i] False where H+ is not positive definite."""
    Q, V, U, T0, ext_i, EXT, OUT, OK = a
    OK[i] = accelerations_one(Q[i], V[i], U[i], T0[i], m, ext_i, EXT[i], s, OUT[i])


@kernel(inline="always")
def _derivative_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """a = (X, U, ext_i, EXT, OUT (C, S), OK (C,)): d/dt of the flat state X[i]."""
    X, U, ext_i, EXT, OUT, OK = a
    OK[i] = state_derivative_one(X[i], U[i], m, ext_i, EXT[i], s, OUT, i)


@kernel(inline="always")
def _rollout_row(b: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """Trajectory b of a rollout (the loop of :func:`~._lanes.rollout_blocks`, one lane wide, on the engine's state
    derivative) with the joint PD. a = (X0, dt, steps, hold, stride, kp, kd, qref, vref, ff, lim, ext_i, EXT, XS, US,
    SAT, DONE)."""
    X0, dt, steps, hold, stride, kp, kd, qref, vref, ff, lim, ext_i, EXT, XS, US, SAT, DONE = a
    C = (kp, kd, qref, vref, ff)
    _rollout_blocks((m, ext_i, EXT[b], s), 1, b, b + 1, X0, dt, steps, hold, stride, C, lim, XS, US, SAT, DONE, s.rows)


@kernel(inline="always")
def _law_rollout_row(b: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """Trajectory b of a rollout with a control law (:func:`~._laws.law_control`; or the joint PD, law code 0) in the
    loop, on the model of the buffers (plant_ints, PLANT[b] or PLANT[0]: a payload variant per trajectory; both kernel
    arguments). a = (X0, dt, steps, hold, stride, C = ((kp, kd, qref, vref, ff), law), lim, plant_ints, PLANT (K, F),
    ext_i, EXT, XS, US, SAT, DONE). Its own kernel (the law's loop), so that a joint PD rollout compiles no law."""
    X0, dt, steps, hold, stride, C, lim, plant_ints, PLANT, ext_i, EXT, XS, US, SAT, DONE = a
    plant = arrays(plant_ints, PLANT[b if PLANT.shape[0] > 1 else 0])
    _law_rollout_blocks((plant, ext_i, EXT[b], s), 1, b, b + 1, X0, dt, steps, hold, stride, C, lim, XS, US, SAT, DONE, s.rows)


frames_batch = driver("frames", _frames_row)
points_batch = driver("points", _points_row)
point_jacobian_batch = driver("point_jacobian", _point_jacobian_row)
point_bias_batch = driver("point_bias", _point_bias_row)
jstar_batch = driver("jstar", _jstar_row)
measure_batch = driver("measure", _measure_row, parallel_min=2)  # rows: lane blocks of 64 configurations
hplus_batch = driver("hplus", _hplus_row)
hplus_rate_batch = driver("hplus_rate", _hplus_rate_row)
inverse_batch = driver("inverse", _inverse_row)
forward_batch = driver("forward", _forward_row)
derivative_batch = driver("derivative", _derivative_row)
rollout_batch = driver("rollout", _rollout_row, parallel_min=2)  # one trajectory is long work: threads pay from two
law_rollout_batch = driver("law_rollout", _law_rollout_row, parallel_min=2)  # with a control law (or the joint PD)


# ----------------------------------------------------------------- joint-limit spans of recorded trajectories
@kernel(inline="always")
def _span_closed(
    b: int, i: int, side: int, t: int, opened: np.ndarray, furthest: np.ndarray, spans: np.ndarray, value: np.ndarray, count: int
) -> int:  # pragma: no cover - compiled
    """The open span of joint i of trajectory b beyond its limit ``side``, closed at sample t: recorded at ``count``
    (when there is room). Returns the count of spans found."""
    if count < value.shape[0]:
        spans[count, 0], spans[count, 1], spans[count, 2] = b, i, side
        spans[count, 3], spans[count, 4] = opened[b, i, side], t
        value[count] = furthest[b, i, side]
    opened[b, i, side] = -1
    return count + 1


@kernel()
def limit_spans(
    q: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    first: int,
    last: int,
    opened: np.ndarray,
    furthest: np.ndarray,
    spans: np.ndarray,
    value: np.ndarray,
) -> int:  # pragma: no cover - compiled
    """The spans of consecutive samples in which a joint of the trajectories first..last of q (T, B, N) is beyond a
    limit (q > upper or q < lower; NaN is neither, as in the comparisons): one pass over the samples, in time order.

    Writes spans (S, 5): trajectory, joint, bound (0 upper, 1 lower), first sample beyond, first sample back inside
    (T: none), and value (S,): the furthest value reached, the spans of a (trajectory, joint, bound) in time order, as
    many as they hold; returns the count found (more than they hold: call again with more room). ``opened`` (B, N, 2)
    int64 and ``furthest`` (B, N, 2): scratch (the open span's start, -1 when none, and its furthest value). No array
    is made or grown here: arrays that a loop may replace are reference-counted at every sample (220 ms on one thread
    for the Panda's rollout below). A rollout of 1,024 trajectories of the Panda (501 samples, 9 joints, a view of its
    states: 31 values a sample) in 11-15 ms on 2 threads, where numpy took 46-70 ms for the same spans (measured)."""
    steps, _, joints = q.shape
    count = 0
    for b in range(first, last):
        for i in range(joints):
            opened[b, i, 0] = -1
            opened[b, i, 1] = -1
    for t in range(steps):
        for b in range(first, last):
            for i in range(joints):
                v = q[t, b, i]
                if v > upper[i]:
                    if opened[b, i, 0] < 0:
                        opened[b, i, 0] = t
                        furthest[b, i, 0] = v
                    elif v > furthest[b, i, 0]:
                        furthest[b, i, 0] = v
                elif opened[b, i, 0] >= 0:
                    count = _span_closed(b, i, 0, t, opened, furthest, spans, value, count)
                if v < lower[i]:
                    if opened[b, i, 1] < 0:
                        opened[b, i, 1] = t
                        furthest[b, i, 1] = v
                    elif v < furthest[b, i, 1]:
                        furthest[b, i, 1] = v
                elif opened[b, i, 1] >= 0:
                    count = _span_closed(b, i, 1, t, opened, furthest, spans, value, count)
    for b in range(first, last):  # the spans still open after the last sample
        for i in range(joints):
            for side in range(2):
                if opened[b, i, side] >= 0:
                    count = _span_closed(b, i, side, steps, opened, furthest, spans, value, count)
    return count


def limit_spans_batch(q: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`limit_spans` of every trajectory of q (T, B, N), on one range of trajectories per thread from 16 of them:
    (spans (S, 5), value (S,)), the ranges' spans one after another (trajectories in order). Each range starts with
    room for 2 spans per joint and trajectory; one that finds more runs again with room for all of them."""
    batch, joints = q.shape[1], q.shape[2]
    opened = np.empty((batch, joints, 2), dtype=np.int64)
    furthest = np.empty((batch, joints, 2))
    parts = threads_for(batch, 16)
    found: list[Any] = [None] * range_count(batch, parts)

    def run(r: int, first: int, last: int) -> None:
        room = 2 * joints * (last - first) + 16
        while True:
            spans, value = np.empty((room, 5), dtype=np.int64), np.empty(room)
            count = limit_spans(q, lower, upper, first, last, opened, furthest, spans, value)
            if count <= room:
                found[r] = (spans[:count], value[:count])
                return
            room = count

    run_ranges(run, batch, parts)
    spans, value = (np.concatenate(part) for part in zip(*found, strict=True))
    return spans, value
