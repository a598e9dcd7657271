"""Compile the engine's kernels once per machine: numba's on-disk cache, kept in the user's cache directory.

Every kernel of :mod:`freefloat.engine.calls` takes the model as plain arrays, so it is
compiled once for all models (a new model or a payload variant costs nothing) and numba keeps the
machine code on disk between processes. This module only decides *where* that cache lives and what
happens when it is unusable:

* location: ``$FREEFLOAT_CACHE_DIR/numba`` if set, else ``platformdirs.user_cache_dir("freefloat")/numba``
  (``~/.cache/freefloat/numba`` on Linux), one subfolder per numba version and engine source
  (:data:`KERNEL_MODULES`); never the install tree;
* two processes starting at once: numba writes each file to a temporary name and renames it
  (atomic on POSIX and Windows); at worst one process compiles what the other is writing;
* a broken cache (truncated or corrupted files, a folder that cannot be written): a
  :class:`CacheWarning` names the folder and the kernel, the kernel is compiled again in memory
  and the cache files are rewritten; never a traceback.

numba's public switch ``cache=True`` picks the folder from a process-wide setting
(``NUMBA_CACHE_DIR``) that would also move the user's own numba caches, so the kernels are
decorated without it and given a :class:`FunctionCache` whose locator points to our folder.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import types
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any, Literal

import numba
import numpy as np
import platformdirs
from llvmlite import ir
from numba import types as nbtypes
from numba.core import cgutils, typed_passes, untyped_passes
from numba.core.caching import CompileResultCacheImpl, FunctionCache, _CacheLocator, _SourceFileBackedLocatorMixin
from numba.core.compiler import CompilerBase
from numba.core.compiler_machinery import PassManager
from numba.extending import intrinsic

from ..core.feedback import notice

__all__ = ["CacheWarning", "bind", "cache_dir", "floats_view", "ints_view", "kernel", "slice_view", "store_fence", "stream_line"]


class CacheWarning(UserWarning):
    """The on-disk kernel cache could not be used; the kernel was compiled again (a few seconds)."""


#: The modules whose kernels are cached; numba does not track calls across files, so the
#: cache folder is keyed by a hash of all of them (an edit or an upgrade starts a fresh folder).
KERNEL_MODULES = (
    "cache.py",
    "layout.py",
    "recursions.py",
    "quantities.py",
    "measures.py",
    "drivers.py",
    "stepper.py",
    "stops.py",
    "specialise/lanes.py",
    "laws.py",
    "threads.py",
)


@functools.cache
def _source_key() -> str:
    digest = hashlib.sha256(numba.__version__.encode())
    here = Path(__file__).parent
    for name in KERNEL_MODULES:
        digest.update((here / name).read_bytes())
    digest.update((here.parent / "core" / "numbers.py").read_bytes())  # core's constants the kernels compile in (MAX_EFFORT)
    return digest.hexdigest()[:16]


def cache_dir() -> Path:
    """The folder that holds the compiled kernels of this numba version and this engine source."""
    root = os.environ.get("FREEFLOAT_CACHE_DIR") or platformdirs.user_cache_dir("freefloat")
    return Path(root) / "numba" / f"{numba.__version__}-{_source_key()}"


class _Locator(_SourceFileBackedLocatorMixin, _CacheLocator):
    """Cache files of a kernel under :func:`cache_dir`, keyed by its source file's path."""

    def __init__(self, py_func: Callable[..., Any], py_file: str) -> None:
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        self._cache_path = str(cache_dir() / self.get_suitable_cache_subpath(py_file))

    def get_cache_path(self) -> str:
        return self._cache_path

    @classmethod
    def from_function(cls, py_func: Callable[..., Any], py_file: str) -> _Locator:
        return cls(py_func, py_file)


class _Impl(CompileResultCacheImpl):
    _locator_classes = [_Locator]  # noqa: RUF012 (numba's attribute)


class _Cache(FunctionCache):
    """numba's per-function cache with our locator; unreadable or unwritable files warn and recompile."""

    _impl_class = _Impl

    def load_overload(self, sig: Any, target_context: Any) -> Any:
        try:
            found = super().load_overload(sig, target_context)
        except Exception as exc:  # a cache must never cost a traceback: whatever is wrong with the files
            warnings.warn(
                f"freefloat: the compiled-kernel cache in {self.cache_path} is broken for {self._py_func.__qualname__} "
                f"({type(exc).__name__}: {exc}); compiling it again and rewriting the cache",
                CacheWarning,
                stacklevel=2,
            )
            self._drop_index()
            _announce_compile(self.cache_path)
            return None
        if found is None:
            _announce_compile(self.cache_path)
        return found

    def save_overload(self, sig: Any, data: Any) -> None:
        for attempt in range(2):
            try:
                super().save_overload(sig, data)
                return
            except Exception as exc:
                if attempt == 0 and not isinstance(exc, PermissionError):
                    self._drop_index()  # an unreadable index: start it afresh and try once more
                    continue
                warnings.warn(
                    f"freefloat: cannot write the compiled-kernel cache in {self.cache_path} ({type(exc).__name__}: {exc}); "
                    "kernels will be compiled again in the next process (set FREEFLOAT_CACHE_DIR to a writable folder)",
                    CacheWarning,
                    stacklevel=2,
                )

    def _drop_index(self) -> None:
        index = getattr(self._cache_file, "_index_path", None)
        if index:
            with contextlib.suppress(OSError):
                os.unlink(index)


_ANNOUNCED: list[bool] = []


def _announce_compile(folder: str) -> None:
    """Once per process, at the first kernel that is not in the cache: say that compiling takes a while, and why."""
    if _ANNOUNCED:
        return
    _ANNOUNCED.append(True)
    notice(
        "compiling the engine's kernels for this machine as they are first used: once, seconds for one kind of call, "
        "a few minutes for all of them (the next uses load them from "
        f"{Path(folder).parent} in under a second)"
    )


class _Straight(CompilerBase):
    """numba's nopython pipeline less the passes that straight-line arithmetic does not need (closures, inlining,
    literal unrolling, rewrites, SSA): 15-20% less compile time on a specialised lane kernel (the 7-DOF arm's J*,
    2,100 lines of ``v = a * b``: 2.5 s instead of 3.0 s, its outputs bit for bit the same, measured). Every
    generated lane kernel is compiled by it, so the tests of the specialised kernels (tests/mechanics/test_specialise.py
    and others) check it."""

    def define_pipelines(self) -> list[PassManager]:
        pm = PassManager("straight")
        pm.add_pass(untyped_passes.TranslateByteCode, "analyzing bytecode")
        pm.add_pass(untyped_passes.FixupArgs, "fix up args")
        pm.add_pass(untyped_passes.IRProcessing, "processing IR")
        pm.add_pass(typed_passes.NopythonTypeInference, "nopython frontend")
        pm.add_pass(typed_passes.NoPythonSupportedFeatureValidation, "ensure features that are in use are in a valid form")
        pm.add_pass(typed_passes.IRLegalization, "ensure IR is legal prior to lowering")
        pm.add_pass(typed_passes.AnnotateTypes, "annotate types")
        pm.add_pass(typed_passes.NativeLowering, "native lowering")
        pm.add_pass(typed_passes.NoPythonBackend, "nopython mode backend")
        pm.finalize()
        return [pm]


def kernel(
    *, parallel: bool = False, inline: Literal["never", "always"] = "never", straight: bool = False
) -> Callable[[Callable[..., Any]], Any]:
    """``numba.njit`` with freefloat's on-disk cache (see the module docstring). ``straight``: a function of
    straight-line arithmetic in loops (no calls, closures or tuples: a generated lane kernel) compiled by the shorter
    pipeline :class:`_Straight`."""

    def wrap(func: Callable[..., Any]) -> Any:
        options: dict[str, Any] = {"pipeline_class": _Straight} if straight else {}
        dispatcher = numba.njit(
            cache=False, nogil=True, error_model="numpy", fastmath={"contract"}, parallel=parallel, inline=inline, **options
        )(func)
        dispatcher._cache = _Cache(func)
        return dispatcher

    return wrap


def bind(template: Callable[..., Any], name: str, **names: Any) -> Callable[..., Any]:
    """A copy of the plain function ``template`` named ``name`` whose global ``names`` are the given objects.

    numba reads globals as compile-time constants, so a kernel made from the copy calls (and inlines) the bound
    kernels as if their names had been typed there; a copy is not a closure, so numba's on-disk cache keeps it (one
    entry per name).
    """
    func = types.FunctionType(template.__code__, {**template.__globals__, **names}, name, template.__defaults__)
    func.__qualname__ = name
    func.__doc__ = template.__doc__
    return func


# ----------------------------------------------------------------- views without reference counting
@intrinsic
def _address(typingctx: Any, src: Any) -> Any:  # pragma: no cover - compiled
    """The integer address ``src`` as a ``void *`` (for :func:`numba.carray`)."""

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        return builder.inttoptr(args[0], cgutils.voidptr_t)

    return nbtypes.voidptr(src), codegen


@kernel(inline="always")
def floats_view(buffer: np.ndarray, offset: int, shape: Any) -> np.ndarray:  # pragma: no cover - compiled
    """The float64 array of ``shape`` (an int or a tuple; C order) that starts at element ``offset`` of ``buffer``
    (1-D float64, contiguous): a view that neither counts references to the memory nor checks bounds.

    It costs ~0.5 ns, where a slice and a reshape cost ~12 ns (a bounds and a size check) and a view that counts
    references ~28 ns (atomic operations): a kernel called from Python makes ~60 views of the model's and the scratch
    buffers at every call (:func:`~._tree.arrays`, :func:`~._recursions.scratch`), about 0.6 us of a simulation's
    step. Only for buffers that are arguments of the calling kernel (its Python caller holds them for the whole call),
    and the maker of the views checks once that the buffer is long enough. (Traced as a slice: :func:`slice_view`.)
    """
    return numba.carray(_address(buffer.ctypes.data + 8 * offset), shape, np.float64)  # type: ignore[call-arg]


@kernel(inline="always")
def ints_view(buffer: np.ndarray, offset: int, shape: Any) -> np.ndarray:  # pragma: no cover - compiled
    """:func:`floats_view` of a 1-D int64 buffer."""
    return numba.carray(_address(buffer.ctypes.data + 8 * offset), shape, np.int64)  # type: ignore[call-arg]


def slice_view(buffer: np.ndarray, offset: int, shape: Any) -> np.ndarray:
    """What :func:`floats_view` and :func:`ints_view` compute, as a checked slice of ``buffer``: their twin in plain
    Python (the tracer of :mod:`._trace` runs the engine's source on object arrays)."""
    size = int(np.prod(shape))
    if offset + size > buffer.shape[0]:
        raise ValueError(f"freefloat: a view of {size} entries from {offset} runs past a buffer of {buffer.shape[0]}")
    return buffer[offset : offset + size].reshape(shape)


# ----------------------------------------------------------------- stores that bypass the caches
#: float64 values per cache line (64 bytes): what one :func:`stream_line` stores.
LINE = 8


@intrinsic
def stream_line(typingctx: Any, address: Any, src: Any, k: Any) -> Any:  # pragma: no cover - compiled
    """Store ``src[k : k + LINE]`` (float64, contiguous) at the integer ``address``, which must be 64-byte aligned, with
    one non-temporal store: the line goes to memory without being read into the caches first.

    A large batch's outputs are written once and not read again by the kernel: with ordinary stores each line is first
    read from memory (a write costs two transfers) and evicts a line of the caches; streamed, it costs one. H+ of the
    7-DOF arm (1352 bytes a configuration) wrote 8.9 GB/s on one thread of the 2-core VM, 23.8 GB/s streamed (a fill,
    measured). The stores are weakly ordered: :func:`store_fence` after the last one, before another thread reads.
    """

    if not (
        isinstance(address, nbtypes.Integer)
        and isinstance(k, nbtypes.Integer)
        and isinstance(src, nbtypes.Array)
        and src.dtype == nbtypes.float64
        and src.layout == "C"
    ):
        return None  # a typing error: an integer address, a C-contiguous float64 source and an integer start only

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        line = ir.VectorType(ir.DoubleType(), LINE)
        source = context.make_array(signature.args[1])(context, builder, args[1])
        value = builder.load(builder.bitcast(builder.gep(source.data, [args[2]]), line.as_pointer()), align=8)
        store = builder.store(value, builder.inttoptr(args[0], line.as_pointer()), align=64)
        store.set_metadata("nontemporal", builder.module.add_metadata([ir.Constant(ir.IntType(32), 1)]))
        return context.get_dummy_value()

    return nbtypes.void(address, src, k), codegen


@intrinsic
def store_fence(typingctx: Any) -> Any:  # pragma: no cover - compiled
    """A full memory fence (x86 ``mfence``): every store before it, :func:`stream_line`'s included, is visible to every
    thread before any memory access after it."""

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        builder.fence("seq_cst")
        return context.get_dummy_value()

    return nbtypes.void(), codegen
