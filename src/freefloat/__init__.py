"""freefloat: kinematics, dynamics, control and workspaces of space robots.

Implements Papadopoulos & Dubowsky 1991 (coordinated manipulator/spacecraft
motion control) and Papadopoulos 1992 (large payload manipulation) in general:
3D trees with any number of arms and joints. See ``freefloat.conventions``
for frames, units and orders.

The everyday names are here (``ff.simulate``, ``ff.forward_dynamics``, ...);
the rest live in namespaces:

- ``ff.conventions``: frames, quaternion order, velocity order, units.
- ``ff.models``: built-in models and ``load_model(name_or_path)``.
- ``ff.mechanics``: every mechanics function (``ff.planar``: the planar view).
- ``ff.control``: controllers, desired motions, task spaces.
- ``ff.workspace``: workspaces, determinant maps, workspace limits.
- ``ff.capture``: payload capture planning (1992 §V), path placement.
- ``ff.scenarios``: simulation and capture scenario files.
- ``ff.campaigns``: a scenario run many times (Monte-Carlo, grids, maps) on a Dask cluster; reports.
- ``ff.papers``: reproduction of the papers.

Every public function whose first argument is ``model`` (here and in the
namespaces) also takes a built-in model name or a model file path there
(``ff.generalized_jacobian("papadopoulos1992", q)``): one resolver,
:func:`freefloat.core.model.resolve_model`, applied at this boundary; anything
else is a TypeError that says what is expected.

The packages below draw the layers (docs/architecture.md): ``core`` <
``mechanics`` < ``simulation`` | ``control`` | ``analysis`` < ``io`` <
``models`` < ``scenarios`` < ``papers`` | ``campaigns`` < ``cli``.
"""

from __future__ import annotations

# namespace modules: ``as`` marks them re-exported (they are attributes, not in __all__: see NAMESPACES)
from . import campaigns as campaigns
from . import control as control
from . import mechanics as mechanics
from . import models as models
from . import papers as papers
from . import scenarios as scenarios
from ._version import __version__ as __version__
from .analysis import capture as capture
from .analysis import workspace as workspace
from .core import conventions as conventions
from .core.barycentric import BarycentricVectors, barycentric_vectors
from .core.builder import ModelBuilder
from .core.errors import (
    FreefloatError,
    ModelError,
    NearSingularWarning,
    ShapeError,
    SimulationError,
    SingularConfigurationError,
    UnknownNameError,
)
from .core.model import Model
from .core.state import Actuation, ActuatorLimits, State
from .io.model_files import load, save
from .mechanics import planar as planar
from .mechanics.dynamics import forward_dynamics, inverse_dynamics, nonlinear_forces
from .mechanics.forces import ExternalWrench, generalized_forces
from .mechanics.jacobians import (
    actuation_jacobian,
    end_effector_jacobian,
    generalized_jacobian,
    jacobian_determinant,
    manipulability,
    point_jacobian,
    task_jacobian,
)
from .mechanics.kinematics import (
    body_cm_positions,
    body_rotations,
    end_effector_positions,
    forward_kinematics,
    point_positions,
    system_cm,
)
from .mechanics.momentum import angular_momentum, inertia_blocks, kinetic_energy, linear_momentum, system_inertia_matrix
from .simulation.capture_event import Capture
from .simulation.pd import JointPD
from .simulation.simulate import rollout, simulate
from .simulation.trajectory import Trajectory

#: The namespace modules (attributes of ``freefloat``, not star-exported): see the module docstring.
NAMESPACES = ("campaigns", "capture", "control", "conventions", "mechanics", "models", "papers", "planar", "scenarios", "workspace")

__all__ = [
    "Actuation",
    "ActuatorLimits",
    "BarycentricVectors",
    "Capture",
    "ExternalWrench",
    "FreefloatError",
    "JointPD",
    "Model",
    "ModelBuilder",
    "ModelError",
    "NearSingularWarning",
    "ShapeError",
    "SimulationError",
    "SingularConfigurationError",
    "State",
    "Trajectory",
    "UnknownNameError",
    "actuation_jacobian",
    "angular_momentum",
    "barycentric_vectors",
    "body_cm_positions",
    "body_rotations",
    "end_effector_jacobian",
    "end_effector_positions",
    "forward_dynamics",
    "forward_kinematics",
    "generalized_forces",
    "generalized_jacobian",
    "inertia_blocks",
    "inverse_dynamics",
    "jacobian_determinant",
    "kinetic_energy",
    "linear_momentum",
    "load",
    "manipulability",
    "nonlinear_forces",
    "point_jacobian",
    "point_positions",
    "rollout",
    "save",
    "simulate",
    "system_cm",
    "system_inertia_matrix",
    "task_jacobian",
]


def _accept_model_names() -> None:
    """Wrap each public function ``f(model, ...)`` of ``ff`` and its namespaces with the one model resolver."""
    import inspect
    import sys

    from .core.model import accepts_model_names

    root = sys.modules[__name__]
    wrapped: dict[int, object] = {}
    for module in (root, *(getattr(root, ns) for ns in NAMESPACES)):
        for name in getattr(module, "__all__", ()):
            func = getattr(module, name, None)
            if not inspect.isfunction(func) or hasattr(func, "__wrapped__"):
                continue
            if next(iter(inspect.signature(func).parameters), None) != "model":
                continue
            if id(func) not in wrapped:
                wrapped[id(func)] = accepts_model_names(func)
            setattr(module, name, wrapped[id(func)])


_accept_model_names()
