"""The measures of a Jacobian, SIMD across configurations: its determinant, singular values, manipulability and
condition number of chosen rows, by Householder reductions written as loops over the ``width`` configurations of a
block (no branches on data), and the smallest singular value by Laguerre's iteration on the bidiagonal's tridiagonal
matrix. The batch drivers (:mod:`.drivers`), the control laws (:mod:`.laws`, J_z's condition number) and the
specialised measure kernels (:mod:`.specialise`) all call these."""

from __future__ import annotations

import math

import numpy as np

from .cache import kernel

#: The measures of :func:`jacobian_measure_lanes`, by code.
MEASURE_CODES = {"det": 0, "sigma_min": 1, "manipulability": 2, "condition": 3, "sigma_max": 4}


@kernel(inline="always")
def measure_work(n: int) -> int:  # pragma: no cover - compiled
    """Rows of work space (``width`` floats each) that :func:`jacobian_measure_lanes` needs for ``n`` joints."""
    return 2 * n * n + 5 * n + 22


@kernel(inline="always")
def _b(rows: np.ndarray, n: int, by_rows: bool, i: int, j: int) -> int:  # pragma: no cover - compiled
    """The row of the lane view holding B[i, j]: B = A^T when A (the chosen rows of J*) is wide (K <= N), else A."""
    return rows[j] * n + i if by_rows else rows[i] * n + j


@kernel(inline="always")
def _pick(x: float, y: float, a: float, b: float) -> float:  # pragma: no cover - compiled
    """``a if x > y else b``: a select on data, which the specialiser traces as one (:mod:`.specialise.trace`)."""
    return a if x > y else b


@kernel(inline="always")
def _magnitude(x: float) -> float:  # pragma: no cover - compiled
    """|x| by :func:`_pick` (traced as one select)."""
    return _pick(x, 0.0, x, -x)


@kernel(inline="always")
def _needs(kind: int, part: int) -> bool:  # pragma: no cover - compiled
    """Whether the measure ``kind`` needs the tridiagonal matrix ``part`` of :func:`_reduce_views` (0: sigma_min's, for
    kinds 1 and 3; 1: sigma_max's, for kinds 3 and 4)."""
    return kind == 3 or (part == 0 and kind == 1) or (part == 1 and kind == 4)


@kernel(inline="always")
def jacobian_measure_lanes(
    W: np.ndarray, at: int, width: int, n: int, rows: np.ndarray, kind: int, tmp: np.ndarray, out: np.ndarray, o0: int, count: int
) -> None:  # pragma: no cover - compiled
    """A measure of the rows ``rows`` (K distinct rows, N = ``n`` columns) of the J* of ``width`` configurations at
    once: out[o0 + l] for the configurations l < ``count``. Element (r, c) of configuration l's J* is
    ``W[at + (r n + c) width + l]`` (the generic kernels: one J*, width 1; the specialised ones: the rows of a lane
    block, width :data:`~.specialise.lanes.LANES`); the chosen rows are overwritten. ``tmp``: at least :func:`measure_work` (N)
    ``width`` floats.

    ``kind`` (:data:`MEASURE_CODES`): 0 det (K = N; LU with partial pivoting, signed); 1 the smallest singular value;
    2 the product of the singular values (sqrt(det(A A^T)) for K <= N: Yoshikawa's manipulability); 3 the condition
    number sigma_max / sigma_min (inf when sigma_min is 0); 4 the largest singular value. Two stages:
    :func:`_reduce_views` (the matrices to a few rows: the determinant, or the product of the singular values and the
    tridiagonal matrices whose largest eigenvalues give sigma_min and sigma_max) and :func:`_finish_views` (those
    eigenvalues). The singular values come from a Householder QR of B (A^T when K <= N, else A; backward stable),
    B = Q R with R r x r, r = min(K, N):

    - the product of the singular values is prod |R_kk|;
    - sigma_min^2 is 1 / (the largest eigenvalue of R^-1 R^-T) and sigma_max^2 the largest eigenvalue of R R^T. A
      largest eigenvalue is exact to a few ulps of itself, so sigma_min is within a few ulps of sigma_max times the
      conditioning of R (what numpy's SVD achieves: its error is eps sigma_max), not eps sigma_max^2 / sigma_min as
      from the eigenvalues of A A^T. ``sigma_min`` is 0 where R has a zero pivot or its inverse overflows
      (sigma_min < ~1e-150 sigma_max, far below that accuracy).
    - The largest eigenvalue of a symmetric matrix: Householder reduction to a tridiagonal matrix, then Laguerre's
      iteration on its characteristic polynomial p from above (from the lower of its Frobenius norm and Gershgorin's
      bound): for a polynomial with real roots it decreases monotonically onto the largest root, cubically (linearly,
      ratio <= 0.4, onto a multiple one), and p'/p and p''/p come from the LDL^T pivots of lambda I - T (Sturm's
      recurrence). It stops when a step is under 4e-16 lambda, or when the point is far closer to the largest root
      than to any other ((p'/p)^2 <= 1.05 (-(p'/p)')) and the last two steps predict, at the cubic rate, an error
      under 1e-17 lambda after the step (step^4 / previous step^3; the step is then taken). The configurations that
      have converged leave the passes (the others move to the front of the block). Where
      rounding makes a step land below the largest root (a multiple or nearly multiple one; seen as a pivot <= 0) the
      root is bracketed: a try just above that point, then bisection, to 2e-14 of itself.

    Each step is a loop over the ``width`` configurations without branches (a select on data is :func:`_pick`) on 2-D
    views (row, configuration) of W and ``tmp``, writing one row per pass: SIMD across a lane block (a flat index at a
    run-time offset is not vectorised: numba's negative-index wraparound makes it a gather). Between Laguerre's
    iterations one scalar pass moves the configurations still iterating to the front of the block. The specialised
    kernels trace :func:`_reduce_views` for their structure's smallest singular value of all the rows of J* (one
    configuration, the same source: straight-line code SIMD across a block, :func:`~.specialise.build.trace_reduction`) and
    run :func:`_finish_views` after it (:func:`measure_finish_lanes`).
    """
    top = 0
    for i in range(rows.shape[0]):
        top = max(top, rows[i] + 1)
    work = measure_work(n)
    _measure_views(
        W[at : at + top * n * width].reshape((top * n, width)), tmp[: work * width].reshape((work, width)), n, rows, kind, out, o0, count
    )


@kernel(inline="always")
def measure_finish_lanes(
    W: np.ndarray, at: int, width: int, r: int, kind: int, out: np.ndarray, o0: int, count: int
) -> None:  # pragma: no cover - compiled
    """:func:`_finish_views` on the rows of ``width`` floats from W[at]: the reduced rows of :func:`_reduce_views`
    (written there by a specialised kernel's traced reduction), then :func:`measure_work` (r) rows of work space."""
    work = measure_work(r)
    _finish_views(W[at : at + work * width].reshape((work, width)), r, kind, out, o0, count)


@kernel(inline="always")
def _reflector(s: float, x: float) -> tuple[float, float]:  # pragma: no cover - compiled
    """The Householder reflection H = I - beta v v^T that maps a column with squared norm ``s`` and first entry ``x``
    onto alpha e_1: (alpha, beta), v = the column - alpha e_1 (alpha of the sign opposite to x: no cancellation in
    v_1); beta = 0 for a zero column (no reflection)."""
    norm = math.sqrt(s)
    alpha = _pick(0.0, x, norm, -norm)
    vtv = 2.0 * (s - x * alpha)
    return alpha, _pick(vtv, 0.0, 2.0 / vtv, 0.0)


@kernel(inline="always")
def _column_dot(
    V: np.ndarray, T: np.ndarray, acc: int, rows: np.ndarray, n: int, by_rows: bool, k: int, j: int, p: int
) -> None:  # pragma: no cover
    """T[acc] = the dot products of columns k and j of B over its rows k .. p - 1, for every configuration: four (then
    two, one) rows per pass over the configurations, so that the sum stays in registers (a pass that reads more than
    about eight rows while it writes one is not vectorised: LLVM's run-time alias checks)."""
    for l in range(T.shape[1]):
        T[acc, l] = 0.0
    i = k
    while i + 4 <= p:
        a0, b0 = _b(rows, n, by_rows, i, k), _b(rows, n, by_rows, i, j)
        a1, b1 = _b(rows, n, by_rows, i + 1, k), _b(rows, n, by_rows, i + 1, j)
        a2, b2 = _b(rows, n, by_rows, i + 2, k), _b(rows, n, by_rows, i + 2, j)
        a3, b3 = _b(rows, n, by_rows, i + 3, k), _b(rows, n, by_rows, i + 3, j)
        for l in range(T.shape[1]):
            T[acc, l] += V[a0, l] * V[b0, l] + V[a1, l] * V[b1, l] + V[a2, l] * V[b2, l] + V[a3, l] * V[b3, l]
        i += 4
    while i < p:
        a0, b0 = _b(rows, n, by_rows, i, k), _b(rows, n, by_rows, i, j)
        for l in range(T.shape[1]):
            T[acc, l] += V[a0, l] * V[b0, l]
        i += 1


@kernel(inline="always")
def _strided_dot(T: np.ndarray, acc: int, a0: int, sa: int, b0: int, sb: int, m: int, add: bool) -> None:  # pragma: no cover
    """T[acc] (+)= sum over t < m of T[a0 + t sa] T[b0 + t sb], row by row for every configuration, two terms per
    pass (four, reading T while writing it, were not vectorised, and slower)."""
    if not add:
        for l in range(T.shape[1]):
            T[acc, l] = 0.0
    t = 0
    while t + 2 <= m:
        a, b = a0 + t * sa, b0 + t * sb
        for l in range(T.shape[1]):
            T[acc, l] += T[a, l] * T[b, l] + T[a + sa, l] * T[b + sb, l]
        t += 2
    while t < m:
        a, b = a0 + t * sa, b0 + t * sb
        for l in range(T.shape[1]):
            T[acc, l] += T[a, l] * T[b, l]
        t += 1


@kernel()
def _measure_views(
    V: np.ndarray, T: np.ndarray, n: int, rows: np.ndarray, kind: int, out: np.ndarray, o0: int, count: int
) -> None:  # pragma: no cover
    """:func:`jacobian_measure_lanes` on the 2-D views V (rows of J*, configurations) and T (work rows, configurations).
    Not inlined: compiled once for every caller (the generic drivers, the specialised kernels, the control laws), its
    loops SIMD across the configurations whether or not N is a constant (inlined into the specialised kernels, where N
    is, it compiled several times slower and ran no faster)."""
    _reduce_views(V, T, n, rows, kind)
    _finish_views(T, min(rows.shape[0], n), kind, out, o0, count)


@kernel()
def _reduce_views(V: np.ndarray, T: np.ndarray, n: int, rows: np.ndarray, kind: int) -> None:  # pragma: no cover
    """The first stage of :func:`jacobian_measure_lanes`: the chosen rows of J* in V to the reduced rows of T, r = min(K, N):
    row 0 the determinant (``kind`` 0) or the product of the singular values; rows 1 .. 2r - 1 the diagonal (r rows)
    and off-diagonal (r - 1) of a tridiagonal matrix whose largest eigenvalue is 1 / sigma_min^2 (kinds 1, 3); rows
    2r .. 4r - 2 those of one whose largest eigenvalue is sigma_max^2 (kinds 3, 4). One configuration of it, traced
    (``width`` 1, the structure as numbers), is the specialised kernels' reduction (:func:`~.specialise.build.trace_reduction`):
    it branches on data only through :func:`_pick`."""
    width = V.shape[1]
    k_rows = rows.shape[0]
    if kind == 0:
        det, piv, big, f = 0, 1, 2, 3
        for l in range(width):
            T[det, l] = 1.0
        for col in range(n):
            top_row = rows[col] * n + col
            for l in range(width):
                T[big, l] = abs(V[top_row, l])
                T[piv, l] = col
            for r in range(col + 1, n):  # the pivot: the first largest |a[r, col]|
                o = rows[r] * n + col
                for l in range(width):
                    v = abs(V[o, l])
                    better = v > T[big, l]
                    T[big, l] = v if better else T[big, l]
                    T[piv, l] = r if better else T[piv, l]
            for r in range(col + 1, n):  # the pivot row swapped with row col where it is row r
                for j in range(col, n):
                    oc = rows[col] * n + j
                    o = rows[r] * n + j
                    for l in range(width):
                        here = T[piv, l] == r
                        a, b = V[oc, l], V[o, l]
                        V[oc, l] = b if here else a
                        V[o, l] = a if here else b
            for l in range(width):
                d = V[top_row, l]
                T[det, l] = (-T[det, l] if T[piv, l] != col else T[det, l]) * d
                T[big, l] = 1.0 / (d if d != 0.0 else 1.0)  # a zero column below the diagonal: det is 0, nothing to eliminate
            for r in range(col + 1, n):
                o = rows[r] * n + col
                for l in range(width):
                    T[f, l] = V[o, l] * T[big, l]
                for j in range(col + 1, n):
                    oc = rows[col] * n + j
                    o = rows[r] * n + j
                    for l in range(width):
                        V[o, l] -= T[f, l] * V[oc, l]
        return
    by_rows = k_rows <= n
    p, r = (n, k_rows) if by_rows else (k_rows, n)
    prod = 0  # then the two tridiagonal matrices (rows 1 ..), then R^-1 (or R) and its Gram matrix: rows X + i r + j
    X = 4 * r - 1
    G = X + r * r
    v0, beta, acc = G + r * r, G + r * r + 1, G + r * r + 2
    e = G + r * r + 3  # then 3 rows for the tridiagonalisation
    for k in range(r):  # Householder QR of B (p x r) in place: R in its upper triangle
        _column_dot(V, T, acc, rows, n, by_rows, k, k, p)
        d = _b(rows, n, by_rows, k, k)
        for l in range(width):
            x = V[d, l]
            alpha, scale = _reflector(T[acc, l], x)
            T[beta, l] = scale
            V[d, l] = x - alpha  # the reflector v = B[k:, k] - alpha e_k, in place
            T[v0, l] = alpha
        for j in range(k + 1, r):
            _column_dot(V, T, acc, rows, n, by_rows, k, j, p)
            for l in range(width):
                T[acc, l] *= T[beta, l]
            i = k
            while i + 2 <= p:  # two rows per pass (two written: still vectorised)
                oi, oj = _b(rows, n, by_rows, i, k), _b(rows, n, by_rows, i, j)
                oi1, oj1 = _b(rows, n, by_rows, i + 1, k), _b(rows, n, by_rows, i + 1, j)
                for l in range(width):
                    c = T[acc, l]
                    V[oj, l] -= c * V[oi, l]
                    V[oj1, l] -= c * V[oi1, l]
                i += 2
            if i < p:
                oi, oj = _b(rows, n, by_rows, i, k), _b(rows, n, by_rows, i, j)
                for l in range(width):
                    V[oj, l] -= T[acc, l] * V[oi, l]
        for l in range(width):
            V[d, l] = T[v0, l]  # R_kk
    for l in range(width):
        T[prod, l] = 1.0
    for k in range(r):
        d = _b(rows, n, by_rows, k, k)
        for l in range(width):
            x = V[d, l]
            T[prod, l] *= _magnitude(x)
    for part in range(2):  # 0: sigma_min from R^-1 (kinds 1, 3); 1: sigma_max from R (kinds 3, 4)
        if not _needs(kind, part):
            continue
        for j in range(r):  # X = R^-1 (upper triangular, column by column), or R
            d = _b(rows, n, by_rows, j, j)
            xd = X + j * r + j
            for l in range(width):
                x = V[d, l]
                T[xd, l] = x if part == 1 else _pick(_magnitude(x), 0.0, 1.0 / x, 0.0)
            for i in range(j - 1, -1, -1):
                xo = X + i * r + j
                if part == 1:
                    o = _b(rows, n, by_rows, i, j)
                    for l in range(width):
                        T[xo, l] = V[o, l]
                    continue
                for l in range(width):
                    T[xo, l] = 0.0
                k = i + 1
                while k + 2 <= j + 1:  # two terms per pass
                    o, xk = _b(rows, n, by_rows, i, k), X + k * r + j
                    o1 = _b(rows, n, by_rows, i, k + 1)
                    for l in range(width):
                        T[xo, l] += V[o, l] * T[xk, l] + V[o1, l] * T[xk + r, l]
                    k += 2
                if k <= j:
                    o, xk = _b(rows, n, by_rows, i, k), X + k * r + j
                    for l in range(width):
                        T[xo, l] += V[o, l] * T[xk, l]
                xi = X + i * r + i
                for l in range(width):
                    T[xo, l] *= -T[xi, l]
        for i in range(r):  # G = X X^T, its lower triangle (all that the reduction reads)
            for j in range(i, r):
                _strided_dot(T, G + j * r + i, X + i * r + j, 1, X + j * r + j, 1, r - j, False)
        a = 1 + part * (2 * r - 1)
        _tridiagonal(T, G, r, width, a, a + r, e)


@kernel()
def _finish_views(T: np.ndarray, r: int, kind: int, out: np.ndarray, o0: int, count: int) -> None:  # pragma: no cover
    """The second stage of :func:`jacobian_measure_lanes`: out[o0 + l] (l < ``count``) from the reduced rows of
    :func:`_reduce_views` (r = min(K, N)) in T, the largest eigenvalues by Laguerre's iteration; rows 4r - 1 ..
    7r + 16 of T are work space. Not inlined: compiled once for the generic and the specialised kernels."""
    width = T.shape[1]
    if kind == 0 or kind == 2:
        for l in range(count):
            out[o0 + l] = T[0, l]
        return
    e = 4 * r - 1
    lam = e + 16 + 3 * r
    small = lam + 1
    for part in range(2):  # 0: sigma_min (kinds 1, 3); 1: sigma_max (kinds 3, 4)
        if not _needs(kind, part):
            continue
        a = 1 + part * (2 * r - 1)
        _laguerre(T, r, width, a, a + r, e, lam)
        for l in range(width):
            x = T[lam, l]
            if part == 0:
                T[small, l] = 1.0 / math.sqrt(x) if T[0, l] != 0.0 and x < math.inf else 0.0
            else:
                T[lam, l] = math.sqrt(x)
    for l in range(count):
        if kind == 1:
            out[o0 + l] = T[small, l]
        elif kind == 4:
            out[o0 + l] = T[lam, l]
        else:
            out[o0 + l] = T[lam, l] / T[small, l] if T[small, l] > 0.0 else math.inf


@kernel(inline="always")
def _bracket(
    T: np.ndarray, l: int, x_: int, lag: int, above: int, hi: int, lo: int, step: int, conv: int
) -> tuple[float, float, bool, float, float, float, bool]:  # pragma: no cover - compiled
    """Configuration l's point, Laguerre step, whether the point is above the largest eigenvalue, the bracket (top,
    bottom) with the point in it, the last step and whether it has converged (:func:`_laguerre`)."""
    x, s = T[x_, l], T[lag, l]
    up = T[above, l] > 0.0
    top = x if up else T[hi, l]
    bottom = T[lo, l] if up else x
    done = T[conv, l] > 0.0 or top - bottom <= 2e-14 * top
    return x, s, up, top, bottom, T[step, l], done


@kernel(inline="always")
def _tridiagonal(T: np.ndarray, G: int, r: int, width: int, a: int, b: int, e: int) -> None:  # pragma: no cover
    """The symmetric r x r matrices T[G + i r + j, l] (their lower triangle read; destroyed) of the ``width``
    configurations l to tridiagonal ones, by Householder reflections: the diagonal into rows a .. a + r - 1, the
    off-diagonal into rows b .. b + r - 2 (same eigenvalues); rows e .. e + 2 of T are work space."""
    beta, half, acc = e, e + 1, e + 2
    for k in range(r - 2):  # the reflector of column k below its diagonal, v stored over it; p, then w, in row k
        v = G + (k + 1) * r + k
        _strided_dot(T, acc, v, r, v, r, r - k - 1, False)
        for l in range(width):
            x = T[v, l]
            alpha, scale = _reflector(T[acc, l], x)
            T[beta, l] = scale
            T[v, l] = x - alpha
            T[a + k, l] = T[G + k * r + k, l]
            T[b + k, l] = alpha
        for i in range(k + 1, r):  # p = beta A v (A the trailing block)
            po = G + k * r + i  # A's lower triangle: A[i, j] for j <= i, A[j, i] after
            _strided_dot(T, po, G + i * r + k + 1, 1, v, r, i - k, False)
            _strided_dot(T, po, G + (i + 1) * r + i, r, G + (i + 1) * r + k, r, r - 1 - i, True)
            for l in range(width):
                T[po, l] *= T[beta, l]
        _strided_dot(T, acc, v, r, G + k * r + k + 1, 1, r - k - 1, False)  # v^T p
        for l in range(width):
            T[half, l] = 0.5 * T[beta, l] * T[acc, l]
        for i in range(k + 1, r):  # w = p - (beta v^T p / 2) v
            vo, po = G + i * r + k, G + k * r + i
            for l in range(width):
                T[po, l] -= T[half, l] * T[vo, l]
        for i in range(k + 1, r):  # A -= v w^T + w v^T, its lower triangle (one row written per pass: vectorised)
            for j in range(k + 1, i + 1):
                vi, vj, wi, wj = G + i * r + k, G + j * r + k, G + k * r + i, G + k * r + j
                ij = G + i * r + j
                for l in range(width):
                    T[ij, l] -= T[vi, l] * T[wj, l] + T[wi, l] * T[vj, l]
    for k in range(max(r - 2, 0), r):
        for l in range(width):
            T[a + k, l] = T[G + k * r + k, l]
    if r >= 2:
        for l in range(width):
            T[b + r - 2, l] = T[G + (r - 1) * r + r - 2, l]


@kernel(inline="always")
def _laguerre(T: np.ndarray, r: int, width: int, a: int, b: int, e: int, lam: int) -> None:  # pragma: no cover
    """T[lam, l] = the largest eigenvalue of the symmetric tridiagonal r x r matrices of the ``width`` configurations l
    (diagonal in rows a .., off-diagonal in rows b ..; both destroyed), by Laguerre's iteration from above (see
    :func:`jacobian_measure_lanes`); rows e .. e + 15 + 3 r of T are work space."""
    # Laguerre's iteration. Each pass over the configurations writes one row (LLVM vectorises a loop only when its
    # run-time alias checks are few): the pivots' reciprocals rho_i, then u_i = d_i' / d_i and w_i = d_i'' / d_i row by
    # row, then p'/p = sum u_i and -(p'/p)' = sum u_i^2 - w_i; the step's state in two sets of rows, old and new.
    g1, h1, above, lag = e, e + 1, e + 2, e + 3
    rho, u, w, slot, conv = e + 14, e + 14 + r, e + 14 + 2 * r, e + 14 + 3 * r, e + 15 + 3 * r
    for l in range(width):
        T[g1, l] = 0.0
        T[h1, l] = 0.0
    for i in range(r):
        for l in range(width):
            x = T[a + i, l]
            T[g1, l] += x * x
    for i in range(r - 1):
        for l in range(width):
            x = T[b + i, l]
            T[g1, l] += 2.0 * x * x
    for i in range(r - 1):
        for l in range(width):
            x = T[b + i, l]
            T[b + i, l] = x * x  # b_i^2 from here on
    for i in range(r):  # Gershgorin's bound: max a_i + |b_i-1| + |b_i|
        for l in range(width):
            y = T[a + i, l] + (math.sqrt(T[b + i - 1, l]) if i > 0 else 0.0) + (math.sqrt(T[b + i, l]) if i < r - 1 else 0.0)
            T[h1, l] = T[h1, l] if T[h1, l] > y else y
    x_, hi, lo, step, probed = e + 4, e + 5, e + 6, e + 7, e + 8  # the point tried, the bracket, Laguerre's last step
    nx, nhi, nlo, nstep, nprobed = e + 9, e + 10, e + 11, e + 12, e + 13
    for l in range(width):
        frobenius = math.sqrt(T[g1, l])
        x = 1.0001 * (frobenius if frobenius < T[h1, l] else T[h1, l])  # above both bounds: above every eigenvalue
        T[x_, l] = x  # the point tried
        T[hi, l] = x  # the lowest point tried above the largest eigenvalue (all pivots positive)
        T[lo, l] = 0.0  # the highest point tried at or below it (G is positive semidefinite)
        T[step, l] = 1e-30 * x  # Laguerre's last step (> 0 while the configuration iterates; none yet)
        T[probed, l] = 0.0
        T[slot, l] = l
    active = width  # the configurations still iterating: the first ``active`` columns (their own in ``slot``)
    for _step in range(120):
        for l in range(active):  # the pivots d_i of x I - T: their reciprocals
            T[rho, l] = 1.0 / (T[x_, l] - T[a, l])
        for i in range(1, r):
            for l in range(active):
                T[rho + i, l] = 1.0 / (T[x_, l] - T[a + i, l] - T[b + i - 1, l] * T[rho + i - 1, l])
        for l in range(active):  # u_i = d_i' / d_i (d_i' = 1 + b^2 d_i-1' / d_i-1^2)
            T[u, l] = T[rho, l]
        for i in range(1, r):
            for l in range(active):
                T[u + i, l] = (1.0 + T[b + i - 1, l] * T[u + i - 1, l] * T[rho + i - 1, l]) * T[rho + i, l]
        for l in range(active):  # w_i = d_i'' / d_i (d_i'' = b^2 (d_i-1'' d_i-1 - 2 d_i-1'^2) / d_i-1^3)
            T[w, l] = 0.0
        for i in range(1, r):
            for l in range(active):
                v = T[u + i - 1, l]
                T[w + i, l] = T[b + i - 1, l] * T[rho + i - 1, l] * (T[w + i - 1, l] - 2.0 * v * v) * T[rho + i, l]
        for l in range(active):
            T[g1, l] = 0.0
            T[h1, l] = 0.0
        for i in range(r):  # p'/p and -(p'/p)'; p'/p NaN unless every u_i (of the sign of d_i: d_i' >= 1) is positive
            for l in range(active):
                v = T[u + i, l]
                T[g1, l] += v if 0.0 < v < math.inf else math.nan
                T[h1, l] += v * v - T[w + i, l]
        for l in range(active):
            g = T[g1, l]
            T[above, l] = 1.0 if g < math.inf else 0.0  # above the largest eigenvalue: every pivot positive
            disc = (r - 1) * (r * T[h1, l] - g * g)
            T[lag, l] = r / (g + math.sqrt(disc if disc > 0.0 else 0.0))
        # Laguerre's step from a point above. Near a multiple or nearly multiple largest eigenvalue its square root
        # cancels to rounding, and a step may land below the largest eigenvalue (a pivot <= 0): that point bounds it
        # from below; the next try is just above it (the eigenvalue within 2e-14 of itself), then bisection of
        # [lo, hi] where Laguerre's step from hi does not land inside it. Converged: a step under 4e-16 x, or, while
        # the steps are Laguerre's and the root looks simple from x ((p'/p)^2 <= 1.05 (-(p'/p)'): x is far closer to
        # it than to any other root; near a pair or cluster the steps are not yet cubic, and with 1.5 a pair 1e-7
        # apart left errors of 1e-11 sigma_max), one whose cubic convergence predicts an error under 1e-17 x after it
        # (the next error ~ step^4 / previous step^3); the point is then the one the step reaches.
        # (one row written per pass, each reading at most eight: vectorised)
        for l in range(active):  # converged from above
            x, s, g = T[x_, l], T[lag, l], T[g1, l]
            last = T[step, l]
            up = g < math.inf
            cubic = T[probed, l] == 0.0 and g * g <= 1.05 * T[h1, l] and s * s * s * s <= 1e-17 * last * last * last * x
            T[conv, l] = 1.0 if up and (s <= 4e-16 * x or cubic) else 0.0
        for l in range(active):
            T[nhi, l] = T[x_, l] if T[step, l] > 0.0 and T[above, l] > 0.0 else T[hi, l]
        for l in range(active):
            T[nlo, l] = T[x_, l] if T[step, l] > 0.0 and T[above, l] <= 0.0 else T[lo, l]
        for l in range(active):
            T[nprobed, l] = 1.0 if T[above, l] <= 0.0 or T[probed, l] > 0.0 else 0.0
        for l in range(active):
            x, s, up, top, bottom, last, done = _bracket(T, l, x_, lag, above, hi, lo, step, conv)
            T[nstep, l] = (0.0 if done else (s if up else last)) if last > 0.0 else 0.0
        for l in range(active):
            x, s, up, top, bottom, last, done = _bracket(T, l, x_, lag, above, hi, lo, step, conv)
            probe = not up and T[probed, l] == 0.0
            trial = top - s if up else top - last
            middle = 0.5 * (bottom + top)
            trial = trial if up and trial > bottom else (bottom * (1.0 + 1e-14) if probe else middle)
            trial = trial if bottom < trial < top else middle
            T[nx, l] = ((top - s if up else top) if done else trial) if last > 0.0 else x
        x_, hi, lo, step, probed, nx, nhi, nlo, nstep, nprobed = nx, nhi, nlo, nstep, nprobed, x_, hi, lo, step, probed
        # the configurations still iterating moved to the front (their rows a, b^2 and state), the others' eigenvalue
        # written: the passes above then run over those only (about 2.5 iterations on average, 4-5 for the slowest of
        # 64 configurations)
        kept = 0
        for l in range(active):
            if T[step, l] > 0.0:
                if kept != l:
                    for i in range(r):
                        T[a + i, kept] = T[a + i, l]
                    for i in range(r - 1):
                        T[b + i, kept] = T[b + i, l]
                    for row in (x_, hi, lo, step, probed, slot):
                        T[row, kept] = T[row, l]
                kept += 1
            else:
                T[lam, int(T[slot, l])] = T[x_, l]
        active = kept
        if active == 0:
            break
    for l in range(active):
        T[lam, int(T[slot, l])] = T[x_, l]
