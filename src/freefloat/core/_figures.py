"""Figures that scripts and notebooks display (private helpers of every ``.plot``).

A figure that a ``plot()`` call hands to the user is made with pyplot
(``plt.figure``), so ``plt.show()`` and a notebook cell display it. Code that
only writes files draws on such a figure too and closes it when saved
(:func:`save_and_close`), so nothing accumulates in pyplot's registry.
matplotlib is imported only when a figure is made.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["box_polygons", "draw_box", "move_box", "new_axes", "new_figure", "save_and_close"]

#: The faces of a box given by its 8 corners, corner k on the + side of axis i where bit i of k is set
#: (the order of :func:`freefloat.mechanics.kinematics.spacecraft_box`); each face's corners go round it.
BOX_FACES = ((0, 2, 6, 4), (1, 3, 7, 5), (0, 1, 5, 4), (2, 3, 7, 6), (0, 1, 3, 2), (4, 5, 7, 6))


def new_figure(**kw: Any) -> Figure:
    """A new pyplot-managed figure (``plt.figure``), constrained layout unless ``layout`` is given."""
    import matplotlib.pyplot as plt

    kw.setdefault("layout", "constrained")
    return plt.figure(**kw)


def new_axes(*, projection: str | None = None, **kw: Any) -> Axes:
    """One axes on a new pyplot-managed figure (``projection="3d"`` for mpl_toolkits.mplot3d axes)."""
    return new_figure(**kw).add_subplot(projection=projection)


def save_and_close(fig: Figure, path: str | Path, **kw: Any) -> Path:
    """``fig.savefig(path, **kw)``, then close the figure (pyplot forgets it); returns the path."""
    import matplotlib.pyplot as plt

    fig.savefig(path, **kw)
    plt.close(fig)
    return Path(path)


def box_polygons(corners: Any, dims: int) -> Any:
    """What draws a box with corners (8, 3): its six faces (6, 4, 3) for 3D axes (``dims=3``), or the
    outline (K, 2) of its shadow on the x-y plane for 2D axes (the convex hull of the corners' x, y)."""
    corners = np.asarray(corners, dtype=float)
    if dims == 3:
        return corners[np.array(BOX_FACES)]
    from scipy.spatial import ConvexHull, QhullError

    xy = corners[:, :2]
    try:
        return xy[ConvexHull(xy).vertices]
    except QhullError:  # a flat box seen edge on: a line
        return xy[[0, 1, 3, 2]]


def draw_box(ax: Any, corners: Any, *, color: Any = "0.25", alpha: float = 1.0, **style: Any) -> Artist:
    """Draw a box with corners (8, 3) (see :func:`box_polygons`): on 2D axes a polygon patch, on 3D axes its six
    faces; edges in ``color``, faces light grey and see-through (more so in 3D, where they would hide what is
    inside or behind). ``alpha`` scales both; ``style``: further patch / collection keywords (label, zorder)."""
    from matplotlib.colors import to_rgba

    three_d = getattr(ax, "name", "") == "3d"
    style = {"facecolor": to_rgba("0.8", (0.12 if three_d else 0.6) * alpha), "edgecolor": to_rgba(color, alpha), "linewidth": 1.0} | style
    if three_d:
        from mpl_toolkits.mplot3d.art3d import Poly3DCollection

        faces = Poly3DCollection(list(box_polygons(corners, 3)), **style)
        ax.add_collection3d(faces)
        return faces
    from matplotlib.patches import Polygon

    return ax.add_patch(Polygon(box_polygons(corners, 2), closed=True, **style))


def move_box(artist: Any, corners: Any) -> None:
    """Move a box drawn by :func:`draw_box` to new corners (8, 3) (animations)."""
    if hasattr(artist, "set_verts"):
        artist.set_verts(list(box_polygons(corners, 3)))
    else:
        artist.set_xy(box_polygons(corners, 2))
