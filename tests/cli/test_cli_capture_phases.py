"""The capture sequence phase by phase (issue 40 items 4 and 7): what happened in each phase is in the report and in
capture.json (a joint's hard stop during the detumbling), the grasp time of ``[grasp] time`` (the target arrives
where the plan grasps it), and the plan kept per robot and path, so that a run with only the target changed does
not plan again."""

from __future__ import annotations

import copy
import dataclasses
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import freefloat as ff
from freefloat.analysis import capture as capture_module
from freefloat.scenarios import _plan_memo
from freefloat.scenarios.capture_outputs import CaptureResult
from freefloat.scenarios.capture_scenario import capture_scenario_from_dict, run_capture_scenario
from freefloat.scenarios.capture_sequence import _earlier, run_capture_sequence

ROOT = Path(__file__).resolve().parents[2]
TUMBLING = tomllib.loads((ROOT / "examples" / "scenarios" / "tumbling_satellite_capture.toml").read_text())


def _scenario(**changes: Any) -> dict[str, Any]:
    """The tumbling example with fewer PIW samples (the path-checked plan is the same kind) and the changes given as
    dotted keys (``payload.velocity``)."""
    data = copy.deepcopy(TUMBLING)
    data["samples"] = 4096
    for dotted, value in changes.items():
        *tables, key = dotted.split(".")
        table = data
        for name in tables:
            table = table.setdefault(name, {})
        table[key] = value
    return data


@pytest.fixture(scope="module")
def result() -> CaptureResult:
    return run_capture_scenario(capture_scenario_from_dict(_scenario()))


def test_a_hard_stop_in_the_detumbling_run_is_in_the_text_and_in_capture_json(result: CaptureResult) -> None:
    plan = result.plan
    assert result.sequence is not None
    # the grasp sets the elbow turning (q2 rate 0.0177 rad/s); its upper limit 5 mrad from the capture posture
    q2 = float(plan.posture.q[1])
    upper = plan.before.joint_upper.copy()
    upper[1] = q2 + 5e-3
    tight = dataclasses.replace(plan.before, joint_upper=upper)
    sequence = run_capture_sequence(dataclasses.replace(plan, before=tight), result.sequence.settings)
    events = sequence.run.after.joint_limit_events  # type: ignore[union-attr]
    assert events and {(e.joint, e.bound, e.kind) for e in events} == {("arm1_q2", "upper", "impact")}
    phases = sequence.as_dict()["phases"]
    assert [p["phase"] for p in phases] == ["before the grasp", "detumbling"]
    assert phases[0]["joint_limit_events"] == []
    assert phases[1]["joint_limit_events"] == [dataclasses.asdict(e) for e in events]
    assert phases[1]["joint_limit_events"][0]["limit"] == upper[1]
    whole = dataclasses.replace(result, plan=dataclasses.replace(plan, before=tight), sequence=sequence)
    assert whole.as_dict()["sequence"]["phases"] == phases  # capture.json
    text = whole.render_text()
    first = events[0]
    assert f"JOINT LIMITS: arm1_q2 at its upper stop {upper[1]:.6g} at t = {first.t:.6g} s" in text
    # the example itself meets no stop, and its z wheel's torque limit acts (as the wheels' lines say)
    plain = result.sequence.as_dict()["phases"]
    assert all(not p["joint_limit_events"] for p in plain)
    assert plain[1]["wheels"]["rw_z"]["torque_limited_outputs"] == int(np.sum(result.sequence.run.after.wheel_torque_saturated[:, 2]))  # type: ignore[index, union-attr]
    assert plain[1]["wheels"]["rw_z"]["torque_limited_outputs"] > 0
    assert "detumbling (t = 0 to 30 s): no joint met a stop; an actuator limit acted at" in result.render_text()


def test_the_grasp_time_brings_the_target_where_the_plan_grasps_it(result: CaptureResult) -> None:
    later = run_capture_scenario(capture_scenario_from_dict(_scenario(**{"grasp.time": 2.5})))
    assert later.sequence is not None and result.sequence is not None
    run, plan = later.sequence.run, later.plan
    assert run.t_capture == 2.5 and run.before.t[0] == 0.0 and run.before.t[-1] == 2.5
    assert plan.target is not None and plan.impact is not None
    at_grasp = run.coast.at(2.5)
    # the target started 2.5 s of its motion before the planned grasp pose (its CM moves uniformly)
    np.testing.assert_allclose(run.target.position[0], plan.target.position - 2.5 * plan.target.velocity, rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(at_grasp.position, plan.target.position, rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(np.abs(at_grasp.attitude @ plan.target.attitude), 1.0, rtol=0.0, atol=1e-12)
    # the robot waited at rest, so the grasp is the planned impact, and the detumbling the same run 2.5 s later
    np.testing.assert_allclose(run.impact.state.velocity, plan.impact.state.velocity, rtol=0.0, atol=1e-12)  # type: ignore[union-attr]
    np.testing.assert_allclose(run.after.t - 2.5, result.sequence.run.after.t, rtol=0.0, atol=1e-12)  # type: ignore[union-attr]
    np.testing.assert_allclose(run.after.omega, result.sequence.run.after.omega, rtol=0.0, atol=1e-9)  # type: ignore[union-attr]
    change = np.abs(later.sequence.momentum_after - later.sequence.momentum_before).max()
    assert change <= 1e-12 * np.abs(later.sequence.momentum_before).max()
    assert later.sequence.as_dict()["grasp_time"] == 2.5
    assert "before the grasp (t = 0 to 2.5 s)" in later.render_text()


def test_a_tumbling_target_run_backwards_then_forwards_is_itself() -> None:
    rng = np.random.default_rng(7)
    target = ff.capture.Target(
        mass=200.0, inertia=[[40.0, 2.0, -1.0], [2.0, 55.0, 3.0], [-1.0, 3.0, 70.0]], position=[1.0, -0.5, 0.3],
        attitude=Rotation.random(random_state=rng), velocity=[0.01, 0.02, -0.005], angular_velocity=[0.03, -0.05, 0.04],
    )  # fmt: skip
    earlier = _earlier(target, 20.0)
    again = ff.simulation.coast(earlier, 20.0).at(20.0)
    np.testing.assert_allclose(again.position, target.position, rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(again.angular_velocity, target.angular_velocity, rtol=0.0, atol=1e-9)
    assert abs(abs(float(again.attitude @ target.attitude)) - 1.0) <= 1e-9
    assert np.abs(earlier.angular_velocity - target.angular_velocity).max() > 1e-3  # it really tumbled


def test_a_run_with_only_the_target_changed_does_not_plan_again(monkeypatch: pytest.MonkeyPatch) -> None:
    calls = {"plan": 0, "candidates": 0}
    plan_once, candidates_once = _plan_memo.fixed_capture_plan, capture_module._candidates

    def plan(*args: Any, **kwargs: Any) -> Any:
        calls["plan"] += 1
        return plan_once(*args, **kwargs)

    def candidates(*args: Any, **kwargs: Any) -> Any:
        calls["candidates"] += 1
        return candidates_once(*args, **kwargs)

    monkeypatch.setattr(_plan_memo, "fixed_capture_plan", plan)
    monkeypatch.setattr(capture_module, "_candidates", candidates)
    _plan_memo.clear()
    first = run_capture_scenario(capture_scenario_from_dict(_scenario()))
    moved = {"payload.velocity": [0.0, 0.012, 0.0], "payload.angular_velocity": [0.0, 0.0, 0.03], "grasp.time": 1.0}
    second = run_capture_scenario(capture_scenario_from_dict(_scenario(**moved)))
    assert calls == {"plan": 1, "candidates": 1}
    # the kept plan gives what planning afresh gives for the new target
    sc = capture_scenario_from_dict(_scenario(**moved))
    fresh = ff.capture.plan_capture(
        sc.model, sc.end_effector, sc.path, mass=sc.mass, inertia=sc.inertia, offset=tuple(sc.offset), samples=sc.samples,
        target_velocity=sc.velocity, target_angular_velocity=sc.angular_velocity, joints=sc.joints, rank_by=sc.rank_by,
    )  # fmt: skip
    assert fresh.ranking is not None and second.plan.ranking is not None
    np.testing.assert_array_equal(second.plan.posture.q, fresh.posture.q)
    np.testing.assert_array_equal(second.plan.ranking.values("spacecraft_rate"), fresh.ranking.values("spacecraft_rate"))
    assert second.plan.impact is not None and fresh.impact is not None
    np.testing.assert_array_equal(second.plan.impact.state.velocity, fresh.impact.state.velocity)
    assert not np.array_equal(second.plan.impact.impulse, first.plan.impact.impulse)  # type: ignore[union-attr]
    # another payload mass, or another robot, is planned afresh
    run_capture_scenario(capture_scenario_from_dict(_scenario(**{"payload.mass": 450.0})))
    assert calls["plan"] == 2
    _plan_memo.clear()


def test_plans_whose_numbers_run_together_are_kept_apart() -> None:
    """R+ = 0.1 with 24,096 samples and R+ = 0.12 with 4,096 write the same digits one after the other: the memo's key
    frames each value, so neither is served the other's plan (a review found the unframed key gave both one plan)."""
    one = capture_scenario_from_dict(_scenario(**{"path.R_plus": 0.1, "samples": 24096}))
    other = capture_scenario_from_dict(_scenario(**{"path.R_plus": 0.12, "samples": 4096}))
    assert (one.R_plus, one.samples, other.R_plus, other.samples) == (0.1, 24096, 0.12, 4096)
    assert _plan_memo.plan_key(one) != _plan_memo.plan_key(other)
    assert _plan_memo.plan_key(one) == _plan_memo.plan_key(capture_scenario_from_dict(_scenario(**{"path.R_plus": 0.1, "samples": 24096})))


def test_a_campaign_varies_the_grasp_time_and_the_target_motion_and_plans_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """The new keys are scenario keys like any other: a campaign over the example varies ``grasp.time`` and
    ``payload.velocity[0]`` (campaigns.spec's dotted keys), each run in this process (campaigns.execute) sees its
    values, and the robot's plan is made once for all of them."""
    from freefloat.campaigns import campaign_from_dict, plan_runs
    from freefloat.campaigns.execute import RunTask, execute_run

    spec = campaign_from_dict(
        {
            "scenario": "tumbling_satellite_capture.toml",
            "parameters": {
                "samples": {"values": [4096]},
                "grasp.time": {"values": [0.0, 1.5]},
                "payload.velocity[0]": {"values": [0.01, 0.013]},
            },
            "record": {"scalars": ["sequence.grasp_time", "grasp.target_velocity[0]", "sequence.detumble.delta_v"]},
        },
        source="c.toml",
        base=ROOT / "examples" / "scenarios",
    )
    calls = {"plan": 0}
    plan_once = _plan_memo.fixed_capture_plan

    def plan(*args: Any, **kwargs: Any) -> Any:
        calls["plan"] += 1
        return plan_once(*args, **kwargs)

    monkeypatch.setattr(_plan_memo, "fixed_capture_plan", plan)
    _plan_memo.clear()
    seen = []
    for run in plan_runs(spec):
        task = RunTask(run.run_id, run.index, spec.kind, spec.scenario, spec.base, spec.function, run.parameters, spec.scalars, ())
        outcome = execute_run(task)
        assert outcome.status == "ok", outcome
        seen.append((outcome.scalars["sequence.grasp_time"], outcome.scalars["grasp.target_velocity[0]"]))
        assert (seen[-1][0], seen[-1][1]) == (run.parameters["grasp.time"], run.parameters["payload.velocity[0]"])
    assert sorted(seen) == [(0.0, 0.01), (0.0, 0.013), (1.5, 0.01), (1.5, 0.013)]
    assert calls["plan"] == 1
    _plan_memo.clear()
