"""The path-independent workspace (1992 eq. 17) and the effect of a payload on the workspaces (1992 §IV) (private).

Import from :mod:`freefloat.analysis.workspace` (``ff.workspace``). Dynamic
singularities (det ⁰J* = 0) are fixed in joint space; the radii |r_E| at which
they occur form the path-dependent workspace (PDW), the rest of the reachable
radii the path-independent workspace (PIW). Distances in m from the system CM.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core.model import Model
from ..mechanics.kinematics import end_effector_positions, point_positions
from . import _workspace_search as search
from ._workspace_reach import (
    POLISH_ACCURACY,
    _check_samples,
    _norm_range,
    end_effector_radius,
    guaranteed_workspace,
    reachable_workspace,
)
from ._workspace_results import PathIndependentWorkspace, PayloadEffect, RadiusRange, ReachableWorkspace
from .singularity import SingularityCriterion

__all__ = ["path_independent_workspace", "payload_effect"]


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
    criterion: SingularityCriterion | None = None,
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
    ``criterion``: which rows of J* and which measure count as singular, with
    a threshold (:class:`~freefloat.analysis.singularity.SingularityCriterion`;
    default: the paper's, exact singularities of det J*). With
    ``SingularityCriterion(rows="position", measure="sigma_min", threshold=t)``
    the PDW holds every radius reached in a configuration whose translational
    J* has σ_min <= t: the boundary σ_min = t is searched like det J* = 0.

    Examples
    --------
    >>> import freefloat as ff
    >>> from freefloat.analysis.workspace import path_independent_workspace
    >>> captured = ff.models.papadopoulos1992(arms=1).with_payload(0, mass=400.0, inertia=25.0)
    >>> piw = path_independent_workspace(captured, samples=1 << 16)
    >>> round(piw.R_min, 4), round(piw.R_max, 4)
    (0.3689, 0.7759)
    """
    e = model.end_effector_index(end_effector)
    if jacobian not in ("system", "end_effector"):
        raise ValueError(f"jacobian: expected 'system' or 'end_effector', got {jacobian!r}")
    _check_samples(samples, 1)
    if model.n_joints == 0:
        raise ValueError(
            f"model {model.name!r} has no joints: its end effectors cannot move relative to the spacecraft, "
            "so there are no dynamic singularities and no path-independent workspace to find (add an arm)"
        )
    reach = reachable if reachable is not None else reachable_workspace(model, e)
    if reach.end_effector != model.end_effector_names[e] or reach.model_name != model.name:
        raise ValueError("reachable: computed for another model or end effector")
    crit_user = criterion if criterion is not None else SingularityCriterion()
    crit = crit_user.search_criterion(model, None if jacobian == "system" else e)
    box = search.model_box(model)
    found = search.singular_points(crit, box, samples=samples, seed=seed)
    gap = 0.02 * reach.R_max if merge_gap is None else float(merge_gap)
    if merge_gap is None and not gap > 0.0:
        raise ValueError(
            f"end effector {reach.end_effector!r}: its reachable workspace has zero size (R_max = {reach.R_max:g} m, "
            "the joints do not move it relative to the system CM); there is no path-independent workspace to find"
        )
    if not gap > 0.0:
        raise ValueError(f"merge_gap: expected a positive distance in m, got {merge_gap!r}")
    q_s = found.q
    # Configurations that are often singular and extreme: the reachable limits' and the collinear ones.
    extra = [q for q in (reach.q_min, reach.q_max) if q is not None]
    if model.n_joints <= 12:
        extra += list(search.collinear_corners(model.n_joints, box))
    if extra:
        cand = np.array(extra)
        inside = crit.level(cand) <= 0.0 if crit.threshold > 0.0 else search.singularity_residual(crit, cand) < 1e-12
        q_s = np.concatenate([q_s, cand[inside]])
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
        q_new = search.polish_extreme_radius(crit, radius2, q_s[k], box, maximize=maximize, trust=trust)
        if q_new is None:
            continue
        r_new = float(end_effector_radius(model, q_new, e))
        if not maximize and r_new < 1e-3 * reach.R_max:  # the singular set may pass through r_E = 0 exactly
            q_zero = search.solve_singular(crit, q_new, extra=lambda qq: end_effector_positions(model, qq)[..., e, :])
            if q_zero is not None:
                q_new, r_new = q_zero, float(end_effector_radius(model, q_zero, e))
        if (r_new - radii[k] if maximize else radii[k] - r_new) <= 1e-12 * max(1.0, reach.R_max):
            converged.add((k, maximize))
            continue
        n_chain = int(min(200, np.ceil(abs(r_new - radii[k]) / (0.25 * gap)) + 1))
        chain, ok = search.project_to_singular(crit, q_s[k] + np.linspace(0.0, 1.0, n_chain + 1)[1:-1, None] * (q_new - q_s[k]))
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
        criterion=crit_user.describe(model, None if jacobian == "system" else e),
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
    :meth:`freefloat.Model.with_payload`, which validates them.
    """
    e = model.end_effector_index(end_effector)
    captured = model.with_payload(e, mass=mass, inertia=inertia, offset=offset)
    m_p = float(mass)
    off = np.asarray(offset, dtype=float)
    ees = range(model.n_end_effectors)
    body = int(model.end_effector_body[e])
    point = model.end_effector_point[e] + off
    box = search.model_box(model)
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
