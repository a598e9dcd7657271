"""Detumbling after a capture: a controller that brings the combined system to rest (or to a commanded spacecraft
attitude) with the thrusters and the joint torques, and what it cost.

:class:`Detumble` is 1991 eq. 27 with the task "zero rates": the task coordinates are the generalized velocities
themselves (J_z = 1), so eq. 27 becomes the computed-torque law on the whole system,

    Q_c = H+ zddot0,des + C+,   zddot0,des = -K zdot0  (+ K_att e_att on the spacecraft rows),

and [f_S; n_S; τ] = J_q⁻ᵀ Q_c (eq. 30). With an exact model and no saturation every rate decays as exp(-k t):
v_cm (inertial, by the thruster force), the spacecraft rate ω0 (spacecraft frame, by the thruster torque) and the
joint rates (by the joint torques). ``attitude=`` adds a commanded spacecraft attitude: ω̇0,des = K_att e - k ω0
with e the rotation vector of T0ᵀ T0,des (spacecraft frame). ``force=False`` keeps the thrusters' force off
(torque only): the CM then keeps its velocity, and rest means zero rotation and joint rates.

:func:`detumble_cost` reads a simulated :class:`~freefloat.Trajectory` of it (or of any controller): thruster
impulse, delta-v of the combined system and the propellant for a specific impulse, peak joint torques, time to rest,
and with reaction wheels (``torque_by="wheels"``, docs/wheels.md) their peak speed, spin momentum, torque and the
limits that acted.
"""

from __future__ import annotations

import copy
import os
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from ..core.conventions import attitude_matrix
from ..core.errors import ShapeError
from ..core.model import Model, resolve_model
from ..core.numbers import real_array
from ..core.state import Actuation, State
from ..mechanics.dynamics import nonlinear_forces
from ..mechanics.momentum import system_inertia_matrix, wheel_spin_momentum
from . import _compiled
from ._compiled import batch_call
from .controllers import actuation_of
from .wheels import check_actuators

__all__ = ["STANDARD_GRAVITY", "Detumble", "DetumbleCost", "detumble_cost"]

STANDARD_GRAVITY = 9.80665
"""g0 of the rocket equation (m/s²): the propellant mass from a specific impulse in seconds."""


def _positive(value: Any, name: str, unit: str) -> float:
    if isinstance(value, np.ndarray) and value.ndim == 0:  # a 0-d array is a number
        value = value[()]
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name}: expected a number ({unit}), got {type(value).__name__} {value!r}")
    number = float(value)
    if not (np.isfinite(number) and number > 0.0):
        raise ValueError(f"{name}: expected a positive finite number ({unit}), got {value!r}")
    return number


class Detumble:
    """A controller ``(t, state) -> Actuation`` that brings the system to rest: 1991 eq. 27 with J_z = 1 (module doc).

    ``rate_gain`` k (1/s): every generalized rate decays as exp(-k t) (a scalar, or (6 + N,) per row of zdot0 =
    [v_cm, ω0, qdot]). ``attitude`` (None: rates only; else a unit quaternion [x, y, z, w] or a scipy ``Rotation``,
    spacecraft frame -> inertial) with ``attitude_gain`` (1/s², default k²/4: critically damped about each axis).
    ``force=False``: no thruster force (the CM keeps drifting). ``torque_by="wheels"``: the spacecraft torque by the
    reaction wheels (:mod:`freefloat.control.wheels`), not the thrusters. Actuator limits are the simulation's
    (``simulate(..., limits=ff.ActuatorLimits(...))``), which saturates and records where it did.

    ``model``: a :class:`~freefloat.Model`, a built-in model name or a model file path (``ff.load``), or a sequence of
    payload variants (one per trajectory). Each argument is checked by name before any work: numbers must be real
    numbers (not text, not booleans), ``force`` a boolean (not the text "true").
    """

    def __init__(
        self,
        model: Model,
        *,
        rate_gain: Any = 0.5,
        attitude: Any = None,
        attitude_gain: float | None = None,
        force: bool = True,
        torque_by: str = "thrusters",
    ) -> None:
        if isinstance(model, (str, os.PathLike)):
            model = resolve_model(model)  # a built-in name or a model file, as everywhere a model is taken
        self.models = _compiled.models_of(model)  # one model, or payload variants per trajectory
        model = self.models[0]
        if not isinstance(force, (bool, np.bool_)):
            raise TypeError(f"force: expected True or False (thrusters stop the CM, or torque only), got {type(force).__name__} {force!r}")
        self.actuators = check_actuators(model, torque_by, "thrusters" if force else "none")
        size = 6 + model.n_joints
        gains = real_array(rate_gain, "rate_gain")
        gains = np.full(size, float(gains)) if gains.ndim == 0 else gains
        if gains.ndim == 2 and gains.shape[1] in (1, size):  # per trajectory: (B, 1) or (B, 6 + N)
            gains = np.broadcast_to(gains, (gains.shape[0], size))
        elif gains.shape != (size,):
            raise ShapeError(
                f"rate_gain: expected a scalar or ({size},) gains (a row of [v_cm, omega, qdot] each), or per trajectory (B, {size}) "
                f"or (B, 1), got {gains.shape}"
            )
        if not (np.all(np.isfinite(gains)) and np.all(gains > 0.0)):
            raise ValueError(f"rate_gain: every gain must be positive and finite (1/s), got {rate_gain!r}")
        self.model, self.rate_gain, self.force = model, gains.copy(), bool(force)
        self.rate_gain_rows = np.atleast_2d(self.rate_gain).copy()
        self.attitude: np.ndarray | None = None
        self.attitude_gain = 0.0
        if attitude is not None:
            rotation = attitude if isinstance(attitude, Rotation) else None
            if rotation is None:
                quat = real_array(attitude, "attitude")
                if quat.shape != (4,) or not np.all(np.isfinite(quat)) or abs(np.linalg.norm(quat) - 1.0) > 1e-9:
                    raise ValueError(f"attitude: expected a unit quaternion [x, y, z, w] or a scipy Rotation, got {attitude!r}")
                rotation = Rotation.from_quat(quat)
            if rotation.single is False:
                raise ShapeError("attitude: expected one attitude, got a batch")
            self.attitude = rotation.as_matrix()
            k = float(np.min(gains[..., 3:6]))
            self.attitude_gain = _positive(k * k / 4.0 if attitude_gain is None else attitude_gain, "attitude_gain", "1/s^2")
        elif attitude_gain is not None:
            raise ValueError("attitude_gain: given without an attitude; pass attitude= as well, or drop attitude_gain")

    def on_capture(self, impact: Any) -> None:
        """Told by :func:`freefloat.simulate` at a capture event (``ff.Capture(controller_after=Detumble(robot))``):
        from then on it controls the combined model (``impact.model``: the same joints, the target attached)."""
        if impact.model.n_joints != self.model.n_joints:
            raise ValueError(f"impact.model: has {impact.model.n_joints} joints, this controller's model {self.model.n_joints}")
        self.model = impact.model
        self.models = (impact.model,)

    def compiled_law(self, batch: int | None = None) -> Any:
        """The controller's law as arrays for the compiled loops, for a run of ``batch`` trajectories (None: one
        simulation): :func:`freefloat.simulate` and :func:`freefloat.rollout` run it in their compiled loops, with no
        Python per step."""
        return _compiled.detumble_law(self, batch)

    def desired_acceleration(self, state: State) -> np.ndarray:
        """zddot0,des (6 + N) at a resolved ``state``: -k zdot0, the attitude error term on the ω0 rows, no force rows
        when ``force=False``."""
        acc = -self.rate_gain * state.velocity
        if self.attitude is not None:
            error = Rotation.from_matrix(attitude_matrix(state.attitude).T @ self.attitude).as_rotvec()
            acc[3:6] += self.attitude_gain * error
        if not self.force:
            acc[0:3] = 0.0
        return acc

    def parameter_rows(self) -> dict[str, int]:
        """The number of rows of each parameter that may have one per trajectory (1: shared)."""
        return {"rate_gain": self.rate_gain_rows.shape[0], "model": len(self.models)}

    def row(self, b: int) -> Detumble:
        """The controller of trajectory b: its row of the rate gains and its model."""
        one = copy.copy(self)
        one.model = self.models[b if len(self.models) > 1 else 0]
        one.models = (one.model,)
        one.rate_gain_rows = self.rate_gain_rows[b if self.rate_gain_rows.shape[0] > 1 else 0][None].copy()
        one.rate_gain = one.rate_gain_rows[0]
        return one

    def __call__(self, t: float, state: State) -> Actuation:
        """Thruster force and torque (spacecraft frame) and joint torques: Q_c = H+ zddot0,des + C+, then eq. 30, in numpy
        (the readable reference that the compiled form of the same law, run inside the compiled loops of
        :func:`freefloat.simulate` and :func:`freefloat.rollout`, is checked against). ``state`` may hold a batch of B
        states (a rollout): row b with its rate gains and model."""
        state = state.resolve(self.model)
        if np.ndim(state.q) != 1:
            return batch_call(self, float(t), state)
        if max(self.parameter_rows().values()) > 1:
            raise ShapeError(
                "state: one state, but the controller has per-trajectory rate gains or models; give a batch of states, one "
                "per row, or run it in freefloat.rollout"
            )
        acc = self.desired_acceleration(state)
        q_c = system_inertia_matrix(self.model, state.q) @ acc + nonlinear_forces(self.model, state.q, state.velocity)
        if not self.force:
            q_c[0:3] = 0.0  # C+ has no r_cm rows: the CM is left alone
        extras: dict[str, Any] = {"desired_acceleration": acc, "_t0": attitude_matrix(state.attitude)}
        return actuation_of(self.model, state, q_c, None, extras, self.actuators)


@dataclass(frozen=True)
class DetumbleCost:
    """What a detumbling (or any) run cost, from its recorded actuation (:func:`detumble_cost`).

    ``thruster_impulse`` ∫|f_S| dt (N s) and ``torque_impulse`` ∫|n_S| dt (N m s); ``delta_v`` = thruster_impulse /
    total mass (m/s, the combined system's); ``propellant_mass`` M (1 - exp(-delta_v / (Isp g0))) (kg; None without a
    specific impulse; the thruster torque's propellant depends on the thrusters' lever arms and is not in it);
    ``peak_joint_torque`` max |τ| per joint (N,) (N m); ``peak_force``, ``peak_torque`` max |f_S|, |n_S|;
    ``time_to_rest`` the first output time from which every later output is at rest (None: not at rest at the end);
    ``final_rates`` (|v_cm|, |ω0|, max |qdot|) at the last output. With reaction wheels (None without):
    ``peak_wheel_speed`` max |Omega| per wheel (W,) (rad/s, relative to the spacecraft), ``peak_wheel_momentum``
    max |Js (Omega + a.ω0)| per wheel (W,) (N m s, the rotor's own spin momentum: what its speed limit bounds in
    Basilisk's terms), ``peak_wheel_torque`` max |u| per wheel (W,) (N m), and ``wheel_saturated`` (W,) whether a
    wheel's torque or speed limit acted at an output.
    """

    thruster_impulse: float
    torque_impulse: float
    delta_v: float
    propellant_mass: float | None
    peak_joint_torque: np.ndarray
    peak_force: float
    peak_torque: float
    time_to_rest: float | None
    final_rates: tuple[float, float, float]
    peak_wheel_speed: np.ndarray | None = None
    peak_wheel_momentum: np.ndarray | None = None
    peak_wheel_torque: np.ndarray | None = None
    wheel_saturated: np.ndarray | None = None


def detumble_cost(
    trajectory: Any,
    *,
    specific_impulse: float | None = None,
    rest_rate: float = 1e-3,
    rest_velocity: float | None = 1e-3,
    rest_joint_rate: float = 1e-3,
) -> DetumbleCost:
    """The cost of a simulated run (a :class:`~freefloat.Trajectory` with its model): :class:`DetumbleCost`.

    The actuation is what the run recorded at each output time, held until the next (exact when the outputs are the
    controller's samples: ``output_period=sample_period``). At rest: |ω0| <= ``rest_rate`` (rad/s), every |qdot| <=
    ``rest_joint_rate`` (rad/s or m/s) and |v_cm| <= ``rest_velocity`` (m/s; None: the CM velocity is not asked,
    as after :class:`Detumble` with ``force=False``). ``specific_impulse`` (s) gives the propellant mass.
    """
    model = getattr(trajectory, "model", None)
    if model is None:
        raise ValueError("trajectory: has no model attached; load it with Trajectory.load(path, model=...)")
    if np.ndim(trajectory.q) != 2:
        raise ShapeError("trajectory: expected one run (a rollout's batch: take one trajectory at a time)")
    isp = None if specific_impulse is None else _positive(specific_impulse, "specific_impulse", "s")
    rest = (_positive(rest_rate, "rest_rate", "rad/s"), _positive(rest_joint_rate, "rest_joint_rate", "rad/s or m/s"))
    velocity_bound = None if rest_velocity is None else _positive(rest_velocity, "rest_velocity", "m/s")
    t = np.asarray(trajectory.t, dtype=float)
    held = np.diff(t)
    force = np.linalg.norm(trajectory.spacecraft_force, axis=-1)
    torque = np.linalg.norm(trajectory.spacecraft_torque, axis=-1)
    impulse, torque_impulse = float(force[:-1] @ held), float(torque[:-1] @ held)
    delta_v = impulse / model.total_mass
    propellant = None if isp is None else float(model.total_mass * -np.expm1(-delta_v / (isp * STANDARD_GRAVITY)))
    rates = (
        np.linalg.norm(trajectory.v_cm, axis=-1),
        np.linalg.norm(trajectory.omega, axis=-1),
        np.abs(trajectory.qdot).max(axis=-1) if model.n_joints else np.zeros(t.shape),
    )
    still = (rates[1] <= rest[0]) & (rates[2] <= rest[1])
    if velocity_bound is not None:
        still &= rates[0] <= velocity_bound
    moving = np.flatnonzero(~still)
    if moving.size == 0:
        time_to_rest: float | None = float(t[0])
    elif moving[-1] == t.size - 1:
        time_to_rest = None
    else:
        time_to_rest = float(t[moving[-1] + 1])
    tau = np.abs(np.asarray(trajectory.joint_torque, dtype=float))
    return DetumbleCost(
        thruster_impulse=impulse,
        torque_impulse=torque_impulse,
        delta_v=delta_v,
        propellant_mass=propellant,
        peak_joint_torque=tau.max(axis=0) if tau.size else np.zeros(model.n_joints),
        peak_force=float(force.max()),
        peak_torque=float(torque.max()),
        time_to_rest=time_to_rest,
        final_rates=(float(rates[0][-1]), float(rates[1][-1]), float(rates[2][-1])),
        **_wheel_costs(model, trajectory),
    )


def _wheel_costs(model: Model, trajectory: Any) -> dict[str, Any]:
    """The reaction wheels' part of :class:`DetumbleCost` (empty without wheels)."""
    if not model.wheels or getattr(trajectory, "wheel_speed", None) is None:
        return {}
    speed = np.asarray(trajectory.wheel_speed, dtype=float)
    spin = wheel_spin_momentum(model, speed, trajectory.omega)
    return {
        "peak_wheel_speed": np.abs(speed).max(axis=0),
        "peak_wheel_momentum": np.abs(spin).max(axis=0),
        "peak_wheel_torque": np.abs(np.asarray(trajectory.wheel_torque, dtype=float)).max(axis=0),
        "wheel_saturated": np.any(trajectory.wheel_torque_saturated | trajectory.wheel_speed_saturated, axis=0),
    }
