"""The compiled (numba) dynamics and simulation against the numpy reference.

numba is in the test extras, so nothing here is skipped: without numba these tests fail.
The equations that are traced and compiled (``freeflyer.mechanics._compiled.state_derivative``) are checked
on random trees in plain floats (cheap, 100 hypothesis examples); the compiled kernels themselves
on the paper systems, the 7-DOF spacecraft and a random tree with a branch and a fixed joint.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import freeflyer as ff
from freeflyer.core.errors import ShapeError
from freeflyer.core.state import Actuation, State
from freeflyer.mechanics import _compiled
from freeflyer.simulation._integrate import _derivative
from freeflyer.simulation.pd import JointPD
from freeflyer.simulation.simulate import ActuatorLimits, rollout, simulate
from freeflyer.simulation.trajectory import Trajectory
from trees import build_random_model, random_trees

RTOL = 1e-10


def random_states(model: ff.Model, rng: np.random.Generator, count: int) -> tuple[np.ndarray, np.ndarray]:
    """Flat states (count, 13 + 2N) with random attitudes and rates, and actuations [tau, f_S, n_S]."""
    n = model.n_joints
    x = np.zeros((count, 13 + 2 * n))
    x[:, 0:6] = rng.normal(size=(count, 6))
    x[:, 6:10] = Rotation.random(count, random_state=rng).as_quat()
    x[:, 10:13] = rng.normal(scale=0.3, size=(count, 3))
    x[:, 13 : 13 + n] = rng.uniform(-np.pi, np.pi, size=(count, n))
    x[:, 13 + n :] = rng.normal(size=(count, n))
    u = rng.normal(scale=5.0, size=(count, n + 6))
    return x, u


def reference_derivative(model: ff.Model, x: np.ndarray, u: np.ndarray) -> np.ndarray:
    n = model.n_joints
    return _derivative(model, x, u[..., :n], u[..., n : n + 3], u[..., n + 3 :], ())


def assert_rel(ours: np.ndarray, ref: np.ndarray, rtol: float = RTOL) -> None:
    """Each row agrees to rtol relative to the largest entry of its reference row."""
    scale = np.max(np.abs(ref), axis=-1, keepdims=True)
    err = np.max(np.abs(ours - ref) / scale)
    assert err <= rtol, f"relative error {err:.2e} > {rtol:.0e}"


def test_numba_is_available() -> None:
    # the test extras install numba; the compiled back end must be there and used by default
    assert _compiled.available()
    assert _compiled.use_compiled("auto") == _compiled.enabled()
    assert _compiled.use_compiled("numba")


@settings(max_examples=100)
@given(random_trees(), st.integers(0, 2**32 - 1))
def test_traced_equations_match_numpy_on_random_trees(model: ff.Model, seed: int) -> None:
    # the scalar code that is traced and compiled, evaluated in floats
    x, u = random_states(model, np.random.default_rng(seed), 1)
    q = x[0, 13 : 13 + model.n_joints]
    ours = _compiled.state_derivative(model, list(x[0]), [math.sin(a) for a in q], [math.cos(a) for a in q], list(u[0]))
    assert_rel(np.array(ours, dtype=float), reference_derivative(model, x[0], u[0]))


COMPILED_MODELS = {
    "papadopoulos1991": ff.models.papadopoulos1991,
    "papadopoulos1992": lambda: ff.models.papadopoulos1992(arms=2),
    "papadopoulos1992_payload": lambda: ff.models.papadopoulos1992(arms=2).with_payload(end_effector=0, mass=400.0, inertia=25.0),
    "spacecraft_7dof": ff.models.spacecraft_7dof,
    "random_tree": lambda: build_random_model(np.random.default_rng(7), [2], [0], [1]),  # a branch and a fixed joint
}


@pytest.mark.parametrize("name", sorted(COMPILED_MODELS))
def test_compiled_derivative_matches_numpy(name: str) -> None:
    model = COMPILED_MODELS[name]()
    x, u = random_states(model, np.random.default_rng(3), 37)  # not a multiple of LANES: a partial block
    ours = _compiled.kernels(model).derivative(x, u)
    assert_rel(ours, reference_derivative(model, x, u))
    one = _compiled.kernels(model).derivative(x[5:6], u[5:6])  # one lane alone (the scalar remainder loop)
    assert_rel(one, ours[5:6], 1e-14)


def test_compiled_mass_matrix_and_bias_match_numpy() -> None:
    model = ff.models.papadopoulos1992(arms=2)
    x, _ = random_states(model, np.random.default_rng(4), 19)
    n = model.n_joints
    kernels = _compiled.kernels(model)
    h_ref = ff.system_inertia_matrix(model, x[:, 13 : 13 + n])[:, 3:, 3:]
    assert_rel(kernels.mass_matrix(x).reshape(19, -1), h_ref.reshape(19, -1))
    velocity = np.concatenate([x[:, 3:6], x[:, 10:13], x[:, 13 + n :]], axis=1)
    c_ref = ff.nonlinear_forces(model, x[:, 13 : 13 + n], velocity)[:, 3:]
    assert_rel(kernels.bias(x), c_ref)


def pd_for(model: ff.Model) -> JointPD:
    n = model.n_joints
    return JointPD(kp=np.linspace(20.0, 40.0, n), kd=np.linspace(8.0, 4.0, n), q_ref=np.full(n, 0.4), qdot_ref=0.1)


def trajectories_close(a: Trajectory, b: Trajectory, atol: float = 1e-9) -> None:
    np.testing.assert_array_equal(a.t, b.t)
    for field in ("q", "qdot", "omega", "attitude", "r_cm", "v_cm", "joint_torque", "spacecraft_force", "spacecraft_torque"):
        np.testing.assert_allclose(getattr(a, field), getattr(b, field), rtol=0, atol=atol, err_msg=field)
    np.testing.assert_array_equal(a.saturated, b.saturated)


def test_compiled_simulation_matches_numpy() -> None:
    model = ff.models.papadopoulos1992(arms=2)
    state = State(q=[0.1, -0.2, 0.3, 0.2], qdot=[0.1, 0.0, -0.1, 0.2], omega=[0.0, 0.0, 0.02], v_cm=[0.01, 0.0, 0.0])
    pd = pd_for(model)

    def controller(t: float, s: State) -> Actuation:  # joint PD plus thrusters, so every input is exercised
        return Actuation(joint_torque=pd(t, s), spacecraft_force=[1.0, -2.0, 0.5], spacecraft_torque=[0.0, 0.3, -1.0])

    options = {"fixed_step": 1e-3, "sample_period": 2e-3, "output_period": 0.01, "limits": ActuatorLimits(joint_torque=8.0)}
    ours = simulate(model, state, 0.1, controller, backend="numba", **options)
    ref = simulate(model, state, 0.1, controller, backend="numpy", **options)
    trajectories_close(ours, ref)
    assert ours.saturated.any()  # the limit was active at some samples: saturation is recorded the same way


def test_compiled_loop_with_python_controller_matches_numpy() -> None:
    model = ff.models.papadopoulos1992(arms=2)
    n = model.n_joints
    state = State(q=np.full(n, 0.2), omega=[0.01, -0.02, 0.01])
    pd = JointPD(kp=4.0, kd=1.0, q_ref=0.5)
    ref = simulate(model, state, 0.02, pd, fixed_step=1e-3, output_period=5e-3, backend="numpy")
    x0 = np.concatenate([[0.0] * 6, [0.0, 0.0, 0.0, 1.0], [0.01, -0.02, 0.01], np.full(n, 0.2), np.zeros(n)])

    def controller(t: float, x: np.ndarray) -> np.ndarray:
        return pd(t, State(q=x[13 : 13 + n], qdot=x[13 + n :]))

    t, xs, us = _compiled.kernels(model).simulate(x0, 1e-3, 20, controller, hold=1, stride=5)
    np.testing.assert_allclose(t, ref.t, rtol=0, atol=1e-15)
    np.testing.assert_allclose(xs[:, 13 : 13 + n], ref.q, rtol=0, atol=1e-10)
    np.testing.assert_allclose(xs[:, 6:10], ref.attitude, rtol=0, atol=1e-12)
    np.testing.assert_allclose(us[:, :n], ref.joint_torque, rtol=0, atol=1e-9)


def batch_setup(model: ff.Model, batch: int) -> tuple[State, JointPD]:
    n = model.n_joints
    rng = np.random.default_rng(11)
    states = State(q=rng.uniform(-1.0, 1.0, size=(batch, n)), qdot=rng.normal(scale=0.2, size=(batch, n)), omega=[0.0, 0.0, 0.01])
    feed = rng.normal(scale=2.0, size=(6, batch, n))  # an open-loop profile: 6 samples of 5 ms, the last held
    pd = JointPD(
        kp=rng.uniform(5.0, 40.0, size=(batch, n)),
        kd=rng.uniform(1.0, 6.0, size=(batch, 1)),
        q_ref=0.3,
        feedforward=feed,
        feedforward_period=5e-3,
    )
    return states, pd


def test_compiled_rollout_matches_loop_of_numpy_simulations() -> None:
    model = ff.models.papadopoulos1992(arms=2)
    batch = 3
    states, pd = batch_setup(model, batch)
    limits = ActuatorLimits(joint_torque=[6.0, 6.0, 9.0, 9.0])
    ours = rollout(model, states, 0.04, dt=1e-3, controller=pd, sample_period=5e-3, output_period=1e-2, limits=limits, backend="numba")
    assert ours.q.shape == (5, batch, model.n_joints)
    for b in range(batch):
        one = State(q=states.q[b], qdot=states.qdot[b], omega=[0.0, 0.0, 0.01])
        pd_b = JointPD(kp=pd.kp[b], kd=pd.kd[b], q_ref=0.3, feedforward=pd.feedforward[:, b], feedforward_period=5e-3)
        ref = simulate(model, one, 0.04, pd_b, fixed_step=1e-3, sample_period=5e-3, output_period=1e-2, limits=limits, backend="numpy")
        for field in ("q", "qdot", "omega", "attitude", "r_cm", "v_cm", "joint_torque"):
            np.testing.assert_allclose(getattr(ours, field)[:, b], getattr(ref, field), rtol=0, atol=1e-9, err_msg=field)
        np.testing.assert_array_equal(ours.saturated[:, b], ref.saturated)
    assert ours.saturated.any()


def test_rollout_with_python_controller_compiled_steps_match_numpy() -> None:
    model = ff.models.papadopoulos1992(arms=2)
    states, pd = batch_setup(model, 11)

    def controller(t: float, s: State) -> np.ndarray:  # not a JointPD: Python per sample, compiled steps
        return pd(t, s)

    ours = rollout(model, states, 0.01, dt=1e-3, controller=controller, sample_period=5e-3, backend="numba")
    ref = rollout(model, states, 0.01, dt=1e-3, controller=controller, sample_period=5e-3, backend="numpy")
    trajectories_close(ours, ref)
    compiled_pd = rollout(model, states, 0.01, dt=1e-3, controller=pd, sample_period=5e-3, backend="numba")
    trajectories_close(compiled_pd, ref)


def test_backend_option() -> None:
    model = ff.models.papadopoulos1992(arms=2)
    state = State(q=[0.1, 0.2, 0.3, 0.4])
    with pytest.raises(ValueError, match="backend"):
        simulate(model, state, 0.01, fixed_step=1e-3, backend="fortran")
    wrench = ff.ExternalWrench(body=1, force=[1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="external wrenches"):
        simulate(model, state, 0.002, fixed_step=1e-3, external=[wrench], backend="numba")
    assert not _compiled.use_compiled("auto", [wrench])  # auto falls back to numpy for external wrenches
    pushed = simulate(model, state, 0.002, fixed_step=1e-3, external=[wrench], backend="auto")
    free = simulate(model, state, 0.002, fixed_step=1e-3, backend="auto")
    assert not np.allclose(pushed.v_cm[-1], free.v_cm[-1])


def test_joint_pd_checks_its_inputs() -> None:
    with pytest.raises(ShapeError, match="feedforward"):
        JointPD(kp=1.0, kd=1.0, feedforward=[1.0, 2.0])
    with pytest.raises(ValueError, match="feedforward_period"):
        JointPD(kp=1.0, kd=1.0, feedforward=np.zeros((3, 2)))
    with pytest.raises(ValueError, match="kp"):
        JointPD(kp=np.nan, kd=1.0)
    pd = JointPD(kp=2.0, kd=0.5, q_ref=[1.0, 0.0], feedforward=[[1.0, 1.0], [3.0, 3.0]], feedforward_period=0.1)
    tau = pd(0.15, State(q=[0.5, 0.5], qdot=[1.0, -1.0]))
    np.testing.assert_allclose(tau, [3.0 + 1.0 - 0.5, 3.0 - 1.0 + 0.5])
