"""Batch drivers of the specialised lane kernels (:mod:`.build`): blocks of :data:`LANES` configurations.

A lane kernel ``lane(W, P)`` computes one result for :data:`LANES` configurations at once: W is a
flat buffer of rows of LANES values (its inputs first, then its outputs), P the model's data
(mass properties, end-effector points). The rows make the loop over configurations a loop over
adjacent memory with constant offsets, which the compiler turns into SIMD instructions (eight
float64 lanes on AVX-512). These drivers copy each block of a user's batch into W (rows), call the
lane kernel, and copy the outputs back; they hold no physics: J* and the state derivative are the
traced recursions of :mod:`freefloat.engine.recursions`. The rollout loop (``_rollout_blocks``: the controller, the
records and the failures) is written once, for rows of ``width`` lanes, and bound to an RK4 step and a controller by
:func:`rollout_loop`: the specialised rollouts run it :data:`LANES` lanes wide with :func:`_rk4_rows` on their lane
kernel (:func:`bound_loops`), the generic rollout and the compiled single simulations (:mod:`freefloat.engine.drivers`)
one lane wide with the engine's RK4 step of one state (:func:`freefloat.engine.quantities.rk4_step`, through
``rk4_step_rows``). They are inlined into the kernels of each generated module (:func:`~.build.load`) and into the
generic rollout kernels.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numba
import numpy as np

from ..cache import bind
from ..layout import ATTITUDE_AT, Q_AT, coordinates, qdot_at

__all__ = [
    "LANES",
    "block_rows",
    "bound_loops",
    "feed",
    "joint_pd",
    "map_blocks",
    "measure_loop",
    "rollout_loop",
    "rollout_rows",
]

#: Configurations per lane block (a multiple of the SIMD width): 16 was slower on the 7-DOF arm; 32, 64 and 128 were
#: as fast as each other.
LANES = 64


@numba.njit(inline="always", nogil=True, error_model="numpy")
def joint_pd(
    C: Any, P: Any, sample: int, t: float, b: int, lim: np.ndarray, x: np.ndarray, x0: int, u: np.ndarray, u0: int, step: int
) -> bool:  # pragma: no cover
    """The joint PD of the rollouts at sample ``sample`` (time t) of trajectory b: C = (kp, kd, qref, vref, ff) (each
    (K, N); ff the feed-forward (S, K, W) as (values, S, sample stride, trajectory stride, W): the values read at
    sample * sample stride + b * trajectory stride + j, so that any layout of the caller's array is read in place:
    ``feed``), u = ff[sample, b] (its last sample held) + kp (qref - q) + kd (vref - qdot), clipped to +-lim.

    The flat state is x[x0 + i * step] (i = 0, 1, ...: ``core.state_layout``) and u is written to u[u0 + j * step] (j = 0 .. N + 6):
    step 1 for one trajectory, LANES for a lane of a block (``_rollout_blocks``). True if any
    component was clipped. A controller of the rollout loop has this signature (``P``: the lane kernel's data).
    """
    kp, kd, qref, vref, (ff, samples, sample_stride, trajectory_stride, width) = C
    at = min(sample, samples - 1) * sample_stride + b * trajectory_stride
    n = kp.shape[1]
    sat = False
    for j in range(n + 6):
        val = ff[at + j] if j < width else 0.0
        if j < n:
            val += kp[b, j] * (qref[b, j] - x[x0 + (Q_AT + j) * step]) + kd[b, j] * (vref[b, j] - x[x0 + (qdot_at(n) + j) * step])
        if val > lim[j]:
            val = lim[j]
            sat = True
        elif val < -lim[j]:
            val = -lim[j]
            sat = True
        u[u0 + j * step] = val
    return sat


#: A joint PD's feed-forward as the compiled rollouts read it (:func:`joint_pd`): (values, samples, sample
#: stride, trajectory stride, width).
Feed = tuple[np.ndarray, int, int, int, int]


def feed(ff: np.ndarray) -> Feed:
    """A joint PD's feed-forward ff (S, K, W) as the compiled rollouts read it: a flat read-only float64 view of its
    memory with the strides of its first two axes (in values), read in place whatever its layout: a series that every
    trajectory shares (broadcast: trajectory stride 0), per-trajectory series laid out (K, S, W) (as
    ``mujoco.rollout`` takes them) and swapped to (S, K, W), a chunk of the trajectories. A copy only when its values
    are not float64 a stride apart along W, or a stride is negative (a large swapped series is read in place, not
    copied). Always read-only: numba compiles one signature for it."""
    a = np.asarray(ff, dtype=np.float64)
    item = a.itemsize
    if a.size == 0:  # no samples (or no trajectories): no feed-forward, width 0 (joint_pd reads none of it)
        empty = np.zeros(0)
        empty.flags.writeable = False
        return empty, 1, 0, 0, 0
    if a.strides[2] != item or min(a.strides) < 0 or not a.flags.aligned:
        a = np.array(a, order="C", copy=True)  # a new, aligned array (ascontiguousarray keeps a misaligned C array)
    samples, trajectories, width = a.shape
    sample_stride = a.strides[0] // item if samples > 1 else 0
    trajectory_stride = a.strides[1] // item if trajectories > 1 else 0
    extent = (samples - 1) * sample_stride + (trajectories - 1) * trajectory_stride + width
    flat = np.lib.stride_tricks.as_strided(a, shape=(extent,), strides=(item,), writeable=False)
    return flat, samples, sample_stride, trajectory_stride, width


@numba.njit(inline="always", nogil=True, error_model="numpy")
def map_blocks(
    lane: Any,
    gather: Any,
    parts: Any,
    P: np.ndarray,
    OUT: np.ndarray,
    rows: np.ndarray,
    W: np.ndarray,
    first: int,
    last: int,
) -> None:  # pragma: no cover
    """OUT[b] = f(inputs of b) for the blocks first..last (configurations LANES * block on), f the lane kernel.

    ``parts``: the inputs, a tuple of arrays (C, width) or (1, width) (the same row for every configuration), read in
    order into the input rows of W; a part of one row is written once per call. ``rows`` (OUT's columns,): the W row
    that holds each column (a module's outputs are distinct values, a value used twice is one row: H+'s symmetric
    entries). ``gather(W, dst, at, first, last)``: the module's copy of the outputs of the lanes first..last into
    ``dst[at:]``, a configuration's row after another, each value from its row of W (``rows``, as constant offsets).
    OUT: the outputs (C, columns), C-contiguous, flat (C * columns,). W: the lane rows, the guards' row (reset to 1.0
    before each block; a lane kernel with guards multiplies it). The outputs are written a configuration's row at a
    time, contiguous (faster than one column of eight configurations at a time).
    """
    n_out = rows.shape[0]
    guard = W.shape[0] // LANES - 1
    size = OUT.shape[0] // n_out
    for block in range(first, last):
        b0 = block * LANES
        count = min(LANES, size - b0)
        at = 0
        for part in parts:  # part by part: a configuration at a time, with this loop inside, ran several times slower
            width = part.shape[1]
            if part.shape[0] != 1:
                for lane_ in range(LANES):
                    src = b0 + (lane_ if lane_ < count else count - 1)  # a short last block repeats its last row
                    for j in range(width):
                        W[(at + j) * LANES + lane_] = part[src, j]
            elif block == first:
                for j in range(width):
                    for lane_ in range(LANES):
                        W[(at + j) * LANES + lane_] = part[0, j]
            at += width
        for lane_ in range(LANES):
            W[guard * LANES + lane_] = 1.0
        lane(W, P)
        gather(W, OUT, b0 * n_out, 0, count)


@numba.njit(inline="always", nogil=True, error_model="numpy")
def block_rows(A: np.ndarray, W: np.ndarray, at: int, block: int) -> None:  # pragma: no cover
    """The rows of A (K, R) of the block ``block`` into the rows at..at + R of W, LANES values a row (a short last block
    repeats its last row): per-trajectory inputs that stay constant over a rollout (its external wrenches)."""
    b0 = block * LANES
    count = min(LANES, A.shape[0] - b0)
    for lane_ in range(LANES):
        src = b0 + (lane_ if lane_ < count else count - 1)
        for j in range(A.shape[1]):
            W[(at + j) * LANES + lane_] = A[src, j]


def _measure_blocks(
    Q: np.ndarray, P: Any, rows: np.ndarray, kind: int, OUT: np.ndarray, W: np.ndarray, first: int, last: int
) -> None:  # pragma: no cover
    """OUT[b] = a measure of the rows ``rows`` of J*(Q[b]) for the blocks first..last: the lane kernel ``LANE`` writes the
    J* of a block into W (inputs, then the K = 6E rows of J* (N each), then ``WORK`` rows of work space), and the engine's
    measure reduces them, :data:`LANES` configurations at a time: the smallest singular value of all the rows, in
    order (kind 1), by the traced reduction ``REDUCE`` (straight-line, the reduced rows written after J*, at the work
    space) and ``FINISH`` (:func:`freefloat.engine.measures.measure_finish_lanes`); any other measure or rows by ``MEASURE``
    (:func:`freefloat.engine.measures.jacobian_measure_lanes`). ``LANE``, ``MEASURE``, ``REDUCE``, ``FINISH``, ``N`` (the joints),
    ``K``, ``R`` (min(K, N)) and ``WORK`` are bound by :func:`measure_loop` as constants; ``MEASURE`` and ``FINISH`` hand the
    block to the engine's compiled measure (``measures._measure_views``, ``measures._finish_views``, not inlined)."""
    size = Q.shape[0]
    off = N * LANES  # type: ignore[name-defined]  # noqa: F821 (bound by measure_loop)
    tmp = W[W.shape[0] - WORK * LANES :]  # type: ignore[name-defined]  # noqa: F821
    traced = kind == 1 and rows.shape[0] == K  # type: ignore[name-defined]  # noqa: F821
    for j in range(rows.shape[0]):
        traced = traced and rows[j] == j
    jstar = W[off:]
    for block in range(first, last):
        b0 = block * LANES
        count = min(LANES, size - b0)
        for lane_ in range(LANES):
            src = b0 + (lane_ if lane_ < count else count - 1)  # a short last block repeats its last row
            for j in range(N):  # type: ignore[name-defined]  # noqa: F821
                W[j * LANES + lane_] = Q[src, j]
        LANE(W, P)  # type: ignore[name-defined]  # noqa: F821
        if traced:
            REDUCE(jstar, P)  # type: ignore[name-defined]  # noqa: F821
            FINISH(tmp, 0, LANES, R, kind, OUT, b0, count)  # type: ignore[name-defined]  # noqa: F821
        else:
            MEASURE(W, off, LANES, N, rows, kind, tmp, OUT, b0, count)  # type: ignore[name-defined]  # noqa: F821


@functools.cache
def measure_loop(lane: Any, measure: Any, reduce: Any, finish: Any, n: int, k: int, work: int, name: str) -> Any:
    """The measure loop above for the lane kernel ``lane`` (J* of a block, ``k`` rows of ``n``), the measure ``measure``,
    the traced reduction ``reduce`` of the smallest singular value of all k rows and its finish ``finish``, and ``work``
    rows of the measure's work space at the end of W, bound as globals (inlined where called):
    ``measure_blocks(Q, P, rows, kind, OUT, W, first, last)``."""
    return numba.njit(inline="always", nogil=True, error_model="numpy")(
        bind(
            _measure_blocks,
            f"measure_blocks_{name}",
            LANE=lane,
            MEASURE=measure,
            REDUCE=reduce,
            FINISH=finish,
            N=n,
            K=k,
            R=min(k, n),
            WORK=work,
        )
    )


def _rk4_rows(P: Any, W: np.ndarray, width: int, size: int, nu: int, dt: float) -> None:  # pragma: no cover
    """One classical RK4 step of the ``width`` states in the x rows of W (u held), each quaternion renormalised after it
    (the same formulas as :func:`freefloat.engine.quantities.rk4_step`, written for rows of lanes;
    ``tests/mechanics/test_specialise.py`` checks the two against each other); the ok row is 1.0 where every stage's H+
    was positive definite, else 0.0. ``LANE`` (bound by :func:`bound_loops`) is the lane kernel.

    W = [y (S rows), u (N + 6 rows), dy/dt (S rows), ok (1 row), x (S rows), sum of the stage derivatives (S rows),
    ...], rows of ``width`` values; ``LANE(W, P)`` writes dy/dt at y and u (and multiplies ok by 0.0 where H+
    failed). The four stages run in a loop, so that the lane kernel is inlined once (compile time).
    """
    o_k = (size + nu) * width
    o_ok = o_k + size * width
    o_x = o_ok + width
    o_acc = o_x + size * width
    for i in range(size * width):
        W[i] = W[o_x + i]
        W[o_acc + i] = 0.0
    for lane_ in range(width):
        W[o_ok + lane_] = 1.0
    for stage in range(4):
        LANE(W, P)  # type: ignore[name-defined]  # noqa: F821 (bound by bound_loops)
        weight = 1.0 if stage == 0 or stage == 3 else 2.0
        c = dt if stage == 2 else 0.5 * dt
        for i in range(size * width):
            W[o_acc + i] += weight * W[o_k + i]
            if stage < 3:
                W[i] = W[o_x + i] + c * W[o_k + i]
    c = dt / 6.0
    for i in range(size * width):
        W[o_x + i] += c * W[o_acc + i]
    for lane_ in range(width):  # the quaternion renormalised
        a = W[o_x + ATTITUDE_AT * width + lane_]
        b = W[o_x + (ATTITUDE_AT + 1) * width + lane_]
        cc = W[o_x + (ATTITUDE_AT + 2) * width + lane_]
        d = W[o_x + (ATTITUDE_AT + 3) * width + lane_]
        norm = math.sqrt(a * a + b * b + cc * cc + d * d)
        for i in range(ATTITUDE_AT, ATTITUDE_AT + 4):
            W[o_x + i * width + lane_] /= norm


def _rollout_blocks(
    P: Any,
    width: int,
    first: int,
    last: int,
    X0: np.ndarray,
    dt: float,
    steps: int,
    hold: int,
    stride: int,
    C: Any,
    lim: np.ndarray,
    XS: np.ndarray,
    US: np.ndarray,
    SAT: np.ndarray,
    DONE: np.ndarray,
    W: np.ndarray,
) -> None:  # pragma: no cover
    """The rollout loop, written once: fixed-step RK4 of the trajectories of blocks first..last, ``width`` at a time,
    with a controller in the loop: ``CONTROL(C, P, k, t, b, lim, W, x0, u0, width)`` (bound by :func:`rollout_loop`: the
    joint PD :func:`joint_pd`, C its gains; or a control law of :mod:`freefloat.engine.laws`, width 1, C its
    :data:`~freefloat.engine.laws.Law`). The generic rollout runs it with width 1, the specialised one with
    :data:`LANES`. Each step is ``RK4_ROWS(P, W, width, size, nu, dt)`` (bound by :func:`rollout_loop`: :func:`_rk4_rows`
    on a lane kernel, or the engine's ``rk4_step_rows``).

    Trajectory b (a row of X0 (K, S)): u = the controller's output at sample k (every ``hold``
    steps), clipped to +-lim; states, actuations and saturation flags recorded at step 0,
    every ``stride`` steps and the last step into XS, US, SAT; DONE[b] = the steps completed (fewer: a non-finite
    state or H+ not positive definite; the records after it are NaN).

    W = [y (S rows), u (N + 6 rows), dy/dt (S rows), ok (1 row), x (S rows), sum of the stage derivatives (S rows),
    failed (1 row), saturated (1 row)], rows of ``width`` values (:func:`rollout_rows`); the step reads x and u,
    advances x and sets ok to 0.0 in a lane whose H+ was not positive definite. ``P``: what the step reads besides W
    (a lane kernel's data; the generic step's model, wrenches and scratch).
    """
    size = X0.shape[1]
    n = coordinates(size)
    nu = n + 6
    k_total = X0.shape[0]
    o_u = size * width
    o_ok = o_u + (nu + size) * width
    o_x = o_ok + width
    o_fail = o_x + 2 * size * width
    o_flag = o_fail + width
    for block in range(first, last):
        b0 = block * width
        count = min(width, k_total - b0)
        for lane_ in range(width):
            src = b0 + (lane_ if lane_ < count else count - 1)
            for i in range(size):
                W[o_x + i * width + lane_] = X0[src, i]
            W[o_fail + lane_] = 0.0
        for lane_ in range(count):
            DONE[b0 + lane_] = steps
        row = 0
        sample = 0
        for step in range(steps + 1):
            if step > 0:
                RK4_ROWS(P, W, width, size, nu, dt)  # type: ignore[name-defined]  # noqa: F821 (bound by bound_loops)
                for lane_ in range(count):
                    if W[o_fail + lane_] != 0.0:
                        continue
                    total = 0.0
                    for i in range(size):
                        total += W[o_x + i * width + lane_]
                    ok = W[o_ok + lane_] != 0.0
                    if not ok or not math.isfinite(total):
                        DONE[b0 + lane_] = step - 1 if not ok else step
                        W[o_fail + lane_] = 1.0
            if step == 0 or (step % hold == 0 and step < steps):
                for lane_ in range(count):
                    sat = CONTROL(C, P, sample, step * dt, b0 + lane_, lim, W, o_x + lane_, W, o_u + lane_, width)  # type: ignore[name-defined]  # noqa: F821
                    W[o_flag + lane_] = 1.0 if sat else 0.0
                for lane_ in range(count, width):  # lanes past the batch: copy lane 0's controls
                    for j in range(nu):
                        W[o_u + j * width + lane_] = W[o_u + j * width]
                sample += 1
            if step == 0 or step % stride == 0 or step == steps:
                for lane_ in range(count):
                    b = b0 + lane_
                    if W[o_fail + lane_] != 0.0:
                        for i in range(size):
                            XS[row, b, i] = np.nan
                        for j in range(nu):
                            US[row, b, j] = np.nan
                        SAT[row, b] = False
                        continue
                    for i in range(size):
                        XS[row, b, i] = W[o_x + i * width + lane_]
                    for j in range(nu):
                        US[row, b, j] = W[o_u + j * width + lane_]
                    SAT[row, b] = W[o_flag + lane_] != 0.0
                row += 1


@functools.cache
def bound_loops(lane: Any, name: str) -> tuple[Any, Any]:
    """The RK4 step and the rollout loop above for the lane kernel ``lane``: (rk4_rows(P, W, width, size, nu, dt),
    rollout_blocks(P, width, first, last, X0, ...)) with the joint PD, both inlined where called. The lane kernel is
    bound as a global of copies of the one source (not passed as an argument), so that numba inlines it into the loop."""
    rk4 = numba.njit(inline="always", nogil=True, error_model="numpy")(bind(_rk4_rows, f"rk4_rows_{name}", LANE=lane))
    return rk4, rollout_loop(rk4, name)


@functools.cache
def rollout_loop(rk4_rows: Any, name: str, control: Any = joint_pd) -> Any:
    """The rollout loop above with the RK4 step ``rk4_rows(P, W, width, size, nu, dt)`` and the controller ``control``
    (:func:`joint_pd`, or a control law's adapter: :func:`freefloat.engine.laws.law_control`), bound as globals: inlined."""
    return numba.njit(inline="always", nogil=True, error_model="numpy")(
        bind(_rollout_blocks, f"rollout_blocks_{name}", RK4_ROWS=rk4_rows, CONTROL=control)
    )


def rollout_rows(size: int, nu: int) -> int:
    """Rows of the W buffer of ``_rollout_blocks`` for states of ``size`` and actuations of ``nu`` components."""
    return 4 * size + nu + 3
