"""Drawing helpers of :mod:`freeflyer.analysis.capture` (private): the system as a stick figure, in 2D or 3D axes.

Positions in the inertial frame, m; the geometry comes from
:func:`freeflyer.mechanics.kinematics.stick_figure`.
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
