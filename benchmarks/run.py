"""Run the freeflyer benchmarks and write their results as JSON.

    python benchmarks/run.py --out out/bench            # 10^6 configurations (``make bench``)
    python benchmarks/run.py --out out/bench --quick    # 10^5, a smoke run

Writes ``<out>/core.json`` and prints a table. See benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_core


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=Path("out/bench"), help="output folder (default out/bench)")
    parser.add_argument("--quick", action="store_true", help="10^5 configurations and a 5,000-configuration Pinocchio loop")
    parser.add_argument("--configs", type=int, default=None, help="configurations per freeflyer call (default 10^6, 10^5 with --quick)")
    parser.add_argument("--pinocchio-configs", type=int, default=None, help="configurations in the Pinocchio loop (default 20,000)")
    parser.add_argument("--repeats", type=int, default=3, help="timed repeats, the best is reported (default 3)")
    parser.add_argument("--no-numba", action="store_true", help="skip the numba evaluation even when numba is installed")
    args = parser.parse_args(argv)

    configs = args.configs or (100_000 if args.quick else 1_000_000)
    pinocchio_configs = min(args.pinocchio_configs or (5_000 if args.quick else 20_000), configs)
    numba = not args.no_numba and _has_numba()
    t0 = time.perf_counter()
    report = bench_core.run(configs, pinocchio_configs, args.repeats, numba, log=lambda msg: print(msg, flush=True))
    report["settings"]["quick"] = args.quick
    report["settings"]["total_s"] = time.perf_counter() - t0
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "core.json"
    path.write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    print()
    print(bench_core.table(report))
    print(f"\nwrote {path}")
    return 0


def _has_numba() -> bool:
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


if __name__ == "__main__":
    raise SystemExit(main())
