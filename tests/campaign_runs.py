"""Run functions for the campaign tests (``function = "campaign_runs:NAME"``), imported by the Dask workers.

The workers find this module on their PYTHONPATH (the tests' folder), which the cluster fixtures set.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import numpy as np

#: Seconds a gated run waits for its gate before it gives up (the test then fails on the missing results).
GATE_TIMEOUT = 60.0


def marked(parameters: dict[str, Any]) -> dict[str, Any]:
    """Write ``start-I-PID`` in ``parameters["dir"]``, wait for the file ``gate`` there (when ``gated``), write
    ``done-I-PID``: the files (each with a unique ``-N`` ending) count how often run I was started and computed, and by
    which worker process."""
    folder, i = Path(parameters["dir"]), int(parameters["i"])
    (folder / f"start-{i}-{os.getpid()}-{time.monotonic_ns()}").touch()
    if parameters.get("gated", False):
        give_up = time.monotonic() + GATE_TIMEOUT
        while not (folder / "gate").exists():
            if time.monotonic() > give_up:
                raise TimeoutError("no gate")
            time.sleep(0.01)
    (folder / f"done-{i}-{os.getpid()}-{time.monotonic_ns()}").touch()
    return {"square": float(i * i), "steps": np.arange(i + 1, dtype=float), "t": 0.5 * np.arange(i + 1)}


def allocate(parameters: dict[str, Any]) -> dict[str, Any]:
    """Take ``parameters["mib"]`` MiB, 32 MiB at a time (each page written), and hold it to the end."""
    held = [np.ones(32 << 17) for _ in range(int(parameters["mib"]) // 32)]  # 32 MiB of float64 each
    return {"held_mib": float(sum(a.nbytes for a in held) >> 20)}


_RECORDERS: list[Any] = []


def compiles(parameters: dict[str, Any]) -> dict[str, Any]:
    """A short fixed-step simulation with a joint PD on the worker; how many kernels the worker's process has compiled
    (numba's compile events, counted from its first run of this function) and whether it loaded portable kernels."""
    from numba.core import event

    import freefloat as ff
    from freefloat.engine import kernel_status

    if not _RECORDERS:
        _RECORDERS.append(event.RecordingListener())
        event.register("numba:compile", _RECORDERS[0])
    model = ff.models.papadopoulos1992()
    n = model.n_joints
    ff.simulate(model, ff.State(q=np.full(n, 0.1 * parameters["i"])), 0.05, ff.JointPD(kp=1.0, kd=1.0), fixed_step=1e-3)
    count = sum(1 for _, e in _RECORDERS[0].buffer if e.is_start)
    return {"compiles": float(count), "portable": float(bool(kernel_status()["portable"]))}


def threads(parameters: dict[str, Any]) -> dict[str, Any]:
    """numba's thread count in the task thread that computes the run (what the engine's batched kernels use)."""
    import numba

    return {"numba_threads": float(numba.get_num_threads())}


def frames(parameters: dict[str, Any]) -> dict[str, Any]:
    """The body frames of the 1992 servicer at joint angles ``0.1 i`` (one of the engine's kernels, compiled on a fresh
    worker that does not load the portable ones): the x coordinate of the last body's origin."""
    import freefloat as ff

    model = ff.models.papadopoulos1992()
    _, origins = ff.forward_kinematics(model, np.full(model.n_joints, 0.1 * parameters["i"]))
    return {"x": float(origins[-1, 0])}
