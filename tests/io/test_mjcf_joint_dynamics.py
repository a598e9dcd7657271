"""An MJCF two-arm robot whose joints carry rotor inertia, damping and friction (issue 21), against MuJoCo on the same file.

The file (written here, realistic values: 0.01-0.05 kg m² of armature, 0.5-2 N m s/rad of damping, 0.1-0.4 N m
of friction) loads with its ``armature``, ``damping`` and ``frictionloss`` read into ``Model.joint_armature``,
``joint_damping`` and ``joint_friction``, and agrees with MuJoCo on the same file:

* the kinetic energy 1/2 qvel^T M qvel (``mj_fullM``: MuJoCo adds the armature to M's diagonal);
* forward dynamics: ``mj_forward``'s qacc with damping and without friction (MuJoCo's frictionloss is a
  constraint, dry friction exact at rest; freefloat's is smooth, so friction is compared on its own law);
* a 5 s simulation with damping, MuJoCo RK4 at 1 ms against ``ff.simulate`` (final joint angles, rad).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import mujoco  # an oracle: a missing one fails these tests
import numpy as np
import pytest

import freefloat as ff
from mjcf_arms import JOINTS, order, set_state, state_of, write_arms
from oracle_checks import MARGIN, assert_within, relative_error

#: Agreement with MuJoCo on this file (relative; the simulation's in rad), measured 2026-11-26 on the 2-core dev VM
#: (MuJoCo 4.0.0, numpy 2.4.6): kinetic energy 7.5e-16, forward dynamics 4.2e-14, final q of the 5 s run 4.4e-16 (both
#: RK4 at 1 ms).
ENERGY_MEASURED = 7.6e-16
FORWARD_MEASURED = 4.2e-14
SIMULATION_MEASURED = 4.5e-16


def write(tmp_path: Path, *, friction: bool = True) -> Path:
    """The two-arm file; ``friction`` False leaves the joints' ``frictionloss`` out."""
    losses = [f' frictionloss="{value}"' if friction else "" for value in (0.4, 0.25, 0.1)]
    joints = ('armature="0.05" damping="2.0"', 'armature="0.03" damping="1.2"', 'armature="0.01" damping="0.5"')
    path = tmp_path / ("arms.xml" if friction else "arms_no_friction.xml")
    return write_arms(path, [j + f for j, f in zip(joints, losses, strict=True)], motors=True, name="two_arm_rotors")


def test_the_joint_parameters_are_read(tmp_path: Path) -> None:
    model = ff.load(write(tmp_path))
    assert model.joint_names == tuple(JOINTS)
    np.testing.assert_array_equal(model.joint_armature, [0.05, 0.03, 0.01] * 2)
    np.testing.assert_array_equal(model.joint_damping, [2.0, 1.2, 0.5] * 2)
    np.testing.assert_array_equal(model.joint_friction, [0.4, 0.25, 0.1] * 2)


def test_kinetic_energy_and_forward_dynamics_agree_with_mujoco(tmp_path: Path) -> None:
    path = write(tmp_path, friction=False)
    model = ff.load(path)
    assert not model.joint_friction.any() and model.joint_damping.all() and model.joint_armature.all()
    mj = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(mj)
    _, vadr = order(mj, model)
    rng = np.random.default_rng(21)
    worst_energy = worst_forward = 0.0
    for _ in range(5):
        state = ff.State(
            q=rng.uniform(-1.0, 1.0, 6), qdot=rng.normal(size=6), omega=rng.normal(scale=0.05, size=3), v_cm=[0.1, 0.0, -0.05]
        ).resolve(model)
        set_state(mj, data, model, state)
        data.ctrl[:] = 0.0
        mujoco.mj_forward(mj, data)
        full = np.zeros((mj.nv, mj.nv))
        mujoco.mj_fullM(mj, data, full)
        energy = 0.5 * data.qvel @ full @ data.qvel
        worst_energy = max(worst_energy, abs(float(ff.kinetic_energy(model, state.q, state.velocity)) - energy) / energy)
        ours = ff.forward_dynamics(model, state.q, state.velocity, attitude=state.attitude)
        ref = np.concatenate([data.qacc[3:6], data.qacc[vadr]])  # the spacecraft's angular acceleration (its frame), qddot
        worst_forward = max(worst_forward, relative_error("forward dynamics", ours[3:], ref))
        # without its damping, the file's model gives other accelerations: the comparison sees the damping
        bare = ff.forward_dynamics(model.without_passive(), state.q, state.velocity, attitude=state.attitude)
        assert relative_error("without damping", bare[3:], ref) > 1e-3
    assert_within("kinetic energy with armature vs mj_fullM", worst_energy, MARGIN * ENERGY_MEASURED)
    assert_within("forward dynamics with armature and damping vs mj_forward", worst_forward, MARGIN * FORWARD_MEASURED)


def test_five_seconds_with_damping_agree_with_mujoco(tmp_path: Path) -> None:
    path = write(tmp_path, friction=False)
    model = ff.load(path)
    mj = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(mj)
    state = ff.State(q=np.linspace(-0.8, 0.9, 6), qdot=np.linspace(1.5, -1.0, 6), omega=[0.01, 0.02, -0.03]).resolve(model)
    set_state(mj, data, model, state)
    for _ in range(5000):
        mujoco.mj_step(mj, data)
    final = state_of(mj, data, model)
    traj = ff.simulate(model, state, 5.0, fixed_step=1e-3, joint_limits="flag")
    error = float(np.abs(traj.q[-1] - final.q).max())
    assert np.abs(traj.q[-1] - traj.q[0]).max() > 0.1, "the arms should move"
    assert traj.dissipated_energy[-1] > 0.1 * traj.kinetic_energy[0], "the damping should take a good part of the energy"
    assert_within("final q after 5 s with damping vs MuJoCo (rad)", error, MARGIN * SIMULATION_MEASURED)  # the issue asks 1e-6
    undamped = ff.simulate(model, state, 5.0, fixed_step=1e-3, joint_limits="flag", passive="ignore")
    assert np.abs(undamped.q[-1] - final.q).max() > 1e-3


def test_armature_error_of_1e_7_is_seen_by_the_energy_bound(tmp_path: Path) -> None:
    path = write(tmp_path, friction=False)
    model = ff.load(path)
    wrong = dataclasses.replace(model, joint_armature=model.joint_armature * (1.0 + 1e-7 * (np.arange(6) == 2)))
    mj = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(mj)
    state = ff.State(q=np.zeros(6), qdot=np.array([0.0, 0.0, 3.0, 0.0, 0.0, 0.0])).resolve(model)
    set_state(mj, data, model, state)
    mujoco.mj_forward(mj, data)
    full = np.zeros((mj.nv, mj.nv))
    mujoco.mj_fullM(mj, data, full)
    energy = 0.5 * data.qvel @ full @ data.qvel
    error = abs(float(ff.kinetic_energy(wrong, state.q, state.velocity)) - energy) / energy
    with pytest.raises(AssertionError, match="exceeds its bound"):
        assert_within("kinetic energy, armature wrong by 1e-7", error, MARGIN * ENERGY_MEASURED)
