"""The model layout: the model as named arrays, the form every kernel of the engine takes (built once per model).

A model reaches the kernels as two flat buffers, ``ints`` and ``floats`` (:class:`Tree`), and each
kernel opens them with :func:`arrays` into an :data:`Arrays` named tuple: ``m.parent[k]``,
``m.mass[k]``, ``m.inertia[k, i, j]``, ``m.total_mass``. Two buffers keep a kernel's argument
list short (numba unboxes every array argument at each call from Python) and the names keep the
kernels readable. Mass properties are data here, never code: a new model or a payload variant
(:meth:`~freefloat.Model.with_payload`) is a new :class:`Tree` and compiles nothing.

Each layout is declared once, in this file, and the kernels that open it are written from the declaration when
the module is imported (:func:`~.cache.inline_kernels`: the source is generated, compiled inline into every kernel
that calls it, and its views are :func:`~.gate.floats_view` and :func:`~.gate.ints_view`, as hand-written ones were):

* the model: :data:`INT_BLOCKS` (after the head of the ints: B, E, N), :data:`BODY_FIELDS` and :data:`FLOAT_BLOCKS`
  give :data:`Arrays`, :func:`arrays`, :func:`buffer_lengths` and the views of :class:`Tree` (the same generated code,
  on checked slices);
* the scratch of one configuration: :data:`SCRATCH` (in the sizes of :data:`SCRATCH_SIZES`) gives :data:`Scratch`,
  :func:`scratch` and :func:`work_size`.

**Adding a per-body or per-joint parameter** (row k of a body field is body k and its joint, row 0
the spacecraft; the joint of body k is driven by column ``coordinate[k]`` of q, with value
``multiplier[k] q[coordinate[k]] + offset[k]``: k - 1, 1 and 0 unless it is a mimic joint) is one line: a
:class:`Field` in :data:`BODY_FIELDS` (its name, shape, role, how it is read from the model, and what it is); then
use ``m.<name>`` in the physics (:mod:`.recursions`, :mod:`.quantities`). The specialiser (:mod:`.specialise.build`)
reads the layout from :data:`BODY_FIELDS` too: a ``"data"`` field is read at run time by the specialised kernels (so
payload variants share them), a ``"structure"`` field is folded into them as numbers. A scratch row is one
:class:`Row` in :data:`SCRATCH`. ``tests/mechanics/test_engine.py`` checks the generated views against the
declarations on random trees.
"""

from __future__ import annotations

import functools
import math
import threading
import weakref
from collections import namedtuple
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core import state_layout as _state
from ..core.state_layout import ATTITUDE_AT, OMEGA_AT, Q_AT, R_CM_AT, V_CM_AT
from .cache import bind, floats_view, inline_kernels, ints_view, kernel, slice_view  # noqa: F401 (the views: names of the generated kernels)

__all__ = [
    "ATTITUDE_AT",
    "BODY_FIELDS",
    "FLOAT_BLOCKS",
    "INT_BLOCKS",
    "OMEGA_AT",
    "Q_AT",
    "R_CM_AT",
    "SCRATCH",
    "V_CM_AT",
    "Arrays",
    "Block",
    "Field",
    "Row",
    "Scratch",
    "Tree",
    "arrays",
    "buffer_lengths",
    "coordinates",
    "dissipated_at",
    "qdot_at",
    "scratch",
    "state_length",
    "tree",
    "work_size",
]


#: The flat state's offsets in the kernels (declared in :mod:`freefloat.core.state_layout`, compiled inline; the
#: fixed ones, ``Q_AT`` and the like, are module-level integers numba compiles in as constants).
qdot_at = kernel(inline="always")(_state.qdot_at)
dissipated_at = kernel(inline="always")(_state.dissipated_at)
state_length = kernel(inline="always")(_state.state_length)
coordinates = kernel(inline="always")(_state.coordinates)


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
    Field("stiffness", (), "data", lambda m, k: m.expanded().joint_stiffness[k - 1] if k > 0 else 0.0, "joint spring (N m/rad, N/m)", True),
    Field("springref", (), "data", lambda m, k: m.expanded().joint_springref[k - 1] if k > 0 else 0.0, "its relaxed value (rad, m)", True),
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


@dataclass(frozen=True)
class Block:
    """A named block of a model's buffers besides the body fields: its ``shape`` in bodies ``"B"``, end effectors ``"E"``
    and numbers (``()``: one number), ``read(model)`` its value, and what it is."""

    name: str
    shape: tuple[int | str, ...]
    read: Callable[[Any], Any]
    doc: str


#: The head of a model's ints: B (bodies), E (end effectors), N (joint coordinates: B - 1 less the mimic joints).
HEADER = 3
#: The model's ints after the head, in buffer order.
INT_BLOCKS: tuple[Block, ...] = (
    Block("parent", ("B",), lambda m: m.parent, "the parent body, -1 for the spacecraft"),
    Block("ancestor", ("B", "B"), lambda m: m.subtree, "[i, k] = 1 when body i is body k or on its path to the spacecraft"),
    Block("ee_body", ("E",), lambda m: m.end_effector_body, "the body of each end effector"),
)
#: The model's floats after the body fields (each (B, *shape), :data:`BODY_FIELDS`), in buffer order.
FLOAT_BLOCKS: tuple[Block, ...] = (
    Block("total_mass", (), lambda m: m.total_mass, "the system mass (kg)"),
    Block("ee_point", ("E", 3), lambda m: np.reshape(m.end_effector_point, (-1, 3)), "each end effector in its body frame (m)"),
)
#: The floats of the model in buffer order: (name, shape in B, E and numbers).
_BODY_LAYOUT: list[tuple[str, tuple[int | str, ...]]] = [(f.name, ("B", *f.shape)) for f in BODY_FIELDS]
_FLOAT_LAYOUT = tuple(_BODY_LAYOUT + [(b.name, b.shape) for b in FLOAT_BLOCKS])
#: The dimensions of the model's blocks as the kernels name them.
_MODEL_DIMS = {"B": "nb", "E": "ne"}

#: The model as the kernels see it (:func:`arrays`): the int blocks, the body fields (row k = body k), the float blocks
#: (:data:`INT_BLOCKS`, :data:`BODY_FIELDS`, :data:`FLOAT_BLOCKS`: their names, in that order) and N (``n_joints``).
Arrays = namedtuple("Arrays", [*(b.name for b in INT_BLOCKS), *(name for name, _ in _FLOAT_LAYOUT), "n_joints"])  # type: ignore[misc]


def _dim(d: int | str, dims: dict[str, str]) -> str:
    return str(d) if isinstance(d, int) else dims.get(d, d)


def _count(shape: tuple[int | str, ...], dims: dict[str, str]) -> str:
    """The number of entries of ``shape`` as a Python expression of the kernels' names ``dims``."""
    parts = [f"({_dim(d, dims)})" if " " in _dim(d, dims) else _dim(d, dims) for d in shape]
    return " * ".join(parts) if parts else "1"


def views_source(buffer: str, offset: str, blocks: Any, dims: dict[str, str], view: str) -> list[str]:
    """Kernel lines that make the views ``name = view(buffer, o, shape)`` of ``blocks`` ((name, shape) in buffer order,
    the shapes in the names ``dims``) from element ``offset`` of ``buffer`` on; a block of shape () is the number there.
    The running offset ``o`` ends past the last block."""
    lines = [f"    o = {offset}"]
    for name, shape in blocks:
        sizes = [_dim(d, dims) for d in shape]
        if not sizes:
            lines.append(f"    {name} = {buffer}[o]")
        else:
            lines.append(f"    {name} = {view}({buffer}, o, {sizes[0] if len(sizes) == 1 else '(' + ', '.join(sizes) + ')'})")
        lines.append(f"    o += {_count(shape, dims)}")
    return lines


def _model_source() -> str:
    """The source of :func:`arrays` and :func:`buffer_lengths`, written from the declaration of the model's buffers."""
    ints_length = " + ".join([str(HEADER), *(_count(b.shape, _MODEL_DIMS) for b in INT_BLOCKS)])
    floats_length = " + ".join(_count(shape, _MODEL_DIMS) for _, shape in _FLOAT_LAYOUT)
    return "\n".join(
        [
            "def buffer_lengths(ints):",
            f'    """{buffer_lengths_doc}"""',
            "    nb = ints[0]",
            "    ne = ints[1]",
            f"    return {ints_length}, {floats_length}",
            "",
            "",
            "def arrays(ints, floats):",
            f'    """{arrays_doc}"""',
            "    if ints.shape[0] < 3 or ints[0] < 1 or ints[1] < 0:",
            "        raise ValueError('freefloat: the model\\'s buffers have no valid header')",
            "    nb = ints[0]",
            "    ne = ints[1]",
            "    ints_length, floats_length = buffer_lengths(ints)",
            "    if ints.shape[0] < ints_length or floats.shape[0] < floats_length:",
            "        raise ValueError('freefloat: the model\\'s buffers are shorter than their header says')",
            *views_source("ints", str(HEADER), ((b.name, b.shape) for b in INT_BLOCKS), _MODEL_DIMS, "ints_view"),
            *views_source("floats", "0", _FLOAT_LAYOUT, _MODEL_DIMS, "floats_view"),
            f"    return Arrays({', '.join(Arrays._fields[:-1])}, ints[2])",
            "",
        ]
    )


buffer_lengths_doc = "(length of the model's ints, of its floats) from the head of its ints: what follows them is the caller's."
arrays_doc = """The :data:`Arrays` of a model from its two buffers (:class:`Tree`; a buffer may continue past the model).

    ints = [B, E, N, the blocks of INT_BLOCKS]; floats = [the body fields of BODY_FIELDS, each (B, *shape), the blocks of
    FLOAT_BLOCKS]. The views count no references and check no bounds (cheaper: gate.floats_view; the buffers' lengths
    are checked here once): the buffers must be arguments of the calling kernel, held by its caller. Written from the
    declaration (layout._model_source)."""
#: ``arrays(ints, floats)``: the :data:`Arrays` of a model's buffers; ``buffer_lengths(ints)``: the lengths of its ints
#: and floats (the kernels written from the declaration by :func:`_model_source`).
buffer_lengths, arrays = inline_kernels(_model_source(), ("buffer_lengths", "arrays"), globals(), "engine.layout: the model's views")


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
        """The length of the flat state the rollouts of this model integrate (:mod:`freefloat.core.state_layout`): with
        the dissipated energy's slot when :attr:`passive` (:func:`~.quantities.state_derivative_one`)."""
        return _state.state_length(self.n_joints, self.passive)

    def field_offset(self, name: str) -> int:
        """Where the float block ``name`` (a body field of :data:`BODY_FIELDS` or a block of :data:`FLOAT_BLOCKS`) starts
        in ``floats``."""
        sizes = {"B": self.n_bodies, "E": int(self.ee_body.shape[0])}
        offset = 0
        for block, shape in _FLOAT_LAYOUT:
            if block == name:
                return offset
            offset += math.prod(sizes[d] if isinstance(d, str) else d for d in shape)
        raise KeyError(name)


_TREES: weakref.WeakKeyDictionary[Any, Tree] = weakref.WeakKeyDictionary()
_TREES_LOCK = threading.Lock()


def _block(value: Any, shape: tuple[int, ...], dtype: Any) -> np.ndarray:
    return np.asarray(value, dtype=dtype).reshape(shape).ravel()


def tree(model: Any) -> Tree:
    """The :class:`Tree` of a model (built once per model, kept while the model lives): its buffers written in the order
    of the declaration, and its views made by the same code as the kernels' (:func:`arrays` on checked slices)."""
    found = _TREES.get(model)
    if found is not None:
        return found
    n_b = model.n_bodies
    n_e = int(np.size(model.end_effector_body))
    sizes = {"B": n_b, "E": n_e}

    def shape_of(block: Block) -> tuple[int, ...]:
        return tuple(sizes[d] if isinstance(d, str) else d for d in block.shape)

    ints = np.concatenate([[n_b, n_e, model.n_joints], *(_block(b.read(model), shape_of(b), np.int64) for b in INT_BLOCKS)]).astype(
        np.int64
    )
    body = [np.array([np.asarray(f.read(model, k), dtype=float).reshape(f.shape) for k in range(n_b)]).ravel() for f in BODY_FIELDS]
    floats = np.concatenate([*body, *(_block(b.read(model), shape_of(b), float) for b in FLOAT_BLOCKS)])
    ints.setflags(write=False)
    floats.setflags(write=False)
    views = _python_arrays(ints, floats)
    out = Tree(
        ints=ints,
        floats=floats,
        fields={f.name: getattr(views, f.name) for f in BODY_FIELDS},
        parent=views.parent,
        ancestor=views.ancestor,
        ee_body=views.ee_body,
        ee_point=views.ee_point,
        total_mass=float(views.total_mass),
        n_joints=int(views.n_joints),
    )
    with _TREES_LOCK:
        _TREES[model] = out
    return out


#: :func:`arrays` in Python, its views checked slices of the buffers (as the specialiser's tracer runs it): the Python
#: views of a :class:`Tree` are made by the kernels' own code.
_python_arrays = bind(arrays.py_func, "arrays_python", floats_view=slice_view, ints_view=slice_view, buffer_lengths=buffer_lengths.py_func)


@dataclass(frozen=True)
class Row:
    """A named view of the scratch buffer of one configuration: its ``shape`` in the sizes of :data:`SCRATCH_SIZES`
    and numbers, and what it holds."""

    name: str
    shape: tuple[int | str, ...]
    doc: str


#: The sizes the scratch rows are declared in, as the kernels compute them from the bodies ``nb``, the end effectors
#: ``ne`` and the joint coordinates ``n`` (B - 1 less the mimic joints; :func:`work_size` makes room for B - 1): names
#: apart from the rows'.
SCRATCH_SIZES = {
    "m": "3 + n",  # the [omega0, q] block of H+
    "nz": "6 + n",  # zdot0 = [rdot_cm, omega0, qdot]
    "size": "state_length(n, True)",  # a flat state with its trailing slot (the dissipated energy), the longest a kernel steps
    "loop": "4 * size + n + 9",  # the rows of one trajectory in the rollout loop (specialise.lanes._rollout_blocks, width 1)
}

#: Scratch space of one configuration, in buffer order: views of one flat buffer, made once per batch range (or per
#: stepper call) and passed down (:data:`Scratch`), so no kernel pays for making views at every configuration.
SCRATCH: tuple[Row, ...] = (
    Row("rot", ("nb", 3, 3), "kinematics: ⁰T_k"),
    Row("pos", ("nb", 3), "kinematics: the joint positions p_k (from O)"),
    Row("axis", ("nb", 3), "kinematics: the angular part of the motion axes, u_k"),
    Row("mom", ("nb", 3), "kinematics: the linear part of the motion axes, p_k x u_k"),
    Row("own_f", ("nb", 3), "first moments m_k c_k about O"),
    Row("own_i", ("nb", 3, 3), "inertias about O"),
    Row("cf", ("nb", 3), "composite first moments"),
    Row("ci", ("nb", 3, 3), "composite inertias about O"),
    Row("g", ("nb", 3), "linear momentum of the subtree of joint l at unit rate"),
    Row("h", ("nb", 3), "angular momentum (about O) of the subtree of joint l at unit rate"),
    Row("w", ("nb", 3), "Newton-Euler: angular velocity"),
    Row("v", ("nb", 3), "Newton-Euler: linear velocity"),
    Row("al", ("nb", 3), "Newton-Euler: angular acceleration"),
    Row("be", ("nb", 3), "Newton-Euler: linear acceleration"),
    Row("nf", ("nb", 3), "Newton-Euler: moment"),
    Row("ff", ("nb", 3), "Newton-Euler: force"),
    Row("pt", (3,), "a 3-vector"),
    Row("fo", (3,), "a 3-vector"),
    Row("no", (3,), "a 3-vector"),
    Row("total", (3,), "a 3-vector"),
    Row("re", (3,), "a 3-vector"),
    Row("a", ("m", "m"), "the [omega0, q] block of H+"),
    Row("low", ("m", "m"), "its Cholesky factor"),
    Row("b", ("m",), "a right-hand side"),
    Row("x", (3, "n"), "X = D^-1 D_q"),
    Row("t0", (3, 3), "the attitude T0"),
    Row("vel", ("nz",), "zdot0"),
    Row("acc", ("nz",), "zddot0"),
    Row("k", (4, "size"), "RK4: the four stage derivatives"),
    Row("y", ("size",), "RK4: the stage state"),
    Row("joints", ("n",), "joint values read from a state"),
    Row("rows", ("loop",), "the rows of one trajectory in the rollout loop (specialise.lanes._rollout_blocks, width 1)"),
    Row("jac", ("6 * ne", "n"), "a J* whose measure is wanted"),
    Row("sel", ("6 * ne * n",), "spare room after jac (no kernel reads it: the measures work in their own block buffer)"),
)

#: The scratch views of one configuration (:func:`scratch`): the rows of :data:`SCRATCH`, by name.
Scratch = namedtuple("Scratch", [r.name for r in SCRATCH])  # type: ignore[misc]


def _scratch_source() -> str:
    """The source of :func:`scratch`, written from :data:`SCRATCH`."""
    return "\n".join(
        [
            "def scratch(work, nb, ne, n):",
            f'    """{scratch_doc}"""',
            *(f"    {name} = {expr}" for name, expr in SCRATCH_SIZES.items()),
            *views_source("work", "0", ((r.name, r.shape) for r in SCRATCH), {}, "floats_view"),
            "    if o > work.shape[0]:",
            "        raise ValueError('freefloat: the scratch buffer is shorter than work_size')",
            f"    return Scratch({', '.join(Scratch._fields)})",
            "",
        ]
    )


scratch_doc = """The :data:`Scratch` views of ``work`` (length :func:`work_size`) for ``nb`` bodies, ``ne`` end effectors
    and ``n`` joint coordinates (``m.n_joints``: B - 1 less the mimic joints).

    The views neither count references to ``work`` nor check bounds (cheaper: gate.floats_view; the length is checked
    here once, before any is read), so ``work`` must outlive them: it is always an argument of the calling kernel (or a
    contiguous slice of one), held by the Python caller for the whole call; never a buffer made inside a kernel, which
    numba may free after its last use (``tests/mechanics/test_engine.py`` checks every call). Written from the
    declaration (layout._scratch_source)."""
#: ``scratch(work, nb, ne, n)``: the :data:`Scratch` views of one configuration's scratch buffer.
(scratch,) = inline_kernels(_scratch_source(), ("scratch",), globals(), "engine.layout: the scratch views")


@functools.lru_cache(maxsize=256)
def work_size(n_bodies: int, n_ee: int) -> int:
    """Length of the scratch buffer of one configuration (the rows of :data:`SCRATCH`) for ``n_bodies`` bodies and
    ``n_ee`` end effectors (for B - 1 joint coordinates: enough for the N <= B - 1 of a model with mimic joints)."""
    sizes = scratch_sizes(n_bodies, n_ee, n_bodies - 1)
    return sum(math.prod(row_shape(r, sizes)) for r in SCRATCH)


def scratch_sizes(n_bodies: int, n_ee: int, n: int) -> dict[str, int]:
    """The sizes of :data:`SCRATCH_SIZES` (and nb, ne, n) for ``n_bodies`` bodies, ``n_ee`` end effectors and ``n`` joint
    coordinates: the kernel's own expressions, on numbers."""
    sizes: dict[str, int] = {"nb": n_bodies, "ne": n_ee, "n": n}
    for name, expr in SCRATCH_SIZES.items():
        sizes[name] = int(eval(expr, {"state_length": _state.state_length}, sizes))
    return sizes


def row_shape(row: Row, sizes: dict[str, int]) -> tuple[int, ...]:
    """The shape of the scratch row ``row`` for the sizes ``sizes`` (:func:`scratch_sizes`)."""
    return tuple(int(eval(d, {}, sizes)) if isinstance(d, str) else d for d in row.shape)
