"""Shape checking and chunked evaluation shared by the batched functions."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import ShapeError

if TYPE_CHECKING:
    from .model import Model

#: Configurations evaluated at once inside one kernel call; keeps temporaries in cache.
CHUNK = 4096


def joint_array(model: Model, q: Any, name: str = "q") -> np.ndarray:
    """``q`` as a float array of shape (..., N); a clear error otherwise."""
    arr = np.asarray(q, dtype=float)
    n = model.n_joints
    if arr.ndim == 0 or arr.shape[-1] != n:
        raise ShapeError(
            f"{name}: expected shape (..., {n}) (one value per joint: {', '.join(model.joint_names) or 'none'}), got {arr.shape}"
        )
    return arr


def vector_array(value: Any, size: int, name: str, what: str) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0 or arr.shape[-1] != size:
        raise ShapeError(f"{name}: expected shape (..., {size}) ({what}), got {arr.shape}")
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
        np.broadcast_to(a, batch + a.shape[a.ndim - nd :]).reshape((size,) + a.shape[a.ndim - nd :])
        for a, nd in zip(arrays, core_ndims, strict=True)
    ]
    pieces = [kernel(*(f[s : s + CHUNK] for f in flat)) for s in range(0, max(size, 1), CHUNK)] if size else [kernel(*flat)]
    single = not isinstance(pieces[0], tuple)
    if single:
        pieces = [(p,) for p in pieces]
    outs = tuple(
        (np.concatenate([p[i] for p in pieces], axis=0) if len(pieces) > 1 else pieces[0][i]).reshape(batch + pieces[0][i].shape[1:])
        for i in range(len(pieces[0]))
    )
    return outs[0] if single else outs
