"""The engine (the O(N) recursions, compiled once for all models) against the barycentric closed forms.

Each public quantity has two algorithms, each written once: the engine (``method="recursive"``,
the default, every batch size) and the papers' barycentric forms (``method="barycentric"``,
numpy). Here they check each other on random trees and the paper systems, at batch sizes that
cross every internal threshold of the engine (one range below ``Batched.PARALLEL_MIN``, one range
per thread above, of unequal lengths for an odd batch); the simulations and rollouts on the engine are checked against an RK4
written here on the barycentric forward dynamics. tests/oracle checks both against Pinocchio and
MuJoCo.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import freefloat as ff
from freefloat.core.errors import ShapeError
from freefloat.core.state import Actuation, State
from freefloat.engine import drivers as _drivers
from freefloat.engine import stepper as _stepper
from freefloat.simulation.pd import JointPD
from freefloat.simulation.simulate import ActuatorLimits, rollout, simulate
from freefloat.simulation.trajectory import Trajectory
from spies import replace_everywhere
from trees import build_random_model, random_trees

RTOL = 1e-10
#: Batch sizes on both sides of every threshold of the drivers (one range / one per thread, ranges of unequal length).
SIZES = (1, 3, 65, _drivers.Batched.PARALLEL_MIN - 1, _drivers.Batched.PARALLEL_MIN, _drivers.Batched.PARALLEL_MIN + 7)

MODELS = {
    "papadopoulos1991": ff.models.papadopoulos1991,
    "papadopoulos1992": lambda: ff.models.papadopoulos1992(arms=2),
    "papadopoulos1992_payload": lambda: ff.models.papadopoulos1992(arms=2).with_payload(end_effector=0, mass=400.0, inertia=25.0),
    "spacecraft_7dof": ff.models.spacecraft_7dof,
    "random_tree": lambda: build_random_model(np.random.default_rng(7), [2], [0], [1]),  # a branch and a fixed joint
}


def assert_rel(ours: np.ndarray, ref: np.ndarray, rtol: float = RTOL) -> None:
    """Agreement to rtol relative to the largest entry of the reference (per leading row)."""
    ours, ref = np.asarray(ours), np.asarray(ref)
    assert ours.shape == ref.shape, (ours.shape, ref.shape)
    if ref.size == 0:
        return
    flat_ref = ref.reshape(ref.shape[0], -1) if ref.ndim > 1 else ref[None]
    flat_ours = ours.reshape(flat_ref.shape)
    scale = np.maximum(np.max(np.abs(flat_ref), axis=-1, keepdims=True), 1e-300)
    err = np.max(np.abs(flat_ours - flat_ref) / scale)
    assert err <= rtol, f"relative error {err:.2e} > {rtol:.0e}"


def random_inputs(model: ff.Model, rng: np.random.Generator, size: int) -> dict[str, np.ndarray]:
    n = model.n_joints
    return {
        "q": rng.uniform(-np.pi, np.pi, size=(size, n)),
        "v": rng.normal(size=(size, 6 + n)),
        "a": rng.normal(size=(size, 6 + n)),
        "tau": rng.normal(scale=5.0, size=(size, n)),
        "f": rng.normal(size=(size, 3)),
        "n": rng.normal(size=(size, 3)),
        "quat": Rotation.random(size, random_state=rng).as_quat(),
    }


def wrenches(model: ff.Model) -> list[ff.ExternalWrench]:
    last = model.n_bodies - 1
    return [
        ff.ExternalWrench(body=last, force=[1.0, -2.0, 0.5], torque=[0.1, 0.0, -0.3], point=[0.1, 0.05, 0.0], frame="body"),
        ff.ExternalWrench(body=0, force=[0.0, 3.0, 0.0], torque=[0.2, 0.0, 0.0], frame="inertial"),
        ff.ExternalWrench(body=min(1, last), force=[0.5, 0.5, 0.0], frame="spacecraft"),
    ]


def check_all(model: ff.Model, x: dict[str, np.ndarray]) -> None:
    """Every quantity with two algorithms: the engine against the barycentric closed form."""
    q, v, a = x["q"], x["v"], x["a"]
    check_kinematics(model, x)
    assert_rel(ff.nonlinear_forces(model, q, v)[:, 3:], ff.nonlinear_forces(model, q, v, method="barycentric")[:, 3:])
    ext = wrenches(model)
    args = (x["tau"], x["f"], x["n"], x["quat"])
    assert_rel(
        ff.forward_dynamics(model, q, v, *args, external=ext), ff.forward_dynamics(model, q, v, *args, external=ext, method="barycentric")
    )
    ours = ff.inverse_dynamics(model, q, v, a, x["quat"], external=ext)
    ref = ff.inverse_dynamics(model, q, v, a, x["quat"], external=ext, method="barycentric")
    for o, r in zip(ours, ref, strict=True):
        assert_rel(o, r, 1e-9)


@pytest.mark.parametrize("size", SIZES)
@pytest.mark.parametrize("name", sorted(MODELS))
def test_engine_matches_barycentric_forms_at_every_batch_size(name: str, size: int) -> None:
    model = MODELS[name]()
    check_all(model, random_inputs(model, np.random.default_rng(size), size))


def check_kinematics(model: ff.Model, x: dict[str, np.ndarray]) -> None:
    """The quantities whose barycentric forms cover prismatic joints (positions, J+, J*, H+)."""
    q = x["q"]
    assert_rel(ff.end_effector_positions(model, q), ff.end_effector_positions(model, q, method="barycentric"))
    assert_rel(ff.body_cm_positions(model, q), ff.body_cm_positions(model, q, method="barycentric"))
    last = model.n_bodies - 1
    assert_rel(ff.point_jacobian(model, q, last, [0.1, 0.2, 0.3]), ff.point_jacobian(model, q, last, [0.1, 0.2, 0.3], method="barycentric"))
    assert_rel(ff.generalized_jacobian(model, q), ff.generalized_jacobian(model, q, method="barycentric"))
    assert_rel(ff.system_inertia_matrix(model, q), ff.system_inertia_matrix(model, q, method="barycentric"))


@pytest.mark.parametrize("size", SIZES)
def test_engine_matches_barycentric_forms_with_prismatic_joints(size: int) -> None:
    model = build_random_model(np.random.default_rng(13), [3, 2], [1, None], [None, 0], prismatic=0.5)
    assert model.has_prismatic
    check_kinematics(model, random_inputs(model, np.random.default_rng(size), size))
    with pytest.raises(ff.ModelError, match="prismatic"):
        ff.nonlinear_forces(model, np.zeros(model.n_joints), np.zeros(6 + model.n_joints), method="barycentric")


@settings(max_examples=40, deadline=None)
@given(random_trees(), st.integers(0, 2**32 - 1), st.sampled_from((1, 300)))
def test_engine_matches_barycentric_forms_on_random_trees(model: ff.Model, seed: int, size: int) -> None:
    check_all(model, random_inputs(model, np.random.default_rng(seed), size))


def test_batch_shapes_and_broadcasting() -> None:
    model = ff.models.papadopoulos1992(arms=2)
    n = model.n_joints
    rng = np.random.default_rng(2)
    q = rng.uniform(-1, 1, size=(4, 70, n))
    jac = ff.generalized_jacobian(model, q)
    assert jac.shape == (4, 70, 6 * model.n_end_effectors, n)
    np.testing.assert_array_equal(jac[2, 5], ff.generalized_jacobian(model, q[2, 5]))
    v = rng.normal(size=6 + n)  # one velocity for the whole batch
    acc = ff.forward_dynamics(model, q, v)
    assert acc.shape == (4, 70, 6 + n)
    np.testing.assert_allclose(acc[3, 9], ff.forward_dynamics(model, q[3, 9], v), rtol=1e-13, atol=1e-13)
    assert ff.system_inertia_matrix(model, np.zeros((0, n))).shape == (0, 6 + n, 6 + n)


# ----------------------------------------------------------------- simulation on the engine vs an RK4 written here
def reference_rk4(model: ff.Model, x0: np.ndarray, u_of: object, dt: float, steps: int, hold: int, external: object = ()) -> np.ndarray:
    """Classical RK4 on ff.forward_dynamics(method="barycentric"), u sampled every ``hold`` steps: states (steps + 1, S)."""
    n = model.n_joints

    def deriv(x: np.ndarray, u: np.ndarray) -> np.ndarray:
        quat = x[6:10] / np.linalg.norm(x[6:10])
        w = x[10:13]
        vel = np.concatenate([x[3:6], w, x[13 + n :]])
        acc = ff.forward_dynamics(
            model, x[13 : 13 + n], vel, u[:n], u[n : n + 3], u[n + 3 :], quat, external=external, method="barycentric"
        )
        dq = 0.5 * np.concatenate([quat[3] * w + np.cross(quat[:3], w), [-quat[:3] @ w]])
        return np.concatenate([x[3:6], acc[:3], dq, acc[3:6], x[13 + n :], acc[6:]])

    out = [x0.copy()]
    x = x0.copy()
    u = u_of(0.0, x)  # type: ignore[operator]
    for i in range(1, steps + 1):
        k1 = deriv(x, u)
        k2 = deriv(x + 0.5 * dt * k1, u)
        k3 = deriv(x + 0.5 * dt * k2, u)
        k4 = deriv(x + dt * k3, u)
        x = x + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        x[6:10] /= np.linalg.norm(x[6:10])
        out.append(x.copy())
        if i % hold == 0:
            u = u_of(i * dt, x)  # type: ignore[operator]
    return np.array(out)


def trajectories_close(a: Trajectory, b: Trajectory, atol: float = 1e-9) -> None:
    np.testing.assert_array_equal(a.t, b.t)
    for field in ("q", "qdot", "omega", "attitude", "r_cm", "v_cm", "joint_torque", "spacecraft_force", "spacecraft_torque"):
        np.testing.assert_allclose(getattr(a, field), getattr(b, field), rtol=0, atol=atol, err_msg=field)
    np.testing.assert_array_equal(a.saturated, b.saturated)


def flat(model: ff.Model, state: State) -> np.ndarray:
    from freefloat.core.state import pack_state

    return pack_state(state.resolve(model))


@pytest.mark.parametrize("name", ["papadopoulos1992", "spacecraft_7dof"])
def test_simulation_with_python_controller_and_wrenches_matches_reference_rk4(name: str) -> None:
    model = MODELS[name]()
    n = model.n_joints
    state = State(q=np.linspace(0.1, 0.4, n), qdot=np.linspace(0.1, -0.1, n), omega=[0.0, 0.0, 0.02], v_cm=[0.01, 0.0, 0.0])
    pd = JointPD(kp=np.linspace(2.0, 4.0, n), kd=np.linspace(0.8, 0.4, n), q_ref=np.full(n, 0.4), qdot_ref=0.1)  # stable at 1 ms
    ext = wrenches(model)

    def controller(t: float, s: State) -> Actuation:  # joint PD plus thrusters, so every input is exercised
        return Actuation(joint_torque=pd(t, s), spacecraft_force=[1.0, -2.0, 0.5], spacecraft_torque=[0.0, 0.3, -1.0])

    ours = simulate(model, state, 0.04, controller, fixed_step=1e-3, sample_period=2e-3, output_period=1e-3, external=ext)

    def u_of(t: float, x: np.ndarray) -> np.ndarray:
        act = controller(t, State(q=x[13 : 13 + n], qdot=x[13 + n :]))
        return np.concatenate([act.joint_torque, act.spacecraft_force, act.spacecraft_torque])

    ref = reference_rk4(model, flat(model, state), u_of, 1e-3, 40, 2, ext)
    np.testing.assert_allclose(ours.q, ref[:, 13 : 13 + n], rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(ours.qdot, ref[:, 13 + n :], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(ours.attitude, ref[:, 6:10], rtol=0, atol=1e-12)
    np.testing.assert_allclose(ours.v_cm, ref[:, 3:6], rtol=0, atol=1e-12)


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


@pytest.mark.parametrize("batch", [1, 3])
def test_compiled_rollout_matches_single_simulations(batch: int) -> None:
    model = ff.models.papadopoulos1992(arms=2)
    states, pd = batch_setup(model, batch)
    limits = ActuatorLimits(joint_torque=[6.0, 6.0, 9.0, 9.0])
    ours = rollout(model, states, 0.04, dt=1e-3, controller=pd, sample_period=5e-3, output_period=1e-2, limits=limits)
    assert ours.q.shape == (5, batch, model.n_joints)
    for b in range(batch):
        one = State(q=states.q[b], qdot=states.qdot[b], omega=[0.0, 0.0, 0.01])
        pd_b = JointPD(kp=pd.kp[b], kd=pd.kd[b], q_ref=0.3, feedforward=pd.feedforward[:, b], feedforward_period=5e-3)
        ref = simulate(model, one, 0.04, pd_b, fixed_step=1e-3, sample_period=5e-3, output_period=1e-2, limits=limits)
        for field in ("q", "qdot", "omega", "attitude", "r_cm", "v_cm", "joint_torque"):
            np.testing.assert_allclose(getattr(ours, field)[:, b], getattr(ref, field), rtol=0, atol=1e-9, err_msg=field)
        np.testing.assert_array_equal(ours.saturated[:, b], ref.saturated)
    assert ours.saturated.any()


def test_rollout_with_prismatic_joints_matches_single_simulations() -> None:
    """A tree with sliding joints: the compiled rollout equals simulate() trajectory by trajectory."""
    model = build_random_model(np.random.default_rng(13), [3, 2], [1, None], [None, 0], prismatic=0.5)
    n = model.n_joints
    rng = np.random.default_rng(2)
    q0 = rng.uniform(-0.3, 0.3, (4, n))
    states = State(q=q0, qdot=rng.uniform(-0.1, 0.1, (4, n)))
    pd = JointPD(kp=20.0, kd=5.0, q_ref=0.2)
    ours = rollout(model, states, 0.05, dt=1e-3, controller=pd, output_period=1e-2)
    for b in range(4):
        ref = simulate(model, State(q=states.q[b], qdot=states.qdot[b]), 0.05, pd, fixed_step=1e-3, output_period=1e-2)
        for field in ("q", "qdot", "omega", "attitude", "r_cm", "v_cm"):
            np.testing.assert_allclose(getattr(ours, field)[:, b], getattr(ref, field), rtol=0, atol=1e-9, err_msg=field)
    assert np.abs(ours.q[-1] - ours.q[0]).max() > 1e-3, "the joints should move"


def test_rollout_with_python_controller_matches_compiled_pd_and_reference() -> None:
    model = ff.models.papadopoulos1992(arms=2)
    n = model.n_joints
    states, pd = batch_setup(model, 11)

    def controller(t: float, s: State) -> np.ndarray:  # not a JointPD: Python per sample, compiled steps
        return pd(t, s)

    ours = rollout(model, states, 0.01, dt=1e-3, controller=controller, sample_period=5e-3)
    compiled_pd = rollout(model, states, 0.01, dt=1e-3, controller=pd, sample_period=5e-3)
    trajectories_close(compiled_pd, ours)
    x0 = flat(model, State(q=states.q[4], qdot=states.qdot[4], omega=[0.0, 0.0, 0.01]))
    pd_4 = JointPD(kp=pd.kp[4], kd=pd.kd[4], q_ref=0.3, feedforward=pd.feedforward[:, 4], feedforward_period=5e-3)

    def u_of(t: float, x: np.ndarray) -> np.ndarray:
        return np.concatenate([pd_4(t, State(q=x[13 : 13 + n], qdot=x[13 + n :])), np.zeros(6)])

    ref = reference_rk4(model, x0, u_of, 1e-3, 10, 5)
    np.testing.assert_allclose(ours.q[:, 4], ref[:, 13 : 13 + n], rtol=0, atol=1e-10)


def test_rollout_failure_names_the_trajectory_and_keeps_the_others() -> None:
    model = ff.models.papadopoulos1992(arms=2)
    n = model.n_joints
    states = State(q=np.zeros((3, n)), qdot=np.zeros((3, n)))
    kp = np.array([[1.0] * n, [1e12] * n, [1.0] * n])  # trajectory 1 blows up
    with pytest.raises(ff.SimulationError, match="trajectory 1") as info:
        rollout(model, states, 0.5, dt=0.01, controller=JointPD(kp=kp, kd=0.0, q_ref=1.0))
    traj = info.value.trajectory
    assert traj is not None and np.isfinite(traj.q[:, 0]).all() and np.isnan(traj.q[-1, 1]).all()


def test_a_feed_forward_is_read_in_place_in_any_layout() -> None:
    """_engine.feed: the joint PD's feed-forward (S, K, W) as the compiled rollouts read it (values at sample * sample
    stride + trajectory * trajectory stride + j): in place for the layouts users pass (C, per-trajectory series swapped
    from (K, S, W), one series shared by every trajectory, a chunk of the trajectories), a copy for the others; read-only
    always (one compiled signature)."""
    from freefloat.engine import calls as _engine

    per = np.random.default_rng(0).normal(size=(5, 7, 3))  # (K, S, W)
    swapped = per.swapaxes(0, 1)
    cases = {
        "C": (np.ascontiguousarray(swapped), True),
        "swapped": (swapped, True),
        "shared": (np.broadcast_to(per[0][:, None, :], (7, 5, 3)), True),
        "chunk": (swapped[:, 1:4], True),
        "one sample": (swapped[:1], True),
        "reversed": (swapped[::-1], False),
        "every other value": (np.ascontiguousarray(swapped.repeat(2, axis=2))[:, :, ::2], False),
        "misaligned": (np.frombuffer(bytearray(7 * 5 * 3 * 8 + 1), dtype=np.float64, offset=1).reshape(7, 5, 3), False),
    }
    for name, (ff_, in_place) in cases.items():
        flat, samples, sample_stride, trajectory_stride, width = _engine.feed(ff_)
        assert flat.ndim == 1 and flat.dtype == np.float64 and not flat.flags.writeable and flat.flags.aligned, name
        assert np.shares_memory(flat, ff_) == in_place, name
        if in_place:  # the view stays within the array's memory
            low, high = np.lib.array_utils.byte_bounds(ff_)
            assert low <= flat.ctypes.data and flat.ctypes.data + flat.nbytes <= high, name
        assert (samples, width) == (ff_.shape[0], ff_.shape[2]), name
        for k in range(samples):
            for b in range(ff_.shape[1]):
                at = k * sample_stride + b * trajectory_stride
                np.testing.assert_array_equal(flat[at : at + width], ff_[k, b], err_msg=name)
    for empty in (np.zeros((0, 5, 3)), np.zeros((7, 0, 3))):  # no samples, no trajectories: nothing is read
        flat, samples, _, _, width = _engine.feed(empty)
        assert flat.size == 0 and width == 0 and samples == 1 and not flat.flags.writeable
    with pytest.raises(ShapeError, match="K >= 1"):
        ff.JointPD(kp=1.0, kd=1.0, feedforward=np.zeros((0, 4)))


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


def test_scratch_buffers_are_always_kernel_arguments() -> None:
    """scratch() and arrays() make views without reference counting: their buffers must be arguments of the calling
    kernel (or slices of one), never arrays made inside it (numba frees those after their last use). The drivers
    call them in one template (and the stepper in unpack), so every driver is covered by these two sites."""
    import ast
    from pathlib import Path

    folder = Path(ff.__file__).parent / "engine"
    sites = []
    for name in ("drivers.py", "stepper.py", "quantities.py", "laws.py"):
        tree = ast.parse((folder / name).read_text(encoding="utf-8"))
        for func in (n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)):
            params = {a.arg for a in func.args.args}
            params |= {  # names unpacked from the call's arrays: X0, ..., PLANT, ... = a (kernel arguments too)
                e.id
                for n in ast.walk(func)
                if isinstance(n, ast.Assign) and isinstance(n.value, ast.Name) and n.value.id in params
                for t in n.targets
                if isinstance(t, ast.Tuple)
                for e in t.elts
                if isinstance(e, ast.Name)
            }
            sliced = {  # names assigned from a subscript or a view of a parameter: work = floats_view(floats, f, ...)
                t.id
                for n in ast.walk(func)
                if isinstance(n, ast.Assign)
                and (
                    (isinstance(n.value, ast.Subscript) and isinstance(n.value.value, ast.Name) and n.value.value.id in params)
                    or (
                        isinstance(n.value, ast.Call)
                        and getattr(n.value.func, "id", None) in ("floats_view", "ints_view")
                        and isinstance(n.value.args[0], ast.Name)
                        and n.value.args[0].id in params
                    )
                )
                for t in n.targets
                if isinstance(t, ast.Name)
            }
            for call in (n for n in ast.walk(func) if isinstance(n, ast.Call) and getattr(n.func, "id", None) in ("scratch", "arrays")):
                sites.append(f"{name}::{func.name}::{call.func.id}")  # type: ignore[attr-defined]
                buffers = call.args[:1] if call.func.id == "scratch" else call.args  # type: ignore[attr-defined]
                for arg in buffers:
                    base = arg.value if isinstance(arg, ast.Subscript) else arg  # a row of an argument: PLANT[b]
                    base = base.value if isinstance(base, ast.Attribute) else base  # a field of one: L.floats
                    ok = isinstance(base, ast.Name) and base.id in params | sliced
                    assert ok, f"{name}::{func.name}: {ast.unparse(call)}"
    assert sorted(sites) == [
        "drivers.py::_law_rollout_row::arrays",  # the plant's mass properties per trajectory
        "drivers.py::_serial_template::arrays",
        "drivers.py::_serial_template::scratch",
        "laws.py::law_one::arrays",  # the controller's model (per trajectory)
        "stepper.py::unpack::arrays",
        "stepper.py::unpack::scratch",
    ]


def stepper_and_state() -> tuple[object, np.ndarray]:
    from freefloat.engine import calls as _engine

    model = ff.models.papadopoulos1992(arms=2)
    return _engine.Stepper(model), flat(model, State(q=np.linspace(0.3, -0.2, model.n_joints), omega=[0.01, 0.0, 0.02]))


@pytest.mark.parametrize("entry", [0, 3, -4, -1], ids=["torque-0", "torque-3", "force-z", "torque-z"])
@pytest.mark.parametrize("value", [np.nan, np.inf, -2e19], ids=["nan", "inf", "minus-2e19"])
def test_the_stepper_refuses_a_bad_actuation_before_any_step(entry: int, value: float) -> None:
    """Stepper.rk4 checks u before it steps: an entry not finite or beyond MAX_EFFORT returns 0 with the reason
    REFUSED and leaves x as it was, bit for bit; the same call with a good u steps."""
    stepper, x0 = stepper_and_state()
    n = stepper.tree.n_joints  # type: ignore[attr-defined]
    u = np.zeros(n + 6)
    u[entry] = value
    x = x0.copy()
    assert stepper.rk4(x, u, 1e-3, 5) == 0  # type: ignore[attr-defined]
    assert stepper.reason == stepper.REFUSED  # type: ignore[attr-defined]
    np.testing.assert_array_equal(x, x0)
    u[entry] = 1e19  # MAX_EFFORT itself passes
    assert stepper.rk4(x, u, 1e-6, 1) == 1 and stepper.reason == 0  # type: ignore[attr-defined]
    assert not np.array_equal(x, x0)


@pytest.mark.parametrize("short", ["model ints", "model floats", "work", "no bodies", "negative wrenches", "no header"])
def test_kernel_views_of_a_short_buffer_raise_before_any_read(short: str) -> None:
    """The model's and the scratch views neither count references nor check bounds (_numba_cache.floats_view): the
    kernel that makes them checks each buffer's length once, and a short one raises instead of reading past its end."""
    from freefloat.engine import cache as _numba_cache

    stepper, x0 = stepper_and_state()
    ints, floats = stepper.ints.copy(), stepper.floats.copy()  # type: ignore[attr-defined]
    tree = stepper.tree  # type: ignore[attr-defined]
    if short == "model ints":  # the header says more bodies than the buffer holds
        ints[0] += 5
    elif short == "model floats":
        floats = floats[: tree.floats.size - 1]
    elif short == "work":
        floats = floats[:-1]
    elif short == "no bodies":
        ints[0] = 0
    elif short == "negative wrenches":  # the stepper's count of external wrenches, after the model's ints
        ints[tree.ints.size] = -1
    else:
        ints = ints[:2]
    x, u = x0.copy(), np.zeros(tree.n_joints + 6)
    with pytest.raises(ValueError, match=r"shorter than|no valid header"):
        _stepper.rk4_steps(ints, floats, x, u, 1e-3, 1)
    np.testing.assert_array_equal(x, x0)
    buffer = np.arange(10.0)  # the traced twin of the views: a checked slice
    np.testing.assert_array_equal(_numba_cache.slice_view(buffer, 4, (2, 3)), buffer[4:].reshape(2, 3))
    with pytest.raises(ValueError, match="runs past a buffer of 10"):
        _numba_cache.slice_view(buffer, 5, (2, 3))


def test_rollout_shows_progress_and_ctrl_c_keeps_the_finished_trajectories(monkeypatch: pytest.MonkeyPatch) -> None:
    """A compiled rollout that reports progress (asked for, or a long run) runs in chunks of trajectories:
    progress after each, Ctrl-C returns the finished ones. A short one without a callback is one call."""
    import freefloat.engine as engine  # the door: the calls the rest of freefloat makes

    model = ff.models.papadopoulos1992(arms=2)
    states, _ = batch_setup(model, 300)
    pd = JointPD(kp=20.0, kd=5.0, q_ref=0.3)  # compiled in the loop
    seen: list[float] = []
    whole = rollout(model, states, 0.02, dt=1e-3, controller=pd, progress=lambda t, d: seen.append(t / d))
    assert whole.status == "finished" and whole.q.shape[1] == 300
    assert len(seen) >= 3 and seen == sorted(seen) and seen[-1] == pytest.approx(1.0)
    real, calls = engine.rollout, []

    def interrupted_second_chunk(*args: object, **kwargs: object) -> object:
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    replace_everywhere(monkeypatch, real, interrupted_second_chunk)  # the door and the engine's own calls (rk4_batch)
    part = rollout(model, states, 0.02, dt=1e-3, controller=pd, progress=lambda t, d: None)  # chunked: progress asked
    assert part.status == "interrupted" and "of 300 trajectories" in part.message
    k = part.q.shape[1]
    assert 0 < k < 300
    np.testing.assert_array_equal(part.q, whole.q[:, :k])  # the finished trajectories are the same
    # a controller in Python (here the feed-forward of batch_setup): every trajectory up to the last step done
    calls.clear()
    stepped = rollout(model, states, 0.02, dt=1e-3, controller=batch_setup(model, 300)[1], progress=False)
    assert stepped.status == "interrupted" and stepped.t[-1] == pytest.approx(0.002) and stepped.q.shape[1] == 300


@pytest.mark.parametrize("seed", [3, 4, 5])
def test_the_generated_views_are_the_declared_blocks(seed: int) -> None:
    """The kernels' views are written from the declarations in engine/layout.py (BODY_FIELDS, INT_BLOCKS, FLOAT_BLOCKS,
    SCRATCH): on random trees (mimic and prismatic joints, several end effectors), every view of arrays() (compiled and
    traced) holds what its block reads from the model, and every scratch view of scratch() (compiled and traced) starts
    where the declaration puts it, with its declared shape."""
    from freefloat.engine import layout as _layout
    from freefloat.engine.specialise import trace as _trace

    model = build_random_model(np.random.default_rng(seed), [3, 2], [0, None], [1, None], prismatic=0.5, mimic=0.4)
    t = _layout.tree(model)
    sizes = {"B": model.n_bodies, "E": t.ee_body.shape[0]}
    for m in (_trace.traced().configuration.arrays(t.ints, t.floats), _layout.arrays(t.ints, t.floats)):
        for f in _layout.BODY_FIELDS:
            np.testing.assert_array_equal(getattr(m, f.name), t.fields[f.name])
            assert getattr(m, f.name).shape == (model.n_bodies, *f.shape)
            for k in range(model.n_bodies):
                np.testing.assert_array_equal(getattr(m, f.name)[k], np.reshape(f.read(model, k), f.shape))
        for b in (*_layout.INT_BLOCKS, *_layout.FLOAT_BLOCKS):
            shape = tuple(sizes.get(d, d) if isinstance(d, str) else d for d in b.shape)
            np.testing.assert_array_equal(getattr(m, b.name), np.reshape(b.read(model), shape))
        assert m.n_joints == model.n_joints
    assert _trace.traced().configuration.buffer_lengths(t.ints) == (t.ints.size, t.floats.size) == _layout.buffer_lengths(t.ints)
    sizes = _layout.scratch_sizes(model.n_bodies, t.ee_body.shape[0], model.n_joints)
    work = np.arange(float(_layout.work_size(model.n_bodies, t.ee_body.shape[0])))
    for s in (
        _trace.traced().configuration.scratch(work, model.n_bodies, t.ee_body.shape[0], model.n_joints),
        _layout.scratch(work, model.n_bodies, t.ee_body.shape[0], model.n_joints),
    ):
        offset = 0
        for row in _layout.SCRATCH:
            view = getattr(s, row.name)
            assert view.shape == _layout.row_shape(row, sizes), row.name
            np.testing.assert_array_equal(view.ravel(), np.arange(offset, offset + view.size), err_msg=row.name)
            offset += view.size
    assert not set(_layout.SCRATCH_SIZES) & {r.name for r in _layout.SCRATCH}  # the sizes and the rows are apart


def test_the_specialiser_traces_the_engine_kernels_themselves() -> None:
    """The specialiser's interface to the engine (engine/specialise/trace.py: ENTRY_POINTS, traced()): the traced functions
    run the compiled kernels' own code (no copy of the source, no file read by path)."""
    from freefloat.engine import layout as _layout
    from freefloat.engine import quantities as _configuration
    from freefloat.engine import recursions as _recursions
    from freefloat.engine.specialise import trace as _trace

    space = _trace.traced().configuration
    for name in (*_trace.ENTRY_POINTS.values(), "prepare", "newton_euler", "scratch", "arrays"):
        kernel = getattr(_configuration, name, None) or getattr(_recursions, name, None) or getattr(_layout, name)
        assert getattr(space, name).__code__ is kernel.py_func.__code__
