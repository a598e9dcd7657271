"""Detumbling after a capture (issue "Capturing a moving target", item 5): the combined system brought to rest, or to a
commanded attitude, by the thrusters and the joint torques (1991 eq. 27 with the task "zero rates"), and its cost."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import freefloat as ff
from freefloat.control import Detumble, detumble_cost


def _captured(spin_deg: float = 3.0) -> tuple[ff.Model, ff.State, ff.Model]:
    """The 1992 two-arm robot after grasping a 500 kg target drifting at 1 cm/s and spinning at ``spin_deg`` deg/s."""
    robot = ff.models.papadopoulos1992()
    state = ff.State(q=[0.3, 1.2, -0.4, 0.9])
    tip = ff.end_effector_positions(robot, state.q)[0]
    target = ff.capture.Target(
        mass=500.0,
        inertia=[300.0, 250.0, 200.0],
        position=tip + np.array([0.5, 0.0, 0.0]),
        velocity=[0.01, 0.0, 0.0],
        angular_velocity=np.radians([0.0, 0.0, spin_deg]),
    )
    hit = ff.capture.impact(robot, state, target)
    return hit.model, hit.state, robot


def numpy_form(controller: Any) -> Any:
    """The controller called from Python at each sample: its numpy form, the law as written (given as itself, a
    fixed-step run would take the compiled kernel, which tests/control/test_compiled.py checks against this form)."""
    return lambda t, s: controller(t, s)


def test_every_rate_decays_as_the_gain_says() -> None:
    """Exact model, no saturation: zdot0(t) = exp(-k t) zdot0(0) (eq. 28 with the task "zero rates") but for the
    controller's hold of each sample: the deviation is first order in the sample period h (measured 8.17e-5 of
    |zdot0(0)| at h = 1 ms, 4.08e-5 at 0.5 ms, 1.63e-5 at 0.2 ms), so it halves with h and vanishes with it."""
    model, state, _ = _captured()
    k = 0.5
    errors = []
    for h in (1e-3, 5e-4):
        traj = ff.simulate(model, state, 4.0, numpy_form(Detumble(model, rate_gain=k)), fixed_step=h, sample_period=h, output_period=0.1)
        start = traj.velocity[0]
        assert np.abs(start).max() > 1e-2, "the grasp should leave the system tumbling"
        errors.append(np.abs(traj.velocity - np.exp(-k * traj.t)[:, None] * start).max() / np.abs(start).max())
    assert errors[1] < 4.5e-5
    assert errors[0] / errors[1] == pytest.approx(2.0, rel=0.01)


def test_the_run_ends_at_rest() -> None:
    model, state, _ = _captured()
    traj = ff.simulate(
        model, state, 30.0, numpy_form(Detumble(model, rate_gain=0.5)), fixed_step=1e-2, sample_period=0.05, output_period=0.05
    )
    cost = detumble_cost(traj)
    assert cost.time_to_rest is not None and 5.0 < cost.time_to_rest < 15.0
    assert max(cost.final_rates) < 1e-5
    late = traj.t >= cost.time_to_rest
    assert np.abs(traj.omega[late]).max() <= 1e-3 and np.abs(traj.qdot[late]).max() <= 1e-3
    assert (
        np.linalg.norm(traj.omega[~late][-1]) > 1e-3
        or np.abs(traj.qdot[~late][-1]).max() > 1e-3
        or (np.linalg.norm(traj.v_cm[~late][-1]) > 1e-3)
    )


def test_the_reported_delta_v_is_the_velocity_the_thrusters_took_away() -> None:
    """A system drifting without rotation: the thruster force stays along -v_cm, so the reported delta-v (the held
    force's impulse over the total mass) equals the drop of |v_cm| the simulation shows, to rounding."""
    model = ff.models.papadopoulos1992()
    state = ff.State(q=[0.3, 1.2, -0.4, 0.9], v_cm=[0.02, -0.01, 0.0])
    traj = ff.simulate(
        model, state, 8.0, numpy_form(Detumble(model, rate_gain=0.4)), fixed_step=1e-2, sample_period=0.05, output_period=0.05
    )
    cost = detumble_cost(traj, specific_impulse=220.0)
    drop = np.linalg.norm(traj.v_cm[0]) - np.linalg.norm(traj.v_cm[-1])
    assert drop > 0.9 * np.linalg.norm(traj.v_cm[0])
    assert cost.delta_v == pytest.approx(drop, rel=1e-12)
    assert cost.thruster_impulse == pytest.approx(drop * model.total_mass, rel=1e-12)
    isp_g0 = 220.0 * ff.control.STANDARD_GRAVITY
    assert cost.propellant_mass == pytest.approx(model.total_mass * (1.0 - np.exp(-drop / isp_g0)), rel=1e-10)
    assert np.abs(traj.omega).max() < 1e-12  # the torque that keeps it so (the force acts at the spacecraft's CM) is paid
    assert cost.torque_impulse > 0.0


def test_a_commanded_attitude_is_reached() -> None:
    model, state, _ = _captured()
    goal = Rotation.from_euler("z", 20.0, degrees=True)
    traj = ff.simulate(model, state, 40.0, numpy_form(Detumble(model, rate_gain=0.6, attitude=goal)), fixed_step=1e-2, sample_period=0.02)
    final = Rotation.from_quat(traj.attitude[-1])
    assert (final.inv() * goal).magnitude() < 1e-4
    assert detumble_cost(traj).time_to_rest is not None


def test_without_thruster_force_the_cm_keeps_its_velocity_and_the_rest_comes_to_rest() -> None:
    model, state, _ = _captured()
    traj = ff.simulate(model, state, 20.0, numpy_form(Detumble(model, rate_gain=0.5, force=False)), fixed_step=1e-2, sample_period=0.05)
    np.testing.assert_allclose(traj.v_cm, np.broadcast_to(traj.v_cm[0], traj.v_cm.shape), rtol=0, atol=1e-15)
    assert np.linalg.norm(traj.v_cm[0]) > 1e-3
    assert np.abs(traj.spacecraft_force).max() == 0.0
    assert detumble_cost(traj).time_to_rest is None  # |v_cm| never drops: not at rest by the default test
    assert detumble_cost(traj, rest_velocity=None).time_to_rest is not None


def test_limits_slow_it_down_and_are_recorded() -> None:
    model, state, _ = _captured()
    limits = ff.ActuatorLimits(spacecraft_torque=2.0, spacecraft_force=1.0, joint_torque=0.5)
    free = ff.simulate(model, state, 30.0, numpy_form(Detumble(model, rate_gain=0.5)), fixed_step=1e-2, sample_period=0.05)
    held = ff.simulate(model, state, 30.0, numpy_form(Detumble(model, rate_gain=0.5)), fixed_step=1e-2, sample_period=0.05, limits=limits)
    assert held.saturated.any() and not free.saturated.any()
    cost = detumble_cost(held)
    assert cost.peak_torque <= 2.0 * np.sqrt(3) + 1e-12 and np.all(cost.peak_joint_torque <= 0.5 + 1e-12)
    assert cost.time_to_rest is not None and cost.time_to_rest > detumble_cost(free).time_to_rest  # type: ignore[operator]


def test_after_a_capture_event_in_a_simulation() -> None:
    """``controller_after=Detumble(robot)``: told of the grasp (``on_capture``), it detumbles the combined model."""
    robot = ff.models.papadopoulos1992()
    state = ff.State(q=[0.3, 1.2, -0.4, 0.9])
    tip = ff.end_effector_positions(robot, state.q)[0]
    target = ff.capture.Target(mass=500.0, inertia=[300.0, 250.0, 200.0], position=tip, angular_velocity=np.radians([0.0, 0.0, 3.0]))
    capture = ff.Capture(target, at=0.5, controller_after=Detumble(robot, rate_gain=0.5))
    run = ff.simulate(robot, state, 25.0, capture=capture, fixed_step=1e-2, sample_period=0.05)
    assert run.after is not None and run.after.model is run.impact.model  # type: ignore[union-attr]
    assert np.abs(run.after.velocity[0]).max() > 1e-3
    cost = detumble_cost(run.after)
    assert cost.time_to_rest is not None and max(cost.final_rates) < 1e-4


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"rate_gain": 0.0}, ValueError, "rate_gain: every gain must be positive"),
        ({"rate_gain": [1.0, 2.0]}, ff.ShapeError, r"rate_gain: expected a scalar or \(10,\)"),
        ({"attitude": [0.0, 0.0, 0.0, 2.0]}, ValueError, "attitude: expected a unit quaternion"),
        ({"attitude_gain": 1.0}, ValueError, "attitude_gain: given without an attitude"),
        ({"attitude": [0.0, 0.0, 0.0, 1.0], "attitude_gain": -1.0}, ValueError, "attitude_gain: expected a positive"),
        ({"rate_gain": float("inf")}, ValueError, "rate_gain: every gain must be positive and finite"),
    ],
)
def test_bad_settings_name_the_field(kwargs: dict, error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        Detumble(ff.models.papadopoulos1992(), **kwargs)


def test_bad_cost_requests_name_the_field() -> None:
    model, state, _ = _captured()
    traj = ff.simulate(model, state, 0.1, numpy_form(Detumble(model)), fixed_step=1e-2)
    with pytest.raises(ValueError, match="specific_impulse: expected a positive"):
        detumble_cost(traj, specific_impulse=0.0)
    with pytest.raises(ValueError, match="rest_rate: expected a positive"):
        detumble_cost(traj, rest_rate=float("nan"))
    batch = ff.rollout(model, ff.State(q=np.tile(state.q, (2, 1))), 0.02, dt=1e-2)
    with pytest.raises(ff.ShapeError, match="expected one run"):
        detumble_cost(batch)


def test_detumble_takes_a_model_name_or_a_model_file() -> None:
    """As everywhere a model is taken (README): a built-in name or a model file path gives the controller of that
    model, the same actuation as the Model itself."""
    state = ff.State(q=[0.3, 1.2, -0.4, 0.9], qdot=[0.02, -0.01, 0.03, 0.0], omega=[0.0, 0.0, 0.01], v_cm=[0.01, 0.0, 0.0])
    path = Path(__file__).resolve().parents[2] / "examples" / "models" / "papadopoulos1992_two_arm.toml"
    for given, model in (("papadopoulos1992", ff.models.papadopoulos1992()), (path, ff.load(path)), (str(path), ff.load(path))):
        by_name, by_model = Detumble(given, rate_gain=0.5)(0.0, state), Detumble(model, rate_gain=0.5)(0.0, state)
        assert by_name.joint_torque is not None and by_model.joint_torque is not None
        np.testing.assert_array_equal(by_name.joint_torque, by_model.joint_torque)
        np.testing.assert_array_equal(by_name.spacecraft_force, by_model.spacecraft_force)
        np.testing.assert_array_equal(by_name.spacecraft_torque, by_model.spacecraft_torque)
    with pytest.raises(ff.ModelError, match="is neither a model file nor a built-in model; did you mean 'papadopoulos1992'"):
        Detumble("papadopoulos1993")
