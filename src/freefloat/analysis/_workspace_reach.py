"""Reachable and guaranteed workspaces (1992 eqs. 15-16), their closed forms, and the radius |r_E| (private).

Import from :mod:`freefloat.analysis.workspace` (``ff.workspace``), whose
docstring describes the workspaces. Distances in m from the system CM; angles in rad.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from ..core.barycentric import barycentric_vectors
from ..core.model import Model
from ..mechanics.kinematics import body_rotations, end_effector_positions
from . import _workspace_search as search
from ._workspace_results import GuaranteedRadii, GuaranteedWorkspace, RadiusRange, ReachableWorkspace
from .singularity import SingularityCriterion

__all__ = [
    "collinear_radii",
    "collinear_radius_range",
    "end_effector_radius",
    "free_sum_radii",
    "guaranteed_radii",
    "guaranteed_workspace",
    "reachable_workspace",
    "singularity_measure",
]

#: Stated accuracy (m, relative to max(1 m, R)) of a limit polished by the optimiser: the optimum is
#: attained by the returned configuration to this tolerance. Global optimality rests on the sampling.
POLISH_ACCURACY = 1e-9
#: Accuracy of the closed forms (floating-point rounding of a sum of a few lengths), relative.
CLOSED_FORM_ACCURACY = 1e-12


# ----------------------------------------------------------------------------------------------------------------- closed forms
def free_sum_radii(lengths: Any) -> RadiusRange:
    """Range of |Σ a_i e^{iφ_i}| (or of a sum of 3D vectors with free directions) for lengths |a_i|.

    The polygon rule: max = Σ|a_i|; min = max(0, max|a_i| - Σ_others |a_i|)
    (the vectors close a polygon unless one is longer than all others
    together). Exact when every direction can be chosen independently.
    """
    arr = np.abs(np.asarray(lengths, dtype=float)).ravel()
    if arr.size == 0:
        return RadiusRange(0.0, 0.0)
    total = float(np.sum(arr))
    return RadiusRange(max(0.0, 2.0 * float(np.max(arr)) - total), total)


def collinear_radii(coefficients: Any) -> RadiusRange:
    """Min and max of |Σ s_i a_i| over signs s_i = ±1 (s_0 = +1): eq. 18 at q in {0, π}^N.

    ``coefficients`` are the (real or complex) coefficients a_i of eq. 18,
    spacecraft first: every joint at 0 or π turns each link either along or
    against its parent, which flips the sign of its term relative to the
    spacecraft's. This "collinear" minimum reproduces the R_min printed in
    Tables III, V and VI of the 1992 paper; the true minimum of eq. 15a
    (:func:`free_sum_radii`) is smaller.
    """
    a = np.asarray(coefficients, dtype=complex).ravel()
    if a.size == 0:
        return RadiusRange(0.0, 0.0)
    if a.size > 21:
        raise ValueError(f"coefficients: at most 21 terms (2^20 sign patterns), got {a.size}")
    signs = np.array(list(itertools.product((1.0, -1.0), repeat=a.size - 1))).reshape(-1, a.size - 1)
    values = np.abs(a[0] + signs @ a[1:])
    return RadiusRange(float(np.min(values)), float(np.max(values)))


def guaranteed_radii(first: tuple[float, float], own: tuple[float, float]) -> GuaranteedRadii:
    """Eq. 16 from the range (min, max) of |first term| and of |own-arm term|.

    R'_max = max|own| - max|first| (16a), R'_min = max|first| + min|own|
    (16b). The shell exists only when R'_max > R'_min. ``inner_radius`` =
    min|first| - min|own| when positive: the points closer to the CM than
    that are guaranteed too (the adversary cannot push the own arm's inner
    hole over them). Eq. 16 leaves this ball out; it is exact for planar
    models with free joints, a containing bound otherwise.
    """
    c_min, c_max = (float(v) for v in first)
    o_min, o_max = (float(v) for v in own)
    r_max = o_max - c_max
    r_min = c_max + o_min
    inner = c_min - o_min if c_min - o_min > 0.0 else None
    if r_max > r_min:
        return GuaranteedRadii(r_min, r_max, inner, True, "")
    reason = (
        f"R'_max = max|own| - max|first| = {o_max:.6g} - {c_max:.6g} = {r_max:.6g} m is not above "
        f"R'_min = max|first| + min|own| = {c_max:.6g} + {o_min:.6g} = {r_min:.6g} m: the rest of the system "
        "moves this end effector more than its own arm can compensate (1992 §IV)"
    )
    return GuaranteedRadii(None, None, inner, False, reason)


# ----------------------------------------------------------------------------------------------------------------- batched maps
def end_effector_radius(model: Model, q: Any, end_effector: str | int = 0) -> np.ndarray:
    """|r_E(q)|: distance of an end effector from the system CM, (...) for q (..., N). Attitude-free."""
    e = model.end_effector_index(end_effector)
    return np.linalg.norm(end_effector_positions(model, q)[..., e, :], axis=-1)


def singularity_measure(
    model: Model, q: Any, *, end_effector: str | int | None = None, criterion: SingularityCriterion | None = None
) -> np.ndarray:
    """The singularity measure of ⁰J*(q), (...) for q (..., N); zero at dynamic singularities.

    ``criterion`` (:class:`~freefloat.analysis.singularity.SingularityCriterion`)
    says which rows of J* (1992 eq. 14, spacecraft frame) and which measure;
    the default keeps [v_x, v_y] per end effector for a planar model (as
    :func:`freefloat.jacobian_determinant`) and all six rows otherwise, and
    gives det J* where that is square, else its smallest singular value.
    ``end_effector`` keeps that end effector's rows only (default: the whole
    system, eq. 17). One call evaluates millions of configurations (in chunks).
    """
    e = None if end_effector is None else model.end_effector_index(end_effector)
    return (criterion or SingularityCriterion()).evaluate(model, q, e)


# ----------------------------------------------------------------------------------------------------------------- computations
def _payload_mass(model: Model) -> float:
    return float(sum(float(p.get("mass", 0.0)) for p in model.payloads))


def _check_samples(samples: int, starts: int) -> None:
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 16:
        raise ValueError(f"samples: expected an integer >= 16, got {samples!r}")
    if isinstance(starts, bool) or not isinstance(starts, (int, np.integer)) or starts < 1:
        raise ValueError(f"starts: expected an integer >= 1, got {starts!r}")


def _norm_range(
    vec_fun: search.Batch, box: search.JointBox, *, samples: int, starts: int, seed: int
) -> tuple[RadiusRange, np.ndarray, np.ndarray, int, int]:
    """(min, max) of |vec_fun(q)| over the box: sampling + polishing. Also the attaining q's."""

    def sq(qq: np.ndarray) -> np.ndarray:
        v = vec_fun(qq)
        return np.einsum("...i,...i->...", v, v)

    top = search.extremize(sq, box, maximize=True, samples=samples, starts=starts, seed=seed)
    low = search.extremize(sq, box, maximize=False, samples=samples, starts=starts, seed=seed + 1)
    x_min = low.x
    if box.lo.size:  # Gauss-Newton on the vector itself: exact zeros where the minimum is 0
        lb = np.where(box.free, -np.inf, box.lo)
        ub = np.where(box.free, np.inf, box.hi)
        pad = 1e-12 * (box.hi - box.lo)
        x0 = np.where(box.free, x_min, np.clip(x_min, box.lo + pad, box.hi - pad))
        res = least_squares(lambda z: vec_fun(z[None])[0], x0, bounds=(lb, ub), xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=200)
        if np.linalg.norm(res.fun) ** 2 <= low.value:
            x_min = res.x
    r_min = float(np.linalg.norm(vec_fun(x_min[None])[0]))
    r_max = float(np.sqrt(top.value))
    return RadiusRange(r_min, r_max), x_min, top.x, top.samples, top.starts


def _embed(n: int, active: np.ndarray, fun: search.Batch) -> search.Batch:
    def full(x: np.ndarray) -> np.ndarray:
        q = np.zeros((*x.shape[:-1], n))
        q[..., active] = x
        return fun(q)

    return full


def reachable_workspace(
    model: Model,
    end_effector: str | int = 0,
    *,
    method: str = "auto",
    samples: int = 1 << 16,
    starts: int = 8,
    seed: int = 0,
) -> ReachableWorkspace:
    """The reachable workspace R_min..R_max of one end effector about the system CM (1992 eq. 15).

    Parameters
    ----------
    model
        Any model; joint limits (``model.joint_lower/upper``) are respected.
    end_effector
        Index or name (``model.end_effector_names``).
    method
        ``"auto"`` (closed form when the model is planar and every joint free,
        sampling otherwise), ``"closed_form"`` or ``"sampling"``.
    samples, starts, seed
        Sampling budget: Sobol samples per limit, optimiser starts from the
        best distinct samples, and the scrambling seed (deterministic).

    Examples
    --------
    >>> import freefloat as ff
    >>> from freefloat.analysis.workspace import reachable_workspace
    >>> ws = reachable_workspace(ff.models.papadopoulos1992(arms=2), "arm1_ee")
    >>> ws.method, round(ws.R_max, 6), ws.R_min
    ('closed_form', 2.5, 0.0)
    """
    e = model.end_effector_index(end_effector)
    if method not in ("auto", "closed_form", "sampling"):
        raise ValueError(f"method: expected 'auto', 'closed_form' or 'sampling', got {method!r}")
    _check_samples(samples, starts)
    box = search.model_box(model)
    closed_ok = model.is_planar and bool(np.all(box.free))
    if method == "auto":
        method = "closed_form" if closed_ok else "sampling"
    name, total, payload = model.end_effector_names[e], model.total_mass, _payload_mass(model)
    if method == "closed_form":
        if not closed_ok:
            raise ValueError(
                f"method='closed_form' needs a planar model whose joints are all free (no limits); {model.name!r} is "
                f"{'not planar' if not model.is_planar else 'limited'}: use method='sampling' or 'auto'"
            )
        lengths = np.linalg.norm(barycentric_vectors(model).end_effector_table[e], axis=-1)
        r = free_sum_radii(lengths)
        accuracy = CLOSED_FORM_ACCURACY * max(1.0, r.max)
        return ReachableWorkspace(model.name, name, r.min, r.max, "closed_form", accuracy, total_mass=total, payload_mass=payload)

    def vec(qq: np.ndarray) -> np.ndarray:
        return end_effector_positions(model, qq)[..., e, :]

    r, q_min, q_max, n_samples, n_starts = _norm_range(vec, box, samples=samples, starts=starts, seed=seed)
    return ReachableWorkspace(
        model_name=model.name,
        end_effector=name,
        R_min=r.min,
        R_max=r.max,
        method="sampling",
        accuracy=POLISH_ACCURACY * max(1.0, r.max),
        samples=n_samples,
        starts=n_starts,
        q_min=q_min,
        q_max=q_max,
        total_mass=total,
        payload_mass=payload,
    )


def collinear_radius_range(model: Model, end_effector: str | int = 0) -> RadiusRange:
    """Min and max of |r_E(q)| over the 2^N "collinear" configurations q in {0, π}^N (joint limits ignored).

    For the papers' planar systems this is eq. 15 restricted to links along or
    against their parents: the reading that reproduces the R_min printed in
    the 1992 paper's Tables III, V and VI (the true minimum over all q is
    smaller, often 0). Equals :func:`collinear_radii` of the eq. 18
    coefficients for planar models. N <= 20.
    """
    e = model.end_effector_index(end_effector)
    n = model.n_joints
    if n > 20:
        raise ValueError(f"collinear_radius_range: 2^N configurations; N = {n} > 20 is too many")
    corners = np.array(list(itertools.product((0.0, np.pi), repeat=n))).reshape(-1, n)
    radii = end_effector_radius(model, corners, e)
    return RadiusRange(float(np.min(radii)), float(np.max(radii)))


def _path_bodies(model: Model, body: int) -> list[int]:
    path = []
    while body > 0:
        path.append(body)
        body = int(model.parent[body])
    return path[::-1]


def guaranteed_workspace(
    model: Model,
    end_effector: str | int = 0,
    *,
    method: str = "auto",
    samples: int = 1 << 15,
    starts: int = 6,
    seed: int = 0,
) -> GuaranteedWorkspace:
    """The guaranteed workspace (GW) of one end effector, 1992 eq. 16, or ``exists=False`` with the reason.

    Which terms move with which joints (general tree): r_E = Σ_i T_i v_iE,
    one barycentric vector per body (eq. 4/10). For the bodies on the path
    from the spacecraft to the end effector, T_i depends on the own joints
    (that path's joints) only: their sum is the own term. Every other body
    (the spacecraft, r*_0; every other arm, l*) forms the first term, moved
    by the other joints and the attitude; a branch hanging from an own link
    is moved by own joints too (``coupled=True``; eq. 16 then treats its
    orientation as free, as for the other arms). max|first| is taken over
    all joints, max/min|own| over the own joints.

    ``method``: ``"closed_form"`` (planar, free joints: polygon rule on the
    lengths |v_iE|), ``"sampling"``, or ``"auto"``.
    """
    e = model.end_effector_index(end_effector)
    if method not in ("auto", "closed_form", "sampling"):
        raise ValueError(f"method: expected 'auto', 'closed_form' or 'sampling', got {method!r}")
    _check_samples(samples, starts)
    box = search.model_box(model)
    closed_ok = model.is_planar and bool(np.all(box.free))
    if method == "auto":
        method = "closed_form" if closed_ok else "sampling"
    if method == "closed_form" and not closed_ok:
        raise ValueError("method='closed_form' needs a planar model whose joints are all free; use 'sampling' or 'auto'")
    table = barycentric_vectors(model).end_effector_table[e]
    own_bodies = _path_bodies(model, int(model.end_effector_body[e]))
    own_mask = np.zeros(model.n_bodies, dtype=bool)
    own_mask[own_bodies] = True
    own_joints = np.array([b - 1 for b in own_bodies], dtype=int)
    other_joints = np.array([j for j in range(model.n_joints) if j not in set(own_joints.tolist())], dtype=int)
    coupled = any(bool(model.subtree[own_bodies[0], b]) for b in np.flatnonzero(~own_mask) if b > 0) if own_bodies else False
    if method == "closed_form":
        lengths = np.linalg.norm(table, axis=-1)
        first = free_sum_radii(lengths[~own_mask])
        own = free_sum_radii(lengths[own_mask])
        accuracy = CLOSED_FORM_ACCURACY * max(1.0, own.max)
    else:

        def terms(qq: np.ndarray, mask: np.ndarray) -> np.ndarray:
            rot = body_rotations(model, qq)[..., mask, :, :]
            return np.einsum("...bij,bj->...i", rot, table[mask])

        first, *_ = _norm_range(lambda qq: terms(qq, ~own_mask), box, samples=samples, starts=starts, seed=seed)
        own_box = search.JointBox(box.lo[own_joints], box.hi[own_joints], box.free[own_joints])
        own_fun = _embed(model.n_joints, own_joints, lambda qq: terms(qq, own_mask))
        own, *_ = _norm_range(own_fun, own_box, samples=samples, starts=starts, seed=seed + 7)
        accuracy = 2.0 * POLISH_ACCURACY * max(1.0, own.max)
    g = guaranteed_radii(first, own)
    return GuaranteedWorkspace(
        model_name=model.name,
        end_effector=model.end_effector_names[e],
        exists=g.exists,
        R_min=g.R_min,
        R_max=g.R_max,
        reason=g.reason,
        first_range=first,
        own_range=own,
        inner_radius=g.inner_radius,
        own_joints=tuple(model.joint_names[j] for j in own_joints),
        other_joints=tuple(model.joint_names[j] for j in other_joints),
        method=method,
        accuracy=accuracy,
        coupled=coupled,
    )
