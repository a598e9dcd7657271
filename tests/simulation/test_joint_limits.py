"""Joint limits in simulation (issue 11 item 2): hard stops that conserve momentum, or violation flags.

The issue's case: a constant 20 N m on a joint limited to 2.0 rad (the elbow of
examples/models/six_dof_arm.urdf), which used to reach 8.67 rad unnoticed. With the stops (the
default) it stays within the limit; the stop is an internal joint impulse through H+, so the
linear momentum does not change at all, one impulse keeps the angular momentum to 1e-14
(test_one_impulse_...), and over the run the angular momentum drifts only by the integrator's
error: measured max |h(t) - h(0)| over 5 s, 1.3e-8 N m s with RK4 at 1 ms (8.4e-10 at 0.5 ms:
fourth order, and already there before the first impact), 1.0e-10 N m s adaptive (DOP853,
1e-10), against a peak arm momentum |D_q qdot| of several N m s. Bounds: 5e-8 and 1e-9 N m s.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import freefloat as ff
from freefloat.simulation._stops import JointStops, limit_violations
from freefloat.simulation.trajectory import JointLimitEvent

ARM = Path(__file__).parents[2] / "examples" / "models" / "six_dof_arm.urdf"
ELBOW = 2


@pytest.fixture(scope="module")
def arm() -> ff.Model:
    return ff.load(ARM)


def push_elbow(t: float, state: ff.State) -> np.ndarray:
    tau = np.zeros(6)
    tau[ELBOW] = 20.0
    return tau


def arm_momentum_scale(traj: ff.Trajectory) -> float:
    """The largest angular momentum of the arm's own motion, |D_q qdot| (N m s): the scale the drift is compared with."""
    blocks = ff.inertia_blocks(traj.model, traj.q)
    return float(np.abs(np.einsum("tij,tj->ti", blocks.D_q, traj.qdot)).max())


@pytest.mark.parametrize(("options", "drift"), [({"fixed_step": 1e-3}, 5e-8), ({"sample_period": 0.01}, 1e-9)], ids=["rk4", "adaptive"])
def test_constant_torque_against_a_limit_stays_within_it_and_conserves_momentum(arm: ff.Model, options: dict, drift: float) -> None:
    assert arm.joint_upper[ELBOW] == 2.0
    traj = ff.simulate(arm, ff.State(), 5.0, push_elbow, **options)
    assert traj.status == "finished"
    assert traj.q[:, ELBOW].max() <= 2.0 + 1e-12 and traj.q[-1, ELBOW] == pytest.approx(2.0, abs=1e-9)
    assert np.all(traj.q <= arm.joint_upper + 1e-12) and np.all(traj.q >= arm.joint_lower - 1e-12)
    impacts = [e for e in traj.joint_limit_events if e.joint == "elbow"]
    assert impacts[0].kind == "impact" and impacts[0].bound == "upper" and impacts[0].limit == 2.0 and impacts[0].value > 1.0
    free = ff.simulate(arm, ff.State(), 1.0, push_elbow, **options, joint_limits="flag")  # the same motion without stops
    t_cross = np.interp(2.0, free.q[:, ELBOW], free.t)  # (monotonic up to the limit)
    assert impacts[0].t == pytest.approx(t_cross, abs=0.01) and not traj.joint_limits_violated
    h = traj.angular_momentum
    assert np.abs(h - h[0]).max() < drift and arm_momentum_scale(traj) > 1.0
    assert np.array_equal(traj.v_cm, np.zeros_like(traj.v_cm))  # linear momentum: exactly zero throughout


def test_with_stops_off_the_violation_and_its_time_are_flagged(arm: ff.Model) -> None:
    traj = ff.simulate(arm, ff.State(), 5.0, push_elbow, fixed_step=1e-3, joint_limits="flag")
    assert traj.q[:, ELBOW].max() > 4.0  # unconstrained, as before
    assert traj.joint_limits_violated
    elbow = [e for e in traj.joint_limit_events if e.joint == "elbow"]
    first_beyond = int(np.argmax(traj.q[:, ELBOW] > 2.0))
    assert elbow[0].kind == "violation" and elbow[0].bound == "upper" and elbow[0].limit == 2.0
    assert elbow[0].t == traj.t[first_beyond] and elbow[0].value == traj.q[first_beyond:, ELBOW][: _span(traj, first_beyond)].max()


def _span(traj: ff.Trajectory, start: int) -> int:
    inside = np.flatnonzero(traj.q[start:, ELBOW] <= 2.0)
    return int(inside[0]) if inside.size else len(traj) - start


@pytest.mark.parametrize("restitution", [0.0, 0.5, 1.0])
def test_one_impulse_reverses_the_rate_and_keeps_both_momenta(arm: ff.Model, restitution: float) -> None:
    """At the limit, moving outward: q'+ = -e q'-, h and v_cm unchanged, kinetic energy down by (1 - e^2) q'^2 / (2 (H+^-1)_ii)."""
    rng = np.random.default_rng(5)
    state = ff.State(q=[0.3, -0.2, 2.0, 0.5, 0.4, -0.3], qdot=rng.uniform(-0.5, 0.5, 6), omega=[0.01, -0.02, 0.015], v_cm=[0.1, 0, 0])
    state = state.resolve(arm)
    x = np.concatenate([state.r_cm, state.v_cm, state.attitude, state.omega, state.q, state.qdot])
    x[13 + 6 + ELBOW] = 0.8  # outward at the upper limit

    def momenta(x: np.ndarray) -> tuple[np.ndarray, float]:
        velocity = np.concatenate([x[3:6], x[10:13], x[19:]])
        return ff.angular_momentum(arm, x[13:19], velocity, attitude=x[6:10]), float(ff.kinetic_energy(arm, x[13:19], velocity))

    h_before, ke_before = momenta(x)
    stops = JointStops(arm, "stop", restitution)
    after = x.copy()
    stops.apply(0.0, after, joints=[ELBOW])
    h_after, ke_after = momenta(after)
    assert after[13 + 6 + ELBOW] == pytest.approx(-restitution * 0.8, abs=1e-12)
    assert np.abs(h_after - h_before).max() < 1e-14 * max(1.0, np.abs(h_before).max())
    assert np.array_equal(after[3:6], x[3:6]) and np.array_equal(after[:3], x[:3])
    h_inv = np.linalg.inv(ff.system_inertia_matrix(arm, x[13:19]))[6 + ELBOW, 6 + ELBOW]
    assert ke_before - ke_after == pytest.approx(0.5 * (1 - restitution**2) * 0.8**2 / h_inv, rel=1e-9, abs=1e-13)
    assert stops.events[0].kind == "impact" and stops.events[0].value == 0.8


def test_elastic_stops_keep_the_work_energy_balance(arm: ff.Model) -> None:
    """e = 1: the stops do no work, so the kinetic energy still changes by the work of the joint torques alone."""
    hold = 0.01
    traj = ff.simulate(arm, ff.State(), 3.0, push_elbow, sample_period=hold, output_period=hold, rtol=1e-12, atol=1e-12, restitution=1.0)
    assert len([e for e in traj.joint_limit_events if e.joint == "elbow"]) >= 2  # it bounces back and comes again
    work = np.concatenate([[0.0], np.cumsum(np.sum(traj.joint_torque[:-1] * np.diff(traj.q, axis=0), axis=-1))])
    assert np.abs(traj.kinetic_energy - traj.kinetic_energy[0] - work).max() < 1e-6 * traj.kinetic_energy.max()


def test_bad_limit_options_and_a_start_beyond_a_limit(arm: ff.Model) -> None:
    with pytest.raises(ValueError, match=r"initial_state\.q: joint 'elbow' = 2\.5 rad is beyond its upper limit 2 rad"):
        ff.simulate(arm, ff.State(q=[0, 0, 2.5, 0, 0, 0]), 1.0)
    ff.simulate(arm, ff.State(q=[0, 0, 2.5, 0, 0, 0]), 0.1, joint_limits="flag")  # allowed without stops
    with pytest.raises(ValueError, match="joint_limits: 'hard'"):
        ff.simulate(arm, ff.State(), 1.0, joint_limits="hard")
    with pytest.raises(ValueError, match=r"restitution: must be in \[0, 1\]"):
        ff.simulate(arm, ff.State(), 1.0, restitution=1.5)


def test_limit_events_survive_save_and_load(arm: ff.Model, tmp_path: Path) -> None:
    traj = ff.simulate(arm, ff.State(), 2.0, push_elbow, fixed_step=1e-3, joint_limits="flag")
    for name in ("run.npz", "run.csv"):
        back = ff.Trajectory.load(traj.save(tmp_path / name), model=arm)
        assert back.joint_limit_events == traj.joint_limit_events and back.joint_limits_violated


def test_scenario_joint_limits_table(tmp_path: Path) -> None:
    from freefloat.scenarios.scenario import load_scenario, run_scenario

    text = (
        f'model = "{ARM.as_posix()}"\nduration = 2.0\n[integrator]\nmethod = "RK4"\nfixed_step = 0.001\n'
        '[actuation]\ntype = "constant"\njoint_torque = [0, 0, 20, 0, 0, 0]\n'
    )
    (tmp_path / "stop.toml").write_text(text)
    (tmp_path / "flag.toml").write_text(text + '[joint_limits]\nmode = "flag"\n')
    stopped = run_scenario(load_scenario(tmp_path / "stop.toml"))
    flagged = run_scenario(load_scenario(tmp_path / "flag.toml"))
    assert stopped.q[:, ELBOW].max() <= 2.0 + 1e-12 and not stopped.joint_limits_violated
    assert flagged.q[:, ELBOW].max() > 2.0 and flagged.joint_limits_violated
    (tmp_path / "bad.toml").write_text(text + "[joint_limits]\nrestitution = 2.0\n")
    with pytest.raises(ff.ModelError, match=r"joint_limits\.restitution: 2\.0 is outside \[0, 1\]"):
        load_scenario(tmp_path / "bad.toml")


def test_rollouts_flag_each_trajectory_beyond_a_limit(arm: ff.Model) -> None:
    """Batched rollouts apply no stops; the violations are recorded with the trajectory index."""
    tau = np.zeros((4, 6))
    tau[1, ELBOW] = 20.0  # trajectory 1 pushes its elbow up, trajectory 3 down; 0 and 2 stay inside
    tau[3, ELBOW] = -20.0
    pd = ff.JointPD(kp=0.0, kd=0.0, feedforward=tau[None])
    traj = ff.rollout(arm, ff.State(q=np.zeros((4, 6))), 2.0, dt=1e-3, controller=pd, output_period=0.01)
    elbow = [e for e in traj.joint_limit_events if e.joint == "elbow"]
    assert {(e.trajectory, e.bound) for e in elbow} == {(1, "upper"), (3, "lower")} and elbow[0].kind == "violation"
    up = next(e for e in elbow if e.trajectory == 1)
    assert up.t == traj.t[int(np.argmax(traj.q[:, 1, ELBOW] > 2.0))]
    beyond = (traj.q > arm.joint_upper) | (traj.q < arm.joint_lower)  # the definition, sample by sample
    assert {e.trajectory for e in traj.joint_limit_events} == set(np.flatnonzero(beyond.any(axis=(0, 2))).tolist())


@pytest.mark.parametrize("restitution", [0.0, 0.7, 1.0])
def test_a_joint_starting_on_its_stop_and_pushed_into_it(arm: ff.Model, restitution: float) -> None:
    """Bounces shorter than an integrator step at the limit (they once restarted the integrator forever)."""
    traj = ff.simulate(arm, ff.State(q=[0, 0, 2.0, 0, 0, 0]), 0.5, push_elbow, restitution=restitution)
    assert traj.status == "finished" and traj.q[:, ELBOW].max() <= 2.0 + 1e-12
    h = traj.angular_momentum
    assert np.abs(h - h[0]).max() < 1e-9


@pytest.mark.parametrize("case", range(6))
def test_random_trees_stay_within_their_limits_with_momentum_kept(case: int) -> None:
    """Random 3D trees (7 joints, branches, a fixed joint), random limits, torques and restitution, each integrator."""
    import dataclasses

    from trees import build_random_model

    rng = np.random.default_rng(100 + case)
    model = build_random_model(np.random.default_rng(case), [3, 2], [1, None], [None, 0])
    lower, upper = rng.uniform(-1.0, -0.2, model.n_joints), rng.uniform(0.2, 1.0, model.n_joints)
    model = dataclasses.replace(model, joint_lower=lower, joint_upper=upper)
    torques = rng.uniform(-10.0, 10.0, (30, model.n_joints))
    options = [{"sample_period": 0.1}, {"fixed_step": 1e-3}, {}][case % 3]
    restitution = [0.0, 0.5, 1.0][case % 3]
    traj = ff.simulate(model, ff.State(), 3.0, lambda t, s: torques[min(int(t / 0.1), 29)], restitution=restitution, **options)
    assert traj.status == "finished" and traj.joint_limit_events and not traj.joint_limits_violated
    assert np.all(traj.q <= upper + 1e-12) and np.all(traj.q >= lower - 1e-12)
    h = traj.angular_momentum
    assert np.abs(h - h[0]).max() < 1e-9  # measured: 1e-13 adaptive, 1e-11 RK4 at 1 ms


def _spans_one_joint_at_a_time(model: ff.Model, t: np.ndarray, q: np.ndarray) -> list[JointLimitEvent]:
    """The definition, one run (q (T, N)), as a readable loop: per joint, its upper then its lower limit, each span of
    consecutive outputs beyond it in time order (its furthest value; its end the first output back inside, None if
    none), then all of them ordered by start (stably)."""
    events = []
    for i, name in enumerate(model.joint_names):
        for side, limit in (("upper", float(model.joint_upper[i])), ("lower", float(model.joint_lower[i]))):
            k = 0
            while k < len(t):
                if not (q[k, i] > limit if side == "upper" else q[k, i] < limit):
                    k += 1
                    continue
                start = k
                while k < len(t) and (q[k, i] > limit if side == "upper" else q[k, i] < limit):
                    k += 1
                span = q[start:k, i]
                worst = float(span.max() if side == "upper" else span.min())
                end = float(t[k]) if k < len(t) else None
                events.append(JointLimitEvent(name, side, limit, "violation", float(t[start]), end, worst))
    return sorted(events, key=lambda e: e.t)


@pytest.mark.parametrize("seed", range(4))
def test_limit_spans_of_runs_and_batches_equal_the_definition(seed: int) -> None:
    """``limit_violations`` (one compiled pass over the samples: ``_stops.limit_spans``) against the loop above: random walks
    across both limits, NaN gaps, spans from the first output and to the last, one-sided and infinite limits; a batch
    (T, B, N) gives each trajectory's events, in trajectory order, with its index."""
    import dataclasses

    model = ff.models.papadopoulos1992()
    model = dataclasses.replace(model, joint_lower=np.array([-1.0, -0.5, -np.inf, -0.2]), joint_upper=np.array([1.0, 0.5, np.inf, 0.3]))
    rng = np.random.default_rng(seed)
    checked = 0
    for _ in range(60):
        steps, batch = int(rng.integers(1, 40)), int(rng.integers(1, 6))
        q = np.cumsum(rng.normal(scale=0.3, size=(steps, batch, 4)), axis=0)
        q[0, 0, 0] = 1.5  # beyond from the first output
        q[-1, -1, 1] = -0.9  # beyond at the last
        gaps = rng.random(q.shape) < 0.05
        q[gaps] = np.nan
        t = np.cumsum(rng.uniform(0.01, 1.0, steps))
        expected = [dataclasses.replace(e, trajectory=b) for b in range(batch) for e in _spans_one_joint_at_a_time(model, t, q[:, b])]
        assert limit_violations(model, t, q) == expected
        assert limit_violations(model, t, q[:, 0]) == _spans_one_joint_at_a_time(model, t, q[:, 0])
        checked += len(expected)
    assert checked > 500  # spans were found, of both bounds


def test_limit_spans_on_threads_and_with_more_spans_than_the_first_room(monkeypatch: pytest.MonkeyPatch) -> None:
    """A batch large enough for a range per thread (asserted), in a strided view as a rollout's q is (its states), with
    more spans than a range's first room (2 per joint and trajectory: the range runs again, asserted): the events of
    the definition, trajectory by trajectory."""
    import dataclasses

    from freefloat.engine import stops as _stops
    from freefloat.engine.threads import range_count, thread_count

    model = ff.models.papadopoulos1992()
    model = dataclasses.replace(model, joint_lower=np.full(4, -0.2), joint_upper=np.full(4, 0.2))
    rng = np.random.default_rng(7)
    steps, batch = 300, 40
    states = np.zeros((steps, batch, 11))
    states[:, :, 3:7] = np.cumsum(rng.normal(scale=0.15, size=(steps, batch, 4)), axis=0) % 1.0 - 0.5  # many crossings
    q = states[:, :, 3:7]
    t = np.linspace(0.0, 3.0, steps)
    calls: list[tuple[int, int]] = []
    kernel = _stops.limit_spans

    def spy(*args: object) -> int:
        calls.append((int(args[3]), int(args[4])))  # type: ignore[call-overload]
        return int(kernel(*args))

    monkeypatch.setattr(_stops, "limit_spans", spy)
    got = limit_violations(model, t, q)
    expected = [dataclasses.replace(e, trajectory=b) for b in range(batch) for e in _spans_one_joint_at_a_time(model, t, q[:, b])]
    assert got == expected and len(expected) > 2 * 4 * batch
    ranges = set(calls)
    assert len(ranges) == range_count(batch, thread_count())  # one range per thread (2 on the project's machines)
    assert len(calls) > len(ranges)  # a range ran again with more room
