"""Helpers of the campaign tests that start Dask clusters: a scheduler and workers as separate processes on 127.0.0.1,
the ``freefloat campaign`` command as a process, and the campaigns of ``campaign_runs`` that count their computations.
"""

from __future__ import annotations

import contextlib
import json
import os
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import tomli_w

from freefloat.campaigns import read_runs

ROOT = Path(__file__).resolve().parents[2]
TESTS = ROOT / "tests"
#: Seconds any wait in these tests may last before it fails the test.
PATIENCE = 90.0


def environment(*extra: Path) -> dict[str, str]:
    """The commands' environment: this checkout's freefloat and the tests' run functions (campaign_runs) importable
    (and the folders ``extra``), and a scheduler that forgives a run one dead worker (as the command's local clusters do)."""
    paths = [str(ROOT / "src"), str(TESTS), *map(str, extra), *filter(None, [os.environ.get("PYTHONPATH")])]
    return {**os.environ, "PYTHONPATH": os.pathsep.join(paths), "DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES": "1"}


def wait_for(condition: Callable[[], Any], what: str, seen: Callable[[], str] = str) -> Any:
    """Poll ``condition`` until it is true (the processes run on their own: nothing to join on); fail after PATIENCE,
    with what ``seen`` shows (the output so far)."""
    give_up = time.monotonic() + PATIENCE
    while not (value := condition()):
        assert time.monotonic() < give_up, f"gave up waiting for {what}; seen:\n{seen()}"
        time.sleep(0.05)
    return value


@dataclass
class Cluster:
    address: str
    folder: Path
    processes: list[subprocess.Popen[bytes]]
    env: dict[str, str] = field(default_factory=dict)  # the workers' environment beyond environment()

    @property
    def modules(self) -> Path:
        """A folder on the workers' module path (a test writes a module there to fix the workers' environment)."""
        return self.folder / "modules"

    def worker(self, name: str) -> subprocess.Popen[bytes]:
        """A worker process of its own (no nanny: its pid is the worker's), registered with the scheduler."""
        log = self.folder / f"{name}.log"
        command = [sys.executable, "-m", "distributed.cli.dask_worker", self.address, "--nthreads", "1", "--no-nanny"]
        with log.open("wb") as sink:  # the child keeps its own descriptor
            env = {**environment(self.modules), **self.env}
            process = subprocess.Popen([*command, "--no-dashboard", "--name", name], env=env, stdout=subprocess.DEVNULL, stderr=sink)
        self.processes.append(process)
        wait_for(lambda: "Registered to" in log.read_text(errors="replace"), f"worker {name} to register")
        return process


@contextlib.contextmanager
def start_cluster(folder: Path, workers: tuple[str, ...] = ("w1", "w2"), env: dict[str, str] | None = None) -> Iterator[Cluster]:
    """A scheduler (and ``workers``, with ``env`` added to their environment) started in ``folder``, stopped at the end
    (the workers first)."""
    file = folder / "scheduler.json"
    command = [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard"]
    with (folder / "scheduler.log").open("wb") as sink:
        scheduler = subprocess.Popen([*command, "--scheduler-file", str(file)], env=environment(), stdout=subprocess.DEVNULL, stderr=sink)
    running = Cluster("", folder, [scheduler], dict(env or {}))
    running.modules.mkdir()
    try:
        running.address = wait_for(lambda: file.is_file() and json.loads(file.read_text() or "{}").get("address"), "the scheduler file")
        for name in workers:
            running.worker(name)
        yield running
    finally:  # the workers first (they say goodbye to the scheduler), then the scheduler; a process that lingers is killed
        for group in (running.processes[1:], running.processes[:1]):
            for process in group:
                process.terminate()
            for process in group:
                try:
                    process.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    process.kill()
                    process.wait()


def campaign(folder: Path, name: str = "campaign.toml", **tables: Any) -> Path:
    path = folder / name
    path.write_text(tomli_w.dumps(tables))
    return path


#: Starts a command with Ctrl-C (SIGINT) and SIGQUIT at their defaults, as a shell starts a foreground job: a process
#: keeps an ignored signal across exec (Python then installs no KeyboardInterrupt), and the test's own process had both
#: ignored at times on a fresh clone (the runner's /proc status showed SigIgn with SIGINT and SIGQUIT, which the C
#: library's system() ignores in its caller while its child runs: some thread of the test process was in one).
AS_A_SHELL = (
    "import os, signal, sys; [signal.signal(s, signal.SIG_DFL) for s in (signal.SIGINT, signal.SIGQUIT)]; "
    "os.execv(sys.argv[1], sys.argv[1:])"
)


def freefloat(*args: str | Path, wait: bool = True) -> Any:
    command = [sys.executable, "-X", "faulthandler", "-m", "freefloat", "campaign", *map(str, args), "--no-progress"]
    if not wait:  # a session of its own: a signal to its process group is a terminal's Ctrl-C
        return subprocess.Popen(
            [sys.executable, "-c", AS_A_SHELL, *command],
            env=environment(),
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            start_new_session=True,
        )
    return subprocess.run(command, env=environment(), capture_output=True, text=True, timeout=300)


def marked_campaign(folder: Path, runs: int, *, gated: bool) -> Path:
    """``runs`` runs of campaign_runs.marked, writing their files in ``folder/marks`` (gated: each waits for its gate)."""
    (folder / "marks").mkdir()
    parameters = {"i": {"values": list(range(runs))}, "dir": {"values": [str(folder / "marks")]}, "gated": {"values": [gated]}}
    return campaign(folder, function="campaign_runs:marked", parameters=parameters, record={"scalars": ["square"], "series": ["steps"]})


def marks(folder: Path, kind: str) -> list[int]:
    """The run indices of the ``kind`` ("start" or "done") files, one entry per file."""
    return sorted(int(p.name.split("-")[1]) for p in (folder / "marks").glob(f"{kind}-*"))


def stored(out: Path) -> list[str]:
    return read_runs(out).column("run_id").to_pylist()
