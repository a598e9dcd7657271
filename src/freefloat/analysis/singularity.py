"""Dynamic singularities: the measure that detects them, and maps of det J*(q) over two joint angles.

Papadopoulos 1992 eq. 17: a free-floating system with zero momentum cannot
move its end effectors in some direction wherever det ⁰J*(q) = 0. These
*dynamic singularities* depend on the mass distribution as well as the
kinematics, so they move when a payload is captured. ⁰J* (1992 eq. 14) is in
the spacecraft frame and depends on the joint angles only, not on the
spacecraft attitude, so a map over joint space is the whole story.

:func:`jacobian_determinant_map` computes the map (one batched call of
:func:`freefloat.jacobian_determinant`); :meth:`DeterminantMap.plot` draws it.
Angles are in radians inside; ``plot(degrees=True)`` shows degrees.

:class:`SingularityCriterion` states which rows of J* and which measure
decide "singular" for the workspaces (PIW/PDW) and the capture planning of
a model: the full J* (eq. 14) or only its translational rows, det J*, the
smallest singular value or the manipulability, and a threshold below which a
configuration counts as singular. A 6-DOF arm with a light wrist is singular
in its full 6 x 6 J* somewhere at every radius (wrist singularities); for
carrying a payload CM along a path only the translational rows matter.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from ..core._figures import new_axes
from ..core.errors import ShapeError
from ..core.model import Model
from ..core.numbers import MAX_JOINT_VALUE
from ..core.resources import require_memory
from ..mechanics.jacobians import generalized_jacobian, jacobian_determinant, jacobian_measure
from . import _workspace_search as search

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.collections import QuadMesh
    from matplotlib.colorbar import Colorbar
    from matplotlib.contour import QuadContourSet

__all__ = ["DeterminantMap", "DeterminantMapArtists", "SingularityCriterion", "jacobian_determinant_map"]

ROWS = ("auto", "full", "position")
_SYMBOLS = {"det": "det ⁰J*", "sigma_min": "σ_min(⁰J*)", "manipulability": "sqrt det(⁰J* ⁰J*ᵀ)"}
_SUPERSCRIPT = str.maketrans("0123456789", "⁰¹²³⁴⁵⁶⁷⁸⁹")
_PLAIN_DIGITS = str.maketrans("⁰¹²³⁴⁵⁶⁷⁸⁹", "0123456789")  # "m¹²" -> "m^12" in error messages
MEASURES = ("auto", *search.MEASURES)


@dataclass(frozen=True)
class SingularityCriterion:
    """Which configurations count as dynamically singular (1992 eq. 17, generalised).

    Parameters
    ----------
    rows
        Rows of ⁰J* (1992 eq. 14, spacecraft frame) per end effector:
        ``"position"``: the translational rows v (3 per end effector; [v_x, v_y]
        for a planar model), enough to move a grasped payload's CM along a
        path; ``"full"``: [v; ω] (6 per end effector; [v_x, v_y, ω_z] planar);
        ``"auto"`` (default): the paper's choice, [v_x, v_y] planar, all 6 in 3D.
    measure
        ``"sigma_min"``: the smallest singular value σ_min of those rows (m/rad
        for position rows): the slowest end-effector speed per unit joint rate;
        ``"manipulability"``: sqrt(det(J Jᵀ)) (Yoshikawa), the product of the
        singular values; ``"det"``: det J (signed; square J only);
        ``"auto"`` (default): det where J is square, else σ_min.
    threshold
        A configuration is singular where |measure| <= threshold (default 0:
        exactly singular, rank-deficient J). In the measure's unit. A finite
        number >= 0; once a model is given (the workspaces, the capture
        planning), a threshold at or above :meth:`measure_bound`, which the
        measure reaches nowhere, is refused: every configuration would be singular.

    Notes
    -----
    With ``threshold = 0`` every measure has the same singular set (rank J <
    rows), so the search may use the fastest one.
    """

    rows: str = "auto"
    measure: str = "auto"
    threshold: float = 0.0

    def __post_init__(self) -> None:
        if self.rows not in ROWS:
            raise ValueError(f"rows: expected one of {', '.join(ROWS)}, got {self.rows!r}")
        if self.measure not in MEASURES:
            raise ValueError(f"measure: expected one of {', '.join(MEASURES)}, got {self.measure!r}")
        t = self.threshold
        if isinstance(t, bool) or not isinstance(t, (int, float, np.floating, np.integer)) or not np.isfinite(t) or t < 0.0:
            raise ValueError(f"threshold: expected a finite number >= 0 (in the measure's unit), got {t!r}")
        object.__setattr__(self, "threshold", float(t))

    def row_indices(self, model: Model, end_effector: int | None = None) -> np.ndarray:
        """Indices of the rows of ⁰J* (6 per end effector, [v; ω]) used: one end effector, or all (None)."""
        ees = range(model.n_end_effectors) if end_effector is None else [int(end_effector)]
        if model.is_planar:
            keep: tuple[int, ...] = (0, 1, 5) if self.rows == "full" else (0, 1)
        else:
            keep = (0, 1, 2) if self.rows == "position" else tuple(range(6))
        return np.array([6 * e + r for e in ees for r in keep], dtype=int)

    def square(self, model: Model, end_effector: int | None = None) -> bool:
        """True when the chosen rows of J* form a square matrix (det J* exists)."""
        return self.row_indices(model, end_effector).size == model.n_joints

    def resolved_measure(self, model: Model, end_effector: int | None = None) -> str:
        """The measure used for ``model``: ``"auto"`` resolved; ``"det"`` checked for a square J*."""
        square = self.square(model, end_effector)
        if self.measure == "auto":
            return "det" if square else "sigma_min"
        if self.measure == "det" and not square:
            n_rows = self.row_indices(model, end_effector).size
            raise ValueError(
                f"measure='det': the chosen rows of J* form a {n_rows} x {model.n_joints} matrix, not square; "
                "use measure='sigma_min' or 'manipulability'"
            )
        return self.measure

    def jacobian(self, model: Model, q: Any, end_effector: int | None = None) -> np.ndarray:
        """The chosen rows of ⁰J*(q), (..., rows, N), spacecraft frame."""
        return generalized_jacobian(model, q)[..., self.row_indices(model, end_effector), :]

    def evaluate(self, model: Model, q: Any, end_effector: int | None = None) -> np.ndarray:
        """The measure at q (..., N), (...). Zero at exact singularities (signed for det)."""
        arr = np.asarray(q, dtype=float)
        measure = self.resolved_measure(model, end_effector)
        if measure == "det" and self.rows == "auto" and end_effector is None:  # the dedicated determinant
            return np.asarray(jacobian_determinant(model, arr))
        return np.asarray(jacobian_measure(model, arr, self.row_indices(model, end_effector), measure))

    def is_singular(self, model: Model, q: Any, end_effector: int | None = None) -> np.ndarray:
        """|measure(q)| <= threshold, (...) booleans."""
        return np.abs(self.evaluate(model, q, end_effector)) <= self.threshold

    def measure_bound(self, model: Model, end_effector: int | None = None) -> float:
        """An upper bound of |measure| over every configuration of ``model`` (inf where none can be given), from its
        masses, inertias and lengths alone; loose (often by orders of magnitude), but a threshold at or above it makes
        every configuration singular.

        With zero momentum the kinetic energy is T = 1/2 q̇ᵀ H* q̇, and H* is at most the joint block H_qq of the
        fixed-spacecraft inertia matrix (the momentum constraint minimises T over the spacecraft's motion). For
        q̇ = e_i, the end effector's body k (mass m_k, central inertia I_k, end-effector point at distance d from
        its CM) has m_k |v_k|² <= 2T and λ_min(I_k) |ω_k|² <= 2T, so column i of ⁰J* is at most
        sqrt(H_qq[i, i]) (1/sqrt(m_k) + d/sqrt(λ_min(I_k))) in its velocity rows and sqrt(H_qq[i, i] / λ_min(I_k))
        in its rotation rows; H_qq[i, i] <= Σ over the bodies j outboard of joint i of m_j D_ij² + λ_max(I_j)
        (revolute; m_j prismatic), with D_ij the length of the tree path from the joint to body j's CM (prismatic
        joints on it at their farthest limit, at most 1e6 m). That bounds the Frobenius norm F of the chosen rows
        (m of them, r = min(m, N) singular values): σ_min <= F / sqrt(r), |det| and the manipulability
        (the product of the r singular values) <= (F² / r)^(r/2).
        """
        rows = self.row_indices(model, end_effector)
        if rows.size == 0 or model.n_joints == 0:
            return float("inf")
        own = model.expanded()  # the joint of every body (mimic joints too: H_qq = M^T H_body M, see below)
        slide = np.zeros(model.n_bodies)
        reach = np.maximum(np.abs(own.joint_lower), np.abs(own.joint_upper))
        slide[1:] = np.where(own.prismatic, np.minimum(reach, MAX_JOINT_VALUE), 0.0)
        link = np.linalg.norm(model.joint_origin, axis=1) + slide
        depth = np.zeros(model.n_bodies)  # length of the tree path from the spacecraft's frame to each body's frame
        for k in range(1, model.n_bodies):
            depth[k] = depth[model.parent[k]] + link[k]
        eig = np.linalg.eigvalsh(model.inertia)
        com = np.linalg.norm(model.com, axis=1)
        trace = 0.0  # bound of trace H_qq
        for k in range(1, model.n_bodies):
            out = np.nonzero(model.subtree[k])[0]
            if own.prismatic[k - 1]:
                trace += float(np.sum(model.mass[out]))
            else:
                trace += float(np.sum(model.mass[out] * (depth[out] - depth[k] + com[out]) ** 2 + eig[out, -1]))
        # with mimic joints trace(M^T H_body M) <= the largest eigenvalue of M^T M (diagonal: per column of q, the sum of
        # its joints' squared multipliers) times trace(H_body)
        trace *= float(np.max(np.sum(model.mimic_matrix**2, axis=0), initial=1.0))
        frobenius2 = 0.0
        for e in np.unique(rows // 6):
            k = int(model.end_effector_body[e])
            kind = rows[rows // 6 == e] % 6
            mass, smallest = float(model.mass[k]), float(eig[k, 0])
            if mass <= 0.0 or smallest <= 0.0:
                return float("inf")
            d = float(np.linalg.norm(model.end_effector_point[e] - model.com[k]))
            if np.any(kind < 3):
                frobenius2 += trace * (1.0 / np.sqrt(mass) + d / np.sqrt(smallest)) ** 2
            if np.any(kind >= 3):
                frobenius2 += trace / smallest
        r = min(rows.size, model.n_joints)
        if self.resolved_measure(model, end_effector) == "sigma_min":
            return float(np.sqrt(frobenius2 / r))
        log_bound = 0.5 * r * np.log(frobenius2 / r)
        return float(np.exp(log_bound)) if log_bound < 700.0 else float("inf")

    def check_threshold(self, model: Model, end_effector: int | None = None) -> None:
        """Refuse a threshold at or above :meth:`measure_bound` (every configuration of ``model`` would count as
        singular) with a ValueError that names the bound and its unit."""
        if self.threshold == 0.0:
            return
        bound = self.measure_bound(model, end_effector)
        if self.threshold < bound:
            return
        unit = re.sub("[⁰¹²³⁴⁵⁶⁷⁸⁹]+", lambda m: "^" + m.group().translate(_PLAIN_DIGITS), self.unit(model, end_effector))
        measure = self.resolved_measure(model, end_effector)
        raise ValueError(
            f"threshold: {self.threshold:g} is at or above {bound:.3g} ({unit}), a bound that |{measure}| of J* never reaches "
            f"on {model.name!r} (from its masses, inertias and lengths): every configuration would count as singular; "
            f"give a threshold below it, in the measure's unit ({unit}), such as 0 (exact singularities)"
        )

    def search_criterion(self, model: Model, end_effector: int | None = None) -> search.Criterion:
        """The criterion of the singular-set search (private helper of the workspace and capture modules); a threshold
        that makes every configuration singular is refused (:meth:`check_threshold`)."""
        self.check_threshold(model, end_effector)
        rows = self.row_indices(model, end_effector)
        measure = self.resolved_measure(model, end_effector)
        if self.threshold == 0.0 and rows.size == model.n_joints:
            measure = "det"  # the same singular set; sign changes are found fastest

        def jac_fun(qq: np.ndarray) -> np.ndarray:
            return generalized_jacobian(model, qq)[..., rows, :]

        def measure_fun(qq: np.ndarray) -> np.ndarray:
            return np.asarray(jacobian_measure(model, qq, rows, measure))

        def residual_fun(qq: np.ndarray) -> np.ndarray:  # |det J| / σ_max^m (square J), else σ_min / σ_max
            largest = jacobian_measure(model, qq, rows, "sigma_max")
            if rows.size == model.n_joints:
                return np.abs(jacobian_measure(model, qq, rows, "det")) / np.maximum(largest**rows.size, 1e-300)
            return np.asarray(jacobian_measure(model, qq, rows, "sigma_min")) / np.maximum(largest, 1e-300)

        return search.Criterion(jac_fun, measure, self.threshold, measure_fun, residual_fun)

    def describe(self, model: Model, end_effector: int | None = None) -> str:
        """One line for reports: the rows, the measure and the threshold."""
        n_rows = self.row_indices(model, end_effector).size
        if self.rows == "position" or (self.rows == "auto" and model.is_planar):
            which = "in-plane velocity" if model.is_planar else "translational"
        else:
            which = "in-plane velocity and rotation" if model.is_planar else "all"
        measure = {
            "det": "det J*",
            "sigma_min": "smallest singular value of J*",
            "manipulability": "manipulability sqrt(det J* J*ᵀ)",
        }[self.resolved_measure(model, end_effector)]
        return f"{measure} ({which} rows of J*, {n_rows} x {model.n_joints}); singular where |measure| <= {self.threshold:g}"

    def symbol(self, model: Model, end_effector: int | None = None) -> str:
        """The measure's symbol for labels: "det ⁰J*", "σ_min(⁰J*)" or "sqrt det(⁰J* ⁰J*ᵀ)"."""
        return _SYMBOLS[self.resolved_measure(model, end_effector)]

    def unit(self, model: Model, end_effector: int | None = None) -> str:
        """The measure's unit. A row of v is in m (m/s per rad/s), a row of ω is a pure number: det and
        manipulability are in mᵏ (k velocity rows, e.g. "m²"), σ_min in m for velocity rows only (else mixed)."""
        rows = self.row_indices(model, end_effector) % 6
        k = int(np.count_nonzero(rows < 3))
        if self.resolved_measure(model, end_effector) != "sigma_min":
            return "1" if k == 0 else "m" if k == 1 else f"m{str(k).translate(_SUPERSCRIPT)}"
        return "m" if k == rows.size else "mixed units: m, 1"

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready: rows, measure, threshold."""
        return {"rows": self.rows, "measure": self.measure, "threshold": self.threshold}


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
        measure      what ``values`` holds: "det ⁰J*" (default, signed), or the measure of a
                     :class:`SingularityCriterion` (σ_min or manipulability, >= 0)
        threshold    the criterion's threshold: singular where |values| <= threshold
        criterion    one line describing the criterion ("" for the paper's det J*)
    """

    model_name: str
    joints: tuple[int, int]
    joint_names: tuple[str, str]
    angles_x: np.ndarray
    angles_y: np.ndarray
    values: np.ndarray
    q_fixed: np.ndarray
    unit: str = ""
    measure: str = "det ⁰J*"
    threshold: float = 0.0
    criterion: str = ""

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

        ``ax`` defaults to the axes of a new pyplot figure (``plt.show()`` and
        notebooks display it). ``degrees=True`` labels the axes in degrees (the data stay in
        radians). Returns the artists; nothing else is drawn or shown.
        """
        from matplotlib.colors import Normalize
        from matplotlib.lines import Line2D
        from matplotlib.ticker import MultipleLocator

        if ax is None:
            ax = new_axes(figsize=(6.4, 5.2))
        fig = ax.get_figure()
        assert fig is not None
        scale = 180.0 / np.pi if degrees else 1.0
        x, y = self.angles_x * scale, self.angles_y * scale
        c = self.values.T  # rows along y
        span = float(np.nanmax(np.abs(c))) or 1.0
        contour = None
        if self.measure.startswith("det") and self.threshold == 0.0:  # signed: a diverging map, the zero contour
            mesh = ax.pcolormesh(x, y, c, shading="nearest", cmap="RdBu_r", norm=Normalize(-span, span), rasterized=True)
            level, text = 0.0, f"{self.measure} = 0: dynamic singularity"
            draw = self.has_sign_change
        else:  # a measure >= 0: a sequential map, the threshold contour
            mesh = ax.pcolormesh(x, y, np.abs(c), shading="nearest", cmap="viridis", norm=Normalize(0.0, span), rasterized=True)
            level, text = self.threshold, f"|{self.measure}| = {self.threshold:g}: singular below"
            draw = self.threshold > 0.0 and float(np.nanmin(np.abs(c))) < self.threshold < float(np.nanmax(np.abs(c)))
            c = np.abs(c)
        if draw:
            contour = ax.contour(x, y, c, levels=[level], colors="k" if level == 0.0 else "tab:red", linewidths=1.6)
            ax.legend(
                handles=[Line2D([], [], color="k" if level == 0.0 else "tab:red", lw=1.6, label=text)],
                loc="upper center",
                bbox_to_anchor=(0.5, -0.12),
                frameon=False,
                fontsize="small",
            )
        unit = f" ({self.unit})" if self.unit else ""
        # A colour bar exactly as tall as the axes, also with an equal aspect ratio.
        colorbar = fig.colorbar(mesh, cax=ax.inset_axes((1.04, 0.0, 0.045, 1.0)), label=f"{self.measure}{unit}")
        angle_unit = "deg" if degrees else "rad"
        ax.set_xlabel(f"{self.joint_names[0]} ({angle_unit})")
        ax.set_ylabel(f"{self.joint_names[1]} ({angle_unit})")
        if degrees:
            for axis, values in ((ax.xaxis, x), (ax.yaxis, y)):
                if values[-1] - values[0] >= 180.0:
                    axis.set_major_locator(MultipleLocator(90.0))
        ax.set_aspect("equal" if np.isclose(x[-1] - x[0], y[-1] - y[0]) else "auto")
        import textwrap

        what = "1992 eq. 17, det ⁰J*" if not self.criterion else textwrap.fill(self.criterion, 64)
        ax.set_title(f"Dynamic singularities of {self.model_name}\n({what})", fontsize="medium" if self.criterion else None)
        return DeterminantMapArtists(mesh=mesh, contour=contour, colorbar=colorbar)


def _grid_size(n: int | Sequence[int]) -> tuple[int, int]:
    try:
        sizes = (n, n) if isinstance(n, (int, np.integer)) else tuple(n)
    except TypeError:
        raise ValueError(f"n: expected an integer >= 2 or two of them (points per joint), got {n!r}") from None
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
    criterion: SingularityCriterion | None = None,
) -> DeterminantMap:
    """det ⁰J*(q) (1992 eq. 17) over a grid of two joint angles, in one batched call.

    Parameters
    ----------
    model
        A model whose J* is square in the sense of :func:`freefloat.jacobian_determinant`
        (planar: 2E rows [v_x, v_y] per end effector = N joints; otherwise 6E = N), or any
        model with a ``criterion``.
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
    criterion
        Map this :class:`SingularityCriterion`'s measure instead of det J* (any
        model, e.g. σ_min of the translational rows of a 6- or 7-DOF arm's J*);
        its threshold is drawn as a contour.

    Returns
    -------
    DeterminantMap
        ``values[a, b]`` = det ⁰J* with joint ``joints[0]`` at ``angles_x[a]`` and
        ``joints[1]`` at ``angles_y[b]``. ⁰J* is in the spacecraft frame and
        does not depend on the attitude.

    Examples
    --------
    >>> import freefloat as ff
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
    # the grid of configurations and the measure at each point (the engine computes the measure without a batch of J*)
    per_point = 8 * (model.n_joints + 2)
    require_memory(
        float(n_x) * n_y * per_point,
        f"a map of {n_x} x {n_y} = {float(n_x) * n_y:.3g} configurations",
        "use a coarser grid (n = 361 is a 1 deg step over a full turn) or smaller ranges",
    )
    angles_x = np.linspace(lo_x, hi_x, n_x)
    angles_y = np.linspace(lo_y, hi_y, n_y)
    q = np.broadcast_to(base, (n_x, n_y, model.n_joints)).copy()
    q[..., i] = angles_x[:, None]
    q[..., j] = angles_y[None, :]
    grid: dict[str, Any] = {
        "model_name": model.name,
        "joints": (i, j),
        "joint_names": (model.joint_names[i], model.joint_names[j]),
        "angles_x": angles_x,
        "angles_y": angles_y,
        "q_fixed": base,
    }
    if criterion is not None:
        return DeterminantMap(
            **grid,
            values=criterion.evaluate(model, q),
            measure=criterion.symbol(model),
            threshold=criterion.threshold,
            criterion=criterion.describe(model),
        )
    unit = f"m{str(model.n_joints).translate(_SUPERSCRIPT)}" if model.is_planar else ""
    return DeterminantMap(**grid, values=jacobian_determinant(model, q), unit=unit)
