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
import types
from collections.abc import Callable
from typing import Any

import numba
import numpy as np
from numba import prange

from ._configuration import accelerations_one, hplus_one, jstar_one, point_jacobian_one, points_one, rk4_step, state_derivative_one
from ._lanes import joint_pd
from ._numba_cache import kernel
from ._recursions import kinematics, newton_euler, prepare, scratch
from ._tree import Tree, arrays, work_size

__all__ = [
    "BLOCK",
    "Batched",
    "derivative_batch",
    "driver",
    "forward_batch",
    "frames_batch",
    "hplus_batch",
    "inverse_batch",
    "jstar_batch",
    "point_jacobian_batch",
    "points_batch",
    "rollout_batch",
]

#: Rows per parallel block (one scratch buffer each).
BLOCK = 64
#: The index of the numba thread running a parallel block: its row of the scratch buffers.
_thread = numba.get_thread_id


# ----------------------------------------------------------------- the two templates, written once
def _serial_template(start: int, stop: int, ints: np.ndarray, floats: np.ndarray, a: Any, work: np.ndarray) -> None:  # pragma: no cover
    """ROW over the rows start..stop of a batch of the model in (ints, floats); ``work`` one scratch buffer."""
    m = arrays(ints, floats)
    s = scratch(work, m.parent.shape[0])
    for i in range(start, stop):
        ROW(i, m, s, a)  # type: ignore[name-defined]  # noqa: F821 (bound by driver())


def _parallel_template(size: int, ints: np.ndarray, floats: np.ndarray, a: Any, WORK: np.ndarray) -> None:  # pragma: no cover
    """SERIAL on blocks of STEP rows, one block per thread at a time; WORK one scratch buffer per thread."""
    for b in prange((size + STEP - 1) // STEP):  # type: ignore[name-defined]  # noqa: F821 (bound by driver())
        SERIAL(b * STEP, min(size, (b + 1) * STEP), ints, floats, a, WORK[_thread()])  # type: ignore[name-defined]  # noqa: F821


def _bind(template: Callable[..., Any], name: str, **names: Any) -> Callable[..., Any]:
    """A copy of ``template`` named ``name`` whose global ``names`` are the given objects (numba reads globals as
    compile-time constants, so ``ROW`` is inlined as if it had been typed there)."""
    func = types.FunctionType(template.__code__, {**template.__globals__, **names}, name, template.__defaults__)
    func.__qualname__ = name
    func.__doc__ = (template.__doc__ or "").replace("ROW", name.rsplit("_", 1)[0])
    return func


class Batched:
    """A driver: the serial range kernel for small batches, its parallel twin from :attr:`PARALLEL_MIN` rows."""

    #: Batches at least this large run on numba's threads (when there is more than one).
    PARALLEL_MIN = 256

    def __init__(self, serial: Any, parallel: Any, parallel_min: int | None = None) -> None:
        self.serial, self.parallel = serial, parallel
        if parallel_min is not None:
            self.PARALLEL_MIN = parallel_min

    def __call__(self, size: int, t: Tree, *a: Any) -> Any:
        """Run on ``size`` rows of the model ``t`` with the call's arrays ``a``; the scratch buffers are made here.

        The kernels make views of their scratch without reference counting (cheaper), so the
        buffers must outlive the call: they are arguments, held by this frame.
        """
        length = work_size(t.n_bodies)
        if size >= self.PARALLEL_MIN and numba.get_num_threads() > 1:
            threads = numba.config.NUMBA_NUM_THREADS  # type: ignore[attr-defined]  # every thread id is below it
            return self.parallel(size, t.ints, t.floats, a, np.empty((threads, length)))
        return self.serial(0, size, t.ints, t.floats, a, np.empty(length))


def driver(name: str, row: Any, *, block: int = BLOCK, parallel_min: int | None = None) -> Batched:
    """The serial and parallel drivers of the row kernel ``row`` (``block`` rows per parallel task)."""
    serial = kernel()(_bind(_serial_template, f"{name}_serial", ROW=row))
    parallel = kernel(parallel=True)(_bind(_parallel_template, f"{name}_parallel", SERIAL=serial, STEP=block))
    return Batched(serial, parallel, parallel_min)


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
def _jstar_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """a = (Q, OUT (C, 6E, N)): J*."""
    Q, OUT = a
    jstar_one(Q[i], m, s, OUT[i])


@kernel(inline="always")
def _hplus_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """a = (Q, OUT (C, 6 + N, 6 + N)): H+."""
    Q, OUT = a
    hplus_one(Q[i], m, s, OUT[i])


@kernel(inline="always")
def _inverse_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """a = (Q, V, A, U, T0, ext_i, EXT, accelerate, OUT (C, 3 + N)): rows [omega0, q] of H+ zddot0 + C+ - Q_u - Q_ext
    (accelerate False: zddot0 = 0)."""
    Q, V, A, U, T0, ext_i, EXT, accelerate, OUT = a
    prepare(Q[i], m, s, True)
    newton_euler(m, s, V[i], A[i], accelerate, U[i], T0[i], ext_i, EXT[i], OUT[i])


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
    """Fixed-step RK4 of trajectory b (row of X0 (K, S)) with the joint PD u = ff[k] + kp (qref - q) + kd (vref - qdot).

    a = (X0, dt, steps, hold, stride, kp, kd, qref, vref, ff, lim, ext_i, EXT, XS, US, SAT, DONE). The controller
    is sampled every ``hold`` steps (ff[k] at sample k, the last one held), clipped to +-lim; states, actuations
    and saturation flags are recorded at step 0, every ``stride`` steps and at the last step. DONE[b] = the steps
    completed (fewer: a non-finite state or H+ failed; the records after it are NaN).
    """
    X0, dt, steps, hold, stride, kp, kd, qref, vref, ff, lim, ext_i, EXT, XS, US, SAT, DONE = a
    n = m.parent.shape[0] - 1
    size = X0.shape[1]
    x, u = s.state, s.control
    for j in range(n + 6):
        u[j] = 0.0
    for i in range(size):
        x[i] = X0[b, i]
    row = 0
    sample = 0
    flag = False
    DONE[b] = steps
    for step in range(steps + 1):
        if step > 0:
            ok = rk4_step(x, u, dt, m, ext_i, EXT[b], s)
            total = 0.0
            for i in range(size):
                total += x[i]
            if not ok or not math.isfinite(total):
                DONE[b] = step - 1 if not ok else step
                for r in range(row, XS.shape[0]):
                    for i in range(size):
                        XS[r, b, i] = np.nan
                    for j in range(n + 6):
                        US[r, b, j] = np.nan
                    SAT[r, b] = False
                break
        if step == 0 or (step % hold == 0 and step < steps):
            flag = joint_pd(ff, min(sample, ff.shape[0] - 1), b, kp, kd, qref, vref, lim, x, 0, u, 0, 1)
            sample += 1
        if step == 0 or step % stride == 0 or step == steps:
            for i in range(size):
                XS[row, b, i] = x[i]
            for j in range(n + 6):
                US[row, b, j] = u[j]
            SAT[row, b] = flag
            row += 1


frames_batch = driver("frames", _frames_row)
points_batch = driver("points", _points_row)
point_jacobian_batch = driver("point_jacobian", _point_jacobian_row)
jstar_batch = driver("jstar", _jstar_row)
hplus_batch = driver("hplus", _hplus_row)
inverse_batch = driver("inverse", _inverse_row)
forward_batch = driver("forward", _forward_row)
derivative_batch = driver("derivative", _derivative_row)
rollout_batch = driver("rollout", _rollout_row, block=1, parallel_min=2)  # one trajectory is long work: threads pay from two
