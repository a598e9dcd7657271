"""Small and mid-size generic calls: this checkout against an earlier revision, in alternated processes.

    python benchmarks/ab_small_calls.py --out out/bench                 # against BASE (below), 3 rounds
    python benchmarks/ab_small_calls.py --out out/bench --base REV --rounds 5

Issue 20 asks that "a one-off small call is never slower than today's generic path", where "today" is the engine
before the issue's work: a call that runs no specialised kernel (automatic specialisation off in both) of 1 to 4,096
configurations, the sizes whose time is mostly the call's fixed cost and the hand-over to threads. The earlier code
is not in this checkout, so the comparison runs it: ``git worktree`` of ``--base`` in a temporary folder, imported
from there; each revision has a kernel cache of its own, ``<out>/ab-cache-<rev>`` and ``<out>/ab-cache-this`` (a first
round compiles its kernels; the user's cache may hold specialised modules of these systems, which a call uses even
with automatic specialisation off), one process per revision per round, alternated, each the best of 3 x 300 calls per size (fewer
for the large sizes). The report has each revision's best over the rounds and the ratio this / base; the load average
at start and end. Not part of ``make bench`` (the first run compiles the base's kernels: minutes).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

#: The commit before issue 20's first change (2026-11-26): the generic path with numba's ``prange`` twins.
BASE = "2f59b41"
SIZES = (1, 16, 64, 128, 256, 512, 1024, 2048, 4096)
SYSTEMS = ("papadopoulos1992", "spacecraft_7dof")
CALLS = ("jstar", "hplus", "forward")

#: Run in each revision's process: prints one JSON object {system: {call: {size: seconds}}}.
MEASURE = """
import json, sys, time
import numpy as np
import freefloat as ff

def best(f, reps):
    b = 1e9
    for _ in range(reps):
        t = time.perf_counter(); f(); b = min(b, time.perf_counter() - t)
    return b

sizes, systems, calls = json.loads(sys.argv[1])
out = {}
for name in systems:
    m = getattr(ff.models, name)()
    rng = np.random.default_rng(0)
    Q = rng.uniform(-2, 2, size=(max(sizes), m.n_joints))
    V = rng.uniform(-1, 1, size=(max(sizes), 6 + m.n_joints))
    funcs = {
        "jstar": lambda s: ff.generalized_jacobian(m, Q[:s]),
        "hplus": lambda s: ff.system_inertia_matrix(m, Q[:s]),
        "forward": lambda s: ff.forward_dynamics(m, Q[:s], V[:s]),
    }
    out[name] = {}
    for call in calls:
        f = funcs[call]
        for s in (1, max(sizes)):
            f(s)  # compiled or loaded, and the threads started
        out[name][call] = {str(s): min(best(lambda: f(s), max(5, min(300, 40000 // s))) for _ in range(3)) for s in sizes}
print(json.dumps(out))
"""


def _run(src: Path, cache: Path, spec: str) -> dict:
    """One revision's process: ``src`` imported, its kernels in ``cache`` (a folder of this benchmark's own: the user's
    cache may hold specialised modules of these systems, which a call uses even with automatic specialisation off)."""
    env = {**os.environ, "FREEFLOAT_AUTO_SPECIALISE": "0", "PYTHONPATH": str(src), "FREEFLOAT_CACHE_DIR": str(cache)}
    done = subprocess.run([sys.executable, "-c", MEASURE, spec], env=env, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, default=Path("out/bench"))
    parser.add_argument("--base", default=BASE)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    root = Path(__file__).resolve().parents[1]
    args.out.mkdir(parents=True, exist_ok=True)
    rev = subprocess.run(
        ["git", "-C", str(root), "rev-parse", "--short", args.base], capture_output=True, text=True, check=True
    ).stdout.strip()
    spec = json.dumps([SIZES, SYSTEMS, CALLS])
    load_start = os.getloadavg()
    with tempfile.TemporaryDirectory() as folder:
        tree = Path(folder) / "base"
        subprocess.run(["git", "-C", str(root), "worktree", "add", "--detach", "-f", str(tree), rev], capture_output=True, check=True)
        try:
            rounds: dict[str, list[dict]] = {"base": [], "this": []}
            for k in range(args.rounds):
                rounds["base"].append(_run(tree / "src", args.out / f"ab-cache-{rev}", spec))
                rounds["this"].append(_run(root / "src", args.out / "ab-cache-this", spec))
                print(f"round {k + 1} of {args.rounds} done", flush=True)
        finally:
            subprocess.run(["git", "-C", str(root), "worktree", "remove", "--force", str(tree)], capture_output=True, check=False)
    best = {
        side: {name: {call: {s: min(r[name][call][s] for r in runs) for s in map(str, SIZES)} for call in CALLS} for name in SYSTEMS}
        for side, runs in rounds.items()
    }
    spread = {  # each revision's slowest round over its fastest, per cell: the noise the ratios sit in
        side: {
            name: {
                call: {s: max(r[name][call][s] for r in runs) / min(r[name][call][s] for r in runs) for s in map(str, SIZES)}
                for call in CALLS
            }
            for name in SYSTEMS
        }
        for side, runs in rounds.items()
    }
    ratio = {
        name: {call: {s: best["this"][name][call][s] / best["base"][name][call][s] for s in map(str, SIZES)} for call in CALLS}
        for name in SYSTEMS
    }
    report = {
        "base": rev,
        "rounds": args.rounds,
        "seconds": best,
        "this_over_base": ratio,
        "slowest_over_fastest_round": spread,
        "rounds_seconds": rounds,
        "load_average_at_start": load_start,
        "load_average_at_end": os.getloadavg(),
        "notes": "best over the rounds of each revision's best of 3 x N calls; automatic specialisation off in both",
    }
    (args.out / "ab_small_calls.json").write_text(json.dumps(report, indent=1))
    print(f"this / {rev}, best of {args.rounds} alternated processes each (load {load_start[0]:.1f} -> {os.getloadavg()[0]:.1f}):")
    print(f"{'':30s}" + "".join(f"{s:>7d}" for s in SIZES))
    for name in SYSTEMS:
        for call in CALLS:
            print(f"{name + ' ' + call:30s}" + "".join(f"{ratio[name][call][str(s)]:7.2f}" for s in SIZES))
    print("each revision's slowest round over its fastest, base | this:")
    for name in SYSTEMS:
        for call in CALLS:
            cells = (f"{spread['base'][name][call][str(s)]:.2f}|{spread['this'][name][call][str(s)]:.2f}" for s in SIZES)
            print(f"{name + ' ' + call:30s}" + "".join(f"{c:>10s}" for c in cells))


if __name__ == "__main__":
    main()
