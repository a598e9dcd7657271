"""Whose failure a run's is, and the store on odd filesystems and older formats (no cluster: seconds)."""

from __future__ import annotations

import errno
import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from freefloat.campaigns import campaign_from_dict, plan_runs, read_runs, read_series, summarize_campaign
from freefloat.campaigns.execute import RunOutcome, RunTask, execute_run
from freefloat.campaigns.store import CampaignStore, DamagedStoreWarning
from freefloat.core.errors import CampaignError


def function_task(function: str, **parameters: Any) -> RunTask:
    return RunTask("r0", 0, "function", {}, "", function, parameters, ("y",), ("s",))


@pytest.mark.parametrize(
    ("source", "words"),
    [
        ("def run(p:\n", "SyntaxError"),
        ("undefined_name\n", "NameError: name 'undefined_name' is not defined"),
        ("raise RuntimeError('no licence')\n", "RuntimeError: no licence"),
        ("from math import nonexistent\n", "ImportError"),
        ("x = 1\n", "has no run"),
    ],
)
def test_a_function_module_that_fails_to_load_is_the_environment(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, source: str, words: str
) -> None:
    module = f"broken_{abs(hash(source))}"
    (tmp_path / f"{module}.py").write_text(source)
    monkeypatch.syspath_prepend(str(tmp_path))
    outcome = execute_run(function_task(f"{module}:run"))
    assert (outcome.status, outcome.failure) == ("environment", "module") and words in outcome.reason


def test_an_import_error_inside_the_call_is_the_environment_of_that_run_only(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "late_import.py").write_text(
        "def run(p):\n    if p['k'] == 2:\n        from math import nonexistent\n    return {'y': 1.0, 's': [1.0, 2.0]}\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    assert execute_run(function_task("late_import:run", k=1)).status == "ok"
    outcome = execute_run(function_task("late_import:run", k=2))
    assert (outcome.status, outcome.failure) == ("environment", "import") and "nonexistent" in outcome.reason


@pytest.mark.parametrize("t", [0.5, [[0.0, 1.0]], [0.0, 1.0, 2.0]])
def test_a_t_that_is_not_the_series_time_axis_is_not_stored_and_fails_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, t: Any
) -> None:
    (tmp_path / "spectrum.py").write_text(f"def run(p):\n    return {{'y': 1.0, 's': [3.0, 4.0], 't': {t!r}}}\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    outcome = execute_run(function_task("spectrum:run"))
    assert outcome.status == "ok", outcome.reason
    assert list(outcome.series) == ["s"] and np.array_equal(outcome.series["s"], [3.0, 4.0])


def test_a_t_sampling_the_series_is_kept(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "sampled.py").write_text("def run(p):\n    return {'y': 1.0, 's': [3.0, 4.0], 't': [0.0, 0.5]}\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    outcome = execute_run(function_task("sampled:run"))
    assert list(outcome.series) == ["t", "s"] and np.array_equal(outcome.series["t"], [0.0, 0.5])


def small_campaign(tmp_path: Path, count: int = 4) -> Any:
    data = {
        "function": "campaign_runs:marked",
        "parameters": {"i": {"values": list(range(count))}, "dir": {"values": [str(tmp_path)]}},
        "record": {"scalars": ["square"], "series": ["steps"]},
    }
    return campaign_from_dict(data, source="f.toml", base=tmp_path)


def ok(run: Any) -> RunOutcome:
    i = run.parameters["i"]
    return RunOutcome(run.run_id, run.index, "ok", scalars={"square": float(i * i)}, series={"steps": np.arange(i + 1.0)})


def test_a_filesystem_without_hard_links_stores_every_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def no_links(src: Any, dst: Any, **_: Any) -> None:
        raise OSError(errno.EPERM, "Operation not permitted")

    monkeypatch.setattr(os, "link", no_links)
    spec = small_campaign(tmp_path)
    plan = plan_runs(spec)
    out = tmp_path / "out"
    CampaignStore.probe(out)
    with CampaignStore.open(out, spec, plan, resume=False) as store:
        for run in plan:
            store.write_series(ok(run))
        store.add([ok(run) for run in plan[:2]])
        store.add([ok(run) for run in plan[2:]])
    assert read_runs(out).column("square").to_pylist() == [0.0, 1.0, 4.0, 9.0]
    assert np.array_equal(read_series(out, plan[3].run_id)["steps"], np.arange(4.0))
    assert not [p for p in (out / "runs").iterdir() if not p.name.startswith("part-")]


def test_a_run_that_killed_its_worker_is_not_finished_for_resume(tmp_path: Path) -> None:
    spec = small_campaign(tmp_path, 2)
    plan = plan_runs(spec)
    out = tmp_path / "out"
    killed = RunOutcome(plan[1].run_id, 1, "failed", "KilledWorker: the worker running it died", failure="worker")
    with CampaignStore.open(out, spec, plan, resume=False) as store:
        store.write_series(ok(plan[0]))
        store.add([ok(plan[0]), killed])
    found = CampaignStore.survey(out, spec, plan)
    assert found.finished == {plan[0].run_id} and found.worker_failed == {plan[1].run_id}


def test_a_format_1_store_is_read_and_resumed(tmp_path: Path) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq
    import zarr

    spec = small_campaign(tmp_path, 3)
    plan = plan_runs(spec)
    out = tmp_path / "out"
    (out / "runs").mkdir(parents=True)
    manifest = {"format": "freefloat-campaign-1", "campaign_id": spec.campaign_id, "source": spec.source, "kind": "function",
                "runs": 3, "parameters": ["i", "dir"], "scalars": ["square"], "series": ["steps"]}  # fmt: skip
    (out / "campaign.json").write_text(json.dumps(manifest))
    schema = pa.schema(
        [("run_id", pa.string()), ("index", pa.int64()), ("status", pa.string()), ("reason", pa.string()),
         ("seconds", pa.float64()), ("worker", pa.string()), ("i", pa.int64()), ("dir", pa.string()), ("square", pa.float64())]
    ).with_metadata({"freefloat_campaign": spec.campaign_id})  # fmt: skip
    rows = [
        {"run_id": plan[0].run_id, "index": 0, "status": "ok", "reason": "", "seconds": 1.0, "worker": "w", "i": 0,
         "dir": str(tmp_path), "square": 0.0},
        {"run_id": plan[1].run_id, "index": 1, "status": "failed", "reason": "ValueError: no", "seconds": 1.0, "worker": "w",
         "i": 1, "dir": str(tmp_path), "square": float("nan")},
    ]  # fmt: skip
    pq.write_table(pa.Table.from_pylist(rows, schema=schema), out / "runs" / "part-000000.parquet")
    group = zarr.open_group(str(out / "series.zarr" / plan[0].run_id), mode="w")
    group.create_array("steps", data=np.arange(1.0))
    old = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    table = read_runs(out)
    assert table.column("failure").to_pylist() == ["", "run"] and table.column("status").to_pylist() == ["ok", "failed"]
    assert np.array_equal(read_series(out, plan[0].run_id)["steps"], np.arange(1.0))
    found = CampaignStore.survey(out, spec, plan)
    assert found.finished == {plan[0].run_id, plan[1].run_id} and not found.damaged and not found.lost_series
    with CampaignStore.open(out, spec, plan, resume=True) as store:
        store.write_series(ok(plan[2]))
        store.add([ok(plan[2])])
    table = read_runs(out)
    assert table.column("square").to_pylist()[::2] == [0.0, 4.0] and table.column("failure").to_pylist() == ["", "run", ""]
    assert all(path.read_bytes() == data for path, data in old.items())  # the old files untouched
    assert np.array_equal(read_series(out, plan[2].run_id)["steps"], np.arange(3.0))
    summary = summarize_campaign(out, spec)
    assert (summary.ok, summary.failed) == (2, 1) and summary.statistics["square"]["max"] == 4.0


def stored_campaign(tmp_path: Path, count: int = 3) -> tuple[Any, list[Any], Path]:
    spec = small_campaign(tmp_path, count)
    plan = plan_runs(spec)
    out = tmp_path / "out"
    with CampaignStore.open(out, spec, plan, resume=False) as store:
        for run in plan:
            store.write_series(ok(run))
        store.add([ok(run) for run in plan])
    return spec, plan, out


def test_an_emptied_series_chunk_is_damage_found_by_the_survey_and_named_by_the_reader(tmp_path: Path) -> None:
    spec, plan, out = stored_campaign(tmp_path)
    victim = plan[2].run_id
    chunks = [p for p in (out / "series.zarr" / victim / "steps").rglob("*") if p.is_file() and p.name != "zarr.json"]
    assert chunks
    for chunk in chunks:
        chunk.write_bytes(b"")
    with pytest.raises(CampaignError, match=rf"run {victim}: series\.zarr/{victim}/steps is damaged .*--resume"):
        read_series(out, victim)
    found = CampaignStore.survey(out, spec, plan)
    assert list(found.lost_series) == [victim] and found.finished == {plan[0].run_id, plan[1].run_id}


def test_a_part_that_cannot_be_read_is_an_error_not_damage(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import pyarrow.parquet as pq

    spec, plan, out = stored_campaign(tmp_path)

    def unreadable(path: Any, **_: Any) -> Any:
        raise OSError(errno.EIO, "Input/output error", str(path))

    monkeypatch.setattr(pq, "read_table", unreadable)
    with pytest.raises(CampaignError, match=r"part-\S+\.parquet: cannot be read \(Input/output error\).*nothing was moved"):
        CampaignStore.survey(out, spec, plan)
    assert not (out / "damaged").exists()


def test_a_part_with_other_columns_names_them(tmp_path: Path) -> None:
    import pyarrow.parquet as pq

    spec, plan, out = stored_campaign(tmp_path)
    part = next((out / "runs").glob("part-*.parquet"))
    table = pq.read_table(part)
    pq.write_table(table.drop_columns(["square"]), out / "runs" / "part-99999999999999999999-00000000-x.parquet")
    with pytest.raises(CampaignError, match=r"is a part of this campaign \(\w+\) with other columns \(no square\)"):
        CampaignStore.survey(out, spec, plan)


def test_a_lost_series_store_is_one_warning_line(tmp_path: Path) -> None:
    import shutil

    spec, plan, out = stored_campaign(tmp_path, 6)
    shutil.rmtree(out / "series.zarr")
    found = CampaignStore.survey(out, spec, plan)
    with pytest.warns(DamagedStoreWarning) as warned, CampaignStore.open(out, spec, plan, resume=True) as store:
        store.repair(found)
    assert len(warned) == 1, [str(w.message) for w in warned]
    assert f"6 stored runs have lost their series (runs {', '.join(r.run_id for r in plan[:3])}, ..." in str(warned[0].message)


def test_the_plan_size_limit_has_an_override_and_states_the_planning_cost() -> None:
    from freefloat.core.errors import ModelError

    data = {
        "function": "campaign_runs:marked",
        "parameters": {"i": {"linspace": [0.0, 1.0, 1000]}, "j": {"linspace": [0.0, 1.0, 1001]}},
        "record": {"scalars": ["square"]},
    }
    with pytest.raises(ModelError, match=r"1,001,000 runs, above the 1,000,000 .*planning them takes about 100 s .*\[runs\] max_plan"):
        campaign_from_dict(data, source="c.toml", base=Path("."))
    spec = campaign_from_dict({**data, "runs": {"max_plan": 1_001_000}}, source="c.toml", base=Path("."))
    assert spec.grid is not None and len(spec.grid["i"]) * len(spec.grid["j"]) == 1_001_000


def test_the_newest_row_is_the_part_stored_last_whatever_the_names(tmp_path: Path) -> None:
    from freefloat.campaigns.stored import StrayPartWarning

    spec, plan, out = stored_campaign(tmp_path, 1)
    with CampaignStore.open(out, spec, plan, resume=True) as store:
        newer = store.add([RunOutcome(plan[0].run_id, 0, "ok", scalars={"square": 7.0}, series={"steps": np.arange(1.0)})])
    older = next(p for p in (out / "runs").glob("part-*.parquet") if p != newer)
    assert newer is not None and older.name < newer.name
    older.rename(tmp_path / "swap"), newer.rename(older), (tmp_path / "swap").rename(newer)  # the newer now sorts first
    assert read_runs(out).column("square").to_pylist() == [7.0]  # the part stored last wins, not the name sorting last
    (out / "runs" / "part-copy.parquet").write_bytes(newer.read_bytes())
    with pytest.warns(StrayPartWarning, match=r"part-copy\.parquet: not a part's name .*not read"):
        assert read_runs(out).column("square").to_pylist() == [7.0]
