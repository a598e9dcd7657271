"""The outputs of the batched calls: large ones carved out of recycled buffers."""

from __future__ import annotations

import math
import sys
import threading
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.resources import require_memory

if TYPE_CHECKING:
    pass


#: Outputs of at least this many bytes are carved out of recycled buffers (:func:`new_output`).
RECYCLE_MIN = 4 << 20
#: Buffers larger than this are never kept for reuse (256 MiB: H+ of 10^5 configurations of a 7-joint arm is 135 MB, of
#: the 9-joint Panda 180 MB; at 128 MiB, until 2026-11-27, the 7-DOF arm's H+ of 10^5 ran at 4.24 M/s on 2 threads
#: of the Intel VM, recycled at 6.64-6.81 M/s, measured in one process).
RECYCLE_MAX = 256 << 20
#: The kept buffers hold at most this many bytes in all (the free ones are dropped oldest first to make room; a sweep
#: holds two: the last result while the next is made). ``ff.mechanics.release_buffers()`` gives the free ones back.
RECYCLE_HELD = 512 << 20
_RECYCLED: list[np.ndarray] = []
_RECYCLE_LOCK = threading.Lock()
#: Per kept buffer (its address): how many of its bytes, from its start, a kernel has written (:func:`mark_written`):
#: their pages are mapped (a new buffer's pages are mapped and zeroed by the system at their first write).
_WRITTEN: dict[int, int] = {}


def _free(i: int) -> bool:
    """Whether no array uses the kept buffer i any more: its only references are the list's and getrefcount's
    argument (every view holds the buffer itself: numpy keeps one base, not a chain of views)."""
    return sys.getrefcount(_RECYCLED[i]) == 2


def _recycled(nbytes: int) -> np.ndarray:
    """A float64 buffer of ``nbytes`` to twice that which no array uses any more, or a new one, kept for later calls
    while the kept buffers hold at most :data:`RECYCLE_HELD` bytes."""
    with _RECYCLE_LOCK:
        for i in range(len(_RECYCLED)):
            if nbytes <= _RECYCLED[i].nbytes <= 2 * nbytes and _free(i):
                _RECYCLED.append(_RECYCLED.pop(i))  # most recently used last
                return _RECYCLED[-1]
        buf = np.empty(-(-nbytes // 8))
        i = 0
        while i < len(_RECYCLED) and sum(b.nbytes for b in _RECYCLED) + buf.nbytes > RECYCLE_HELD:
            if _free(i):
                _WRITTEN.pop(_RECYCLED.pop(i).ctypes.data, None)  # the oldest free buffer makes room
            else:
                i += 1
        if sum(b.nbytes for b in _RECYCLED) + buf.nbytes <= RECYCLE_HELD:
            _RECYCLED.append(buf)
        return buf


def _holder(start: int) -> np.ndarray | None:
    """The kept buffer whose memory holds the address ``start`` (under the lock)."""
    for b in _RECYCLED:
        if b.ctypes.data <= start < b.ctypes.data + b.nbytes:
            return b
    return None


def mark_written(a: np.ndarray) -> None:
    """Record that a kernel has written every byte of ``a`` (C-contiguous): when it lies in a kept buffer from within
    the part already written, that part now reaches ``a``'s end. Anything else is left as it was."""
    start = a.ctypes.data
    with _RECYCLE_LOCK:
        b = _holder(start)
        if b is None:
            return
        base = b.ctypes.data
        done = _WRITTEN.get(base, 0)
        if start - base <= done:
            _WRITTEN[base] = max(done, start + a.nbytes - base)


def written_before(a: np.ndarray) -> bool:
    """Whether all of ``a`` lies in the written part of a kept buffer (:func:`mark_written`): its pages are mapped, and a
    kernel's stores meet no page fault (a new mapping's pages are zeroed by the system at the first write, which
    leaves their lines in the caches). A buffer handed out again but never filled by a kernel is not."""
    start = a.ctypes.data
    with _RECYCLE_LOCK:
        b = _holder(start)
        return b is not None and start + a.nbytes - b.ctypes.data <= _WRITTEN.get(b.ctypes.data, 0)


def release_buffers() -> int:
    """Drop the output buffers kept for reuse that no array uses any more (:func:`new_output`; at most
    :data:`RECYCLE_HELD` bytes are ever kept): their memory goes back to the system now instead of serving the next
    large call. Buffers under a result the caller still holds stay. Returns the bytes dropped."""
    with _RECYCLE_LOCK:
        dropped = 0
        i = 0
        while i < len(_RECYCLED):
            if _free(i):
                buf = _RECYCLED.pop(i)
                _WRITTEN.pop(buf.ctypes.data, None)
                dropped += buf.nbytes
            else:
                i += 1
        return dropped


def new_output(shape: tuple[int, ...], dtype: Any = np.float64) -> np.ndarray:
    """``np.empty(shape)`` for a kernel's output, after a check that it fits in the free memory.

    A float64 output of :data:`RECYCLE_MIN` to :data:`RECYCLE_MAX` bytes is a view of a buffer that an earlier
    output used and the caller has since dropped (no view of it left): a sweep of calls of the same size then writes
    into memory it already has, instead of a fresh mapping whose pages the system zeroes at the first write, one fault
    at a time. Measured on the project's 2-core VM (J* of the 1992 system, 10^5 configurations, 38 MB, specialised
    kernels, load 1): a fresh mapping took 11-12 ms a call with 4 kB pages, and with the transparent huge pages that
    numpy asks for, 40-45 ms in a process's first 5-8 calls (the system compacting memory for them), 3.2-3.6 ms after.
    A recycled buffer is written in 2.1-2.3 ms a call from the third call on (the first two make the buffers; an
    anonymous mapping of 4 kB pages instead of numpy's made those 13-14 ms, then 3.0 ms a call: more TLB misses). The
    kept buffers hold at most :data:`RECYCLE_HELD` bytes (a sweep uses two: the last result while the next is made).

    Its pages are left to the kernel that fills it: the system zeroes each page at the first write, just
    before the kernel's stores, which then find its lines in cache. Touched first in the calling thread
    (as this did until the engine's maps were measured again), every page was zeroed out to memory and
    read back by the kernel's stores: alternated call by call on the project's 2-core VM (load 3.6,
    10^5 configurations, specialised kernels), touched / untouched: H+ of the 7-DOF arm (135 MB) 29 / 24
    ms median on one thread, 38 / 33 on two (worst 370 / 38 ms); J* of the 1992 system (38 MB) 16 / 12
    ms on two threads (worst 51 / 23). The spread that the touching was for (concurrent first-touch faults
    on two threads, J* at 1.6-33 M/s) remains in a process's first one to three such calls only (docs/performance.md).
    """
    size = math.prod(map(int, shape))  # Python integers: exact at any size (np.prod: 1.5 us a call)
    nbytes = float(size * np.dtype(dtype).itemsize)
    require_memory(nbytes, f"a result of shape {shape}", "pass fewer configurations per call (a loop over chunks of the batch)")
    if np.dtype(dtype) != np.float64 or not RECYCLE_MIN <= nbytes <= RECYCLE_MAX:
        return np.empty(shape, dtype=dtype)
    return _recycled(int(nbytes))[:size].reshape(shape)


def owned(arr: Any, dtype: Any = np.float64) -> np.ndarray:
    """arr as a C-contiguous, writable array of ``dtype``.

    numba types read-only arrays apart from writable ones, so a kernel called with both would be
    compiled twice: every array passed to a kernel goes through here (a copy only when needed).
    """
    out = np.ascontiguousarray(arr, dtype=dtype)
    return out if out.flags.writeable else out.copy()
