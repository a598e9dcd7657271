"""numba's internals behind one gate (src/freefloat/engine/gate.py): nowhere else in freefloat, checked against the
numba range pyproject.toml declares, and each with a public fallback that computes the same values and says so once."""

from __future__ import annotations

import ast
import json
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from packaging.requirements import Requirement
from packaging.version import Version

import freefloat as ff
from freefloat.engine import gate, threads
from freefloat.engine.specialise import build

PACKAGE = Path(ff.__file__).parent
ROOT = PACKAGE.parents[1]

#: numba's public modules: ``import numba`` and its documented top-level names.
PUBLIC = {"numba"}
#: Attributes of numba's objects that are not its public API (the gate's lookups): none of them outside the gate.
PRIVATE_ATTRIBUTES = {
    "_cache",
    "overloads",
    "fold_argument_types",
    "typeof_pyval",
    "call_conv",
    "_launch_threads",
    "_is_initialized",
    "get_pointer_to_function",
    "fndesc",
    "pipeline_class",
    "compute_fingerprint",
    "targetctx",
    "add_overload",
}


#: numba's submodules (reached as attributes of ``numba``).
NUMBA_SUBMODULES = ("core", "np", "misc", "_dispatcher", "extending", "typed", "cpython")


def internals_used(source: str) -> list[str]:
    """Where ``source`` (Python) reaches one of numba's or llvmlite's internals: an import of a submodule of numba or
    of llvmlite, a ``numba.<submodule>`` attribute chain, or a private attribute of numba's objects."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [f"import {a.name}" for a in node.names if a.name.split(".")[0] in ("numba", "llvmlite") and a.name not in PUBLIC]
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] in ("numba", "llvmlite"):
            found.append(f"from {node.module} import ...")
        elif isinstance(node, ast.Attribute):
            if node.attr in PRIVATE_ATTRIBUTES:
                found.append(f".{node.attr}")
            elif isinstance(node.value, ast.Name) and node.value.id == "numba" and node.attr in NUMBA_SUBMODULES:
                found.append(f"numba.{node.attr}")
    return found


def test_no_internal_of_numba_outside_the_gate() -> None:
    sites = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        if path == PACKAGE / "engine" / "gate.py":
            continue
        used = internals_used(path.read_text(encoding="utf-8"))
        if used:
            sites[path.relative_to(PACKAGE).as_posix()] = used
    assert sites == {}


@pytest.mark.parametrize(
    "planted",
    [
        "from numba.core import cgutils",
        "import numba.np.ufunc.parallel",
        "from numba._dispatcher import compute_fingerprint",
        "from llvmlite import ir",
        "import llvmlite.binding",
        "x = numba.core.config",
        "n = len(kernel.overloads)",
        "d._cache = None",
        "status = context.call_conv.call_function(b, f, t, a, v)",
    ],
)
def test_the_scan_finds_an_internal_planted_in_a_module(planted: str) -> None:
    source = (PACKAGE / "engine" / "threads.py").read_text(encoding="utf-8")
    assert internals_used(source) == []
    assert internals_used(source + "\n\ndef _planted(numba, kernel, d, context, b, f, t, a, v):\n    " + planted + "\n") != []


def test_the_gate_checks_the_numba_range_that_pyproject_declares() -> None:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    (numba,) = [Requirement(r) for r in project["dependencies"] if Requirement(r).name == "numba"]
    low, high = (Version(".".join(map(str, v))) for v in gate.TESTED)
    spec = numba.specifier
    assert str(spec) in (f"<{high},>={low}", f">={low},<{high}"), spec
    import numba as installed

    assert Version(installed.__version__) in spec  # the suite runs on a tested numba: every internal on
    assert gate.off() == {} and gate.CACHE and gate.VIEWS and gate.THREADS


PROBE = """
import json, sys, warnings
warnings.simplefilter("always")
{setup}
import numpy as np
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    import freefloat as ff
    from freefloat.engine import gate
    m = ff.models.papadopoulos1992()
    q = np.random.default_rng(5).uniform(-1.0, 1.0, (3000, m.n_joints))
    j = ff.generalized_jacobian(m, q)
said = [str(w.message) for w in caught if w.category.__name__ == "EngineWarning"]
np.save(sys.argv[1], j)
print(json.dumps({{"off": gate.off(), "said": said, "flags": [gate.CACHE, gate.VIEWS, gate.THREADS]}}))
"""


def probe(tmp_path: Path, setup: str, name: str) -> tuple[dict[str, object], np.ndarray]:
    env = {**os.environ, "FREEFLOAT_CACHE_DIR": str(tmp_path / "cache"), "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    env["NUMBA_NUM_THREADS"] = "2"
    env["FREEFLOAT_KERNELS"] = "native"  # compiled for this machine, as the fallbacks' kernels are (never portable)
    out = tmp_path / f"{name}.npy"
    done = subprocess.run(
        [sys.executable, "-c", PROBE.format(setup=setup), str(out)], env=env, capture_output=True, text=True, timeout=900, check=False
    )
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1]), np.load(out)


@pytest.fixture(scope="module")
def native_jstar(tmp_path_factory: pytest.TempPathFactory) -> np.ndarray:
    """The probe's J* with every internal on, compiled for this machine in a process of its own (this process may run
    the portable kernels, whose last bits differ)."""
    report, j = probe(tmp_path_factory.mktemp("native"), "", "native")
    assert report["flags"] == [True, True, True] and report["off"] == {}
    return j


def test_failed_lookups_fall_back_to_public_numba_warn_once_and_compute_the_same(tmp_path: Path, native_jstar: np.ndarray) -> None:
    """A numba that renamed a lookup of the cache and of the threads (simulated: deleted before freefloat is imported;
    the views' lookups are numba's own code generation helpers, which numba itself needs: an untested numba turns them
    off, below): the engine imports, warns once naming each internal and why, and J* on two threads is the same to the
    bit."""
    expected = native_jstar  # every internal on
    renamed = "import numba.core.caching, numba._dispatcher\ndel numba.core.caching._CacheLocator, numba._dispatcher.compute_fingerprint"
    report, j = probe(tmp_path, renamed, "renamed")
    assert report["flags"] == [False, True, False]
    assert set(report["off"]) == {"cache", "threads"}  # type: ignore[arg-type]
    assert all(reason.startswith(("ImportError", "AttributeError")) for reason in report["off"].values())  # type: ignore[attr-defined]
    (said,) = report["said"]  # type: ignore[misc]
    for name in ("_CacheLocator", "compute_fingerprint", "numba's own cache", "pool"):
        assert name in said, said
    np.testing.assert_array_equal(j, expected)
    assert not (tmp_path / "cache" / "numba").exists() or not any((tmp_path / "cache" / "numba").rglob("*.nbi"))  # numba's own cache
    assert any((tmp_path / "numba").rglob("*.nbi"))


def test_an_untested_numba_uses_no_internal(tmp_path: Path, native_jstar: np.ndarray) -> None:
    report, j = probe(tmp_path, "import numba\nnumba.__version__ = '0.99.0'", "untested")
    assert report["flags"] == [False, False, False]
    (said,) = report["said"]  # type: ignore[misc]
    assert "numba 0.99.0 is outside the tested range" in said and "checked" in said, said
    np.testing.assert_array_equal(j, native_jstar)


def test_a_lookup_that_fails_at_its_first_use_falls_back_to_the_pool(monkeypatch: pytest.MonkeyPatch) -> None:
    """The threads' lookups are made at a kernel's first call on threads: one that fails there (a changed dispatcher)
    turns the internal off with the warning, and this call and the next run on the pool with the same results."""
    monkeypatch.setattr(gate, "THREADS", True)
    monkeypatch.setattr(gate, "_OFF", {})
    monkeypatch.setattr(threads, "_NUMBA_THREADS", [True])
    assert threads.thread_count() >= 2, "the test needs numba's threads (NUMBA_NUM_THREADS >= 2)"
    model = ff.models.papadopoulos1992()
    q = np.random.default_rng(6).uniform(-1.0, 1.0, (4000, model.n_joints))
    with build.generic():  # the generic kernels' drivers (a specialised kernel would take this batch otherwise)
        expected = ff.generalized_jacobian(model, q)

        def renamed(run: object, args: object) -> int:
            raise AttributeError("'CPUDispatcher' object has no attribute 'overloads'")

        monkeypatch.setattr(gate, "machine_address", renamed)
        pooled: list[int] = []
        real = threads.run_ranges
        monkeypatch.setattr(threads, "run_ranges", lambda run, count, parts: (pooled.append(parts), real(run, count, parts))[1])
        with pytest.warns(gate.EngineWarning, match="threads .AttributeError: 'CPUDispatcher' object has no attribute 'overloads'"):
            first = ff.generalized_jacobian(model, q)
        second = ff.generalized_jacobian(model, q)  # no second warning (warnings are errors in this suite)
    assert gate.THREADS is False and set(gate.off()) == {"threads"}
    assert pooled and all(p > 1 for p in pooled)  # the first call's ranges, and the second's, on the pool
    np.testing.assert_array_equal(first, expected)
    np.testing.assert_array_equal(second, expected)


READY = """
import json, sys
import numpy as np
from freefloat.engine import gate, stops
q = np.zeros((3, 2, 2)); lower = np.full(2, -1.0); upper = np.full(2, 1.0)
opened, furthest = np.empty((2, 2, 2), dtype=np.int64), np.empty((2, 2, 2))
args = (q, lower, upper, 0, 2, opened, furthest, np.empty((8, 5), dtype=np.int64), np.empty(8))
report = {"ready": gate.ready(stops.limit_spans, args), "signatures": len(stops.limit_spans.signatures)}
stops.limit_spans_batch(q, lower, upper)
report["after_call"] = gate.ready(stops.limit_spans, args)
report["misses"] = sum(stops.limit_spans.stats.cache_misses.values())
print(json.dumps(report))
"""


def test_ready_loads_from_the_cache_and_never_compiles(tmp_path: Path) -> None:
    """``gate.ready``: False on an empty cache, without compiling (no signature after it); True once the kernel is
    compiled; in the next process, True at once, loaded from the cache (no miss: nothing compiled)."""
    env = {**os.environ, "FREEFLOAT_CACHE_DIR": str(tmp_path / "cache"), "FREEFLOAT_KERNELS": "native"}
    runs = []
    for _ in range(2):
        done = subprocess.run([sys.executable, "-c", READY], env=env, capture_output=True, text=True, timeout=600, check=False)
        assert done.returncode == 0, done.stderr
        runs.append(json.loads(done.stdout.strip().splitlines()[-1]))
    assert runs[0] == {"ready": False, "signatures": 0, "after_call": True, "misses": 1}
    assert runs[1] == {"ready": True, "signatures": 1, "after_call": True, "misses": 0}


def test_ready_without_the_threads_internal_asks_the_public_signatures(monkeypatch: pytest.MonkeyPatch) -> None:
    from freefloat.engine import stops

    monkeypatch.setattr(gate, "_THREADS", None)
    assert gate.ready(stops.limit_spans, ()) is bool(stops.limit_spans.signatures)

    class Fresh:
        def __init__(self) -> None:
            self.signatures: list[object] = []

    assert gate.ready(Fresh(), ()) is False
