"""The engine: freefloat's compiled kernels, one unit behind this door (private to freefloat).

The rest of freefloat calls the engine through the names below and never imports its submodules (an import contract
checks it). Every call takes a :class:`~freefloat.Model` (turned into flat arrays once per model: :func:`tree`) and
batches of inputs over leading axes, and returns new arrays (or fills the caller's ``out`` where a call takes one:
:func:`check_out`); frames and units are those of the public functions of
:mod:`freefloat.mechanics` that call them.

Inside, read from the bottom up (the order an import contract checks): ``gate`` (the one module that uses numba's
internals, each with a fallback on public numba), ``cache`` (the on-disk kernel cache) and ``buffers`` (the outputs: a
new array or the caller's ``out``), ``layout`` (the model's and the scratch's layouts, declared once) and ``threads`` (a batch on
numba's threads), ``recursions`` (the O(N) recursions of one configuration), ``quantities`` (J*, J+, H+,
accelerations, the state derivative and the RK4 step of one configuration), ``measures`` (the measures of a Jacobian,
SIMD across configurations) and ``specialise/lanes`` (the lane loops), ``laws`` (the compiled control laws),
``drivers`` (the batch loops), ``stepper`` (one trajectory stepped from Python), ``stops`` (joint-limit spans of
recorded trajectories) and ``specialise/trace``, ``specialise/build`` (the same recursions traced, emitted as SIMD
code for one model structure and driven block by block), and ``calls`` (the Python side of every call below).
"""

from __future__ import annotations

from .buffers import check_out, owned
from .calls import (
    Stepper,
    accelerations,
    frames,
    generalized_jacobian,
    inertia_matrix,
    inertia_matrix_rate,
    jacobian_measures,
    law_rollout,
    point_biases,
    point_jacobians,
    points,
    residual_rows,
    rk4_batch,
    rollout,
    specialised_rollouts,
    state_derivative,
)
from .drivers import Batched as _Batched
from .folders import (
    KERNELS_ENV,
    cache_dir,
    compiling_now,
    kernel_status,
    kernels_setting,
    portable_dir,
    source_key,
    watch_compiles,
)
from .gate import recorded_compiles
from .laws import DETUMBLE, OPERATIONAL_SPACE, PROFILES, TRANSPOSED_JACOBIAN, actuator_bounds, make_law, same_structure
from .layout import Tree, tree
from .recursions import FRICTION_SPEED
from .specialise.build import AUTO_AFTER, WRENCH_KINDS, auto_enabled, set_auto
from .specialise.build import KINDS as SPECIALISED_KINDS
from .specialise.build import Layout as WrenchLayout
from .specialise.build import find as find_specialised
from .specialise.build import layout as wrench_layout
from .specialise.build import specialise as specialise_structure
from .stepper import REFUSED
from .stops import limit_spans_batch
from .threads import numba_threads

#: The batch size from which a batched call runs on threads (the warm-up compiles the threaded drivers with it).
PARALLEL_MIN = _Batched.PARALLEL_MIN

__all__ = [
    "AUTO_AFTER",
    "DETUMBLE",
    "FRICTION_SPEED",
    "KERNELS_ENV",
    "OPERATIONAL_SPACE",
    "PARALLEL_MIN",
    "PROFILES",
    "REFUSED",
    "SPECIALISED_KINDS",
    "TRANSPOSED_JACOBIAN",
    "WRENCH_KINDS",
    "Stepper",
    "Tree",
    "WrenchLayout",
    "accelerations",
    "actuator_bounds",
    "auto_enabled",
    "cache_dir",
    "check_out",
    "compiling_now",
    "find_specialised",
    "frames",
    "generalized_jacobian",
    "inertia_matrix",
    "inertia_matrix_rate",
    "jacobian_measures",
    "kernel_status",
    "kernels_setting",
    "law_rollout",
    "limit_spans_batch",
    "make_law",
    "numba_threads",
    "owned",
    "point_biases",
    "point_jacobians",
    "points",
    "portable_dir",
    "recorded_compiles",
    "residual_rows",
    "rk4_batch",
    "rollout",
    "same_structure",
    "set_auto",
    "source_key",
    "specialise_structure",
    "specialised_rollouts",
    "state_derivative",
    "tree",
    "watch_compiles",
    "wrench_layout",
]
