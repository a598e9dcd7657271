"""Shape checking and chunked evaluation shared by the batched functions (numpy side, private)."""

from __future__ import annotations

import contextvars
import math
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.errors import ShapeError
from ..core.numbers import check_joint_values, real_array
from ..core.resources import require_memory

if TYPE_CHECKING:
    from ..core.model import Model

#: Configurations evaluated at once by the numpy reference paths; keeps temporaries in cache.
CHUNK = 4096
#: Upper bound on (configurations x bodies^2) per call of a barycentric pair kernel; keeps the pair arrays small.
PAIR_BUDGET = 1 << 17


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


#: Set within :func:`computed_states`: joint arrays a simulation computed (no magnitude bound: a diverged run is still plotted).
_COMPUTED = contextvars.ContextVar("freefloat_computed_states", default=False)


@contextmanager
def computed_states() -> Iterator[None]:
    """Within this block, joint arrays are states a simulation computed, not a user's input: no magnitude bound."""
    token = _COMPUTED.set(True)
    try:
        yield
    finally:
        _COMPUTED.reset(token)


def joint_array(model: Model, q: Any, name: str = "q") -> np.ndarray:
    """``q`` as a float array of shape (..., N); a clear error otherwise (not real numbers, NaN/inf, beyond
    ``MAX_JOINT_VALUE`` of :mod:`freefloat.core.numbers`)."""
    arr = real_array(q, name)
    if not arr.flags.c_contiguous:  # one copy, which the engine makes anyway; the checks below then read it 3x faster
        arr = np.ascontiguousarray(arr)
    n = model.n_joints
    if arr.ndim == 0 or arr.shape[-1] != n:
        raise ShapeError(
            f"{name}: expected shape (..., {n}) (one value per joint: {', '.join(model.joint_names) or 'none'}), got {arr.shape}"
        )
    if not np.isfinite(arr).all():
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ValueError(
            f"{name}: has NaN or infinite entries (first at index {tuple(int(i) for i in bad)}, joint "
            f"{model.joint_names[int(bad[-1])]!r}); every joint angle must be a finite number in rad"
        )
    if not _COMPUTED.get():
        check_joint_values(arr, name, model.joint_names)
    return arr


def vector_array(value: Any, size: int, name: str, what: str) -> np.ndarray:
    """``value`` as a float array of shape (..., size); a clear error otherwise (finiteness: :func:`finite_vector`)."""
    arr = real_array(value, name)
    if arr.ndim == 0 or arr.shape[-1] != size:
        raise ShapeError(f"{name}: expected shape (..., {size}) ({what}), got {arr.shape}")
    return arr


def finite_vector(value: Any, size: int, name: str, what: str) -> np.ndarray:
    """:func:`vector_array`, with NaN and infinite entries refused."""
    arr = vector_array(value, size, name, what)
    if not np.isfinite(arr).all():
        raise ValueError(f"{name}: has NaN or infinite entries ({what}); every entry must be a finite number")
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
    size = math.prod(map(int, batch))
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


def pieces(kernel: Callable[..., Any], n_bodies: int) -> Callable[..., Any]:
    """Wrap a flat-batch kernel so that it runs on slices small enough for its B^2 pair arrays."""
    step = max(1, PAIR_BUDGET // max(1, n_bodies * n_bodies))

    def run(*arrays: np.ndarray) -> Any:
        size = arrays[0].shape[0]
        if size <= step:
            return kernel(*arrays)
        parts = [kernel(*(a[s : s + step] for a in arrays)) for s in range(0, size, step)]
        if isinstance(parts[0], tuple):
            return tuple(np.concatenate([p[i] for p in parts]) for i in range(len(parts[0])))
        return np.concatenate(parts)

    return run
