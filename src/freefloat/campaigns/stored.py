"""Reading a campaign's output directory, and checking it (:func:`survey`): what is stored, what is damaged.

The layout and its guarantees are :mod:`.store`'s. A reader never changes the directory: a damaged part or a
run's missing series is an error here (:func:`read_runs`, :func:`read_series`) that names the file and says that
``--resume`` repairs it; :func:`survey` is what ``--resume`` runs first, before any cluster starts.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import CampaignError

__all__ = [
    "DAMAGED",
    "FORMAT",
    "MANIFEST",
    "PART_GLOB",
    "SERIES",
    "StoreSurvey",
    "expected_series",
    "read_runs",
    "read_series",
    "survey",
]

MANIFEST = "campaign.json"
#: The manifest's format: 2 adds the ``failure`` column, part names that cannot collide and one Zarr store.
FORMAT = "freefloat-campaign-2"
PART_GLOB = "part-*.parquet"
SERIES = "series.zarr"
#: Where damaged parts and series are moved aside (never deleted).
DAMAGED = "damaged"


@dataclass
class StoreSurvey:
    """What a campaign directory holds: ``rows`` (run id -> its newest stored row, a dict), the ``damaged`` parts
    (path -> why), the ``lost_series`` (run id -> why: rows of ok runs whose series are missing or not theirs)."""

    rows: dict[str, dict[str, Any]] = field(default_factory=dict)
    damaged: dict[Path, str] = field(default_factory=dict)
    lost_series: dict[str, str] = field(default_factory=dict)

    @property
    def finished(self) -> set[str]:
        """The run ids stored whole: a row, and its series where it has some."""
        return set(self.rows) - set(self.lost_series)


def _manifest(out: Path) -> dict[str, Any]:
    try:
        held = json.loads((out / MANIFEST).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise CampaignError(f"{out}: holds no campaign (no {MANIFEST})") from None
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        raise CampaignError(f"{out / MANIFEST}: is not a campaign's manifest ({exc})") from None
    if not isinstance(held, dict) or held.get("format") != FORMAT:
        raise CampaignError(f"{out / MANIFEST}: is not a freefloat campaign's manifest of format {FORMAT}")
    return held


def expected_series(manifest: dict[str, Any]) -> tuple[str, ...]:
    """The arrays each ok run of this campaign has in its series group (none: the campaign records no series)."""
    from .maps import MAP_SERIES

    kind, series = manifest.get("kind"), tuple(manifest.get("series", ()))
    if kind == "map":
        return MAP_SERIES
    if kind in ("simulate", "capture") and series:
        return ("t", *series)
    return series


def _read_part(path: Path, schema: Any, campaign_id: str) -> tuple[Any, str]:
    """(the part's table, "") when it is whole and this campaign's; (None, why) when damaged; a CampaignError when
    it is whole but another campaign's or another program's (foreign: it is refused, not moved)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        table = pq.read_table(path)
    except (OSError, pa.ArrowException) as exc:  # truncated, empty, not Parquet: damaged
        return None, " ".join(str(exc).split()) or type(exc).__name__
    metadata = table.schema.metadata or {}
    held = metadata.get(b"freefloat_campaign", b"").decode(errors="replace")
    if held != campaign_id or (schema is not None and not table.schema.remove_metadata().equals(schema)):
        whose = f"campaign {held}" if held else "another program"
        raise CampaignError(
            f"{path}: is a Parquet file of {whose}, not a part of this campaign ({campaign_id}); move it out of "
            f"{path.parent} (nothing was run, nothing was changed)"
        )
    return table, ""


def _series_problem(root: Path, run_id: str, names: tuple[str, ...]) -> str:
    """Why the series group of ``run_id`` is not whole ("" when it is): read from the Zarr v3 metadata files."""
    group = root / SERIES / run_id
    try:
        meta = json.loads((group / "zarr.json").read_text(encoding="utf-8"))
    except FileNotFoundError:
        return f"{SERIES}/{run_id} is missing"
    except (OSError, ValueError, UnicodeDecodeError):
        return f"{SERIES}/{run_id}/zarr.json is damaged"
    held = meta.get("attributes", {}).get("run_id") if isinstance(meta, dict) else None
    if held != run_id:
        return f"{SERIES}/{run_id} holds the series of run {held}"
    missing = [name for name in names if not (group / name / "zarr.json").is_file()]
    return f"{SERIES}/{run_id} has no {', '.join(missing)}" if missing else ""


def survey(out: str | Path, schema: Any = None, plan_index: dict[str, int] | None = None) -> StoreSurvey:
    """Read every part and check every stored run's series (module docstring). ``schema``: the parts' expected
    schema; ``plan_index``: the plan's run id -> index (rows of runs not in it are foreign: a CampaignError)."""
    root = Path(out)
    found = StoreSurvey()
    if not (root / MANIFEST).is_file():
        return found
    manifest = _manifest(root)
    campaign_id = str(manifest.get("campaign_id"))
    for path in sorted((root / "runs").glob(PART_GLOB)):  # names start with the time written: the newest last
        table, why = _read_part(path, schema, campaign_id)
        if table is None:
            found.damaged[path] = why
            continue
        for row in table.to_pylist():
            run_id = row["run_id"]
            if plan_index is not None and plan_index.get(run_id) != row["index"]:
                raise CampaignError(
                    f"{path}: holds run {run_id} (index {row['index']}), which is not in this campaign's plan; move the "
                    f"part out of {path.parent} (nothing was run, nothing was changed)"
                )
            found.rows[run_id] = row
    names = expected_series(manifest)
    if names:
        for run_id, row in found.rows.items():
            if row["status"] == "ok" and (problem := _series_problem(root, run_id, names)):
                found.lost_series[run_id] = problem
    return found


def read_runs(out: str | Path, columns: list[str] | None = None) -> Any:
    """The finished runs of a campaign directory: one pyarrow Table, the newest row of each run, sorted by run
    index. A damaged part is a CampaignError (``--resume`` moves it aside and computes its runs again)."""
    import pyarrow as pa

    root = Path(out)
    found = survey(root)
    if found.damaged:
        path, why = next(iter(found.damaged.items()))
        raise CampaignError(
            f"{path}: is damaged ({why}); run the campaign again with --resume: it moves the part to "
            f"{root / DAMAGED} and computes its runs again"
        )
    if not found.rows:
        raise CampaignError(f"{out}: holds no finished runs (no runs/{PART_GLOB})")
    rows = sorted(found.rows.values(), key=lambda row: row["index"])
    first = next(iter(sorted((root / "runs").glob(PART_GLOB))))
    import pyarrow.parquet as pq

    schema = pq.read_schema(first).remove_metadata()
    table = pa.Table.from_pylist(rows, schema=schema)
    return table.select(columns) if columns is not None else table


def read_series(out: str | Path, run_id: str) -> dict[str, np.ndarray]:
    """The recorded time series of one stored run (``t`` and one array per name, time first; {} for a failed run or
    a campaign that records none). A stored ok run whose series are missing or damaged is a CampaignError."""
    root = Path(out)
    names = expected_series(_manifest(root))
    if names and not _series_problem(root, run_id, names):
        return _arrays(root, run_id)
    row = survey(root).rows.get(run_id)
    if row is None:
        raise CampaignError(f"{out}: holds no run {run_id}")
    if row["status"] != "ok" or not names:
        return {}
    raise CampaignError(
        f"{out}: run {run_id}: {_series_problem(root, run_id, names)}; run the campaign again with --resume to compute it again"
    )


def _arrays(root: Path, run_id: str) -> dict[str, np.ndarray]:
    import zarr

    group = zarr.open_group(str(root / SERIES), mode="r")[run_id]
    return {name: np.asarray(array[...]) for name, array in group.arrays()}  # type: ignore[union-attr]


def fsync_file(path: Path) -> None:
    """Flush ``path`` to the disk (a part is renamed into place only once its bytes are there)."""
    descriptor = os.open(path, os.O_RDONLY)
    try:
        os.fsync(descriptor)
    finally:
        os.close(descriptor)
