"""Joint limits in simulation (private): hard stops as momentum-conserving impulses, or violation flags.

The model of a hard stop (docs/simulation.md, "Joint limits"): when joint i reaches its limit
moving outward with rate q'_i-, the stop applies an internal joint-space impulse e_i lambda. The
velocities jump by the free-floating response

    delta zdot0 = H+^-1 e_i lambda,        lambda = -(1 + e) q'_i- / (H+^-1)_ii

so that q'_i+ = -e q'_i- (``restitution`` e in [0, 1]; 0: the joint stops dead, 1: elastic).
The impulse is a joint torque, internal to the system: the CM velocity (H+ has no coupling to
r_cm) and the angular momentum (rows omega0 of H+ delta zdot0 = the omega0 entries of e_i = 0)
do not change, exactly; the kinetic energy drops by (1 - e^2) (q'_i-)^2 / (2 (H+^-1)_ii).
The crossing is found at the end of the RK4 step (or adaptive sub-step) in which it happens; the
joint is then put back on its limit with the spacecraft rate re-solved from the angular momentum
(omega0 = D^-1 (h0 - D_q q'), 1992 eq. 12), which keeps the momentum too. A joint pushed into its
stop stays on it (one impulse per step, recorded once as an impact).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .. import engine
from ..core.model import Model
from ..core.state_layout import span
from ..mechanics.momentum import zero_momentum_rate
from .trajectory import JointLimitEvent, Trajectory

__all__ = ["MODES", "JointStops", "limit_violations", "with_limit_events", "with_violations"]

#: ``simulate(joint_limits=...)``: "stop" (hard stops), "flag" (no stops; violations recorded).
MODES = ("stop", "flag")
#: A joint counts as back inside (so that its next impact is recorded) this far from its limit (rad).
_RELEASE = 1e-6
#: A joint whose rate after the impulse is below this (rad/s) rests on its stop: no event chases it.
_REST_RATE = 1e-6


def _side(q: float, lower: float, upper: float) -> str | None:
    if q > upper:
        return "upper"
    if q < lower:
        return "lower"
    return None


class JointStops:
    """The hard stops of ``model``'s finite joint limits, applied in place to flat states."""

    def __init__(self, model: Model, mode: str, restitution: float) -> None:
        if mode not in MODES:
            raise ValueError(f"joint_limits: {mode!r} is not one of {', '.join(repr(m) for m in MODES)}")
        try:
            e = float(restitution)
        except (TypeError, ValueError):
            raise ValueError(f"restitution: expected a number in [0, 1], got {restitution!r}") from None
        if not 0.0 <= e <= 1.0:
            raise ValueError(f"restitution: must be in [0, 1] (0: the joint stops dead at its limit, 1: elastic), got {restitution!r}")
        self.model = model
        self.restitution = e
        self.lower = np.asarray(model.joint_lower, dtype=float)
        self.upper = np.asarray(model.joint_upper, dtype=float)
        self.active = mode == "stop" and bool(np.any(np.isfinite(self.lower) | np.isfinite(self.upper)))
        self._n = int(model.n_joints)
        self._q = span("q", self._n)  # the flat state's joint values (core.state_layout)
        self._bounds = list(zip(self.lower.tolist(), self.upper.tolist(), strict=True))  # the per-step test in plain floats
        self.events: list[JointLimitEvent] = []
        self.at_stop: set[int] = set()  # at a stop since the last recorded impact
        self.resting: set[int] = set()  # at a stop with (almost) no rate: put back at each step or piece end

    def release(self, x: np.ndarray) -> None:
        """Forget the joints of the flat state x that are back inside their limits."""
        q = x[self._q]
        for i in list(self.at_stop):
            if self.lower[i] + _RELEASE < q[i] < self.upper[i] - _RELEASE:
                self.at_stop.discard(i)
                self.resting.discard(i)

    def check_initial(self, q: np.ndarray) -> None:
        """A start beyond a limit is an error (naming the joint) when the stops are on."""
        if not self.active:
            return
        for i, value in enumerate(q):
            side = _side(float(value), self.lower[i], self.upper[i])
            if side is not None:
                limit = self.upper[i] if side == "upper" else self.lower[i]
                raise ValueError(
                    f"initial_state.q: joint {self.model.joint_names[i]!r} = {value:.6g} rad is beyond its {side} limit "
                    f"{limit:.6g} rad; start inside the limits, or pass joint_limits='flag' to simulate without stops"
                )

    def beyond(self, x: np.ndarray | list[float]) -> bool:
        """Whether a joint of the flat state x (an array, or its ``tolist()``) is beyond a limit."""
        # plain floats: ~0.5 us for a few joints, against ~4 us for numpy's reductions (this runs every step)
        values = x[self._q]
        for value, (low, high) in zip(values if isinstance(values, list) else values.tolist(), self._bounds, strict=True):
            if value > high or value < low:
                return True
        return False

    def apply(self, t: float, x: np.ndarray, joints: list[int] | None = None) -> None:
        """Put every joint beyond its limit (or the ``joints`` given, at their limit) back on it and apply its impulse."""
        n = self.model.n_joints
        q, qdot, omega = x[self._q], x[span("qdot", n)], x[span("omega", n)]  # (a dissipated energy after them: untouched)
        self.release(x)
        for i in range(n) if joints is None else joints:
            side = _side(float(q[i]), self.lower[i], self.upper[i])
            if side is None and joints is not None:  # located on the limit by an event: the side it moves to
                side = "upper" if abs(q[i] - self.upper[i]) <= abs(q[i] - self.lower[i]) else "lower"
            if side is None:
                continue
            limit = self.upper[i] if side == "upper" else self.lower[i]
            # back on the limit, the angular momentum kept: omega0 = D^-1 (h0 - D_q qdot)
            h_plus = engine.inertia_matrix(self.model, np.ascontiguousarray(q, dtype=float))  # a computed state: no input checks
            h0 = h_plus[3:6, 3:] @ np.concatenate([omega, qdot])
            q[i] = limit
            h_plus = engine.inertia_matrix(self.model, np.ascontiguousarray(q, dtype=float))
            omega[:] = zero_momentum_rate(h_plus, qdot, h0)
            block = h_plus[3:, 3:]
            rate = float(qdot[i])
            if (rate > 0.0) if side == "upper" else (rate < 0.0):
                unit = np.zeros(n + 3)
                unit[3 + i] = 1.0
                response = np.linalg.solve(block, unit)  # H+^-1 e_i on [omega0, q] (the r_cm block is decoupled)
                jump = response * (-(1.0 + self.restitution) * rate / response[3 + i])
                omega += jump[:3]
                qdot += jump[3:]
                if i not in self.at_stop:
                    self.events.append(JointLimitEvent(self.model.joint_names[i], side, float(limit), "impact", float(t), float(t), rate))
            self.at_stop.add(i)
            if abs(qdot[i]) < _REST_RATE:
                self.resting.add(i)


def limit_violations(model: Model, t: np.ndarray, q: np.ndarray) -> list[JointLimitEvent]:
    """The spans of output times in which a joint is beyond a limit (stops off), of one run (q (T, N)) or of a batch of
    trajectories (q (T, B, N): each event with its trajectory's index), ordered by trajectory, then by start, joint and
    bound (upper first). ``t`` (T,): the output times, increasing.

    One compiled pass over the samples (:func:`~freefloat.engine.limit_spans_batch`), on one range of
    trajectories per thread: a rollout of 1,024 trajectories of the Panda (9 joints, 501 outputs, 3,456 spans) took
    235 ms in a Python loop over its trajectories (the kernel that computed it: 250 ms), 46-70 ms in numpy array
    operations, 16 ms now (measured).
    """
    batched = q.ndim == 3
    q3 = q if batched else q[:, None, :]
    lower = engine.owned(model.joint_lower)  # C-contiguous, writable float64: one compiled signature
    upper = engine.owned(model.joint_upper)
    spans, value = engine.limit_spans_batch(q3, lower, upper)  # (S, 5): trajectory, joint, bound, start, stop
    order = np.lexsort((spans[:, 2], spans[:, 1], spans[:, 3], spans[:, 0]))
    times = [*np.asarray(t, dtype=float).tolist(), None]  # a span still beyond at the end stops at None
    at_limit = (upper.tolist(), lower.tolist())
    names, sides = model.joint_names, ("upper", "lower")
    return [
        JointLimitEvent(names[j], sides[c], at_limit[c][j], "violation", times[a], times[z], v, w if batched else None)
        for (w, j, c, a, z), v in zip(spans[order].tolist(), value[order].tolist(), strict=True)
    ]


def with_limit_events(traj: Trajectory, stops: JointStops) -> Trajectory:
    """A simulation's trajectory with its joint-limit events: the stops' impacts, or (stops off) the spans beyond a limit."""
    found = stops.events if stops.active else (limit_violations(stops.model, traj.t, traj.q) if len(traj) else [])
    return dataclasses.replace(traj, joint_limit_events=tuple(found)) if found else traj


def with_violations(traj: Trajectory) -> Trajectory:
    """A rollout's trajectory with its joint-limit violations (rollouts apply no stops), each with its trajectory index."""
    model = traj.model
    if model is None or not len(traj):
        return traj
    found = limit_violations(model, traj.t, traj.q)
    return dataclasses.replace(traj, joint_limit_events=tuple(found)) if found else traj
