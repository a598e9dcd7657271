"""Sampling and polishing shared by :mod:`freefloat.workspace` and :mod:`freefloat.capture` (private).

Three numerical tools, all batched over configurations:

* :func:`extremize`: the global maximum or minimum of a smooth scalar function
  of the joint angles over the joint box: scrambled Sobol samples (plus the
  "collinear" corners q in {0, π}^N for small N), then L-BFGS-B from the best
  distinct samples with batched central-difference gradients.
* :func:`singular_points`: points of the singular set of a Jacobian. Square
  Jacobians: sign changes of det along axis-parallel lines (every line of a
  full grid for N <= 3, Sobol-placed random lines otherwise), each root then
  polished by batched Illinois false position (a bracketing method with the
  guarantees of ``scipy.optimize.brentq``, run on all edges at once).
  Non-square Jacobians: local minima of the smallest singular value along the
  lines, polished by least squares on (q, u) with J(q)ᵀu = 0 (or J(q)u = 0),
  |u| = 1.
* :func:`polish_extreme_radius`: the local extreme of a radius on the singular
  set (SLSQP with the singularity as an equality constraint), used for the
  boundaries of the path-dependent workspace.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import least_squares, minimize

from ..core import feedback
from ..core.errors import ModelError
from ..core.numbers import MAX_JOINT_VALUE
from ..core.resources import require_memory

Batch = Callable[[np.ndarray], np.ndarray]

#: Configurations per kernel call inside the batched evaluations (bounds memory).
CHUNK = 1 << 16
#: Joint ranges at least this wide are a full turn: the joint is free (periodic).
FULL_TURN = 2.0 * np.pi - 1e-12


@dataclass(frozen=True)
class JointBox:
    """Sampling box of a set of joints: ``lo``/``hi`` (rad) and ``free`` (a full turn, periodic)."""

    lo: np.ndarray
    hi: np.ndarray
    free: np.ndarray


def joint_box(lower: np.ndarray, upper: np.ndarray) -> JointBox:
    """The box [lower, upper]; joints without limits (or with a full turn) become [-π, π], free."""
    lower = np.asarray(lower, dtype=float)
    upper = np.asarray(upper, dtype=float)
    free = ~np.isfinite(lower) | ~np.isfinite(upper) | (upper - lower >= FULL_TURN)
    lo = np.where(free, -np.pi, lower)
    hi = np.where(free, np.pi, upper)
    return JointBox(lo=lo, hi=hi, free=free)


def model_box(model: Any) -> JointBox:
    """The sampling box of a model's joints: :func:`joint_box` of its limits, a prismatic joint never free.

    A workspace needs the reach of every joint: a prismatic joint without both limits would make
    it unbounded, so it is refused with a :class:`ModelError` naming the joint.
    """
    lower = np.asarray(model.joint_lower, dtype=float)
    upper = np.asarray(model.joint_upper, dtype=float)
    sliding = np.asarray(model.prismatic, dtype=bool)
    for j in np.flatnonzero(sliding & ~(np.isfinite(lower) & np.isfinite(upper))):
        raise ModelError(
            f"{model.name}: joint {model.joint_names[j]!r}.limits",
            "is a prismatic joint without limits, so its workspace is unbounded",
            "give the joint [lower, upper] limits in m (model file: limits = [lo, hi]; URDF: <limit lower= upper=>)",
        )
    box = joint_box(lower, upper)
    free = box.free & ~sliding
    return JointBox(lo=np.where(sliding, lower, box.lo), hi=np.where(sliding, upper, box.hi), free=free)


def batched(fun: Batch, q: np.ndarray, chunk: int = CHUNK, *, count: str = "") -> np.ndarray:
    """``fun`` over the rows of q (M, N) in chunks; concatenated along axis 0. With ``count`` (a unit, "configurations"),
    the rows done are counted in the current :func:`freefloat.core.feedback.status` step (a bar with M as its total)."""
    step = feedback.current() if count else None
    if step is not None:
        step.expect(q.shape[0], count)
    if q.shape[0] == 0:
        return fun(q)
    out = []
    for s in range(0, q.shape[0], chunk):
        out.append(fun(q[s : s + chunk]))
        if step is not None:
            step.advance(min(chunk, q.shape[0] - s))
    return out[0] if len(out) == 1 else np.concatenate(out, axis=0)


def sobol(n: int, lo: np.ndarray, hi: np.ndarray, seed: int) -> np.ndarray:
    """At least ``n`` scrambled Sobol points (a power of two) in the box, (M, d)."""
    d = lo.size
    if d == 0:
        return np.zeros((1, 0))
    m = max(int(np.ceil(np.log2(max(n, 2)))), 1)
    # the points (float64) and scipy's Sobol state (uint64) of 2^m points, and a J* (6 x d) per point for the search
    require_memory(
        float(2**m) * d * 8 * (2 + 6),
        f"sampling {2**m:.3g} configurations ({n:.3g} samples asked, rounded up to a power of two)",
        "ask for fewer samples: the results report their sampling accuracy, and 2^16 to 2^20 samples are usually enough",
    )
    from scipy.stats import qmc  # (here: scipy.stats is not imported with freefloat)

    points = qmc.Sobol(d, scramble=True, seed=np.random.default_rng(seed)).random_base2(m)
    return lo + points * (hi - lo)


def collinear_corners(n: int, box: JointBox) -> np.ndarray:
    """q in {0, π}^n (the papers' "collinear" configurations) kept inside the box, (≤ 2^n, n)."""
    corners = np.array(np.meshgrid(*([[0.0, np.pi]] * n), indexing="ij")).reshape(n, -1).T
    inside = np.all((corners >= box.lo) & (corners <= box.hi), axis=1) | np.all(box.free)
    return corners[inside]


@dataclass(frozen=True)
class Extremum:
    value: float  # of the objective (not negated)
    x: np.ndarray  # the active variables at the optimum
    best_sample: float  # best objective among the samples, before polishing
    samples: int
    starts: int


def _fd_value_grad(fun: Batch, x: np.ndarray, h: float = 1e-6) -> tuple[float, np.ndarray]:
    n = x.size
    pts = np.concatenate([x[None], x + h * np.eye(n), x - h * np.eye(n)])
    vals = fun(pts)
    return float(vals[0]), (vals[1 : n + 1] - vals[n + 1 :]) / (2.0 * h)


def extremize(
    fun: Batch,
    box: JointBox,
    *,
    maximize: bool,
    samples: int,
    starts: int,
    seed: int,
) -> Extremum:
    """Global extreme of a smooth batched ``fun`` (M, d) -> (M,) over ``box`` (sampling + L-BFGS-B)."""
    d = box.lo.size
    if d == 0:
        v = float(fun(np.zeros((1, 0)))[0])
        return Extremum(value=v, x=np.zeros(0), best_sample=v, samples=1, starts=0)
    x = sobol(samples, box.lo, box.hi, seed)
    if d <= 12:
        x = np.concatenate([x, collinear_corners(d, box)])
    values = batched(fun, x)
    sign = -1.0 if maximize else 1.0
    order = np.argsort(sign * values)
    span = box.hi - box.lo
    picked: list[np.ndarray] = []
    for i in order:  # best distinct samples (at least 5 % of the box apart in some joint)
        if all(np.max(np.abs(x[i] - p) / span) > 0.05 for p in picked):
            picked.append(x[i])
        if len(picked) >= starts:
            break
    bounds = [(None, None) if f else (lo, hi) for lo, hi, f in zip(box.lo, box.hi, box.free, strict=True)]

    def objective(z: np.ndarray) -> tuple[float, np.ndarray]:
        v, g = _fd_value_grad(fun, z)
        return sign * v, sign * g

    best_x, best_v = x[order[0]], float(values[order[0]])
    for p in picked:
        res = minimize(objective, p, jac=True, method="L-BFGS-B", bounds=bounds, options={"ftol": 1e-15, "gtol": 1e-12, "maxiter": 500})
        v = float(fun(res.x[None])[0])
        if sign * v < sign * best_v:
            best_x, best_v = res.x, v
    return Extremum(value=best_v, x=np.asarray(best_x), best_sample=float(values[order[0]]), samples=int(x.shape[0]), starts=len(picked))


# ----------------------------------------------------------------------------------------------------------------- singular set
@dataclass(frozen=True)
class SingularSearch:
    q: np.ndarray  # (K, N) configurations on the singular set
    evaluated: int  # configurations evaluated while sampling
    lines: int  # sampling lines
    step: np.ndarray  # (N,) spacing of the samples along each joint (rad)
    grid: bool  # True: a full grid (every edge checked); False: random lines
    method: str


#: The measures a criterion may use (computed by the engine's kernel: :func:`freefloat.mechanics.jacobian_measure`).
MEASURES = ("det", "sigma_min", "manipulability")


@dataclass(frozen=True)
class Criterion:
    """The singular set searched: {q : measure(J(q)) <= threshold}, J = ``jac_fun(q)`` (M, N) -> (M, m, N).

    With ``threshold == 0`` the set is the exact singular set (rank J < m): a
    square J is searched by the sign changes of det J, another by the null
    vectors of J. With ``threshold > 0`` it is the sublevel set of the
    measure, whose boundary measure = threshold is the zero set of the
    signed ``level`` and is searched by its sign changes.
    """

    jac_fun: Batch
    measure: str
    threshold: float
    measure_fun: Batch  # the measure at each row of q, computed without J (the engine's kernel)
    residual_fun: Batch  # the relative distance to the exact singular set at each row of q (the engine's kernel)

    @property
    def signed(self) -> bool:
        """True when the boundary is a sign change of :meth:`level` (det J, or any measure with a threshold)."""
        return self.measure == "det" or self.threshold > 0.0

    def values(self, q: np.ndarray) -> np.ndarray:
        """The measure at each row of q (M, N)."""
        return self.measure_fun(q)

    def level(self, q: np.ndarray) -> np.ndarray:
        """Signed level function: det J (threshold 0), else |measure| - threshold; <= 0 inside the set."""
        v = self.values(q)
        return v if self.threshold == 0.0 else np.abs(v) - self.threshold


def _lines(box: JointBox, samples: int, seed: int, points_per_line: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    """Axis-parallel sampling lines: base configurations (M, N), axes (M,), parameters t (K,) in [0, 1]."""
    n = box.lo.size
    require_memory(  # the configurations along all lines at once, their measures and J*s (a few times the samples)
        float(samples) * max(n, 1) * 8 * 8,
        f"sampling {samples:.3g} configurations along lines",
        "ask for fewer samples: the results report their sampling accuracy, and 2^16 to 2^20 samples are usually enough",
    )
    if n <= 3:
        k = max(round(samples ** (1.0 / n)), 8) | 1  # odd: 0 is a node
        nodes = np.linspace(0.0, 1.0, k)
        bases: list[np.ndarray] = []
        axis_list: list[np.ndarray] = []
        for a in range(n):
            others = [nodes if b != a else np.zeros(1) for b in range(n)]
            grid = np.array(np.meshgrid(*others, indexing="ij")).reshape(n, -1).T
            bases.append(grid)
            axis_list.append(np.full(grid.shape[0], a))
        base = np.concatenate(bases)
        return box.lo + base * (box.hi - box.lo), np.concatenate(axis_list), nodes, True
    k = points_per_line
    m = max(samples // k, n)
    base = sobol(m, box.lo, box.hi, seed)
    axes = np.arange(base.shape[0]) % n
    return base, axes, np.linspace(0.0, 1.0, k), False


def _along(base: np.ndarray, axes: np.ndarray, values: np.ndarray) -> np.ndarray:
    q = base.copy()
    q[np.arange(q.shape[0]), axes] = values
    return q


def _illinois(
    f: Batch, base: np.ndarray, axes: np.ndarray, a: np.ndarray, b: np.ndarray, fa: np.ndarray, fb: np.ndarray, xtol: float
) -> np.ndarray:
    """Batched Illinois false position: roots of f along each edge [a, b] with fa fb < 0."""
    a, b, fa, fb = a.copy(), b.copy(), fa.copy(), fb.copy()
    active = np.ones(a.shape, dtype=bool)
    for _ in range(200):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        aa, bb, ffa, ffb = a[idx], b[idx], fa[idx], fb[idx]
        c = bb - ffb * (bb - aa) / (ffb - ffa)
        lo, hi = np.minimum(aa, bb), np.maximum(aa, bb)
        bad = ~np.isfinite(c) | (c <= lo) | (c >= hi)
        c = np.where(bad, 0.5 * (aa + bb), c)
        fc = batched(f, _along(base[idx], axes[idx], c))
        flip = fc * ffb < 0.0
        a[idx] = np.where(flip, bb, aa)
        fa[idx] = np.where(flip, ffb, 0.5 * ffa)
        b[idx], fb[idx] = c, fc
        done = (np.abs(b[idx] - a[idx]) <= xtol) | (fc == 0.0)
        active[idx[done]] = False
    return np.where(np.abs(fb) <= np.abs(fa), b, a)


def singular_points(
    crit: Criterion, box: JointBox, *, samples: int, seed: int, points_per_line: int = 64, max_inside: int = 4096
) -> SingularSearch:
    """Sample the singular set of a :class:`Criterion` over ``box``.

    With a threshold, the sampled configurations inside the set (up to ``max_inside`` of them) are
    returned with the boundary points: each lies in the set, and each seeds the search of the
    PDW boundaries from another part of it.
    """
    n = box.lo.size
    base, axes, t, grid = _lines(box, samples, seed, points_per_line)
    span = box.hi - box.lo
    q_lines = base[:, None, :].repeat(t.size, axis=1)
    rows = np.arange(base.shape[0])
    q_lines[rows, :, axes] = box.lo[axes][:, None] + t[None, :] * span[axes][:, None]
    square = crit.signed
    measure = crit.level

    if grid:  # evaluate every node once; the lines along each axis are views of the grid
        nodes = [box.lo[a] + t * span[a] for a in range(n)]
        full = np.array(np.meshgrid(*nodes, indexing="ij")).reshape(n, -1).T
        values_grid = batched(measure, full, count="configurations").reshape((t.size,) * n)
        values = np.concatenate([np.moveaxis(values_grid, a, -1).reshape(-1, t.size) for a in range(n)])
        evaluated = int(full.shape[0])
    else:
        values = batched(measure, q_lines.reshape(-1, n), count="configurations").reshape(base.shape[0], t.size)
        evaluated = int(base.shape[0] * t.size)
    step = span / (t.size - 1)
    if square:
        zero = values == 0.0
        found = [q_lines[zero]]
        li, ki = np.nonzero(np.sign(values[:, :-1]) * np.sign(values[:, 1:]) < 0.0)  # no overflow of huge values
        if li.size:
            lo_t = box.lo[axes[li]] + t[ki] * span[axes[li]]
            hi_t = box.lo[axes[li]] + t[ki + 1] * span[axes[li]]
            roots = _illinois(
                measure, base[li], axes[li], lo_t, hi_t, values[li, ki], values[li, ki + 1], xtol=1e-13 * max(1.0, float(np.max(span)))
            )
            found.append(_along(base[li], axes[li], roots))
        if crit.threshold > 0.0:  # samples inside the near-singular set belong to it too (a random subset of them)
            inside = q_lines[values < 0.0]
            if inside.shape[0] > max_inside:
                inside = inside[np.random.default_rng(seed).choice(inside.shape[0], max_inside, replace=False)]
            found.append(inside)
        q = np.concatenate(found) if found else np.zeros((0, n))
        what = "det J*" if crit.threshold == 0.0 else f"{crit.measure} - threshold"
        method = f"{what} sign changes on " + ("every grid edge" if grid else "random axis-parallel lines") + ", Illinois root polishing"
    else:
        q = _nonsquare_roots(crit, q_lines, values)
        method = (
            "local minima of the smallest singular value on " + ("grid lines" if grid else "random lines") + ", least-squares polishing"
        )
    return SingularSearch(q=q, evaluated=evaluated, lines=int(base.shape[0]), step=step, grid=grid, method=method)


def fd_jacobian(fun: Batch, x: np.ndarray, h: float = 1e-7) -> np.ndarray:
    """Central-difference Jacobian (k, d) of a batched ``fun`` (M, d) -> (M, k) at x (d,), one batched call."""
    d = x.size
    eye = np.eye(d)
    vals = fun(np.concatenate([x + h * eye, x - h * eye]))
    return ((vals[:d] - vals[d:]) / (2.0 * h)).T


def singular_system(crit: Criterion, n: int, q0: np.ndarray) -> tuple[Batch, np.ndarray]:
    """Batched residual F(x) (M, k) that vanishes exactly on the boundary of the set, and a start x0.

    Signed criteria: x = q, F = det J(q) / |J(q0)|^m (threshold 0) or
    (|measure| - threshold) / threshold. Otherwise x = (q, u) with a unit null
    vector u: F = [J(q)ᵀu (wide J) or J(q)u (tall J); |u|² - 1], J scaled by
    1 / |J(q0)|.
    """
    jac_fun = crit.jac_fun
    jac0 = jac_fun(q0[None])[0]
    norm = max(float(np.linalg.norm(jac0)), 1e-300)
    if crit.signed:
        scale = crit.threshold if crit.threshold > 0.0 else norm ** jac0.shape[0]

        def det_f(x: np.ndarray) -> np.ndarray:
            return (crit.level(x[:, :n]) / scale)[:, None]

        return det_f, q0.copy()
    wide = jac0.shape[0] < jac0.shape[1]
    u_svd = np.linalg.svd(jac0)
    u0 = u_svd[0][:, -1] if wide else u_svd[2][-1]

    def null_f(x: np.ndarray) -> np.ndarray:
        jac = jac_fun(x[:, :n]) / norm
        u = x[:, n:]
        prod = np.einsum("kij,ki->kj", jac, u) if wide else np.einsum("kij,kj->ki", jac, u)
        return np.concatenate([prod, np.einsum("ki,ki->k", u, u)[:, None] - 1.0], axis=1)

    return null_f, np.concatenate([q0, u0])


def solve_singular(crit: Criterion, q0: np.ndarray, extra: Batch | None = None) -> np.ndarray | None:
    """Least squares from q0 onto the singular set (and onto extra(q) = 0 if given); None if it does not converge."""
    n = q0.size
    system, x0 = singular_system(crit, n, q0)

    def full(x: np.ndarray) -> np.ndarray:
        out = system(x)
        return out if extra is None else np.concatenate([extra(x[:, :n]), out], axis=1)

    res = least_squares(
        lambda z: full(z[None])[0], x0, jac=lambda z: fd_jacobian(full, z), xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=100
    )
    if np.linalg.norm(res.fun) > 1e-13:
        return None
    return np.asarray(res.x[:n])


def _nonsquare_roots(crit: Criterion, q_lines: np.ndarray, values: np.ndarray, max_polish: int = 80) -> np.ndarray:
    """Singular configurations of a non-square Jacobian from the smallest singular value along the lines."""
    n = q_lines.shape[-1]
    inner = (values[:, 1:-1] <= values[:, :-2]) & (values[:, 1:-1] <= values[:, 2:])
    li, ki = np.nonzero(inner)
    ki = ki + 1
    if li.size == 0:
        return np.zeros((0, n))
    keep = np.argsort(values[li, ki])[:max_polish]
    found = [solve_singular(crit, q0) for q0 in q_lines[li[keep], ki[keep]]]
    return np.array([q for q in found if q is not None]).reshape(-1, n)


def singularity_residual(crit: Criterion, q: np.ndarray) -> np.ndarray:
    """Relative distance to the set's boundary at each row of q: |det J| / σ_max^m (square J), σ_min / σ_max (another),
    or |level| / threshold; from the engine's measures (:attr:`Criterion.residual_fun`), no J written."""
    if crit.threshold > 0.0:
        return np.abs(batched(crit.level, q)) / crit.threshold
    return batched(crit.residual_fun, q)


def polish_extreme_radius(
    crit: Criterion,
    radius2_fun: Batch,
    q0: np.ndarray,
    box: JointBox,
    *,
    maximize: bool,
    trust: np.ndarray,
) -> np.ndarray | None:
    """The local extreme of the squared radius on the singular set near q0 (SLSQP), or None if it fails.

    The search stays within ``q0 ± trust`` (and the joint limits); the
    singular set is the equality constraint of :func:`singular_system`.
    Gradients are central differences, each evaluated in one batched call.
    """
    n = q0.size
    sign = -1.0 if maximize else 1.0
    lo = np.where(box.free, q0 - trust, np.maximum(box.lo, q0 - trust))
    hi = np.where(box.free, q0 + trust, np.minimum(box.hi, q0 + trust))
    system, x0 = singular_system(crit, n, q0)

    def objective(x: np.ndarray) -> np.ndarray:
        return sign * radius2_fun(x[:, :n])[:, None]

    def f(x: np.ndarray) -> tuple[float, np.ndarray]:
        return float(objective(x[None])[0, 0]), fd_jacobian(objective, x)[0]

    cons = [{"type": "eq", "fun": lambda x: system(x[None])[0], "jac": lambda x: fd_jacobian(system, x)}]
    bounds = list(zip(lo, hi, strict=True)) + [(-1.5, 1.5)] * (x0.size - n)
    try:
        res = minimize(f, x0, jac=True, method="SLSQP", bounds=bounds, constraints=cons, options={"ftol": 1e-15, "maxiter": 300})
    except (ValueError, np.linalg.LinAlgError):  # pragma: no cover - defensive
        return None
    q, ok = project_to_singular(crit, np.asarray(res.x[:n])[None])  # land exactly on the singular set
    if not ok[0] or np.max(np.abs(q[0] - res.x[:n])) > 1e-6:
        return None
    return q[0]


def project_to_singular(crit: Criterion, q: np.ndarray, h: float = 1e-7) -> tuple[np.ndarray, np.ndarray]:
    """Project configurations (M, N) onto the singular set: (projected q, ok mask).

    Square Jacobians: batched Newton steps on det J (minimal-norm step along
    its gradient, central differences). Others: least squares on (q, u) per
    configuration. ``ok`` marks the configurations that converged.
    """
    m, n = q.shape
    if m == 0:
        return q, np.zeros(0, dtype=bool)
    if not crit.signed:
        found = [solve_singular(crit, qi) for qi in q]
        ok = np.array([f is not None for f in found])
        return np.array([f if f is not None else qi for f, qi in zip(found, q, strict=True)]), ok
    x = q.copy()
    eye = np.eye(n)
    lost = np.zeros(m, dtype=bool)  # configurations that a step threw out of any joint's range (a threshold nothing meets)
    for _ in range(20):
        pts = np.concatenate([x[:, None, :], x[:, None, :] + h * eye, x[:, None, :] - h * eye], axis=1).reshape(-1, n)
        vals = batched(crit.level, pts).reshape(m, 2 * n + 1)
        f, grad = vals[:, 0], (vals[:, 1 : n + 1] - vals[:, n + 1 :]) / (2.0 * h)
        g2 = np.maximum(np.einsum("mi,mi->m", grad, grad), 1e-300)
        with np.errstate(over="ignore", invalid="ignore"):
            moved = x - (f / g2)[:, None] * grad
        lost |= ~np.all(np.abs(moved) <= MAX_JOINT_VALUE, axis=1)
        x = np.where(lost[:, None], x, moved)
    tol = 1e-12 if crit.threshold > 0.0 else 1e-14
    ok = (singularity_residual(crit, x) < tol) & ~lost
    return x, ok
