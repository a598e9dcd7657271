"""Reading a campaign's output directory, and checking it (:func:`survey`): what is stored, what is damaged.

The layout and its guarantees are :mod:`.store`'s. A reader never changes the directory: a damaged part or a
run's missing series is an error here (:func:`read_runs`, :func:`read_series`) that names the file and says that
``--resume`` repairs it; :func:`survey` is what ``--resume`` runs first, before any cluster starts.
"""

from __future__ import annotations

import json
import os
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import CampaignError, ModelCorrectionWarning

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
#: The format before it (parts without the ``failure`` column, a Zarr group per run without a root group): read,
#: reported and resumed as it is (its files are never rewritten; new parts are of format 2, the readers unify them).
FORMAT_1 = "freefloat-campaign-1"
FORMATS = (FORMAT, FORMAT_1)
PART_GLOB = "part-*.parquet"
#: The names parts are written under (format 2: time, random bits, first run id; format 1: a counter). A file of
#: another name in runs/ (a hand-made copy) is not read: a warning names it.
PART_NAME = re.compile(r"part-(\d{20}-[0-9a-f]{8}-\w+|\d{6})\.parquet")
#: The part's metadata key holding its place in the store's order: 1 + the largest before it, given under the lock.
#: The newest row of a run is the one in the part of the largest (parts without one: before, by name).
SEQUENCE_KEY = b"freefloat_stored"
SERIES = "series.zarr"
#: Where damaged parts and series are moved aside (never deleted).
DAMAGED = "damaged"


class StrayPartWarning(ModelCorrectionWarning):
    """A file in ``runs/`` whose name is not a part's (a hand-made copy): not read, left where it is."""


def part_paths(root: Path) -> list[Path]:
    """The parts in ``root/runs`` (names of :data:`PART_NAME`); any other ``part-*.parquet`` there is named in a
    :class:`StrayPartWarning` and not read."""
    paths = sorted((root / "runs").glob(PART_GLOB))
    stray = [path for path in paths if not PART_NAME.fullmatch(path.name)]
    if stray:
        warnings.warn(
            f"{root / 'runs'}: {', '.join(p.name for p in stray)}: not a part's name (part-<time>-<random>-<run id>.parquet); "
            "not read (move it out of runs/)",
            StrayPartWarning,
            stacklevel=3,
        )
    return [path for path in paths if PART_NAME.fullmatch(path.name)]


def sequence_of(metadata: dict[bytes, bytes] | None) -> int:
    """A part's place in the store's order (:data:`SEQUENCE_KEY`; -1 for a part written without one)."""
    try:
        return int((metadata or {}).get(SEQUENCE_KEY, b"-1"))
    except ValueError:
        return -1


@dataclass
class StoreSurvey:
    """What a campaign directory holds: ``rows`` (run id -> its newest stored row, a dict), the ``damaged`` parts
    (path -> why), the ``lost_series`` (run id -> why: rows of ok runs whose series are missing or not theirs)."""

    rows: dict[str, dict[str, Any]] = field(default_factory=dict)
    damaged: dict[Path, str] = field(default_factory=dict)
    lost_series: dict[str, str] = field(default_factory=dict)

    @property
    def worker_failed(self) -> set[str]:
        """The run ids stored as failed by their worker (killed on each try: the environment's, run again by --resume)."""
        return {run_id for run_id, row in self.rows.items() if row.get("failure") == "worker"}

    @property
    def finished(self) -> set[str]:
        """The run ids stored whole and finished: a row, its series where it has some, not failed by its worker."""
        return set(self.rows) - set(self.lost_series) - self.worker_failed


def _manifest(out: Path) -> dict[str, Any]:
    try:
        held = json.loads((out / MANIFEST).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise CampaignError(f"{out}: holds no campaign (no {MANIFEST})") from None
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        raise CampaignError(f"{out / MANIFEST}: is not a campaign's manifest ({exc})") from None
    if not isinstance(held, dict) or held.get("format") not in FORMATS:
        raise CampaignError(f"{out / MANIFEST}: is not a freefloat campaign's manifest of format {' or '.join(FORMATS)}")
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
    """(the part's table, "") when it is whole and this campaign's; (None, why) when damaged (empty, truncated, not
    Parquet); a CampaignError when it is whole but another campaign's or another program's (foreign: it is refused,
    not moved), or when it cannot be read (a disk or permission error: nothing is damage, nothing is moved). A part
    of format 1 (no ``failure`` column) is given one: "run" for its failed rows."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        if path.stat().st_size == 0:
            return None, "an empty file"
        table = pq.read_table(path)
    except pa.ArrowInvalid as exc:  # truncated, not Parquet: damaged
        return None, " ".join(str(exc).split()) or type(exc).__name__
    except OSError as exc:
        if exc.errno is None:  # (Arrow's own: a part whose metadata cannot be decoded)
            return None, " ".join(str(exc).split()) or type(exc).__name__
        raise CampaignError(
            f"{path}: cannot be read ({exc.strerror or exc}); fix the disk or the file's permissions and run again "
            "(nothing was moved, nothing was changed)"
        ) from None
    metadata = table.schema.metadata or {}
    held = metadata.get(b"freefloat_campaign", b"").decode(errors="replace")
    if held == campaign_id and "failure" not in table.schema.names and "status" in table.schema.names:
        failure = pa.array(["run" if status == "failed" else "" for status in table.column("status").to_pylist()], pa.string())
        table = table.add_column(table.schema.get_field_index("status") + 1, "failure", failure)
    got = table.schema.remove_metadata()
    if held != campaign_id:
        whose = f"campaign {held}" if held else "another program"
        raise CampaignError(
            f"{path}: is a Parquet file of {whose}, not a part of this campaign ({campaign_id}); move it out of "
            f"{path.parent} (nothing was run, nothing was changed)"
        )
    if schema is not None and not got.equals(schema):
        raise CampaignError(
            f"{path}: is a part of this campaign ({campaign_id}) with other columns ({_columns_differ(got, schema)}); "
            f"move it out of {path.parent} (nothing was run, nothing was changed)"
        )
    return table, ""


def _columns_differ(got: Any, wanted: Any) -> str:
    """Which columns of schema ``got`` differ from ``wanted``: missing, extra, of another type (one phrase)."""
    have = {f.name: f.type for f in got}
    want = {f.name: f.type for f in wanted}
    said = []
    if missing := [name for name in want if name not in have]:
        said.append(f"no {', '.join(missing)}")
    if extra := [name for name in have if name not in want]:
        said.append(f"extra {', '.join(extra)}")
    said += [f"{name} is {have[name]}, not {want[name]}" for name in want if name in have and have[name] != want[name]]
    return "; ".join(said) or "the same columns in another order"


def _series_problem(root: Path, run_id: str, names: tuple[str, ...], *, deep: bool = False, legacy: bool = False) -> str:
    """Why the series group of ``run_id`` is not whole ("" when it is): read from the Zarr v3 metadata files, and
    with ``deep`` every array read whole (a chunk that does not decode is damage)."""
    group = root / SERIES / run_id
    try:
        meta = json.loads((group / "zarr.json").read_text(encoding="utf-8"))
    except FileNotFoundError:
        return f"{SERIES}/{run_id} is missing"
    except (OSError, ValueError, UnicodeDecodeError):
        return f"{SERIES}/{run_id}/zarr.json is damaged"
    held = meta.get("attributes", {}).get("run_id") if isinstance(meta, dict) else None
    if held != run_id and not (held is None and legacy):  # (format 1 wrote no run_id attribute)
        return f"{SERIES}/{run_id} holds the series of run {held}"
    missing = [name for name in names if not (group / name / "zarr.json").is_file()]
    if missing:
        return f"{SERIES}/{run_id} has no {', '.join(missing)}"
    if deep:
        try:
            _arrays(root, run_id)
        except SeriesDamaged as exc:
            return str(exc)
    return ""


class SeriesDamaged(Exception):
    """A stored series whose data does not decode (an emptied or truncated chunk file)."""


def survey(out: str | Path, schema: Any = None, plan_index: dict[str, int] | None = None, *, deep: bool = False) -> StoreSurvey:
    """Read every part and check every stored run's series (module docstring). ``schema``: the parts' expected
    schema; ``plan_index``: the plan's run id -> index (rows of runs not in it are foreign: a CampaignError);
    ``deep``: read every stored series whole (what ``--resume`` does: a chunk that does not decode is damage)."""
    root = Path(out)
    found = StoreSurvey()
    if not (root / MANIFEST).is_file():
        return found
    manifest = _manifest(root)
    campaign_id = str(manifest.get("campaign_id"))
    tables = []
    for path in part_paths(root):
        table, why = _read_part(path, schema, campaign_id)
        if table is None:
            found.damaged[path] = why
            continue
        tables.append((sequence_of(table.schema.metadata), path.name, path, table))
    for _, _, path, table in sorted(tables, key=lambda held: held[:2]):  # the newest part last: its rows win
        for row in table.to_pylist():
            run_id = row["run_id"]
            if plan_index is not None and plan_index.get(run_id) != row["index"]:
                raise CampaignError(
                    f"{path}: holds run {run_id} (index {row['index']}), which is not in this campaign's plan; move the "
                    f"part out of {path.parent} (nothing was run, nothing was changed)"
                )
            found.rows[run_id] = row
    names, legacy = expected_series(manifest), manifest.get("format") == FORMAT_1
    if names:
        for run_id, row in found.rows.items():
            if row["status"] == "ok" and (problem := _series_problem(root, run_id, names, deep=deep, legacy=legacy)):
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
    import pyarrow.parquet as pq

    schema = pq.read_schema(part_paths(root)[0]).remove_metadata()
    if "failure" not in schema.names:  # (a part of format 1: the readers give it the column)
        schema = schema.insert(schema.get_field_index("status") + 1, pa.field("failure", pa.string()))
    table = pa.Table.from_pylist(rows, schema=schema)
    return table.select(columns) if columns is not None else table


def read_series(out: str | Path, run_id: str) -> dict[str, np.ndarray]:
    """The recorded time series of one stored run (``t`` and one array per name, time first; {} for a failed run or
    a campaign that records none). A stored ok run whose series are missing or damaged is a CampaignError."""
    root = Path(out)
    manifest = _manifest(root)
    names, legacy = expected_series(manifest), manifest.get("format") == FORMAT_1
    if names and not _series_problem(root, run_id, names, legacy=legacy):
        try:
            return _arrays(root, run_id)
        except SeriesDamaged as exc:
            raise CampaignError(f"{out}: run {run_id}: {exc}; run the campaign again with --resume to compute it again") from None
    row = survey(root).rows.get(run_id)
    if row is None:
        raise CampaignError(f"{out}: holds no run {run_id}")
    if row["status"] != "ok" or not names:
        return {}
    problem = _series_problem(root, run_id, names, legacy=legacy)
    raise CampaignError(f"{out}: run {run_id}: {problem}; run the campaign again with --resume to compute it again")


def _arrays(root: Path, run_id: str) -> dict[str, np.ndarray]:
    """The arrays of the run's group (format 1 has no root group: the run's group is opened by its path)."""
    import zarr

    group = zarr.open_group(str(root / SERIES / run_id), mode="r")
    out: dict[str, np.ndarray] = {}
    for name, array in group.arrays():
        try:
            out[name] = np.asarray(array[...])
        except (RuntimeError, ValueError, TypeError) as exc:  # (a codec's error: Zstd's on an emptied chunk)
            raise SeriesDamaged(f"{SERIES}/{run_id}/{name} is damaged ({type(exc).__name__}: {' '.join(str(exc).split())})") from None
        except OSError as exc:
            if exc.errno is not None:
                raise CampaignError(
                    f"{root / SERIES / run_id / name}: cannot be read ({exc.strerror or exc}); fix the disk or its permissions"
                ) from None
            raise SeriesDamaged(f"{SERIES}/{run_id}/{name} is damaged ({' '.join(str(exc).split())})") from None
    return out


def fsync_file(path: Path) -> None:
    """Flush ``path`` to the disk (a part is renamed into place only once its bytes are there)."""
    descriptor = os.open(path, os.O_RDONLY)
    try:
        os.fsync(descriptor)
    finally:
        os.close(descriptor)
