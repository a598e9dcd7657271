"""Reaction wheels in a simulation (private): their limits at each command, and the user's trajectory of a run that
integrated them as joints (:func:`freefloat.core.wheels.wheel_joint_model`; conventions in :mod:`freefloat.core.wheels`).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..core.model import Model
from ..core.wheels import wheel_limits
from .trajectory import Trajectory


def limit_wheel_torque(model: Model, command: np.ndarray, speed: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The motor torques the wheels apply for a ``command`` (W,) at wheel speeds ``speed`` (W,), rad/s:
    ``(applied, torque_saturated, speed_saturated)``. As Basilisk's reaction-wheel model: a command beyond
    ``max_torque`` is clipped to it; a wheel at or beyond ``max_speed`` gets no torque that would spin it faster
    (set to zero). Both are flagged, per wheel."""
    max_torque, max_speed = wheel_limits(model)
    applied = np.clip(command, -max_torque, max_torque)
    torque_saturated = applied != command
    speed_saturated = (np.abs(speed) >= max_speed) & (applied * speed > 0.0)
    applied = np.where(speed_saturated, 0.0, applied)
    return applied, torque_saturated, speed_saturated


def user_trajectory(model: Model, run: Trajectory) -> Trajectory:
    """The trajectory of ``model`` (with W wheels) from ``run``, a trajectory of its wheel-joint model whose
    ``saturated`` holds [any, torque saturated (W), speed saturated (W)] per output: q, qdot and joint torques of the
    robot's N joints, the wheels' angles, speeds and motor torques, and their saturation flags."""
    n, w = model.n_joints, model.n_wheels
    flags = np.asarray(run.saturated, dtype=bool)
    if flags.ndim == run.t.ndim:  # no output (an empty run): nothing recorded per wheel
        flags = np.zeros((*run.t.shape, 1 + 2 * w), dtype=bool)
    return dataclasses.replace(
        run,
        q=run.q[..., :n],
        qdot=run.qdot[..., :n],
        joint_torque=run.joint_torque[..., :n],
        saturated=flags[..., 0],
        wheel_angle=run.q[..., n:],
        wheel_speed=run.qdot[..., n:],
        wheel_torque=run.joint_torque[..., n:],
        wheel_torque_saturated=flags[..., 1 : 1 + w],
        wheel_speed_saturated=flags[..., 1 + w :],
        model=model,
        model_name=model.name,
        joint_limit_events=tuple(e for e in run.joint_limit_events if e.joint in model.joint_names),
    )
