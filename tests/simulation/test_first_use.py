"""A first simulation compiles only the kernel it runs, and the estimate made before it says whether the engine's
kernels are compiled yet (issue 44: no compile for an estimate or a check before the run).

Each case runs in a fresh process (a kernel compiled or loaded in this one would hide what a first run does): the
engine's numba kernels that hold machine code after the work are the ones it compiled or loaded from the cache.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

#: Run in the child: the engine kernels (module.name) that hold machine code after ``WORK``, and the estimates.
PROBE = """
import json, sys, types
import numpy as np
import freefloat as ff
import freefloat.engine as engine
from freefloat.engine import drivers, laws, measures, quantities, stepper, stops

def ready_kernels():
    found = set()
    for module in (drivers, laws, measures, quantities, stepper, stops):
        for name, value in vars(module).items():
            kernel = value.serial if isinstance(value, drivers.Batched) else value
            if hasattr(kernel, "signatures") and hasattr(kernel, "py_func") and kernel.signatures:
                found.add(kernel.py_func.__qualname__)
    return sorted(found)

model = ff.models.spacecraft_7dof()
n = model.n_joints
report = {}
before = ff.simulation.estimate_run(model, 0.05, fixed_step=1e-3)
report["before"] = [before.compiles, before.describe()]
report["after_estimate"] = ready_kernels()
if sys.argv[1] == "simulate":
    inertia = np.diagonal(ff.system_inertia_matrix(model, np.zeros(n), method="barycentric"))[6:]
    pd = ff.JointPD(kp=400.0 * inertia, kd=28.0 * inertia, q_ref=np.full(n, 0.3))
    traj = ff.simulate(model, ff.State(q=np.zeros(n)), 0.05, controller=lambda t, s: pd(t, s), fixed_step=1e-3)
    report["t_end"] = float(traj.t[-1])
    report["after_run"] = ready_kernels()
    after = ff.simulation.estimate_run(model, 0.05, fixed_step=1e-3)
    report["after"] = [after.compiles, after.describe()]
print(json.dumps(report))
"""


def probe(work: str, cache: Path | None) -> dict[str, object]:
    env = dict(os.environ, FREEFLOAT_AUTO_SPECIALISE="0")
    if cache is not None:  # an empty cache and nothing portable: what a machine without the shipped kernels meets
        env["FREEFLOAT_CACHE_DIR"] = str(cache)
        env["FREEFLOAT_KERNELS"] = "native"
    done = subprocess.run([sys.executable, "-c", PROBE, work], env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])  # type: ignore[no-any-return]


def test_an_estimate_on_an_empty_cache_compiles_nothing_and_says_the_run_compiles(tmp_path: Path) -> None:
    report = probe("estimate", tmp_path / "empty")
    compiles, line = report["before"]  # type: ignore[misc]
    assert compiles is True
    # the compile's length: what rk4_steps took to compile when the portable kernels were built (their manifest)
    seconds = json.loads((ROOT / "src/freefloat/engine/portable/kernels.json").read_text())["compile_seconds"]["rk4_steps"]
    assert f"after about {seconds:.2g} s of compiling the engine's kernels for this machine (once)" in line, line
    assert report["after_estimate"] == [], "the estimate compiled a kernel"
    assert not any((tmp_path / "empty").rglob("*.nbi")), "the estimate wrote compiled kernels"


def test_a_first_simulation_runs_the_rk4_kernel_and_no_other() -> None:
    """With the user's cache (warm in the suite: loading stands for compiling), a fixed-step run with a Python
    controller loads the one kernel it steps with: its estimate times that kernel (not the state derivative of the
    adaptive integrators) and its checks before the run take H+ of the initial state from numpy (not the H+ kernel).
    The second estimate is timed (compiles False)."""
    report = probe("simulate", None)
    assert report["t_end"] == pytest.approx(0.05)
    assert report["after_run"] == ["rk4_steps"], report["after_run"]
    assert report["after_estimate"] in ([], ["rk4_steps"])  # loaded for the estimate when it was in the cache
    assert report["after"][0] is False  # type: ignore[index]
    assert "compiling" not in report["after"][1]  # type: ignore[index]
