"""Control benchmark: the 1991 §V simulation per controller, and a controlled simulation against MuJoCo.

* ``section5``: wall time of the 30 s §V simulation (Table I system, Kp = 30, Kd = 60) for the
  transposed-Jacobian controller (eqs. 29-30) and the operational-space controller (eq. 27), exactly
  as ``freefloat reproduce 1991`` runs it (adaptive LSODA, continuous control);
* ``steps``: the same controllers sampled once per step with fixed-step RK4 (dt = 10 ms), steps per
  second of ``freefloat.simulate`` against MuJoCo (``freefloat.io.mujoco_bridge.to_mujoco``, RK4, same
  dt) running the same Python controller each step: state read back with ``from_mujoco_state``, joint
  torques into ``data.ctrl``, the thruster wrench (rotated to the world frame) into
  ``data.xfrc_applied`` of the spacecraft (MuJoCo applies it at the body CM, where the paper's
  thrusters act). The end states of both engines are compared (they integrate the same equations).
"""

from __future__ import annotations

import os
import platform
import time
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from bench_core import machine_line
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
    traj = simulate(model, state, duration, controller, fixed_step=DT)
    return time.perf_counter() - t0, round(duration / DT), traj


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
    lines.append(machine_line(report["machine"]))
    return "\n".join(lines)
