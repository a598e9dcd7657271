"""The campaign runner: the plan's missing runs on a Dask cluster, stored as they finish.

:func:`run_campaign` is what ``freefloat campaign`` calls. With ``scheduler`` (``tcp://host:port``) it connects
a :class:`distributed.Client` to an existing cluster; without, it starts a :class:`distributed.LocalCluster` of
worker processes on 127.0.0.1 and connects the same way: one code path. It keeps at most ``window`` runs
submitted at a time, writes each finished run's series at once and its row in a Parquet part every
``flush_seconds`` (or ``flush_runs`` rows), and on Ctrl-C stops submitting, waits for the runs in progress
(a second Ctrl-C leaves them), stores them and returns. A worker that dies during a run (killed, out of memory)
loses it; the scheduler tries it once more elsewhere (a local cluster's ``allowed-failures`` is 1; an external
cluster's is its own setting), then the run is stored as failed with that reason.
"""

from __future__ import annotations

import contextlib
import logging
import os
import socket
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from ..core.errors import CampaignError
from ..simulation._guard import Progress
from .execute import RunOutcome, RunTask, execute_run
from .spec import CampaignSpec, Run, plan_runs
from .store import CampaignStore, finished_runs

__all__ = ["CONNECT_TIMEOUT", "CampaignRun", "dask_client", "run_campaign"]

#: Seconds to wait for an external scheduler to answer.
CONNECT_TIMEOUT = 4.0
#: Allowed failures of a run on a local cluster: a worker dying once (a lost machine) is forgiven, twice is the run's.
ALLOWED_FAILURES = 1


@dataclass(frozen=True)
class CampaignRun:
    """What one invocation did: ``planned`` runs in the campaign, ``selected`` (the first ``max_runs``),
    ``skipped`` (already stored), ``ok`` and ``failed`` now, ``interrupted`` (Ctrl-C), wall ``seconds``."""

    out: Path
    campaign_id: str
    planned: int
    selected: int
    skipped: int
    ok: int
    failed: int
    interrupted: bool
    seconds: float

    def line(self) -> str:
        """One line for the terminal."""
        stopped = "; interrupted: run it again with --resume" if self.interrupted else ""
        return (
            f"campaign {self.campaign_id}: {self.ok} ok, {self.failed} failed, {self.skipped} already stored, "
            f"of {self.selected} selected ({self.planned} planned) in {self.seconds:.3g} s{stopped}"
        )


@contextlib.contextmanager
def dask_client(
    scheduler: str | None = None, *, workers: int | None = None, memory_limit: str | None = None, numba_threads: int | None = None
) -> Iterator[Any]:
    """A Dask client on ``scheduler``, or on a new local cluster of ``workers`` processes (one task thread each) on
    127.0.0.1 with ``memory_limit`` per worker (e.g. "2GiB") and ``numba_threads`` for the batched kernels in each
    (default :func:`local_threads`: the cores shared between the workers); closed (and the cluster stopped) on exit."""
    import dask
    from distributed import Client, LocalCluster

    if scheduler is not None:
        if workers is not None or memory_limit is not None:
            raise CampaignError("--workers and --memory-limit shape a local cluster; with --scheduler, the cluster's own workers run")
        host, port = _address(scheduler)
        try:
            if scheduler.startswith("tcp://"):
                with socket.create_connection((host, port), timeout=CONNECT_TIMEOUT):  # refused at once, before Dask's retries
                    pass
            client = Client(scheduler, timeout=CONNECT_TIMEOUT, set_as_default=False)
        except (OSError, ValueError, TypeError, MemoryError) as exc:  # (MemoryError: something that is not a scheduler answered)
            why = " ".join(str(exc).split())
            raise CampaignError(
                f"--scheduler {scheduler}: no Dask scheduler answered within {CONNECT_TIMEOUT:g} s ({why}); "
                "start one (dask scheduler) or check the address (tcp://host:port)"
            ) from None
        with client:
            yield client
        return
    if workers is not None and workers < 1:
        raise CampaignError(f"--workers: expected at least 1, got {workers}")
    threads = numba_threads if numba_threads is not None else local_threads(workers or 1)
    environ = {**dask.config.get("distributed.nanny.pre-spawn-environ"), "NUMBA_NUM_THREADS": str(threads)}  # read at numba's import
    settings = {"distributed.scheduler.allowed-failures": ALLOWED_FAILURES, "distributed.nanny.pre-spawn-environ": environ}
    with dask.config.set(settings), _workers_ignore_ctrl_c():
        cluster = LocalCluster(
            n_workers=workers or 1,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address="127.0.0.1:0",  # the scheduler's HTTP server on a free port (None still takes 8787, warning when busy)
            memory_limit=memory_limit or "auto",
            silence_logs=logging.CRITICAL,
        )
    with cluster, Client(cluster, set_as_default=False) as client:
        yield client


@contextlib.contextmanager
def _workers_ignore_ctrl_c() -> Iterator[None]:
    """Start the local workers with SIGINT ignored (a process started so keeps it: Python then installs no
    KeyboardInterrupt), so that a terminal's Ctrl-C, which reaches the whole process group, stops the runner only and
    the runs in progress finish. (A worker that its nanny restarts later, after an out-of-memory kill, has the
    default again.) Off the main thread, where no signal can be set, nothing changes."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _address(address: str) -> tuple[str, int]:
    """The host and port of a scheduler address ``protocol://host:port``; a CampaignError if it is not one."""
    parts = urlsplit(address)
    try:
        port = parts.port
    except ValueError:
        port = None
    if not parts.scheme or not parts.hostname or port is None:
        raise CampaignError(f"--scheduler {address}: expected a scheduler address such as tcp://127.0.0.1:8786")
    return parts.hostname, port


def _lost(run: Run, exc: BaseException) -> RunOutcome:
    """The outcome of a run whose task raised on the cluster. Its worker died on each try (KilledWorker: killed, or
    out of memory): the run is failed, with that reason. Anything else (freefloat missing on a worker, the task
    cancelled, the scheduler gone) is the cluster's failure, not the run's: a CampaignError stops the campaign (the
    finished runs are kept) so that ``--resume`` runs it once the cluster is fixed."""
    message = " ".join(str(exc).split()) or type(exc).__name__
    if type(exc).__name__ == "KilledWorker":
        reason = f"KilledWorker: the worker running it died (killed, or out of memory) on each try ({message})"
        return RunOutcome(run.run_id, run.index, "failed", reason)
    raise CampaignError(
        f"run {run.run_id} could not run on the cluster ({type(exc).__name__}: {message}); the finished runs are kept: "
        "check the workers (freefloat installed, the scenario's files at the same paths), then --resume"
    ) from exc


def _task(spec: CampaignSpec, run: Run) -> RunTask:
    return RunTask(run.run_id, run.index, spec.kind, spec.scenario, spec.base, spec.function, run.parameters, spec.scalars, spec.series)


def local_threads(workers: int) -> int:
    """Threads of the batched kernels in each worker of a local cluster: the machine's cores shared between them."""
    return max(1, (os.cpu_count() or 1) // workers)


def run_campaign(
    spec: CampaignSpec,
    out: str | Path,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    memory_limit: str | None = None,
    resume: bool = False,
    max_runs: int | None = None,
    progress: bool | None = None,
    window: int | None = None,
    flush_seconds: float = 2.0,
    flush_runs: int = 256,
    on_started: Callable[[Any], None] | None = None,
    numba_threads: int | None = None,
) -> CampaignRun:
    """Run the campaign's missing runs into ``out`` (module docstring). ``max_runs``: only the first N of the plan;
    ``window``: runs submitted at a time (default twice the cluster's threads, at least 4); ``on_started``: called
    with the client once it is connected; ``numba_threads``: threads of the batched kernels in each run (default: on a
    local cluster the cores shared between its workers, :func:`local_threads`; on an existing one, its workers')."""
    start = time.perf_counter()
    if max_runs is not None and max_runs < 1:
        raise CampaignError(f"--max-runs: expected at least 1, got {max_runs}")
    plan = plan_runs(spec)
    selected = plan[:max_runs] if max_runs is not None else plan
    CampaignStore.check(out, spec, resume=resume)  # a refused directory or an unreachable scheduler: nothing written
    stored = finished_runs(out)
    todo = [run for run in selected if run.run_id not in stored]
    counts = {"ok": 0, "failed": 0}
    interrupted = False
    if todo:
        with (
            dask_client(scheduler, workers=workers, memory_limit=memory_limit, numba_threads=numba_threads) as client,
            CampaignStore.open(out, spec, plan, resume=resume) as store,
        ):
            if on_started is not None:
                on_started(client)
            limit = window or max(4, 2 * sum(client.nthreads().values()))
            bar = Progress(progress, float(len(todo)), what=f"campaign {spec.campaign_id}", unit="runs", rate=True)
            try:
                interrupted = _drive(client, spec, store, todo, limit, bar, counts, flush_seconds, flush_runs)
            finally:
                bar.close()
    return CampaignRun(
        Path(out), spec.campaign_id, len(plan), len(selected), len(selected) - len(todo), counts["ok"], counts["failed"],
        interrupted, time.perf_counter() - start,
    )  # fmt: skip


def _drive(
    client: Any,
    spec: CampaignSpec,
    store: CampaignStore,
    todo: list[Run],
    limit: int,
    bar: Progress,
    counts: dict[str, int],
    flush_seconds: float,
    flush_runs: int,
) -> bool:
    """Submit, collect and store; True when interrupted (Ctrl-C, SIGTERM)."""
    from distributed import as_completed

    queue = iter(todo)
    running: dict[Any, Run] = {}
    finished = as_completed(loop=client.loop)
    pending: list[RunOutcome] = []
    flushed = time.perf_counter()
    stopping = False

    def submit() -> None:
        while len(running) < limit:
            run = next(queue, None)
            if run is None:
                return
            future = client.submit(execute_run, _task(spec, run), key=f"freefloat-run-{run.run_id}", retries=0)
            running[future] = run
            finished.add(future)

    def collect() -> None:
        for future in finished.next_batch(block=True):  # waits in 0.1 s steps: Ctrl-C gets through
            run = running.pop(future)
            try:
                outcome = future.result()
            except Exception as exc:  # (a run's own failure is an outcome: this is the cluster's)
                outcome = _lost(run, exc)
            future.release()
            store.write_series(outcome)
            pending.append(outcome)
            counts[outcome.status] += 1
        bar.update(float(counts["ok"] + counts["failed"]))

    def flush() -> None:
        nonlocal flushed
        store.add(pending)
        pending.clear()
        flushed = time.perf_counter()

    try:
        submit()
        while running:
            collect()
            submit()
            if len(pending) >= flush_runs or (pending and time.perf_counter() - flushed >= flush_seconds):
                flush()
    except KeyboardInterrupt:
        stopping = True
        logging.getLogger("freefloat.progress").warning(
            "stopping: waiting for the %d runs in progress (Ctrl-C again to leave them)", len(running)
        )
        with contextlib.suppress(KeyboardInterrupt):
            while running:
                collect()
        for future in running:
            future.cancel()
    finally:
        flush()
    return stopping
