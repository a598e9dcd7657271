"""Capture of a moving target during a simulation (``ff.simulate(..., capture=ff.Capture(...))``).

The momentum of robot plus target (inertial frame, about the inertial origin) is the same just before and just
after the grasp to 1e-12 relative, at a time event and at a distance event, both joint modes, adaptive and RK4,
on the 1992 system and a random 3D tree with a sliding joint; the post-event state is ``ff.capture.impact`` of
the pre-event state and the coasting target (the same call, equal); the target coasts torque-free (its
angular momentum constant, its energy kept, an axisymmetric body against the closed form); a capture that
never comes ends the run with the closest approach and its time; bad capture descriptions are refused
naming the field. The capture event against MuJoCo (its robot from the raw URDF, its own combined system and grasp,
never freefloat's converters) is tests/oracle/test_impact_mujoco_raw.py.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import freefloat as ff
from impacts import random_state
from trees import build_random_model, random_inertia

#: Momentum of robot plus target just after the grasp against just before, relative to the sum of the sizes of the
#: robot's and the target's momentum. Measured 2026-11-26 (2-core dev VM) over the 16 cases below: at most 3.1e-16
#: (linear) and 8.3e-16 (angular).
JUMP_BOUND = 1e-12
#: The same through both phases (1 s): the integrator's error (DOP853 at rtol = atol = 1e-10; RK4 at 0.005 s).
#: Measured there: at most 2.9e-16 (linear) and 1.7e-14 (angular).
DRIFT_BOUND = 1e-10


def system(name: str) -> tuple[ff.Model, ff.State]:
    if name == "1992":
        return ff.models.papadopoulos1992(arms=1), ff.State(q=[0.5, 1.0], qdot=[0.02, -0.01], omega=[0.0, 0.0, 0.005])
    rng = np.random.default_rng(11)
    model = build_random_model(rng, [3, 2], [None, 0], [1, None], prismatic=0.3, sliding=(0, 2))
    state = random_state(model, rng)
    return model, ff.State(q=state.q, qdot=0.2 * state.qdot, omega=0.2 * state.omega, attitude=state.attitude, r_cm=state.r_cm)


def tip_motion(model: ff.Model, state: ff.State, e: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """The end-effector point's position and velocity at ``state`` (inertial frame)."""
    s = state.resolve(model)
    tip = s.r_cm + s.rotation.apply(ff.end_effector_positions(model, s.q)[e])
    k = int(model.end_effector_body[e])
    jac = ff.point_jacobian(model, s.q, k, model.end_effector_point[e], attitude=s.attitude)
    return tip, (jac @ s.velocity)[:3]


def closing_target(model: ff.Model, state: ff.State, gap: float = 0.4, speed: float = 0.4) -> tuple[ff.capture.Target, np.ndarray]:
    """A tumbling target whose grasp point starts ``gap`` m from the end effector and closes at ``speed`` m/s
    (relative to the end effector's velocity at t = 0); returns it and the grasp point (target frame)."""
    rng = np.random.default_rng(5)
    tip, v_tip = tip_motion(model, state)
    u = np.array([0.6, 0.0, 0.8])  # from the end effector to the grasp point, inertial
    attitude = Rotation.random(random_state=rng)
    grasp = np.array([-0.3, 0.1, 0.05])  # target frame, from its CM
    cm = tip + gap * u - attitude.apply(grasp)
    target = ff.capture.Target(
        mass=150.0, inertia=random_inertia(rng, 150.0), position=cm, attitude=attitude, velocity=v_tip - speed * u,
        angular_velocity=[0.0, 0.0, 0.0],
    )  # fmt: skip
    return target, grasp


def total_momentum(model: ff.Model, state: ff.State, target: ff.capture.Target) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Linear and angular momentum (about the inertial origin) of robot plus target, and the sizes of the sums' terms."""
    s = state.resolve(model)
    p_robot = ff.linear_momentum(model, s.velocity)
    l_robot = ff.angular_momentum(model, s.q, s.velocity, attitude=s.attitude) + np.cross(s.r_cm, p_robot)
    h = target.momentum
    l_target = h[3:] + np.cross(target.position, h[:3])
    size_p = float(np.linalg.norm(p_robot) + np.linalg.norm(h[:3]))
    size_l = float(np.linalg.norm(l_robot) + np.linalg.norm(l_target))
    return p_robot + h[:3], l_robot + l_target, size_p, size_l


CASES = [(name, kind) for name in ("1992", "tree") for kind in ("at", "within")]


@pytest.mark.parametrize("integrator", ["adaptive", "rk4"])
@pytest.mark.parametrize("joints", ["free", "locked"])
@pytest.mark.parametrize(("name", "kind"), CASES)
def test_momentum_of_robot_plus_target_is_the_same_across_the_grasp(name: str, kind: str, joints: str, integrator: str) -> None:
    model, state = system(name)
    target, grasp = closing_target(model, state)
    when = {"at": 0.35} if kind == "at" else {"within": 0.2}
    step = {"fixed_step": 0.005} if integrator == "rk4" else {}
    run = ff.simulate(model, state, 1.0, capture=ff.Capture(target, grasp_point=grasp, joints=joints, **when), **step)
    assert run.captured and run.status == "finished", run.message
    assert run.after is not None and run.impact is not None and run.t_capture is not None
    assert run.after.model is run.impact.model and run.after.t[-1] == pytest.approx(1.0, abs=1e-12)
    if kind == "at":
        assert run.t_capture == 0.35 and run.before.t[-1] == 0.35
    else:
        assert 0.3 < run.t_capture < 0.8
    # just before: the robot's last state and the coasting target there (independent of the run's sums); just after
    p0, l0, size_p, size_l = total_momentum(model, run.before.state(-1), run.coast.at(run.t_capture))
    s1 = run.after.state(0).resolve(run.after.model)
    p1 = ff.linear_momentum(run.after.model, s1.velocity)
    l1 = ff.angular_momentum(run.after.model, s1.q, s1.velocity, attitude=s1.attitude) + np.cross(s1.r_cm, p1)
    assert np.linalg.norm(p1 - p0) <= JUMP_BOUND * size_p
    assert np.linalg.norm(l1 - l0) <= JUMP_BOUND * size_l
    # the run's own record of the total momentum: the same at both samples of the event, and through both phases
    i = len(run.before)
    assert run.t[i - 1] == run.t[i] == run.t_capture
    assert np.linalg.norm(run.linear_momentum[i] - run.linear_momentum[i - 1]) <= JUMP_BOUND * size_p
    assert np.linalg.norm(run.angular_momentum[i] - run.angular_momentum[i - 1]) <= JUMP_BOUND * size_l
    assert np.abs(run.linear_momentum - run.linear_momentum[0]).max() <= DRIFT_BOUND * size_p
    assert np.abs(run.angular_momentum - run.angular_momentum[0]).max() <= DRIFT_BOUND * size_l


@pytest.mark.parametrize("joints", ["free", "locked"])
def test_the_post_event_state_is_the_impact_of_the_pre_event_state(joints: str) -> None:
    model, state = system("tree")
    target, grasp = closing_target(model, state)
    run = ff.simulate(model, state, 1.0, capture=ff.Capture(target, within=0.2, grasp_point=grasp, joints=joints, end_effector=0))
    assert run.impact is not None and run.after is not None and run.t_capture is not None
    again = ff.capture.impact(model, run.before.state(-1), run.coast.at(run.t_capture), end_effector=0, joints=joints)
    for field in ("q", "qdot", "omega", "attitude", "r_cm", "v_cm"):
        assert np.array_equal(getattr(run.impact.state, field), getattr(again.state, field)), field
        assert np.allclose(getattr(run.after, field)[0], getattr(again.state, field), rtol=0.0, atol=1e-15), field
    assert np.array_equal(run.impact.impulse, again.impulse) and run.impact.energy_lost == again.energy_lost
    assert run.after.model.total_mass == pytest.approx(model.total_mass + 150.0, rel=1e-15)
    # the adaptive integrator located the crossing: the end effector is at the capture distance there, not before
    assert run.grasp_distance[-1] == pytest.approx(0.2, abs=1e-9)
    assert np.all(run.grasp_distance[:-1] > 0.2)


def test_with_fixed_steps_the_event_is_taken_at_the_end_of_the_step_that_crossed() -> None:
    model, state = system("1992")
    target, grasp = closing_target(model, state)
    run = ff.simulate(model, state, 1.0, fixed_step=0.01, capture=ff.Capture(target, within=0.2, grasp_point=grasp))
    assert run.t_capture is not None and round(run.t_capture / 0.01) * 0.01 == pytest.approx(run.t_capture, abs=1e-12)
    assert run.grasp_distance[-1] <= 0.2 < run.grasp_distance[-2]


def test_a_start_within_the_distance_captures_at_once() -> None:
    model, state = system("1992")
    target, grasp = closing_target(model, state, gap=0.1)
    run = ff.simulate(model, state, 0.5, capture=ff.Capture(target, within=0.2, grasp_point=grasp))
    assert run.t_capture == 0.0 and len(run.before) == 1 and run.after is not None and run.after.t[0] == 0.0


def test_the_target_coasts_torque_free() -> None:
    rng = np.random.default_rng(2)
    target = ff.capture.Target(
        mass=80.0, inertia=random_inertia(rng, 80.0), position=[1.0, 2.0, 3.0], attitude=Rotation.random(random_state=rng),
        velocity=[0.1, -0.2, 0.05], angular_velocity=[0.3, -0.5, 0.4],
    )  # fmt: skip
    times = np.linspace(0.0, 60.0, 61)
    later = ff.simulation.coast(target, 60.0).at(times)
    # its momentum (linear, and angular about its CM, inertial frame) constant; its CM moving uniformly
    assert np.abs(later.momentum - target.momentum).max() <= 1e-13 * np.abs(target.momentum).max()  # measured 2.8e-16
    assert np.allclose(later.position, target.position + times[:, None] * target.velocity, rtol=0.0, atol=1e-14)
    # Euler's equations: the energy ½ Lᵀ R I⁻¹ Rᵀ L kept to the integrator's tolerance, the body really tumbling
    assert np.abs(later.kinetic_energy - target.kinetic_energy).max() <= 1e-10 * float(target.kinetic_energy)  # measured 1.1e-12
    assert np.ptp(later.angular_velocity, axis=0).max() > 0.1


def test_an_axisymmetric_target_follows_the_closed_form() -> None:
    """R(t) = exp(t L/I_t) R0 exp(-t (I_a - I_t)/I_t ω3 e3): a steady precession about L and a spin about the axis."""
    i_t, i_a = 2.0, 3.5
    r0 = Rotation.from_euler("xyz", [0.3, -0.2, 1.1])
    target = ff.capture.Target(mass=10.0, inertia=[i_t, i_t, i_a], position=[0.0, 0.0, 0.0], attitude=r0, angular_velocity=[0.4, 0.2, -0.6])
    omega3 = r0.inv().apply(np.array(target.angular_velocity))[2]
    moment = np.array(target.momentum[3:])
    motion = ff.simulation.coast(target, 100.0)
    for t in np.linspace(0.0, 100.0, 21):
        exact = Rotation.from_rotvec(moment / i_t * t) * r0 * Rotation.from_rotvec([0.0, 0.0, -(i_a - i_t) / i_t * omega3 * t])
        assert (exact.inv() * Rotation.from_quat(motion.attitude(t))).magnitude() <= 1e-9  # measured 6.2e-12 at 100 s


def test_the_run_records_the_target_until_the_grasp() -> None:
    model, state = system("1992")
    target, grasp = closing_target(model, state)
    target = ff.capture.Target(**{**vars(target), "angular_velocity": [0.05, -0.1, 0.2]})
    run = ff.simulate(model, state, 1.0, capture=ff.Capture(target, at=0.5, grasp_point=grasp))
    assert run.target.shape == (len(run.before),)
    assert np.array_equal(run.target.position, run.coast.at(run.before.t).position)
    assert np.abs(run.target.momentum - target.momentum).max() <= 1e-13 * np.abs(target.momentum).max()


def test_a_capture_that_never_comes_says_how_close_it_came() -> None:
    model, state = system("1992")
    target, grasp = closing_target(model, state, gap=0.5, speed=0.0)
    run = ff.simulate(model, state, 2.0, capture=ff.Capture(target, within=0.1, grasp_point=grasp))
    assert not run.captured and run.status == "no capture"
    assert run.after is None and run.impact is None and run.t_capture is None
    assert run.before.status == "finished" and run.before.t[-1] == 2.0  # the whole run kept
    distance, when = run.closest_approach
    assert distance == pytest.approx(run.grasp_distance.min(), abs=1e-12) and distance > 0.1
    assert when == pytest.approx(run.before.t[int(np.argmin(run.grasp_distance))], abs=1e-12)
    assert f"no closer than {distance:.6g} m" in run.message and f"at t = {when:.6g} s" in run.message
    assert "not within 0.1 m" in run.message
    assert len(run.t) == len(run.linear_momentum) == len(run.angular_momentum) == len(run.before)


class Told:
    """A controller that records what it is told and the times it sees."""

    def __init__(self) -> None:
        self.impacts: list[object] = []
        self.times: list[float] = []

    def __call__(self, t: float, state: ff.State) -> np.ndarray:
        self.times.append(t)
        return np.zeros(2)

    def on_capture(self, impact: object) -> None:
        self.impacts.append(impact)


def test_the_controllers_are_told_and_the_second_takes_over() -> None:
    model, state = system("1992")
    target, grasp = closing_target(model, state)
    first, second = Told(), Told()
    run = ff.simulate(
        model, state, 1.0, first, sample_period=0.05, capture=ff.Capture(target, at=0.4, grasp_point=grasp, controller_after=second)
    )
    assert first.impacts == [run.impact] and second.impacts == [run.impact]
    assert max(first.times) <= 0.4 and min(second.times) == pytest.approx(0.4, abs=1e-12)  # absolute times in both phases
    # the same controller (a joint PD) goes on with the combined model
    pd = ff.JointPD(kp=5.0, kd=20.0, q_ref=[0.5, 1.0])
    run = ff.simulate(model, state, 1.0, pd, capture=ff.Capture(target, at=0.4, grasp_point=grasp))
    assert run.status == "finished" and run.after is not None and np.any(run.after.joint_torque != 0.0)


@pytest.mark.parametrize(
    ("change", "error", "message"),
    [
        ({"at": None}, ValueError, "Capture: give either at (the capture time, s) or within (the capture distance, m), not neither"),
        ({"within": 0.2}, ValueError, "Capture: give either at (the capture time, s) or within (the capture distance, m), not both"),
        ({"at": None, "within": -0.1}, ValueError, "Capture.within: the capture distance must be finite and > 0 m, got -0.1"),
        ({"at": None, "within": 0.0}, ValueError, "Capture.within: the capture distance must be finite and > 0 m"),
        ({"at": -1.0}, ValueError, "Capture.at: the capture time must be finite and >= 0 s"),
        ({"at": "soon"}, TypeError, "Capture.at: expected a number"),
        ({"grasp_point": [1.0, 2.0]}, ValueError, "Capture.grasp_point: expected 3 finite numbers"),
        ({"joints": "welded"}, ValueError, "Capture.joints: expected one of 'free', 'locked', got 'welded'"),
        ({"controller_after": 3}, TypeError, "Capture.controller_after: expected a callable"),
        ({"end_effector": 1.5}, TypeError, "Capture.end_effector: expected a name or an index"),
    ],
)
def test_bad_captures_are_refused_naming_the_field(change: dict, error: type, message: str) -> None:
    target = ff.capture.Target(mass=10.0, inertia=1.0, position=[1.0, 0.0, 0.0])
    with pytest.raises(error, match=re.escape(message)):
        ff.Capture(**{"target": target, "at": 0.5, **change})


def test_bad_captures_for_the_run_are_refused_naming_the_field() -> None:
    model, state = system("1992")
    target = ff.capture.Target(mass=10.0, inertia=1.0, position=[1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=re.escape("Capture.at: the capture time 3 s is beyond the duration 2 s")):
        ff.simulate(model, state, 2.0, capture=ff.Capture(target, at=3.0))
    with pytest.raises(ValueError, match=re.escape("Capture.end_effector: unknown end effector 1; known: 0=arm1_ee")):
        ff.simulate(model, state, 2.0, capture=ff.Capture(target, at=1.0, end_effector=1))
    with pytest.raises(ValueError, match=re.escape("Capture.end_effector: unknown end effector 'hand'")):
        ff.simulate(model, state, 2.0, capture=ff.Capture(target, within=0.1, end_effector="hand"))
    with pytest.raises(ValueError, match=re.escape("Capture.at: 0.015 s is not a multiple of fixed_step = 0.01 s")):
        ff.simulate(model, state, 2.0, fixed_step=0.01, capture=ff.Capture(target, at=0.015))
    with pytest.raises(ValueError, match=re.escape("Capture.target: expected one target, got a batch of shape (2,)")):
        ff.Capture(ff.capture.Target(mass=[1.0, 2.0], inertia=1.0, position=[1.0, 0.0, 0.0]), at=1.0)
    with pytest.raises(TypeError, match=re.escape("capture: expected a freefloat.Capture, got dict")):
        ff.simulate(model, state, 2.0, capture={"at": 1.0})  # type: ignore[call-overload]


def test_an_event_before_the_first_output_of_a_piece_with_joint_stops() -> None:
    """A terminal event that fires before any output instant of an adaptive piece, on a model whose joints have
    limits (the stops' path of the integrator): the run stops there (it failed with 'need at least one array')."""
    model, state = system("tree")
    assert np.isfinite(model.joint_upper).any()

    def soon(t: float, s: ff.State) -> float:
        return t - 0.004

    traj = ff.simulate(model, state, 1.0, events=[soon], output_period=0.01)
    assert traj.status == "event" and traj.t[-1] == pytest.approx(0.004, abs=1e-9) and len(traj) == 2


def test_a_failure_after_the_grasp_keeps_both_phases() -> None:
    model, state = system("1992")
    target, grasp = closing_target(model, state)

    def broken(t: float, s: ff.State) -> np.ndarray:
        raise RuntimeError("no torque today")

    said = "after the grasp at t = 0.4 s (times from the grasp): the controller raised RuntimeError at t = 0 s"
    with pytest.raises(ff.SimulationError, match=re.escape(said)) as info:
        ff.simulate(model, state, 1.0, capture=ff.Capture(target, at=0.4, grasp_point=grasp, controller_after=broken))
    run = info.value.run  # type: ignore[attr-defined]
    assert run.status == "failed" and run.t_capture == 0.4 and run.impact is not None and run.before.t[-1] == 0.4
    assert info.value.trajectory is run.after and run.after.status == "failed"


@pytest.mark.parametrize("at", [0.0, 1.0])
def test_a_capture_at_the_start_or_the_end_of_the_run(at: float) -> None:
    model, state = system("1992")
    target, grasp = closing_target(model, state)
    run = ff.simulate(model, state, 1.0, capture=ff.Capture(target, at=at, grasp_point=grasp))
    assert run.captured and run.status == "finished" and run.t_capture == at and run.after is not None
    assert run.before.t[-1] == run.after.t[0] == at and run.after.t[-1] == 1.0
    assert len(run.before if at == 0.0 else run.after) == 1  # the phase of zero length: one sample
    i = len(run.before)
    jump = np.linalg.norm(run.angular_momentum[i] - run.angular_momentum[i - 1])
    assert jump <= JUMP_BOUND * np.linalg.norm(run.angular_momentum[i - 1])
