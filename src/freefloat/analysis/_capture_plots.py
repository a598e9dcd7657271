"""Drawing helpers of :mod:`freefloat.analysis.capture` (private): the system as a stick figure, in 2D or 3D axes.

Positions in the inertial frame, m; the geometry comes from
:func:`freefloat.mechanics.kinematics.stick_figure`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.model import Model
from ..mechanics.kinematics import point_positions, stick_figure

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes

__all__ = ["draw_system", "is_3d"]


def is_3d(ax: Any) -> bool:
    """True for mpl_toolkits.mplot3d axes."""
    return getattr(ax, "name", "") == "3d"


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
    spacecraft a square at its CM, the system CM a cross. Returns the artists.
    """
    q = np.asarray(q, dtype=float)
    c = np.zeros(3)
    given = np.asarray(center, dtype=float).ravel()
    c[: given.size] = given
    seg = stick_figure(model, q, attitude=attitude) + c
    sc = point_positions(model, q, 0, model.com[0])
    if attitude is not None:
        from scipy.spatial.transform import Rotation

        sc = Rotation.from_quat(np.asarray(attitude, dtype=float)).apply(sc)
    sc = sc + c
    dims = 3 if is_3d(ax) else 2
    style: dict[str, Any] = {"color": color, "alpha": alpha}
    artists: list[Artist] = []
    for k, (a, b) in enumerate(seg):
        artists += ax.plot(*[[a[i], b[i]] for i in range(dims)], "-", lw=linewidth, label=label if k == 0 else None, **style)
    joints = seg[: model.n_bodies - 1, 1]
    tips = seg[model.n_bodies - 1 :, 1]
    artists += ax.plot(*[joints[:, i] for i in range(dims)], "o", ms=3, **style)
    artists += ax.plot(*[tips[:, i] for i in range(dims)], "o", ms=5, **style)
    artists += ax.plot(*[[sc[i]] for i in range(dims)], "s", ms=12, mfc="0.8", mec=color, alpha=alpha)
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
    motion. 3D axes: the same without the workspace shells. Every artist has a readable label.
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
    if motion is not None:
        end_att = motion.attitude[-1]
        artists += draw_system(
            ax, plan.captured, motion.q[-1], attitude=end_att, center=motion.cm, color="0.6", alpha=0.8, label="robot with the payload at B"
        )
        artists += ax.plot(*[motion.end_effector[:, i] for i in range(dims)], ":", color="C2", lw=1.5, label="planned end-effector motion")
    artists += draw_system(
        ax, plan.captured, posture.q, attitude=posture.attitude, center=placement.cm_plus, color="0.15", label="robot at capture (A)"
    )
    path = placement.path
    pts = np.zeros((path.shape[0], 3))
    pts[:, : path.shape[1]] = path
    artists += ax.plot(*[pts[:, i] for i in range(dims)], "-", color="C3", lw=3.0, alpha=0.9, label="payload path A→B")
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
    if placement.approach_point is not None:
        ap = np.zeros(3)
        ap[: placement.approach_point.size] = placement.approach_point
        artists += ax.plot(*[[ap[i]] for i in range(dims)], "x", color="C0", ms=10, mew=2.5, label="free-flyer CM before capture")
    if three_d:
        every = np.concatenate([pts, cm[None], motion.end_effector if motion is not None else pts])
        lo, hi = every.min(axis=0), every.max(axis=0)
        mid, half = 0.5 * (lo + hi), 0.6 * max(float(np.max(hi - lo)), plan.placement.R_plus)
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
