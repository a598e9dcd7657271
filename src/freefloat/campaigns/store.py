"""A campaign's output directory: what finished, written as it finishes, never rewritten.

::

    DIR/campaign.json          the campaign (its id, the spec, the scenario, the plan's size); written first
    DIR/runs/part-000000.parquet, part-000001.parquet, ...
                               one row per finished run: run_id, index, status ("ok" / "failed"), reason, seconds,
                               worker, each varied parameter, each recorded scalar (NaN where a run has none)
    DIR/series.zarr/<run_id>/  the recorded time series of each run ("t" and one array per name, time first)
    DIR/report/                the summary tables and plots (.report), rewritten after each invocation

A part is written to a hidden temporary file and renamed into place (atomic on POSIX), so a part is either
whole or absent; a run counts as finished once its row is in a part. A run's series are written before its row,
so a finished run always has them. ``--resume`` runs the plan's run ids that no part holds. One runner at a time
holds the directory (an advisory lock, released when its process ends, however it ends).

A directory that holds another campaign (another id), or files that are not a campaign's, is refused: nothing
in it is ever overwritten.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from .._version import __version__
from ..core.errors import CampaignError
from .execute import RunOutcome
from .spec import COLUMNS, CampaignSpec, Run

__all__ = ["MANIFEST", "CampaignStore", "finished_runs", "read_runs", "read_series"]

MANIFEST = "campaign.json"
FORMAT = "freefloat-campaign-1"
_LOCK = ".campaign.lock"


def _column_type(values: list[Any]) -> Any:
    """Arrow type of a parameter column: bool, int64, float64 or string, from every value the plan gives it."""
    import pyarrow as pa

    if all(isinstance(v, bool) for v in values):
        return pa.bool_()
    if all(isinstance(v, int) and not isinstance(v, bool) for v in values):
        return pa.int64()
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        return pa.float64()
    return pa.string()


class CampaignStore:
    """The output directory of one campaign (module docstring); :meth:`open` it, then :meth:`add` outcomes."""

    def __init__(self, root: Path, spec: CampaignSpec, plan: list[Run], lock: TextIO) -> None:
        import pyarrow as pa

        self.root, self.spec, self.plan, self._lock = root, spec, plan, lock
        params = [(name, _column_type([run.parameters[name] for run in plan])) for name in spec.parameters]
        self.schema = pa.schema(
            [("run_id", pa.string()), ("index", pa.int64()), ("status", pa.string()), ("reason", pa.string()),
             ("seconds", pa.float64()), ("worker", pa.string()), *params, *((name, pa.float64()) for name in self.scalar_names)]
        )  # fmt: skip
        self.parts = len(list((root / "runs").glob("part-*.parquet")))

    @property
    def scalar_names(self) -> tuple[str, ...]:
        from .maps import MAP_SCALARS

        return MAP_SCALARS if self.spec.kind == "map" else self.spec.scalars

    @staticmethod
    def check(out: str | Path, spec: CampaignSpec, *, resume: bool) -> None:
        """Refuse ``out`` unless it is new, empty, or this campaign's with ``resume`` (before any work: nothing written)."""
        root = Path(out)
        if not str(out).strip():
            raise CampaignError("--out: is empty; give an output directory")
        if root.exists() and not root.is_dir():
            raise CampaignError(f"--out {root}: is a file, not a directory; give a new or empty directory")
        manifest = root / MANIFEST
        if manifest.is_file():
            try:
                held = json.loads(manifest.read_text(encoding="utf-8"))
            except (ValueError, UnicodeDecodeError):
                raise CampaignError(f"--out {root}: {MANIFEST} is not a campaign's manifest; give another directory") from None
            if not isinstance(held, dict) or held.get("format") != FORMAT:
                raise CampaignError(f"--out {root}: {MANIFEST} is not a freefloat campaign's; give another directory")
            if held.get("campaign_id") != spec.campaign_id:
                raise CampaignError(
                    f"--out {root}: holds the results of another campaign (id {held.get('campaign_id')}, from {held.get('source')}); "
                    f"this campaign (id {spec.campaign_id}) is refused there: nothing is overwritten; give another directory"
                )
            if not resume:
                raise CampaignError(f"--out {root}: holds results of this campaign already; pass --resume to run only the missing runs")
        elif root.is_dir() and any(p.name != _LOCK for p in root.iterdir()):
            raise CampaignError(f"--out {root}: is not empty and holds no campaign; give a new or empty directory (nothing is overwritten)")

    @classmethod
    def open(cls, out: str | Path, spec: CampaignSpec, plan: list[Run], *, resume: bool) -> CampaignStore:
        """The store in ``out`` (:meth:`check`): created (with its manifest), or this campaign's, reopened with ``resume``."""
        cls.check(out, spec, resume=resume)
        root, manifest = Path(out), Path(out) / MANIFEST
        wanted = {"format": FORMAT, "campaign_id": spec.campaign_id}
        root.mkdir(parents=True, exist_ok=True)
        lock = open(root / _LOCK, "a")  # held for the store's life
        try:
            fcntl.flock(lock.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            lock.close()
            raise CampaignError(
                f"--out {root}: another freefloat campaign is writing there now; wait for it or give another directory"
            ) from None
        if not manifest.is_file():
            (root / "runs").mkdir(exist_ok=True)
            content = {
                **wanted, "source": spec.source, "description": spec.description, "kind": spec.kind, "runs": len(plan),
                "parameters": list(spec.parameters), "scalars": list(spec.scalars), "series": list(spec.series),
                "scenario": spec.scenario, "function": spec.function, "base": spec.base, "count": spec.count, "seed": spec.seed,
                "grid": spec.grid, "random": spec.random, "freefloat": __version__,
            }  # fmt: skip
            _atomic_write(manifest, (json.dumps(content, indent=2) + "\n").encode())
        return cls(root, spec, plan, lock)

    def close(self) -> None:
        """Release the directory."""
        self._lock.close()

    def __enter__(self) -> CampaignStore:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def write_series(self, outcome: RunOutcome) -> None:
        """The run's time series into ``series.zarr/<run_id>`` (a run not yet finished may be written again)."""
        if not outcome.series:
            return
        import zarr

        group = zarr.open_group(str(self.root / "series.zarr" / outcome.run_id), mode="w")
        for name, values in outcome.series.items():
            group.create_array(name, data=np.asarray(values))

    def add(self, outcomes: list[RunOutcome]) -> Path | None:
        """Finished runs as a new part (their series written first); the part's path (None: nothing to add)."""
        if not outcomes:
            return None
        import pyarrow as pa
        import pyarrow.parquet as pq

        by_id = {run.run_id: run for run in self.plan}
        rows: dict[str, list[Any]] = {name: [] for name in self.schema.names}
        for outcome in outcomes:
            params = by_id[outcome.run_id].parameters
            fixed = (outcome.run_id, outcome.index, outcome.status, outcome.reason, outcome.seconds, outcome.worker)
            for name, value in zip(COLUMNS, fixed, strict=True):
                rows[name].append(value)
            for name in self.spec.parameters:
                rows[name].append(params[name] if self.schema.field(name).type != pa.string() else str(params[name]))
            for name in self.scalar_names:
                rows[name].append(outcome.scalars.get(name, float("nan")))
        table = pa.table(rows, schema=self.schema)
        final = self.root / "runs" / f"part-{self.parts:06d}.parquet"
        temporary = final.with_name(f".{final.name}.tmp")
        pq.write_table(table, temporary)
        os.replace(temporary, final)
        self.parts += 1
        return final


def _atomic_write(path: Path, data: bytes) -> None:
    temporary = path.with_name(f".{path.name}.tmp")
    temporary.write_bytes(data)
    os.replace(temporary, path)


def finished_runs(out: str | Path) -> set[str]:
    """The run ids that the parts in ``out`` hold (none for a new directory)."""
    if not any((Path(out) / "runs").glob("part-*.parquet")):
        return set()
    return set(read_runs(out, columns=["run_id"]).column("run_id").to_pylist())


def read_runs(out: str | Path, columns: list[str] | None = None) -> Any:
    """The finished runs of a campaign directory: one pyarrow Table of every part (sorted by run index)."""
    import pyarrow.parquet as pq

    parts = sorted((Path(out) / "runs").glob("part-*.parquet"))
    if not parts:
        raise CampaignError(f"{out}: holds no finished runs (no runs/part-*.parquet)")
    import pyarrow as pa

    table = pa.concat_tables([pq.read_table(p, columns=columns) for p in parts])
    if "index" in table.column_names:
        table = table.sort_by("index")
    return table


def read_series(out: str | Path, run_id: str) -> dict[str, np.ndarray]:
    """The recorded time series of one run ({} when it has none)."""
    import zarr

    path = Path(out) / "series.zarr" / run_id
    if not path.is_dir():
        return {}
    group = zarr.open_group(str(path), mode="r")
    with contextlib.suppress(KeyError):
        return {name: np.asarray(array[...]) for name, array in group.arrays()}
    return {}
