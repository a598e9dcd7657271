"""Workspace benchmark (1992 §III-V): the PIW of the §V system to 1 mm, and det J* map throughput.

* **PIW to 1 mm**: ``path_independent_workspace`` of the 1992 one-arm system after
  capturing the 400 kg payload (Table VI), for growing sampling budgets. A budget "reaches
  1 mm" when its reported ``accuracy`` is at most 1 mm and its PIW limits (R_min, R_max)
  are within 1 mm of a reference run with 16x more samples. Headline: the shortest
  wall-clock time (best of ``repeats``) among the budgets that reach 1 mm.
* **det J* map throughput**: ``ff.workspace.singularity_measure(model, Q)`` (det J* where J* is
  square, else its smallest singular value) and the plain ``ff.jacobian_determinant`` /
  ``ff.manipulability`` over Q of shape (configs, N), uniform within the joint limits, for
  the two-arm 1992 system (N = 4, planar J* 4 x 4) and ``ff.models.spacecraft_7dof()``
  (3D, N = 7, J* 6 x 7: smallest singular value / manipulability); the library calls as they
  are (one engine), the first call in the process timed apart.
* **3D capture plans**: ``plan_capture`` with the translational rows of J* (σ_min > 0.02 m/rad)
  for a 0.2 m path on ``spacecraft_7dof`` (100 kg payload; the path fits in the PIW) and on the
  user-style 6-DOF arm of ``tests/data/user_arm_6dof.urdf`` (50 kg payload; no PIW annulus fits,
  the plan is checked along the path), wall-clock time and the plan found.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from typing import Any

import numpy as np

import freefloat as ff
from bench_core import machine_info, machine_line
from freefloat.analysis._workspace_search import joint_box
from freefloat.analysis.capture import plan_capture
from freefloat.analysis.singularity import SingularityCriterion
from freefloat.analysis.workspace import path_independent_workspace, reachable_workspace

MM = 1e-3


def best_of(fn: Callable[[], Any], repeats: int) -> tuple[float, Any]:
    best, value = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        value = fn()
        best = min(best, time.perf_counter() - t0)
    return best, value


def bench_piw(budgets: list[int], reference: int, repeats: int, log: Callable[[str], None]) -> dict[str, Any]:
    model = ff.models.papadopoulos1992(arms=1).with_payload(0, mass=400.0, inertia=25.0)
    reach = reachable_workspace(model, 0)
    log(f"[piw] reference run, {reference:,} samples")
    ref = path_independent_workspace(model, 0, samples=reference, reachable=reach)
    rows = []
    headline = None
    for samples in budgets:
        log(f"[piw] {samples:,} samples, best of {repeats}")
        seconds, piw = best_of(lambda s=samples: path_independent_workspace(model, 0, samples=s, reachable=reach), repeats)
        err = max(abs(float(piw.R_min) - float(ref.R_min)), abs(float(piw.R_max) - float(ref.R_max)))
        ok = piw.accuracy <= MM and err <= MM
        rows.append(
            {
                "samples": samples,
                "evaluated": piw.samples,
                "seconds": seconds,
                "R_min": piw.R_min,
                "R_max": piw.R_max,
                "accuracy_m": piw.accuracy,
                "resolution_m": piw.resolution,
                "error_vs_reference_m": err,
                "within_1mm": ok,
            }
        )
        if ok and (headline is None or seconds < headline["seconds"]):
            headline = rows[-1]
    return {
        "system": "Papadopoulos 1992 one-arm system after capturing 400 kg, 25 kg m² (Table VI)",
        "reference": {"samples": reference, "R_min": ref.R_min, "R_max": ref.R_max, "accuracy_m": ref.accuracy},
        "runs": rows,
        "time_to_1mm_s": None if headline is None else headline["seconds"],
        "samples_to_1mm": None if headline is None else headline["samples"],
        "reachable_s_note": "the reachable workspace (closed form) is computed once and passed in; it takes microseconds",
    }


def bench_maps(configs: int, repeats: int, log: Callable[[str], None]) -> dict[str, Any]:
    systems = {
        "papadopoulos1992": (ff.models.papadopoulos1992(arms=2), ff.jacobian_determinant, "det J* (4 x 4 planar rows)"),
        "spacecraft_7dof": (ff.models.spacecraft_7dof(), ff.manipulability, "J* 6 x 7: smallest singular value / manipulability"),
    }
    out: dict[str, Any] = {}
    for key, (model, plain, what) in systems.items():
        box = joint_box(model.joint_lower, model.joint_upper)
        q = np.random.default_rng(0).uniform(box.lo, box.hi, size=(configs, model.n_joints))
        entry: dict[str, Any] = {"what": what, "configs": configs, "n_joints": model.n_joints}
        for label, fn in (
            ("singularity_measure", lambda m=model, qq=q: ff.workspace.singularity_measure(m, qq)),
            (
                "jacobian_determinant" if plain is ff.jacobian_determinant else "manipulability",
                lambda m=model, f=plain, qq=q: f(m, qq),
            ),
        ):
            t0 = time.perf_counter()
            fn()
            first = time.perf_counter() - t0
            log(f"[map] {key} {label}, {configs:,} configurations, best of {repeats}")
            seconds, _ = best_of(fn, repeats)
            entry[label] = {"seconds": seconds, "configs_per_s": configs / seconds, "first_call_s": first}
        out[key] = entry
    return out


USER_ARM = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tests", "data", "user_arm_6dof.urdf")


def bench_capture_3d(samples: int, repeats: int, log: Callable[[str], None]) -> dict[str, Any]:
    criterion = SingularityCriterion("position", "sigma_min", 0.02)
    path = np.array([[0.0, 0.0, 0.0], [0.0, 0.2, 0.0]])
    cases = {
        "spacecraft_7dof": (ff.models.spacecraft_7dof(), 100.0, 5.0),
        "user_arm_6dof": (ff.load(USER_ARM), 50.0, 2.0),
    }
    out: dict[str, Any] = {"criterion": criterion.as_dict(), "path_m": path.tolist(), "samples": samples}
    for key, (model, mass, inertia) in cases.items():
        log(f"[capture] {key}, best of {repeats}")
        seconds, plan = best_of(
            lambda m=model, mp=mass, i=inertia: plan_capture(m, 0, path, mass=mp, inertia=i, samples=samples, criterion=criterion),
            repeats,
        )
        out[key] = {
            "seconds": seconds,
            "method": plan.method,
            "R_plus_m": plan.placement.R_plus,
            "piw_m": [list(iv) for iv in plan.piw.piw],
            "min_sigma_min_along_path": plan.motion.min_measure,
            "max_deviation_m": plan.motion.deviation,
        }
    return out


def run(quick: bool, log: Callable[[str], None]) -> dict[str, Any]:
    budgets = [1 << 10, 1 << 12, 1 << 14] if quick else [1 << 10, 1 << 12, 1 << 14, 1 << 16, 1 << 18]
    configs = 1 << 17 if quick else 1 << 20
    repeats = 2 if quick else 3
    report: dict[str, Any] = {
        "benchmark": "workspace: PIW of the 1992 §V system to 1 mm; det J* map throughput",
        "machine": machine_info(),
        "settings": {"budgets": budgets, "configs": configs, "repeats": repeats},
        "notes": [
            "seconds: best wall-clock time of `repeats` calls; configs_per_s = configs / seconds.",
            "PIW: within_1mm = reported accuracy <= 1 mm and PIW limits within 1 mm of the 16x reference run.",
            "det J* map: the library calls as they are (one engine: numba kernels, cached on disk, on numba's threads); "
            "first_call_s: the first call in this process.",
        ],
    }
    report["piw"] = bench_piw(budgets, 16 * budgets[-1] if quick else 1 << 20, repeats, log)
    report["det_map"] = bench_maps(configs, repeats, log)
    report["capture_3d"] = bench_capture_3d(1 << 14 if quick else 1 << 16, repeats, log)
    if hasattr(os, "getloadavg"):
        report["machine"]["load_average_at_end"] = list(os.getloadavg())
    return report


def table(report: dict[str, Any]) -> str:
    piw = report["piw"]
    lines = [f"PIW of the §V system (reference R_min {piw['reference']['R_min']:.6f} m, R_max {piw['reference']['R_max']:.6f} m)"]
    lines.append(f"{'samples':>9s} {'seconds':>9s} {'R_min':>10s} {'R_max':>10s} {'accuracy':>10s} {'error':>10s}  1 mm")
    for r in piw["runs"]:
        lines.append(
            f"{r['samples']:>9,d} {r['seconds']:>9.3f} {r['R_min']:>10.6f} {r['R_max']:>10.6f} "
            f"{r['accuracy_m']:>10.1e} {r['error_vs_reference_m']:>10.1e}  {'yes' if r['within_1mm'] else 'no'}"
        )
    lines.append(f"time to the PIW to 1 mm: {piw['time_to_1mm_s']} s ({piw['samples_to_1mm']} samples)")
    lines.append("")
    lines.append(f"{'system':18s} {'call':34s} {'configs/s':>14s}")
    for key, entry in report["det_map"].items():
        for label, value in entry.items():
            if isinstance(value, dict):
                lines.append(f"{key:18s} {label:34s} {value['configs_per_s']:>14,.0f}")
    lines.append("")
    cap = report["capture_3d"]
    lines.append(f"3D capture plans ({cap['samples']:,} PIW samples; translational J*, sigma_min > 0.02 m/rad)")
    for key in ("spacecraft_7dof", "user_arm_6dof"):
        c = cap[key]
        lines.append(
            f"{key:18s} {c['seconds']:>8.2f} s  method {c['method']:4s}  R+ {c['R_plus_m']:.3f} m  "
            f"min sigma_min along the path {c['min_sigma_min_along_path']:.3f} m/rad"
        )
    lines.append(machine_line(report["machine"]))
    return "\n".join(lines)
