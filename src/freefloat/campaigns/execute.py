"""One run of a campaign, on a worker: the scenario with the run's values, run, and what the campaign records.

:func:`execute_run` is the function each Dask task calls. It never raises for a run's own failure (a value the
scenario refuses, a simulation that diverges, a missing quantity): the :class:`RunOutcome` says "failed" and
why, and the campaign goes on. A failure of the worker's environment is not the run's: an outcome with status
"environment", which the runner never stores. ``failure`` "module": the campaign's function module did not load
(any exception while importing it) or lacks the name: no run can run there, the runner stops the campaign.
``failure`` "import": an ImportError raised inside the run's call: that run is left not finished and the campaign
goes on (``--resume`` tries it again). A worker that dies (out of memory, killed) loses a run; Dask tries it once
more elsewhere (``allowed-failures``), then the runner stores it as failed by its worker (run again by
``--resume``).
"""

from __future__ import annotations

import contextlib
import importlib
import math
import os
import socket
import time
import traceback
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .spec import get_path, set_path

__all__ = ["NUMBA_THREADS", "RunOutcome", "RunTask", "execute_run", "scalar_value"]

#: The numba threads of each run in this worker process (one entry), set by the campaign's worker plugin
#: (:class:`.worker_threads.ThreadShare`) when the worker joins; empty outside a campaign's worker.
NUMBA_THREADS: list[int] = []


@contextlib.contextmanager
def _run_threads() -> Iterator[None]:
    """The run's numba threads (:data:`NUMBA_THREADS`; numba's thread count is a setting of the calling thread, the
    worker's task thread), the worker's own setting again after the run."""
    if not NUMBA_THREADS:
        yield
        return
    from .. import engine

    with engine.numba_threads(NUMBA_THREADS[0]):
        yield


@dataclass(frozen=True)
class RunTask:
    """What a worker needs for one run (plain data: it is pickled to the worker)."""

    run_id: str
    index: int
    kind: str
    scenario: dict[str, Any]
    base: str
    function: str
    parameters: dict[str, Any]
    scalars: tuple[str, ...]
    series: tuple[str, ...]


@dataclass(frozen=True)
class RunOutcome:
    """A finished run: "ok" with its scalars and time series, or "failed" with the reason (one line) and whose
    failure it is (``failure``: "run", its own; "worker", it killed its worker on each try); or "environment": not
    run, the worker could not (never stored; ``failure`` "module" or "import", see the module docstring)."""

    run_id: str
    index: int
    status: str
    reason: str = ""
    scalars: dict[str, float] = field(default_factory=dict)
    series: dict[str, np.ndarray] = field(default_factory=dict)
    seconds: float = 0.0
    worker: str = ""
    failure: str = ""


def scalar_value(result: Any, name: str) -> float:
    """The number at ``name`` (a dotted path) in a run's result: a float (None: NaN; true / false: 1 / 0)."""
    value = get_path(result, name)
    if value is None:
        return math.nan
    if isinstance(value, (bool, np.bool_)):
        return float(value)
    if isinstance(value, (int, float, np.integer, np.floating)):
        return float(value)
    raise TypeError(f"{name} is {type(value).__name__} {value!r}, not a number; record one entry ({name}[0] or {name}.key)")


def _trajectory_series(traj: Any, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    if traj is None:
        return {}
    missing = [name for name in names if getattr(traj, name) is None]
    if missing:
        raise ValueError(f"record.series: this run has no {', '.join(missing)} (a model without wheels has no wheel series)")
    return {"t": np.asarray(traj.t), **{name: np.asarray(getattr(traj, name)) for name in names}}


def _run_scenario(task: RunTask, scenario: dict[str, Any]) -> tuple[Any, Any]:
    """(the result's dict, the trajectory) of a simulation or capture scenario."""
    base = Path(task.base)
    source = f"run {task.run_id}"
    if task.kind == "capture":
        from ..scenarios.capture_scenario import capture_scenario_from_dict, run_capture_scenario

        result = run_capture_scenario(capture_scenario_from_dict(scenario, source=source, base_dir=base))
        return result.as_dict(), None if result.sequence is None else result.sequence.run.after
    from ..core.errors import SimulationError
    from ..scenarios.scenario import run_scenario, scenario_from_dict
    from ..scenarios.scenario_outputs import trajectory_summary

    loaded = scenario_from_dict(scenario, source=source, base=base)
    try:
        traj = run_scenario(loaded, progress=False, warn_after=None)
    except SimulationError as exc:
        raise RuntimeError(str(exc)) from None  # the partial trajectory stays on the worker
    if traj.status != "finished":
        raise RuntimeError(f"the simulation {traj.status}: {traj.message}")
    return trajectory_summary(traj, loaded), traj


def _compute(task: RunTask) -> tuple[dict[str, float], dict[str, np.ndarray]]:
    if task.kind == "map":
        from .maps import map_chunk

        return map_chunk(task.scenario, task.base, int(task.parameters["start"]), int(task.parameters["size"]))
    if task.kind == "function":
        result = _function(task.function)(dict(task.parameters))
        if not isinstance(result, dict):
            raise TypeError(f"function {task.function} returned {type(result).__name__}, not a dict of results")
        missing = [key for key in task.series if key not in result]
        if missing:
            raise KeyError(f"the result has no series {', '.join(missing)}")
        arrays = {key: np.asarray(result[key]) for key in task.series}
        t = np.asarray(result.get("t", ()))
        if arrays and "t" in result and t.ndim == 1 and all(v.ndim and len(v) == len(t) for v in arrays.values()):
            arrays = {"t": t, **arrays}  # the time axis of the series, kept with them (else they have none: a spectrum)
        return {name: scalar_value(result, name) for name in task.scalars}, arrays
    scenario = task.scenario
    for name, value in task.parameters.items():
        scenario = set_path(scenario, name, value)
    result, traj = _run_scenario(task, scenario)
    if task.series and traj is None:
        raise ValueError("record.series: this scenario's run has no trajectory (a capture needs a [detumble] table)")
    return {name: scalar_value(result, name) for name in task.scalars}, _trajectory_series(traj, task.series)


class EnvironmentFailure(Exception):
    """The worker cannot run any run (its environment, not the run): the function's module cannot be imported."""


def _function(spec: str) -> Any:
    """The campaign's function; any failure to import its module is the environment's (:class:`EnvironmentFailure`)."""
    module, name = spec.split(":")
    try:
        loaded = importlib.import_module(module)
    except BaseException as exc:  # (ImportError, SyntaxError, NameError, a RuntimeError at import: none is a run's)
        if isinstance(exc, KeyboardInterrupt):  # (a SystemExit at import is the module's failure too)
            raise
        raise EnvironmentFailure(f"function {spec}: importing {module}: {type(exc).__name__}: {' '.join(str(exc).split())}") from None
    try:
        return getattr(loaded, name)
    except AttributeError:
        raise EnvironmentFailure(f"function {spec}: module {module} has no {name}") from None


def execute_run(task: RunTask) -> RunOutcome:
    """Run one task; a failure of the run itself is a "failed" outcome with its reason, never an exception."""
    start = time.perf_counter()
    worker = f"{socket.gethostname()}:{os.getpid()}"
    try:
        try:
            with _run_threads():
                scalars, series = _compute(task)
        except EnvironmentFailure as exc:  # the campaign's module: no run can run on this worker
            return RunOutcome(task.run_id, task.index, "environment", str(exc), worker=worker, failure="module")
        except ImportError as exc:  # a module missing for this run (its own code, or a package it needs): retried
            where = traceback.extract_tb(exc.__traceback__)[-1]
            reason = f"{type(exc).__name__}: {' '.join(str(exc).split())} ({Path(where.filename).name}:{where.lineno})"
            return RunOutcome(task.run_id, task.index, "environment", reason, worker=worker, failure="import")
    except MemoryError as exc:
        reason = f"out of memory: {' '.join(str(exc).split())}"
        return RunOutcome(task.run_id, task.index, "failed", reason, seconds=time.perf_counter() - start, worker=worker, failure="run")
    except Exception as exc:  # a run's own failure: kept with its reason, the campaign goes on
        message = " ".join(str(exc).split()) or type(exc).__name__
        where = traceback.extract_tb(exc.__traceback__)[-1]
        reason = f"{type(exc).__name__}: {message} ({Path(where.filename).name}:{where.lineno})"
        return RunOutcome(task.run_id, task.index, "failed", reason, seconds=time.perf_counter() - start, worker=worker, failure="run")
    return RunOutcome(task.run_id, task.index, "ok", "", scalars, series, time.perf_counter() - start, worker)
