"""The engine's threads: a batch cut into contiguous ranges, one per thread, each run by the same compiled kernel.

Every batched kernel of the engine (:mod:`._drivers`' serial range kernels, a specialised module's ``blocks``) is
compiled once, without ``parallel=True``, and releases the GIL (``nogil``). :func:`run_ranges` runs it on the ranges
of a batch at once: the calling thread takes the first range, the threads of a pool kept for the process the others.
There is no threaded twin to compile: numba's ``prange`` driver of a kernel links the kernel and everything it inlines
into a module of its own and optimises it again (measured on the 2-core VM: J* of the 1992 system 10 s for its serial
kernel, 14 s more for the threaded one; the specialised measure of the 7-DOF arm 8 s, 13 s more), and that twin is
gone. The number of ranges is numba's thread count of the calling thread (``numba.set_num_threads``, the environment
variable ``NUMBA_NUM_THREADS``), so a user limits the engine's threads as before.

A kernel's ranges write into the call's outputs: :func:`run_ranges` returns, or raises, only when every range has
finished, Ctrl-C included (an interrupt is raised once the ranges running have finished, as numba's threads did), so
that no output is written after its call has ended (a recycled output buffer, :func:`~._arrays.new_output`, serves the
next call).
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor, wait

import numba

__all__ = ["range_count", "run_ranges", "thread_count", "threads_for"]

_POOL: list[ThreadPoolExecutor] = []
_LOCK = [threading.Lock()]


def _after_fork() -> None:
    """In a child made by ``fork`` (``multiprocessing``'s default on Linux): none of the parent's threads exist there, so
    a pool of its own is made at need (the parent's would take ranges that no thread runs: a hang)."""
    _POOL.clear()
    _LOCK[0] = threading.Lock()


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
