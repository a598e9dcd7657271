"""The model as the arrays the engine's kernels take (:class:`Tree`), built once per model.

Mass properties are data here, never code: a new model or a payload variant
(:meth:`~freefloat.Model.with_payload`) is a new :class:`Tree` and compiles nothing.
"""

from __future__ import annotations

import threading
import weakref
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["NF", "Tree", "tree", "work_size"]

# columns of Tree.body (one row per body; row 0 the spacecraft)
_T = 0  # joint position in the parent frame (3)
_P0 = 3  # joint placement P (3x3, row-major)
_P1 = 12  # P K, K the cross-product matrix of the axis
_P2 = 21  # P K^2
_AX = 30  # joint axis in the parent frame, P u (3)
_M = 33  # mass
_C = 34  # CM in the body frame (3)
_I = 37  # inertia about the CM, body axes (3x3, row-major)
_S = 46  # mass of the subtree of the body (itself included)
_PR = 47  # 1.0 when the body's joint is prismatic (slides along the axis), 0.0 when revolute
NF = 48


@dataclass(frozen=True, eq=False)
class Tree:
    """A model as the arrays the kernels take (read-only).

    parent (B,) int64, -1 for the spacecraft; body (B, NF) float64, the columns above;
    ancestor (B, B) uint8, [i, k] = 1 when body i is body k or on its path to the spacecraft;
    ee_body (E,) int64 and ee_point (E, 3), the end effectors (point in the body frame).
    """

    parent: np.ndarray
    body: np.ndarray
    ancestor: np.ndarray
    ee_body: np.ndarray
    ee_point: np.ndarray
    total_mass: float
    n_joints: int


_TREES: weakref.WeakKeyDictionary[Any, Tree] = weakref.WeakKeyDictionary()
_TREES_LOCK = threading.Lock()


def tree(model: Any) -> Tree:
    """The :class:`Tree` of a model (built once per model, kept while the model lives)."""
    found = _TREES.get(model)
    if found is not None:
        return found
    n_b = model.n_bodies
    body = np.zeros((n_b, NF))
    axis = np.asarray(model.joint_axis, dtype=float)
    for k in range(n_b):
        u = axis[k]
        sliding = k > 0 and bool(model.prismatic[k - 1])
        w = 0.0 * u if sliding else u  # a prismatic joint does not turn: K = 0
        kx = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
        place = np.asarray(model.joint_rotation[k], dtype=float)
        body[k, _T : _T + 3] = model.joint_origin[k]
        body[k, _P0 : _P0 + 9] = place.ravel()
        body[k, _P1 : _P1 + 9] = (place @ kx).ravel()
        body[k, _P2 : _P2 + 9] = (place @ kx @ kx).ravel()
        body[k, _AX : _AX + 3] = place @ u
        body[k, _PR] = 1.0 if sliding else 0.0
        body[k, _M] = model.mass[k]
        body[k, _C : _C + 3] = model.com[k]
        body[k, _I : _I + 9] = np.asarray(model.inertia[k], dtype=float).ravel()
    ancestor = np.asarray(model.subtree, dtype=np.uint8)
    body[:, _S] = ancestor.astype(float) @ np.asarray(model.mass, dtype=float)
    out = Tree(
        parent=np.ascontiguousarray(model.parent, dtype=np.int64),
        body=body,
        ancestor=np.ascontiguousarray(ancestor),
        ee_body=np.ascontiguousarray(model.end_effector_body, dtype=np.int64),
        ee_point=np.ascontiguousarray(np.asarray(model.end_effector_point, dtype=float).reshape(-1, 3)),
        total_mass=float(model.total_mass),
        n_joints=int(model.n_joints),
    )
    for arr in (out.parent, out.body, out.ancestor, out.ee_body, out.ee_point):
        arr.setflags(write=False)
    with _TREES_LOCK:
        _TREES[model] = out
    return out


# One flat float64 buffer, sliced into views by _views (no allocation per configuration).
def work_size(n_bodies: int) -> int:
    """Length of the scratch buffer of one configuration (the views of ``_recursions.Scratch``) for ``n_bodies`` bodies."""
    n = n_bodies - 1
    m = 3 + n
    return 66 * n_bodies + 15 + 2 * m * m + m + 3 * n + 9 + 2 * (6 + n) + 5 * (13 + 2 * n)
