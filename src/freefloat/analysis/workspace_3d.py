"""Workspaces of spatial arms drawn in 3D: sections through the system CM and point clouds.

The limits of :mod:`freefloat.analysis.workspace` are radii about the system
CM (the attitude is free, so each workspace is a spherical shell). For a
spatial model they are drawn as sections of those shells by the planes xy,
xz and yz through the CM, and next to them the cloud of end-effector
positions over sampled joint configurations at a fixed attitude (spacecraft
frame), coloured by a singularity measure, in 3D axes (mpl_toolkits.mplot3d).

:func:`workspace_cloud` computes the cloud (one batched call);
:meth:`WorkspaceCloud.plot` and :meth:`WorkspaceCloud.plot_section` draw it;
:func:`plot_workspace_sections` draws the four panels. Distances in m.
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core._figures import new_axes, new_figure
from ..core.model import Model
from ..mechanics.kinematics import end_effector_positions
from . import _workspace_search as search
from ._workspace_results import PLANES, GuaranteedWorkspace, PathIndependentWorkspace, ReachableWorkspace, _freeze
from .singularity import SingularityCriterion

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["WorkspaceCloud", "plot_workspace_sections", "workspace_cloud"]

_AXIS = {"x": 0, "y": 1, "z": 2}


@dataclass(frozen=True, eq=False)
class WorkspaceCloud:
    """End-effector positions over sampled joint configurations, with a singularity measure at each.

    ``points`` (M, 3): r_E relative to the system CM, spacecraft frame (the
    attitude held at identity), m; ``q`` (M, N) the configurations (rad);
    ``measure`` (M,): the criterion's measure (``criterion`` describes it,
    ``threshold`` its threshold, ``symbol`` and ``unit`` name it and its unit
    in labels); ``singular`` (M,): |measure| <= threshold
    (to the 5th percentile of |measure| when the threshold is 0, so the
    near-singular configurations show).
    """

    model_name: str
    end_effector: str
    points: np.ndarray
    q: np.ndarray
    measure: np.ndarray
    criterion: str
    threshold: float
    symbol: str = "measure"
    unit: str = ""

    def __post_init__(self) -> None:
        _freeze(self)

    @property
    def singular(self) -> np.ndarray:
        """Configurations counted as (near-)singular, (M,) booleans."""
        cut = self.threshold if self.threshold > 0.0 else float(np.percentile(np.abs(self.measure), 5.0))
        return np.asarray(np.abs(self.measure) <= cut)

    def plot(self, ax: Any = None, *, max_points: int = 20000) -> list[Artist]:
        """3D scatter of the cloud coloured by |measure| (a colour bar names it and its unit), the (near-)singular
        points in red; the CM a black cross.

        ``ax``: 3D axes (``projection="3d"``); default a new pyplot figure. Returns the artists, the colour bar's
        axes last."""
        ax = ax if ax is not None else new_axes(figsize=(6.4, 6.0), projection="3d")
        step = max(1, self.points.shape[0] // max_points)
        pts, val, sing = self.points[::step], np.abs(self.measure[::step]), self.singular[::step]
        reached = ax.scatter(pts[~sing, 0], pts[~sing, 1], pts[~sing, 2], c=val[~sing], cmap="viridis", s=2, alpha=0.35, label="reached")
        artists: list[Artist] = [reached]
        artists.append(ax.scatter(pts[sing, 0], pts[sing, 1], pts[sing, 2], c="tab:red", s=3, alpha=0.6, label="(near-)singular"))
        artists += ax.plot([0.0], [0.0], [0.0], "kx", ms=9, mew=2, label="system CM")
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        mid, half = 0.5 * (lo + hi), 0.55 * float(np.max(hi - lo))
        ax.set_xlim(mid[0] - half, mid[0] + half)
        ax.set_ylim(mid[1] - half, mid[1] + half)
        ax.set_zlim(mid[2] - half, mid[2] + half)
        ax.set_box_aspect((1.0, 1.0, 1.0))
        ax.set_xlabel("x (m, spacecraft frame)")
        ax.set_ylabel("y (m, spacecraft frame)")
        ax.set_zlabel("z (m, spacecraft frame)")
        red = textwrap.fill(f"red: {self.criterion}", 70)
        ax.set_title(f"{self.end_effector}: reached points at a fixed attitude, coloured by |{self.symbol}|\n{red}", fontsize=8)
        fig = ax.get_figure()
        assert fig is not None
        unit = f" ({self.unit})" if self.unit else ""
        colorbar = fig.colorbar(reached, ax=ax, shrink=0.6, pad=0.12, label=f"|{self.symbol}|{unit}")
        artists.append(colorbar.ax)
        return artists

    def plot_section(self, ax: Axes | None = None, *, plane: str = "xy", thickness: float | None = None) -> list[Artist]:
        """The cloud's points within ``thickness`` (default 5 % of the reach) of ``plane`` through the CM, 2D."""
        if plane not in PLANES:
            raise ValueError(f"plane: expected one of {', '.join(PLANES)}, got {plane!r}")
        ax = ax if ax is not None else new_axes(figsize=(6.0, 6.0))
        i, j = _AXIS[plane[0]], _AXIS[plane[1]]
        k = 3 - i - j
        reach = float(np.max(np.linalg.norm(self.points, axis=1)))
        slab = np.abs(self.points[:, k]) <= (thickness if thickness is not None else 0.05 * reach)
        sing = self.singular & slab
        artists: list[Artist] = [
            ax.scatter(self.points[slab & ~sing, i], self.points[slab & ~sing, j], s=2, color="0.55", alpha=0.4, label="reached (slab)"),
            ax.scatter(self.points[sing, i], self.points[sing, j], s=3, color="tab:red", alpha=0.6, label="(near-)singular"),
        ]
        return artists


def workspace_cloud(
    model: Model,
    end_effector: str | int = 0,
    *,
    samples: int = 1 << 14,
    seed: int = 0,
    criterion: SingularityCriterion | None = None,
) -> WorkspaceCloud:
    """End-effector positions (spacecraft frame, about the system CM) over ``samples`` Sobol configurations within
    the joint limits, and the singularity measure of ``criterion`` (default: the paper's) at each; one batched call."""
    e = model.end_effector_index(end_effector)
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 16:
        raise ValueError(f"samples: expected an integer >= 16, got {samples!r}")
    crit = criterion if criterion is not None else SingularityCriterion()
    box = search.model_box(model)
    q = search.sobol(int(samples), box.lo, box.hi, seed)
    return WorkspaceCloud(
        model_name=model.name,
        end_effector=model.end_effector_names[e],
        points=end_effector_positions(model, q)[:, e],
        q=q,
        measure=crit.evaluate(model, q),
        criterion=crit.describe(model),
        threshold=crit.threshold,
        symbol=crit.symbol(model),
        unit=crit.unit(model),
    )


def plot_workspace_sections(
    reachable: ReachableWorkspace,
    guaranteed: GuaranteedWorkspace | None = None,
    piw: PathIndependentWorkspace | None = None,
    cloud: WorkspaceCloud | None = None,
    *,
    fig: Figure | None = None,
) -> Figure:
    """Four panels: the workspace shells' sections by the xy, xz and yz planes through the system CM (with the
    cloud's points near each plane) and the cloud in 3D. ``fig``: draw on it (default a new pyplot figure)."""
    fig = fig if fig is not None else new_figure(figsize=(12.0, 11.0))
    axes = [fig.add_subplot(2, 2, k + 1) for k in range(3)]
    for ax, plane in zip(axes, PLANES, strict=True):
        if cloud is not None:
            cloud.plot_section(ax, plane=plane)
        reachable.plot(ax, color="C0", label=f"reachable [{reachable.R_min:.3f}, {reachable.R_max:.3f}] m", plane=plane)
        if guaranteed is not None and guaranteed.exists:
            guaranteed.plot(ax, color="C2", label=f"guaranteed [{guaranteed.R_min:.3f}, {guaranteed.R_max:.3f}] m", plane=plane)
        if piw is not None:
            widest = "" if piw.R_min is None else f" (widest [{piw.R_min:.3f}, {piw.R_max:.3f}] m)"
            piw.plot(ax, color="C1", label=f"path-independent{widest}", plane=plane)
        ax.plot([0.0], [0.0], "k+", ms=10, mew=1.5, label="system CM")
        ax.set_title(f"section by the {plane} plane through the system CM", fontsize="medium")
        ax.grid(True, lw=0.3, alpha=0.5)
    axes[0].legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), ncols=2, fontsize="x-small", frameon=False)
    if cloud is not None:
        cloud.plot(fig.add_subplot(2, 2, 4, projection="3d"))
    return fig
