"""The numba threads of a campaign's runs on its workers: a Dask worker plugin (a module of its own: Dask's plugin
class is imported only when a campaign connects to a cluster)."""

from __future__ import annotations

import os
from typing import Any
from urllib.parse import urlsplit

from distributed.diagnostics.plugin import WorkerPlugin

__all__ = ["ThreadShare"]


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
