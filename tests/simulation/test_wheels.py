"""Reaction wheels (``Model.wheels``, :mod:`freefloat.core.wheels`): declared, simulated, limited, used by controllers.

A wheel spun up on a free-floating spacecraft turns the spacecraft the other way by the split computed by hand; the
momentum of the whole system, wheels included, is conserved over 1000 s to the integrator's tolerance; the torque
and speed limits act and are recorded; a spacecraft with an arm and two offset wheels agrees with MuJoCo, where each
wheel is a body of its own on a hinge (and a 1e-7 change of a wheel's inertia fails that bound); model files, the
builder and the side file declare them, and bad ones are refused naming the field; the controllers send the
spacecraft torque to them; a grasp keeps the momentum of robot, wheels and target.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import freefloat as ff
from freefloat.core.wheels import reaction_wheel
from freefloat.mechanics.momentum import wheel_spin_momentum

# ------------------------------------------------------------------ the MuJoCo model: hub, arm, two offset wheels
HUB_MASS, HUB_INERTIA, HUB_CM = 300.0, np.diag([40.0, 50.0, 60.0]), np.array([0.05, -0.02, 0.01])
#: name, spin axis, position in the bus frame (m), mass (kg), Js, Jt (kg m^2)
WHEELS = [
    ("rw_x", np.array([1.0, 0.0, 0.0]), np.array([0.3, 0.1, 0.0]), 4.0, 0.08, 0.045),
    ("rw_z", np.array([0.0, 0.0, 1.0]), np.array([-0.2, 0.0, 0.25]), 5.0, 0.10, 0.06),
]
ARM_MASS, ARM_INERTIA, ARM_CM, ARM_ORIGIN = 20.0, np.diag([0.5, 2.0, 2.0]), np.array([0.6, 0.0, 0.0]), np.array([0.8, 0.0, 0.0])
#: freefloat against MuJoCo, both RK4 at 1 ms for 5 s with the same torques held over each step: spacecraft rate,
#: attitude, arm angle and rate, wheel speeds. Measured 2026-11-26 (2-core dev VM): at most 1.9e-15.
MUJOCO_BOUND = 1e-12


#: A third wheel, for the wheels to span three axes (the detumbling by wheels alone).
RW_Y = ("rw_y", np.array([0.0, 1.0, 0.0]), np.array([0.0, -0.25, 0.1]), 4.5, 0.09, 0.05)


def locked_spacecraft(wheels: list = WHEELS) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, CM and inertia about it of the hub with its wheels locked (what a freefloat spacecraft body holds)."""
    mass = HUB_MASS + sum(w[3] for w in wheels)
    cm = (HUB_MASS * HUB_CM + sum(w[3] * w[2] for w in wheels)) / mass

    def about_cm(inertia: np.ndarray, m: float, at: np.ndarray) -> np.ndarray:
        d = at - cm
        return inertia + m * (d @ d * np.eye(3) - np.outer(d, d))

    inertia = about_cm(HUB_INERTIA, HUB_MASS, HUB_CM)
    for _, a, p, m, js, jt in wheels:
        inertia = inertia + about_cm(js * np.outer(a, a) + jt * (np.eye(3) - np.outer(a, a)), m, p)
    return mass, cm, inertia


def wheeled_model(js_scale: float = 1.0, wheels: list = WHEELS, **limits: float) -> ff.Model:
    """The hub with the arm and ``wheels``; ``limits``: each wheel's max_torque, max_speed, viscous (a wheel's)."""
    mass, cm, inertia = locked_spacecraft(wheels)
    b = ff.ModelBuilder("wheeled")
    b.add_body("bus", mass=mass, inertia=inertia, com=cm)
    b.add_body("arm", mass=ARM_MASS, inertia=ARM_INERTIA, com=ARM_CM)
    b.add_joint("shoulder", parent="bus", child="arm", origin=ARM_ORIGIN, axis=[0.0, 0.0, 1.0])
    for name, a, _, _, js, _ in wheels:
        b.add_wheel(name, axis=a, inertia=js * js_scale, **limits)
    return b.build()


def mujoco_xml(dt: float, wheels: list = WHEELS, viscous: float = 0.0) -> str:
    """The same system in MuJoCo: each wheel a body of its own on a hinge (its bearing's viscous friction the hinge's
    damping)."""

    def f(v: object) -> str:
        return " ".join(f"{x:.17g}" for x in np.ravel(np.asarray(v, dtype=float)))

    wheels_xml = "".join(
        f'<body name="{n}" pos="{f(p)}"><inertial pos="0 0 0" mass="{m!r}" diaginertia="{f(js * a + jt * (1 - a))}"/>'
        f'<joint name="{n}" type="hinge" axis="{f(a)}" damping="{viscous!r}"/></body>'
        for n, a, p, m, js, jt in wheels
    )
    return (
        f'<mujoco><option timestep="{dt}" integrator="RK4" gravity="0 0 0"/><worldbody>'
        f'<body name="bus"><freejoint/><inertial pos="{f(HUB_CM)}" mass="{HUB_MASS!r}" diaginertia="{f(np.diag(HUB_INERTIA))}"/>'
        f'<body name="arm" pos="{f(ARM_ORIGIN)}"><joint name="shoulder" type="hinge" axis="0 0 1"/>'
        f'<inertial pos="{f(ARM_CM)}" mass="{ARM_MASS!r}" diaginertia="{f(np.diag(ARM_INERTIA))}"/></body>{wheels_xml}</body>'
        "</worldbody></mujoco>"
    )


def torques(t: float) -> tuple[float, np.ndarray]:
    return 2.0 * np.sin(0.7 * t), np.array([0.05 * np.cos(0.5 * t), -0.04])


def mujoco_difference(model: ff.Model, duration: float = 5.0, dt: float = 1e-3) -> float:
    """Largest difference of spacecraft rate, attitude, arm angle and rate, and wheel speeds, at 0.5 s outputs."""
    import mujoco  # an oracle: a missing one fails the test

    mj = mujoco.MjModel.from_xml_string(mujoco_xml(dt))
    data = mujoco.MjData(mj)
    states = []
    for i in range(round(duration / dt)):
        tau, u = torques(i * dt)
        data.qfrc_applied[:] = 0.0
        data.qfrc_applied[6], data.qfrc_applied[7:9] = tau, u  # the wheel motors act between wheel and bus
        mujoco.mj_step(mj, data)
        if (i + 1) % 500 == 0:
            states.append((data.qpos.copy(), data.qvel.copy()))

    def controller(t: float, state: ff.State) -> ff.Actuation:
        tau, u = torques(t)
        return ff.Actuation(joint_torque=[tau], wheel_torque=u)

    traj = ff.simulate(model, ff.State(), duration, controller, fixed_step=dt, output_period=0.5)
    worst = 0.0
    for i, (qpos, qvel) in enumerate(states, start=1):
        quat = np.r_[qpos[4:7], qpos[3]]  # MuJoCo's [w, x, y, z]
        quat = quat if quat @ traj.attitude[i] >= 0 else -quat
        worst = max(
            worst,
            np.abs(qvel[3:6] - traj.omega[i]).max(),  # a free joint's angular velocity is in the body frame, as omega0
            np.abs(quat - traj.attitude[i]).max(),
            abs(qpos[7] - traj.q[i, 0]),
            abs(qvel[6] - traj.qdot[i, 0]),
            np.abs(qvel[7:9] - traj.wheel_speed[i]).max(),  # a hinge's rate is relative to its parent: the wheel speed
        )
    return float(worst)


def test_a_spacecraft_with_an_arm_and_offset_wheels_agrees_with_mujoco() -> None:
    assert mujoco_difference(wheeled_model()) < MUJOCO_BOUND


def test_a_1e_7_error_in_a_wheels_inertia_fails_the_mujoco_bound() -> None:
    assert mujoco_difference(wheeled_model(js_scale=1.0 + 1e-7)) > MUJOCO_BOUND


#: A compiled rollout of this system with three wheels (the third on y) and the detumbling by them alone, each trajectory
#: its own torque limit (acting in one) and initial state, the wheels' viscous bearing friction on: each trajectory's
#: recorded joint and wheel torques, replayed in MuJoCo (RK4 at 1 ms, 5 s, the wheels' friction the hinges' damping), give
#: the same spacecraft rate, attitude, arm angle and rate, wheel speeds and angles. Measured 2026-12-02: at most 1.1e-13
#: (the wheel angles, up to 260 rad); the wheels' Js moved by 1e-7 in freefloat: 5.8e-7.
ROLLOUT_MUJOCO_BOUND = 3e-13


def mujoco_replay(traj: ff.Trajectory, b: int, dt: float, hold: int, wheels: list, viscous: float) -> float:
    """Trajectory b of a rollout of this system (sampled and recorded every ``hold`` steps of ``dt``) against MuJoCo
    from its initial state under the torques it recorded, held over each sample: the largest difference of spacecraft
    rate, attitude, arm angle and rate, wheel speeds and angles at the outputs."""
    import mujoco  # an oracle: a missing one fails the test

    mj = mujoco.MjModel.from_xml_string(mujoco_xml(dt, wheels, viscous))
    data = mujoco.MjData(mj)
    data.qpos[7] = traj.q[0, b, 0]
    data.qvel[3:6], data.qvel[6], data.qvel[7:] = traj.omega[0, b], traj.qdot[0, b, 0], traj.wheel_speed[0, b]
    mujoco.mj_forward(mj, data)
    mujoco.mj_subtreeVel(mj, data)
    data.qvel[0:3] -= data.subtree_linvel[1]  # the system's CM at rest, as freefloat's v_cm = 0
    worst = 0.0
    for i in range(round(traj.t[-1] / dt)):
        data.qfrc_applied[:] = 0.0
        data.qfrc_applied[6], data.qfrc_applied[7:] = traj.joint_torque[i // hold, b, 0], traj.wheel_torque[i // hold, b]
        mujoco.mj_step(mj, data)
        if (i + 1) % hold == 0:
            k = (i + 1) // hold
            quat = np.r_[data.qpos[4:7], data.qpos[3]]
            quat = quat if quat @ traj.attitude[k, b] >= 0 else -quat
            worst = max(
                worst,
                np.abs(data.qvel[3:6] - traj.omega[k, b]).max(),
                np.abs(quat - traj.attitude[k, b]).max(),
                abs(data.qpos[7] - traj.q[k, b, 0]),
                abs(data.qvel[6] - traj.qdot[k, b, 0]),
                np.abs(data.qvel[7:] - traj.wheel_speed[k, b]).max(),
                np.abs(data.qpos[8:] - traj.wheel_angle[k, b]).max(),
            )
    return float(worst)


def test_a_compiled_rollout_with_a_wheel_law_agrees_with_mujoco() -> None:
    wheels, viscous, dt, hold = [*WHEELS, RW_Y], 2e-3, 1e-3, 10
    models = [wheeled_model(wheels=wheels, max_torque=limit, viscous=viscous) for limit in (0.03, None)]
    states = ff.State(
        q=[[0.2], [-0.4]],
        qdot=[[0.1], [-0.05]],
        omega=[[0.02, -0.03, 0.05], [-0.01, 0.04, 0.02]],
        wheel_speed=[[20.0, -10.0, 5.0], [-8.0, 15.0, 30.0]],
    )
    controller = ff.control.Detumble(models, rate_gain=0.5, torque_by="wheels", force=False)
    traj = ff.rollout(models, states, 5.0, dt=dt, controller=controller, sample_period=hold * dt, output_period=hold * dt)
    assert traj.wheel_torque_saturated[:, 0].any() and not traj.wheel_torque_saturated[:, 1].any()
    assert np.all(traj.spacecraft_torque == 0.0) and np.abs(traj.wheel_torque).max() > 0.02
    assert max(mujoco_replay(traj, b, dt, hold, wheels, viscous) for b in range(2)) < ROLLOUT_MUJOCO_BOUND


# ------------------------------------------------------------------ the momentum split by hand
def test_a_wheel_spun_up_turns_the_spacecraft_the_other_way_by_the_split_computed_by_hand() -> None:
    """A bare spacecraft (inertia I about the axis, wheels locked) and a wheel Js driven by u for T seconds from rest:
    the rotor's own spin Js (omega + Omega) = u T and the total I omega + Js Omega = 0, so Omega = u T / (Js (1 - Js / I))
    and omega = -Js Omega / I. RK4 integrates this (constant torque, linear in t) exactly."""
    inertia, js, u, duration = 100.0, 0.5, 0.1, 10.0
    b = ff.ModelBuilder("bare")
    b.add_body("bus", mass=500.0, inertia=[80.0, 90.0, inertia])
    b.add_wheel("rw", axis=[0.0, 0.0, 1.0], inertia=js)
    model = b.build()
    traj = ff.simulate(model, ff.State(), duration, lambda t, s: ff.Actuation(wheel_torque=[u]), fixed_step=0.01)
    speed = u * duration / (js * (1.0 - js / inertia))
    assert traj.wheel_speed[-1, 0] == pytest.approx(speed, rel=1e-12)
    assert traj.omega[-1] == pytest.approx([0.0, 0.0, -js * speed / inertia], rel=1e-12, abs=1e-15)
    assert np.abs(traj.angular_momentum).max() < 1e-13  # zero throughout
    assert traj.wheel_torque[:-1, 0] == pytest.approx(u)


# ------------------------------------------------------------------ momentum over 1000 s
def long_run_model() -> ff.Model:
    wheels = (
        reaction_wheel("rw_z", axis=[0.0, 0.0, 1.0], inertia=0.5, viscous=2e-3, coulomb=1e-3),
        reaction_wheel("rw_y", axis=[0.0, 1.0, 0.0], inertia=0.4),
    )
    return dataclasses.replace(ff.models.papadopoulos1992(arms=2), wheels=wheels)


#: Relative drift of the total angular momentum (arms, spacecraft, wheels) over 1000 s of arm and wheel torques,
#: with wheel bearing friction. Measured 2026-11-26: 1.1e-12 (DOP853, rtol = atol = 1e-12), 4.1e-8 (RK4, 0.05 s).
DRIFT_BOUND = {"DOP853": 5e-12, "RK4": 1.5e-7}


@pytest.mark.parametrize("integrator", ["DOP853", "RK4"])
def test_momentum_with_wheels_is_conserved_over_1000_s(integrator: str) -> None:
    model = long_run_model()

    def controller(t: float, s: ff.State) -> ff.Actuation:
        wheel = [0.02 * np.sin(0.01 * t), 0.01 * np.cos(0.02 * t)]
        return ff.Actuation(joint_torque=0.3 * np.sin(0.05 * t + np.arange(4)) - 0.5 * s.qdot, wheel_torque=wheel)

    state = ff.State(q=[0.3, 0.5, -0.2, 0.4], omega=[0.001, 0.002, -0.003], wheel_speed=[20.0, -10.0], v_cm=[0.01, 0.0, 0.0])
    options = dict(fixed_step=0.05, sample_period=0.05) if integrator == "RK4" else dict(rtol=1e-12, atol=1e-12, sample_period=0.5)
    traj = ff.simulate(model, state, 1000.0, controller, output_period=10.0, **options)
    h = traj.angular_momentum
    assert np.abs(h - h[0]).max() / np.linalg.norm(h[0]) < DRIFT_BOUND[integrator]
    assert np.abs(traj.wheel_speed[-1] - traj.wheel_speed[0]).max() > 1.0  # the wheels did exchange momentum
    assert traj.dissipated_energy[-1] > 0.0  # the bearing friction dissipates
    locked = ff.angular_momentum(model, traj.q, traj.velocity, attitude=traj.attitude)  # without the wheels' spin
    assert np.abs(locked - locked[0]).max() > 100 * np.abs(h - h[0]).max()


# ------------------------------------------------------------------ limits
def test_torque_and_speed_limits_act_and_are_recorded() -> None:
    b = ff.ModelBuilder("limited")
    b.add_body("bus", mass=500.0, inertia=[80.0, 90.0, 100.0])
    b.add_wheel("rw", axis=[0.0, 0.0, 1.0], inertia=0.5, max_torque=0.2, max_speed=10.0)
    model = b.build()

    # commands 0.5 N m (above the limit) for 40 s, then -0.1 N m: the speed reaches its limit at 25 s
    def controller(t: float, s: ff.State) -> ff.Actuation:
        return ff.Actuation(wheel_torque=[0.5 if t < 40.0 else -0.1])

    traj = ff.simulate(model, ff.State(), 60.0, controller, fixed_step=0.1, output_period=0.1)
    applied, speed = traj.wheel_torque[:, 0], traj.wheel_speed[:, 0]
    assert np.abs(applied).max() == pytest.approx(0.2)  # clipped to max_torque
    early = traj.t < 20.0
    assert traj.wheel_torque_saturated[early, 0].all() and not traj.wheel_speed_saturated[early, 0].any()
    limited = traj.wheel_speed_saturated[:, 0]
    assert limited.any() and (applied[limited] == 0.0).all()  # at the speed limit: no torque that would spin it faster
    assert speed.max() <= 10.0 + 0.2 / 0.5 * 0.1 * 1.01  # beyond it by at most one sample's worth
    late = traj.t > 40.5
    assert (applied[late][:-1] == pytest.approx(-0.1)) and not limited[late].any()  # slowing down is allowed
    assert traj.saturated[early].all()
    cost = ff.control.detumble_cost(traj)
    assert cost.wheel_saturated.tolist() == [True] and cost.peak_wheel_speed[0] == pytest.approx(speed.max())


# ------------------------------------------------------------------ files, builder, bad input
def test_a_command_beyond_the_torque_limit_is_clipped_on_both_sides() -> None:
    """Commands of +-0.5 N m on a wheel limited to 0.2 N m: +-0.2 N m applied, flagged; 0.1 N m passes unflagged."""
    b = ff.ModelBuilder("limited")
    b.add_body("bus", mass=500.0, inertia=[80.0, 90.0, 100.0])
    b.add_wheel("rw", axis=[0.0, 0.0, 1.0], inertia=0.5, max_torque=0.2)
    model = b.build()
    commands = {0: 0.5, 1: -0.5, 2: 0.1}

    def controller(t: float, s: ff.State) -> ff.Actuation:
        return ff.Actuation(wheel_torque=[commands[min(2, int(t + 1e-9))]])

    traj = ff.simulate(model, ff.State(), 3.0, controller, fixed_step=0.1, output_period=0.1, sample_period=0.1)
    second = np.floor(traj.t[:-1] + 1e-9).astype(int)
    applied, flagged = traj.wheel_torque[:-1, 0], traj.wheel_torque_saturated[:-1, 0]
    np.testing.assert_array_equal(applied, np.array([0.2, -0.2, 0.1])[second])
    np.testing.assert_array_equal(flagged, second < 2)


def test_model_files_the_builder_and_the_side_file_declare_wheels(tmp_path: Path) -> None:
    text = Path("examples/models/papadopoulos1991.toml").read_text(encoding="utf-8")
    (tmp_path / "m.toml").write_text(text + '\n[[wheels]]\nname = "rw1"\naxis = [0, 0, 1]\ninertia = 0.3\nmax_torque = 0.1\n')
    model = ff.load(tmp_path / "m.toml")
    assert [w.name for w in model.wheels] == ["rw1"] and model.wheels[0].max_torque == 0.1 and model.wheels[0].max_speed == np.inf
    ff.save(model, tmp_path / "again.toml")
    assert ff.load(tmp_path / "again.toml").wheels == model.wheels
    (tmp_path / "wheels.toml").write_text('[[wheels]]\nname = "rwx"\naxis = [1, 0, 0]\ninertia = 0.2\nmax_speed = 300\n')
    urdf = ff.load("examples/models/six_dof_arm.urdf", wheels=tmp_path / "wheels.toml")
    assert urdf.n_wheels == 1 and urdf.wheels[0].max_speed == 300.0 and urdf.wheels[0].axis.tolist() == [1.0, 0.0, 0.0]
    assert ff.load("papadopoulos1992", wheels=[{"name": "a", "axis": [0, 1, 0], "inertia": 0.1}]).n_wheels == 1
    from typer.testing import CliRunner

    from freefloat.cli import app

    shown = CliRunner().invoke(app, ["inspect", str(tmp_path / "m.toml")])  # what freefloat inspect says of them
    assert (
        shown.exit_code == 0
        and "wheel rw1           axis [0, 0, 1] (spacecraft frame), Js 0.3 kg m², max torque 0.1 N m, max speed none" in shown.stdout
    )


@pytest.mark.parametrize(
    ("wheel", "message"),
    [
        ({"name": "a", "axis": [1, 1, 0], "inertia": 0.1}, r"wheels\[0\] \(a\)\.axis: is not a unit vector"),
        ({"name": "a", "axis": [1, 0, 0], "inertia": -0.1}, r"wheels\[0\] \(a\)\.inertia: must be positive"),
        ({"name": "a", "axis": [1, 0, 0], "inertia": 0.1, "max_speed": 0}, r"\.max_speed: must be positive"),
        ({"name": "a", "axis": [1, 0, 0], "inertia": 0.1, "coulomb": float("nan")}, r"\.coulomb: must be zero or positive"),
        ({"name": "a", "axis": [1, 0, 0]}, r"wheels\[0\]\.inertia: is missing"),
        ({"name": "a", "axis": [1, 0, 0], "inertia": 0.1, "Js": 0.1}, r"wheels\[0\]\.Js: unknown key 'Js'"),
        ({"name": "a", "axis": [1, 0, 0], "inertia": 1e6}, r"wheels: the wheels' spin inertias .* not smaller than the spacecraft"),
        ({"name": "arm1_q1", "axis": [1, 0, 0], "inertia": 0.1}, r"wheels\[0\]\.name: duplicate name 'arm1_q1'"),
    ],
)
def test_bad_wheels_are_refused_naming_the_field(wheel: dict, message: str) -> None:
    with pytest.raises(ff.ModelError, match=message):
        ff.load("papadopoulos1992", wheels=[wheel])


def test_wheel_inputs_the_model_does_not_have_are_refused() -> None:
    plain = ff.models.papadopoulos1992(arms=1)
    with pytest.raises(ff.ShapeError, match=r"State\.wheel_speed: expected shape .* has no reaction wheels"):
        ff.State(wheel_speed=[1.0]).resolve(plain)
    with pytest.raises(ff.SimulationError, match="has no reaction wheels"):
        ff.simulate(plain, ff.State(), 0.1, lambda t, s: ff.Actuation(wheel_torque=[0.1]), fixed_step=0.01)
    with pytest.raises(ValueError, match=r"torque_by: 'wheels', but .* has no reaction wheels"):
        ff.control.Detumble(plain, torque_by="wheels")
    wheeled = wheeled_model()
    with pytest.raises(ff.SimulationError, match=r"wheel_torque of shape \(3,\); expected \(2,\)"):
        ff.simulate(wheeled, ff.State(), 0.1, lambda t, s: ff.Actuation(wheel_torque=[0.1, 0.2, 0.3]), fixed_step=0.01)
    with pytest.warns(ff.NearSingularWarning, match="span 2 axes of 3"):
        ff.control.Detumble(wheeled, torque_by="wheels")
    # rollout refused a model with wheels; it simulates them now (tests/simulation/test_wheel_rollouts.py: against the
    # Python path and MuJoCo)
    rolled = ff.rollout(wheeled, ff.State(q=np.zeros((2, 1)), wheel_speed=[[5.0, -3.0], [0.0, 1.0]]), 0.1, dt=0.01)
    assert rolled.wheel_speed.shape == (11, 2, 2) and rolled.wheel_speed[0].tolist() == [[5.0, -3.0], [0.0, 1.0]]


def test_a_trajectory_with_wheels_is_saved_and_loaded(tmp_path: Path) -> None:
    model = wheeled_model()
    traj = ff.simulate(model, ff.State(wheel_speed=[5.0, -3.0]), 1.0, lambda t, s: ff.Actuation(wheel_torque=[0.1, 0.0]), fixed_step=0.01)
    for name in ("t.npz", "t.csv"):
        back = ff.Trajectory.load(traj.save(tmp_path / name), model=model)
        assert back.equals(traj, rtol=1e-15) and back.wheel_speed_saturated.dtype == bool
    assert traj.state().wheel_speed.tolist() == traj.wheel_speed[-1].tolist()


# ------------------------------------------------------------------ controllers
def test_the_detumbling_controller_brings_the_system_to_rest_with_wheels_alone() -> None:
    model = dataclasses.replace(
        ff.models.papadopoulos1992(arms=1),
        wheels=tuple(reaction_wheel(f"rw{i}", axis=np.eye(3)[i], inertia=0.5, max_torque=1.0, max_speed=200.0) for i in range(3)),
    )
    controller = ff.control.Detumble(model, rate_gain=0.2, torque_by="wheels", force=False)
    state = ff.State(q=[0.5, 1.0], qdot=[0.01, -0.02], omega=[0.02, -0.01, 0.03])
    traj = ff.simulate(model, state, 60.0, controller, fixed_step=0.01, sample_period=0.1, output_period=0.1)
    cost = ff.control.detumble_cost(traj, rest_velocity=None)
    assert cost.time_to_rest is not None and cost.final_rates[1] < 1e-6 and cost.final_rates[2] < 1e-6
    assert cost.thruster_impulse == 0.0 and cost.torque_impulse == 0.0  # no thruster: the wheels took the momentum
    h_wheels = ff.mechanics.momentum.wheel_momentum(model, traj.wheel_speed[-1])
    h0 = traj.angular_momentum[0]
    assert np.linalg.norm(h_wheels) == pytest.approx(np.linalg.norm(h0), rel=1e-5)  # all of it, at rest
    assert cost.peak_wheel_momentum.max() > 0.0 and cost.peak_wheel_torque.max() <= 1.0


def test_the_1991_controllers_send_the_spacecraft_torque_to_the_wheels() -> None:
    model = dataclasses.replace(
        ff.models.papadopoulos1992(arms=1),
        wheels=tuple(reaction_wheel(f"rw{i}", axis=np.eye(3)[i], inertia=0.5) for i in range(3)),
    )
    task = ff.control.TaskSpace.create(model, end_effectors=[])  # the spacecraft's position and attitude
    state = ff.State(q=[0.5, 1.0], omega=[0.01, 0.02, -0.01], wheel_speed=[3.0, -2.0, 1.0]).resolve(model)
    desired = task.evaluate(state)[0] + 0.05
    by = {}
    for torque_by in ("thrusters", "wheels"):
        controller = ff.control.TransposedJacobianController(model, task, desired, kp=5.0, kd=20.0, torque_by=torque_by, force_by="none")
        by[torque_by] = controller(0.0, state)
    wanted = by["thrusters"].spacecraft_torque
    wheel = by["wheels"].wheel_torque
    axes = np.eye(3)
    gyroscopic = np.cross(state.omega, 0.5 * state.wheel_speed)
    assert -axes @ wheel == pytest.approx(wanted + gyroscopic, rel=1e-12)  # the reaction gives the torque, spin compensated
    assert np.all(by["wheels"].spacecraft_torque == 0.0) and np.all(by["wheels"].spacecraft_force == 0.0)


# ------------------------------------------------------------------ a grasp with spinning wheels
@pytest.mark.parametrize("joints", ["free", "locked"])
def test_a_grasp_keeps_the_momentum_of_robot_wheels_and_target(joints: str) -> None:
    model = dataclasses.replace(ff.models.papadopoulos1992(arms=1), wheels=(reaction_wheel("rw", axis=[0.0, 0.6, 0.8], inertia=2.0),))
    state = ff.State(q=[0.5, 1.0], qdot=[0.01, 0.0], omega=[0.0, 0.002, 0.01], wheel_speed=[30.0]).resolve(model)
    tip = ff.end_effector_positions(model, state.q)[0]
    target = ff.capture.Target(
        mass=100.0,
        inertia=[8.0, 10.0, 12.0],
        position=tip + np.array([0.1, 0.05, 0.0]),
        velocity=[0.0, 0.05, 0.01],
        angular_velocity=[0.01, 0.0, 0.05],
    )
    result = ff.capture.impact(model, state, target, joints=joints)

    def robot_momentum(m: ff.Model, s: ff.State) -> np.ndarray:
        return ff.angular_momentum(m, s.q, s.velocity, attitude=s.attitude, wheel_speed=s.wheel_speed) + np.cross(
            s.r_cm, m.total_mass * s.v_cm
        )

    before = robot_momentum(model, state) + target.momentum[3:] + np.cross(target.position, target.momentum[:3])
    after = robot_momentum(result.model, result.state.resolve(result.model))
    assert np.abs(after - before).max() < 1e-12 * np.abs(before).max()
    spin = np.array([state.omega, result.state.omega]) @ model.wheels[0].axis  # a . omega before, after
    if joints == "free":  # no motor impulse: each rotor keeps its own spin, its speed relative to the bus changes
        assert result.wheel_impulse[0] == 0.0
        assert result.state.wheel_speed[0] + spin[1] == pytest.approx(state.wheel_speed[0] + spin[0], rel=1e-14)
    else:  # the motors hold the relative speed
        assert result.state.wheel_speed[0] == state.wheel_speed[0] and result.wheel_impulse[0] != 0.0
    assert result.model.wheels == model.wheels


# ------------------------------------------------------------------ bearing friction and spin momentum, closed forms
#: The spin-down against its closed form (relative to Omega0 and omega0), RK4 at 10 ms over 30 s. Measured 2026-12-01:
#: 1.4e-15 (Omega), 3.6e-14 (omega). A rotor's spin momentum over 20 s of DOP853 at 1e-12: 5.9e-16 (relative).
SPIN_DOWN_BOUND = 1e-12
SPIN_BOUND = 1e-13


def spin_down_error(scale: float = 1.0) -> float:
    """The spin-down of :func:`test_bearing_friction_spins_a_wheel_down_as_the_closed_form` against its closed form, with
    freefloat's viscous friction ``scale`` times the closed form's: the largest error of Omega / Omega0, omega / omega0."""
    inertia, js, b, c, speed0, omega0 = 100.0, 0.5, 0.02, 0.05, 50.0, 0.01
    builder = ff.ModelBuilder("spin-down")
    builder.add_body("bus", mass=500.0, inertia=[80.0, 90.0, inertia])
    builder.add_wheel("rw", axis=[0.0, 0.0, 1.0], inertia=js, viscous=b * scale, coulomb=c)
    model = builder.build()
    start = ff.State(omega=[0.0, 0.0, omega0], wheel_speed=[speed0])
    traj = ff.simulate(model, start, 30.0, None, fixed_step=0.01, output_period=1.0)
    j_e = js * (1.0 - js / inertia)
    speed = (speed0 + c / b) * np.exp(-b * traj.t / j_e) - c / b
    assert speed[-1] > 10.0  # far above v_s = 0.01 rad/s throughout
    assert np.abs(traj.omega[:, :2]).max() < 1e-15
    return max(
        float(np.abs(traj.wheel_speed[:, 0] - speed).max()) / speed0,
        float(np.abs(traj.omega[:, 2] - (omega0 - js * (speed - speed0) / inertia)).max()) / omega0,
    )


def test_bearing_friction_spins_a_wheel_down_as_the_closed_form() -> None:
    """One wheel (Js, viscous b, Coulomb c) on the principal axis of a bare bus (inertia I about it, wheels locked), no
    motor torque: the rotor Js (ω̇ + Ω̇) = -b Ω - c (tanh(Ω/v_s) = 1 to rounding while Ω >> v_s) and the total
    I ω + Js Ω is constant, so J_e Ω̇ = -b Ω - c with J_e = Js (1 - Js / I):
    Ω(t) = (Ω0 + c/b) exp(-b t / J_e) - c/b and ω(t) = ω0 - Js (Ω - Ω0) / I. A viscous friction 1e-7 off fails it."""
    assert spin_down_error() < SPIN_DOWN_BOUND
    assert spin_down_error(1.0 + 1e-7) > SPIN_DOWN_BOUND


def test_each_free_rotor_keeps_its_own_spin_momentum() -> None:
    """Two frictionless wheels on axes that are not principal, a tumbling bus, no torque: each rotor's spin momentum
    about its axis, h_i = Js_i (Ω_i + a_i · ω0) computed here from the raw numbers, is constant while Ω_i itself changes;
    ``wheel_spin_momentum`` and ``detumble_cost``'s ``peak_wheel_momentum`` report it."""
    axes = np.array([[0.6, 0.8, 0.0], [0.0, 0.6, -0.8]])
    js = np.array([0.3, 0.45])
    builder = ff.ModelBuilder("tumbling")
    builder.add_body("bus", mass=400.0, inertia=[[60.0, 5.0, -3.0], [5.0, 80.0, 2.0], [-3.0, 2.0, 70.0]])
    for i in range(2):
        builder.add_wheel(f"rw{i}", axis=axes[i], inertia=js[i])
    model = builder.build()
    start = ff.State(omega=[0.3, -0.2, 0.25], wheel_speed=[40.0, -25.0])
    traj = ff.simulate(model, start, 20.0, None, rtol=1e-12, atol=1e-12, output_period=0.5)
    h = js * (traj.wheel_speed + traj.omega @ axes.T)
    assert np.abs(h - h[0]).max() < SPIN_BOUND * np.abs(h[0]).max()
    assert np.ptp(traj.wheel_speed, axis=0).min() > 0.1  # the relative speeds did change with the bus's rate
    spin = wheel_spin_momentum(model, traj.wheel_speed, traj.omega)
    assert np.abs(spin - h).max() <= 1e-15 * np.abs(h).max()
    cost = ff.control.detumble_cost(traj)
    assert np.abs(cost.peak_wheel_momentum - np.abs(h).max(axis=0)).max() <= 1e-15 * np.abs(h).max()
