"""Reading a user's numbers: real numbers only, one rule for every public boundary (core, mechanics, simulation).

Booleans, complex numbers, text and other objects are a ``TypeError`` that names the field; NaN,
infinity and bounds are checked by the callers, who know the field's meaning. The bounds shared by
several modules live here: finite values beyond them are no space robot's (a unit slip or a typo),
and are refused with an error that names the field, the bound and the fix.
"""

from __future__ import annotations

import contextvars
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import ShapeError

if TYPE_CHECKING:
    from .model import Model

__all__ = [
    "MAX_EFFORT",
    "MAX_FREQUENCY",
    "MAX_JOINT_VALUE",
    "MAX_POSITION",
    "MAX_RATE",
    "MAX_RTOL",
    "MAX_SPEED",
    "MIN_RTOL",
    "check_joint_rates",
    "check_joint_values",
    "check_largest",
    "computed_states",
    "finite_vector",
    "joint_array",
    "real_array",
    "tolerance_problem",
    "vector_array",
]

#: |q| above this (rad or m) is refused as input: no joint turns or slides that far, and sin/cos of such
#: angles lose their precision (an ulp of 1e6 rad is 1e-10 rad).
MAX_JOINT_VALUE = 1e6
#: No joint of a space robot turns faster than this (rad/s; about 95,000 rpm) nor slides faster (m/s), and no
#: spacecraft spins faster: a rate beyond it means the actuation or the initial state is not physical, and
#: an adaptive integrator would take forever to resolve the motion. A reference rate beyond it is refused
#: as input; a simulation that reaches it stops with an error naming it (``simulation._guard.DivergenceGuard``).
MAX_RATE = 1e4
#: |r_cm| above this (m) is refused as input: 1e12 m is about 7 astronomical units, past Jupiter's orbit
#: in a Sun-centred frame (an ulp of 1e12 m is 0.1 mm: beyond it an arm's motion drowns in rounding).
MAX_POSITION = 1e12
#: |v_cm| above this (m/s) is refused as input: a third of the speed of light, some 2000 times the fastest
#: spacecraft launched.
MAX_SPEED = 1e8
#: A joint torque (N m) or force (N) above this is refused as input: it would spin the largest inertia a
#: model may have (1e15 kg m^2, :data:`freefloat.core.model.MAX_INERTIA`) beyond :data:`MAX_RATE` within
#: one second.
MAX_EFFORT = 1e19
#: A sinusoidal actuation faster than this (Hz) is refused: no actuator of a space robot follows a
#: megahertz, and resolving one would take steps below a microsecond.
MAX_FREQUENCY = 1e6
#: The adaptive integrators' relative tolerance ``rtol`` must lie in [MIN_RTOL, MAX_RTOL): below 100 machine
#: epsilons (2.2e-14) scipy raises it itself; at 1 or more it asks for no accuracy at all. The absolute
#: tolerance ``atol`` must lie in (0, MAX_RTOL): it applies to every entry of the state, the unit
#: quaternion and the joint angles (rad) included, where an error of 1 is no accuracy either.
MIN_RTOL = 100 * float(np.finfo(float).eps)
MAX_RTOL = 1.0


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


def check_largest(
    arr: np.ndarray, name: str, limit: float, unit: str, why: str, fix: str, labels: Callable[[int], str] | Sequence[str] | None = None
) -> None:
    """Refuse finite values (..., K) whose magnitude exceeds ``limit``: a ValueError
    ``"{name}: {value}[ for {label}] is beyond {limit} ({unit}), {why}; {fix}"`` naming the largest one
    (and its label, ``labels[k]`` (or ``labels(k)``) for the last axis, when given)."""
    if not arr.size or max(float(arr.max()), -float(arr.min())) <= limit:
        return
    index = np.unravel_index(int(np.argmax(np.abs(arr))), arr.shape)
    k = int(index[-1]) if arr.ndim else 0
    label = "" if labels is None or not arr.ndim else f" for {labels(k) if callable(labels) else labels[k]}"
    raise ValueError(f"{name}: {float(arr[index]):.3g}{label} is beyond {limit:g} ({unit}), {why}; {fix}")


def check_joint_values(arr: np.ndarray, name: str, joint_names: Sequence[str] | None = None) -> None:
    """Refuse joint values (..., N) beyond :data:`MAX_JOINT_VALUE`, naming the largest and its joint."""
    labels = None if joint_names is None else lambda k: f"joint {joint_names[k]!r}"  # made only for the error
    check_largest(arr, name, MAX_JOINT_VALUE, "rad or m", "which no joint reaches", "check the units (radians, metres)", labels)


def check_joint_rates(arr: np.ndarray, name: str, joint_names: Sequence[str] | None = None) -> None:
    """Refuse joint rates (..., N) beyond :data:`MAX_RATE`, naming the largest and its joint."""
    labels = None if joint_names is None else lambda k: f"joint {joint_names[k]!r}"  # made only for the error
    check_largest(arr, name, MAX_RATE, "rad/s or m/s", "which no joint of a space robot reaches", "check the units (rad/s, m/s)", labels)


def tolerance_problem(name: str, value: float) -> tuple[str, str] | None:
    """What is wrong with an adaptive integrator's tolerance ``name`` ("rtol" or "atol"), already a positive finite
    float: ``(problem, fix)``, or None when it lies in range (rtol in [:data:`MIN_RTOL`, :data:`MAX_RTOL`), atol in
    (0, :data:`MAX_RTOL`))."""
    if value >= MAX_RTOL:
        what = "a relative" if name == "rtol" else "an absolute"
        return (
            f"{value:g} is not below {MAX_RTOL:g}: {what} tolerance of {MAX_RTOL:g} or more asks for no accuracy at all"
            + ("" if name == "rtol" else " (it applies to the unit quaternion and the joint angles in rad too)"),
            f"give a small positive number, such as 1e-10 (rtol in [{MIN_RTOL:.3g}, 1), atol in (0, 1))",
        )
    if name == "rtol" and value < MIN_RTOL:
        return (
            f"{value:g} is below {MIN_RTOL:.3g}, 100 machine epsilons: no integrator resolves the state more finely",
            f"give a number in [{MIN_RTOL:.3g}, 1), such as 1e-10",
        )
    return None


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
