"""The outputs of the batched calls: a new array each call, or the caller's own (``out=``), and the kernels' inputs."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..core.errors import ShapeError
from ..core.resources import require_memory


def check_out(out: Any, shape: tuple[int, ...], name: str = "out") -> np.ndarray:
    """``out`` when it can take a result of ``shape``: a numpy array of exactly that shape, float64, writable,
    C-contiguous and aligned (the kernels write its memory row by row); else an error naming ``name``, what was
    expected and the fix (TypeError for the type and the dtype, ShapeError for the shape, ValueError for the layout)."""
    shape = tuple(int(s) for s in shape)
    fix = f"pass {name}=np.empty({shape}) (float64), or call without {name} for a new array"
    if not isinstance(out, np.ndarray):
        raise TypeError(f"{name}: expected a float64 numpy array of shape {shape}, got {type(out).__name__}; {fix}")
    if out.dtype != np.float64:
        raise TypeError(f"{name}: expected dtype float64, got {out.dtype}; {fix}")
    if out.shape != shape:
        raise ShapeError(f"{name}: expected shape {shape} (the result's), got {out.shape}; {fix}")
    if not out.flags.writeable:
        raise ValueError(f"{name}: is read-only; {fix}")
    if not (out.flags.c_contiguous and out.flags.aligned):
        raise ValueError(f"{name}: is not C-contiguous and aligned (a strided view, a transpose or an offset buffer); {fix}")
    return out


def new_output(shape: tuple[int, ...], dtype: Any = np.float64, *, out: Any = None) -> np.ndarray:
    """A kernel's output of ``shape``: the caller's ``out`` once :func:`check_out` accepts it (float64 only), else
    ``np.empty(shape, dtype)`` after a check that it fits in the free memory."""
    if out is not None:
        return check_out(out, shape)
    size = math.prod(map(int, shape))  # Python integers: exact at any size, and cheaper than np.prod
    nbytes = float(size * np.dtype(dtype).itemsize)
    require_memory(nbytes, f"a result of shape {shape}", "pass fewer configurations per call (a loop over chunks of the batch)")
    return np.empty(shape, dtype=dtype)


def owned(arr: Any, dtype: Any = np.float64) -> np.ndarray:
    """arr as a C-contiguous, writable array of ``dtype``.

    numba types read-only arrays apart from writable ones, so a kernel called with both would be
    compiled twice: every array passed to a kernel goes through here (a copy only when needed).
    """
    out = np.ascontiguousarray(arr, dtype=dtype)
    return out if out.flags.writeable else out.copy()
