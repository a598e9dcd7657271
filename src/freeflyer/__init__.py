"""freeflyer: kinematics, dynamics, control and workspaces of space robots.

Implements Papadopoulos & Dubowsky 1991 (coordinated manipulator/spacecraft
motion control) and Papadopoulos 1992 (large payload manipulation) in general:
3D trees with any number of arms and joints. See ``freeflyer.conventions``
for frames, units and orders.
"""

from __future__ import annotations

from . import conventions, models, planar
from .barycentric import BarycentricVectors, barycentric_vectors
from .capture import (
    CaptureFamilies,
    CapturePlan,
    CapturePosture,
    PathDoesNotFitError,
    PathPlacement,
    approach_distance,
    capture_families,
    optimal_capture_posture,
    place_path,
    plan_capture,
)
from .capture_scenario import CaptureScenario, load_capture_scenario, run_capture_scenario
from .control import OperationalSpaceController, TransposedJacobianController
from .desired import DesiredPoint, FunctionTrajectory, MinimumJerk, SetPoint, StraightLine
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
from .pd import JointPD
from .scenario import Scenario, load_scenario, run_scenario
from .simulate import ActuatorLimits, SimulationError, rollout, simulate
from .singularity import DeterminantMap, jacobian_determinant_map
from .state import Actuation, State
from .tasks import TaskItem, TaskSpace
from .trajectory import Trajectory
from .workspace import (
    GuaranteedWorkspace,
    PathIndependentWorkspace,
    PayloadEffect,
    ReachableWorkspace,
    end_effector_radius,
    guaranteed_workspace,
    path_independent_workspace,
    payload_effect,
    reachable_workspace,
    singularity_measure,
)
from .workspace_report import WorkspaceLimits, workspace_limits

__version__ = "0.1.0"

__all__ = [
    "Actuation",
    "ActuatorLimits",
    "BarycentricVectors",
    "CaptureFamilies",
    "CapturePlan",
    "CapturePosture",
    "CaptureScenario",
    "DesiredPoint",
    "DeterminantMap",
    "ExternalWrench",
    "FreeflyerError",
    "FunctionTrajectory",
    "GuaranteedWorkspace",
    "InertiaBlocks",
    "JointPD",
    "MinimumJerk",
    "Model",
    "ModelBuilder",
    "ModelError",
    "NearSingularWarning",
    "OperationalSpaceController",
    "PathDoesNotFitError",
    "PathIndependentWorkspace",
    "PathPlacement",
    "PayloadEffect",
    "ReachableWorkspace",
    "Scenario",
    "SetPoint",
    "ShapeError",
    "SimulationError",
    "SingularConfigurationError",
    "State",
    "StraightLine",
    "TaskItem",
    "TaskSpace",
    "Trajectory",
    "TransposedJacobianController",
    "UnknownNameError",
    "WorkspaceLimits",
    "actuation_from_generalized_forces",
    "actuation_jacobian",
    "angular_momentum",
    "approach_distance",
    "barycentric_vectors",
    "body_cm_positions",
    "body_rotations",
    "capture_families",
    "conventions",
    "end_effector_jacobian",
    "end_effector_positions",
    "end_effector_radius",
    "end_effector_rotations",
    "forward_dynamics",
    "forward_kinematics",
    "generalized_forces",
    "generalized_jacobian",
    "generalized_jacobian_drift",
    "guaranteed_workspace",
    "inertia_blocks",
    "inverse_dynamics",
    "jacobian_determinant",
    "jacobian_determinant_map",
    "kinetic_energy",
    "linear_momentum",
    "load",
    "load_capture_scenario",
    "load_scenario",
    "manipulability",
    "models",
    "nonlinear_forces",
    "optimal_capture_posture",
    "path_independent_workspace",
    "payload_effect",
    "place_path",
    "plan_capture",
    "planar",
    "point_bias_acceleration",
    "point_jacobian",
    "point_positions",
    "reachable_workspace",
    "rollout",
    "run_capture_scenario",
    "run_scenario",
    "save",
    "simulate",
    "singularity_measure",
    "spacecraft_fixed_dynamics",
    "system_cm",
    "system_inertia_matrix",
    "system_inertia_matrix_rate",
    "task_jacobian",
    "workspace_limits",
]
