"""Shape checking and chunked evaluation shared by the batched functions."""

from __future__ import annotations

import threading
import weakref
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.errors import ShapeError

if TYPE_CHECKING:
    from ..core.model import Model

#: Configurations evaluated at once inside one kernel call; keeps temporaries in cache.
CHUNK = 4096
#: Batches (or chunks) of at least this many configurations use the compiled kernels (see ``Program``);
#: smaller ones use plain numpy, which has no per-model compile cost and less per-call overhead.
COMPILE_MIN = 1024


def joint_array(model: Model, q: Any, name: str = "q") -> np.ndarray:
    """``q`` as a float array of shape (..., N); a clear error otherwise."""
    arr = np.asarray(q, dtype=float)
    n = model.n_joints
    if arr.ndim == 0 or arr.shape[-1] != n:
        raise ShapeError(
            f"{name}: expected shape (..., {n}) (one value per joint: {', '.join(model.joint_names) or 'none'}), got {arr.shape}"
        )
    return arr


def vector_array(value: Any, size: int, name: str, what: str) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0 or arr.shape[-1] != size:
        raise ShapeError(f"{name}: expected shape (..., {size}) ({what}), got {arr.shape}")
    return arr


def chunked(kernel: Callable[..., Any], *arrays: np.ndarray, core_ndims: tuple[int, ...]) -> Any:
    """Evaluate ``kernel`` over the broadcast leading batch axes of ``arrays`` in chunks.

    ``core_ndims[i]`` is the number of trailing (non-batch) axes of ``arrays[i]``.
    The kernel takes arrays with one flat batch axis and returns an array or a
    tuple of arrays with a leading batch axis. An unbatched input gives an
    unbatched output.
    """
    batch_shapes = [a.shape[: a.ndim - nd] for a, nd in zip(arrays, core_ndims, strict=True)]
    batch = np.broadcast_shapes(*batch_shapes)
    size = int(np.prod(batch, dtype=int))
    flat = [
        np.broadcast_to(a, (*batch, *a.shape[a.ndim - nd :])).reshape((size, *a.shape[a.ndim - nd :]))
        for a, nd in zip(arrays, core_ndims, strict=True)
    ]
    chunk = CHUNK
    if size <= chunk:
        first = kernel(*flat)
        single = not isinstance(first, tuple)
        outs = tuple(p.reshape(batch + p.shape[1:]) for p in ((first,) if single else first))
        return outs[0] if single else outs
    # one output array per result, filled chunk by chunk (no list of pieces, no concatenation)
    results: tuple[np.ndarray, ...] = ()
    single = False
    for start in range(0, size, chunk):
        piece = kernel(*(f[start : start + chunk] for f in flat))
        if not results:
            single = not isinstance(piece, tuple)
            results = tuple(np.empty((size, *p.shape[1:]), dtype=p.dtype) for p in ((piece,) if single else piece))
        for res, p in zip(results, (piece,) if single else piece, strict=True):
            res[start : start + chunk] = p
    outs = tuple(r.reshape(batch + r.shape[1:]) for r in results)
    return outs[0] if single else outs


# --------------------------------------------------------------------------------------------------
# Compiled straight-line kernels.
#
# The hot paths (J*, det J*, manipulability) are a fixed sequence of scalar operations per
# configuration whose structure depends only on the model. They are traced once per model with
# ``Sym`` scalars (constant folding, folding of constant factors into a coefficient, common
# subexpression elimination, dead code elimination), then emitted as Python source that calls numpy
# ufuncs on rows of length CHUNK with preallocated buffers: one configuration per lane, the batch
# axis last. Exact zeros and ones of a model (axis-aligned joints, planar systems, diagonal
# inertias) cost nothing.
# --------------------------------------------------------------------------------------------------


class Sym:
    """A traced scalar ``coef * register + off`` (a constant when ``reg`` is None).

    Constant factors and offsets ride along for free and are applied only where needed.
    """

    __slots__ = ("coef", "off", "reg", "tape")

    def __init__(self, tape: Tape, coef: float, reg: int | None, off: float = 0.0) -> None:
        if reg is None or coef == 0.0:
            coef, reg = 0.0, None
        self.tape, self.coef, self.reg, self.off = tape, float(coef), reg, float(off)

    def _sym(self, other: Sym | float) -> Sym:
        return other if isinstance(other, Sym) else Sym(self.tape, 0.0, None, float(other))

    def __add__(self, other: Sym | float) -> Sym:
        return self.tape.add(self, self._sym(other))

    __radd__ = __add__

    def __sub__(self, other: Sym | float) -> Sym:
        return self.tape.add(self, -self._sym(other))

    def __rsub__(self, other: Sym | float) -> Sym:
        return self.tape.add(self._sym(other), -self)

    def __neg__(self) -> Sym:
        return Sym(self.tape, -self.coef, self.reg, -self.off)

    def __mul__(self, other: Sym | float) -> Sym:
        return self.tape.mul(self, self._sym(other))

    __rmul__ = __mul__

    def __truediv__(self, other: Sym | float) -> Sym:
        return self.tape.div(self, self._sym(other))

    def __rtruediv__(self, other: Sym | float) -> Sym:
        return self.tape.div(self._sym(other), self)


class Tape:
    """A recording of scalar operations: ``ops[r] = (kind, a, b, k)`` defines register r."""

    def __init__(self, eager_offsets: bool = False) -> None:
        self.ops: list[tuple[str, int, int, float]] = []
        self._memo: dict[tuple[str, int, int, float], int] = {}
        self.n_inputs = 0
        #: Fold a constant into a register as soon as it is added (else only where it is multiplied).
        self.eager_offsets = eager_offsets

    def emit(self, kind: str, a: int, b: int = -1, k: float = 0.0) -> int:
        if kind in ("add", "mul") and b < a:
            a, b = b, a
        key = (kind, a, b, k)
        reg = self._memo.get(key)
        if reg is None:
            reg = self._memo[key] = len(self.ops)
            self.ops.append(key)
        return reg

    def input(self) -> Sym:
        self.n_inputs += 1
        return Sym(self, 1.0, self.emit("in", self.n_inputs - 1))

    def const(self, value: float) -> Sym:
        return Sym(self, 0.0, None, value)

    def add(self, x: Sym, y: Sym) -> Sym:
        off = x.off + y.off
        if x.reg is None or y.reg is None:
            out = Sym(self, x.coef, x.reg, off) if y.reg is None else Sym(self, y.coef, y.reg, off)
            return self._scaled(out) if self.eager_offsets else out
        if x.reg == y.reg:
            return Sym(self, x.coef + y.coef, x.reg, off)
        if x.coef == y.coef:
            return Sym(self, x.coef, self.emit("add", x.reg, y.reg), off)
        if x.coef == -y.coef:  # a (r1 - r2), operands ordered so that r2 - r1 reuses the register
            if x.reg > y.reg:
                x, y = y, x
            assert x.reg is not None and y.reg is not None
            return Sym(self, x.coef, self.emit("sub", x.reg, y.reg), off)
        if abs(y.coef) == 1.0 and abs(x.coef) != 1.0:
            x, y = y, x
        assert x.reg is not None and y.reg is not None
        return Sym(self, x.coef, self.emit("axpy", x.reg, y.reg, y.coef / x.coef), off)

    def _scaled(self, x: Sym) -> Sym:
        """x with its offset folded into the register: coef * (reg + off / coef)."""
        if x.off == 0.0 or x.reg is None:
            return x
        return Sym(self, x.coef, self.emit("addk", x.reg, k=x.off / x.coef))

    def mul(self, x: Sym, y: Sym) -> Sym:
        if x.reg is None:
            return Sym(self, y.coef * x.off, y.reg, y.off * x.off)
        if y.reg is None:
            return Sym(self, x.coef * y.off, x.reg, x.off * y.off)
        x, y = self._scaled(x), self._scaled(y)
        assert x.reg is not None and y.reg is not None
        return Sym(self, x.coef * y.coef, self.emit("mul", x.reg, y.reg))

    def div(self, x: Sym, y: Sym) -> Sym:
        if y.reg is None:
            return Sym(self, x.coef / y.off, x.reg, x.off / y.off)
        y = self._scaled(y)
        assert y.reg is not None
        if x.reg is None:
            return Sym(self, x.off / y.coef, self.emit("recip", y.reg))
        x = self._scaled(x)
        assert x.reg is not None
        return Sym(self, x.coef / y.coef, self.emit("div", x.reg, y.reg))

    def unit(self, x: Sym) -> int:
        """The register holding exactly x (coefficient 1, no offset)."""
        x = self._scaled(x)
        assert x.reg is not None
        return x.reg if x.coef == 1.0 else self.emit("mulk", x.reg, k=x.coef)

    def positive_part(self, x: Sym) -> Sym:
        """max(x, 0)."""
        if x.reg is None:
            return self.const(max(x.off, 0.0))
        x = self._scaled(x)
        assert x.reg is not None
        if x.coef > 0.0:
            return Sym(self, x.coef, self.emit("pos", x.reg))
        return Sym(self, 1.0, self.emit("pos", self.unit(x)))

    def positive_reciprocal(self, x: Sym) -> Sym:
        """1 / x where x > 0, else 0."""
        if x.reg is None:
            return self.const(1.0 / x.off if x.off > 0.0 else 0.0)
        x = self._scaled(x)
        assert x.reg is not None
        if x.coef > 0.0:
            return Sym(self, 1.0 / x.coef, self.emit("rpos", x.reg))
        return Sym(self, 1.0, self.emit("rpos", self.unit(x)))

    def sqrt(self, x: Sym) -> Sym:
        if x.reg is None:
            return self.const(float(np.sqrt(x.off)))
        x = self._scaled(x)
        assert x.reg is not None
        if x.coef > 0.0:
            return Sym(self, float(np.sqrt(x.coef)), self.emit("sqrt", x.reg))
        return Sym(self, 1.0, self.emit("sqrt", self.unit(x)))


_UFUNCS = {"add": "add", "sub": "subtract", "mul": "multiply", "div": "divide"}


class Program:
    """A traced tape compiled to a numpy kernel ``run(inputs (n_inputs, C), out (n_outputs, C))``.

    ``ops``/``outputs`` (the live tape after dead code elimination, and per output either
    ``("reg", r)`` or ``("const", value)``) are kept for other back ends.
    """

    def __init__(self, tape: Tape, outputs: list[Sym], name: str = "kernel") -> None:
        self.n_inputs = tape.n_inputs
        self.n_outputs = len(outputs)
        targets: list[tuple[str, float]] = []
        for o in outputs:
            targets.append(("const", o.off) if o.reg is None else ("reg", float(tape.unit(o))))
        live = [False] * len(tape.ops)
        for kind, value in targets:
            if kind == "reg":
                live[int(value)] = True
        for r in range(len(tape.ops) - 1, -1, -1):
            if live[r]:
                kind, a, b, _ = tape.ops[r]
                if kind != "in":
                    live[a] = True
                    if b >= 0:
                        live[b] = True
        order = [r for r in range(len(tape.ops)) if live[r]]
        self.ops = [tape.ops[r] for r in order]
        renumber = {r: i for i, r in enumerate(order)}
        self.ops = [(kind, a if kind == "in" else renumber[a], renumber[b] if b >= 0 else -1, k) for kind, a, b, k in self.ops]
        self.outputs: list[tuple[str, float]] = [(kind, float(renumber[int(v)]) if kind == "reg" else v) for kind, v in targets]
        self.n_ops = sum(1 for op in self.ops if op[0] != "in")
        self._source, self._consts, self.n_buffers, self.n_calls = self._emit(name)  # n_calls: ufunc calls per chunk
        namespace: dict[str, Any] = {"np": np, **self._consts}
        exec(compile(self._source, f"<freeflyer {name}>", "exec"), namespace)
        self._run = namespace[name]

    def _emit(self, name: str) -> tuple[str, dict[str, Any], int, int]:
        ops = self.ops
        last: dict[int, int] = {}
        for i, (kind, a, b, _) in enumerate(ops):
            if kind != "in":
                last[a] = i
                if b >= 0:
                    last[b] = i
        output_of: dict[int, int] = {}
        for j, (kind, v) in enumerate(self.outputs):
            if kind == "reg" and int(v) not in output_of and ops[int(v)][0] != "in":
                output_of[int(v)] = j
        consts: dict[str, Any] = {}
        const_names: dict[tuple[float, bool], str] = {}

        def const(value: float) -> str:
            key = (value, bool(np.signbit(value)))
            if key not in const_names:
                const_names[key] = f"k{len(consts)}"
                consts[const_names[key]] = np.array(value)  # a 0-d array: the cheapest scalar operand for a ufunc
            return const_names[key]

        where: dict[int, str] = {}  # register -> variable name
        free: list[str] = []
        n_buf = 0
        body: list[str] = []
        for i, (kind, a, b, k) in enumerate(ops):
            if kind == "in":
                where[i] = f"inp[{a}]"
                continue
            dying = [r for r in (b, a) if r >= 0 and last.get(r) == i and where[r].startswith("b")]
            if i in output_of:
                dest = f"out[{output_of[i]}]"
            elif dying:
                dest = where[dying[0]]  # in place (axpy writing over its first operand goes through scratch)
            elif free:
                dest = free.pop()
            else:
                dest = f"b{n_buf}"
                n_buf += 1
            A = where[a]
            B = where[b] if b >= 0 else ""
            if kind in _UFUNCS:
                body.append(f"{_UFUNCS[kind]}({A}, {B}, {dest})")
            elif kind == "addk":
                body.append(f"add({A}, {const(k)}, {dest})")
            elif kind == "mulk":
                body.append(f"multiply({A}, {const(k)}, {dest})")
            elif kind == "axpy":
                if dest == A:
                    body.append(f"multiply({B}, {const(k)}, scratch)")
                    body.append(f"add({A}, scratch, {dest})")
                else:
                    body.append(f"multiply({B}, {const(k)}, {dest})")
                    body.append(f"add({dest}, {A}, {dest})")
            elif kind == "recip":
                body.append(f"divide({const(1.0)}, {A}, {dest})")
            elif kind == "sqrt":
                body.append(f"sqrt({A}, {dest})")
            elif kind == "pos":
                body.append(f"maximum({A}, {const(0.0)}, out={dest})")
            elif kind == "rpos":
                # 1/x where x > 0, else 0 (x > 0 below 1e-300 gives 1e300: harmless where used)
                body.append(f"greater({A}, {const(0.0)}, mask)")
                body.append(f"maximum({A}, {const(1e-300)}, out={dest})")
                body.append(f"divide(mask, {dest}, {dest})")
            else:  # pragma: no cover
                raise AssertionError(kind)
            for r in dying:
                if where[r] != dest and where[r] not in free:
                    free.append(where[r])
            where[i] = dest
        tail: list[str] = []
        for j, (kind, v) in enumerate(self.outputs):
            if kind == "const":
                tail.append(f"out[{j}] = {v!r}" if v != 0.0 else f"if not zeroed: out[{j}] = 0.0")
            elif output_of.get(int(v)) != j:
                tail.append(f"out[{j}] = {where[int(v)]}")
        names = {n for line in body for n in _names(line)}
        head = [f"def {name}(inp, out, buf, scratch, mask, zeroed):"]
        head += [f"    {n} = np.{n}" for n in ("add", "subtract", "multiply", "divide", "sqrt", "maximum", "greater") if n in names]
        head += [f"    b{j} = buf[{j}]" for j in range(n_buf)]
        src = "\n".join(head + [f"    {line}" for line in body + tail] + ["    return out", ""])
        return src, consts, n_buf, len(body)

    @property
    def has_zero_outputs(self) -> bool:
        return any(kind == "const" and v == 0.0 for kind, v in self.outputs)

    def __call__(self, inputs: np.ndarray, out: np.ndarray, zeroed: bool = False) -> np.ndarray:
        """Evaluate on ``inputs`` (n_inputs, C) into ``out`` (n_outputs, C) (rows may be views).

        ``zeroed``: ``out`` is already zero, so constant-zero outputs are not written.
        """
        c = inputs.shape[1]
        buf, scratch, mask = _buffers(self.n_buffers, c)
        return self._run(inputs, out, buf, scratch, mask, zeroed)


def _names(line: str) -> list[str]:
    return [line.split("(", 1)[0]] if "(" in line else []


_local = threading.local()


def _buffers(n: int, c: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-thread scratch rows, reused across calls (cache-warm, no page faults)."""
    have = getattr(_local, "buffers", None)
    if have is None or have[0].shape[0] < n or have[0].shape[1] < c:
        rows = max(n, have[0].shape[0] if have is not None else 0)
        cols = max(c, have[0].shape[1] if have is not None else 0)
        have = (np.empty((max(rows, 1), cols)), np.empty(cols), np.empty(cols, dtype=bool))
        _local.buffers = have
    return have[0][:n, :c], have[1][:c], have[2][:c]


def _sincos_table() -> tuple[np.ndarray, np.ndarray]:
    """sin and cos of j pi/64, j = 0..127, from angles <= pi/4 and exact symmetries (each within 1 ulp)."""
    step = np.pi / 64
    sin, cos = np.zeros(128), np.zeros(128)
    for j in range(17):
        sin[j], cos[j] = np.sin(j * step), np.cos(j * step)
    for j in range(17, 33):
        sin[j], cos[j] = cos[32 - j], sin[32 - j]
    for j in range(33, 65):
        sin[j], cos[j] = sin[64 - j], -cos[64 - j]
    for j in range(65, 128):
        sin[j], cos[j] = -sin[j - 64], -cos[j - 64]
    return sin, cos


_SIN, _COS = _sincos_table()
# pi/64 = _STEP_HI + _STEP_LO: _STEP_HI has 31 significant bits, so k * _STEP_HI is exact for |k| < 2^22;
# _STEP_LO is the rest, computed to 50 digits
_STEP_HI = 0.049087385210441425
_STEP_LO = 1.899093908283185e-12
_MAX_TABLE_ANGLE = 1e5


def sincos(x: np.ndarray, sin_out: np.ndarray, cos_out: np.ndarray) -> None:
    """sin(x), cos(x) within 1 ulp of 1 (absolute ~2e-16), about 3x faster than np.sin + np.cos.

    x = k pi/64 + r, |r| <= pi/128: table values at k pi/64 and short Taylor series in r.
    """
    if x.size == 0:
        return
    if not np.abs(x).max() <= _MAX_TABLE_ANGLE:  # also NaN
        np.sin(x, out=sin_out)
        np.cos(x, out=cos_out)
        return
    t = _scratch("sincos", (5, *x.shape))
    k, r, z, a, b = t
    np.multiply(x, 64 / np.pi, out=k)
    np.rint(k, out=k)
    np.multiply(k, _STEP_HI, out=r)
    np.subtract(x, r, out=r)
    np.multiply(k, _STEP_LO, out=z)
    np.subtract(r, z, out=r)
    np.multiply(r, r, out=z)
    # sin r = r (1 - z/6 + z^2/120 - z^3/5040), cos r = 1 - z/2 + z^2/24 - z^3/720 (next terms < 1e-18)
    np.multiply(z, -1 / 5040, out=a)
    np.add(a, 1 / 120, out=a)
    np.multiply(a, z, out=a)
    np.add(a, -1 / 6, out=a)
    np.multiply(a, z, out=a)
    np.multiply(a, r, out=a)
    np.add(a, r, out=a)  # sin r
    np.multiply(z, -1 / 720, out=b)
    np.add(b, 1 / 24, out=b)
    np.multiply(b, z, out=b)
    np.add(b, -0.5, out=b)
    np.multiply(b, z, out=b)
    np.add(b, 1.0, out=b)  # cos r
    idx = _scratch("sincos_index", x.shape, np.intp)
    np.copyto(idx, k, casting="unsafe")
    np.bitwise_and(idx, 127, out=idx)
    np.take(_SIN, idx, out=k)  # sin(k pi/64)
    np.take(_COS, idx, out=r)  # cos(k pi/64)
    np.multiply(k, b, out=sin_out)
    np.multiply(r, a, out=z)
    np.add(sin_out, z, out=sin_out)
    np.multiply(r, b, out=cos_out)
    np.multiply(k, a, out=z)
    np.subtract(cos_out, z, out=cos_out)


def _scratch(name: str, shape: tuple[int, ...], dtype: Any = float) -> np.ndarray:
    """A per-thread scratch array, reused across calls (cache-warm, no page faults)."""
    store = getattr(_local, "scratch", None)
    if store is None:
        store = _local.scratch = {}
    size = int(np.prod(shape, dtype=int))
    have = store.get(name)
    if have is None or have.size < size:
        have = store[name] = np.empty(max(size, 1), dtype=dtype)
    return have[:size].reshape(shape)


def map_angles(program: Program, q: np.ndarray) -> np.ndarray:
    """Run ``program`` on inputs [sin q, cos q] for every row of q (size, N): (n_outputs, size), batch last.

    Chunks of 2 CHUNK configurations (the temporaries are rows of length C, not (C, B, 3, 3)
    blocks). Outputs that are constant zeros are never written: the result comes from calloc'd
    memory whose untouched rows cost nothing (a planar system's J* is half zeros).
    """
    size, n = q.shape
    out = (np.zeros if program.has_zero_outputs else np.empty)((program.n_outputs, size))
    chunk = 2 * CHUNK
    for start in range(0, size, chunk):
        stop = min(start + chunk, size)
        qt = _scratch("angles", (n, stop - start))
        np.copyto(qt, q[start:stop].T)
        inp = _scratch("inputs", (2 * n, stop - start))
        sincos(qt, inp[:n], inp[n:])
        program(inp, out[:, start:stop], zeroed=True)
    return out


class _ProgramCache:
    def __init__(self) -> None:
        self.programs: dict[Any, Any] = {}
        self.lock = threading.Lock()


_PROGRAMS: weakref.WeakKeyDictionary[Model, _ProgramCache] = weakref.WeakKeyDictionary()
_PROGRAMS_LOCK = threading.Lock()


def program_cache(model: Model) -> _ProgramCache:
    """The per-model cache of compiled programs (kept as long as the model lives)."""
    with _PROGRAMS_LOCK:
        cache = _PROGRAMS.get(model)
        if cache is None:
            cache = _PROGRAMS[model] = _ProgramCache()
    return cache


def compiled(model: Model, key: Any, build: Callable[[bool], Program | None]) -> Program | None:
    """The program ``key`` of ``model``, built on first use and kept as long as the model lives.

    ``build(eager_offsets)`` traces it; both ways of handling constant offsets are tried and the
    program with fewer numpy calls is kept. ``build`` may return None (no compiled form).
    """
    cache = program_cache(model)
    if key not in cache.programs:
        with cache.lock:
            if key not in cache.programs:
                built = [p for p in (build(False), build(True)) if p is not None]
                cache.programs[key] = min(built, key=lambda p: p.n_calls) if built else None
    return cache.programs[key]
