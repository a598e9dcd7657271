"""Workspaces of free-floating space robots (Papadopoulos 1992 §III-IV), for any tree.

Every workspace here is a set of distances from the **system CM**: the
distance |r_E| of an end effector from the system CM does not depend on the
spacecraft attitude, so each workspace is a spherical shell (an annulus for a
planar model) or a union of them, centred on the CM, which does not move.

* :func:`reachable_workspace`: R_min = min_q |r_E|, R_max = max_q |r_E| (eq. 15).
* :func:`guaranteed_workspace`: the shell R'_min..R'_max of eq. 16, the
  points the end effector reaches whatever the rest of the system does, or
  ``exists=False`` with the reason.
* :func:`path_independent_workspace`: the radii reached in a dynamic
  singularity (det ⁰J* = 0, eq. 17), the path-dependent workspace (PDW), and
  the path-independent workspace PIW = reachable radii minus PDW radii.
* :func:`payload_effect`: workspaces before and after grasping a payload (§IV).
* :func:`collinear_radius_range`: min and max of |r_E| over q in {0, π}^N,
  the reading of eq. 15 that reproduces the paper's printed R_min values.

Closed forms. For a planar model whose joints are all free (no limits, or a
full turn), r_E = Σ_i a_i exp(iφ_i) (eq. 18 generalised: one barycentric
vector a_i per body, φ_i the absolute angle of body i). The absolute angles
are independent (the map (θ, q) -> φ is triangular with unit diagonal), so
|r_E| ranges over [max(0, 2 max|a_i| - Σ|a_i|), Σ|a_i|]: the polygon rule
(:func:`free_sum_radii`). Everything else is computed by dense batched
sampling plus polishing (see ``freeflyer._workspace_search``) and reports
the method and its accuracy. All distances are in m; angles in rad.
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.optimize import least_squares

from . import _workspace_search as search
from ._workspace_results import (
    GuaranteedRadii,
    GuaranteedWorkspace,
    PathIndependentWorkspace,
    PayloadEffect,
    RadiusRange,
    ReachableWorkspace,
)
from .barycentric import barycentric_vectors
from .jacobians import generalized_jacobian, jacobian_determinant
from .kinematics import body_rotations, end_effector_positions, point_positions
from .model import Model

if TYPE_CHECKING:
    pass

__all__ = [
    "GuaranteedRadii",
    "GuaranteedWorkspace",
    "PathIndependentWorkspace",
    "PayloadEffect",
    "RadiusRange",
    "ReachableWorkspace",
    "collinear_radii",
    "collinear_radius_range",
    "end_effector_radius",
    "free_sum_radii",
    "guaranteed_radii",
    "guaranteed_workspace",
    "path_independent_workspace",
    "payload_effect",
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


def _jacobian_rows(model: Model, end_effector: int | None) -> np.ndarray:
    """Rows of ⁰J* used for singularities: [v_x, v_y] per end effector (planar) or all 6 (3D)."""
    ees = range(model.n_end_effectors) if end_effector is None else [end_effector]
    keep = (0, 1) if model.is_planar else tuple(range(6))
    return np.array([6 * e + r for e in ees for r in keep], dtype=int)


def _jacobian_fun(model: Model, end_effector: int | None) -> search.Batch:
    rows = _jacobian_rows(model, end_effector)
    return lambda qq: generalized_jacobian(model, qq)[..., rows, :]


def singularity_measure(model: Model, q: Any, *, end_effector: str | int | None = None) -> np.ndarray:
    """det ⁰J*(q) where J* is square, else its smallest singular value; (...) for q (..., N).

    J* (1992 eq. 14, spacecraft frame) keeps the rows [v_x, v_y] per end
    effector for a planar model (as :func:`freeflyer.jacobian_determinant`)
    and all six otherwise; ``end_effector`` keeps that end effector's rows
    only (default: the whole system, eq. 17). Zero at dynamic singularities.
    One call evaluates millions of configurations (in chunks).
    """
    e = None if end_effector is None else model.end_effector_index(end_effector)
    arr = np.asarray(q, dtype=float)
    if e is None and _jacobian_rows(model, None).size == model.n_joints:  # square: the dedicated (compiled) determinant
        return np.asarray(jacobian_determinant(model, arr))
    fun = _jacobian_fun(model, e)
    flat = arr.reshape(-1, model.n_joints) if arr.ndim > 1 else arr[None]
    out = search.batched(lambda qq: search.singularity_values(fun(qq)), flat)
    return out.reshape(arr.shape[:-1])


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
    >>> import freeflyer as ff
    >>> from freeflyer.workspace import reachable_workspace
    >>> ws = reachable_workspace(ff.models.papadopoulos1992(arms=2), "arm1_ee")
    >>> ws.method, round(ws.R_max, 6), ws.R_min
    ('closed_form', 2.5, 0.0)
    """
    e = model.end_effector_index(end_effector)
    if method not in ("auto", "closed_form", "sampling"):
        raise ValueError(f"method: expected 'auto', 'closed_form' or 'sampling', got {method!r}")
    _check_samples(samples, starts)
    box = search.joint_box(model.joint_lower, model.joint_upper)
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
    box = search.joint_box(model.joint_lower, model.joint_upper)
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


def _piw_ends(radii: np.ndarray, gap: float, low: float, high: float) -> list[tuple[int, bool]]:
    """(index into radii, is-upper-end) of every cluster end strictly between ``low`` and ``high``."""
    if radii.size == 0:
        return []
    order = np.argsort(radii, kind="stable")
    r = radii[order]
    breaks = np.flatnonzero(np.diff(r) > gap)
    firsts = np.concatenate([[0], breaks + 1])
    lasts = np.concatenate([breaks, [r.size - 1]])
    ends = [(int(order[i]), False) for i in firsts if r[i] > low] + [(int(order[i]), True) for i in lasts if r[i] < high]
    return sorted(ends, key=lambda end: radii[end[0]])


def _merge(radii: np.ndarray, gap: float) -> list[list[float]]:
    out: list[list[float]] = []
    for r in np.sort(radii):
        if out and r - out[-1][1] <= gap:
            out[-1][1] = float(r)
        else:
            out.append([float(r), float(r)])
    return out


def path_independent_workspace(
    model: Model,
    end_effector: str | int = 0,
    *,
    jacobian: str = "system",
    samples: int = 1 << 18,
    seed: int = 0,
    merge_gap: float | None = None,
    reachable: ReachableWorkspace | None = None,
    max_steps: int = 400,
) -> PathIndependentWorkspace:
    """The path-independent workspace (PIW) and path-dependent workspace (PDW) of one end effector.

    Dynamic singularities are the configurations with det ⁰J* = 0 (eq. 17;
    the smallest singular value for a non-square J*). They are fixed in joint
    space; the PDW is the set of radii |r_E| at which they occur (any point
    at such a distance can be reached in a singular configuration, since the
    attitude is free), the PIW the reachable radii outside the PDW.

    ``jacobian``: ``"system"`` (all rows of J*, eq. 17) or ``"end_effector"``
    (this end effector's rows only). ``samples``: configurations sampled (a
    full grid, every edge checked, for N <= 3; random axis-parallel lines
    otherwise); each sign change of det J* is polished to 1e-13 rad, then the
    ends of every PDW interval that borders the PIW are polished by SLSQP on
    the singular set (at most ``max_steps`` trust-region steps in all).
    ``merge_gap`` (default 2 % of R_max): PDW radii closer than this are one
    interval. ``reachable``: a precomputed
    :func:`reachable_workspace` of the same model and end effector.

    Examples
    --------
    >>> import freeflyer as ff
    >>> from freeflyer.workspace import path_independent_workspace
    >>> captured = ff.models.papadopoulos1992(arms=1).with_payload(0, mass=400.0, inertia=25.0)
    >>> piw = path_independent_workspace(captured, samples=1 << 16)
    >>> round(piw.R_min, 4), round(piw.R_max, 4)
    (0.3689, 0.7759)
    """
    e = model.end_effector_index(end_effector)
    if jacobian not in ("system", "end_effector"):
        raise ValueError(f"jacobian: expected 'system' or 'end_effector', got {jacobian!r}")
    _check_samples(samples, 1)
    reach = reachable if reachable is not None else reachable_workspace(model, e)
    if reach.end_effector != model.end_effector_names[e] or reach.model_name != model.name:
        raise ValueError("reachable: computed for another model or end effector")
    jac_fun = _jacobian_fun(model, None if jacobian == "system" else e)
    box = search.joint_box(model.joint_lower, model.joint_upper)
    found = search.singular_points(jac_fun, box, samples=samples, seed=seed)
    gap = 0.02 * reach.R_max if merge_gap is None else float(merge_gap)
    if not gap > 0.0:
        raise ValueError(f"merge_gap: expected a positive distance in m, got {merge_gap!r}")
    q_s = found.q
    # Configurations that are often singular and extreme: the reachable limits' and the collinear ones.
    extra = [q for q in (reach.q_min, reach.q_max) if q is not None]
    if model.n_joints <= 12:
        extra += list(search.collinear_corners(model.n_joints, box))
    if extra:
        cand = np.array(extra)
        q_s = np.concatenate([q_s, cand[search.singularity_residual(jac_fun, cand) < 1e-12]])
    radii = end_effector_radius(model, q_s, e) if q_s.shape[0] else np.zeros(0)
    slack = max(10.0 * reach.accuracy, 1e-8 * max(1.0, reach.R_max))
    trust = 3.0 * found.step if found.grid else np.full(model.n_joints, 0.5)
    fallback = float(np.max(found.step)) * reach.R_max  # error bound of an unpolished boundary (Lipschitz-style)

    def radius2(qq: np.ndarray) -> np.ndarray:
        return end_effector_radius(model, qq, e) ** 2

    # Clusters of singular radii. Every cluster end that faces the PIW is followed on the singular set
    # towards its local extreme: one SLSQP step within the trust region at a time; the straight segment
    # between the old and the new end is projected back onto the singular set, so the radii passed on the
    # way join the cluster. Repeat until the ends stop moving.
    pending: set[tuple[int, bool]] = set()
    converged: set[tuple[int, bool]] = set()
    for _ in range(max_steps):
        facing = [(k, mx) for k, mx in _piw_ends(radii, gap, reach.R_min + slack, reach.R_max - slack) if (k, mx) not in pending]
        if not facing:
            break
        k, maximize = facing[0]
        pending.add((k, maximize))
        q_new = search.polish_extreme_radius(jac_fun, radius2, q_s[k], box, maximize=maximize, trust=trust)
        if q_new is None:
            continue
        r_new = float(end_effector_radius(model, q_new, e))
        if not maximize and r_new < 1e-3 * reach.R_max:  # the singular set may pass through r_E = 0 exactly
            q_zero = search.solve_singular(jac_fun, q_new, extra=lambda qq: end_effector_positions(model, qq)[..., e, :])
            if q_zero is not None:
                q_new, r_new = q_zero, float(end_effector_radius(model, q_zero, e))
        if (r_new - radii[k] if maximize else radii[k] - r_new) <= 1e-12 * max(1.0, reach.R_max):
            converged.add((k, maximize))
            continue
        n_chain = int(min(200, np.ceil(abs(r_new - radii[k]) / (0.25 * gap)) + 1))
        chain, ok = search.project_to_singular(jac_fun, q_s[k] + np.linspace(0.0, 1.0, n_chain + 1)[1:-1, None] * (q_new - q_s[k]))
        new_q = np.concatenate([chain[ok], q_new[None]])
        q_s = np.concatenate([q_s, new_q])
        radii = np.concatenate([radii, end_effector_radius(model, new_q, e)])
    ends = _piw_ends(radii, gap, reach.R_min + slack, reach.R_max - slack)
    errors = [POLISH_ACCURACY * max(1.0, reach.R_max) if end in converged else fallback for end in ends]
    intervals = _merge(radii, gap)
    pdw = tuple((max(lo, reach.R_min), min(hi, reach.R_max)) for lo, hi in intervals)
    piw: list[tuple[float, float]] = []
    start = reach.R_min
    for lo, hi in pdw:
        if lo > start + slack:
            piw.append((start, lo))
        start = max(start, hi)
    if reach.R_max > start + slack:
        piw.append((start, reach.R_max))
    spacing = np.diff(np.sort(radii))
    resolution = float(np.max(spacing[spacing <= gap])) if np.any(spacing <= gap) else 0.0
    return PathIndependentWorkspace(
        model_name=model.name,
        end_effector=model.end_effector_names[e],
        reachable=reach,
        pdw=pdw,
        piw=tuple(piw),
        singular_q=q_s,
        singular_radii=radii,
        method=found.method + "; PIW boundaries by SLSQP on the singular set",
        jacobian=jacobian,
        samples=found.evaluated,
        resolution=resolution,
        accuracy=max(errors) if errors else 0.0,
        merge_gap=gap,
    )


# ----------------------------------------------------------------------------------------------------------------- payload
def payload_effect(model: Model, end_effector: str | int, mass: float, inertia: Any, *, offset: Any = (0.0, 0.0, 0.0)) -> PayloadEffect:
    """Compare the workspaces before and after ``end_effector`` grasps a payload (1992 §IV).

    ``mass`` (kg, > 0), ``inertia`` (about the payload CM: scalar = I_zz of a
    planar model, [Ixx, Iyy, Izz] or 3x3) and ``offset`` (payload CM from
    the end-effector point, grasping body frame) as in
    :meth:`freeflyer.Model.with_payload`, which validates them.
    """
    e = model.end_effector_index(end_effector)
    captured = model.with_payload(e, mass=mass, inertia=inertia, offset=offset)
    m_p = float(mass)
    off = np.asarray(offset, dtype=float)
    ees = range(model.n_end_effectors)
    body = int(model.end_effector_body[e])
    point = model.end_effector_point[e] + off
    box = search.joint_box(model.joint_lower, model.joint_upper)
    reach_p, *_ = _norm_range(lambda qq: point_positions(model, qq, body, point), box, samples=1 << 14, starts=4, seed=3)
    scale = m_p / (model.total_mass + m_p)
    return PayloadEffect(
        model_name=model.name,
        end_effector=model.end_effector_names[e],
        payload_mass=m_p,
        mass_before=model.total_mass,
        mass_after=captured.total_mass,
        reachable_before=tuple(reachable_workspace(model, k) for k in ees),
        reachable_after=tuple(reachable_workspace(captured, k) for k in ees),
        guaranteed_before=tuple(guaranteed_workspace(model, k) for k in ees),
        guaranteed_after=tuple(guaranteed_workspace(captured, k) for k in ees),
        cm_shift_range=RadiusRange(scale * reach_p.min, scale * reach_p.max),
        captured=captured,
        before=model,
        offset=off,
    )
