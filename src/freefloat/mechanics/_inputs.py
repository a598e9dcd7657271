"""Argument checks shared by the mechanics entry points (private).

Joint arrays (..., N), vectors (..., size), velocities zdot0 (..., 6 + N) and
attitudes (quaternion [x, y, z, w], ``Rotation`` or 3x3 matrices) are read
with a batch shape and checked to be finite; errors name the argument and the
expected shape. ``_rotate`` applies T0 (spacecraft -> inertial) or its
transpose, the identity when the attitude is None.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core.conventions import attitude_matrix
from ..core.errors import ModelError, ShapeError
from ..core.model import Model
from ..core.numbers import finite_vector, joint_array


def _finite(arr: np.ndarray, name: str) -> np.ndarray:
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: has NaN or infinite entries; every entry must be a finite number")
    return arr


def _joints(model: Model, value: Any, name: str) -> np.ndarray:
    return joint_array(model, value, name)  # finite and real, checked there


def _vector(value: Any, size: int, name: str, what: str) -> np.ndarray:
    return finite_vector(value, size, name, what)


def _velocity(model: Model, value: Any, name: str = "velocity") -> np.ndarray:
    return _vector(value, 6 + model.n_joints, name, "zdot0 = [rdot_cm (inertial), omega0 (spacecraft frame), qdot]")


def _attitude(attitude: Any) -> np.ndarray | None:
    """T0 (..., 3, 3) or None for the identity; checks finiteness and orthonormality."""
    if attitude is None:
        return None
    t0 = attitude_matrix(attitude)
    if t0.shape[-2:] != (3, 3):
        raise ShapeError(f"attitude: expected a quaternion (..., 4), a Rotation or matrices (..., 3, 3), got {np.shape(attitude)}")
    _finite(t0, "attitude")
    err = np.max(np.abs(t0 @ np.swapaxes(t0, -1, -2) - np.eye(3)), initial=0.0)
    if err > 1e-6 or np.any(np.linalg.det(t0) < 0):
        raise ValueError("attitude: the matrix is not a proper rotation (orthonormal, determinant +1)")
    return t0


def _rotate(t0: np.ndarray | None, vec: np.ndarray, inverse: bool = False) -> np.ndarray:
    """T0 @ vec (or T0^T @ vec), broadcasting over batch axes; identity when t0 is None."""
    if t0 is None:
        return vec
    return np.einsum("...ji,...j->...i" if inverse else "...ij,...j->...i", t0, vec)


#: The two algorithms of every mechanics quantity: the engine (default) and the papers' barycentric closed forms.
METHODS = ("recursive", "barycentric")


def check_method(method: str, reference: str) -> str:
    """``method`` if it is one of :data:`METHODS`, else a ValueError that names both and the reference equations."""
    if method not in METHODS:
        raise ValueError(f"method: expected 'recursive' (the engine) or 'barycentric' ({reference}), got {method!r}")
    return method


def check_out_inputs(out: Any, method: str, name: str = "out", **inputs: Any) -> None:
    """Refuse an ``out=`` (given as ``name``) that the call cannot fill: with ``method="barycentric"`` (the numpy
    reference makes its own arrays), or sharing memory with one of the call's ``inputs`` (by argument name; the fields
    of :class:`~freefloat.mechanics.ExternalWrench` items too), which the kernels would overwrite while they read it.
    Nothing when ``out`` is None; its type, dtype, shape and layout are the engine's checks (``engine.check_out``)."""
    if out is None:
        return
    if method != "recursive":
        raise ValueError(
            f"{name}: method={method!r} (the numpy reference) makes its own arrays and takes no out=; "
            "call with method='recursive' (the default) or without out"
        )
    if not isinstance(out, np.ndarray):
        return
    for arg, value in inputs.items():
        for label, arr in _input_arrays(arg, value):
            if np.may_share_memory(out, arr) and np.shares_memory(out, arr):
                raise ValueError(
                    f"{name}: shares memory with {label}, which the call reads while it writes {name}; "
                    f"pass an array of its own ({name}=np.empty({tuple(out.shape)})) or a copy of {label}"
                )


def _input_arrays(name: str, value: Any) -> list[tuple[str, np.ndarray]]:
    """The numpy arrays of one argument: itself, or the fields of an ExternalWrench, or of each of a sequence of them
    (``external=``; other lists are copied into new arrays before any kernel reads them)."""
    if isinstance(value, np.ndarray):
        return [(name, value)]
    fields = ("point", "force", "torque")
    if any(hasattr(value, f) for f in fields):
        return [(f"{name}.{f}", getattr(value, f)) for f in fields if isinstance(getattr(value, f), np.ndarray)]
    if name == "external" and isinstance(value, tuple | list):
        return [pair for i, item in enumerate(value) for pair in _input_arrays(f"external[{i}]", item)]
    return []


def revolute_only(model: Model, what: str) -> None:
    """Refuse a model with prismatic joints (mimic ones included) in a closed form written for revolute joints only."""
    model = model.expanded()
    if model.has_prismatic:
        sliding = [n for n, t in zip(model.joint_names, model.joint_type, strict=True) if t == "prismatic"]
        raise ModelError(
            f"{model.name}.joint_type",
            f"{what} is the barycentric closed form of revolute joints; joints {sliding} are prismatic",
            "use method='recursive' (the engine covers prismatic joints), or a model with revolute joints only",
        )


# ----------------------------------------------------------------- mimic joints in the closed forms
# The closed forms (method="barycentric") compute on the model's expanded twin (every joint of a body independent,
# Model.expanded) at the body joints' values, then gather each body joint's column into the column of q that drives
# it: with M = Model.mimic_matrix ((B - 1) x N) and T = diag(1_6, M), J = J_body M, H+ = T^T H_body T, C+ = T^T C_body.


def body_joints(model: Model, q: np.ndarray) -> tuple[Model, np.ndarray]:
    """(the expanded model, the body joints' values (..., B - 1)) of a model at q; the model and q themselves without mimics."""
    return (model.expanded(), model.body_joint_values(q)) if model.has_mimic else (model, q)


def body_velocity(model: Model, velocity: np.ndarray) -> np.ndarray:
    """zdot0 (..., 6 + N) as the expanded model's (..., 6 + B - 1): the joint rates through the mimic laws."""
    if not model.has_mimic:
        return velocity
    return np.concatenate([velocity[..., :6], velocity[..., 6:] @ model.mimic_matrix.T], axis=-1)


def gather_columns(model: Model, arr: np.ndarray, first: int = 0) -> np.ndarray:
    """``arr`` (..., first + B - 1) with its body-joint columns (from ``first``) gathered into the columns of q (times M)."""
    if not model.has_mimic:
        return arr
    return np.concatenate([arr[..., :first], arr[..., first:] @ model.mimic_matrix], axis=-1)


def gather_square(model: Model, arr: np.ndarray, first: int) -> np.ndarray:
    """T^T arr T for a square ``arr`` (..., first + B - 1, first + B - 1) whose rows and columns from ``first`` are body joints."""
    if not model.has_mimic:
        return arr
    cols = gather_columns(model, arr, first)
    return np.swapaxes(gather_columns(model, np.swapaxes(cols, -1, -2), first), -1, -2)
