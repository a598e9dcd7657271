"""Result types of :mod:`freefloat.workspace` and their plots (private; import them from ``freefloat.workspace``).

Every workspace is a set of distances from the system CM; ``.plot(ax=None)``
draws it as annuli around a centre (the system CM, m) with the matplotlib
object API and returns the artists, like the 1992 paper's Figs. 4 and 7.
Without ``ax`` the figure is a new pyplot figure, so ``plt.show()`` shows it.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from ..core._figures import new_axes
from ..core.model import Model
from ..mechanics.kinematics import point_positions

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes

__all__ = ["GuaranteedRadii", "GuaranteedWorkspace", "PathIndependentWorkspace", "PayloadEffect", "RadiusRange", "ReachableWorkspace"]


class RadiusRange(NamedTuple):
    """A range of distances from the system CM, m."""

    min: float
    max: float


class GuaranteedRadii(NamedTuple):
    """Eq. 16 from the ranges of the two terms; see :func:`guaranteed_radii`."""

    R_min: float | None
    R_max: float | None
    inner_radius: float | None
    exists: bool
    reason: str


# ----------------------------------------------------------------------------------------------------------------- results
def _freeze(obj: Any) -> None:
    for f in fields(obj):
        value = getattr(obj, f.name)
        if isinstance(value, np.ndarray):
            value = np.array(value, copy=True)
            value.setflags(write=False)
            object.__setattr__(obj, f.name, value)


def _axes(ax: Axes | None) -> Axes:
    """``ax``, or the axes of a new pyplot-managed figure (``plt.show()`` and notebooks display it)."""
    return ax if ax is not None else new_axes(figsize=(6.0, 6.0))


def _ring(ax: Axes, center: Any, r_in: float, r_out: float, **style: Any) -> Artist:
    from matplotlib.patches import Wedge

    c = (float(center[0]), float(center[1]))
    width = None if r_in <= 0.0 else r_out - r_in
    patch = Wedge(c, r_out, 0.0, 360.0, width=width, **style)
    ax.add_patch(patch)
    return patch


def _circle(ax: Axes, center: Any, r: float, **style: Any) -> Artist:
    from matplotlib.patches import Circle

    patch = Circle((float(center[0]), float(center[1])), r, fill=False, **style)
    ax.add_patch(patch)
    return patch


PLANES = ("xy", "xz", "yz")
_PDW_LABEL = "path-dependent workspace (PDW)"


def _finish(ax: Axes, center: Any, reach: float, plane: str = "xy") -> None:
    """Equal axes that show everything drawn so far (patches update the data limits) and the circle of ``reach``.

    ``plane``: the section through the system CM the axes show (a shell about the CM is the
    same annulus in every such plane): the axes are labelled with its two coordinates.
    """
    if plane not in PLANES:
        raise ValueError(f"plane: expected one of {', '.join(PLANES)}, got {plane!r}")
    c = np.asarray(center, dtype=float)
    ax.update_datalim([(c[0] - reach, c[1] - reach), (c[0] + reach, c[1] + reach)])
    ax.set_aspect("equal")
    ax.margins(0.05)
    ax.autoscale_view()
    ax.set_xlabel(f"{plane[0]} (m)")
    ax.set_ylabel(f"{plane[1]} (m)")


@dataclass(frozen=True, eq=False)
class ReachableWorkspace:
    """The reachable workspace of one end effector: the shell R_min <= |r_E| <= R_max about the system CM (eq. 15).

    ``method`` is ``"closed_form"`` (planar, free joints: the polygon rule) or
    ``"sampling"`` (Sobol samples + L-BFGS-B / least squares from the best
    ``starts`` samples). ``accuracy`` (m) bounds the error of each limit as
    attained by the optimiser; with sampling, global optimality rests on
    ``samples`` and ``starts``. ``q_min``/``q_max`` attain the limits
    (None for the closed form). ``total_mass``/``payload_mass`` (kg) come
    from the model (payload mass: the payloads it was built with).
    """

    model_name: str
    end_effector: str
    R_min: float
    R_max: float
    method: str
    accuracy: float
    samples: int = 0
    starts: int = 0
    q_min: np.ndarray | None = None
    q_max: np.ndarray | None = None
    total_mass: float = 0.0
    payload_mass: float = 0.0

    def __post_init__(self) -> None:
        _freeze(self)

    def plot(
        self, ax: Axes | None = None, *, center: Any = (0.0, 0.0), color: str = "C0", label: str | None = None, plane: str = "xy"
    ) -> list[Artist]:
        """Draw the annulus R_min..R_max around ``center`` (the system CM, m) as in the paper's Figs. 4 and 7.

        In 3D the shell's section by ``plane`` ("xy", "xz" or "yz") through the CM."""
        ax = _axes(ax)
        text = label if label is not None else f"reachable {self.end_effector} [{self.R_min:.3f}, {self.R_max:.3f}] m"
        artists = [_ring(ax, center, self.R_min, self.R_max, facecolor=color, alpha=0.15, edgecolor=color, label=text)]
        _finish(ax, center, self.R_max, plane)
        return artists


@dataclass(frozen=True, eq=False)
class GuaranteedWorkspace:
    """The guaranteed workspace (GW) of one end effector (1992 eq. 16).

    r_E = (first term) + (own term): the own term sums the barycentric
    vectors of the bodies on the path from the spacecraft to the end
    effector (moved by ``own_joints`` only); the first term sums those of all
    other bodies, the spacecraft's r*_0 and every other arm's l* vectors
    (moved by ``other_joints`` and, for branches hanging from an own link,
    by own joints too). ``first_range``/``own_range`` are the (min, max) of
    their lengths. When ``exists`` the GW is the shell R_min..R_max (eq. 16);
    otherwise R_min = R_max = None and ``reason`` says why. ``inner_radius``:
    see :func:`guaranteed_radii`.
    """

    model_name: str
    end_effector: str
    exists: bool
    R_min: float | None
    R_max: float | None
    reason: str
    first_range: RadiusRange
    own_range: RadiusRange
    inner_radius: float | None
    own_joints: tuple[str, ...]
    other_joints: tuple[str, ...]
    method: str
    accuracy: float
    coupled: bool = False

    def plot(
        self, ax: Axes | None = None, *, center: Any = (0.0, 0.0), color: str = "C2", label: str | None = None, plane: str = "xy"
    ) -> list[Artist]:
        """Draw the GW shell (dashed outline) around ``center``; nothing but an empty list when it does not exist."""
        ax = _axes(ax)
        if not self.exists or self.R_min is None or self.R_max is None:
            return []
        text = label if label is not None else f"guaranteed {self.end_effector} [{self.R_min:.3f}, {self.R_max:.3f}] m"
        artists = [
            _ring(ax, center, self.R_min, self.R_max, facecolor=color, alpha=0.15, edgecolor=color, linestyle="--", label=text),
        ]
        _finish(ax, center, self.R_max, plane)
        return artists


@dataclass(frozen=True, eq=False)
class PathIndependentWorkspace:
    """Path-independent and path-dependent workspaces of one end effector (1992 §III, eq. 17).

    ``pdw``: intervals of |r_E| reached at a singular configuration; ``piw``:
    the reachable radii minus the PDW. ``R_min``/``R_max``: the widest PIW
    interval (the paper's PIW; None if there is none). ``singular_q`` (K, N)
    and ``singular_radii`` (K,): the singular configurations found.
    ``resolution`` (m): every radius inside a PDW interval lies within
    resolution / 2 of a found singular radius (gaps narrower than
    ``merge_gap`` are not resolved). ``accuracy`` (m): of the PIW
    boundaries, polished on the singular set (the sampling resolution where
    polishing failed). ``criterion``: what counted as singular (the rows of
    J*, the measure and its threshold).
    """

    model_name: str
    end_effector: str
    reachable: ReachableWorkspace
    pdw: tuple[tuple[float, float], ...]
    piw: tuple[tuple[float, float], ...]
    singular_q: np.ndarray
    singular_radii: np.ndarray
    method: str
    jacobian: str
    samples: int
    resolution: float
    accuracy: float
    merge_gap: float
    criterion: str = "det J* = 0 (1992 eq. 17)"

    def __post_init__(self) -> None:
        _freeze(self)

    @property
    def R_min(self) -> float | None:
        """Inner radius of the widest PIW annulus (m), or None where there is no PIW."""
        widest = self._widest()
        return None if widest is None else widest[0]

    @property
    def R_max(self) -> float | None:
        """Outer radius of the widest PIW annulus (m), or None where there is no PIW."""
        widest = self._widest()
        return None if widest is None else widest[1]

    def _widest(self) -> tuple[float, float] | None:
        return max(self.piw, key=lambda iv: iv[1] - iv[0]) if self.piw else None

    def plot(
        self, ax: Axes | None = None, *, center: Any = (0.0, 0.0), color: str = "C1", label: str | None = None, plane: str = "xy"
    ) -> list[Artist]:
        """Draw the PIW annuli (filled), the PDW (hatched) and the reachable outline around ``center``."""
        ax = _axes(ax)
        artists: list[Artist] = []
        for k, (lo, hi) in enumerate(self.piw):
            text = (label if label is not None else f"PIW {self.end_effector}") if k == 0 else None
            artists.append(_ring(ax, center, lo, hi, facecolor=color, alpha=0.3, edgecolor=color, label=text))
        for k, (lo, hi) in enumerate(self.pdw):
            artists.append(
                _ring(
                    ax,
                    center,
                    lo,
                    hi,
                    fill=False,
                    hatch="///",
                    edgecolor="0.5",
                    linewidth=0.0,
                    label="path-dependent workspace (PDW)" if k == 0 else None,
                )
            )
        artists.append(_circle(ax, center, self.reachable.R_max, edgecolor="k", linewidth=0.8))
        if self.reachable.R_min > 0.0:
            artists.append(_circle(ax, center, self.reachable.R_min, edgecolor="k", linewidth=0.8))
        _finish(ax, center, self.reachable.R_max, plane)
        return artists


@dataclass(frozen=True, eq=False)
class PayloadEffect:
    """Workspaces of every end effector before and after one of them grasps a payload (1992 §IV).

    ``reachable_before/after`` and ``guaranteed_before/after``: one entry per
    end effector (``model.end_effector_names`` order). ``cm_shift_range``
    (m): min and max over q of the distance the system CM moves at capture,
    m_p |r_p| / (M + m_p), r_p the payload CM relative to the old system CM.
    """

    model_name: str
    end_effector: str
    payload_mass: float
    mass_before: float
    mass_after: float
    reachable_before: tuple[ReachableWorkspace, ...]
    reachable_after: tuple[ReachableWorkspace, ...]
    guaranteed_before: tuple[GuaranteedWorkspace, ...]
    guaranteed_after: tuple[GuaranteedWorkspace, ...]
    cm_shift_range: RadiusRange
    captured: Model
    before: Model
    offset: np.ndarray

    def __post_init__(self) -> None:
        _freeze(self)

    def cm_shift(self, q: Any) -> np.ndarray:
        """Shift of the system CM at capture, (..., 3), spacecraft frame, for q (..., N): m_p r_p / (M + m_p)."""
        e = self.before.end_effector_index(self.end_effector)
        body = int(self.before.end_effector_body[e])
        r_p = point_positions(self.before, q, body, self.before.end_effector_point[e] + self.offset)
        return self.payload_mass * r_p / self.mass_after

    def plot(self, ax: Axes | None = None) -> list[Artist]:
        """Reachable and guaranteed workspaces of the grasping end effector before (blue) and after (orange), same CM."""
        ax = _axes(ax)
        e = self.before.end_effector_index(self.end_effector)
        artists = self.reachable_before[e].plot(ax, color="C0", label="reachable, before")
        artists += self.guaranteed_before[e].plot(ax, color="C0", label="guaranteed, before")
        artists += self.reachable_after[e].plot(ax, color="C1", label="reachable, after")
        artists += self.guaranteed_after[e].plot(ax, color="C1", label="guaranteed, after")
        _finish(ax, (0.0, 0.0), max(r.R_max for r in self.reachable_before))
        return artists
