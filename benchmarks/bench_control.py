"""Control benchmark: the 1991 §V simulation per controller, and a controlled simulation against MuJoCo.

* ``section5``: wall time of the 30 s §V simulation (Table I system, Kp = 30, Kd = 60) for the
  transposed-Jacobian controller (eqs. 29-30) and the operational-space controller (eq. 27), exactly
  as ``freefloat reproduce 1991`` runs it (adaptive LSODA, continuous control);
* ``steps``: the same controllers sampled once per step with fixed-step RK4 (dt = 10 ms), steps per
  second of ``freefloat.simulate`` against MuJoCo (``freefloat.io.mujoco_bridge.to_mujoco``, RK4, same
  dt) running the same Python controller each step: state read back with ``from_mujoco_state``, joint
  torques into ``data.ctrl``, the thruster wrench (rotated to the world frame) into
  ``data.xfrc_applied`` of the spacecraft (MuJoCo applies it at the body CM, where the paper's
  thrusters act). The end states of both engines are compared (they integrate the same equations);
* ``compiled`` (issue 23): the built-in controllers inside the compiled loops. ``single``: one simulation of §V with
  the transposed-Jacobian controller (dt = 10 ms, sampled every step) compiled (``simulate(..., controller)``), against
  the same controller called from Python every step (``simulate(..., lambda t, s: controller(t, s))``) and against
  MuJoCo with that Python controller (as ``steps``); ``rollouts``: 1024 trajectories of §V with the operational-space
  controller (per-trajectory set points) compiled (``rollout(..., controller=controller)``), against the same controller
  in Python (called on one state or on the batch, it runs its numpy form, row by row) over a ``mujoco.rollout``-style
  loop: the whole batch's controls computed in Python each step, then the
  batch stepped by compiled code (freefloat's batched RK4 step; MuJoCo's own batch stepper would need a Python
  conversion of each of the 1024 states per step, which would measure the conversion). Both with the largest
  difference of the recorded states between the compiled and the Python loop.
* ``wheels`` (issue 43): a rollout of 64 servicers with reaction wheels, each its own wheels (inertia, torque and speed
  limits, bearing friction) and initial state, with the detumbling by the wheels alone compiled
  (``rollout(models, ..., controller=Detumble(models, torque_by="wheels", force=False))``), against the same 64 through
  the Python loop (``simulate`` of each servicer with the controller's numpy form called every sample: per-trajectory
  models have no batched Python loop); with the largest difference of the recorded states and wheel outputs.
"""

from __future__ import annotations

import os
import platform
import time
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from bench_core import machine_line
from bench_workspace import best_of
from freefloat.control import OperationalSpaceController, TransposedJacobianController
from freefloat.io.mujoco_bridge import from_mujoco_state, mujoco_state, to_mujoco
from freefloat.papers.paper1991 import run_controller, section5_setup
from freefloat.simulation.simulate import simulate

DT = 0.01
CONTROLLERS = {"tj": TransposedJacobianController, "ct": OperationalSpaceController}


def _mujoco_run(name: str, duration: float) -> tuple[float, int, Any]:
    import mujoco

    model, task, state, target = section5_setup()
    controller = CONTROLLERS[name](model, task, target, 30.0, 60.0)
    mj = to_mujoco(model, timestep=DT, integrator="RK4")
    data = mujoco.MjData(mj)
    qpos, qvel = mujoco_state(model, state)
    data.qpos[:], data.qvel[:] = qpos, qvel
    mujoco.mj_forward(mj, data)
    steps = round(duration / DT)
    t0 = time.perf_counter()
    for i in range(steps):
        s = from_mujoco_state(model, data.qpos, data.qvel)
        act = controller(i * DT, s)
        rot = Rotation.from_quat(s.attitude).as_matrix()
        data.ctrl[:] = act.joint_torque
        data.xfrc_applied[1, 0:3] = rot @ act.spacecraft_force
        data.xfrc_applied[1, 3:6] = rot @ act.spacecraft_torque
        mujoco.mj_step(mj, data)
    wall = time.perf_counter() - t0
    return wall, steps, from_mujoco_state(model, data.qpos, data.qvel)


def _freefloat_run(name: str, duration: float) -> tuple[float, int, Any]:
    model, task, state, target = section5_setup()
    controller = CONTROLLERS[name](model, task, target, 30.0, 60.0)
    t0 = time.perf_counter()
    # the controller in Python every step (a built-in controller given as itself runs compiled: see compiled_controllers)
    traj = simulate(model, state, duration, lambda t, s: controller(t, s), fixed_step=DT)
    return time.perf_counter() - t0, round(duration / DT), traj


def compiled_controllers(quick: bool, log: Any) -> dict[str, Any]:
    """The two targets of issue 23 (see the module docstring); ratios measured in this run."""
    from freefloat.simulation.simulate import rollout

    model, task, state, target = section5_setup()
    tj = TransposedJacobianController(model, task, target, 30.0, 60.0)
    horizon = 3.0 if quick else 30.0
    steps = round(horizon / DT)
    simulate(model, state, 0.1, tj, fixed_step=DT)  # compiled already: no compile in the timings
    wall, fast = best_of(lambda: simulate(model, state, horizon, tj, fixed_step=DT), 5)
    short = min(horizon, 3.0)
    py_wall, slow = best_of(lambda: simulate(model, state, short, lambda t, s: tj(t, s), fixed_step=DT), 3)
    mj_wall = min(_mujoco_run("tj", short)[0] for _ in range(3))
    n_short = round(short / DT)
    single = {
        "steps": steps,
        "compiled_steps_per_s": steps / wall,
        "python_steps_per_s": n_short / py_wall,
        "mujoco_python_controller_steps_per_s": n_short / mj_wall,
        "ratio_over_python": (steps / wall) / (n_short / py_wall),
        "ratio_over_mujoco": (steps / wall) / (n_short / mj_wall),
        "max_dq_compiled_vs_python": float(np.abs(fast.q[: len(slow)] - slow.q).max()),
    }
    log(
        f"compiled single TJ: {single['compiled_steps_per_s']:.0f} steps/s; Python controller {single['python_steps_per_s']:.0f}; "
        f"MuJoCo + Python controller {single['mujoco_python_controller_steps_per_s']:.0f}; x{single['ratio_over_mujoco']:.1f} MuJoCo"
    )
    batch = 128 if quick else 1024
    rng = np.random.default_rng(23)
    targets = np.tile(target, (batch, 1))
    targets[:, 3:5] += rng.uniform(-0.1, 0.1, (batch, 2))
    states = ff_state_batch(state, batch, rng)
    osc = OperationalSpaceController(model, task, targets, 30.0, 60.0)
    duration = 1.0
    rollout(model, states, DT, dt=DT, controller=osc)  # compiled already
    r_wall, r_fast = best_of(lambda: rollout(model, states, duration, dt=DT, controller=osc), 3)
    p_wall, r_slow = best_of(lambda: rollout(model, states, duration, dt=DT, controller=lambda t, s: osc(t, s)), 1 if not quick else 2)
    r_steps = round(duration / DT) * batch
    per_state = _per_state_loop(model, task, targets, states, 0.1 if not quick else 0.05)
    rollouts = {
        "trajectories": batch,
        "steps_each": round(duration / DT),
        "compiled_wall_s": r_wall,
        "python_loop_wall_s": p_wall,
        "compiled_trajectory_steps_per_s": r_steps / r_wall,
        "python_loop_trajectory_steps_per_s": r_steps / p_wall,
        "ratio_over_python_loop": p_wall / r_wall,
        "max_dq_compiled_vs_python": float(np.abs(r_fast.q - r_slow.q).max()),
        "per_state_python_loop_trajectory_steps_per_s": per_state,
        "ratio_over_per_state_python_loop": (r_steps / r_wall) / per_state,
    }
    log(f"per-state Python loop: {per_state:.0f} trajectory steps/s")
    log(f"compiled rollouts OSC x{batch}: {r_wall:.3f} s vs Python loop {p_wall:.3f} s: x{rollouts['ratio_over_python_loop']:.1f}")
    return {"single": single, "rollouts": rollouts, "load_average": os.getloadavg()}


def _servicer(b: int) -> Any:
    """Servicer b of the wheel benchmark: the 1992 one-arm robot with four wheels in a pyramid, their inertia, limits and
    friction depending on b (as tests/simulation/test_wheel_rollouts.py)."""
    import dataclasses

    import freefloat as ff
    from freefloat.core.wheels import reaction_wheel

    tilt = np.arctan(1.0 / np.sqrt(2.0))
    wheels = tuple(
        reaction_wheel(
            f"rw{i}",
            axis=[np.cos(tilt) * np.cos(i * np.pi / 2), np.cos(tilt) * np.sin(i * np.pi / 2), np.sin(tilt)],
            inertia=0.3 + 0.004 * b + 0.05 * i,
            max_torque=None if b % 4 == 0 else 0.04 + 0.002 * b,
            max_speed=None if b % 3 == 0 else 25.0 + 0.2 * b,
            viscous=1e-4 * (b % 5),
            coulomb=2e-4 * (b % 7),
        )
        for i in range(4)
    )
    return dataclasses.replace(ff.models.papadopoulos1992(arms=1), wheels=wheels)


def wheel_rollouts(quick: bool, log: Any) -> dict[str, Any]:
    """The wheel rollout of the module docstring: 64 servicers, 10 s (quick: 2 s) at dt = 10 ms, sampled every 3 steps."""
    from freefloat.control import Detumble
    from freefloat.core.state import State
    from freefloat.simulation.simulate import rollout

    batch, duration = 64, 2.0 if quick else 10.0
    models = [_servicer(b) for b in range(batch)]
    rng = np.random.default_rng(43)
    columns = {
        "q": np.array([0.5, 1.0]) + rng.uniform(-0.3, 0.3, (batch, 2)),
        "qdot": rng.uniform(-0.02, 0.02, (batch, 2)),
        "omega": rng.uniform(-0.04, 0.04, (batch, 3)),
        "wheel_speed": rng.uniform(-32.0, 32.0, (batch, 4)),
    }
    controller = Detumble(models, rate_gain=np.linspace(0.1, 0.4, batch)[:, None], torque_by="wheels", force=False)
    options = {"dt": DT, "sample_period": 3 * DT, "output_period": 0.1}
    rollout(models, State(**columns), 3 * DT, controller=controller, **options)  # compiled already
    c_wall, fast = best_of(lambda: rollout(models, State(**columns), duration, controller=controller, **options), 3)
    t0 = time.perf_counter()
    worst = 0.0
    for b in range(batch):
        own = controller.row(b)
        start = State(**{k: v[b] for k, v in columns.items()})
        slow = simulate(models[b], start, duration, lambda t, s, own=own: own(t, s), fixed_step=DT, sample_period=3 * DT, output_period=0.1)
        for name in ("q", "qdot", "omega", "attitude", "wheel_angle", "wheel_speed", "wheel_torque", "joint_torque"):
            worst = max(worst, float(np.abs(getattr(fast, name)[:, b] - getattr(slow, name)).max()))
    p_wall = time.perf_counter() - t0
    steps = round(duration / DT) * batch
    out = {
        "trajectories": batch,
        "steps_each": round(duration / DT),
        "compiled_wall_s": c_wall,
        "python_loop_wall_s": p_wall,
        "compiled_trajectory_steps_per_s": steps / c_wall,
        "python_loop_trajectory_steps_per_s": steps / p_wall,
        "ratio_over_python_loop": p_wall / c_wall,
        "max_difference_compiled_vs_python": worst,
        "saturated_trajectories": int(np.any(fast.wheel_torque_saturated | fast.wheel_speed_saturated, axis=(0, 2)).sum()),
        "load_average": os.getloadavg(),
    }
    ratio = out["ratio_over_python_loop"]
    log(f"wheel rollouts x{batch}: {c_wall:.3f} s compiled vs Python loop {p_wall:.3f} s: x{ratio:.1f}, max diff {worst:.1e}")
    return out


def _per_state_loop(model: Any, task: Any, targets: np.ndarray, states: Any, duration: float) -> float:
    """Trajectory steps per second of the mujoco.rollout-style loop with a Python controller called per state (as a
    MuJoCo user calls one: ``mujoco.rollout`` steps the batch, the controller runs per trajectory in Python between
    steps): one OperationalSpaceController per trajectory, its ``__call__`` on each state, then the batch's RK4 step."""
    from freefloat.core.state import pack_state, unpack_state
    from freefloat.engine import calls as _engine

    own = [OperationalSpaceController(model, task, z, 30.0, 60.0) for z in targets]
    x = pack_state(states.resolve(model))
    n = model.n_joints
    u = np.zeros((x.shape[0], n + 6))
    steps = round(duration / DT)
    t0 = time.perf_counter()
    for i in range(steps):
        for b, controller in enumerate(own):
            act = controller(i * DT, unpack_state(model, x[b]))
            u[b, :n], u[b, n : n + 3], u[b, n + 3 :] = act.joint_torque, act.spacecraft_force, act.spacecraft_torque
        x = _engine.rk4_batch(model, x, u, DT, 1)
    return steps * x.shape[0] / (time.perf_counter() - t0)


def ff_state_batch(state: Any, batch: int, rng: np.random.Generator) -> Any:
    """``batch`` states around ``state`` (joint angles spread by 0.05 rad)."""
    from freefloat.core.state import State

    q = np.asarray(state.q) + rng.uniform(-0.05, 0.05, (batch, len(state.q)))
    return State(q=q, attitude=np.tile(state.attitude, (batch, 1)))


def run(quick: bool, log: Any) -> dict[str, Any]:
    report: dict[str, Any] = {
        "machine": {"python": platform.python_version(), "cpu_count": os.cpu_count(), "platform": platform.platform()},
        "section5": {},
        "steps": {},
    }
    duration = 5.0 if quick else 30.0
    for name in CONTROLLERS:
        t0 = time.perf_counter()
        traj = run_controller(name, duration)
        wall = time.perf_counter() - t0
        report["section5"][name] = {"simulated_s": duration, "wall_s": wall, "outputs": len(traj)}
        log(f"section5 {name}: {duration:g} s simulated in {wall:.2f} s")
    horizon = 1.0 if quick else 3.0
    for name in CONTROLLERS:
        ff_wall, steps, traj = _freefloat_run(name, horizon)
        mj_wall, _, mj_state = _mujoco_run(name, horizon)
        dq = float(np.abs(traj.q[-1] - mj_state.q).max())
        dr = float(np.abs(traj.r_cm[-1] - mj_state.r_cm).max())
        report["steps"][name] = {
            "dt": DT,
            "steps": steps,
            "freefloat_steps_per_s": steps / ff_wall,
            "mujoco_steps_per_s": steps / mj_wall,
            "ratio_freefloat_over_mujoco": mj_wall / ff_wall,
            "end_state_max_dq_rad": dq,
            "end_state_max_dr_cm_m": dr,
        }
        log(f"steps {name}: freefloat {steps / ff_wall:.0f} steps/s, MuJoCo + Python controller {steps / mj_wall:.0f} steps/s, dq {dq:.1e}")
    report["compiled"] = compiled_controllers(quick, log)
    report["wheels"] = wheel_rollouts(quick, log)
    report["settings"] = {"dt": DT, "section5_duration_s": duration, "steps_horizon_s": horizon}
    return report


def table(report: dict[str, Any]) -> str:
    lines = ["1991 §V simulation (adaptive, continuous control):"]
    for name, r in report["section5"].items():
        lines.append(f"  {name}: {r['simulated_s']:g} s simulated in {r['wall_s']:.2f} s wall")
    lines.append(f"controlled RK4 simulation, dt = {DT * 1e3:g} ms, controller in Python every step:")
    lines.append(f"  {'ctrl':4s} {'freefloat steps/s':>18s} {'MuJoCo steps/s':>15s} {'ratio':>6s} {'end |dq| (rad)':>15s}")
    for name, r in report["steps"].items():
        lines.append(
            f"  {name:4s} {r['freefloat_steps_per_s']:18.0f} {r['mujoco_steps_per_s']:15.0f} "
            f"{r['ratio_freefloat_over_mujoco']:6.2f} {r['end_state_max_dq_rad']:15.1e}"
        )
    if "compiled" in report:
        c, r = report["compiled"]["single"], report["compiled"]["rollouts"]
        lines.append("built-in controllers compiled (issue 23), same run:")
        lines.append(
            f"  one §V simulation, TJ: {c['compiled_steps_per_s']:.0f} steps/s compiled, {c['python_steps_per_s']:.0f} with the "
            f"controller in Python (x{c['ratio_over_python']:.1f}), "
            f"MuJoCo + Python controller {c['mujoco_python_controller_steps_per_s']:.0f} "
            f"(x{c['ratio_over_mujoco']:.1f}); max |dq| compiled - Python {c['max_dq_compiled_vs_python']:.1e}"
        )
        lines.append(
            f"  {r['trajectories']} rollouts x {r['steps_each']} steps, OSC: {r['compiled_wall_s']:.3f} s compiled, "
            f"{r['python_loop_wall_s']:.3f} s Python loop (x{r['ratio_over_python_loop']:.1f}); "
            f"max |dq| {r['max_dq_compiled_vs_python']:.1e}; controller per state in Python (mujoco.rollout style) "
            f"{r['per_state_python_loop_trajectory_steps_per_s']:.0f} trajectory steps/s (x{r['ratio_over_per_state_python_loop']:.1f})"
        )
        lines.append(f"  load average {report['compiled']['load_average']}")
    if "wheels" in report:
        w = report["wheels"]
        lines.append(
            f"  {w['trajectories']} servicers with their own reaction wheels x {w['steps_each']} steps, detumbling by wheels: "
            f"{w['compiled_wall_s']:.3f} s compiled, {w['python_loop_wall_s']:.3f} s Python loop (x{w['ratio_over_python_loop']:.1f}); "
            f"max difference {w['max_difference_compiled_vs_python']:.1e}; a wheel limit acted in {w['saturated_trajectories']}; "
            f"load average {w['load_average']}"
        )
    lines.append(machine_line(report["machine"]))
    return "\n".join(lines)
