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

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.optimize import minimize
from scipy.spatial.transform import Rotation

from ..core._figures import new_axes
from ..core.feedback import status
from ..core.model import Model
from ..core.target import Target
from ..mechanics.impact import Impact, impact
from ..mechanics.jacobians import end_effector_jacobian, jacobian_measure
from ..mechanics.kinematics import end_effector_positions
from . import _workspace_search as search
from ._capture_families import CaptureFamilies, _family_of, _is_two_link, _two_link_coefficients, capture_families
from ._capture_path import PathMotion, free_floating_path_motion, path_checked_candidates, refine_candidates
from ._capture_plots import draw_system, plot_plan
from ._path_placement import PathDoesNotFitError, PathPlacement, _check_path, _margin, _perpendiculars, approach_distance, place_path
from ._workspace_reach import end_effector_radius, reachable_workspace, singularity_measure
from ._workspace_results import PathIndependentWorkspace, _axes, _freeze
from ._workspace_singular import path_independent_workspace
from .singularity import SingularityCriterion

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes

__all__ = [
    "CaptureFamilies",
    "CapturePlan",
    "CapturePosture",
    "Impact",
    "PathDoesNotFitError",
    "PathMotion",
    "PathPlacement",
    "Target",
    "approach_distance",
    "capture_families",
    "draw_system",
    "free_floating_path_motion",
    "impact",
    "optimal_capture_posture",
    "place_path",
    "plan_capture",
]


# ----------------------------------------------------------------------------------------------------------------- posture
@dataclass(frozen=True, eq=False)
class CapturePosture:
    """The capture configuration of 1992 §V: max |det J*| subject to |r_E| = R+ and the joint limits.

    ``q`` (N,) rad; ``measure``: |det J*| (square J*) or sqrt(det J* J*ᵀ),
    see :func:`freefloat.manipulability`; ``det``: the signed determinant
    (None if J* is not square); ``residual`` = |r_E(q)| - R+ (m);
    ``attitude``: quaternion [x, y, z, w] of the spacecraft that puts the end
    effector at CM+ + R+ ``direction`` (eq. 20; the smallest rotation in
    3D); ``theta``: that attitude as the planar angle θ (rad; None in 3D);
    ``family``: 0 or 1 (eq. 21) for a planar two-link arm.
    """

    model_name: str
    end_effector: str
    q: np.ndarray
    R_plus: float
    measure: float
    det: float | None
    residual: float
    direction: np.ndarray
    attitude: np.ndarray
    theta: float | None
    family: int | None
    starts: int

    def __post_init__(self) -> None:
        _freeze(self)

    def plot(self, model: Model, ax: Axes | None = None, *, center: Any = (0.0, 0.0)) -> list[Artist]:
        """Stick figure of ``model`` in this posture and attitude, system CM at ``center`` (x-y plane)."""
        return draw_system(_axes(ax), model, self.q, attitude=self.attitude, center=center)


def _dexterity(model: Model, q: np.ndarray, criterion: SingularityCriterion | None = None) -> np.ndarray:
    """What the capture posture maximises, (...) for q (..., N): the criterion's measure, absolute.

    Default (``criterion`` None or measure ``"auto"``): the product of the
    singular values of J* (1992 eq. 14; planar rows for a planar model):
    |det J*| when J* is square, sqrt(det J* J*ᵀ) (the manipulability) otherwise.
    """
    crit = criterion if criterion is not None else SingularityCriterion()
    measure = "manipulability" if crit.measure == "auto" else crit.measure
    return np.abs(jacobian_measure(model, np.asarray(q, dtype=float), crit.row_indices(model), measure))


def _starts(
    model: Model, e: int, R_plus: float, box: search.JointBox, samples: int, starts: int, seed: int, criterion: SingularityCriterion | None
) -> list[np.ndarray]:
    out: list[np.ndarray] = []
    if _is_two_link(model):  # the best point of each family of eq. 21 on a fine q1 grid
        q1 = np.linspace(-np.pi, np.pi, 3601)
        fam = capture_families(model, e, R_plus, q1)
        for k in range(2):
            d = np.abs(fam.det[:, k])
            if np.any(np.isfinite(d)):
                i = int(np.nanargmax(d))
                out.append(np.array([q1[i], fam.q2[i, k]]))
    q = search.sobol(samples, box.lo, box.hi, seed)
    r = end_effector_radius(model, q, e)
    near = np.argsort(np.abs(r - R_plus))[: max(64, q.shape[0] // 50)]
    meas = _dexterity(model, q[near], criterion)
    out += [q[i] for i in near[np.argsort(-meas)][:starts]]
    return out


def optimal_capture_posture(
    model: Model,
    end_effector: str | int,
    R_plus: float,
    *,
    direction: Any = None,
    family: int | None = None,
    samples: int = 1 << 14,
    starts: int = 8,
    seed: int = 0,
    criterion: SingularityCriterion | None = None,
) -> CapturePosture:
    """The capture posture that maximises |det J*| (or sqrt det J* J*ᵀ) with |r_E(q)| = R+ (1992 §V, eq. 21).

    ``criterion``: maximise its measure on its rows of J* instead
    (:class:`~freefloat.analysis.singularity.SingularityCriterion`; measure
    ``"auto"``: the product of the singular values).

    SLSQP with the equality constraint |r_E|² = R+² (analytic gradient from
    :func:`freefloat.end_effector_jacobian`) and the joint limits as bounds,
    from the best point of each eq. 21 family (planar two-link arm) and the
    best of ``samples`` Sobol configurations near |r_E| = R+. Ties between
    mirror optima go to det > 0, then the larger first joint angle (the
    paper's "choosing the positive value"). ``direction``: unit vector from
    CM+ to the path start A, inertial (default +x: eq. 20 with x_E = R+,
    y_E = 0); the attitude rotates r_E onto it. ``family`` (0: +acos,
    1: -acos; planar two-link arm only): the best posture on that family
    of eq. 21 only (the paper's Fig. 6 shows both).
    """
    e = model.end_effector_index(end_effector)
    if family is not None:
        if family not in (0, 1) or isinstance(family, bool):
            raise ValueError(f"family: expected 0 (+acos) or 1 (-acos) of eq. 21, got {family!r}")
        _two_link_coefficients(model, e)  # ModelError unless a planar two-link arm
    R_plus = float(R_plus)
    reach = reachable_workspace(model, e)
    tol = 10.0 * reach.accuracy
    if not (np.isfinite(R_plus) and reach.R_min - tol <= R_plus <= reach.R_max + tol):
        raise ValueError(
            f"R_plus = {R_plus!r} m is outside the reachable workspace [{reach.R_min:.6g}, {reach.R_max:.6g}] m of {reach.end_effector!r}"
        )
    box = search.model_box(model)
    bounds = [(None, None) if f else (lo, hi) for lo, hi, f in zip(box.lo, box.hi, box.free, strict=True)]

    def constraint(q: np.ndarray) -> np.ndarray:
        return np.array([(end_effector_radius(model, q, e) ** 2 - R_plus**2)])

    def constraint_jac(q: np.ndarray) -> np.ndarray:
        r = end_effector_positions(model, q)[e]
        return (2.0 * r @ end_effector_jacobian(model, q, e)[0:3, 6:])[None, :]

    def objective(q: np.ndarray) -> float:
        return -float(_dexterity(model, q, criterion))

    results = []
    candidates = _starts(model, e, R_plus, box, samples, starts, seed, criterion)
    for q0 in candidates:
        res = minimize(
            objective,
            q0,
            method="SLSQP",
            bounds=bounds,
            constraints=[{"type": "eq", "fun": constraint, "jac": constraint_jac}],
            options={"ftol": 1e-14, "maxiter": 500},
        )
        q = np.asarray(res.x)
        residual = float(end_effector_radius(model, q, e)) - R_plus
        inside = bool(np.all((q >= box.lo - 1e-12) | box.free) and np.all((q <= box.hi + 1e-12) | box.free))
        if abs(residual) < 1e-9 * max(1.0, R_plus) and inside:
            on = _family_of(model, e, R_plus, q)
            if family is None or on == family:
                results.append((float(_dexterity(model, q, criterion)), q, on))
    if not results:
        which = "" if family is None else f" on family {family}"
        raise ValueError(f"optimal_capture_posture: no start converged to |r_E| = {R_plus:.6g} m{which}; try more samples or starts")
    best_value = max(r[0] for r in results)
    square = _square(model) and (criterion is None or criterion.rows == "auto")

    def rank(item: tuple[float, np.ndarray, int | None]) -> tuple[bool, float, float]:
        value, q, _ = item
        det = float(singularity_measure(model, q)) if square else 0.0
        return (value >= best_value * (1.0 - 1e-9), det > 0.0, float(np.angle(np.exp(1j * q[0]))) if q.size else 0.0)

    value, q, on_family = max(results, key=rank)
    q = np.where(box.free, np.angle(np.exp(1j * q)), q)
    r0 = end_effector_positions(model, q)[e]
    d = np.zeros(3)
    if direction is None:
        d[0] = 1.0
    else:
        given = np.asarray(direction, dtype=float).ravel()
        if given.size not in (2, 3) or not np.all(np.isfinite(given)) or np.linalg.norm(given) == 0.0:
            raise ValueError(f"direction: expected a nonzero 2D or 3D vector, got {direction!r}")
        d[: given.size] = given / np.linalg.norm(given)
    theta: float | None
    if model.is_planar and abs(d[2]) < 1e-12:
        theta = float(np.angle(np.exp(1j * (np.arctan2(d[1], d[0]) - np.arctan2(r0[1], r0[0])))))
        rotation = Rotation.from_rotvec([0.0, 0.0, theta])
    else:
        theta = None
        rotation = Rotation.align_vectors(d[None], r0[None] / np.linalg.norm(r0))[0]
    return CapturePosture(
        model_name=model.name,
        end_effector=model.end_effector_names[e],
        q=q,
        R_plus=R_plus,
        measure=value,
        det=float(singularity_measure(model, q)) if square else None,
        residual=float(end_effector_radius(model, q, e)) - R_plus,
        direction=d,
        attitude=rotation.as_quat(),
        theta=theta,
        family=on_family,
        starts=len(candidates),
    )


def _square(model: Model) -> bool:
    rows = 2 * model.n_end_effectors if model.is_planar else 6 * model.n_end_effectors
    return rows == model.n_joints


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


def _snap_to_radius(model: Model, e: int, q: np.ndarray, R_plus: float, box: search.JointBox) -> np.ndarray:
    """Newton steps along the gradient of |r_E| that put each configuration (M, N) on |r_E| = R+; NaN rows where it fails."""
    q = q.copy()
    for _ in range(30):
        r = end_effector_positions(model, q)[:, e]
        norm = np.linalg.norm(r, axis=-1)
        grad = np.einsum("mi,mij->mj", r / np.maximum(norm, 1e-300)[:, None], end_effector_jacobian(model, q, e)[:, 0:3, 6:])
        q -= ((norm - R_plus) / np.maximum(np.einsum("mj,mj->m", grad, grad), 1e-300))[:, None] * grad
    ok = np.abs(end_effector_radius(model, q, e) - R_plus) < 1e-9 * max(1.0, R_plus)
    ok &= np.all(((q >= box.lo) & (q <= box.hi)) | box.free, axis=1)
    q[~ok] = np.nan
    return q


def _posture_candidates(
    model: Model, e: int, R_plus: float, criterion: SingularityCriterion, *, count: int = 4, seed: int = 0
) -> list[np.ndarray]:
    """Up to ``count`` distinct capture configurations on |r_E| = R+ (Sobol samples put on the sphere), the most dexterous first."""
    out: list[np.ndarray] = []
    box = search.model_box(model)
    q = search.sobol(1 << 12, box.lo, box.hi, seed + 1)
    near = np.argsort(np.abs(end_effector_radius(model, q, e) - R_plus))[:256]
    snapped = _snap_to_radius(model, e, q[near], R_plus, box)
    snapped = snapped[np.all(np.isfinite(snapped), axis=1)]
    if snapped.size:
        for qq in snapped[np.argsort(-_dexterity(model, snapped, criterion))]:
            if len(out) >= count:
                break
            if all(np.max(np.abs(np.angle(np.exp(1j * (qq - p))))) > 0.3 for p in out):
                out.append(qq)
    return out


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


def _path_checked_plan(
    model: Model,
    captured: Model,
    e: int,
    path: np.ndarray,
    piw: PathIndependentWorkspace,
    mass: float,
    criterion: SingularityCriterion,
    R_plus: float | None,
) -> tuple[PathPlacement, CapturePosture, PathMotion] | None:
    """Search placements, postures and attitudes whose free-floating motion along the path stays non-singular."""
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
        return None
    found = path_checked_candidates(
        captured, e, pts, np.array(fits), normals, lambda r: _posture_candidates(captured, e, r, criterion), criterion=criterion
    )
    best = refine_candidates(captured, e, pts, found[:8], criterion=criterion)
    if best is None:
        return None
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
        starts=len(found),
    )
    return placement, posture, best.motion


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

    Progress: the post-capture PIW sampling and the path-checked search show a spinner, their elapsed time and a count
    (configurations; stages: one per candidate R+, then the batch integration) on a terminal, and log the same to the
    ``freefloat.progress`` logger elsewhere.
    """
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
            checked = _path_checked_plan(model, captured, e, pts, piw, float(mass), crit, R_plus)
        if checked is None:
            where = ", ".join(f"[{lo:.4g}, {hi:.4g}]" for lo, hi in piw.piw) or "(empty)"
            raise PathDoesNotFitError(
                f"{why_path} (PIW {where} m), and no capture placement, posture and attitude found moves the payload along "
                f"it free-floating without a singularity ({crit.describe(captured)}) within the joint limits: use the "
                "thrusters (1992 §V), a lower threshold, wider joint limits or a shorter path",
                margin=-np.inf,
                fits_reachable=None,
            )
        found = ("path", *checked)
    method, placement, posture, motion = found
    return CapturePlan(
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
