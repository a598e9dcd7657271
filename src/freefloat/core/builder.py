"""The :class:`ModelBuilder` that makes a :class:`~freefloat.Model`, and the user's body and joint descriptions.

The builder validates the tree once (names, parents, physical inertias, joint
axes), merges fixed joints into their parents and returns the frozen
:class:`~freefloat.core.model.Model`. File readers (:mod:`freefloat.io.model_files`)
and the built-in models (:mod:`freefloat.models`) go through it too.
"""

from __future__ import annotations

import difflib
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from .errors import ModelError
from .mimic import leader_limits, resolve_mimics
from .model import JOINT_PASSIVE, JOINT_SIGNED, Model, _vector, check_inertia, check_mass, inertia_matrix
from .wheels import ReactionWheel, reaction_wheel

__all__ = ["BodySpec", "EndEffectorSpec", "JointSpec", "ModelBuilder"]


def _rotation_matrix(rotation: Any, path: str) -> np.ndarray:
    if rotation is None:
        return np.eye(3)
    if isinstance(rotation, Rotation):
        return np.asarray(rotation.as_matrix())
    arr = np.asarray(rotation, dtype=float)
    if arr.shape != (3, 3):
        raise ModelError(
            path, f"expected a 3x3 rotation matrix, got shape {arr.shape}", "give a proper rotation (or rpy = [r, p, y] in a file)"
        )
    if not np.all(np.isfinite(arr)):
        raise ModelError(path, "has NaN or infinite entries", "give a proper rotation (or rpy = [r, p, y] in a file)")
    if np.max(np.abs(arr @ arr.T - np.eye(3))) > 1e-8 or np.linalg.det(arr) < 0:
        raise ModelError(path, "is not a proper rotation matrix", "give an orthonormal matrix with determinant +1")
    return arr


@dataclass(frozen=True)
class BodySpec:
    """A rigid body as described by the user (before fixed joints are merged).

    ``com`` is the CM in the body frame; ``inertia`` is about the CM, in body
    frame axes; ``end_effector`` is the tip point (body frame) used when the
    body is a leaf, default the body frame origin.
    """

    name: str
    mass: float
    inertia: np.ndarray
    com: np.ndarray
    end_effector: np.ndarray | None = None
    end_effector_name: str | None = None


@dataclass(frozen=True)
class JointSpec:
    """A joint as described by the user: ``origin`` and ``rotation`` place the
    joint frame in the parent frame; ``axis`` is a unit vector in the joint frame."""

    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray
    rotation: np.ndarray
    axis: np.ndarray
    lower: float = -np.inf
    upper: float = np.inf
    armature: float = 0.0
    damping: float = 0.0
    friction: float = 0.0
    stiffness: float = 0.0
    springref: float = 0.0


@dataclass(frozen=True)
class EndEffectorSpec:
    """An end effector named by the user: a point (``point``, frame of ``body``) of a body or frame."""

    name: str
    body: str
    point: np.ndarray


class ModelBuilder:
    """Build a :class:`Model` in Python.

    >>> import freefloat as ff
    >>> b = ff.ModelBuilder("demo")
    >>> b.add_body("bus", mass=100.0, inertia=10.0)
    >>> b.add_body("link", mass=5.0, inertia=[0.01, 0.4, 0.4], com=[0.5, 0, 0], end_effector=[1, 0, 0])
    >>> b.add_joint("q1", parent="bus", child="link", origin=[0.5, 0, 0], axis=[0, 0, 1])
    >>> model = b.build()
    >>> model.joint_names
    ('q1',)
    """

    def __init__(self, name: str = "model") -> None:
        self.name = name
        self._bodies: list[BodySpec] = []
        self._joints: list[JointSpec] = []
        self._end_effectors: list[EndEffectorSpec] = []
        self._mimics: list[tuple[str, str, float, float]] = []
        self._wheels: list[ReactionWheel] = []

    def add_body(
        self,
        name: str,
        *,
        mass: float,
        inertia: Any,
        com: Any = (0.0, 0.0, 0.0),
        end_effector: Any = None,
        end_effector_name: str | None = None,
        frame: bool = False,
        degenerate_ok: bool = False,
    ) -> ModelBuilder:
        """Add a body. ``inertia`` is about the CM: 3x3, [Ixx, Iyy, Izz] or a scalar.

        ``frame=True`` allows a massless frame (mass 0, as a URDF link without
        ``<inertial>``); it must be attached by a fixed joint to a body with mass.
        ``degenerate_ok=True`` accepts a zero or semi-definite inertia (a point mass, a thin rod,
        as small links in real files have): the model is then checked as a whole (every merged
        body, and H+ positive definite when loaded from a file).
        """
        path = f"bodies[{len(self._bodies)}]"
        if not isinstance(name, str) or not name:
            raise ModelError(f"{path}.name", f"expected a non-empty string, got {name!r}", "name every body")
        path = f"bodies[{len(self._bodies)}] ({name})"
        if any(b.name == name for b in self._bodies):
            raise ModelError(f"{path}.name", f"duplicate body name {name!r}", "give every body a unique name")
        try:
            mass_value = float(mass)
        except (TypeError, ValueError):
            raise ModelError(f"{path}.mass", f"cannot read {mass!r} as a number", "give the mass in kg") from None
        massless = frame and mass_value == 0.0
        if not massless:
            check_mass(mass_value, f"{path}.mass", "give the body's mass in kg (> 0)")
        spec = BodySpec(
            name=name,
            mass=mass_value,
            inertia=np.zeros((3, 3)) if massless else inertia_matrix(inertia, f"{path}.inertia", degenerate_ok=degenerate_ok),
            com=_vector(com, f"{path}.com", "give the CM [x, y, z] in the body frame, in m"),
            end_effector=None
            if end_effector is None
            else _vector(end_effector, f"{path}.end_effector", "give the tip point [x, y, z] in the body frame, in m"),
            end_effector_name=end_effector_name,
        )
        self._bodies.append(spec)
        return self

    def add_joint(
        self,
        name: str,
        *,
        parent: str,
        child: str,
        origin: Any = (0.0, 0.0, 0.0),
        rotation: Any = None,
        rpy: Any = None,
        axis: Any = (0.0, 0.0, 1.0),
        type: str = "revolute",
        limits: Sequence[float] | None = None,
        armature: float = 0.0,
        damping: float = 0.0,
        friction: float = 0.0,
        stiffness: float = 0.0,
        springref: float = 0.0,
    ) -> ModelBuilder:
        """Add a joint from ``parent`` to ``child``.

        ``origin`` (m) and ``rotation`` (3x3) or ``rpy`` (fixed-axis roll, pitch,
        yaw in rad, as URDF) place the joint frame in the parent frame; the child
        frame equals the joint frame at zero angle. ``axis`` is in the joint
        frame and is normalised. ``type`` is ``revolute``, ``continuous`` (a revolute
        joint without limits), ``prismatic`` (the child slides along the axis; q in m) or
        ``fixed``; ``limits`` = (lower, upper) in rad (m for a prismatic joint).
        The joint's own dynamics (``Model.joint_armature`` / ``joint_damping`` / ``joint_friction``): ``armature``
        the rotor inertia reflected to the joint (kg m², kg when prismatic: with a gear ratio n and a rotor
        inertia I_r about its axis, n² I_r), ``damping`` viscous (N m s/rad, N s/m), ``friction`` Coulomb (N m, N),
        ``stiffness`` a spring (N m/rad, N/m) relaxed at ``springref`` (rad, m): the torque -stiffness (q - springref).
        """
        index = len(self._joints)
        path = f"joints[{index}] ({name})"
        if not isinstance(name, str) or not name:
            raise ModelError(f"joints[{index}].name", f"expected a non-empty string, got {name!r}", "name every joint")
        if any(j.name == name for j in self._joints):
            raise ModelError(f"{path}.name", f"duplicate joint name {name!r}", "give every joint a unique name")
        if type not in ("revolute", "continuous", "prismatic", "fixed"):
            raise ModelError(f"{path}.type", f"unknown joint type {type!r}", "use 'revolute', 'continuous', 'prismatic' or 'fixed'")
        if rotation is not None and rpy is not None:
            raise ModelError(f"{path}.rotation", "both rotation and rpy given", "give one of them")
        if rpy is not None:
            rot = Rotation.from_euler("xyz", _vector(rpy, f"{path}.rpy", "give [roll, pitch, yaw] in rad")).as_matrix()
        else:
            rot = _rotation_matrix(rotation, f"{path}.rotation")
        axis_vec = _vector(axis, f"{path}.axis", "give the joint axis [x, y, z] in the joint frame")
        norm = float(np.linalg.norm(axis_vec))
        if type != "fixed" and norm < 1e-12:
            raise ModelError(f"{path}.axis", "is the zero vector", "give a nonzero axis, e.g. [0, 0, 1]")
        lower, upper = -np.inf, np.inf
        unit = "m" if type == "prismatic" else "rad"
        if limits is not None and type in ("revolute", "prismatic"):
            try:
                lower, upper = (float(v) for v in limits)
            except (TypeError, ValueError):
                raise ModelError(f"{path}.limits", f"cannot read {limits!r} as [lower, upper]", f"give two numbers in {unit}") from None
            if np.isnan(lower) or np.isnan(upper) or not lower < upper:
                raise ModelError(
                    f"{path}.limits", f"lower {lower} must be below upper {upper}", f"give [lower, upper] in {unit} with lower < upper"
                )
        self._joints.append(
            JointSpec(
                name=name,
                type=type,
                parent=parent,
                child=child,
                origin=_vector(origin, f"{path}.origin", "give the joint position [x, y, z] in the parent frame, in m"),
                rotation=rot,
                axis=axis_vec / norm if norm > 0 else axis_vec,
                lower=lower,
                upper=upper,
                **{
                    key: _joint_value(value, f"{path}.{key}", what, signed=key in JOINT_SIGNED)
                    for key, value, what in _passive_values(
                        armature=armature, damping=damping, friction=friction, stiffness=stiffness, springref=springref
                    )
                },
            )
        )
        return self

    def add_mimic(self, joint: str, *, leader: str, multiplier: float = 1.0, offset: float = 0.0) -> ModelBuilder:
        """Make ``joint`` a mimic joint of ``leader`` (URDF ``<mimic>``): q_joint = multiplier q_leader + offset.

        A mimic joint is a dependent coordinate: it has no column of q (nor of qdot, tau, J*, H+); its body
        moves with the leader's value, and everything it does to the dynamics (its body's inertia, its own
        rotor inertia, damping and friction) acts through the leader. A mimic of a mimic follows the root
        leader (the laws composed). Its limits bound the leader through the law (``Model.joint_lower`` /
        ``joint_upper`` of the leader are the intersection). Both joints must be revolute or prismatic.
        """
        path = f"mimic ({joint})"
        if not isinstance(joint, str) or not joint:
            raise ModelError("mimic.joint", f"expected a joint name, got {joint!r}", "name the joint that follows another")
        if any(m[0] == joint for m in self._mimics):
            raise ModelError(f"{path}", f"joint {joint!r} is given two mimic laws", "give each mimic joint one leader")
        if not isinstance(leader, str) or not leader:
            raise ModelError(f"{path}.leader", f"expected a joint name, got {leader!r}", "name the joint it follows")
        law = []
        for key, value in (("multiplier", multiplier), ("offset", offset)):
            if isinstance(value, (bool, np.bool_, str, bytes)):
                raise ModelError(f"{path}.{key}", f"cannot read {value!r} as a number", "give a finite number")
            try:
                number = float(value)
            except (TypeError, ValueError):
                raise ModelError(f"{path}.{key}", f"cannot read {value!r} as a number", "give a finite number") from None
            if not np.isfinite(number):
                raise ModelError(f"{path}.{key}", f"is {number}", "give a finite number")
            law.append(number)
        self._mimics.append((joint, leader, law[0], law[1]))
        return self

    def add_wheel(
        self,
        name: str,
        *,
        axis: Any,
        inertia: float,
        max_torque: float | None = None,
        max_speed: float | None = None,
        viscous: float = 0.0,
        coulomb: float = 0.0,
    ) -> ModelBuilder:
        """Add a reaction wheel to the spacecraft (:mod:`freefloat.core.wheels`, docs/wheels.md; Basilisk's names in
        brackets): ``axis`` the unit spin axis in the spacecraft frame [gsHat_B], ``inertia`` the rotor's inertia
        about it in kg m² [Js], ``max_torque`` N m [u_max] and ``max_speed`` rad/s [Omega_max] (None: no limit),
        ``viscous`` (N m s/rad) and ``coulomb`` (N m) bearing friction. The spacecraft body's mass and inertia
        include the wheels (locked): add them to it.
        """
        wheel = reaction_wheel(
            name,
            axis=axis,
            inertia=inertia,
            max_torque=max_torque,
            max_speed=max_speed,
            viscous=viscous,
            coulomb=coulomb,
            path=f"wheels[{len(self._wheels)}]",
        )
        self._wheels.append(wheel)
        return self

    def add_end_effector(self, name: str, *, body: str, point: Any = (0.0, 0.0, 0.0)) -> ModelBuilder:
        """Name an end effector: ``point`` (m) in the frame of ``body`` (a body or a frame fixed to one).

        Once any end effector is named, only the named ones are end effectors (in the order named);
        leaves not named (a solar array, an antenna, a camera mast) are plain frames. When none is
        named, every leaf body is an end effector (``Model.end_effector_rule`` says which rule).
        """
        path = f"end_effectors[{len(self._end_effectors)}]"
        if not isinstance(name, str) or not name:
            raise ModelError(f"{path}.name", f"expected a non-empty string, got {name!r}", "name every end effector")
        if any(e.name == name for e in self._end_effectors):
            raise ModelError(f"{path}.name", f"duplicate end-effector name {name!r}", "give every end effector a unique name")
        if not isinstance(body, str) or not body:
            raise ModelError(f"{path} ({name}).body", f"expected a body or frame name, got {body!r}", "name the body that holds the tool")
        point_vec = _vector(point, f"{path} ({name}).point", "give the point [x, y, z] in the body frame, in m")
        self._end_effectors.append(EndEffectorSpec(name=name, body=body, point=point_vec))
        return self

    def build(self, *, source: str = "", corrections: Sequence[dict[str, Any]] = ()) -> Model:
        """Validate the tree, merge fixed joints and return the frozen :class:`Model`.

        ``corrections``: what a file reader changed in the given data (``Model.corrections``).
        """
        model = _build(self.name, self._bodies, self._joints, source, self._end_effectors, self._mimics)
        if corrections or self._wheels:
            import dataclasses

            model = dataclasses.replace(model, corrections=tuple(dict(c) for c in corrections), wheels=tuple(self._wheels))
        return model


def _passive_values(**values: Any) -> list[tuple[str, Any, str]]:
    return [(name, values[name], JOINT_PASSIVE[name]) for name in JOINT_PASSIVE]


def _joint_value(value: Any, path: str, what: str, signed: bool = False) -> float:
    """A joint parameter (a number; >= 0 unless ``signed``), or an error naming it."""
    if isinstance(value, (bool, np.bool_, str, bytes)):
        raise ModelError(path, f"cannot read {value!r} as a number", f"give the {what}")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ModelError(path, f"cannot read {value!r} as a number", f"give the {what}") from None
    if not (np.isfinite(number) and (number >= 0.0 or signed)):
        raise ModelError(path, f"is {number}", f"give the {what}, {'finite' if signed else 'finite and >= 0'}")
    return number


def _close(name: str, known: Sequence[str]) -> str:
    close = difflib.get_close_matches(name, list(known), n=3)
    return f" (did you mean {', '.join(repr(c) for c in close)}?)" if close else ""


def _build(
    name: str,
    bodies: Sequence[BodySpec],
    joints: Sequence[JointSpec],
    source: str,
    named: Sequence[EndEffectorSpec] = (),
    mimics: Sequence[tuple[str, str, float, float]] = (),
) -> Model:
    if not bodies:
        raise ModelError("bodies", "the model has no bodies", "add at least the spacecraft body")
    by_name = {b.name: b for b in bodies}
    names = [b.name for b in bodies]
    parent_joint: dict[str, JointSpec] = {}
    children: dict[str, list[JointSpec]] = {b.name: [] for b in bodies}
    for i, joint in enumerate(joints):
        path = f"joints[{i}] ({joint.name})"
        for role in ("parent", "child"):
            ref = getattr(joint, role)
            if ref not in by_name:
                raise ModelError(f"{path}.{role}", f"unknown body {ref!r}{_close(ref, names)}", "name a body defined in the model")
        if joint.parent == joint.child:
            raise ModelError(f"{path}.child", f"joint connects body {joint.child!r} to itself", "connect two different bodies")
        if joint.child in parent_joint:
            other = parent_joint[joint.child].name
            raise ModelError(
                f"{path}.child",
                f"body {joint.child!r} already has parent joint {other!r} (a body has one parent; this closes a loop)",
                "freefloat handles trees only: remove one of the joints",
            )
        parent_joint[joint.child] = joint
        children[joint.parent].append(joint)
    roots = [b.name for b in bodies if b.name not in parent_joint]
    if not roots:
        raise ModelError(
            "joints", "every body has a parent joint, so the joints form a cycle", "leave the spacecraft (root) without a parent joint"
        )
    if len(roots) > 1:
        raise ModelError(
            "joints",
            f"bodies {', '.join(repr(r) for r in roots[1:])} are not connected to the spacecraft {roots[0]!r} (several roots)",
            "connect every body to the tree with a joint",
        )
    root = roots[0]

    # Depth-first traversal (children in declaration order), merging fixed
    # joints into their movable host body.
    order: list[str] = []  # movable bodies (hosts), depth-first
    leaves: list[str] = []
    host: dict[str, str] = {root: root}
    to_host: dict[str, tuple[np.ndarray, np.ndarray]] = {root: (np.eye(3), np.zeros(3))}  # body -> host frame
    placement: dict[str, tuple[np.ndarray, np.ndarray]] = {}  # movable body -> its joint frame in the parent host
    stack: list[str] = [root]
    while stack:
        body = stack.pop()
        if host[body] == body:
            order.append(body)
        if not children[body] and body != root:
            leaves.append(body)
        r_hb, t_hb = to_host[body]
        for joint in children[body]:
            frame = (r_hb @ joint.rotation, t_hb + r_hb @ joint.origin)
            if joint.type == "fixed":
                host[joint.child], to_host[joint.child] = host[body], frame
            else:
                host[joint.child], to_host[joint.child] = joint.child, (np.eye(3), np.zeros(3))
                placement[joint.child] = frame
        stack.extend(j.child for j in reversed(children[body]))
    unreached = [b for b in names if b not in host]
    if unreached:
        raise ModelError(
            "joints",
            f"bodies {unreached} are not reachable from the spacecraft {root!r} (their joints form a cycle)",
            "connect every body to the tree with exactly one parent joint",
        )
    laws = resolve_mimics(joints, mimics, _close)
    movable_joints: list[JointSpec] = []
    for body in order[1:]:
        movable_joints.append(parent_joint[body])
    index = {b: i for i, b in enumerate(order)}

    n_bodies = len(order)
    mass = np.zeros(n_bodies)
    first = np.zeros((n_bodies, 3))
    second = np.zeros((n_bodies, 3, 3))  # inertia about the host frame origin
    for spec in bodies:
        k = index[host[spec.name]]
        r, t = to_host[spec.name]
        c = t + r @ spec.com
        mass[k] += spec.mass
        first[k] += spec.mass * c
        second[k] += r @ spec.inertia @ r.T + spec.mass * (c @ c * np.eye(3) - np.outer(c, c))
    for k in range(n_bodies):
        if mass[k] <= 0.0:
            raise ModelError(
                f"bodies ({order[k]}).mass",
                "a massless body moves on a joint (or is the spacecraft), which makes the inertia matrix singular",
                "give it a positive mass and an inertia (URDF: an <inertial> element), or attach it with a fixed joint",
            )
    com = first / mass[:, None]
    inertia = np.empty_like(second)
    for k in range(n_bodies):
        c = com[k]
        inertia[k] = second[k] - mass[k] * (c @ c * np.eye(3) - np.outer(c, c))
        inertia[k] = 0.5 * (inertia[k] + inertia[k].T)
        if sum(1 for b in bodies if host[b.name] == order[k]) > 1:
            check_inertia(inertia[k], f"bodies ({order[k]}, merged through fixed joints).inertia")

    parent = np.full(n_bodies, -1, dtype=int)
    joint_origin = np.zeros((n_bodies, 3))
    joint_rotation = np.tile(np.eye(3), (n_bodies, 1, 1))
    joint_axis = np.zeros((n_bodies, 3))
    lower = np.full(n_bodies - 1, -np.inf)
    upper = np.full(n_bodies - 1, np.inf)
    for k, body in enumerate(order[1:], start=1):
        joint = parent_joint[body]
        parent[k] = index[host[joint.parent]]
        joint_rotation[k], joint_origin[k] = placement[body]
        joint_axis[k] = joint.axis
        lower[k - 1], upper[k - 1] = joint.lower, joint.upper

    ee_names: list[str] = []
    ee_body: list[int] = []
    ee_point: list[np.ndarray] = []
    if named:  # the user's list: only these, in their order
        for i, ee in enumerate(named):
            if ee.body not in by_name:
                raise ModelError(
                    f"end_effectors[{i}] ({ee.name}).body",
                    f"{ee.body!r} is not a body or frame of the model{_close(ee.body, names)}",
                    "name a link (URDF), body or frame of the model",
                )
            r, t = to_host[ee.body]
            ee_names.append(ee.name)
            ee_body.append(index[host[ee.body]])
            ee_point.append(t + r @ ee.point)
    else:
        for leaf in leaves:
            spec = by_name[leaf]
            r, t = to_host[leaf]
            point = np.zeros(3) if spec.end_effector is None else spec.end_effector
            ee_names.append(spec.end_effector_name or leaf)
            ee_body.append(index[host[leaf]])
            ee_point.append(t + r @ point)
    if len(set(ee_names)) != len(ee_names):
        raise ModelError("end_effector_name", f"duplicate end-effector names {ee_names}", "give every end effector a unique name")

    independent = [k for k, j in enumerate(movable_joints) if j.name not in laws]
    lower, upper = leader_limits(movable_joints, laws, lower, upper)
    free = [movable_joints[k] for k in independent]
    mimic_records = tuple(
        {
            "joint": j.name,
            "body": j.child,
            "leader": laws[j.name][0],
            "multiplier": laws[j.name][1],
            "offset": laws[j.name][2],
            "type": "prismatic" if j.type == "prismatic" else "revolute",
            "lower": j.lower,
            "upper": j.upper,
            **{key: getattr(j, key) for key in JOINT_PASSIVE},
        }
        for j in movable_joints
        if j.name in laws
    )
    movable_joints = free
    passive: dict[str, Any] = {f"joint_{key}": [getattr(j, key) for j in movable_joints] for key in JOINT_PASSIVE}
    return Model(
        name=name,
        body_names=tuple(order),
        parent=parent,
        joint_names=tuple(j.name for j in movable_joints),
        joint_origin=joint_origin,
        joint_rotation=joint_rotation,
        joint_axis=joint_axis,
        joint_lower=lower[independent],
        joint_upper=upper[independent],
        mass=mass,
        com=com,
        inertia=inertia,
        end_effector_names=tuple(ee_names),
        end_effector_body=np.asarray(ee_body, dtype=int),
        end_effector_point=np.asarray(ee_point, dtype=float).reshape(-1, 3),
        source=source,
        joint_type=tuple("prismatic" if j.type == "prismatic" else "revolute" for j in movable_joints),
        **passive,
        end_effector_rule="named" if named else "leaves",
        mimic=mimic_records,
    )
