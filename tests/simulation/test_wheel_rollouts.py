"""Reaction wheels in the compiled loops: ``ff.rollout`` of models with wheels, and the compiled laws with
``torque_by="wheels"`` (engine/laws.py: the wheel routing u = -A⁺ (n_S + ω0 × h_w) and the wheels' torque and speed
limits), against the Python path (the controllers' numpy form, control/wheels.py, and the simulation's wheel limits,
simulation/_wheels.py, run by ``ff.simulate`` every sample).

A rollout of 64 servicers whose wheels differ per trajectory (rotor inertia, torque and speed limits, bearing
friction), from 64 initial states, with the detumbling by wheels alone compiled, equals 64 Python-path simulations
at every step, saturation flags included (both limits act in some trajectories and not in others); a rotor inertia
moved by 1e-7 breaks the bound. The task controllers with ``torque_by="wheels"``, ``force_by="none"``, a joint PD and a
Python controller do the same on a few trajectories; per-trajectory wheels of another number or axes are refused.
Spies (tests/spies.py) show that each side took its path. The MuJoCo comparison of a compiled rollout is in
tests/simulation/test_wheels.py (its machinery).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

import freefloat as ff
from freefloat.control import Detumble, OperationalSpaceController, TransposedJacobianController
from freefloat.control.tasks import TaskSpace
from freefloat.core.wheels import reaction_wheel
from mechanics.test_specialise_dynamics import own_cache as own_cache  # the fixture
from spies import Paths

#: Trajectory b of the compiled rollout against the Python-path simulation b: every state and wheel output, largest
#: absolute difference over every output of the 64 trajectories. Measured 2026-12-02 (2-core dev VM): 7.1e-15 (the
#: wheel angles, ~30 rad after 1.5 s; the wheel torques 6.7e-16).
BOUND = 2e-14
#: The task controllers (6 trajectories): states 2.8e-14 (OSC; TJ 1.8e-15), actuation 1.9e-13 (the OSC's wheel torques
#: of up to 48 N m where no torque limit clips them: the two forms' operation orders in J_q⁻ᵀ), measured 2026-12-02.
TASK_BOUND = 1e-13
ACTUATION_BOUND = 1e-12
#: The specialised rollout kernel (traced from the engine's state derivative: other operation orders) against the
#: generic kernels and the Python path, nine trajectories of 0.5 s.
SPECIALISED_BOUND = 1e-12
DT = 0.01
FIELDS = (
    "q",
    "qdot",
    "omega",
    "attitude",
    "r_cm",
    "v_cm",
    "wheel_angle",
    "wheel_speed",
    "wheel_torque",
    "joint_torque",
    "spacecraft_force",
    "spacecraft_torque",
    "dissipated_energy",
)
FLAGS = ("saturated", "wheel_torque_saturated", "wheel_speed_saturated")
BATCH = 64
#: Four wheels in a pyramid about the spacecraft z-axis (they span three axes, one more than needed).
ELEVATION = np.arctan(1.0 / np.sqrt(2.0))
AXES = np.array([[np.cos(ELEVATION) * np.cos(a), np.cos(ELEVATION) * np.sin(a), np.sin(ELEVATION)] for a in np.arange(4) * np.pi / 2])


def servicer(b: int) -> ff.Model:
    """The servicer of trajectory b: the 1992 one-arm robot with four wheels whose inertia, limits and friction depend on b
    (every fourth has no torque limit, every third no speed limit; the others' limits are low enough to act)."""
    wheels = tuple(
        reaction_wheel(
            f"rw{i}",
            axis=AXES[i],
            inertia=0.3 + 0.004 * b + 0.05 * i,
            max_torque=None if b % 4 == 0 else 0.04 + 0.002 * b,
            max_speed=None if b % 3 == 0 else 25.0 + 0.2 * b,
            viscous=1e-4 * (b % 5),
            coulomb=2e-4 * (b % 7),
        )
        for i in range(4)
    )
    return dataclasses.replace(ff.models.papadopoulos1992(arms=1), wheels=wheels)


def initial_states(batch: int, seed: int = 7) -> ff.State:
    rng = np.random.default_rng(seed)
    return ff.State(
        q=np.array([0.5, 1.0]) + rng.uniform(-0.3, 0.3, (batch, 2)),
        qdot=rng.uniform(-0.02, 0.02, (batch, 2)),
        omega=rng.uniform(-0.04, 0.04, (batch, 3)),
        wheel_speed=rng.uniform(-32.0, 32.0, (batch, 4)),
        v_cm=rng.uniform(-0.01, 0.01, (batch, 3)),
    )


def row(states: ff.State, b: int) -> ff.State:
    return ff.State(
        **{f.name: np.asarray(getattr(states, f.name))[b] for f in dataclasses.fields(ff.State) if getattr(states, f.name) is not None}
    )


def python(controller: Any) -> Callable[[float, ff.State], Any]:
    """The controller as a plain Python function: the simulation loops call it every sample (its numpy form)."""
    return lambda t, state: controller(t, state)


def gap(fast: ff.Trajectory, b: int, slow: ff.Trajectory, fields: tuple[str, ...] = FIELDS) -> float:
    """The largest absolute difference of trajectory b of the rollout ``fast`` and the single run ``slow``, over
    ``fields`` at every output; the saturation flags must be equal."""
    assert np.array_equal(fast.t, slow.t)
    for name in FLAGS:
        assert np.array_equal(np.asarray(getattr(fast, name))[:, b], getattr(slow, name)), name
    return max(float(np.abs(np.asarray(getattr(fast, f))[:, b] - getattr(slow, f)).max()) for f in fields)


@pytest.fixture
def paths(monkeypatch: pytest.MonkeyPatch) -> Paths:
    return Paths(monkeypatch)


@pytest.fixture(scope="module")
def servicers() -> list[ff.Model]:
    return [servicer(b) for b in range(BATCH)]


def test_64_servicers_with_their_own_wheels_equal_64_python_simulations(servicers: list[ff.Model], paths: Paths) -> None:
    """The detumbling by wheels alone (``torque_by="wheels"``, no thrusters) with per-trajectory rate gains, compiled in a
    rollout of 64 servicers (each its own wheels' inertia, limits and friction, its own initial state): trajectory b
    equals ``ff.simulate`` of servicer b with the numpy form of the law, every state and wheel output at every step,
    to BOUND, flags equal; the torque and the speed limit each act in some trajectories and not in others."""
    states = initial_states(BATCH)
    gains = np.linspace(0.1, 0.4, BATCH)[:, None]
    controller = Detumble(servicers, rate_gain=gains, torque_by="wheels", force=False)
    options = dict(sample_period=3 * DT, output_period=DT)
    fast = paths.compiled("detumble", ff.rollout, servicers, states, 1.5, dt=DT, controller=controller, **options)
    assert fast.wheel_speed.shape == (151, BATCH, 4) and fast.wheel_torque_saturated.shape == (151, BATCH, 4)
    worst = 0.0
    for b in range(BATCH):
        slow = paths.python(ff.simulate, servicers[b], row(states, b), 1.5, python(controller.row(b)), fixed_step=DT, **options)
        worst = max(worst, gap(fast, b, slow))
    assert worst <= BOUND
    torque_hit = fast.wheel_torque_saturated.any(axis=(0, 2))
    speed_hit = fast.wheel_speed_saturated.any(axis=(0, 2))
    assert 0 < torque_hit.sum() < BATCH and 0 < speed_hit.sum() < BATCH
    assert not torque_hit[::4].any() and not speed_hit[::3].any()  # (no limit: never flagged)
    assert np.all(fast.spacecraft_force == 0.0) and np.all(fast.spacecraft_torque == 0.0)  # the wheels alone
    assert np.abs(fast.wheel_torque).max() > 0.01 and (fast.dissipated_energy[-1] > 0.0).sum() > BATCH // 2


def test_a_rotor_inertia_moved_by_1e_7_breaks_the_bound(servicers: list[ff.Model]) -> None:
    """The comparison above can fail: trajectory 5 with its wheels' Js moved by 1e-7 (in the plant and the controller)."""
    states = initial_states(8)
    models = servicers[:8]
    moved = [
        dataclasses.replace(servicers[5], wheels=tuple(dataclasses.replace(w, inertia=w.inertia * (1 + 1e-7)) for w in servicers[5].wheels))
    ]
    for plant in (models, models[:5] + moved + models[6:]):
        controller = Detumble(plant, rate_gain=0.3, torque_by="wheels", force=False)
        fast = ff.rollout(plant, states, 1.0, dt=DT, controller=controller, sample_period=2 * DT)
        slow = ff.simulate(
            models[5],
            row(states, 5),
            1.0,
            python(Detumble(models[5], rate_gain=0.3, torque_by="wheels", force=False)),
            fixed_step=DT,
            sample_period=2 * DT,
            output_period=DT,
        )
        difference = max(float(np.abs(fast.wheel_speed[:, 5] - slow.wheel_speed).max()), float(np.abs(fast.omega[:, 5] - slow.omega).max()))
        assert (difference <= BOUND) == (plant is models)


@pytest.mark.parametrize("law", [TransposedJacobianController, OperationalSpaceController])
def test_the_task_controllers_by_wheels_equal_the_python_loop(law: type, servicers: list[ff.Model], paths: Paths) -> None:
    """The 1991 controllers on the spacecraft's position and attitude with the torque by the wheels and no thruster
    force (``force_by="none"``), per-trajectory servicers and set points, outputs every 5 steps of a controller sampled
    every 2: the compiled rollout equals the Python loop, trajectory by trajectory."""
    batch = 6
    models = servicers[10 : 10 + batch]
    states = initial_states(batch, seed=3)
    task = TaskSpace.create(models[0], end_effectors=[])
    start = np.stack([task.coordinates(row(states, b).resolve(models[b])) for b in range(batch)])
    desired = start + np.linspace(0.02, 0.08, batch)[:, None]
    controller = law(models, task, desired, kp=4.0, kd=15.0, torque_by="wheels", force_by="none")
    options = dict(sample_period=2 * DT, output_period=5 * DT)
    name = "transposed_jacobian" if law is TransposedJacobianController else "operational_space"
    fast = paths.compiled(name, ff.rollout, models, states, 1.0, dt=DT, controller=controller, **options)
    for b in range(batch):
        slow = paths.python(ff.simulate, models[b], row(states, b), 1.0, python(controller.row(b)), fixed_step=DT, **options)
        assert gap(fast, b, slow, FIELDS[:8]) <= TASK_BOUND
        assert gap(fast, b, slow) <= ACTUATION_BOUND
    assert np.all(fast.spacecraft_force == 0.0) and np.abs(fast.wheel_torque).max() > 1e-3
    assert fast.wheel_torque_saturated.any()


def test_a_single_simulation_with_wheels_runs_compiled_and_equals_python(servicers: list[ff.Model], paths: Paths) -> None:
    """``ff.simulate`` of a servicer with wheels and a wheel law runs inside the compiled loop (a rollout of one),
    with the simulation's own limits on the joints, and equals the Python loop; a joint PD drives the arm and no wheel."""
    model, state = servicers[7], row(initial_states(8), 7)
    limits = ff.ActuatorLimits(joint_torque=0.5)
    controller = Detumble(model, rate_gain=0.5, torque_by="wheels", force=False)
    fast = paths.compiled("detumble", ff.simulate, model, state, 1.0, controller, fixed_step=DT, limits=limits, output_period=DT)
    slow = paths.python(ff.simulate, model, state, 1.0, python(controller), fixed_step=DT, limits=limits, output_period=DT)
    assert gap(_as_batch(fast), 0, slow) <= BOUND
    assert fast.saturated.any() and fast.wheel_speed.shape == (101, 4)
    pd = ff.JointPD(kp=2.0, kd=5.0, q_ref=[0.4, 0.9])
    fast = paths.compiled("joint_pd", ff.simulate, model, state, 1.0, pd, fixed_step=DT, output_period=DT)
    slow = paths.python(ff.simulate, model, state, 1.0, python(pd), fixed_step=DT, output_period=DT)
    assert gap(_as_batch(fast), 0, slow) <= BOUND and np.all(fast.wheel_torque == 0.0)


def _as_batch(traj: ff.Trajectory) -> ff.Trajectory:
    """A single run as a rollout of one (a batch axis after time)."""
    changes = {name: np.asarray(getattr(traj, name))[:, None] for name in (*FIELDS, *FLAGS)}
    return dataclasses.replace(traj, **changes)


def test_a_joint_pd_and_a_python_controller_roll_out_servicers_with_wheels(servicers: list[ff.Model], paths: Paths) -> None:
    """A joint PD (compiled, per-trajectory wheels: the wheels coast under their bearing friction) and a Python
    controller that commands the wheels (the Python loop over the batch, one model) equal single Python simulations."""
    batch = 4
    states = initial_states(batch, seed=11)
    pd = ff.JointPD(kp=2.0, kd=5.0, q_ref=[0.4, 0.9])
    fast = paths.compiled("joint_pd", ff.rollout, servicers[:batch], states, 0.5, dt=DT, controller=pd)
    for b in range(batch):
        slow = paths.python(ff.simulate, servicers[b], row(states, b), 0.5, python(pd), fixed_step=DT, output_period=DT)
        assert gap(fast, b, slow) <= BOUND

    def wheels(t: float, state: ff.State) -> ff.Actuation:
        return ff.Actuation(joint_torque=-state.qdot, wheel_torque=0.1 * np.sin(t + np.arange(4)) + 0.0 * state.wheel_speed)

    model = servicers[1]
    batched = ff.rollout(model, states, 0.5, dt=DT, controller=wheels, sample_period=2 * DT)
    for b in range(batch):
        slow = ff.simulate(model, row(states, b), 0.5, wheels, fixed_step=DT, output_period=DT, sample_period=2 * DT)
        assert gap(batched, b, slow) <= BOUND
    assert batched.wheel_torque_saturated.any()


def test_per_trajectory_wheels_of_another_number_or_axes_are_refused(servicers: list[ff.Model]) -> None:
    states = initial_states(2)
    three = dataclasses.replace(servicers[1], wheels=servicers[1].wheels[:3])
    with pytest.raises(ff.ModelError, match=r"model\[1\]\.wheels: .* has 3 reaction wheels, model\[0\] .* 4; per-trajectory models may"):
        ff.rollout([servicers[0], three], states, 0.1, dt=DT)
    turned = dataclasses.replace(
        servicers[1], wheels=(*servicers[1].wheels[:3], dataclasses.replace(servicers[1].wheels[3], axis=np.array([0.0, 0.0, 1.0])))
    )
    with pytest.raises(ff.ModelError, match=r"model\[1\]\.wheels: the reaction wheels of .* spin about other axes than model\[0\]'s"):
        ff.rollout([servicers[0], turned], states, 0.1, dt=DT)
    with pytest.raises(ff.ModelError, match=r"model\[1\]\.wheels: .* has 3 reaction wheels"):
        Detumble([servicers[0], three], torque_by="wheels", force=False)


def test_a_joint_pd_rollout_with_wheels_runs_on_the_specialised_kernels(
    own_cache: None, servicers: list[ff.Model], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Nine trajectories of one servicer with wheels and a joint PD: the specialised rollout kernel of its plant (the
    wheels as joints, their bearing friction as the joints': :func:`~freefloat.core.wheels.wheel_joint_model`) runs
    them, and they equal the generic kernels' run and nine Python-path simulations."""
    from freefloat.core.wheels import wheel_joint_model
    from freefloat.engine.specialise import build as _specialise

    model, batch = servicers[1], 9  # the specialised rollouts serve 8 trajectories or more
    states = initial_states(batch, seed=13)
    pd = ff.JointPD(kp=2.0, kd=5.0, q_ref=[0.4, 0.9])
    generic = ff.rollout(model, states, 0.5, dt=DT, controller=pd)  # (nothing specialised yet)
    calls: list[str] = []
    real = _specialise.rollout
    _specialise._ENABLED[0] = True
    ff.mechanics.specialise(wheel_joint_model(model), ["rollout"])
    monkeypatch.setattr(_specialise, "rollout", lambda m, t, *a: (calls.append(m.__name__), real(m, t, *a))[1])
    fast = ff.rollout(model, states, 0.5, dt=DT, controller=pd)
    assert calls, "the specialised rollout kernel ran"
    worst = max(gap(fast, b, _single(generic, b)) for b in range(batch))
    assert worst <= SPECIALISED_BOUND, worst
    for b in range(batch):
        slow = ff.simulate(model, row(states, b), 0.5, python(pd), fixed_step=DT, output_period=DT)
        measured = gap(fast, b, slow)
        print(f"specialised: generic {worst:.2e}, python {measured:.2e}")
        assert measured <= SPECIALISED_BOUND


def _single(batch: ff.Trajectory, b: int) -> ff.Trajectory:
    """Trajectory b of a rollout as a single run (its batch axis dropped)."""
    return dataclasses.replace(batch, **{name: np.asarray(getattr(batch, name))[:, b] for name in (*FIELDS, *FLAGS)})
