"""An MJCF two-arm robot whose joints carry springs (``stiffness``, ``springref``), against MuJoCo on the same file.

The file (written here: 5-40 N m/rad springs relaxed at -0.4 to 0.6 rad, no damping) loads with its ``stiffness`` and
``springref`` read into ``Model.joint_stiffness`` and ``joint_springref`` (the new per-joint field of issue 43: one
line of ``engine.layout.BODY_FIELDS`` each, the torque in ``engine.recursions.passive_spring`` and its numpy
reference ``ff.mechanics.spring_torque``), and agrees with MuJoCo on the same file:

* forward dynamics: ``mj_forward``'s qacc (MuJoCo's passive force ``qfrc_spring`` = -stiffness (qpos - springref));
* a 5 s simulation, MuJoCo RK4 at 1 ms against ``ff.simulate`` (final joint angles, rad);
* the spring is conservative: the kinetic energy plus ``ff.mechanics.spring_energy`` stays constant, the dissipated
  energy is zero, the momentum is conserved.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import mujoco  # an oracle: a missing one fails these tests
import numpy as np
import pytest

import freefloat as ff
from freefloat.io.mujoco_bridge import to_mjcf
from mechanics.test_specialise_dynamics import own_cache as own_cache  # the fixture
from mjcf_arms import JOINTS, order, set_state, state_of, write_arms
from oracle_checks import MARGIN, assert_within, relative_error
from trees import build_random_model

#: Agreement with MuJoCo on this file (relative; the simulation's in rad and m), measured 2026-12-02 on the 2-core dev
#: VM (MuJoCo 4.0.0, numpy 2.4.6): forward dynamics 6.6e-15, final q of the 5 s run 1.4e-14 (both RK4 at 1 ms); the
#: drift of the kinetic energy plus the springs' potential over the run, relative to it, 2.9e-11 (RK4's error at 1 ms).
FORWARD_MEASURED = 6.7e-15
SIMULATION_MEASURED = 1.4e-14
ENERGY_DRIFT_MEASURED = 2.9e-11


def write(tmp_path: Path) -> Path:
    joints = ('stiffness="40" springref="0.6"', 'stiffness="12" springref="-0.4"', 'stiffness="5" springref="0.05"')
    return write_arms(tmp_path / "springs.xml", joints, wrist_type="slide", angle="radian", name="two_arm_springs")


def without_springs(model: ff.Model) -> ff.Model:
    return dataclasses.replace(model, joint_stiffness=None, joint_springref=None)


def test_the_springs_are_read_and_written(tmp_path: Path) -> None:
    model = ff.load(write(tmp_path))
    assert model.joint_names == tuple(JOINTS)
    np.testing.assert_array_equal(model.joint_stiffness, [40.0, 12.0, 5.0] * 2)
    np.testing.assert_array_equal(model.joint_springref, [0.6, -0.4, 0.05] * 2)
    assert model.has_springs and not model.has_passive  # a spring dissipates nothing
    assert not model.unmodelled  # modelled: nothing dropped
    again = ff.load(ff.save(model, tmp_path / "springs.toml"))  # TOML keeps them
    np.testing.assert_array_equal(again.joint_stiffness, model.joint_stiffness)
    np.testing.assert_array_equal(again.joint_springref, model.joint_springref)
    mj = mujoco.MjModel.from_xml_string(to_mjcf(model))  # and the MJCF the oracles build
    qadr, _ = order(mj, model)
    np.testing.assert_array_equal([mj.jnt_stiffness[mj.joint(n).id] for n in JOINTS], model.joint_stiffness)
    np.testing.assert_array_equal(mj.qpos_spring[qadr], model.joint_springref)


def test_forward_dynamics_with_springs_agree_with_mujoco(tmp_path: Path) -> None:
    path = write(tmp_path)
    model = ff.load(path)
    mj = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(mj)
    _, vadr = order(mj, model)
    rng = np.random.default_rng(43)
    worst = 0.0
    for _ in range(5):
        state = ff.State(q=rng.uniform(-1.0, 1.0, 6), qdot=rng.normal(size=6), omega=rng.normal(scale=0.05, size=3)).resolve(model)
        set_state(mj, data, model, state)
        mujoco.mj_forward(mj, data)
        assert np.abs(data.qfrc_spring).max() > 1.0  # the springs act
        ref = np.concatenate([data.qacc[3:6], data.qacc[vadr]])  # the spacecraft's angular acceleration (its frame), qddot
        ours = ff.forward_dynamics(model, state.q, state.velocity, attitude=state.attitude)
        worst = max(worst, relative_error("forward dynamics", ours[3:], ref))
        bare = ff.forward_dynamics(without_springs(model), state.q, state.velocity, attitude=state.attitude)
        assert relative_error("without springs", bare[3:], ref) > 1e-3  # the comparison sees the springs
    assert_within("forward dynamics with springs vs mj_forward", worst, MARGIN * FORWARD_MEASURED)


def test_five_seconds_with_springs_agree_with_mujoco_and_conserve_the_energy(tmp_path: Path) -> None:
    path = write(tmp_path)
    model = ff.load(path)
    mj = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(mj)
    state = ff.State(q=np.linspace(-0.8, 0.9, 6), qdot=np.linspace(1.5, -1.0, 6), omega=[0.01, 0.02, -0.03]).resolve(model)
    set_state(mj, data, model, state)
    for _ in range(5000):
        mujoco.mj_step(mj, data)
    final = state_of(mj, data, model)
    traj = ff.simulate(model, state, 5.0, fixed_step=1e-3, joint_limits="flag")
    assert np.abs(traj.q[-1] - traj.q[0]).max() > 0.1, "the arms should move"
    assert_within("final q after 5 s with springs vs MuJoCo", float(np.abs(traj.q[-1] - final.q).max()), MARGIN * SIMULATION_MEASURED)
    assert np.abs(ff.simulate(without_springs(model), state, 5.0, fixed_step=1e-3, joint_limits="flag").q[-1] - final.q).max() > 1e-3
    springs = ff.mechanics.spring_energy(model, traj.q)
    energy = traj.kinetic_energy + springs
    assert springs.max() - springs.min() > 0.1 * energy[0]  # energy goes back and forth between motion and springs
    assert_within("energy drift with springs", float(np.abs(energy - energy[0]).max() / energy[0]), MARGIN * ENERGY_DRIFT_MEASURED)
    np.testing.assert_array_equal(traj.dissipated_energy, 0.0)  # conservative: nothing dissipated
    momentum = traj.angular_momentum
    assert float(np.abs(momentum - momentum[0]).max()) < 1e-9 * max(1.0, float(np.abs(momentum).max()))
    np.testing.assert_allclose(traj.passive_torque, ff.mechanics.spring_torque(model, traj.q), rtol=0, atol=0)


def test_springs_of_mimic_joints_in_the_engine_equal_the_reference() -> None:
    """The engine's spring (``recursions.passive_spring``, at each body joint's value: multiplier q + offset) against
    the numpy reference (``mechanics.spring_torque``, gathered on the leaders, in the barycentric closed forms of
    revolute joints) through forward and inverse dynamics (a prismatic joint's spring: against MuJoCo, above)."""
    rng = np.random.default_rng(5)
    base = build_random_model(rng, [3, 2], [0, None], [1, None], mimic=0.4)
    assert base.has_mimic
    n = base.n_joints
    mimic = tuple({**r, "stiffness": 7.0, "springref": -0.2} for r in base.mimic)
    model = dataclasses.replace(base, joint_stiffness=rng.uniform(1.0, 30.0, n), joint_springref=rng.uniform(-0.5, 0.5, n), mimic=mimic)
    q, v = rng.uniform(-1.0, 1.0, (4, n)), rng.normal(size=(4, 6 + n))
    engine = ff.forward_dynamics(model, q, v)
    reference = ff.forward_dynamics(model, q, v, method="barycentric")
    assert relative_error("forward dynamics, springs", engine, reference) < 1e-11
    assert relative_error("the springs act", ff.forward_dynamics(without_springs(base), q, v), engine) > 1e-3
    tau = ff.inverse_dynamics(model, q, v, np.zeros((4, 6 + n)))[2]  # holds the arm against its springs: -spring torque
    free = ff.inverse_dynamics(base, q, v, np.zeros((4, 6 + n)))[2]
    np.testing.assert_allclose(tau - free, -ff.mechanics.spring_torque(model, q), rtol=1e-9, atol=1e-9)
    with pytest.raises(ValueError, match=r"q: .* has joint springs"):
        ff.mechanics.passive_torque(model, v[:, 6:])


@pytest.mark.parametrize(
    ("key", "value", "match"),
    [
        ("stiffness", -1.0, r"joints\[0\] \(j\)\.stiffness: is -1\.0; give the spring stiffness, in N m/rad .*finite and >= 0"),
        ("stiffness", float("inf"), r"joints\[0\] \(j\)\.stiffness: is inf"),
        ("springref", float("nan"), r"joints\[0\] \(j\)\.springref: is nan; give the joint value at which the spring is relaxed.*finite"),
    ],
)
def test_bad_springs_name_the_joint(key: str, value: float, match: str) -> None:
    builder = ff.ModelBuilder("bad")
    builder.add_body("bus", mass=100.0, inertia=10.0)
    builder.add_body("link", mass=5.0, inertia=[0.1, 0.2, 0.3], com=[0.5, 0, 0])
    with pytest.raises(ff.ModelError, match=match):
        builder.add_joint("j", parent="bus", child="link", **{key: value})
    builder.add_joint("j", parent="bus", child="link", springref=-0.3)  # a negative springref is a joint value
    model = builder.build()
    with pytest.raises(ff.ModelError, match=match.replace(r"\(j\)", r"\(j\)")):
        dataclasses.replace(model, **{f"joint_{key}": [value]})


def test_fixed_steps_too_long_for_a_spring_are_said_before_the_run(tmp_path: Path) -> None:
    """A joint spring K on an effective inertia m oscillates at w = sqrt(K / m); RK4 steps longer than 2 sqrt(2) / w
    diverge, and the run says so before it starts, naming the joint; shorter steps say nothing."""
    from freefloat.core.errors import StiffGainsWarning

    model = ff.load(write(tmp_path))
    stiff = dataclasses.replace(model, joint_stiffness=model.joint_stiffness * 1e5)
    state = ff.State(q=np.full(6, 0.1))
    with (
        pytest.warns(StiffGainsWarning, match=r"cannot follow the joints' springs: joint '[ab]_\w+' .* needs steps below"),
        pytest.raises(ff.SimulationError, match="diverged"),  # as it says
    ):
        ff.simulate(stiff, state, 0.01, fixed_step=0.01, joint_limits="flag")
    ff.simulate(model, state, 0.01, fixed_step=0.01, joint_limits="flag")  # the file's springs: no warning


def test_the_specialised_kernels_read_the_springs(own_cache: None) -> None:
    """The springs are data the specialised kernels read (``fold_zeros``: a zero stiffness is folded away, and where
    they are zero is part of the structure): specialised forward dynamics equal the generic ones."""
    from freefloat.engine.layout import tree
    from freefloat.engine.specialise import build as _specialise

    rng = np.random.default_rng(12)
    base = build_random_model(rng, [3, 2], [0, None], [1, None], prismatic=0.5)
    n = base.n_joints
    stiffness = np.where(np.arange(n) % 2 == 0, rng.uniform(5.0, 50.0, n), 0.0)
    model = dataclasses.replace(base, joint_stiffness=stiffness, joint_springref=rng.uniform(-0.5, 0.5, n))
    q, v = rng.uniform(-2, 2, (300, n)), rng.uniform(-1, 1, (300, 6 + n))
    a_ref = ff.forward_dynamics(model, q, v)
    assert np.abs(a_ref - ff.forward_dynamics(base, q, v)).max() > 1e-3 * np.abs(a_ref).max()  # the springs act
    calls: list[str] = []
    real = _specialise.mapped
    _specialise.specialise(tree(model), ("forward",))
    _specialise._ENABLED[0] = True
    _specialise.mapped = lambda module, *args: (calls.append(module.__name__), real(module, *args))[1]  # type: ignore[assignment]
    try:
        a = ff.forward_dynamics(model, q, v)
    finally:
        _specialise.mapped = real  # type: ignore[assignment]
        _specialise._ENABLED[0] = False
    assert len(calls) == 1, calls  # it ran specialised
    assert np.abs(a - a_ref).max() < 1e-12 * np.abs(a_ref).max()
    keys = {_specialise.structure_key(tree(m), "forward") for m in (base, model)}
    assert len(keys) == 2, "where the stiffness is zero is part of the structure"
