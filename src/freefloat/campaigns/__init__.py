"""Campaigns (``ff.campaigns``): a scenario run many times with values varied, on a Dask cluster; its reports.

- :mod:`.spec`: the campaign file (:func:`load_campaign`) and its runs (:func:`plan_runs`), each with a stable id.
- :mod:`.execute`: one run on a worker (:func:`execute_run`): a failure is kept with its reason.
- :mod:`.store`: the output directory: Parquet parts of finished runs, one Zarr store of time series, resumable;
  :mod:`.stored`: reading it and checking it (a damaged part or a lost series named, never silently dropped).
- :mod:`.runner`: :func:`run_campaign`, on a local cluster or an existing one (``scheduler="tcp://host:port"``).
- :mod:`.maps`: singularity-measure and workspace maps over 10^8+ configurations, a chunk per run.
- :mod:`.report`: summary tables (Markdown, JSON) and plots of a campaign's results.

Layer: above :mod:`freefloat.scenarios` (it runs them), beside :mod:`freefloat.papers`, below the CLI. Dask,
pyarrow and zarr are imported when a campaign runs, not with freefloat.
"""

from __future__ import annotations

from .report import CampaignSummary, summarize_campaign, write_campaign_report
from .runner import CampaignRun, run_campaign
from .spec import CampaignSpec, Run, campaign_from_dict, load_campaign, plan_runs
from .store import read_runs, read_series

__all__ = [
    "CampaignRun",
    "CampaignSpec",
    "CampaignSummary",
    "Run",
    "campaign_from_dict",
    "load_campaign",
    "plan_runs",
    "read_runs",
    "read_series",
    "run_campaign",
    "summarize_campaign",
    "write_campaign_report",
]
