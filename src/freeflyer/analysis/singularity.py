"""Maps of dynamic singularities: det J*(q) over a grid of two joint angles.

Papadopoulos 1992 eq. 17: a free-floating system with zero momentum cannot
move its end effectors in some direction wherever det ⁰J*(q) = 0. These
*dynamic singularities* depend on the mass distribution as well as the
kinematics, so they move when a payload is captured. ⁰J* (1992 eq. 14) is in
the spacecraft frame and depends on the joint angles only, not on the
spacecraft attitude, so a map over joint space is the whole story.

:func:`jacobian_determinant_map` computes the map (one batched call of
:func:`freeflyer.jacobian_determinant`); :meth:`DeterminantMap.plot` draws it.
Angles are in radians inside; ``plot(degrees=True)`` shows degrees.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from ..core.errors import ShapeError
from ..core.model import Model
from ..mechanics.jacobians import jacobian_determinant

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.collections import QuadMesh
    from matplotlib.colorbar import Colorbar
    from matplotlib.contour import QuadContourSet

__all__ = ["DeterminantMap", "DeterminantMapArtists", "jacobian_determinant_map"]

_SUPERSCRIPT = str.maketrans("0123456789", "⁰¹²³⁴⁵⁶⁷⁸⁹")


class DeterminantMapArtists(NamedTuple):
    """What :meth:`DeterminantMap.plot` drew."""

    mesh: QuadMesh
    contour: QuadContourSet | None  # None when det J* does not change sign on the grid
    colorbar: Colorbar


def _frozen(arr: Any) -> np.ndarray:
    out = np.array(arr, dtype=float, copy=True)
    out.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class DeterminantMap:
    """det ⁰J* (1992 eq. 17) over a grid of two joint angles, the other joints fixed.

    Attributes
        model_name   name of the model the map was computed for
        joints       (i, j): indices of the two swept joints (``model.joint_names`` order)
        joint_names  their names
        angles_x     (n_x,) values of joint i, rad (x axis of the plot)
        angles_y     (n_y,) values of joint j, rad (y axis of the plot)
        values       (n_x, n_y) det ⁰J* at (angles_x[a], angles_y[b]) (``indexing="ij"``)
        q_fixed      (N,) the configuration of every joint, rad; entries i and j are
                     replaced by the grid values
        unit         unit of the determinant ("mᴺ", e.g. "m²", for a planar model, whose J*
                     keeps the in-plane velocity rows; "" otherwise)
    """

    model_name: str
    joints: tuple[int, int]
    joint_names: tuple[str, str]
    angles_x: np.ndarray
    angles_y: np.ndarray
    values: np.ndarray
    q_fixed: np.ndarray
    unit: str = ""

    def __post_init__(self) -> None:
        for name in ("angles_x", "angles_y", "values", "q_fixed"):
            object.__setattr__(self, name, _frozen(getattr(self, name)))
        if self.values.shape != (self.angles_x.size, self.angles_y.size):
            raise ShapeError(f"values: expected shape {(self.angles_x.size, self.angles_y.size)}, got {self.values.shape}")

    @property
    def has_sign_change(self) -> bool:
        """True when det J* takes both signs on the grid, so a zero contour exists."""
        return bool(np.nanmin(self.values) < 0.0 < np.nanmax(self.values))

    def plot(self, ax: Axes | None = None, degrees: bool = True) -> DeterminantMapArtists:
        """Draw the map: colour mesh of det J*, the det J* = 0 contour (black), a colour bar.

        ``ax`` defaults to a new :class:`matplotlib.figure.Figure` (no pyplot
        state). ``degrees=True`` labels the axes in degrees (the data stay in
        radians). Returns the artists; nothing else is drawn or shown.
        """
        from matplotlib.colors import Normalize
        from matplotlib.figure import Figure
        from matplotlib.lines import Line2D
        from matplotlib.ticker import MultipleLocator

        if ax is None:
            ax = Figure(figsize=(6.4, 5.2), layout="constrained").add_subplot()
        fig = ax.get_figure()
        assert fig is not None
        scale = 180.0 / np.pi if degrees else 1.0
        x, y = self.angles_x * scale, self.angles_y * scale
        c = self.values.T  # rows along y
        span = float(np.nanmax(np.abs(c))) or 1.0
        mesh = ax.pcolormesh(x, y, c, shading="nearest", cmap="RdBu_r", norm=Normalize(-span, span), rasterized=True)
        contour = None
        if self.has_sign_change:
            contour = ax.contour(x, y, c, levels=[0.0], colors="k", linewidths=1.6)
            ax.legend(
                handles=[Line2D([], [], color="k", lw=1.6, label="det ⁰J* = 0: dynamic singularity")],
                loc="upper center",
                bbox_to_anchor=(0.5, -0.12),
                frameon=False,
                fontsize="small",
            )
        unit = f" ({self.unit})" if self.unit else ""
        # A colour bar exactly as tall as the axes, also with an equal aspect ratio.
        colorbar = fig.colorbar(mesh, cax=ax.inset_axes((1.04, 0.0, 0.045, 1.0)), label=f"det ⁰J*{unit}")
        angle_unit = "deg" if degrees else "rad"
        ax.set_xlabel(f"{self.joint_names[0]} ({angle_unit})")
        ax.set_ylabel(f"{self.joint_names[1]} ({angle_unit})")
        if degrees:
            for axis, values in ((ax.xaxis, x), (ax.yaxis, y)):
                if values[-1] - values[0] >= 180.0:
                    axis.set_major_locator(MultipleLocator(90.0))
        ax.set_aspect("equal" if np.isclose(x[-1] - x[0], y[-1] - y[0]) else "auto")
        ax.set_title(f"Dynamic singularities of {self.model_name}\n(1992 eq. 17, det ⁰J*)")
        return DeterminantMapArtists(mesh=mesh, contour=contour, colorbar=colorbar)


def _grid_size(n: int | Sequence[int]) -> tuple[int, int]:
    sizes = (n, n) if isinstance(n, (int, np.integer)) else tuple(n)
    if len(sizes) != 2 or any(isinstance(s, bool) or not isinstance(s, (int, np.integer)) or s < 2 for s in sizes):
        raise ValueError(f"n: expected an integer >= 2 or two of them (points per joint), got {n!r}")
    return int(sizes[0]), int(sizes[1])


def _range(value: Any, which: str) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f"ranges[{which}]: expected (lower, upper) in rad, got {value!r}") from None
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
        raise ValueError(f"ranges[{which}]: expected finite lower < upper in rad, got ({lo}, {hi})")
    return lo, hi


def jacobian_determinant_map(
    model: Model,
    joints: Sequence[str | int] = (0, 1),
    *,
    n: int | Sequence[int] = 361,
    ranges: Sequence[Sequence[float]] | None = None,
    q_fixed: Any = None,
) -> DeterminantMap:
    """det ⁰J*(q) (1992 eq. 17) over a grid of two joint angles, in one batched call.

    Parameters
    ----------
    model
        A model whose J* is square in the sense of :func:`freeflyer.jacobian_determinant`
        (planar: 2E rows [v_x, v_y] per end effector = N joints; otherwise 6E = N).
    joints
        The two swept joints, by index or name (``model.joint_names``).
    n
        Grid points per joint (one integer for both, or two); 361 over the
        default range is a 1° step.
    ranges
        ((lo_x, hi_x), (lo_y, hi_y)) in rad, end points included; default
        [-π, π] for both.
    q_fixed
        (N,) configuration of the other joints, rad; default zeros.

    Returns
    -------
    DeterminantMap
        ``values[a, b]`` = det ⁰J* with joint ``joints[0]`` at ``angles_x[a]`` and
        ``joints[1]`` at ``angles_y[b]``. ⁰J* is in the spacecraft frame and
        does not depend on the attitude.

    Examples
    --------
    >>> import freeflyer as ff
    >>> captured = ff.models.papadopoulos1992(arms=1).with_payload(0, mass=400.0, inertia=25.0)
    >>> dmap = ff.workspace.jacobian_determinant_map(captured, n=181)
    >>> dmap.values.shape, dmap.has_sign_change
    ((181, 181), True)
    """
    if isinstance(joints, (str, int)) or len(joints) != 2:
        raise ValueError(f"joints: expected two joints (indices or names), got {joints!r}")
    i, j = (model.joint_index(k) for k in joints)
    if i == j:
        raise ValueError(f"joints: expected two different joints, got {model.joint_names[i]!r} twice")
    n_x, n_y = _grid_size(n)
    if ranges is None:
        (lo_x, hi_x), (lo_y, hi_y) = (-np.pi, np.pi), (-np.pi, np.pi)
    else:
        if len(ranges) != 2:
            raise ValueError(f"ranges: expected ((lo_x, hi_x), (lo_y, hi_y)) in rad, got {ranges!r}")
        (lo_x, hi_x), (lo_y, hi_y) = _range(ranges[0], "0"), _range(ranges[1], "1")
    base = np.zeros(model.n_joints) if q_fixed is None else np.asarray(q_fixed, dtype=float)
    if base.shape != (model.n_joints,):
        raise ShapeError(f"q_fixed: expected shape ({model.n_joints},) ({', '.join(model.joint_names)}), got {base.shape}")
    angles_x = np.linspace(lo_x, hi_x, n_x)
    angles_y = np.linspace(lo_y, hi_y, n_y)
    q = np.broadcast_to(base, (n_x, n_y, model.n_joints)).copy()
    q[..., i] = angles_x[:, None]
    q[..., j] = angles_y[None, :]
    values = jacobian_determinant(model, q)
    return DeterminantMap(
        model_name=model.name,
        joints=(i, j),
        joint_names=(model.joint_names[i], model.joint_names[j]),
        angles_x=angles_x,
        angles_y=angles_y,
        values=values,
        q_fixed=base,
        unit=f"m{str(model.n_joints).translate(_SUPERSCRIPT)}" if model.is_planar else "",
    )
