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
# the figures are of this machine's own kernels (compiled by the warm-up below), never of the portable ones freefloat
# ships (the start-up benchmark measures those, in processes of its own)
os.environ["FREEFLOAT_KERNELS"] = "native"

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
    """Call every engine kernel once (tiny sizes), so that no timing below includes a compile: the two parts of
    ``tests/warm_kernels.py`` (which ``make test`` runs before the suite), here in this process.

    The kernels are compiled once per machine and engine source (the cache is keyed by a hash of
    the engine's files: an edit, even a reformat, compiles them again); the start-up benchmark
    measures that cost on its own, in fresh processes.
    """
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from warm_kernels import PARTS

    t0 = time.perf_counter()
    for part in PARTS.values():
        part()
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
