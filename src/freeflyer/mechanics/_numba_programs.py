"""Optional back end: the traced freeflyer programs (``freeflyer._batch.Program``) compiled by numba.

Used by :mod:`freeflyer.jacobians` for large batches when numba is installed (the ``fast``
extra, ``pip install freeflyer[fast]``) and :func:`enabled`; freeflyer runs without it, on the
numpy back end, with the same results (the same program, the same sin/cos). This module emits the same traced straight-line program
(the one the numpy back end runs as ufunc calls on rows of CHUNK configurations) as scalar code in
a loop over configurations, compiled by numba: everything stays in registers, LLVM vectorises the
loop over configurations, and ``prange`` spreads blocks of configurations over the cores. sin and
cos are evaluated inside the loop with the same table + short series as ``freeflyer._batch.sincos``.
"""

from __future__ import annotations

import os
import time
from typing import Any

import numpy as np

from . import _batch

#: Batches of at least this many configurations use numba when it is enabled (compiling a program
#: takes 1-5 s once per model and process, so small batches stay on the numpy back end).
NUMBA_MIN = 65536


def available() -> bool:
    """True when numba can be imported."""
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


def enabled() -> bool:
    """numba installed and not switched off by the environment variable ``FREEFLYER_NUMBA=0``."""
    return os.environ.get("FREEFLYER_NUMBA", "1") != "0" and available()


BLOCK = 2048

_SINCOS = """
    k{j} = np.rint(qv{j} * INV_STEP)
    x{j} = (qv{j} - k{j} * STEP_HI) - k{j} * STEP_LO
    z{j} = x{j} * x{j}
    sr{j} = x{j} + x{j} * (z{j} * (((z{j} * (-1.0 / 5040.0)) + 1.0 / 120.0) * z{j} - 1.0 / 6.0))
    cr{j} = 1.0 + z{j} * ((((z{j} * (-1.0 / 720.0)) + 1.0 / 24.0) * z{j}) - 0.5)
    t{j} = np.int64(k{j}) & 127
    st{j} = SIN[t{j}]
    ct{j} = COS[t{j}]
    r{s} = st{j} * cr{j} + ct{j} * sr{j}
    r{c} = ct{j} * cr{j} - st{j} * sr{j}"""


def numba_source(program: _batch.Program, name: str = "kernel", batch_first: bool = False) -> str:
    """Source of ``name(qt, out, lo, hi)`` for configurations lo..hi-1 (``qt[j, i - lo]`` = q[i, j]) for a program on [sin q, cos q].

    ``out`` is (n_outputs, n) (batch last) or, with ``batch_first``, (n, n_outputs).
    """
    n_in = program.n_inputs
    n_joints = n_in // 2
    body: list[str] = []
    input_reg: dict[int, int] = {}
    for r, (kind, a, _b, _k) in enumerate(program.ops):
        if kind == "in":
            input_reg[a] = r
    for j in range(n_joints):
        s_reg = input_reg.get(j, -1)
        c_reg = input_reg.get(n_joints + j, -1)
        if s_reg < 0 and c_reg < 0:
            continue
        body.append(f"    qv{j} = qt[{j}, i - lo]")
        block = _SINCOS.format(j=j, s=s_reg if s_reg >= 0 else f"_unused_s{j}", c=c_reg if c_reg >= 0 else f"_unused_c{j}")
        body += block.strip("\n").splitlines()
    for r, (kind, a, b, k) in enumerate(program.ops):
        if kind == "in":
            continue
        A, B, K = f"r{a}", f"r{b}", repr(k)
        expr = {
            "add": f"{A} + {B}",
            "sub": f"{A} - {B}",
            "mul": f"{A} * {B}",
            "div": f"{A} / {B}",
            "addk": f"{A} + {K}",
            "mulk": f"{A} * {K}",
            "axpy": f"{A} + {B} * {K}",
            "recip": f"1.0 / {A}",
            "sqrt": f"np.sqrt({A})",
            "pos": f"max({A}, 0.0)",
            "rpos": f"(1.0 / {A}) if {A} > 0.0 else 0.0",
        }[kind]
        body.append(f"    r{r} = {expr}")
    for j, (kind, v) in enumerate(program.outputs):
        target = f"out[i, {j}]" if batch_first else f"out[{j}, i]"
        body.append(f"    {target} = {f'r{int(v)}' if kind == 'reg' else repr(v)}")
    lines = [f"def {name}(qt, out, lo, hi):", "    for i in range(lo, hi):"]
    lines += ["        " + line.strip() for line in body]
    return "\n".join(lines) + "\n"


class NumbaProgram:
    """A numba-compiled program: ``__call__(q (size, N)) -> (n_outputs, size)``, batch last."""

    def __init__(self, program: _batch.Program, parallel: bool = True, batch_first: bool = False) -> None:
        import numba

        self.n_outputs = program.n_outputs
        self.batch_first = batch_first
        self.source = numba_source(program, batch_first=batch_first)
        namespace: dict[str, Any] = {
            "np": np,
            "prange": numba.prange,
            "SIN": _batch._SIN,
            "COS": _batch._COS,
            "INV_STEP": 64 / np.pi,
            "STEP_HI": _batch._STEP_HI,
            "STEP_LO": _batch._STEP_LO,
        }
        exec(compile(self.source, "<numba kernel>", "exec"), namespace)
        inner = numba.njit(fastmath=False, error_model="numpy")(namespace["kernel"])

        def blocks(q: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover - compiled
            n = q.shape[0]
            nb = (n + BLOCK - 1) // BLOCK
            for blk in numba.prange(nb):
                lo = blk * BLOCK
                hi = min(lo + BLOCK, n)
                qt = np.empty((q.shape[1], hi - lo))
                for i in range(lo, hi):
                    for j in range(q.shape[1]):
                        qt[j, i - lo] = q[i, j]
                inner(qt, out, lo, hi)

        self._inner = inner
        self._kernel = numba.njit(parallel=parallel, error_model="numpy")(blocks)
        t = time.perf_counter()
        self._max_abs = numba.njit(_max_abs)
        q = np.zeros((4, program.n_inputs // 2))
        self._kernel(q, np.empty((4, self.n_outputs) if batch_first else (self.n_outputs, 4)))
        self._max_abs(q)
        self.compile_seconds = time.perf_counter() - t

    def __call__(self, q: np.ndarray) -> np.ndarray | None:
        """(size, n_outputs) with ``batch_first``, else (n_outputs, size); None when an angle is
        beyond the range of the sin/cos table (or NaN): the caller then uses the numpy back end."""
        q = np.ascontiguousarray(q, dtype=float)
        if not self._max_abs(q) <= _batch._MAX_TABLE_ANGLE:
            return None
        out = np.empty((q.shape[0], self.n_outputs) if self.batch_first else (self.n_outputs, q.shape[0]))
        self._kernel(q, out)
        return out


def _max_abs(q: np.ndarray) -> float:  # pragma: no cover - compiled
    flat = q.reshape(-1)
    best = 0.0
    for i in range(flat.size):  # numba turns this into a parallel reduction
        a = abs(flat[i])
        if not a <= best:
            best = a
    return best


def program(model: Any, which: str, traced: _batch.Program) -> NumbaProgram:
    """The numba build of ``traced`` (program ``which`` of ``model``), compiled once per model and process."""
    cache = _batch.program_cache(model)
    key = ("numba", which)
    if key not in cache.programs:
        with cache.lock:
            if key not in cache.programs:
                cache.programs[key] = NumbaProgram(traced, parallel=True, batch_first=True)
    return cache.programs[key]
