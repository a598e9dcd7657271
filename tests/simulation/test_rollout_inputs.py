"""Rollout inputs refused before any per-trajectory work (issue 40), and a trajectory of no samples written to files."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import freefloat as ff
from freefloat.core.errors import MemoryBudgetError, ShapeError
from freefloat.core.state import State

Q = np.radians([0.0, 90.0, 180.0, -90.0])


def test_a_rollout_too_large_is_refused_before_a_state_is_resolved(monkeypatch: pytest.MonkeyPatch) -> None:
    """10^8 trajectories x 1000 steps: the memory refusal comes from the fields' shapes; no State is resolved or packed."""
    monkeypatch.setenv("FREEFLOAT_MEMORY_LIMIT", "16G")
    states = ff.State(q=np.broadcast_to(Q, (10**8, 4)))

    def resolve(self: State, model: ff.Model) -> State:
        raise AssertionError("resolved a state before the memory check")

    monkeypatch.setattr(State, "resolve", resolve)
    with pytest.raises(MemoryBudgetError, match=r"a rollout of 100000000 trajectories x 1002 recorded states"):
        ff.rollout(ff.load("papadopoulos1992"), states, 10.0, dt=0.01)


_ARRAYS = [f.name for f in dataclasses.fields(ff.Trajectory) if f.name not in ("t", "status", "message", "model_name", "model")]
_ARRAYS.remove("joint_limit_events")


@pytest.mark.parametrize("controller", ["none", "joint-pd", "python"])
def test_an_empty_batch_gives_an_empty_trajectory(controller: str) -> None:
    """B = 0 initial states: every field (T, 0, ...), at the times a rollout of one trajectory records, as every batched
    call gives an empty result for an empty batch (J* of (0, N) configurations is (0, 6E, N)); no controller is called."""
    model = ff.load("papadopoulos1992")

    def python_law(t: float, states: ff.State) -> np.ndarray:
        assert len(states.q) > 0, "called a controller for no trajectory"
        return np.zeros_like(states.q)

    law = {"none": None, "joint-pd": ff.JointPD(kp=np.ones(4), kd=1.0), "python": python_law}[controller]
    run = {"duration": 0.1, "dt": 0.01, "output_period": 0.03, "controller": law}
    empty = ff.rollout(model, ff.State(q=np.zeros((0, 4)), omega=np.zeros((0, 3))), **run)
    one = ff.rollout(model, ff.State(q=np.zeros((1, 4))), **run)
    assert empty.status == "finished" and empty.joint_limit_events == ()
    np.testing.assert_array_equal(empty.t, one.t)
    for name in _ARRAYS:
        got, single = getattr(empty, name), getattr(one, name)
        assert (got is None) == (single is None), name
        if single is not None:
            assert got.shape == (single.shape[0], 0, *single.shape[2:]), name
    assert empty.angular_momentum.shape == (empty.t.size, 0, 3)


def test_an_empty_batch_is_checked_like_any_other() -> None:
    """The checks of a rollout run for B = 0 too: the memory of the recorded times, and JointPD's shapes."""
    empty = ff.State(q=np.zeros((0, 4)))
    with pytest.raises(MemoryBudgetError, match=r"^a rollout of 0 trajectories x 100000000000002 recorded states"):
        ff.rollout(ff.load("papadopoulos1992"), empty, 1e12, dt=0.01)
    with pytest.raises(ShapeError, match=r"^JointPD\.kp: shape \(3, 4\) does not broadcast to the states' \(0, 4\)"):
        ff.rollout(ff.load("papadopoulos1992"), empty, 0.1, dt=0.01, controller=ff.JointPD(kp=np.ones((3, 4)), kd=1.0))


def test_a_broadcast_batch_is_checked_as_its_distinct_values() -> None:
    """A NaN in the one row that a broadcast batch repeats is still found (the checks read the distinct entries)."""
    row = np.array([0.0, np.nan, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"State\.q: has NaN or infinite entries"):
        ff.State(q=np.broadcast_to(row, (10**6, 4)))
    with pytest.raises(ValueError, match=r"State\.wheel_speed: 2e\+04 is beyond 10000"):
        ff.State(wheel_speed=np.broadcast_to([2e4], (10**6, 1)))


def test_a_run_stopped_at_its_start_is_written_to_files(tmp_path: Path) -> None:
    """The divergence guard stops a spin beyond meaning at t = 0; the trajectory it returns (no samples) saves."""
    with pytest.raises(ff.SimulationError) as caught:
        ff.simulate(ff.load("papadopoulos1992"), ff.State(q=Q, qdot=[1e300, 0, 0, 0]), 1.0)
    traj = caught.value.trajectory
    assert traj is not None and traj.t.shape == (0,)
    for name in ("run.csv", "run.npz"):
        traj.save(tmp_path / name)
        assert (tmp_path / name).stat().st_size > 0


# the per-trajectory parameters of a rollout of B = 4 trajectories of the 4-joint system, each broken
B = 4
_BROKEN = {  # (value, error class, what the message says)
    "wrong-rows": (np.ones((3, 4)), ShapeError, r"does not broadcast to the states' \(4, 4\)"),
    "wrong-joints": (np.ones((4, 3)), ShapeError, r"does not broadcast to the states' \(4, 4\)"),
    "extra-axis": (np.ones((2, 4, 4)), ShapeError, r"does not broadcast to the states' \(4, 4\)"),
    "empty": (np.ones(0), ShapeError, r"does not broadcast to the states' \(4, 4\)"),
    "nan": (np.array([[1.0, np.nan, 1.0, 1.0]] * B), ValueError, r"has NaN or infinite entries"),
    "inf": (np.array([[1.0, 1.0, np.inf, 1.0]] * B), ValueError, r"has NaN or infinite entries"),
}


@pytest.mark.parametrize("broken", list(_BROKEN))
@pytest.mark.parametrize("name", ["kp", "kd", "q_ref", "qdot_ref"])
def test_joint_pd_parameters_per_trajectory(name: str, broken: str) -> None:
    value, error, match = _BROKEN[broken]
    given = {"kp": 1.0, "kd": 1.0, name: value}
    with pytest.raises(error, match=rf"^JointPD\.{name}: .*{match}"):
        ff.rollout(ff.load("papadopoulos1992"), ff.State(q=np.tile(Q, (B, 1))), 0.02, dt=0.01, controller=ff.JointPD(**given))


@pytest.mark.parametrize(
    ("feedforward", "error", "match"),
    [
        (np.zeros((2, 3, 4)), ShapeError, r"samples of shape \(3, 4\) does not broadcast to the states' \(4, 4\)"),
        (np.zeros((2, 3)), ShapeError, r"samples of shape \(3,\) does not broadcast"),
        (np.zeros((0, 4)), ShapeError, r"expected \(K, N\) or \(K, B, N\) torques per sample, K >= 1"),
        (np.full((2, B, 4), np.nan), ValueError, r"has NaN or infinite entries"),
        (np.full((2, 4), -np.inf), ValueError, r"has NaN or infinite entries"),
    ],
    ids=["wrong-rows", "wrong-joints", "empty", "nan", "inf"],
)
def test_joint_pd_feedforward_per_trajectory(feedforward: np.ndarray, error: type[Exception], match: str) -> None:
    with pytest.raises(error, match=rf"^JointPD\.feedforward: .*{match}"):
        pd = ff.JointPD(kp=1.0, kd=1.0, feedforward=feedforward, feedforward_period=0.01)
        ff.rollout(ff.load("papadopoulos1992"), ff.State(q=np.tile(Q, (B, 1))), 0.02, dt=0.01, controller=pd)


@pytest.mark.parametrize("broken", ["wrong-rows", "wrong-size", "empty", "nan", "inf"])
@pytest.mark.parametrize("name", ["q", "qdot", "omega", "r_cm", "v_cm", "attitude"])
def test_state_fields_per_trajectory(name: str, broken: str) -> None:
    size = {"q": 4, "qdot": 4, "attitude": 4}.get(name, 3)
    good = np.tile([0.0, 0.0, 0.0, 1.0] if name == "attitude" else np.zeros(size), (B, 1))
    value = {
        "wrong-rows": good[:3],
        "wrong-size": np.zeros((B, size + 1)),
        "empty": np.zeros((B, 0)),
        "nan": np.where(np.arange(size) == 0, np.nan, good),
        "inf": np.where(np.arange(size) == 0, np.inf, good),
    }[broken]
    error: type[Exception] = ShapeError if broken in ("wrong-rows", "wrong-size", "empty") else ValueError
    with pytest.raises(error, match=rf"State(\.{name})?: "):
        fields = {"q": np.tile(Q, (B, 1)), "v_cm": np.zeros((B, 3)), name: value}  # another field holds the batch
        ff.rollout(ff.load("papadopoulos1992"), ff.State(**fields), 0.02, dt=0.01)


def test_per_trajectory_models() -> None:
    model = ff.load("papadopoulos1992")
    with pytest.raises(ValueError, match=r"^model: an empty sequence of models"):
        ff.rollout([], ff.State(q=np.tile(Q, (B, 1))), 0.02, dt=0.01)
    with pytest.raises(ShapeError, match=r"^model: 3 per-trajectory models, but initial_states has 4 trajectories"):
        ff.rollout([model] * 3, ff.State(q=np.tile(Q, (B, 1))), 0.02, dt=0.01)
