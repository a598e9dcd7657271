"""The engine's threads: a batch cut into contiguous ranges, one per thread, each run by the same compiled kernel.

Every batched kernel of the engine (:mod:`.drivers`' serial range kernels, a specialised module's ``blocks``) is
compiled once, without ``parallel=True``, and releases the GIL (``nogil``). :func:`run_kernel` runs it on the ranges of
a batch at once on numba's own threads (its threading layer, as a ``prange`` would): one small parallel loop,
:func:`_fan_out`, calls the kernel's machine code through its address (:func:`.gate.machine_address`,
:data:`.gate.call_range`), so that no kernel is compiled twice. A ``prange`` driver of the kernel itself would link the
kernel and everything it inlines into a module of its own and optimise it again, which more than doubled a kernel's
compile time; :func:`_fan_out` is small and compiles quickly, once per signature of the kernels it calls and per
machine (numba's cache). numba's threads wait for work spinning a while before they sleep, so handing them the ranges
is far cheaper than waking a thread of a pool (:func:`run_ranges`, which runs a Python callable on the ranges: the
calling thread takes the first, the threads of a pool kept for the process the others). The number of ranges is
numba's thread count of the calling thread (``numba.set_num_threads``, the environment variable
``NUMBA_NUM_THREADS``), so a user limits the engine's threads as with numba's own parallel loops.

Where numba's threads cannot serve, :func:`run_kernel` runs the ranges on the pool instead: with the ``threads``
internal off (:mod:`.gate`: an untested numba, a failed lookup, ``FREEFLOAT_NUMBA_INTERNALS=0``), in a child made by
``fork`` after the parent launched them (GNU OpenMP, numba's usual layer on Linux, ends such a child at its first
parallel loop), and while another thread of the process has a loop of the engine's on the ``workqueue`` layer (it takes
one at a time; numba falls back to it where neither TBB nor an OpenMP runtime is installed; a user's own ``prange``
running at once in another thread on that layer still ends the process, as numba documents). On GNU OpenMP each
calling thread gets a team of numba's threads of its own (many threads calling at once: more threads than cores).

A kernel's ranges write into the call's outputs: :func:`run_kernel` and :func:`run_ranges` return, or raise, only when every range has
finished, Ctrl-C included (an interrupt is raised once the ranges running have finished, as numba's threads did), so
that no output is written after its call has ended (the caller may read or reuse its outputs as soon as the call
returns).
"""

from __future__ import annotations

import contextlib
import functools
import os
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor, wait
from typing import Any

import numba
import numpy as np

from . import gate
from .cache import kernel

__all__ = ["compiled_count", "range_count", "run_kernel", "run_ranges", "thread_count", "threads_for"]

_POOL: list[ThreadPoolExecutor] = []
_LOCK = [threading.Lock()]
#: Whether numba's threads may run the ranges in this process (:func:`run_kernel`): not in a child forked after its
#: parent launched them.
_NUMBA_THREADS = [True]
#: Held while a loop runs on numba's ``workqueue`` layer, which takes one loop at a time.
_WORKQUEUE = threading.Lock()


def _after_fork() -> None:
    """In a child made by ``fork`` (``multiprocessing``'s default on Linux): none of the parent's threads exist there, so
    a pool of its own is made at need (the parent's would take ranges that no thread runs: a hang); numba's threads,
    if the parent had launched them, are not used (GNU OpenMP ends the child at its first parallel loop)."""
    _POOL.clear()
    _LOCK[0] = threading.Lock()
    if gate.threads_launched():
        _NUMBA_THREADS[0] = False


os.register_at_fork(after_in_child=_after_fork)


def thread_count() -> int:
    """The threads a batch may run on: numba's thread count of the calling thread."""
    return int(numba.get_num_threads())


def threads_for(size: int, threshold: int) -> int:
    """The ranges a batch of ``size`` asks for: numba's thread count of the calling thread from ``threshold`` on, else 1."""
    return thread_count() if size >= threshold else 1


def range_count(count: int, parts: int) -> int:
    """How many ranges :func:`run_ranges` makes of ``[0, count)`` when asked for ``parts``: at least one, at most
    ``count`` (a caller makes one scratch buffer per range)."""
    return max(1, min(parts, count))


def _pool() -> ThreadPoolExecutor:
    with _LOCK[0]:
        if not _POOL:  # as many threads as numba may use, less the calling thread's
            _POOL.append(ThreadPoolExecutor(max(1, int(numba.config.NUMBA_NUM_THREADS) - 1), thread_name_prefix="freefloat"))  # type: ignore[attr-defined]
        return _POOL[0]


def _finish(futures: list[Future[object]]) -> None:
    """Wait for every future, through Ctrl-C: an interrupt is raised again once all of them have finished."""
    interrupt: KeyboardInterrupt | None = None
    while True:
        try:
            wait(futures)
            break
        except KeyboardInterrupt as exc:
            interrupt = exc
    if interrupt is not None:
        raise interrupt


def run_ranges(run: Callable[[int, int, int], object], count: int, parts: int) -> None:
    """``run(r, first, last)`` for the ``parts`` contiguous ranges r of ``[0, count)`` (at most ``count`` of them; their
    lengths differ by one at most), at once: range 0 in the calling thread, the others on the pool's threads (in the
    calling thread too once the interpreter is shutting down, when a pool takes no more work: a thread left running
    after the main script, an ``atexit`` handler). Returns when every range has finished; the first exception raised
    by a range is raised here."""
    parts = range_count(count, parts)
    if parts == 1:
        run(0, 0, count)
        return
    edges = [r * count // parts for r in range(parts + 1)]
    pool = _pool()
    futures: list[Future[object]] = []
    mine = [0]  # the ranges this thread runs: range 0, and any the pool no longer takes
    try:
        for r in range(1, parts):
            try:
                futures.append(pool.submit(run, r, edges[r], edges[r + 1]))
            except RuntimeError:  # the interpreter is shutting down ("cannot schedule new futures"): run it here
                mine.append(r)
        for r in mine:
            run(r, edges[r], edges[r + 1])
    finally:
        _finish(futures)
    for future in futures:
        future.result()


# ----------------------------------------------------------------- a compiled kernel on numba's threads
#: The intrinsic that calls a kernel's machine code (:func:`.gate.call_range`; None when that internal is off).
_call_range: Any = gate.call_range


@kernel(parallel=True)
def _fan_out(address: int, pre: Any, work: np.ndarray, post: Any, count: int, failed: np.ndarray) -> int:  # pragma: no cover - compiled
    """The kernel at ``address`` on the ``failed.shape[0]`` ranges r of ``[0, count)``, each on a thread of numba's with
    the scratch row ``work[r]``; ``failed[r]`` 1 where range r raised, 0 where it returned; how many raised."""
    parts = failed.shape[0]
    for r in numba.prange(parts):
        first = np.int64(r) * count // parts
        last = (np.int64(r) + 1) * count // parts
        failed[r] = _call_range(address, pre, work[r], first, last, post)
    return failed.sum()


def compiled_count() -> int:
    """How many signatures of :func:`_fan_out` this process has compiled or loaded (one per signature of the kernels it
    has called on threads): a call that raised it compiled one."""
    return gate.overload_count(_fan_out)


def _flat(values: tuple[Any, ...]) -> tuple[Any, ...]:
    """``values`` with every tuple in it replaced by its items, at any depth: what :func:`_fan_out` passes (a tuple in a
    tuple cannot enter a ``prange`` loop; the kernel's machine code takes a tuple's fields one by one either way)."""
    if not any(isinstance(v, tuple) for v in values):
        return values
    return tuple(item for v in values for item in (_flat(v) if isinstance(v, tuple) else (v,)))


@functools.cache
def _layer() -> str:
    """numba's threading layer, its threads launched here if they were not yet."""
    gate.launch_threads()
    return str(numba.threading_layer())


def run_kernel(run: Any, pre: tuple[Any, ...], work: np.ndarray, post: tuple[Any, ...], count: int, parts: int) -> None:
    """``run(*pre, work[r], first, last, *post)`` for the ``parts`` contiguous ranges r of ``[0, count)`` (at most
    ``count`` of them, their lengths differ by one at most) at once, on numba's threads (see the module docstring);
    ``run`` a compiled kernel (a numba dispatcher) that returns nothing, ``work`` one scratch row per range; the arrays
    of native byte order, as the engine's are (:func:`.buffers.owned`: numba's fingerprints of arrays, the key of
    :func:`.gate.machine_address`, do not tell byte orders apart). Returns when every range has finished; a range that raised is
    run again in the calling thread, which raises its error."""
    count = int(count)
    parts = range_count(count, parts)
    if work.shape[0] < parts:
        raise ValueError(f"freefloat: run_kernel needs a scratch row per range: {parts} ranges, {work.shape[0]} rows")
    if parts == 1:
        run(*pre, work[0], 0, count, *post)
        return

    def one(r: int, first: int, last: int) -> None:  # range r in the calling thread, a Python call of the kernel
        run(*pre, work[r], first, last, *post)

    if not (gate.THREADS and _NUMBA_THREADS[0]):  # numba's internals off, or forked
        run_ranges(one, count, parts)
        return
    try:
        address = gate.machine_address(run, (*pre, work[0], 0, count, *post))
    except gate.NotAVoidKernel:
        raise
    except Exception as exc:  # a lookup of numba's internals failed at its first use: the pool from now on
        gate.turn_off("threads", exc)
        run_ranges(one, count, parts)
        return
    queue = _layer() == "workqueue"
    if queue and not _WORKQUEUE.acquire(blocking=False):  # the layer is busy
        run_ranges(one, count, parts)
        return
    failed = np.empty(parts, dtype=np.int64)
    try:
        raised = _fan_out(address, _flat(pre), work, _flat(post), count, failed)
    finally:
        if queue:
            _WORKQUEUE.release()
    if raised:
        for r in map(int, np.flatnonzero(failed)):
            one(r, r * count // parts, (r + 1) * count // parts)


@contextlib.contextmanager
def numba_threads(count: int) -> Iterator[None]:
    """The calling thread's numba thread count set to ``count`` (at most numba's own), its own again on exit."""
    before = numba.get_num_threads()
    numba.set_num_threads(max(1, min(int(count), int(numba.config.NUMBA_NUM_THREADS))))  # type: ignore[attr-defined]
    try:
        yield
    finally:
        numba.set_num_threads(before)
