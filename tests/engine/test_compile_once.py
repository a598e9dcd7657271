"""One compile of a kernel per machine, caches that must not load, and the setting that chooses the kernels (issue 44).

Every case runs in fresh processes with a cache folder of its own (``FREEFLOAT_CACHE_DIR``). Compiles are counted with
numba's event API (``numba:compile``, one event per kernel compiled). These tests run at every numba the project
supports (``make test-lowest`` too); the portable kernels' own tests are in ``test_portable.py``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numba
import pytest

from freefloat.engine import folders as kernel_cache


def test_the_shipped_portable_kernels_are_of_this_engine_source() -> None:
    """``make kernels`` was run after the last change to the engine's kernel sources: the manifest names this source's
    key, for the numba and Python this suite runs on (at another numba, as ``make test-lowest`` runs, they are not
    used, and the reason names numba)."""
    manifest = kernel_cache.portable_manifest()
    assert manifest is not None, "no src/freefloat/engine/portable/kernels.json: run make kernels"
    assert kernel_cache.PORTABLE_ARCHIVE.is_file(), "no src/freefloat/engine/portable/kernels.tar.xz: run make kernels"
    why = kernel_cache._portable_mismatch(manifest)
    if manifest["numba"] == numba.__version__:
        assert why is None, f"{why}: run make kernels"
        assert manifest["key"] == kernel_cache.source_key()
        assert manifest["python"] == "{}.{}".format(*sys.version_info[:2])
        assert manifest["kernels"] >= 20, manifest
    else:
        assert why is not None and f"numba {manifest['numba']}" in why, why


#: A kernel of freefloat's cache (``freefloat.engine.cache.kernel``), written into a module of its own; the child
#: waits until the instant it is given, calls it and prints the compiles (two processes at once:
#: ``tests/mechanics/test_numba_cache.py``).
SLOW_KERNEL = "\n".join(
    ["from freefloat.engine.cache import kernel", "", "@kernel()", "def slow(x):", "    y = x"]
    + [f"    y = y * {1.0 + i * 1e-6!r} + {i * 1e-3!r} - (y * y) * 1e-9" for i in range(600)]
    + ["    return y", ""]
)
RACE = """
import json, sys, time
from numba.core import event
sys.path.insert(0, sys.argv[1])
recorder = event.RecordingListener()
event.register("numba:compile", recorder)
import slow_kernel
start = float(sys.argv[2])
while time.time() < start:
    time.sleep(0.001)
value = slow_kernel.slow(0.5)
compiles = sum(1 for _, e in recorder.buffer if e.is_start)
print(json.dumps({"value": value, "compiles": compiles, "after": time.time() - start}))
"""


def test_a_cache_compiled_for_another_cpu_is_not_loaded(tmp_path: Path) -> None:
    """numba keys every cache entry by the CPU it was compiled for: a cache written for another CPU name
    (``NUMBA_CPU_NAME``) is not loaded by this machine's processes (they compile), and is by that CPU name's."""
    (tmp_path / "slow_kernel.py").write_text(SLOW_KERNEL)
    env = dict(os.environ, FREEFLOAT_CACHE_DIR=str(tmp_path / "cache"), FREEFLOAT_KERNELS="native")
    other = dict(env, NUMBA_CPU_NAME="x86-64-v2" if os.uname().machine == "x86_64" else "generic")

    def compiles(environment: dict[str, str]) -> int:
        done = subprocess.run(
            [sys.executable, "-c", RACE, str(tmp_path), repr(time.time())], env=environment, capture_output=True, text=True, timeout=300
        )
        assert done.returncode == 0, done.stderr[-3000:]
        return int(json.loads(done.stdout.strip().splitlines()[-1])["compiles"])

    assert compiles(other) == 1
    assert compiles(other) == 0  # that CPU's entry loads
    assert compiles(env) == 1  # this machine's does not: compiled
    assert compiles(env) == 0


@pytest.mark.parametrize("entry", ["library", "cli"])
def test_an_unknown_kernels_setting_is_refused_naming_the_variable(tmp_path: Path, entry: str) -> None:
    """``FREEFLOAT_KERNELS=fast``: the first call that needs a kernel raises :class:`freefloat.core.errors.SettingError`
    naming the variable and its three values (nothing compiled or loaded first); ``freefloat kernels`` prints it as one
    ``error:`` line and exits 1."""
    env = dict(os.environ, FREEFLOAT_CACHE_DIR=str(tmp_path / "cache"), FREEFLOAT_KERNELS="fast")
    if entry == "library":
        code = "import numpy as np, freefloat as ff\nff.generalized_jacobian(ff.models.papadopoulos1992(), np.zeros(4))"
        done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
        assert done.returncode == 1
        assert (
            "freefloat.core.errors.SettingError: FREEFLOAT_KERNELS='fast' is not a setting: use one of auto, portable, native"
            in done.stderr
        )
    else:
        done = subprocess.run([sys.executable, "-m", "freefloat", "kernels"], env=env, capture_output=True, text=True, timeout=300)
        assert done.returncode == 1, done.stderr
        lines = done.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(
            "error: FREEFLOAT_KERNELS='fast' is not a setting: use one of auto, portable, native"
        ), lines
    assert not any((tmp_path / "cache").rglob("*.nbi")), "a kernel was compiled or unpacked before the setting was checked"


#: The child of the watch test: the engine's compile watcher and a progress bar (logging, no terminal) around a call
#: that compiles (or loads) the kernel of ``slow_kernel``; prints what the watcher was told.
WATCHED = """
import json, logging, sys, time
sys.path.insert(0, sys.argv[1])
logging.basicConfig(level=logging.INFO, stream=sys.stdout, format="%(name)s|%(message)s")
from freefloat import engine
from freefloat.simulation._guard import Progress
import slow_kernel
seen = []
with engine.watch_compiles(lambda what, seconds: seen.append([what, seconds])):
    bar = Progress(None, 1.0)
    start = time.perf_counter()
    value = slow_kernel.slow(0.5)
    took = time.perf_counter() - start
    time.sleep(1.5)  # (the watcher's last word comes within its period)
    bar.close()
print(json.dumps({"seen": seen, "took": took, "after": engine.compiling_now()}))
"""


def test_a_compile_is_watched_while_it_lasts_and_a_progress_bar_says_so(tmp_path: Path) -> None:
    """While a kernel compiles, the thread that needs it is blocked: the engine's compile watcher tells its watchers
    what compiles (at the start, every half second, and once at the end with how long it took), and a progress bar
    that is open logs "waiting: compiling the engine's kernel ..." with the time so far. A kernel the cache holds is
    loaded: nothing is watched (issue 44: a progress bar that waits for a compile says so)."""
    (tmp_path / "slow_kernel.py").write_text(SLOW_KERNEL)
    env = dict(os.environ, FREEFLOAT_CACHE_DIR=str(tmp_path / "cache"), FREEFLOAT_KERNELS="native")

    def child() -> tuple[dict[str, Any], list[str]]:
        done = subprocess.run([sys.executable, "-c", WATCHED, str(tmp_path)], env=env, capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr[-3000:]
        lines = done.stdout.strip().splitlines()
        return json.loads(lines[-1]), [line.split("|", 1)[1] for line in lines if line.startswith("freefloat.progress|")]

    compiled, logged = child()
    what = "compiling the engine's kernel slow for this machine (once)"
    seen, took = compiled["seen"], compiled["took"]
    assert took > 2.5, f"the kernel compiled in {took:.2f} s: too short to watch the progress bar's delay pass"
    assert [entry[0] for entry in seen[:-1]] == [what] * (len(seen) - 1) and seen[-1][0] is None, seen
    assert len(seen) - 1 >= took / 0.5 - 2, f"{len(seen) - 1} calls in {took:.2f} s"  # every half second
    assert abs(seen[-1][1] - took) < 0.7 and compiled["after"] is None, (seen[-1], took)
    assert any(line.startswith("simulating: 0 / 1 s (0%)") and f"; waiting: {what}, " in line for line in logged), logged
    loaded, logged = child()
    assert loaded["seen"] == [] and logged == [], (loaded, logged)
