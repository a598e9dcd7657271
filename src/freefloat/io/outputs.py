"""Output directories that never clobber: what ``--out DIR`` of every ``freefloat`` command writes through.

A run writes its files into a fresh staging folder inside DIR; when it ends they are moved into
DIR, and ``DIR/freefloat-manifest.json`` lists every file freefloat wrote there with its SHA-256.
A file of DIR that the run would replace is

- refused unless ``overwrite`` is set (the run's files are then discarded, DIR is unchanged);
- with ``overwrite``, replaced only if a manifest lists it and its content is still what
  freefloat wrote (a file the user made or edited is never replaced).

A file's entry lives in the deepest manifest that lists it, in DIR or a folder above it (so
``freefloat reproduce 1992 --out out/1992 --overwrite`` may replace what ``freefloat demo --out
out`` wrote there); a new file is entered in DIR's own manifest.

:func:`check_targets` does the same test before a run for the names a command knows in advance,
so that a long run is refused before it starts.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import socket
import tempfile
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from ..core.errors import SimulationError

__all__ = ["MANIFEST", "OutputDirectory", "check_targets", "output_directory", "staged_outputs"]

#: The manifest of the files freefloat wrote into an output directory (relative paths -> SHA-256).
MANIFEST = "freefloat-manifest.json"
_STAGING_PREFIX = ".freefloat-staging-"


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _read_manifest(folder: Path) -> dict[str, Any]:
    path = folder / MANIFEST
    if not path.is_file():
        return {}
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        files = data["files"]
        return files if isinstance(files, dict) else {}
    except (OSError, ValueError, KeyError, TypeError):
        return {}  # an unreadable manifest vouches for nothing: every existing file is then protected


class _Manifests:
    """The manifests of a folder and the folders above it, read once; :meth:`entry` finds a file's."""

    def __init__(self) -> None:
        self.files: dict[Path, dict[str, Any]] = {}

    def of(self, folder: Path) -> dict[str, Any]:
        folder = folder.resolve()
        if folder not in self.files:
            self.files[folder] = _read_manifest(folder)
        return self.files[folder]

    def entry(self, target: Path) -> tuple[Path, str, dict[str, Any]] | None:
        """(manifest folder, path relative to it, entry) of the deepest manifest listing ``target``."""
        target = target.resolve()
        for folder in target.parents:
            rel = target.relative_to(folder).as_posix()
            entry = self.of(folder).get(rel)
            if isinstance(entry, dict):
                return folder, rel, entry
        return None


def output_directory(path: Path | str) -> Path:
    """Create the output directory ``path`` (and its parents); refuse an empty path or a path that is a file.

    ``~`` is expanded, and a path with ``..`` is taken as the folder it names (``n/../m`` is ``m``: no ``n`` is made).
    Returns the folder's path (the one given, or the normalised one where it had ``..``)."""
    return _make_output_directory(path)[0]


def _out_problem(given: str, path: Path) -> str | None:
    """Why no folder can be made at ``path`` (``--out given``) before anything is made: a broken symbolic link on the way
    (named with the target it misses), or a file or device where a folder of the path must be; None when it can be."""
    parts = path.parts
    for i in range(1, len(parts) + 1):
        level = Path(*parts[:i])
        if level.is_symlink() and not level.exists():
            return (
                f"--out {given}: {level} is a symbolic link to {os.path.realpath(level)}, which does not exist; "
                "make that folder, or choose another --out"
            )
        if i < len(parts) and level.exists() and not level.is_dir():  # the system would not go through it (not even "..")
            return f"--out {given}: cannot create this folder (Not a directory): {level} is not a folder; choose another --out"
    return None


def _make_output_directory(path: Path | str) -> tuple[Path, list[Path]]:
    """``output_directory``, and the folders this process created (deepest first), to remove if the run fails.

    Each missing level is made with one ``os.mkdir`` of its own; a level that another process made in the meantime is
    used and not listed, so that the caller removes only what this process made."""
    if not str(path).strip():
        raise ValueError("--out: an empty path would write into the current directory; name an output directory, e.g. --out out")
    given = str(Path(path))
    path = Path(os.path.expanduser(path))
    problem = _out_problem(given, path)
    if problem is not None:
        raise OSError(problem)
    if ".." in path.parts:  # the folder it names, as the system reads it (a link before ".." followed)
        path = Path(os.path.realpath(path))
    if path.exists() and not path.is_dir():
        raise FileExistsError(f"--out {given}: exists and is not a directory; choose another --out")
    missing = []
    for level in (path, *path.parents):
        if level.exists():
            break
        missing.append(level)
    created: list[Path] = []
    for level in reversed(missing):  # outermost first
        try:
            os.mkdir(level)
        except FileExistsError:
            if not level.is_dir():  # made by another process, as something else than a folder
                _remove(created)
                raise FileExistsError(f"--out {given}: {level} exists and is not a directory; choose another --out") from None
            continue  # made by another process meanwhile: theirs, not ours to remove
        except OSError as exc:
            _remove(created)
            raise OSError(f"--out {given}: cannot create this folder ({exc.strerror or exc}); choose a folder you can write to") from None
        created.insert(0, level)
    return path, created


def _remove(created: list[Path]) -> None:
    """Remove the folders this process made for an output directory (deepest first); one that holds anything stays."""
    for folder in created:
        try:
            folder.rmdir()
        except OSError:
            break


def _cannot_write(given: Path | str, exc: OSError) -> OSError:
    return OSError(f"--out {Path(given)}: cannot write here ({exc.strerror or exc}); choose a folder you can write to")


def _stage_owner() -> str:
    """``PID@HOST`` of this process: the staging folder's name says who writes it (a shared disk has other hosts' runs)."""
    return f"{os.getpid()}@{socket.gethostname().replace('-', '_')}"


def _remove_stale_stages(out: Path) -> None:
    """Remove the staging folders of runs that were killed: this host's, whose process no longer exists."""
    host = _stage_owner().split("@", 1)[1]
    for stage in out.glob(f"{_STAGING_PREFIX}*"):
        pid, _, owner_host = stage.name[len(_STAGING_PREFIX) :].split("-", 1)[0].partition("@")
        if owner_host == host and pid.isdigit() and not _alive(int(pid)):
            shutil.rmtree(stage, ignore_errors=True)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _conflict(out: Path, rel: str, overwrite: bool, manifests: _Manifests) -> str | None:
    """Why replacing ``out / rel`` is refused (None: it may be written)."""
    target = out / rel
    if not target.exists() and not target.is_symlink():
        return None
    if not overwrite:
        return f"{target} exists"
    if target.is_symlink() or not target.is_file():
        return f"{target} exists and is not a file freefloat wrote"
    found = manifests.entry(target)
    if found is None:
        return f"{target} was not written by freefloat (in no {MANIFEST})"
    if found[2].get("sha256") != _sha256(target):
        return f"{target} was changed after freefloat wrote it"
    return None


def _refuse(out: Path, problems: list[str], overwrite: bool, when: str) -> None:
    shown = "; ".join(problems[:5]) + (f"; and {len(problems) - 5} more" if len(problems) > 5 else "")
    if overwrite:
        fix = "freefloat replaces only the files it wrote itself and that are unchanged; move those files or choose another --out"
    else:
        fix = f"choose another --out, or pass --overwrite to replace the outputs of an earlier freefloat run (listed in {out / MANIFEST})"
    raise FileExistsError(f"--out {out}: the run would replace files ({shown}); {when}; {fix}")


def check_targets(out: Path, names: Iterable[str], *, overwrite: bool) -> None:
    """Before a run: refuse if ``out`` cannot be made (a path through a file, a folder this process cannot write in:
    tried, and the folders made for the try removed again) or if writing ``names`` (paths relative to ``out``) would
    replace a protected file."""
    given, (out, created) = out, _make_output_directory(out)
    try:  # a folder this process can write in: a file made and removed in it (as the run's staging folder will be)
        os.rmdir(tempfile.mkdtemp(prefix=f"{_STAGING_PREFIX}check-", dir=out))
    except OSError as exc:
        raise _cannot_write(given, exc) from None
    finally:
        _remove(created)  # the run makes them again when it starts
    manifests = _Manifests()
    problems = [p for p in (_conflict(out, name, overwrite, manifests) for name in names) if p]
    if problems:
        _refuse(out, problems, overwrite, "nothing was run")


@dataclass
class OutputDirectory:
    """An output directory being written: ``stage`` is where the run writes; :meth:`commit` moves its files into ``path``."""

    path: Path
    stage: Path
    overwrite: bool
    command: str
    written: list[Path] = field(default_factory=list)

    def final(self, paths: Iterable[Path]) -> list[Path]:
        """The paths a run reported under ``stage``, as they are in ``path`` after the commit."""
        out = []
        for p in paths:
            try:
                out.append(self.path / Path(p).relative_to(self.stage))
            except ValueError:
                out.append(Path(p))
        return out

    def rewrite(self, text: str) -> str:
        """``text`` with the staging folder replaced by the output directory (for messages)."""
        return text.replace(str(self.stage), str(self.path))

    def commit(self) -> list[Path]:
        """Move the staged files into the output directory and record them in the manifest (or refuse, changing nothing)."""
        manifests = _Manifests()
        staged = sorted(p for p in self.stage.rglob("*") if p.is_file())
        rels = [p.relative_to(self.stage).as_posix() for p in staged]
        problems = [c for c in (_conflict(self.path, rel, self.overwrite, manifests) for rel in rels) if c]
        if any(Path(rel).name == MANIFEST for rel in rels):
            problems.append(f"the run wrote a file named {MANIFEST}, which freefloat keeps for itself")
        if problems:
            _refuse(self.path, problems, self.overwrite, "the run's outputs were discarded")
        now = datetime.now(UTC).isoformat(timespec="seconds")
        changed: set[Path] = set()
        for src, rel in zip(staged, rels, strict=True):
            dest = self.path / rel
            dest.parent.mkdir(parents=True, exist_ok=True)
            found = manifests.entry(dest) if dest.exists() else None
            os.replace(src, dest)
            folder, key = (found[0], found[1]) if found is not None else (self.path.resolve(), rel)
            manifests.of(folder)[key] = {"sha256": _sha256(dest), "command": self.command, "written": now}
            changed.add(folder)
            self.written.append(dest)
        for folder in changed:
            body: dict[str, Any] = {"written_by": "freefloat", "note": "files freefloat wrote here; --overwrite replaces only these"}
            body["files"] = manifests.of(folder)
            tmp = folder / f"{MANIFEST}.tmp"
            tmp.write_text(json.dumps(body, indent=2, sort_keys=True) + "\n", encoding="utf-8")
            os.replace(tmp, folder / MANIFEST)
        return self.written


@contextmanager
def staged_outputs(path: Path | str, *, overwrite: bool, command: str) -> Iterator[OutputDirectory]:
    """Write a run's outputs through a staging folder in ``path``; commit them when the block ends.

    A :class:`~freefloat.SimulationError` (a simulation that failed part-way and wrote its partial
    trajectory) commits what was written, then propagates with the staging folder's name replaced
    by ``path``; any other error discards the staged files, and the folders this run created are
    removed again if they are empty. The staging folder carries the process id and host name: a run
    that was killed (SIGKILL; the command line turns SIGTERM into an interruption that ends cleanly)
    leaves one behind, and the next run on that host into ``path`` removes it (never another host's).
    """
    out, created = _make_output_directory(path)
    _remove_stale_stages(out)
    try:
        stage = Path(tempfile.mkdtemp(prefix=f"{_STAGING_PREFIX}{_stage_owner()}-", dir=out))
    except OSError as exc:
        _remove(created)
        raise _cannot_write(path, exc) from None
    target = OutputDirectory(out, stage, overwrite, command)
    committed = False
    try:
        yield target
        target.commit()
        committed = True
    except SimulationError as exc:
        target.commit()
        committed = True
        raise SimulationError(target.rewrite(str(exc)), exc.trajectory) from exc
    finally:
        shutil.rmtree(stage, ignore_errors=True)
        if not committed:
            _remove(created)
