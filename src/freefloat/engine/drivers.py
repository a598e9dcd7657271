"""Batch drivers of the engine: each one-configuration kernel, looped over a batch, in one thread or on several.

A driver is made from one *row* kernel, ``row(i, m, s, a)``: the work of row i of a batch, given the
model ``m`` (:data:`~.layout.Arrays`), the scratch views ``s`` (:data:`~.layout.Scratch`) and
the call's arrays ``a`` (a tuple: inputs, outputs and scalars). :func:`driver` makes from it, by
binding it into the template written once below (:func:`_serial_template`), one range kernel over the rows
``[start, stop)`` of a batch (one scratch buffer per range); :class:`Batched` runs it on the whole batch, or from
:attr:`Batched.PARALLEL_MIN` rows on one contiguous range per thread at once (:func:`~.threads.run_kernel`: numba's
threads call the kernel's machine code; no threaded twin is compiled). A new batched quantity is one row kernel and one line
``driver(...)``.

The template is bound by copying its code with the row kernel as a global (not a closure), so
numba's on-disk cache keeps one entry per driver (keyed by the driver's name) across processes.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .cache import bind, kernel
from .laws import law_control
from .layout import Tree, arrays, scratch, work_size
from .measures import jacobian_measure_lanes, measure_work
from .quantities import (
    accelerations_one,
    hplus_one,
    hplus_rate_one,
    inverse_one,
    jstar_one,
    point_bias_one,
    point_jacobian_one,
    points_one,
    rk4_step_rows,
    state_derivative_one,
)
from .recursions import kinematics
from .specialise.lanes import LANES, rollout_loop
from .threads import compiled_count, range_count, run_kernel, threads_for

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

    #: Batches at least this large run on several threads (when numba has more than one): below it, handing the ranges
    #: to numba's threads (:func:`~.threads.run_kernel`) costs more than a second thread saves (sizes in
    #: benchmarks/README.md, Measurement history).
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
        before = (len(self.serial.signatures), compiled_count())
        parts = threads_for(size, self.PARALLEL_MIN)
        work = np.empty((range_count(size, parts), length))
        run_kernel(self.serial, (t.ints, t.floats), work, a, size, parts)
        self.compiled = before[0] > 0 and before == (len(self.serial.signatures), compiled_count())


def driver(name: str, row: Any, *, parallel_min: int | None = None) -> Batched:
    """The driver of the row kernel ``row``: its range kernel, compiled once, named ``<name>_serial`` in the cache."""
    return Batched(kernel()(bind(_serial_template, f"{name}_serial", ROW=row)), parallel_min)


# ----------------------------------------------------------------- the rollout loop, one trajectory at a time
#: The rollout loop of specialise.lanes, one trajectory at a time, stepped by the engine's RK4 step of one state
#: (quantities.rk4_step_rows, bound as a global: inlined), with the joint PD in it; and the same loop with
#: laws.law_control (a control law, or the joint PD) in it.
_rollout_blocks = rollout_loop(rk4_step_rows, "generic")
_law_rollout_blocks = rollout_loop(rk4_step_rows, "law", law_control)


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
    (:data:`~.specialise.lanes.LANES` of them, fewer in the last block): their J* one by one into the rows of a block buffer, then
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
    """Trajectory b of a rollout (the loop of ``specialise.lanes._rollout_blocks``, one lane wide, stepped by the engine's
    RK4 step of one state) with the joint PD. a = (X0, dt, steps, hold, stride, kp, kd, qref, vref, ff, lim, ext_i, EXT, XS, US,
    SAT, DONE)."""
    X0, dt, steps, hold, stride, kp, kd, qref, vref, ff, lim, ext_i, EXT, XS, US, SAT, DONE = a
    C = (kp, kd, qref, vref, ff)
    _rollout_blocks((m, ext_i, EXT[b], s), 1, b, b + 1, X0, dt, steps, hold, stride, C, lim, XS, US, SAT, DONE, s.rows)


@kernel(inline="always")
def _law_rollout_row(b: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """Trajectory b of a rollout with a control law (:func:`~.laws.law_control`; or the joint PD, law code 0) in the
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
