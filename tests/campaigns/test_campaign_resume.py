"""A campaign's store under damage, and the failures that are not a run's (a real scheduler and workers on 127.0.0.1).

- parts deleted, truncated and swapped, series deleted and swapped between two resumes: every finished run kept bit
  for bit, the damaged files moved aside (never deleted), only the runs whose results were lost computed again (the
  ``done-I-PID`` files of ``campaign_runs.marked`` count the computations), and nothing after that;
- a function module that the workers cannot import stops the campaign, stores nothing, and ``--resume`` runs every
  run once the module is there;
- a scheduler without workers, the last worker killed, a plain TCP server at the address: one clear error each, within
  the stated time.
"""

from __future__ import annotations

import shutil
import signal
import socket
import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import zarr
from clusters import Cluster, campaign, freefloat, marked_campaign, marks, start_cluster, wait_for

from freefloat.campaigns import load_campaign, plan_runs, read_runs, read_series, run_campaign
from freefloat.campaigns.store import DamagedStoreWarning
from freefloat.core.errors import CampaignError


@pytest.fixture(scope="module")
def cluster(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cluster]:
    with start_cluster(tmp_path_factory.mktemp("dask")) as running:
        yield running


def parts(out: Path) -> list[Path]:
    return sorted((out / "runs").glob("part-*.parquet"))


def test_damaged_parts_and_series_are_run_again_and_every_finished_run_is_kept(cluster: Cluster, tmp_path: Path) -> None:
    spec = load_campaign(marked_campaign(tmp_path, 12, gated=False))
    out = tmp_path / "out"
    first = run_campaign(spec, out, scheduler=cluster.address, progress=False, flush_runs=3, window=3)
    assert (first.ok, first.failed) == (12, 0) and len(parts(out)) >= 4
    rows = {row["run_id"]: row for row in read_runs(out).to_pylist()}
    series = {run_id: read_series(out, run_id) for run_id in rows}
    files = {path.name: path.read_bytes() for path in parts(out)}
    ids_of = {path.name: read_runs_of(path) for path in parts(out)}
    deleted, truncated, a, b = parts(out)[:4]
    deleted.unlink()
    truncated.write_bytes(files[truncated.name][: len(files[truncated.name]) // 2])
    a.rename(tmp_path / "a"), b.rename(a), (tmp_path / "a").rename(b)  # two parts swap names: both still whole
    kept = sorted(set(rows) - set(ids_of[deleted.name]) - set(ids_of[truncated.name]))
    x, y, z = kept[:3]
    store = out / "series.zarr"
    (store / x).rename(tmp_path / "x"), (store / y).rename(store / x), (tmp_path / "x").rename(store / y)  # swapped series
    shutil.rmtree(store / z)  # lost series
    lost = {*ids_of[deleted.name], *ids_of[truncated.name], x, y, z}
    with pytest.warns(DamagedStoreWarning) as warned:
        again = run_campaign(spec, out, scheduler=cluster.address, resume=True, progress=False)
    said = [str(w.message) for w in warned]
    assert any(str(truncated) in m and "is damaged" in m for m in said), said
    assert all(any(f"run {r} is stored but" in m for m in said) for r in (x, y, z)), said
    assert (again.ok, again.skipped) == (len(lost), 12 - len(lost))
    # the damaged part and the swapped series are kept aside, bit for bit; the parts left whole are never rewritten
    assert (out / "damaged" / truncated.name).read_bytes() == files[truncated.name][: len(files[truncated.name]) // 2]
    assert sorted(p.name for p in (out / "damaged" / "series").iterdir()) == sorted([x, y])
    assert all(b_.read_bytes() == files[name] for name in files if (b_ := out / "runs" / name).exists() and name not in (a.name, b.name))
    assert a.read_bytes() == files[b.name] and b.read_bytes() == files[a.name]
    # every run stored once: the kept ones bit for bit, the lost ones computed again to the same numbers
    now = {row["run_id"]: row for row in read_runs(out).to_pylist()}
    assert set(now) == set(rows)
    for run_id, row in now.items():
        if run_id in lost:
            assert {k: v for k, v in row.items() if k not in ("seconds", "worker")} == {
                k: v for k, v in rows[run_id].items() if k not in ("seconds", "worker")
            }
        else:
            assert row == rows[run_id]
        got = read_series(out, run_id)
        assert got.keys() == series[run_id].keys() == {"t", "steps"}
        assert all(np.array_equal(got[k], series[run_id][k]) for k in got)
    index = {r.run_id: r.index for r in plan_runs(spec)}
    expected = sorted([*range(12), *(index[r] for r in lost)])
    assert marks(tmp_path, "done") == expected  # the lost runs computed twice, the others once
    # a second resume: nothing to do, nothing computed, no warning
    final = run_campaign(spec, out, scheduler=cluster.address, resume=True, progress=False)
    assert (final.ok, final.skipped) == (0, 12) and marks(tmp_path, "done") == expected
    # one Zarr store: a group per run, with its time axis
    root = zarr.open_group(str(store), mode="r")
    assert sorted(name for name, _ in root.groups()) == sorted(rows)
    assert np.array_equal(root[x]["t"][...], 0.5 * np.arange(index[x] + 1))


def read_runs_of(path: Path) -> list[str]:
    import pyarrow.parquet as pq

    return pq.read_table(path, columns=["run_id"]).column("run_id").to_pylist()


def test_an_unimportable_function_stores_nothing_and_resume_runs_it_once_fixed(cluster: Cluster, tmp_path: Path) -> None:
    module = f"late_{tmp_path.name.replace('-', '_')}"
    spec = load_campaign(
        campaign(tmp_path, function=f"{module}:run", parameters={"k": {"values": [1, 2, 3, 4]}}, record={"scalars": ["k2"]})
    )
    out = tmp_path / "out"
    with pytest.raises(
        CampaignError, match=rf"could not run on worker .*No module named '{module}'.*not the run, failed; nothing is stored"
    ):
        run_campaign(spec, out, scheduler=cluster.address, progress=False)
    assert not list((out / "runs").glob("part-*"))
    (cluster.modules / f"{module}.py").write_text("def run(p):\n    return {'k2': float(p['k'] ** 2)}\n")
    done = run_campaign(spec, out, scheduler=cluster.address, resume=True, progress=False)
    assert (done.ok, done.failed, done.skipped) == (4, 0, 0)
    assert read_runs(out).column("k2").to_pylist() == [1.0, 4.0, 9.0, 16.0]


def test_an_import_error_inside_one_run_leaves_it_unfinished_and_the_campaign_goes_on(cluster: Cluster, tmp_path: Path) -> None:
    module = f"inside_{tmp_path.name.replace('-', '_')}"
    flag = tmp_path / "broken"
    flag.touch()
    source = (
        "import os\n"
        "def run(p):\n"
        f"    if p['k'] == 2 and os.path.exists({str(flag)!r}):\n"
        "        from math import nonexistent\n"
        "    return {'k2': float(p['k'] ** 2)}\n"
    )
    (cluster.modules / f"{module}.py").write_text(source)
    spec = load_campaign(
        campaign(tmp_path, function=f"{module}:run", parameters={"k": {"values": [1, 2, 3, 4]}}, record={"scalars": ["k2"]})
    )
    out = tmp_path / "out"
    first = run_campaign(spec, out, scheduler=cluster.address, progress=False)
    assert (first.ok, first.failed, first.unfinished) == (3, 0, 1) and "cannot import name 'nonexistent'" in first.unfinished_reason
    assert "1 not finished (a module missing on the workers: ImportError" in first.line() and "--resume runs them again" in first.line()
    assert read_runs(out).column("k2").to_pylist() == [1.0, 9.0, 16.0]
    flag.unlink()
    again = run_campaign(spec, out, scheduler=cluster.address, resume=True, progress=False)
    assert (again.ok, again.skipped, again.unfinished) == (1, 3, 0)
    assert read_runs(out).column("k2").to_pylist() == [1.0, 4.0, 9.0, 16.0]


def test_import_errors_in_the_first_runs_stop_the_campaign(cluster: Cluster, tmp_path: Path) -> None:
    from freefloat.campaigns.runner import ENVIRONMENT_STOP

    module = f"never_{tmp_path.name.replace('-', '_')}"
    (cluster.modules / f"{module}.py").write_text("def run(p):\n    import not_installed_anywhere\n")
    values = list(range(ENVIRONMENT_STOP + 4))
    spec = load_campaign(campaign(tmp_path, function=f"{module}:run", parameters={"k": {"values": values}}, record={"scalars": ["y"]}))
    with pytest.raises(CampaignError, match=rf"the first {ENVIRONMENT_STOP} runs .*could not run on worker .*not_installed_anywhere"):
        run_campaign(spec, tmp_path / "out", scheduler=cluster.address, progress=False, window=2)
    assert not list((tmp_path / "out" / "runs").glob("part-*"))


def test_a_run_that_killed_its_worker_runs_again_on_resume(cluster: Cluster, tmp_path: Path) -> None:
    from freefloat.campaigns.execute import RunOutcome
    from freefloat.campaigns.store import CampaignStore

    spec = load_campaign(marked_campaign(tmp_path, 2, gated=False))
    plan = plan_runs(spec)
    out = tmp_path / "out"
    first = run_campaign(spec, out, scheduler=cluster.address, progress=False, max_runs=1)
    assert first.ok == 1
    killed = RunOutcome(plan[1].run_id, 1, "failed", "KilledWorker: the worker running it died", failure="worker")
    with CampaignStore.open(out, spec, plan, resume=True) as store:
        store.add([killed])
    old = {path.name: path.read_bytes() for path in parts(out)}
    again = run_campaign(spec, out, scheduler=cluster.address, resume=True, progress=False)
    assert (again.ok, again.skipped, again.retried) == (1, 1, 1) and "1 ok (1 that had killed their worker run again)" in again.line()
    assert marks(tmp_path, "done") == [0, 1]
    assert read_runs(out).column("status").to_pylist() == ["ok", "ok"]
    assert all((out / "runs" / name).read_bytes() == data for name, data in old.items())  # the old rows kept on disk


def test_a_scheduler_without_workers_and_the_last_worker_killed(tmp_path: Path) -> None:
    spec = load_campaign(marked_campaign(tmp_path, 3, gated=True))
    with start_cluster(tmp_path, workers=()) as lonely:
        with pytest.raises(CampaignError, match=r"no worker joined the scheduler within 0\.5 s; start workers \(dask worker tcp://"):
            run_campaign(spec, tmp_path / "a", scheduler=lonely.address, progress=False, worker_timeout=0.5)
        assert not (tmp_path / "a").exists()
        # the command says what it waits for, and SIGTERM (a batch system's time limit) ends the wait with no traceback
        command = freefloat(spec.source, "--out", tmp_path / "c", "--scheduler", lonely.address, "--worker-timeout", "60", wait=False)
        said: list[str] = []
        reader = threading.Thread(target=lambda: said.extend(command.stderr), daemon=True)
        reader.start()
        wait_for(lambda: "waiting for workers at" in "".join(said), "the waiting line", lambda: "".join(said))
        command.send_signal(signal.SIGTERM)
        output = command.stdout.read()
        assert command.wait(timeout=60) == 130 and "interrupted" in output, "".join(said)
        reader.join(10)
        command.stdout.close(), command.stderr.close()
        assert "Traceback" not in "".join(said) and "giving up after 60 s" in "".join(said)
        worker = lonely.worker("only")

        def kill_when_started() -> None:
            wait_for(lambda: marks(tmp_path, "start"), "a run to start")
            worker.kill()

        killer = threading.Thread(target=kill_when_started)
        killer.start()
        with pytest.raises(CampaignError, match=r"the cluster has had no worker for 1 s; the finished runs are kept"):
            run_campaign(spec, tmp_path / "b", scheduler=lonely.address, progress=False, worker_timeout=1.0)
        killer.join()
        assert marks(tmp_path, "done") == []


def test_a_scheduler_that_goes_away_is_one_line_and_the_finished_runs_are_kept(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    import logging

    import dask

    spec = load_campaign(marked_campaign(tmp_path, 3, gated=True))
    with start_cluster(tmp_path, workers=("only",)) as doomed:
        scheduler = doomed.processes[0]

        def kill_when_started() -> None:
            wait_for(lambda: marks(tmp_path, "start"), "a run to start")
            scheduler.kill()

        killer = threading.Thread(target=kill_when_started)
        killer.start()
        with (
            dask.config.set({"distributed.comm.timeouts.connect": "1s"}),
            pytest.raises(
                CampaignError, match=rf"--scheduler {doomed.address}: the scheduler stopped answering .*finished runs are kept.*--resume"
            ),
        ):
            run_campaign(spec, tmp_path / "out", scheduler=doomed.address, progress=False, worker_timeout=30.0)
        killer.join()
    assert not [r for r in caplog.records if r.name.startswith("distributed.client") and r.levelno >= logging.ERROR]


@pytest.mark.parametrize(
    ("answer", "words"),
    [
        (b"", "something that accepts connections but did not answer as a Dask scheduler"),
        (b"HTTP/1.0 200 OK\r\n\r\n" * 64, "a program that does not speak Dask"),
    ],
)
def test_a_plain_tcp_server_is_not_a_scheduler(tmp_path: Path, answer: bytes, words: str) -> None:
    spec = load_campaign(marked_campaign(tmp_path, 2, gated=False))
    with socket.create_server(("127.0.0.1", 0)) as server:
        accepted: list[socket.socket] = []

        def serve() -> None:  # every connection (the command's probe, then Dask's) until the server closes
            while True:
                try:
                    connection, _ = server.accept()
                except OSError:
                    return
                accepted.append(connection)
                connection.sendall(answer)

        thread = threading.Thread(target=serve, daemon=True)
        thread.start()
        address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
        with pytest.raises(CampaignError, match=rf"--scheduler {address}: {words}.* is there, not a Dask scheduler"):
            run_campaign(spec, tmp_path / "out", scheduler=address, progress=False)
        server.shutdown(socket.SHUT_RDWR)  # (wakes the accept)
        thread.join(10)
        for connection in accepted:
            connection.close()
    assert not (tmp_path / "out").exists()
