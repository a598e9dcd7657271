"""The campaign runner: the plan's missing runs on a Dask cluster, stored as they finish.

:func:`run_campaign` is what ``freefloat campaign`` calls. With ``scheduler`` (``tcp://host:port``) it connects
a :class:`distributed.Client` to an existing cluster; without, it starts a :class:`distributed.LocalCluster` of
worker processes on 127.0.0.1 and connects the same way: one code path. Before the plan is drawn and before any
cluster starts, the options, ``out`` and the stored runs are checked. An existing scheduler must answer as one
within :data:`CONNECT_TIMEOUT` s (nothing there, a program that is not a Dask scheduler, an unknown scheme, TLS
without certificates: each one error line) and have a worker within ``worker_timeout`` s ("waiting for workers"
is said meanwhile); a cluster left without workers during the campaign stops it after the same time.

It keeps at most ``window`` runs submitted at a time, writes each finished run's series at once and its row in a
Parquet part every ``flush_seconds`` (or ``flush_runs`` rows), and on Ctrl-C stops submitting, waits for the runs
in progress (a second Ctrl-C leaves them), stores them and returns.

Whose failure: a run that raises is the run's own (stored "failed", ``failure`` "run"). A worker that dies during
a run (killed, out of memory) loses it; the scheduler tries it once more elsewhere (a local cluster's
``allowed-failures`` is 1; an external cluster's is its own setting); a run that killed its worker on every try
is stored as failed by its worker (``failure`` "worker"; ``--resume`` runs it again: a dead worker is the
environment's). The environment's failures (the function's module not loadable on a worker, freefloat missing
there, the scheduler gone, no worker left) are never stored: they stop the campaign with one error, every run that
finished stored first, and ``--resume`` runs the rest once the cluster is fixed. An ImportError inside one run's
call leaves that run not finished (counted, not stored) and the campaign goes on, unless the first
:data:`ENVIRONMENT_STOP` runs all raise one.
"""

from __future__ import annotations

import contextlib
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..core.errors import CampaignError
from ..simulation._guard import Progress
from .cluster import CONNECT_TIMEOUT, WORKER_TIMEOUT, _one_line, check_cluster_options, dask_client
from .execute import RunOutcome, RunTask, execute_run
from .spec import CampaignSpec, Run, plan_runs
from .store import CampaignStore

__all__ = ["CONNECT_TIMEOUT", "CampaignRun", "dask_client", "run_campaign"]

#: A module missing inside a run (an ImportError raised by the run's call) leaves that run not finished and the
#: campaign goes on (``--resume`` tries it again); when the first this many runs of an invocation all raise one, the
#: workers' environment is broken: the campaign stops.
ENVIRONMENT_STOP = 8


@dataclass(frozen=True)
class CampaignRun:
    """What one invocation did: ``planned`` runs in the campaign, ``selected`` (the first ``max_runs``),
    ``skipped`` (already stored), ``ok`` and ``failed`` now, ``interrupted`` (Ctrl-C), wall ``seconds`` (and
    ``first_result``: those until the first run finished)."""

    out: Path
    campaign_id: str
    planned: int
    selected: int
    skipped: int
    ok: int
    failed: int
    interrupted: bool
    seconds: float
    unfinished: int = 0
    unfinished_reason: str = ""
    retried: int = 0
    first_result: float | None = None  # seconds from the start to the first run finished now (None: none finished)

    def line(self) -> str:
        """One line for the terminal."""
        stopped = "; interrupted: run it again with --resume" if self.interrupted else ""
        again = f" ({self.retried} that had killed their worker run again)" if self.retried else ""
        missing = (
            f", {self.unfinished} not finished (a module missing on the workers: {self.unfinished_reason}; nothing stored "
            "for them: --resume runs them again)"
            if self.unfinished
            else ""
        )
        return (
            f"campaign {self.campaign_id}: {self.ok} ok{again}, {self.failed} failed{missing}, {self.skipped} already stored, "
            f"of {self.selected} selected ({self.planned} planned) in {self.seconds:.3g} s{stopped}"
        )


def _lost(run: Run, exc: BaseException) -> RunOutcome:
    """The outcome of a run whose task raised on the cluster. Its worker died on each try (KilledWorker): the run is
    failed by its worker (``failure`` "worker"). A worker killed once, by a user or a lost machine, is forgiven
    (``allowed-failures``: the run runs again elsewhere); a run that kills every worker it runs on (out of memory,
    a crash in compiled code) would kill any other, so it is the run's failure, stored so that ``--resume`` does
    not kill more. Anything else (freefloat missing on a worker, the task cancelled, the scheduler gone) is the
    cluster's failure, not the run's: a CampaignError stops the campaign (the finished runs are kept) so that
    ``--resume`` runs it once the cluster is fixed."""
    message = _one_line(exc)
    if type(exc).__name__ == "KilledWorker":
        reason = f"KilledWorker: the worker running it died (killed, or out of memory) on each try ({message})"
        return RunOutcome(run.run_id, run.index, "failed", reason, failure="worker")
    raise CampaignError(
        f"run {run.run_id} could not run on the cluster ({type(exc).__name__}: {message}); the finished runs are kept: "
        "check the workers (freefloat installed, the scenario's files at the same paths), then --resume"
    ) from exc


def _environment(outcome: RunOutcome, first: int = 0) -> CampaignError:
    which = f"the first {first} runs (the last: run {outcome.run_id})" if first else f"run {outcome.run_id}"
    return CampaignError(
        f"{which} could not run on worker {outcome.worker} ({outcome.reason}): the workers' environment, not "
        "the run, failed; nothing is stored for it and the finished runs are kept: make it importable there "
        "(installed, or on the workers' PYTHONPATH), then --resume"
    )


def _task(spec: CampaignSpec, run: Run) -> RunTask:
    return RunTask(run.run_id, run.index, spec.kind, spec.scenario, spec.base, spec.function, run.parameters, spec.scalars, spec.series)


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
    worker_timeout: float | None = None,
) -> CampaignRun:
    """Run the campaign's missing runs into ``out`` (module docstring). ``max_runs``: only the first N of the plan;
    ``window``: runs submitted at a time (default twice the cluster's threads, at least 4); ``on_started``: called
    with the client once it is connected; ``numba_threads``: threads of the batched kernels in each run (default: each
    machine's cores shared between the task threads of the workers on it, :func:`.cluster.share_threads`, as
    :func:`.cluster.local_threads` shares them on a local cluster);
    ``worker_timeout``: seconds to wait for a worker (default :data:`WORKER_TIMEOUT`).

    Before the plan is drawn and before any cluster starts: the options, ``out`` and (with ``resume``) every stored
    part and series are checked (:meth:`CampaignStore.survey`)."""
    start = time.perf_counter()
    if max_runs is not None and max_runs < 1:
        raise CampaignError(f"--max-runs: expected at least 1, got {max_runs}")
    if worker_timeout is not None and not 0 < worker_timeout < 1e6:
        raise CampaignError(f"--worker-timeout: expected seconds between 0 and 1e6, got {worker_timeout}")
    check_cluster_options(scheduler, workers=workers, memory_limit=memory_limit)
    CampaignStore.check(out, spec, resume=resume)  # a refused directory or a bad option: nothing drawn, nothing written
    plan = plan_runs(spec)
    selected = plan[:max_runs] if max_runs is not None else plan
    counts = {"ok": 0, "failed": 0, "environment": 0}
    reasons: list[str] = []
    first_result: list[float] = []
    interrupted = False
    with contextlib.ExitStack() as held:
        lock = CampaignStore.lock(out)  # an existing directory: held (or refused) before the survey and any cluster
        if lock is not None:
            held.callback(lock.close)
        found = CampaignStore.survey(out, spec, plan)  # a foreign part: refused here, nothing changed
        stored = found.finished
        todo = [run for run in selected if run.run_id not in stored]
        retried = sum(1 for run in todo if run.run_id in found.worker_failed)
        if found.damaged or found.lost_series:
            CampaignStore.open(out, spec, plan, resume=resume, lock=lock).repair(found)
        if todo:
            CampaignStore.probe(out)  # --out can take a part (links, or exclusive creation): before any cluster starts
            try:
                with (
                    dask_client(scheduler, workers=workers, memory_limit=memory_limit, numba_threads=numba_threads,
                                worker_timeout=worker_timeout) as client,
                    CampaignStore.open(out, spec, plan, resume=resume, lock=lock) as store,
                ):  # fmt: skip
                    if on_started is not None:
                        on_started(client)
                    limit = window or max(4, 2 * sum(client.nthreads().values()))
                    bar = Progress(progress, float(len(todo)), what=f"campaign {spec.campaign_id}", unit="runs", rate=True)
                    patience = WORKER_TIMEOUT if worker_timeout is None else worker_timeout
                    timing = (flush_seconds, flush_runs, patience)
                    try:
                        interrupted = _drive(client, spec, store, todo, limit, bar, counts, reasons, timing, scheduler, first_result)
                    finally:
                        bar.close()
            except KeyboardInterrupt:  # (Ctrl-C, SIGTERM while the cluster starts, waits for workers or stops: nothing lost)
                interrupted = True
    return CampaignRun(
        Path(out), spec.campaign_id, len(plan), len(selected), len(selected) - len(todo), counts["ok"], counts["failed"],
        interrupted, time.perf_counter() - start, counts["environment"], reasons[0] if reasons else "", retried,
        first_result[0] - start if first_result else None,
    )  # fmt: skip


def _drive(
    client: Any,
    spec: CampaignSpec,
    store: CampaignStore,
    todo: list[Run],
    limit: int,
    bar: Progress,
    counts: dict[str, int],
    reasons: list[str],
    timing: tuple[float, int, float],
    scheduler: str | None = None,
    first_result: list[float] | None = None,
) -> bool:
    """Submit, collect and store; True when interrupted (Ctrl-C, SIGTERM). ``timing``: (flush every so many s, or so
    many rows; the seconds a cluster may have no worker while runs wait); ``first_result`` gets the time
    (``time.perf_counter``) at which the first run finished."""
    from distributed import as_completed

    flush_seconds, flush_runs, patience = timing
    compiling = _compile_news(client)
    first_result = [] if first_result is None else first_result
    queue = iter(todo)
    running: dict[Any, Run] = {}
    finished = as_completed(loop=client.loop)
    pending: list[RunOutcome] = []
    flushed = time.perf_counter()
    stopping = False
    log = logging.getLogger("freefloat.progress")
    alone: float | None = None  # since when the cluster has had no worker

    def submit() -> None:
        while len(running) < limit:
            run = next(queue, None)
            if run is None:
                return
            future = client.submit(execute_run, _task(spec, run), key=f"freefloat-run-{run.run_id}", retries=0)
            running[future] = run
            finished.add(future)

    def wait() -> None:
        """Until a run finishes (0.1 s steps: Ctrl-C gets through); a CampaignError when no worker is left for long."""
        nonlocal alone
        while not finished.has_ready():
            time.sleep(0.1)
            workers = client.nthreads()
            _say_compiles(bar, compiling, workers)
            if workers:
                alone = None
                continue
            now = time.perf_counter()
            if alone is None:
                alone = now
                log.info("waiting for workers: the cluster has none (%d runs waiting; giving up after %g s)", len(running), patience)
            elif now - alone > patience:
                raise CampaignError(
                    f"the cluster has had no worker for {patience:g} s; the finished runs are kept: start workers, then --resume"
                )

    def collect() -> None:
        """Store every run of the batch that finished, then raise the first error of the batch (none is lost)."""
        wait()
        errors: list[CampaignError] = []
        for future in finished.next_batch(block=False):
            run = running.pop(future)
            try:
                outcome = future.result()
            except Exception as exc:  # (a run's own failure is an outcome: this is the cluster's)
                try:
                    outcome = _lost(run, exc)
                except CampaignError as error:
                    errors.append(error)
                    continue
            finally:
                future.release()
            if outcome.status == "environment":
                counts["environment"] += 1
                reasons.append(outcome.reason)
                first = counts["environment"] if counts["ok"] + counts["failed"] == 0 else 0
                if outcome.failure == "module" or first >= ENVIRONMENT_STOP:
                    errors.append(_environment(outcome, first if outcome.failure != "module" else 0))
                continue
            store.write_series(outcome)
            pending.append(outcome)
            counts[outcome.status] += 1
        done = counts["ok"] + counts["failed"] + counts["environment"]
        if done and not first_result:
            first_result.append(time.perf_counter())
        bar.update(float(done))
        if errors:
            raise errors[0]

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
        log.warning("stopping: waiting for the %d runs in progress (Ctrl-C again to leave them)", len(running))
        with contextlib.suppress(KeyboardInterrupt):
            while running:
                collect()
        for future in running:
            future.cancel()
    except CampaignError:
        for future in running:
            future.cancel()
        raise
    except OSError as exc:  # (the scheduler gone: Dask's "Timed out trying to connect", a closed comm)
        where = f"--scheduler {scheduler}" if scheduler else "the local cluster"
        raise CampaignError(
            f"{where}: the scheduler stopped answering ({_one_line(exc)}); the finished runs are kept: start it again, then --resume"
        ) from None
    finally:
        flush()
        with contextlib.suppress(Exception):  # (the scheduler gone: nothing to unsubscribe from)
            client.unsubscribe_topic(_compile_topic())
    return stopping


def _compile_news(client: Any) -> dict[str, float]:
    """The workers compiling the engine's kernels now, as their :class:`.worker_threads.CompileNews` tell the client:
    {worker address: since (this process's clock)}, kept up to date by Dask's event handler."""
    compiling: dict[str, float] = {}

    def heard(event: tuple[float, dict[str, Any]]) -> None:
        news = event[1]
        if news.get("what"):
            compiling.setdefault(str(news["worker"]), time.perf_counter() - float(news.get("seconds", 0.0)))
        else:
            compiling.pop(str(news.get("worker")), None)

    client.subscribe_topic(_compile_topic(), heard)
    return compiling


def _compile_topic() -> str:
    from .worker_threads import COMPILE_TOPIC  # (Dask's plugin module: imported once a campaign has a cluster)

    return COMPILE_TOPIC


def _say_compiles(bar: Progress, compiling: dict[str, float], workers: dict[str, Any]) -> None:
    """The progress says how many workers compile the engine (a worker that left the cluster no longer counts), and the
    time it waits for them is left out of its estimate of the time left."""
    for gone in [address for address in list(compiling) if address not in workers]:
        compiling.pop(gone, None)
    count = len(compiling)
    bar.waiting(f"{count} worker{'s' if count > 1 else ''} compiling the engine" if count else None)
