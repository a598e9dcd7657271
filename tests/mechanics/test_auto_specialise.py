"""Specialised when it pays, without being asked (issue "One engine a newcomer can extend", item 4).

A process that has spent AUTO_AFTER seconds of generic J* work on one structure specialises it in a background
thread, says so once, and later calls use it; a small call never triggers it; FREEFLOAT_AUTO_SPECIALISE=0 and
ff.mechanics.auto_specialise(False) turn it off; the results equal the generic kernel's to rounding. Everything
here compiles into a temporary cache folder (never the user's).
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numba
import numpy as np
import pytest

import freefloat as ff
from freefloat.engine import threads as _threads
from freefloat.engine.layout import tree
from freefloat.engine.specialise import build as _specialise
from freefloat.engine.specialise.lanes import LANES


@pytest.fixture
def auto(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """Automatic specialisation on, in a cache of this test's own, with a threshold a test can reach in a second."""
    monkeypatch.setenv("FREEFLOAT_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv(_specialise.AUTO_ENV, "1")
    monkeypatch.setitem(_specialise.AUTO_AFTER, "jstar", 0.05)
    monkeypatch.setattr(_specialise, "_STARTED", {})
    before = (_specialise.FOLDER[0], _specialise._ENABLED[0], _specialise._AUTO[0])
    _specialise.FOLDER[0] = tmp_path / "specialised"
    _specialise._ENABLED[0] = True  # the suite runs on the generic kernels (tests/conftest.py)
    _specialise._AUTO[0] = True
    _specialise._FOUND.clear()
    _specialise._SPENT.clear()
    try:
        yield
    finally:
        assert _specialise.wait_for_auto(300)
        _specialise.FOLDER[0], _specialise._ENABLED[0], _specialise._AUTO[0] = before
        _specialise._FOUND.clear()
        _specialise._LOADED.clear()


def two_arm_variant() -> ff.Model:
    """A structure no other test specialises: the 1992 two-arm system with a payload on arm 2 (a new end-effector point)."""
    return ff.models.papadopoulos1992().with_payload(1, mass=123.0, inertia=4.5, offset=[0.05, 0.0, 0.0])


def test_a_large_sweep_triggers_it_and_results_do_not_change(auto: None, capsys: pytest.CaptureFixture[str]) -> None:
    model = two_arm_variant()
    t = tree(model)
    q = np.random.default_rng(0).uniform(-3, 3, (20000, model.n_joints))
    generic = ff.generalized_jacobian(model, q)
    while _specialise._SPENT.get(t, {}).get(("jstar", ()), 0.0) < _specialise.AUTO_AFTER["jstar"]:
        ff.generalized_jacobian(model, q)
    assert len(_specialise._STARTED) == 1
    assert _specialise.wait_for_auto(300)
    said = capsys.readouterr().err
    assert said.count("specialising J* for this model structure in the background") == 1, said
    assert "FREEFLOAT_AUTO_SPECIALISE=0" in said
    assert _specialise.find(t, "jstar") is not None  # later calls use it
    fast = ff.generalized_jacobian(model, q)
    scale = np.max(np.abs(generic), axis=(-1, -2), keepdims=True)
    assert np.max(np.abs(fast - generic) / scale) <= 1e-12
    assert list((Path(str(_specialise._folder()))).glob("jstar_*.py"))  # kept on disk for the next process


def test_a_small_call_never_triggers_it(auto: None) -> None:
    model = two_arm_variant()
    for _ in range(2000):  # many small calls: below the specialised kernels' batch size, not counted
        ff.generalized_jacobian(model, np.zeros((8, model.n_joints)))
    assert _specialise._STARTED == {} and _specialise.find(tree(model), "jstar") is None


@pytest.mark.parametrize("how", ["environment", "function"])
def test_it_can_be_turned_off(auto: None, monkeypatch: pytest.MonkeyPatch, how: str) -> None:
    if how == "environment":
        monkeypatch.setenv(_specialise.AUTO_ENV, "0")
    else:
        assert ff.mechanics.auto_specialise(False) is False
    model = two_arm_variant()
    q = np.random.default_rng(1).uniform(-3, 3, (20000, model.n_joints))
    for _ in range(20):
        ff.generalized_jacobian(model, q)
    assert _specialise._STARTED == {}
    if how == "function":
        assert ff.mechanics.auto_specialise(True) is True


def test_dynamics_with_wrenches_trigger_their_layout(
    auto: None, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Generic forward dynamics under external wrenches count towards the kernels of their layout (bodies, frames)."""
    monkeypatch.setitem(_specialise.AUTO_AFTER, "forward", 0.05)
    model = two_arm_variant()
    t = tree(model)
    rng = np.random.default_rng(2)
    q, v = rng.uniform(-3, 3, (5000, model.n_joints)), rng.normal(size=(5000, 6 + model.n_joints))
    external = [ff.ExternalWrench(model.body_names[-1], force=rng.normal(size=(5000, 3)), frame="body")]
    layout = ((model.n_bodies - 1, 2),)
    generic = ff.forward_dynamics(model, q, v, external=external)
    while _specialise._SPENT.get(t, {}).get(("forward", layout), 0.0) < _specialise.AUTO_AFTER["forward"]:
        ff.forward_dynamics(model, q, v, external=external)
    assert _specialise.wait_for_auto(300)
    assert "specialising forward dynamics with 1 external wrench for this model structure" in capsys.readouterr().err
    assert ff.mechanics.is_specialised(model, "forward", external=external)
    assert not ff.mechanics.is_specialised(model, "forward")  # the layout without wrenches is another
    fast = ff.forward_dynamics(model, q, v, external=external)
    scale = np.max(np.abs(generic), axis=-1, keepdims=True)
    assert np.max(np.abs(fast - generic) / scale) <= 1e-12


def test_a_large_map_of_measures_triggers_the_measure_kernel(auto: None, monkeypatch: pytest.MonkeyPatch) -> None:
    """The measures count towards their own kind ("measure"), as J* does towards "jstar"; the results do not change."""
    monkeypatch.setitem(_specialise.AUTO_AFTER, "measure", 0.05)
    model = two_arm_variant()
    t = tree(model)
    q = np.random.default_rng(1).uniform(-3, 3, (20000, model.n_joints))
    generic = ff.jacobian_determinant(model, q)
    while _specialise._SPENT.get(t, {}).get(("measure", ()), 0.0) < _specialise.AUTO_AFTER["measure"]:
        ff.jacobian_determinant(model, q)
    assert _specialise.wait_for_auto(300)
    assert _specialise.find(t, "measure") is not None and _specialise.find(t, "jstar") is None
    fast = ff.jacobian_determinant(model, q)
    np.testing.assert_allclose(fast, generic, rtol=1e-11, atol=1e-14 * np.abs(generic).max())


def test_a_large_call_runs_the_module_on_one_range_per_thread(auto: None, monkeypatch: pytest.MonkeyPatch) -> None:
    """Once its kernel is compiled (``ready``), the calls use a specialised module: one of THREADS_FROM configurations or
    more on one contiguous range of lane blocks per numba thread at once (``_threads.run_kernel``: numba's threads call
    the module's machine code; no threaded twin of the kernel is compiled), a smaller one on the whole batch in the
    calling thread. Both agree with the generic kernel."""
    model = two_arm_variant()
    t = tree(model)
    big = np.random.default_rng(3).uniform(-3, 3, (_specialise.THREADS_FROM + 5, model.n_joints))
    small = big[: _specialise.THREADS_FROM - 1]
    generic = ff.generalized_jacobian(model, big)
    seen: list[tuple[int, int, int]] = []
    real, fan_out = _specialise.run_kernel, _threads._fan_out
    fanned: list[int] = []

    def counted(*args: Any) -> int:
        fanned.append(args[-1].shape[0])  # the ranges handed to numba's threads
        return int(fan_out(*args))

    def spy(run: Any, pre: Any, work: np.ndarray, post: Any, count: int, parts: int) -> None:
        fanned.clear()
        real(run, pre, work, post, count, parts)
        seen.append((count, parts, fanned[0] if fanned else 1))

    monkeypatch.setattr(_specialise, "run_kernel", spy)
    monkeypatch.setattr(_threads, "_fan_out", counted)
    ready: list[str] = []
    _specialise.specialise(t, ("jstar",), ready=ready.append)
    assert ready == ["jstar"] and seen == [(1, 1, 1)]  # compiled on one block
    seen.clear()
    before = numba.get_num_threads()
    numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))  # type: ignore[attr-defined]
    try:
        threads = numba.get_num_threads()
        fast_big, fast_small = ff.generalized_jacobian(model, big), ff.generalized_jacobian(model, small)
    finally:
        numba.set_num_threads(before)
    blocks = -(-big.shape[0] // LANES)
    assert seen == [(blocks, threads, threads), (-(-small.shape[0] // LANES), 1, 1)]
    scale = np.max(np.abs(generic), axis=(-1, -2), keepdims=True)
    for fast, ref in ((fast_big, generic), (fast_small, generic[: small.shape[0]])):
        assert np.max(np.abs(fast - ref) / scale[: ref.shape[0]]) <= 1e-12
