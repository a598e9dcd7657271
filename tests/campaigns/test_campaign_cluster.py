"""``freefloat campaign`` on real Dask clusters: a scheduler and workers started as separate processes on the loopback
address (one for the module), and local clusters of the command itself.

- the same campaign through ``--scheduler`` and on a local cluster: the same run ids and the same numbers;
- a worker killed mid-campaign, and a runner interrupted (Ctrl-C to its process group, local workers included;
  and ``--max-runs``) then resumed: every run stored once, and computed once (the ``done-I-PID`` files that each
  run writes count the computations);
- a worker that runs out of memory: its run is stored as failed with the reason, the others finish.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import tomli_w
from clusters import PATIENCE, Cluster, campaign, environment, freefloat, marked_campaign, marks, start_cluster, stored, wait_for

from freefloat.campaigns import load_campaign, plan_runs, read_runs, read_series


@pytest.fixture(scope="module")
def cluster(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cluster]:
    with start_cluster(tmp_path_factory.mktemp("dask")) as running:
        yield running


def test_scheduler_and_local_cluster_give_the_same_runs(cluster: Cluster, tmp_path: Path) -> None:
    scenario = {
        "model": "papadopoulos1992",
        "duration": 0.2,
        "initial": {"q_deg": [0.0, 90.0, 180.0, -90.0], "qdot": [0.0, 0.0, 0.0, 0.0]},
        "integrator": {"method": "RK4", "fixed_step": 0.01, "sample_period": 0.01, "output_period": 0.05},
        "controller": {"type": "joint_pd", "kp": 20.0, "kd": 30.0, "q_ref_deg": [40.0, 60.0, 170.0, -90.0]},
    }
    (tmp_path / "pd.toml").write_text(tomli_w.dumps(scenario))
    spec = campaign(
        tmp_path,
        scenario="pd.toml",
        runs={"count": 2, "seed": 11},
        parameters={"controller.kp": {"values": [10.0, 20.0]}, "initial.qdot[0]": {"distribution": "normal", "mean": 0.0, "std": 0.05}},
        record={"scalars": ["kinetic_energy.final", "angular_momentum_change", "final_state.q[1]"], "series": ["q", "omega"]},
    )
    # on the cluster: the first 3 runs (--max-runs), then the rest (--resume); here: all at once on a local cluster
    first = freefloat(spec, "--out", tmp_path / "cluster", "--scheduler", cluster.address, "--max-runs", "3")
    there = freefloat(spec, "--out", tmp_path / "cluster", "--scheduler", cluster.address, "--resume")
    here = freefloat(spec, "--out", tmp_path / "local", "--workers", "1")
    assert first.returncode == there.returncode == here.returncode == 0, first.stderr + there.stderr + here.stderr
    assert "3 ok, 0 failed, 0 already stored, of 3 selected (4 planned)" in first.stdout
    assert "1 ok, 0 failed, 3 already stored, of 4 selected" in there.stdout and "4 ok, 0 failed" in here.stdout
    a, b = (read_runs(tmp_path / name).drop_columns(["seconds", "worker"]) for name in ("cluster", "local"))
    assert a.equals(b)  # same ids, parameters and numbers, bit for bit
    assert a.column("run_id").to_pylist() == [r.run_id for r in plan_runs(load_campaign(spec))]
    for run_id in a.column("run_id").to_pylist():
        there_series, here_series = read_series(tmp_path / "cluster", run_id), read_series(tmp_path / "local", run_id)
        assert set(there_series) == {"t", "q", "omega"} and there_series["q"].shape == (5, 4)
        assert all(np.array_equal(there_series[k], here_series[k]) for k in there_series)
    assert (tmp_path / "cluster" / "report" / "summary.md").is_file()


def test_workers_started_by_hand_share_their_machine_s_cores(cluster: Cluster, tmp_path: Path) -> None:
    """The module's two workers, started as ``dask worker --nthreads 1`` without NUMBA_NUM_THREADS (numba's default:
    every core in each), run each run on half the machine's cores, as a local cluster of two workers does: the
    campaign registers its worker plugin (issue 44: set by freefloat, not by a recipe the user must follow)."""
    runs = {"i": {"values": [0, 1, 2, 3]}}
    spec = campaign(tmp_path, function="campaign_runs:threads", parameters=runs, record={"scalars": ["numba_threads"]})
    there = freefloat(spec, "--out", tmp_path / "cluster", "--scheduler", cluster.address)
    here = freefloat(spec, "--out", tmp_path / "local", "--workers", "2")
    assert there.returncode == here.returncode == 0, there.stderr + here.stderr
    share = max(1, (os.cpu_count() or 1) // 2)
    assert read_runs(tmp_path / "cluster").column("numba_threads").to_pylist() == [float(share)] * 4
    assert read_runs(tmp_path / "local").column("numba_threads").to_pylist() == [float(share)] * 4


def test_fresh_workers_load_the_portable_kernels_and_compile_nothing(tmp_path: Path) -> None:
    """A fresh cluster: a scheduler and two ``dask worker`` processes whose cache folder is empty. Each run loads the
    portable kernels freefloat ships; no worker compiles a kernel (numba's compile events, counted in every run)
    (issue 44: a fresh cluster is productive in seconds; the time to the first result is in ``make bench``)."""
    (tmp_path / "dask").mkdir()
    fresh = {"FREEFLOAT_CACHE_DIR": str(tmp_path / "empty"), "FREEFLOAT_KERNELS": "portable"}
    with start_cluster(tmp_path / "dask", env=fresh) as running:
        runs = {"i": {"values": [0, 1, 2, 3]}}
        spec = campaign(tmp_path, function="campaign_runs:compiles", parameters=runs, record={"scalars": ["compiles", "portable"]})
        done = freefloat(spec, "--out", tmp_path / "out", "--scheduler", running.address)
    assert done.returncode == 0, done.stderr
    table = read_runs(tmp_path / "out")
    assert table.column("portable").to_pylist() == [1.0] * 4
    assert table.column("compiles").to_pylist() == [0.0] * 4
    compiled = [f for f in (tmp_path / "empty").rglob("*.nbc") if not any(part.endswith("-portable") for part in f.parts)]
    assert compiled == [], "a worker wrote compiled kernels into its cache"


def test_the_client_says_while_fresh_workers_compile_the_engine(tmp_path: Path) -> None:
    """Two ``dask worker`` processes with an empty cache and no portable kernels (``FREEFLOAT_KERNELS=native``) compile
    the engine's kernel of the runs (one of them, the other waits for it: one machine); meanwhile the client's progress
    (a log line on stderr, not a terminal) says how many workers compile the engine and for how long (issue 44)."""
    (tmp_path / "dask").mkdir()
    fresh = {"FREEFLOAT_CACHE_DIR": str(tmp_path / "empty"), "FREEFLOAT_KERNELS": "native"}
    with start_cluster(tmp_path / "dask", env=fresh) as running:
        spec = campaign(tmp_path, function="campaign_runs:frames", parameters={"i": {"values": [0, 1, 2, 3]}}, record={"scalars": ["x"]})
        command = [sys.executable, "-m", "freefloat", "campaign", str(spec), "--out", str(tmp_path / "out"), "--scheduler", running.address]
        done = subprocess.run(command, env=environment(), capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "4 ok, 0 failed" in done.stdout, done.stdout
    said = re.findall(r"waiting: ([12]) workers? compiling the engine, (\S+) s elapsed", done.stderr)
    assert said, done.stderr
    assert list((tmp_path / "empty").rglob("*.nbc")), "no kernel compiled into the workers' cache"
    x = read_runs(tmp_path / "out").column("x").to_pylist()
    assert len(set(x)) == 4, x


def test_a_worker_killed_mid_campaign_loses_nothing(cluster: Cluster, tmp_path: Path) -> None:
    doomed = cluster.worker("doomed")
    spec = marked_campaign(tmp_path, 6, gated=True)
    runner = freefloat(spec, "--out", tmp_path / "out", "--scheduler", cluster.address, wait=False)
    wait_for(lambda: list((tmp_path / "marks").glob(f"start-*-{doomed.pid}-*")), "a run on the doomed worker")
    doomed.kill()
    doomed.wait(timeout=30)
    (tmp_path / "marks" / "gate").touch()
    output, errors = runner.communicate(timeout=PATIENCE)
    assert runner.returncode == 0, errors
    assert "6 ok, 0 failed" in output
    assert sorted(stored(tmp_path / "out")) == sorted(r.run_id for r in plan_runs(load_campaign(spec)))
    assert marks(tmp_path, "done") == list(range(6))  # each run computed to the end once
    assert len(marks(tmp_path, "start")) == 7  # the killed worker's run started again elsewhere


def stuck(runner: subprocess.Popen[str], said: list[str]) -> str:
    """What a runner that did not answer Ctrl-C was doing: its signal masks, then the stacks of its threads (SIGABRT
    to a process run with ``-X faulthandler``) after what it had written on stderr."""
    try:
        status = Path(f"/proc/{runner.pid}/status").read_text().splitlines()
        masks = "\n".join(line for line in status if line.startswith(("State", "SigPnd", "ShdPnd", "SigBlk", "SigIgn", "SigCgt")))
        here = [line for line in Path("/proc/self/status").read_text().splitlines() if line.startswith("SigIgn")]
        masks += f"\n(the test's process: {here[0] if here else '?'})"
    except OSError as exc:
        masks = f"(no status: {exc})"
    runner.send_signal(signal.SIGABRT)
    time.sleep(3.0)  # the dump, read by the test's reader thread
    return f"{masks}\n{''.join(said)}"


def test_an_interrupted_runner_resumes_without_computing_twice(cluster: Cluster, tmp_path: Path) -> None:
    spec = marked_campaign(tmp_path, 8, gated=True)
    out = tmp_path / "out"
    # on a local cluster of 2 workers, Ctrl-C as a terminal sends it: to the command and its workers alike
    runner = freefloat(spec, "--out", out, "--workers", "2", wait=False)
    assert runner.stderr is not None and runner.stdout is not None
    said: list[str] = []  # the runner's stderr, read as it comes (a blocking read would outlast PATIENCE)
    reader = threading.Thread(target=lambda: said.extend(runner.stderr), daemon=True)
    reader.start()
    try:
        wait_for(lambda: len(marks(tmp_path, "start")) >= 2, "two runs in progress")
        os.killpg(runner.pid, signal.SIGINT)
        waiting = wait_for(
            lambda: re.search(r"stopping: waiting for the (\d+) runs in progress", "".join(said)),
            "the runner to stop submitting",
            lambda: stuck(runner, said),
        )
    finally:
        (tmp_path / "marks" / "gate").touch()  # the runs in progress finish, and are stored
        output = runner.stdout.read()
        runner.wait(timeout=PATIENCE)
        reader.join(PATIENCE)
        runner.stdout.close()
        runner.stderr.close()
    assert runner.returncode == 130 and "interrupted" in output, "".join(said)
    first = stored(out)
    # the runs submitted when Ctrl-C came (2 running, 2 queued: the window of a 2-worker cluster), none of the others
    assert len(first) == int(waiting[1]) == 4, "".join(said)
    resumed = freefloat(spec, "--out", out, "--scheduler", cluster.address, "--resume")  # the same campaign on the cluster
    assert resumed.returncode == 0, resumed.stderr
    assert f"{8 - len(first)} ok, 0 failed, {len(first)} already stored" in resumed.stdout
    ids = stored(out)
    assert len(ids) == len(set(ids)) == 8 and set(first) < set(ids)
    assert marks(tmp_path, "done") == marks(tmp_path, "start") == list(range(8))


def test_a_worker_out_of_memory_fails_its_run_only(tmp_path: Path) -> None:
    spec = campaign(
        tmp_path, function="campaign_runs:allocate", parameters={"mib": {"values": [64, 8192]}}, record={"scalars": ["held_mib"]}
    )
    done = freefloat(spec, "--out", tmp_path / "out", "--workers", "1", "--memory-limit", "700MiB")
    assert done.returncode == 0, done.stderr
    assert "1 ok, 1 failed" in done.stdout
    table = read_runs(tmp_path / "out").to_pylist()
    assert (table[0]["mib"], table[0]["held_mib"], table[0]["status"]) == (64, 64.0, "ok")
    assert table[1]["status"] == "failed" and table[1]["reason"].startswith("KilledWorker: the worker running it died")
    assert table[1]["failure"] == "worker"
    assert "| 1 | worker | KilledWorker" in (tmp_path / "out" / "report" / "summary.md").read_text()
