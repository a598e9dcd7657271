"""Capture postures ranked by the grasp of a moving target (private; see ``ff.capture`` and docs/impact.md).

1992 §V chooses the capture posture farthest from dynamic singularities (max |det J*| on |r_E| = R+, eq. 21).
A target that moves hits the robot at the grasp (:func:`freefloat.mechanics.impact.impact`), and the postures on
|r_E| = R+ differ in what that impact does: the spacecraft's rate after it, the impulse on the target, the impulse
the locked joints take. :func:`rank_candidates` evaluates the impact at every candidate capture in one batched call
and picks one by a criterion (:data:`RANKINGS`) among the candidates that pass the planner's checks.

The grasp at a candidate capture (CM+, posture q, spacecraft attitude T0) is :func:`grasp_setup`: the robot before
the grasp is at rest in posture q and attitude T0, and the target is where the plan puts the payload. Its CM is at
CM+ + T0 r_p(q), r_p the payload's CM in the captured model (the end-effector point plus ``offset``, grasping body
frame) from that model's system CM, spacecraft frame; its axes are those of the grasping body, so ``inertia``
(given in the grasping body's axes, as for ``Model.with_payload``) is also its inertia in its own frame. The
robot's CM is ((M + m_p) CM+ - m_p p_t) / M, the free-flyer's CM of eq. 19 (the approach point when the payload is
grasped at its CM). Positions in the inertial frame (m), the target's velocities inertial (m/s, rad/s).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.spatial.transform import Rotation

from ..core.conventions import attitude_matrix
from ..core.errors import ShapeError
from ..core.model import Model
from ..core.state import State
from ..core.target import Target, motion_field
from ..mechanics.impact import JOINT_MODES, impact
from ..mechanics.kinematics import body_rotations, end_effector_positions, point_positions
from ._capture_path import CheckedCandidate, _attitudes, _pad3, free_floating_path_motion
from ._capture_plots import plot_ranking
from ._capture_posture import CapturePosture, _dexterity, posture_candidates
from ._workspace_results import _axes, _freeze
from .singularity import SingularityCriterion

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes

__all__ = ["RANKINGS", "CaptureRanking", "Grasp", "Payload", "grasp_setup", "rank_candidates"]

RANKINGS = ("measure", "spacecraft_rate", "impulse", "angular_impulse", "joint_impulse")
"""What a plan's capture posture is chosen by (``plan_capture(..., rank_by=)``): the largest singularity measure (1992
§V, the default), or the smallest post-impact spacecraft rate |ω0⁺| (rad/s), linear grasp impulse (N s), angular
grasp impulse about the target's CM (N m s) or joint impulse |τ̂| (N m s; locked joints only)."""


def check_twist(value: Any, name: str, which: str) -> np.ndarray:
    """A target velocity (``which="velocity"``) or angular velocity (``"angular_velocity"``) as 3 finite floats, checked
    as the :class:`Target`'s field (:func:`~freefloat.core.target.motion_field`) with errors naming ``name``; one
    target only (a ``ShapeError`` otherwise)."""
    arr = motion_field(value, which, name)
    if arr.shape != (3,):
        raise ShapeError(f"{name}: expected 3 numbers (one target), got shape {arr.shape}")
    return arr


def grasp_problem(moving: bool, joints: Any, rank_by: Any) -> tuple[str, str, str] | None:
    """The first rule the moving-target options of a plan break, as (the option: ``"rank_by"`` or ``"joints"``, the
    problem, the fix), or None. ``moving``: whether the target's motion was given; ``joints``: None (not given),
    "free" or "locked"."""
    if not isinstance(rank_by, str) or rank_by not in RANKINGS:
        return "rank_by", f"unknown criterion {rank_by!r}", f"use one of {', '.join(RANKINGS)}"
    if joints is not None and (not isinstance(joints, str) or joints not in JOINT_MODES):
        return (
            "joints",
            f"unknown joint mode {joints!r}",
            "use 'free' (no impulsive joint torque) or 'locked' (the joint rates do not jump)",
        )
    if not moving and rank_by != "measure":
        return (
            "rank_by",
            f"{rank_by!r} ranks the grasp of a moving target, and no motion of the target is given",
            "give the target's velocity and angular velocity (zeros for a target at rest), or rank by 'measure'",
        )
    if not moving and joints is not None:
        return (
            "joints",
            "what the joints do at the grasp matters only for a moving target, and no motion of the target is given",
            "give the target's velocity and angular velocity, or leave joints out",
        )
    if rank_by == "joint_impulse" and joints != "locked":
        return "rank_by", "'joint_impulse' is zero for free joints (they take no impulsive torque)", "give joints = 'locked'"
    return None


@dataclass(frozen=True, eq=False)
class Payload:
    """The payload of a plan as ``Model.with_payload`` takes it: ``mass`` kg, ``inertia`` (3, 3) kg m² about its CM in
    the grasping body's axes, ``offset`` (3,) m its CM from the end-effector point, grasping body frame."""

    mass: float
    inertia: np.ndarray
    offset: np.ndarray

    def __post_init__(self) -> None:
        _freeze(self)


@dataclass(frozen=True, eq=False)
class Grasp:
    """The motion of the target at the grasp and how the plan uses it (the moving-target options of ``plan_capture``).

    ``velocity`` (3,) m/s and ``angular_velocity`` (3,) rad/s: the target's CM velocity and angular velocity,
    inertial frame; ``joints``: "free" or "locked" during the grasp (:func:`~freefloat.mechanics.impact.impact`);
    ``rank_by``: one of :data:`RANKINGS`.
    """

    velocity: np.ndarray
    angular_velocity: np.ndarray
    joints: str = "free"
    rank_by: str = "measure"

    def __post_init__(self) -> None:
        _freeze(self)


def grasp_setup(
    before: Model,
    captured: Model,
    end_effector: int,
    cm_plus: Any,
    q: Any,
    attitude: Any,
    *,
    payload: Payload,
    grasp: Grasp,
) -> tuple[State, Target]:
    """The robot just before the grasp and the target, for captures at CM+ (..., 3) with posture q (..., N) and
    spacecraft attitude (..., 4) [x, y, z, w]: the robot at rest, the target where the plan puts the payload
    (module docstring), moving as ``grasp`` says; ``captured`` is ``before`` with ``payload``. Batched over the leading
    axes; one capture gives one State and one Target."""
    q = np.asarray(q, dtype=float)
    k = int(captured.end_effector_body[end_effector])
    t0 = attitude_matrix(attitude)
    cm = _pad3(np.asarray(cm_plus, dtype=float))
    p_rel = point_positions(captured, q, k, captured.end_effector_point[end_effector] + payload.offset)
    position = cm + np.einsum("...ij,...j->...i", t0, p_rel)
    rot = t0 @ body_rotations(captured, q)[..., k, :, :]
    quat = Rotation.from_matrix(rot.reshape(-1, 3, 3)).as_quat().reshape((*rot.shape[:-2], 4))
    r_cm = ((before.total_mass + payload.mass) * cm - payload.mass * position) / before.total_mass  # eq. 19
    state = State(q=q, attitude=attitude, r_cm=r_cm)
    target = Target(
        mass=payload.mass,
        inertia=payload.inertia,
        position=position,
        attitude=quat,
        velocity=grasp.velocity,
        angular_velocity=grasp.angular_velocity,
    )
    return state, target


@dataclass(frozen=True, eq=False)
class CaptureRanking:
    """The candidate captures of a plan for a moving target, the impact at each, and the one chosen (K candidates).

    ``q`` (K, N) rad, ``attitude`` (K, 4) [x, y, z, w], ``cm_plus`` (K, 3) m inertial, ``R_plus`` (K,) m: each
    candidate capture; ``family`` (K,): its eq. 21 family (0: +acos, 1: -acos; -1: none, or not a planar two-link
    arm). ``measure`` (K,): the singularity measure at capture, absolute (``measure_name`` says which);
    ``min_measure`` (K,): its smallest value along the path (the planner's free-floating motion); ``valid`` (K,):
    the candidate passes the planner's checks (the motion follows the path, singularity-free, within the joint
    limits). The grasp at each (robot at rest, :func:`grasp_setup`; ``joints``): ``spacecraft_rate`` (K,) |ω0⁺|
    rad/s, ``impulse`` (K,) the linear grasp impulse |p̂| N s, ``angular_impulse`` (K,) about the target's CM
    N m s, ``joint_impulse`` (K,) |τ̂| N m s (zeros for free joints), ``energy_lost`` (K,) J. ``planner``: the
    index of the 1992 §V choice (most dexterous: max measure, or, for a path-checked plan, max smallest measure
    along the path); ``chosen``: the index chosen by ``rank_by`` (the planner's for "measure"; else the smallest
    value among the valid candidates, ties to the planner's, then to the larger measure).
    """

    rank_by: str
    joints: str
    measure_name: str
    q: np.ndarray
    attitude: np.ndarray
    cm_plus: np.ndarray
    R_plus: np.ndarray
    family: np.ndarray
    measure: np.ndarray
    min_measure: np.ndarray
    valid: np.ndarray
    spacecraft_rate: np.ndarray
    impulse: np.ndarray
    angular_impulse: np.ndarray
    joint_impulse: np.ndarray
    energy_lost: np.ndarray
    planner: int
    chosen: int

    def __post_init__(self) -> None:
        _freeze(self)

    def __len__(self) -> int:
        return int(self.measure.size)

    def values(self, criterion: str | None = None) -> np.ndarray:
        """The candidates' values (K,) of a criterion of :data:`RANKINGS` (default: ``rank_by``), or of ``"energy_lost"``."""
        name = self.rank_by if criterion is None else criterion
        if name not in (*RANKINGS, "energy_lost"):
            raise ValueError(f"criterion: expected one of {', '.join((*RANKINGS, 'energy_lost'))}, got {name!r}")
        return np.asarray(getattr(self, name))

    def plot(self, ax: Axes | None = None, *, y: str | None = None) -> list[Artist]:
        """The trade-off: each candidate's singularity measure (x) against ``y`` (a criterion of :data:`RANKINGS` or
        ``"energy_lost"``; default ``rank_by``, or ``"spacecraft_rate"`` when ranking by the measure), the valid ones
        per eq. 21 family, those that fail a check, the most dexterous and the chosen one marked. Returns the artists."""
        return plot_ranking(self, _axes(ax), y=y)


def piw_candidates(
    captured: Model, end_effector: int, path: np.ndarray, chosen: CapturePosture, cm_plus: np.ndarray, criterion: SingularityCriterion
) -> tuple[list[CheckedCandidate], np.ndarray]:
    """The other captures of a PIW plan: the postures of :func:`posture_candidates` on |r_E| = R+ at the plan's CM+,
    each with the attitude of eq. 20 (the end effector on the path start), and the free-floating motion along the path
    from each (one batch). Returns the candidates and their eq. 21 families (-1: none)."""
    q, family = posture_candidates(captured, end_effector, chosen.R_plus, criterion)
    if not q.shape[0]:
        return [], family
    r0 = end_effector_positions(captured, q)[:, end_effector]
    attitude = np.array([_attitudes(r, chosen.direction, captured.is_planar, 1)[0] for r in r0])
    cm = _pad3(np.asarray(cm_plus, dtype=float))
    motions = free_floating_path_motion(captured, end_effector, q, attitude, cm, path, criterion=criterion)
    return [CheckedCandidate(cm, chosen.R_plus, qq, a, m) for qq, a, m in zip(q, attitude, motions, strict=True)], family


def rank_candidates(
    before: Model,
    captured: Model,
    end_effector: int,
    candidates: Sequence[CheckedCandidate],
    family: np.ndarray,
    planner: int,
    *,
    payload: Payload,
    grasp: Grasp,
    criterion: SingularityCriterion,
) -> CaptureRanking:
    """The grasp at every candidate capture (one batched :func:`~freefloat.mechanics.impact.impact`), and the choice by
    ``grasp.rank_by`` (see :class:`CaptureRanking`). ``planner``: the index of the planner's own choice, which passed
    every check."""
    q = np.array([c.q for c in candidates])
    attitude = np.array([c.attitude for c in candidates])
    cm_plus = np.array([_pad3(np.asarray(c.cm_plus, dtype=float)) for c in candidates])
    state, target = grasp_setup(before, captured, end_effector, cm_plus, q, attitude, payload=payload, grasp=grasp)
    hit = impact(before, state, target, end_effector, joints=grasp.joints)
    measure = _dexterity(captured, q, criterion)
    valid = np.array([c.motion.usable for c in candidates])
    values = {
        "measure": measure,
        "spacecraft_rate": np.linalg.norm(hit.state.omega, axis=-1),
        "impulse": np.linalg.norm(hit.impulse[:, 0:3], axis=-1),
        "angular_impulse": np.linalg.norm(hit.impulse[:, 3:6], axis=-1),
        "joint_impulse": np.linalg.norm(hit.joint_impulse, axis=-1),
    }
    if grasp.rank_by == "measure":
        chosen = planner
    else:
        value = values[grasp.rank_by]
        chosen = int(min(np.flatnonzero(valid), key=lambda i: (value[i], i != planner, -measure[i])))
    return CaptureRanking(
        rank_by=grasp.rank_by,
        joints=grasp.joints,
        measure_name=criterion.describe(captured).split(";")[0],
        q=q,
        attitude=attitude,
        cm_plus=cm_plus,
        R_plus=np.array([c.R_plus for c in candidates], dtype=float),
        family=np.asarray(family, dtype=int),
        valid=valid,
        min_measure=np.array([c.motion.min_measure for c in candidates]),
        energy_lost=np.asarray(hit.energy_lost, dtype=float),
        planner=int(planner),
        chosen=chosen,
        **values,
    )
