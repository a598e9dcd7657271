"""A free rigid body to be grasped: :class:`Target` (``ff.capture.Target``), one or a batch of them.

Frames and units as in :mod:`freefloat.core.conventions`: the target's own frame has its origin at the
target's CM; ``attitude`` is the rotation from that frame to the inertial frame I (quaternion [x, y, z, w],
scalar last, or a scipy ``Rotation``); positions and velocities are in the inertial frame, SI units.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from .conventions import as_quaternion
from .errors import ModelError, ShapeError
from .model import MAX_INERTIA, MAX_MASS, check_inertia, check_mass, inertia_matrix
from .numbers import MAX_POSITION, MAX_RATE, MAX_SPEED, check_largest, real_array

__all__ = ["Target"]

_INERTIA_FIX = (
    "give the inertia about the target's CM in its own frame: a 3x3 matrix (or (..., 3, 3) for a batch), [Ixx, Iyy, Izz] or one number"
)
#: The motion fields: (what, unit, bound, why the bound, fix).
_MOTION = {
    "position": ("position of the target's CM, inertial frame", "m", MAX_POSITION, "farther than any space robot goes"),
    "velocity": ("velocity of the target's CM, inertial frame", "m/s", MAX_SPEED, "a third of the speed of light"),
    "angular_velocity": ("angular velocity of the target, inertial frame", "rad/s", MAX_RATE, "faster than any body in orbit spins"),
}


def _numbers(value: Any, name: str, fix: str, where: str | None = None) -> np.ndarray:
    field = where or f"Target.{name}"
    try:
        return real_array(value, field)
    except TypeError:
        raise ModelError(field, f"cannot read {value!r:.80} as real numbers", fix) from None


def _masses(value: Any) -> np.ndarray:
    """Masses (...) in kg, each positive, finite and at most MAX_MASS; else a ModelError naming the first bad one."""
    fix = "give the target's mass in kg (> 0), or an array of masses for a batch"
    mass = _numbers(value, "mass", fix)
    bad = ~(np.isfinite(mass) & (mass > 0.0) & (mass <= MAX_MASS))
    if np.any(bad):
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        check_mass(float(mass[index]), f"Target.mass{list(index) if index else ''}", fix)
    return mass


def _inertias(value: Any) -> np.ndarray:
    """Inertias (..., 3, 3) about the CM; one target may give a scalar or [Ixx, Iyy, Izz] (``inertia_matrix``)."""
    arr = _numbers(value, "inertia", _INERTIA_FIX)
    if arr.ndim < 3:
        return inertia_matrix(arr, "Target.inertia")
    if arr.shape[-2:] != (3, 3):
        raise ModelError("Target.inertia", f"expected shape (..., 3, 3) for a batch, got {arr.shape}", _INERTIA_FIX)
    # the checks of core.model.check_inertia, vectorised: any matrix they may refuse is then checked by it, for its message
    flat = arr.reshape(-1, 3, 3)
    finite = np.all(np.isfinite(flat), axis=(1, 2))
    suspect = ~finite
    ok = flat[finite]
    scale = np.maximum(np.max(np.abs(ok), axis=(1, 2)), 1e-300)
    moments = np.linalg.eigvalsh(0.5 * (ok + np.swapaxes(ok, 1, 2)))
    near = (
        (scale > MAX_INERTIA)
        | (np.max(np.abs(ok - np.swapaxes(ok, 1, 2)), axis=(1, 2)) > 1e-10 * scale)
        | (moments[:, 0] <= 1e-8 * scale)
        | (moments[:, 2] >= (moments[:, 0] + moments[:, 1]) * (1.0 - 1e-8))
    )
    suspect[np.flatnonzero(finite)[near]] = True
    for i in np.flatnonzero(suspect):
        check_inertia(flat[i], f"Target.inertia{[int(j) for j in np.unravel_index(int(i), arr.shape[:-2])]}")
    return arr


def motion_field(value: Any, name: str, where: str | None = None) -> np.ndarray:
    """A motion field of a target (``name``: "position", "velocity" or "angular_velocity"), (..., 3) floats, finite and
    within its bound; errors name ``where`` (default ``Target.<name>``): ``ModelError``, ``ShapeError``, ``ValueError``."""
    what, unit, bound, why = _MOTION[name]
    field = where or f"Target.{name}"
    fix = f"give the {what} in {unit}, shape (3,) (or (..., 3) for a batch), finite"
    arr = _numbers(value, name, fix, where)
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise ShapeError(f"{field}: expected shape (..., 3) ({what}), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ModelError(field, "has NaN or infinite entries", fix)
    check_largest(arr, field, bound, unit, why, f"check the units ({unit})")
    return arr


def _attitude(value: Any) -> np.ndarray:
    if value is None:
        return np.array([0.0, 0.0, 0.0, 1.0])
    if isinstance(value, Rotation):
        return as_quaternion(value)
    try:
        return as_quaternion(_numbers(value, "attitude", "give a unit quaternion [x, y, z, w] (scalar last) or a scipy Rotation"))
    except ModelError:
        raise
    except (ShapeError, ValueError) as exc:  # as_quaternion's messages start with "attitude: "
        raise type(exc)(f"Target.{exc}") from None


@dataclass(frozen=True, eq=False)
class Target:
    """A free rigid body before it is grasped (the moving target of ``ff.capture.impact``), or a batch of them.

    Parameters (SI units; every field may carry leading batch axes, which broadcast to :attr:`shape`)
        mass              (...) kg, positive
        inertia           (..., 3, 3) kg m^2 about the target's CM, in the target's own frame (one target may
                          give [Ixx, Iyy, Izz] or one isotropic moment); positive definite and each principal
                          moment at most the sum of the other two (the checks of ``Model`` bodies)
        position          (..., 3) m, the target's CM, inertial frame
        attitude          (..., 4) the rotation from the target's frame to the inertial frame: a unit
                          quaternion [x, y, z, w] (scalar last) or a scipy ``Rotation``; None = identity
        velocity          (..., 3) m/s, velocity of the CM, inertial frame (default zero)
        angular_velocity  (..., 3) rad/s, inertial frame (default zero)

    After construction every field is a float array (``attitude`` a quaternion), broadcast to :attr:`shape`.
    A non-physical value raises :class:`~freefloat.ModelError` (a ``ValueError``) naming the field
    (``Target.inertia``, ``Target.mass[3]`` in a batch); a wrong shape raises ``ShapeError``.

    Examples
    --------
    >>> import freefloat as ff
    >>> t = ff.capture.Target(mass=50.0, inertia=[2.0, 3.0, 4.0], position=[1.0, 0.0, 0.0], velocity=[0.0, 0.1, 0.0])
    >>> t.momentum.tolist()
    [0.0, 5.0, 0.0, 0.0, 0.0, 0.0]
    """

    mass: Any
    inertia: Any
    position: Any
    attitude: Any = None
    velocity: Any = (0.0, 0.0, 0.0)
    angular_velocity: Any = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        fields = {
            "mass": _masses(self.mass),
            "inertia": _inertias(self.inertia),
            "position": motion_field(self.position, "position"),
            "attitude": _attitude(self.attitude),
            "velocity": motion_field(self.velocity, "velocity"),
            "angular_velocity": motion_field(self.angular_velocity, "angular_velocity"),
        }
        core = {"mass": 0, "inertia": 2, "position": 1, "attitude": 1, "velocity": 1, "angular_velocity": 1}
        shapes = {name: arr.shape[: arr.ndim - core[name]] for name, arr in fields.items()}
        try:
            shape = np.broadcast_shapes(*shapes.values())
        except ValueError:
            given = ", ".join(f"{name} {s}" for name, s in shapes.items())
            raise ShapeError(f"Target: the fields' leading (batch) shapes do not broadcast: {given}") from None
        for name, arr in fields.items():
            out = np.array(np.broadcast_to(arr, shape + arr.shape[arr.ndim - core[name] :]), dtype=float)
            out.setflags(write=False)
            object.__setattr__(self, name, out)

    @property
    def shape(self) -> tuple[int, ...]:
        """The batch shape: () for one target."""
        return tuple(np.shape(self.mass))

    def __len__(self) -> int:
        if not self.shape:
            raise TypeError("a single Target has no length (Target.shape is ())")
        return self.shape[0]

    def __getitem__(self, index: Any) -> Target:
        """The targets at ``index`` of the batch (numpy indexing of the leading axes)."""
        if not self.shape:
            raise TypeError("a single Target cannot be indexed (Target.shape is ())")
        target = object.__new__(Target)
        for name in ("mass", "inertia", "position", "attitude", "velocity", "angular_velocity"):
            object.__setattr__(target, name, getattr(self, name)[index])
        return target

    @property
    def rotation(self) -> Rotation:
        """The attitude (target frame -> inertial frame) as a scipy ``Rotation``."""
        return Rotation.from_quat(self.attitude)

    @property
    def rotation_matrix(self) -> np.ndarray:
        """The attitude as rotation matrices (..., 3, 3): ``x_I = R @ x_target``."""
        flat = Rotation.from_quat(self.attitude.reshape(-1, 4)).as_matrix()
        return flat.reshape((*self.shape, 3, 3))

    @property
    def inertia_inertial(self) -> np.ndarray:
        """The inertia about the CM in the inertial frame's axes, R I Rᵀ, (..., 3, 3) kg m^2."""
        rot = self.rotation_matrix
        return rot @ self.inertia @ np.swapaxes(rot, -1, -2)

    @property
    def momentum(self) -> np.ndarray:
        """Spatial momentum (..., 6): [m v (N s); angular momentum about its own CM (N m s)], inertial frame."""
        angular = np.einsum("...ij,...j->...i", self.inertia_inertial, self.angular_velocity)
        return np.concatenate([self.mass[..., None] * self.velocity, angular], axis=-1)

    @property
    def kinetic_energy(self) -> np.ndarray:
        """Kinetic energy (...) J: ½ m |v|² + ½ ωᵀ I ω."""
        return 0.5 * np.sum(self.momentum * np.concatenate([self.velocity, self.angular_velocity], axis=-1), axis=-1)
