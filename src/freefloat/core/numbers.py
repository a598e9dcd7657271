"""Reading a user's numbers: real numbers only, one rule for every public boundary (core, mechanics, simulation).

Booleans, complex numbers, text and other objects are a ``TypeError`` that names the field; NaN,
infinity and bounds are checked by the callers, who know the field's meaning.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["MAX_JOINT_VALUE", "check_joint_values", "real_array"]

#: |q| above this (rad or m) is refused as input: no joint turns or slides that far, and sin/cos of such
#: angles lose their precision (an ulp of 1e6 rad is 1e-10 rad).
MAX_JOINT_VALUE = 1e6


def real_array(value: Any, name: str) -> np.ndarray:
    """``value`` as a float array; booleans, complex numbers, text and other objects are a TypeError naming ``name``."""
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError) as exc:  # ragged nested lists
        raise TypeError(f"{name}: expected real numbers in a regular array, got {value!r:.80} ({exc})") from None
    kind = arr.dtype.kind
    if kind in "iuf":
        return arr.astype(float, copy=False)
    kinds = {"b": "booleans", "c": "complex numbers", "U": "text", "S": "bytes", "O": "objects that are not all numbers"}
    what = kinds.get(kind, str(arr.dtype))
    raise TypeError(f"{name}: expected real numbers, got {what} ({value!r:.80})")


def check_joint_values(arr: np.ndarray, name: str, joint_names: Sequence[str] | None = None) -> None:
    """Refuse joint values (..., N) beyond :data:`MAX_JOINT_VALUE`, naming the largest and its joint."""
    if not arr.size or max(float(arr.max()), -float(arr.min())) <= MAX_JOINT_VALUE:
        return
    index = np.unravel_index(int(np.argmax(np.abs(arr))), arr.shape)
    joint = f" for joint {joint_names[int(index[-1])]!r}" if joint_names is not None and arr.ndim else ""
    raise ValueError(
        f"{name}: {float(arr[index]):.3g}{joint} is beyond {MAX_JOINT_VALUE:g} (rad or m), which no joint reaches; "
        "check the units (radians, metres)"
    )
