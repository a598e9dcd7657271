"""The controller in the loop (private): its output checked and turned into what the engine steps with.

A controller is a callable ``controller(t, state) -> joint torques (N,) or Actuation``
(:class:`~freefloat.core.state.Actuation`: joint torques N m or N, the spacecraft's thruster force N and torque N m in
the spacecraft frame, and the wheel torques N m for a model with reaction wheels). :func:`call_controller` runs it on a
flat state ``x = [r_cm, v_cm, attitude (x, y, z, w), omega, q, qdot]`` (:mod:`freefloat.core.state`) and returns the
arrays (tau, f_S, n_S); :func:`command_of` adds the actuator limits and the wheels' limits: the one callable
``command(t, x) -> (tau, f_S, n_S, saturated)`` that the integration loops of :func:`freefloat.simulate` call at
each controller sample.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from ..core.errors import ShapeError, SimulationError
from ..core.model import Model
from ..core.numbers import MAX_EFFORT
from ..core.state import Actuation, ActuatorLimits, State, unpack_state
from ..core.state_layout import ATTITUDE_AT, span
from ._wheels import limit_wheel_torque

__all__ = ["Command", "Controller", "actuation", "call_controller", "check_output", "command_of", "plain_torques", "zero_thrust"]

Controller = Callable[[float, State], Any]
#: ``command(t, x, kernel_checks=False) -> (tau, f_S, n_S, saturated)``: the controller as the loops call it.
Command = Callable[..., tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]

_FLOAT64 = np.dtype(np.float64)
_ZEROS: dict[tuple[int, ...], np.ndarray] = {}


def zero_thrust(batch: tuple[int, ...]) -> np.ndarray:
    """A shared read-only zero thrust (batch, 3): a controller's plain joint torques carry it as their spacecraft force
    and torque (the fixed-step loop then writes only the torques)."""
    if batch not in _ZEROS:
        zeros = np.zeros((*batch, 3))
        zeros.flags.writeable = False
        _ZEROS[batch] = zeros
    return _ZEROS[batch]


_QUIET = zero_thrust(())


def plain_torques(raw: np.ndarray) -> bool:
    """True when every entry of ``raw`` is finite and within :data:`~freefloat.core.numbers.MAX_EFFORT` (N m or N).
    For one configuration on Python floats (a third of numpy's reductions on a few values, every step of a
    simulation); a NaN or inf makes the sum non-finite, a sum that overflows sends finite values to the full check."""
    if raw.ndim != 1:
        return bool(np.abs(raw).max(initial=0.0) <= MAX_EFFORT)  # NaN compares false
    values = raw.tolist()
    return not values or (-MAX_EFFORT <= min(values) and max(values) <= MAX_EFFORT and math.isfinite(sum(values)))


def check_output(name: str, arr: np.ndarray) -> None:
    """A controller's output ``name`` (an array): a ValueError that says what is wrong when an entry is not finite or
    beyond :data:`~freefloat.core.numbers.MAX_EFFORT` (N m or N)."""
    if not np.isfinite(arr).all():
        raise ValueError(f"controller returned a non-finite {name}: {arr}")
    if np.abs(arr).max(initial=0.0) > MAX_EFFORT:
        raise ValueError(
            f"controller returned a {name} of {np.abs(arr).max():.3g}, beyond {MAX_EFFORT:.0e} (N m or N), more than any actuator "
            "gives (it would spin the largest inertia a model may have beyond 1e4 rad/s within a second); check the controller's "
            "gains and units"
        )


def actuation(model: Model, raw: Any, batch: tuple[int, ...], kernel_checks: bool = False) -> tuple[np.ndarray, ...]:
    """Controller output -> (tau, f_S, n_S) arrays, and the wheel torques last for a model with reaction wheels (zeros
    when not given), with errors that name what is wrong.

    ``kernel_checks``: plain torques (a float64 array of shape (*batch, N)) go through unchecked, because the caller's
    kernel checks them before it steps (the RK4 loop of :func:`freefloat.simulate`: the engine's RK4 steps refuse an
    entry that is not finite or beyond MAX_EFFORT, and the loop then names it with :func:`check_output`)."""
    n = model.n_joints
    if (
        raw.__class__ is np.ndarray
        and (raw.dtype is _FLOAT64 or raw.dtype == _FLOAT64)
        and raw.shape == (*batch, n)
        and (kernel_checks or plain_torques(raw))
    ):
        zeros = zero_thrust(batch) if batch else _QUIET  # the fast path of plain torques, finite and in range
        return (raw, zeros, zeros, np.zeros((*batch, model.n_wheels))) if model.wheels else (raw, zeros, zeros)
    if raw is None:
        raise TypeError(f"controller returned None; return joint torques of shape {(*batch, n)} or a freefloat.Actuation")
    if not isinstance(raw, Actuation):
        raw = Actuation(joint_torque=raw)
    if raw.wheel_torque is not None and not model.wheels:
        raise ValueError(f"controller returned wheel torques, but {model.name!r} has no reaction wheels (model.wheels; docs/wheels.md)")
    parts = []
    fields = [
        ("joint_torque", n, f"one torque per joint: {', '.join(model.joint_names) or 'none'}"),
        ("spacecraft_force", 3, "thruster force, spacecraft frame"),
        ("spacecraft_torque", 3, "thruster torque, spacecraft frame"),
    ]
    if model.wheels:
        fields.append(("wheel_torque", model.n_wheels, f"one per wheel: {', '.join(w.name for w in model.wheels)}"))
    for name, size, what in fields:
        value = getattr(raw, name)
        if value is None:
            parts.append(np.zeros((*batch, size)))
            continue
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"controller returned a {name} that is not numbers: {value!r}") from exc
        if arr.shape != (*batch, size):
            raise ShapeError(f"controller returned {name} of shape {arr.shape}; expected {(*batch, size)} ({what})")
        check_output(name, arr)
        parts.append(arr)
    return tuple(parts)


#: The attitude quaternion's entries in the flat state.
_ATTITUDE = slice(ATTITUDE_AT, ATTITUDE_AT + 4)


def call_controller(
    controller: Controller, model: Model, t: float, x: np.ndarray, batch: tuple[int, ...], kernel_checks: bool = False
) -> tuple[np.ndarray, ...]:
    """Evaluate the controller at (t, x); any failure becomes a SimulationError that says when and what. Returns
    (tau, f_S, n_S), and the wheel torques last for a model with reaction wheels. ``kernel_checks``: see
    :func:`actuation`."""
    quat = x[..., _ATTITUDE]
    # |quat|² - 1 = 2 (|quat| - 1) to first order: off by more than 1e-12 in norm (a dot product, not a norm: this
    # runs at every sample)
    if quat.ndim == 1:
        off = abs(float(quat @ quat) - 1.0) > 2e-12
    else:
        off = bool(np.any(np.abs(np.einsum("...i,...i->...", quat, quat) - 1.0) > 2e-12))
    if off:  # an integrator's stage state: its quaternion drifts off unit length
        x = x.copy()
        state = unpack_state(model, x)
        state.attitude[...] /= np.linalg.norm(state.attitude, axis=-1, keepdims=True)  # the attitude the stage stands for
    else:
        state = unpack_state(model, x)
    try:
        raw = controller(t, state)
    except Exception as exc:
        raise SimulationError(f"the controller raised {type(exc).__name__} at t = {t:.6g} s: {exc}") from exc
    try:
        return actuation(model, raw, batch, kernel_checks)
    except (TypeError, ValueError) as exc:
        raise SimulationError(f"bad controller output at t = {t:.6g} s: {exc}") from exc


def command_of(controller: Controller | None, user: Model, model: Model, limits: ActuatorLimits, batch: tuple[int, ...] = ()) -> Command:
    """The controller of one simulation (or of a rollout's ``batch`` of states) as its loops call it: ``command(t, x,
    kernel_checks=False) -> (tau, f_S, n_S, saturated)`` on the flat state ``x`` of ``model`` (what the engine integrates:
    ``user``'s reaction wheels as joints, :func:`freefloat.core.wheels.wheel_joint_model`), with the controller called
    on ``user``'s state.

    The output is clipped to ``limits`` (:meth:`~freefloat.core.state.ActuatorLimits.apply`; ``saturated`` says where)
    and a model's wheel torques to the wheels' torque and speed limits (:func:`._wheels.limit_wheel_torque`), joined
    after the joint torques (``saturated`` is then [any, torque saturated (W), speed saturated (W)]). None: no
    actuation. ``kernel_checks=True`` lets plain torques reach the compiled RK4 step unchecked (it checks them), only
    where nothing changes them before the step: no clip (which makes an inf finite) and no wheels."""
    n_wheels = user.n_wheels
    zero = (np.zeros((*batch, model.n_joints)), np.zeros((*batch, 3)), np.zeros((*batch, 3)))
    unlimited = np.zeros((*batch, 1 + 2 * n_wheels) if n_wheels else batch, dtype=bool)
    rates = span("qdot", model.n_joints)
    speeds = slice(rates.stop - n_wheels, rates.stop)
    clips = not limits.unlimited
    unchanged = not clips and not n_wheels

    def command(t: float, x: np.ndarray, kernel_checks: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        if controller is None:
            return (*zero, unlimited)
        parts = call_controller(controller, user, t, x, batch, kernel_checks and unchanged)
        if not n_wheels:
            return limits.apply(*parts) if clips else (parts[0], parts[1], parts[2], unlimited)
        tau, force, torque, saturated = limits.apply(*parts[:3])
        wheel, torque_limited, speed_limited = limit_wheel_torque(user, parts[3], x[..., speeds])
        limited = saturated | torque_limited.any(axis=-1) | speed_limited.any(axis=-1)
        flags = np.concatenate([limited[..., None], torque_limited, speed_limited], axis=-1)
        return np.concatenate([tau, wheel], axis=-1), force, torque, flags

    return command
