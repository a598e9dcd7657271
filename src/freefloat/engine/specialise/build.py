"""The specialiser: the engine's recursions compiled for one model *structure*, SIMD across configurations.

The generic kernels (:mod:`freefloat.engine.drivers`) take any model as arrays and compile nothing per model. For
large batches on one model this module compiles, per model structure, faster kernels **from the same source**:
:mod:`.trace` runs the one-configuration kernels of :mod:`freefloat.engine.quantities` (:data:`~.trace.ENTRY_POINTS`:
``jstar_one``, ``state_derivative_one``, ``hplus_one``, ``accelerations_one``, ``inverse_one``) on symbols, with the
structure as numbers (the tree, joint types, placements and axes: folded) and the data as symbols (masses, CMs,
inertias, the total mass, end-effector points: read at run time, so :meth:`~freefloat.Model.with_payload` variants
share the kernels; the layout of external wrenches, their bodies and frames, is structure too and their values are
inputs). :func:`emit` writes the graph as straight-line code over one block of :data:`~.lanes.LANES` configurations
(rows of a flat buffer), which LLVM vectorises; sin and cos become :data:`SINCOS` (a vectorisable sin/cos: within 1 ulp
of the C library's over |q| <= 7 rad and 2 ulp over |q| <= 1e5 rad, checked by ``tests/mechanics/test_specialise.py``;
beyond about 1e6 rad the reduction is no longer exact). :mod:`.lanes` drives the blocks.

A structure is specialised when asked (:func:`specialise`, public as ``ff.mechanics.specialise``), or by itself in a
background thread once a process has spent :data:`AUTO_AFTER` seconds on its generic kernels (:func:`account`;
``FREEFLOAT_AUTO_SPECIALISE=0`` turns that off): a structure compiles once per machine (:data:`COMPILE_TIME`), and its
calls use it once the lane kernel and the driver ``blocks`` are compiled (a large call on one range of blocks per
thread: :func:`_run`); the generated source and numba's machine code are then kept in the user's cache folder (inside
the generic kernels' folder for this numba version and engine source, keyed by the structure) and found by every later
process, which then uses them for J*, H+ and dynamics batches and rollouts of every model of that structure (with
external wrenches: of their layout, each layout apart). The kind "measure" is J*'s lane kernel followed, on each
block, by the engine's :func:`freefloat.engine.measures.jacobian_measure_lanes` (det, singular values: written once,
SIMD across the block), for the singularity measures of chosen rows (:func:`measured`).
Everything else, and every model not specialised, runs on the generic kernels. Two processes specialising the same
structure at once both compile; the file each writes is the same and replaced atomically.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import importlib.util
import logging
import os
import sys
import tempfile
import threading
import time
import types
import warnings
import weakref
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from .. import cache as _numba_cache
from .. import layout as _tree
from .. import measures as _measures
from .. import quantities as _configuration
from .. import recursions as _recursions
from ..folders import CacheWarning, cache_dir
from ..layout import BODY_FIELDS, Arrays, Tree, work_size
from ..threads import range_count, run_kernel, threads_for
from . import lanes as _lanes
from . import trace as _trace
from .lanes import LANES
from .trace import ENTRY_POINTS, Graph, Sym, traced

__all__ = [
    "AUTO_AFTER",
    "AUTO_ENV",
    "KINDS",
    "SINCOS",
    "WRENCH_KINDS",
    "account",
    "auto_enabled",
    "emit",
    "find",
    "layout",
    "load",
    "measured",
    "set_auto",
    "specialise",
    "structure_key",
    "trace",
    "wait_for_auto",
]

logger = logging.getLogger("freefloat")

#: What can be specialised: J* of a batch of configurations, RK4 rollouts (their state derivative), H+, forward
#: dynamics and inverse dynamics (C+ - Q); the last three with or without external wrenches (:data:`WRENCH_KINDS`); and
#: the measures of J* (det, smallest singular value, manipulability, condition number of chosen rows: :func:`measured`).
KINDS = ("jstar", "rollout", "hplus", "forward", "inverse", "measure")
#: The kinds that map a batch of inputs to a batch of outputs (lane by lane: :func:`~.lanes.map_blocks`).
MAPS = ("jstar", "hplus", "forward", "inverse")
#: The kinds that take external wrenches: each layout of wrenches (:func:`layout`) is specialised apart.
WRENCH_KINDS = ("rollout", "forward", "inverse")

#: The layout of external wrenches: one (body, frame code) pair per wrench (the engine's ext_i rows; part of the
#: structure: folded into the code). Their values (point, force, couple) are inputs.
Layout = tuple[tuple[int, int], ...]


def layout(ext_i: np.ndarray) -> Layout:
    """The layout of the external wrenches ext_i (W, 2) = [body, frame code] (:data:`Layout`; () for none)."""
    return tuple((int(b), int(f)) for b, f in np.asarray(ext_i, dtype=np.int64).reshape(-1, 2))


def wrench_inputs(kind: str, wrenches: Layout) -> int:
    """Inputs per configuration of the map ``kind`` beyond those without them (:func:`map_parts`) for the wrenches
    ``wrenches``: their values (9 each: point, force, couple)."""
    return 9 * len(wrenches)


#: sin and cos of one angle without calls (vectorisable): the reduction by the nearest multiple k
#: of pi/2 in four parts (Cody-Waite; the first two products exact for |k| < 2^20), then fdlibm's minimax
#: polynomials of sin and cos on [-pi/4, pi/4] (``__kernel_sin``, ``__kernel_cos``), then the
#: quadrant k mod 4. Placeholders: {x} the angle, {sin} and {cos} the results, {t} a prefix.
SINCOS = """\
{t}k = math.floor({x} * 0.6366197723675814 + 0.5)
{t}r = (({x} - {t}k * 1.5707963267341256) - {t}k * 6.077100506303966e-11) - {t}k * 2.0222662487111665e-21
{t}r = {t}r - {t}k * 8.4784276603688996e-32
{t}z = {t}r * {t}r
{t}a = 2.7557313707070068e-06 + {t}z * (-2.5050760253406863e-08 + {t}z * 1.5896909952115501e-10)
{t}s = {t}r + {t}z * {t}r * (-0.16666666666666632 + {t}z * (8.33333333332248946124e-03 + {t}z * (-0.00019841269829857949 + {t}z * {t}a)))
{t}h = 0.5 * {t}z
{t}w = 1.0 - {t}h
{t}b = -2.7557314351390663e-07 + {t}z * (2.0875723212981748e-09 + {t}z * -1.1359647557788195e-11)
{t}b = 0.041666666666666602 + {t}z * (-0.0013888888888874110 + {t}z * (2.4801587289476729e-05 + {t}z * {t}b))
{t}c = {t}w + (((1.0 - {t}w) - {t}h) + {t}z * {t}z * {t}b)
{t}n = {t}k - 4.0 * math.floor({t}k * 0.25)
{sin} = ({t}c if {t}n == 1.0 or {t}n == 3.0 else {t}s) * (-1.0 if {t}n >= 2.0 else 1.0)
{cos} = ({t}s if {t}n == 1.0 or {t}n == 3.0 else {t}c) * (-1.0 if {t}n == 1.0 or {t}n == 2.0 else 1.0)
"""


# ----------------------------------------------------------------- tracing
def data_vector(t: Tree) -> np.ndarray:
    """The model's data as the kernels read it: the model's float buffer (:func:`freefloat.engine.layout.arrays`)."""
    return t.floats


def _symbolic_model(t: Tree, g: Graph) -> Any:
    """The model's :data:`freefloat.engine.layout.Arrays` with the structure as numbers and the data as inputs "data"
    (slots of ``t.floats``): every body field of role "data" in :data:`freefloat.engine.layout.BODY_FIELDS`, the total mass and the
    end-effector points."""
    fields: dict[str, np.ndarray] = {}
    for f in BODY_FIELDS:
        values = t.fields[f.name]
        sym = np.array([float(v) for v in values.ravel()], dtype=object).reshape(values.shape)
        if f.role == "data":
            start = t.field_offset(f.name)
            flat = values.ravel()
            sym = np.array(
                [0.0 if f.fold_zeros and flat[i] == 0.0 else g.input("data", start + i) for i in range(values.size)], dtype=object
            ).reshape(values.shape)
        fields[f.name] = sym
    total_at, points_at = t.field_offset("total_mass"), t.field_offset("ee_point")
    points = np.array([g.input("data", points_at + i) for i in range(t.ee_point.size)], dtype=object).reshape(t.ee_point.shape)
    views: dict[str, Any] = {"parent": _ints(t.parent), "ancestor": _ints(t.ancestor), "ee_body": _ints(t.ee_body), **fields}
    views.update(total_mass=g.input("data", total_at), ee_point=points, n_joints=t.n_joints)
    return Arrays(**views)


def _ints(a: np.ndarray) -> np.ndarray:
    return np.array([int(v) for v in a.ravel()], dtype=object).reshape(a.shape)


def trace(t: Tree, kind: str, wrenches: Layout = ()) -> tuple[Graph, list[Any], int]:
    """The graph of one configuration of ``kind`` for the structure of ``t``: (graph, outputs, inputs per lane).

    Inputs "W" rows: "jstar" q (N); "rollout" the flat state x (S = ``t.state_size``: with the dissipated energy when
    a joint has damping or friction) then u (N + 6). Outputs: "jstar" J* (6E x N, row-major); "rollout" dx/dt (S: with
    the dissipated power, the engine's, when x has that slot). Guards: the Cholesky pivots.
    ``wrenches`` (kinds :data:`WRENCH_KINDS`): the external wrenches' layout (:func:`layout`: bodies and frames,
    numbers while tracing); their values ext_f (W x 9) are inputs: of a map, the rows after its other inputs
    (:func:`wrench_inputs`); of a rollout, the rows after the rollout loop's buffer (:func:`~.lanes.rollout_rows`),
    filled once per block of trajectories (a trajectory's wrenches are constant).
    """
    if wrenches and kind not in WRENCH_KINDS:
        raise ValueError(f"freefloat: the kind {kind!r} takes no external wrenches (those that do: {WRENCH_KINDS})")
    mod = traced()
    g = Graph()
    m = _symbolic_model(t, g)
    nb = t.n_bodies
    n = t.n_joints
    work = np.full(work_size(nb, t.ee_body.shape[0]), 0.0, dtype=object)
    s = mod.recursions.scratch(work, nb, t.ee_body.shape[0], n)
    ext_i = np.array(wrenches, dtype=object).reshape(len(wrenches), 2)

    def ext_f(first: int) -> np.ndarray:  # the wrenches' values, W rows from ``first`` on
        return np.array([g.input("W", first + i) for i in range(9 * len(wrenches))], dtype=object).reshape(len(wrenches), 9)

    if kind == "jstar":
        q = np.array([g.input("W", j) for j in range(n)], dtype=object)
        out = np.full((6 * t.ee_body.shape[0], n), 0.0, dtype=object)
        getattr(mod.configuration, ENTRY_POINTS["jstar"])(q, m, s, out)
        return g, list(out.ravel()), n
    if kind == "rollout":
        size = t.state_size
        x = np.array([g.input("W", i) for i in range(size)], dtype=object)
        u = np.array([g.input("W", size + j) for j in range(n + 6)], dtype=object)
        dx = np.full((1, size), 0.0, dtype=object)
        ext = ext_f(_lanes.rollout_rows(size, n + 6))
        ok = getattr(mod.configuration, ENTRY_POINTS["rollout"])(x, u, m, ext_i, ext, s, dx, 0)
        if ok is not True:  # a pivot that folded to a number <= 0: the structure itself is singular
            raise AssertionError("freefloat: the traced state derivative failed on numbers alone")
        return g, list(dx.ravel()), size + n + 6
    if kind == "hplus":
        q = np.array([g.input("W", j) for j in range(n)], dtype=object)
        out = np.full((6 + n, 6 + n), 0.0, dtype=object)
        getattr(mod.configuration, ENTRY_POINTS["hplus"])(q, m, s, out)
        return g, list(out.ravel()), n
    if kind == "forward":  # inputs q (N), zdot0 (6 + N), u (N + 6), T0 (9), ext_f (9W); outputs zddot0 (6 + N), then the guards' row
        w = [g.input("W", j) for j in range(sum(map_parts("forward", n)))]
        q, vel = np.array(w[:n], dtype=object), np.array(w[n : 6 + 2 * n], dtype=object)
        u, t0 = np.array(w[6 + 2 * n : 12 + 3 * n], dtype=object), np.array(w[12 + 3 * n :], dtype=object).reshape(3, 3)
        out = np.full(6 + n, 0.0, dtype=object)
        getattr(mod.configuration, ENTRY_POINTS["forward"])(q, vel, u, t0, m, ext_i, ext_f(len(w)), s, out)
        return g, list(out), len(w) + wrench_inputs(kind, wrenches)
    if kind == "inverse":
        # inputs q (N), zdot0 (6 + N), zddot0 (6 + N), u (N + 6), T0 (9) [, ext_f (9W)]; outputs H+ zddot0 + C+ - Q (6 + N)
        w = [g.input("W", j) for j in range(sum(map_parts("inverse", n)))]
        q, vel = np.array(w[:n], dtype=object), np.array(w[n : 6 + 2 * n], dtype=object)
        acc, u = np.array(w[6 + 2 * n : 12 + 3 * n], dtype=object), np.array(w[12 + 3 * n : 18 + 4 * n], dtype=object)
        t0 = np.array(w[18 + 4 * n :], dtype=object).reshape(3, 3)
        out = np.full(6 + n, 0.0, dtype=object)
        getattr(mod.configuration, ENTRY_POINTS["inverse"])(q, vel, acc, True, u, t0, m, ext_i, ext_f(len(w)), s, out)
        return g, list(out), len(w) + wrench_inputs(kind, wrenches)
    raise ValueError(f"freefloat: no specialised kernel of kind {kind!r}; the kinds are {KINDS}")


def trace_reduction(k_rows: int, n: int) -> tuple[Graph, list[Any], int]:
    """The graph of the engine's reduction (``measures._reduce_views``) for the smallest singular value of
    K = ``k_rows`` rows of N = ``n`` columns, one configuration: (graph, outputs, inputs). Inputs "W": the K N entries,
    row-major; outputs: the reduced rows that ``measures._finish_views`` reads for it (the product of the
    singular values, the 2r - 1 rows of the tridiagonal matrix; r = min(K, N))."""
    mod = traced()
    g = Graph()
    matrix = np.array([[g.input("W", i)] for i in range(k_rows * n)], dtype=object)
    work = np.full((_measures.measure_work.py_func(n), 1), 0.0, dtype=object)
    mod.configuration._reduce_views(matrix, work, n, _ints(np.arange(k_rows)), _measures.MEASURE_CODES["sigma_min"])
    return g, [work[i, 0] for i in range(2 * min(k_rows, n))], k_rows * n


# ----------------------------------------------------------------- code
def emit(g: Graph, outputs: list[Any], n_in: int, name: str = "lane") -> tuple[str, list[int]]:
    """Python source of ``name(W, P)``: the live nodes of ``g`` over LANES configurations, and the data slots.

    W holds n_in input rows, then one row per output, then (when the graph has guards) a row that
    is multiplied by 1.0 where every guard holds and 0.0 elsewhere. P[i] = data[slots[i]]. Lane
    inputs are read in the loop; data is read once, before it.
    """
    roots = [o.index for o in outputs if isinstance(o, Sym)] + list(g.guards)
    keep = g.live(roots)
    slots: list[int] = []
    before: list[str] = []
    body: list[str] = []
    done: set[int] = set()

    def ref(a: Any) -> str:
        return f"v{a}" if isinstance(a, int) else repr(float(a))

    for i, op in enumerate(g.ops):
        if not keep[i]:
            continue
        a = g.args[i]
        if op == "in":
            if a[0] == "W":
                body.append(f"v{i} = W[{a[1] * LANES} + i]")
            else:
                before.append(f"v{i} = P[{len(slots)}]")
                slots.append(a[1])
        elif op in ("sin", "cos"):
            x = a[0]
            if x in done:
                continue
            done.add(x)
            sin, cos = g.find("sin", x), g.find("cos", x)
            text = SINCOS.format(
                x=ref(x),
                t=f"t{x}",
                sin=f"v{sin}" if sin is not None and keep[sin] else f"t{x}sin",
                cos=f"v{cos}" if cos is not None and keep[cos] else f"t{x}cos",
            )
            body.extend(text.splitlines())
        elif op == "neg":
            body.append(f"v{i} = -{ref(a[0])}")
        elif op in ("sqrt", "tanh"):
            body.append(f"v{i} = math.{op}({ref(a[0])})")
        elif op == ">":
            body.append(f"v{i} = 1.0 if {ref(a[0])} > {ref(a[1])} else 0.0")
        elif op == "pick":
            body.append(f"v{i} = {ref(a[2])} if {ref(a[0])} > {ref(a[1])} else {ref(a[3])}")
        else:
            body.append(f"v{i} = {ref(a[0])} {op} {ref(a[1])}")
    for r, o in enumerate(outputs):
        body.append(f"W[{(n_in + r) * LANES} + i] = {ref(o.index) if isinstance(o, Sym) else ref(o)}")
    if g.guards:
        ok = " * ".join(f"v{k}" for k in g.guards)
        body.append(f"W[{(n_in + len(outputs)) * LANES} + i] *= {ok}")
    lines = [f"def {name}(W, P):  # pragma: no cover - compiled", *("    " + s for s in before), f"    for i in range({LANES}):"]
    lines += ["        " + s for s in body]
    return "\n".join(lines) + "\n", slots


def gather_source(columns: list[int]) -> str:
    """Python source of ``gather(W, dst, at, first, last)`` (:func:`~.lanes.map_blocks`): the outputs of the lanes
    first..last of W into ``dst[at:]``, a configuration's row (``columns`` values: column c from the lane row columns[c])
    after another. The rows are constant offsets: more than twice as fast as reading the rows from an array."""
    lines = ["def gather(W, dst, at, first, last):  # pragma: no cover - compiled", "    for i in range(first, last):"]
    lines.append(f"        o = at + (i - first) * {len(columns)}")
    lines += [f"        dst[o + {c}] = W[{row * LANES} + i]" for c, row in enumerate(columns)]
    return "\n".join(lines) + "\n"


def distinct(outputs: list[Any]) -> tuple[list[Any], list[int]]:
    """The distinct values of ``outputs`` (nodes and numbers, first seen first) and, for each output, its index among
    them: a map's lane kernel writes each value once (H+ (6 + N)^2 outputs: (3 + N)(4 + N) / 2 distinct entries of its
    symmetric block, its mass and a zero) and its driver copies a row into every column that holds it."""
    index: dict[tuple[str, Any], int] = {}
    values: list[Any] = []
    where = []
    for o in outputs:
        key = ("node", o.index) if isinstance(o, Sym) else ("number", repr(float(o)))  # 0.0 and -0.0 apart
        if key not in index:
            index[key] = len(values)
            values.append(o)
        where.append(index[key])
    return values, where


#: Each kind's one driver, ``blocks(<its arguments>, W, first, last)``: the blocks first..last of a batch, W a scratch
#: buffer (ROWS x LANES); (its arguments, the body). A large batch runs it on one
#: contiguous range of blocks per thread (:func:`_run`, :func:`freefloat.engine.threads.run_kernel`): no threaded twin is
#: compiled.
_DRIVERS = {
    "map": (
        "parts, P, OUT, rows",
        "    _lanes.map_blocks(lane, gather, parts, P, OUT, rows, W, first, last)\n",
    ),
    "measure": (
        "Q, P, rows, kind, OUT",
        "    measure_blocks(Q, P, rows, kind, OUT, W, first, last)\n",
    ),
    "rollout": (
        "P, X0, dt, steps, hold, stride, C, lim, XS, US, SAT, DONE, EXT",
        "    for block in range(first, last):\n"
        "        _lanes.block_rows(EXT, W, EXT_AT, block)  # the block's external wrenches (EXT (K, 9W); W = 0: none)\n"
        "        rollout_blocks(P, LANES, block, block + 1, X0, dt, steps, hold, stride, C, lim, XS, US, SAT, DONE, W)\n",
    ),
}
#: What a kind's module defines before its driver.
_PRELUDE = {
    "map": "",
    "measure": """
from freefloat.engine.measures import jacobian_measure_lanes, measure_finish_lanes  # the engine's measures, written once

# the engine's measure after this lane kernel, on each block (compiled once for every structure: not inlined), or
# the traced reduction above and the engine's finish (the smallest singular value of all the rows of J*)
measure_blocks = _lanes.measure_loop(lane, jacobian_measure_lanes, reduce, measure_finish_lanes, {n}, {k}, {work}, "specialised")
""",
    "rollout": """
_, rollout_blocks = _lanes.bound_loops(lane, "specialised")  # the one rollout loop, with this lane kernel inlined
""",
}
_BLOCKS = """

@kernel()
def blocks({args}, W, first, last):  # pragma: no cover - compiled
{body}"""


def source(t: Tree, kind: str, wrenches: Layout = ()) -> tuple[str, list[int], int]:
    """The generated module of ``kind`` (with the external wrenches ``wrenches``) for the structure of ``t``: (source,
    data slots, rows of W). The measures: J*'s lane kernel, then the engine's measure."""
    g, outputs, n_in = trace(t, "jstar" if kind == "measure" else kind, wrenches)
    columns: list[int] = []
    if kind in MAPS:  # each distinct value in one row: H+'s symmetric entries and its zeros once
        outputs, where = distinct(outputs)
        columns = [n_in + k for k in where] + ([n_in + len(outputs)] if g.guards else [])
    lane, slots = emit(g, outputs, n_in)
    if kind in MAPS:
        lane += '\n\n@kernel(inline="always")\n' + gather_source(columns)
    if kind == "measure":  # the smallest singular value of all the rows of J*: the engine's reduction, traced
        reduction, reduced, k_n = trace_reduction(6 * t.ee_body.shape[0], t.n_joints)  # K = 6E rows: {k} below
        lane += "\n\n@kernel()\n" + emit(reduction, reduced, k_n, "reduce")[0]
    ext_at = 0
    if kind in MAPS:
        rows = n_in + len(outputs) + 1  # then the guards' row (lanes.map_blocks)
    elif kind == "measure":
        rows = n_in + len(outputs) + _measures.measure_work.py_func(t.n_joints)  # then the measure's work space
    else:
        size = t.state_size
        ext_at = _lanes.rollout_rows(size, t.n_joints + 6)  # the W layout of lanes._rollout_blocks, then the wrenches
        rows = ext_at + 9 * len(wrenches)
    head = (
        f'"""freefloat: {kind} specialised for one model structure (generated by freefloat.engine.specialise.build; do not edit)."""\n\n'
        "import math\n\nimport numpy as np\n\n"
        "from freefloat.engine.specialise import lanes as _lanes\nfrom freefloat.engine.specialise.lanes import LANES\n"
        "from freefloat.engine.cache import kernel\n\n"
        f"SLOTS = {slots!r}\nROWS = {rows}\nWRENCHES = {wrenches!r}\nEXT_AT = {ext_at}\n"
        f"COLUMNS = np.array({columns!r}, dtype=np.int64)\n"
        + (f"STATE = {t.state_size}  # the length of the flat state (with the dissipated energy or without)\n" if kind == "rollout" else "")
        + "\n\n@kernel()\n"
    )
    guarded = f"GUARDED = {bool(g.guards)}\n\n\n"
    group = "map" if kind in MAPS else kind
    arguments, body = _DRIVERS[group]
    drivers = _PRELUDE[group].replace("{n}", str(t.n_joints)).replace("{work}", str(_measures.measure_work.py_func(t.n_joints)))
    drivers = drivers.replace("{k}", str(6 * t.ee_body.shape[0]))
    drivers += _BLOCKS.format(args=arguments, body=body)
    return (
        head.replace("\n\n\n@kernel()\n", "\n" + guarded + "@kernel()\n") + lane + drivers,
        slots,
        rows,
    )


# ----------------------------------------------------------------- the cache of structures
@functools.cache
def _engine_key() -> str:
    digest = hashlib.sha256()
    for module in (
        _trace,
        sys.modules[__name__],
        _lanes,
        _recursions,
        _measures,
        _configuration,
        _tree,
        _numba_cache,
    ):  # what a kernel is made of
        digest.update(Path(str(module.__file__)).read_bytes())
    return digest.hexdigest()[:12]


def structure_key(t: Tree, kind: str, wrenches: Layout = ()) -> str:
    """What the specialised kernels depend on: the tree, joint types, placements and axes, the end-effector bodies, and
    the layout of the external wrenches (their bodies and frames; none: the key has no wrench part)."""
    digest = hashlib.sha256(f"{kind}:{LANES}:{_engine_key()}".encode())
    structure = [t.fields[f.name] for f in BODY_FIELDS if f.role == "structure"]
    structure += [t.fields[f.name] != 0.0 for f in BODY_FIELDS if f.fold_zeros]  # where the folded fields are zero
    for arr in (t.ints, *structure):
        digest.update(str(arr.shape).encode())
        digest.update(np.ascontiguousarray(arr).tobytes())
    if wrenches:
        digest.update(f"wrenches:{wrenches!r}".encode())
        return f"{kind}_{t.n_joints}j_{len(wrenches)}w_{digest.hexdigest()[:20]}"
    return f"{kind}_{t.n_joints}j_{digest.hexdigest()[:20]}"


#: Where generated modules are kept (None: ``specialised`` next to the generic kernels' cache); tests set their own.
FOLDER: list[Path | None] = [None]


def _folder() -> Path:
    return FOLDER[0] or cache_dir() / "specialised"  # per numba version and engine source, like the generic kernels


_LOADED: dict[str, types.ModuleType] = {}
_LOCK = threading.Lock()


def _import(path: Path, key: str) -> types.ModuleType:
    spec = importlib.util.spec_from_file_location(f"freefloat_specialised_{key}", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # numba's cache finds the kernels' module by name
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[spec.name]
        raise
    return module


@functools.cache
def _private_folder() -> Path:
    """One temporary folder per process for generated modules when the cache folder cannot be written."""
    return Path(tempfile.mkdtemp(prefix="freefloat-specialised-"))


def _write(path: Path, text: str) -> Path:
    """Write a generated module to ``path`` atomically (a temporary file renamed: a process starting at the same
    time sees no file or the whole one); if the cache folder cannot be written, to a private temporary folder
    (with a warning: it is then compiled again in every process)."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
        with os.fdopen(fd, "w") as f:
            f.write(text)
        os.replace(tmp, path)
        return path
    except OSError as exc:
        warnings.warn(
            f"freefloat: cannot write the specialised kernel to {path.parent} ({type(exc).__name__}: {exc}); "
            "compiling it from a temporary folder (again in every process; set FREEFLOAT_CACHE_DIR to a writable folder)",
            CacheWarning,
            stacklevel=4,
        )
        other = _private_folder() / path.name
        other.write_text(text)
        return other


def load(t: Tree, kind: str, *, build: bool, wrenches: Layout = ()) -> types.ModuleType | None:
    """The generated module of ``kind`` (with the external wrenches ``wrenches``) for ``t``'s structure: in memory, else
    from the cache folder, else (``build``) generated, written there (atomically: a temporary file renamed) and
    imported; None if absent."""
    key = structure_key(t, kind, wrenches)
    found = _LOADED.get(key)
    if found is not None:
        return found
    with _LOCK:
        found = _LOADED.get(key)
        if found is not None:
            return found
        path = _folder() / f"{key}.py"
        module = None
        if path.exists():
            try:
                module = _import(path, key)
            except Exception as exc:  # a broken cache file costs a warning, never a traceback
                warnings.warn(
                    f"freefloat: the specialised kernel {path} is broken ({type(exc).__name__}: {exc}); "
                    + ("generating it again" if build else "using the generic kernels (run specialise again to rebuild it)"),
                    CacheWarning,
                    stacklevel=3,
                )  # the file stays: only a process that builds replaces it (atomically), never one that reads
        if module is None:
            if not build:
                return None
            text, _, _ = source(t, kind, wrenches)
            module = _import(_write(path, text), key)
        _LOADED[key] = module
        return module


#: Per model tree, kind and wrench layout: the specialised module, or None (looked up once per tree; cleared by
#: :func:`specialise`).
_FOUND: weakref.WeakKeyDictionary[Tree, dict[tuple[str, Layout], types.ModuleType | None]] = weakref.WeakKeyDictionary()
#: False inside :func:`generic` (benchmarks and tests compare the two paths).
_ENABLED = [True]


def find(t: Tree, kind: str, wrenches: Layout = ()) -> types.ModuleType | None:
    """The specialised module of ``kind`` (with the external wrenches ``wrenches``) for ``t``'s structure if
    :func:`specialise` made it (in any process); else None."""
    if not _ENABLED[0]:
        return None
    memo = _FOUND.setdefault(t, {})
    if (kind, wrenches) not in memo:
        memo[kind, wrenches] = load(t, kind, build=False, wrenches=wrenches)
    return memo[kind, wrenches]


# ----------------------------------------------------------------- automatic specialisation
#: Seconds of generic-kernel work on one model structure (in this process) after which that structure is specialised
#: in the background: about half the compile time of each kind (:data:`COMPILE_TIME`). Waiting until the work done
#: equals the cost of the compile spends at most twice the best choice made knowing the future work (the ski-rental
#: rule), and a one-off call never pays for a compile. The compile runs on one core while the calls go on, so on two
#: cores it costs them about half its time (less with more cores); and its result serves every later process on the
#: machine. (The full compile time as the threshold made the sweeps of benchmarks/bench_sweep.py slower: the history
#: is in benchmarks/README.md.)
AUTO_AFTER = {"jstar": 1.5, "rollout": 4.0, "hplus": 1.5, "forward": 3.0, "inverse": 2.5, "measure": 4.0}
#: What each kind usually takes to compile, once per machine (the paper systems and the 7-DOF arm; docs/performance.md).
#: The notice of an automatic specialisation quotes it.
COMPILE_TIME = {
    "jstar": "2-5 s",
    "rollout": "4-12 s",
    "hplus": "a few seconds",
    "forward": "3-10 s",
    "inverse": "3-10 s",
    "measure": "5-10 s",
}
#: The environment variable that turns automatic specialisation off ("0", "false", "no" or "off").
AUTO_ENV = "FREEFLOAT_AUTO_SPECIALISE"
_AUTO = [True]
#: Per model tree: seconds of generic work by kind and wrench layout.
_SPENT: weakref.WeakKeyDictionary[Tree, dict[tuple[str, Layout], float]] = weakref.WeakKeyDictionary()
#: Structure keys compiling now or compiled by this process automatically (each is built once).
_STARTED: dict[str, threading.Thread] = {}


#: Automatic specialisations compiling now, in background threads (:func:`leave_a_core`).
COMPILING = [0]


@contextlib.contextmanager
def leave_a_core() -> Iterator[None]:
    """Within: this thread's numba calls run on one thread fewer (at least one), leaving a core to the background
    compile (entered by the engine's calls while :data:`COMPILING`). The compile then finishes sooner, and the calls
    going on meanwhile are as fast (the compile holds the GIL and a core either way)."""
    import numba

    before = numba.get_num_threads()
    numba.set_num_threads(max(1, before - 1))  # numba's thread count is per calling thread
    try:
        yield
    finally:
        numba.set_num_threads(before)


_NO_COMPILE = contextlib.nullcontext()


def sharing() -> contextlib.AbstractContextManager[None]:
    """:func:`leave_a_core` while a background compile runs (:data:`COMPILING`), else nothing: what every engine call
    of a batch runs in."""
    return leave_a_core() if COMPILING[0] else _NO_COMPILE


def auto_enabled() -> bool:
    """Whether automatic specialisation is on: :func:`set_auto` and the environment variable :data:`AUTO_ENV`."""
    return _AUTO[0] and os.environ.get(AUTO_ENV, "1").strip().lower() not in ("0", "false", "no", "off")


def set_auto(on: bool) -> None:
    """Turn automatic specialisation on or off for this process."""
    _AUTO[0] = bool(on)


def account(t: Tree, kind: str, seconds: float, wrenches: Layout = ()) -> None:
    """Count ``seconds`` of generic work of ``kind`` (with the external wrenches ``wrenches``) on ``t``'s structure; past
    :data:`AUTO_AFTER`, specialise it in a background thread (once per structure, layout and process; the kernels then
    serve every later call and process)."""
    if not _ENABLED[0] or not auto_enabled():
        return
    spent = _SPENT.setdefault(t, {})
    total = spent[kind, wrenches] = spent.get((kind, wrenches), 0.0) + seconds
    if total < AUTO_AFTER[kind]:
        return
    key = structure_key(t, kind, wrenches)
    with _LOCK:
        if key in _STARTED:
            return
        worker = threading.Thread(target=_auto_build, args=(t, kind, total, wrenches), name=f"freefloat-specialise-{kind}", daemon=True)
        _STARTED[key] = worker
    worker.start()


def _auto_build(t: Tree, kind: str, spent: float, wrenches: Layout = ()) -> None:
    from ...core.feedback import notice

    what = {
        "jstar": "J*",
        "rollout": "the rollouts",
        "hplus": "H+",
        "forward": "forward dynamics",
        "inverse": "inverse dynamics",
        "measure": "the measures of J*",
    }[kind]
    if wrenches:
        what += f" with {len(wrenches)} external wrench{'es' if len(wrenches) > 1 else ''}"
    notice(
        f"specialising {what} for this model structure in the background after {spent:.3g} s of work on the generic kernels "
        f"({COMPILE_TIME[kind]} to compile, once per machine, kept in {_folder()}; the calls go on meanwhile); "
        f"set {AUTO_ENV}=0 to turn this off"
    )
    start = time.perf_counter()

    def ready(_: str) -> None:
        logger.info("specialised %s for this model structure in %.3g s: later calls use it", what, time.perf_counter() - start)

    with _LOCK:
        COMPILING[0] += 1
    try:
        specialise(t, (kind,), wrenches=wrenches, ready=ready)
    except Exception as exc:  # a failed background compile must never disturb the user's work: the generic kernels stay
        warnings.warn(
            f"freefloat: automatic specialisation of {what} failed ({type(exc).__name__}: {exc}); the generic kernels stay",
            CacheWarning,
            stacklevel=1,
        )
        return
    finally:
        with _LOCK:
            COMPILING[0] -= 1


def wait_for_auto(timeout: float | None = None) -> bool:
    """Wait for the automatic specialisations started in this process; True when none is still running."""
    for worker in list(_STARTED.values()):
        worker.join(timeout)
    return not any(w.is_alive() for w in _STARTED.values())


@contextlib.contextmanager
def generic() -> Iterator[None]:
    """Within: every call runs on the generic kernels, specialised or not (to compare the two).

    A switch of the whole process, for tests and benchmarks: not meant for threads that overlap.
    """
    before = _ENABLED[0]
    _ENABLED[0] = False
    try:
        yield
    finally:
        _ENABLED[0] = before


def _warm(module: types.ModuleType, t: Tree, kind: str, wrenches: Layout = ()) -> None:
    """Compile (or load from numba's cache) a module's driver ``blocks`` on a tiny batch."""
    data = data_vector(t)[module.SLOTS]
    n = t.n_joints
    if kind in MAPS:
        parts = [np.zeros((1, width)) for width in map_parts(kind, n, wrenches)]
        if kind == "forward":
            parts[5][0, ::4] = 1.0  # T0 = 1
        args: tuple[Any, ...] = (tuple(parts), data, np.empty(module.COLUMNS.shape[0]), module.COLUMNS)
    elif kind == "measure":
        args = (np.zeros((1, n)), data, np.zeros(1, dtype=np.int64), 1, np.empty(1))
    else:
        size = module.STATE
        x0 = np.zeros((1, size))
        x0[0, 9] = 1.0
        zero = np.zeros((1, n))
        args = (data, x0, 1e-3, 1, 1, 1, (zero, zero, zero, zero, _lanes.feed(np.zeros((1, 1, n)))), np.full(n + 6, np.inf))
        args += (np.empty((2, 1, size)), np.empty((2, 1, n + 6)), np.empty((2, 1), dtype=np.bool_), np.empty(1, dtype=np.int64))
        args += (np.zeros((1, 9 * len(wrenches))),)
    _run(module, 1, args, threads=1)


#: A specialised module's calls of this many configurations or more run on several threads: below it, a block of LANES
#: configurations is so quick that handing the ranges to numba's threads (:func:`freefloat.engine.threads.run_kernel`)
#: costs more than a second thread saves (sizes in benchmarks/README.md, Measurement history). Rollouts: from two
#: blocks of trajectories (each a long run).
THREADS_FROM = 8 * LANES


def _run(
    module: types.ModuleType, size: int, args: tuple[Any, ...], *, threads: int | None = None, threads_from: int = THREADS_FROM
) -> None:
    """A module's driver ``blocks`` on a batch of ``size`` (configurations or trajectories) with the arguments ``args``,
    on one contiguous range of blocks per thread where it pays (``threads_from`` rows or more and more than one thread,
    one fewer while a background compile runs: :func:`leave_a_core`), else on every block in the calling thread; the
    scratch buffers made here. ``threads``: that many ranges whatever the size (tests, warming)."""
    if threads is None:
        with sharing():
            _run(module, size, args, threads=threads_for(size, threads_from))
        return
    count = (size + LANES - 1) // LANES
    work = np.empty((range_count(count, threads), module.ROWS * LANES))
    run_kernel(module.blocks, args, work, (), count, threads)


def specialise(
    t: Tree,
    kinds: tuple[str, ...] = KINDS,
    progress: Callable[[str], None] | None = None,
    *,
    wrenches: Layout = (),
    ready: Callable[[str], None] | None = None,
) -> dict[str, str]:
    """Generate and compile the specialised kernels of ``kinds`` for ``t``'s structure (kept on disk); the keys made.

    Per kind: the lane kernel and the driver ``blocks``, from which on the calls use them (``ready(kind)`` is called
    then), on several threads where it pays (:func:`_run`).
    ``wrenches``: the layout of external wrenches (:func:`layout`) the kinds of :data:`WRENCH_KINDS` are made for (the
    other kinds take none: made without)."""
    made = {}
    for kind in kinds:
        if kind not in KINDS:
            raise ValueError(f"freefloat: no specialised kernel of kind {kind!r}; the kinds are {KINDS}")
        if progress is not None:
            progress(kind)
        layout_ = wrenches if kind in WRENCH_KINDS else ()
        module = load(t, kind, build=True, wrenches=layout_)
        assert module is not None
        _warm(module, t, kind, layout_)
        _FOUND.clear()  # the calls use it from now on
        if ready is not None:
            ready(kind)
        made[kind] = structure_key(t, kind, layout_)
    return made


# ----------------------------------------------------------------- calls
def map_parts(kind: str, n: int, wrenches: Layout = ()) -> tuple[int, ...]:
    """The widths of the input parts of the map ``kind`` for N joints and the external wrenches ``wrenches``, in the order
    of its lane rows (what :func:`mapped` takes): "jstar" and "hplus" q (N); "forward" q (N), zdot0 (6 + N),
    u = [tau (N), f_S (3), n_S (3)] in three parts, T0 (9); "inverse" q (N), zdot0 (6 + N), zddot0 (6 + N),
    u (N + 6), T0 (9); then, with wrenches, their values ext_f (9W) (:func:`wrench_inputs`)."""
    parts = {"jstar": (n,), "hplus": (n,), "forward": (n, 6 + n, n, 3, 3, 9), "inverse": (n, 6 + n, 6 + n, n + 6, 9)}[kind]
    return (*parts, wrench_inputs(kind, wrenches)) if wrenches else parts


def mapped(module: types.ModuleType, t: Tree, parts: tuple[np.ndarray, ...], out: np.ndarray) -> None:
    """The outputs of a map kind for C configurations into out (C, outputs [+ 1: the guards, 1.0 where every guard held,
    else 0.0]; C-contiguous) by the specialised kernel (J*: 6E * N of them, row-major; H+: (6 + N)^2). ``parts``: the
    inputs (:func:`map_parts`), each a C-contiguous float64 array (C, width), or (1, width) for a row that every
    configuration shares."""
    if not (out.flags.c_contiguous and out.dtype == np.float64 and out.flags.aligned):
        raise ValueError("freefloat: a specialised map writes into a C-contiguous, aligned float64 array")
    _run(module, out.shape[0], (parts, data_vector(t)[module.SLOTS], out.reshape(-1), module.COLUMNS))


def measured(module: types.ModuleType, t: Tree, q: np.ndarray, rows: np.ndarray, code: int, out: np.ndarray) -> None:
    """out (C,) = the measure ``code`` (:data:`freefloat.engine.measures.MEASURE_CODES`) of the distinct rows ``rows`` (K,) of J*
    at the rows of q (C, N), by the specialised "measure" kernel: J* of a lane block, then the engine's measure."""
    _run(module, q.shape[0], (q, data_vector(t)[module.SLOTS], rows, code, out))


def rollout(module: types.ModuleType, t: Tree, *args: Any) -> None:
    """The rollout loop (``lanes._rollout_blocks``, the generic rollout's loop too) with the specialised lane kernel: the same
    arguments as the generic rollout, less the model, with the wrenches' values (K, 9W) after the outputs (W = 0:
    none; their layout is the module's)."""
    _run(module, args[0].shape[0], (data_vector(t)[module.SLOTS], *args), threads_from=LANES + 1)  # from two blocks
