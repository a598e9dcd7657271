"""Faster J* batches and rollouts for one model structure, compiled once per machine (``ff.mechanics.specialise``).

Every call of freefloat runs without compiling anything per model (the engine's generic kernels).
Sweeps and campaigns on one robot can ask for more: :func:`specialise` compiles J* and the RK4
rollouts for the model's *structure* (its tree, joint types, joint placements and axes), from
the same recursions, with the structure folded into the code and several configurations per SIMD
instruction (eight on AVX-512, four on AVX2). It takes 2-5 s (J*) and 9-18 s (rollouts) once per
machine on the paper systems (kept in the user's cache folder); from then on, in every process,
:func:`~freefloat.generalized_jacobian` on batches of 64 configurations or more and
:func:`~freefloat.rollout` of 8 trajectories or more without external wrenches use it for every model of that
structure: masses, inertias and end-effector points are read at run time, so every
:meth:`~freefloat.Model.with_payload` variant shares it. Results agree with the generic kernels
to rounding (sin and cos within 1 ulp of the C library's over |q| <= 7 rad, 2 ulp over
|q| <= 1e5 rad). Measured on a 2-core AVX-512 machine: J* 4-6x and rollouts 4-8x the generic
kernels (docs/performance.md).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

from ..core.errors import UnknownNameError
from . import _specialise
from ._tree import tree

__all__ = ["is_specialised", "specialise"]


def specialise(model: Any, kinds: Sequence[str] = _specialise.KINDS, *, progress: Callable[[str], None] | None = None) -> dict[str, float]:
    """Compile the specialised kernels of ``kinds`` ("jstar", "rollout") for the structure of ``model``.

    Once per machine and structure: a later call (in any process) only loads them (well under a
    second). ``progress(kind)`` is called before each kind. Returns the seconds each kind took.
    Raises :class:`~freefloat.UnknownNameError` for an unknown kind.
    """
    for kind in kinds:
        if kind not in _specialise.KINDS:
            raise UnknownNameError("kind of specialised kernel", kind, _specialise.KINDS)
    t = tree(model)
    took = {}
    for kind in kinds:
        start = time.perf_counter()
        _specialise.specialise(t, (kind,), progress)
        took[kind] = time.perf_counter() - start
    return took


def is_specialised(model: Any, kind: str = "jstar") -> bool:
    """True when the kernels of ``kind`` for the structure of ``model`` were compiled on this machine (:func:`specialise`)."""
    if kind not in _specialise.KINDS:
        raise UnknownNameError("kind of specialised kernel", kind, _specialise.KINDS)
    return _specialise.find(tree(model), kind) is not None
