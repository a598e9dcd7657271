"""The simulation state and the actuation a controller returns.

State (all SI, frames as in :mod:`freeflyer.conventions`):
    q         (N,)  joint angles
    qdot      (N,)  joint rates
    omega     (3,)  spacecraft angular velocity, spacecraft frame (⁰ω0)
    attitude  (4,)  spacecraft attitude quaternion [x, y, z, w], spacecraft -> inertial
    r_cm      (3,)  system CM position, inertial frame
    v_cm      (3,)  system CM velocity, inertial frame

Omitted fields are zero (attitude: identity). Every field may carry leading
batch axes (for batched rollouts); all fields then share them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .conventions import as_quaternion
from .errors import ShapeError
from .model import Model

__all__ = ["Actuation", "State", "pack_state", "state_size", "unpack_state"]


def _finite(name: str, value: Any, size: int, what: str) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0 or arr.shape[-1] != size:
        raise ShapeError(f"{name}: expected shape (..., {size}) ({what}), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: has NaN or infinite entries; give finite values")
    return arr


@dataclass(frozen=True)
class State:
    """A state of the space robot; ``State(q=...)`` leaves the rest at rest and at identity.

    Call :meth:`resolve` with a model to fill omitted fields and check shapes.
    """

    q: Any = None
    qdot: Any = None
    omega: Any = None
    attitude: Any = None
    r_cm: Any = None
    v_cm: Any = None

    def resolve(self, model: Model) -> State:
        """A copy with every field an array of the right size for ``model`` (errors name the field)."""
        n = model.n_joints
        given = [np.asarray(v) for v in (self.q, self.qdot, self.omega, self.r_cm, self.v_cm) if v is not None]
        batch: tuple[int, ...] = ()
        if given:
            batch = np.broadcast_shapes(*(g.shape[:-1] if g.ndim else () for g in given))

        def get(name: str, size: int, what: str) -> np.ndarray:
            value = getattr(self, name)
            if value is None:
                return np.zeros((*batch, size))
            return np.broadcast_to(_finite(name, value, size, what), (*batch, size)).copy()

        if self.attitude is None:
            quat = np.broadcast_to(np.array([0.0, 0.0, 0.0, 1.0]), (*batch, 4)).copy()
        else:
            quat = np.broadcast_to(as_quaternion(self.attitude), (*batch, 4)).copy()
        return State(
            q=get("q", n, f"one angle per joint: {', '.join(model.joint_names)}"),
            qdot=get("qdot", n, "one rate per joint"),
            omega=get("omega", 3, "spacecraft angular velocity, spacecraft frame"),
            attitude=quat,
            r_cm=get("r_cm", 3, "system CM position, inertial frame"),
            v_cm=get("v_cm", 3, "system CM velocity, inertial frame"),
        )

    @property
    def velocity(self) -> np.ndarray:
        """zdot0 = [v_cm, omega, qdot] (1991 eq. 8)."""
        return np.concatenate([self.v_cm, self.omega, self.qdot], axis=-1)


@dataclass(frozen=True)
class Actuation:
    """What a controller returns: joint torques (N,), and the thruster force and torque at the
    spacecraft CM (3,), both in the spacecraft frame. ``None`` means zero (free-floating)."""

    joint_torque: Any = None
    spacecraft_force: Any = None
    spacecraft_torque: Any = None
    extras: dict[str, Any] = field(default_factory=dict)


def state_size(model: Model) -> int:
    """Length of the flat state vector [r_cm, v_cm, attitude, omega, q, qdot]: 13 + 2N."""
    return 13 + 2 * model.n_joints


def pack_state(state: State) -> np.ndarray:
    """Flat state [r_cm (3), v_cm (3), attitude (4), omega (3), q (N), qdot (N)] of a resolved state."""
    return np.concatenate([state.r_cm, state.v_cm, state.attitude, state.omega, state.q, state.qdot], axis=-1)


def unpack_state(model: Model, x: np.ndarray) -> State:
    """Inverse of :func:`pack_state` (views, no copies)."""
    n = model.n_joints
    return State(
        r_cm=x[..., 0:3],
        v_cm=x[..., 3:6],
        attitude=x[..., 6:10],
        omega=x[..., 10:13],
        q=x[..., 13 : 13 + n],
        qdot=x[..., 13 + n : 13 + 2 * n],
    )
