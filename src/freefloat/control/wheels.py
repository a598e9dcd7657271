"""Spacecraft torque by reaction wheels (1991 §II: wheels and momentum gyros beside the thrusters).

A controller of :mod:`freefloat.control` computes the thruster force and torque of 1991 eq. 30; with
``torque_by="wheels"`` the torque goes to the spacecraft's reaction wheels instead (:mod:`freefloat.core.wheels`).
The reaction on the spacecraft of motor torques u (W,) is ``-A u`` (A = [a_1 ... a_W], the spin axes, spacecraft
frame), and the spinning wheels add the gyroscopic torque ``-ω0 × h_w`` (h_w the wheels' momentum relative to the
spacecraft): the wheels give the torque n when ``-A u = n + ω0 × h_w``, solved in least squares,
``u = -A⁺ (n + ω0 × h_w)`` (Basilisk's ``rwMotorTorque`` maps a body torque to the wheels the same way, with the
pseudo-inverse). Not compensated: the bearing friction, and the spin inertia the wheels take out of the locked
spacecraft's while they turn freely (``Σ Js a aᵀ``, small beside the spacecraft's own). A torque about an axis the
wheels do not span cannot be given by them: a warning says so when the controller is made, and ``extras`` holds the
part not given (``unrealised_torque``).
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from ..core.errors import NearSingularWarning
from ..core.model import Model
from ..core.state import State
from ..core.wheels import wheel_arrays
from ..mechanics.momentum import wheel_momentum

__all__ = ["FORCE_BY", "TORQUE_BY", "check_actuators", "route_actuation", "wheel_torques"]

#: Who gives the spacecraft torque of a controller: the thrusters (1991 eq. 30 as printed) or the reaction wheels.
TORQUE_BY = ("thrusters", "wheels")
#: Who gives the spacecraft force: the thrusters, or nobody (the CM drifts).
FORCE_BY = ("thrusters", "none")


def check_actuators(model: Model, torque_by: Any, force_by: Any) -> tuple[str, str]:
    """``(torque_by, force_by)`` checked against :data:`TORQUE_BY`, :data:`FORCE_BY` and the model's wheels; a warning
    when the wheels span fewer than three axes."""
    if not isinstance(torque_by, str) or torque_by not in TORQUE_BY:
        raise ValueError(f"torque_by: expected one of {', '.join(map(repr, TORQUE_BY))}, got {torque_by!r}")
    if not isinstance(force_by, str) or force_by not in FORCE_BY:
        raise ValueError(f"force_by: expected one of {', '.join(map(repr, FORCE_BY))}, got {force_by!r}")
    if torque_by == "wheels":
        if not model.wheels:
            raise ValueError(
                f"torque_by: 'wheels', but {model.name!r} has no reaction wheels; declare them (ModelBuilder.add_wheel, "
                "[[wheels]] in a model file, ff.load(..., wheels=...): docs/wheels.md) or use 'thrusters'"
            )
        rank = int(np.linalg.matrix_rank(_axes(model)))
        if rank < 3:
            warnings.warn(
                f"torque_by='wheels': the {model.n_wheels} wheels of {model.name!r} span {rank} axes of 3; the spacecraft "
                "torque about the others is not applied (extras['unrealised_torque'] holds it)",
                NearSingularWarning,
                stacklevel=3,
            )
    return torque_by, force_by


def _axes(model: Model) -> np.ndarray:
    return wheel_arrays(model)[0].T


def wheel_torques(model: Model, state: State, spacecraft_torque: Any) -> tuple[np.ndarray, np.ndarray]:
    """The wheel motor torques (..., W), N m, that give the spacecraft torque ``spacecraft_torque`` (..., 3), N m,
    spacecraft frame, at the resolved ``state`` (its ``omega`` and ``wheel_speed``): ``u = -A⁺ (n + ω0 × h_w)`` (module
    docstring), and the part of n the wheels cannot give (..., 3) (zero when they span three axes)."""
    axes = _axes(model)
    demand = np.asarray(spacecraft_torque, dtype=float) + np.cross(state.omega, wheel_momentum(model, state.wheel_speed))
    torques = -demand @ np.linalg.pinv(axes).T
    return torques, demand + torques @ axes.T


def route_actuation(
    model: Model, state: State, force: np.ndarray, torque: np.ndarray, actuators: tuple[str, str], extras: dict[str, Any]
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """A controller's thruster force and torque sent where ``actuators`` = (torque_by, force_by) says
    (:func:`check_actuators`): ``(force, torque, wheel torques or None)``; ``extras`` gains ``wheel_torque`` and
    ``unrealised_torque`` when the wheels take the torque. Every controller of :mod:`freefloat.control` ends here."""
    wheel = None
    if actuators[0] == "wheels":
        wheel, extras["unrealised_torque"] = wheel_torques(model, state, torque)
        extras["wheel_torque"] = wheel
        torque = np.zeros_like(torque)
    if actuators[1] == "none":
        force = np.zeros_like(force)
    return force, torque, wheel
