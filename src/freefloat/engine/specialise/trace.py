"""Trace the engine's one-configuration kernels on symbols: the expression graph a specialiser compiles.

The recursions of :mod:`freefloat.engine.recursions`, :mod:`freefloat.engine.quantities` and
:mod:`freefloat.engine.measures` are plain scalar Python over arrays (numba compiles them as written). Run on
:class:`Sym` values instead of floats, with the model's *structure* (tree, joint types, joint placements and axes) as
numbers and its *data* (mass properties, end-effector points, the state) as symbols, the same source yields the graph
of one configuration for one model structure. Nothing of the physics is written here: this module only knows
arithmetic.

Rules applied while tracing:

* constant folding: an operation on numbers is a number (Python floats, the same IEEE doubles);
* identities, exact in IEEE arithmetic: x + 0 = x, x - 0 = x, 0 - x = -x, x * 1 = x, x * -1 = -x,
  x / 1 = x, -(-x) = x;
* zeros: x * 0 = 0, 0 / x = 0 and x - x = 0. These hold for finite, non-zero x only: an
  intermediate that overflows to inf (values near 1e154 and beyond) or a zero divisor gives NaN in
  the generic kernels, which then report the configuration, and 0 in the specialised ones. The
  engine divides only by the total mass, the determinant of the spacecraft-block of H+ and the
  Cholesky pivots (guarded), none of which is zero for a valid model;
* common subexpressions: an operation on the same operands is the same node (hash-consing; the
  operands of + and * are ordered, which IEEE addition and multiplication do not mind; numbers
  and node indices are told apart in the key);
* dead code: :meth:`Graph.live` keeps only the nodes the outputs (and guards) need.

Branches on a symbol (the positive-pivot test of the Cholesky factorisation) cannot be taken while
tracing: the comparison is recorded as a *guard* (assumed true while tracing, evaluated by the
compiled kernel, which reports the configurations where it fails, as the generic kernel does).
"""

from __future__ import annotations

import functools
import math
import types
from typing import Any

import numpy as np

from .. import layout as _tree
from .. import measures as _measures
from .. import quantities as _configuration
from .. import recursions as _recursions
from ..cache import slice_view

__all__ = ["ENTRY_POINTS", "Graph", "Sym", "traced"]

Number = float


class Graph:
    """Nodes of one trace, in creation order (a topological order). Node i is ``ops[i]``, ``args[i]``.

    ops: ``"in"`` (args = (array name, flat index)), ``"+"``, ``"-"``, ``"*"``, ``"/"``, ``"neg"``,
    ``"sqrt"``, ``"sin"``, ``"cos"``, ``"tanh"``, ``">"`` (a guard's comparison), ``"pick"`` (args (x, y, a, b):
    a if x > y else b, a select); an argument is a node index (int) or a number (float).
    """

    def __init__(self) -> None:
        self.ops: list[str] = []
        self.args: list[tuple[Any, ...]] = []
        self._memo: dict[tuple[Any, ...], int] = {}
        self.guards: list[int] = []

    def node(self, op: str, *args: Any) -> Sym:
        key = _memo_key(op, args)
        found = self._memo.get(key)
        if found is None:
            found = len(self.ops)
            self.ops.append(op)
            self.args.append(args)
            self._memo[key] = found
        return Sym(self, found)

    def find(self, op: str, *args: Any) -> int | None:
        """The node of ``op`` on ``args`` if the trace made it, else None."""
        return self._memo.get(_memo_key(op, args))

    def input(self, name: str, index: int) -> Sym:
        return self.node("in", name, index)

    def live(self, roots: list[int]) -> list[bool]:
        """Which nodes the ``roots`` need (dead-code elimination)."""
        keep = [False] * len(self.ops)
        stack = list(roots)
        while stack:
            i = stack.pop()
            if keep[i]:
                continue
            keep[i] = True
            if self.ops[i] != "in":
                stack.extend(a for a in self.args[i] if isinstance(a, int))
        return keep

    def evaluate(self, inputs: dict[str, np.ndarray], roots: list[int]) -> dict[int, float]:
        """The value of every live node on float ``inputs`` (the reference the tests compare with)."""
        keep = self.live(roots)
        val: dict[int, float] = {}

        def arg(a: Any) -> float:
            return val[a] if isinstance(a, int) else a

        for i, op in enumerate(self.ops):
            if not keep[i]:
                continue
            a = self.args[i]
            if op == "in":
                val[i] = float(np.asarray(inputs[a[0]]).reshape(-1)[a[1]])
            elif op == "neg":
                val[i] = -arg(a[0])
            elif op in ("sqrt", "sin", "cos", "tanh"):
                val[i] = getattr(math, op)(arg(a[0]))
            elif op == "pick":
                val[i] = arg(a[2]) if arg(a[0]) > arg(a[1]) else arg(a[3])
            else:
                x, y = arg(a[0]), arg(a[1])
                val[i] = _BINARY[op](x, y)
        return val


_BINARY = {
    "+": lambda x, y: x + y,
    "-": lambda x, y: x - y,
    "*": lambda x, y: x * y,
    "/": lambda x, y: x / y,
    ">": lambda x, y: float(x > y),
}


def _memo_key(op: str, args: tuple[Any, ...]) -> tuple[Any, ...]:
    """The hash-consing key of a node: node indices and numbers tagged apart (Python has 2 == 2.0), and -0.0 apart from 0.0."""
    return (op, *(("n", a) if isinstance(a, int) else ("c", a, math.copysign(1.0, a)) if isinstance(a, float) else a for a in args))


def _key(a: Any) -> tuple[int, Any]:
    return (0, a.index) if isinstance(a, Sym) else (1, a)


def _raw(a: Any) -> Any:
    return a.index if isinstance(a, Sym) else float(a)


def _is(a: Any, value: float) -> bool:
    return not isinstance(a, Sym) and a == value


class Sym:
    """A value of a trace: node ``index`` of ``graph``. Arithmetic with numbers and other symbols folds as above."""

    __slots__ = ("graph", "index")

    def __init__(self, graph: Graph, index: int) -> None:
        self.graph = graph
        self.index = index

    # -- the rules
    @staticmethod
    def add(x: Any, y: Any) -> Any:
        if not isinstance(x, Sym) and not isinstance(y, Sym):
            return float(x) + float(y)
        if _is(x, 0.0):
            return y
        if _is(y, 0.0):
            return x
        g = x.graph if isinstance(x, Sym) else y.graph
        a, b = sorted((x, y), key=_key)
        return g.node("+", _raw(a), _raw(b))

    @staticmethod
    def sub(x: Any, y: Any) -> Any:
        if not isinstance(x, Sym) and not isinstance(y, Sym):
            return float(x) - float(y)
        if _is(y, 0.0):
            return x
        if _is(x, 0.0):
            return Sym.neg(y)
        if isinstance(x, Sym) and isinstance(y, Sym) and x.index == y.index:
            return 0.0
        g = x.graph if isinstance(x, Sym) else y.graph
        return g.node("-", _raw(x), _raw(y))

    @staticmethod
    def mul(x: Any, y: Any) -> Any:
        if not isinstance(x, Sym) and not isinstance(y, Sym):
            return float(x) * float(y)
        if _is(x, 0.0) or _is(y, 0.0):
            return 0.0
        if _is(x, 1.0):
            return y
        if _is(y, 1.0):
            return x
        if _is(x, -1.0):
            return Sym.neg(y)
        if _is(y, -1.0):
            return Sym.neg(x)
        g = x.graph if isinstance(x, Sym) else y.graph
        a, b = sorted((x, y), key=_key)
        return g.node("*", _raw(a), _raw(b))

    @staticmethod
    def div(x: Any, y: Any) -> Any:
        if not isinstance(x, Sym) and not isinstance(y, Sym):
            return float(x) / float(y)
        if _is(y, 1.0):
            return x
        if _is(x, 0.0):
            return 0.0
        g = x.graph if isinstance(x, Sym) else y.graph
        return g.node("/", _raw(x), _raw(y))

    @staticmethod
    def neg(x: Any) -> Any:
        if not isinstance(x, Sym):
            return -float(x)
        g = x.graph
        if g.ops[x.index] == "neg":
            return Sym(g, g.args[x.index][0])
        return g.node("neg", x.index)

    # -- Python's operators
    def __add__(self, o: Any) -> Any:
        return Sym.add(self, o)

    def __radd__(self, o: Any) -> Any:
        return Sym.add(o, self)

    def __sub__(self, o: Any) -> Any:
        return Sym.sub(self, o)

    def __rsub__(self, o: Any) -> Any:
        return Sym.sub(o, self)

    def __mul__(self, o: Any) -> Any:
        return Sym.mul(self, o)

    def __rmul__(self, o: Any) -> Any:
        return Sym.mul(o, self)

    def __truediv__(self, o: Any) -> Any:
        return Sym.div(self, o)

    def __rtruediv__(self, o: Any) -> Any:
        return Sym.div(o, self)

    def __neg__(self) -> Any:
        return Sym.neg(self)

    def __pos__(self) -> Sym:
        return self

    def __gt__(self, o: Any) -> _Guard:
        return _Guard(self.graph, self, o)

    def __lt__(self, o: Any) -> _Guard:
        return _Guard(self.graph, o, self)

    def __bool__(self) -> bool:
        raise TypeError("freefloat: a branch on a traced value (only comparisons may be traced, as guards)")

    def __eq__(self, o: object) -> bool:
        raise TypeError("freefloat: == on a traced value (only > and < may be traced, as guards)")

    def __ne__(self, o: object) -> bool:
        raise TypeError("freefloat: != on a traced value (only > and < may be traced, as guards)")

    __hash__ = None  # type: ignore[assignment]

    def __float__(self) -> float:
        raise TypeError("freefloat: a traced value has no number")


class _Guard:
    """``a > b`` on a symbol: true while tracing; recorded so that the kernel checks it."""

    def __init__(self, graph: Graph, a: Any, b: Any) -> None:
        self.graph, self.a, self.b = graph, a, b

    def __bool__(self) -> bool:
        g = self.graph
        node = g.node(">", _raw(self.a), _raw(self.b)) if isinstance(self.a, Sym) else g.node(">", float(self.a), _raw(self.b))
        g.guards.append(node.index)
        return True


def _sqrt(x: Any) -> Any:
    return x.graph.node("sqrt", x.index) if isinstance(x, Sym) else math.sqrt(x)


def _sin(x: Any) -> Any:
    return x.graph.node("sin", x.index) if isinstance(x, Sym) else math.sin(x)


def _cos(x: Any) -> Any:
    return x.graph.node("cos", x.index) if isinstance(x, Sym) else math.cos(x)


def _tanh(x: Any) -> Any:
    return x.graph.node("tanh", x.index) if isinstance(x, Sym) else math.tanh(x)


def _pick(x: Any, y: Any, a: Any, b: Any) -> Any:
    """The traced ``measures._pick`` (``a if x > y else b``): chosen while tracing when x and y are numbers,
    else a "pick" node (the one select on data the engine's measures make)."""
    if not isinstance(x, Sym) and not isinstance(y, Sym):
        return a if x > y else b
    if _memo_key("pick", (_raw(a),)) == _memo_key("pick", (_raw(b),)):  # the same node or number (0.0 and -0.0 apart)
        return a
    g = x.graph if isinstance(x, Sym) else y.graph
    return g.node("pick", _raw(x), _raw(y), _raw(a), _raw(b))


#: ``math`` as the traced kernels see it.
_MATH = types.SimpleNamespace(sqrt=_sqrt, sin=_sin, cos=_cos, tanh=_tanh, isfinite=math.isfinite, pi=math.pi)


#: The interface between the engine and the specialiser: the engine's one-configuration kernels the specialiser
#: traces, by kind. Each is plain scalar Python over arrays (numba compiles it as written): arithmetic, ``math.sqrt``,
#: ``math.sin``, ``math.cos``, ``math.tanh``, loops and branches on the model's *structure* (numbers while tracing), and branches on
#: data only through ``>`` / ``<`` comparisons (traced as guards). Every kernel they call is traced with them.
ENTRY_POINTS = {
    "jstar": "jstar_one",
    "rollout": "state_derivative_one",
    "hplus": "hplus_one",
    "forward": "accelerations_one",
    "inverse": "inverse_one",
}


@functools.cache
def traced() -> types.SimpleNamespace:
    """The engine's kernels (of :mod:`freefloat.engine.layout`, :mod:`~freefloat.engine.recursions`,
    :mod:`~freefloat.engine.measures`, :mod:`~freefloat.engine.quantities`) as plain Python on :class:`Sym` values.

    Each kernel's Python function (``py_func``, the one source numba compiles) is rebound to a namespace in which
    every kernel name is its traced twin, the views without reference counting are checked slices and ``math`` is
    the shim above: the same code, run by the interpreter instead of numba (nothing is compiled, no file is read).
    """
    names: dict[str, Any] = {}
    for module in (_tree, _recursions, _measures, _configuration):
        names.update(vars(module))
    twins: dict[str, Any] = {}
    for key, value in list(names.items()):
        py_func = getattr(value, "py_func", None)
        if py_func is not None and py_func.__module__.startswith("freefloat.core"):  # core's arithmetic on numbers (the
            twins[key] = py_func  # flat state's offsets: core.state_layout), run as it is
        elif py_func is not None:
            twins[key] = types.FunctionType(py_func.__code__, names, key, py_func.__defaults__, py_func.__closure__)
    names.update(twins)
    names.update(math=_MATH, floats_view=slice_view, ints_view=slice_view, _pick=_pick)
    space = types.SimpleNamespace(**twins)
    return types.SimpleNamespace(recursions=space, configuration=space)
