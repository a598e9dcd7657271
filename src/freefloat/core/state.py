"""The simulation state and the actuation a controller returns.

State (all SI, frames as in :mod:`freefloat.conventions`):
    q         (N,)  joint angles, ``model.joint_names`` order
    qdot      (N,)  joint rates
    omega     (3,)  spacecraft angular velocity, spacecraft frame (the paper's ⁰ω0)
    attitude  (4,)  spacecraft attitude T0 (frame 0 -> frame I) as a unit quaternion
                    [x, y, z, w] (scalar last); a scipy ``Rotation`` or a 3x3
                    rotation matrix is accepted too
    r_cm      (3,)  system CM position, inertial frame (|r_cm| up to MAX_POSITION = 1e12 m)
    v_cm      (3,)  system CM velocity, inertial frame (|v_cm| up to MAX_SPEED = 1e8 m/s)
    wheel_speed (W,) reaction wheel speeds relative to the spacecraft, rad/s, ``model.wheels`` order (Basilisk's
                    Omega; :mod:`freefloat.core.wheels`); only for a model with wheels; |speed| up to MAX_RATE = 1e4

Omitted fields are zero (attitude: identity). Values beyond the bounds of :mod:`freefloat.core.numbers`
(|q| > 1e6 rad or m, a CM position or speed component beyond 1e12 m or 1e8 m/s) are refused as input: no
space robot has them, they are a unit slip. Every field may carry leading
batch axes (for batched rollouts); all fields then broadcast to one batch shape.

The flat state vector that the integrators see is
``x = [r_cm (3), v_cm (3), attitude (4), omega (3), q (N), qdot (N)]``
(:func:`pack_state`, :func:`unpack_state`; declared once in :mod:`freefloat.core.state_layout`). A model with W reaction
wheels integrates them as joints (:func:`freefloat.core.wheels.wheel_joint_model`):
``x = [..., omega, q (N), wheel angles (W), qdot (N), wheel_speed (W)]``. A run that models the joints' damping and friction
(:func:`dissipates`) carries one more, last: the energy they have dissipated since the start (J), integrated with
the state (its rate is the dissipated power), so that it is exact to the integrator's accuracy
(``Trajectory.dissipated_energy``); :func:`unpack_state` reads either form.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from .conventions import as_quaternion
from .errors import ShapeError
from .model import Model
from .numbers import MAX_POSITION, MAX_RATE, MAX_SPEED, check_joint_values, check_largest, real_array
from .state_layout import dissipated_at, span, state_length

__all__ = ["Actuation", "ActuatorLimits", "State", "dissipated", "dissipates", "pack_state", "state_size", "unpack_state"]

_FIELDS = ("q", "qdot", "omega", "attitude", "r_cm", "v_cm", "wheel_speed")
# the rates refused as input: (unit, why, fix) for check_largest at MAX_RATE (a joint rate or a spin beyond it is the
# divergence guard's: a simulation stops at t = 0 naming the joint; a wheel's speed is refused here)
_RATE_BOUNDS = {
    "wheel_speed": (
        "rad/s",
        "which no reaction wheel turns at (about 95,000 rpm)",
        "check the units (rad/s, relative to the spacecraft; rpm / 9.549 = rad/s)",
    ),
}
# the CM's bounds: (limit, unit, why, fix) for check_largest
_CM_BOUNDS = {
    "r_cm": (
        MAX_POSITION,
        "m",
        "farther than any space robot goes (7 AU, past Jupiter's orbit)",
        "check the units (metres) and the origin of the inertial frame",
    ),
    "v_cm": (MAX_SPEED, "m/s", "a third of the speed of light, which no spacecraft reaches", "check the units (m/s)"),
}


def _distinct(arr: np.ndarray) -> np.ndarray:
    """The entries of ``arr`` that can differ: a view with every axis of stride 0 (a broadcast, ``np.broadcast_to``) cut
    to its first index, so that a batch of 10^8 copies of one state is checked as one."""
    if arr.ndim == 0 or all(arr.strides):
        return arr
    return arr[tuple(slice(0, 1) if stride == 0 else slice(None) for stride in arr.strides)]


def _finite(name: str, value: Any, size: int, what: str) -> np.ndarray:
    """``value`` as a float array of shape (..., size) with finite, real entries, or an error naming ``name``;
    joint values beyond :data:`~freefloat.core.numbers.MAX_JOINT_VALUE` are refused too (:func:`check_joint_values`),
    and so are CM positions beyond :data:`~freefloat.core.numbers.MAX_POSITION` and CM speeds beyond
    :data:`~freefloat.core.numbers.MAX_SPEED`."""
    arr = real_array(value, f"State.{name}")
    if arr.ndim == 0 or arr.shape[-1] != size:
        raise ShapeError(f"State.{name}: expected shape (..., {size}) ({what}), got {arr.shape}")
    _check_values(name, _distinct(arr))
    return arr


def _check_values(name: str, arr: np.ndarray) -> None:
    """Refuse NaN, infinities and values beyond their bounds in the field ``name`` (:mod:`freefloat.core.numbers`)."""
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"State.{name}: has NaN or infinite entries; give finite values")
    if name == "q":
        check_joint_values(arr, "State.q")
    elif name in _CM_BOUNDS:
        check_largest(arr, f"State.{name}", *_CM_BOUNDS[name])
    elif name in _RATE_BOUNDS:
        check_largest(arr, f"State.{name}", MAX_RATE, *_RATE_BOUNDS[name])


def _quaternion(attitude: Any) -> np.ndarray:
    """An attitude (Rotation, quaternion [x, y, z, w] or 3x3 matrix) as unit quaternions (..., 4)."""
    if isinstance(attitude, Rotation):
        return as_quaternion(attitude)
    try:
        arr = np.asarray(attitude, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"State.attitude: expected a quaternion [x, y, z, w], a scipy Rotation or a 3x3 matrix, got {attitude!r}") from exc
    if arr.shape[-2:] == (3, 3):
        if not np.all(np.isfinite(arr)):
            raise ValueError("State.attitude: rotation matrix has NaN or infinite entries")
        eye = np.einsum("...ji,...jk->...ik", arr, arr)
        if np.max(np.abs(eye - np.eye(3)), initial=0.0) > 1e-6 or np.any(np.linalg.det(arr) < 0):
            raise ValueError("State.attitude: a 3x3 attitude must be a proper rotation matrix (orthonormal to 1e-6, determinant +1)")
        return np.asarray(Rotation.from_matrix(arr.reshape(-1, 3, 3)).as_quat(), dtype=float).reshape((*arr.shape[:-2], 4))
    try:
        return as_quaternion(arr)
    except (ShapeError, ValueError) as exc:
        raise type(exc)(f"State.{exc}") from exc


@dataclass(frozen=True, eq=False)
class State:
    """A state of the space robot; ``State(q=...)`` leaves the rest at rest and at identity.

    Fields and frames are listed in the module docstring. The model-independent
    checks (finite values, trailing sizes 3 and 4, a unit quaternion) run here;
    :meth:`resolve` checks the joint-sized fields against a model and fills
    the omitted ones.

    Examples
    --------
    >>> import freefloat as ff
    >>> from scipy.spatial.transform import Rotation
    >>> s = ff.State(q=[0.1, 0.2], omega=[0.0, 0.0, 0.01], attitude=Rotation.from_euler("z", 0.3))
    >>> s.attitude.round(4).tolist()
    [0.0, 0.0, 0.1494, 0.9888]
    """

    q: Any = None
    qdot: Any = None
    omega: Any = None
    attitude: Any = None
    r_cm: Any = None
    v_cm: Any = None
    wheel_speed: Any = None

    def __post_init__(self) -> None:
        for name, what in (
            ("omega", "spacecraft angular velocity, spacecraft frame"),
            ("r_cm", "system CM position, inertial frame"),
            ("v_cm", "system CM velocity, inertial frame"),
        ):
            if getattr(self, name) is not None:
                object.__setattr__(self, name, _finite(name, getattr(self, name), 3, what))
        if self.attitude is not None:
            object.__setattr__(self, "attitude", _quaternion(self.attitude))
        for name in ("q", "qdot", "wheel_speed"):
            value = getattr(self, name)
            if value is not None:
                arr = real_array(value, f"State.{name}")
                if arr.ndim == 0:
                    each = "reaction wheel, shape (..., W)" if name == "wheel_speed" else "joint, shape (..., N)"
                    raise ShapeError(f"State.{name}: expected one value per {each}, got a scalar {value!r}")
                _check_values(name, _distinct(arr))
                object.__setattr__(self, name, arr)

    @classmethod
    def _trusted(cls, **fields: np.ndarray) -> State:
        """A state from arrays known to be valid (no checks: used by the integrators)."""
        state = object.__new__(cls)
        state.__dict__.update(fields)  # frozen: write the instance dict directly
        return state

    def resolve(self, model: Model) -> State:
        """A copy with every field an array of the right size for ``model`` (errors name the field)."""
        n = model.n_joints
        shapes = [np.shape(getattr(self, name))[:-1] for name in _FIELDS if getattr(self, name) is not None]
        try:
            batch = np.broadcast_shapes(*shapes) if shapes else ()
        except ValueError as exc:
            given = ", ".join(f"{name} {np.shape(getattr(self, name))}" for name in _FIELDS if getattr(self, name) is not None)
            raise ShapeError(f"State: the fields' leading (batch) shapes do not broadcast: {given}") from exc

        def get(name: str, size: int, what: str) -> np.ndarray:
            value = getattr(self, name)
            if value is None:
                return np.zeros((*batch, size))
            return np.broadcast_to(_finite(name, value, size, what), (*batch, size)).copy()

        names = ", ".join(model.joint_names) or "none"
        quat = np.array([0.0, 0.0, 0.0, 1.0]) if self.attitude is None else self.attitude
        return State._trusted(
            q=get("q", n, f"{model.name!r} has {n} joints: {names}"),
            qdot=get("qdot", n, f"one rate per joint of {model.name!r}: {names}"),
            omega=get("omega", 3, "spacecraft angular velocity, spacecraft frame"),
            attitude=np.broadcast_to(quat, (*batch, 4)).copy(),
            r_cm=get("r_cm", 3, "system CM position, inertial frame"),
            v_cm=get("v_cm", 3, "system CM velocity, inertial frame"),
            wheel_speed=get(
                "wheel_speed",
                model.n_wheels,
                f"one speed per reaction wheel of {model.name!r}: {', '.join(w.name for w in model.wheels)}"
                if model.wheels
                else f"{model.name!r} has no reaction wheels",
            ),
        )

    @property
    def velocity(self) -> np.ndarray:
        """zdot0 = [v_cm (inertial), omega (spacecraft frame), qdot] (1991 eq. 8), of a resolved state."""
        return np.concatenate([self.v_cm, self.omega, self.qdot], axis=-1)

    @property
    def rotation(self) -> Rotation:
        """The attitude T0 (frame 0 -> frame I) as a scipy ``Rotation`` (identity when omitted)."""
        return Rotation.from_quat([0.0, 0.0, 0.0, 1.0] if self.attitude is None else self.attitude)


class _View:
    """A field of a :class:`_FlatState`: the view of its flat state vector, made when first read and then kept in the
    instance's dict (a non-data descriptor: Python looks there first)."""

    __slots__ = ("index", "name")

    def __init__(self, index: int) -> None:
        self.index = index
        self.name = ""

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def __get__(self, state: Any, owner: type | None = None) -> Any:
        if state is None:
            return self
        found = state.__dict__
        value = found["_flat"][found["_parts"][self.index]]
        found[self.name] = value
        return value


class _FlatState(State):
    """The :class:`State` of one flat state vector (:func:`unpack_state`): each field a view of the vector; ``q`` and
    ``qdot`` made with the state, the others when first read. A controller called every step of a simulation reads a
    few fields (a joint PD reads ``q`` and ``qdot``); seven views made up front cost it about 0.6 us a step (~120 ns
    each, a read through :class:`_View` ~300 ns). It is a State in every other respect (its fields, ``repr``,
    ``dataclasses.replace``, pickling, copying), with two more entries in its ``__dict__``: the vector and the slices."""

    def __repr__(self) -> str:
        return repr(State._trusted(**{name: getattr(self, name) for name in _FIELDS}))

    def __setattr__(self, name: str, value: Any) -> None:  # frozen like State (its frozen check spares a subclass's new names)
        raise dataclasses.FrozenInstanceError(f"cannot assign to field {name!r}")

    def __delattr__(self, name: str) -> None:
        raise dataclasses.FrozenInstanceError(f"cannot delete field {name!r}")

    r_cm = _View(0)
    v_cm = _View(1)
    attitude = _View(2)
    omega = _View(3)
    q = _View(4)
    qdot = _View(5)
    wheel_speed = _View(6)


@dataclass(frozen=True)
class Actuation:
    """What a controller returns: joint torques (N,) in N m, and the thruster force (N) and torque
    (N m) at the spacecraft CM (3,), both in the spacecraft frame. ``None`` means zero (free-floating).

    ``wheel_torque`` (W,), N m: the motor torque on each reaction wheel about its spin axis (``model.wheels`` order;
    the spacecraft gets the opposite torque), before the wheels' limits (:mod:`freefloat.core.wheels`).

    ``extras`` is free for the controller's own diagnostics; the simulator ignores it.
    """

    joint_torque: Any = None
    spacecraft_force: Any = None
    spacecraft_torque: Any = None
    wheel_torque: Any = None
    extras: dict[str, Any] = field(default_factory=dict)


_NOT_SATURATED = np.array(False)
_NOT_SATURATED.flags.writeable = False


@dataclass(frozen=True)
class ActuatorLimits:
    """Symmetric actuator limits: each component is saturated to [-limit, +limit].

    ``joint_torque`` (scalar or (N,), N m), ``spacecraft_force`` (scalar or (3,),
    N, spacecraft frame), ``spacecraft_torque`` (scalar or (3,), N m). ``None``
    means unlimited. Saturation is recorded in ``Trajectory.saturated``.
    """

    joint_torque: Any = None
    spacecraft_force: Any = None
    spacecraft_torque: Any = None

    def __post_init__(self) -> None:
        for name in ("joint_torque", "spacecraft_force", "spacecraft_torque"):
            limit = getattr(self, name)
            if limit is None:
                continue
            try:
                lim = real_array(limit, f"ActuatorLimits.{name}")
            except TypeError as exc:
                raise ValueError(f"ActuatorLimits.{name}: expected a positive number or an array of them, got {limit!r}") from exc
            if lim.ndim > 1 or np.any(~np.isfinite(lim)) or np.any(lim <= 0):
                raise ValueError(
                    f"ActuatorLimits.{name}: every limit must be positive and finite (a scalar or one per component), got {limit!r}"
                )

    @property
    def unlimited(self) -> bool:
        """True when no component is limited (:meth:`apply` then clips nothing)."""
        return self.joint_torque is None and self.spacecraft_force is None and self.spacecraft_torque is None

    def apply(self, tau: np.ndarray, force: np.ndarray, torque: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Clip joint torques, spacecraft force and torque to these limits: ``(tau, force, torque, saturated)``, with
        ``saturated`` true (per leading index) where any component was clipped."""
        if self.unlimited:
            return tau, force, torque, _NOT_SATURATED if tau.ndim == 1 else np.zeros(tau.shape[:-1], dtype=bool)
        saturated = np.zeros(tau.shape[:-1], dtype=bool)
        out = []
        for value, limit, name in (
            (tau, self.joint_torque, "joint_torque"),
            (force, self.spacecraft_force, "spacecraft_force"),
            (torque, self.spacecraft_torque, "spacecraft_torque"),
        ):
            if limit is None:
                out.append(value)
                continue
            lim = np.asarray(limit, dtype=float)
            if np.any(lim <= 0) or not np.all(np.isfinite(lim)):
                raise ValueError(f"limits.{name}: every limit must be positive and finite, got {limit!r}")
            clipped = np.clip(value, -lim, lim)
            saturated |= np.any(clipped != value, axis=-1)
            out.append(clipped)
        return out[0], out[1], out[2], saturated


def state_size(model: Model) -> int:
    """Length of the flat state vector [r_cm, v_cm, attitude, omega, q, (wheel angles), qdot, (wheel speeds)]
    (:mod:`~freefloat.core.state_layout`), without the dissipated energy's slot."""
    return state_length(model.n_joints + model.n_wheels)


def dissipates(model: Model) -> bool:
    """Whether a run of ``model`` integrates the energy its joints' damping and friction dissipate, in the last slot of
    its flat state: when it has them (``model.has_passive``; a run with ``passive="ignore"`` simulates the
    model without them, which has none)."""
    return model.has_passive or any(w.viscous or w.coulomb for w in model.wheels)


def pack_state(state: State, dissipated: Any = None) -> np.ndarray:
    """Flat state [r_cm (3), v_cm (3), attitude (4), omega (3), q (N), qdot (N)] of a resolved state; with
    ``dissipated`` (J, a number or one per state of a batch), that energy appended as the last slot.
    With wheel speeds (W > 0): [..., omega, q, wheel angles (zeros), qdot, wheel_speed] (module docstring)."""
    speed = getattr(state, "wheel_speed", None)
    if speed is not None and np.shape(speed)[-1]:
        parts = [state.r_cm, state.v_cm, state.attitude, state.omega, state.q, np.zeros_like(speed), state.qdot, speed]
    else:
        parts = [state.r_cm, state.v_cm, state.attitude, state.omega, state.q, state.qdot]
    if dissipated is not None:
        parts.append(np.broadcast_to(np.asarray(dissipated, dtype=float)[..., None], (*np.shape(state.q)[:-1], 1)))
    return np.concatenate(parts, axis=-1)


def dissipated(model: Model, x: np.ndarray) -> np.ndarray:
    """The dissipated energy (...) of flat states x (..., S), with the energy's slot or without it: the last slot (a
    view), or zeros when the states carry none (:func:`dissipates`)."""
    n = model.n_joints + model.n_wheels
    if x.shape[-1] == state_length(n, True):
        return x[..., dissipated_at(n)]
    return np.zeros(x.shape[:-1])


def unpack_state(model: Model, x: np.ndarray) -> State:
    """Inverse of :func:`pack_state` (views into ``x``, no copies and no checks); the dissipated energy's slot, if
    there, is not a field of the state (:func:`dissipated` reads it)."""
    n, w = model.n_joints, model.n_wheels
    if x.shape[-1] not in (state_length(n + w), state_length(n + w, True)):
        raise ShapeError(
            f"state vector: expected shape (..., {state_length(n + w)}) for {model.name!r} (r_cm, v_cm, attitude, omega, "
            f"then q and qdot of N = {n} joints and W = {w} wheels; or {state_length(n + w, True)} with the dissipated energy "
            f"last), got {x.shape}"
        )
    parts = _parts(n, w)
    if x.ndim == 1:  # a controller's every step reads one: q and qdot now, the other views when read (:class:`_FlatState`)
        flat = object.__new__(_FlatState)
        found = flat.__dict__
        found["_flat"] = x
        found["_parts"] = parts
        found["q"] = x[parts[4]]
        found["qdot"] = x[parts[5]]
        return flat
    state = object.__new__(State)  # State._trusted, written out
    fields = zip(("r_cm", "v_cm", "attitude", "omega", "q", "qdot", "wheel_speed"), parts, strict=True)
    state.__dict__.update((name, x[..., part]) for name, part in fields)
    return state


@functools.lru_cache(maxsize=64)
def _parts(n: int, w: int) -> tuple[slice, ...]:
    """The slices of the flat state that hold r_cm, v_cm, the attitude, omega, q, qdot and the wheel speeds (N joints,
    W wheels)."""
    q, qdot = span("q", n + w), span("qdot", n + w)  # the wheels' after the joints' in each
    return (
        span("r_cm", n + w),
        span("v_cm", n + w),
        span("attitude", n + w),
        span("omega", n + w),
        slice(q.start, q.start + n),
        slice(qdot.start, qdot.start + n),
        slice(qdot.start + n, qdot.stop),
    )
