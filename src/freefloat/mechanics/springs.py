"""The joints' springs (``Model.joint_stiffness`` K, ``Model.joint_springref`` q_ref; MJCF's ``stiffness`` and
``springref``): the torque -K (q - q_ref) of each joint and the potential energy 1/2 K (q - q_ref)^2 it derives from.

A conservative passive torque: internal (it changes no momentum), and a free-floating run keeps the kinetic energy plus
:func:`spring_energy` constant (the dissipated energy of ``Trajectory.dissipated_energy`` counts the joints' damping and
friction only). A mimic joint's spring acts at its own value (multiplier q_leader + offset) and on its leader through the
law. The numpy reference of the engine's ``recursions.passive_spring``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core.model import Model
from ._inputs import _joints, gather_columns

__all__ = ["spring_energy", "spring_torque"]


def _stretch(model: Model, q: Any) -> tuple[Model, np.ndarray]:
    """The model whose joints are the body joints, and their springs' stretch q_body - q_ref (..., B - 1)."""
    body = model.expanded()
    return body, model.body_joint_values(_joints(model, q, "q")) - body.joint_springref


def spring_torque(model: Model, q: Any) -> np.ndarray:
    """The joints' spring torques -K (q - q_ref) (..., N) at the joint values ``q`` (N m, N for a prismatic joint;
    zeros for a model without springs)."""
    body, stretch = _stretch(model, q)
    return gather_columns(model, -body.joint_stiffness * stretch)


def spring_energy(model: Model, q: Any) -> np.ndarray:
    """The potential energy of the joints' springs, sum 1/2 K (q - q_ref)^2 (...) in J, at the joint values ``q``."""
    body, stretch = _stretch(model, q)
    return 0.5 * np.sum(body.joint_stiffness * stretch**2, axis=-1)
