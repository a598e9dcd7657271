"""Bad-input cases of issue 40: campaign specs and storage, the cluster, capture campaigns (gathered by tests/test_bad_inputs.py).

Each is refused before the plan is drawn and before any cluster starts: counts too large for a plan, ``--out`` paths
that cannot be a campaign's folder, scheduler addresses and cluster options that cannot work, and stores that are
damaged or hold another campaign's parts (a reader names the file; nothing is changed).
"""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from bad_case import Case, add_file, api, cli
from freefloat.core.errors import CampaignError

CASES: list[Case] = []

ROOT = Path(__file__).resolve().parents[1]
_SCENARIO = (ROOT / "examples" / "scenarios" / "papadopoulos1992_joint_pd.toml").as_posix()
_RANDOM = '"controller.kp" = { distribution = "uniform", low = 1.0, high = 2.0 }\n'

add_file("camp40/ok.toml", f'scenario = "{_SCENARIO}"\n[parameters]\n"controller.kp" = {{ values = [1.0, 2.0] }}\n')
add_file("camp40/count-1e8.toml", f'scenario = "{_SCENARIO}"\n[runs]\ncount = 100000000\n[parameters]\n{_RANDOM}')
add_file("camp40/count-1e12.toml", f'scenario = "{_SCENARIO}"\n[runs]\ncount = 1000000000000\n[parameters]\n{_RANDOM}')
add_file(
    "camp40/grid-product.toml",
    f'scenario = "{_SCENARIO}"\n[parameters]\n"controller.kp" = {{ linspace = [1.0, 2.0, 1000] }}\n'
    '"controller.kd" = { linspace = [1.0, 2.0, 2000] }\n',
)
add_file(
    "camp40/linspace-1e12.toml", f'scenario = "{_SCENARIO}"\n[parameters]\n"controller.kp" = {{ linspace = [1.0, 2.0, 1000000000000] }}\n'
)
add_file("camp40/map-samples.toml", '[map]\nmodel = "papadopoulos1992"\nsamples = 1099511627776\nchunk = 1048576\n')
add_file("camp40/map-chunks.toml", '[map]\nmodel = "papadopoulos1992"\nsamples = 1073741824\nchunk = 16\n')
add_file("camp40/map-chunk-memory.toml", '[map]\nmodel = "papadopoulos1992"\nsamples = 1073741824\nchunk = 1073741824\n')

_OK = "campaign {files}/camp40/ok.toml"
CASES += [
    cli(
        "cli-campaign40-count-1e8",
        "campaign {files}/camp40/count-1e8.toml --out out --max-runs 1",
        r"runs\.count: 100,000,000 runs are above",
    ),
    cli("cli-campaign40-count-1e12", "campaign {files}/camp40/count-1e12.toml --out out", r"runs\.count: 1,000,000,000,000 runs are above"),
    cli(
        "cli-campaign40-grid-product",
        "campaign {files}/camp40/grid-product.toml --out out",
        r"parameters: plans 1000 x 2000 = 2,000,000 runs",
    ),
    cli(
        "cli-campaign40-linspace-1e12",
        "campaign {files}/camp40/linspace-1e12.toml --out out",
        r"controller\.kp\.linspace: num 1000000000000",
    ),
    cli(
        "cli-campaign40-map-samples",
        "campaign {files}/camp40/map-samples.toml --out out",
        r"map\.samples: 1,099,511,627,776 .* above the 2\^30",
    ),
    cli("cli-campaign40-map-chunks", "campaign {files}/camp40/map-chunks.toml --out out", r"map\.chunk: 67,108,864 chunks are above"),
    cli(
        "cli-campaign40-map-chunk-memory",
        "campaign {files}/camp40/map-chunk-memory.toml --out out",
        r"map\.chunk: a chunk of 1,073,741,824 .*memory",
    ),
    cli("cli-campaign40-out-a-file", f"{_OK} --out {{files}}/camp40/ok.toml", r"--out \S+ok\.toml: is a file, not a directory"),
    cli(
        "cli-campaign40-out-under-a-file",
        f"{_OK} --out {{files}}/camp40/ok.toml/sub/out",
        r"--out \S+: \S+ok\.toml is a file, not a folder",
    ),
    cli("cli-campaign40-scheduler-scheme", f"{_OK} --out out --scheduler foo://127.0.0.1:1", r"unknown scheme foo://; use tcp://host:port"),
    cli(
        "cli-campaign40-scheduler-tls",
        f"{_OK} --out out --scheduler tls://127.0.0.1:1",
        r"a tls scheduler needs this client's certificates",
    ),
    cli("cli-campaign40-scheduler-no-port", f"{_OK} --out out --scheduler tcp://127.0.0.1", r"expected a scheduler address such as tcp://"),
    cli("cli-campaign40-scheduler-bad-port", f"{_OK} --out out --scheduler tcp://127.0.0.1:99999", r"expected a scheduler address"),
    cli(
        "cli-campaign40-scheduler-and-workers",
        f"{_OK} --out out --scheduler tcp://127.0.0.1:1 --workers 2",
        r"--workers and --memory-limit shape",
    ),
    cli("cli-campaign40-workers-huge", f"{_OK} --out out --workers 100000", r"--workers: expected 1 to \d+ \(this machine's cores\)"),
    cli(
        "cli-campaign40-memory-tiny",
        f"{_OK} --out out --memory-limit 1MiB",
        r"--memory-limit 1MiB: a worker with freefloat loaded needs at least",
    ),
    cli("cli-campaign40-memory-text", f"{_OK} --out out --memory-limit lots", r"--memory-limit lots: not a size"),
    cli(
        "cli-campaign40-memory-huge",
        f"{_OK} --out out --memory-limit 1000TiB",
        r"--memory-limit 1000TiB: 1 worker\(s\) of .* exceed this machine's",
    ),
    cli("cli-campaign40-worker-timeout", f"{_OK} --out out --worker-timeout 0", r"--worker-timeout: expected seconds between 0 and 1e6"),
]


# --------------------------------------------------------------------- damaged stores (each built in a folder of its own)
def _spec(folder: Path, k: float = 1.0) -> Any:
    from freefloat.campaigns import campaign_from_dict

    data = {"function": "campaign_runs:marked", "parameters": {"i": {"values": [0, 1, 2]}, "k": {"values": [k]}}}
    return campaign_from_dict({**data, "record": {"scalars": ["square"], "series": ["steps"]}}, source="c.toml", base=folder)


def _store(folder: Path, k: float = 1.0) -> tuple[Any, Path]:
    """A store of three ok runs with their series (no cluster: the outcomes written as the runner writes them)."""
    from freefloat.campaigns import plan_runs
    from freefloat.campaigns.execute import RunOutcome
    from freefloat.campaigns.store import CampaignStore

    spec, out = _spec(folder, k), folder / f"out-{k}"
    plan = plan_runs(spec)
    with CampaignStore.open(out, spec, plan, resume=False) as store:
        outcomes = [RunOutcome(r.run_id, r.index, "ok", scalars={"square": 1.0}, series={"steps": np.arange(3.0)}) for r in plan]
        for outcome in outcomes:
            store.write_series(outcome)
        store.add(outcomes)
    return spec, out


def _in_temporary(check: Callable[[Path], Any]) -> Callable[[Path], Any]:
    def run(files: Path) -> Any:
        with tempfile.TemporaryDirectory() as folder:
            return check(Path(folder))

    return run


def _truncated(folder: Path) -> Any:
    from freefloat.campaigns import read_runs

    _, out = _store(folder)
    part = next((out / "runs").glob("part-*.parquet"))
    part.write_bytes(part.read_bytes()[:100])
    return read_runs(out)


def _empty_part(folder: Path) -> Any:
    from freefloat.campaigns import read_runs

    _, out = _store(folder)
    (out / "runs" / "part-00000000000000000000-00000000-empty.parquet").write_bytes(b"")
    return read_runs(out)


def _lost_series(folder: Path) -> Any:
    from freefloat.campaigns import plan_runs, read_series

    spec, out = _store(folder)
    run_id = plan_runs(spec)[1].run_id
    shutil.rmtree(out / "series.zarr" / run_id)
    return read_series(out, run_id)


def _foreign_part(folder: Path) -> Any:
    from freefloat.campaigns import run_campaign

    spec, out = _store(folder)
    _, other = _store(folder, k=2.0)
    shutil.copy(next((other / "runs").glob("part-*.parquet")), out / "runs" / "part-99999999999999999999-00000000-copied.parquet")
    return run_campaign(spec, out, resume=True, progress=False)


def _other_program(folder: Path) -> Any:
    import pyarrow as pa
    import pyarrow.parquet as pq

    from freefloat.campaigns import run_campaign

    spec, out = _store(folder)
    pq.write_table(pa.table({"x": [1.0, 2.0]}), out / "runs" / "part-99999999999999999999-00000000-theirs.parquet")
    return run_campaign(spec, out, resume=True, progress=False)


def _older_format(folder: Path) -> Any:
    from freefloat.campaigns import run_campaign

    spec, out = _store(folder)
    manifest = out / "campaign.json"
    manifest.write_text(manifest.read_text().replace("freefloat-campaign-2", "freefloat-campaign-0"))
    return run_campaign(spec, out, resume=True, progress=False)


def _broken_link(folder: Path) -> Any:
    from freefloat.campaigns import run_campaign

    spec = _spec(folder)
    (folder / "out").symlink_to(folder / "gone")
    return run_campaign(spec, folder / "out", scheduler="tcp://127.0.0.1:1", progress=False)


def _being_written(folder: Path) -> Any:
    from freefloat.campaigns import run_campaign
    from freefloat.campaigns.store import CampaignStore

    spec, out = _store(folder)
    lock = CampaignStore.lock(out)  # another campaign writing there now (a port nothing listens on: refused first)
    try:
        return run_campaign(spec, out, scheduler="tcp://127.0.0.1:1", resume=True, progress=False)
    finally:
        assert lock is not None
        lock.close()


CASES += [
    api(
        "api-campaign40-out-broken-link",
        _in_temporary(_broken_link),
        CampaignError,
        r"--out \S+out: is a broken symbolic link \(to \S+gone\)",
    ),
    api(
        "api-campaign40-out-being-written", _in_temporary(_being_written), CampaignError, r"another freefloat campaign is writing there now"
    ),
]

CASES += [
    api("api-campaign40-truncated-part", _in_temporary(_truncated), CampaignError, r"part-\S+\.parquet: is damaged .*--resume: it moves"),
    api("api-campaign40-empty-part", _in_temporary(_empty_part), CampaignError, r"part-0+-0+-empty\.parquet: is damaged"),
    api("api-campaign40-lost-series", _in_temporary(_lost_series), CampaignError, r"run \w+: series\.zarr/\w+ is missing; run .*--resume"),
    api(
        "api-campaign40-foreign-part",
        _in_temporary(_foreign_part),
        CampaignError,
        r"part-9+-0+-copied\.parquet: is a Parquet file of campaign \w+, not",
    ),
    api(
        "api-campaign40-other-program",
        _in_temporary(_other_program),
        CampaignError,
        r"part-9+-0+-theirs\.parquet: is a Parquet file of another program",
    ),
    api(
        "api-campaign40-older-format",
        _in_temporary(_older_format),
        CampaignError,
        r"written by another freefloat \(format freefloat-campaign-0; this one reads freefloat-campaign-1 and",
    ),
]
