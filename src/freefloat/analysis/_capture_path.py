"""The free-floating motion along a payload path, and capture plans checked along it (private; see ``ff.capture``).

The PIW of 1992 §III is a set of radii: no configuration at those distances
from the system CM is singular, so any path inside it is safe. For spatial
arms that set is often empty: the singular set of a 6-DOF arm's J* (or of
its translational rows, with a threshold) reaches every radius somewhere.
The motion along one given path is still well defined: with zero momentum
(free-floating, 1992 eq. 12) the end-effector velocity in the spacecraft frame
is ⁰J*(q) q̇ (eq. 14), so the path fixes q(s) and the attitude T0(s) from the
capture configuration on (the resolved-rate motion, minimum joint rate for a
redundant arm). :func:`free_floating_path_motion` integrates it for a batch of
capture configurations at once; :func:`path_checked_candidates` searches the
placements, postures and attitudes whose motion stays away from the
singularities of a :class:`~freefloat.analysis.singularity.SingularityCriterion`.

Frames: the path, CM+ and end-effector positions inertial (m); q (rad); the
attitude a quaternion [x, y, z, w] (spacecraft to inertial).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from ..core import feedback
from ..core.model import Model
from ..mechanics.jacobians import generalized_jacobian
from ..mechanics.kinematics import end_effector_positions
from ..mechanics.momentum import system_inertia_matrix, zero_momentum_rate
from ._workspace_results import _freeze
from .singularity import SingularityCriterion

__all__ = ["PathMotion", "free_floating_path_motion", "resample_path"]

#: Largest deviation (m, relative to the path length, at least 1 mm) of a motion that "follows" the path.
FOLLOW_TOLERANCE = 1e-3


@dataclass(frozen=True, eq=False)
class PathMotion:
    """The free-floating, zero-momentum motion that carries the end effector along a path (1992 eqs. 12, 14).

    ``s`` (K,): arc length along the path, m; ``q`` (K, N) rad;
    ``attitude`` (K, 4): spacecraft quaternion [x, y, z, w]; ``end_effector``
    (K, 3): end-effector point, inertial, m (the system CM stays at ``cm``);
    ``measure`` (K,): the criterion's singularity measure along the motion;
    ``deviation``: the largest distance of the end effector from the path
    point it should be at, m. ``criterion`` describes the measure and
    ``threshold`` is its threshold: the motion is ``singularity_free`` when
    it follows the path and |measure| > threshold everywhere. ``limit_margin``:
    the smallest distance of any joint from its limits along the motion (rad or
    m; negative: a limit is crossed); ``usable`` when singularity-free and
    within the joint limits.
    """

    s: np.ndarray
    q: np.ndarray
    attitude: np.ndarray
    end_effector: np.ndarray
    cm: np.ndarray
    measure: np.ndarray
    deviation: float
    tolerance: float
    criterion: str
    threshold: float
    limit_margin: float = float("inf")

    def __post_init__(self) -> None:
        _freeze(self)

    @property
    def min_measure(self) -> float:
        """The smallest |measure| along the motion."""
        return float(np.min(np.abs(self.measure)))

    @property
    def follows_path(self) -> bool:
        """True when the end effector stays within ``tolerance`` of the path."""
        return bool(self.deviation <= self.tolerance)

    @property
    def singularity_free(self) -> bool:
        """True when the motion follows the path and never reaches |measure| <= threshold."""
        return self.follows_path and self.min_measure > self.threshold

    @property
    def within_limits(self) -> bool:
        """True when no joint leaves its limits along the motion."""
        return self.limit_margin >= 0.0

    @property
    def usable(self) -> bool:
        """Singularity-free and within the joint limits: a motion the arm can make."""
        return self.singularity_free and self.within_limits


def resample_path(path: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Points (K, d) along a polyline every ``step`` m or less (every vertex kept), and their arc length (K,)."""
    pts: list[np.ndarray] = [path[0]]
    for a, b in itertools.pairwise(path):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
        pts += list(a + np.linspace(0.0, 1.0, n + 1)[1:, None] * (b - a))
    out = np.array(pts)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(out, axis=0), axis=1))])
    return out, s


def _pad3(v: np.ndarray) -> np.ndarray:
    out = np.zeros((*v.shape[:-1], 3))
    out[..., : v.shape[-1]] = v
    return out


def _rates(model: Model, e: int, q: np.ndarray, rot: np.ndarray, step_i: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Joint step and spacecraft rotation vector (spacecraft frame) that move the end effector by ``step_i`` (inertial)."""
    jac = generalized_jacobian(model, q)[..., 6 * e : 6 * e + 3, :]  # ⁰J*, translational rows: v_E = J* q̇ (eq. 14)
    step_0 = np.einsum("kji,kj->ki", rot, step_i)  # inertial -> spacecraft frame
    dq = np.einsum("kij,kj->ki", np.linalg.pinv(jac), step_0)  # minimum-norm joint step
    h = system_inertia_matrix(model, q)
    dphi = zero_momentum_rate(h, dq)  # D ω0 + D_q q̇ = 0 (eq. 12)
    return dq, dphi


def free_floating_path_motion(
    model: Model,
    end_effector: int,
    q0: Any,
    attitude0: Any,
    cm: Any,
    path: Any,
    *,
    criterion: SingularityCriterion | None = None,
    step: float | None = None,
) -> list[PathMotion]:
    """Integrate the free-floating motion along ``path`` from each capture configuration, in one batch.

    ``q0`` (B, N) and ``attitude0`` (B, 4) [x, y, z, w]: B capture configurations whose end
    effector is at path[0]; ``cm`` (3,) or (B, 3): the system CM (inertial, fixed: zero linear
    momentum).
    Each step moves the end effector to the next path point (spacing ``step``, default 1/200 of
    the path length, at most 5 mm) by a midpoint (second-order) step of q̇ = J*⁺ ⁰v_E with the
    spacecraft rotating as zero angular momentum requires (1992 eq. 12); the error left by one
    step is corrected in the next one. Returns one :class:`PathMotion` per configuration.
    """
    crit = criterion if criterion is not None else SingularityCriterion()
    pts = _pad3(np.asarray(path, dtype=float))
    length = float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
    ds = step if step is not None else min(length / 200.0, 5e-3)
    targets, s = resample_path(pts, ds)
    q = np.array(q0, dtype=float, ndmin=2)
    rot = Rotation.from_quat(np.array(attitude0, dtype=float, ndmin=2)).as_matrix()
    n_b = q.shape[0]
    c = np.broadcast_to(_pad3(np.array(cm, dtype=float, ndmin=2)), (n_b, 3))
    qs, atts, ees = [q.copy()], [Rotation.from_matrix(rot).as_quat()], []

    def tip(qq: np.ndarray, rr: np.ndarray) -> np.ndarray:
        return c + np.einsum("kij,kj->ki", rr, end_effector_positions(model, qq)[:, end_effector])

    ees.append(tip(q, rot))
    for target in targets[1:]:
        delta = target - tip(q, rot)
        dq, dphi = _rates(model, end_effector, q, rot, 0.5 * delta)
        q_mid = q + dq
        rot_mid = rot @ Rotation.from_rotvec(dphi).as_matrix()
        dq, dphi = _rates(model, end_effector, q_mid, rot_mid, delta)
        q = q + dq
        rot = rot @ Rotation.from_rotvec(dphi).as_matrix()
        qs.append(q.copy())
        atts.append(Rotation.from_matrix(rot).as_quat())
        ees.append(tip(q, rot))
    q_all = np.stack(qs, axis=1)  # (B, K, N)
    att_all = np.stack(atts, axis=1)
    ee_all = np.stack(ees, axis=1)
    measure = crit.evaluate(model, q_all)
    dev = np.max(np.linalg.norm(ee_all - targets[None], axis=-1), axis=1)
    with np.errstate(invalid="ignore"):  # inf - inf of unlimited joints: no limit
        margin = np.minimum(q_all - model.joint_lower, model.joint_upper - q_all)
    margin = np.where(np.isnan(margin), np.inf, margin).min(axis=(1, 2))
    tol = max(FOLLOW_TOLERANCE * length, 1e-3)
    text = crit.describe(model)
    return [
        PathMotion(
            s=s,
            q=q_all[b],
            attitude=att_all[b],
            end_effector=ee_all[b],
            cm=c[b],
            measure=measure[b],
            deviation=float(dev[b]) if np.isfinite(dev[b]) else float("inf"),
            tolerance=tol,
            criterion=text,
            threshold=crit.threshold,
            limit_margin=float(margin[b]),
        )
        for b in range(n_b)
    ]


@dataclass(frozen=True, eq=False)
class CheckedCandidate:
    """One capture placement checked along the path: CM+, R+, the posture, the attitude and the motion."""

    cm_plus: np.ndarray
    R_plus: float
    q: np.ndarray
    attitude: np.ndarray
    motion: PathMotion

    def score(self) -> tuple[bool, float]:
        """Sort key: usable (singularity-free, within the joint limits) first, then the largest smallest measure."""
        return (self.motion.usable, self.motion.min_measure if self.motion.follows_path else -np.inf)


def _attitudes(r0: np.ndarray, d: np.ndarray, planar: bool, twists: int) -> list[np.ndarray]:
    """Spacecraft attitudes that turn r_E (spacecraft frame) onto the direction d (inertial): eq. 20.

    Planar: the rotation about z. 3D: the smallest rotation, then ``twists`` turns about d.
    """
    if planar and abs(d[2]) < 1e-12 and abs(r0[2]) < 1e-12:
        theta = np.arctan2(d[1], d[0]) - np.arctan2(r0[1], r0[0])
        return [Rotation.from_rotvec([0.0, 0.0, theta]).as_quat()]
    base = Rotation.align_vectors(d[None], (r0 / np.linalg.norm(r0))[None])[0]
    return [(Rotation.from_rotvec(d * 2.0 * np.pi * k / twists) * base).as_quat() for k in range(twists)]


def path_checked_candidates(
    model: Model,
    end_effector: int,
    path: np.ndarray,
    radii: np.ndarray,
    directions: np.ndarray,
    postures: Any,
    *,
    criterion: SingularityCriterion,
    twists: int = 4,
    steps: int = 50,
) -> list[CheckedCandidate]:
    """Every combination of R+ in ``radii``, CM+ direction (unit vectors from A, ``directions``), posture
    (``postures(R_plus)`` -> list of q with |r_E(q)| = R+) and attitude twist, each integrated along
    the path in one batch (``steps`` steps: a coarse screen, see :func:`refine_candidates`); best
    first (see :meth:`CheckedCandidate.score`)."""
    a = _pad3(path[0])
    cms, rps, qs, atts = [], [], [], []
    step = feedback.current()  # progress: the postures of each radius, then the batch integration
    if step is not None:
        step.expect(len(radii) + 1, "stages")
    for r_plus in radii:
        if step is not None:
            step.advance(1)
        for q in postures(float(r_plus)):
            r0 = end_effector_positions(model, q)[end_effector]
            for n in directions:
                n3 = _pad3(np.asarray(n, dtype=float))
                for att in _attitudes(r0, -n3, model.is_planar, twists):
                    cms.append(a + float(r_plus) * n3)
                    rps.append(float(r_plus))
                    qs.append(q)
                    atts.append(att)
    if not qs:
        return []
    length = float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))
    motions = free_floating_path_motion(
        model, end_effector, np.array(qs), np.array(atts), np.array(cms), path, criterion=criterion, step=length / steps
    )
    if step is not None:
        step.advance(1)
    out = [CheckedCandidate(c, r, q, att, m) for c, r, q, att, m in zip(cms, rps, qs, atts, motions, strict=True)]
    return sorted(out, key=CheckedCandidate.score, reverse=True)


def refine_candidates(
    model: Model, end_effector: int, path: np.ndarray, candidates: list[CheckedCandidate], *, criterion: SingularityCriterion
) -> list[CheckedCandidate]:
    """The screened candidates integrated again at the default (fine) step, in the same order."""
    if not candidates:
        return []
    motions = free_floating_path_motion(
        model,
        end_effector,
        np.array([c.q for c in candidates]),
        np.array([c.attitude for c in candidates]),
        np.array([c.cm_plus for c in candidates]),
        path,
        criterion=criterion,
    )
    return [CheckedCandidate(c.cm_plus, c.R_plus, c.q, c.attitude, m) for c, m in zip(candidates, motions, strict=True)]


def best_candidate(candidates: list[CheckedCandidate]) -> int | None:
    """The index of the best usable candidate (singularity-free, within the joint limits; :meth:`CheckedCandidate.score`),
    or None."""
    if not candidates:
        return None
    best = max(range(len(candidates)), key=lambda i: candidates[i].score())
    return best if candidates[best].motion.usable else None
