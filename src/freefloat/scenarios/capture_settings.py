"""The ``[detumble]`` table of a capture scenario (:class:`DetumbleSettings`, :func:`detumble_settings`) and the
estimate of the capture sequence's run before it starts (:func:`estimate_sequence`, :func:`check_sequence_estimate`):
the estimate of ``ff.simulate`` (:func:`freefloat.simulation.estimate_run`), the memory it needs checked as every
large result is (:func:`freefloat.core.resources.require_memory`). The sequence itself: :mod:`.capture_sequence`.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..control.wheels import TORQUE_BY
from ..core.errors import LongRunWarning, ModelError
from ..core.numbers import MAX_RATE, MAX_SPEED
from ..core.resources import require_memory
from ..simulation import RunEstimate, estimate_run
from .scenario import _number, _where

if TYPE_CHECKING:
    from ..core.model import Model

__all__ = ["MAX_FRAMES", "MAX_SPECIFIC_IMPULSE", "DetumbleSettings", "check_sequence_estimate", "detumble_settings", "estimate_sequence"]

#: The largest specific impulse accepted (s): electric thrusters reach some 1e4 s; beyond 1e5 s it is a unit slip.
MAX_SPECIFIC_IMPULSE = 1e5
#: The most frames of the animation: 10,000 frames are 17 minutes at its 10 frames per second.
MAX_FRAMES = 10_000


@dataclass(frozen=True)
class DetumbleSettings:
    """The scenario's ``[detumble]`` table: :class:`~freefloat.control.Detumble` and
    :func:`~freefloat.control.detumble_cost` settings, SI units."""

    rate_gain: float = 0.5  # 1/s
    duration: float = 20.0  # s
    sample_period: float = 0.05  # s, the controller's and the outputs'
    specific_impulse: float | None = None  # s
    rest_rate: float = 1e-3  # rad/s
    rest_velocity: float = 1e-3  # m/s
    rest_joint_rate: float = 1e-3  # rad/s
    attitude: tuple[float, float, float, float] | None = None  # [x, y, z, w], spacecraft -> inertial
    force: bool = True
    frames: int = 40  # frames of the animation
    torque_by: str = "thrusters"  # or "wheels": the spacecraft torque by the reaction wheels


#: [detumble] numbers: unit and the largest value a space robot can mean (None: the estimate of the run decides).
_UNITS: dict[str, tuple[str, float | None]] = {
    "rate_gain": ("1/s", None), "duration": ("s", None), "sample_period": ("s", None),
    "specific_impulse": ("s", MAX_SPECIFIC_IMPULSE), "rest_rate": ("rad/s", MAX_RATE), "rest_velocity": ("m/s", MAX_SPEED),
    "rest_joint_rate": ("rad/s", MAX_RATE),
}  # fmt: skip


def detumble_settings(table: dict[str, Any], source: str) -> DetumbleSettings:
    """The [detumble] table (its keys already checked against :class:`DetumbleSettings`'), each field checked by name."""
    values: dict[str, Any] = {}
    for key, (unit, largest) in _UNITS.items():
        if key in table:
            fix = f"give detumble.{key} in {unit}, a number > 0" + ("" if largest is None else f" and at most {largest:g}")
            values[key] = _number(table[key], source, f"detumble.{key}", fix)
            if values[key] <= 0.0:
                raise ModelError(_where(source, f"detumble.{key}"), f"must be positive, got {table[key]!r}", fix)
            if largest is not None and values[key] > largest:
                raise ModelError(_where(source, f"detumble.{key}"), f"{table[key]!r} {unit} is beyond {largest:g} {unit}", fix)
    if "force" in table:
        if not isinstance(table["force"], bool):
            fix = "write force = true (thrusters stop the CM) or false (torque only), without quotes"
            raise ModelError(_where(source, "detumble.force"), f"expected true or false, got {table['force']!r}", fix)
        values["force"] = table["force"]
    if "torque_by" in table:
        if table["torque_by"] not in TORQUE_BY:
            fix = 'write torque_by = "thrusters" or "wheels" (the model\'s [[wheels]]: docs/wheels.md)'
            raise ModelError(_where(source, "detumble.torque_by"), f"unknown {table['torque_by']!r}", fix)
        values["torque_by"] = table["torque_by"]
    if "frames" in table:
        frames = table["frames"]
        if isinstance(frames, bool) or not isinstance(frames, int) or not 2 <= frames <= MAX_FRAMES:
            fix = f"e.g. frames = 40 (at most {MAX_FRAMES})"
            raise ModelError(_where(source, "detumble.frames"), f"expected an integer from 2 to {MAX_FRAMES}, got {frames!r}", fix)
        values["frames"] = frames
    if "attitude" in table:
        fix = "give attitude = [x, y, z, w], a unit quaternion (spacecraft -> inertial), or leave it out (rates only)"
        raw = table["attitude"]
        if not isinstance(raw, list) or len(raw) != 4:
            raise ModelError(_where(source, "detumble.attitude"), f"expected [x, y, z, w], got {raw!r}", fix)
        quat = np.array([_number(v, source, "detumble.attitude", fix) for v in raw])
        norm = math.hypot(*quat)  # without the overflow of squaring 1e300
        if abs(norm - 1.0) > 1e-6:
            raise ModelError(_where(source, "detumble.attitude"), f"has norm {norm:.6g}, not 1", fix)
        values["attitude"] = tuple(float(v) for v in quat / np.linalg.norm(quat))
    settings = DetumbleSettings(**values)
    if settings.sample_period > settings.duration:
        fix = "make sample_period (s) at most the duration"
        raise ModelError(_where(source, "detumble.sample_period"), f"{settings.sample_period:g} s exceeds the duration", fix)
    if settings.rate_gain * settings.sample_period >= 1.0:
        # the held computed torque takes k T of each rate per sample: the rate after a sample is (1 - k T) times the rate
        fix = f"make rate_gain x sample_period below 1 (e.g. rate_gain <= {0.5 / settings.sample_period:.3g} 1/s at this sample_period)"
        problem = (
            f"{settings.rate_gain:g} 1/s x sample_period {settings.sample_period:g} s = {settings.rate_gain * settings.sample_period:.3g}: "
            "each sample would remove all of the rates (k T = 1) or reverse them (k T > 1) instead of damping them "
            "(the held control takes k T of each per sample)"
        )
        raise ModelError(_where(source, "detumble.rate_gain"), problem, fix)
    return settings


def estimate_sequence(model: Model, settings: DetumbleSettings, grasp_time: float = 0.0) -> RunEstimate:
    """The cost of the sequence's simulation (both phases) before it runs: :func:`freefloat.simulation.estimate_run`
    with its duration, controller samples and outputs."""
    period = settings.sample_period
    return estimate_run(model, grasp_time + settings.duration, sample_period=period, output_period=period, controller=True)


def check_sequence_estimate(estimate: RunEstimate, warn_after: float | None) -> None:
    """Refuse a sequence whose recorded states exceed the free memory (:class:`~freefloat.MemoryBudgetError`); warn
    :class:`~freefloat.core.errors.LongRunWarning` when it is estimated to take over ``warn_after`` seconds (None: never)."""
    fix = "shorten [detumble] duration (or [grasp] time), or lengthen [detumble] sample_period"
    require_memory(estimate.memory_bytes, f"the capture sequence ({estimate.describe()})", fix)
    if warn_after is not None and estimate.seconds > warn_after:
        message = f"the capture sequence will take long: {estimate.describe()} (over warn_after = {warn_after:g} s); {fix} to shorten it"
        warnings.warn(message, LongRunWarning, stacklevel=3)
