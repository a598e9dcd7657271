"""The campaign's Dask worker plugins: the numba threads of its runs, and what the worker compiles, told to the client
(a module of its own: Dask's plugin class is imported only when a campaign connects to a cluster)."""

from __future__ import annotations

import contextlib
import os
from typing import Any
from urllib.parse import urlsplit

from distributed.diagnostics.plugin import WorkerPlugin

__all__ = ["COMPILE_TOPIC", "CompileNews", "ThreadShare"]

#: The Dask event topic on which each worker says when it starts and ends a compile of the engine's kernels.
COMPILE_TOPIC = "freefloat-compiles"


class ThreadShare(WorkerPlugin):
    """A Dask worker plugin (``Client.register_plugin``) that sets the numba threads of the campaign's runs in each
    worker, those there and those that join (:data:`.execute.NUMBA_THREADS`): ``threads`` when given, else the
    worker's machine's cores shared between the task threads of the workers on that machine (``task_threads``: by
    host, as the scheduler saw them; a worker on another host: its own threads), as a local cluster shares them. A
    worker started by hand (``dask worker``) otherwise runs each run on all the machine's cores, beside the other
    workers' runs."""

    name = "freefloat-numba-threads"

    def __init__(self, threads: int | None, task_threads: dict[str, int]) -> None:
        self.threads = threads
        self.task_threads = task_threads

    def setup(self, worker: Any) -> None:
        from . import execute

        host = urlsplit(worker.address).hostname or ""
        sharing = max(self.task_threads.get(host, 0), int(worker.state.nthreads))
        execute.NUMBA_THREADS[:] = [self.threads or max(1, (os.cpu_count() or 1) // sharing)]


class CompileNews(WorkerPlugin):
    """A Dask worker plugin that tells the campaign's client when the worker starts to compile one of the engine's
    kernels (or to wait for another process of its machine that compiles it) and when that has ended: an event of
    :data:`COMPILE_TOPIC` (``Worker.log_event``) ``{"worker": address, "what": what it does, "" at the end, "seconds":
    how long it has lasted}``, from the engine's compile watcher (``engine.watch_compiles``)."""

    name = "freefloat-compile-news"

    def __init__(self) -> None:
        self._watching: contextlib.ExitStack | None = None

    def setup(self, worker: Any) -> None:
        from .. import engine

        compiling = [False]

        def said(what: str | None, seconds: float) -> None:
            if (what is not None) == compiling[0]:
                return
            compiling[0] = what is not None
            worker.log_event(COMPILE_TOPIC, {"worker": worker.address, "what": what or "", "seconds": seconds})

        self._watching = contextlib.ExitStack()
        self._watching.enter_context(engine.watch_compiles(said))

    def teardown(self, worker: Any) -> None:
        if self._watching is not None:
            self._watching.close()
            self._watching = None
