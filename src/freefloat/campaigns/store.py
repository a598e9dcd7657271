"""A campaign's output directory: what finished, written as it finishes, never rewritten nor lost.

::

    DIR/campaign.json          the campaign (its id, the spec, the scenario, the plan's size); written first
    DIR/runs/part-<time>-<random>-<first run id>.parquet
                               one row per finished run: run_id, index, status ("ok" / "failed"), failure ("run",
                               "worker" or "" for ok), reason, seconds, worker, each varied parameter, each recorded
                               scalar (NaN where a run has none)
    DIR/series.zarr/           one Zarr v3 store; a group per run, series.zarr/<run_id>/ ("t" and one array per name,
                               time first; its attribute run_id)
    DIR/damaged/               parts and series groups found damaged by --resume, moved here (never deleted)
    DIR/report/                the summary tables and plots (.report), rewritten after each invocation

A part's name cannot be another's (the time in nanoseconds, random bits and the first run's id): it is written to a
hidden temporary file, flushed to the disk and linked into place under its name, which fails if the name exists (so
no part is ever replaced), then the temporary name is removed: a part is whole or absent. A run's series are
written before its row, so a finished run always has them; a run counts as finished once its row is in a part.

``--resume`` first reads every part and checks every stored ok run's series (:func:`.stored.survey`), before any
cluster starts: a part that is another campaign's or another program's is refused (an error naming it; nothing is
changed); a damaged part (truncated, empty, unreadable) is moved to ``DIR/damaged/`` with a warning naming it, and
its runs run again; an ok run whose series are missing or are another run's is named in a warning (a series
group that is there but not whole is moved to ``DIR/damaged/``) and runs again: its new row goes into a new part,
and the readers keep the newest row of each run (that of the part stored last: its metadata holds its place in
the store's order, 1 + the largest, given under the lock; a stored row is never rewritten). One runner at a time holds the
directory (an advisory lock, released when its process ends, however it ends).

A directory that holds another campaign (another id), or files that are not a campaign's, is refused: nothing
in it is ever overwritten.
"""

from __future__ import annotations

import errno
import fcntl
import json
import os
import secrets
import time
import warnings
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from .._version import __version__
from ..core.errors import CampaignError, ModelCorrectionWarning
from .execute import RunOutcome
from .spec import COLUMNS, CampaignSpec, Run
from .stored import (
    DAMAGED,
    FORMAT,
    FORMATS,
    MANIFEST,
    SEQUENCE_KEY,
    SERIES,
    StoreSurvey,
    fsync_file,
    part_paths,
    read_runs,
    read_series,
    sequence_of,
    survey,
)

__all__ = ["MANIFEST", "CampaignStore", "DamagedStoreWarning", "read_runs", "read_series"]

_LOCK = ".campaign.lock"
#: More runs with lost series than this are one warning line (their count and the first ids), not a line each.
SUMMARY_AFTER = 3


class DamagedStoreWarning(ModelCorrectionWarning):
    """A damaged part or a run's lost series found by ``--resume``: moved aside (never deleted), its runs run again."""


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


def part_schema(spec: CampaignSpec, plan: list[Run]) -> Any:
    """The schema of every part of this campaign (without its metadata, which names the campaign)."""
    import pyarrow as pa

    from .maps import MAP_SCALARS

    scalars = MAP_SCALARS if spec.kind == "map" else spec.scalars
    params = [(name, _column_type([run.parameters[name] for run in plan])) for name in spec.parameters]
    return pa.schema(
        [("run_id", pa.string()), ("index", pa.int64()), ("status", pa.string()), ("failure", pa.string()),
         ("reason", pa.string()), ("seconds", pa.float64()), ("worker", pa.string()), *params,
         *((name, pa.float64()) for name in scalars)]
    )  # fmt: skip


def _check_out(root: Path, out: str | Path) -> None:
    """``--out`` refused with one line when it cannot be this campaign's folder (before anything is written; its
    missing parents are created later, as every command's ``--out``)."""
    if not str(out).strip():
        raise CampaignError("--out: is empty; give an output directory")
    if root.is_symlink() and not root.exists():
        raise CampaignError(f"--out {root}: is a broken symbolic link (to {os.readlink(root)}); remove it or give another directory")
    if root.exists() and not root.is_dir():
        raise CampaignError(f"--out {root}: is a file, not a directory; give a new or empty directory")
    above = root.parent
    while not above.exists():
        above = above.parent
    if not root.exists() and not above.is_dir():
        raise CampaignError(f"--out {root}: {above} is a file, not a folder; give a directory whose parents are folders")
    folder = root if root.exists() else above
    if not os.access(folder, os.W_OK | os.X_OK):
        raise CampaignError(f"--out {root}: {folder} is not writable by this user; give a directory you can write in")


class CampaignStore:
    """The output directory of one campaign (module docstring); :meth:`open` it, then :meth:`add` outcomes."""

    def __init__(self, root: Path, spec: CampaignSpec, plan: list[Run], lock: TextIO, *, owned: bool = True) -> None:
        self.root, self.spec, self.plan, self._lock, self._owned = root, spec, plan, lock, owned
        self.schema = part_schema(spec, plan).with_metadata({"freefloat_campaign": spec.campaign_id})
        self._series: Any = None
        self._sequence = 1 + max([-1, *(_sequence_at(path) for path in part_paths(root))]) if (root / "runs").is_dir() else 0

    @property
    def scalar_names(self) -> tuple[str, ...]:
        from .maps import MAP_SCALARS

        return MAP_SCALARS if self.spec.kind == "map" else self.spec.scalars

    @staticmethod
    def check(out: str | Path, spec: CampaignSpec, *, resume: bool) -> None:
        """Refuse ``out`` unless it is new, empty, or this campaign's with ``resume`` (before any work: nothing written)."""
        root = Path(out)
        _check_out(root, out)
        manifest = root / MANIFEST
        if manifest.is_file():
            try:
                held = json.loads(manifest.read_text(encoding="utf-8"))
            except (ValueError, UnicodeDecodeError):
                raise CampaignError(f"--out {root}: {MANIFEST} is not a campaign's manifest; give another directory") from None
            if isinstance(held, dict) and str(held.get("format", "")).startswith("freefloat-campaign-") and held["format"] not in FORMATS:
                raise CampaignError(
                    f"--out {root}: holds a campaign written by another freefloat (format {held['format']}; this one "
                    f"reads {' and '.join(sorted(FORMATS))}); give another directory (nothing is overwritten)"
                )
            if not isinstance(held, dict) or held.get("format") not in FORMATS:
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

    @staticmethod
    def survey(out: str | Path, spec: CampaignSpec, plan: list[Run]) -> StoreSurvey:
        """What ``out`` holds of this campaign (:func:`.stored.survey` with this campaign's schema and plan)."""
        return survey(out, part_schema(spec, plan), {run.run_id: run.index for run in plan}, deep=True)

    @staticmethod
    def lock(out: str | Path) -> TextIO | None:
        """The directory's lock, taken now when ``out`` exists (None when it does not yet: :meth:`open` takes it); a
        CampaignError when another campaign holds it."""
        root = Path(out)
        if not root.is_dir():
            return None
        lock = open(root / _LOCK, "a")
        try:
            fcntl.flock(lock.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            lock.close()
            raise CampaignError(
                f"--out {root}: another freefloat campaign is writing there now; wait for it or give another directory"
            ) from None
        return lock

    @staticmethod
    def probe(out: str | Path) -> None:
        """Check, before any cluster starts, that ``out`` (or its first existing parent) can take a part: a file
        created exclusively, written and flushed (nothing is left there)."""
        root = Path(out)
        folder = root / "runs" if (root / "runs").is_dir() else root if root.is_dir() else _existing_parent(root)
        probe = folder / f".probe-{os.getpid()}-{secrets.token_hex(4)}.tmp"
        try:
            _exclusive_write(probe, b"freefloat")
        except OSError as exc:
            raise CampaignError(f"--out {root}: cannot write a part in {folder} ({exc.strerror or exc}); give another directory") from None
        finally:
            probe.unlink(missing_ok=True)

    @classmethod
    def open(cls, out: str | Path, spec: CampaignSpec, plan: list[Run], *, resume: bool, lock: TextIO | None = None) -> CampaignStore:
        """The store in ``out`` (:meth:`check`): created (with its manifest), or this campaign's, reopened with ``resume``.
        ``lock``: the directory's lock already held (:meth:`lock`; it stays the caller's), else it is taken here."""
        cls.check(out, spec, resume=resume)
        root, manifest = Path(out), Path(out) / MANIFEST
        wanted = {"format": FORMAT, "campaign_id": spec.campaign_id}
        root.mkdir(parents=True, exist_ok=True)
        owned = lock is None
        held = cls.lock(root) if lock is None else lock  # held for the store's life
        assert held is not None
        if not manifest.is_file():
            (root / "runs").mkdir(exist_ok=True)
            content = {
                **wanted, "source": spec.source, "description": spec.description, "kind": spec.kind, "runs": len(plan),
                "parameters": list(spec.parameters), "scalars": list(spec.scalars), "series": list(spec.series),
                "scenario": spec.scenario, "function": spec.function, "base": spec.base, "count": spec.count, "seed": spec.seed,
                "grid": spec.grid, "random": spec.random, "freefloat": __version__,
            }  # fmt: skip
            _atomic_write(manifest, (json.dumps(content, indent=2) + "\n").encode())
        return cls(root, spec, plan, held, owned=owned)

    def close(self) -> None:
        """Release the directory (unless its lock was given to :meth:`open`)."""
        if self._owned:
            self._lock.close()

    def __enter__(self) -> CampaignStore:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def repair(self, found: StoreSurvey) -> None:
        """Move the damaged parts and the series groups that are not whole to ``DIR/damaged/`` (never deleted),
        with a :class:`DamagedStoreWarning` naming each; their runs are not finished, so they run again."""
        aside = self.root / DAMAGED
        for path, why in found.damaged.items():
            aside.mkdir(exist_ok=True)
            target = _free_name(aside / path.name)
            os.rename(path, target)
            warnings.warn(f"{path}: is damaged ({why}); moved to {target}, its runs run again", DamagedStoreWarning, stacklevel=2)
        said: list[str] = []
        for run_id, why in found.lost_series.items():
            group = self.root / SERIES / run_id
            moved = ""
            if group.exists():
                (aside / "series").mkdir(parents=True, exist_ok=True)
                target = _free_name(aside / "series" / run_id)
                os.rename(group, target)
                moved = f"; moved to {target}"
            said.append(f"run {run_id} is stored but {why}{moved}")
        if len(said) > SUMMARY_AFTER:  # (a lost series.zarr: one line, not one per run)
            first = ", ".join(list(found.lost_series)[:SUMMARY_AFTER])
            warnings.warn(
                f"{self.root}: {len(said)} stored runs have lost their series (runs {first}, ...; the first: {said[0]}); "
                "they run again (their new rows supersede the old ones)",
                DamagedStoreWarning,
                stacklevel=2,
            )
            return
        for line in said:
            warnings.warn(f"{self.root}: {line}; it runs again (its new row supersedes the old one)", DamagedStoreWarning, stacklevel=2)

    def write_series(self, outcome: RunOutcome) -> None:
        """The run's time series into the group ``series.zarr/<run_id>`` (a run not yet finished may be written again)."""
        if not outcome.series:
            return
        import zarr

        if self._series is None:
            self._series = zarr.open_group(str(self.root / SERIES), mode="a")
        try:
            self._write_group(outcome)
        except OSError as exc:  # a filesystem without hard links: Zarr's exclusive writes link; the lock makes them ours
            if exc.errno not in _NO_LINKS:
                raise
            self._series = zarr.open_group(_unlinked_store(self.root / SERIES), mode="a")
            self._write_group(outcome)

    def _write_group(self, outcome: RunOutcome) -> None:
        attributes = {"run_id": outcome.run_id, "campaign_id": self.spec.campaign_id}
        group = self._series.create_group(outcome.run_id, overwrite=True, attributes=attributes)
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
            failure = outcome.failure or ("run" if outcome.status == "failed" else "")
            fixed = (outcome.run_id, outcome.index, outcome.status, failure, outcome.reason, outcome.seconds, outcome.worker)
            for name, value in zip(COLUMNS, fixed, strict=True):
                rows[name].append(value)
            for name in self.spec.parameters:
                rows[name].append(params[name] if self.schema.field(name).type != pa.string() else str(params[name]))
            for name in self.scalar_names:
                rows[name].append(outcome.scalars.get(name, float("nan")))
        table = pa.table(rows, schema=self.schema.with_metadata({**self.schema.metadata, SEQUENCE_KEY: str(self._sequence).encode()}))
        self._sequence += 1
        runs = self.root / "runs"
        temporary = runs / f".part-{os.getpid()}-{secrets.token_hex(8)}.tmp"
        pq.write_table(table, temporary)
        fsync_file(temporary)
        try:
            while True:  # a new name each try: an existing part is never replaced
                final = runs / f"part-{time.time_ns():020d}-{secrets.token_hex(4)}-{outcomes[0].run_id}.parquet"
                try:
                    _place(temporary, final)
                    break
                except FileExistsError:
                    continue
        finally:
            temporary.unlink()
        return final


#: What ``os.link`` raises on a filesystem without hard links.
_NO_LINKS = {errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EXDEV, errno.ENOSYS, errno.EMLINK}


def _place(temporary: Path, final: Path) -> None:
    """``temporary``'s bytes at ``final``, which must not exist (FileExistsError): a hard link, or where the
    filesystem has none, a file created exclusively, written and flushed (never a replacement)."""
    try:
        os.link(temporary, final)
    except FileExistsError:
        raise
    except OSError as exc:
        if exc.errno not in _NO_LINKS:
            raise
        _exclusive_write(final, temporary.read_bytes())


def _unlinked_store(path: Path) -> Any:
    """A Zarr LocalStore at ``path`` whose "write unless it exists" checks, then writes (LocalStore links a
    temporary file into place, which a filesystem without hard links refuses); this runner holds the directory."""
    from zarr.storage import LocalStore

    class UnlinkedStore(LocalStore):
        async def set_if_not_exists(self, key: str, value: Any) -> None:
            if not await self.exists(key):
                await self.set(key, value)

    return UnlinkedStore(str(path))


def _exclusive_write(path: Path, data: bytes) -> None:
    descriptor = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
    try:
        view = memoryview(data)
        while view:
            view = view[os.write(descriptor, view) :]
        os.fsync(descriptor)
    finally:
        os.close(descriptor)


def _existing_parent(path: Path) -> Path:
    while not path.exists():
        path = path.parent
    return path


def _sequence_at(path: Path) -> int:
    """The sequence of the part at ``path`` (-1 when it has none or cannot be read: the survey says why)."""
    import pyarrow.parquet as pq

    try:
        return sequence_of(pq.read_schema(path).metadata)
    except (OSError, ValueError):
        return -1


def _free_name(path: Path) -> Path:
    """``path``, or ``path.N`` for the first N that is free (a second damaged file of the same name is kept too)."""
    candidate, k = path, 1
    while candidate.exists():
        candidate, k = path.with_name(f"{path.name}.{k}"), k + 1
    return candidate


def _atomic_write(path: Path, data: bytes) -> None:
    temporary = path.with_name(f".{path.name}.tmp")
    temporary.write_bytes(data)
    os.replace(temporary, path)
