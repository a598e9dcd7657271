"""The stepper's kernels: RK4 steps of one trajectory from Python (a Python controller between calls), with the model,
the external wrenches, the watch bounds and the scratch in two flat buffers (:func:`unpack`), and the state
derivative of one state (the adaptive integrators' right-hand side). The Python side is :class:`~.calls.Stepper`."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..core.numbers import MAX_EFFORT
from .cache import floats_view, ints_view, kernel
from .layout import OMEGA_AT, Q_AT, arrays, buffer_lengths, qdot_at, scratch
from .quantities import rk4_step, state_derivative_one

#: REASON of :func:`rk4_steps` when it refused u (an entry not finite, or beyond MAX_EFFORT); 1 and 2 are :func:`watched`'s.
REFUSED = 4


@kernel(inline="always")
def unpack(ints: np.ndarray, floats: np.ndarray) -> Any:  # pragma: no cover - compiled
    """The model, its external wrenches and the scratch of one trajectory from the two buffers of
    :class:`~.calls.Stepper` (fewer arguments: numba unboxes each array argument at every call).

    ints = [the model's ints (:func:`~.layout.arrays`), W, WATCH, REASON, ext_i (W x 2)];
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
        if 1.7320508075688772 * abs(x[OMEGA_AT + i]) > fast:
            reason = 1
    for j in range(n):
        if abs(x[qdot_at(n) + j]) > watch[1 + 2 * n + j]:
            reason = 1
    for j in range(n):
        v = x[Q_AT + j]
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
