"""Large batched results: a new array each call against the caller's own array reused (``out=``), in one process.

    PYTHONPATH=src python benchmarks/ab_outputs.py                          # this checkout, specialised kernels
    PYTHONPATH=/path/to/other/src python benchmarks/ab_outputs.py --json out/ab-other.json
    python benchmarks/ab_outputs.py --kernels generic --size 100000 --repeats 7

Times J* (``ff.generalized_jacobian``) of ``--size`` configurations of the 1992 two-arm system (12 x 4 per
configuration) and H+ (``ff.system_inertia_matrix``) of as many of the 7-DOF arm (13 x 13), each the best of
``--repeats`` calls, alternated call by call: (a) without ``out``, the result dropped at the next call (as a loop over
chunks of a sweep does), (b) into one array given as ``out=`` (skipped where the imported freefloat has no ``out=``:
an earlier revision, to compare with, imported through ``PYTHONPATH``). Every variant is called twice before it is
timed (its kernels compiled or loaded, its memory mapped). ``--kernels specialised`` (default) specialises the two
calls for their models first (in ``--cache``, by default a folder in the system's temporary folder named after the
freefloat source folder imported, so that two checkouts never share kernels: the first run of each compiles for
minutes); ``generic`` keeps the generic kernels. Prints one line per call and
variant in M configurations/s, with the load average (``os.getloadavg()``) at the start and at the end and numba's
thread count; ``--json`` writes the same as JSON. Not part of ``make bench``.
"""

from __future__ import annotations

import argparse
import hashlib
import importlib.util
import inspect
import json
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

#: (label, model factory name in ff.models, public call, specialised kind).
CALLS = (
    ("J* of the 1992 system", "papadopoulos1992", "generalized_jacobian", "jstar"),
    ("H+ of the 7-DOF arm", "spacecraft_7dof", "system_inertia_matrix", "hplus"),
)


def _arguments(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=100_000, help="configurations per call (default 10^5)")
    parser.add_argument("--repeats", type=int, default=7, help="timed calls per variant; the best counts (default 7)")
    parser.add_argument("--kernels", choices=("specialised", "generic"), default="specialised")
    parser.add_argument("--cache", type=Path, default=None, help="kernel cache folder (default: one per freefloat source folder)")
    parser.add_argument("--json", type=Path, default=None, help="also write the results here")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    args = _arguments(argv)
    spec = importlib.util.find_spec("freefloat")  # where it would be imported from, before it is
    where = str(Path(spec.origin).parent) if spec is not None and spec.origin else "none"
    cache = args.cache or Path(tempfile.gettempdir()) / f"ff-ab-outputs-{hashlib.sha256(where.encode()).hexdigest()[:12]}"
    os.environ["FREEFLOAT_CACHE_DIR"] = str(cache)  # read when freefloat is imported: set before
    os.environ["FREEFLOAT_AUTO_SPECIALISE"] = "0"  # only what this run specialises
    import numba
    import numpy as np

    import freefloat as ff

    report: dict[str, Any] = {
        "freefloat": ff.__file__,
        "size": args.size,
        "repeats": args.repeats,
        "kernels": args.kernels,
        "threads": numba.get_num_threads(),
        "load_start": os.getloadavg(),
        "calls": {},
    }
    print(f"freefloat from {Path(ff.__file__).parent}; {args.kernels} kernels; {report['threads']} threads; cache {cache}", flush=True)
    rng = np.random.default_rng(0)
    for label, name, call, kind in CALLS:
        model = getattr(ff.models, name)()
        if args.kernels == "specialised":
            ff.mechanics.specialise(model, [kind])
        f = getattr(ff, call)
        q = rng.uniform(-2.0, 2.0, (args.size, model.n_joints))
        variants: dict[str, Any] = {"new array": lambda f=f, model=model, q=q: f(model, q)}
        if "out" in inspect.signature(f).parameters:
            out = np.empty((args.size, *f(model, q[:1]).shape[1:]))
            variants["out= reused"] = lambda f=f, model=model, q=q, out=out: f(model, q, out=out)
        best = dict.fromkeys(variants, float("inf"))
        held = dict.fromkeys(variants)
        for _ in range(2):  # compiled or loaded, memory mapped
            for v, run in variants.items():
                held[v] = run()
        for _ in range(args.repeats):
            for v, run in variants.items():
                start = time.perf_counter()
                result = run()
                best[v] = min(best[v], time.perf_counter() - start)
                held[v] = result  # the last result dropped only now, as a loop that keeps each result until the next
        report["calls"][label] = {
            v: {"best_ms": 1e3 * t, "M_per_s": args.size / t / 1e6, "MB": held[v].nbytes / 1e6} for v, t in best.items()
        }
        for v, r in report["calls"][label].items():
            print(f"{label:24s} {v:12s} {r['M_per_s']:6.2f} M configurations/s  (best {r['best_ms']:.2f} ms, {r['MB']:.0f} MB)", flush=True)
    report["load_end"] = os.getloadavg()
    print(f"load average: start {report['load_start']}, end {report['load_end']}")
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(report, indent=2) + "\n")
    return report


if __name__ == "__main__":
    main(sys.argv[1:])
