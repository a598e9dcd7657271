"""The detumbling law (:class:`freefloat.control.Detumble`) against its closed forms, on the compiled path and the Python
path (the spies of tests/spies.py show which ran).

- ``attitude=`` with the default gain k²/4: about one axis the exact model closes the loop to θ̈ = -k θ̇ - (k²/4) θ,
  critically damped: θ(t) = θ0 (1 + k t/2) exp(-k t/2), ω(t) = -θ0 (k²/4) t exp(-k t/2); never an overshoot.
  The law is sampled once per RK4 step and held, so the run approaches the closed form to first order in the step.
- ``force=False``: no thruster force at any sample; the CM keeps its velocity exactly; ω0 and q̇ still decay.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import freefloat as ff
from freefloat.control import Detumble
from freefloat.papers.paper1991 import section5_setup
from spies import compiled_runs

K, THETA0, DT, DURATION = 2.0, 0.3, 1e-3, 4.0
#: |θ - closed form| (rad) and |ω - closed form| (rad/s) over 4 s, RK4 at 1 ms with the law held over each step (first
#: order in the step: 5.7e-4 at 10 ms). Measured 2026-12-01: 5.7e-5 (θ), 5.9e-5 (ω), both paths.
CLOSED_FORM_BOUND = 1e-4


@pytest.fixture(scope="module")
def section5() -> tuple[ff.Model, np.ndarray]:
    model, _, state, _ = section5_setup()
    return model, np.asarray(state.q, dtype=float)


def run(model: ff.Model, start: ff.State, controller: Any, path: str, monkeypatch: pytest.MonkeyPatch) -> ff.Trajectory:
    """A fixed-step simulation on ``path`` ("compiled": the controller as given; "python": wrapped in a function)."""
    runs = compiled_runs(monkeypatch)
    law = controller if path == "compiled" else (lambda t, s: controller(t, s))
    traj = ff.simulate(model, start, DURATION, law, fixed_step=DT, output_period=0.05)
    assert runs == (["detumble"] if path == "compiled" else [])  # the path it names
    return traj


@pytest.mark.parametrize("gains", ["scalar", "per_row"])
@pytest.mark.parametrize("path", ["compiled", "python"])
def test_the_default_attitude_gain_is_critically_damped(section5: Any, path: str, gains: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """A scalar rate gain k, or one per row of zdot0 whose smallest ω0 gain is k, about z: the default gain is k²/4 of
    that smallest one (critically damped about the slowest axis; z here)."""
    model, q = section5
    start = ff.State(q=q, attitude=Rotation.from_euler("z", THETA0).as_quat())
    rate = K if gains == "scalar" else np.array([1.0, 1.0, 1.0, 3.0, 4.0, K, 1.0, 1.0])
    controller = Detumble(model, rate_gain=rate, attitude=Rotation.identity())
    assert controller.attitude_gain == K * K / 4.0
    traj = run(model, start, controller, path, monkeypatch)
    t = traj.t
    theta = Rotation.from_quat(traj.attitude).as_rotvec()
    assert np.abs(theta[:, :2]).max() < 1e-12  # about z only
    assert np.abs(theta[:, 2] - THETA0 * (1 + K * t / 2) * np.exp(-K * t / 2)).max() < CLOSED_FORM_BOUND
    assert np.abs(traj.omega[:, 2] - (-THETA0 * K * K / 4 * t * np.exp(-K * t / 2))).max() < CLOSED_FORM_BOUND
    assert np.all(theta[:, 2] > 0.0) and np.all(np.diff(theta[:, 2]) < 0.0)  # no overshoot


@pytest.mark.parametrize("path", ["compiled", "python"])
def test_without_force_the_cm_keeps_its_velocity(section5: Any, path: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """``force=False`` on the default path of a fixed-step ``simulate`` (the compiled law) and from Python: the thrusters
    give no force at any sample, so v_cm is constant to rounding while ω0 and q̇ decay as exp(-k t)."""
    model, q = section5
    v_cm = np.array([0.05, -0.03, 0.0])
    start = ff.State(q=q, qdot=[0.3, -0.2], omega=[0.0, 0.0, 0.2], v_cm=v_cm)
    traj = run(model, start, Detumble(model, rate_gain=1.0, force=False), path, monkeypatch)
    assert np.all(traj.spacecraft_force == 0.0)
    assert np.abs(traj.v_cm - v_cm).max() < 1e-15
    cost = ff.control.detumble_cost(traj, rest_velocity=None)
    assert cost.final_rates[1] < 0.2 * np.exp(-DURATION) * 1.01 and cost.final_rates[2] < 0.3 * np.exp(-DURATION) * 1.01
    assert np.abs(traj.joint_torque).max() > 0.1  # the joints did work


def test_an_adaptive_run_gives_the_controller_unit_attitudes() -> None:
    """The adaptive integrator's stage states carry quaternions off unit length (by ~1e-6 within 0.2 s here); the
    controller is given the attitude the stage stands for, so an attitude-holding Detumble runs to the end (it raised
    "quaternion norm ... is not 1" at t = 0.14 s) and turns the spacecraft to the attitude asked for."""
    model = ff.load("papadopoulos1992")
    target = Rotation.from_rotvec([0.0, 0.0, 0.2])
    seen: list[float] = []
    law = Detumble(model, attitude=target.as_quat())

    def controller(t: float, state: ff.State) -> Any:
        seen.append(float(np.linalg.norm(state.attitude)))
        return law(t, state)

    run = ff.simulate(model, ff.State(q=[0.1, 0.2, 0.3, 0.4], omega=[0.0, 0.0, 0.05]), 20.0, controller=controller)
    assert run.t[-1] == 20.0
    assert max(abs(n - 1.0) for n in seen) <= 1e-12
    start, final = (Rotation.from_quat(run.attitude[i]).inv() * target for i in (0, -1))
    assert final.magnitude() < 1e-2 * start.magnitude()  # turned to the attitude asked for
