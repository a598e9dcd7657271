"""Reading a user's numbers: real numbers only, one rule for every public boundary (core, mechanics, simulation).

Booleans, complex numbers, text and other objects are a ``TypeError`` that names the field; NaN,
infinity and bounds are checked by the callers, who know the field's meaning.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["MAX_JOINT_VALUE", "real_array"]

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
