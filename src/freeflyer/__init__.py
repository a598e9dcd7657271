"""freeflyer: kinematics, dynamics, control and workspaces of space robots.

Implements Papadopoulos & Dubowsky 1991 (coordinated manipulator/spacecraft
motion control) and Papadopoulos 1992 (large payload manipulation) in general:
3D trees with any number of arms and joints. See ``freeflyer.conventions``
for frames, units and orders.
"""

from __future__ import annotations

from . import conventions, models
from .barycentric import BarycentricVectors, barycentric_vectors
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
from . import planar

__version__ = "0.1.0"

__all__ = [
    "BarycentricVectors",
    "FreeflyerError",
    "InertiaBlocks",
    "Model",
    "ModelBuilder",
    "ModelError",
    "NearSingularWarning",
    "ShapeError",
    "SingularConfigurationError",
    "UnknownNameError",
    "actuation_jacobian",
    "angular_momentum",
    "barycentric_vectors",
    "body_cm_positions",
    "body_rotations",
    "conventions",
    "end_effector_jacobian",
    "end_effector_positions",
    "end_effector_rotations",
    "forward_kinematics",
    "generalized_jacobian",
    "generalized_jacobian_drift",
    "inertia_blocks",
    "jacobian_determinant",
    "kinetic_energy",
    "linear_momentum",
    "load",
    "manipulability",
    "models",
    "planar",
    "point_jacobian",
    "point_positions",
    "save",
    "system_cm",
    "system_inertia_matrix",
    "task_jacobian",
]
