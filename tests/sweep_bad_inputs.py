"""Sweep the bad-input table (tests/test_bad_inputs.py) and print the issue's summary table.

    PYTHONPATH=src .venv/bin/python tests/sweep_bad_inputs.py [-k TEXT] [-v]

Every case runs as the test runs it: in a scratch folder of its own with the bad files, the working directory empty,
FREEFLOAT_MEMORY_LIMIT=16G and a 60 s alarm (``test_bad_inputs.scratch_dir``), classified by ``test_bad_inputs.outcome``:
clear, unclear, traceback, silent or hang. Prints a markdown table (rows CLI and API), then every case that is not clear
and every case that changed something outside its output folder. ``-k TEXT``: only the cases whose id contains TEXT;
``-v``: print every case with its outcome and time.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
sys.path.insert(0, str(Path(__file__).resolve().parent))

from freefloat.engine.specialise import build as _specialise
from test_bad_inputs import CASES, Hang, outcome, scratch_dir

KINDS = ("clear", "unclear", "traceback", "silent", "hang")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-k", default="", help="only the cases whose id contains this")
    parser.add_argument("-v", action="store_true", help="print every case")
    args = parser.parse_args()
    warnings.simplefilter("error")  # as the test suite runs (pyproject: filterwarnings = ["error"])
    counts = {side: dict.fromkeys(KINDS, 0) for side in ("CLI", "API")}
    notes: list[str] = []
    started = time.perf_counter()
    with _specialise.generic():  # as the test suite runs (tests/conftest.py)
        for case in (c for c in CASES if args.k in c.id):
            side = "CLI" if isinstance(case.run, list) else "API"
            with tempfile.TemporaryDirectory() as root, scratch_dir(Path(root), case.files) as scratch:
                start = time.perf_counter()
                try:
                    kind, shown = outcome(case, scratch.files)
                except Hang as exc:
                    kind, shown = "hang", str(exc)
                took = time.perf_counter() - start
            counts[side][kind] += 1
            if kind != "clear" or args.v:
                notes.append(f"- {case.id} [{kind}, {took:.2f} s]: {' '.join(shown.split())[:400]}")
            notes += [f"- {case.id} [side effect]: {effect}" for effect in scratch.side_effects]
    print("| | cases | " + " | ".join(KINDS) + " |")
    print("|---|---:|" + "---:|" * len(KINDS))
    for side, row in counts.items():
        print(f"| {side} | {sum(row.values())} | " + " | ".join(str(row[k]) for k in KINDS) + " |")
    print(f"\n{sum(sum(r.values()) for r in counts.values())} cases in {time.perf_counter() - started:.1f} s")
    if notes:
        print("\n" + "\n".join(notes))
    bad = sum(row[k] for row in counts.values() for k in KINDS[1:])
    return 1 if bad or any("[side effect]" in n for n in notes) else 0


if __name__ == "__main__":
    sys.exit(main())
