"""The immutable :class:`Model` of a space robot (:class:`~freefloat.core.builder.ModelBuilder` makes it).

A model is a tree of rigid bodies rooted at the spacecraft (body 0), joined by
revolute or prismatic joints (fixed joints are merged into the parent at build time). It is
validated once, when built, and never changes: ``with_payload`` returns a new
model. Everything that depends only on the mass distribution (outboard mass
fractions, barycenters, barycentric vectors, 1992 eqs. 5-9) is computed at
build time; see :mod:`freefloat.core.barycentric`.
"""

from __future__ import annotations

import dataclasses
import functools
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import barycentric
from .errors import ModelError, UnknownNameError
from .mimic import body_joints
from .numbers import real_array
from .wheels import ReactionWheel, check_wheels, wheels_from

__all__ = [
    "JOINT_TYPES",
    "MAX_INERTIA",
    "MAX_LENGTH",
    "MAX_MASS",
    "Model",
    "accepts_model_names",
    "check_inertia",
    "check_mass",
    "inertia_defect",
    "inertia_matrix",
    "nearest_physical_inertia",
    "register_model_resolver",
    "resolve_model",
]

#: The joint types a model holds after fixed joints are merged: a revolute joint turns its body
#: about the axis by q (rad); a prismatic joint slides it along the axis by q (m).
JOINT_TYPES = ("revolute", "prismatic")

_INERTIA_RTOL = 1e-9

#: The physical bounds a model is checked against (SI). Beyond them a number is a typo or a unit
#: slip (mm for m, g for kg), not a space robot, and the arithmetic loses its meaning (1e300 kg
#: overflows the inertia sums). Bodies: mass in (0, MAX_MASS] kg, 1e9 kg being some 2000 times the
#: International Space Station; positions (joint origins, CMs, end-effector points, payload offsets)
#: within MAX_LENGTH m of their frame's origin, 10 km; principal moments of inertia up to MAX_INERTIA
#: kg m^2, MAX_MASS spread over 1 km.
MAX_MASS = 1e9
MAX_LENGTH = 1e4
MAX_INERTIA = 1e15


def check_mass(value: float, path: str, fix: str) -> float:
    """``value`` (kg) if positive, finite and at most :data:`MAX_MASS`; else a :class:`ModelError`."""
    if not np.isfinite(value) or value <= 0.0:
        raise ModelError(path, f"must be positive and finite, got {value!r}", fix)
    if value > MAX_MASS:
        raise ModelError(path, f"{value:g} kg is above the {MAX_MASS:g} kg freefloat accepts for one body (a unit slip?)", fix)
    return value


def _vector(value: Any, path: str, fix: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(path, f"cannot read {value!r} as three numbers", fix) from None
    if arr.shape != (3,):
        raise ModelError(path, f"expected three numbers [x, y, z], got shape {arr.shape}", fix)
    if not np.all(np.isfinite(arr)):
        raise ModelError(path, "has NaN or infinite entries", fix)
    if np.abs(arr).max() > MAX_LENGTH:
        too_far = f"{np.abs(arr).max():g} m is beyond the {MAX_LENGTH:g} m freefloat accepts for a position (a unit slip?)"
        raise ModelError(path, too_far, fix)
    return arr


def inertia_matrix(value: Any, path: str, *, degenerate_ok: bool = False) -> np.ndarray:
    """Read an inertia given as a 3x3 matrix, three principal moments, or one isotropic moment."""
    fix = "give a 3x3 symmetric matrix, [Ixx, Iyy, Izz], or one number (isotropic), in kg m^2 about the CM"
    try:
        arr = real_array(value, path)  # booleans and text are not moments of inertia
    except TypeError:
        raise ModelError(path, f"cannot read {value!r} as an inertia", fix) from None
    if arr.shape == ():
        arr = np.eye(3) * arr
    elif arr.shape == (3,):
        arr = np.diag(arr)
    elif arr.shape != (3, 3):
        raise ModelError(path, f"expected shape (3, 3), (3,) or a scalar, got {arr.shape}", fix)
    check_inertia(arr, path, degenerate_ok=degenerate_ok)
    return arr


def check_inertia(inertia: np.ndarray, path: str, *, degenerate_ok: bool = False) -> None:
    """Raise :class:`ModelError` unless ``inertia`` is a physical inertia matrix about a CM.

    Physical means finite, symmetric, positive definite (``degenerate_ok``: semi-definite, as a
    point mass), and principal moments that satisfy the triangle inequality ``I1 <= I2 + I3``.
    """
    fix = "use the inertia of a real body about its CM (symmetric, positive definite, each principal moment <= the sum of the other two)"
    if np.all(np.isfinite(inertia)) and np.abs(inertia).max() > MAX_INERTIA:
        raise ModelError(
            path, f"{np.abs(inertia).max():g} kg m^2 is above the {MAX_INERTIA:g} kg m^2 freefloat accepts (a unit slip?)", fix
        )
    defect = inertia_defect(inertia, degenerate_ok=degenerate_ok)
    if defect is not None:
        raise ModelError(path, defect, fix)


def inertia_defect(inertia: np.ndarray, *, degenerate_ok: bool = False) -> str | None:
    """What makes ``inertia`` (3x3, about a CM) non-physical, or None when it is physical.

    Physical: finite, symmetric, principal moments positive (``degenerate_ok``: zero allowed, as a
    point mass or a thin rod) and each at most the sum of the other two (triangle inequality), with
    a relative tolerance of 1e-9 of the largest moment.
    """
    if not np.all(np.isfinite(inertia)):
        return "has NaN or infinite entries"
    scale = max(float(np.max(np.abs(inertia))), 1e-300)
    if np.max(np.abs(inertia - inertia.T)) > 1e-9 * scale:
        return "is not symmetric"
    moments = np.linalg.eigvalsh(0.5 * (inertia + inertia.T))
    floor = -_INERTIA_RTOL * scale if degenerate_ok else 0.0
    if moments[0] < floor or (not degenerate_ok and moments[0] == 0.0):
        return f"is not positive definite (principal moments {moments.tolist()})"
    if moments[2] > (moments[0] + moments[1]) * (1.0 + _INERTIA_RTOL) + (_INERTIA_RTOL * scale if degenerate_ok else 0.0):
        return f"violates the triangle inequality: principal moment {moments[2]:.6g} > {moments[0]:.6g} + {moments[1]:.6g}"
    return None


def nearest_physical_inertia(inertia: np.ndarray) -> np.ndarray:
    """The physical inertia nearest to ``inertia`` in the Frobenius norm.

    The set of physical inertias depends on the principal moments only, so the nearest one keeps
    the principal axes of the symmetric part and moves the moments to the nearest point of the
    cone {I_k >= 0, I_a <= I_b + I_c}: a small quadratic programme (scipy.optimize, SLSQP).
    Asymmetry is removed first (the symmetric part is the nearest symmetric matrix).
    """
    from scipy.optimize import minimize

    sym = 0.5 * (inertia + inertia.T)
    moments, axes = np.linalg.eigh(sym)
    cone = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0], [-1.0, 1, 1], [1, -1.0, 1], [1, 1, -1.0]])
    result = minimize(
        lambda x: float(np.sum((x - moments) ** 2)),
        np.clip(moments, 0.0, None),
        jac=lambda x: 2.0 * (x - moments),
        constraints=[{"type": "ineq", "fun": lambda x: cone @ x, "jac": lambda x: cone}],
        method="SLSQP",
        options={"ftol": 1e-30, "maxiter": 200},
    )
    fixed = np.clip(result.x, 0.0, None)
    # tiny round-off of the QP may leave the triangle inequality violated by ~1e-16: close it exactly
    fixed[np.argmax(fixed)] = min(float(fixed.max()), float(np.sum(fixed) - fixed.max()))
    return (axes * fixed) @ axes.T


#: The per-joint parameters of the joints' own dynamics (rotor inertia, passive torques): name -> what and its unit.
JOINT_PASSIVE = {
    "armature": "rotor inertia reflected to the joint, in kg m^2 (kg for a prismatic joint)",
    "damping": "viscous damping, in N m s/rad (N s/m for a prismatic joint)",
    "friction": "Coulomb friction torque, in N m (N for a prismatic joint)",
    "stiffness": "spring stiffness, in N m/rad (N/m for a prismatic joint)",
    "springref": "joint value at which the spring is relaxed, in rad (m for a prismatic joint)",
}
#: The parameters of :data:`JOINT_PASSIVE` that may be negative (the others are >= 0).
JOINT_SIGNED = frozenset({"springref"})


def _joint_parameter(model: Any, name: str, value: Any, what: str) -> np.ndarray:
    """One value per joint, >= 0 unless signed (:data:`JOINT_SIGNED`); zeros for None; each error naming the joint and
    the fix."""
    n = len(model.joint_names)
    if value is None:
        return np.zeros(n)
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"joint_{name}", f"cannot read {value!r} as numbers", f"give one {what} per joint") from None
    if arr.shape != (n,):
        raise ModelError(f"joint_{name}", f"has shape {arr.shape} for {n} joints", f"give one {what} per joint")
    for j, v in enumerate(arr):
        if not (np.isfinite(v) and (v >= 0.0 or name in JOINT_SIGNED)):
            bound = "finite" if name in JOINT_SIGNED else "finite and >= 0"
            raise ModelError(f"joints[{j}] ({model.joint_names[j]}).{name}", f"is {v}", f"give the {what}, {bound}")
    return arr


def _count(n: int, one: str, many: str | None = None) -> str:
    """'1 joint', '2 joints' (English plurals in messages)."""
    return f"{n} {one if n == 1 else (many or one + 's')}"


def _frozen(arr: Any, dtype: Any = float) -> np.ndarray:
    out = np.array(arr, dtype=dtype, copy=True)
    out.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class Model:
    """A space robot: a tree of rigid bodies rooted at the spacecraft (body 0).

    Body k > 0 is moved by joint k - 1 (``joint_names[k - 1]``; with mimic joints ``body_joint_names[k - 1]``,
    below); bodies are in depth-first order, so each arm's joints are contiguous, as in the 1992
    paper's q = [q⁽¹⁾, ..., q⁽ⁿ⁾]. All arrays are read-only.

    Attributes (body frames unless stated)
        parent            (B,) parent body index, -1 for the spacecraft
        joint_origin      (B, 3) joint position in the parent frame (row 0 unused)
        joint_rotation    (B, 3, 3) joint frame relative to the parent frame
        joint_axis        (B, 3) unit joint axis in the joint (= child) frame
        joint_type        (N,) "revolute" (q in rad) or "prismatic" (q in m, the body slides
                          along the axis; its frame origin is joint_origin + q axis)
        joint_lower/upper (N,) joint limits in rad or m (±inf when none)
        joint_armature    (N,) rotor inertia reflected to the joint (kg m² for a revolute joint, kg for a
                          prismatic one): added to the joint's diagonal entry of H+, as MuJoCo's ``armature``
                          and Pinocchio's ``armature`` (zeros when not given)
        joint_damping     (N,) viscous damping: passive torque -damping qdot (N m s/rad, N s/m)
        joint_friction    (N,) Coulomb friction: passive torque of that size against qdot (N m, N), smooth
                          (:mod:`freefloat.simulation.passive`)
        joint_stiffness   (N,) spring stiffness: passive torque -stiffness (q - springref) (N m/rad, N/m; MJCF's
        joint_springref   ``stiffness`` and ``springref``), a conservative torque: zeros when not given
        end_effector_rule "named" (the model file or builder named them) or "leaves" (every leaf)
        corrections       every change made to the given data when loading (see ``ff.load``)
        unmodelled        every element of the file that acts on the dynamics and that freefloat
                          dropped (``freefloat.io.unmodelled``): where, element, effect, items
        mass, com, inertia  per body; inertia about the CM
        end_effector_body, end_effector_point  (E,), (E, 3)
        mimic             the mimic joints (dependent coordinates), one record each: {"joint", "body" (the body it
                          moves), "leader" (the independent joint it follows, chains resolved to their root),
                          "multiplier", "offset", "type", and its own "lower", "upper", "armature", "damping",
                          "friction", "stiffness", "springref"}: q_mimic = multiplier q_leader + offset. A mimic joint has no column of q;
                          its body moves with the leader. Empty for most models (then N = B - 1).
        wheels            the spacecraft's reaction wheels (:class:`~freefloat.core.wheels.ReactionWheel`: spin axis in the
                          spacecraft frame, rotor inertia, torque and speed limits, friction; docs/wheels.md). The
                          spacecraft body's mass and inertia include them, locked; a simulation adds their spin
                          (``State.wheel_speed``). Empty for most models.

    Body joints: with mimic joints, the B - 1 joints that move bodies 1..B-1 are the N independent joints and
    the mimic ones; ``body_joint_names``, ``body_joint_type``, ``body_joint_prismatic`` and the map
    ``body_joint_coordinate`` / ``body_joint_multiplier`` / ``body_joint_offset`` (each (B - 1,): the joint of
    body k is ``[k - 1]``) say which column of q drives each body and how (:meth:`body_joint_values`,
    :attr:`mimic_matrix`). Without mimic joints they are the joints themselves.
    """

    name: str
    body_names: tuple[str, ...]
    parent: np.ndarray
    joint_names: tuple[str, ...]
    joint_origin: np.ndarray
    joint_rotation: np.ndarray
    joint_axis: np.ndarray
    joint_lower: np.ndarray
    joint_upper: np.ndarray
    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray
    end_effector_names: tuple[str, ...]
    end_effector_body: np.ndarray
    end_effector_point: np.ndarray
    source: str = ""
    payloads: tuple[dict[str, Any], ...] = ()
    joint_type: tuple[str, ...] = ()
    end_effector_rule: str = "leaves"
    corrections: tuple[dict[str, Any], ...] = ()
    joint_armature: Any = None
    joint_damping: Any = None
    joint_friction: Any = None
    joint_stiffness: Any = None
    joint_springref: Any = None
    unmodelled: tuple[dict[str, Any], ...] = ()
    mimic: tuple[dict[str, Any], ...] = ()
    wheels: tuple[ReactionWheel, ...] = ()
    # derived at build time
    total_mass: float = field(init=False)
    subtree: np.ndarray = field(init=False, repr=False)
    bary: barycentric.BarycentricVectors = field(init=False, repr=False)
    rotation_basis: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        for name in (
            "joint_origin",
            "joint_rotation",
            "joint_axis",
            "joint_lower",
            "joint_upper",
            "mass",
            "com",
            "inertia",
            "end_effector_point",
        ):
            object.__setattr__(self, name, _frozen(getattr(self, name)))
        for name in ("parent", "end_effector_body"):
            object.__setattr__(self, name, _frozen(getattr(self, name), int))
        if not self.joint_type:
            object.__setattr__(self, "joint_type", ("revolute",) * len(self.joint_names))
        object.__setattr__(self, "joint_type", tuple(str(t) for t in self.joint_type))
        if len(self.joint_type) != len(self.joint_names):
            raise ModelError(
                "joint_type", f"has {len(self.joint_type)} entries for {len(self.joint_names)} joints", "give one type per joint"
            )
        for j, kind in enumerate(self.joint_type):
            if kind not in JOINT_TYPES:
                raise ModelError(
                    f"joints[{j}] ({self.joint_names[j]}).type", f"unknown joint type {kind!r}", f"use one of {', '.join(JOINT_TYPES)}"
                )
        object.__setattr__(self, "_prismatic", _frozen([t == "prismatic" for t in self.joint_type], bool))
        for name, what in JOINT_PASSIVE.items():
            object.__setattr__(self, f"joint_{name}", _frozen(_joint_parameter(self, name, getattr(self, f"joint_{name}"), what)))
        object.__setattr__(self, "mimic", tuple(dict(r) for r in self.mimic))
        object.__setattr__(self, "_body_joints", body_joints(self, JOINT_TYPES, tuple(JOINT_PASSIVE)))
        object.__setattr__(self, "wheels", wheels_from(self.wheels))
        check_wheels(self.wheels, self.inertia[0], self.joint_names)
        if self.mimic:  # the same bodies with every joint independent: the mass tables are the expanded model's
            expanded = self.expanded()
            for name in ("subtree", "total_mass", "bary", "rotation_basis"):
                object.__setattr__(self, name, getattr(expanded, name))
            return
        n = len(self.body_names)
        subtree = np.zeros((n, n), dtype=bool)
        for k in range(n):
            j = k
            while j >= 0:
                subtree[j, k] = True
                j = int(self.parent[j])
        object.__setattr__(self, "subtree", _frozen(subtree, bool))
        object.__setattr__(self, "total_mass", float(np.sum(self.mass)))
        object.__setattr__(self, "bary", barycentric.compute(self))
        # (P, P K, P K^2) per joint: placement P, axis cross matrix K; the joint's
        # rotation relative to its parent is P (1 + sin q K + (1 - cos q) K^2).
        # A prismatic joint does not turn: K = 0, so its rotation is P at every q.
        axis = self.joint_axis[1:] * ~self.prismatic[:, None]
        kx = np.zeros((self.n_joints, 3, 3))
        kx[:, 0, 1], kx[:, 0, 2], kx[:, 1, 2] = -axis[:, 2], axis[:, 1], -axis[:, 0]
        kx -= np.swapaxes(kx, 1, 2)
        place = self.joint_rotation[1:]
        object.__setattr__(self, "rotation_basis", _frozen(np.stack([place, place @ kx, place @ kx @ kx])))

    # ----------------------------------------------------------------- sizes
    @property
    def n_bodies(self) -> int:
        """Number of bodies B after fixed joints are merged (spacecraft included)."""
        return len(self.body_names)

    @property
    def n_joints(self) -> int:
        """Number of joint coordinates N: the independent joints (= B - 1 without mimic joints)."""
        return len(self.joint_names)

    @property
    def n_wheels(self) -> int:
        """Number of reaction wheels W (``wheels``)."""
        return len(self.wheels)

    @property
    def has_mimic(self) -> bool:
        """True when the model has mimic joints (dependent coordinates: N < B - 1)."""
        return bool(self.mimic)

    @property
    def body_joint_names(self) -> tuple[str, ...]:
        """(B - 1,) the joint of each body 1..B-1: the independent joints and the mimic joints, in body order."""
        return self._body_joints["names"]  # type: ignore[attr-defined]  # made once in __post_init__

    @property
    def body_joint_type(self) -> tuple[str, ...]:
        """(B - 1,) the type of the joint of each body ("revolute" or "prismatic")."""
        return self._body_joints["type"]  # type: ignore[attr-defined]

    @property
    def body_joint_prismatic(self) -> np.ndarray:
        """(B - 1,) bool: True where the joint of body k (row k - 1) slides."""
        return self._body_joints["prismatic"]  # type: ignore[attr-defined]

    @property
    def body_joint_coordinate(self) -> np.ndarray:
        """(B - 1,) int: the column of q that drives the joint of body k (row k - 1): its own, or its leader's."""
        return self._body_joints["coordinate"]  # type: ignore[attr-defined]

    @property
    def body_joint_multiplier(self) -> np.ndarray:
        """(B - 1,): the joint value of body k is multiplier q[coordinate] + offset (1 for an independent joint)."""
        return self._body_joints["multiplier"]  # type: ignore[attr-defined]

    @property
    def body_joint_offset(self) -> np.ndarray:
        """(B - 1,): the offset of the mimic law (0 for an independent joint), rad or m."""
        return self._body_joints["offset"]  # type: ignore[attr-defined]

    @property
    def mimic_matrix(self) -> np.ndarray:
        """(B - 1, N): the rates of the body joints from the independent ones, qdot_body = mimic_matrix qdot (read-only)."""
        return self._body_joints["matrix"]  # type: ignore[attr-defined]

    def body_joint_values(self, q: Any) -> np.ndarray:
        """The values (..., B - 1) of the joints of bodies 1..B-1 at q (..., N): multiplier q[coordinate] + offset."""
        arr = np.asarray(q, dtype=float)
        if not self.mimic:
            return arr
        return arr[..., self.body_joint_coordinate] * self.body_joint_multiplier + self.body_joint_offset

    def expanded(self) -> Model:
        """This model with every joint independent: the mimic joints become columns of q (the same model without
        mimic joints). The closed forms (``method="barycentric"``) compute on it and contract with
        :attr:`mimic_matrix`; made once per model."""
        if not self.mimic:
            return self
        found = self.__dict__.get("_expanded")
        if found is None:
            bj = self._body_joints  # type: ignore[attr-defined]
            found = dataclasses.replace(
                self,
                joint_names=bj["names"],
                joint_type=bj["type"],
                joint_lower=bj["lower"],
                joint_upper=bj["upper"],
                joint_armature=bj["armature"],
                joint_damping=bj["damping"],
                joint_friction=bj["friction"],
                joint_stiffness=bj["stiffness"],
                joint_springref=bj["springref"],
                mimic=(),
            )
            object.__setattr__(self, "_expanded", found)
        return found

    @property
    def n_end_effectors(self) -> int:
        """Number of end effectors E."""
        return len(self.end_effector_names)

    @property
    def prismatic(self) -> np.ndarray:
        """(N,) bool, read-only: True where joint j is prismatic (q_j in m), False where it is revolute (rad)."""
        return self._prismatic  # type: ignore[attr-defined]  # made once in __post_init__

    @property
    def has_prismatic(self) -> bool:
        """True when any joint is prismatic."""
        return "prismatic" in self.joint_type

    @property
    def is_planar(self) -> bool:
        """True when the model moves in the spacecraft x-y plane (see :mod:`freefloat.conventions`)."""
        return barycentric.is_planar(self.expanded())  # every body's joint, mimic joints included

    # ----------------------------------------------------------------- lookup
    def body_index(self, name: str | int) -> int:
        """Index of a body in ``body_names`` (0 = spacecraft), by name or index; unknown names raise with close matches."""
        return _lookup("body", name, self.body_names)

    def joint_index(self, name: str | int) -> int:
        """Index of a joint in ``joint_names`` (the column of q), by name or index; unknown names raise with close matches."""
        for record in self.mimic:
            if name == record["joint"]:
                err = UnknownNameError("joint", name, self.joint_names)
                err.message = f"{name!r} is a mimic joint (it follows {record['leader']!r}): it has no column of q; use the leader"
                raise err
        return _lookup("joint", name, self.joint_names)

    def end_effector_index(self, name: str | int) -> int:
        """Index of an end effector in ``end_effector_names``, by name or index; unknown names raise with close matches."""
        return _lookup("end effector", name, self.end_effector_names)

    # ----------------------------------------------------------------- payload
    def with_payload(
        self,
        end_effector: str | int = 0,
        mass: float = 0.0,
        inertia: Any = 0.0,
        offset: Any = (0.0, 0.0, 0.0),
        name: str = "payload",
    ) -> Model:
        """Return a NEW model with a payload rigidly grasped by an end effector.

        The payload (``mass`` kg, ``inertia`` about its own CM: a scalar means an
        isotropic inertia whose Izz is that value, the planar papers' I_p; or
        [Ixx, Iyy, Izz]; or 3x3 in the grasping body's axes) is merged into the
        grasping link (1992 §IV: "the payload becomes part of the last link").
        Its CM is at the end-effector point plus ``offset`` (grasping body
        frame; default zero: grasped at its CM, as in 1992 §V). The end-effector
        point itself does not move.
        """
        e = self.end_effector_index(end_effector)
        path = f"with_payload(end_effector={self.end_effector_names[e]!r})"
        try:
            if isinstance(mass, (bool, np.bool_, str, bytes)):
                raise TypeError
            m_p = float(mass)
        except (TypeError, ValueError):
            raise ModelError(f"{path}.mass", f"cannot read {mass!r} as a number", "give the payload mass in kg") from None
        check_mass(m_p, f"{path}.mass", "give the payload mass in kg (> 0)")
        i_p = inertia_matrix(inertia, f"{path}.inertia")
        k = int(self.end_effector_body[e])
        c_p = self.end_effector_point[e] + _vector(
            offset, f"{path}.offset", "give the payload CM offset [x, y, z] from the end effector, body frame"
        )
        m_k, c_k = self.mass[k], self.com[k]
        m_new = m_k + m_p
        c_new = (m_k * c_k + m_p * c_p) / m_new

        def shifted(inertia_c: np.ndarray, m: float, c: np.ndarray) -> np.ndarray:
            d = c - c_new
            return inertia_c + m * (d @ d * np.eye(3) - np.outer(d, d))

        mass_new = self.mass.copy()
        com_new = self.com.copy()
        inertia_new = self.inertia.copy()
        mass_new[k] = m_new
        com_new[k] = c_new
        inertia_new[k] = shifted(self.inertia[k], m_k, c_k) + shifted(i_p, m_p, c_p)
        record = {
            "name": name,
            "end_effector": self.end_effector_names[e],
            "mass": m_p,
            "inertia": i_p.tolist(),
            "cm": c_p.tolist(),
            "body": self.body_names[k],
        }
        return dataclasses.replace(
            self, name=f"{self.name}+{name}", mass=mass_new, com=com_new, inertia=inertia_new, payloads=(*self.payloads, record)
        )

    @property
    def has_springs(self) -> bool:
        """True when a joint has a spring (``joint_stiffness`` > 0): a conservative passive torque -k (q - springref)."""
        return bool(np.any(self.joint_stiffness)) or any(r.get("stiffness", 0.0) for r in self.mimic)

    @property
    def has_passive(self) -> bool:
        """True when a joint has viscous damping or Coulomb friction (passive joint torques)."""
        return bool(np.any(self.joint_damping) or np.any(self.joint_friction)) or any(
            r.get("damping", 0.0) or r.get("friction", 0.0) for r in self.mimic
        )

    def without_passive(self) -> Model:
        """This model without its joints' damping and friction (the same model when it has none; rotor inertia stays:
        it is inertia, not a passive torque). Made once per model."""
        if not self.has_passive:
            return self
        found = self.__dict__.get("_without_passive")
        if found is None:
            quiet = tuple({**r, "damping": 0.0, "friction": 0.0} for r in self.mimic)
            found = dataclasses.replace(self, joint_damping=None, joint_friction=None, mimic=quiet)
            object.__setattr__(self, "_without_passive", found)
        return found

    def __repr__(self) -> str:
        return (
            f"Model({self.name!r}: {_count(self.n_bodies, 'body', 'bodies')}, {_count(self.n_joints, 'joint')}"
            f"{f' (+{len(self.mimic)} mimic)' if self.mimic else ''}, "
            f"{_count(self.n_wheels, 'wheel') + ', ' if self.wheels else ''}"
            f"{_count(self.n_end_effectors, 'end effector')}, mass {self.total_mass:.6g} kg)"
        )


def _lookup(kind: str, key: str | int, names: Sequence[str]) -> int:
    if isinstance(key, (int, np.integer)) and not isinstance(key, bool):
        if 0 <= int(key) < len(names):
            return int(key)
        raise UnknownNameError(kind, key, [f"{i}={n}" for i, n in enumerate(names)])
    if key in names:
        return list(names).index(str(key))
    raise UnknownNameError(kind, key, names)


# --------------------------------------------------------------------- model names at the public boundary
_RESOLVER: list[Callable[[str], Model]] = []


def register_model_resolver(resolver: Callable[[str], Model]) -> None:
    """Set the function that turns a model name or file path into a Model (``freefloat.models`` registers
    :func:`~freefloat.models.load_model`; the core cannot import it, being below it)."""
    _RESOLVER[:] = [resolver]


def resolve_model(model: Any, argument: str = "model") -> Model:
    """``model`` itself if it is a :class:`Model`; a built-in model name or a model file path, loaded; else a TypeError."""
    if isinstance(model, Model):
        return model
    if isinstance(model, (str, os.PathLike)) and _RESOLVER:
        return _RESOLVER[0](os.fspath(model))
    raise TypeError(
        f"{argument}: expected a freefloat.Model, a built-in model name (e.g. 'papadopoulos1992') or a model file path, "
        f"got {type(model).__name__} {str(model)[:60]!r}"
    )


def accepts_model_names(func: Callable[..., Any]) -> Callable[..., Any]:
    """``func(model, ...)`` that also takes a model name or file path for ``model`` (:func:`resolve_model`)."""

    many = getattr(func, "takes_model_sequences", False)  # a sequence of Models (one per trajectory) passes as it is

    def resolve(model: Any) -> Any:
        if many and isinstance(model, (list, tuple)) and all(isinstance(m, Model) for m in model):
            return model
        return resolve_model(model)

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        if args:
            args = (resolve(args[0]), *args[1:])
        elif "model" in kwargs:
            kwargs["model"] = resolve(kwargs["model"])
        return func(*args, **kwargs)

    return wrapper
