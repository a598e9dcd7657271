"""The planar view of a planar model: (x, y, θ, q) instead of 3D.

For a planar model (see :mod:`freefloat.conventions`) every quantity here is
exactly the matching rows and columns of the 3D result: x, y are rows 0, 1 of
a position, θ is the z rotation (row 5 of zdot0, row 2 of omega).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core.errors import ModelError
from ..core.model import Model
from .jacobians import generalized_jacobian as _gj
from .kinematics import end_effector_positions as _ee
from .momentum import system_inertia_matrix as _hplus

__all__ = [
    "check_planar",
    "end_effector_positions",
    "generalized_jacobian",
    "position_coefficients",
    "system_inertia_matrix",
    "velocity_indices",
]


def check_planar(model: Model) -> None:
    """Raise :class:`ModelError` unless ``model.is_planar``."""
    if not model.is_planar:
        raise ModelError(
            f"model {model.name!r}",
            "is not planar (joint axes not all along the spacecraft z axis, points not in one plane, or out-of-plane inertia products)",
            "use the 3D functions of freefloat",
        )


def velocity_indices(model: Model) -> np.ndarray:
    """Indices of [x, y, θ, q...] within zdot0 = [rdot_cm, omega0, qdot]."""
    return np.concatenate([[0, 1, 5], 6 + np.arange(model.n_joints)])


def end_effector_positions(model: Model, q: Any) -> np.ndarray:
    """(x_E, y_E) of every end effector relative to the system CM, spacecraft frame, (..., E, 2)."""
    check_planar(model)
    return _ee(model, q)[..., :2]


def generalized_jacobian(model: Model, q: Any, *, angular: bool = False) -> np.ndarray:
    """Planar J*: rows [v_x, v_y] (and ω_z with ``angular=True``) per end effector, (..., 2E or 3E, N)."""
    check_planar(model)
    keep = [0, 1, 5] if angular else [0, 1]
    rows = np.concatenate([[6 * e + r for r in keep] for e in range(model.n_end_effectors)])
    return _gj(model, q)[..., rows, :]


def system_inertia_matrix(model: Model, q: Any) -> np.ndarray:
    """Planar H+ over (x, y, θ, q), (..., 3+N, 3+N)."""
    check_planar(model)
    idx = velocity_indices(model)
    return _hplus(model, q)[..., idx[:, None], idx[None, :]]


def position_coefficients(model: Model, end_effector: str | int = 0) -> np.ndarray:
    """Complex coefficients of 1992 eq. 18 / eq. 20 for a planar model, (B,).

    The end-effector position relative to the system CM, as a complex number
    x_E + i y_E, is sum_i a_i exp(i φ_i), with φ_i the absolute angle of body
    i's x axis (θ for the spacecraft, θ + q1 + ... + qk for link k in the
    papers' convention) and a_i the barycentric vector v_iE of body i written
    in body i's frame as x + i y. For the papers' systems every a_i is real:
    a_0 = α, then β, γ (own arm) and δ, ε (the other arm): Tables II and IV.
    """
    check_planar(model)
    e = model.end_effector_index(end_effector)
    table = model.bary.end_effector_table[e]
    from .kinematics import body_rotations

    rot = body_rotations(model, np.zeros(model.n_joints))
    if np.any(rot[:, 2, 2] < 0) or np.any(np.einsum("kij,kj->ki", rot[1:], model.joint_axis[1:])[:, 2] < 0):
        raise ModelError(
            f"model {model.name!r}",
            "has body frames or joint axes along -z, where the angles of eq. 18 change sign",
            "orient every joint axis along +z of the spacecraft",
        )
    return table[:, 0] + 1j * table[:, 1]
