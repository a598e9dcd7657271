"""Dynamics and simulation benchmark: freefloat against Pinocchio and MuJoCo, in one run.

For the 1992 two-arm system and the 7-DOF spacecraft (``ff.models.spacecraft_7dof``):

1. **Per configuration** (batched): H+ (1991 eq. 15), C+ (eq. 19) and forward dynamics for
   ``configs`` random states, one batched public call each (``ff.system_inertia_matrix``,
   ``ff.nonlinear_forces``, ``ff.forward_dynamics``: freefloat's one engine), against the same
   quantities from Pinocchio in a Python loop (``pin.crba``, ``pin.nonLinearEffects``,
   ``pin.aba`` with a free-flyer root, one ``Data`` reused).
2. **One simulation**, fixed-step RK4 at 1 ms with a joint PD controller written in numpy and
   called every step (the same function for both): MuJoCo (``mj_step``, integrator RK4, timestep
   1 ms, the controller writing ``data.ctrl`` before each step) against the public
   ``ff.simulate(..., fixed_step=1e-3)`` (the controller in Python, the RK4 steps compiled).
3. **Batched rollouts** of 1024 trajectories with ``ff.JointPD`` in the loop (zero gains and an
   open-loop joint-torque profile as feed-forward, so that both engines get the same torques),
   every state recorded (as ``mujoco.rollout`` does): ``mujoco.rollout`` with one ``MjData`` per
   thread against ``ff.rollout`` (the whole batch compiled, trajectories on numba threads); both
   on 2 threads and on 1.

Everything is verified before it is timed (forward dynamics == Pinocchio's ABA to 1e-9, the
simulations and rollouts == MuJoCo's to 1e-6). Throughputs are best-of-``repeats`` wall-clock
rates; ratios are freefloat / reference, both measured in this run.
"""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Callable
from typing import Any

import numba
import numpy as np

import freefloat as ff
from bench_core import best_of, machine_info, machine_line, panda_model, set_threads, thread_counts
from freefloat.core.state import State
from freefloat.engine.specialise.build import generic
from freefloat.io.mujoco_bridge import from_mujoco_state, mujoco_state, to_mujoco
from freefloat.io.oracles import acceleration_from_pinocchio, pinocchio_configuration, pinocchio_velocity, to_pinocchio
from freefloat.simulation.pd import JointPD
from freefloat.simulation.simulate import rollout, simulate

DT = 1e-3
TARGET_SIMULATION = 1.0
TARGET_ROLLOUT = 10.0


def systems() -> dict[str, tuple[str, ff.Model]]:
    return {
        "papadopoulos1992": ("Papadopoulos 1992 two-arm planar system (N = 4)", ff.models.papadopoulos1992(arms=2)),
        "spacecraft_7dof": ("1500 kg spacecraft with a 7-DOF iiwa-style arm, 3D (N = 7)", ff.models.spacecraft_7dof()),
        # without its joint damping (the URDF's <dynamics damping>, modelled since issue 21): Pinocchio's ABA and RNEA leave it out
        "panda_prismatic": (
            "Franka Panda URDF under a 500 kg spacecraft: 7 revolute + 2 prismatic fingers (N = 9), without its joints' damping",
            panda_model().without_passive(),
        ),
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
@numba.njit(parallel=True)
def _write_all(block: np.ndarray) -> None:  # pragma: no cover - compiled
    for i in numba.prange(block.shape[0]):
        block[i] = 1.0


def output_write_bound(per_config: int, configs: int, repeats: int) -> dict[str, Any]:
    """What writing a batched call's output alone costs: ``configs`` x ``per_config`` float64 values written once by all
    of numba's threads (best of ``repeats``), nothing computed. ``fresh``: into a new array each time (its pages zeroed
    by the system at the first write, then written); ``reused``: into memory written before (a caller's ``out=``). No
    call that returns a new array can run faster than ``fresh``, none into ``out=`` faster than ``reused``."""
    size = per_config * configs
    _write_all(np.empty(8))
    fresh = best_of(lambda: _write_all(np.empty(size)), repeats)
    block = np.empty(size)
    _write_all(block)
    reused = best_of(lambda: _write_all(block), repeats)
    if not (block == 1.0).all():
        raise AssertionError("the write bound wrote the wrong values")
    out: dict[str, Any] = {"bytes_per_config": 8 * per_config}
    for name, timing in (("fresh", fresh), ("reused", reused)):
        out[name] = {"GB_per_s": 8 * size / timing["best_wall_s"] / 1e9, "configs_per_s": configs / timing["best_wall_s"]}
    return out


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


def public_calls(model: ff.Model, x: np.ndarray, tau: np.ndarray) -> dict[str, Callable[[], Any]]:
    n = model.n_joints
    q = x[:, 13 : 13 + n]
    velocity = np.concatenate([x[:, 3:6], x[:, 10:13], x[:, 13 + n :]], axis=1)
    return {
        "hplus": lambda: ff.system_inertia_matrix(model, q),
        "cplus": lambda: ff.nonlinear_forces(model, q, velocity),
        "fd": lambda: ff.forward_dynamics(model, q, velocity, tau),
    }


def per_configuration(model: ff.Model, configs: int, pin_configs: int, repeats: int, log: Callable[[str], None]) -> dict[str, Any]:
    x, tau = random_states(model, configs, 2024)
    ours = public_calls(model, x, tau)
    for fn in ours.values():  # first calls: load the engine's kernels
        fn()
    # verification: forward dynamics == Pinocchio's ABA (1e-9 of the largest entry)
    pin_loop = PinocchioLoop(model)
    items = pin_loop.inputs(x[:pin_configs], tau[:pin_configs])
    fd_ours = ours["fd"]()
    worst = 0.0
    for i in range(0, pin_configs, max(1, pin_configs // 20)):
        q = x[i, 13 : 13 + model.n_joints]
        pin_acc = pin_loop.loop("fd", [items[i]])[0]
        ref_acc = acceleration_from_pinocchio(model, pin_loop.pm, q, items[i][1], pin_acc)
        worst = max(worst, float(np.max(np.abs(fd_ours[i] - ref_acc)) / np.max(np.abs(ref_acc))))
    if worst > 1e-9:
        raise AssertionError(f"{model.name}: forward dynamics differs from Pinocchio's ABA by {worst:.1e}")
    out: dict[str, Any] = {"verification": {"fd_vs_pinocchio_aba": worst}, "configs": configs, "pinocchio_configs": pin_configs}
    for key in ("hplus", "cplus", "fd"):
        log(f"[{model.name}] {key}: freefloat ({configs:,}), Pinocchio loop ({pin_configs:,})")
        with generic():
            a = rate(best_of(ours[key], repeats), configs, "configs")
        c = rate(best_of(lambda key=key: pin_loop.loop(key, items), repeats), pin_configs, "configs")
        out[key] = {"freefloat": a, "pinocchio_loop": c, "ratio": a["configs_per_s"] / c["configs_per_s"]}
    # the same calls on the kernels specialised to the structure (compiled once per machine; the library does it by itself
    # after a few seconds of such work, here up front so that the figures are reproducible)
    t0 = time.perf_counter()
    ff.mechanics.specialise(model, ["hplus", "inverse", "forward"])
    out["specialise_dynamics_s"] = time.perf_counter() - t0
    fd_fast = ours["fd"]()
    out["verification"]["fd_specialised_vs_generic"] = float(np.max(np.abs(fd_fast - fd_ours)) / np.max(np.abs(fd_ours)))
    for key in ("hplus", "cplus", "fd"):
        log(f"[{model.name}] {key}: freefloat specialised ({configs:,})")
        a = rate(best_of(ours[key], repeats), configs, "configs")
        out[key]["freefloat_specialised"] = a
        out[key]["ratio_specialised"] = a["configs_per_s"] / out[key]["pinocchio_loop"]["configs_per_s"]
    # H+ writes (6 + N)^2 values a configuration, far more than C+ and FD (6 + N): the bound of its output alone
    bound = output_write_bound((6 + model.n_joints) ** 2, configs, repeats)
    for name in ("fresh", "reused"):
        bound[name]["ratio"] = bound[name]["configs_per_s"] / out["hplus"]["pinocchio_loop"]["configs_per_s"]
        bound[name]["specialised_share"] = out["hplus"]["freefloat_specialised"]["configs_per_s"] / bound[name]["configs_per_s"]
    out["hplus"]["output_write_bound"] = bound
    return out


# ----------------------------------------------------------------- 2. one simulation with a Python controller
def pd_gains(model: ff.Model, q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """kp = wn^2 I_j, kd = 2 zeta wn I_j with I_j the joint's diagonal entry of H+ at q0 (wn = 20 rad/s, zeta = 0.7)."""
    inertia = np.diagonal(ff.system_inertia_matrix(model, q0))[6:]
    wn, zeta = 20.0, 0.7
    return wn**2 * inertia, 2.0 * zeta * wn * inertia


def single_simulation(model: ff.Model, steps: int, repeats: int, log: Callable[[str], None]) -> dict[str, Any]:
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

    def controller(t: float, s: State) -> np.ndarray:
        return pd(s.q, s.qdot)

    def run_freefloat() -> ff.Trajectory:
        # the MuJoCo model has no joint limits: both run without stops (freefloat flags crossings only)
        return simulate(model, state, steps * DT, controller, fixed_step=DT, output_period=stride * DT, joint_limits="flag")

    # verification: the final joint angles of both engines
    kept = run_mujoco()
    final = from_mujoco_state(model, kept[-1][: m.nq], kept[-1][m.nq :])
    traj = run_freefloat()
    err_mj = float(np.max(np.abs(traj.q[-1] - final.q)))
    if err_mj > 1e-6:
        raise AssertionError(f"{model.name}: ff.simulate and MuJoCo disagree by {err_mj:.1e} rad")
    log(f"[{model.name}] one simulation, {steps} steps of 1 ms, PD controller in Python, best of {repeats}")
    mj = rate(best_of(run_mujoco, repeats), steps, "steps")
    ours = rate(best_of(run_freefloat, repeats), steps, "steps")
    return {
        "steps": steps,
        "controller": "tau = kp (q_ref - q) - kd qdot, numpy, every step (kp = 400 I_jj, kd = 28 I_jj: wn = 20 rad/s, zeta = 0.7)",
        "verification": {"max_abs_q_final_vs_mujoco": err_mj},
        "mujoco_python_controller": mj,
        "freefloat_simulate": ours,
        "ratio": ours["steps_per_s"] / mj["steps_per_s"],
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
    pd = JointPD(kp=0.0, kd=0.0, feedforward=np.swapaxes(torque, 0, 1), feedforward_period=DT)
    counts = thread_counts()

    def run_mujoco(threads: int) -> Any:
        datas = [mujoco.MjData(m) for _ in range(threads)]
        return lambda: mj_rollout.rollout(m, datas, init, torque, persistent_pool=threads > 1)

    def run_freefloat(threads: int) -> Callable[[], ff.Trajectory]:
        def go() -> ff.Trajectory:
            old = set_threads(threads)
            try:
                return rollout(model, states, steps * DT, dt=DT, controller=pd, output_period=DT)
            finally:
                set_threads(old)

        return go

    # the specialised rollout kernel of this structure (compiled once per machine; loaded from the cache afterwards)
    t0 = time.perf_counter()
    ff.mechanics.specialise(model, ["rollout"])
    specialise_s = time.perf_counter() - t0
    log(f"[{model.name}] specialised rollouts ready in {specialise_s:.2f} s")
    # verification: final joint angles of the two engines (specialised and generic freefloat)
    mj_state, _ = run_mujoco(counts[0])()
    nq = m.nq
    errs = []
    for engine in (contextlib.nullcontext(), generic()):
        with engine:
            ours = run_freefloat(counts[0])()
        errs.append(float(np.max(np.abs(mj_state[:, -1, 1 + 7 : 1 + nq] - ours.q[-1]))))
    err = max(errs)
    if err > 1e-6:
        raise AssertionError(f"{model.name}: freefloat and mujoco.rollout disagree by {err:.1e} rad")
    out: dict[str, Any] = {
        "specialise_s": specialise_s,
        "batch": batch,
        "steps": steps,
        "threads": counts,
        "controls": "ff.JointPD in the loop with zero gains and the open-loop joint torques I_jj sin(pi t + phase_bj) as "
        "feed-forward; the same torque array goes to mujoco.rollout",
        "verification": {"max_abs_q_final_vs_mujoco_rollout": err},
    }
    items = batch * steps
    for threads in counts:
        log(f"[{model.name}] rollouts, {batch} x {steps} steps, {threads} thread(s), best of {repeats}")
        mj = rate(best_of(run_mujoco(threads), repeats), items, "trajectory_steps")
        pub = rate(best_of(run_freefloat(threads), repeats), items, "trajectory_steps")
        with generic():
            gen = rate(best_of(run_freefloat(threads), repeats), items, "trajectory_steps")
        out[f"threads_{threads}"] = {
            "mujoco_rollout": mj,
            "freefloat_rollout": pub,
            "ratio": pub["trajectory_steps_per_s"] / mj["trajectory_steps_per_s"],
        }
        out[f"generic_threads_{threads}"] = {
            "mujoco_rollout": mj,
            "freefloat_rollout": gen,
            "ratio": gen["trajectory_steps_per_s"] / mj["trajectory_steps_per_s"],
        }
    out["ratio"] = out[f"threads_{counts[0]}"]["ratio"]
    return out


# ----------------------------------------------------------------- driver
def run(quick: bool, log: Callable[[str], None]) -> dict[str, Any]:
    """``run.py`` entry."""
    configs, pin_configs = (20_000, 2_000) if quick else (100_000, 20_000)
    steps = 500 if quick else 3000
    batch, rollout_steps = 1024, (100 if quick else 500)
    repeats = 3 if quick else 5  # best of 5: this 2-core VM is noisy (single runs vary by 30%)
    report: dict[str, Any] = {
        "benchmark": "dynamics: H+, C+, forward dynamics vs a Pinocchio loop; RK4 simulation vs MuJoCo; batched rollouts vs mujoco.rollout",
        "machine": machine_info(),
        "settings": {
            "configs": configs,
            "pinocchio_configs": pin_configs,
            "simulation_steps": steps,
            "rollout_batch": batch,
            "rollout_steps": rollout_steps,
            "repeats": repeats,
            "dt": DT,
            "threads": thread_counts(),
        },
        "targets": {"simulation_ratio": TARGET_SIMULATION, "rollout_ratio": TARGET_ROLLOUT},
        "notes": [
            "*_per_s: items / best wall-clock time of `repeats` calls; ratios = freefloat / reference, both measured in this run.",
            "freefloat: the public calls. H+, C+, FD and one simulation run the generic kernels (the model as arrays, compiled "
            "once per machine and cached on disk); rollouts also the kernels specialised to the structure (below).",
            "Per configuration: freefloat's batched calls on numba's threads (all of them); the Pinocchio loop is one Python thread.",
            "One simulation: ff.simulate(..., fixed_step=1e-3) with the controller in Python every step (the RK4 steps compiled) vs "
            "MuJoCo mj_step with the same Python controller; single-threaded on both sides.",
            "Rollouts: mujoco.rollout with one MjData per thread (persistent pool when > 1 thread) vs ff.rollout "
            "(JointPD compiled in the loop, trajectories on numba threads), both recording every state; threads_<k>: k threads each, "
            "the rollout kernel specialised to the model's structure (ff.mechanics.specialise; specialise_s its compile or load); "
            "generic_threads_<k>: the generic kernels, same run.",
            "hplus.output_write_bound: H+'s output (configs x (6 + N)^2 float64) written once by all of numba's threads, "
            "nothing computed, into a new array (fresh: a call without out=) or into memory written before (reused: "
            "a call with out=): "
            "the fastest an H+ batch can run on "
            "this machine (its ratio against the same Pinocchio loop), and the specialised H+'s share of it.",
        ],
        "systems": {},
    }
    for key, (description, model) in systems().items():
        entry: dict[str, Any] = {"description": description, "n_joints": model.n_joints}
        entry["per_configuration"] = per_configuration(model, configs, pin_configs, repeats, log)
        entry["simulation"] = single_simulation(model, steps, repeats, log)
        entry["rollout"] = batched_rollouts(model, batch, rollout_steps, repeats, log)
        report["systems"][key] = entry
    if hasattr(os, "getloadavg"):
        report["machine"]["load_average_at_end"] = list(os.getloadavg())
    return report


def table(report: dict[str, Any]) -> str:
    lines = []
    head = f"{'system':18s} {'item':40s} {'freefloat /s':>14s} {'reference /s':>14s} {'ratio':>8s} {'check':>9s}"
    lines += [head, "-" * len(head)]
    for key, res in report["systems"].items():
        pc = res["per_configuration"]
        for item, label in (
            ("hplus", "H+ (configs) vs pin.crba loop"),
            ("cplus", "C+ (configs) vs pin.nonLinearEffects"),
            ("fd", "FD (configs) vs pin.aba loop"),
        ):
            r = pc[item]
            check = f"{pc['verification']['fd_vs_pinocchio_aba']:9.1e}" if item == "fd" else ""
            lines.append(
                f"{key:18s} {label:40s} {r['freefloat']['configs_per_s']:14,.0f} {r['pinocchio_loop']['configs_per_s']:14,.0f} "
                f"{r['ratio']:7.1f}x {check:>9s}"
            )
            if "freefloat_specialised" in r:
                lines.append(
                    f"{key:18s} {label + ' (specialised)':40s} {r['freefloat_specialised']['configs_per_s']:14,.0f} "
                    f"{r['pinocchio_loop']['configs_per_s']:14,.0f} {r['ratio_specialised']:7.1f}x"
                )
            for name in ("fresh", "reused") if "output_write_bound" in r else ():
                b = r["output_write_bound"][name]
                lines.append(
                    f"{key:18s} {'H+ output written alone, ' + name + ' memory':40s} {b['configs_per_s']:14,.0f} "
                    f"{r['pinocchio_loop']['configs_per_s']:14,.0f} {b['ratio']:7.1f}x  ({b['GB_per_s']:.1f} GB/s; "
                    f"specialised H+ at {100 * b['specialised_share']:.0f}% of it)"
                )
        s = res["simulation"]
        lines.append(
            f"{key:18s} {'ff.simulate + Py PD (steps) vs MuJoCo':40s} {s['freefloat_simulate']['steps_per_s']:14,.0f} "
            f"{s['mujoco_python_controller']['steps_per_s']:14,.0f} {s['ratio']:7.2f}x "
            f"{s['verification']['max_abs_q_final_vs_mujoco']:9.1e}"
        )
        ro = res["rollout"]
        for name, sub in ro.items():
            if "threads_" not in name:
                continue
            engine = "generic " if name.startswith("generic") else ""
            label = f"{engine}rollout {ro['batch']}x{ro['steps']} (traj-steps) thr={name.rsplit('_', 1)[1]}"
            ours = sub["freefloat_rollout"]["trajectory_steps_per_s"]
            theirs = sub["mujoco_rollout"]["trajectory_steps_per_s"]
            lines.append(
                f"{key:18s} {label:40s} {ours:14,.0f} {theirs:14,.0f} {sub['ratio']:7.1f}x "
                f"{ro['verification']['max_abs_q_final_vs_mujoco_rollout']:9.1e}"
            )
    lines.append("")
    lines.append(
        f"targets: one simulation >= {TARGET_SIMULATION:.0f}x MuJoCo with a Python controller; "
        f"rollouts >= {TARGET_ROLLOUT:.0f}x mujoco.rollout; check = max error vs the reference (FD relative, q in rad)"
    )
    lines.append(machine_line(report["machine"]))
    return "\n".join(lines)
