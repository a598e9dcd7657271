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
