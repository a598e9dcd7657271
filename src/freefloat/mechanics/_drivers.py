"""Batch drivers of the engine: loops over configurations (or trajectories) of the one-configuration kernels.

Each driver is a serial kernel over a range ``[start, stop)`` of rows (one scratch buffer per
range, made by :class:`Batched` and passed in; one row per thread for the parallel kernel) and a
parallel kernel that cuts the batch into blocks of :data:`BLOCK` rows and runs the
serial kernel on each block with ``prange``. Small batches call the serial kernel directly (no
thread start-up); :class:`Batched` chooses. The one-configuration kernels are inlined into the
serial range kernels only, never into a ``prange`` body.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numba
import numpy as np
from numba import prange

from ._configuration import accelerations_one, hplus_one, jstar_one, point_jacobian_one, points_one, rk4_step, state_derivative_one
from ._lanes import joint_pd
from ._numba_cache import kernel
from ._recursions import kinematics, newton_euler, prepare, scratch
from ._tree import work_size

__all__ = [
    "BLOCK",
    "Batched",
    "derivative_batch",
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


class Batched:
    """A driver: the serial range kernel for small batches, its parallel twin from :attr:`PARALLEL_MIN` rows."""

    #: Batches at least this large run on numba's threads (when there is more than one).
    PARALLEL_MIN = 256

    def __init__(self, serial: Callable[..., Any], parallel: Callable[..., Any]) -> None:
        self.serial, self.parallel = serial, parallel
        self.__doc__ = serial.__doc__

    def __call__(self, size: int, n_bodies: int, *args: Any) -> Any:
        """Run on ``size`` rows of a tree of ``n_bodies`` bodies; the scratch buffers are made here.

        The kernels make views of their scratch without reference counting (cheaper), so the
        buffers must outlive the call: they are arguments, held by this frame.
        """
        length = work_size(n_bodies)
        if size >= self.PARALLEL_MIN and numba.get_num_threads() > 1:
            threads = numba.config.NUMBA_NUM_THREADS  # type: ignore[attr-defined]  # every thread id is below it
            return self.parallel(*args, np.empty((threads, length)))
        return self.serial(0, size, *args, np.empty(length))


# ----------------------------------------------------------------- kinematics
@kernel()
def _frames_range(
    start: int, stop: int, Q: np.ndarray, parent: np.ndarray, body: np.ndarray, ROT: np.ndarray, POS: np.ndarray, work: np.ndarray
) -> None:  # pragma: no cover
    """⁰T_k and the body frame origins (from O) of rows start..stop."""
    nb = parent.shape[0]
    s = scratch(work, nb)
    for i in range(start, stop):
        kinematics(Q[i], parent, body, ROT[i], POS[i], s.axis, s.mom)


@kernel(parallel=True)
def _frames_parallel(
    Q: np.ndarray, parent: np.ndarray, body: np.ndarray, ROT: np.ndarray, POS: np.ndarray, WORK: np.ndarray
) -> None:  # pragma: no cover
    size = Q.shape[0]
    for b in prange((size + BLOCK - 1) // BLOCK):
        _frames_range(b * BLOCK, min(size, (b + 1) * BLOCK), Q, parent, body, ROT, POS, WORK[_thread()])


@kernel()
def _points_range(
    start: int,
    stop: int,
    Q: np.ndarray,
    parent: np.ndarray,
    body: np.ndarray,
    total_mass: float,
    pbody: np.ndarray,
    ppoint: np.ndarray,
    OUT: np.ndarray,
    work: np.ndarray,
) -> None:  # pragma: no cover
    """Points relative to the system CM of rows start..stop."""
    s = scratch(work, parent.shape[0])
    for i in range(start, stop):
        points_one(Q[i], parent, body, total_mass, pbody, ppoint, s, OUT[i])


@kernel(parallel=True)
def _points_parallel(
    Q: np.ndarray,
    parent: np.ndarray,
    body: np.ndarray,
    total_mass: float,
    pbody: np.ndarray,
    ppoint: np.ndarray,
    OUT: np.ndarray,
    WORK: np.ndarray,
) -> None:  # pragma: no cover
    size = Q.shape[0]
    for b in prange((size + BLOCK - 1) // BLOCK):
        _points_range(b * BLOCK, min(size, (b + 1) * BLOCK), Q, parent, body, total_mass, pbody, ppoint, OUT, WORK[_thread()])


# ----------------------------------------------------------------- Jacobians and H+
@kernel()
def _point_jacobian_range(
    start: int,
    stop: int,
    Q: np.ndarray,
    parent: np.ndarray,
    body: np.ndarray,
    ancestor: np.ndarray,
    total_mass: float,
    pbody: np.ndarray,
    ppoint: np.ndarray,
    OUT: np.ndarray,
    work: np.ndarray,
) -> None:  # pragma: no cover
    """J+ of points of rows start..stop."""
    s = scratch(work, parent.shape[0])
    for i in range(start, stop):
        point_jacobian_one(Q[i], parent, body, ancestor, total_mass, pbody, ppoint, s, OUT[i])


@kernel(parallel=True)
def _point_jacobian_parallel(
    Q: np.ndarray,
    parent: np.ndarray,
    body: np.ndarray,
    ancestor: np.ndarray,
    total_mass: float,
    pbody: np.ndarray,
    ppoint: np.ndarray,
    OUT: np.ndarray,
    WORK: np.ndarray,
) -> None:  # pragma: no cover
    size = Q.shape[0]
    for b in prange((size + BLOCK - 1) // BLOCK):
        _point_jacobian_range(
            b * BLOCK, min(size, (b + 1) * BLOCK), Q, parent, body, ancestor, total_mass, pbody, ppoint, OUT, WORK[_thread()]
        )


@kernel()
def _jstar_range(
    start: int,
    stop: int,
    Q: np.ndarray,
    parent: np.ndarray,
    body: np.ndarray,
    ancestor: np.ndarray,
    total_mass: float,
    ee_body: np.ndarray,
    ee_point: np.ndarray,
    OUT: np.ndarray,
    work: np.ndarray,
) -> None:  # pragma: no cover
    """J* of rows start..stop."""
    s = scratch(work, parent.shape[0])
    for i in range(start, stop):
        jstar_one(Q[i], parent, body, ancestor, total_mass, ee_body, ee_point, s, OUT[i])


@kernel(parallel=True)
def _jstar_parallel(
    Q: np.ndarray,
    parent: np.ndarray,
    body: np.ndarray,
    ancestor: np.ndarray,
    total_mass: float,
    ee_body: np.ndarray,
    ee_point: np.ndarray,
    OUT: np.ndarray,
    WORK: np.ndarray,
) -> None:  # pragma: no cover
    size = Q.shape[0]
    for b in prange((size + BLOCK - 1) // BLOCK):
        _jstar_range(
            b * BLOCK,
            min(size, (b + 1) * BLOCK),
            Q,
            parent,
            body,
            ancestor,
            total_mass,
            ee_body,
            ee_point,
            OUT,
            WORK[_thread()],
        )


@kernel()
def _hplus_range(
    start: int,
    stop: int,
    Q: np.ndarray,
    parent: np.ndarray,
    body: np.ndarray,
    ancestor: np.ndarray,
    total_mass: float,
    OUT: np.ndarray,
    work: np.ndarray,
) -> None:  # pragma: no cover
    """H+ of rows start..stop."""
    s = scratch(work, parent.shape[0])
    for i in range(start, stop):
        hplus_one(Q[i], parent, body, ancestor, total_mass, s, OUT[i])


@kernel(parallel=True)
def _hplus_parallel(
    Q: np.ndarray, parent: np.ndarray, body: np.ndarray, ancestor: np.ndarray, total_mass: float, OUT: np.ndarray, WORK: np.ndarray
) -> None:  # pragma: no cover
    size = Q.shape[0]
    for b in prange((size + BLOCK - 1) // BLOCK):
        _hplus_range(b * BLOCK, min(size, (b + 1) * BLOCK), Q, parent, body, ancestor, total_mass, OUT, WORK[_thread()])


# ----------------------------------------------------------------- dynamics
@kernel()
def _inverse_range(
    start: int,
    stop: int,
    Q: np.ndarray,
    V: np.ndarray,
    A: np.ndarray,
    U: np.ndarray,
    T0: np.ndarray,
    parent: np.ndarray,
    body: np.ndarray,
    total_mass: float,
    ext_i: np.ndarray,
    EXT: np.ndarray,
    accelerate: bool,
    OUT: np.ndarray,
    work: np.ndarray,
) -> None:  # pragma: no cover
    """Rows [omega0, q] of H+ zddot0 + C+ - Q_u - Q_ext of rows start..stop (accelerate False: zddot0 = 0)."""
    s = scratch(work, parent.shape[0])
    for i in range(start, stop):
        prepare(Q[i], parent, body, s, True)
        newton_euler(body, parent, total_mass, s, V[i], A[i], accelerate, U[i], T0[i], ext_i, EXT[i], OUT[i])


@kernel(parallel=True)
def _inverse_parallel(
    Q: np.ndarray,
    V: np.ndarray,
    A: np.ndarray,
    U: np.ndarray,
    T0: np.ndarray,
    parent: np.ndarray,
    body: np.ndarray,
    total_mass: float,
    ext_i: np.ndarray,
    EXT: np.ndarray,
    accelerate: bool,
    OUT: np.ndarray,
    WORK: np.ndarray,
) -> None:  # pragma: no cover
    size = Q.shape[0]
    for b in prange((size + BLOCK - 1) // BLOCK):
        _inverse_range(
            b * BLOCK,
            min(size, (b + 1) * BLOCK),
            Q,
            V,
            A,
            U,
            T0,
            parent,
            body,
            total_mass,
            ext_i,
            EXT,
            accelerate,
            OUT,
            WORK[_thread()],
        )


@kernel()
def _forward_range(
    start: int,
    stop: int,
    Q: np.ndarray,
    V: np.ndarray,
    U: np.ndarray,
    T0: np.ndarray,
    parent: np.ndarray,
    body: np.ndarray,
    ancestor: np.ndarray,
    total_mass: float,
    ext_i: np.ndarray,
    EXT: np.ndarray,
    OUT: np.ndarray,
    OK: np.ndarray,
    work: np.ndarray,
) -> None:  # pragma: no cover
    """zddot0 of rows start..stop; OK[i] False where H+ is not positive definite."""
    s = scratch(work, parent.shape[0])
    for i in range(start, stop):
        OK[i] = accelerations_one(Q[i], V[i], U[i], T0[i], parent, body, ancestor, total_mass, ext_i, EXT[i], s, OUT[i])


@kernel(parallel=True)
def _forward_parallel(
    Q: np.ndarray,
    V: np.ndarray,
    U: np.ndarray,
    T0: np.ndarray,
    parent: np.ndarray,
    body: np.ndarray,
    ancestor: np.ndarray,
    total_mass: float,
    ext_i: np.ndarray,
    EXT: np.ndarray,
    OUT: np.ndarray,
    OK: np.ndarray,
    WORK: np.ndarray,
) -> None:  # pragma: no cover
    size = Q.shape[0]
    for b in prange((size + BLOCK - 1) // BLOCK):
        _forward_range(
            b * BLOCK,
            min(size, (b + 1) * BLOCK),
            Q,
            V,
            U,
            T0,
            parent,
            body,
            ancestor,
            total_mass,
            ext_i,
            EXT,
            OUT,
            OK,
            WORK[_thread()],
        )


@kernel()
def _derivative_range(
    start: int,
    stop: int,
    X: np.ndarray,
    U: np.ndarray,
    parent: np.ndarray,
    body: np.ndarray,
    ancestor: np.ndarray,
    total_mass: float,
    ext_i: np.ndarray,
    EXT: np.ndarray,
    OUT: np.ndarray,
    OK: np.ndarray,
    work: np.ndarray,
) -> None:  # pragma: no cover
    """d/dt of the flat states of rows start..stop."""
    s = scratch(work, parent.shape[0])
    q = np.empty(parent.shape[0] - 1)
    for i in range(start, stop):
        OK[i] = state_derivative_one(X[i], U[i], parent, body, ancestor, total_mass, ext_i, EXT[i], s, q, OUT, i)


@kernel(parallel=True)
def _derivative_parallel(
    X: np.ndarray,
    U: np.ndarray,
    parent: np.ndarray,
    body: np.ndarray,
    ancestor: np.ndarray,
    total_mass: float,
    ext_i: np.ndarray,
    EXT: np.ndarray,
    OUT: np.ndarray,
    OK: np.ndarray,
    WORK: np.ndarray,
) -> None:  # pragma: no cover
    size = X.shape[0]
    for b in prange((size + BLOCK - 1) // BLOCK):
        _derivative_range(
            b * BLOCK,
            min(size, (b + 1) * BLOCK),
            X,
            U,
            parent,
            body,
            ancestor,
            total_mass,
            ext_i,
            EXT,
            OUT,
            OK,
            WORK[_thread()],
        )


# ----------------------------------------------------------------- rollouts with a joint PD in the loop
@kernel()
def _rollout_range(
    start: int,
    stop: int,
    X0: np.ndarray,
    dt: float,
    steps: int,
    hold: int,
    stride: int,
    kp: np.ndarray,
    kd: np.ndarray,
    qref: np.ndarray,
    vref: np.ndarray,
    ff: np.ndarray,
    lim: np.ndarray,
    parent: np.ndarray,
    body: np.ndarray,
    ancestor: np.ndarray,
    total_mass: float,
    ext_i: np.ndarray,
    EXT: np.ndarray,
    XS: np.ndarray,
    US: np.ndarray,
    SAT: np.ndarray,
    DONE: np.ndarray,
    work: np.ndarray,
) -> None:  # pragma: no cover
    """Fixed-step RK4 of trajectories start..stop (rows of X0 (K, S)) with the joint PD u = ff[k] + kp (qref - q) + kd (vref - qdot).

    The controller is sampled every ``hold`` steps (ff[k] at sample k, the last one held), clipped to
    +-lim; states, actuations and saturation flags are recorded at step 0, every ``stride`` steps and
    at the last step. DONE[b] = the steps completed (fewer: a non-finite state or H+ failed; the
    records after it are NaN).
    """
    nb = parent.shape[0]
    n = nb - 1
    size = X0.shape[1]
    s = scratch(work, nb)
    q = np.empty(n)
    x = np.empty(size)
    u = np.zeros(n + 6)
    for b in range(start, stop):
        for i in range(size):
            x[i] = X0[b, i]
        row = 0
        sample = 0
        flag = False
        DONE[b] = steps
        for step in range(steps + 1):
            if step > 0:
                ok = rk4_step(x, u, dt, parent, body, ancestor, total_mass, ext_i, EXT[b], s, q)
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


@kernel(parallel=True)
def _rollout_parallel(
    X0: np.ndarray,
    dt: float,
    steps: int,
    hold: int,
    stride: int,
    kp: np.ndarray,
    kd: np.ndarray,
    qref: np.ndarray,
    vref: np.ndarray,
    ff: np.ndarray,
    lim: np.ndarray,
    parent: np.ndarray,
    body: np.ndarray,
    ancestor: np.ndarray,
    total_mass: float,
    ext_i: np.ndarray,
    EXT: np.ndarray,
    XS: np.ndarray,
    US: np.ndarray,
    SAT: np.ndarray,
    DONE: np.ndarray,
    WORK: np.ndarray,
) -> None:  # pragma: no cover
    for b in prange(X0.shape[0]):
        _rollout_range(
            b,
            b + 1,
            X0,
            dt,
            steps,
            hold,
            stride,
            kp,
            kd,
            qref,
            vref,
            ff,
            lim,
            parent,
            body,
            ancestor,
            total_mass,
            ext_i,
            EXT,
            XS,
            US,
            SAT,
            DONE,
            WORK[_thread()],
        )


frames_batch = Batched(_frames_range, _frames_parallel)
points_batch = Batched(_points_range, _points_parallel)
point_jacobian_batch = Batched(_point_jacobian_range, _point_jacobian_parallel)
jstar_batch = Batched(_jstar_range, _jstar_parallel)
hplus_batch = Batched(_hplus_range, _hplus_parallel)
inverse_batch = Batched(_inverse_range, _inverse_parallel)
forward_batch = Batched(_forward_range, _forward_parallel)
derivative_batch = Batched(_derivative_range, _derivative_parallel)
rollout_batch = Batched(_rollout_range, _rollout_parallel)
rollout_batch.PARALLEL_MIN = 2  # one trajectory is long work: threads pay from two
