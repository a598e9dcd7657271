"""Compile the engine's generic kernels into the user's cache before ``make test`` runs the suite, in two processes
with disjoint sets at once (the control laws and their loops; every other kernel), so that the suite's two workers do
not compile the same kernels side by side on a fresh clone. A warm cache makes this a second or two. The sets are
balanced by their cold compile times (2026-11-27, both parts at once on the 2-core VM, since the drivers' threaded
twins are gone: the laws with the forward-dynamics batches 249 s, the rest 153 s; the forward dynamics now with the
rest; before, with the twins: 232 s and 339 s).

``python tests/warm_kernels.py`` runs both parts and prints the time they took; ``python tests/warm_kernels.py PART``
runs one. ``benchmarks/run.py`` calls both parts in its own process before it times anything. The parts are the
package's warm-up (:mod:`freefloat.warmup`); with the portable kernels freefloat ships (``make test`` runs the suite
with ``FREEFLOAT_KERNELS=portable``) they load rather than compile.
"""

from __future__ import annotations

import subprocess
import sys
import time

from freefloat import warmup

#: The warm-up's two heaviest parts (the package's own: what a new user's first calls need), each in a process.
PARTS = {"laws": warmup.laws, "engine": warmup.engine}

if __name__ == "__main__":
    if len(sys.argv) > 1:
        PARTS[sys.argv[1]]()
        sys.exit(0)
    start = time.perf_counter()
    running = {name: subprocess.Popen([sys.executable, __file__, name]) for name in PARTS}
    took: dict[str, float] = {}
    while len(took) < len(running):
        for name, process in running.items():
            if name not in took and process.poll() is not None:
                took[name] = time.perf_counter() - start
        time.sleep(0.1)
    failed = [name for name, process in running.items() if process.returncode != 0]
    parts = ", ".join(f"{name} {seconds:.0f} s" for name, seconds in took.items())
    print(f"warm_kernels: the engine's kernels compiled or loaded in {time.perf_counter() - start:.0f} s ({parts})", flush=True)
    sys.exit(1 if failed else 0)
