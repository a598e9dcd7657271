"""The capture posture of 1992 §V (private; see ``ff.capture``): max |det J*| subject to |r_E| = R+ (eq. 21), and
candidate postures on that sphere.

:func:`optimal_capture_posture` is the paper's choice (eq. 21 with the joint limits, the attitude of eq. 20);
:func:`posture_candidates` gives other capture configurations on |r_E| = R+ (the eq. 21 families of a planar
two-link arm, else Sobol samples put on the sphere), which the planner checks along the path and ranks
(:mod:`._capture_ranking`). Angles in rad, distances in m from the system CM.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.optimize import minimize
from scipy.spatial.transform import Rotation

from ..core.model import Model
from ..mechanics.jacobians import end_effector_jacobian, jacobian_measure
from ..mechanics.kinematics import end_effector_positions
from . import _workspace_search as search
from ._capture_families import _family_of, _is_two_link, _two_link_coefficients, capture_families
from ._capture_plots import draw_system
from ._workspace_reach import end_effector_radius, reachable_workspace, singularity_measure
from ._workspace_results import _axes, _freeze
from .singularity import SingularityCriterion

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes

__all__ = ["CapturePosture", "optimal_capture_posture", "posture_at", "posture_candidates"]


# ----------------------------------------------------------------------------------------------------------------- posture
@dataclass(frozen=True, eq=False)
class CapturePosture:
    """The capture configuration of 1992 §V: max |det J*| subject to |r_E| = R+ and the joint limits.

    ``q`` (N,) rad; ``measure``: |det J*| (square J*) or sqrt(det J* J*ᵀ),
    see :func:`freefloat.manipulability`; ``det``: the signed determinant
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
        return draw_system(_axes(ax), model, self.q, attitude=self.attitude, center=center)


def _dexterity(model: Model, q: np.ndarray, criterion: SingularityCriterion | None = None) -> np.ndarray:
    """What the capture posture maximises, (...) for q (..., N): the criterion's measure, absolute.

    Default (``criterion`` None or measure ``"auto"``): the product of the
    singular values of J* (1992 eq. 14; planar rows for a planar model):
    |det J*| when J* is square, sqrt(det J* J*ᵀ) (the manipulability) otherwise.
    """
    crit = criterion if criterion is not None else SingularityCriterion()
    measure = "manipulability" if crit.measure == "auto" else crit.measure
    return np.abs(jacobian_measure(model, np.asarray(q, dtype=float), crit.row_indices(model), measure))


def _starts(
    model: Model, e: int, R_plus: float, box: search.JointBox, samples: int, starts: int, seed: int, criterion: SingularityCriterion | None
) -> list[np.ndarray]:
    out: list[np.ndarray] = []
    if _is_two_link(model):  # the best point of each family of eq. 21 on a fine q1 grid
        q1 = np.linspace(-np.pi, np.pi, 3601)
        fam = capture_families(model, e, R_plus, q1)
        for k in range(2):
            d = np.abs(fam.det[:, k])
            if np.any(np.isfinite(d)):
                i = int(np.nanargmax(d))
                out.append(np.array([q1[i], fam.q2[i, k]]))
    q = search.sobol(samples, box.lo, box.hi, seed)
    r = end_effector_radius(model, q, e)
    near = np.argsort(np.abs(r - R_plus))[: max(64, q.shape[0] // 50)]
    meas = _dexterity(model, q[near], criterion)
    out += [q[i] for i in near[np.argsort(-meas)][:starts]]
    return out


def optimal_capture_posture(
    model: Model,
    end_effector: str | int,
    R_plus: float,
    *,
    direction: Any = None,
    family: int | None = None,
    samples: int = 1 << 14,
    starts: int = 8,
    seed: int = 0,
    criterion: SingularityCriterion | None = None,
) -> CapturePosture:
    """The capture posture that maximises |det J*| (or sqrt det J* J*ᵀ) with |r_E(q)| = R+ (1992 §V, eq. 21).

    ``criterion``: maximise its measure on its rows of J* instead
    (:class:`~freefloat.analysis.singularity.SingularityCriterion`; measure
    ``"auto"``: the product of the singular values).

    SLSQP with the equality constraint |r_E|² = R+² (analytic gradient from
    :func:`freefloat.end_effector_jacobian`) and the joint limits as bounds,
    from the best point of each eq. 21 family (planar two-link arm) and the
    best of ``samples`` Sobol configurations near |r_E| = R+. Ties between
    mirror optima go to det > 0, then the larger first joint angle (the
    paper's "choosing the positive value"). ``direction``: unit vector from
    CM+ to the path start A, inertial (default +x: eq. 20 with x_E = R+,
    y_E = 0); the attitude rotates r_E onto it. ``family`` (0: +acos,
    1: -acos; planar two-link arm only): the best posture on that family
    of eq. 21 only (the paper's Fig. 6 shows both).
    """
    e = model.end_effector_index(end_effector)
    if family is not None:
        if family not in (0, 1) or isinstance(family, bool):
            raise ValueError(f"family: expected 0 (+acos) or 1 (-acos) of eq. 21, got {family!r}")
        _two_link_coefficients(model, e)  # ModelError unless a planar two-link arm
    R_plus = float(R_plus)
    reach = reachable_workspace(model, e)
    tol = 10.0 * reach.accuracy
    if not (np.isfinite(R_plus) and reach.R_min - tol <= R_plus <= reach.R_max + tol):
        raise ValueError(
            f"R_plus = {R_plus!r} m is outside the reachable workspace [{reach.R_min:.6g}, {reach.R_max:.6g}] m of {reach.end_effector!r}"
        )
    box = search.model_box(model)
    bounds = [(None, None) if f else (lo, hi) for lo, hi, f in zip(box.lo, box.hi, box.free, strict=True)]

    def constraint(q: np.ndarray) -> np.ndarray:
        return np.array([(end_effector_radius(model, q, e) ** 2 - R_plus**2)])

    def constraint_jac(q: np.ndarray) -> np.ndarray:
        r = end_effector_positions(model, q)[e]
        return (2.0 * r @ end_effector_jacobian(model, q, e)[0:3, 6:])[None, :]

    def objective(q: np.ndarray) -> float:
        return -float(_dexterity(model, q, criterion))

    results = []
    candidates = _starts(model, e, R_plus, box, samples, starts, seed, criterion)
    for q0 in candidates:
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
            on = _family_of(model, e, R_plus, q)
            if family is None or on == family:
                results.append((float(_dexterity(model, q, criterion)), q, on))
    if not results:
        which = "" if family is None else f" on family {family}"
        raise ValueError(f"optimal_capture_posture: no start converged to |r_E| = {R_plus:.6g} m{which}; try more samples or starts")
    best_value = max(r[0] for r in results)
    square = _square(model) and (criterion is None or criterion.rows == "auto")

    def rank(item: tuple[float, np.ndarray, int | None]) -> tuple[bool, float, float]:
        value, q, _ = item
        det = float(singularity_measure(model, q)) if square else 0.0
        return (value >= best_value * (1.0 - 1e-9), det > 0.0, float(np.angle(np.exp(1j * q[0]))) if q.size else 0.0)

    value, q, on_family = max(results, key=rank)
    q = np.where(box.free, np.angle(np.exp(1j * q)), q)
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
        family=on_family,
        starts=len(candidates),
    )


def _square(model: Model) -> bool:
    rows = 2 * model.n_end_effectors if model.is_planar else 6 * model.n_end_effectors
    return rows == model.n_joints


def _snap_to_radius(model: Model, e: int, q: np.ndarray, R_plus: float, box: search.JointBox) -> np.ndarray:
    """Newton steps along the gradient of |r_E| that put each configuration (M, N) on |r_E| = R+; NaN rows where it fails."""
    q = q.copy()
    for _ in range(30):
        r = end_effector_positions(model, q)[:, e]
        norm = np.linalg.norm(r, axis=-1)
        grad = np.einsum("mi,mij->mj", r / np.maximum(norm, 1e-300)[:, None], end_effector_jacobian(model, q, e)[:, 0:3, 6:])
        q -= ((norm - R_plus) / np.maximum(np.einsum("mj,mj->m", grad, grad), 1e-300))[:, None] * grad
    ok = np.abs(end_effector_radius(model, q, e) - R_plus) < 1e-9 * max(1.0, R_plus)
    ok &= np.all(((q >= box.lo) & (q <= box.hi)) | box.free, axis=1)
    q[~ok] = np.nan
    return q


def _posture_candidates(
    model: Model, e: int, R_plus: float, criterion: SingularityCriterion, *, count: int = 4, seed: int = 0
) -> list[np.ndarray]:
    """Up to ``count`` distinct capture configurations on |r_E| = R+ (Sobol samples put on the sphere), the most dexterous first."""
    out: list[np.ndarray] = []
    box = search.model_box(model)
    q = search.sobol(1 << 12, box.lo, box.hi, seed + 1)
    near = np.argsort(np.abs(end_effector_radius(model, q, e) - R_plus))[:256]
    snapped = _snap_to_radius(model, e, q[near], R_plus, box)
    snapped = snapped[np.all(np.isfinite(snapped), axis=1)]
    if snapped.size:
        for qq in snapped[np.argsort(-_dexterity(model, snapped, criterion))]:
            if len(out) >= count:
                break
            if all(np.max(np.abs(np.angle(np.exp(1j * (qq - p))))) > 0.3 for p in out):
                out.append(qq)
    return out


#: How many q1 values (evenly spaced over a turn, 5° apart) of each eq. 21 family are capture candidates.
FAMILY_GRID = 72


def posture_candidates(
    model: Model, end_effector: int, R_plus: float, criterion: SingularityCriterion, *, count: int = 32
) -> tuple[np.ndarray, np.ndarray]:
    """Capture configurations on |r_E| = R+ within the joint limits, the candidates a plan is ranked among.

    A planar two-link arm: both families of eq. 21 (:func:`capture_families`) at :data:`FAMILY_GRID` values of q1
    over a turn, family 0 first. Any other model: up to ``count`` distinct configurations (Sobol samples put on
    |r_E| = R+, the most dexterous first). Returns q (K, N) rad and the family of each (K,): 0 (+acos), 1 (-acos),
    -1 for none.
    """
    if _is_two_link(model):
        q1 = np.linspace(-np.pi, np.pi, FAMILY_GRID, endpoint=False)
        fam = capture_families(model, end_effector, R_plus, q1)
        q = np.stack([np.broadcast_to(q1, fam.q2.T.shape), fam.q2.T], axis=-1).reshape(-1, 2)  # family-major
        family = np.repeat([0, 1], q1.size)
        box = search.model_box(model)
        ok = np.all(np.isfinite(q), axis=1) & np.all(((q >= box.lo) & (q <= box.hi)) | box.free, axis=1)
        return q[ok], family[ok]
    found = _posture_candidates(model, end_effector, R_plus, criterion, count=count)
    return np.array(found, dtype=float).reshape(-1, model.n_joints), np.full(len(found), -1)


def posture_at(
    model: Model,
    end_effector: int,
    q: np.ndarray,
    attitude: np.ndarray,
    R_plus: float,
    direction: np.ndarray,
    criterion: SingularityCriterion | None,
    family: int,
    starts: int,
) -> CapturePosture:
    """A capture posture q (N,) on |r_E| = R+ with its spacecraft attitude (quaternion [x, y, z, w], eq. 20: the end
    effector along ``direction`` (3,) from CM+), described as :func:`optimal_capture_posture` describes its optimum;
    ``family``: 0, 1 (eq. 21) or -1 (none); ``starts``: how many candidates it was chosen among."""
    square = _square(model) and (criterion is None or criterion.rows == "auto")
    theta: float | None = None
    if model.is_planar and abs(direction[2]) < 1e-12:
        r0 = end_effector_positions(model, q)[end_effector]
        theta = float(np.angle(np.exp(1j * (np.arctan2(direction[1], direction[0]) - np.arctan2(r0[1], r0[0])))))
    return CapturePosture(
        model_name=model.name,
        end_effector=model.end_effector_names[end_effector],
        q=q,
        R_plus=R_plus,
        measure=float(_dexterity(model, q, criterion)),
        det=float(singularity_measure(model, q)) if square else None,
        residual=float(end_effector_radius(model, q, end_effector)) - R_plus,
        direction=direction,
        attitude=attitude,
        theta=theta,
        family=None if family < 0 else family,
        starts=starts,
    )
