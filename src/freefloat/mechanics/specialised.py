"""Faster batches and rollouts for one model structure, compiled once per machine (``ff.mechanics.specialise``).

Every call of freefloat starts on the engine's generic kernels, which compile nothing per model.
Sweeps and campaigns on one robot get more **without asking**: once a process has spent, on the generic kernels of
one kind (J* batches, rollouts, H+, dynamics, the measures of J*) for one model structure, about half of what that
kind's specialisation takes to compile (:data:`AUTO_AFTER`, seconds per kind), it specialises that structure in a
background thread, says so once on standard error (and to the ``freefloat`` logger), and every later call and process
uses the result; the calls never wait for it. ``FREEFLOAT_AUTO_SPECIALISE=0`` or :func:`auto_specialise` (False) turns
this off. :func:`specialise` does it up front: it compiles the kinds of :data:`KINDS` (J*, the RK4 rollouts, H+,
forward and inverse dynamics, the measures of J*) for the model's *structure* (its tree, joint types, joint placements
and axes), from the same recursions, with the structure folded into the code and several configurations per SIMD
instruction (eight on AVX-512, four on AVX2). It compiles once per machine, seconds per kind (kept in the user's cache
folder); from then on, in every process, :func:`~freefloat.generalized_jacobian`, H+, the dynamics and the measures
of J* on batches of 64 configurations or more and :func:`~freefloat.rollout` of 8 trajectories or more use it for every model of that
structure (with external wrenches: for the wrenches' layout, their bodies and frames, given as ``external``; their
forces, couples and points are read at run time): masses, inertias and end-effector points are read at run time, so
every :meth:`~freefloat.Model.with_payload` variant shares it. Results agree with the generic kernels to rounding (sin
and cos within 1 ulp of the C library's over |q| <= 7 rad, 2 ulp over |q| <= 1e5 rad). On large batches the
specialised kernels are several times faster than the generic ones (docs/performance.md).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

from .. import engine
from ..core.errors import UnknownNameError
from ..engine import tree
from .forces import _engine_wrenches, _wrenches

__all__ = ["AUTO_AFTER", "KINDS", "auto_specialise", "is_specialised", "specialise"]

#: What can be specialised: "jstar" (J* batches), "rollout" (RK4 rollouts with the joint PD), "hplus" (H+ batches),
#: "forward" and "inverse" (forward and inverse dynamics batches), "measure" (det J*, the smallest singular value,
#: manipulability and condition number of chosen rows of J*: :func:`~.jacobians.jacobian_measure`, the singularity maps
#: and searches). The rollouts and dynamics are made for one layout of external wrenches (``external``; none by default).
KINDS = engine.SPECIALISED_KINDS

#: Seconds of work on the generic kernels (J*, rollouts) of one structure, in one process, after which it is
#: specialised in the background.
AUTO_AFTER = engine.AUTO_AFTER


def specialise(
    model: Any, kinds: Sequence[str] = engine.SPECIALISED_KINDS, *, external: Any = (), progress: Callable[[str], None] | None = None
) -> dict[str, float]:
    """Compile the specialised kernels of ``kinds`` (:data:`KINDS`; default all) for the structure of ``model``.

    Once per machine and structure: a later call (in any process) only loads them (well under a
    second). ``external``: :class:`~freefloat.ExternalWrench` items whose layout (bodies and frames, in that
    order; their forces, couples and points do not matter) the rollouts and forward and inverse dynamics are
    made for, as the calls with those wrenches pass them (``simulate(..., external=...)``); each layout is
    specialised apart. ``progress(kind)`` is called before each kind. Returns the seconds each kind took.
    Raises :class:`~freefloat.UnknownNameError` for an unknown kind.
    """
    for kind in kinds:
        if kind not in engine.SPECIALISED_KINDS:
            raise UnknownNameError("kind of specialised kernel", kind, engine.SPECIALISED_KINDS)
    t = tree(model)
    wrenches = _layout(model, external)
    took = {}
    for kind in kinds:
        start = time.perf_counter()
        engine.specialise_structure(t, (kind,), progress, wrenches=wrenches)
        took[kind] = time.perf_counter() - start
    return took


def is_specialised(model: Any, kind: str = "jstar", *, external: Any = ()) -> bool:
    """True when the kernels of ``kind`` for the structure of ``model`` (and the layout of the wrenches ``external``, for
    the kinds that take them) were compiled on this machine (:func:`specialise`)."""
    if kind not in engine.SPECIALISED_KINDS:
        raise UnknownNameError("kind of specialised kernel", kind, engine.SPECIALISED_KINDS)
    wrenches = _layout(model, external) if kind in engine.WRENCH_KINDS else ()
    return engine.find_specialised(tree(model), kind, wrenches) is not None


def _layout(model: Any, external: Any) -> engine.WrenchLayout:
    """The layout (bodies, frame codes) of the :class:`~freefloat.ExternalWrench` items ``external``, checked."""
    return engine.wrench_layout(_engine_wrenches(model, _wrenches(external))[0])


def auto_specialise(on: bool | None = None) -> bool:
    """Turn automatic specialisation on or off for this process (``on``); returns whether it is on now.

    On by default; the environment variable ``FREEFLOAT_AUTO_SPECIALISE=0`` turns it off for every process. When on,
    a structure whose generic J* batches (or rollouts) have taken :data:`AUTO_AFTER` seconds in this process is
    specialised in a background thread (once per machine: kept in the cache folder, like :func:`specialise`).
    """
    if on is not None:
        engine.set_auto(on)
    return engine.auto_enabled()
