"""Batch drivers of the engine: each one-configuration kernel, looped over a batch, serial or on threads.

A driver is made from one *row* kernel, ``row(i, m, s, a)``: the work of row i of a batch, given the
model ``m`` (:data:`~._tree.Arrays`), the scratch views ``s`` (:data:`~._recursions.Scratch`) and
the call's arrays ``a`` (a tuple: inputs, outputs and scalars). :func:`driver` makes from it, by
binding it into two templates written once below (:func:`_serial_template`,
:func:`_parallel_template`), a serial kernel over a range ``[start, stop)`` of rows (one scratch
buffer per range) and a parallel kernel that cuts the batch into blocks and runs the serial kernel
on each block with ``prange``; :class:`Batched` chooses between them (small batches start no
threads). The row kernels are inlined into the serial range kernels only, never into a
``prange`` body. A new batched quantity is one row kernel and one line ``driver(...)``.

The templates are bound by copying their code with the row kernel as a global (not a closure), so
numba's on-disk cache keeps one entry per driver (keyed by the driver's name) across processes.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np
from numba import prange

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
from ._laws import Law, law_control
from ._numba_cache import bind, kernel, unowned_floats, unowned_ints
from ._recursions import kinematics, scratch
from ._tree import Tree, arrays, buffer_lengths, work_size

__all__ = [
    "BLOCK",
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
    "measure_batch",
    "point_bias_batch",
    "point_jacobian_batch",
    "points_batch",
    "rollout_batch",
]

#: Rows per parallel block (one scratch buffer each).
BLOCK = 64
#: The index of the numba thread running a parallel block: its row of the scratch buffers.
_thread = numba.get_thread_id


# ----------------------------------------------------------------- the two templates, written once
def _serial_template(start: int, stop: int, ints: np.ndarray, floats: np.ndarray, work: np.ndarray, *a: Any) -> None:  # pragma: no cover
    """ROW over the rows start..stop of a batch of the model in (ints, floats); ``work`` one scratch buffer."""
    m = arrays(ints, floats)
    s = scratch(work, m.parent.shape[0], m.ee_body.shape[0], m.n_joints)
    for i in range(start, stop):
        ROW(i, m, s, a)  # type: ignore[name-defined]  # noqa: F821 (bound by driver())


def _parallel_template(size: int, ints: np.ndarray, floats: np.ndarray, WORK: np.ndarray, *a: Any) -> None:  # pragma: no cover
    """SERIAL on blocks of STEP rows, one block per thread at a time; WORK one scratch buffer per thread."""
    for b in prange((size + STEP - 1) // STEP):  # type: ignore[name-defined]  # noqa: F821 (bound by driver())
        SERIAL(b * STEP, min(size, (b + 1) * STEP), ints, floats, WORK[_thread()], *a)  # type: ignore[name-defined]  # noqa: F821


class Batched:
    """A driver: the serial range kernel for small batches, its parallel twin from :attr:`PARALLEL_MIN` rows."""

    #: Batches at least this large run on numba's threads (when there is more than one).
    PARALLEL_MIN = 256
    #: Whether the last call found its kernel compiled (or loaded) already: its time was work, not compiling.
    compiled = False

    def __init__(self, serial: Any, parallel: Any, parallel_min: int | None = None) -> None:
        self.serial, self.parallel = serial, parallel
        if parallel_min is not None:
            self.PARALLEL_MIN = parallel_min

    def __call__(self, size: int, t: Tree, *a: Any) -> Any:
        """Run on ``size`` rows of the model ``t`` with the call's arrays ``a``; the scratch buffers are made here.

        The kernels make views of their scratch without reference counting (cheaper), so the
        buffers must outlive the call: they are arguments, held by this frame.
        """
        length = work_size(t.n_bodies, t.ee_body.shape[0])
        if size >= self.PARALLEL_MIN and numba.get_num_threads() > 1:
            threads = numba.config.NUMBA_NUM_THREADS  # type: ignore[attr-defined]  # every thread id is below it
            self.compiled = bool(self.parallel.overloads)
            return self.parallel(size, t.ints, t.floats, np.empty((threads, length)), *a)
        self.compiled = bool(self.serial.overloads)
        return self.serial(0, size, t.ints, t.floats, np.empty(length), *a)


def driver(name: str, row: Any, *, block: int = BLOCK, parallel_min: int | None = None) -> Batched:
    """The serial and parallel drivers of the row kernel ``row`` (``block`` rows per parallel task)."""
    serial = kernel()(bind(_serial_template, f"{name}_serial", ROW=row))
    parallel = kernel(parallel=True)(bind(_parallel_template, f"{name}_parallel", SERIAL=serial, STEP=block))
    return Batched(serial, parallel, parallel_min)


# ----------------------------------------------------------------- one trajectory stepped from Python (the Stepper)
#: The rollout loop of _lanes, one trajectory at a time, stepped by the engine's RK4 step (bound as a global: inlined),
#: with the joint PD in it; and the same loop with a control law of _laws (or the joint PD) in it.
_rollout_blocks = rollout_loop(rk4_step_rows, "generic")
_law_rollout_blocks = rollout_loop(rk4_step_rows, "law", law_control)


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
    ints = unowned_ints(ints)  # views without reference counting: the caller holds both buffers
    floats = unowned_floats(floats)
    nb = m.parent.shape[0]
    nw = ints[o]
    header = ints[o : o + 3]
    ext_i = ints[o + 3 : o + 3 + 2 * nw].reshape((nw, 2))
    ext_f = floats[f : f + 9 * nw].reshape((nw, 9))
    f += 9 * nw
    watch = floats[f : f + 1 + 3 * m.n_joints]
    f += 1 + 3 * m.n_joints
    work = floats[f:]
    return m, ext_i, ext_f, watch, header, scratch(work, nb, m.ee_body.shape[0], m.n_joints)


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
    beyond a limit), returns k + 1 and leaves the reason in ints[4] (0 otherwise).
    """
    m, ext_i, ext_f, watch, header, s = unpack(ints, floats)
    header[2] = 0
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


def _rollout_parallel(size: int, ints: np.ndarray, floats: np.ndarray, WORK: np.ndarray, *a: Any) -> None:  # pragma: no cover
    """The parallel rollout with a law: one trajectory per task on numba's threads (:func:`_rollout_task`). numba's threads
    take no tuple of arrays, so the controller C = ((kp, kd, qref, vref, ff), law) arrives as its arrays, flat
    (:meth:`RolloutBatched.__call__`), and each task makes it again, in a kernel of its own: built in the ``prange`` body,
    the law's writes (its ``lowest``) through the inlined loop are lost (numba 0.68)."""
    for b in prange(size):
        _rollout_task(np.int64(b), ints, floats, WORK[_thread()], *a)  # type: ignore[arg-type]  # prange's index is unsigned


def _rollout_task(b: int, ints: np.ndarray, floats: np.ndarray, work: np.ndarray, *a: Any) -> None:  # pragma: no cover
    """Trajectory b of the parallel rollout with a law: the controller's tuples made from the flat arguments (:data:`ROLLOUT_FLAT`
    of them after X0, dt, steps, hold, stride), then the loop of :func:`_law_rollout_row`, inlined here (a serial kernel
    called from here would be compiled, then linked and optimized again inside this one)."""
    pd = (a[5], a[6], a[7], a[8], a[9])
    law = Law(  # type: ignore[call-arg]
        a[10], a[11], a[12], a[13], a[14], a[15], a[16], a[17], a[18], a[19], a[20], a[21], a[22], a[23], a[24], a[25], a[26], a[27]
    )
    m = arrays(ints, floats)
    s = scratch(work, m.parent.shape[0], m.ee_body.shape[0], m.n_joints)
    _law_rollout_row(b, m, s, (a[0], a[1], a[2], a[3], a[4], (pd, law), *a[28:]))


#: The arrays of a rollout's controller: the joint PD's five, then the fields of a control law.
ROLLOUT_FLAT = 5 + len(Law._fields)


class RolloutBatched(Batched):
    """The rollout's driver: the serial kernel with the controller as tuples, the parallel one with them flat."""

    def __call__(self, size: int, t: Tree, *a: Any) -> Any:
        if size >= self.PARALLEL_MIN and numba.get_num_threads() > 1:
            pd, law = a[5]
            return super().__call__(size, t, *a[:5], *pd, *law, *a[6:])
        return super().__call__(size, t, *a)


frames_batch = driver("frames", _frames_row)
points_batch = driver("points", _points_row)
point_jacobian_batch = driver("point_jacobian", _point_jacobian_row)
point_bias_batch = driver("point_bias", _point_bias_row)
jstar_batch = driver("jstar", _jstar_row)
measure_batch = driver("measure", _measure_row, block=1, parallel_min=4)  # rows: lane blocks of configurations
hplus_batch = driver("hplus", _hplus_row)
hplus_rate_batch = driver("hplus_rate", _hplus_rate_row)
inverse_batch = driver("inverse", _inverse_row)
forward_batch = driver("forward", _forward_row)
derivative_batch = driver("derivative", _derivative_row)
rollout_batch = driver("rollout", _rollout_row, block=1, parallel_min=2)  # one trajectory is long work: threads pay from two
# A rollout with a law runs on the threaded kernel from one trajectory on (a single compiled simulation too: one call
# per run, so the threads' start costs once); the serial one only where numba has one thread.
law_rollout_batch = RolloutBatched(
    kernel()(bind(_serial_template, "law_rollout_serial", ROW=_law_rollout_row)),
    kernel(parallel=True)(bind(_rollout_parallel, "law_rollout_parallel", _rollout_task=kernel()(bind(_rollout_task, "law_rollout_task")))),
    parallel_min=1,
)
