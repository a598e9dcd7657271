"""Batch first (STYLE.md): every batched function takes (..., N), an unbatched input gives an
unbatched output, and a batch equals the loop over single configurations, also across the
internal chunks of ``freefloat.mechanics._batches.CHUNK`` configurations.

Two kinds of path: the engine (the default ``method="recursive"``, numba kernels that cut a batch
into blocks of their own) and the numpy reference forms (``method="barycentric"``,
dH+/dt, the point bias acceleration), which run through ``_batches.chunked``. ``CHUNKED`` names the
cases of the second kind; a counting spy (tests/spies.py) asserts that exactly these reach
``chunked`` and that the chunk tests really cut their batch into several chunks.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import freefloat as ff
import freefloat.mechanics._batches
from spies import count_chunks
from trees import build_random_model

PAPER = ff.models.papadopoulos1992()  # planar, two arms, square planar J* (4 x 4)
TREE = build_random_model(np.random.default_rng(2024), [3, 2], [1, None], [0, None], name="batch-tree")  # 3D, a branch, a fixed joint

Inputs = dict[str, np.ndarray]
Case = Callable[[ff.Model, Inputs], Any]

CASES: dict[str, Case] = {
    "end_effector_positions": lambda m, x: ff.end_effector_positions(m, x["q"]),
    "end_effector_positions(attitude)": lambda m, x: ff.end_effector_positions(m, x["q"], attitude=x["attitude"]),
    "end_effector_positions(barycentric)": lambda m, x: ff.end_effector_positions(m, x["q"], method="barycentric"),
    "end_effector_rotations": lambda m, x: ff.mechanics.end_effector_rotations(m, x["q"]),
    "body_cm_positions": lambda m, x: ff.body_cm_positions(m, x["q"]),
    "body_cm_positions(barycentric)": lambda m, x: ff.body_cm_positions(m, x["q"], method="barycentric"),
    "body_rotations": lambda m, x: ff.body_rotations(m, x["q"]),
    "point_positions": lambda m, x: ff.point_positions(m, x["q"], 2, [0.1, -0.2, 0.3]),
    "forward_kinematics": lambda m, x: ff.forward_kinematics(m, x["q"]),
    "system_cm": lambda m, x: ff.system_cm(m, x["q"]),
    "inertia_blocks": lambda m, x: ff.inertia_blocks(m, x["q"]),
    "system_inertia_matrix": lambda m, x: ff.system_inertia_matrix(m, x["q"]),
    "angular_momentum": lambda m, x: ff.angular_momentum(m, x["q"], x["velocity"]),
    "angular_momentum(attitude)": lambda m, x: ff.angular_momentum(m, x["q"], x["velocity"], attitude=x["attitude"]),
    "linear_momentum": lambda m, x: ff.linear_momentum(m, x["velocity"]),
    "kinetic_energy": lambda m, x: ff.kinetic_energy(m, x["q"], x["velocity"]),
    "point_jacobian": lambda m, x: ff.point_jacobian(m, x["q"], 2, [0.1, -0.2, 0.3]),
    "point_jacobian(attitude)": lambda m, x: ff.point_jacobian(m, x["q"], 1, attitude=x["attitude"]),
    "end_effector_jacobian": lambda m, x: ff.end_effector_jacobian(m, x["q"], 1, attitude=x["attitude"]),
    "actuation_jacobian": lambda m, x: ff.actuation_jacobian(m, x["q"]),
    "actuation_jacobian(attitude)": lambda m, x: ff.actuation_jacobian(m, x["q"], attitude=x["attitude"]),
    "task_jacobian(euler321)": lambda m, x: ff.task_jacobian(m, x["q"], attitude=x["attitude"], orientation="euler321"),
    "task_jacobian(quaternion)": lambda m, x: ff.task_jacobian(m, x["q"], attitude=x["attitude"], orientation="quaternion"),
    "task_jacobian(positions)": lambda m, x: ff.task_jacobian(m, x["q"], orientation=None, spacecraft=False),
    "generalized_jacobian": lambda m, x: ff.generalized_jacobian(m, x["q"]),
    "generalized_jacobian_drift": lambda m, x: ff.mechanics.generalized_jacobian_drift(m, x["q"], x["h"], x["p"], attitude=x["attitude"]),
    "manipulability": lambda m, x: ff.manipulability(m, x["q"]),
    # the numpy reference forms: through _batches.chunked
    "end_effector_positions(attitude, barycentric)": lambda m, x: ff.end_effector_positions(
        m, x["q"], attitude=x["attitude"], method="barycentric"
    ),
    "point_positions(barycentric)": lambda m, x: ff.point_positions(m, x["q"], 2, [0.1, -0.2, 0.3], method="barycentric"),
    "system_inertia_matrix(barycentric)": lambda m, x: ff.system_inertia_matrix(m, x["q"], method="barycentric"),
    "inertia_blocks(barycentric)": lambda m, x: ff.inertia_blocks(m, x["q"], method="barycentric"),
    "point_jacobian(barycentric)": lambda m, x: ff.point_jacobian(m, x["q"], 2, [0.1, -0.2, 0.3], method="barycentric"),
    "generalized_jacobian(barycentric)": lambda m, x: ff.generalized_jacobian(m, x["q"], method="barycentric"),
    "nonlinear_forces(barycentric)": lambda m, x: ff.nonlinear_forces(m, x["q"], x["velocity"], method="barycentric"),
    "system_inertia_matrix_rate(barycentric)": lambda m, x: ff.mechanics.system_inertia_matrix_rate(
        m, x["q"], x["velocity"][..., 6:], method="barycentric"
    ),
    "point_bias_acceleration(barycentric)": lambda m, x: ff.mechanics.point_bias_acceleration(
        m, x["q"], x["velocity"], 2, attitude=x["attitude"], method="barycentric"
    ),
    # the engine (its drivers' blocks)
    "system_inertia_matrix_rate": lambda m, x: ff.mechanics.system_inertia_matrix_rate(m, x["q"], x["velocity"][..., 6:]),
    "point_bias_acceleration": lambda m, x: ff.mechanics.point_bias_acceleration(m, x["q"], x["velocity"], 2, attitude=x["attitude"]),
}
#: The cases that run through ``_batches.chunked`` (the others run on the engine's blocks); asserted below.
CHUNKED = {name for name in CASES if "barycentric" in name}
PLANAR_CASES: dict[str, Case] = {
    "jacobian_determinant": lambda m, x: ff.jacobian_determinant(m, x["q"]),
    "planar.end_effector_positions": lambda m, x: ff.planar.end_effector_positions(m, x["q"]),
    "planar.generalized_jacobian": lambda m, x: ff.planar.generalized_jacobian(m, x["q"]),
    "planar.generalized_jacobian(angular)": lambda m, x: ff.planar.generalized_jacobian(m, x["q"], angular=True),
    "planar.system_inertia_matrix": lambda m, x: ff.planar.system_inertia_matrix(m, x["q"]),
}
PARAMS = [pytest.param(PAPER, name, id=f"paper-{name}") for name in [*CASES, *PLANAR_CASES]] + [
    pytest.param(TREE, name, id=f"tree-{name}") for name in CASES
]
CHUNKED_PARAMS = [p for p in PARAMS if p.values[1] in CHUNKED]
#: Reference forms built on B x B pair arrays: slow on 8199 configurations, chunk-tested at CHUNK = 5 only.
PAIR_FORMS = {
    "system_inertia_matrix(barycentric)",
    "inertia_blocks(barycentric)",
    "generalized_jacobian(barycentric)",
    "nonlinear_forces(barycentric)",
    "system_inertia_matrix_rate(barycentric)",
}
LARGE_PARAMS = [p for p in PARAMS if p.values[1] not in PAIR_FORMS]
ALL_CASES = {**CASES, **PLANAR_CASES}


def make_inputs(model: ff.Model, shape: tuple[int, ...], seed: int) -> Inputs:
    rng = np.random.default_rng(seed)
    size = int(np.prod(shape, dtype=int))
    return {
        "q": rng.uniform(-np.pi, np.pi, size=(*shape, model.n_joints)),
        "velocity": rng.normal(size=(*shape, 6 + model.n_joints)),
        "attitude": Rotation.random(size, random_state=rng).as_quat().reshape(*shape, 4),
        "h": rng.normal(scale=10.0, size=(*shape, 3)),
        "p": rng.normal(scale=10.0, size=(*shape, 3)),
    }


def arrays(out: Any) -> tuple[np.ndarray, ...]:
    if isinstance(out, ff.mechanics.InertiaBlocks):
        return (out.D, out.D_q, out.D_qq)
    if isinstance(out, tuple):
        return tuple(np.asarray(o) for o in out)
    return (np.asarray(out),)


def at(x: Inputs, index: tuple[int, ...]) -> Inputs:
    return {key: value[index] for key, value in x.items()}


def assert_batch_equals_loop(
    case: Case, model: ff.Model, x: Inputs, indices: list[tuple[int, ...]], batch: tuple[np.ndarray, ...] | None = None
) -> None:
    """The batch result (``batch``, or computed here) equals the single calls at ``indices``."""
    batch = arrays(case(model, x)) if batch is None else batch
    shape = x["q"].shape[:-1]
    for index in indices:
        single = arrays(case(model, at(x, index)))
        assert len(single) == len(batch)
        for b, s in zip(batch, single, strict=True):
            assert b.shape == shape + s.shape, (b.shape, shape, s.shape)
            np.testing.assert_allclose(b[index], s, rtol=1e-12, atol=1e-12 * max(1.0, float(np.max(np.abs(s), initial=0.0))))


@pytest.mark.parametrize(("model", "name"), PARAMS)
def test_unbatched_input_gives_unbatched_output(model: ff.Model, name: str) -> None:
    case = ALL_CASES[name]
    x = make_inputs(model, (1,), seed=1)
    single = arrays(case(model, at(x, (0,))))
    batched = arrays(case(model, x))
    for s, b in zip(single, batched, strict=True):
        assert b.shape == (1, *s.shape)
        np.testing.assert_allclose(b[0], s, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize(("model", "name"), PARAMS)
def test_batch_equals_loop(model: ff.Model, name: str) -> None:
    x = make_inputs(model, (3, 4), seed=2)
    assert_batch_equals_loop(ALL_CASES[name], model, x, [(a, b) for a in range(3) for b in range(4)])


def test_exactly_the_chunked_cases_reach_chunked(monkeypatch: pytest.MonkeyPatch) -> None:
    """The list ``CHUNKED`` is what the code does: a reference form that left ``chunked`` (or an engine path
    that took it) would otherwise leave the chunk tests below checking a path they do not reach."""
    runs = count_chunks(monkeypatch)
    for param in PARAMS:
        model, name = param.values
        runs.clear()
        ALL_CASES[name](model, make_inputs(model, (3, 4), seed=3))
        assert bool(runs) == (name in CHUNKED), f"{param.id}: chunked called {len(runs)} times"


@pytest.mark.parametrize(("model", "name"), CHUNKED_PARAMS)
def test_batch_equals_loop_across_small_chunks(model: ff.Model, name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """With CHUNK = 5 a (3, 4) batch runs in three pieces; the pieces must join in order."""
    monkeypatch.setattr(freefloat.mechanics._batches, "CHUNK", 5)
    x = make_inputs(model, (3, 4), seed=3)
    runs = count_chunks(monkeypatch)
    batch = arrays(ALL_CASES[name](model, x))
    assert runs and all(r == 3 for r in runs), f"chunk counts {runs}: the batch was not cut into three chunks of CHUNK = 5"
    assert_batch_equals_loop(ALL_CASES[name], model, x, [(a, b) for a in range(3) for b in range(4)], batch)


@pytest.mark.parametrize(("model", "name"), LARGE_PARAMS)
def test_batch_larger_than_the_chunk_equals_loop(model: ff.Model, name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """2 CHUNK + 7 configurations: the reference forms run in three chunks (asserted); the engine, which
    does not chunk, runs the same batch on one range per thread."""
    chunk = freefloat.mechanics._batches.CHUNK  # 4096
    size = 2 * chunk + 7  # three chunks, the last one short
    x = make_inputs(model, (size,), seed=4)
    runs = count_chunks(monkeypatch)
    batch = arrays(ALL_CASES[name](model, x))
    assert all(r == 3 for r in runs) and bool(runs) == (name in CHUNKED), f"chunk counts {runs}"
    picks = {0, 1, chunk - 1, chunk, chunk + 1, 2 * chunk - 1, 2 * chunk, size - 1}
    picks |= set(np.random.default_rng(5).integers(0, size, size=4).tolist())
    assert_batch_equals_loop(ALL_CASES[name], model, x, [(i,) for i in sorted(picks)], batch)


def test_two_dimensional_batch_across_the_chunk_boundary(monkeypatch: pytest.MonkeyPatch) -> None:
    chunk = freefloat.mechanics._batches.CHUNK
    cols = chunk // 2 + 52  # 2 * cols > chunk: the boundary falls inside row 1, at column chunk - cols
    x = make_inputs(PAPER, (2, cols), seed=6)
    picks = [(0, 0), (0, cols - 1), (1, chunk - cols - 1), (1, chunk - cols), (1, cols - 1)]
    runs = count_chunks(monkeypatch)
    for name in ("generalized_jacobian(barycentric)", "inertia_blocks(barycentric)", "body_cm_positions(barycentric)"):
        runs.clear()
        batch = arrays(ALL_CASES[name](PAPER, x))
        assert runs == [2], f"{name}: chunk counts {runs}, expected one call cut into two chunks"
        assert_batch_equals_loop(ALL_CASES[name], PAPER, x, picks, batch)
    for name in ("generalized_jacobian", "jacobian_determinant", "forward_kinematics", "angular_momentum(attitude)"):  # the engine
        assert_batch_equals_loop(ALL_CASES[name], PAPER, x, picks)


BROADCAST: dict[str, Callable[[ff.Model, np.ndarray, Inputs], Any]] = {
    "angular_momentum": lambda m, q, one: ff.angular_momentum(m, q, one["velocity"], attitude=one["attitude"]),
    "kinetic_energy": lambda m, q, one: ff.kinetic_energy(m, q, one["velocity"]),
    "generalized_jacobian_drift": lambda m, q, one: ff.mechanics.generalized_jacobian_drift(
        m, q, one["h"], one["p"], attitude=one["attitude"]
    ),
    "end_effector_positions": lambda m, q, one: ff.end_effector_positions(m, q, attitude=one["attitude"]),
    "point_jacobian": lambda m, q, one: ff.point_jacobian(m, q, 1, attitude=one["attitude"]),
    "task_jacobian": lambda m, q, one: ff.task_jacobian(m, q, attitude=one["attitude"]),
    "actuation_jacobian": lambda m, q, one: ff.actuation_jacobian(m, q, attitude=one["attitude"]),
}


@pytest.mark.parametrize("name", BROADCAST)
def test_single_velocity_attitude_or_momentum_broadcasts_over_a_batch_of_q(name: str) -> None:
    x = make_inputs(TREE, (2, 3), seed=7)
    one = at(make_inputs(TREE, (1,), seed=8), (0,))
    fn = BROADCAST[name]
    batch = arrays(fn(TREE, x["q"], one))
    for a in range(2):
        for b in range(3):
            for got, want in zip(batch, arrays(fn(TREE, x["q"][a, b], one)), strict=True):
                assert got.shape == (2, 3, *want.shape)
                np.testing.assert_allclose(got[a, b], want, rtol=1e-12, atol=1e-12)


def test_empty_batch_gives_empty_results() -> None:
    q = np.zeros((0, PAPER.n_joints))
    assert ff.generalized_jacobian(PAPER, q).shape == (0, 12, 4)
    assert ff.system_inertia_matrix(PAPER, q).shape == (0, 10, 10)
    assert ff.end_effector_positions(PAPER, q).shape == (0, 2, 3)
    assert ff.angular_momentum(PAPER, q, np.zeros((0, 10))).shape == (0, 3)
