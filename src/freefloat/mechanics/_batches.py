"""Chunked evaluation of the numpy reference paths (the papers' barycentric forms) over leading batch axes (private)."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

#: Configurations evaluated at once by the numpy reference paths; keeps temporaries in cache.
CHUNK = 4096


#: Upper bound on (configurations x bodies^2) per call of a barycentric pair kernel; keeps the pair arrays small.
PAIR_BUDGET = 1 << 17


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
