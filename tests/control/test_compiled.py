"""The built-in controllers inside the compiled loops equal their Python versions step for step (issue 23).

``ff.simulate`` / ``ff.rollout`` run a built-in controller (its ``compiled_law``: the numba kernel of
engine/laws.py) inside the compiled RK4 loop; wrapped in a plain function the same controller runs from Python
every sample in its numpy form (controllers.py, detumble.py: the readable reference of the law; on a batch of states,
row by row). Both must record the same states and actuation to 1e-12 at every step, with limits, sample-and-hold,
per-trajectory gains, set points and payload models; a gain moved by 1e-7 must break that bound (the comparison can
fail). Spies (tests/spies.py) show each side took its path: the compiled run ran the named law in the engine's loop and
never called the controller's Python form; the Python run called it every sample and ran no compiled law. Small
models and a few dozen steps: the kernels are compiled once per machine (engine/cache.py).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import freefloat as ff
from freefloat.control import Detumble, OperationalSpaceController, TransposedJacobianController
from freefloat.control.desired import StraightLine
from freefloat.control.tasks import TaskSpace
from freefloat.core.errors import ShapeError
from freefloat.papers.paper1991 import section5_setup
from spies import Paths

BOUND = 1e-12
STATES = ("q", "qdot", "omega", "attitude", "r_cm", "v_cm")
#: The payload variants' bound on the actuation (their states are held to BOUND: they agree to 4e-15): the operational-
#: space law in closed loop is sensitive to the two forms' different operation orders, and its torques (up to 1.7e4
#: N m on the 200 kg payload) differ by 3.2e-12 of 1 + |value| at step 5 (6.4e-13 while the engine divided by the
#: total mass and the Cholesky pivots, before it multiplied by their reciprocals); a gain moved by 1e-7 moves them by
#: 1e-7.
PAYLOAD_BOUND = 1e-11
#: The spatial OSC's actuation on the 7-DOF arm (its states are held to BOUND: they agree to 4e-15): its task-space
#: inertia is ill-conditioned (the tool's roll inertia is 2.5e-3 kg m^2), so the two forms' operation orders give thruster
#: forces that differ by 2.0e-10 of 1 + |value| (quaternion orientations; 8.6e-12 Euler angles), measured 2026-12-01;
#: a gain moved by 1e-7 moves them by 5e-8.
SPATIAL_ACTUATION_BOUND = 1e-9
DT = 0.01
FIELDS = ("q", "qdot", "omega", "attitude", "r_cm", "v_cm", "joint_torque", "spacecraft_force", "spacecraft_torque")


def python(controller: Any) -> Any:
    """The controller as a plain Python function: the simulation loops call it every sample."""
    return lambda t, state: controller(t, state)


def gap(a: ff.Trajectory, b: ff.Trajectory, row: int | None = None, fields: tuple[str, ...] = FIELDS) -> float:
    """The largest difference of the recorded states and actuation (every field of ``fields``, every output), relative
    to 1 + |value|; ``row``: trajectory ``row`` of the rollout ``a`` against the single run ``b``."""
    assert np.array_equal(a.t, b.t)

    def of(traj: ff.Trajectory, name: str, r: int | None) -> np.ndarray:
        return np.asarray(getattr(traj, name)) if r is None else np.asarray(getattr(traj, name))[:, r]

    assert np.array_equal(of(a, "saturated", row), b.saturated)
    return max(float(np.max(np.abs(of(a, f, row) - of(b, f, None)) / (1.0 + np.abs(of(b, f, None))))) for f in fields)


@pytest.fixture
def paths(monkeypatch: pytest.MonkeyPatch) -> Paths:
    return Paths(monkeypatch)


def law_name(controller: Any) -> str:
    return {
        TransposedJacobianController: "transposed_jacobian",
        OperationalSpaceController: "operational_space",
        Detumble: "detumble",
        ff.JointPD: "joint_pd",
    }[type(controller)]


@pytest.fixture(scope="module")
def section5() -> tuple[ff.Model, TaskSpace, ff.State, np.ndarray]:
    return section5_setup()


def test_single_simulations_equal_the_python_loop(section5: Any, paths: Paths) -> None:
    """TJ (eq. 29, with the controller's limits and the simulation's), OSC (eq. 27, sampled every 3 steps), a straight
    line, the detumbling and a joint PD: compiled single simulations equal the Python loop to 1e-12 at every step."""
    model, task, state, target = section5
    start = task.coordinates(state)
    limits = ff.ActuatorLimits(joint_torque=60.0, spacecraft_force=40.0)
    spinning = ff.State(q=state.q, qdot=[0.3, -0.2], omega=[0.0, 0.0, 0.2], attitude=state.attitude, v_cm=[0.05, 0.0, 0.0])
    runs = [
        (TransposedJacobianController(model, task, target, 30.0, 60.0, limits=ff.ActuatorLimits(joint_torque=50.0)), {"limits": limits}),
        (OperationalSpaceController(model, task, target, [30, 30, 20, 30, 30], 60.0), {"sample_period": 3 * DT}),
        (OperationalSpaceController(model, task, StraightLine(start, target, 0.3, "minimum_jerk", task=task), 30.0, 60.0), {}),
        (Detumble(model, rate_gain=[0.5, 0.5, 0.5, 0.6, 0.6, 0.7, 0.8, 0.9], attitude=Rotation.from_euler("z", 0.3)), {}),
        (ff.JointPD(kp=[40.0, 20.0], kd=[9.0, 5.0], q_ref=[0.2, -0.4]), {"limits": ff.ActuatorLimits(joint_torque=8.0)}),
    ]
    for controller, options in runs:
        start_state = spinning if isinstance(controller, Detumble) else state
        fast = paths.compiled(
            law_name(controller), ff.simulate, model, start_state, 0.4, controller, fixed_step=DT, output_period=DT, **options
        )
        slow = paths.python(ff.simulate, model, start_state, 0.4, python(controller), fixed_step=DT, output_period=DT, **options)
        assert len(fast) == 41
        assert gap(fast, slow) <= BOUND, type(controller).__name__
    assert fast.saturated.any()  # the joint PD's limit acted, recorded alike


@pytest.mark.parametrize("orientation", ["euler321", "quaternion"])
def test_spatial_tasks_equal_the_python_loop(orientation: str, paths: Paths) -> None:
    """Spatial tasks (eq. 22: end-effector and spacecraft positions and orientations) on a 3D arm, both laws."""
    model = ff.models.load_model("spacecraft_7dof")
    task = TaskSpace.paper1991(model, orientation=orientation)
    q = np.array([0.3, -0.5, 0.4, -0.7, 0.2, 0.6, -0.3])
    state = ff.State(q=q, qdot=np.full(model.n_joints, 0.05), omega=[0.01, -0.02, 0.03]).resolve(model)
    goal = task.coordinates(ff.State(q=q + 0.05))  # a nearby posture: reachable, away from the Euler singularity
    dt = 1e-3  # the tool's roll inertia is 2.5e-3 kg m^2: scalar gains need short steps (docs/control.md)
    for law in (TransposedJacobianController, OperationalSpaceController):
        controller = law(model, task, goal, 2.0, 0.1, null_space_damping=0.05)
        # the arm's joint limits as flags: hard stops ("stop", the default) run in the Python loop only
        options = {"fixed_step": dt, "output_period": dt, "joint_limits": "flag"}
        fast = paths.compiled(law_name(controller), ff.simulate, model, state, 0.02, controller, **options)
        slow = paths.python(ff.simulate, model, state, 0.02, python(controller), **options)
        assert not fast.joint_limits_violated and not slow.joint_limits_violated
        assert len(fast) == 21
        assert gap(fast, slow, fields=STATES) <= BOUND
        assert gap(fast, slow) <= (BOUND if law is TransposedJacobianController else SPATIAL_ACTUATION_BOUND)
        moved = law(model, task, goal, 2.0 * (1.0 + 1e-7), 0.1, null_space_damping=0.05)
        assert gap(ff.simulate(model, state, 0.02, moved, **options), slow, fields=STATES) > BOUND


def test_rollouts_with_per_trajectory_parameters_equal_python(section5: Any, paths: Paths) -> None:
    """A rollout of 4 with per-trajectory gains (B, d) and set points (B, size): the compiled loop equals the Python
    loop over the batch (the controller's __call__ takes the batch, row b its parameters) at every step, and row b
    equals a single simulation with the numpy form of the law and the parameters of b; a gain moved by 1e-7 breaks the
    bound."""
    model, task, state, target = section5
    batch = 4
    states = ff.State(q=np.tile(state.q, (batch, 1)) + np.linspace(0, 0.1, batch)[:, None], attitude=np.tile(state.attitude, (batch, 1)))
    kp = np.outer(np.linspace(20.0, 35.0, batch), np.ones(task.dim))
    targets = np.tile(target, (batch, 1))
    targets[:, 3] += np.linspace(-0.1, 0.1, batch)
    for law in (TransposedJacobianController, OperationalSpaceController):
        controller = law(model, task, targets, kp, 60.0)
        fast = paths.compiled(law_name(controller), ff.rollout, model, states, 0.2, dt=DT, controller=controller, sample_period=2 * DT)
        slow = paths.python(ff.rollout, model, states, 0.2, dt=DT, controller=python(controller), sample_period=2 * DT)
        assert fast.q.shape == (21, batch, 2)
        assert gap(fast, slow) <= BOUND
        moved = law(model, task, targets, kp * (1.0 + 1e-7), 60.0)
        assert gap(ff.rollout(model, states, 0.2, dt=DT, controller=moved, sample_period=2 * DT), slow) > BOUND
        for b in (0, batch - 1):  # row b against the numpy form of the law with the parameters of b, one simulation
            own = law(model, task, targets[b], kp[b], 60.0)
            start = ff.State(q=states.q[b], attitude=states.attitude[b])
            single = paths.python(ff.simulate, model, start, 0.2, python(own), fixed_step=DT, output_period=DT, sample_period=2 * DT)
            assert gap(fast, single, b) <= BOUND
    assert np.ptp(fast.q[-1, :, 0]) > 1e-3  # the trajectories differ: each took its own parameters


def test_payload_models_per_trajectory_equal_single_python_runs(section5: Any, paths: Paths) -> None:
    """Payload variants per trajectory (plant and controller models, detumbling rate gains (B, 1)): trajectory b of the
    compiled rollout equals a Python simulation of model b with the parameters of b, at every step."""
    model, _, state, target = section5
    models = [model.with_payload(mass=m, inertia=i) for m, i in ((50.0, 5.0), (200.0, 20.0), (400.0, 25.0))]
    spinning = ff.State(q=state.q, qdot=[0.3, -0.2], omega=[0.0, 0.0, 0.2], attitude=state.attitude)
    states = ff.State(q=np.tile(state.q, (3, 1)), qdot=np.tile([0.3, -0.2], (3, 1)), omega=[0.0, 0.0, 0.2], attitude=state.attitude)
    gains = np.array([[0.4], [0.6], [0.8]])
    controllers = [
        (OperationalSpaceController(models, TaskSpace.planar_1991(models[0]), target, 30.0, 60.0), None),
        (Detumble(models, rate_gain=gains), gains),
    ]
    for controller, rate in controllers:
        fast = paths.compiled(law_name(controller), ff.rollout, models, states, 0.2, dt=DT, controller=controller)
        for b, m in enumerate(models):
            if rate is None:
                own: Any = OperationalSpaceController(m, TaskSpace.planar_1991(m), target, 30.0, 60.0)
                start = spinning
            else:
                own, start = Detumble(m, rate_gain=float(rate[b, 0])), spinning
            slow = paths.python(ff.simulate, m, start, 0.2, python(own), fixed_step=DT, output_period=DT)
            assert gap(fast, slow, b, STATES) <= BOUND
            assert gap(fast, slow, b) <= PAYLOAD_BOUND
    assert np.ptp(fast.omega[-1, :, 2]) > 1e-4  # the payloads (and gains) made the trajectories differ


def test_bad_per_trajectory_inputs_are_named(section5: Any) -> None:
    model, task, state, target = section5
    states = ff.State(q=np.tile(state.q, (4, 1)), attitude=state.attitude)
    controller = TransposedJacobianController(model, task, target, np.full((3, task.dim), 30.0), 60.0)
    with pytest.raises(ShapeError, match=r"kp: 3 per-trajectory values, but the rollout has 4 trajectories"):
        ff.rollout(model, states, 0.1, dt=DT, controller=controller)
    with pytest.raises(ShapeError, match=r"kp: 3 per-trajectory values, but a single simulation has one trajectory"):
        ff.simulate(model, state, 0.1, controller, fixed_step=DT)
    with pytest.raises(ShapeError, match=r"model: 2 per-trajectory models, but initial_states has 4 trajectories"):
        ff.rollout([model, model.with_payload(mass=10.0, inertia=1.0)], states, 0.1, dt=DT, controller=ff.JointPD(kp=1.0, kd=1.0))
    with pytest.raises(ShapeError, match=r"rate_gain: expected a scalar or \(8,\)"):
        Detumble(model, rate_gain=np.ones((3, 5)))
    with pytest.raises(ValueError, match=r"model\[1\]: .* has another structure than model\[0\]"):
        ff.rollout([model, ff.models.papadopoulos1992()], states, 0.1, dt=DT, controller=ff.JointPD(kp=1.0, kd=1.0))
    with pytest.raises(ValueError, match=r"per-trajectory models run with the compiled controllers only"):
        ff.rollout([model] * 4, states, 0.1, dt=DT, controller=python(ff.JointPD(kp=1.0, kd=1.0)))


def test_a_compiled_run_through_a_singular_configuration_warns_once_after_it(section5: Any) -> None:
    """The OSC through q2 = 0 (J_z singular) inside the compiled loop: it finishes, finite, with the near-singular warning
    once, after the run (the loop records the smallest σ_min/σ_max), and records what the numpy form does."""
    model, task, _, target = section5
    start = ff.State(q=[0.3, 1e-4], qdot=[0.0, -1.0], attitude=Rotation.from_euler("z", 0.2).as_quat()).resolve(model)
    with pytest.warns(ff.NearSingularWarning) as seen:
        fast = ff.simulate(model, start, 0.2, OperationalSpaceController(model, task, target, 30.0, 60.0), fixed_step=0.005)
    assert len([w for w in seen if issubclass(w.category, ff.NearSingularWarning)]) == 1
    assert fast.status == "finished" and np.all(np.isfinite(fast.q))
    with pytest.warns(ff.NearSingularWarning):
        slow = ff.simulate(model, start, 0.2, python(OperationalSpaceController(model, task, target, 30.0, 60.0)), fixed_step=0.005)
    assert np.array_equal(fast.t, slow.t)
    assert np.abs(fast.q - slow.q).max() <= 1e-9
