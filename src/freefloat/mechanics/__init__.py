"""Mechanics of a space robot (``ff.mechanics``): kinematics, Jacobians, momentum, H+, C+, dynamics.

Pure functions ``f(model, q, ...)`` batched over leading axes of
configurations (Papadopoulos & Dubowsky 1991, Papadopoulos 1992). The
everyday ones are also at the top level (``ff.forward_dynamics``); this
namespace gathers all of them, including the less common ones
(``generalized_jacobian_drift``, ``point_bias_acceleration``,
``spacecraft_fixed_dynamics``, ...). :mod:`.planar` is the planar view
(``ff.planar``). The physics is written once, in the compiled engine
(:mod:`freefloat.engine`, private), compiled once per machine. For large
batches on one robot, the library specialises J* and rollouts for the model's
structure by itself once the work pays for the compile (:func:`auto_specialise`;
:func:`specialise` does it up front), from the same recursions. The
papers' barycentric closed forms (``method="barycentric"``) check it.

Layer: imports :mod:`freefloat.core` and :mod:`freefloat.engine`.
"""

from __future__ import annotations

import warnings

from . import planar
from .dynamics import (
    forward_dynamics,
    inverse_dynamics,
    nonlinear_forces,
    passive_torque,
    point_bias_acceleration,
    spacecraft_fixed_dynamics,
    system_inertia_matrix_rate,
)
from .forces import ExternalWrench, actuation_from_generalized_forces, generalized_forces
from .jacobians import (
    actuation_jacobian,
    end_effector_jacobian,
    generalized_jacobian,
    generalized_jacobian_drift,
    jacobian_determinant,
    jacobian_measure,
    manipulability,
    point_jacobian,
    task_jacobian,
)
from .kinematics import (
    body_cm_positions,
    body_rotations,
    end_effector_positions,
    end_effector_rotations,
    forward_kinematics,
    joint_axes,
    point_positions,
    system_cm,
)
from .momentum import (
    InertiaBlocks,
    angular_momentum,
    free_floating_joint_inertia,
    inertia_blocks,
    kinetic_energy,
    linear_momentum,
    system_inertia_matrix,
    zero_momentum_rate,
)
from .specialised import auto_specialise, is_specialised, specialise
from .springs import spring_energy, spring_torque


def release_buffers() -> int:
    """Deprecated, to be removed in the next release: does nothing and returns 0 (bytes given back).

    The batched calls no longer keep output buffers for reuse: each result is a new array, or the caller's own
    array given as ``out=`` (``ff.generalized_jacobian(model, q, out=jac)``), which a loop of calls of one size
    fills again instead of making a new one. Emits a :class:`DeprecationWarning`.
    """
    warnings.warn(
        "ff.mechanics.release_buffers() does nothing: results are no longer recycled; pass out= to reuse an output",
        DeprecationWarning,
        stacklevel=2,
    )
    return 0


__all__ = [
    "ExternalWrench",
    "InertiaBlocks",
    "actuation_from_generalized_forces",
    "actuation_jacobian",
    "angular_momentum",
    "auto_specialise",
    "body_cm_positions",
    "body_rotations",
    "end_effector_jacobian",
    "end_effector_positions",
    "end_effector_rotations",
    "forward_dynamics",
    "forward_kinematics",
    "free_floating_joint_inertia",
    "generalized_forces",
    "generalized_jacobian",
    "generalized_jacobian_drift",
    "inertia_blocks",
    "inverse_dynamics",
    "is_specialised",
    "jacobian_determinant",
    "jacobian_measure",
    "joint_axes",
    "kinetic_energy",
    "linear_momentum",
    "manipulability",
    "nonlinear_forces",
    "passive_torque",
    "planar",
    "point_bias_acceleration",
    "point_jacobian",
    "point_positions",
    "release_buffers",
    "spacecraft_fixed_dynamics",
    "specialise",
    "spring_energy",
    "spring_torque",
    "system_cm",
    "system_inertia_matrix",
    "system_inertia_matrix_rate",
    "task_jacobian",
    "zero_momentum_rate",
]
