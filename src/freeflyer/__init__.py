"""freeflyer: kinematics, dynamics, control and workspaces of space robots.

Implements Papadopoulos & Dubowsky 1991 (coordinated manipulator/spacecraft
motion control) and Papadopoulos 1992 (large payload manipulation) in general:
3D trees with any number of arms and joints. See ``freeflyer.conventions``
for frames, units and orders.
"""

from __future__ import annotations

from . import conventions, models, planar
from .barycentric import BarycentricVectors, barycentric_vectors
from .dynamics import (
    ExternalWrench,
    actuation_from_generalized_forces,
    forward_dynamics,
    generalized_forces,
    inverse_dynamics,
    nonlinear_forces,
    point_bias_acceleration,
    spacecraft_fixed_dynamics,
    system_inertia_matrix_rate,
)
from .errors import (
    FreeflyerError,
    ModelError,
    NearSingularWarning,
    ShapeError,
    SingularConfigurationError,
    UnknownNameError,
)
from .io import load, save
from .jacobians import (
    actuation_jacobian,
    end_effector_jacobian,
    generalized_jacobian,
    generalized_jacobian_drift,
    jacobian_determinant,
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
    point_positions,
    system_cm,
)
from .model import Model, ModelBuilder
from .momentum import (
    InertiaBlocks,
    angular_momentum,
    inertia_blocks,
    kinetic_energy,
    linear_momentum,
    system_inertia_matrix,
)
from .singularity import DeterminantMap, jacobian_determinant_map

__version__ = "0.1.0"

__all__ = [
    "BarycentricVectors",
    "DeterminantMap",
    "ExternalWrench",
    "FreeflyerError",
    "InertiaBlocks",
    "Model",
    "ModelBuilder",
    "ModelError",
    "NearSingularWarning",
    "ShapeError",
    "SingularConfigurationError",
    "UnknownNameError",
    "actuation_from_generalized_forces",
    "actuation_jacobian",
    "angular_momentum",
    "barycentric_vectors",
    "body_cm_positions",
    "body_rotations",
    "conventions",
    "end_effector_jacobian",
    "end_effector_positions",
    "end_effector_rotations",
    "forward_dynamics",
    "forward_kinematics",
    "generalized_forces",
    "generalized_jacobian",
    "generalized_jacobian_drift",
    "inertia_blocks",
    "inverse_dynamics",
    "jacobian_determinant",
    "jacobian_determinant_map",
    "kinetic_energy",
    "linear_momentum",
    "load",
    "manipulability",
    "models",
    "nonlinear_forces",
    "planar",
    "point_bias_acceleration",
    "point_jacobian",
    "point_positions",
    "save",
    "spacecraft_fixed_dynamics",
    "system_cm",
    "system_inertia_matrix",
    "system_inertia_matrix_rate",
    "task_jacobian",
]
