"""Capture of a large payload (Papadopoulos 1992 §V), for any model: ``ff.capture``.

The §V procedure: (1) compute the post-capture workspaces of the robot with
the payload (:mod:`freefloat.workspace`); (2) place the post-capture
path-independent workspace (PIW) so that the payload's desired path fits in
it (:func:`place_path`): this fixes the post-capture system CM, CM+, and the
distance R+ from CM+ to the path start A; (3) the free-flyer's CM must come
to the approach distance R = (M + m_p) / M R+ from the payload (eq. 19,
:func:`approach_distance`); (4) choose the capture configuration that is as
far as possible from dynamic singularities, max |det J*(q)| subject to
|r_E(q)| = R+ (eq. 21) and the joint limits
(:func:`optimal_capture_posture`), and the spacecraft attitude that puts the
end effector on A (eq. 20). :func:`plan_capture` runs all of it.

A moving target: :class:`Target` and :func:`impact`, the grasp as an impact that conserves momentum,
with the joints free or locked (:class:`Impact`: the combined model and its post-impact state), re-exported
here from their homes :mod:`freefloat.core.target` and :mod:`freefloat.mechanics.impact` (below
:mod:`freefloat.simulation`, whose capture during a run uses them).

Positions of a path are in the inertial frame, 2D (planar models) or 3D, m.
Angles in rad (``theta_deg``-style values only in :mod:`freefloat.papers.paper1992`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.spatial.transform import Rotation

from ..core._figures import new_axes
from ..core.feedback import status
from ..core.model import Model, inertia_matrix
from ..core.state import State
from ..core.target import Target
from ..mechanics.impact import Impact, impact
from ._capture_families import CaptureFamilies, capture_families
from ._capture_path import (
    CheckedCandidate,
    PathMotion,
    best_candidate,
    free_floating_path_motion,
    path_checked_candidates,
    refine_candidates,
)
from ._capture_plots import draw_system, plot_plan
from ._capture_posture import CapturePosture, _dexterity, _posture_candidates, optimal_capture_posture, posture_at
from ._capture_ranking import (
    RANKINGS,
    CaptureRanking,
    Grasp,
    Payload,
    check_twist,
    grasp_problem,
    grasp_setup,
    piw_candidates,
    rank_candidates,
)
from ._path_placement import PathDoesNotFitError, PathPlacement, _check_path, _margin, _perpendiculars, approach_distance, place_path
from ._workspace_reach import end_effector_radius
from ._workspace_results import PathIndependentWorkspace
from ._workspace_singular import path_independent_workspace
from .singularity import SingularityCriterion

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes

__all__ = [
    "RANKINGS",
    "CaptureFamilies",
    "CapturePlan",
    "CapturePosture",
    "CaptureRanking",
    "FixedCapturePlan",
    "Impact",
    "PathDoesNotFitError",
    "PathMotion",
    "PathPlacement",
    "Target",
    "approach_distance",
    "capture_families",
    "draw_system",
    "fixed_capture_plan",
    "free_floating_path_motion",
    "impact",
    "optimal_capture_posture",
    "place_path",
    "plan_capture",
]


# ----------------------------------------------------------------------------------------------------------------- the whole §V
STRATEGIES = ("auto", "piw", "path")


@dataclass(frozen=True, eq=False)
class CapturePlan:
    """The §V procedure end to end: workspaces after capture, path placement, approach, posture.

    ``method``: ``"piw"`` (the paper's: the path lies in the post-capture
    PIW, so no configuration met on it can be singular) or ``"path"`` (the
    free-floating motion along the path from this posture and attitude was
    integrated and never meets a singularity of ``criterion`` nor a joint
    limit). ``why_path``: why the PIW plan was not taken (the path fits in no
    PIW annulus, or the paper's posture fails a check along it); empty for
    ``"piw"``. ``motion``: that free-floating motion (1992 eqs. 12, 14) along
    the path, with the singularity measure along it.

    A moving target (``plan_capture(..., target_velocity=, target_angular_velocity=)``; else these are None):
    ``grasp_state``, the robot's :class:`~freefloat.State` just before the grasp (at rest in ``posture``, its CM at
    the approach point of eq. 19); ``target``, the payload as a :class:`Target` at the grasp (its CM where the plan
    puts it, the grasping body's axes, the given motion); ``impact``, :func:`impact` of the two (the combined model is
    ``captured`` up to rounding); ``ranking``, every candidate capture with its measure, its checks and its impact,
    and the one chosen (:class:`CaptureRanking`, drawn by :meth:`plot_tradeoff`).
    """

    before: Model
    captured: Model
    end_effector: str
    piw: PathIndependentWorkspace
    placement: PathPlacement
    posture: CapturePosture
    method: str = "piw"
    motion: PathMotion | None = None
    criterion: SingularityCriterion = field(default_factory=SingularityCriterion)
    why_path: str = ""
    grasp_state: State | None = None
    target: Target | None = None
    impact: Impact | None = None
    ranking: CaptureRanking | None = None

    @property
    def approach_distance(self) -> float:
        """Eq. 19, m."""
        assert self.placement.approach_distance is not None
        return self.placement.approach_distance

    def plot(self, ax: Axes | None = None) -> list[Artist]:
        """The plan like the 1992 paper's Fig. 7 ("the workspaces before and after the capture of a payload at A"):
        the reachable workspace before capture, the reachable workspace, PIW and PDW after capture, the path A→B,
        CM+, the free-flyer's CM before capture, the robot at capture and at B. Without ``ax``: a new pyplot figure,
        3D axes for a spatial model. Returns the artists."""
        if ax is None:
            ax = new_axes(figsize=(7.4, 7.6), projection=None if self.captured.is_planar else "3d")
        return plot_plan(self, ax)

    def plot_tradeoff(self, ax: Axes | None = None, *, y: str | None = None) -> list[Artist]:
        """The trade-off among the candidate capture postures of a moving target (:meth:`CaptureRanking.plot`): the
        singularity measure at capture against ``y`` (default the ranking's criterion, or the spacecraft rate after the
        grasp when it ranks by the measure), the most dexterous and the chosen posture marked. Returns the artists."""
        if self.ranking is None:
            raise ValueError(
                "plot_tradeoff: this plan has no ranking; give plan_capture the target's motion (target_velocity, target_angular_velocity)"
            )
        return self.ranking.plot(ax, y=y)


def _failed_checks(motion: PathMotion) -> str:
    """Which checks of a free-floating motion along the path fail, in words."""
    failed = []
    if not motion.follows_path:
        failed.append(f"the end effector leaves the path by {motion.deviation:.3g} m (tolerance {motion.tolerance:.3g} m)")
    elif not motion.singularity_free:
        failed.append(f"|measure| falls to {motion.min_measure:.3g} (singular at <= {motion.threshold:.3g})")
    if not motion.within_limits:
        failed.append(f"a joint crosses its limit (by {-motion.limit_margin:.3g} rad or m)")
    return "; ".join(failed)


def _path_checked_candidates(
    captured: Model,
    e: int,
    path: np.ndarray,
    piw: PathIndependentWorkspace,
    criterion: SingularityCriterion,
    R_plus: float | None,
) -> tuple[list[CheckedCandidate], int]:
    """Placements, postures and attitudes whose free-floating motion along the path was integrated: the best screened
    ones integrated again at the fine step, and how many were screened."""
    reach = piw.reachable
    pts = np.asarray(path, dtype=float)
    a = pts[0]
    u = (pts[1] - a) / np.linalg.norm(pts[1] - a)
    normals = _perpendiculars(u)
    if normals.shape[0] > 8:
        normals = normals[:: normals.shape[0] // 8]
    if R_plus is not None:
        radii = np.array([float(R_plus)])
    else:
        radii = np.linspace(reach.R_min, reach.R_max, 8)[1:-1]
    fits = [r for r in radii if max(_margin(pts, a + r * n, reach.R_min, reach.R_max) for n in normals) >= 0.0]
    if not fits:
        return [], 0
    found = path_checked_candidates(
        captured, e, pts, np.array(fits), normals, lambda r: _posture_candidates(captured, e, r, criterion), criterion=criterion
    )
    return refine_candidates(captured, e, pts, found[:8], criterion=criterion), len(found)


def _path_checked_plan(
    model: Model,
    captured: Model,
    e: int,
    path: np.ndarray,
    piw: PathIndependentWorkspace,
    mass: float,
    criterion: SingularityCriterion,
    best: CheckedCandidate,
    starts: int,
) -> tuple[PathPlacement, CapturePosture, PathMotion]:
    """The plan of one path-checked candidate: its placement (CM+, R+, eq. 19), posture and motion."""
    reach = piw.reachable
    pts = np.asarray(path, dtype=float)
    a = pts[0]
    c = best.cm_plus[: pts.shape[1]]
    robot = model.total_mass
    placement = PathPlacement(
        path=pts,
        cm_plus=c,
        start=a,
        direction=(a - c) / best.R_plus,
        R_plus=best.R_plus,
        margin=_margin(pts, c, reach.R_min, reach.R_max),
        interval=(reach.R_min, reach.R_max),
        workspace="reachable workspace (path checked)",
        rule="path_checked",
        robot_mass=robot,
        payload_mass=mass,
        approach_distance=approach_distance(robot, mass, best.R_plus),
        approach_point=a + (c - a) * (robot + mass) / robot,
    )
    d = np.zeros(3)
    d[: pts.shape[1]] = placement.direction
    rot = Rotation.from_quat(best.attitude)
    theta = float(rot.as_rotvec()[2]) if captured.is_planar and abs(d[2]) < 1e-12 else None
    posture = CapturePosture(
        model_name=captured.name,
        end_effector=captured.end_effector_names[e],
        q=best.q,
        R_plus=best.R_plus,
        measure=float(_dexterity(captured, best.q, criterion)),
        det=None,
        residual=float(end_effector_radius(captured, best.q, e)) - best.R_plus,
        direction=d,
        attitude=best.attitude,
        theta=theta,
        family=None,
        starts=starts,
    )
    return placement, posture, best.motion


def _grasp_options(target_velocity: Any, target_angular_velocity: Any, joints: Any, rank_by: Any) -> Grasp | None:
    """The moving-target options of :func:`plan_capture`, checked; None when no motion of the target was given."""
    moving = target_velocity is not None or target_angular_velocity is not None
    problem = grasp_problem(moving, joints, rank_by)
    if problem is not None:
        raise ValueError("{}: {}; {}".format(*problem))
    if not moving:
        return None
    zero = np.zeros(3)
    return Grasp(
        velocity=zero if target_velocity is None else check_twist(target_velocity, "target_velocity", "velocity"),
        angular_velocity=zero
        if target_angular_velocity is None
        else check_twist(target_angular_velocity, "target_angular_velocity", "angular_velocity"),
        joints="free" if joints is None else joints,
        rank_by=rank_by,
    )


def plan_capture(
    model: Model,
    end_effector: str | int,
    path: Any,
    *,
    mass: float,
    inertia: Any,
    offset: Sequence[float] = (0.0, 0.0, 0.0),
    rule: str = "perpendicular",
    R_plus: float | None = None,
    samples: int = 1 << 18,
    criterion: SingularityCriterion | None = None,
    strategy: str = "auto",
    target_velocity: Any = None,
    target_angular_velocity: Any = None,
    joints: str | None = None,
    rank_by: str = "measure",
) -> CapturePlan:
    """Run 1992 §V: capture of a payload (``mass`` kg, ``inertia`` about its CM) that must then follow ``path``.

    Returns the post-capture PIW, where CM+ and the free-flyer's CM must be
    (eq. 19), the capture posture and attitude (eqs. 20-21) and the
    free-floating motion along the path with the singularity measure along it.

    ``criterion`` (:class:`~freefloat.analysis.singularity.SingularityCriterion`):
    which rows of J* and which measure count as singular, with a threshold;
    for a spatial arm carrying a payload CM, ``rows="position"`` (the full
    6 x 6 J* of a 6-DOF arm is singular at every radius through its wrist).
    A plan is returned only when every check holds: the path lies in the workspace, and the
    free-floating motion along it follows the path, stays singularity-free and keeps every joint
    within its limits (a PIW plan that fails one of them is replaced by a path-checked search with
    ``strategy="auto"``, and refused with ``"piw"``).
    ``strategy``: ``"piw"`` (the paper's: the path must lie in the PIW),
    ``"path"`` (search CM+ on the reachable workspace, the posture and the
    attitude, integrating the free-floating motion along the path, and keep
    the one whose smallest measure along it is largest, above the threshold),
    or ``"auto"`` (the PIW, else the path check). Raises
    :class:`PathDoesNotFitError` when no plan is found.

    A moving target (docs/impact.md, "Moving targets in the capture planner"): ``target_velocity`` (3,) m/s and
    ``target_angular_velocity`` (3,) rad/s, the payload's CM velocity and angular velocity at the grasp, inertial
    frame (either may be left out: zero). The payload's mass and inertia stay ``mass`` and ``inertia``, and its pose
    at the grasp is the plan's (so no :class:`Target` is taken: its position and attitude are what the plan
    decides). ``joints``: "free" (default) or "locked" during the grasp (:func:`impact`). The plan then also holds
    ``grasp_state`` (the robot at rest in the capture posture and attitude, its CM at the approach point of eq. 19),
    ``target`` (the payload there, moving) and ``impact`` (:func:`impact` of the two), and ``ranking``: every
    candidate capture (the eq. 21 families of a planar two-link arm on a 5° grid of q1, else sampled postures on
    |r_E| = R+; for a path-checked plan its checked placements) with its measure, its checks and its impact.
    ``rank_by``: "measure" (default: the 1992 §V choice, the same plan as without a moving target),
    "spacecraft_rate", "impulse", "angular_impulse" or "joint_impulse" (locked joints): the candidate that passes
    every check with the smallest value (:class:`CaptureRanking`). Without the target's motion these four are refused,
    and ``impact``, ``grasp_state``, ``target`` and ``ranking`` are None.

    Progress: the post-capture PIW sampling and the path-checked search show a spinner, their elapsed time and a count
    (configurations; stages: one per candidate R+, then the batch integration) on a terminal, and log the same to the
    ``freefloat.progress`` logger elsewhere.
    """
    grasp = _grasp_options(target_velocity, target_angular_velocity, joints, rank_by)
    fixed = fixed_capture_plan(
        model, end_effector, path, mass=mass, inertia=inertia, offset=offset, rule=rule, R_plus=R_plus, samples=samples,
        criterion=criterion, strategy=strategy,
    )  # fmt: skip
    return fixed.plan if grasp is None else fixed.grasped(grasp)


@dataclass(frozen=True, eq=False)
class FixedCapturePlan:
    """The part of :func:`plan_capture` that the target's motion does not change (:func:`fixed_capture_plan`): the
    plan of a payload at rest, the checked candidates of a path-checked plan, and the inputs of the ranking.
    :meth:`moving` adds a target's motion (the candidates' impacts and the ranking), which is cheap beside it."""

    plan: CapturePlan
    checked: tuple[CheckedCandidate, ...]
    path: np.ndarray
    payload: Payload
    end_effector: int

    def moving(
        self, target_velocity: Any = None, target_angular_velocity: Any = None, joints: str | None = None, rank_by: str = "measure"
    ) -> CapturePlan:
        """The plan for a target with this motion (the arguments of :func:`plan_capture`): ``plan_capture``'s result."""
        grasp = _grasp_options(target_velocity, target_angular_velocity, joints, rank_by)
        return self.plan if grasp is None else self.grasped(grasp)

    def candidates(self) -> tuple[list[CheckedCandidate], np.ndarray, int]:
        """The candidate captures (their path checks done once, kept: they do not depend on the target's motion), their
        eq. 21 families (-1: none) and the planner's index among them."""
        found = self.__dict__.get("_candidates")
        if found is None:
            with status("checking the candidate capture postures along the path"):
                found = _candidates(self.plan, self.end_effector, self.path, list(self.checked))
            object.__setattr__(self, "_candidates", found)
        return found

    def grasped(self, grasp: Grasp) -> CapturePlan:
        """The plan for checked moving-target options (:class:`Grasp`): the candidates ranked, the chosen one's impact."""
        candidates = self.candidates()
        with status(f"the grasp of the moving target at each candidate capture posture (ranked by {grasp.rank_by})"):
            return _ranked_plan(self.plan, self.end_effector, self.path, candidates, grasp, self.payload)


def fixed_capture_plan(
    model: Model,
    end_effector: str | int,
    path: Any,
    *,
    mass: float,
    inertia: Any,
    offset: Sequence[float] = (0.0, 0.0, 0.0),
    rule: str = "perpendicular",
    R_plus: float | None = None,
    samples: int = 1 << 18,
    criterion: SingularityCriterion | None = None,
    strategy: str = "auto",
) -> FixedCapturePlan:
    """:func:`plan_capture` without the target's motion (the same arguments): the PIW, the placement, the posture and
    the path checks, kept with what :meth:`FixedCapturePlan.moving` needs to rank the candidates for a moving target."""
    if strategy not in STRATEGIES:
        raise ValueError(f"strategy: expected one of {', '.join(STRATEGIES)}, got {strategy!r}")
    if R_plus is not None and (
        isinstance(R_plus, bool) or not isinstance(R_plus, (int, float, np.number)) or not np.isfinite(R_plus) or R_plus <= 0
    ):
        raise ValueError(f"R_plus: expected a positive distance (m) from CM+ to A, got {R_plus!r}")
    crit = criterion if criterion is not None else SingularityCriterion()
    e = model.end_effector_index(end_effector)
    captured = model.with_payload(e, mass=mass, inertia=inertia, offset=offset)
    pts = _check_path(path)
    with status(f"post-capture PIW of {captured.end_effector_names[e]}: {samples:,} sampled configurations"):
        piw = path_independent_workspace(captured, e, samples=samples, criterion=crit)
    found: tuple[str, PathPlacement, CapturePosture, PathMotion] | None = None
    checked: list[CheckedCandidate] = []
    why_path = "strategy 'path' was asked for"
    if strategy != "path":
        try:
            placement = place_path(piw, pts, rule=rule, R_plus=R_plus, robot_mass=model.total_mass, payload_mass=float(mass))
        except PathDoesNotFitError as exc:
            if strategy == "piw" or exc.fits_reachable is False:  # not even in the reachable workspace: thrusters
                raise
            why_path = "the path fits in no PIW annulus"
        else:
            posture = optimal_capture_posture(captured, e, placement.R_plus, direction=placement.direction, criterion=criterion)
            motion = free_floating_path_motion(captured, e, posture.q, posture.attitude, placement.cm_plus, pts, criterion=crit)[0]
            why_path = f"the paper's capture posture in the PIW fails along the path: {_failed_checks(motion)}"
            if motion.usable:
                found = ("piw", placement, posture, motion)
                why_path = ""
            elif strategy == "piw":
                raise PathDoesNotFitError(
                    f"the path fits in the PIW, but the paper's capture posture fails along it: {_failed_checks(motion)} "
                    "(strategy 'auto' or 'path' searches other placements, postures and attitudes)",
                    margin=placement.margin,
                    fits_reachable=True,
                )
    if found is None:
        with status("searching capture placements, postures and attitudes whose free-floating motion follows the path"):
            checked, starts = _path_checked_candidates(captured, e, pts, piw, crit, R_plus)
        best = best_candidate(checked)
        if best is None:
            where = ", ".join(f"[{lo:.4g}, {hi:.4g}]" for lo, hi in piw.piw) or "(empty)"
            raise PathDoesNotFitError(
                f"{why_path} (PIW {where} m), and no capture placement, posture and attitude found moves the payload along "
                f"it free-floating without a singularity ({crit.describe(captured)}) within the joint limits: use the "
                "thrusters (1992 §V), a lower threshold, wider joint limits or a shorter path",
                margin=-np.inf,
                fits_reachable=None,
            )
        found = ("path", *_path_checked_plan(model, captured, e, pts, piw, float(mass), crit, checked[best], starts))
    method, placement, posture, motion = found
    plan = CapturePlan(
        before=model,
        captured=captured,
        end_effector=model.end_effector_names[e],
        piw=piw,
        placement=placement,
        posture=posture,
        method=method,
        motion=motion,
        criterion=crit,
        why_path=why_path if method == "path" else "",
    )
    payload = Payload(float(mass), inertia_matrix(inertia, "inertia"), np.asarray(offset, dtype=float))
    return FixedCapturePlan(plan=plan, checked=tuple(checked), path=pts, payload=payload, end_effector=e)


def _candidates(
    plan: CapturePlan, e: int, path: np.ndarray, checked: list[CheckedCandidate]
) -> tuple[list[CheckedCandidate], np.ndarray, int]:
    """The candidate captures of :meth:`FixedCapturePlan.candidates`: a PIW plan's posture and the eq. 21 families'
    (or sampled postures), each checked along the path; a path-checked plan's checked placements."""
    motion = plan.motion
    assert motion is not None
    if plan.method == "piw":
        posture = plan.posture
        others, family = piw_candidates(plan.captured, e, path, posture, plan.placement.cm_plus, plan.criterion)
        candidates = [CheckedCandidate(plan.placement.cm_plus, posture.R_plus, posture.q, posture.attitude, motion), *others]
        return candidates, np.concatenate([[-1 if posture.family is None else posture.family], family]), 0
    best = best_candidate(checked)
    assert best is not None  # the plan was made from it
    return checked, np.full(len(checked), -1), best


def _ranked_plan(
    plan: CapturePlan, e: int, path: np.ndarray, found: tuple[list[CheckedCandidate], np.ndarray, int], grasp: Grasp, payload: Payload
) -> CapturePlan:
    """The plan with the grasp of a moving target: the candidates (:func:`_candidates`) ranked, the chosen one's
    placement, posture and motion, and the impact there."""
    captured, crit, posture = plan.captured, plan.criterion, plan.posture
    candidates, families, planner = found
    ranking = rank_candidates(plan.before, captured, e, candidates, families, planner, payload=payload, grasp=grasp, criterion=crit)
    chosen = candidates[ranking.chosen]
    placement = plan.placement
    if ranking.chosen != planner:
        if plan.method == "piw":
            family, count = int(families[ranking.chosen]), len(candidates)
            posture = posture_at(captured, e, chosen.q, chosen.attitude, posture.R_plus, posture.direction, crit, family, count)
        else:
            placement, posture, _ = _path_checked_plan(
                plan.before, captured, e, path, plan.piw, payload.mass, crit, chosen, plan.posture.starts
            )
    state, target = grasp_setup(plan.before, captured, e, chosen.cm_plus, posture.q, posture.attitude, payload=payload, grasp=grasp)
    hit = impact(plan.before, state, target, e, joints=grasp.joints)
    return dataclasses.replace(
        plan, placement=placement, posture=posture, motion=chosen.motion, impact=hit, grasp_state=state, target=target, ranking=ranking
    )
