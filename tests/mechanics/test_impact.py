"""The grasp of a moving target as an impact (``ff.capture.Target``, ``ff.capture.impact``): against ourselves.

Momentum of robot plus target, computed independently before (the robot's own H+ rows, the target's momentum)
and after (the combined model's H+ rows, through ``ff.linear_momentum`` / ``ff.angular_momentum``), is the same
to 1e-12 relative on random 3D trees with revolute and prismatic joints, both joint modes; the energy lost is
the kinetic energy before minus after (``ff.kinetic_energy`` of each model) and >= 0 for free joints; a system
at rest stays at rest; a target of negligible mass changes nothing, to its size; a batch of 10^4 targets is
one call equal to the loop; every bad input is refused naming the field. Pinocchio's view of the same grasp:
tests/oracle/test_pinocchio_impact.py.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import freefloat as ff
from impacts import random_state, random_target
from trees import random_inertia, random_trees

Target = ff.capture.Target
impact = ff.capture.impact

#: Momentum conservation, relative to the sum of the sizes of the robot's and the target's momentum before:
#: measured 2026-11-26 (2-core dev VM) on 400 random trees (30 % sliding joints) x both joint modes: at most 8.6e-16
#: (linear) and 3.3e-15 (angular).
MOMENTUM_BOUND = 1e-12
#: Energy lost against ff.kinetic_energy of both models, relative to the energy before (measured there: 1.1e-14).
ENERGY_BOUND = 1e-12


def momentum_before(model: ff.Model, state: ff.State, target: ff.capture.Target) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Linear and angular momentum (about the inertial origin) of robot plus target, and the size of each sum."""
    s = state.resolve(model)
    p_robot = ff.linear_momentum(model, s.velocity)
    l_robot = ff.angular_momentum(model, s.q, s.velocity, attitude=s.attitude) + np.cross(s.r_cm, p_robot)
    h = target.momentum
    l_target = h[3:] + np.cross(target.position, h[:3])
    size_p = float(np.linalg.norm(p_robot) + np.linalg.norm(h[:3]))
    size_l = float(np.linalg.norm(l_robot) + np.linalg.norm(l_target))
    return p_robot + h[:3], l_robot + l_target, size_p, size_l


def momentum_after(result: ff.capture.Impact) -> tuple[np.ndarray, np.ndarray]:
    """Linear and angular momentum (about the inertial origin) of the combined model's post-impact state."""
    model, s = result.model, result.state
    p = ff.linear_momentum(model, s.velocity)
    return p, ff.angular_momentum(model, s.q, s.velocity, attitude=s.attitude) + np.cross(s.r_cm, p)


@settings(max_examples=60)
@given(model=random_trees(prismatic=0.3), seed=st.integers(0, 2**32 - 1), joints=st.sampled_from(["free", "locked"]))
def test_momentum_is_conserved_and_energy_is_accounted(model: ff.Model, seed: int, joints: str) -> None:
    rng = np.random.default_rng(seed)
    state = random_state(model, rng)
    e = int(rng.integers(model.n_end_effectors))
    target = random_target(model, state, e, rng)
    r = impact(model, state, target, end_effector=e, joints=joints)

    p0, l0, size_p, size_l = momentum_before(model, state, target)
    p1, l1 = momentum_after(r)
    assert np.linalg.norm(p1 - p0) <= MOMENTUM_BOUND * size_p
    assert np.linalg.norm(l1 - l0) <= MOMENTUM_BOUND * size_l
    # the impulse is the jump of the target's momentum, and the target now moves with the grasping body
    assert np.allclose(
        r.impulse,
        Target(**{**vars(target), "velocity": r.target_twist[:3], "angular_velocity": r.target_twist[3:]}).momentum - target.momentum,
        rtol=0,
        atol=1e-12 * size_p + 1e-12 * size_l,
    )
    k = int(model.end_effector_body[e])
    offset = model.end_effector_point[e] + r.payload_offset
    jac = ff.point_jacobian(r.model, r.state.q, k, offset, attitude=r.state.attitude)
    assert np.allclose(jac @ r.state.velocity, r.target_twist, rtol=0, atol=1e-11 * max(1.0, np.abs(r.target_twist).max()))

    s = state.resolve(model)
    before = ff.kinetic_energy(model, s.q, s.velocity) + float(target.kinetic_energy)
    after = ff.kinetic_energy(r.model, r.state.q, r.state.velocity)
    assert abs((before - after) - r.energy_lost) <= ENERGY_BOUND * before
    if joints == "free":
        assert np.all(r.joint_impulse == 0.0)
        assert r.energy_lost >= -ENERGY_BOUND * before
        assert np.allclose(r.state.q, s.q) and np.allclose(r.state.attitude, s.attitude)
    else:
        assert np.array_equal(r.state.qdot, s.qdot)  # the locked joints keep their rates, exactly
        # the rigid-robot part of the loss is >= 0; the joints did the work qdot . joint_impulse
        assert r.energy_lost + float(s.qdot @ r.joint_impulse) >= -ENERGY_BOUND * before


@pytest.mark.parametrize("joints", ["free", "locked"])
def test_joints_at_rest_lose_energy(joints: str) -> None:
    rng = np.random.default_rng(3)
    model = ff.models.papadopoulos1992(arms=2)
    for _ in range(20):
        state = ff.State(q=rng.uniform(-2, 2, size=4), omega=rng.normal(scale=0.1, size=3), v_cm=rng.normal(scale=0.1, size=3))
        r = impact(model, state, random_target(model, state, 1, rng), end_effector=1, joints=joints)
        assert r.energy_lost >= 0.0


def test_at_rest_nothing_happens() -> None:
    rng = np.random.default_rng(0)
    model = ff.models.papadopoulos1992(arms=2)
    state = ff.State(q=[0.3, 1.1, -0.4, 0.9], attitude=Rotation.from_euler("z", 0.7), r_cm=[1.0, 2.0, 0.0])
    target = Target(mass=300.0, inertia=random_inertia(rng, 300.0), position=[2.0, 3.0, 0.5], attitude=Rotation.random(random_state=rng))
    for joints in ("free", "locked"):
        r = impact(model, state, target, end_effector=1, joints=joints)
        assert np.all(r.impulse == 0.0) and np.all(r.joint_impulse == 0.0) and r.energy_lost == 0.0
        assert np.all(r.state.velocity == 0.0)
        assert np.allclose(
            r.state.r_cm, (model.total_mass * np.array([1.0, 2.0, 0.0]) + 300.0 * target.position) / (model.total_mass + 300.0)
        )


@pytest.mark.parametrize("joints", ["free", "locked"])
def test_a_negligible_target_changes_nothing(joints: str) -> None:
    rng = np.random.default_rng(1)
    model = ff.models.papadopoulos1992(arms=2)
    state = random_state(model, rng)
    s = state.resolve(model)
    mass = 1e-9
    target = random_target(model, state, 0, rng)
    tiny = Target(**{**vars(target), "mass": mass, "inertia": random_inertia(rng, mass)})
    r = impact(model, state, tiny, joints=joints)
    ratio = mass / model.total_mass
    velocity = np.abs(s.velocity).max() + np.abs(target.velocity).max() + np.abs(target.angular_velocity).max()
    assert np.abs(r.state.velocity - s.velocity).max() <= 100 * ratio * velocity
    assert np.abs(r.state.r_cm - s.r_cm).max() <= 100 * ratio * np.linalg.norm(target.position - s.r_cm)
    assert np.abs(r.joint_impulse).max() <= 1e3 * mass * velocity
    assert abs(r.energy_lost) <= 1e3 * mass * velocity**2


def test_the_combined_model_holds_the_target_where_it_was() -> None:
    """The combined model's CM and inertia are the robot's and the target's, placed at the grasp instant."""
    rng = np.random.default_rng(2)
    model = ff.models.papadopoulos1992(arms=1)
    state = random_state(model, rng)
    target = random_target(model, state, 0, rng)
    r = impact(model, state, target)
    assert r.model.total_mass == pytest.approx(model.total_mass + float(target.mass))
    s = r.state
    # the target's CM seen through the combined model: system CM + rotated body point
    k = int(model.end_effector_body[0])
    point = model.end_effector_point[0] + r.payload_offset
    seen = s.r_cm + Rotation.from_quat(s.attitude).apply(ff.point_positions(r.model, s.q, k, point))
    assert np.allclose(seen, target.position, atol=1e-12)
    body = Rotation.from_quat(s.attitude).as_matrix() @ ff.body_rotations(model, s.q)[k]
    assert np.allclose(body @ r.payload_inertia @ body.T, target.inertia_inertial, atol=1e-12 * np.abs(target.inertia).max())
    assert r.model.payloads[-1]["name"] == "target"


def test_a_batch_of_targets_is_one_call_equal_to_the_loop() -> None:
    rng = np.random.default_rng(4)
    model = ff.models.papadopoulos1992(arms=2)
    state = random_state(model, rng)
    targets = random_target(model, state, 0, rng, size=(10_000,))
    for joints in ("free", "locked"):
        batch = impact(model, state, targets, joints=joints)
        assert batch.shape == (10_000,)
        assert batch.state.velocity.shape == (10_000, 6 + model.n_joints) and np.shape(batch.energy_lost) == (10_000,)
        for i in range(0, 10_000, 250):
            one = impact(model, state, targets[i], joints=joints)
            np.testing.assert_allclose(batch.state.velocity[i], one.state.velocity, rtol=1e-13, atol=1e-15)
            np.testing.assert_allclose(batch.state.r_cm[i], one.state.r_cm, rtol=1e-14, atol=1e-15)
            np.testing.assert_allclose(batch.impulse[i], one.impulse, rtol=1e-12, atol=1e-12)
            np.testing.assert_allclose(batch.joint_impulse[i], one.joint_impulse, rtol=1e-12, atol=1e-12)
            assert batch.energy_lost[i] == pytest.approx(one.energy_lost, rel=1e-12, abs=1e-12)
            np.testing.assert_allclose(batch.payload_offset[i], one.payload_offset, rtol=1e-13, atol=1e-15)
    models = impact(model, state, targets[:3]).model  # a batch's combined models, one per target
    assert models.shape == (3,) and all(isinstance(m, ff.Model) for m in models)
    # a batch of robot states with one target broadcasts too
    states = ff.State(
        q=np.stack([state.q, state.q + 0.1]), qdot=state.qdot, omega=state.omega, attitude=state.attitude, r_cm=state.r_cm, v_cm=state.v_cm
    )
    both = impact(model, states, targets[7])
    one = impact(
        model,
        ff.State(q=state.q + 0.1, qdot=state.qdot, omega=state.omega, attitude=state.attitude, r_cm=state.r_cm, v_cm=state.v_cm),
        targets[7],
    )
    np.testing.assert_allclose(both.state.velocity[1], one.state.velocity, rtol=1e-13, atol=1e-15)


# ------------------------------------------------------------------------------------------------ bad input
GOOD = {"mass": 10.0, "inertia": [1.0, 2.0, 2.5], "position": [1.0, 0.0, 0.0], "velocity": [0.1, 0.0, 0.0]}
BAD_TARGETS = [
    ("mass", {"mass": 0.0}),
    ("mass", {"mass": -3.0}),
    ("mass", {"mass": np.nan}),
    ("mass", {"mass": np.inf}),
    ("mass", {"mass": "heavy"}),
    ("mass", {"mass": 1e12}),
    ("mass[2]", {"mass": [1.0, 2.0, -1.0]}),
    ("inertia", {"inertia": [1.0, 1.0, 3.0]}),  # triangle inequality
    ("inertia", {"inertia": [0.0, 1.0, 1.0]}),  # not positive definite
    ("inertia", {"inertia": -1.0}),
    ("inertia", {"inertia": [[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]}),  # not symmetric
    ("inertia", {"inertia": [1.0, np.nan, 1.0]}),
    ("inertia", {"inertia": np.ones((2, 2))}),
    ("inertia[1]", {"inertia": np.stack([np.eye(3), np.diag([1.0, 1.0, 5.0])])}),
    ("position", {"position": [1.0, np.nan, 0.0]}),
    ("position", {"position": [1.0, 2.0]}),
    ("position", {"position": [1e13, 0.0, 0.0]}),
    ("velocity", {"velocity": [np.inf, 0.0, 0.0]}),
    ("velocity", {"velocity": [1e9, 0.0, 0.0]}),
    ("angular_velocity", {"angular_velocity": [0.0, 0.0, np.nan]}),
    ("angular_velocity", {"angular_velocity": 1.0}),
    ("attitude", {"attitude": [0.0, 0.0, 0.0, 2.0]}),
    ("attitude", {"attitude": [0.0, 0.0, 1.0]}),
    ("attitude", {"attitude": [0.0, 0.0, np.nan, 1.0]}),
]


@pytest.mark.parametrize(("field", "change"), BAD_TARGETS)
def test_each_bad_target_field_is_named(field: str, change: dict) -> None:
    with pytest.raises(ValueError, match="^" + re.escape(f"Target.{field}") + "(?![A-Za-z_])"):
        Target(**{**GOOD, **change})


def test_bad_target_errors_are_model_errors() -> None:
    with pytest.raises(ff.ModelError) as info:
        Target(**{**GOOD, "mass": -1.0})
    assert info.value.field == "Target.mass"
    with pytest.raises(ff.ShapeError, match="batch"):
        Target(**{**GOOD, "mass": [1.0, 2.0], "position": np.zeros((3, 3))})


def test_bad_impact_arguments() -> None:
    model = ff.models.papadopoulos1992(arms=2)
    state = ff.State(q=[0.3, 1.1, -0.4, 0.9])
    target = Target(**GOOD)
    with pytest.raises(ff.UnknownNameError):
        impact(model, state, target, end_effector=2)
    with pytest.raises(ff.UnknownNameError, match="arm"):
        impact(model, state, target, end_effector="nope")
    for joints in ("rigid", "Free", None):
        with pytest.raises(ValueError, match="joints: expected one of 'free', 'locked'"):
            impact(model, state, target, joints=joints)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="target"):
        impact(model, state, {"mass": 1.0})  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="state"):
        impact(model, [0.3, 1.1, -0.4, 0.9], target)  # type: ignore[arg-type]
    with pytest.raises(ff.ShapeError, match="do not broadcast"):
        impact(model, ff.State(q=np.zeros((2, 4))), Target(**{**GOOD, "mass": [1.0, 2.0, 3.0]}))


def test_a_target_the_hand_is_not_on_is_refused() -> None:
    """The end-effector point must lie within GRASP_REACH of the target's largest radii of gyration from its CM: just
    inside is an impact, just outside (and the issue's target 50 m away) is refused, naming the distance."""
    from freefloat.mechanics.impact import GRASP_REACH

    model = ff.models.papadopoulos1992(arms=2)
    state = ff.State(q=[0.3, 1.1, -0.4, 0.9], r_cm=[1.0, -2.0, 0.5], attitude=Rotation.from_euler("z", 0.4))
    s = state.resolve(model)
    tip = s.r_cm + s.rotation.apply(ff.end_effector_positions(model, s.q)[1])
    inertia = np.diag([20.0, 30.0, 45.0])
    r_g = np.sqrt(45.0 / 200.0)
    along = np.array([0.6, 0.0, 0.8])
    for factor, refused in ((0.999, False), (1.001, True)):
        target = Target(mass=200.0, inertia=inertia, position=tip + factor * GRASP_REACH * r_g * along, velocity=[0.0, 0.02, 0.0])
        if refused:
            with pytest.raises(ValueError, match=rf"^target: its CM at .* is {factor * GRASP_REACH * r_g:.6g} m from the grasping"):
                impact(model, state, target, end_effector=1)
        else:
            assert impact(model, state, target, end_effector=1).energy_lost >= 0.0
    far = Target(mass=200.0, inertia=inertia, position=tip + np.array([50.0, 0.0, 0.0]))
    with pytest.raises(ValueError, match=r"is 50 m from the grasping end effector 'arm2_ee' at \[.*\] m \(inertial\), more than 10 of its"):
        impact(model, state, far, end_effector=1)
    # in a batch, the target the hand is farthest from is named by its index
    batch = Target(mass=[200.0, 200.0, 200.0], inertia=inertia, position=np.stack([tip, tip + np.array([50.0, 0.0, 0.0]), tip]))
    with pytest.raises(ValueError, match=r"^target\[1\]: its CM"):
        impact(model, state, batch, end_effector=1)
