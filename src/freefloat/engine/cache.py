"""Compile the engine's kernels once per machine: numba's on-disk cache, kept in the user's cache directory.

Every generic kernel of the engine (those :mod:`.calls` runs) takes the model as plain arrays, so it is
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
given a cache whose locator points to our folder (:func:`.gate.attach_cache`: one of numba's internals; where it
cannot be used, the kernels keep numba's own cache, ``cache=True``).
"""

from __future__ import annotations

import functools
import hashlib
import linecache
import os
import types
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any, Literal

import numba
import platformdirs

from ..core.feedback import notice
from . import gate
from .gate import floats_view, ints_view, slice_view

__all__ = ["CacheWarning", "bind", "cache_dir", "floats_view", "inline_kernels", "ints_view", "kernel", "slice_view"]


class CacheWarning(UserWarning):
    """The on-disk kernel cache could not be used; the kernel was compiled again (a few seconds)."""


#: The modules whose kernels are cached; numba does not track calls across files, so the
#: cache folder is keyed by a hash of all of them (an edit or an upgrade starts a fresh folder).
KERNEL_MODULES = (
    "gate.py",
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
    for name in ("numbers.py", "state_layout.py"):  # core's constants the kernels compile in (MAX_EFFORT, the flat state's offsets)
        digest.update((here.parent / "core" / name).read_bytes())
    return digest.hexdigest()[:16]


def cache_dir() -> Path:
    """The folder that holds the compiled kernels of this numba version and this engine source."""
    root = os.environ.get("FREEFLOAT_CACHE_DIR") or platformdirs.user_cache_dir("freefloat")
    return Path(root) / "numba" / f"{numba.__version__}-{_source_key()}"


def _broken(folder: str, name: str, exc: BaseException) -> None:
    warnings.warn(
        f"freefloat: the compiled-kernel cache in {folder} is broken for {name} ({type(exc).__name__}: {exc}); "
        "compiling it again and rewriting the cache",
        CacheWarning,
        stacklevel=4,
    )


def _unwritable(folder: str, exc: BaseException) -> None:
    warnings.warn(
        f"freefloat: cannot write the compiled-kernel cache in {folder} ({type(exc).__name__}: {exc}); "
        "kernels will be compiled again in the next process (set FREEFLOAT_CACHE_DIR to a writable folder)",
        CacheWarning,
        stacklevel=4,
    )


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


#: numba's options of every kernel of the engine.
_OPTIONS: dict[str, Any] = {"nogil": True, "error_model": "numpy", "fastmath": {"contract"}}


def kernel(*, parallel: bool = False, inline: Literal["never", "always"] = "never") -> Callable[[Callable[..., Any]], Any]:
    """``numba.njit`` with freefloat's on-disk cache (see the module docstring)."""

    def wrap(func: Callable[..., Any]) -> Any:
        options: dict[str, Any] = {**_OPTIONS, "parallel": parallel, "inline": inline}
        dispatcher = numba.njit(cache=False, **options)(func)
        if gate.attach_cache(dispatcher, func, _EVENTS):
            return dispatcher
        return numba.njit(cache=True, **options)(func)  # numba's own cache

    return wrap


def inline_kernels(text: str, names: tuple[str, ...], namespace: dict[str, Any], origin: str) -> tuple[Any, ...]:
    """The kernels ``names`` defined by the generated Python source ``text`` (written from a declaration: the model's
    and the scratch's views, :mod:`.layout`), compiled inline (``inline="always"``) in every kernel that calls them.

    ``text`` runs in ``namespace`` (the globals of the declaring module: its functions see the module's names, as a
    function written there would); ``origin`` names the declaration in tracebacks and :func:`inspect.getsource` (the text is
    kept under ``<freefloat: origin>``, no file is written). An inline kernel needs no cache of its own (numba's caches need
    a source file): its machine code is in each calling kernel's cache entry, and the calling kernels' folder is keyed
    by the declaring module's source (:data:`KERNEL_MODULES`), from which ``text`` is written.
    """
    filename = f"<freefloat: {origin}>"
    linecache.cache[filename] = (len(text), None, text.splitlines(keepends=True), filename)
    exec(compile(text, filename, "exec"), namespace)
    return tuple(numba.njit(cache=False, **_OPTIONS, inline="always")(namespace[name]) for name in names)


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


#: What freefloat's cache reports (:class:`.gate.CacheEvents`).
_EVENTS = gate.CacheEvents(
    folder=lambda: str(cache_dir()), missed=lambda folder: _announce_compile(folder), broken=_broken, unwritable=_unwritable
)
