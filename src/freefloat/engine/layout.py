"""The model layout: the model as named arrays, the form every kernel of the engine takes (built once per model).

A model reaches the kernels as two flat buffers, ``ints`` and ``floats`` (:class:`Tree`), and each
kernel opens them with :func:`arrays` into an :data:`Arrays` named tuple: ``m.parent[k]``,
``m.mass[k]``, ``m.inertia[k, i, j]``, ``m.total_mass``. Two buffers keep a kernel's argument
list short (numba unboxes every array argument at each call from Python) and the names keep the
kernels readable. Mass properties are data here, never code: a new model or a payload variant
(:meth:`~freefloat.Model.with_payload`) is a new :class:`Tree` and compiles nothing.

**Adding a per-body or per-joint parameter** (row k of a body field is body k and its joint, row 0
the spacecraft; the joint of body k is driven by column ``coordinate[k]`` of q, with value
``multiplier[k] q[coordinate[k]] + offset[k]``: k - 1, 1 and 0 unless it is a mimic joint): add a
:class:`Field` to :data:`BODY_FIELDS` (its shape, its role, and how it is read from the model), the
same name to :data:`Arrays` and its view to :func:`arrays` (all three in this file; ``tests/mechanics/test_engine.py`` checks that they
agree), then use ``m.<name>`` in the recursions (:mod:`.recursions`). The specialiser
(:mod:`.specialise.build`) reads the layout from :data:`BODY_FIELDS`: a ``"data"`` field is read at run
time by the specialised kernels (so payload variants share them), a ``"structure"`` field is folded
into them as numbers.
"""

from __future__ import annotations

import threading
import weakref
from collections import namedtuple
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .cache import floats_view, ints_view, kernel

__all__ = ["BODY_FIELDS", "Arrays", "Field", "Tree", "arrays", "tree", "work_size"]


def _skew(u: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])


def _turn_axis(model: Any, k: int) -> np.ndarray:
    """The axis joint k - 1 turns about (zero for a prismatic joint and for the spacecraft row)."""
    sliding = k > 0 and bool(model.body_joint_prismatic[k - 1])
    return np.zeros(3) if sliding else np.asarray(model.joint_axis[k], dtype=float)


@dataclass(frozen=True)
class Field:
    """A named per-body array of the layout: ``shape`` per body, ``role`` ``"structure"`` (folded into specialised
    kernels) or ``"data"`` (read at run time), ``read(model, k)`` the value of body k, and what it is."""

    name: str
    shape: tuple[int, ...]
    role: str
    read: Callable[[Any, int], Any]
    doc: str
    #: A "data" field that is zero for most models (a joint's rotor inertia, damping, friction): the specialiser folds
    #: its zero entries as numbers (their terms vanish from the kernels) and keys the kernels by where they are zero.
    fold_zeros: bool = False

    @property
    def width(self) -> int:
        return int(np.prod(self.shape, dtype=np.int64))


#: The per-body fields, in buffer order (each one contiguous block of B rows).
BODY_FIELDS: tuple[Field, ...] = (
    Field("origin", (3,), "structure", lambda m, k: m.joint_origin[k], "joint position t_k in the parent frame (m)"),
    Field("place", (3, 3), "structure", lambda m, k: m.joint_rotation[k], "joint placement P_k: parent <- joint frame at q = 0"),
    Field(
        "place_k",
        (3, 3),
        "structure",
        lambda m, k: np.asarray(m.joint_rotation[k], dtype=float) @ _skew(_turn_axis(m, k)),
        "P_k K_k, K_k the cross-product matrix of the turning axis (zero for a prismatic joint)",
    ),
    Field(
        "place_k2",
        (3, 3),
        "structure",
        lambda m, k: np.asarray(m.joint_rotation[k], dtype=float) @ _skew(_turn_axis(m, k)) @ _skew(_turn_axis(m, k)),
        "P_k K_k^2 (Rodrigues: the joint rotation is P_k + sin q P_k K_k + (1 - cos q) P_k K_k^2)",
    ),
    Field(
        "axis",
        (3,),
        "structure",
        lambda m, k: np.asarray(m.joint_rotation[k], dtype=float) @ np.asarray(m.joint_axis[k], dtype=float),
        "joint axis in the parent frame, P_k u_k",
    ),
    Field(
        "prismatic",
        (),
        "structure",
        lambda m, k: 1.0 if k > 0 and bool(m.body_joint_prismatic[k - 1]) else 0.0,
        "1.0 when the joint slides along its axis, 0.0 when it turns",
    ),
    Field(
        "coordinate",
        (),
        "structure",
        lambda m, k: float(m.body_joint_coordinate[k - 1]) if k > 0 else -1.0,
        "the column of q that drives joint k (its own; a mimic joint's leader's), as a float (-1 for the spacecraft)",
    ),
    Field(
        "multiplier",
        (),
        "structure",
        lambda m, k: float(m.body_joint_multiplier[k - 1]) if k > 0 else 0.0,
        "joint k's value is multiplier q[coordinate] + offset: 1 for an independent joint, a mimic joint's law",
    ),
    Field("mass", (), "data", lambda m, k: m.mass[k], "mass m_k (kg)"),
    Field("com", (3,), "data", lambda m, k: m.com[k], "CM in the body frame (m)"),
    Field("inertia", (3, 3), "data", lambda m, k: m.inertia[k], "inertia about the CM, body axes (kg m^2)"),
    Field(
        "armature",
        (),
        "data",
        lambda m, k: m.expanded().joint_armature[k - 1] if k > 0 else 0.0,
        "rotor inertia reflected to the joint (kg m^2, kg when prismatic): added to its diagonal entry of H+",
        fold_zeros=True,
    ),
    Field(
        "damping",
        (),
        "data",
        lambda m, k: m.expanded().joint_damping[k - 1] if k > 0 else 0.0,
        "viscous joint damping (N m s/rad, N s/m)",
        True,
    ),
    Field(
        "friction", (), "data", lambda m, k: m.expanded().joint_friction[k - 1] if k > 0 else 0.0, "Coulomb joint friction (N m, N)", True
    ),
    Field(
        "offset",
        (),
        "data",
        lambda m, k: float(m.body_joint_offset[k - 1]) if k > 0 else 0.0,
        "the offset of a mimic joint's law (rad, m; 0 for an independent joint)",
        fold_zeros=True,
    ),
    Field(
        "subtree_mass",
        (),
        "data",
        lambda m, k: float(np.asarray(m.subtree, dtype=float)[k] @ np.asarray(m.mass, dtype=float)),
        "mass of the subtree of body k, itself included (kg)",
    ),
)

#: Floats per body (the sum of the field widths).
BODY_WIDTH = sum(f.width for f in BODY_FIELDS)

#: The model as the kernels see it: the tree (ints), the body fields of :data:`BODY_FIELDS` (floats, row k = body k),
#: the total mass and the end-effector points.
Arrays = namedtuple(
    "Arrays",
    [
        "parent",  # (B,) int64: the parent body, -1 for the spacecraft
        "ancestor",  # (B, B) int64: [i, k] = 1 when body i is body k or on its path to the spacecraft
        "ee_body",  # (E,) int64: the body of each end effector
        "origin",
        "place",
        "place_k",
        "place_k2",
        "axis",
        "prismatic",
        "coordinate",
        "multiplier",
        "mass",
        "com",
        "inertia",
        "armature",
        "damping",
        "friction",
        "offset",
        "subtree_mass",  # the body fields, in BODY_FIELDS order
        "total_mass",  # float: the system mass (kg)
        "ee_point",  # (E, 3): each end effector in its body frame (m)
        "n_joints",  # int: N, the columns of q (B - 1 less the mimic joints)
    ],
)


@kernel(inline="always")
def arrays(ints: np.ndarray, floats: np.ndarray) -> Any:  # pragma: no cover - compiled
    """The :data:`Arrays` of a model from its two buffers (:class:`Tree`; a buffer may continue past the model).

    ints = [B, E, N, parent (B), ancestor (B x B), ee_body (E)]; floats = [the body fields of :data:`BODY_FIELDS`,
    each (B, *shape), total mass, ee_point (E x 3)]. The views count no references and check no bounds (cheaper:
    :func:`~.gate.floats_view`; the buffers' lengths are checked here once): the buffers must be arguments of
    the calling kernel, held by its caller.
    """
    if ints.shape[0] < 3 or ints[0] < 1 or ints[1] < 0:
        raise ValueError("freefloat: the model's buffers have no valid header")
    nb = ints[0]
    ne = ints[1]
    ints_length, floats_length = buffer_lengths(ints)
    if ints.shape[0] < ints_length or floats.shape[0] < floats_length:
        raise ValueError("freefloat: the model's buffers are shorter than their header says")
    o = 3
    parent = ints_view(ints, o, nb)
    o += nb
    ancestor = ints_view(ints, o, (nb, nb))
    o += nb * nb
    ee_body = ints_view(ints, o, ne)
    f = 0
    origin = floats_view(floats, f, (nb, 3))
    f += 3 * nb
    place = floats_view(floats, f, (nb, 3, 3))
    f += 9 * nb
    place_k = floats_view(floats, f, (nb, 3, 3))
    f += 9 * nb
    place_k2 = floats_view(floats, f, (nb, 3, 3))
    f += 9 * nb
    axis = floats_view(floats, f, (nb, 3))
    f += 3 * nb
    prismatic = floats_view(floats, f, nb)
    f += nb
    coordinate = floats_view(floats, f, nb)
    f += nb
    multiplier = floats_view(floats, f, nb)
    f += nb
    mass = floats_view(floats, f, nb)
    f += nb
    com = floats_view(floats, f, (nb, 3))
    f += 3 * nb
    inertia = floats_view(floats, f, (nb, 3, 3))
    f += 9 * nb
    armature = floats_view(floats, f, nb)
    f += nb
    damping = floats_view(floats, f, nb)
    f += nb
    friction = floats_view(floats, f, nb)
    f += nb
    offset = floats_view(floats, f, nb)
    f += nb
    subtree_mass = floats_view(floats, f, nb)
    f += nb
    total_mass = floats[f]
    ee_point = floats_view(floats, f + 1, (ne, 3))
    return Arrays(
        parent,
        ancestor,
        ee_body,
        origin,
        place,
        place_k,
        place_k2,
        axis,
        prismatic,
        coordinate,
        multiplier,
        mass,
        com,
        inertia,
        armature,
        damping,
        friction,
        offset,
        subtree_mass,
        total_mass,
        ee_point,
        ints[2],
    )


@kernel(inline="always")
def buffer_lengths(ints: np.ndarray) -> tuple[int, int]:  # pragma: no cover - compiled
    """(length of the model's ints, of its floats) from the head of its ints: what follows them is the caller's."""
    nb = ints[0]
    ne = ints[1]
    return 3 + nb + nb * nb + ne, nb * BODY_WIDTH + 1 + 3 * ne


@dataclass(frozen=True, eq=False)
class Tree:
    """A model as the engine's two buffers (read-only), with named views of them for Python.

    ``ints`` and ``floats``: see :func:`arrays`. ``fields``: the body fields by name, (B, *shape) views of
    ``floats``. parent (B,), ancestor (B, B), ee_body (E,) and ee_point (E, 3) are views of the buffers.
    """

    ints: np.ndarray
    floats: np.ndarray
    fields: dict[str, np.ndarray]
    parent: np.ndarray
    ancestor: np.ndarray
    ee_body: np.ndarray
    ee_point: np.ndarray
    total_mass: float
    n_joints: int

    @property
    def n_bodies(self) -> int:
        return int(self.parent.shape[0])

    @property
    def passive(self) -> bool:
        """Whether a joint has viscous damping or Coulomb friction: then the engine's rollouts of this model integrate
        the energy they dissipate, in a trailing slot of the flat state (:attr:`state_size`)."""
        return bool(np.any(self.fields["damping"]) or np.any(self.fields["friction"]))

    @property
    def state_size(self) -> int:
        """The flat state the rollouts of this model integrate: 13 + 2N, and the dissipated energy (14 + 2N) when
        :attr:`passive` (:func:`~.quantities.state_derivative_one`)."""
        return 13 + 2 * self.n_joints + (1 if self.passive else 0)

    def field_offset(self, name: str) -> int:
        """Where body field ``name`` starts in ``floats``."""
        offset = 0
        for f in BODY_FIELDS:
            if f.name == name:
                return offset
            offset += f.width * self.n_bodies
        raise KeyError(name)


_TREES: weakref.WeakKeyDictionary[Any, Tree] = weakref.WeakKeyDictionary()
_TREES_LOCK = threading.Lock()


def tree(model: Any) -> Tree:
    """The :class:`Tree` of a model (built once per model, kept while the model lives)."""
    found = _TREES.get(model)
    if found is not None:
        return found
    n_b = model.n_bodies
    ee_body = np.asarray(model.end_effector_body, dtype=np.int64)
    ee_point = np.asarray(model.end_effector_point, dtype=float).reshape(-1, 3)
    ancestor = np.asarray(model.subtree, dtype=np.int64)
    ints = np.concatenate(
        [[n_b, ee_body.shape[0], model.n_joints], np.asarray(model.parent, dtype=np.int64), ancestor.ravel(), ee_body]
    ).astype(np.int64)
    blocks = [np.array([np.asarray(f.read(model, k), dtype=float).reshape(f.shape) for k in range(n_b)]).ravel() for f in BODY_FIELDS]
    floats = np.concatenate([*blocks, [float(model.total_mass)], ee_point.ravel()])
    ints.setflags(write=False)
    floats.setflags(write=False)
    fields: dict[str, np.ndarray] = {}
    offset = 0
    for f in BODY_FIELDS:
        fields[f.name] = floats[offset : offset + f.width * n_b].reshape((n_b, *f.shape))
        offset += f.width * n_b
    o = 3 + n_b
    out = Tree(
        ints=ints,
        floats=floats,
        fields=fields,
        parent=ints[3:o],
        ancestor=ints[o : o + n_b * n_b].reshape((n_b, n_b)),
        ee_body=ints[o + n_b * n_b :],
        ee_point=floats[offset + 1 :].reshape((-1, 3)),
        total_mass=float(floats[offset]),
        n_joints=int(model.n_joints),
    )
    with _TREES_LOCK:
        _TREES[model] = out
    return out


def work_size(n_bodies: int, n_ee: int) -> int:
    """Length of the scratch buffer of one configuration (the views of :data:`~.recursions.Scratch`) for ``n_bodies`` bodies
    and ``n_ee`` end effectors (for B - 1 joint coordinates: enough for the N <= B - 1 of a model with mimic joints)."""
    n = n_bodies - 1
    m = 3 + n
    size = 14 + 2 * n  # a flat state with the dissipated energy's slot
    return 66 * n_bodies + 15 + 2 * m * m + m + 3 * n + 9 + 2 * (6 + n) + 5 * size + n + (4 * size + n + 9) + 12 * n_ee * n
