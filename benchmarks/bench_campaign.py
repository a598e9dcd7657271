"""Campaign benchmark (issue 23): a campaign's throughput on 1 and 2 local workers, and the runner's overhead per run.

* **Runner overhead**: a campaign of ``trivial`` runs (a function that returns at once: ``function =
  "bench_campaign:trivial"``, 400 runs, 100 with ``--quick``) through :func:`freefloat.campaigns.run_campaign` on
  a local cluster of 1 and of 2 worker processes: wall time from the connected client to the last run stored
  (the cluster's start is reported apart, ``cluster_start_s``), runs/s, and the time per run: on one worker that
  is the whole machinery per run (plan entry, task, scheduling, transfer, Parquet and bookkeeping), since the
  run itself takes microseconds (``direct_per_run_s``: the same function called in this process).
* **Throughput**: the example campaign ``examples/campaigns/tumbling_capture.toml`` (the capture and 20 s of
  detumbling of a tumbling satellite, one ``freefloat capture`` each), its first 16 runs (4 with ``--quick``)
  on 1 and on 2 workers: runs/s from the connected client to the last run stored (each fresh worker loads the
  compiled kernels on its first run: included, ``first_run_s`` says how long), and the same runs in a loop in
  this process (``in_process_runs_per_s``: :func:`~freefloat.campaigns.execute.execute_run`, kernels warm).
  A local cluster shares the cores between its workers (``numba_threads``: 2 threads for the batched kernels of the
  one worker, 1 each for two, on 2 cores); ``workers_1_threads_1`` is one worker with its kernels on 1 thread.
  ``speedup_2_over_1``: the 2-worker rate over the 1-worker rate; ``speedup_2_over_1_threads_1``: over the
  1-worker, 1-thread rate (at most 2 on 2 cores; the machine's other load changes both).
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from bench_core import machine_line
from freefloat.campaigns import campaign_from_dict, load_campaign, plan_runs, read_runs, run_campaign
from freefloat.campaigns.execute import execute_run
from freefloat.campaigns.runner import _task

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "campaigns" / "tumbling_capture.toml"


def trivial(parameters: dict[str, Any]) -> dict[str, Any]:
    """A run that costs nothing: what is left of a campaign's time is the runner's."""
    return {"x": float(parameters["i"])}


def timed_campaign(spec: Any, workers: int, max_runs: int | None = None, numba_threads: int | None = None) -> dict[str, Any]:
    """One campaign on a fresh local cluster of ``workers`` processes, into a temporary folder."""
    started: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as folder:
        t0 = time.perf_counter()
        done = run_campaign(
            spec, Path(folder) / "out", workers=workers, max_runs=max_runs, progress=False, numba_threads=numba_threads,
            on_started=lambda client: started.setdefault("t", time.perf_counter()),
        )  # fmt: skip
        end = time.perf_counter()
        seconds = np.asarray(read_runs(Path(folder) / "out").column("seconds").to_numpy())
    runs = done.ok + done.failed
    busy = end - started["t"]
    return {
        "workers": workers,
        "runs": runs,
        "failed": done.failed,
        "cluster_start_s": started["t"] - t0,
        "wall_s": busy,
        "runs_per_s": runs / busy,
        "per_run_s": busy / runs,
        "run_seconds_median": float(np.median(seconds)),
        "first_run_s": float(seconds.max()),
    }


def bench_overhead(runs: int, log: Callable[[str], None]) -> dict[str, Any]:
    spec = campaign_from_dict(
        {"function": "bench_campaign:trivial", "parameters": {"i": {"linspace": [0.0, runs - 1.0, runs]}}, "record": {"scalars": ["x"]}},
        source="trivial",
    )
    t0 = time.perf_counter()
    for run in plan_runs(spec):
        execute_run(_task(spec, run))
    direct = (time.perf_counter() - t0) / runs
    out: dict[str, Any] = {"runs": runs, "direct_per_run_s": direct}
    for workers in (1, 2):
        log(f"[overhead] {runs} trivial runs on {workers} worker(s)")
        out[f"workers_{workers}"] = timed_campaign(spec, workers)
    out["overhead_per_run_s"] = out["workers_1"]["per_run_s"] - direct
    return out


def bench_throughput(runs: int, log: Callable[[str], None]) -> dict[str, Any]:
    spec = load_campaign(EXAMPLE)
    plan = plan_runs(spec)[:runs]
    log(f"[throughput] {runs} runs of {EXAMPLE.name} in this process")
    execute_run(_task(spec, plan[0]))  # kernels loaded
    t0 = time.perf_counter()
    outcomes = [execute_run(_task(spec, run)) for run in plan]
    local = runs / (time.perf_counter() - t0)
    out: dict[str, Any] = {"runs": runs, "in_process_runs_per_s": local, "in_process_failed": sum(o.status != "ok" for o in outcomes)}
    for workers in (1, 2):
        log(f"[throughput] {runs} runs on {workers} worker(s)")
        out[f"workers_{workers}"] = timed_campaign(spec, workers, max_runs=runs)
    log(f"[throughput] {runs} runs on 1 worker, kernels on 1 thread")
    out["workers_1_threads_1"] = timed_campaign(spec, 1, max_runs=runs, numba_threads=1)
    out["speedup_2_over_1"] = out["workers_2"]["runs_per_s"] / out["workers_1"]["runs_per_s"]
    out["speedup_2_over_1_threads_1"] = out["workers_2"]["runs_per_s"] / out["workers_1_threads_1"]["runs_per_s"]
    return out


def run(quick: bool, log: Callable[[str], None]) -> dict[str, Any]:
    """``run.py`` entry: 400 trivial runs and 16 capture runs (100 and 4 with quick)."""
    trivial_runs, capture_runs = (100, 4) if quick else (400, 16)
    return {
        "overhead": bench_overhead(trivial_runs, log),
        "throughput": bench_throughput(capture_runs, log),
        "settings": {"trivial_runs": trivial_runs, "capture_runs": capture_runs, "threads_per_worker": 1},
    }


def table(report: dict[str, Any]) -> str:
    o, t = report["overhead"], report["throughput"]
    lines = [f"campaign runner, {o['runs']} trivial runs (direct call {o['direct_per_run_s'] * 1e6:.1f} µs/run)"]
    lines.append(f"{'workers':>8s} {'cluster start':>14s} {'wall':>8s} {'runs/s':>9s} {'per run':>10s}")
    for k in (1, 2):
        e = o[f"workers_{k}"]
        lines.append(f"{k:>8d} {e['cluster_start_s']:>13.2f}s {e['wall_s']:>7.2f}s {e['runs_per_s']:>9.1f} {e['per_run_s'] * 1e3:>8.2f}ms")
    lines.append(f"overhead per run (1 worker): {o['overhead_per_run_s'] * 1e3:.2f} ms")
    lines.append("")
    lines.append(f"{EXAMPLE.name}: {t['runs']} runs; in this process {t['in_process_runs_per_s']:.2f} runs/s")
    lines.append(f"{'workers':>8s} {'cluster start':>14s} {'wall':>8s} {'runs/s':>9s} {'median run':>11s} {'slowest run':>12s}")
    for key, label in (("workers_1", "1"), ("workers_1_threads_1", "1 (1 thr)"), ("workers_2", "2")):
        e = t[key]
        lines.append(
            f"{label:>8s} {e['cluster_start_s']:>13.2f}s {e['wall_s']:>7.2f}s {e['runs_per_s']:>9.2f} {e['run_seconds_median']:>10.2f}s "
            f"{e['first_run_s']:>11.2f}s"
        )
    lines.append(
        f"2 workers over 1: {t['speedup_2_over_1']:.2f}x (kernels on 2 threads in the 1 worker), "
        f"{t['speedup_2_over_1_threads_1']:.2f}x (on 1 thread)"
    )
    lines.append(machine_line(report["machine"]))
    return "\n".join(lines)
