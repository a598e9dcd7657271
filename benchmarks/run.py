"""Run the freefloat benchmarks and write their results as JSON.

    python benchmarks/run.py --out out/bench                # everything (``make bench``)
    python benchmarks/run.py --out out/bench --quick        # smaller sizes, a smoke run
    python benchmarks/run.py --out out/bench --only core    # one benchmark

Each benchmark module in :data:`BENCHMARKS` has ``run(quick: bool, log) -> dict`` (the JSON
report) and ``table(report) -> str`` (a readable summary); its report is written to
``<out>/<name>.json``. See benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_core import machine_info

#: name -> module (in this folder). Register a new benchmark by adding one line.
BENCHMARKS: dict[str, str] = {
    "campaign": "bench_campaign",
    "capture": "bench_capture",
    "control": "bench_control",
    "core": "bench_core",
    "dynamics": "bench_dynamics",
    "startup": "bench_startup",
    "sweep": "bench_sweep",
    "workspace": "bench_workspace",
}

#: Added to every report's notes.
NOISE_NOTE = (
    "Timings are best of N runs on a noisy shared machine (2 cores); compare ratios measured in the same run, "
    "and the load average before and after (machine.load_average_at_start / _at_end)."
)


def warm_up() -> float:
    """Call every engine kernel once (tiny sizes), so that no timing below includes a compile.

    The kernels are compiled once per machine and engine source (the cache is keyed by a hash of
    the engine's files: an edit, even a reformat, compiles them again); the start-up benchmark
    measures that cost on its own, in fresh processes.
    """
    import numpy as np

    import freefloat as ff

    t0 = time.perf_counter()
    model = ff.models.papadopoulos1992()
    n = model.n_joints
    for size in (1, 300):  # serial and threaded drivers
        q = np.zeros((size, n))
        v = np.zeros((size, 6 + n))
        ff.generalized_jacobian(model, q)
        ff.system_inertia_matrix(model, q)
        ff.point_jacobian(model, q, 1)
        ff.end_effector_positions(model, q)
        ff.forward_kinematics(model, q)
        ff.forward_dynamics(model, q, v)
        ff.inverse_dynamics(model, q, v, v)
    state = ff.State(q=np.zeros(n))
    pd = ff.JointPD(kp=1.0, kd=1.0)
    ff.simulate(model, state, 0.01, pd, fixed_step=1e-3)  # the compiled loop
    ff.simulate(model, state, 0.01, lambda t, s: pd(t, s), fixed_step=1e-3)  # the Python-stepped RK4
    ff.simulate(model, state, 0.01, pd)
    ff.rollout(model, ff.State(q=np.zeros((2, n))), 0.01, dt=1e-3, controller=pd)
    # the 1991 controllers: their numpy form (task J_z and bias, H+, C+) and their compiled law in the loops
    from freefloat.control import OperationalSpaceController
    from freefloat.papers.paper1991 import section5_setup

    robot, task, start, target = section5_setup()
    osc = OperationalSpaceController(robot, task, target, 30.0, 60.0)
    osc(0.0, start)
    ff.simulate(robot, start, 0.02, osc, fixed_step=0.01)
    return time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=Path("out/bench"), help="output folder (default out/bench)")
    parser.add_argument("--quick", action="store_true", help="smaller problem sizes: a smoke run")
    parser.add_argument("--only", action="append", choices=sorted(BENCHMARKS), help="run only this benchmark (repeatable)")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    seconds = warm_up()
    print(f"warm-up: every engine kernel compiled or loaded from the cache in {seconds:.1f} s (not part of any timing)\n", flush=True)
    for name in args.only or list(BENCHMARKS):
        module = importlib.import_module(BENCHMARKS[name])
        print(f"== {name} ==", flush=True)
        t0 = time.perf_counter()
        before = machine_info()
        report = module.run(args.quick, lambda msg: print(msg, flush=True))
        # every report: machine information (cores, load average before and after) and the noise note
        machine = report.setdefault("machine", {})
        for key, value in before.items():
            machine.setdefault(key, value)
        if hasattr(os, "getloadavg"):
            machine["load_average_at_end"] = list(os.getloadavg())
        report.setdefault("notes", []).append(NOISE_NOTE)
        report.setdefault("settings", {})["quick"] = args.quick
        report["settings"]["total_s"] = time.perf_counter() - t0
        path = args.out / f"{name}.json"
        path.write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
        print()
        print(module.table(report))
        print(f"\nwrote {path}\n", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
