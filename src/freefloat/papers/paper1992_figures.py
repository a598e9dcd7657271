"""Figures of ``freefloat reproduce 1992``, like the paper's Figs. 4, 6 and 7, plus maps of the dynamic singularities.

Every figure is drawn from freefloat's own results
(:class:`freefloat.papers.paper1992.Results1992`); each ``figure_*`` function
returns a pyplot figure (``plt.show()`` and notebooks display it), and
:func:`write_figures_1992` saves each as PNG and closes it:

* ``fig4_two_arm_workspaces.png``: the two-arm system of Table I, reachable
  and guaranteed workspaces of both end effectors about the system CM,
  before (Table III) and after (Table V) arm 1 grasps the 400 kg payload,
  with the shift of the system CM at capture (the paper's Fig. 4 and §IV).
* ``fig6_capture_families.png``: the two families q2(q1) of eq. 21 and
  det J* along them at R+ (the paper's Fig. 6), our optimum and the
  paper's printed q1 = 79° marked.
* ``fig7_capture_plan.png``: the §V capture: the post-capture PIW around
  CM+, the path AB, the approach point, the reachable workspace before
  capture and the capture posture (the paper's Fig. 7).
* ``fig_singularity_maps.png``: det J* over the whole joint space of the
  one-arm system before and after capture, the singular set (det J* = 0)
  and the |r_E| contours at the PDW boundaries, and the PIW / PDW radii.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..analysis.capture import draw_system
from ..analysis.singularity import jacobian_determinant_map
from ..analysis.workspace import PathIndependentWorkspace, end_effector_radius, path_independent_workspace, payload_effect
from ..core._figures import new_figure, save_and_close
from ..mechanics.kinematics import end_effector_positions
from ..models import papadopoulos1992
from ..scenarios.capture_outputs import plot_capture_families, plot_capture_plan

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from .paper1992 import Results1992

__all__ = ["FIGURE_NAMES", "write_figures_1992"]

FIGURE_NAMES = ("fig4_two_arm_workspaces.png", "fig6_capture_families.png", "fig7_capture_plan.png", "fig_singularity_maps.png")
#: Joint angles (deg) at which Fig. 4 draws the two-arm system: arm 1 then arm 2 (absolute angle θ + q1 + ... as in eq. 18).
FIG4_POSTURE_DEG = (35.0, 70.0, 200.0, -80.0)
DPI = 200


def _circle(ax: Axes, r: float, **style: Any) -> None:
    from matplotlib.patches import Circle

    ax.add_patch(Circle((0.0, 0.0), r, fill=False, **style))


def _annulus(ax: Axes, r_in: float, r_out: float, **style: Any) -> None:
    from matplotlib.patches import Wedge

    ax.add_patch(Wedge((0.0, 0.0), r_out, 0.0, 360.0, width=r_out - r_in, **style))


#: Per arm: colour, outline line style and hatching of its guaranteed workspace (Fig. 4), so overlapping bands stay readable.
ARM_STYLES = {1: ("C0", "-", "////"), 2: ("C3", (0, (6, 3)), "\\\\\\\\")}


def _workspace_panel(ax: Axes, results: Results1992, table: str, *, after: bool, limit: float) -> None:
    """One panel of Fig. 4: both arms' reachable (R_max; collinear R_min dotted) and guaranteed workspaces.

    Each arm's guaranteed workspace is an unfilled band hatched in its own direction and
    outlined in its own colour and line style: where the bands overlap the hatchings cross,
    and each legend entry shows exactly what is drawn. ``limit``: both axes span ±limit (m).
    """
    two = papadopoulos1992(arms=2)
    model = two.with_payload(0, mass=400.0, inertia=25.0) if after else two
    q = np.radians(FIG4_POSTURE_DEG)
    for arm, (color, style, hatch) in ARM_STYLES.items():
        reach, gw = results.reachable[f"{table}.arm{arm}"], results.guaranteed[f"{table}.arm{arm}"]
        _circle(ax, reach.R_max, edgecolor=color, lw=1.6, ls=style, label=f"arm {arm}: reachable, R_max = {reach.R_max:.3f} m")
        _circle(ax, results.collinear[f"{table}.arm{arm}"], edgecolor=color, lw=1.0, ls=":")
        if gw.exists and gw.R_min is not None and gw.R_max is not None:
            label = f"arm {arm}: guaranteed [{gw.R_min:.3f}, {gw.R_max:.3f}] m"
            _annulus(ax, gw.R_min, gw.R_max, facecolor="none", edgecolor=color, hatch=hatch, lw=1.0, ls=style, label=label)
        else:
            ax.plot([], [], " ", label=f"arm {arm}: no guaranteed workspace (R'_max < R'_min)")
    ax.plot([], [], ":", color="0.3", lw=1.0, label="collinear R_min (the paper's reading)")
    draw_system(ax, model, q, color="k")
    ax.plot([0.0], [0.0], "k+", ms=12, mew=1.8, label="system CM" + (" after capture (CM+)" if after else ""))
    if after:
        tip = end_effector_positions(model, q)[0]
        ax.plot([tip[0]], [tip[1]], "o", color="0.45", ms=14, alpha=0.8, label="payload, 400 kg (held at its CM)")
        effect = payload_effect(two, 0, 400.0, 25.0)
        shift = effect.cm_shift(q)
        ax.plot([-shift[0]], [-shift[1]], "x", color="C1", ms=9, mew=2, label="system CM before capture")
        ax.annotate("", xy=(0.0, 0.0), xytext=(-shift[0], -shift[1]), arrowprops={"arrowstyle": "->", "color": "C1", "lw": 1.5})
        lo, hi = effect.cm_shift_range
        ax.text(
            0.02,
            0.02,
            f"CM shift at capture {np.linalg.norm(shift):.3f} m here; {lo:.3f}-{hi:.3f} m over all q",
            transform=ax.transAxes,
            fontsize="small",
        )
    ax.set_xlim(-limit, limit)
    ax.set_ylim(-limit, limit)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.grid(True, lw=0.3, alpha=0.5)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), ncols=2, fontsize="x-small", frameon=False)
    name = "Table V: arm 1 holds the 400 kg payload" if after else "Table III: no payload"
    ax.set_title(f"({'b' if after else 'a'}) {name}", fontsize="medium")


def figure_4(results: Results1992) -> Any:
    """Reachable and guaranteed workspaces of the two-arm system before and after capture (Fig. 4, Tables III and V)."""
    fig = new_figure(figsize=(12.0, 7.4))
    left, right = fig.subplots(1, 2, sharex=True, sharey=True)
    limit = 1.08 * max(results.reachable[f"{t}.arm{a}"].R_max for t in ("T3", "T5") for a in (1, 2))
    _workspace_panel(left, results, "T3", after=False, limit=limit)
    _workspace_panel(right, results, "T5", after=True, limit=limit)
    fig.suptitle(
        "Papadopoulos 1992 Fig. 4: workspaces of the two-arm system about the system CM (eqs. 15-16), "
        f"drawn at q = {', '.join(f'{v:g}°' for v in FIG4_POSTURE_DEG)}"
    )
    return fig


def figure_6(results: Results1992) -> Any:
    """The two families of eq. 21 and det J* along them (Fig. 6)."""
    fig = new_figure(figsize=(8.0, 5.0))
    ax = fig.add_subplot()
    plot_capture_families(results.plan, ax, marks={"paper: q1 = 79°": 79.0})
    return fig


def figure_7(results: Results1992) -> Any:
    """The §V capture: PIW after capture, path AB, CM+, approach point, posture (Fig. 7)."""
    fig = new_figure(figsize=(7.4, 8.4))
    ax = fig.add_subplot()
    plot_capture_plan(results.plan, ax)
    ax.set_title(ax.get_title().replace("(1992 §V", "(Papadopoulos 1992 Fig. 7, §V"), fontsize="medium")
    return fig


def _radius_contours(ax: Axes, model: Any, piw: PathIndependentWorkspace, n: int) -> None:
    """|r_E| contours at the PDW interval ends on a det J* map (degrees)."""
    angles = np.linspace(-np.pi, np.pi, n)
    q = np.stack(np.meshgrid(angles, angles, indexing="ij"), axis=-1)
    radius = end_effector_radius(model, q, 0)
    levels = sorted({round(v, 6) for iv in piw.pdw for v in iv if piw.reachable.R_min + 1e-6 < v < piw.reachable.R_max - 1e-6})
    if levels:
        deg = np.degrees(angles)
        cs = ax.contour(deg, deg, radius.T, levels=levels, colors="C2", linestyles="--", linewidths=1.2)
        ax.clabel(cs, fmt=lambda v: f"{v:.3f} m", fontsize="x-small", inline=True, manual=_inner_points(cs.allsegs, deg[0], deg[-1]))


#: Contour labels of the singularity maps stay this share of each axis's range away from its edges.
LABEL_MARGIN = 0.1


def _inner_points(allsegs: list[list[np.ndarray]], lo: float, hi: float) -> list[tuple[float, float]]:
    """One label position per piece of contour that enters the inner part of the map (``LABEL_MARGIN`` from
    every edge of [lo, hi]²): its middle point there, so that no label sticks out of the axes."""
    margin = LABEL_MARGIN * (hi - lo)
    points = []
    for segs in allsegs:
        for seg in segs:
            inner = seg[np.all((seg > lo + margin) & (seg < hi - margin), axis=1)]
            if len(inner):
                points.append((float(inner[len(inner) // 2, 0]), float(inner[len(inner) // 2, 1])))
    return points


def _radii_strip(ax: Axes, rows: list[tuple[str, PathIndependentWorkspace]]) -> None:
    for k, (_, piw) in enumerate(rows):
        y = len(rows) - 1 - k
        for lo, hi in piw.piw:
            ax.barh(y, hi - lo, left=lo, height=0.5, color="C1", alpha=0.6, label="PIW" if k == 0 and lo == piw.piw[0][0] else None)
        for lo, hi in piw.pdw:
            ax.barh(
                y,
                hi - lo,
                left=lo,
                height=0.5,
                color="none",
                edgecolor="0.4",
                hatch="///",
                label="PDW" if k == 0 and lo == piw.pdw[0][0] else None,
            )
        for lo, hi in piw.pdw:
            for v in (lo, hi):
                ax.text(v, y + 0.3, f"{v:.3f}", ha="center", fontsize="x-small")
    ax.set_yticks(range(len(rows)), [label for label, _ in rows][::-1])
    ax.set_xlabel("distance |r_E| of the end effector from the system CM (m)")
    ax.set_ylim(-0.6, len(rows) - 0.2)
    ax.legend(loc="lower right", fontsize="small")
    ax.set_title("Path-independent (PIW) and path-dependent (PDW) workspace radii (eq. 17)", fontsize="medium")


def figure_singularity_maps(results: Results1992, n: int = 361) -> Any:
    """det J* over joint space of the one-arm system before and after capture, with the PDW radii."""
    from matplotlib.lines import Line2D

    one = papadopoulos1992(arms=1)
    after = results.plan.captured
    before_piw = path_independent_workspace(one, samples=1 << 16)
    fig = new_figure(figsize=(12.0, 8.4))
    grid = fig.add_gridspec(2, 2, height_ratios=(3.2, 1.0))
    cases = (("(a) before capture", one, before_piw), ("(b) after capturing 400 kg, 25 kg m²", after, results.plan.piw))
    for col, (title, model, piw) in enumerate(cases):
        ax = fig.add_subplot(grid[0, col])
        jacobian_determinant_map(model, (0, 1), n=n).plot(ax)
        _radius_contours(ax, model, piw, n)
        ax.legend(
            handles=[
                Line2D([], [], color="k", lw=1.6, label="det J* = 0 (dynamic singularity)"),
                Line2D([], [], color="C2", ls="--", lw=1.2, label="|r_E| at a PDW boundary"),
            ],
            loc="upper center",
            bbox_to_anchor=(0.5, -0.12),
            ncols=2,
            frameon=False,
            fontsize="x-small",
        )
        ax.set_title(f"{title}: det ⁰J*(q1, q2)", fontsize="medium")
    strip = fig.add_subplot(grid[1, :])
    _radii_strip(strip, [("before capture", before_piw), ("after capture", results.plan.piw)])
    fig.suptitle("Dynamic singularities of the 1992 one-arm system (§V) over its whole joint space")
    return fig


def write_figures_1992(results: Results1992, out: Path) -> list[Path]:
    """Draw and save the four figures in ``out`` (created); returns their paths in :data:`FIGURE_NAMES` order."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for name, make in zip(FIGURE_NAMES, (figure_4, figure_6, figure_7, figure_singularity_maps), strict=True):
        path = out / name
        save_and_close(make(results), path, dpi=DPI, bbox_inches="tight", pad_inches=0.15)
        written.append(path)
    return written
