"""The Dask cluster of a campaign: a client on an existing scheduler (checked within a stated time) or on a new local
cluster of worker processes on 127.0.0.1 (:func:`dask_client`), and the cluster options checked before any work."""

from __future__ import annotations

import contextlib
import logging
import os
import socket
from collections.abc import Iterator
from typing import Any
from urllib.parse import urlsplit

from ..core.errors import CampaignError

__all__ = [
    "ALLOWED_FAILURES",
    "CONNECT_TIMEOUT",
    "WORKER_TIMEOUT",
    "check_cluster_options",
    "dask_client",
    "local_threads",
    "share_threads",
]

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
        with _quiet("distributed.client"), client:  # (its ERROR lines when the scheduler goes: our one line says it)
            _wait_for_workers(client, scheduler, WORKER_TIMEOUT if worker_timeout is None else worker_timeout)
            share_threads(client, numba_threads)
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
        share_threads(client, threads)
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
def _quiet(name: str) -> Iterator[None]:
    """The logger ``name`` silenced for the block."""
    logger = logging.getLogger(name)
    previous = logger.level
    logger.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        logger.setLevel(previous)


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


def share_threads(client: Any, threads: int | None) -> None:
    """Register :class:`.worker_threads.ThreadShare` with the cluster of ``client`` (the task threads by host, from the
    scheduler): every worker, there or joining, runs each run on its share of its machine's cores; and
    :class:`.worker_threads.CompileNews`: every worker tells the client when it compiles the engine's kernels."""
    from .worker_threads import CompileNews, ThreadShare

    task_threads: dict[str, int] = {}
    for address, count in client.nthreads().items():
        host = urlsplit(address).hostname or ""
        task_threads[host] = task_threads.get(host, 0) + int(count)
    client.register_plugin(ThreadShare(threads, task_threads))
    client.register_plugin(CompileNews())


def local_threads(workers: int) -> int:
    """Threads of the batched kernels in each worker of a local cluster: the machine's cores shared between them."""
    return max(1, (os.cpu_count() or 1) // workers)
