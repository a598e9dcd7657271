"""Drawing helpers of :mod:`freefloat.analysis.capture` (private): the system as a stick figure, in 2D or 3D axes, and
the trade-off of a moving target's capture postures (:func:`plot_ranking`).

Positions in the inertial frame, m; the geometry comes from
:func:`freefloat.mechanics.kinematics.stick_figure` (links) and
:func:`freefloat.mechanics.kinematics.spacecraft_box` (the bus).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ..core._figures import draw_box
from ..core.model import Model
from ..mechanics.kinematics import spacecraft_box, stick_figure

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes

__all__ = ["draw_system", "is_3d", "plot_ranking", "system_points"]


def is_3d(ax: Any) -> bool:
    """True for mpl_toolkits.mplot3d axes."""
    return getattr(ax, "name", "") == "3d"


def _center(center: Any) -> np.ndarray:
    c = np.zeros(3)
    given = np.asarray(center, dtype=float).ravel()
    c[: given.size] = given
    return c


def system_points(model: Model, q: Any, *, attitude: Any = None, center: Any = (0.0, 0.0)) -> np.ndarray:
    """Every point :func:`draw_system` draws for these arguments, inertial frame, (K, 3): for axis limits."""
    c = _center(center)
    q = np.asarray(q, dtype=float)
    seg = stick_figure(model, q, attitude=attitude).reshape(-1, 3)
    return np.concatenate([seg, spacecraft_box(model, q, attitude=attitude), np.zeros((1, 3))]) + c


def draw_system(
    ax: Axes,
    model: Model,
    q: Any,
    *,
    attitude: Any = None,
    center: Any = (0.0, 0.0),
    color: str = "k",
    label: str | None = None,
    alpha: float = 1.0,
    linewidth: float = 2.0,
) -> list[Artist]:
    """Stick figure of ``model`` at joint angles q (N,), inertial frame, m: the x-y plane, or 3D on 3D axes.

    The system CM is put at ``center`` (2 or 3 numbers) and the spacecraft
    turned by ``attitude`` (quaternion [x, y, z, w]; None: identity). Links
    are lines from joint to joint (from the spacecraft CM for the first
    link of each arm), joints small dots, end effectors larger dots, the
    spacecraft bus the box of :func:`~freefloat.mechanics.kinematics.spacecraft_box`
    at its true size (on 2D axes its outline in the x-y plane), the system CM a cross.
    Returns the artists.
    """
    q = np.asarray(q, dtype=float)
    c = _center(center)
    seg = stick_figure(model, q, attitude=attitude) + c
    dims = 3 if is_3d(ax) else 2
    style: dict[str, Any] = {"color": color, "alpha": alpha}
    artists: list[Artist] = [draw_box(ax, spacecraft_box(model, q, attitude=attitude) + c, color=color, alpha=alpha, zorder=1.5)]
    for k, (a, b) in enumerate(seg):
        artists += ax.plot(*[[a[i], b[i]] for i in range(dims)], "-", lw=linewidth, label=label if k == 0 else None, **style)
    joints = seg[: model.n_bodies - 1, 1]
    tips = seg[model.n_bodies - 1 :, 1]
    artists += ax.plot(*[joints[:, i] for i in range(dims)], "o", ms=3, **style)
    artists += ax.plot(*[tips[:, i] for i in range(dims)], "o", ms=5, **style)
    artists += ax.plot(*[[c[i]] for i in range(dims)], "x", ms=6, **style)
    if dims == 2:
        ax.set_aspect("equal")
        ax.autoscale_view()
    return artists


def plot_plan(plan: Any, ax: Any) -> list[Artist]:
    """Draw a capture plan (:class:`~freefloat.analysis.capture.CapturePlan`), like the 1992 paper's Fig. 7.

    2D axes (x-y plane of the inertial frame): the reachable workspace before capture about
    the free-flyer's CM (dashed), the reachable workspace (outline), PIW (filled) and PDW
    (hatched) after capture about CM+, the payload path A→B (red arrow), CM+ and the
    free-flyer's CM before capture, the robot at capture (dark) and with the payload at B at
    the end of the planned free-floating motion (light), and the end-effector path of that
    motion. 3D axes: the same without the workspace shells, within equal ranges on x, y and z
    that hold everything drawn (a cube). Every artist has a readable label.
    """
    from matplotlib.patches import FancyArrowPatch

    from ._workspace_reach import reachable_workspace
    from ._workspace_results import _circle

    placement, posture, motion = plan.placement, plan.posture, plan.motion
    three_d = is_3d(ax)
    dims = 3 if three_d else 2
    artists: list[Artist] = []
    if not three_d:
        if placement.approach_point is not None:
            before = reachable_workspace(plan.before, plan.end_effector)
            for k, r in enumerate(r for r in (before.R_max, before.R_min) if r > 0.0):
                label = "reachable workspace before capture (about the free-flyer's CM)" if k == 0 else None
                artists.append(_circle(ax, placement.approach_point[:2], r, edgecolor="C0", linestyle="--", linewidth=1.0, label=label))
        artists += plan.piw.plot(ax, center=placement.cm_plus[:2], label="path-independent workspace (PIW) after capture")
        reach = plan.piw.reachable
        artists += ax.plot(
            [], [], "-", color="k", lw=0.8, label=f"reachable workspace after capture [{reach.R_min:.3f}, {reach.R_max:.3f}] m"
        )
    drawn = [system_points(plan.captured, posture.q, attitude=posture.attitude, center=placement.cm_plus)]
    if motion is not None:
        end_att = motion.attitude[-1]
        artists += draw_system(
            ax, plan.captured, motion.q[-1], attitude=end_att, center=motion.cm, color="0.6", alpha=0.8, label="robot with the payload at B"
        )
        drawn += [system_points(plan.captured, motion.q[-1], attitude=end_att, center=motion.cm), motion.end_effector]
    artists += draw_system(
        ax, plan.captured, posture.q, attitude=posture.attitude, center=placement.cm_plus, color="0.15", label="robot at capture (A)"
    )
    path = placement.path
    pts = np.zeros((path.shape[0], 3))
    pts[:, : path.shape[1]] = path
    artists += ax.plot(*[pts[:, i] for i in range(dims)], "-", color="C3", lw=3.0, alpha=0.9, label="payload path A→B")
    if motion is not None:  # on top of the payload path, which it follows (the end effector holds the payload)
        artists += ax.plot(
            *[motion.end_effector[:, i] for i in range(dims)], "--", color="C2", lw=1.8, zorder=2.5, label="planned end-effector motion"
        )
    if not three_d:
        arrow = FancyArrowPatch(tuple(pts[-2, :2]), tuple(pts[-1, :2]), arrowstyle="-|>", mutation_scale=18, color="C3", lw=0)
        ax.add_patch(arrow)
        artists.append(arrow)
    artists += ax.plot(*[[pts[0, i]] for i in range(dims)], "o", color="C3", ms=9, mfc="0.85", label="payload (grasped at its CM)")
    for name, p in (("A", pts[0]), ("B", pts[-1])):
        artists.append(ax.text(*p[:dims], f"  {name}", color="C3", fontsize=11, fontweight="bold"))
    cm = np.zeros(3)
    cm[: placement.cm_plus.size] = placement.cm_plus
    artists += ax.plot(*[[cm[i]] for i in range(dims)], "+", color="C1", ms=12, mew=2.5, label="CM+ (system CM after capture)")
    drawn += [pts, cm[None]]
    if placement.approach_point is not None:
        ap = np.zeros(3)
        ap[: placement.approach_point.size] = placement.approach_point
        artists += ax.plot(*[[ap[i]] for i in range(dims)], "x", color="C0", ms=10, mew=2.5, label="free-flyer CM before capture")
        drawn.append(ap[None])
    if three_d:  # every drawn point inside equal ranges on x, y and z, shown as a cube
        every = np.concatenate(drawn)
        lo, hi = every.min(axis=0), every.max(axis=0)
        mid, half = 0.5 * (lo + hi), 0.55 * max(float(np.max(hi - lo)), 1e-3)
        ax.set_xlim(mid[0] - half, mid[0] + half)
        ax.set_ylim(mid[1] - half, mid[1] + half)
        ax.set_zlim(mid[2] - half, mid[2] + half)
        ax.set_box_aspect((1.0, 1.0, 1.0))
        ax.set_zlabel("z (m, inertial)")
    else:
        ax.set_aspect("equal")
        ax.autoscale_view()
    ax.set_xlabel("x (m, inertial)")
    ax.set_ylabel("y (m, inertial)")
    return artists


#: Axis labels of the ranking criteria (:data:`freefloat.analysis._capture_ranking.RANKINGS`) and the energy lost.
RANKING_LABELS = {
    "measure": "singularity measure at capture",
    "spacecraft_rate": "spacecraft rate after the grasp |ω0⁺| (rad/s)",
    "impulse": "linear grasp impulse on the target (N s)",
    "angular_impulse": "angular grasp impulse about the target's CM (N m s)",
    "joint_impulse": "joint impulse |τ̂| of the locked joints (N m s)",
    "energy_lost": "energy lost in the grasp (J)",
}


def plot_ranking(ranking: Any, ax: Any, *, y: str | None = None) -> list[Artist]:
    """Draw the trade-off of a :class:`~freefloat.analysis._capture_ranking.CaptureRanking` on 2D axes.

    x: each candidate's singularity measure at capture; y: its value of ``y`` (a ranking criterion or
    ``"energy_lost"``; default the ranking's criterion, or the spacecraft rate after the grasp when it ranks by the
    measure). The candidates that pass the planner's checks are dots (one series per eq. 21 family of a planar
    two-link arm, labelled "family 1 (+acos)", "family 2 (-acos)"; else one series "candidate postures"), those
    that fail a check grey crosses, the planner's most dexterous choice an open diamond and the chosen one a star.
    Returns the artists.
    """
    name = y if y is not None else ("spacecraft_rate" if ranking.rank_by == "measure" else ranking.rank_by)
    value = ranking.values(name)
    x, ok, family = ranking.measure, ranking.valid, ranking.family
    artists: list[Artist] = []
    groups = [(family == k, f"family {k + 1} ({'+' if k == 0 else '-'}acos)") for k in (0, 1) if np.any(family == k)]
    for k, (members, label) in enumerate(groups or [(np.ones(x.shape, dtype=bool), "candidate postures")]):
        pick = members & ok
        if np.any(pick):
            artists += ax.plot(x[pick], value[pick], "o", ls="none", color=f"C{k}", ms=4, label=f"{label}: pass the checks")
    if np.any(~ok):
        artists += ax.plot(x[~ok], value[~ok], "x", ls="none", color="0.6", ms=5, label="fail a check along the path")
    p, c = ranking.planner, ranking.chosen
    artists += ax.plot([x[p]], [value[p]], "D", ls="none", mfc="none", mec="k", ms=10, mew=1.5, label="most dexterous (1992 §V)")
    artists += ax.plot([x[c]], [value[c]], "*", ls="none", color="C3", ms=14, label=f"chosen (rank by {ranking.rank_by})")
    ax.set_xlabel(f"{RANKING_LABELS['measure']}, absolute: {ranking.measure_name}")
    ax.set_ylabel(RANKING_LABELS[name])
    return artists
