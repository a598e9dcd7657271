"""Desired motions z1,des(t) for the task-space controllers (1991 eqs. 26-27).

A desired motion is any callable ``desired(t) -> DesiredPoint`` with the task
coordinates z (``task.size`` rows) and their rates ż and accelerations z̈
(``task.dim`` rows; for quaternion items these are the inertial angular
velocity and acceleration). Provided:

* :class:`SetPoint` — a constant z (ż = z̈ = 0), as in the 1991 §V example;
* :class:`StraightLine` — a straight line in z from ``start`` to ``goal`` in
  ``duration`` with a time scaling: ``"linear"`` (constant rate; the rate
  jumps at both ends), ``"cubic"`` (3s² − 2s³; rest to rest, acceleration
  jumps) or ``"minimum_jerk"`` (10s³ − 15s⁴ + 6s⁵, Flash & Hogan 1985; rest
  to rest with zero acceleration at both ends). :class:`MinimumJerk` is the
  last one;
* :class:`FunctionTrajectory` — wraps a user callable ``f(t)`` that returns z,
  (z, ż) or (z, ż, z̈) (missing derivatives are zero).

Orientations interpolate along the task's own geometry (wrapped Euler angles,
or slerp for quaternions), so pass the :class:`~freefloat.control.tasks.TaskSpace`.
:func:`as_desired` turns an array (a set point), a callable or a desired
motion into a desired motion.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.errors import ShapeError
from .tasks import TaskSpace

__all__ = ["DesiredPoint", "FunctionTrajectory", "MinimumJerk", "SetPoint", "StraightLine", "as_desired"]

PROFILES = ("linear", "cubic", "minimum_jerk")


@dataclass(frozen=True, eq=False)
class DesiredPoint:
    """z1,des (size,), its rate ż1,des (dim,) and acceleration z̈1,des (dim,) at one time."""

    z: np.ndarray
    zdot: np.ndarray
    zddot: np.ndarray


@dataclass(frozen=True, eq=False)
class SetPoint:
    """A constant target z1,des (task coordinates, ``task.size`` rows)."""

    z: Any

    def __call__(self, t: float) -> DesiredPoint:
        z = np.asarray(self.z, dtype=float)
        return DesiredPoint(z, np.zeros(0), np.zeros(0))

    def targets(self) -> list[np.ndarray]:
        """The z vectors a controller checks for reach when it is built."""
        return [np.asarray(self.z, dtype=float)]


def time_scaling(profile: str, tau: float) -> tuple[float, float, float]:
    """(s, ds/dτ, d²s/dτ²) of a time scaling at τ = t / duration in [0, 1]."""
    tau = min(max(tau, 0.0), 1.0)
    if profile == "linear":
        return tau, (1.0 if 0.0 <= tau < 1.0 else 0.0), 0.0
    if profile == "cubic":
        return 3 * tau**2 - 2 * tau**3, 6 * tau - 6 * tau**2, 6 - 12 * tau
    if profile == "minimum_jerk":
        return (
            10 * tau**3 - 15 * tau**4 + 6 * tau**5,
            30 * tau**2 - 60 * tau**3 + 30 * tau**4,
            60 * tau - 180 * tau**2 + 120 * tau**3,
        )
    raise ValueError(f"profile: expected one of {', '.join(PROFILES)}, got {profile!r}")


@dataclass(frozen=True, eq=False)
class StraightLine:
    """From ``start`` to ``goal`` (task coordinates) along a straight line in z in ``duration`` s.

    Holds ``start`` before ``start_time`` and ``goal`` after ``start_time + duration``.
    ``task`` (a :class:`TaskSpace`) supplies the geometry of orientations; without
    it z is treated as a plain vector (size = dim).
    """

    start: Any
    goal: Any
    duration: float
    profile: str = "linear"
    task: TaskSpace | None = None
    start_time: float = 0.0

    def __post_init__(self) -> None:
        if not (np.isfinite(self.duration) and self.duration > 0):
            raise ValueError(f"duration: must be positive and finite, got {self.duration!r}")
        if not np.isfinite(self.start_time):
            raise ValueError(f"start_time: must be finite, got {self.start_time!r}")
        if self.profile not in PROFILES:
            raise ValueError(f"profile: expected one of {', '.join(PROFILES)}, got {self.profile!r}")
        a, b = np.asarray(self.start, dtype=float), np.asarray(self.goal, dtype=float)
        if a.ndim != 1 or a.shape != b.shape:
            raise ShapeError(f"start, goal: expected two vectors of the same shape (size,), got {a.shape} and {b.shape}")
        if self.task is not None and a.shape != (self.task.size,):
            raise ShapeError(f"start: expected shape ({self.task.size},) (the task's coordinates), got {a.shape}")
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
            raise ValueError("start, goal: have NaN or infinite entries; give finite task coordinates")

    def __call__(self, t: float) -> DesiredPoint:
        s, ds, dds = time_scaling(self.profile, (t - self.start_time) / self.duration)
        start, goal = np.asarray(self.start, dtype=float), np.asarray(self.goal, dtype=float)
        if self.task is None:
            z = start + s * (goal - start)
            direction = goal - start
        else:
            z = self.task.interpolate(start, goal, s)
            direction = self.task.difference(goal, start)
        return DesiredPoint(z, direction * ds / self.duration, direction * dds / self.duration**2)

    def targets(self) -> list[np.ndarray]:
        """The z vectors a controller checks for reach when it is built: the start and the goal."""
        return [np.asarray(self.start, dtype=float), np.asarray(self.goal, dtype=float)]


def MinimumJerk(start: Any, goal: Any, duration: float, *, task: TaskSpace | None = None, start_time: float = 0.0) -> StraightLine:
    """A straight line with the minimum-jerk time scaling 10s³ − 15s⁴ + 6s⁵ (rest to rest)."""
    return StraightLine(start, goal, duration, profile="minimum_jerk", task=task, start_time=start_time)


@dataclass(frozen=True, eq=False)
class FunctionTrajectory:
    """A user callable ``f(t)`` returning z, (z, ż) or (z, ż, z̈) as a desired motion."""

    function: Callable[[float], Any]

    def __call__(self, t: float) -> DesiredPoint:
        out = self.function(t)
        if isinstance(out, DesiredPoint):
            return out
        if isinstance(out, tuple):
            if not 1 <= len(out) <= 3:
                raise ValueError(f"desired(t): returned a tuple of {len(out)} items; return z, (z, zdot) or (z, zdot, zddot)")
            parts = [np.asarray(x, dtype=float) for x in out]
            z = parts[0]
            zdot = parts[1] if len(parts) > 1 else np.zeros(0)
            zddot = parts[2] if len(parts) > 2 else np.zeros(0)
            return DesiredPoint(z, zdot, zddot)
        return DesiredPoint(np.asarray(out, dtype=float), np.zeros(0), np.zeros(0))

    def targets(self) -> list[np.ndarray]:
        """None: a function's values are not known before the run, so nothing is checked for reach when it is built."""
        return []


def as_desired(desired: Any) -> Any:
    """A desired motion from a desired motion, a callable ``f(t)`` or an array (a set point)."""
    if isinstance(desired, (SetPoint, StraightLine, FunctionTrajectory)):
        return desired
    if callable(desired):
        return FunctionTrajectory(desired)
    try:
        arr = np.asarray(desired, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(
            f"desired: expected task coordinates (an array), a callable f(t) or a desired motion, got {type(desired).__name__}"
        ) from None
    return SetPoint(arr)
