"""Capture of a large payload (Papadopoulos 1992 §V), for any model.

The §V procedure: (1) compute the post-capture workspaces of the robot with
the payload (:mod:`freeflyer.workspace`); (2) place the post-capture
path-independent workspace (PIW) so that the payload's desired path fits in
it (:func:`place_path`): this fixes the post-capture system CM, CM+, and the
distance R+ from CM+ to the path start A; (3) the free-flyer's CM must come
to the approach distance R = (M + m_p) / M R+ from the payload (eq. 19,
:func:`approach_distance`); (4) choose the capture configuration that is as
far as possible from dynamic singularities, max |det J*(q)| subject to
|r_E(q)| = R+ (eq. 21) and the joint limits
(:func:`optimal_capture_posture`), and the spacecraft attitude that puts the
end effector on A (eq. 20). :func:`plan_capture` runs all of it.

Positions of a path are in the inertial frame, 2D (planar models) or 3D, m.
Angles in rad (``theta_deg``-style values only in :mod:`freeflyer.paper1992`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.optimize import minimize, minimize_scalar
from scipy.spatial.transform import Rotation

from . import _workspace_search as search
from ._workspace_results import _axes, _circle, _freeze, _ring
from .errors import FreeflyerError, ModelError
from .jacobians import end_effector_jacobian
from .kinematics import end_effector_positions, forward_kinematics, system_cm
from .model import Model
from .planar import position_coefficients
from .workspace import (
    GuaranteedWorkspace,
    PathIndependentWorkspace,
    ReachableWorkspace,
    _jacobian_fun,
    end_effector_radius,
    path_independent_workspace,
    reachable_workspace,
    singularity_measure,
)

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes

__all__ = [
    "CaptureFamilies",
    "CapturePlan",
    "CapturePosture",
    "PathDoesNotFitError",
    "PathPlacement",
    "approach_distance",
    "capture_families",
    "optimal_capture_posture",
    "place_path",
    "plan_capture",
]


class PathDoesNotFitError(FreeflyerError, ValueError):
    """The desired path fits in no annulus of the workspace: the thrusters are needed (1992 §V).

    ``fits_reachable`` is True when the path would fit in the reachable
    workspace but not in the PIW (dynamic singularities may occur: use the
    thrusters or a special path), False when it does not fit even there.
    """

    def __init__(self, message: str, *, margin: float, fits_reachable: bool | None) -> None:
        self.margin = margin
        self.fits_reachable = fits_reachable
        super().__init__(message)


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
        A :class:`~freeflyer.workspace.PathIndependentWorkspace` (its PIW
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


# ----------------------------------------------------------------------------------------------------------------- eq. 21 families
@dataclass(frozen=True, eq=False)
class CaptureFamilies:
    """The two families q2(q1) of eq. 21 and det J* along them (1992 Fig. 6).

    ``q1`` (...) rad; ``q2`` and ``det`` (..., 2): family 0 takes +acos, family
    1 -acos; NaN where |r_E| = R+ has no solution for that q1.
    """

    R_plus: float
    q1: np.ndarray
    q2: np.ndarray
    det: np.ndarray

    def __post_init__(self) -> None:
        _freeze(self)

    def plot(self, ax: Axes | None = None, *, degrees: bool = True) -> list[Artist]:
        """q2(q1) of both families and det J* along them (second y axis), like Fig. 6."""
        ax = _axes(ax)
        s = 180.0 / np.pi if degrees else 1.0
        unit = "deg" if degrees else "rad"
        artists: list[Artist] = []
        twin = ax.twinx()
        for k, style in ((0, "-"), (1, "--")):
            artists += ax.plot(self.q1 * s, self.q2[..., k] * s, "C0" + style, label=f"q2, family {k + 1}")
            artists += twin.plot(self.q1 * s, self.det[..., k], "C3" + style, label=f"det J*, family {k + 1}")
        ax.set_xlabel(f"q1 ({unit})")
        ax.set_ylabel(f"q2 ({unit})")
        twin.set_ylabel("det J*")
        return artists


def _two_link_coefficients(model: Model, end_effector: str | int) -> np.ndarray:
    ok = model.n_joints == 2 and model.n_bodies == 3 and list(model.parent) == [-1, 0, 1]
    if not ok or not model.is_planar:
        raise ModelError(
            f"model {model.name!r}",
            "eq. 21 has two families q2(q1) only for a planar spacecraft with one two-link arm",
            "use optimal_capture_posture, which works for any model",
        )
    return position_coefficients(model, end_effector)


def capture_families(model: Model, end_effector: str | int, R_plus: float, q1: Any) -> CaptureFamilies:
    """Solve eq. 21, |r_E(q1, q2)| = R+, for q2: two families, and det J* along them; batched over q1 (...).

    r_E = a0 + a1 e^{i q1} + a2 e^{i(q1+q2)} with the eq. 20 coefficients
    (complex in general); with w = a0 + a1 e^{i q1},
    q2 = arg w - arg a2 - q1 ± acos((R+² - |w|² - |a2|²) / (2 |a2| |w|)).
    """
    a = _two_link_coefficients(model, end_effector)
    q1 = np.asarray(q1, dtype=float)
    w = a[0] + a[1] * np.exp(1j * q1)
    c = (float(R_plus) ** 2 - np.abs(w) ** 2 - np.abs(a[2]) ** 2) / (2.0 * np.abs(a[2]) * np.maximum(np.abs(w), 1e-300))
    valid = np.abs(c) <= 1.0
    base = np.angle(w) - np.angle(a[2]) - q1
    acos = np.arccos(np.clip(c, -1.0, 1.0))
    q2 = np.stack([base + acos, base - acos], axis=-1)
    q2 = np.angle(np.exp(1j * q2))
    q2 = np.where(valid[..., None], q2, np.nan)
    q = np.stack([np.broadcast_to(q1[..., None], q2.shape), np.nan_to_num(q2)], axis=-1)
    det = np.where(valid[..., None], singularity_measure(model, q), np.nan)
    return CaptureFamilies(R_plus=float(R_plus), q1=q1, q2=q2, det=det)


# ----------------------------------------------------------------------------------------------------------------- posture
@dataclass(frozen=True, eq=False)
class CapturePosture:
    """The capture configuration of 1992 §V: max |det J*| subject to |r_E| = R+ and the joint limits.

    ``q`` (N,) rad; ``measure``: |det J*| (square J*) or sqrt(det J* J*ᵀ),
    see :func:`freeflyer.manipulability`; ``det``: the signed determinant
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
        ax = _axes(ax)
        rot, pos = forward_kinematics(model, self.q)
        cm = system_cm(model, self.q)
        t0 = Rotation.from_quat(self.attitude).as_matrix()
        c = np.zeros(3)
        c[: len(center)] = np.asarray(center, dtype=float)
        to_i = lambda p: (t0 @ (np.asarray(p) - cm).T).T + c  # noqa: E731
        joints = to_i(pos)
        artists: list[Artist] = []
        for k in range(1, model.n_bodies):
            p = int(model.parent[k])
            start = to_i(pos[p] + rot[p] @ model.com[p]) if p == 0 else joints[p]
            artists += ax.plot([start[0], joints[k][0]], [start[1], joints[k][1]], "k-", lw=2)
        for e, body in enumerate(model.end_effector_body):
            tip = to_i(pos[body] + rot[body] @ model.end_effector_point[e])
            artists += ax.plot([joints[body][0], tip[0]], [joints[body][1], tip[1]], "k-", lw=2)
            artists += ax.plot(tip[0], tip[1], "ko", ms=4)
        sc = to_i(model.com[0])
        artists += ax.plot(sc[0], sc[1], "ks", ms=12, mfc="0.8")
        artists.append(_circle(ax, c, 0.01, edgecolor="k"))
        ax.set_aspect("equal")
        ax.autoscale_view()
        return artists


def _dexterity(model: Model, q: np.ndarray) -> np.ndarray:
    """Product of the singular values of J* (1992 eq. 14; planar rows for a planar model), (...) for q (..., N).

    |det J*| when J* is square, sqrt(det J* J*ᵀ) (the manipulability) otherwise.
    """
    jac = _jacobian_fun(model, None)(np.asarray(q, dtype=float))
    return np.prod(np.linalg.svd(jac, compute_uv=False), axis=-1)


def _starts(
    model: Model, e: int, R_plus: float, box: search.JointBox, samples: int, starts: int, seed: int
) -> list[tuple[np.ndarray, int | None]]:
    out: list[tuple[np.ndarray, int | None]] = []
    try:
        _two_link_coefficients(model, e)
        two_link = True
    except ModelError:
        two_link = False
    if two_link:  # the best point of each family of eq. 21 on a fine q1 grid
        q1 = np.linspace(-np.pi, np.pi, 3601)
        fam = capture_families(model, e, R_plus, q1)
        for k in range(2):
            d = np.abs(fam.det[:, k])
            if np.any(np.isfinite(d)):
                i = int(np.nanargmax(d))
                out.append((np.array([q1[i], fam.q2[i, k]]), k))
    q = search.sobol(samples, box.lo, box.hi, seed)
    r = end_effector_radius(model, q, e)
    near = np.argsort(np.abs(r - R_plus))[: max(64, q.shape[0] // 50)]
    meas = _dexterity(model, q[near])
    for i in near[np.argsort(-meas)][:starts]:
        out.append((q[i], None))
    return out


def optimal_capture_posture(
    model: Model,
    end_effector: str | int,
    R_plus: float,
    *,
    direction: Any = None,
    samples: int = 1 << 14,
    starts: int = 8,
    seed: int = 0,
) -> CapturePosture:
    """The capture posture that maximises |det J*| (or sqrt det J* J*ᵀ) with |r_E(q)| = R+ (1992 §V, eq. 21).

    SLSQP with the equality constraint |r_E|² = R+² (analytic gradient from
    :func:`freeflyer.end_effector_jacobian`) and the joint limits as bounds,
    from the best point of each eq. 21 family (planar two-link arm) and the
    best of ``samples`` Sobol configurations near |r_E| = R+. Ties between
    mirror optima go to det > 0, then the larger first joint angle (the
    paper's "choosing the positive value"). ``direction``: unit vector from
    CM+ to the path start A, inertial (default +x: eq. 20 with x_E = R+,
    y_E = 0); the attitude rotates r_E onto it.
    """
    e = model.end_effector_index(end_effector)
    R_plus = float(R_plus)
    reach = reachable_workspace(model, e)
    tol = 10.0 * reach.accuracy
    if not (np.isfinite(R_plus) and reach.R_min - tol <= R_plus <= reach.R_max + tol):
        raise ValueError(
            f"R_plus = {R_plus!r} m is outside the reachable workspace [{reach.R_min:.6g}, {reach.R_max:.6g}] m of {reach.end_effector!r}"
        )
    box = search.joint_box(model.joint_lower, model.joint_upper)
    bounds = [(None, None) if f else (lo, hi) for lo, hi, f in zip(box.lo, box.hi, box.free, strict=True)]

    def constraint(q: np.ndarray) -> np.ndarray:
        return np.array([(end_effector_radius(model, q, e) ** 2 - R_plus**2)])

    def constraint_jac(q: np.ndarray) -> np.ndarray:
        r = end_effector_positions(model, q)[e]
        return (2.0 * r @ end_effector_jacobian(model, q, e)[0:3, 6:])[None, :]

    def objective(q: np.ndarray) -> float:
        return -float(_dexterity(model, q))

    results = []
    candidates = _starts(model, e, R_plus, box, samples, starts, seed)
    for q0, family in candidates:
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
            results.append((float(_dexterity(model, q)), q, family))
    if not results:
        raise ValueError(f"optimal_capture_posture: no start converged to |r_E| = {R_plus:.6g} m; try more samples or starts")
    best_value = max(r[0] for r in results)
    square = _square(model)

    def rank(item: tuple[float, np.ndarray, int | None]) -> tuple[bool, float, float]:
        value, q, _ = item
        det = float(singularity_measure(model, q)) if square else 0.0
        return (value >= best_value * (1.0 - 1e-9), det > 0.0, float(np.angle(np.exp(1j * q[0]))) if q.size else 0.0)

    value, q, family = max(results, key=rank)
    q = np.where(box.free, np.angle(np.exp(1j * q)), q)
    if family is None and model.n_joints == 2 and model.is_planar and model.n_bodies == 3 and list(model.parent) == [-1, 0, 1]:
        fam = capture_families(model, e, R_plus, q[0])
        family = int(np.nanargmin(np.abs(np.angle(np.exp(1j * (fam.q2 - q[1]))))))
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
        family=family,
        starts=len(candidates),
    )


def _square(model: Model) -> bool:
    rows = 2 * model.n_end_effectors if model.is_planar else 6 * model.n_end_effectors
    return rows == model.n_joints


# ----------------------------------------------------------------------------------------------------------------- the whole §V
@dataclass(frozen=True, eq=False)
class CapturePlan:
    """The §V procedure end to end: workspaces after capture, path placement, approach, posture."""

    before: Model
    captured: Model
    end_effector: str
    piw: PathIndependentWorkspace
    placement: PathPlacement
    posture: CapturePosture

    @property
    def approach_distance(self) -> float:
        """Eq. 19, m."""
        assert self.placement.approach_distance is not None
        return self.placement.approach_distance

    def plot(self, ax: Axes | None = None) -> list[Artist]:
        """Fig. 7: reachable workspace before capture (dashed, around the free-flyer's CM), PIW after capture around
        CM+, the path, the approach point and the capture posture."""
        ax = _axes(ax)
        artists: list[Artist] = []
        if self.placement.approach_point is not None:  # the reachable workspace before capture, around the free-flyer's CM
            before = reachable_workspace(self.before, self.end_effector)
            for r in (before.R_min, before.R_max):
                if r > 0.0:
                    artists.append(_circle(ax, self.placement.approach_point[:2], r, edgecolor="C0", linestyle="--", linewidth=1.0))
        artists += self.piw.plot(ax, center=self.placement.cm_plus[:2])
        artists += self.placement.plot(ax, annulus=False)
        artists += self.posture.plot(self.captured, ax, center=self.placement.cm_plus)
        return artists


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
) -> CapturePlan:
    """Run 1992 §V: capture of a payload (``mass`` kg, ``inertia`` about its CM) that must then follow ``path``.

    Returns the post-capture PIW, where CM+ and the free-flyer's CM must be
    (eq. 19), and the capture posture and attitude (eqs. 20-21). Raises
    :class:`PathDoesNotFitError` when the path fits nowhere.
    """
    e = model.end_effector_index(end_effector)
    captured = model.with_payload(e, mass=mass, inertia=inertia, offset=offset)
    piw = path_independent_workspace(captured, e, samples=samples)
    placement = place_path(piw, path, rule=rule, R_plus=R_plus, robot_mass=model.total_mass, payload_mass=float(mass))
    posture = optimal_capture_posture(captured, e, placement.R_plus, direction=placement.direction)
    return CapturePlan(
        before=model, captured=captured, end_effector=model.end_effector_names[e], piw=piw, placement=placement, posture=posture
    )
