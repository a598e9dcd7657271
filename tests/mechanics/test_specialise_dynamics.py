"""H+, forward and inverse dynamics specialised like J* (issue "One engine a newcomer can extend", item 5): the same
one-configuration kernels traced (``_trace.ENTRY_POINTS``), batches of 64 or more served by them once made, results
equal to the generic kernels to rounding. Compiled into a temporary cache folder."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import freefloat as ff
from freefloat.engine import calls as _engine
from freefloat.engine.layout import tree
from freefloat.engine.specialise import build as _specialise
from trees import build_random_model

KINDS = ("hplus", "forward", "inverse")


@pytest.fixture
def own_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    monkeypatch.setenv("FREEFLOAT_CACHE_DIR", str(tmp_path))
    before = (_specialise.FOLDER[0], _specialise._ENABLED[0])
    _specialise.FOLDER[0] = tmp_path / "specialised"
    _specialise._FOUND.clear()
    try:
        yield
    finally:
        _specialise.FOLDER[0], _specialise._ENABLED[0] = before
        _specialise._FOUND.clear()
        _specialise._LOADED.clear()


def outputs(model: ff.Model, size: int, seed: int) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(seed)
    n = model.n_joints
    q, v, a = rng.uniform(-1.5, 1.5, (size, n)), rng.normal(size=(size, 6 + n)), rng.normal(size=(size, 6 + n))
    u, t0 = rng.normal(size=(size, n + 6)) * 10.0, Rotation.random(size, random_state=seed).as_matrix()
    acc, ok = _engine.accelerations(model, q, v, u, t0)
    return (
        _engine.inertia_matrix(model, q),
        acc,
        ok,
        _engine.residual_rows(model, q, v, a, u, t0),
        _engine.residual_rows(model, q, v, None, u, t0),
    )


def test_specialised_dynamics_equal_the_generic_kernels(own_cache: None) -> None:
    """A tree with a branch, a fixed joint and sliding joints (the paper systems and the 7-DOF arm were checked the
    same way when this was written: 2e-16 to 1e-12 relative)."""
    model = build_random_model(np.random.default_rng(5), [2, 2], [0, None], [1, None], prismatic=0.5)
    assert model.has_prismatic
    generic = outputs(model, 300, 1)  # the suite runs on the generic kernels (tests/conftest.py)
    _specialise._ENABLED[0] = True
    ff.mechanics.specialise(model, KINDS)
    assert all(_specialise.find(tree(model), kind) is not None for kind in KINDS)
    calls: list[str] = []
    real = _specialise.mapped
    _specialise.mapped = lambda module, *args: (calls.append(module.__name__), real(module, *args))[1]  # type: ignore[assignment]
    try:
        fast = outputs(model, 300, 1)
        small = outputs(model, 3, 2)  # below the specialised kernels' batch size: the generic kernels
    finally:
        _specialise.mapped = real  # type: ignore[assignment]
    assert len(calls) == 4  # H+, forward, and both inverse calls of the large batch; none of the small one
    h, acc, ok, rows, rows0 = generic
    for ours, ref in ((fast[0], h), (fast[1], acc), (fast[3], rows), (fast[4], rows0)):
        scale = np.max(np.abs(ref), axis=tuple(range(1, ref.ndim)), keepdims=True)
        assert np.max(np.abs(ours - ref) / scale) <= 1e-12
    assert np.array_equal(fast[2], ok) and ok.all()
    _specialise._ENABLED[0] = False
    np.testing.assert_allclose(small[1], outputs(model, 3, 2)[1], rtol=0, atol=0)  # the small batch ran generic
