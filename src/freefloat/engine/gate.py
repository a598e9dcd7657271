"""numba's internals behind one gate: the one module of freefloat that uses numba's or llvmlite's private API.

Three of numba's internals make the engine faster; each has a fallback on public numba:

============================  ===============================================  =============================================
internal                      what it gives                                    fallback (public numba)
============================  ===============================================  =============================================
``cache``: numba's cache      the compiled kernels kept in freefloat's own     numba's own cache (``cache=True``: next to
classes (``numba.core.        cache folder (:func:`~.cache.cache_dir`),        the installed source, or numba's user-wide
caching``)                    apart from the user's own numba caches           cache folder)
``views``: an intrinsic that  views of the model's and the scratch buffers     checked slices of the buffers (a bounds and
casts an address              that neither count references nor check bounds  size check per view)
``threads``: numba's calling  a batch on numba's own threads: one small        the batch's ranges on a pool of Python
convention, dispatcher        parallel loop calls the serial kernel's          threads (the kernels release the GIL)
typing and threading state    machine code (:mod:`.threads`)
============================  ===============================================  =============================================

At import the numba version is checked against :data:`TESTED` (the range ``pyproject.toml`` declares and the test
suite runs): outside it, every internal is off. Each internal's lookups are made here, once; one that fails turns
that internal off. Either way one :class:`EngineWarning` says which internal is off, why, and what it costs; results
are the same (the fallbacks compute the same values). ``FREEFLOAT_NUMBA_INTERNALS=0`` turns every internal off.
"""

from __future__ import annotations

import contextlib
import os
import re
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numba
import numpy as np

from ..core.errors import EngineWarning

__all__ = [
    "CACHE",
    "ENV",
    "TESTED",
    "THREADS",
    "VIEWS",
    "EngineWarning",
    "NotAVoidKernel",
    "attach_cache",
    "call_range",
    "floats_view",
    "ints_view",
    "launch_threads",
    "machine_address",
    "off",
    "overload_count",
    "ready",
    "recorded_compiles",
    "slice_view",
    "threads_launched",
    "turn_off",
]

#: The numba versions the project tests (``pyproject.toml``: ``numba>=0.60,<0.69``), as (major, minor): lowest
#: included, highest excluded.
TESTED = ((0, 60), (0, 69))
#: The environment variable that turns every internal off (``0``).
ENV = "FREEFLOAT_NUMBA_INTERNALS"


class NotAVoidKernel(TypeError):
    """:func:`machine_address` of a kernel that returns something (the engine's threads call kernels that return
    nothing)."""


#: Why each internal is off (its name: the reason), for the one warning and for :func:`off`.
_OFF: dict[str, str] = {}
_COST = {
    "cache": "kernels are kept in numba's own cache folder instead of freefloat's",
    "views": "the kernels' views of their buffers are checked slices (slower small calls)",
    "threads": "batches run on a pool of Python threads instead of numba's (slower hand-over)",
}


def _version(text: str) -> tuple[int, int] | None:
    found = re.match(r"(\d+)\.(\d+)", text)
    return (int(found.group(1)), int(found.group(2))) if found else None


def _gate_reason() -> str | None:
    """Why every internal is off (the environment variable, an untested numba), or None."""
    if os.environ.get(ENV, "").strip() == "0":
        return f"{ENV}=0"
    version = _version(numba.__version__)
    if version is None or not TESTED[0] <= version < TESTED[1]:
        low, high = (".".join(map(str, v)) for v in TESTED)
        return f"numba {numba.__version__} is outside the tested range >={low},<{high}"
    return None


_ALL_OFF = _gate_reason()


def _try(name: str, lookup: Callable[[], Any]) -> Any:
    """``lookup()``, or None with the internal ``name`` off (every internal is off outside the tested range)."""
    if _ALL_OFF is not None:
        _OFF[name] = _ALL_OFF
        return None
    try:
        return lookup()
    except Exception as exc:  # any failed lookup (ImportError, AttributeError, a changed signature): the public path
        _OFF[name] = f"{type(exc).__name__}: {exc}"
        return None


def turn_off(name: str, exc: BaseException) -> None:
    """Turn the internal ``name`` off after a lookup failed at its first use (the warning, once per internal)."""
    global CACHE, THREADS
    if name not in _OFF:
        _OFF[name] = f"{type(exc).__name__}: {exc}"
        _say(name)
    if name == "cache":
        CACHE = False
    elif name == "threads":
        THREADS = False


def off() -> dict[str, str]:
    """The internals that are off in this process, with the reason of each ({} when all are used)."""
    return dict(_OFF)


def _say(*names: str) -> None:
    """The warning that the internals ``names`` are off: why (each reason once), and what each costs."""
    reasons: dict[str, list[str]] = {}
    for name in names:
        reasons.setdefault(_OFF[name], []).append(name)
    why = "; ".join(f"{', '.join(group)}: {reason}" for reason, group in reasons.items()) if len(reasons) > 1 else next(iter(reasons))
    cost = "; ".join(_COST[name] for name in names)
    low, high = (".".join(map(str, v)) for v in TESTED)
    warnings.warn(
        f"freefloat: the engine runs on public numba for {', '.join(names)} ({why}): {cost}. Results are the same "
        f"(numba {numba.__version__}; tested >={low},<{high}; {ENV}=0 turns the internals off on purpose)",
        EngineWarning,
        stacklevel=3,
    )


# ----------------------------------------------------------------- cache: freefloat's own folder
@dataclass(frozen=True)
class CacheEvents:
    """What the cache does on the engine's behalf: where a kernel's files are, what marks them as this engine
    source's, where the portable kernels are, and the four things it reports."""

    folder: Callable[[], str]  # the cache folder of this numba version and engine source
    stamp: Callable[[], str]  # the engine source's key: the stamp of every index (not the files' dates or paths)
    portable: Callable[[], str | None]  # the folder of the portable kernels (compiled for any CPU), None when none
    missed: Callable[[str], None]  # a kernel neither in the cache nor portable (compiled now): its folder
    loaded_portable: Callable[[str], None]  # a kernel loaded from the portable folder: that folder
    hold: Callable[[str, str], bool]  # take the compile lock of a kernel (its index file, its name): False if not taken
    release: Callable[[str], None]  # give back the compile lock of a kernel's index file, if this process holds it
    broken: Callable[[str, str, BaseException], None]  # unreadable files (folder, kernel, error): compiled again
    unwritable: Callable[[str, BaseException], None]  # the cache could not be written (folder, error)


#: The CPU name and features numba compiles for with ``NUMBA_CPU_NAME=generic`` (its portable target): the part of
#: a cache entry's key that names the machine, beside the target triple.
PORTABLE_CPU = ("generic", "")
#: The freefloat package's folder: a kernel's cache files are kept under its source folder's path relative to it,
#: so that a cache is the same wherever freefloat is installed.
_PACKAGE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _cache_classes() -> Any:
    from numba.core.caching import (
        CompileResultCacheImpl,
        FunctionCache,
        IndexDataCacheFile,
        NullCache,
        _CacheLocator,
        _SourceFileBackedLocatorMixin,
    )

    class Locator(_SourceFileBackedLocatorMixin, _CacheLocator):
        """Cache files of a kernel under freefloat's folder, in a subfolder named by its source file's folder in the
        package (``engine``, ``engine-specialise``) and stamped with the engine source's key: a cache built in one
        checkout or installation loads in another of the same source (numba's own locator names the folder by a hash
        of its absolute path)."""

        events: CacheEvents

        def __init__(self, py_func: Callable[..., Any], py_file: str) -> None:
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno
            self._cache_path = os.path.join(self.events.folder(), self.get_suitable_cache_subpath(py_file))

        def get_cache_path(self) -> str:
            return self._cache_path

        def get_source_stamp(self) -> str:
            return self.events.stamp()

        @classmethod
        def get_suitable_cache_subpath(cls, py_file: str) -> str:
            folder = os.path.relpath(os.path.dirname(os.path.abspath(py_file)), _PACKAGE)
            if folder.startswith(os.pardir):  # not a file of the package: numba's own subfolder
                return str(super().get_suitable_cache_subpath(py_file))
            return folder.replace(os.sep, "-")

        @classmethod
        def from_function(cls, py_func: Callable[..., Any], py_file: str) -> Any:
            return cls(py_func, py_file)

    class Impl(CompileResultCacheImpl):
        _locator_classes = [Locator]  # noqa: RUF012 (numba's attribute)

    class Cache(FunctionCache):
        """numba's per-function cache with freefloat's locator; unreadable or unwritable files are reported and the
        kernel compiled again."""

        _impl_class = Impl
        events: CacheEvents

        def load_overload(self, sig: Any, target_context: Any, compiling: bool = True) -> Any:
            """The kernel's machine code for ``sig`` from this machine's cache, else from the portable folder, else
            None: then (``compiling``, numba's dispatcher compiles next) this process takes the kernel's compile lock
            first, waiting while another process compiles it, and loads what that process saved; the lock is given
            back once the compiled kernel is saved (:meth:`save_overload`)."""
            index = self._cache_file._index_path
            self.events.release(index)  # a compile of this kernel that failed in this process
            portable = self.events.portable()  # outside the try: a bad setting is the user's error, raised
            try:
                found = super().load_overload(sig, target_context)
                if found is None and portable is not None:
                    found = self._load_portable(portable, sig, target_context)
                if found is None and compiling and self.events.hold(index, self._py_func.__qualname__):
                    found = super().load_overload(sig, target_context)  # saved while this process waited
                    if found is not None:
                        self.events.release(index)
            except Exception as exc:  # a cache must never cost a traceback: whatever is wrong with the files
                self.events.broken(self.cache_path, self._py_func.__qualname__, exc)
                self._drop_index()
                self.events.missed(self.cache_path)
                return None
            if found is None:
                self.events.missed(self.cache_path)
            return found

        def _load_portable(self, folder: str, sig: Any, target_context: Any) -> Any:
            """The kernel compiled for numba's portable CPU (``generic``) in the portable ``folder``, for this target
            triple, this signature and this bytecode; None when it is not there. Never saved into the native cache."""
            locator = self._impl.locator
            files = IndexDataCacheFile(
                cache_path=os.path.join(folder, locator.get_suitable_cache_subpath(locator._py_file)),
                filename_base=self._impl.filename_base,
                source_stamp=locator.get_source_stamp(),
            )
            signature, (triple, *_), code = self._index_key(sig, target_context.codegen())
            try:
                data = files.load((signature, (triple, *PORTABLE_CPU), code))
                found = None if data is None else self._impl.rebuild(target_context, data)
            except Exception as exc:  # damaged portable files: said, and the kernel compiled (this machine's cache kept)
                self.events.broken(folder, self._py_func.__qualname__, exc)
                return None
            if found is not None:
                self.events.loaded_portable(folder)
            return found

        def save_overload(self, sig: Any, data: Any) -> None:
            try:
                for attempt in range(2):
                    try:
                        super().save_overload(sig, data)
                        return
                    except Exception as exc:
                        if attempt == 0 and not isinstance(exc, PermissionError):
                            self._drop_index()  # an unreadable index: start it afresh and try once more
                            continue
                        self.events.unwritable(self.cache_path, exc)
            finally:
                self.events.release(self._cache_file._index_path)

        def _drop_index(self) -> None:
            index = getattr(self._cache_file, "_index_path", None)
            if index:
                with contextlib.suppress(OSError):
                    os.unlink(index)

    return Locator, Cache, NullCache


_CACHE = _try("cache", _cache_classes)
#: Whether the kernels are kept in freefloat's own cache folder (else numba's own cache, ``cache=True``).
CACHE = _CACHE is not None


def attach_cache(dispatcher: Any, func: Callable[..., Any], events: CacheEvents) -> bool:
    """Give the numba dispatcher of ``func`` (made with ``cache=False``) freefloat's cache: what ``cache=True`` does,
    with freefloat's folder.

    The dispatcher must hold numba's empty cache (``NullCache``) where this one then goes: a numba that keeps its cache
    elsewhere is found here (the kernels would otherwise be compiled again in every process without a word). False
    when anything differs (the internal off, with the warning, once): the caller then uses numba's own cache.
    """
    if _CACHE is None:
        return False
    locator, cache, null_cache = _CACHE
    try:
        if not isinstance(getattr(dispatcher, "_cache", None), null_cache):
            raise AttributeError("numba's dispatcher keeps its cache elsewhere than _cache")
        locator.events = cache.events = events
        dispatcher._cache = cache(func)
        return True
    except Exception as exc:
        turn_off("cache", exc)
        return False


# ----------------------------------------------------------------- views without reference counting
def slice_view(buffer: np.ndarray, offset: int, shape: Any) -> np.ndarray:
    """The array of ``shape`` (an int or a tuple; C order) that starts at element ``offset`` of ``buffer`` (1-D), as a
    checked slice: what :func:`floats_view` and :func:`ints_view` compute, in plain Python (the specialiser's tracer
    runs the engine's source on object arrays with this in their place)."""
    size = int(np.prod(shape))
    if offset + size > buffer.shape[0]:
        raise ValueError(f"freefloat: a view of {size} entries from {offset} runs past a buffer of {buffer.shape[0]}")
    return buffer[offset : offset + size].reshape(shape)


def _raw_views() -> tuple[Any, Any]:
    from numba import types as nbtypes
    from numba.core import cgutils
    from numba.extending import intrinsic

    pointer = cgutils.voidptr_t

    @intrinsic
    def address(typingctx: Any, src: Any) -> Any:  # pragma: no cover - compiled
        """The integer address ``src`` as a ``void *`` (for :func:`numba.carray`)."""

        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            return builder.inttoptr(args[0], pointer)

        return nbtypes.voidptr(src), codegen

    @numba.njit(inline="always", nogil=True, error_model="numpy")
    def floats(buffer: np.ndarray, offset: int, shape: Any) -> np.ndarray:  # pragma: no cover - compiled
        return numba.carray(address(buffer.ctypes.data + 8 * offset), shape, np.float64)  # type: ignore[call-arg]

    @numba.njit(inline="always", nogil=True, error_model="numpy")
    def ints(buffer: np.ndarray, offset: int, shape: Any) -> np.ndarray:  # pragma: no cover - compiled
        return numba.carray(address(buffer.ctypes.data + 8 * offset), shape, np.int64)  # type: ignore[call-arg]

    return floats, ints


def _checked_views() -> tuple[Any, Any]:
    from numba import types as nbtypes
    from numba.extending import overload

    def count(shape):  # (numba's overload compares the signatures: no annotations)
        return int(np.prod(shape))

    @overload(count)
    def _count(shape):
        if isinstance(shape, nbtypes.Integer):
            return lambda shape: shape

        def impl(shape):  # pragma: no cover - compiled
            size = 1
            for s in shape:
                size *= s
            return size

        return impl

    @numba.njit(inline="always", nogil=True, error_model="numpy")
    def view(buffer: np.ndarray, offset: int, shape: Any) -> np.ndarray:  # pragma: no cover - compiled
        return buffer[offset : offset + count(shape)].reshape(shape)

    return view, view


_RAW = _try("views", _raw_views)
#: Whether the kernels' views of their buffers skip reference counting and bounds checks (else checked slices).
VIEWS = _RAW is not None
#: ``floats_view(buffer, offset, shape)``: the float64 array of ``shape`` (an int or a tuple; C order) that starts at
#: element ``offset`` of ``buffer`` (1-D float64, contiguous). Compiled inline; with the ``views`` internal it neither
#: counts references nor checks bounds: only for buffers that are arguments of the calling kernel (its Python caller
#: holds them for the whole call), and the maker of the views checks once that the buffer is long enough.
#: ``ints_view``: the same of a 1-D int64 buffer.
floats_view, ints_view = _RAW if _RAW is not None else _checked_views()


# ----------------------------------------------------------------- threads: a kernel's machine code on numba's threads
def _thread_internals() -> Any:
    from numba import types as nbtypes
    from numba._dispatcher import compute_fingerprint
    from numba.core import cgutils
    from numba.extending import intrinsic
    from numba.np.ufunc import parallel as numba_parallel

    for name in ("_is_initialized", "_launch_threads"):
        if not hasattr(numba_parallel, name):
            raise AttributeError(f"numba.np.ufunc.parallel has no {name}")
    for name in ("fold_argument_types", "typeof_pyval", "compile"):
        if not hasattr(numba.core.dispatcher.Dispatcher, name):
            raise AttributeError(f"numba's Dispatcher has no {name}")

    @intrinsic
    def call(typingctx: Any, address: Any, pre: Any, work: Any, first: Any, last: Any, post: Any) -> Any:  # pragma: no cover - compiled
        """Call the compiled function at the integer ``address`` (numba's calling convention, returning nothing) with
        the arguments ``(*pre, work, first, last, *post)``: 0 when it returned, 1 when it raised (its exception is
        dropped: the caller runs that range again from Python, where it is raised). numba's calling convention passes
        every argument as its fields, flattened, so a tuple's items given one after another are the same values."""
        if not (isinstance(address, nbtypes.Integer) and isinstance(pre, nbtypes.BaseTuple) and isinstance(post, nbtypes.BaseTuple)):
            return None  # a typing error
        argtypes = [*pre.types, work, first, last, *post.types]  # type: ignore[attr-defined]

        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            function = context.call_conv.get_function_type(nbtypes.none, argtypes)
            callee = builder.inttoptr(args[0], function.as_pointer())
            values = [*cgutils.unpack_tuple(builder, args[1]), args[2], args[3], args[4], *cgutils.unpack_tuple(builder, args[5])]
            status, _ = context.call_conv.call_function(builder, callee, nbtypes.none, argtypes, values)
            return builder.select(status.is_ok, context.get_constant(nbtypes.int64, 0), context.get_constant(nbtypes.int64, 1))

        return nbtypes.int64(address, pre, work, first, last, post), codegen

    return call, compute_fingerprint, numba_parallel, nbtypes


_THREADS = _try("threads", _thread_internals)
#: Whether a batch's ranges run on numba's own threads (else on a pool of Python threads).
THREADS = _THREADS is not None
#: The intrinsic that calls a kernel's machine code (None when the ``threads`` internal is off).
call_range: Any = _THREADS[0] if _THREADS is not None else None

#: The machine code's address of each (kernel, argument types) that :func:`machine_address` has looked up, keyed by
#: numba's fingerprints of the arguments (what its dispatcher keys its own types by: far cheaper than typing them).
_ADDRESSES: dict[tuple[Any, ...], int] = {}


def machine_address(run: Any, args: tuple[Any, ...]) -> int:
    """The address of the machine code that ``run`` (a numba dispatcher of a kernel that returns nothing) runs for
    ``args``: the overload that a call from Python compiles (or loads from the cache), compiled here if it has not run
    yet. A kernel's ``*args`` are one tuple: numba's dispatcher types them as the tuple of their types (``Tuple``,
    ``UniTuple``), not as the ``StarArgTuple`` that ``fold_argument_types`` makes, so they are typed as it does (else
    the kernel would be compiled a second time, and kept twice on disk). Only with the ``threads`` internal on."""
    assert _THREADS is not None
    _, fingerprint, _, nbtypes = _THREADS
    key = (run, *(fingerprint(a) for a in args))
    found = _ADDRESSES.get(key)
    if found is None:
        types = _argument_types(run, args)
        result = run.overloads.get(types)
        if result is None:
            run.compile(types)
            result = run.overloads[types]
        if result.signature.return_type != nbtypes.none:
            raise NotAVoidKernel(f"freefloat: run_kernel calls kernels that return nothing, not {result.signature.return_type}")
        found = _ADDRESSES[key] = int(result.library.get_pointer_to_function(result.fndesc.llvm_func_name))
    return found


def _argument_types(run: Any, args: tuple[Any, ...]) -> tuple[Any, ...]:
    """numba's types of ``args`` as ``run``'s dispatcher keys its overloads (a ``*args`` tuple as the tuple of its types)."""
    assert _THREADS is not None
    nbtypes = _THREADS[3]
    _, folded = run.fold_argument_types(tuple(run.typeof_pyval(a) for a in args), {})
    stars = (nbtypes.StarArgTuple, nbtypes.StarArgUniTuple)
    return tuple(nbtypes.BaseTuple.from_types(t.types) if isinstance(t, stars) else t for t in folded)


def overload_count(run: Any) -> int:
    """How many signatures the numba dispatcher ``run`` holds machine code for in this process (compiled or loaded):
    the size of its overloads, at the cost of a ``len`` (numba's public ``signatures`` lists them, hashing every
    argument type of every signature: tens of microseconds once a kernel has a few dozen, on every call that asks)."""
    try:
        return len(run.overloads)
    except (AttributeError, TypeError):
        return len(run.signatures)


def ready(run: Any, args: tuple[Any, ...]) -> bool:
    """Whether the kernel ``run`` (a numba dispatcher) has machine code for ``args`` without compiling: compiled in
    this process, or loaded now from its cache. Never compiles. With the ``threads`` internal off (it types the
    arguments): whether ``run`` has any compiled overload in this process."""
    if _THREADS is None:
        return bool(run.signatures)
    from numba.core.compiler_lock import global_compiler_lock

    types = _argument_types(run, args)
    if types in run.overloads:
        return True
    with global_compiler_lock:  # what the dispatcher's compile does before it compiles: the cache's overload, if any
        if types in run.overloads:
            return True
        cache = run._cache
        if _CACHE is not None and isinstance(cache, _CACHE[1]):
            found = cache.load_overload(types, run.targetctx, compiling=False)  # without taking the compile lock
        else:
            found = cache.load_overload(types, run.targetctx)  # numba's own cache
        if found is None:
            return False
        run.targetctx.insert_user_function(found.entry_point, found.fndesc, [found.library])
        run.add_overload(found)
        return True


@contextlib.contextmanager
def recorded_compiles() -> Iterator[dict[str, float]]:
    """The kernels this process compiles inside the block: the dict yielded is filled, at the end, with the longest
    compile of each (its name: seconds), from numba's compile events (``numba.core.event``, ``numba:compile``); left
    empty where numba has no such events."""
    took: dict[str, float] = {}
    try:
        from numba.core import event
    except ImportError:
        yield took
        return
    recorder = event.RecordingListener()
    event.register("numba:compile", recorder)
    try:
        yield took
    finally:
        event.unregister("numba:compile", recorder)
        started: dict[int, float] = {}
        for when, happened in recorder.buffer:
            data = happened.data if isinstance(happened.data, dict) else {}
            dispatcher = data.get("dispatcher")
            if dispatcher is None:
                continue
            if happened.is_start:
                started[id(data)] = when
            elif id(data) in started:
                name = str(dispatcher.py_func.__qualname__)
                took[name] = round(max(took.get(name, 0.0), when - started.pop(id(data))), 2)


def threads_launched() -> bool:
    """Whether numba's threads were launched in this process (True when that cannot be known: the safe answer for a
    child made by ``fork``, which must then not use them)."""
    return True if _THREADS is None else bool(_THREADS[2]._is_initialized)


def launch_threads() -> None:
    """Launch numba's threads (before asking numba which threading layer it uses)."""
    if _THREADS is not None:
        _THREADS[2]._launch_threads()


if _OFF:
    _say(*_OFF)
