"""Simulations that cannot hang (issue 11 item 1): divergence guard, stiff-gain check, run estimate, progress, Ctrl-C.

The issue's case: a 6-DOF arm whose last wrist link has 0.005 kg m^2 about its axis, on a 500 kg
spacecraft (examples/models/six_dof_arm.urdf), JointPD kp = 50, kd = 30 sampled every 10 ms for
5 s. The sampled PD is unstable on the wrist (kd h / m = 60 > 2); before, the adaptive integrator
chased the growing state for over 15 minutes. Now a StiffGainsWarning names the joint before the
run and the divergence guard stops it after about a simulated 0.013 s (0.2 s of wall time
measured) with a SimulationError naming the joint and holding the partial trajectory.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import freefloat as ff
from freefloat.cli import app
from freefloat.core.errors import LongRunWarning, StiffGainsWarning
from freefloat.core.state import pack_state
from freefloat.simulation import estimate_run, pd_gain_bounds, pd_stability
from freefloat.simulation._guard import PROGRESS_DELAY, DivergenceGuard, Progress

ARM = Path(__file__).parents[2] / "examples" / "models" / "six_dof_arm.urdf"
Q_TARGET = np.array([0.3, -0.5, 1.0, 0.4, -0.6, 0.8])


@pytest.fixture(scope="module")
def arm() -> ff.Model:
    return ff.load(ARM)


def one_joint() -> ff.Model:
    b = ff.ModelBuilder("one_joint")
    b.add_body("bus", mass=500.0, inertia=[80.0, 90.0, 100.0])
    b.add_body("link", mass=2.0, inertia=[0.01, 0.1, 0.1], com=[0.3, 0, 0], end_effector=[0.6, 0, 0])
    b.add_joint("q1", parent="bus", child="link", origin=[1.0, 0, 0], axis=[0, 0, 1])
    return b.build()


def test_the_issue_hanging_pd_case_stops_with_an_error_naming_the_wrist(arm: ff.Model) -> None:
    m_wrist = np.diagonal(ff.mechanics.free_floating_joint_inertia(arm, np.zeros(6)))[5]
    assert m_wrist == pytest.approx(0.005, rel=1e-3)  # the user's wrist: 0.005 kg m^2 with the spacecraft free
    pd = ff.JointPD(kp=50.0, kd=30.0, q_ref=Q_TARGET)
    with pytest.warns(StiffGainsWarning, match=r"joint 'tool_roll' \(effective inertia 0.005 kg m\^2.*kd < 1 N m s/rad"):
        with pytest.raises(ff.SimulationError, match=r"diverged at t = .*joint 'tool_roll'") as info:
            ff.simulate(arm, ff.State(q=np.zeros(6)), 5.0, pd, sample_period=0.01)
    partial = info.value.trajectory
    assert partial.status == "failed" and "tool_roll" in partial.message
    assert 0.0 < partial.t[-1] < 0.05  # stopped after a few samples of the 5 s asked for
    assert np.all(np.isfinite(partial.q))


@pytest.mark.parametrize(("fraction", "stable"), [(0.5, True), (0.95, True), (1.5, False)])
def test_coupled_stability_factor_predicts_the_simulated_arm(arm: ff.Model, fraction: float, stable: bool) -> None:
    """All six joints together (pd_stability): gains at 0.5 and 0.95 of the stable factor converge (no false alarm), 1.5x diverge."""
    kp, kd, h = np.array([40.0, 40.0, 20.0, 2.0, 2.0, 1.0]), np.array([20.0, 20.0, 10.0, 0.5, 0.5, 0.5]), 0.01
    rho, scale, _ = pd_stability(arm, kp, kd, np.zeros(6), h)
    assert rho > 1.0 and 0.0 < scale < 1.0  # unstable as given, although each joint alone is within its bound
    assert not any(
        k >= b
        for k, b in zip(kd, pd_gain_bounds(np.diagonal(ff.mechanics.free_floating_joint_inertia(arm, np.zeros(6))), h, kd)[0], strict=True)
    )
    pd = ff.JointPD(kp=fraction * scale * kp, kd=fraction * scale * kd, q_ref=0.2 * Q_TARGET)
    run = dict(sample_period=h, fixed_step=h / 10)
    if stable:
        traj = ff.simulate(arm, ff.State(q=np.zeros(6)), 20.0, pd, **run)
        assert traj.status == "finished" and np.abs(traj.q[-1] - 0.2 * Q_TARGET).max() < 1e-3
        return
    with (
        pytest.warns(StiffGainsWarning, match="all joints together"),
        pytest.raises(ff.SimulationError, match=r"diverged.*joint PD can supply"),
    ):
        ff.simulate(arm, ff.State(q=np.zeros(6)), 20.0, pd, **run)


@pytest.mark.parametrize(
    ("kd_fraction", "kp_fraction", "stable"),
    [(0.9, 0.9, True), (1.1, 0.5, False), (0.5, 1.1, False), (0.5, 0.9, True)],
)
def test_pd_gain_bounds_predict_the_simulated_stability(kd_fraction: float, kp_fraction: float, stable: bool) -> None:
    """kd < 2 m/h and kp < 2 kd/h (Jury on the exact zero-order-hold map) against the simulated loop on one free joint."""
    model, h = one_joint(), 0.01
    m = float(ff.mechanics.free_floating_joint_inertia(model, np.zeros(1))[0, 0])
    kd_max, _ = pd_gain_bounds(m, h, 0.0)
    kd = kd_fraction * float(kd_max)
    kp = kp_fraction * 2.0 * min(kd, float(kd_max)) / h
    pd = ff.JointPD(kp=kp, kd=kd, q_ref=0.0)
    run = dict(sample_period=h, fixed_step=h / 10, output_period=h)
    if stable:
        traj = ff.simulate(model, ff.State(q=[0.1]), 6.0, pd, **run)
        assert np.abs(traj.q[-60:]).max() < 1e-3 * 0.1  # decayed
        return
    with pytest.warns(StiffGainsWarning, match="joint 'q1'"), pytest.raises(ff.SimulationError, match=r"diverged.*joint 'q1'"):
        ff.simulate(model, ff.State(q=[0.1]), 6.0, pd, **run)


def test_collapsing_adaptive_step_stops_the_run() -> None:
    """tau = qdot^2 drives qdot to infinity in finite time: the guard stops it (the rate bound comes first now)."""
    with pytest.raises(ff.SimulationError, match=r"joint 'q1' moves at .* beyond 10000 rad/s") as info:
        ff.simulate(one_joint(), ff.State(q=[0.1], qdot=[1.0]), 1.0, lambda t, s: s.qdot**2)
    assert info.value.trajectory.status == "failed" and len(info.value.trajectory) > 1
    # the step-collapse test itself: 20 x 64 right-hand-side calls spanning 1e-12 s, against outputs every 0.01 s
    model = one_joint()
    x0 = pack_state(ff.State(q=[0.1], qdot=[1.0]).resolve(model))
    guard = DivergenceGuard(model, x0, 0.01, None, "RK4 step")
    with pytest.raises(ff.SimulationError, match=r"adaptive step collapsed to .* joint 'q1'"):
        for k in range(64 * 20):
            guard.tick(k * 1e-15, x0)


def test_estimate_counts_steps_samples_and_outputs(arm: ff.Model) -> None:
    est = estimate_run(arm, 10.0, fixed_step=1e-3, sample_period=1e-2)
    assert (est.steps, est.samples, est.outputs) == (10_000, 1_000, 1_001) and not est.adaptive
    assert est.memory_bytes == 1_001 * (13 + 3 * 6 + 7) * 8 and est.seconds > 0
    huge = estimate_run(arm, 1e12, sample_period=0.01)
    assert huge.adaptive and huge.samples == 10**14 and "years" in huge.describe()


def test_a_run_estimated_too_long_warns_before_it_starts(arm: ff.Model) -> None:
    # warnings are errors in the test suite, so the run never starts: the estimate comes first
    with pytest.raises(LongRunWarning, match=r"1e\+09 steps.*over warn_after = 60 s"):
        ff.simulate(arm, ff.State(), 1e6, None, fixed_step=1e-3)
    with pytest.raises(LongRunWarning, match="years"):
        ff.simulate(arm, ff.State(), 1e12, None, sample_period=0.01)


@pytest.mark.filterwarnings("always::freefloat.core.errors.StiffGainsWarning")  # its warning line is part of what it checks
def test_cli_asks_for_confirmation_and_yes_skips_it(tmp_path: Path) -> None:
    scenario = tmp_path / "long.toml"
    scenario.write_text(
        f'model = "{ARM.as_posix()}"\nduration = 1e12\n[integrator]\nsample_period = 0.01\n'
        '[controller]\ntype = "joint_pd"\nkp = 50.0\nkd = 30.0\nq_ref = [0.3, -0.5, 1.0, 0.4, -0.6, 0.8]\n[outputs]\nplots = false\n'
    )
    refused = CliRunner().invoke(app, ["simulate", str(scenario), "--out", str(tmp_path / "a"), "--no-progress"])
    assert refused.exit_code == 1 and "pass --yes" in refused.output and "years" in refused.output
    assert not (tmp_path / "a" / "trajectory.json").exists()
    ran = CliRunner().invoke(app, ["simulate", str(scenario), "--out", str(tmp_path / "b"), "--no-progress", "--yes"])
    assert ran.exit_code == 1  # it ran, the wrist PD diverged, the guard stopped it
    assert "warning: JointPD sampled every 0.01 s is unstable: joint 'tool_roll'" in ran.output
    assert "diverged" in ran.output and "partial trajectory" in ran.output and ".freefloat-staging" not in ran.output
    assert json.loads((tmp_path / "b" / "trajectory.json").read_text())["status"] == "failed"


def test_ctrl_c_returns_what_was_computed(arm: ff.Model) -> None:
    def impatient(t: float, state: ff.State) -> np.ndarray:
        if t >= 0.5:
            raise KeyboardInterrupt
        return np.full(6, 0.01)

    for options in ({"fixed_step": 1e-3}, {"sample_period": 0.01}):
        traj = ff.simulate(arm, ff.State(), 2.0, impatient, **options)
        assert traj.status == "interrupted" and "Ctrl-C" in traj.message
        assert traj.t[-1] == pytest.approx(0.5, abs=0.011) and len(traj) >= 49 and np.all(np.isfinite(traj.q))


def test_progress_callback_and_delayed_bar(arm: ff.Model, monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[tuple[float, float]] = []
    ff.simulate(arm, ff.State(), 1.0, None, fixed_step=1e-3, progress=lambda t, total: seen.append((t, total)))
    assert len(seen) >= 10 and all(total == 1.0 for _, total in seen)
    assert np.all(np.diff([t for t, _ in seen]) > 0) and seen[-1][0] == pytest.approx(1.0)

    clock = [0.0]
    monkeypatch.setattr("freefloat.simulation._guard.time.perf_counter", lambda: clock[0])
    monkeypatch.setattr("freefloat.simulation._guard.interactive", lambda: True)  # a terminal: a bar
    bar = Progress(None, 10.0)  # automatic: no bar for a short run
    clock[0] = PROGRESS_DELAY / 2
    bar.update(1.0)
    assert bar.bar is None
    clock[0] = PROGRESS_DELAY + 1.0
    bar.update(2.0)
    assert bar.bar is not None and bar.bar.tasks[0].completed == 2.0
    bar.close()
    quiet = Progress(False, 10.0)
    clock[0] += 100.0
    quiet.update(5.0)
    assert quiet.bar is None


def test_cli_ctrl_c_writes_the_partial_run_and_exits_130(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import dataclasses

    from freefloat.scenarios import scenario_outputs

    def impatient(t: float, state: ff.State) -> np.ndarray:
        if t >= 0.3:
            raise KeyboardInterrupt  # what Ctrl-C raises in the controller's or the integrator's Python
        return np.zeros(6)

    real = scenario_outputs.run_scenario
    monkeypatch.setattr(scenario_outputs, "run_scenario", lambda sc, **kw: real(dataclasses.replace(sc, controller=impatient), **kw))
    scenario = tmp_path / "s.toml"
    scenario.write_text(f'model = "{ARM.as_posix()}"\nduration = 5.0\n[integrator]\nsample_period = 0.01\n[outputs]\nplots = false\n')
    result = CliRunner().invoke(app, ["simulate", str(scenario), "--out", str(tmp_path / "out"), "--no-progress"])
    assert result.exit_code == 130 and "interrupted (Ctrl-C)" in result.output
    summary = json.loads((tmp_path / "out" / "trajectory.json").read_text())
    assert summary["status"] == "interrupted" and summary["t_end"] == pytest.approx(0.3, abs=0.011)


@pytest.mark.parametrize("sample_period", [None, 0.01])
def test_a_run_of_1e12_seconds_allocates_nothing_up_front_and_ctrl_c_returns_it(arm: ff.Model, sample_period: float | None) -> None:
    """The integration pieces and output instants are made as the run goes (they were arrays of 1e14 entries)."""

    def impatient(t: float, state: ff.State) -> np.ndarray:
        if t >= 1.0:
            raise KeyboardInterrupt
        return np.zeros(6)

    with pytest.warns(LongRunWarning, match="years"):
        traj = ff.simulate(arm, ff.State(), 1e12, impatient, sample_period=sample_period)
    assert traj.status == "interrupted" and 0.98 <= traj.t[-1] <= 1.0 and len(traj) >= 99


def test_progress_outside_a_terminal_goes_to_the_logger(monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    """Batch jobs and notebooks: no bar, one INFO line of the ``freefloat.progress`` logger every LOG_PERIOD seconds."""
    from freefloat.core.feedback import LOG_PERIOD

    clock = [0.0]
    monkeypatch.setattr("freefloat.simulation._guard.time.perf_counter", lambda: clock[0])
    monkeypatch.setattr("freefloat.simulation._guard.interactive", lambda: False)
    caplog.set_level("INFO", logger="freefloat.progress")
    bar = Progress(None, 10.0)
    for k in range(1, 40):
        clock[0] = PROGRESS_DELAY + k  # one second of wall time per simulated quarter second
        bar.update(0.25 * k)
    lines = [r.getMessage() for r in caplog.records if r.name == "freefloat.progress"]
    assert bar.bar is None and 3 <= len(lines) <= 39 / LOG_PERIOD + 1
    assert lines[0] == "simulating: 2 / 10 s (20%), 10 s elapsed, about 40 s left", lines[0]


def test_progress_says_what_it_waits_for_and_leaves_the_wait_out_of_the_estimate(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """A wait (a compile of the engine's kernels, a campaign's workers compiling) is said at once, then with the log's
    period, with its length; the rate and the time left count the work's own wall time, not the wait (issue 44)."""
    clock = [0.0]
    monkeypatch.setattr("freefloat.simulation._guard.time.perf_counter", lambda: clock[0])
    monkeypatch.setattr("freefloat.simulation._guard.interactive", lambda: False)
    caplog.set_level("INFO", logger="freefloat.progress")
    bar = Progress(None, 10.0, what="campaign c", unit="runs", rate=True)
    for now, call in [
        (3.0, lambda: bar.update(1.0)),
        (4.0, lambda: bar.waiting("2 workers compiling the engine")),
        (5.0, lambda: bar.waiting("2 workers compiling the engine")),  # (within the log's period: not logged)
        (20.0, lambda: bar.waiting("2 workers compiling the engine")),
        (44.0, lambda: bar.waiting(None)),
        (60.0, lambda: bar.update(5.0)),
    ]:
        clock[0] = now
        call()
    bar.close()
    lines = [r.getMessage() for r in caplog.records if r.name == "freefloat.progress"]
    assert lines == [
        # (3 s: within the first log period, no line) the wait is said at once
        "campaign c: 1 / 10 runs (10%), 0.25 runs/s, 4 s elapsed, about 36 s left; waiting: 2 workers compiling the engine, 0 s elapsed",
        "campaign c: 1 / 10 runs (10%), 0.25 runs/s, 20 s elapsed, about 36 s left; waiting: 2 workers compiling the engine, 16 s elapsed",
        "campaign c: 1 / 10 runs (10%), 0.25 runs/s, 44 s elapsed, about 36 s left",
        "campaign c: 5 / 10 runs (50%), 0.25 runs/s, 60 s elapsed, about 20 s left",  # (60 s left if the wait counted)
    ], lines
    assert bar.waited == 40.0


def test_a_bar_on_a_terminal_shows_the_wait_beside_the_estimate(monkeypatch: pytest.MonkeyPatch) -> None:
    """On a terminal the bar appears for a wait (nothing else would redraw it: the thread that waits is blocked) and
    shows what it waits for; the note goes when the wait ends."""
    monkeypatch.setattr("freefloat.simulation._guard.interactive", lambda: True)
    bar = Progress(True, 10.0)
    bar.waiting("compiling the engine's kernel rk4_steps for this machine (once)")
    assert bar.bar is not None
    fields = bar.bar.tasks[0].fields
    assert fields["note"] == "waiting: compiling the engine's kernel rk4_steps for this machine (once), 0 s elapsed", fields
    bar.waiting(None)
    bar.update(2.0)
    assert bar.bar.tasks[0].fields["note"] == "" and bar.bar.tasks[0].fields["left"].startswith("about "), bar.bar.tasks[0].fields
    bar.close()
    assert bar.bar is None
