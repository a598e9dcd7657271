"""Rollouts, forward and inverse dynamics with external wrenches specialised like those without (issue "One engine a
newcomer can extend", item 5): the wrenches' layout (bodies, frames) folded into the traced code, their values read per
configuration (per trajectory in a rollout); results equal to the generic kernels to rounding, the specialised kernels
reached at batch sizes around the lane block. Compiled into a temporary cache folder."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import freefloat as ff
from freefloat.engine import calls as _engine
from freefloat.engine.layout import tree
from freefloat.engine.specialise import build as _specialise
from freefloat.engine.specialise import lanes as _lanes
from freefloat.mechanics.forces import _engine_wrenches
from spies import count_calls, replace_everywhere
from trees import build_random_model

KINDS = ("forward", "inverse", "rollout")
LANES = _lanes.LANES


@pytest.fixture(scope="module")
def own_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """Specialised kernels on, in a cache folder of this module's own (shared by its tests)."""
    folder = tmp_path_factory.mktemp("freefloat-cache")
    with pytest.MonkeyPatch.context() as env:
        env.setenv("FREEFLOAT_CACHE_DIR", str(folder))
        before = (_specialise.FOLDER[0], _specialise._ENABLED[0])
        _specialise.FOLDER[0] = Path(folder) / "specialised"
        _specialise._ENABLED[0] = True
        _specialise._FOUND.clear()
        try:
            yield
        finally:
            _specialise.FOLDER[0], _specialise._ENABLED[0] = before
            _specialise._FOUND.clear()
            _specialise._LOADED.clear()


def _model(which: str) -> ff.Model:
    if which == "papadopoulos1992":
        return ff.models.papadopoulos1992()
    return build_random_model(np.random.default_rng(5), [2, 2], [0, None], [1, None], prismatic=0.5)


def _layout(model: ff.Model) -> np.ndarray:
    """Three wrenches, one per frame code (0 inertial, 1 spacecraft, 2 body): on the last body, the spacecraft, body 1."""
    return np.array([[model.n_bodies - 1, 2], [0, 0], [1, 1]], dtype=np.int64)


#: The rollouts' tolerance, relative: 40 RK4 steps of forward dynamics, whose forward error is cond(H+) times rounding
#: (an ill-conditioned H+, such as the 7-DOF arm's, a 1500 kg spacecraft with a light wrist, needs 5e-12).
ROLLOUT_RTOL = {"papadopoulos1992": 1e-12, "random-tree": 1e-12}


def _close(ours: np.ndarray, ref: np.ndarray, rtol: float = 1e-12) -> None:
    """Equal to ``rtol`` relative to each row's largest value."""
    scale = np.max(np.abs(ref), axis=tuple(range(1, ref.ndim)), keepdims=True)
    assert np.max(np.abs(ours - ref) / scale) <= rtol


def _same_solution(model: ff.Model, q: np.ndarray, ours: np.ndarray, ref: np.ndarray) -> None:
    """Forward dynamics: rddot_cm to 1e-12 relative, and [d/dt omega0, qddot] solving the same H+ zddot0 = Q - C+ to
    1e-12 relative (the backward error: the forward error is cond(H+) times larger, 3e-12 on the 7-DOF arm's random
    configurations with or without wrenches)."""
    _close(ours[:, :3], ref[:, :3])
    with _specialise.generic():
        h = _engine.inertia_matrix(model, q)[:, 3:, 3:]
    lhs = np.einsum("cij,cj->ci", h, ours[:, 3:] - ref[:, 3:])
    scale = np.max(np.abs(h), axis=(1, 2)) * np.max(np.abs(ref[:, 3:]), axis=1)
    assert np.max(np.abs(lhs).max(axis=1) / scale) <= 1e-12


def _dynamics(model: ff.Model, size: int, ext_i: np.ndarray, seed: int) -> tuple[np.ndarray, ...]:
    """(q, zddot0, ok, H+ zddot0 + C+ - Q rows, C+ - Q rows) of ``size`` random configurations under wrenches of their own."""
    rng = np.random.default_rng(seed)
    n = model.n_joints
    q, v, a = rng.uniform(-1.5, 1.5, (size, n)), rng.normal(size=(size, 6 + n)), rng.normal(size=(size, 6 + n))
    u, t0 = rng.normal(size=(size, n + 6)) * 10.0, Rotation.random(size, random_state=seed).as_matrix()
    ext = (ext_i, rng.normal(size=(size, ext_i.shape[0], 9)) * 20.0)
    acc, ok = _engine.accelerations(model, q, v, u, t0, ext)
    return q, acc, ok, _engine.residual_rows(model, q, v, a, u, t0, ext), _engine.residual_rows(model, q, v, None, u, t0, ext)


def _rollout(model: ff.Model, k: int, ext_i: np.ndarray, seed: int) -> tuple[np.ndarray, ...]:
    """k trajectories under a joint PD and wrenches of their own (per trajectory), 40 steps."""
    rng = np.random.default_rng(seed)
    n = model.n_joints
    x0 = np.zeros((k, 13 + 2 * n))
    x0[:, 6:10] = Rotation.random(k, random_state=seed).as_quat()
    x0[:, 10:13] = rng.normal(scale=0.05, size=(k, 3))
    x0[:, 13 : 13 + n] = rng.uniform(-1.0, 1.0, (k, n))
    x0[:, 13 + n :] = rng.uniform(-0.3, 0.3, (k, n))
    gains = (rng.uniform(1.0, 5.0, (k, n)), np.ones((k, n)), np.full((k, n), 0.2), np.zeros((k, n)))
    ext = (ext_i, rng.normal(size=(k, ext_i.shape[0], 9)) * 0.5)  # moderate: a light wrist link spins fast under more
    return _engine.rollout(model, x0, 1e-3, 40, 5, 7, gains, rng.normal(size=(3, k, n)), np.full(n + 6, 4.0), ext)


# Two structures: the paper system (whose kernels the last test reuses) and a branched tree with sliding joints. The 7-DOF
# arm, a chain (83 s of compiles on a loaded machine), adds no code path these lack and is left out for the suite's time.
@pytest.mark.parametrize("which", ["papadopoulos1992", "random-tree"])
def test_specialised_dynamics_and_rollouts_with_wrenches_equal_the_generic_kernels(own_cache: None, which: str) -> None:
    model = _model(which)
    ext_i = _layout(model)
    sizes = (LANES - 1, LANES, 2 * LANES + 1, _specialise.THREADS_FROM + 1)  # below the maps' minimum (generic), one block,
    # a short last block, one range of blocks per thread
    trajectories = (7, 8, LANES + 6, 2 * LANES + 1)  # below the rollouts' minimum (generic), one block, two and three blocks
    with _specialise.generic():
        generic = [_dynamics(model, size, ext_i, size) for size in sizes]
        rolled = [_rollout(model, k, ext_i, k) for k in trajectories]
        unforced = _rollout(model, 8, ext_i[:0], 8)
    external = [ff.ExternalWrench(model.body_names[b], frame=("inertial", "spacecraft", "body")[f]) for b, f in ext_i]
    ff.mechanics.specialise(model, KINDS, external=external)
    assert all(ff.mechanics.is_specialised(model, kind, external=external) for kind in KINDS)
    assert not ff.mechanics.is_specialised(model, "rollout")  # without wrenches: another layout, not made
    with pytest.MonkeyPatch.context() as mp:
        maps = count_calls(mp, _specialise.mapped)
        runs = count_calls(mp, _specialise.rollout)
        for size, ref in zip(sizes, generic, strict=True):
            before = len(maps)
            fast = _dynamics(model, size, ext_i, size)
            assert len(maps) - before == (0 if size < _engine._SPECIALISED_MIN else 3)  # forward and both inverse calls
            q, acc, ok, rows, rows0 = fast
            _same_solution(model, q, acc, ref[1])
            assert np.array_equal(ok, ref[2]) and ok.all()
            _close(rows, ref[3])
            _close(rows0, ref[4])
        for k, ref in zip(trajectories, rolled, strict=True):
            before = len(runs)
            fast = _rollout(model, k, ext_i, k)
            assert len(runs) - before == (0 if k < _engine._SPECIALISED_ROLLOUTS_MIN else 1)
            _close(fast[0], ref[0], ROLLOUT_RTOL[which])  # the states (each record)
            _close(fast[1], ref[1], ROLLOUT_RTOL[which])  # the actuation
            assert np.array_equal(fast[2], ref[2]) and np.array_equal(fast[3], ref[3]) and (fast[3] == 40).all()
    assert np.abs(rolled[1][0] - unforced[0]).max() > 1e-6  # the wrenches act


def test_a_layout_is_part_of_the_key_and_its_values_are_not(own_cache: None) -> None:
    model = ff.models.papadopoulos1992()
    t = tree(model)
    keys = {
        _specialise.structure_key(t, "rollout"),
        _specialise.structure_key(t, "rollout", ((4, 2),)),
        _specialise.structure_key(t, "rollout", ((4, 0),)),
        _specialise.structure_key(t, "rollout", ((3, 2),)),
        _specialise.structure_key(t, "rollout", ((4, 2), (0, 1))),
    }
    assert len(keys) == 5
    assert _specialise.structure_key(t, "rollout", ((4, 2),)).startswith(f"rollout_{model.n_joints}j_1w_")
    with pytest.raises(ValueError, match="takes no external wrenches"):
        _specialise.trace(t, "hplus", ((4, 2),))


def test_simulate_with_constant_wrenches_uses_the_specialised_rollouts(own_cache: None) -> None:
    """The public path: ff.rollout with ``external`` (the same wrenches for every trajectory) on the kernels made for
    their layout (the first test's, whose kernels this module's cache holds: only the values differ)."""
    model = ff.models.papadopoulos1992()
    names = model.body_names
    external: Any = [
        ff.ExternalWrench(names[-1], force=(0.0, 2.0, 0.0), point=(0.1, 0.0, 0.0), frame="body"),
        ff.ExternalWrench(names[0], torque=(0.0, 0.0, 1.0), frame="inertial"),
        ff.ExternalWrench(names[1], force=(1.0, 0.0, 0.0), frame="spacecraft"),
    ]
    assert _specialise.layout(_engine_wrenches(model, external)[0]) == _specialise.layout(_layout(model))
    ff.mechanics.specialise(model, ["rollout"], external=external)
    n = model.n_joints
    state = ff.State(q=np.random.default_rng(1).uniform(-1, 1, (LANES + 3, n)))
    with pytest.MonkeyPatch.context() as mp:
        runs = count_calls(mp, _specialise.rollout)
        fast = ff.rollout(model, state, 0.05, dt=1e-3, external=external)
    assert len(runs) == 1
    with _specialise.generic():
        slow = ff.rollout(model, state, 0.05, dt=1e-3, external=external)
    _close(fast.q, slow.q)
    assert np.abs(fast.q[-1] - state.q).max() > 1e-6


def test_inverse_dynamics_hands_its_wrenches_to_the_specialised_kernel(own_cache: None) -> None:
    """The public ``ff.inverse_dynamics(..., external=)`` passes its wrenches to the engine (the wrench law written once,
    in ``_recursions.newton_euler``), as ``ff.forward_dynamics`` does: a batch of 64 or more reaches the specialised
    inverse-dynamics kernel of their layout (spied), and equals the former route, J_q^-T (H+ zddot0 + C+) less
    J_q^-T Q_ext with Q_ext = sum J+^T [f; n] in numpy (``ff.generalized_forces``), to 1e-12."""
    model = ff.models.spacecraft_7dof()
    names = model.body_names
    rng = np.random.default_rng(21)
    size, n = 2 * LANES + 5, model.n_joints
    q, v, acc = rng.uniform(-1.5, 1.5, (size, n)), rng.normal(size=(size, 6 + n)), rng.normal(size=(size, 6 + n))
    att = Rotation.random(size, random_state=21).as_quat()
    external = [  # the layout of _layout(model): the first test's kernels serve it when it ran before
        ff.ExternalWrench(
            names[-1], force=rng.normal(size=(size, 3)) * 20.0, torque=rng.normal(size=3), point=(0.1, 0.0, 0.05), frame="body"
        ),
        ff.ExternalWrench(names[0], force=rng.normal(size=3) * 20.0, torque=rng.normal(size=(size, 3)), point=(0.3, -0.2, 0.1)),
        ff.ExternalWrench(names[1], force=rng.normal(size=(size, 3)) * 20.0, frame="spacecraft"),
    ]
    assert _specialise.layout(_engine_wrenches(model, external)[0]) == _specialise.layout(_layout(model))
    with _specialise.generic():
        plain = ff.inverse_dynamics(model, q, v, acc, att)
        q_ext = ff.generalized_forces(model, q, external=external, attitude=att)
        wrench_part = ff.mechanics.actuation_from_generalized_forces(model, q, q_ext, att)
        generic = ff.inverse_dynamics(model, q, v, acc, att, external=external)
    former = [p - w for p, w in zip(plain, wrench_part, strict=True)]
    ff.mechanics.specialise(model, ["inverse"], external=external)
    reached: list[Any] = []

    def spy(module: Any, *args: Any) -> Any:
        reached.append(module.WRENCHES)
        return real(module, *args)

    real = _specialise.mapped
    with pytest.MonkeyPatch.context() as mp:
        replace_everywhere(mp, real, spy)
        fast = ff.inverse_dynamics(model, q, v, acc, att, external=external)
    assert reached == [_specialise.layout(_layout(model))]  # one call, the kernel of the three wrenches' layout
    for ours, ref, gen in zip(fast, former, generic, strict=True):
        _close(ours, ref)
        _close(gen, ref)
