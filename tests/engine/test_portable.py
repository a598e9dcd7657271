"""The portable kernels freefloat ships, one compile per kernel and machine, and caches that must not load (issue 44).

Every case runs in fresh processes with a cache folder of its own (``FREEFLOAT_CACHE_DIR``): what a kernel does on
first use is only seen in a process that has not used it. Compiles are counted with numba's event API
(``numba:compile``, one event per kernel compiled). The portable kernels are built for the newest numba the project
supports: ``make test-lowest`` leaves this file out (there they are not used, which ``test_compile_once.py``
checks).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]

#: What the child reports: the kernels it compiled (numba's compile events) and the engine's kernel status.
REPORT = """
compiled = sorted({str(data["dispatcher"].py_func.__qualname__) for _, e in recorder.buffer
                   for data in [e.data] if e.is_start and isinstance(data, dict) and "dispatcher" in data})
print(json.dumps({"compiled": compiled, "status": kernel_status(), **found}))
"""
#: Run in the child: J* of a batch on threads, the forward dynamics of a batch and a short fixed-step simulation with
#: a joint PD (compiled loop), and the papers' barycentric J* and accelerations (numpy: nothing compiled) at the same
#: states; the compiles counted, the results and what the engine said on standard error.
FIRST_USE = (
    """
import json, sys
from numba.core import event
import numpy as np
recorder = event.RecordingListener()
event.register("numba:compile", recorder)
import freefloat as ff
from freefloat.engine import kernel_status
model = ff.models.papadopoulos1992()
rng = np.random.default_rng(3)
q = rng.uniform(-1.0, 1.0, size=(256, model.n_joints))
v = rng.uniform(-0.5, 0.5, size=(256, 6 + model.n_joints))
tau = rng.uniform(-1.0, 1.0, size=(256, model.n_joints))
traj = ff.simulate(model, ff.State(q=q[0]), 0.05, controller=ff.JointPD(kp=1.0, kd=1.0), fixed_step=1e-3)
found = {
    "jstar": ff.generalized_jacobian(model, q).tolist(),
    "jstar_reference": ff.generalized_jacobian(model, q, method="barycentric").tolist(),
    "acc": ff.mechanics.forward_dynamics(model, q, v, tau).tolist(),
    "acc_reference": ff.mechanics.forward_dynamics(model, q, v, tau, method="barycentric").tolist(),
    "simulated": traj.status,
}
"""
    + REPORT
)
#: Run in the child: the body frames of a batch (the engine's smallest kernel to compile: seconds).
FRAMES = (
    """
import json
from numba.core import event
import numpy as np
recorder = event.RecordingListener()
event.register("numba:compile", recorder)
import freefloat as ff
from freefloat.engine import kernel_status
model = ff.models.papadopoulos1992()
found = {"x": ff.forward_kinematics(model, np.full((4, model.n_joints), 0.3))[1].tolist()}
"""
    + REPORT
)


def child(code: str, cache: Path, setting: str, *args: str, timeout: float = 600) -> tuple[dict[str, object], str]:
    env = dict(os.environ, FREEFLOAT_CACHE_DIR=str(cache), FREEFLOAT_KERNELS=setting, FREEFLOAT_AUTO_SPECIALISE="0")
    done = subprocess.run([sys.executable, "-c", code, *args], env=env, capture_output=True, text=True, timeout=timeout)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1]), done.stderr


def test_a_fresh_machine_loads_the_portable_kernels_and_compiles_none_of_them(tmp_path: Path) -> None:
    """An empty cache: J* on threads, the forward dynamics and a simulation with a joint PD load the shipped kernels
    (nothing compiled, said once), their numbers those of the papers' barycentric forms (numpy, an independent
    algorithm); the background compile is not started with ``portable``. (That the portable kernels equal this
    machine's own, compiled from the same source: ``make bench --only startup`` runs both.)"""
    portable, said = child(FIRST_USE, tmp_path / "portable", "portable")
    assert portable["compiled"] == [], portable["compiled"]
    assert said.count("using the portable kernels shipped with freefloat") == 1, said
    assert "compiling the engine's kernels" not in said, said
    status = portable["status"]
    assert isinstance(status, dict) and status["portable"] and status["background"] == "not started"
    assert status["native"] == 0, "portable kernels were written into this machine's cache"
    assert portable["simulated"] == "finished"
    # (measured: 8.9e-16 of |J*| <= 1.7; 1.1e-14 of accelerations <= 3.2)
    np.testing.assert_allclose(portable["jstar"], portable["jstar_reference"], rtol=0, atol=5e-15)
    np.testing.assert_allclose(portable["acc"], portable["acc_reference"], rtol=0, atol=1e-13)
    again, said = child(FRAMES, tmp_path / "portable", "portable")  # the next process: said once per machine
    assert again["compiled"] == [] and "using the portable kernels" not in said, said
    native, said = child(FRAMES, tmp_path / "native", "native")
    assert native["compiled"], "an empty cache with FREEFLOAT_KERNELS=native compiled nothing"
    assert "using the portable kernels" not in said
    np.testing.assert_allclose(again["x"], native["x"], rtol=0, atol=1e-15)  # the same source, another CPU target


def test_auto_starts_one_background_compile_per_machine(tmp_path: Path) -> None:
    """``auto``: the first process that loads a portable kernel starts this machine's compile in a background
    process; a second process started meanwhile does not start another; once that process has died unfinished, the
    next one starts it again."""
    cache = tmp_path / "cache"
    marker = "native-compile.started"
    first, said = child(FRAMES, cache, "auto")
    assert "compiling in a background process" in said, said
    folder = Path(str(first["status"]["folder"]))  # type: ignore[index]
    pid = int((folder / marker).read_text())
    try:
        os.kill(pid, 0)  # alive
        second, said = child(FRAMES, cache, "auto")
        assert "compiling in a background process" not in said and second["status"]["background"] == "running"  # type: ignore[index]
        assert int((folder / marker).read_text()) == pid
    finally:
        os.killpg(pid, signal.SIGKILL)
    for _ in range(100):
        try:
            os.waitpid(pid, os.WNOHANG)
        except ChildProcessError:
            pass
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            break
        time.sleep(0.05)
    _, said = child(FRAMES, cache, "auto")
    assert "compiling in a background process" in said, said
    os.killpg(int((folder / marker).read_text()), signal.SIGKILL)


def test_another_numba_s_portable_kernels_are_not_loaded(tmp_path: Path) -> None:
    """A manifest of another numba version: the portable kernels are not used, every kernel compiles on this machine,
    and the compile notice says why (once)."""
    code = (
        textwrap.dedent(
            f"""
        import json, pathlib
        from freefloat.engine import folders as cache
        manifest = cache.portable_manifest()
        manifest["numba"] = "0.0.1"
        other = pathlib.Path({str(tmp_path)!r}) / "kernels.json"
        other.write_text(json.dumps(manifest))
        cache.PORTABLE_MANIFEST = other
        """
        )
        + FRAMES
    )
    report, said = child(code, tmp_path / "cache", "portable")
    assert report["compiled"], "nothing compiled: the portable kernels of another numba were loaded"
    assert "using the portable kernels" not in said
    assert said.count("the portable kernels shipped with freefloat are for numba 0.0.1") == 1, said
