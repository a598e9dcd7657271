"""Dynamics and simulation benchmark: freeflyer against Pinocchio and MuJoCo, in one run.

For the 1992 two-arm system and the 7-DOF spacecraft (``ff.models.spacecraft_7dof``):

1. **Per configuration** (batched): H+ (1991 eq. 15), C+ (eq. 19) and forward dynamics for
   ``configs`` random states, one batched call, against the same quantities from Pinocchio in a
   Python loop (``pin.crba``, ``pin.nonLinearEffects``, ``pin.aba`` with a free-flyer root, one
   ``Data`` reused). freeflyer's compiled kernels (numba, ``freeflyer.mechanics._compiled``) and its numpy
   reference (``ff.system_inertia_matrix``, ``ff.nonlinear_forces``, ``ff.forward_dynamics``).
2. **One simulation**, fixed-step RK4 at 1 ms with a joint PD controller written in Python in the
   loop (the same function for both): MuJoCo (``mj_step``, integrator RK4, timestep 1 ms, the
   controller writing ``data.ctrl`` before each step) against freeflyer's compiled RK4 loop
   (``Kernels.simulate``: the controller at every step, the steps compiled), against the public
   ``simulate(..., fixed_step=1e-3)`` (which adds input validation, saturation bookkeeping and a
   ``State`` per call), with the compiled and the numpy back ends.
3. **Batched rollouts** of 1024 trajectories under open-loop joint-torque profiles (the same
   torques for both), every state recorded (as ``mujoco.rollout`` does): ``mujoco.rollout`` with
   one ``MjData`` per thread against the public ``freeflyer.rollout`` (``JointPD`` with zero gains
   and the profile as feed-forward, compiled) and its kernel ``Kernels.rollout_pd``; both with
   the same number of threads (all cores), and single-threaded.

Everything is verified before it is timed (freeflyer compiled == numpy to 1e-10, forward dynamics
== Pinocchio's ABA to 1e-9, the simulations and rollouts == MuJoCo's to 1e-6). Throughputs are
best-of-``repeats`` wall-clock rates; ratios are freeflyer / reference, both measured in this run.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from typing import Any

import numpy as np

import freeflyer as ff
from bench_core import best_of, machine_info
from freeflyer.core.state import State
from freeflyer.io.mujoco_bridge import from_mujoco_state, mujoco_state, to_mujoco
from freeflyer.io.oracles import acceleration_from_pinocchio, pinocchio_configuration, pinocchio_velocity, to_pinocchio
from freeflyer.mechanics import _compiled
from freeflyer.simulation.pd import JointPD
from freeflyer.simulation.simulate import rollout, simulate

DT = 1e-3
TARGET_SIMULATION = 1.0
TARGET_ROLLOUT = 10.0


def systems() -> dict[str, tuple[str, ff.Model]]:
    return {
        "papadopoulos1992": ("Papadopoulos 1992 two-arm planar system (N = 4)", ff.models.papadopoulos1992(arms=2)),
        "spacecraft_7dof": ("1500 kg spacecraft with a 7-DOF iiwa-style arm, 3D (N = 7)", ff.models.spacecraft_7dof()),
    }


def random_states(model: ff.Model, count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Flat states (count, 13 + 2N) (identity attitude, random q, qdot, omega0) and joint torques (count, N)."""
    rng = np.random.default_rng(seed)
    n = model.n_joints
    x = np.zeros((count, 13 + 2 * n))
    x[:, 9] = 1.0
    x[:, 10:13] = rng.normal(scale=0.05, size=(count, 3))
    x[:, 13 : 13 + n] = rng.uniform(-np.pi, np.pi, size=(count, n))
    x[:, 13 + n :] = rng.normal(scale=0.5, size=(count, n))
    return x, rng.normal(scale=5.0, size=(count, n))


def rate(timing: dict[str, Any], items: float, unit: str) -> dict[str, Any]:
    out = dict(timing)
    out[unit] = items
    out[f"{unit}_per_s"] = items / timing["best_wall_s"]
    return out


# ----------------------------------------------------------------- 1. per configuration
class PinocchioLoop:
    def __init__(self, model: ff.Model) -> None:
        import pinocchio as pin

        self.pin = pin
        self.model = model
        self.pm = to_pinocchio(model)
        self.data = self.pm.createData()

    def inputs(self, x: np.ndarray, tau: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        n = self.model.n_joints
        out = []
        for xi, ti in zip(x, tau, strict=True):
            q = xi[13 : 13 + n]
            velocity = np.concatenate([xi[3:6], xi[10:13], xi[13 + n :]])
            out.append(
                (
                    pinocchio_configuration(self.model, q),
                    pinocchio_velocity(self.model, self.pm, q, velocity),
                    np.concatenate([np.zeros(6), ti]),
                )
            )
        return out

    def loop(self, which: str, items: list[tuple[np.ndarray, np.ndarray, np.ndarray]]) -> list[Any]:
        pin, pm, data = self.pin, self.pm, self.data
        if which == "hplus":
            return [pin.crba(pm, data, q).copy() for q, _, _ in items]
        if which == "cplus":
            return [pin.nonLinearEffects(pm, data, q, v).copy() for q, v, _ in items]
        return [pin.aba(pm, data, q, v, t).copy() for q, v, t in items]


def compiled_calls(model: ff.Model, x: np.ndarray, tau: np.ndarray) -> dict[str, Callable[[], Any]]:
    kernels = _compiled.kernels(model)
    n = model.n_joints
    u = np.zeros((x.shape[0], n + 6))
    u[:, :n] = tau

    def hplus() -> np.ndarray:
        out = np.zeros((x.shape[0], 6 + n, 6 + n))
        out[:, 0, 0] = out[:, 1, 1] = out[:, 2, 2] = model.total_mass
        out[:, 3:, 3:] = kernels.mass_matrix(x)
        return out

    def cplus() -> np.ndarray:
        out = np.zeros((x.shape[0], 6 + n))
        out[:, 3:] = kernels.bias(x)
        return out

    def fd() -> np.ndarray:
        d = kernels.derivative(x, u)
        return np.concatenate([d[:, 3:6], d[:, 10:13], d[:, 13 + n :]], axis=1)

    return {"hplus": hplus, "cplus": cplus, "fd": fd}


def numpy_calls(model: ff.Model, x: np.ndarray, tau: np.ndarray) -> dict[str, Callable[[], Any]]:
    n = model.n_joints
    q = x[:, 13 : 13 + n]
    velocity = np.concatenate([x[:, 3:6], x[:, 10:13], x[:, 13 + n :]], axis=1)
    return {
        "hplus": lambda: ff.system_inertia_matrix(model, q),
        "cplus": lambda: ff.nonlinear_forces(model, q, velocity),
        "fd": lambda: ff.forward_dynamics(model, q, velocity, tau),
    }


def per_configuration(
    model: ff.Model, configs: int, numpy_configs: int, pin_configs: int, repeats: int, log: Callable[[str], None]
) -> dict[str, Any]:
    x, tau = random_states(model, configs, 2024)
    ours = compiled_calls(model, x, tau)
    ref = numpy_calls(model, x[:numpy_configs], tau[:numpy_configs])
    # verification: compiled == numpy (1e-10 of each row's scale), forward dynamics == Pinocchio's ABA (1e-9)
    check: dict[str, float] = {}
    for key in ours:
        a = ours[key]()[:numpy_configs].reshape(numpy_configs, -1)
        b = ref[key]().reshape(numpy_configs, -1)
        err = float(np.max(np.abs(a - b) / np.max(np.abs(b), axis=1, keepdims=True)))
        check[f"{key}_compiled_vs_numpy"] = err
        if err > 1e-10:
            raise AssertionError(f"{model.name}: compiled {key} differs from numpy by {err:.1e}")
    pin_loop = PinocchioLoop(model)
    items = pin_loop.inputs(x[:pin_configs], tau[:pin_configs])
    fd_ours = ours["fd"]()
    worst = 0.0
    for i in range(0, pin_configs, max(1, pin_configs // 20)):
        q = x[i, 13 : 13 + model.n_joints]
        pin_acc = pin_loop.loop("fd", [items[i]])[0]
        ref_acc = acceleration_from_pinocchio(model, pin_loop.pm, q, items[i][1], pin_acc)
        worst = max(worst, float(np.max(np.abs(fd_ours[i] - ref_acc)) / np.max(np.abs(ref_acc))))
    check["fd_compiled_vs_pinocchio_aba"] = worst
    if worst > 1e-9:
        raise AssertionError(f"{model.name}: forward dynamics differs from Pinocchio's ABA by {worst:.1e}")
    out: dict[str, Any] = {"verification": check, "configs": configs, "numpy_configs": numpy_configs, "pinocchio_configs": pin_configs}
    for key in ("hplus", "cplus", "fd"):
        log(f"[{model.name}] {key}: compiled ({configs:,}), numpy ({numpy_configs:,}), Pinocchio loop ({pin_configs:,})")
        a = rate(best_of(ours[key], repeats), configs, "configs")
        b = rate(best_of(ref[key], max(1, repeats // 2)), numpy_configs, "configs")
        c = rate(best_of(lambda key=key: pin_loop.loop(key, items), repeats), pin_configs, "configs")
        out[key] = {
            "freeflyer_numba": a,
            "freeflyer_numpy": b,
            "pinocchio_loop": c,
            "ratio": a["configs_per_s"] / c["configs_per_s"],
            "ratio_numpy": b["configs_per_s"] / c["configs_per_s"],
        }
    return out


# ----------------------------------------------------------------- 2. one simulation with a Python controller
def pd_gains(model: ff.Model, q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """kp = wn^2 I_j, kd = 2 zeta wn I_j with I_j the joint's diagonal entry of H+ at q0 (wn = 20 rad/s, zeta = 0.7)."""
    inertia = np.diagonal(ff.system_inertia_matrix(model, q0))[6:]
    wn, zeta = 20.0, 0.7
    return wn**2 * inertia, 2.0 * zeta * wn * inertia


def single_simulation(model: ff.Model, steps: int, numpy_steps: int, repeats: int, log: Callable[[str], None]) -> dict[str, Any]:
    import mujoco

    n = model.n_joints
    q0 = np.linspace(0.2, -0.3, n)
    kp, kd = pd_gains(model, q0)
    q_ref = q0 + 0.5

    def pd(q: np.ndarray, qdot: np.ndarray) -> np.ndarray:  # the controller, the same for both
        return kp * (q_ref - q) - kd * qdot

    state = State(q=q0, omega=[0.0, 0.0, 0.01])
    stride = 10
    # MuJoCo: mj_step with RK4 at 1 ms, controller in Python, a state kept every `stride` steps
    m = to_mujoco(model, timestep=DT, integrator="RK4")
    d = mujoco.MjData(m)
    qpos0, qvel0 = mujoco_state(model, state)

    def run_mujoco() -> list[np.ndarray]:
        mujoco.mj_resetData(m, d)
        d.qpos[:], d.qvel[:] = qpos0, qvel0
        kept = []
        for i in range(steps):
            d.ctrl[:] = pd(d.qpos[7:], d.qvel[6:])
            mujoco.mj_step(m, d)
            if (i + 1) % stride == 0:
                kept.append(np.concatenate([d.qpos, d.qvel]))
        return kept

    kernels = _compiled.kernels(model)
    x0 = np.concatenate([state.resolve(model).r_cm, np.zeros(3), [0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.01], q0, np.zeros(n)])

    def loop_controller(t: float, x: np.ndarray) -> np.ndarray:
        return pd(x[13 : 13 + n], x[13 + n :])

    def run_compiled_loop() -> Any:
        return kernels.simulate(x0, DT, steps, loop_controller, hold=1, stride=stride)

    def controller(t: float, s: State) -> np.ndarray:
        return pd(s.q, s.qdot)

    def run_public(backend: str, count: int) -> ff.Trajectory:
        return simulate(model, state, count * DT, controller, fixed_step=DT, output_period=stride * DT, backend=backend)

    # verification: the three agree with each other (q at the end)
    kept = run_mujoco()
    _, xs, _ = run_compiled_loop()
    final = from_mujoco_state(model, kept[-1][: m.nq], kept[-1][m.nq :])
    err_mj = float(np.max(np.abs(xs[-1, 13 : 13 + n] - final.q)))
    traj = run_public("numba", steps)
    err_pub = float(np.max(np.abs(traj.q[-1] - xs[-1, 13 : 13 + n])))
    short = run_public("numpy", numpy_steps)
    err_np = float(np.max(np.abs(short.q - traj.q[: short.q.shape[0]])))
    if max(err_mj, err_pub, err_np) > 1e-6:
        raise AssertionError(f"{model.name}: simulations disagree (MuJoCo {err_mj:.1e}, public {err_pub:.1e}, numpy {err_np:.1e})")
    log(f"[{model.name}] one simulation, {steps} steps of 1 ms, PD controller in Python")
    mj = rate(best_of(run_mujoco, repeats), steps, "steps")
    loop = rate(best_of(run_compiled_loop, repeats), steps, "steps")
    public = rate(best_of(lambda: run_public("numba", steps), repeats), steps, "steps")
    public_np = rate(best_of(lambda: run_public("numpy", numpy_steps), 1), numpy_steps, "steps")
    return {
        "steps": steps,
        "controller": "tau = kp (q_ref - q) - kd qdot, numpy, every step (kp = 400 I_jj, kd = 28 I_jj: wn = 20 rad/s, zeta = 0.7)",
        "verification": {
            "max_abs_q_compiled_loop_vs_mujoco": err_mj,
            "max_abs_q_public_vs_loop": err_pub,
            "max_abs_q_numpy_vs_numba": err_np,
        },
        "mujoco_python_controller": mj,
        "freeflyer_compiled_loop": loop,
        "freeflyer_simulate_numba": public,
        "freeflyer_simulate_numpy": public_np,
        "ratio_compiled_loop": loop["steps_per_s"] / mj["steps_per_s"],
        "ratio_simulate": public["steps_per_s"] / mj["steps_per_s"],
        "ratio_simulate_numpy": public_np["steps_per_s"] / mj["steps_per_s"],
    }


# ----------------------------------------------------------------- 3. batched rollouts
def batched_rollouts(model: ff.Model, batch: int, steps: int, repeats: int, log: Callable[[str], None]) -> dict[str, Any]:
    import mujoco
    from mujoco import rollout as mj_rollout

    n = model.n_joints
    rng = np.random.default_rng(5)
    q0 = rng.uniform(-0.5, 0.5, size=(batch, n))
    qd0 = rng.normal(scale=0.1, size=(batch, n))
    scale = np.diagonal(ff.system_inertia_matrix(model, np.zeros(n)))[6:]  # torques ~ 1 rad/s^2 per joint
    t = np.arange(steps) * DT
    phase = rng.uniform(0, 2 * np.pi, size=(batch, 1, n))
    torque = scale * np.sin(2 * np.pi * 0.5 * t[None, :, None] + phase)  # (B, steps, N)
    states = State(q=q0, qdot=qd0)
    m = to_mujoco(model, timestep=DT, integrator="RK4")
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    d = mujoco.MjData(m)
    init = np.empty((batch, mujoco.mj_stateSize(m, spec)))
    for b in range(batch):
        qpos, qvel = mujoco_state(model, State(q=q0[b], qdot=qd0[b]))
        mujoco.mj_resetData(m, d)
        d.qpos[:], d.qvel[:] = qpos, qvel
        mujoco.mj_getState(m, d, init[b], spec)
    cores = _compiled.threads()
    pd = JointPD(kp=0.0, kd=0.0, feedforward=np.swapaxes(torque, 0, 1), feedforward_period=DT)
    kernels = _compiled.kernels(model)
    x0 = np.concatenate([np.zeros((batch, 9)), np.ones((batch, 1)), np.zeros((batch, 3)), q0, qd0], axis=1)
    x0[:, 0:3] = states.resolve(model).r_cm
    feed = np.zeros((steps, batch, n + 6))
    feed[:, :, :n] = np.swapaxes(torque, 0, 1)
    zeros = np.zeros((batch, n))

    def run_mujoco(threads: int) -> Any:
        datas = [mujoco.MjData(m) for _ in range(threads)]
        return lambda: mj_rollout.rollout(m, datas, init, torque, persistent_pool=threads > 1)

    def run_public(threads: int) -> Callable[[], ff.Trajectory]:
        def go() -> ff.Trajectory:
            os.environ["FREEFLYER_THREADS"] = str(threads)
            try:
                return rollout(model, states, steps * DT, dt=DT, controller=pd, output_period=DT)
            finally:
                del os.environ["FREEFLYER_THREADS"]

        return go

    def run_kernel(threads: int) -> Callable[[], Any]:
        return lambda: kernels.rollout_pd(x0, DT, steps, 1, 1, zeros, zeros, zeros, None, feed, None, n_threads=threads)

    # verification: final joint angles of the two engines
    mj_state, _ = run_mujoco(cores)()
    ours = run_public(cores)()
    nq = m.nq
    err = float(np.max(np.abs(mj_state[:, -1, 1 + 7 : 1 + nq] - ours.q[-1])))
    if err > 1e-6:
        raise AssertionError(f"{model.name}: freeflyer and mujoco.rollout disagree by {err:.1e} rad")
    out: dict[str, Any] = {
        "batch": batch,
        "steps": steps,
        "threads": cores,
        "controls": "open-loop joint torques I_jj sin(pi t + phase_bj), the same array for both engines",
        "verification": {"max_abs_q_final_vs_mujoco_rollout": err},
    }
    items = batch * steps
    for threads in sorted({1, cores}):
        log(f"[{model.name}] rollouts, {batch} x {steps} steps, {threads} thread(s)")
        mj = rate(best_of(run_mujoco(threads), repeats), items, "trajectory_steps")
        pub = rate(best_of(run_public(threads), repeats), items, "trajectory_steps")
        ker = rate(best_of(run_kernel(threads), repeats), items, "trajectory_steps")
        out[f"threads_{threads}"] = {
            "mujoco_rollout": mj,
            "freeflyer_rollout": pub,
            "freeflyer_kernel": ker,
            "ratio": pub["trajectory_steps_per_s"] / mj["trajectory_steps_per_s"],
            "ratio_kernel": ker["trajectory_steps_per_s"] / mj["trajectory_steps_per_s"],
        }
    numpy_steps = 20
    log(f"[{model.name}] rollouts, numpy back end ({batch} x {numpy_steps} steps)")
    np_rate = rate(
        best_of(lambda: rollout(model, states, numpy_steps * DT, dt=DT, controller=pd, output_period=DT, backend="numpy"), 1),
        batch * numpy_steps,
        "trajectory_steps",
    )
    out["freeflyer_rollout_numpy"] = np_rate
    out["ratio_numpy"] = np_rate["trajectory_steps_per_s"] / out[f"threads_{cores}"]["mujoco_rollout"]["trajectory_steps_per_s"]
    out["ratio"] = out[f"threads_{cores}"]["ratio"]
    return out


# ----------------------------------------------------------------- compile time
_COLD = """
import json, sys, time
import freeflyer as ff
from freeflyer.mechanics import _compiled
out = {}
for key, make in (("papadopoulos1992", lambda: ff.models.papadopoulos1992(arms=2)), ("spacecraft_7dof", ff.models.spacecraft_7dof)):
    t0 = time.perf_counter()
    k = _compiled.kernels(make())
    trace = time.perf_counter() - t0
    drivers = k.warm()
    out[key] = {"trace_and_generate_s": trace, "drivers_s": drivers, "total_s": time.perf_counter() - t0, "n_ops": k.n_ops}
print(json.dumps(out))
"""


def cold_compile() -> dict[str, Any]:
    """Compile every kernel of both systems in a fresh process with an empty cache folder."""
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, FREEFLYER_CACHE_DIR=tmp)
        t0 = time.perf_counter()
        done = subprocess.run([sys.executable, "-c", _COLD], env=env, capture_output=True, text=True, check=True)
        result: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
        result["process_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        again = subprocess.run([sys.executable, "-c", _COLD], env=env, capture_output=True, text=True, check=True)
        result["cached"] = json.loads(again.stdout.strip().splitlines()[-1])
        result["cached_process_s"] = time.perf_counter() - t0
    return result


# ----------------------------------------------------------------- driver
def run(quick: bool, log: Callable[[str], None]) -> dict[str, Any]:
    """``run.py`` entry."""
    if not _compiled.available():
        raise RuntimeError("bench_dynamics needs numba (pip install freeflyer[fast])")
    configs, numpy_configs, pin_configs = (20_000, 2_000, 2_000) if quick else (200_000, 10_000, 20_000)
    steps, numpy_steps = (500, 20) if quick else (3000, 50)
    batch, rollout_steps = 1024, (100 if quick else 500)
    repeats = 3 if quick else 7  # best of 7: this 2-core VM is noisy (single runs vary by 30%)
    report: dict[str, Any] = {
        "benchmark": "dynamics: H+, C+, forward dynamics vs a Pinocchio loop; RK4 simulation vs MuJoCo; batched rollouts vs mujoco.rollout",
        "machine": machine_info(),
        "settings": {
            "configs": configs,
            "numpy_configs": numpy_configs,
            "pinocchio_configs": pin_configs,
            "simulation_steps": steps,
            "rollout_batch": batch,
            "rollout_steps": rollout_steps,
            "repeats": repeats,
            "dt": DT,
            "threads": _compiled.threads(),
            "lanes": _compiled.LANES,
        },
        "targets": {"simulation_ratio": TARGET_SIMULATION, "rollout_ratio": TARGET_ROLLOUT},
        "notes": [
            "*_per_s: items / best wall-clock time of `repeats` calls; ratios = freeflyer / reference, both measured in this run.",
            "freeflyer_numba: the compiled kernels of freeflyer.mechanics._compiled; "
            "freeflyer_numpy: the numpy reference path (single-threaded).",
            "Per configuration: freeflyer's batched calls use all threads; the Pinocchio loop is one Python thread (as a user writes it).",
            "One simulation: single-threaded everywhere. ratio_compiled_loop: Kernels.simulate (controller every step, RK4 compiled) vs "
            "MuJoCo mj_step with the same Python controller; ratio_simulate: the public freeflyer.simulate (validation, bookkeeping).",
            "Rollouts: mujoco.rollout with one MjData per thread (persistent pool when > 1 thread) vs freeflyer.rollout "
            "(JointPD feed-forward, compiled, blocks of trajectories on a thread pool), both recording every state.",
        ],
        "systems": {},
    }
    for key, (description, model) in systems().items():
        t0 = time.perf_counter()
        kernels = _compiled.kernels(model)
        first = kernels.warm()
        entry: dict[str, Any] = {
            "description": description,
            "n_joints": model.n_joints,
            "n_ops": kernels.n_ops,
            "first_use_s": {"trace_and_generate": kernels.trace_seconds, **first, "total": time.perf_counter() - t0},
        }
        entry["per_configuration"] = per_configuration(model, configs, numpy_configs, pin_configs, repeats, log)
        entry["simulation"] = single_simulation(model, steps, numpy_steps, repeats, log)
        entry["rollout"] = batched_rollouts(model, batch, rollout_steps, repeats, log)
        report["systems"][key] = entry
    if not quick:
        log("cold compile (fresh process, empty cache) of both systems' kernels")
        report["compile"] = cold_compile()
    if hasattr(os, "getloadavg"):
        report["machine"]["load_average_at_end"] = list(os.getloadavg())
    return report


def table(report: dict[str, Any]) -> str:
    lines = []
    head = f"{'system':18s} {'item':34s} {'freeflyer /s':>14s} {'reference /s':>14s} {'ratio':>8s} {'numpy ratio':>12s}"
    lines += [head, "-" * len(head)]
    for key, res in report["systems"].items():
        pc = res["per_configuration"]
        for item, label in (
            ("hplus", "H+ (configs) vs pin.crba loop"),
            ("cplus", "C+ (configs) vs pin.nonLinearEffects"),
            ("fd", "FD (configs) vs pin.aba loop"),
        ):
            r = pc[item]
            lines.append(
                f"{key:18s} {label:34s} {r['freeflyer_numba']['configs_per_s']:14,.0f} {r['pinocchio_loop']['configs_per_s']:14,.0f} "
                f"{r['ratio']:7.1f}x {r['ratio_numpy']:11.2f}x"
            )
        s = res["simulation"]
        mj = s["mujoco_python_controller"]["steps_per_s"]
        loop = s["freeflyer_compiled_loop"]["steps_per_s"]
        lines.append(f"{key:18s} {'RK4 loop + Py PD (steps) vs MuJoCo':34s} {loop:14,.0f} {mj:14,.0f} {s['ratio_compiled_loop']:7.2f}x")
        lines.append(
            f"{key:18s} {'ff.simulate + Py PD (steps)':34s} {s['freeflyer_simulate_numba']['steps_per_s']:14,.0f} {mj:14,.0f} "
            f"{s['ratio_simulate']:7.2f}x {s['ratio_simulate_numpy']:11.4f}x"
        )
        ro = res["rollout"]
        for name, sub in ro.items():
            if not name.startswith("threads_"):
                continue
            label = "rollout 1024 (traj-steps) " + name.replace("_", "=")
            ours = sub["freeflyer_rollout"]["trajectory_steps_per_s"]
            theirs = sub["mujoco_rollout"]["trajectory_steps_per_s"]
            lines.append(f"{key:18s} {label:34s} {ours:14,.0f} {theirs:14,.0f} {sub['ratio']:7.1f}x")
        slow = ro["freeflyer_rollout_numpy"]["trajectory_steps_per_s"]
        lines.append(f"{key:18s} {'  (numpy back end rollout)':34s} {slow:14,.0f} {'':14s} {'':8s} {ro['ratio_numpy']:11.4f}x")
    lines.append("")
    targets = (
        f"one simulation >= {TARGET_SIMULATION:.0f}x MuJoCo with a Python controller; rollouts >= {TARGET_ROLLOUT:.0f}x mujoco.rollout"
    )
    lines.append("targets: " + targets)
    if "compile" in report:
        c = report["compile"]
        lines.append(
            "cold compile (all kernels, fresh cache): "
            + ", ".join(f"{k} {v['total_s']:.1f} s" for k, v in c.items() if isinstance(v, dict) and "total_s" in v)
            + f"; cached: {c['cached_process_s']:.1f} s for the whole process"
        )
    machine = report["machine"]
    lines.append(f"machine: {machine.get('cpu')}, {machine['cpu_count']} cpus, load average {machine.get('load_average_at_start')}")
    return "\n".join(lines)
