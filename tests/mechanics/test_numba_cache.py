"""The engine's on-disk kernel cache: under the user's cache folder, safe for two processes at once,
rebuilt with a warning (never a traceback) when broken.

Each test runs fresh Python processes against an empty ``FREEFLOAT_CACHE_DIR`` (a temporary folder),
so the kernels really compile, are written, and are loaded; numba's own counters say which.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from freefloat.engine import cache as _numba_cache

PROBE = """
import json, os, pathlib, sys, time, warnings
import numpy as np
warnings.simplefilter("default")
import freefloat as ff
from freefloat.engine import drivers as _drivers
from freefloat.engine import cache as _numba_cache
m = ff.models.papadopoulos1991()
barrier, count = pathlib.Path(sys.argv[1]), int(sys.argv[2])  # every probe ready (imported) before any compiles
(barrier / f"ready-{os.getpid()}").touch()
while len(list(barrier.glob("ready-*"))) < count:
    time.sleep(0.005)
j = ff.forward_kinematics(m, np.linspace(-1.0, 1.0, m.n_joints))[1]
stats = _drivers.frames_batch.serial.stats
print(json.dumps({"hits": sum(stats.cache_hits.values()), "misses": sum(stats.cache_misses.values()),
                  "frames": j.tolist(), "folder": str(_numba_cache.cache_dir())}))
"""
#: The probe's kernel: the body frames (the engine's kernel that compiles fastest: seconds, not a minute).
PROBED = "frames_serial"


def run_probes(cache: Path, count: int) -> list[tuple[dict[str, object], str]]:
    """Start ``count`` probe processes at once; their results and stderr."""
    env = {**os.environ, "FREEFLOAT_CACHE_DIR": str(cache), "FREEFLOAT_KERNELS": "native"}  # compiled here, not portable
    barrier = Path(tempfile.mkdtemp(prefix="barrier-"))
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", PROBE, str(barrier), str(count)], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        for _ in range(count)
    ]
    out = []
    for p in procs:
        stdout, stderr = p.communicate(timeout=600)
        assert p.returncode == 0, stderr
        assert "Traceback" not in stderr, stderr
        out.append((json.loads(stdout.strip().splitlines()[-1]), stderr))
    shutil.rmtree(barrier, ignore_errors=True)
    return out


def test_cache_folder_is_under_the_chosen_cache_dir_and_keyed_by_versions(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FREEFLOAT_CACHE_DIR", str(tmp_path))
    folder = _numba_cache.cache_dir()
    assert folder.parent == tmp_path / "numba"
    import numba

    assert folder.name.startswith(numba.__version__ + "-")
    monkeypatch.delenv("FREEFLOAT_CACHE_DIR")
    import platformdirs

    assert Path(platformdirs.user_cache_dir("freefloat")) in _numba_cache.cache_dir().parents


def test_two_processes_at_once_compile_once_then_a_third_loads_from_the_cache(tmp_path: Path) -> None:
    """Both start with an empty folder and need the body frames' kernel at the same time: one compiles it, the other says it
    waits for that compile and loads what it saved (issue 44: never the same compile twice)."""
    first = run_probes(tmp_path, 2)
    assert sorted((r["misses"], r["hits"]) for r, _ in first) == [(0, 1), (1, 0)], [r for r, _ in first]
    waiting = "waiting for another process that compiles the engine's kernel"
    assert sorted(waiting in err for _, err in first) == [False, True], [err for _, err in first]
    assert first[0][0]["frames"] == first[1][0]["frames"]
    assert all("CacheWarning" not in err for _, err in first)
    folder = Path(str(first[0][0]["folder"]))
    assert folder.is_relative_to(tmp_path) and any(folder.rglob("*.nbi"))
    ((third, err),) = run_probes(tmp_path, 1)
    assert third["hits"] == 1 and third["misses"] == 0, third  # loaded, not compiled
    assert third["frames"] == first[0][0]["frames"] and "CacheWarning" not in err


def test_a_broken_cache_warns_recompiles_and_is_rewritten(tmp_path: Path) -> None:
    ((good, _),) = run_probes(tmp_path, 1)
    files = [f for f in tmp_path.rglob("*") if f.is_file()]
    assert files
    for f in files:  # truncate / overwrite every cache file
        f.write_bytes(b"not a numba cache file")
    ((broken, err),) = run_probes(tmp_path, 1)
    assert "CacheWarning" in err and PROBED in err, err
    assert broken["frames"] == good["frames"] and broken["misses"] == 1
    ((healed, err),) = run_probes(tmp_path, 1)
    assert healed["hits"] == 1 and "CacheWarning" not in err  # the cache was rewritten
