"""Mimic joints: dependent coordinates q_mimic = multiplier q_leader + offset (ModelBuilder.add_mimic, URDF <mimic>).

The engine gathers each mimic joint's terms into its leader's column and row (``_tree`` fields ``coordinate``,
``multiplier``, ``offset``); the closed forms compute on the expanded model (every joint independent) and contract
with T = diag(1_6, Model.mimic_matrix). Here: the builder's laws, limits and refusals; the engine against the
expanded model contracted (numpy) and against the closed forms, at batch sizes on both drivers; a mimic joint's own
rotor, damping and friction; 1000 s of free-floating motion (momentum conserved); the specialised kernels against
the generic ones. Files (TOML, URDF, MJCF) and MuJoCo: tests/io/test_mimic_files.py; Pinocchio:
tests/oracle/test_pinocchio_mimic.py, tests/oracle/test_real_robots.py.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import block_diag

import freefloat as ff
from freefloat.engine import drivers as _drivers
from freefloat.engine.specialise import build as _specialise
from mechanics.test_specialise import specialised  # noqa: F401 (the fixture: specialised kernels in a cache of their own)
from simulation.test_simulate import bounded_random_torques, moving_state
from trees import build_random_model

#: Engine against the expanded model contracted, and against the closed forms (relative; measured 2026-11-26: 2e-15).
BOUND = 1e-12


def gripper(*, mimic: bool = True, passive: bool = False) -> ff.Model:
    """A spacecraft, a 2-link arm, a wrist, two fingers (the second mimics the first, negatively) and a camera mast
    whose tilt follows the shoulder through a chain (a mimic of a mimic, in another arm), one prismatic mimic."""
    rng = np.random.default_rng(2)
    b = ff.ModelBuilder("gripper")
    b.add_body("bus", mass=300.0, inertia=[40.0, 50.0, 60.0], com=[0.05, -0.02, 0.1])
    for name, mass in (("upper", 8.0), ("fore", 5.0), ("wrist", 2.0), ("left", 0.4), ("right", 0.5), ("mast", 3.0), ("cam", 1.0)):
        b.add_body(name, mass=mass, inertia=mass * rng.uniform(0.01, 0.02, 3), com=rng.normal(scale=0.1, size=3))
    p = {"damping": 0.3, "friction": 0.2, "armature": 0.05} if passive else {}
    b.add_joint("shoulder", parent="bus", child="upper", origin=[0.6, 0, 0.2], axis=[0, 0, 1], limits=(-2.5, 2.5))
    b.add_joint("elbow", parent="upper", child="fore", origin=[0.7, 0, 0], axis=[0, 1, 0.2], **p)
    b.add_joint("wrist", parent="fore", child="wrist", origin=[0.5, 0, 0], axis=[1, 0, 0])
    b.add_joint("finger_l", parent="wrist", child="left", origin=[0.1, 0.02, 0], axis=[0, 1, 0], type="prismatic", limits=(0, 0.04))
    b.add_joint("finger_r", parent="wrist", child="right", origin=[0.1, -0.02, 0], axis=[0, 1, 0], type="prismatic", limits=(-0.04, 0), **p)
    b.add_joint("mast", parent="bus", child="mast", origin=[-0.5, 0, 0.5], axis=[0, 1, 0], limits=(-1.0, 1.0), **p)
    b.add_joint("tilt", parent="mast", child="cam", origin=[0, 0, 0.4], axis=[1, 0, 1], **p)
    if mimic:
        b.add_mimic("finger_r", leader="finger_l", multiplier=-1.0)
        b.add_mimic("mast", leader="shoulder", multiplier=0.5, offset=0.1)
        b.add_mimic("tilt", leader="mast", multiplier=-2.0, offset=0.3)  # a chain: tilt = -shoulder + 0.1
    b.add_end_effector("tool", body="wrist", point=[0.15, 0, 0])
    b.add_end_effector("eye", body="cam", point=[0, 0, 0.1])
    return b.build()


def rel(ours: np.ndarray, ref: np.ndarray) -> float:
    return float(np.max(np.abs(ours - ref)) / max(np.max(np.abs(ref)), 1e-300))


# ----------------------------------------------------------------- the model
def test_laws_are_resolved_to_the_root_leader_and_limits_carried_to_it() -> None:
    model = gripper()
    assert model.joint_names == ("shoulder", "elbow", "wrist", "finger_l")
    assert model.body_joint_names == ("shoulder", "elbow", "wrist", "finger_l", "finger_r", "mast", "tilt")
    laws = {r["joint"]: (r["leader"], r["multiplier"], r["offset"]) for r in model.mimic}
    assert laws == {"finger_r": ("finger_l", -1.0, 0.0), "mast": ("shoulder", 0.5, 0.1), "tilt": ("shoulder", -1.0, pytest.approx(0.1))}
    np.testing.assert_array_equal(model.body_joint_coordinate, [0, 1, 2, 3, 3, 0, 0])
    np.testing.assert_allclose(model.body_joint_values([0.4, 0, 0, 0.01]), [0.4, 0, 0, 0.01, -0.01, 0.3, -0.3])
    # the mast's limits [-1, 1] bound the shoulder to [-2.2, 1.8] (its own [-2.5, 2.5] intersected); the fingers agree
    np.testing.assert_allclose(model.joint_lower, [-2.2, -np.inf, -np.inf, 0.0])
    np.testing.assert_allclose(model.joint_upper, [1.8, np.inf, np.inf, 0.04])
    assert model.prismatic.tolist() == [False, False, False, True]
    assert model.body_joint_prismatic.tolist() == [False, False, False, True, True, False, False]
    assert not gripper(mimic=False).has_mimic and gripper().has_mimic


def test_a_mimic_joint_has_no_column_of_q() -> None:
    with pytest.raises(ff.UnknownNameError, match=r"'tilt' is a mimic joint .*follows 'shoulder'.*use the leader"):
        gripper().joint_index("tilt")


@pytest.mark.parametrize(
    ("mimics", "match"),
    [
        ([("j2", "j2")], r"mimic \(j2\): joint 'j2' mimics itself through a chain of mimic joints \(j2 -> j2\)"),
        ([("j2", "j3"), ("j3", "j2")], r"mimic \(j2\): joint 'j2' mimics itself .*\(j2 -> j3 -> j2\); let the chain end"),
        ([("j2", "weld")], r"mimic \(j2\)\.leader: joint 'j2' mimics the fixed joint 'weld', which has no coordinate; make 'j2' fixed"),
        ([("weld", "j1")], r"mimic \(weld\): joint 'weld' is fixed: it has no coordinate to follow another"),
        ([("j2", "j9")], r"mimic \(j2\)\.leader: joint 'j2' mimics 'j9', which is not a joint of the model"),
        ([("j7", "j1")], r"mimic \(j7\): there is no joint named 'j7'"),
    ],
)
def test_bad_mimics_are_refused_naming_the_joint(mimics: list[tuple[str, str]], match: str) -> None:
    b = ff.ModelBuilder("bad")
    b.add_body("bus", mass=100.0, inertia=10.0)
    for k in range(4):
        b.add_body(f"l{k}", mass=1.0, inertia=0.1, com=[0.2, 0, 0])
    b.add_joint("j1", parent="bus", child="l0", origin=[0.5, 0, 0])
    b.add_joint("j2", parent="l0", child="l1", origin=[0.5, 0, 0])
    b.add_joint("j3", parent="l1", child="l2", origin=[0.5, 0, 0])
    b.add_joint("weld", parent="l2", child="l3", origin=[0.5, 0, 0], type="fixed")
    for joint, leader in mimics:
        b.add_mimic(joint, leader=leader)
    with pytest.raises(ff.ModelError, match=match):
        b.build()


def test_bad_laws_and_limits_are_refused_naming_the_joint() -> None:
    b = ff.ModelBuilder("bad")
    with pytest.raises(ff.ModelError, match=r"mimic \(j2\)\.multiplier: is nan; give a finite number"):
        b.add_mimic("j2", leader="j1", multiplier=float("nan"))
    with pytest.raises(ff.ModelError, match=r"mimic \(j2\)\.offset: cannot read 'x' as a number"):
        b.add_mimic("j2", leader="j1", offset="x")  # type: ignore[arg-type]
    b.add_mimic("j2", leader="j1")
    with pytest.raises(ff.ModelError, match=r"mimic \(j2\): joint 'j2' is given two mimic laws"):
        b.add_mimic("j2", leader="j1")
    b.add_body("bus", mass=100.0, inertia=10.0)
    b.add_body("a", mass=1.0, inertia=0.1, com=[0.2, 0, 0])
    b.add_body("c", mass=1.0, inertia=0.1, com=[0.2, 0, 0])
    b.add_joint("j1", parent="bus", child="a", origin=[0.5, 0, 0], limits=(0.0, 1.0))
    b.add_joint("j2", parent="a", child="c", origin=[0.5, 0, 0], limits=(2.0, 3.0))
    with pytest.raises(ff.ModelError, match=r"mimic \(j2\): its limits \[2, 3\] leave no range of its leader 'j1'.*widen"):
        b.build()


# ----------------------------------------------------------------- the engine
def contracted(model: ff.Model, q: np.ndarray, v: np.ndarray) -> dict[str, np.ndarray]:
    """The engine's answers for the expanded model at the body joints' values and rates, contracted by the laws."""
    ex, m = model.expanded(), model.mimic_matrix
    t = block_diag(np.eye(6), m)
    qb, vb = model.body_joint_values(q), v @ t.T
    tau = np.linspace(-1.0, 1.0, model.n_joints)
    h = t.T @ ff.system_inertia_matrix(ex, qb) @ t
    c = ff.nonlinear_forces(ex, qb, vb) @ t
    rhs = np.concatenate([np.zeros((*q.shape[:-1], 3)), np.broadcast_to(tau, (*q.shape[:-1], model.n_joints))], axis=-1)
    return {
        "J*": ff.generalized_jacobian(ex, qb) @ m,
        "H+": h,
        "C+": c,
        "J+": ff.point_jacobian(ex, qb, model.n_bodies - 1, [0.1, 0.0, 0.2]) @ t,
        "Hdot": t.T @ ff.mechanics.system_inertia_matrix_rate(ex, qb, vb[..., 6:]) @ t,
        "positions": ff.end_effector_positions(ex, qb),
        "bias": ff.mechanics.point_bias_acceleration(ex, qb, vb, model.n_bodies - 1),
        "forward": np.linalg.solve(h[..., 3:, 3:], (rhs - c[..., 3:])[..., None])[..., 0],
        "tau": tau,
    }


def answers(model: ff.Model, q: np.ndarray, v: np.ndarray, tau: np.ndarray, **method: str) -> dict[str, np.ndarray]:
    return {
        "J*": ff.generalized_jacobian(model, q, **method),
        "H+": ff.system_inertia_matrix(model, q, **method),
        "C+": ff.nonlinear_forces(model, q, v, **method),
        "J+": ff.point_jacobian(model, q, model.n_bodies - 1, [0.1, 0.0, 0.2], **method),
        "Hdot": ff.mechanics.system_inertia_matrix_rate(model, q, v[..., 6:], **method),
        "positions": ff.end_effector_positions(model, q, **method),
        "bias": ff.mechanics.point_bias_acceleration(model, q, v, model.n_bodies - 1, **method),
        "forward": ff.forward_dynamics(model, q, v, tau, **method)[..., 3:],
    }


@pytest.mark.parametrize("size", [1, _drivers.Batched.PARALLEL_MIN + 3])  # one range, and one range per thread
def test_the_engine_equals_the_expanded_model_contracted(size: int) -> None:
    model = gripper()
    rng = np.random.default_rng(size)
    q = rng.uniform(-1.0, 1.0, (size, model.n_joints)) * np.where(model.prismatic, 0.02, 1.0)
    v = rng.normal(size=(size, 6 + model.n_joints))
    ref = contracted(model, q, v)
    ours = answers(model, q, v, ref["tau"])
    for name, value in ours.items():
        assert rel(value, ref[name]) < BOUND, name
    # a loop over single configurations equals the batch
    np.testing.assert_array_equal(ff.generalized_jacobian(model, q[0]), ours["J*"][0])


def test_the_engine_equals_the_closed_forms() -> None:
    """The barycentric forms (revolute joints only for C+, dH+/dt and forward dynamics: the fingers become revolute)."""
    rng = np.random.default_rng(1)
    model = gripper()
    q = rng.uniform(-1.0, 1.0, (5, model.n_joints)) * np.where(model.prismatic, 0.02, 1.0)
    v = rng.normal(size=(5, 6 + model.n_joints))
    for name in ("J*", "H+", "J+", "positions", "bias"):
        fn = {
            "J*": ff.generalized_jacobian,
            "H+": ff.system_inertia_matrix,
            "J+": lambda m, q, **k: ff.point_jacobian(m, q, m.n_bodies - 1, [0.1, 0.0, 0.2], **k),
            "positions": ff.end_effector_positions,
            "bias": lambda m, q, **k: ff.mechanics.point_bias_acceleration(m, q, v, m.n_bodies - 1, **k),
        }[name]
        assert rel(fn(model, q), fn(model, q, method="barycentric")) < BOUND, name
    revolute = build_random_model(np.random.default_rng(4), [3, 2], [1, None], [None, 0], mimic=0.5)
    assert revolute.has_mimic and not revolute.expanded().has_prismatic
    q = rng.uniform(-1.0, 1.0, (5, revolute.n_joints))
    v = rng.normal(size=(5, 6 + revolute.n_joints))
    tau = rng.normal(size=revolute.n_joints)
    ours, ref = answers(revolute, q, v, tau), answers(revolute, q, v, tau, method="barycentric")
    for name in ours:
        assert rel(ours[name], ref[name]) < BOUND, name


def test_a_mimic_joints_rotor_damping_and_friction_act_through_its_leader() -> None:
    """Armature r^2 a on the leader's diagonal; damping and friction at the mimic joint's own rate, times r."""
    model = gripper(passive=True)
    ex = model.expanded()
    assert ex.joint_damping.tolist() == [0, 0.3, 0, 0, 0.3, 0.3, 0.3] and model.joint_damping.tolist() == [0, 0.3, 0, 0]
    rng = np.random.default_rng(3)
    q = rng.uniform(-1.0, 1.0, (4, model.n_joints)) * np.where(model.prismatic, 0.02, 1.0)
    v = rng.normal(size=(4, 6 + model.n_joints))
    t = block_diag(np.eye(6), model.mimic_matrix)
    qb, vb = model.body_joint_values(q), v @ t.T
    assert rel(ff.system_inertia_matrix(model, q), t.T @ ff.system_inertia_matrix(ex, qb) @ t) < BOUND
    passive = ff.mechanics.passive_torque(model, v[:, 6:])
    assert rel(passive, ff.mechanics.passive_torque(ex, vb[:, 6:]) @ model.mimic_matrix) < BOUND
    tau = rng.normal(size=model.n_joints)
    h = t.T @ ff.system_inertia_matrix(ex, qb) @ t
    rhs = np.concatenate([np.zeros((4, 3)), tau + passive], axis=-1) - (ff.nonlinear_forces(ex, qb, vb) @ t)[:, 3:]
    expected = np.linalg.solve(h[:, 3:, 3:], rhs[..., None])[..., 0]
    assert rel(ff.forward_dynamics(model, q, v, tau)[:, 3:], expected) < BOUND


def test_a_mimic_joints_armature_adds_r_squared_a_to_its_leaders_diagonal() -> None:
    """H+ with rotors minus H+ without is diagonal on the joints: each independent joint's own armature a plus, for each
    mimic joint following it with ratio r (chains multiplied out), r^2 a. The numbers are the gripper's, written here:
    armature 0.05 on elbow, finger_r (r = -1 of finger_l), mast (r = 0.5 of shoulder) and tilt (r = -2 x 0.5 = -1 of
    shoulder). r a in place of r^2 a gives the shoulder 0.05 (0.5 - 1) < 0 and finger_l -0.05: far from it."""
    a = 0.05
    expected = np.diag(np.concatenate([np.zeros(6), [a * (0.5**2 + (-2.0 * 0.5) ** 2), a, 0.0, a * (-1.0) ** 2]]))
    with_rotors = dataclasses.replace(gripper(passive=True), joint_damping=np.zeros(4), joint_friction=np.zeros(4))
    bare = gripper()
    assert with_rotors.joint_names == bare.joint_names == ("shoulder", "elbow", "wrist", "finger_l")
    q = np.random.default_rng(4).uniform(-1.0, 1.0, (3, 4)) * np.where(bare.prismatic, 0.02, 1.0)
    for method in ("recursive", "barycentric"):
        added = ff.system_inertia_matrix(with_rotors, q, method=method) - ff.system_inertia_matrix(bare, q, method=method)
        assert np.abs(added - expected).max() < 1e-14, method


def test_free_floating_1000_s_with_mimic_joints_conserves_momentum() -> None:
    """1000 s of random torques on the independent joints (thrusters off): momentum conserved to 1e-9 (relative).

    Measured at the default tolerances (1e-10): angular momentum drift 1.8e-12, linear 0 (9 s on the dev VM)."""
    model = gripper()
    state = moving_state(model, np.random.default_rng(5))
    controller = bounded_random_torques(model, seed=1)
    traj = ff.simulate(model, state, 1000.0, controller, output_period=1.0, joint_limits="flag")
    assert traj.status == "finished" and traj.t[-1] == 1000.0
    assert np.abs(traj.qdot).max() > 0.05, "the joints should move"
    h, p = traj.angular_momentum, traj.linear_momentum
    assert np.abs(h - h[0]).max() / np.linalg.norm(h[0]) < 1e-9
    assert np.abs(p - p[0]).max() / np.linalg.norm(p[0]) < 1e-9
    # the momentum the bodies carry (each body's own Jacobian, mimic bodies included) is the system's
    linear = np.zeros((len(traj), 3))
    for k in range(model.n_bodies):
        jac = ff.point_jacobian(model, traj.q, k, model.com[k], attitude=traj.attitude)[..., 0:3, :]
        linear += model.mass[k] * np.einsum("tij,tj->ti", jac, traj.velocity)
    assert np.abs(linear - p).max() < 1e-9 * np.linalg.norm(p[0])


# ----------------------------------------------------------------- the specialiser
def test_specialised_kernels_of_a_mimic_model_equal_the_generic_ones(specialised: Path) -> None:  # noqa: F811
    """J* and forward dynamics (the Newton-Euler rows and H+ of the rollouts' state derivative) traced with the mimic
    map as structure (folded) and the offsets as data."""
    model = gripper()
    ff.mechanics.specialise(model, ["jstar", "forward"])
    assert ff.mechanics.is_specialised(model, "jstar") and ff.mechanics.is_specialised(model, "forward")
    rng = np.random.default_rng(6)
    n = model.n_joints
    q = rng.uniform(-1.0, 1.0, (130, n)) * np.where(model.prismatic, 0.02, 1.0)
    v = rng.normal(size=(130, 6 + n))
    tau = rng.normal(size=(130, n))
    fast = ff.generalized_jacobian(model, q), ff.forward_dynamics(model, q, v, tau)
    with _specialise.generic():
        slow = ff.generalized_jacobian(model, q), ff.forward_dynamics(model, q, v, tau)
    for a, b in zip(fast, slow, strict=True):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * np.abs(b).max())
