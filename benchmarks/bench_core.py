"""Core benchmark: J* and det J* over many random configurations, freefloat against a Pinocchio loop.

For each system, in the same process and run:

* freefloat: one batched call ``ff.generalized_jacobian(model, Q)`` and one
  ``ff.jacobian_determinant(model, Q)`` (``ff.manipulability`` for a redundant arm, whose J* is
  not square) on Q of shape (configs, N); best of ``repeats`` wall-clock times;
* Pinocchio: a Python loop over a subsample, written the way a user would write it: per
  configuration ``computeCentroidalMap``, ``computeJointJacobians``, ``updateFramePlacements``,
  ``getFrameJacobian(..., LOCAL_WORLD_ALIGNED)`` per end effector, then
  J* = J_q - J_b A_b^-1 A_q with numpy and ``np.linalg.det`` (sqrt det(J* J*ᵀ) for the redundant
  arm); best of ``repeats`` as well;
* freefloat's one engine (generic numba kernels, compiled once per machine and cached on disk),
  on 2 numba threads and on 1 (``numba.set_num_threads``).

Before timing, J* and the determinant of both agree on a sample of configurations to 1e-10
(relative to the largest entry), else the benchmark stops. Results: configurations per second,
the ratios freefloat / Pinocchio loop, machine information, as a dict for ``run.py`` to write.
"""

from __future__ import annotations

import contextlib
import os
import platform
import re
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

import freefloat as ff
from freefloat.engine.specialise.build import generic
from freefloat.io.oracles import pinocchio_configuration, to_pinocchio
from freefloat.mechanics.jacobians import _singularity_row_indices

#: Agreement required between freefloat and Pinocchio before timing (relative to the largest entry).
VERIFY_RTOL = 1e-10
TARGET_RATIO = 100.0
GOAL_RATIO = 500.0


@dataclass(frozen=True)
class System:
    key: str
    description: str
    model: ff.Model
    square: bool  # J* (singularity rows) square: det J*; else manipulability sqrt det(J* J*ᵀ)

    @property
    def det_name(self) -> str:
        return "det J*" if self.square else "manipulability sqrt(det(J* J*^T))"

    def freefloat_det(self, q: np.ndarray) -> np.ndarray:
        return ff.jacobian_determinant(self.model, q) if self.square else ff.manipulability(self.model, q)


def panda_model() -> ff.Model:
    """The Panda of example-robot-data under a spacecraft (tests/robots.py), tool frame panda_hand_tcp, with its
    second finger made independent (its ``<mimic>`` removed here): N = 9, as in the timings published before mimic
    joints were read, and a model ``to_pinocchio`` builds."""
    import sys
    import tempfile
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from robots import REAL_ROBOTS, spacecraft_urdf

    relative, tools = REAL_ROBOTS["panda"]
    with tempfile.TemporaryDirectory() as folder:
        path = spacecraft_urdf(relative, Path(folder))
        path.write_text(re.sub(r"<mimic[^>]*/>", "", path.read_text(encoding="utf-8")), encoding="utf-8")
        return ff.load(path, end_effectors=tools)


def systems() -> list[System]:
    paper = ff.models.papadopoulos1992()
    arm = ff.models.spacecraft_7dof()
    return [
        System(
            "papadopoulos1992",
            "Papadopoulos 1992 two-arm planar system (N = 4; J* 12 x 4, det over the planar rows [vx, vy] of both end effectors: 4 x 4)",
            paper,
            True,
        ),
        System(
            "panda_prismatic",
            "Franka Panda (example-robot-data URDF) under a 500 kg spacecraft: 7 revolute joints and 2 prismatic fingers "
            "(N = 9; J* 6 x 9 at panda_hand_tcp: 'det' is the manipulability)",
            panda_model(),
            False,
        ),
        System(
            "spacecraft_7dof",
            "1500 kg spacecraft with a 7-DOF iiwa-style arm, 3D (N = 7; J* 6 x 7 is not square: 'det' is the manipulability "
            "sqrt(det(J* J*^T)), ff.manipulability)",
            arm,
            False,
        ),
    ]


class PinocchioLoop:
    """J* from Pinocchio's centroidal momentum map, one configuration at a time."""

    def __init__(self, system: System) -> None:
        import pinocchio as pin

        self.pin = pin
        self.system = system
        model = system.model
        self.pm = to_pinocchio(model)
        self.data = self.pm.createData()
        self.frames = [self.pm.getFrameId(name) for name in model.end_effector_names]
        self.base = pinocchio_configuration(model, np.zeros(model.n_joints))
        self.rows = _singularity_row_indices(model)

    def jstar(self, q: np.ndarray) -> np.ndarray:
        pin, pm, data = self.pin, self.pm, self.data
        config = self.base.copy()
        config[7:] = q
        centroidal = pin.computeCentroidalMap(pm, data, config)
        pin.computeJointJacobians(pm, data, config)
        pin.updateFramePlacements(pm, data)
        jac = np.vstack([pin.getFrameJacobian(pm, data, f, pin.LOCAL_WORLD_ALIGNED) for f in self.frames])
        return jac[:, 6:] - jac[:, :6] @ np.linalg.solve(centroidal[:, :6], centroidal[:, 6:])

    def det(self, q: np.ndarray) -> float:
        jac = self.jstar(q)[self.rows]
        if self.system.square:
            return float(np.linalg.det(jac))
        return float(np.sqrt(np.linalg.det(jac @ jac.T)))

    def sigma_min(self, q: np.ndarray) -> float:
        return float(np.linalg.svd(self.jstar(q)[self.rows], compute_uv=False)[-1])

    def loop(self, which: str, qs: np.ndarray) -> list[Any]:
        fn = {"jstar": self.jstar, "det": self.det, "sigma_min": self.sigma_min}[which]
        return [fn(q) for q in qs]


def best_of(fn: Callable[[], Any], repeats: int) -> dict[str, Any]:
    """Best wall-clock and process-CPU time over ``repeats`` calls."""
    wall, cpu = [], []
    for _ in range(repeats):
        c0, t0 = time.process_time(), time.perf_counter()
        result = fn()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
        del result
    return {"wall_s": wall, "cpu_s": cpu, "best_wall_s": min(wall), "best_cpu_s": min(cpu)}


def rate(timing: dict[str, Any], n: int) -> dict[str, Any]:
    out = dict(timing)
    out["configs"] = n
    out["configs_per_s"] = n / timing["best_wall_s"]
    out["cpu_configs_per_s"] = n / timing["best_cpu_s"] if timing["best_cpu_s"] > 0 else None
    return out


def verify(system: System, loop: PinocchioLoop, q: np.ndarray, batch: int) -> dict[str, float]:
    """freefloat (as benchmarked: one batch of ``batch`` configurations) against Pinocchio on a sample."""
    model = system.model
    jstar = ff.generalized_jacobian(model, q[:batch])
    dets = system.freefloat_det(q[:batch])
    smallest = ff.mechanics.jacobian_measure(model, q[:batch], None, "sigma_min")
    picks = np.unique(np.concatenate([[0, batch - 1], np.random.default_rng(1).integers(0, batch, size=30)]))
    err_j = err_d = err_s = 0.0
    scale_d = scale_s = 0.0
    for i in picks:
        ref = loop.jstar(q[i])
        err_j = max(err_j, float(np.max(np.abs(jstar[i] - ref)) / np.max(np.abs(ref))))
        ref_d = loop.det(q[i])
        err_d = max(err_d, abs(float(dets[i]) - ref_d))
        scale_d = max(scale_d, abs(ref_d))
        ref_s = loop.sigma_min(q[i])
        err_s = max(err_s, abs(float(smallest[i]) - ref_s))
        scale_s = max(scale_s, ref_s)
    err_d /= max(scale_d, 1e-300)
    err_s /= max(scale_s, 1e-300)
    if not (err_j <= VERIFY_RTOL and err_d <= VERIFY_RTOL and err_s <= VERIFY_RTOL):
        raise AssertionError(
            f"{system.key}: freefloat and Pinocchio disagree (J* {err_j:.1e}, {system.det_name} {err_d:.1e}, sigma_min {err_s:.1e} "
            f"> {VERIFY_RTOL})"
        )
    return {"max_rel_err_jstar": err_j, "max_rel_err_det": err_d, "max_rel_err_sigma_min": err_s, "configurations_checked": len(picks)}


def machine_info() -> dict[str, Any]:
    import numpy

    info: dict[str, Any] = {
        "cpu_count": os.cpu_count(),
        "platform": platform.platform(),
        "machine": platform.machine(),
        "python": platform.python_version(),
        "numpy": numpy.__version__,
        "freefloat": ff.__version__,
    }
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            names = [line.split(":", 1)[1].strip() for line in f if line.startswith("model name")]
        info["cpu"] = names[0] if names else platform.processor()
    except OSError:
        info["cpu"] = platform.processor()
    try:
        import pinocchio

        info["pinocchio"] = pinocchio.__version__
    except ImportError:
        info["pinocchio"] = None
    try:
        import numba

        info["numba"] = numba.__version__
        info["numba_threads"] = numba.get_num_threads()
    except ImportError:
        info["numba"] = None
    if hasattr(os, "getloadavg"):
        info["load_average_at_start"] = list(os.getloadavg())
    names = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")
    info["threads_env"] = {k: os.environ[k] for k in names if k in os.environ}
    return info


def set_threads(threads: int) -> int:
    """numba's thread count for the calls that follow (capped at numba's maximum); returns the previous one."""
    import numba

    old = numba.get_num_threads()
    numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))
    return old


def thread_counts() -> list[int]:
    """The thread counts every multi-threaded figure is measured at: 2 (or all cores, if fewer) and 1."""
    import numba

    most = min(2, numba.config.NUMBA_NUM_THREADS)
    return sorted({most, 1}, reverse=True)


def bench_system(system: System, configs: int, pinocchio_configs: int, repeats: int, log: Callable[[str], None]) -> dict[str, Any]:
    model = system.model
    rng = np.random.default_rng(2024)
    lower = np.where(np.isfinite(model.joint_lower), model.joint_lower, -np.pi)
    upper = np.where(np.isfinite(model.joint_upper), model.joint_upper, np.pi)
    q = rng.uniform(lower, upper, size=(configs, model.n_joints))
    loop = PinocchioLoop(system)
    result: dict[str, Any] = {
        "description": system.description,
        "n_bodies": model.n_bodies,
        "n_joints": model.n_joints,
        "n_end_effectors": model.n_end_effectors,
        "jstar_shape": [6 * model.n_end_effectors, model.n_joints],
        "det": system.det_name,
    }
    # first calls of this model in this process, generic kernels (loads the engine's cached kernels; compiles them if the cache is empty)
    t0 = time.perf_counter()
    with generic():
        ff.generalized_jacobian(model, q)
        system.freefloat_det(q)
        ff.mechanics.jacobian_measure(model, q, None, "sigma_min")
    result["freefloat_first_call_s"] = time.perf_counter() - t0
    # the specialised kernels of this structure (compiled once per machine; loaded from the cache afterwards)
    t0 = time.perf_counter()
    ff.mechanics.specialise(model, ["jstar", "measure"])
    result["specialise_s"] = time.perf_counter() - t0
    log(f"[{system.key}] specialised J* and measures ready in {result['specialise_s']:.2f} s; verifying both engines against Pinocchio")
    result["verification"] = verify(system, loop, q, configs)
    with generic():
        result["verification_generic"] = verify(system, loop, q, configs)

    # jstar_out: J* into one array the caller owns, reused call after call (out=; how a sweep over chunks gets the speed)
    jstar_buffer = np.empty((len(q), 6 * model.n_end_effectors, model.n_joints))
    calls = {
        "jstar": lambda: ff.generalized_jacobian(model, q),
        "jstar_out": lambda: ff.generalized_jacobian(model, q, out=jstar_buffer),
        "det": lambda: system.freefloat_det(q),
        "sigma_min": lambda: ff.mechanics.jacobian_measure(model, q, None, "sigma_min"),
    }
    sub = q[:pinocchio_configs]
    log(f"[{system.key}] Pinocchio loop, {len(sub):,} configurations, best of {repeats}")
    theirs = {key: rate(best_of(lambda key=key: loop.loop(key, sub), repeats), len(sub)) for key in calls if key != "jstar_out"}
    theirs["jstar_out"] = theirs["jstar"]  # the Pinocchio loop makes J* one configuration at a time either way
    result["pinocchio_loop"] = theirs
    for engine in ("specialised", "generic"):
        for threads in thread_counts():
            old = set_threads(threads)
            try:
                log(f"[{system.key}] freefloat ({engine}), {len(q):,} configurations, {threads} thread(s), best of {repeats}")
                with generic() if engine == "generic" else contextlib.nullcontext():
                    ours = {key: rate(best_of(fn, repeats), len(q)) for key, fn in calls.items()}
            finally:
                set_threads(old)
            jstar_bytes = 8 * 6 * model.n_end_effectors * model.n_joints  # written per configuration
            result[f"{'' if engine == 'specialised' else 'generic_'}threads_{threads}"] = {
                "freefloat": ours,
                "ratio": {k: ours[k]["configs_per_s"] / theirs[k]["configs_per_s"] for k in ours},
                "ratio_cpu": {k: ours[k]["cpu_configs_per_s"] / theirs[k]["cpu_configs_per_s"] for k in ours},
                "measure_vs_jstar": {k: ours[k]["configs_per_s"] / ours["jstar"]["configs_per_s"] for k in ("det", "sigma_min")},
                "jstar_write_GB_per_s": ours["jstar"]["configs_per_s"] * jstar_bytes / 1e9,
            }
    return result


def fill_bandwidth(repeats: int, megabytes: int = 512) -> dict[str, Any]:
    """Memory-write bandwidth of this machine, one thread: numpy's ``fill`` of a large float64 array (best of ``repeats``)."""
    block = np.empty(megabytes * 2**20 // 8)
    block.fill(0.0)  # pages touched before timing
    timing = best_of(lambda: block.fill(1.0), repeats)
    return {"bytes": block.nbytes, "best_wall_s": timing["best_wall_s"], "GB_per_s": block.nbytes / timing["best_wall_s"] / 1e9}


def run_core(configs: int, pinocchio_configs: int, repeats: int, log: Callable[[str], None] = print) -> dict[str, Any]:
    report: dict[str, Any] = {
        "benchmark": "core: J* and det J* over random configurations, freefloat (one batched call) vs a Python loop over Pinocchio",
        "machine": machine_info(),
        "settings": {"configs": configs, "pinocchio_configs": pinocchio_configs, "repeats": repeats, "threads": thread_counts()},
        "targets": {"min_ratio": TARGET_RATIO, "goal_ratio": GOAL_RATIO},
        "notes": [
            "configs_per_s: configurations / best wall-clock time of one call over the whole batch (freefloat) "
            "or of the loop over the subsample (Pinocchio); cpu_configs_per_s uses process CPU time instead "
            "(with 2 threads it adds both threads' time).",
            "ratio = freefloat configs/s / Pinocchio-loop configs/s, both measured in this run; threads_<k>: freefloat's "
            "engine on k numba threads (numba.set_num_threads); the Pinocchio loop is one Python thread, as a user writes it.",
            "threads_<k>: the kernels specialised to the model's structure (ff.mechanics.specialise; specialise_s: their compile, "
            "or their load when the cache has them); generic_threads_<k>: the generic kernels (the model as arrays, nothing "
            "compiled per model), timed in the same run; freefloat_first_call_s is this model's first generic call in the process.",
            "freefloat's batched J* is returned with the batch axis innermost in memory (a transposed view) when the "
            "engine produces it so; values and shape are the documented ones.",
            "det: det J* (square singularity rows) or the manipulability; sigma_min: the smallest singular value of the "
            "singularity rows (ff.mechanics.jacobian_measure; Pinocchio loop: numpy's SVD of its J*). measure_vs_jstar: "
            "the measure's configs/s over J*'s in the same engine and thread count (the measures never write J*).",
            "jstar: a new result array each call (the previous one dropped, as a loop over chunks does); jstar_out: "
            "into one array the caller owns and passes as out= call after call (its pages already mapped); the Pinocchio "
            "loop's figure is the same for both.",
            "memory_write: numpy fill of a 512 MiB array on one thread (GB/s); jstar_write_GB_per_s: the bytes of J* "
            "written per second (8 x 6E x N per configuration) and jstar_write_share_of_fill its share of that bandwidth.",
        ],
        "systems": {},
    }
    report["memory_write"] = fill_bandwidth(repeats)
    log(f"memory write (numpy fill, one thread): {report['memory_write']['GB_per_s']:.1f} GB/s")
    for system in systems():
        result = bench_system(system, configs, pinocchio_configs, repeats, log)
        for key, sub in result.items():
            if "threads_" in key:
                sub["jstar_write_share_of_fill"] = sub["jstar_write_GB_per_s"] / report["memory_write"]["GB_per_s"]
        report["systems"][system.key] = result
    if hasattr(os, "getloadavg"):
        report["machine"]["load_average_at_end"] = list(os.getloadavg())
    return report


def table(report: dict[str, Any]) -> str:
    """A readable table of the report."""
    lines = []
    head = (
        f"{'system':18s} {'quantity':36s} {'thr':>3s} {'freefloat cfg/s':>16s} {'Pinocchio cfg/s':>16s} {'ratio':>8s} "
        f"{'ratio (cpu)':>12s} {'max rel err':>12s}"
    )
    lines.append(head)
    lines.append("-" * len(head))
    for key, res in report["systems"].items():
        for name in ("jstar", "jstar_out", "det", "sigma_min"):
            label = {"jstar": "J*", "jstar_out": "J* into out=", "det": res["det"], "sigma_min": "sigma_min"}[name]
            err = res["verification"][f"max_rel_err_{'jstar' if name == 'jstar_out' else name}"]
            for sub_key, sub in res.items():
                if "threads_" not in sub_key:
                    continue
                ours, theirs = sub["freefloat"][name], res["pinocchio_loop"][name]
                tag = ("generic " if sub_key.startswith("generic") else "") + label
                lines.append(
                    f"{key:18s} {tag[:36]:36s} {sub_key.rsplit('_', 1)[1]:>3s} "
                    f"{ours['configs_per_s']:16,.0f} {theirs['configs_per_s']:16,.0f} "
                    f"{sub['ratio'][name]:7.0f}x {sub['ratio_cpu'][name]:11.0f}x {err:12.1e}"
                )
    lines.append("")
    settings = report["settings"]
    lines.append(
        f"batch {settings['configs']:,} configurations (Pinocchio loop: {settings['pinocchio_configs']:,}); "
        f"best of {settings['repeats']}; max rel err = largest difference from Pinocchio (J* / det), must be <= {VERIFY_RTOL:g}"
    )
    lines.append(f"target: >= {report['targets']['min_ratio']:.0f}x on both systems (goal {report['targets']['goal_ratio']:.0f}x)")
    lines.append("")
    lines.append(
        f"{'system':18s} {'kernels':8s} {'thr':>3s} {'det / J*':>9s} {'sigma_min / J*':>15s} {'J* written GB/s':>16s} {'of fill':>8s}"
    )
    for key, res in report["systems"].items():
        for sub_key, sub in res.items():
            if "threads_" in sub_key:
                share = sub.get("jstar_write_share_of_fill", float("nan"))
                lines.append(
                    f"{key:18s} {'generic' if sub_key.startswith('generic') else 'special':8s} {sub_key.rsplit('_', 1)[1]:>3s} "
                    f"{100 * sub['measure_vs_jstar']['det']:8.0f}% {100 * sub['measure_vs_jstar']['sigma_min']:14.0f}% "
                    f"{sub['jstar_write_GB_per_s']:16.2f} {100 * share:7.0f}%"
                )
    memory = report.get("memory_write")
    if memory:
        lines.append(f"memory write bandwidth (numpy fill, one thread): {memory['GB_per_s']:.1f} GB/s")
    lines.append(machine_line(report["machine"]))
    return "\n".join(lines)


def machine_line(machine: dict[str, Any]) -> str:
    """One line: CPU, cores, load average before and after."""
    return (
        f"machine: {machine.get('cpu')}, {machine.get('cpu_count')} cpus, numba threads {machine.get('numba_threads')}, "
        f"load average at start {machine.get('load_average_at_start')}, at end {machine.get('load_average_at_end')}"
    )


def run(quick: bool, log: Callable[[str], None]) -> dict[str, Any]:
    """``run.py`` entry: 10^5 configurations (2 x 10^4 with quick), a 20,000 (2,000) configuration Pinocchio loop."""
    if quick:
        return run_core(20_000, 2_000, 3, log)
    return run_core(100_000, 20_000, 5, log)
