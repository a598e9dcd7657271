"""Path placement and the approach distance of 1992 §V (private; import from :mod:`freefloat.analysis.capture`, ``ff.capture``).

Step (2) of the §V procedure: put the post-capture workspace (an annulus or
spherical shell about CM+) so that the payload's desired path fits in it
(:func:`place_path`), and step (3): the approach distance of eq. 19
(:func:`approach_distance`). Positions in the inertial frame, m.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.optimize import minimize, minimize_scalar

from ..core.errors import PathDoesNotFitError
from ..core.model import MAX_LENGTH
from ._workspace_results import GuaranteedWorkspace, PathIndependentWorkspace, ReachableWorkspace, _axes, _freeze, _ring

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes

__all__ = ["PathDoesNotFitError", "PathPlacement", "approach_distance", "place_path"]


def approach_distance(robot_mass: Any, payload_mass: Any, R_plus: Any) -> Any:
    """Approach distance R = (M + m_p) / M R+ (1992 eq. 19), m; broadcasts over arrays.

    The free-flyer's CM must be at R from the payload CM just before capture,
    on the line from the payload through CM+ (the post-capture system CM),
    when the end effector grasps the payload at its CM at distance R+ from CM+.
    """
    m = np.asarray(robot_mass, dtype=float)
    m_p = np.asarray(payload_mass, dtype=float)
    r = np.asarray(R_plus, dtype=float)
    if np.any(~np.isfinite(m)) or np.any(m <= 0.0):
        raise ValueError(f"robot_mass: expected a positive mass in kg, got {robot_mass!r}")
    if np.any(~np.isfinite(m_p)) or np.any(m_p < 0.0):
        raise ValueError(f"payload_mass: expected a mass >= 0 in kg, got {payload_mass!r}")
    if np.any(~np.isfinite(r)) or np.any(r < 0.0):
        raise ValueError(f"R_plus: expected a distance >= 0 in m, got {R_plus!r}")
    out = (m + m_p) / m * r
    return float(out) if out.ndim == 0 else out


# ----------------------------------------------------------------------------------------------------------------- path placement
def _annuli(workspace: Any) -> tuple[list[tuple[float, float]], str, list[tuple[float, float]], float, float]:
    """(annuli to try, their name, the reachable annulus, total mass, payload mass) of a workspace argument."""
    if isinstance(workspace, PathIndependentWorkspace):
        reach = workspace.reachable
        order = sorted(workspace.piw, key=lambda iv: iv[0] - iv[1])  # widest first
        return list(order), "PIW", [(reach.R_min, reach.R_max)], reach.total_mass, reach.payload_mass
    if isinstance(workspace, ReachableWorkspace):
        return [(workspace.R_min, workspace.R_max)], "reachable workspace", [], workspace.total_mass, workspace.payload_mass
    if isinstance(workspace, GuaranteedWorkspace):
        shells = (
            [(workspace.R_min, workspace.R_max)] if workspace.exists and workspace.R_min is not None and workspace.R_max is not None else []
        )
        return shells, "guaranteed workspace", [], 0.0, 0.0
    arr = np.asarray(workspace, dtype=float)
    if arr.shape == (2,):
        arr = arr[None]
    if arr.ndim != 2 or arr.shape[1] != 2 or np.any(~np.isfinite(arr)) or np.any(arr[:, 0] < 0) or np.any(arr[:, 1] <= arr[:, 0]):
        raise ValueError(f"workspace: expected a workspace result or (r_in, r_out) interval(s) with 0 <= r_in < r_out, got {workspace!r}")
    return [(float(a), float(b)) for a, b in arr], "annulus", [], 0.0, 0.0


def _check_path(path: Any) -> np.ndarray:
    arr = np.asarray(path, dtype=float)
    if arr.ndim != 2 or arr.shape[0] == 0:
        raise ValueError(f"path: expected a polyline of shape (P, 2) or (P, 3) with P >= 2 points, got shape {arr.shape} (empty path?)")
    if arr.shape[1] not in (2, 3):
        raise ValueError(f"path: expected points in 2D or 3D, shape (P, 2) or (P, 3), got {arr.shape}")
    if arr.shape[0] < 2:
        raise ValueError("path: needs at least two points, the start A and the next point B")
    if not np.all(np.isfinite(arr)):
        raise ValueError("path: has NaN or infinite coordinates")
    if np.abs(arr).max() > MAX_LENGTH:
        raise ValueError(f"path: {np.abs(arr).max():g} m is beyond the {MAX_LENGTH:g} m freefloat accepts for a position (a unit slip?)")
    if np.linalg.norm(arr[1] - arr[0]) <= 0.0:
        raise ValueError("path: the first segment A-B has zero length")
    return arr


def _margins(path: np.ndarray, centers: np.ndarray, r_in: float, r_out: float) -> np.ndarray:
    """Smallest radial clearance of the polyline in the annulus [r_in, r_out] around each center, (K,) for (K, d).

    The farthest point of a polyline from a center is a vertex; the nearest is
    on a segment (clamped projection).
    """
    a, b = path[:-1], path[1:]
    ab = b - a
    ca = centers[:, None, :] - a[None]
    t = np.clip(np.einsum("ksi,si->ks", ca, ab) / np.maximum(np.einsum("si,si->s", ab, ab), 1e-300), 0.0, 1.0)
    d_min = np.min(np.linalg.norm(ca - t[..., None] * ab[None], axis=-1), axis=1)
    d_max = np.max(np.linalg.norm(path[None] - centers[:, None, :], axis=-1), axis=1)
    return np.minimum(d_min - r_in, r_out - d_max)


def _margin(path: np.ndarray, c: np.ndarray, r_in: float, r_out: float) -> float:
    return float(_margins(path, np.asarray(c, dtype=float)[None], r_in, r_out)[0])


def _perpendiculars(u: np.ndarray) -> np.ndarray:
    if u.size == 2:
        left = np.array([-u[1], u[0]])
        return np.array([left, -left])
    helper = np.array([0.0, 0.0, 1.0]) if abs(u[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(u, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    phi = np.linspace(0.0, 2.0 * np.pi, 360, endpoint=False)
    return np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2


def _best_radius(path: np.ndarray, n: np.ndarray, r_in: float, r_out: float) -> tuple[float, float]:
    """Distance R from A to CM+ = A + R n that maximises the margin, and that margin."""
    a = path[0]
    grid = np.linspace(0.0, r_out, 801)
    margins = _margins(path, a + grid[:, None] * n, r_in, r_out)
    k = int(np.argmax(margins))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    res = minimize_scalar(lambda r: -_margin(path, a + r * n, r_in, r_out), bounds=(lo, hi), method="bounded", options={"xatol": 1e-13})
    r_best = float(res.x) if -res.fun >= margins[k] else float(grid[k])
    return r_best, _margin(path, a + r_best * n, r_in, r_out)


@dataclass(frozen=True, eq=False)
class PathPlacement:
    """Where the post-capture workspace must sit so that a path fits in it (1992 §V, Figs. 5 and 7).

    Inertial frame, m. ``cm_plus``: the post-capture system CM; ``start``:
    the path start A (where the payload CM is grasped); ``direction``: the
    unit vector from CM+ to A; ``R_plus`` = |A - CM+|; ``margin``: the
    smallest radial clearance of the path inside ``interval`` = (r_in, r_out);
    ``approach_distance`` (eq. 19) and ``approach_point`` (the free-flyer's
    CM before capture) when the masses are known, else None.
    """

    path: np.ndarray
    cm_plus: np.ndarray
    start: np.ndarray
    direction: np.ndarray
    R_plus: float
    margin: float
    interval: tuple[float, float]
    workspace: str
    rule: str
    robot_mass: float | None = None
    payload_mass: float | None = None
    approach_distance: float | None = None
    approach_point: np.ndarray | None = None

    def __post_init__(self) -> None:
        _freeze(self)

    def plot(self, ax: Axes | None = None, *, annulus: bool = True) -> list[Artist]:
        """The annulus around CM+ (unless ``annulus=False``), the path A-B, CM+ and the approach point (x-y plane), like Fig. 7."""
        ax = _axes(ax)
        r_in, r_out = self.interval
        artists: list[Artist] = []
        if annulus:
            label = f"{self.workspace} after capture"
            artists.append(_ring(ax, self.cm_plus, r_in, r_out, facecolor="C1", alpha=0.25, edgecolor="C1", label=label))
        (line,) = ax.plot(self.path[:, 0], self.path[:, 1], "k-", lw=2.0, label="payload path")
        artists.append(line)
        artists += ax.plot(*self.start[:2], "ko")
        artists.append(ax.annotate("A", (float(self.start[0]), float(self.start[1])), textcoords="offset points", xytext=(4, 4)))
        artists += ax.plot(*self.cm_plus[:2], "C1+", ms=10, mew=2, label="CM+")
        if self.approach_point is not None:
            artists += ax.plot(*self.approach_point[:2], "C0x", ms=9, mew=2, label="free-flyer CM before capture")
        ax.set_aspect("equal")
        ax.autoscale_view()
        return artists


def place_path(
    workspace: Any,
    path: Any,
    *,
    rule: str = "perpendicular",
    R_plus: float | None = None,
    robot_mass: float | None = None,
    payload_mass: float | None = None,
) -> PathPlacement:
    """Place the post-capture workspace so that ``path`` fits in it; the paper's step (2) of §V.

    Parameters
    ----------
    workspace
        A :class:`~freefloat.analysis.workspace.PathIndependentWorkspace` (its PIW
        intervals are tried, widest first; the paper's choice), a reachable or
        guaranteed workspace, or (r_in, r_out) interval(s) in m.
    path
        Polyline (P, 2) or (P, 3), P >= 2, inertial frame, m; path[0] is A.
    rule
        ``"perpendicular"`` (the paper: (CM+)A ⟂ AB for the first segment;
        R+ maximises the smallest radial margin of the whole path, which for a
        straight segment of length L in [r_in, r_out] centres its radial span:
        R+ - r_in = r_out - sqrt(R+² + L²), i.e. R+ = (S² - L²) / (2 S),
        S = r_in + r_out), or ``"max_margin"`` (CM+ anywhere).
    R_plus
        Impose R+ (m) instead of choosing it (perpendicular rule).
    robot_mass, payload_mass
        For eq. 19; default from the workspace's model (a model built with
        ``with_payload``: M = total - payload).

    Raises
    ------
    PathDoesNotFitError
        The path fits in no annulus: the thrusters are needed (§V).
    """
    if rule not in ("perpendicular", "max_margin"):
        raise ValueError(f"rule: expected 'perpendicular' or 'max_margin', got {rule!r}")
    pts = _check_path(path)
    annuli, name, reach_annuli, total, payload = _annuli(workspace)
    a = pts[0]
    u = (pts[1] - a) / np.linalg.norm(pts[1] - a)
    best: tuple[float, np.ndarray, float, tuple[float, float]] | None = None
    for r_in, r_out in annuli:
        for n in _perpendiculars(u):
            if R_plus is not None:
                r, m = float(R_plus), _margin(pts, a + float(R_plus) * n, r_in, r_out)
            else:
                r, m = _best_radius(pts, n, r_in, r_out)
            c = a + r * n
            if rule == "max_margin" and R_plus is None:
                res = minimize(
                    lambda x, lo=r_in, hi=r_out: -_margin(pts, x, lo, hi),
                    c,
                    method="Nelder-Mead",
                    options={"xatol": 1e-12, "fatol": 1e-14, "maxiter": 4000},
                )
                if -res.fun > m:
                    c, m = np.asarray(res.x), float(-res.fun)
            if best is None or m > best[0] + 1e-12:
                best = (m, c, float(np.linalg.norm(a - c)), (r_in, r_out))
    length = float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
    if best is None or best[0] < -1e-12:
        fits_reach: bool | None = None
        if reach_annuli:
            lo, hi = reach_annuli[0]
            fits_reach = max(_best_radius(pts, n, lo, hi)[1] for n in _perpendiculars(u)) >= 0.0
        where = ", ".join(f"[{lo:.4g}, {hi:.4g}]" for lo, hi in annuli) or "(empty)"
        if fits_reach:
            advice = (
                "it fits in the reachable workspace, but dynamic singularities may occur: use the thrusters or a special path (1992 §V)"
            )
        else:
            advice = "the thrusters are needed (1992 §V)"
        margin = best[0] if best is not None else -np.inf
        raise PathDoesNotFitError(
            f"the path (length {length:.4g} m) fits in no {name} annulus {where} m (best margin {margin:.4g} m): {advice}",
            margin=float(margin),
            fits_reachable=fits_reach,
        )
    margin, c, r_plus, interval = best
    m_robot = robot_mass if robot_mass is not None else (total - payload if payload > 0.0 else None)
    m_pay = payload_mass if payload_mass is not None else (payload if payload > 0.0 else None)
    dist = point = None
    if m_robot is not None and m_pay is not None:
        dist = approach_distance(m_robot, m_pay, r_plus)
        point = a + (c - a) * (float(m_robot) + float(m_pay)) / float(m_robot)
    return PathPlacement(
        path=pts,
        cm_plus=c,
        start=a,
        direction=(a - c) / max(r_plus, 1e-300),
        R_plus=r_plus,
        margin=float(margin),
        interval=interval,
        workspace=name,
        rule=rule,
        robot_mass=None if m_robot is None else float(m_robot),
        payload_mass=None if m_pay is None else float(m_pay),
        approach_distance=dist,
        approach_point=point,
    )
