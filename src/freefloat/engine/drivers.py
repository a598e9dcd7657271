"""Batch drivers of the engine: each one-configuration kernel, looped over a batch, in one thread or on several.

A driver is made from one *row* kernel, ``row(i, m, s, a)``: the work of row i of a batch, given the
model ``m`` (:data:`~.layout.Arrays`), the scratch views ``s`` (:data:`~.layout.Scratch`) and
the call's arrays ``a``: a named tuple (inputs, outputs and scalars) declared once, next to the row (``JstarCall``,
``RolloutCall``, ...), built by name by the caller (:mod:`.calls`) and read by name in the row (``a.q[i]``).
:func:`driver` makes from it, by binding it into the template written once below (:func:`_serial_template`), one range
kernel over the rows ``[start, stop)`` of a batch (one scratch buffer per range); :class:`Batched` runs it on the whole
batch, or from :attr:`Batched.PARALLEL_MIN` rows on one contiguous range per thread at once (:func:`~.threads.run_kernel`:
numba's threads call the kernel's machine code; no threaded twin is compiled). A new batched quantity is one row kernel,
its call's named tuple and one line ``driver(...)``.

The template is bound by copying its code with the row kernel as a global (not a closure), so
numba's on-disk cache keeps one entry per driver (keyed by the driver's name) across processes.
"""

from __future__ import annotations

from collections import namedtuple
from typing import Any

import numpy as np

from . import gate
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
    "DerivativeCall",
    "ForwardCall",
    "FramesCall",
    "HplusRateCall",
    "InverseCall",
    "LawRolloutCall",
    "MapCall",
    "MeasureCall",
    "PointBiasCall",
    "PointsCall",
    "RolloutCall",
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
    """ROW over the rows start..stop of a batch of the model in (ints, floats); ``work`` one scratch buffer; ``a`` the
    items of the call's named tuple CALL, named again here (numba unboxes a tuple's items faster than a named tuple)."""
    m = arrays(ints, floats)
    s = scratch(work, m.parent.shape[0], m.ee_body.shape[0], m.n_joints)
    call = CALL(*a)  # type: ignore[name-defined]  # noqa: F821 (bound by driver())
    for i in range(start, stop):
        ROW(i, m, s, call)  # type: ignore[name-defined]  # noqa: F821 (bound by driver())


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

    def __init__(self, serial: Any, call: Any, parallel_min: int | None = None) -> None:
        self.serial = serial
        self.call = call
        if parallel_min is not None:
            self.PARALLEL_MIN = parallel_min

    def __call__(self, size: int, t: Tree, a: Any) -> None:
        """Run on ``size`` rows of the model ``t`` with the call's arrays ``a`` (the driver's named tuple, :attr:`call`);
        the scratch buffers are made here.

        The kernels make views of their scratch without reference counting (cheaper), so the
        buffers must outlive the call: they are arguments, held by this frame.
        """
        if type(a) is not self.call:
            raise TypeError(f"freefloat: the driver takes a {self.call.__name__}, not a {type(a).__name__}")
        length = work_size(t.n_bodies, t.ee_body.shape[0])
        before = (gate.overload_count(self.serial), compiled_count())
        parts = threads_for(size, self.PARALLEL_MIN)
        work = np.empty((range_count(size, parts), length))
        run_kernel(self.serial, (t.ints, t.floats), work, tuple(a), size, parts)  # its items: the kernel names them again
        self.compiled = before[0] > 0 and before == (gate.overload_count(self.serial), compiled_count())


def driver(name: str, row: Any, call: Any, *, parallel_min: int | None = None) -> Batched:
    """The driver of the row kernel ``row`` with the call's arrays ``call`` (a named tuple class): its range kernel,
    compiled once, named ``<name>_serial`` in the cache."""
    return Batched(kernel()(bind(_serial_template, f"{name}_serial", ROW=row, CALL=call)), call, parallel_min)


# ----------------------------------------------------------------- the rollout loop, one trajectory at a time
#: The rollout loop of specialise.lanes, one trajectory at a time, stepped by the engine's RK4 step of one state
#: (quantities.rk4_step_rows, bound as a global: inlined), with the joint PD in it; and the same loop with
#: laws.law_control (a control law, or the joint PD) in it.
_rollout_blocks = rollout_loop(rk4_step_rows, "generic")
_law_rollout_blocks = rollout_loop(rk4_step_rows, "law", law_control)


# ----------------------------------------------------------------- the rows, each with its call's arrays
#: The configurations (C, N), and the outputs: ⁰T_k (C, B, 3, 3) and the body frame origins from O (C, B, 3).
FramesCall = namedtuple("FramesCall", ["q", "rot", "pos"])


@kernel(inline="always")
def _frames_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """⁰T_k and the body frame origins (from O) of row i (a: :data:`FramesCall`)."""
    kinematics(a.q[i], m, a.rot[i], a.pos[i], s.axis, s.mom)


#: The configurations (C, N), the points' bodies (P,) and positions in them (P, 3), the output (C, P, 3) or (C, P, 6, 6 + N).
PointsCall = namedtuple("PointsCall", ["q", "bodies", "points", "out"])


@kernel(inline="always")
def _points_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """Points relative to the system CM (a: :data:`PointsCall`)."""
    points_one(a.q[i], m, a.bodies, a.points, s, a.out[i])


@kernel(inline="always")
def _point_jacobian_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """J+ of points (a: :data:`PointsCall`, out (C, P, 6, 6 + N))."""
    point_jacobian_one(a.q[i], m, a.bodies, a.points, s, a.out[i])


#: The configurations (C, N) and velocities zdot0 (C, 6 + N), the points as in :data:`PointsCall`, the external
#: wrenches ext_i (W, 2) and ext (W, 9) (the same for every row; none: (0, 2), (0, 9)), the output (C, P, 6).
PointBiasCall = namedtuple("PointBiasCall", ["q", "v", "bodies", "points", "ext_i", "ext", "out"])


@kernel(inline="always")
def _point_bias_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """Jdot+ zdot0 of points (a: :data:`PointBiasCall`)."""
    point_bias_one(a.q[i], a.v[i], m, a.bodies, a.points, a.ext_i, a.ext, s, a.out[i])


#: The configurations (C, N) and the output: J* (C, 6E, N), H+ (C, 6 + N, 6 + N).
MapCall = namedtuple("MapCall", ["q", "out"])


@kernel(inline="always")
def _jstar_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """J* (a: :data:`MapCall`)."""
    jstar_one(a.q[i], m, s, a.out[i])


#: The configurations (C, N), the rows of J* (K,), the measure's code (``measures.MEASURE_CODES``), the output (C,).
MeasureCall = namedtuple("MeasureCall", ["q", "rows", "kind", "out"])


@kernel(inline="always")
def _measure_row(b: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """A measure of the rows ``a.rows`` of J* for the configurations of lane block b (a: :data:`MeasureCall`;
    :data:`~.specialise.lanes.LANES` of them, fewer in the last block): their J* one by one into the rows of a block
    buffer, then the measure of the whole block at once (SIMD across it, as in the specialised kernels); no J* batch written."""
    Q, rows, kind, OUT = a.q, a.rows, a.kind, a.out
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
    """H+ (a: :data:`MapCall`)."""
    hplus_one(a.q[i], m, s, a.out[i])


#: The configurations (C, N), the joint rates (C, N), the output (C, 6 + N, 6 + N).
HplusRateCall = namedtuple("HplusRateCall", ["q", "qdot", "out"])


@kernel(inline="always")
def _hplus_rate_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """dH+/dt along the joint rates a.qdot[i] (a: :data:`HplusRateCall`)."""
    hplus_rate_one(a.q[i], a.qdot[i], m, s, a.out[i])


#: The configurations (C, N), zdot0 (C, 6 + N), zddot0 (C, 6 + N), u (C, N + 6), T0 (C, 3, 3), the external wrenches
#: ext_i (W, 2) and ext (C, W, 9), whether to accelerate (False: zddot0 = 0), the output (C, 6 + N).
InverseCall = namedtuple("InverseCall", ["q", "v", "acc", "u", "t0", "ext_i", "ext", "accelerate", "out"])


@kernel(inline="always")
def _inverse_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """H+ zddot0 + C+ - Q_u - Q_ext, its first block in the spacecraft frame (a: :data:`InverseCall`)."""
    inverse_one(a.q[i], a.v[i], a.acc[i], a.accelerate, a.u[i], a.t0[i], m, a.ext_i, a.ext[i], s, a.out[i])


#: As :data:`InverseCall` without zddot0, the output zddot0 (C, 6 + N) and ok (C,) (False where H+ is not positive definite).
ForwardCall = namedtuple("ForwardCall", ["q", "v", "u", "t0", "ext_i", "ext", "out", "ok"])


@kernel(inline="always")
def _forward_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """zddot0 (a: :data:`ForwardCall`)."""
    a.ok[i] = accelerations_one(a.q[i], a.v[i], a.u[i], a.t0[i], m, a.ext_i, a.ext[i], s, a.out[i])


#: The flat states (C, S), u (C, N + 6), the external wrenches ext_i (W, 2) and ext (C, W, 9), the output (C, S), ok (C,).
DerivativeCall = namedtuple("DerivativeCall", ["x", "u", "ext_i", "ext", "out", "ok"])


@kernel(inline="always")
def _derivative_row(i: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """d/dt of the flat state a.x[i] (a: :data:`DerivativeCall`)."""
    a.ok[i] = state_derivative_one(a.x[i], a.u[i], m, a.ext_i, a.ext[i], s, a.out, i)


#: A rollout (``specialise.lanes._rollout_blocks``): the initial flat states x0 (K, S), the step dt, the steps, the steps
#: per sample (hold) and per record (stride); the joint PD's kp, kd, qref, vref (K, N) and feed-forward ff
#: (``lanes.feed``); the actuation limits lim (N + 6); the external wrenches ext_i (W, 2) and ext (K, W, 9); the records
#: xs (T, K, S), us (T, K, N + 6), sat (T, K) and the steps done (K,).
RolloutCall = namedtuple(
    "RolloutCall",
    ["x0", "dt", "steps", "hold", "stride", "kp", "kd", "qref", "vref", "ff", "lim", "ext_i", "ext", "xs", "us", "sat", "done"],
)


@kernel(inline="always")
def _rollout_row(b: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """Trajectory b of a rollout (the loop of ``specialise.lanes._rollout_blocks``, one lane wide, stepped by the engine's
    RK4 step of one state) with the joint PD (a: :data:`RolloutCall`)."""
    C = (a.kp, a.kd, a.qref, a.vref, a.ff)
    P = (m, a.ext_i, a.ext[b], s)
    _rollout_blocks(P, 1, b, b + 1, a.x0, a.dt, a.steps, a.hold, a.stride, C, a.lim, a.xs, a.us, a.sat, a.done, s.rows)


#: A rollout with a control law: as :data:`RolloutCall`, with control = ((kp, kd, qref, vref, ff), law) in place of the
#: joint PD's arrays (:func:`~.laws.law_control`), and the plant's model: its ints and floats (1 or K rows (K, F): a
#: payload variant per trajectory).
LawRolloutCall = namedtuple(
    "LawRolloutCall",
    ["x0", "dt", "steps", "hold", "stride", "control", "lim", "plant_ints", "plant", "ext_i", "ext", "xs", "us", "sat", "done"],
)


@kernel(inline="always")
def _law_rollout_row(b: int, m: Any, s: Any, a: Any) -> None:  # pragma: no cover
    """Trajectory b of a rollout with a control law (:func:`~.laws.law_control`; or the joint PD, law code 0) in the
    loop, on the model of the buffers (a.plant_ints, a.plant[b] or a.plant[0]: both kernel arguments; a:
    :data:`LawRolloutCall`). Its own kernel (the law's loop), so that a joint PD rollout compiles no law."""
    plant = arrays(a.plant_ints, a.plant[b if a.plant.shape[0] > 1 else 0])
    P = (plant, a.ext_i, a.ext[b], s)
    _law_rollout_blocks(P, 1, b, b + 1, a.x0, a.dt, a.steps, a.hold, a.stride, a.control, a.lim, a.xs, a.us, a.sat, a.done, s.rows)


frames_batch = driver("frames", _frames_row, FramesCall)
points_batch = driver("points", _points_row, PointsCall)
point_jacobian_batch = driver("point_jacobian", _point_jacobian_row, PointsCall)
point_bias_batch = driver("point_bias", _point_bias_row, PointBiasCall)
jstar_batch = driver("jstar", _jstar_row, MapCall)
measure_batch = driver("measure", _measure_row, MeasureCall, parallel_min=2)  # rows: lane blocks of 64 configurations
hplus_batch = driver("hplus", _hplus_row, MapCall)
hplus_rate_batch = driver("hplus_rate", _hplus_rate_row, HplusRateCall)
inverse_batch = driver("inverse", _inverse_row, InverseCall)
forward_batch = driver("forward", _forward_row, ForwardCall)
derivative_batch = driver("derivative", _derivative_row, DerivativeCall)
rollout_batch = driver("rollout", _rollout_row, RolloutCall, parallel_min=2)  # one trajectory is long work: threads pay from two
law_rollout_batch = driver("law_rollout", _law_rollout_row, LawRolloutCall, parallel_min=2)  # with a control law (or the joint PD)
