"""``out=`` on the batched calls: the caller's array receives the result (the numbers of a call without it), is the
array returned, and is written again by the next call; a bad one (shape, dtype, layout, read-only, sharing memory with
an input, a method that makes its own arrays) is refused before any kernel runs, with an error naming ``out`` and the
fix. On the generic kernels and on those specialised to the model's structure. ``ff.mechanics.release_buffers`` is
deprecated (there is no pool of outputs any more)."""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest

import freefloat as ff
from freefloat.core.errors import ShapeError
from freefloat.engine import calls as _engine
from freefloat.engine.specialise import build as _specialise
from spies import count_calls


@dataclass(frozen=True)
class Inputs:
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    tau: np.ndarray


def _inputs(model: ff.Model, batch: tuple[int, ...], seed: int) -> Inputs:
    rng = np.random.default_rng(seed)
    n = model.n_joints
    q = rng.uniform(-1.5, 1.5, (*batch, n))
    return Inputs(q, rng.normal(size=(*batch, 6 + n)) * 0.3, rng.normal(size=(*batch, 6 + n)), rng.normal(size=(*batch, n)))


#: The calls that take out=, each as a function of (model, inputs, **keywords).
CALLS: dict[str, Callable[..., Any]] = {
    "generalized_jacobian": lambda m, x, **kw: ff.generalized_jacobian(m, x.q, **kw),
    "system_inertia_matrix": lambda m, x, **kw: ff.system_inertia_matrix(m, x.q, **kw),
    "nonlinear_forces": lambda m, x, **kw: ff.nonlinear_forces(m, x.q, x.v, **kw),
    "forward_dynamics": lambda m, x, **kw: ff.forward_dynamics(m, x.q, x.v, x.tau, spacecraft_torque=[0.0, 0.0, 1.0], **kw),
    "inverse_dynamics": lambda m, x, **kw: ff.inverse_dynamics(m, x.q, x.v, x.a, **kw),
    "jacobian_measure": lambda m, x, **kw: ff.mechanics.jacobian_measure(m, x.q, **kw),
    "jacobian_determinant": lambda m, x, **kw: ff.jacobian_determinant(m, x.q, **kw),
    "manipulability": lambda m, x, **kw: ff.manipulability(m, x.q, **kw),
}
#: The calls whose method= has a numpy reference ("barycentric").
REFERENCES = ("generalized_jacobian", "system_inertia_matrix", "nonlinear_forces", "forward_dynamics", "inverse_dynamics")


def _like(result: Any) -> Any:
    """An out= for ``result`` (an array, or inverse_dynamics' tuple of three), filled with NaN."""
    if isinstance(result, tuple):
        return tuple(np.full(r.shape, np.nan) for r in result)
    return np.full(result.shape, np.nan)


def _main(result: Any) -> np.ndarray:
    """The array of a result (inverse_dynamics': its joint torques)."""
    return result[2] if isinstance(result, tuple) else result


def _same(result: Any, out: Any, expected: Any) -> None:
    """``result`` is ``out`` (each array of it) and holds exactly ``expected``."""
    assert result is out
    for r, o, e in zip(*((x,) if not isinstance(x, tuple) else x for x in (result, out, expected)), strict=True):
        assert r is o and r.shape == e.shape
        np.testing.assert_array_equal(r, e)


@pytest.mark.parametrize("batch", [(), (5,), (3, 70)])
@pytest.mark.parametrize("name", CALLS)
def test_out_receives_the_result_and_is_returned(name: str, batch: tuple[int, ...]) -> None:
    model = ff.models.papadopoulos1992()
    call = CALLS[name]
    first, second = _inputs(model, batch, 1), _inputs(model, batch, 2)
    expected = call(model, first)
    out = _like(expected)
    _same(call(model, first, out=out), out, expected)
    _same(call(model, second, out=out), out, call(model, second))  # the same array, written again
    assert not np.array_equal(_main(call(model, first)), _main(call(model, second)))  # (the second call changed it)


def test_out_may_be_a_view_that_is_contiguous() -> None:
    """A C-contiguous slice of a larger array (rows of a preallocated sweep) is a valid out: only it is written."""
    model = ff.models.papadopoulos1992()
    x = _inputs(model, (40,), 3)
    sweep = np.full((100, 12, model.n_joints), np.nan)
    part = sweep[20:60]
    assert ff.generalized_jacobian(model, x.q, out=part) is part
    np.testing.assert_array_equal(sweep[20:60], ff.generalized_jacobian(model, x.q))
    assert np.isnan(sweep[:20]).all() and np.isnan(sweep[60:]).all()


def _shape_of(name: str, batch: tuple[int, ...]) -> tuple[int, ...]:
    model = ff.models.papadopoulos1992()
    return _main(CALLS[name](model, _inputs(model, batch, 4))).shape


def _bad_outs() -> list[tuple[str, Callable[[tuple[int, ...]], Any], type[Exception], str]]:
    """(id, a bad out made from the result's shape, the error, the message's start)."""
    fix = r".*; pass out=np\.empty\("

    def read_only(shape: tuple[int, ...]) -> np.ndarray:
        out = np.empty(shape)
        out.flags.writeable = False
        return out

    return [
        ("wider", lambda s: np.empty((*s[:-1], s[-1] + 1)), ShapeError, r"^out: expected shape \(.*\) \(the result's\), got" + fix),
        ("one-more-axis", lambda s: np.empty((1, *s)), ShapeError, r"^out: expected shape .* \(the result's\), got \(1, " + fix),
        ("float32", lambda s: np.empty(s, dtype=np.float32), TypeError, r"^out: expected dtype float64, got float32" + fix),
        ("integers", lambda s: np.zeros(s, dtype=np.int64), TypeError, r"^out: expected dtype float64, got int64" + fix),
        ("a-list", lambda s: np.empty(s).tolist(), TypeError, r"^out: expected a float64 numpy array of shape \(70.*\), got list" + fix),
        ("strided", lambda s: np.empty((*s, 2))[..., 0], ValueError, r"^out: is not C-contiguous and aligned" + fix),
        ("read-only", read_only, ValueError, r"^out: is read-only" + fix),
    ]


_BAD = [(name, *case) for name in CALLS if name != "inverse_dynamics" for case in _bad_outs()]


@pytest.mark.parametrize(("name", "id", "make", "error", "match"), _BAD, ids=[f"{c[0]}-{c[1]}" for c in _BAD])
def test_a_bad_out_is_refused_before_any_kernel(
    name: str, id: str, make: Callable[..., Any], error: type[Exception], match: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    model = ff.models.papadopoulos1992()
    batch = (70,)  # above the specialised kernels' batch size
    out = make(_shape_of(name, batch))
    runs = [count_calls(monkeypatch, f) for f in (_engine._timed, _engine._specialised_map, _specialise.measured)]
    with pytest.raises(error, match=match):
        CALLS[name](model, _inputs(model, batch, 5), out=out)
    assert runs == [[], [], []]


@pytest.mark.parametrize("name", [n for n in CALLS if n != "inverse_dynamics"])
def test_an_unbatched_call_takes_an_out_of_the_unbatched_shape(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """q (N,) gives one result without a batch axis: an out with a batch axis of one is refused, and the right one taken."""
    model = ff.models.papadopoulos1992()
    x = _inputs(model, (), 6)
    expected = CALLS[name](model, x)
    runs = [count_calls(monkeypatch, f) for f in (_engine._timed, _engine._specialised_map, _specialise.measured)]
    message = f"out: expected shape {expected.shape} (the result's), got {(1, *expected.shape)}; "
    with pytest.raises(ShapeError, match="^" + re.escape(message)):
        CALLS[name](model, x, out=np.empty((1, *expected.shape)))
    assert runs == [[], [], []]
    out = np.empty(expected.shape)
    _same(CALLS[name](model, x, out=out), out, expected)


def _sharing(model: ff.Model, name: str, batch: tuple[int, ...], which: str) -> tuple[Inputs, np.ndarray]:
    """Inputs and an out of the call's result shape that starts where the input ``which`` starts (its values kept)."""
    x = _inputs(model, batch, 7)
    shape = _shape_of(name, batch)
    value = getattr(x, which)
    room = np.empty(max(int(np.prod(shape)), value.size))
    out = room[: int(np.prod(shape))].reshape(shape)
    inside = room[: value.size].reshape(value.shape)
    inside[...] = value
    return Inputs(**{**x.__dict__, which: inside}), out


_SHARING = [(n, "q") for n in CALLS if n != "inverse_dynamics"] + [
    ("nonlinear_forces", "v"),
    ("forward_dynamics", "v"),
    ("forward_dynamics", "tau"),
]


@pytest.mark.parametrize(("name", "which"), _SHARING)
def test_an_out_that_shares_memory_with_an_input_is_refused(name: str, which: str, monkeypatch: pytest.MonkeyPatch) -> None:
    model = ff.models.papadopoulos1992()
    x, out = _sharing(model, name, (70,), which)
    assert np.shares_memory(out, getattr(x, which))
    label = {"q": "q", "v": "velocity", "tau": "joint_torque"}[which]
    runs = [count_calls(monkeypatch, f) for f in (_engine._timed, _engine._specialised_map, _specialise.measured)]
    with pytest.raises(ValueError, match=rf"^out: shares memory with {label}, which the call reads while it writes out; pass an array"):
        CALLS[name](model, x, out=out)
    assert runs == [[], [], []]


def test_an_out_next_to_an_input_is_taken() -> None:
    """Two halves of one buffer share no memory: q in one, out in the other is fine."""
    model = ff.models.papadopoulos1992()
    x = _inputs(model, (30,), 8)
    room = np.empty(30 * model.n_joints + 30 * 12 * model.n_joints)
    q = room[: x.q.size].reshape(x.q.shape)
    q[...] = x.q
    out = room[x.q.size :].reshape((30, 12, model.n_joints))
    _same(ff.generalized_jacobian(model, q, out=out), out, ff.generalized_jacobian(model, x.q))


def test_an_out_that_shares_memory_with_an_external_wrench_is_refused() -> None:
    model = ff.models.papadopoulos1992()
    x = _inputs(model, (10,), 9)
    out = np.zeros((10, 6 + model.n_joints))
    wrench = ff.ExternalWrench(body=model.n_bodies - 1, force=out[:, :3])
    with pytest.raises(ValueError, match=r"^out: shares memory with external\[0\]\.force, which the call reads"):
        ff.forward_dynamics(model, x.q, x.v, external=[wrench], out=out)


@pytest.mark.parametrize("name", REFERENCES)
def test_the_barycentric_reference_takes_no_out(name: str) -> None:
    model = ff.models.papadopoulos1992()
    x = _inputs(model, (4,), 10)
    expected = CALLS[name](model, x)
    with pytest.raises(
        ValueError, match=r"^out: method='barycentric' \(the numpy reference\) makes its own arrays and takes no out=; call"
    ):
        CALLS[name](model, x, method="barycentric", out=_like(expected))


# ----------------------------------------------------------------- inverse dynamics: a tuple of three
def test_inverse_dynamics_fills_a_tuple_of_three() -> None:
    model = ff.models.papadopoulos1992()
    x = _inputs(model, (2, 35), 11)
    expected = ff.inverse_dynamics(model, x.q, x.v, x.a, attitude=[0.0, 0.0, np.sin(0.3), np.cos(0.3)])
    out = _like(expected)
    _same(ff.inverse_dynamics(model, x.q, x.v, x.a, attitude=[0.0, 0.0, np.sin(0.3), np.cos(0.3)], out=out), out, expected)
    broadcast = ff.inverse_dynamics(model, x.q, x.v[0, 0], x.a[0, 0])  # the batch of q alone
    _same(ff.inverse_dynamics(model, x.q, x.v[0, 0], x.a[0, 0], out=out), out, broadcast)


def _bad_triples(n: int) -> list[tuple[str, Any, type[Exception], str]]:
    b = (70,)
    good = (np.zeros((*b, 3)), np.zeros((*b, 3)), np.zeros((*b, n)))
    both = np.zeros((52, 6))  # rows 17-34 in both halves
    return [
        (
            "an-array",
            np.zeros((*b, 6 + n)),
            TypeError,
            r"^out: expected a tuple of three arrays \(spacecraft_force, spacecraft_torque, joint_torque",
        ),
        ("a-list", list(good), TypeError, r"^out: expected a tuple of three arrays .*got a list of 3; pass such a tuple"),
        ("two", good[:2], TypeError, r"^out: expected a tuple of three arrays .*got a tuple of 2"),
        (
            "torque-wrong-shape",
            (good[0], np.zeros((*b, 4)), good[2]),
            ShapeError,
            r"^out\[1\] \(spacecraft_torque\): expected shape \(70, 3\)",
        ),
        (
            "joints-wrong-shape",
            (good[0], good[1], np.zeros((*b, n + 1))),
            ShapeError,
            rf"^out\[2\] \(joint_torque\): expected shape \(70, {n}\)",
        ),
        (
            "force-float32",
            (good[0].astype(np.float32), good[1], good[2]),
            TypeError,
            r"^out\[0\] \(spacecraft_force\): expected dtype float64",
        ),
        (
            "torque-strided",
            (good[0], np.zeros((*b, 6))[:, ::2], good[2]),
            ValueError,
            r"^out\[1\] \(spacecraft_torque\): is not C-contiguous",
        ),
        (
            "force-and-torque-overlap",
            (both[:35].reshape((*b, 3)), both[17:52].reshape((*b, 3)), good[2]),
            ValueError,
            r"^out\[1\] \(spacecraft_torque\): shares memory with out\[0\] \(spacecraft_force\)",
        ),
        (
            "same-array-twice",
            (good[0], good[0], good[2]),
            ValueError,
            r"^out\[1\] \(spacecraft_torque\): shares memory with out\[0\] \(spacecraft_force\)",
        ),
    ]


@pytest.mark.parametrize("case", range(len(_bad_triples(1))))
def test_a_bad_out_of_inverse_dynamics_is_refused_before_any_kernel(case: int, monkeypatch: pytest.MonkeyPatch) -> None:
    model = ff.models.papadopoulos1992()
    id, out, error, match = _bad_triples(model.n_joints)[case]
    x = _inputs(model, (70,), 12)
    runs = [count_calls(monkeypatch, f) for f in (_engine._timed, _engine._specialised_map, _specialise.measured)]
    with pytest.raises(error, match=match):
        ff.inverse_dynamics(model, x.q, x.v, x.a, out=out)
    assert runs == [[], [], []], id


def test_inverse_dynamics_refuses_an_out_in_the_inputs() -> None:
    model = ff.models.papadopoulos1992()
    x = _inputs(model, (70,), 13)
    acc = np.array(x.a)
    out = (acc.reshape(-1)[:210].reshape((70, 3)), np.empty((70, 3)), np.empty((70, model.n_joints)))  # in acc's memory
    with pytest.raises(ValueError, match=r"^out\[0\] \(spacecraft_force\): shares memory with acceleration"):
        ff.inverse_dynamics(model, x.q, x.v, acc, out=out)


# ----------------------------------------------------------------- the specialised kernels
@pytest.fixture(scope="module")
def specialised(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ff.Model]:
    """The 1992 system's map and measure kernels specialised, in a cache folder of this module's own."""
    kinds = ["jstar", "hplus", "forward", "inverse", "measure"]
    model = ff.models.papadopoulos1992()
    with pytest.MonkeyPatch.context() as env:
        env.setenv("FREEFLOAT_CACHE_DIR", str(tmp_path_factory.mktemp("freefloat-cache")))
        before = _specialise.FOLDER[0]
        _specialise.FOLDER[0] = None
        _specialise._LOADED.clear()
        _specialise._FOUND.clear()
        _specialise._ENABLED[0] = True
        try:
            ff.mechanics.specialise(model, kinds)
            assert all(ff.mechanics.is_specialised(model, k) for k in kinds)
            yield model
        finally:
            _specialise.FOLDER[0] = before
            _specialise._ENABLED[0] = False
            _specialise._LOADED.clear()
            _specialise._FOUND.clear()


@pytest.mark.parametrize("name", CALLS)
def test_the_specialised_kernels_write_into_out(name: str, specialised: ff.Model, monkeypatch: pytest.MonkeyPatch) -> None:
    """The specialised map and measure kernels write the caller's array itself (forward dynamics: its rows carry the
    guards' flag, copied into out after), with the numbers of a call without out."""
    model = specialised
    x, y = _inputs(model, (2, 100), 14), _inputs(model, (2, 100), 15)
    expected = CALLS[name](model, x)
    out = _like(expected)
    targets: list[np.ndarray] = []
    mapped, measured = _specialise.mapped, _specialise.measured
    monkeypatch.setattr(_specialise, "mapped", lambda module, t, parts, o: (targets.append(o), mapped(module, t, parts, o))[1])
    monkeypatch.setattr(_specialise, "measured", lambda module, t, q, r, c, o: (targets.append(o), measured(module, t, q, r, c, o))[1])
    _same(CALLS[name](model, x, out=out), out, expected)
    _same(CALLS[name](model, y, out=out), out, CALLS[name](model, y))
    assert len(targets) == 3  # the specialised kernels ran, each call
    writes_out = name not in ("forward_dynamics", "inverse_dynamics")  # inverse: the kernel's rows are then inverted
    outs = out if isinstance(out, tuple) else (out,)
    assert all(any(np.shares_memory(t, o) for o in outs) == writes_out for t in targets[:2])


# ----------------------------------------------------------------- the pool's last trace
def test_release_buffers_is_deprecated_and_does_nothing() -> None:
    with pytest.warns(DeprecationWarning, match=r"release_buffers\(\) does nothing: results are no longer recycled; pass out= to reuse"):
        assert ff.mechanics.release_buffers() == 0


def test_results_are_arrays_of_their_own() -> None:
    """Without out, each call's result is a new array that owns its memory (no view of a kept buffer)."""
    model = ff.models.papadopoulos1992()
    q = _inputs(model, (20_000,), 16).q
    first, second = ff.generalized_jacobian(model, q), ff.generalized_jacobian(model, q)
    assert first.flags.owndata and second.flags.owndata and not np.shares_memory(first, second)
