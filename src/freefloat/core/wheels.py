"""Reaction wheels: spacecraft torque actuators that store angular momentum (1991 §II names them beside thrusters).

A reaction wheel is a balanced rotor in the spacecraft, spinning about an axis fixed in the spacecraft frame. Its
motor applies a torque ``u`` to the rotor about that axis and ``-u`` to the spacecraft; the rotor's speed relative to
the spacecraft, ``Omega`` (rad/s), is a state of the simulation (``State.wheel_speed``).

Conventions, following Basilisk's ``reactionWheelStateEffector`` where they fit (docs/wheels.md):

- ``axis``: the spin axis, a unit vector in the spacecraft frame (Basilisk's ``gsHat_B``);
- ``inertia``: the rotor's inertia about the spin axis, kg m² (Basilisk's ``Js``);
- ``max_torque``: the motor torque limit, N m (``u_max``): a command beyond it is clipped to it, and recorded;
- ``max_speed``: the speed limit, rad/s (``Omega_max``, at most MAX_RATE = 1e4): as in Basilisk, a wheel at or beyond it gets no motor
  torque that would spin it faster (the command is set to zero, and recorded); torque that slows it is applied;
- ``viscous`` (N m s/rad) and ``coulomb`` (N m): the bearing friction, a torque ``-viscous Omega`` and a smooth Coulomb
  torque against ``Omega`` (the joints' law, :func:`freefloat.mechanics.passive_torque`), acting between rotor and
  spacecraft (Basilisk's ``cViscous`` and ``fCoulomb``; its static friction and Stribeck curve are not modelled).

**The spacecraft body of the model holds the wheels as rigid parts** (its mass and inertia are those of the
spacecraft with its wheels locked, as a mass-properties report of the assembled spacecraft gives them), so every
kinematic and momentum quantity of the model (J*, H+, the barycentric vectors) is that of the whole spacecraft; the
wheels add only their spin relative to it. This is Basilisk's own convention for balanced wheels: with its default
``includeWheelMassProperties = False``, a ``BalancedWheels`` wheel adds no mass or constant inertia and the hub
(``mHub``, ``r_BcB_B``, ``IHubPntBc_B``) must include the wheels locked, so a Basilisk hub is taken as it is (only
with ``includeWheelMassProperties = True``, a hub without its wheels, are their mass and inertia added to it). A
balanced wheel's position does not enter the dynamics (its CM is fixed in the spacecraft), so it is not asked.

For the dynamics, :func:`wheel_joint_model` turns the wheels into bodies on revolute joints of the spacecraft, which
the engine integrates like any joint: each a rotor of inertia ``Js a aᵀ`` (no mass, at the spacecraft's CM), and the
spacecraft body keeps the rest, ``I_locked - Σ Js a aᵀ``. That is exact for balanced wheels: the total angular
momentum about the system CM is ``H+``'s of the locked system plus ``Σ Js Omega_i a_i``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import ModelError
from .numbers import MAX_RATE

if TYPE_CHECKING:
    from .model import Model

__all__ = [
    "WHEEL_KEYS",
    "ReactionWheel",
    "check_same_wheels",
    "check_wheels",
    "reaction_wheel",
    "wheel_arrays",
    "wheel_joint_model",
    "wheel_limits",
    "wheels_from",
]

#: The keys of a wheel's table in a model file or side file (``[[wheels]]``), with what each holds.
WHEEL_KEYS = {
    "name": "the wheel's name",
    "axis": "spin axis [x, y, z], unit vector, spacecraft frame (Basilisk gsHat_B)",
    "inertia": "rotor inertia about the spin axis, kg m^2 (Basilisk Js)",
    "max_torque": "motor torque limit, N m (Basilisk u_max; omit for none)",
    "max_speed": "speed limit relative to the spacecraft, rad/s (Basilisk Omega_max; omit for none)",
    "viscous": "viscous bearing friction, N m s/rad (Basilisk cViscous; default 0)",
    "coulomb": "Coulomb bearing friction, N m (Basilisk fCoulomb; default 0)",
}


@dataclass(frozen=True, eq=False)
class ReactionWheel:
    """One reaction wheel (module docstring: the conventions, Basilisk's names in brackets).

    ``axis`` (3,) unit spin axis, spacecraft frame [gsHat_B]; ``inertia`` rotor inertia about it, kg m² [Js];
    ``max_torque`` N m [u_max] and ``max_speed`` rad/s [Omega_max] (inf: none); ``viscous`` N m s/rad and ``coulomb``
    N m bearing friction. Made by :func:`reaction_wheel`, which checks every field.
    """

    name: str
    axis: np.ndarray
    inertia: float
    max_torque: float = float("inf")
    max_speed: float = float("inf")
    viscous: float = 0.0
    coulomb: float = 0.0

    def __eq__(self, other: object) -> bool:
        return isinstance(other, ReactionWheel) and self.as_dict() == other.as_dict()

    def __hash__(self) -> int:
        return hash(repr(self.as_dict()))

    def as_dict(self) -> dict[str, Any]:
        """The wheel as a model file's table (limits that are infinite left out)."""
        out: dict[str, Any] = {"name": self.name, "axis": self.axis.tolist(), "inertia": self.inertia}
        for key in ("max_torque", "max_speed"):
            if np.isfinite(getattr(self, key)):
                out[key] = getattr(self, key)
        for key in ("viscous", "coulomb"):
            if getattr(self, key):
                out[key] = getattr(self, key)
        return out


def _number(value: Any, path: str, what: str, *, positive: bool, allow_inf: bool = False) -> float:
    if isinstance(value, (bool, np.bool_, str, bytes)) or value is None:
        raise ModelError(path, f"cannot read {value!r} as a number", f"give the {what}")
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise ModelError(path, f"cannot read {value!r} as a number", f"give the {what}") from None
    if np.isnan(out) or (np.isinf(out) and not allow_inf) or out < 0 or (positive and out == 0):
        sign = "positive" if positive else "zero or positive"
        raise ModelError(path, f"must be {sign}{'' if allow_inf else ' and finite'}, got {value!r}", f"give the {what}")
    return out


def _speed_limit(value: Any, path: str) -> float:
    """A wheel's ``max_speed``: positive, finite and at most :data:`~freefloat.core.numbers.MAX_RATE` (a speed beyond
    it is refused as a wheel's state and stops a simulation, so a limit beyond it could never act)."""
    out = _number(value, path, "speed limit in rad/s (> 0)", positive=True)
    if out > MAX_RATE:
        raise ModelError(
            path,
            f"{out:.6g} rad/s is beyond {MAX_RATE:g} rad/s (about 95,000 rpm), the fastest a wheel may turn in freefloat",
            "check the units (rad/s; rpm / 9.549 = rad/s), or leave max_speed out for no limit",
        )
    return out


def reaction_wheel(
    name: str,
    *,
    axis: Any,
    inertia: float,
    max_torque: float | None = None,
    max_speed: float | None = None,
    viscous: float = 0.0,
    coulomb: float = 0.0,
    path: str = "wheels[0]",
) -> ReactionWheel:
    """A checked :class:`ReactionWheel`; each error (a :class:`ModelError`) names the field (``path.axis``) and the fix.

    ``axis`` must be a unit vector to 1e-6 (it is not normalised for you: a non-unit axis is a typo or a unit slip).
    """
    if not isinstance(name, str) or not name:
        raise ModelError(f"{path}.name", f"expected a non-empty string, got {name!r}", "name every wheel")
    path = f"{path} ({name})"
    try:
        vec = np.asarray(axis, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{path}.axis", f"cannot read {axis!r} as three numbers", "give the spin axis [x, y, z]") from None
    if vec.shape != (3,) or not np.all(np.isfinite(vec)):
        raise ModelError(f"{path}.axis", f"expected three finite numbers [x, y, z], got {axis!r}", "give the spin axis, spacecraft frame")
    norm = float(np.linalg.norm(vec))
    if abs(norm - 1.0) > 1e-6:
        raise ModelError(f"{path}.axis", f"is not a unit vector (norm {norm:.6g})", "give the unit spin axis in the spacecraft frame")
    vec = vec.copy()
    vec.setflags(write=False)
    limit = float("inf")
    return ReactionWheel(
        name=name,
        axis=vec,
        inertia=_number(inertia, f"{path}.inertia", "rotor inertia about the spin axis in kg m^2 (> 0)", positive=True),
        max_torque=limit if max_torque is None else _number(max_torque, f"{path}.max_torque", "torque limit in N m (> 0)", positive=True),
        max_speed=limit if max_speed is None else _speed_limit(max_speed, f"{path}.max_speed"),
        viscous=_number(viscous, f"{path}.viscous", "viscous friction in N m s/rad (>= 0)", positive=False),
        coulomb=_number(coulomb, f"{path}.coulomb", "Coulomb friction torque in N m (>= 0)", positive=False),
    )


def wheels_from(tables: Any, where: str = "wheels") -> tuple[ReactionWheel, ...]:
    """Wheels from a list of tables (a model file's ``[[wheels]]``, a side file's, or ``ff.load(wheels=...)``'s dicts)
    or of :class:`ReactionWheel`; an unknown key is refused, naming it and the known ones."""
    if isinstance(tables, (str, bytes, Mapping)) or not isinstance(tables, Iterable):
        raise ModelError(where, f"expected a list of wheel tables, got {tables!r}", "give [[wheels]] tables (docs/wheels.md)")
    out = []
    for i, table in enumerate(tables):
        path = f"{where}[{i}]"
        if isinstance(table, ReactionWheel):
            out.append(table)
            continue
        if not isinstance(table, Mapping):
            raise ModelError(path, f"expected a table of {', '.join(WHEEL_KEYS)}, got {table!r}", "give each wheel as a table")
        unknown = [k for k in table if k not in WHEEL_KEYS]
        if unknown:
            raise ModelError(
                f"{path}.{unknown[0]}", f"unknown key {unknown[0]!r}", f"use the keys {', '.join(WHEEL_KEYS)} (docs/wheels.md)"
            )
        for key in ("name", "axis", "inertia"):
            if key not in table:
                raise ModelError(f"{path}.{key}", "is missing", f"give the {WHEEL_KEYS[key]}")
        out.append(reaction_wheel(path=path, **dict(table)))
    return tuple(out)


def check_wheels(wheels: Sequence[ReactionWheel], spacecraft_inertia: np.ndarray, joint_names: Sequence[str] = ()) -> None:
    """Refuse duplicate wheel names and wheels whose spin inertia the spacecraft body cannot hold: the spacecraft's
    inertia less ``Σ Js a aᵀ`` (what spins with the spacecraft when the wheels are free) must be positive definite."""
    seen: set[str] = set()
    for i, wheel in enumerate(wheels):
        if wheel.name in seen or wheel.name in joint_names:
            raise ModelError(f"wheels[{i}].name", f"duplicate name {wheel.name!r}", "give every wheel a name no joint or wheel has")
        seen.add(wheel.name)
    if wheels:
        rest = spacecraft_inertia - sum(w.inertia * np.outer(w.axis, w.axis) for w in wheels)
        smallest = float(np.linalg.eigvalsh(0.5 * (rest + rest.T))[0])
        if not smallest > 1e-12 * float(np.max(np.abs(spacecraft_inertia))):
            raise ModelError(
                "wheels",
                f"the wheels' spin inertias (Σ Js a aᵀ) are not smaller than the spacecraft body's inertia about their axes "
                f"(smallest moment left: {smallest:.6g} kg m^2)",
                "the spacecraft body's inertia must include its wheels (locked): check each wheel's inertia (Js, kg m^2) "
                "and the spacecraft's (docs/wheels.md)",
            )


def check_same_wheels(first: Model, other: Model, i: int) -> None:
    """Refuse ``other``, model[i] of a sequence of per-trajectory models, when its reaction wheels are not those of
    ``first`` (model[0]) in number and spin axes: per-trajectory models may differ in their wheels' inertia, limits and
    friction only (one rollout integrates one structure)."""
    mine, theirs = wheel_arrays(first)[0], wheel_arrays(other)[0]
    if mine.shape == theirs.shape and np.array_equal(mine, theirs):
        return
    if mine.shape != theirs.shape:
        problem = f"{other.name!r} has {other.n_wheels} reaction wheels, model[0] ({first.name!r}) {first.n_wheels}"
    else:
        problem = f"the reaction wheels of {other.name!r} spin about other axes than model[0]'s ({first.name!r}: {mine.tolist()})"
    raise ModelError(
        f"model[{i}].wheels",
        problem,
        "per-trajectory models may differ in their wheels' inertia, max_torque, max_speed, viscous and coulomb, not in their "
        "number or axes: run each set of wheels as its own rollout",
    )


def wheel_arrays(model: Model) -> tuple[np.ndarray, np.ndarray]:
    """(spin axes (W, 3), spacecraft frame; rotor inertias Js (W,), kg m²) of the model's wheels."""
    return np.array([w.axis for w in model.wheels]).reshape(-1, 3), np.array([w.inertia for w in model.wheels])


def wheel_limits(model: Model) -> tuple[np.ndarray, np.ndarray]:
    """(max_torque (W,), max_speed (W,)) of the model's wheels (inf where none)."""
    return (np.array([w.max_torque for w in model.wheels]), np.array([w.max_speed for w in model.wheels]))


def wheel_joint_model(model: Model) -> Model:
    """The model the engine integrates when ``model`` has wheels: each wheel a body on a revolute joint about its axis,
    child of the spacecraft, appended after the robot's bodies (so q = [robot joints (N), wheel angles (W)]): a rotor
    of inertia ``Js a aᵀ`` with no mass at the spacecraft's CM, joint damping = ``viscous``, friction = ``coulomb``;
    the spacecraft body keeps ``I_locked - Σ Js a aᵀ``. Kinematics and momentum equal the locked model's with the
    wheels' relative spin added. The model itself when it has none; made once per model."""
    if not model.wheels:
        return model
    found = model.__dict__.get("_wheel_joint_model")
    if found is not None:
        return found
    w = len(model.wheels)
    axes, js = wheel_arrays(model)
    spin = js[:, None, None] * axes[:, :, None] * axes[:, None, :]
    inertia = np.concatenate([model.inertia, spin])
    inertia[0] = model.inertia[0] - spin.sum(axis=0)
    origin = np.concatenate([model.joint_origin, np.broadcast_to(model.com[0], (w, 3))])
    found = dataclasses.replace(
        model,
        name=f"{model.name} (wheels as joints)",
        body_names=(*model.body_names, *(f"wheel:{wh.name}" for wh in model.wheels)),
        parent=np.concatenate([model.parent, np.zeros(w, dtype=int)]),
        joint_names=(*model.joint_names, *(wh.name for wh in model.wheels)),
        joint_origin=origin,
        joint_rotation=np.concatenate([model.joint_rotation, np.broadcast_to(np.eye(3), (w, 3, 3))]),
        joint_axis=np.concatenate([model.joint_axis, axes]),
        joint_lower=np.concatenate([model.joint_lower, np.full(w, -np.inf)]),
        joint_upper=np.concatenate([model.joint_upper, np.full(w, np.inf)]),
        mass=np.concatenate([model.mass, np.zeros(w)]),
        com=np.concatenate([model.com, np.zeros((w, 3))]),
        inertia=inertia,
        joint_type=(*model.joint_type, *("revolute",) * w),
        joint_armature=np.concatenate([model.joint_armature, np.zeros(w)]),
        joint_damping=np.concatenate([model.joint_damping, [wh.viscous for wh in model.wheels]]),
        joint_friction=np.concatenate([model.joint_friction, [wh.coulomb for wh in model.wheels]]),
        joint_stiffness=np.concatenate([model.joint_stiffness, np.zeros(w)]),
        joint_springref=np.concatenate([model.joint_springref, np.zeros(w)]),
        wheels=(),
    )
    object.__setattr__(model, "_wheel_joint_model", found)
    return found
