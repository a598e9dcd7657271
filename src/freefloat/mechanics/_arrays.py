"""Shape checking and chunked evaluation shared by the batched functions (numpy side, private)."""

from __future__ import annotations

import contextvars
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


def new_output(shape: tuple[int, ...], dtype: Any = np.float64) -> np.ndarray:
    """``np.empty(shape)`` for a kernel's output, after a check that it fits in the free memory.

    Its pages are left to the kernel that fills it: the system zeroes each page at the first write, just
    before the kernel's stores, which then find its lines in cache. Touched first in the calling thread
    (as this did until the engine's maps were measured again), every page was zeroed out to memory and
    read back by the kernel's stores: alternated call by call on the project's 2-core VM (load 3.6,
    10^5 configurations, specialised kernels), touched / untouched: H+ of the 7-DOF arm (135 MB) 29 / 24
    ms median on one thread, 38 / 33 on two (worst 370 / 38 ms); J* of the 1992 system (38 MB) 16 / 12
    ms on two threads (worst 51 / 23). The spread that the touching was for (concurrent first-touch faults
    on two threads, J* at 1.6-33 M/s) remains in a process's first one to three such calls only (docs/performance.md).
    """
    nbytes = float(np.prod(shape, dtype=float)) * np.dtype(dtype).itemsize
    require_memory(nbytes, f"a result of shape {shape}", "pass fewer configurations per call (a loop over chunks of the batch)")
    return np.empty(shape, dtype=dtype)


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
