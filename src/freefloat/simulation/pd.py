"""A joint-space PD controller with optional open-loop feed-forward, for simulations and batched rollouts.

    tau = feedforward[k] + kp (q_ref - q) + kd (qdot_ref - qdot)          (N m, per joint)

``JointPD`` is an ordinary controller ``(t, state) -> joint torques`` for
:func:`freefloat.simulate` and :func:`freefloat.rollout`; :func:`freefloat.rollout` with the
numba back end recognises it and runs the whole batch compiled (no Python per step). Every
parameter broadcasts against the state's batch: a scalar, (N,), or (B, N) for one value per
trajectory of a batch (per-trajectory gains for sweeps and Monte Carlo).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.errors import ShapeError
from ..core.numbers import MAX_EFFORT, check_joint_rates, check_joint_values, check_largest, real_array

__all__ = ["JointPD"]


@dataclass(frozen=True)
class JointPD:
    """Joint PD control ``tau = feedforward[k] + kp (q_ref - q) + kd (qdot_ref - qdot)``.

    ``kp`` (N m/rad), ``kd`` (N m s/rad), ``q_ref`` (rad), ``qdot_ref`` (rad/s): scalars, (N,)
    or (B, N). ``feedforward``: joint torques per sample, (K, N) or (K, B, N); sample k applies
    from t = k ``feedforward_period`` on and the last one is held after the K-th (None: zero).
    A constant feed-forward is a (1, N) array.

    Values no space robot has are refused as input (:mod:`freefloat.core.numbers`): |q_ref| beyond 1e6 rad
    (or m), |qdot_ref| beyond 1e4 rad/s (or m/s), feed-forward torques beyond 1e19 N m (or N).
    """

    kp: Any
    kd: Any
    q_ref: Any = 0.0
    qdot_ref: Any = 0.0
    feedforward: Any = None
    feedforward_period: float | None = None

    def __post_init__(self) -> None:
        for name in ("kp", "kd", "q_ref", "qdot_ref"):
            arr = real_array(getattr(self, name), f"JointPD.{name}")
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"JointPD.{name}: has NaN or infinite entries")
            if name == "q_ref":
                check_joint_values(arr, "JointPD.q_ref")
            if name == "qdot_ref":
                check_joint_rates(arr, "JointPD.qdot_ref")
            if name in ("kp", "kd") and np.any(arr < 0):
                raise ValueError(
                    f"JointPD.{name}: must be >= 0 (a negative gain drives the joints away from the reference and pumps energy "
                    f"in), got {getattr(self, name)!r}"
                )
        if self.feedforward is not None:
            ff = real_array(self.feedforward, "JointPD.feedforward")
            if ff.ndim < 2 or ff.shape[0] == 0:
                raise ShapeError(
                    f"JointPD.feedforward: expected (K, N) or (K, B, N) torques per sample, K >= 1, got shape {ff.shape} "
                    "(no feed-forward: leave it None)"
                )
            if not np.all(np.isfinite(ff)):
                raise ValueError("JointPD.feedforward: has NaN or infinite entries")
            check_largest(
                ff,
                "JointPD.feedforward",
                MAX_EFFORT,
                "N m or N",
                "which would spin the largest inertia a model may have (1e15 kg m^2) past 1e4 rad/s within a second",
                "check the units (N m, N)",
            )
            period = self.feedforward_period
            if ff.shape[0] > 1 and (
                period is None
                or isinstance(period, (bool, np.bool_, str, bytes))
                or not isinstance(period, (int, float, np.number))
                or not np.isfinite(period)
                or not period > 0
            ):
                raise ValueError(
                    f"JointPD.feedforward_period: give the time between feed-forward samples (s, a finite number > 0), got {period!r}"
                )

    def check_batch(self, shape: tuple[int, ...]) -> None:
        """Refuse parameters that do not broadcast to the states' ``shape`` ((B, N) for a rollout of B trajectories of
        N joints; (N,) for one simulation), naming the parameter, before the run; the feed-forward's samples likewise."""
        rows = len(shape) == 2
        each = "a scalar, one value per joint (N,)" + (", or one row per trajectory (B, N)" if rows else "")
        each_ff = "(K, N) torques per sample" + (", or (K, B, N)" if rows else "")
        given = {name: np.shape(getattr(self, name)) for name in ("kp", "kd", "q_ref", "qdot_ref")}
        if self.feedforward is not None:
            given["feedforward"] = np.shape(self.feedforward)[1:]  # each sample
        for name, part in given.items():
            try:
                fits = np.broadcast_shapes(part, shape) == shape
            except ValueError:
                fits = False
            if not fits:
                what = f"samples of shape {part}" if name == "feedforward" else f"shape {part}"
                to = f"the states' {shape} (trajectories x joints)" if rows else f"the model's {shape[0]} joints {shape}"
                raise ShapeError(f"JointPD.{name}: {what} does not broadcast to {to}; give {each_ff if name == 'feedforward' else each}")

    def sample(self, t: float) -> int:
        """Index of the feed-forward sample in force at time ``t``."""
        ff = np.asarray(self.feedforward)
        if self.feedforward is None or ff.shape[0] == 1 or self.feedforward_period is None:
            return 0
        return min(round(t / self.feedforward_period), ff.shape[0] - 1)

    def __call__(self, t: float, state: Any) -> np.ndarray:
        q = np.asarray(state.q, dtype=float)
        qdot = np.asarray(state.qdot, dtype=float)
        feed = 0.0 if self.feedforward is None else np.asarray(self.feedforward, dtype=float)[self.sample(t)]
        tau = feed + np.asarray(self.kp, dtype=float) * (np.asarray(self.q_ref, dtype=float) - q)
        tau = tau + np.asarray(self.kd, dtype=float) * (np.asarray(self.qdot_ref, dtype=float) - qdot)
        return np.broadcast_to(tau, np.broadcast_shapes(np.shape(tau), q.shape)).copy()
