"""Campaign files, their plans and run ids, one run in this process, the store and the reports (no cluster)."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from scipy import stats

import freefloat as ff
from freefloat.campaigns import campaign_from_dict, load_campaign, plan_runs, read_runs, read_series, summarize_campaign
from freefloat.campaigns.execute import RunOutcome, RunTask, execute_run
from freefloat.campaigns.maps import map_chunk, radius_bound
from freefloat.campaigns.spec import get_path, set_path
from freefloat.campaigns.store import CampaignStore
from freefloat.core.errors import CampaignError, ModelError

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / "examples" / "scenarios"


def capture_campaign(**extra: Any) -> dict[str, Any]:
    return {
        "scenario": "tumbling_satellite_capture.toml",
        "runs": {"count": 6, "seed": 7},
        "parameters": {
            "payload.mass": {"distribution": "uniform", "low": 400.0, "high": 600.0},
            "payload.angular_velocity[2]": {"distribution": "normal", "mean": 0.05, "std": 0.01},
            "grasp.joints": {"distribution": "choice", "values": ["free", "locked"]},
            "detumble.rate_gain": {"values": [0.25, 0.5]},
        },
        "record": {"scalars": ["sequence.detumble.delta_v"]},
        **extra,
    }


def spec_of(data: dict[str, Any]) -> Any:
    return campaign_from_dict(data, source="c.toml", base=SCENARIOS)


def test_plan_is_the_grid_times_the_draws_with_stable_ids() -> None:
    spec = spec_of(capture_campaign())
    runs = plan_runs(spec)
    assert spec.kind == "capture" and len(runs) == 2 * 6
    assert [r.parameters["detumble.rate_gain"] for r in runs] == [0.25] * 6 + [0.5] * 6
    assert {r.parameters["grasp.joints"] for r in runs} == {"free", "locked"}
    assert all(400.0 <= r.parameters["payload.mass"] <= 600.0 for r in runs)
    # the draws are scipy.stats' with numpy's Generator, one parameter after the other
    rng = np.random.default_rng(7)
    masses = stats.uniform(loc=400.0, scale=200.0).rvs(size=12, random_state=rng)
    rates = stats.norm(loc=0.05, scale=0.01).rvs(size=12, random_state=rng)
    assert [r.parameters["payload.mass"] for r in runs] == masses.tolist()
    assert [r.parameters["payload.angular_velocity[2]"] for r in runs] == rates.tolist()
    again = plan_runs(spec_of(capture_campaign()))
    assert [r.run_id for r in again] == [r.run_id for r in runs]
    assert len({r.run_id for r in runs}) == len(runs)
    # another seed, another scenario content, another record: another campaign
    other = [spec_of(capture_campaign(runs={"count": 6, "seed": 8})), spec_of(capture_campaign(record={"scalars": ["margin"]}))]
    assert all(o.campaign_id != spec.campaign_id for o in other)
    assert not {r.run_id for r in plan_runs(other[0])} & {r.run_id for r in runs}


def test_the_example_campaigns_load() -> None:
    spec = load_campaign(ROOT / "examples" / "campaigns" / "tumbling_capture.toml")
    assert spec.kind == "capture" and len(plan_runs(spec)) == 64 and spec.rank_by == "sequence.detumble.delta_v"
    draws = np.array([r.parameters["payload.inertia"] for r in plan_runs(spec)])
    assert np.all(draws > 0.0)  # lognormal
    maps = load_campaign(ROOT / "examples" / "campaigns" / "singularity_map_7dof.toml")
    assert maps.kind == "map" and len(plan_runs(maps)) == 128 and maps.scenario["threshold"] == 0.02


def test_dotted_paths_read_and_replace_without_touching_the_original() -> None:
    data = {"payload": {"mass": 1.0, "angular_velocity": [0.0, 0.0, 0.1]}}
    assert get_path(data, "payload.angular_velocity[2]") == 0.1
    new = set_path(data, "payload.angular_velocity[2]", 0.3)
    assert new["payload"]["angular_velocity"] == [0.0, 0.0, 0.3] and data["payload"]["angular_velocity"] == [0.0, 0.0, 0.1]
    with pytest.raises(KeyError, match="did you mean mass"):
        get_path(data, "payload.mas")


@pytest.mark.parametrize(
    ("change", "field", "words"),
    [
        ({"parameters": {"target.mass": {"values": [1.0]}}}, "c.toml: parameters.target.mass", "unknown parameter"),
        ({"parameters": {"payload.mas": {"values": [1.0]}}}, "c.toml: parameters.payload.mas", "did you mean mass"),
        ({"parameters": {"payload.angular_velocity[5]": {"values": [1.0]}}}, "c.toml: parameters.payload.angular_velocity[5]", "list of 3"),
        ({"parameters": {"payload": {"values": [1.0]}}}, "c.toml: parameters.payload", "a table or a list"),
        (
            {"parameters": {"payload.mass": {"distribution": "gamma"}}},
            "c.toml: parameters.payload.mass.distribution",
            "unknown distribution",
        ),
        ({"parameters": {"payload.mass": {"distribution": "normal", "mean": 1.0}}}, "c.toml: parameters.payload.mass.std", "missing"),
        (
            {"parameters": {"payload.mass": {"distribution": "uniform", "low": 1, "high": 2, "scale": 3}}},
            "c.toml: parameters.payload.mass.scale",
            "unknown key",
        ),
        ({"colour": "red"}, "c.toml: colour", "unknown key"),
        ({"runs": {"count": 0}}, "c.toml: runs.count", "integer >= 1"),
        ({"record": {"series": ["omegas"]}}, "c.toml: record.series.omegas", "unknown time series"),
        ({"summary": {"rank_by": "margin"}}, "c.toml: summary.rank_by", "not recorded"),
        ({"summary": {"statistics": ["mode"]}}, "c.toml: summary.statistics", "unknown statistic"),
        ({"record": {"scalars": ["payload.mass"]}}, "c.toml: record.scalars", "also a column"),
    ],
)
def test_bad_campaign_files_name_the_field(change: dict[str, Any], field: str, words: str) -> None:
    data = capture_campaign()
    data.update({key: value for key, value in change.items() if key != "parameters"})
    if "parameters" in change:
        data["parameters"] = change["parameters"]
    with pytest.raises(ModelError) as caught:
        spec_of(data)
    assert str(caught.value).startswith(field + ":") and words in str(caught.value), str(caught.value)


def test_a_map_chunk_by_chunk_is_the_map_of_the_whole_sample() -> None:
    model = ff.models.papadopoulos1992(arms=1)
    table = {"model": "papadopoulos1992-one-arm", "end_effector": 0, "samples": 1024, "chunk": 256, "seed": 3, "bins": 16}
    table["singularity"] = {"threshold": 0.05}
    spec = campaign_from_dict({"map": table}, base=ROOT)
    runs = plan_runs(spec)
    assert [r.parameters for r in runs] == [{"start": s, "size": 256} for s in (0, 256, 512, 768)]
    chunks = [map_chunk(spec.scenario, spec.base, **r.parameters) for r in runs]
    whole_scalars, whole = map_chunk(spec.scenario, spec.base, 0, 1024)
    for name in ("radius_histogram", "singular_radius_histogram", "map"):
        assert np.array_equal(sum(c[1][name] for c in chunks), whole[name])
    assert min(c[0]["radius_min"] for c in chunks) == whole_scalars["radius_min"]
    assert sum(c[0]["singular"] for c in chunks) == whole_scalars["singular"] > 0
    assert whole["radius_histogram"].sum() == 1024 and whole_scalars["radius_max"] < radius_bound(model)
    # the same configurations as one batched call: the measure of the library, not a second algorithm
    q = ff.workspace.workspace_cloud(model, samples=1024, seed=3).q
    measure = np.abs(ff.workspace.singularity_measure(model, q, end_effector=0))
    assert whole_scalars["singular"] == np.count_nonzero(measure <= 0.05)


def simple_task(**parameters: Any) -> RunTask:
    scenario = {"model": "papadopoulos1992", "duration": 0.1, "integrator": {"method": "RK4", "fixed_step": 0.01, "output_period": 0.05}}
    scenario["controller"] = {"type": "joint_pd", "kp": 1.0, "kd": 1.0}
    return RunTask("r0", 0, "simulate", scenario, str(ROOT), "", parameters, ("kinetic_energy.final", "t_end"), ("omega",))


def test_a_run_that_fails_is_an_outcome_with_its_reason() -> None:
    ok = execute_run(simple_task(**{"controller.kp": 2.0}))
    assert ok.status == "ok" and ok.scalars["t_end"] == pytest.approx(0.1) and ok.series["omega"].shape == (3, 3)
    bad = execute_run(simple_task(**{"controller.kp": -1.0}))
    assert bad.status == "failed" and "controller.kp: has negative gains" in bad.reason
    missing = execute_run(RunTask(**{**simple_task().__dict__, "scalars": ("final_state.q",)}))
    assert missing.status == "failed" and "not a number" in missing.reason


def test_store_and_report_from_stored_runs(tmp_path: Path) -> None:
    data = {
        "function": "campaign_runs:marked",
        "runs": {"count": 8, "seed": 1},
        "parameters": {"i": {"distribution": "uniform", "low": 0.0, "high": 10.0}, "dir": {"values": [str(tmp_path)]}},
        "record": {"scalars": ["square"], "series": ["steps"]},
        "summary": {"statistics": ["mean", "p50", "max", "count"], "worst": 2},
    }
    spec = campaign_from_dict(data, source="f.toml", base=tmp_path)
    plan = plan_runs(spec)
    x = np.array([r.parameters["i"] for r in plan])
    outcomes = [
        RunOutcome(r.run_id, r.index, "ok", scalars={"square": float(v) ** 2}, series={"steps": np.arange(3.0)})
        if k != 5
        else RunOutcome(r.run_id, r.index, "failed", "ValueError: no")
        for k, (r, v) in enumerate(zip(plan, x, strict=True))
    ]
    out = tmp_path / "out"
    with CampaignStore.open(out, spec, plan, resume=False) as store:
        for o in outcomes:
            store.write_series(o)
        store.add(outcomes[:3])
        store.add(outcomes[3:])
    with pytest.raises(CampaignError, match="holds results of this campaign already; pass --resume"):
        CampaignStore.open(out, spec, plan, resume=False)
    table = read_runs(out)
    assert table.column("run_id").to_pylist() == [r.run_id for r in plan] and table.column("status").to_pylist()[5] == "failed"
    assert np.array_equal(read_series(out, plan[0].run_id)["steps"], np.arange(3.0))
    summary = summarize_campaign(out, spec)
    ok = np.arange(8) != 5
    y = x**2
    assert (summary.ok, summary.failed, summary.reasons) == (7, 1, {"ValueError: no": 1})
    assert summary.statistics["square"] == {"mean": np.mean(y[ok]), "p50": np.median(y[ok]), "max": y[ok].max(), "count": 7.0}
    assert summary.sensitivity["square"]["i"] == pytest.approx(1.0)  # monotone
    assert [w["run_id"] for w in summary.worst] == [plan[k].run_id for k in np.argsort(-np.where(ok, y, -1))[:2]]
    assert math.isnan(summary.as_dict()["sensitivity_spearman"]["square"].get("dir", math.nan))
    text = summary.markdown()
    assert "failure rate 12.5 %" in text and "| square |" in text
    assert len(summary.plot_distributions()) == 1 and summary.plot_failures() is not None
    assert summary.plot_sensitivity().get_xticklabels()[0].get_text() == "i"


def test_a_map_campaign_summed_from_its_store(tmp_path: Path) -> None:
    table = {"model": "papadopoulos1992-one-arm", "samples": 512, "chunk": 128, "seed": 5, "bins": 8, "singularity": {"threshold": 0.05}}
    spec = campaign_from_dict({"map": table}, source="m.toml", base=tmp_path)
    plan = plan_runs(spec)
    with CampaignStore.open(tmp_path / "out", spec, plan, resume=False) as store:
        outcomes = [RunOutcome(r.run_id, r.index, "ok", "", *map_chunk(spec.scenario, spec.base, **r.parameters)) for r in plan]
        for outcome in outcomes:
            store.write_series(outcome)
        store.add(outcomes[:1])
        store.add(outcomes[1:])
    totals = summarize_campaign(tmp_path / "out", spec).totals
    whole_scalars, whole = map_chunk(spec.scenario, spec.base, 0, 512)
    assert totals["configurations"] == 512 and totals["radius_max"] == whole_scalars["radius_max"]
    assert totals["singular_fraction"] == whole_scalars["singular"] / 512
    assert totals["map"] == whole["map"].tolist() and totals["radius_histogram"] == whole["radius_histogram"].tolist()
    summary = summarize_campaign(tmp_path / "out", spec)
    assert summary.worst == [] and "## Map totals" in summary.markdown()
    assert len(summary.plot_map()) == 2


def test_a_worker_death_fails_the_run_and_any_other_cluster_error_stops_the_campaign() -> None:
    from distributed.scheduler import KilledWorker

    from freefloat.campaigns.runner import _lost
    from freefloat.campaigns.spec import Run

    run = Run("abc", 3, {})
    worker = SimpleNamespace(address="tcp://127.0.0.1:1")  # the scheduler's record of the worker that died last
    outcome = _lost(run, KilledWorker("freefloat-run-abc", worker, 1))
    assert (outcome.status, outcome.index) == ("failed", 3) and outcome.reason.startswith("KilledWorker: the worker running it died")
    with pytest.raises(CampaignError, match=r"run abc could not run on the cluster \(ModuleNotFoundError: No module named 'freefloat'\)"):
        _lost(run, ModuleNotFoundError("No module named 'freefloat'"))


def test_failures_group_by_pattern_and_the_histograms_have_units(tmp_path: Path) -> None:
    data = {
        "function": "campaign_runs:marked",
        "parameters": {"i": {"values": list(range(9))}, "dir": {"values": [str(tmp_path)]}},
        "record": {"scalars": ["square", "t_end"], "units": {"square": "m^2"}},
    }
    spec = campaign_from_dict(data, source="f.toml", base=tmp_path)
    plan = plan_runs(spec)
    reasons = [f"RuntimeError: the simulation diverged at t = {0.25 * k} s (step {k})" for k in range(6)]
    outcomes = [RunOutcome(r.run_id, r.index, "failed", reasons[r.index]) for r in plan[:6]]
    outcomes.append(RunOutcome(plan[6].run_id, 6, "failed", "KilledWorker: died (tcp://127.0.0.1:40233)", failure="worker"))
    outcomes += [RunOutcome(r.run_id, r.index, "ok", scalars={"square": 1.0, "t_end": 2.0}) for r in plan[7:]]
    with CampaignStore.open(tmp_path / "out", spec, plan, resume=False) as store:
        store.add(outcomes)
    summary = summarize_campaign(tmp_path / "out", spec)
    assert summary.failure_groups == [
        {"pattern": "RuntimeError: the simulation diverged at t = # s (step #)", "runs": 6, "failure": "run", "example": reasons[0]},
        {"pattern": "KilledWorker: died (tcp://#:#)", "runs": 1, "failure": "worker", "example": outcomes[6].reason},
    ]
    assert "| 6 | run | RuntimeError: the simulation diverged at t = # s (step #) |" in summary.markdown()
    labels = [ax.get_xlabel() for ax in summary.plot_distributions()]
    assert labels == ["square (m^2)", "t_end (s)"]


def test_import_freefloat_loads_nothing_heavy() -> None:
    heavy = ("scipy.stats", "pyarrow", "zarr", "distributed", "dask", "matplotlib", "matplotlib.pyplot", "pandas")
    code = f"import sys, freefloat; print(sorted(m for m in {heavy!r} if m in sys.modules))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert done.stdout.strip() == "[]", done.stdout + done.stderr
