"""The singularity measures inside the engine's kernel (issue "One engine a newcomer can extend", item 3).

``ff.mechanics.jacobian_measure`` computes det (LU), the smallest singular value, the manipulability (the product of
the singular values) and the condition number of chosen rows of J* per configuration, without writing J*. Checked
against numpy's det and SVD of the J* of the same configurations on the paper systems, the 7-DOF arm, the Panda and
random trees, at batch sizes across every threshold of the drivers, near-singular configurations included.
"""

from __future__ import annotations

from collections.abc import Iterator

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import freefloat as ff
from freefloat.engine import drivers as _drivers
from freefloat.engine.layout import tree
from freefloat.engine.measures import MEASURE_CODES, jacobian_measure_lanes, measure_work
from freefloat.engine.specialise import build as _specialise
from freefloat.engine.specialise import lanes as _lanes
from robots import REAL_ROBOTS, load_real, spacecraft_urdf
from trees import random_trees

#: Agreement with numpy relative to each value (numpy's smallest singular value refined, see numpy_measure).
RTOL = 1e-10
LANES = _lanes.LANES
#: Around every threshold of the generic measure's driver: a lane block (LANES configurations: one measured at once, the
#: last one shorter) and the threads (from measure_batch.PARALLEL_MIN lane blocks).
PARALLEL = _drivers.measure_batch.PARALLEL_MIN * LANES
SIZES = (1, 3, LANES - 1, LANES, LANES + 1, PARALLEL - LANES, PARALLEL - LANES + 1, 4 * LANES + 3)


def numpy_measure(jac: np.ndarray, measure: str) -> np.ndarray:
    """numpy's det, or the singular values from numpy's SVD with the smallest refined as ||u_min^T A|| (K <= N) or
    ||A v_min|| (K > N): accurate relative to itself, which numpy's own smallest singular value is not near a
    singularity (its error is eps sigma_max)."""
    if measure == "det":
        return np.linalg.det(jac)
    u, sv, vt = np.linalg.svd(jac)
    sv = sv.copy()
    if jac.shape[-2] <= jac.shape[-1]:
        sv[..., -1] = np.linalg.norm(np.einsum("...i,...ij->...j", u[..., :, jac.shape[-2] - 1], jac), axis=-1)
    else:
        sv[..., -1] = np.linalg.norm(np.einsum("...ij,...j->...i", jac, vt[..., jac.shape[-1] - 1, :]), axis=-1)
    if measure == "sigma_min":
        return sv[..., -1]
    if measure == "sigma_max":
        return sv[..., 0]
    if measure == "manipulability":
        return np.prod(sv, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return sv[..., 0] / sv[..., -1]


#: The conditioning floor: no algorithm that starts from J* in float64 gets a singular value closer than about
#: eps sigma_max (numpy's SVD included), so near a singularity the comparison allows that much absolute error.
FLOOR = 64 * np.finfo(float).eps


def check(model: ff.Model, q: np.ndarray, rows: np.ndarray, measures: tuple[str, ...]) -> None:
    """Each measure by ff.mechanics.jacobian_measure against numpy's (:func:`agree`)."""
    for measure in measures:
        ours = ff.mechanics.jacobian_measure(model, q, rows, measure)
        assert ours.shape == q.shape[:-1]
        agree(ours, ff.generalized_jacobian(model, q)[..., rows, :], measure)


def agree(ours: np.ndarray, jac: np.ndarray, measure: str) -> None:
    """|ours - ref| <= RTOL |ref| + the conditioning floor, ref numpy's measure of ``jac`` (FLOOR sigma_max for
    sigma_min; for det and the product, FLOOR times sigma_max times the product of the other singular values: what a
    perturbation of J* by eps sigma_max changes them by). The condition number only where J* is well conditioned."""
    sv = np.linalg.svd(jac, compute_uv=False)
    others = sv[..., 0] * np.prod(sv[..., :-1], axis=-1)
    ref = numpy_measure(jac, measure)
    if measure in ("det", "manipulability"):
        allowed = RTOL * np.abs(ref) + FLOOR * others
    elif measure in ("sigma_min", "sigma_max"):
        allowed = RTOL * ref + FLOOR * sv[..., 0]
    else:
        keep = sv[..., -1] > 1e-6 * sv[..., 0]
        ours, ref = ours[keep], ref[keep]
        allowed = RTOL * ref
    with np.errstate(invalid="ignore", divide="ignore"):  # nothing allowed (a zero matrix): equal exactly
        excess = np.where(allowed > 0.0, np.abs(ours - ref) / allowed, np.where(ours == ref, 0.0, np.inf))
    assert np.all(excess <= 1.0), (measure, float(np.max(excess)))


def panda() -> ff.Model:
    import tempfile
    from pathlib import Path

    relative, ees = REAL_ROBOTS["panda"]
    with tempfile.TemporaryDirectory() as folder:
        return load_real("panda", spacecraft_urdf(relative, Path(folder)), end_effectors=ees)


@pytest.mark.parametrize("size", SIZES)
def test_measures_of_the_paper_systems_and_the_7dof_arm_at_every_batch_size(size: int) -> None:
    rng = np.random.default_rng(size)
    planar = ff.models.papadopoulos1992()
    check(planar, rng.uniform(-3, 3, (size, 4)), np.array([0, 1, 6, 7]), ("det", "sigma_min", "manipulability", "condition", "sigma_max"))
    check(ff.models.papadopoulos1991(), rng.uniform(-3, 3, (size, 2)), np.array([0, 1]), ("det", "sigma_min", "condition"))
    arm = ff.models.spacecraft_7dof()
    q = rng.uniform(-3, 3, (size, 7))
    check(arm, q, np.arange(6), ("sigma_min", "manipulability", "condition", "sigma_max"))
    check(arm, q, np.array([0, 1, 2]), ("sigma_min", "manipulability", "condition"))


def test_measures_of_the_panda() -> None:
    model = panda()
    rng = np.random.default_rng(3)
    lo, hi = model.joint_lower, model.joint_upper
    q = rng.uniform(lo, hi, (300, model.n_joints))
    check(model, q, np.arange(6), ("sigma_min", "manipulability", "condition", "sigma_max"))


def test_measures_near_singular_configurations() -> None:
    """Configurations 1e-3 .. 1e-9 rad from a singularity (located by numpy alone): det J* of the 1992 one-arm system
    on either side of a root of det J*, and the 7-DOF arm near a minimum of sigma_min found by scipy on numpy's SVD.
    The measures go to zero with the distance and stay accurate relative to themselves."""
    from scipy.optimize import brentq, minimize

    planar = ff.models.papadopoulos1992(arms=1)
    rows = np.array([0, 1])
    base, step = np.array([0.3, -1.0]), np.array([0.0, 1.0])

    def det(t: float) -> float:
        return float(np.linalg.det(ff.generalized_jacobian(planar, base + t * step)[rows]))

    root = brentq(det, 0.0, 2.0, xtol=1e-15)
    offsets = 10.0 ** -np.arange(3, 10)
    q = base + (root + np.concatenate([offsets, -offsets]))[:, None] * step
    check(planar, q, rows, ("det", "sigma_min", "manipulability"))
    near = np.abs(ff.mechanics.jacobian_measure(planar, q, rows, "det"))
    assert np.all(np.diff(np.log10(near[:7])) < -0.9)  # det proportional to the distance

    arm = ff.models.spacecraft_7dof()

    def smallest(x: np.ndarray) -> float:
        return float(np.linalg.svd(ff.generalized_jacobian(arm, x)[:6], compute_uv=False)[-1])

    found = minimize(smallest, np.full(7, 0.4), method="Nelder-Mead", options={"xatol": 1e-12, "fatol": 1e-14, "maxiter": 4000})
    assert found.fun < 1e-4
    direction = np.random.default_rng(1).normal(size=7)
    q = found.x + (offsets / np.linalg.norm(direction))[:, None] * direction
    ours = ff.mechanics.jacobian_measure(arm, q, np.arange(6), "sigma_min")
    jac = ff.generalized_jacobian(arm, q)[:, :6]
    u, _, _ = np.linalg.svd(jac)
    refined = np.linalg.norm(np.einsum("ci,cij->cj", u[:, :, -1], jac), axis=-1)  # ||A^T u_min||: accurate relative to itself
    assert np.all(np.abs(ours - refined) <= 1e-10 * refined + FLOOR * 3.0)  # sigma_max of these rows is about 3
    check(arm, q, np.arange(6), ("sigma_min", "manipulability", "condition"))


@given(random_trees(), st.integers(0, 2**31 - 1))
@settings(max_examples=40, deadline=None)
def test_measures_of_random_trees(model: ff.Model, seed: int) -> None:
    rng = np.random.default_rng(seed)
    q = rng.uniform(-2, 2, (5, model.n_joints))
    rows = np.sort(rng.choice(6 * model.n_end_effectors, size=min(model.n_joints, 6 * model.n_end_effectors), replace=False))
    measures = (
        ("det", "sigma_min", "manipulability", "condition", "sigma_max")
        if rows.size == model.n_joints
        else ("sigma_min", "manipulability", "sigma_max")
    )
    check(model, q, rows, measures)


def hard_matrices(k: int, n: int, rng: np.random.Generator) -> np.ndarray:
    """LANES K x N matrices with the singular values that are hardest for the measure kernel's iteration (a largest
    eigenvalue of R^-1 R^-T that is multiple or nearly so) or its QR (a zero pivot): all equal, equal in pairs, the two
    smallest 1e-9 apart, graded to 1e-12, exactly rank deficient, all within 1e-9 of each other, zero, and plain
    Gaussian."""
    r = min(k, n)
    spectra = [
        np.full(r, 2.5),
        np.repeat(10.0 ** -np.arange(0, r, 2), 2)[:r],
        np.r_[np.linspace(3.0, 1.0, r - 2), 1e-4 * (1 + 1e-9), 1e-4] if r >= 3 else np.array([1.0, 1.0 - 1e-9])[:r],
        np.logspace(0, -12, r),
        np.r_[np.ones(r - 1), 0.0],
        0.7 * (1.0 + 1e-9 * np.arange(r)),
    ]
    mats = []
    for i in range(LANES):
        if i % 8 == 6:
            mats.append(np.zeros((k, n)))
        elif i % 8 == 7:
            mats.append(rng.normal(size=(k, n)))
        else:
            u = np.linalg.qr(rng.normal(size=(k, k)))[0][:, :r]
            v = np.linalg.qr(rng.normal(size=(n, n)))[0][:, :r]
            mats.append(u @ np.diag(rng.permutation(spectra[i % 8])) @ v.T)
    return np.array(mats)


@numba.njit(cache=False, error_model="numpy")  # as the engine's kernels: 1/0 is inf
def _measure_lane_block(mats: np.ndarray, kind: int, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """The engine's measure of LANES matrices (LANES, K, N) side by side, as the kernels lay out a block of J*s."""
    width, k, n = mats.shape
    W = np.empty(k * n * width)
    for l in range(width):
        for i in range(k):
            for j in range(n):
                W[(i * n + j) * width + l] = mats[l, i, j]
    jacobian_measure_lanes(W, 0, width, n, np.arange(k), kind, np.empty(measure_work(n) * width), out, 0, width)


@pytest.mark.parametrize("shape", [(6, 7), (4, 4), (3, 7), (7, 6), (1, 5), (2, 2)])
def test_singular_values_of_hard_matrices(shape: tuple[int, int]) -> None:
    """The singular-value measures of the kernel itself on :func:`hard_matrices` (multiple and nearly multiple
    singular values, rank deficiency, zero) against numpy's refined SVD; the condition number is inf exactly where
    sigma_min is 0."""
    mats = hard_matrices(*shape, np.random.default_rng(sum(shape)))
    results = {}
    for measure in ("sigma_min", "sigma_max", "manipulability", "condition"):
        out = np.full(LANES, np.nan)
        _measure_lane_block(mats, MEASURE_CODES[measure], out)
        agree(out, mats, measure)
        results[measure] = out
    zero = results["sigma_min"] == 0.0
    assert zero.any() and np.all(np.isinf(results["condition"][zero])) and np.all(np.isfinite(results["condition"][~zero]))


@pytest.mark.parametrize("shape", [(6, 7), (3, 7), (7, 6), (2, 2)])
def test_singular_values_with_close_pairs(shape: tuple[int, int]) -> None:
    """The smallest two (and, in every other matrix, the largest two) singular values 1e-6 to 1e-9 apart, sigma_min
    1e-3, to FLOOR sigma_max (a few ulps, as numpy's SVD; tighter than :func:`agree`): the iteration's early stop
    (from the cubic rate) must wait until the point is far closer to the largest eigenvalue than to its neighbour
    (with a looser test, 3 x 7 matrices with pairs 1e-7 apart were off by 1e-11 sigma_max)."""
    k, n = shape
    r = min(k, n)
    rng = np.random.default_rng(11 + k * n)
    for gap in (1e-6, 1e-7, 1e-8, 1e-9):
        mats = []
        for i in range(LANES):
            u = np.linalg.qr(rng.normal(size=(k, k)))[0][:, :r]
            v = np.linalg.qr(rng.normal(size=(n, n)))[0][:, :r]
            spectrum = rng.uniform(0.5, 3.0, r)
            spectrum[-1] = 1e-3
            if r > 1:
                spectrum[-2] = 1e-3 * (1.0 + gap)
            if r > 2 and i % 2:
                spectrum[0] = spectrum[1] * (1.0 + gap)
            mats.append(u @ np.diag(spectrum) @ v.T)
        sv = np.linalg.svd(np.array(mats), compute_uv=False)
        for measure, ref in (("sigma_min", sv[:, -1]), ("sigma_max", sv[:, 0])):
            out = np.full(LANES, np.nan)
            _measure_lane_block(np.array(mats), MEASURE_CODES[measure], out)
            excess = float(np.max(np.abs(out - ref) / (FLOOR * sv[:, 0])))  # as numpy's SVD: a few ulps of sigma_max
            assert excess <= 1.0, (measure, gap, excess)


def test_the_map_and_search_paths_use_the_kernel(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every public call that needs a measure reaches the measure kernel, not a J* batch and numpy."""
    import freefloat.engine as _engine  # the door: the calls the rest of freefloat makes

    calls: list[str] = []
    real = _engine.jacobian_measures

    def spy(model: ff.Model, q: np.ndarray, rows: object, measure: str, out: np.ndarray | None = None) -> np.ndarray:
        calls.append(measure)
        return real(model, q, rows, measure, out)

    monkeypatch.setattr(_engine, "jacobian_measures", spy)
    model = ff.models.papadopoulos1992(arms=1)
    ff.jacobian_determinant(model, [0.1, 0.2])
    ff.workspace.singularity_measure(model, np.zeros((3, 2)))
    ff.workspace.jacobian_determinant_map(model, n=5)
    before = len(calls)
    ff.workspace.path_independent_workspace(model, 0, samples=256)
    assert calls.count("det") >= 4, calls
    assert "sigma_max" in calls[before:], calls  # the search's test of "on the singular set" (|det J*| / sigma_max^m)


def test_bad_rows_and_measures_are_refused() -> None:
    model = ff.models.spacecraft_7dof()
    with pytest.raises(ValueError, match="measure: expected one of"):
        ff.mechanics.jacobian_measure(model, np.zeros(7), None, "volume")
    with pytest.raises(ValueError, match="rows: expected distinct indices"):
        ff.mechanics.jacobian_measure(model, np.zeros(7), [0, 6], "sigma_min")
    with pytest.raises(ValueError, match="rows: expected distinct indices"):
        ff.mechanics.jacobian_measure(model, np.zeros(7), [0, 1, 1], "sigma_min")  # a repeated row: refused, not singular
    with pytest.raises(ff.ShapeError, match="not square"):
        ff.mechanics.jacobian_measure(model, np.zeros(7), None, "det")


# ----------------------------------------------------------------- the specialised kernels (kind "measure")
@pytest.fixture(scope="module")
def specialised(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[ff.Model, ff.Model]]:
    """The measures specialised for the 1992 two-arm system and the 7-DOF arm, in a cache folder of this module's own
    (``FREEFLOAT_CACHE_DIR``, a temporary folder: never the user's cache), specialised kernels on."""
    with pytest.MonkeyPatch.context() as env:
        env.setenv("FREEFLOAT_CACHE_DIR", str(tmp_path_factory.mktemp("freefloat-cache")))
        before = _specialise.FOLDER[0]
        _specialise.FOLDER[0] = None
        _specialise._LOADED.clear()
        _specialise._ENABLED[0] = True
        _specialise._FOUND.clear()
        try:
            models = (ff.models.papadopoulos1992(), ff.models.spacecraft_7dof())
            for model in models:
                assert not ff.mechanics.is_specialised(model, "measure")
                ff.mechanics.specialise(model, ["measure"])
                assert ff.mechanics.is_specialised(model, "measure")
            yield models
        finally:
            _specialise.FOLDER[0] = before
            _specialise._ENABLED[0] = False
            _specialise._LOADED.clear()
            _specialise._FOUND.clear()


#: (model index in the fixture, rows, measures): square rows (det), K < N, K > N (all 12 rows of the planar system).
CASES = (
    (0, np.array([0, 1, 6, 7]), ("det", "sigma_min", "manipulability", "condition")),
    (0, np.arange(12), ("sigma_min", "manipulability", "sigma_max")),
    (1, np.arange(6), ("sigma_min", "manipulability", "condition")),
    (1, np.array([0, 1, 2]), ("sigma_min", "manipulability", "condition")),
    (1, np.array([5, 3, 4, 0]), ("sigma_min", "condition", "sigma_max")),
)


def run_specialised(model: ff.Model, q: np.ndarray, rows: np.ndarray, measure: str, threads: bool) -> np.ndarray:
    """The specialised kernel's driver ``blocks`` on the whole batch, or on two ranges of blocks at once (two threads), called
    directly (any batch size, even below the engine's minimum for threads)."""
    from freefloat.engine.measures import MEASURE_CODES

    t = tree(model)
    module = _specialise.find(t, "measure")
    assert module is not None
    data = _specialise.data_vector(t)[module.SLOTS]
    out = np.full(q.shape[0], np.nan)
    args = (np.ascontiguousarray(q), data, rows.astype(np.int64), MEASURE_CODES[measure], out)
    _specialise._run(module, q.shape[0], args, threads=2 if threads else 1)
    return out


@pytest.mark.parametrize("size", (1, LANES - 1, LANES, LANES + 1, 2 * LANES - 1, 4 * LANES + 3))
@pytest.mark.parametrize("threads", [False, True], ids=["serial", "parallel"])
def test_specialised_measures_equal_numpy_at_every_block_size(specialised: tuple[ff.Model, ...], size: int, threads: bool) -> None:
    rng = np.random.default_rng(size)
    for which, rows, measures in CASES:
        model = specialised[which]
        q = rng.uniform(-3, 3, (size, model.n_joints))
        jac = ff.generalized_jacobian(model, q)[:, rows, :]
        for measure in measures:
            agree(run_specialised(model, q, rows, measure, threads), jac, measure)


@pytest.mark.parametrize("size", (LANES, LANES + 1, 4 * LANES + 3, _specialise.THREADS_FROM + 3))
def test_the_engine_uses_the_specialised_kernel(specialised: tuple[ff.Model, ...], size: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """The public measure runs on the specialised kernel from the engine's minimum batch (serial, then threaded), agrees
    with numpy and with the generic kernel; a payload variant shares the kernel and its mass is read, not folded."""
    calls: list[int] = []
    real = _specialise.measured

    def spy(*args: object) -> None:
        calls.append(1)
        real(*args)  # type: ignore[arg-type]

    monkeypatch.setattr(_specialise, "measured", spy)
    rng = np.random.default_rng(7 + size)
    for which, rows, measures in CASES:
        model = specialised[which]
        q = rng.uniform(-3, 3, (size, model.n_joints))
        for measure in measures:
            before = len(calls)
            fast = ff.mechanics.jacobian_measure(model, q, rows, measure)
            assert len(calls) == before + 1  # the specialised path ran
            agree(fast, ff.generalized_jacobian(model, q)[:, rows, :], measure)
            with _specialise.generic():
                slow = ff.mechanics.jacobian_measure(model, q, rows, measure)
            assert len(calls) == before + 1
            np.testing.assert_allclose(fast, slow, rtol=1e-11)
    heavy = specialised[0].with_payload(mass=150.0, inertia=np.diag([5.0, 6.0, 7.0]))
    q = rng.uniform(-3, 3, (size, 4))
    fast = ff.jacobian_determinant(heavy, q)
    agree(fast, ff.generalized_jacobian(heavy, q)[:, [0, 1, 6, 7], :], "det")
    assert np.abs(fast - ff.jacobian_determinant(specialised[0], q)).max() > 1e-3


def test_the_smallest_singular_value_of_all_rows_runs_the_traced_reduction(specialised: tuple[ff.Model, ...]) -> None:
    """sigma_min of all the rows of J*, in order, runs the engine's reduction traced for the structure
    (:func:`~freefloat.engine.specialise.build.trace_reduction`): the block's rows of J* stay as the lane kernel wrote
    them. Other rows (the same ones in another order) or another measure run the compiled measure, which reduces the
    chosen rows in place. Each agrees with numpy."""
    from freefloat.engine.measures import MEASURE_CODES

    rng = np.random.default_rng(5)
    for model in specialised:
        t = tree(model)
        module = _specialise.find(t, "measure")
        assert module is not None
        n, k = model.n_joints, 6 * model.n_end_effectors
        q = rng.uniform(-3, 3, (LANES, n))
        jac = ff.generalized_jacobian(model, q)
        for rows, measure, traced in (
            (np.arange(k), "sigma_min", True),
            (np.arange(k)[::-1].copy(), "sigma_min", False),
            (np.arange(k), "condition", False),
        ):
            work = np.zeros(module.ROWS * LANES)
            out = np.full(LANES, np.nan)
            module.blocks(q, _specialise.data_vector(t)[module.SLOTS], rows, MEASURE_CODES[measure], out, work, 0, 1)
            block = work[n * LANES : (n + k * n) * LANES].reshape(k, n, LANES).transpose(2, 0, 1)  # J* of each lane
            assert np.allclose(block, jac, rtol=1e-12, atol=1e-12) == traced, (n, rows, measure)
            agree(out, jac[:, rows, :], measure)


def near_singular() -> list[tuple[ff.Model, np.ndarray, np.ndarray, tuple[str, ...]]]:
    """Configurations 1e-3 .. 1e-9 rad from a singularity (located by numpy alone): det J* of the 1992 two-arm system
    (arm 2 held) on either side of a root, and the 7-DOF arm near a minimum of sigma_min found by scipy on numpy's SVD."""
    from scipy.optimize import brentq, minimize

    offsets = 10.0 ** -np.arange(3, 10)
    planar = ff.models.papadopoulos1992()
    rows = np.array([0, 1, 6, 7])
    base, step = np.array([0.3, -1.0, 0.7, 1.1]), np.array([0.0, 1.0, 0.0, 0.0])

    def det(t: float) -> float:
        return float(np.linalg.det(ff.generalized_jacobian(planar, base + t * step)[rows]))

    root = brentq(det, 0.0, 2.0, xtol=1e-15)
    q_planar = base + (root + np.concatenate([offsets, -offsets]))[:, None] * step
    arm = ff.models.spacecraft_7dof()

    def smallest(x: np.ndarray) -> float:
        return float(np.linalg.svd(ff.generalized_jacobian(arm, x)[:6], compute_uv=False)[-1])

    found = minimize(smallest, np.full(7, 0.4), method="Nelder-Mead", options={"xatol": 1e-12, "fatol": 1e-14, "maxiter": 4000})
    assert found.fun < 1e-4
    direction = np.random.default_rng(1).normal(size=7)
    q_arm = found.x + (offsets / np.linalg.norm(direction))[:, None] * direction
    return [
        (planar, q_planar, rows, ("det", "sigma_min", "manipulability")),
        (arm, q_arm, np.arange(6), ("sigma_min", "manipulability", "condition")),
    ]


def test_specialised_measures_near_singular_configurations(specialised: tuple[ff.Model, ...]) -> None:
    """The near-singular configurations in every lane of a block (tiled past the engine's minimum, with random ones
    between) through the public path: the measures go to zero with the distance and agree with numpy."""
    rng = np.random.default_rng(11)
    for model, near, rows, measures in near_singular():
        q = np.concatenate([np.tile(near, (LANES // near.shape[0] + 1, 1)), rng.uniform(-3, 3, (3 * LANES + 5, model.n_joints))])
        jac = ff.generalized_jacobian(model, q)[:, rows, :]
        for measure in measures:
            ours = ff.mechanics.jacobian_measure(model, q, rows, measure)
            agree(ours, jac, measure)
            if measure in ("det", "sigma_min"):
                small = np.abs(ours[: near.shape[0] // 2 if model.n_joints == 4 else near.shape[0]])
                assert np.all(np.diff(np.log10(small)) < -0.9), small  # proportional to the distance


def test_cli_specialises_the_measures(specialised: tuple[ff.Model, ...]) -> None:
    from typer.testing import CliRunner

    from freefloat.cli import app

    result = CliRunner().invoke(app, ["specialise", "spacecraft_7dof", "--kind", "measure"])
    assert result.exit_code == 0, result.output
    assert result.stdout.startswith("measure: ready in ")
