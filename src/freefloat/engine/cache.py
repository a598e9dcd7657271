"""``numba.njit`` with freefloat's on-disk cache: every kernel of the engine is made here (:func:`kernel`,
:func:`inline_kernels`, :func:`bind`), with numba's options of all of them (:data:`_OPTIONS`).

Every generic kernel of the engine (those :mod:`.calls` runs) takes the model as plain arrays, so it is compiled once
for all models and numba keeps the machine code on disk between processes. numba's public switch ``cache=True``
picks the folder from a process-wide setting (``NUMBA_CACHE_DIR``) that would also move the user's own numba caches,
so the kernels are given a cache whose locator points to freefloat's folder (:func:`.gate.attach_cache`: one of
numba's internals; where it cannot be used, the kernels keep numba's own cache, ``cache=True``). Where that folder
is, the portable kernels and the compile lock: :mod:`.folders`.
"""

from __future__ import annotations

import linecache
import types
from collections.abc import Callable
from typing import Any, Literal

import numba

from . import gate
from .folders import EVENTS, CacheWarning, cache_dir, source_key
from .gate import floats_view, ints_view, slice_view

__all__ = ["CacheWarning", "bind", "cache_dir", "floats_view", "inline_kernels", "ints_view", "kernel", "slice_view", "source_key"]


#: numba's options of every kernel of the engine.
_OPTIONS: dict[str, Any] = {"nogil": True, "error_model": "numpy", "fastmath": {"contract"}}


def kernel(*, parallel: bool = False, inline: Literal["never", "always"] = "never") -> Callable[[Callable[..., Any]], Any]:
    """``numba.njit`` with freefloat's on-disk cache (see the module docstring)."""

    def wrap(func: Callable[..., Any]) -> Any:
        options: dict[str, Any] = {**_OPTIONS, "parallel": parallel, "inline": inline}
        dispatcher = numba.njit(cache=False, **options)(func)
        if gate.attach_cache(dispatcher, func, EVENTS):
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
