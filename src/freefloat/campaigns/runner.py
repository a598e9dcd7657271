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
is stored as failed by its worker (``failure`` "worker"). The environment's failures (the function's module not
importable on a worker, freefloat missing there, the scheduler gone, no worker left) are never stored: they stop
the campaign with one error, the finished runs kept, and ``--resume`` runs the rest once the cluster is fixed.
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
from .store import CampaignStore

__all__ = ["CONNECT_TIMEOUT", "CampaignRun", "dask_client", "run_campaign"]

#: Seconds to wait for an external scheduler to answer.
CONNECT_TIMEOUT = 4.0
#: Seconds to wait for an external scheduler's first worker, and for a worker when a running campaign has none left.
WORKER_TIMEOUT = 60.0
#: The least memory a local worker can live in: a worker process that has run a simulation holds about 215 MiB
#: (freefloat, numba and Dask loaded), and Dask pauses a worker at 80 % of its limit.
MIN_WORKER_MEMORY = 320 << 20
#: The schemes of a scheduler's address this command connects to.
SCHEMES = ("tcp", "tls", "ws", "wss")
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
    scheduler: str | None = None,
    *,
    workers: int | None = None,
    memory_limit: str | None = None,
    numba_threads: int | None = None,
    worker_timeout: float | None = None,
) -> Iterator[Any]:
    """A Dask client on ``scheduler``, or on a new local cluster of ``workers`` processes (one task thread each) on
    127.0.0.1 with ``memory_limit`` per worker (e.g. "2GiB") and ``numba_threads`` for the batched kernels in each
    (default :func:`local_threads`: the cores shared between the workers); closed (and the cluster stopped) on exit.
    An existing scheduler must answer as one within :data:`CONNECT_TIMEOUT` and have a worker within
    ``worker_timeout`` (default :data:`WORKER_TIMEOUT`) s, else a CampaignError says which."""
    import dask
    from distributed import Client, LocalCluster

    check_cluster_options(scheduler, workers=workers, memory_limit=memory_limit)
    if scheduler is not None:
        _probe(scheduler)
        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT, set_as_default=False)
        except (OSError, ValueError, TypeError, MemoryError) as exc:
            raise CampaignError(f"--scheduler {scheduler}: the scheduler answered, then the connection failed ({_one_line(exc)})") from None
        with client:
            _wait_for_workers(client, scheduler, WORKER_TIMEOUT if worker_timeout is None else worker_timeout)
            yield client
        return
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


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


def check_cluster_options(scheduler: str | None, *, workers: int | None, memory_limit: str | None) -> None:
    """The cluster's options checked before any work (a CampaignError naming the option and the fix)."""
    if scheduler is not None:
        if workers is not None or memory_limit is not None:
            raise CampaignError("--workers and --memory-limit shape a local cluster; with --scheduler, the cluster's own workers run")
        _address(scheduler)
        scheme = urlsplit(scheduler).scheme
        if scheme in ("tls", "wss"):
            from distributed.security import Security

            if Security().get_connection_args("client").get("ssl_context") is None:
                raise CampaignError(
                    f"--scheduler {scheduler}: a {scheme} scheduler needs this client's certificates; set them in Dask's "
                    "configuration (DASK_DISTRIBUTED__COMM__TLS__CA_FILE, ..._CLIENT__CERT, ..._CLIENT__KEY) or use tcp://"
                )
        return
    cores = os.cpu_count() or 1
    if workers is not None and not 1 <= workers <= cores:
        raise CampaignError(
            f"--workers: expected 1 to {cores} (this machine's cores), got {workers}; a cluster of more machines: start one "
            "and give --scheduler"
        )
    if memory_limit is not None:
        from dask.utils import format_bytes, parse_bytes

        try:
            size = parse_bytes(memory_limit)
        except (ValueError, TypeError):
            raise CampaignError(f"--memory-limit {memory_limit}: not a size; give one such as 2GiB or 500MB") from None
        total = _total_memory()
        if size < MIN_WORKER_MEMORY:
            raise CampaignError(
                f"--memory-limit {memory_limit}: a worker with freefloat loaded needs at least {format_bytes(MIN_WORKER_MEMORY)}; "
                "give more (e.g. 2GiB)"
            )
        if total is not None and size * (workers or 1) > total:
            raise CampaignError(
                f"--memory-limit {memory_limit}: {workers or 1} worker(s) of {format_bytes(size)} exceed this machine's "
                f"{format_bytes(total)}; give less, or fewer --workers"
            )


def _total_memory() -> int | None:
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError):
        return None


def _probe(scheduler: str) -> None:
    """Ask ``scheduler`` who it is, within :data:`CONNECT_TIMEOUT` s: a CampaignError unless a Dask scheduler answers."""
    import asyncio
    import threading

    from distributed.comm import connect
    from distributed.security import Security

    args = Security().get_connection_args("client")

    host, port = _address(scheduler)
    try:  # nothing listening: refused at once, before Dask's retries
        socket.create_connection((host, port), timeout=CONNECT_TIMEOUT).close()
    except OSError as exc:
        raise CampaignError(
            f"--scheduler {scheduler}: no Dask scheduler answered within {CONNECT_TIMEOUT:g} s ({_one_line(exc)}); start one "
            "(dask scheduler) or check the address (tcp://host:port)"
        ) from None

    async def identity() -> Any:
        comm = await connect(scheduler, timeout=CONNECT_TIMEOUT, **args)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    answer: list[Any] = []

    def ask() -> None:  # (a thread of its own: the caller may be inside an event loop)
        try:
            answer.append(asyncio.run(asyncio.wait_for(identity(), CONNECT_TIMEOUT)))
        except BaseException as exc:  # (anything a non-scheduler's bytes make the reader raise)
            answer.append(exc)

    thread = threading.Thread(target=ask, daemon=True)
    thread.start()
    thread.join(CONNECT_TIMEOUT + 2.0)
    reply = answer[0] if answer else TimeoutError()
    if isinstance(reply, dict) and reply.get("type") == "Scheduler":
        return
    if isinstance(reply, dict) and reply.get("type"):
        what = f"a Dask {str(reply['type']).lower()}"
    elif isinstance(reply, (TimeoutError, asyncio.TimeoutError)):
        what = f"something that accepts connections but did not answer as a Dask scheduler within {CONNECT_TIMEOUT:g} s"
    else:
        what = "a program that does not speak Dask's protocol"
    raise CampaignError(
        f"--scheduler {scheduler}: {what} is there, not a Dask scheduler; give the scheduler's address (dask scheduler "
        "prints it: tcp://host:port)"
    )


def _wait_for_workers(client: Any, scheduler: str, timeout: float) -> None:
    """Wait until the cluster has a worker, saying so; a CampaignError after ``timeout`` s."""
    if client.nthreads():
        return
    log = logging.getLogger("freefloat.progress")
    log.info("waiting for workers at %s (none yet; giving up after %g s)", scheduler, timeout)
    try:
        client.wait_for_workers(1, timeout=timeout)
    except TimeoutError:
        raise CampaignError(
            f"--scheduler {scheduler}: no worker joined the scheduler within {timeout:g} s; start workers "
            f"(dask worker {scheduler} --nthreads 1) and run it again"
        ) from None


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
    if parts.scheme not in SCHEMES:
        raise CampaignError(f"--scheduler {address}: unknown scheme {parts.scheme}://; use tcp://host:port (or tls://, ws://, wss://)")
    return parts.hostname, port


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


def _environment(outcome: RunOutcome) -> CampaignError:
    return CampaignError(
        f"run {outcome.run_id} could not run on worker {outcome.worker} ({outcome.reason}): the workers' environment, not "
        "the run, failed; nothing is stored for it and the finished runs are kept: make it importable there "
        "(installed, or on the workers' PYTHONPATH), then --resume"
    )


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
    worker_timeout: float | None = None,
) -> CampaignRun:
    """Run the campaign's missing runs into ``out`` (module docstring). ``max_runs``: only the first N of the plan;
    ``window``: runs submitted at a time (default twice the cluster's threads, at least 4); ``on_started``: called
    with the client once it is connected; ``numba_threads``: threads of the batched kernels in each run (default: on a
    local cluster the cores shared between its workers, :func:`local_threads`; on an existing one, its workers');
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
    found = CampaignStore.survey(out, spec, plan)  # a foreign part: refused here, nothing changed
    stored = found.finished
    todo = [run for run in selected if run.run_id not in stored]
    counts = {"ok": 0, "failed": 0}
    interrupted = False
    if found.damaged or found.lost_series:
        with CampaignStore.open(out, spec, plan, resume=resume) as store:
            store.repair(found)
    if todo:
        try:
            with (
                dask_client(scheduler, workers=workers, memory_limit=memory_limit, numba_threads=numba_threads,
                            worker_timeout=worker_timeout) as client,
                CampaignStore.open(out, spec, plan, resume=resume) as store,
            ):  # fmt: skip
                if on_started is not None:
                    on_started(client)
                limit = window or max(4, 2 * sum(client.nthreads().values()))
                bar = Progress(progress, float(len(todo)), what=f"campaign {spec.campaign_id}", unit="runs", rate=True)
                patience = WORKER_TIMEOUT if worker_timeout is None else worker_timeout
                try:
                    interrupted = _drive(client, spec, store, todo, limit, bar, counts, (flush_seconds, flush_runs, patience))
                finally:
                    bar.close()
        except KeyboardInterrupt:  # (Ctrl-C, SIGTERM while the cluster starts, waits for workers or stops: nothing lost)
            interrupted = True
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
    timing: tuple[float, int, float],
) -> bool:
    """Submit, collect and store; True when interrupted (Ctrl-C, SIGTERM). ``timing``: (flush every so many s, or so
    many rows; the seconds a cluster may have no worker while runs wait)."""
    from distributed import as_completed

    flush_seconds, flush_runs, patience = timing
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
            if client.nthreads():
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
        wait()
        for future in finished.next_batch(block=False):
            run = running.pop(future)
            try:
                outcome = future.result()
            except Exception as exc:  # (a run's own failure is an outcome: this is the cluster's)
                outcome = _lost(run, exc)
            future.release()
            if outcome.status == "environment":
                raise _environment(outcome)
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
    finally:
        flush()
    return stopping
