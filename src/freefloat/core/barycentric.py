"""Barycenters and barycentric vectors, generalized from chains to trees.

Papadopoulos 1992 eqs. 4-9 (and 1991 eq. 3) for n arms, here for any tree.
The **barycenter** of body i is the CM of body i after adding, at each of its
joints, a point mass equal to the mass on the far side of that joint (1992
Fig. 2). Because body frames have their origin at the inboard joint,

    b_i = ( m_i c_i + sum_{children c} S_c t_c ) / M          (body-i frame)

with S_c the mass of the subtree hanging from joint c, t_c the position of
joint c in body i, and M the total mass. The barycentric vectors of body i run
from its barycenter to its CM and to each of its joints:

    c*_i = c_i - b_i                 (1992 eq. 8b / 9, "c*")
    l*_i = 0 - b_i                   (to the inboard joint, eq. 9, "l*")
    r*_c = t_c - b_i                 (to the joint of child c, eq. 8a / 9, "r*")

The vector from the system CM to any point P of body k is then a sum of one
barycentric vector per body (1992 eq. 4, generalized):

    rho_P = sum_i  T_i v_{iP},   v_{iP} = r*_(child of i towards k)  if i is an ancestor of k
                                        = l*_i                        if i is not on the path to k
                                        = P - b_k                     if i = k  (c*_k for the CM)

The outboard mass fraction mu*_k = S_k / M (1992 eq. 6) is the mass beyond
joint k. All of this depends on the mass distribution only, so it is computed
once when the model is built.

**Prismatic joints** (docs/theory.md §"Prismatic joints"). When joint c slides body c by q_c
along a_c (parent frame), the joint position in the parent p is t_c + q_c a_c, so the barycenter
b_p moves by q_c mu*_c a_c and every barycentric vector of body p is affine in q_c:

    v_pk(q) = v_pk(0) + q_c (chi_c(k) - mu*_c) a_c,   chi_c(k) = 1 if body k is in the subtree of c

(the vector towards the sliding subtree grows by (1 - mu*_c) q_c a_c, all others shrink by
mu*_c q_c a_c; sum_k m_k v_pk = 0 still holds). The tables below hold v(0); ``slide_coefficient``
and ``slide_axis`` hold the affine part.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

__all__ = ["BarycentricVectors", "MassTree", "barycentric_vectors", "compute", "is_planar"]


class MassTree(Protocol):
    """The parts of a model that its barycentric quantities depend on (a :class:`freefloat.Model` is one).

    Written as a protocol so that this module needs nothing from :mod:`freefloat.core.model`,
    which imports it to compute ``Model.bary`` at build time. Body frames; see ``Model``.
    """

    @property
    def parent(self) -> np.ndarray: ...
    @property
    def subtree(self) -> np.ndarray: ...
    @property
    def mass(self) -> np.ndarray: ...
    @property
    def com(self) -> np.ndarray: ...
    @property
    def inertia(self) -> np.ndarray: ...
    @property
    def joint_origin(self) -> np.ndarray: ...
    @property
    def joint_rotation(self) -> np.ndarray: ...
    @property
    def joint_axis(self) -> np.ndarray: ...
    @property
    def end_effector_body(self) -> np.ndarray: ...
    @property
    def end_effector_point(self) -> np.ndarray: ...
    @property
    def n_bodies(self) -> int: ...
    @property
    def n_end_effectors(self) -> int: ...
    @property
    def prismatic(self) -> np.ndarray: ...


class _Built(Protocol):
    @property
    def bary(self) -> BarycentricVectors: ...


@dataclass(frozen=True, eq=False)
class BarycentricVectors:
    """Barycentric quantities of a model, all in body frames (1992 eqs. 5-9).

    outboard_mass_fraction (B,)  mu*_k = (mass of the subtree of body k) / M, eq. 6
    barycenter   (B, 3)  b_i, position of the barycenter of body i (body frame, from its joint)
    c_star       (B, 3)  barycenter -> CM of body i
    l_star       (B, 3)  barycenter -> inboard joint of body i (row 0, the spacecraft, is zero)
    r_star       (B, 3)  row c: barycenter of parent(c) -> joint c, in the parent frame (row 0 zero)
    point_table  (B, B, 3)  row k, column i: v_ik of the CM of body k (eq. 4)
    end_effector_table (E, B, 3)  row e, column i: v_iE of end effector e (eq. 10)
    diagonal_inertia (B, 3, 3)  I_i + sum_k m_k (|v_ik|^2 1 - v_ik v_ik^T), the i = j case of 1991 eq. 17
                     (at q = 0 of the prismatic joints)
    slide_coefficient (N, B)  row j: chi_c(k) - mu*_c for prismatic joint j (body c = j + 1), zero for revolute
    slide_axis   (N, 3)  a_c, the axis of prismatic joint j in its parent's frame (zero for revolute)
    """

    outboard_mass_fraction: np.ndarray
    barycenter: np.ndarray
    c_star: np.ndarray
    l_star: np.ndarray
    r_star: np.ndarray
    point_table: np.ndarray
    end_effector_table: np.ndarray
    diagonal_inertia: np.ndarray
    slide_coefficient: np.ndarray
    slide_axis: np.ndarray

    def point_vectors(self, model: MassTree, body: int, point: np.ndarray) -> np.ndarray:
        """v_iP (B, 3) for a point P (body frame of ``body``): rho_P = sum_i T_i v_iP."""
        table = self.point_table[body].copy()
        table[body] = np.asarray(point, dtype=float) - self.barycenter[body]
        return table


def _towards(model: MassTree, i: int, k: int) -> int:
    """The child of body i on the path from i down to its descendant k."""
    j = k
    while int(model.parent[j]) != i:
        j = int(model.parent[j])
    return j


def compute(model: MassTree) -> BarycentricVectors:
    """Compute the barycentric quantities of ``model`` (called once at build time)."""
    n = model.n_bodies
    total = float(np.sum(model.mass))
    subtree_mass = model.subtree.astype(float) @ model.mass
    bary = model.mass[:, None] * model.com
    for c in range(1, n):
        bary[model.parent[c]] += subtree_mass[c] * model.joint_origin[c]
    bary = bary / total
    c_star = model.com - bary
    l_star = -bary
    l_star[0] = 0.0
    r_star = np.zeros((n, 3))
    for c in range(1, n):
        r_star[c] = model.joint_origin[c] - bary[model.parent[c]]

    table = np.zeros((n, n, 3))  # table[k, i] = v_ik for the CM of body k
    for k in range(n):
        for i in range(n):
            if i == k:
                table[k, i] = c_star[k]
            elif model.subtree[i, k]:
                table[k, i] = r_star[_towards(model, i, k)]
            else:
                table[k, i] = l_star[i]
    ee = np.zeros((model.n_end_effectors, n, 3))
    for e in range(model.n_end_effectors):
        k = int(model.end_effector_body[e])
        ee[e] = table[k]
        ee[e, k] = model.end_effector_point[e] - bary[k]
    eye = np.eye(3)
    diag = model.inertia.copy()
    for i in range(n):
        v = table[:, i, :]  # v_ik over k
        diag[i] += np.sum(model.mass * np.sum(v * v, axis=1)) * eye - np.einsum("k,kx,ky->xy", model.mass, v, v)
    n_j = n - 1
    prismatic = np.asarray(model.prismatic, dtype=bool).reshape(n_j)
    slide = np.zeros((n_j, n))
    slide_axis = np.zeros((n_j, 3))
    for j in np.flatnonzero(prismatic):
        c = int(j) + 1
        slide[j] = model.subtree[c].astype(float) - subtree_mass[c] / total
        slide_axis[j] = model.joint_rotation[c] @ model.joint_axis[c]
    out = BarycentricVectors(
        outboard_mass_fraction=subtree_mass / total,
        barycenter=bary,
        c_star=c_star,
        l_star=l_star,
        r_star=r_star,
        point_table=table,
        end_effector_table=ee,
        diagonal_inertia=diag,
        slide_coefficient=slide,
        slide_axis=slide_axis,
    )
    for arr in vars(out).values():
        arr.setflags(write=False)
    return out


def barycentric_vectors(model: _Built) -> BarycentricVectors:
    """The barycentric vectors l*, r*, c* and barycenters of every body (1992 eqs. 5-9).

    Body frames; computed once at build time, so this is free.
    """
    return model.bary


def is_planar(model: MassTree, tol: float = 1e-12) -> bool:
    """True when all joint axes stay parallel to the spacecraft z axis and all
    CMs, joints and end-effector points share one z (see conventions)."""
    n = model.n_bodies
    rot = np.zeros((n, 3, 3))
    pos = np.zeros((n, 3))
    rot[0] = np.eye(3)
    ez = np.array([0.0, 0.0, 1.0])
    for k in range(1, n):
        p = int(model.parent[k])
        rot[k] = rot[p] @ model.joint_rotation[k]
        pos[k] = pos[p] + rot[p] @ model.joint_origin[k]
        along_z = abs(rot[k] @ model.joint_axis[k] @ ez)
        if (abs(along_z) > tol) if model.prismatic[k - 1] else (abs(along_z - 1.0) > tol):
            return False  # a revolute axis along z, a prismatic axis in the x-y plane
        if abs(abs(rot[k][2, 2]) - 1.0) > tol:
            return False
    heights = [pos[k][2] + (rot[k] @ model.com[k])[2] for k in range(n)]
    heights += [pos[k][2] for k in range(1, n)]
    heights += [pos[b][2] + (rot[b] @ pt)[2] for b, pt in zip(model.end_effector_body, model.end_effector_point, strict=True)]
    scale = max(1.0, float(np.max(np.abs(pos))) if n > 1 else 1.0)
    if np.ptp(heights) > tol * scale * 1e3:
        return False
    for k in range(n):
        inertia0 = rot[k] @ model.inertia[k] @ rot[k].T
        if abs(inertia0[0, 2]) + abs(inertia0[1, 2]) > 1e-12 * max(1.0, float(np.trace(inertia0))):
            return False
    return True
