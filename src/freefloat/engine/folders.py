"""Where the engine's compiled kernels are: this machine's cache folder, the portable kernels freefloat ships, and
the lock that makes one compile of a kernel per machine (what :func:`.gate.attach_cache` is told: :data:`EVENTS`).

Every generic kernel of the engine (those :mod:`.calls` runs) takes the model as plain arrays, so it is
compiled once for all models (a new model or a payload variant costs nothing) and numba keeps the
machine code on disk between processes (:func:`.cache.kernel`). This module decides *where* that cache lives and
what happens when it is unusable:

* location: ``$FREEFLOAT_CACHE_DIR/numba`` if set, else ``platformdirs.user_cache_dir("freefloat")/numba``
  (``~/.cache/freefloat/numba`` on Linux), one subfolder per numba version and engine source
  (:data:`KERNEL_MODULES`); never the install tree;
* two processes that need one kernel at once: the first takes the kernel's compile lock (a file lock beside its
  index, :func:`_hold`), the second waits (said once) and loads what the first saved; numba writes each file to a
  temporary name and renames it (atomic on POSIX and Windows);
* a broken cache (truncated or corrupted files, a folder that cannot be written): a
  :class:`CacheWarning` names the folder and the kernel, the kernel is compiled again in memory
  and the cache files are rewritten; never a traceback.

numba's public switch ``cache=True`` picks the folder from a process-wide setting
(``NUMBA_CACHE_DIR``) that would also move the user's own numba caches, so the kernels are
given a cache whose locator points to our folder (:func:`.gate.attach_cache`: one of numba's internals; where it
cannot be used, the kernels keep numba's own cache, ``cache=True``).

Portable kernels: freefloat ships the generic kernels compiled for numba's portable CPU (``NUMBA_CPU_NAME=generic``:
any CPU of the target triple) for the numba version and Python it was built with (:data:`PORTABLE_ARCHIVE`, its
manifest :data:`PORTABLE_MANIFEST`). A kernel that is not in this machine's cache is loaded from them, unpacked once
into the cache folder (:func:`portable_dir`), instead of compiled; they run up to about 2.5x slower than kernels
compiled for this machine. ``FREEFLOAT_KERNELS`` (:data:`KERNELS_ENV`) chooses: ``auto`` (the default) loads them and
starts one background process per machine that compiles this machine's own (:func:`start_native_compile`: the next
processes load those); ``portable`` loads them and compiles nothing in the background; ``native`` never loads them
(every kernel compiled on this machine on first use). Kernels for another numba, Python or engine source are never
loaded (said once); the cache's entries are keyed by the target triple and CPU, so another CPU's never load either.

This module is not part of the key of the cache folder (:data:`KERNEL_MODULES`): nothing here changes the kernels'
machine code.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tarfile
import tempfile
import threading
import time
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import filelock
import numba
import platformdirs

from ..core.errors import SettingError
from ..core.feedback import notice
from . import gate

__all__ = [
    "EVENTS",
    "KERNELS_ENV",
    "KERNEL_MODULES",
    "PORTABLE_ARCHIVE",
    "PORTABLE_MANIFEST",
    "CacheWarning",
    "cache_dir",
    "compile_seconds",
    "compiling_now",
    "kernel_status",
    "kernels_setting",
    "portable_dir",
    "portable_manifest",
    "source_key",
    "start_native_compile",
    "watch_compiles",
]


class CacheWarning(UserWarning):
    """The on-disk kernel cache could not be used; the kernel was compiled again (a few seconds)."""


#: The modules whose kernels are cached; numba does not track calls across files, so the
#: cache folder is keyed by a hash of all of them (an edit or an upgrade starts a fresh folder).
KERNEL_MODULES = (
    "gate.py",
    "cache.py",
    "layout.py",
    "recursions.py",
    "quantities.py",
    "measures.py",
    "drivers.py",
    "stepper.py",
    "stops.py",
    "specialise/lanes.py",
    "laws.py",
    "threads.py",
)


@functools.cache
def source_key() -> str:
    """The key of this numba version and engine source (:data:`KERNEL_MODULES`): the cache folder's name and the stamp
    of every cache index."""
    digest = hashlib.sha256(numba.__version__.encode())
    here = Path(__file__).parent
    for name in KERNEL_MODULES:
        digest.update((here / name).read_bytes())
    for name in ("numbers.py", "state_layout.py"):  # core's constants the kernels compile in (MAX_EFFORT, the flat state's offsets)
        digest.update((here.parent / "core" / name).read_bytes())
    return digest.hexdigest()[:16]


def cache_dir() -> Path:
    """The folder that holds the compiled kernels of this numba version and this engine source."""
    root = os.environ.get("FREEFLOAT_CACHE_DIR") or platformdirs.user_cache_dir("freefloat")
    return Path(root) / "numba" / f"{numba.__version__}-{source_key()}"


def _broken(folder: str, name: str, exc: BaseException) -> None:
    warnings.warn(
        f"freefloat: the compiled-kernel cache in {folder} is broken for {name} ({type(exc).__name__}: {exc}); "
        "compiling it again and rewriting the cache",
        CacheWarning,
        stacklevel=4,
    )


def _unwritable(folder: str, exc: BaseException) -> None:
    warnings.warn(
        f"freefloat: cannot write the compiled-kernel cache in {folder} ({type(exc).__name__}: {exc}); "
        "kernels will be compiled again in the next process (set FREEFLOAT_CACHE_DIR to a writable folder)",
        CacheWarning,
        stacklevel=4,
    )


_ANNOUNCED: list[bool] = []


def _announce_compile(folder: str) -> None:
    """Once per process, at the first kernel that is not in the cache: say that compiling takes a while, and why."""
    if _ANNOUNCED:
        return
    _ANNOUNCED.append(True)
    why = _PORTABLE_STATE.get("unusable")
    notice(
        "compiling the engine's kernels for this machine as they are first used: once, seconds for one kind of call, "
        "a few minutes for all of them (the next uses load them from "
        f"{Path(folder).parent} in under a second)" + (f"; {why}" if why else "")
    )


# ----------------------------------------------------------------- the portable kernels freefloat ships
#: The environment variable that chooses between this machine's kernels and the portable ones (module docstring).
KERNELS_ENV = "FREEFLOAT_KERNELS"
KERNELS_SETTINGS = ("auto", "portable", "native")
_HERE = Path(__file__).parent
#: The portable kernels: numba's cache folder of the engine's generic kernels, compiled for ``NUMBA_CPU_NAME=generic``
#: (``make kernels`` builds it), packed with its manifest.
PORTABLE_ARCHIVE = _HERE / "portable" / "kernels.tar.xz"
#: What the portable kernels were built with: ``numba``, ``python`` (``3.11``), ``key`` (:func:`source_key`),
#: ``triple`` (numba's target triple), ``kernels`` (how many), ``bytes`` (unpacked).
PORTABLE_MANIFEST = _HERE / "portable" / "kernels.json"
#: What this process found of the portable kernels: ``folder`` (unpacked, usable), ``unusable`` (why not), ``said``.
_PORTABLE_STATE: dict[str, str] = {}


def kernels_setting() -> str:
    """``FREEFLOAT_KERNELS``: ``auto`` (unset or empty), ``portable`` or ``native``; anything else is an error that names
    the variable and its values (raised at the first kernel the process needs)."""
    value = os.environ.get(KERNELS_ENV, "").strip().lower() or "auto"
    if value not in KERNELS_SETTINGS:
        raise SettingError(
            f"{KERNELS_ENV}={os.environ[KERNELS_ENV]!r} is not a setting: use one of {', '.join(KERNELS_SETTINGS)} "
            "(auto: the portable kernels shipped with freefloat while this machine's compile in the background; "
            "portable: those only; native: compile every kernel on this machine)"
        )
    return value


def portable_manifest() -> dict[str, Any] | None:
    """The manifest of the portable kernels shipped with this installation, None when it has none."""
    try:
        return dict(json.loads(PORTABLE_MANIFEST.read_text()))
    except (OSError, ValueError):
        return None


def compile_seconds(name: str) -> float | None:
    """How long the engine's kernel ``name`` (``rk4_steps``) took to compile when the portable kernels were built (s,
    the longest of its signatures; the manifest's ``compile_seconds``), None when not recorded."""
    value = (portable_manifest() or {}).get("compile_seconds", {}).get(name)
    return float(value) if isinstance(value, (int, float)) else None


def _portable_mismatch(manifest: dict[str, Any] | None) -> str | None:
    """Why the shipped portable kernels cannot be used here (None: they can)."""
    if manifest is None or not PORTABLE_ARCHIVE.is_file():
        return "this installation has no portable kernels"
    here = {"numba": numba.__version__, "python": "{}.{}".format(*sys.version_info[:2]), "key": source_key()}
    for field, value in here.items():
        if manifest.get(field) != value:
            if field == "key":
                return "the portable kernels shipped with freefloat are of another engine source (make kernels builds them)"
            return f"the portable kernels shipped with freefloat are for {field} {manifest.get(field)}, this is {value}"
    return None


def portable_dir() -> str | None:
    """The folder of the portable kernels, unpacked into the cache folder the first time; None when they are not to be
    used (``FREEFLOAT_KERNELS=native``), not shipped, or built for another numba, Python or engine source (the reason
    is kept for the compile notice)."""
    if "folder" in _PORTABLE_STATE:
        return _PORTABLE_STATE["folder"]
    if "unusable" in _PORTABLE_STATE or kernels_setting() == "native":
        return None
    why = _portable_mismatch(portable_manifest())
    if why is not None:
        _PORTABLE_STATE["unusable"] = why
        return None
    folder = cache_dir().with_name(cache_dir().name + "-portable")
    if not (folder / "kernels.json").is_file():
        try:
            _unpack(folder)
        except (OSError, tarfile.TarError) as exc:
            _PORTABLE_STATE["unusable"] = f"the portable kernels could not be unpacked into {folder} ({exc})"
            return None
    _PORTABLE_STATE["folder"] = str(folder)
    return str(folder)


def _unpack(folder: Path) -> None:
    """Unpack the portable kernels into ``folder``: into a temporary folder beside it, then renamed (two processes
    unpacking at once: one rename wins, the other's copy is removed)."""
    folder.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=folder.name + ".", dir=folder.parent))
    try:
        with tarfile.open(PORTABLE_ARCHIVE, "r:xz") as archive:
            archive.extractall(staging, filter="data")
        shutil.copyfile(PORTABLE_MANIFEST, staging / "kernels.json")  # last: marks the folder complete
        try:
            staging.rename(folder)
        except OSError:
            if not (folder / "kernels.json").is_file():
                raise
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _loaded_portable(folder: str) -> None:
    """At the first portable kernel a process loads: (``auto``) start this machine's compile, and say so when it
    started one or when no process of this cache folder has said it before (the marker ``announced`` in ``folder``):
    once per machine, not in every process."""
    if "said" in _PORTABLE_STATE:
        return
    _PORTABLE_STATE["said"] = "yes"
    started = kernels_setting() == "auto" and start_native_compile()
    try:
        os.close(os.open(Path(folder) / "announced", os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        first = True
    except FileExistsError:
        first = False
    except OSError:  # a folder that cannot be written: said in every process
        first = True
    if not (started or first):
        return
    if started:
        then = "this machine's own are compiling in a background process (once; the next processes load them)"
    elif kernels_setting() == "auto":
        then = "this machine's own are compiling in the background or compiled (the next processes load them)"
    else:
        then = "freefloat kernels --compile compiles this machine's own (a few minutes, once)"
    notice(
        f"using the portable kernels shipped with freefloat (for any {platform_cpu()} CPU, up to about 2.5x slower "
        f"than kernels compiled for this machine): {then}"
    )


def platform_cpu() -> str:
    """The architecture of the portable kernels' target triple (``x86_64``)."""
    manifest = portable_manifest() or {}
    return str(manifest.get("triple", "unknown")).split("-", 1)[0]


#: The module whose run compiles this machine's kernels (the package's warm-up; named, not imported: it is above
#: the engine).
NATIVE_COMPILE_MODULE = "freefloat.warmup"


def start_native_compile() -> bool:
    """Start one background process per machine and cache folder that compiles this machine's own kernels
    (``python -m freefloat.warmup --background``, which lowers its own priority); False when one was started before (its marker
    ``native-compile.started`` in the cache folder names its process, which is alive or finished) or it cannot be
    started. The marker is made with an exclusive create: two processes never both start one."""
    folder = cache_dir()
    marker = folder / "native-compile.started"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        if marker.exists() and not _marker_is_dead(marker):
            return False
        marker.unlink(missing_ok=True)
        descriptor = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
    except OSError:
        return False
    env = {**os.environ, KERNELS_ENV: "native"}
    try:
        process = subprocess.Popen(
            [sys.executable, "-m", NATIVE_COMPILE_MODULE, "--background"],
            env=env,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
        )
    except OSError:
        os.close(descriptor)
        marker.unlink(missing_ok=True)
        return False
    with os.fdopen(descriptor, "w") as file:
        file.write(str(process.pid))
    return True


def _marker_is_dead(marker: Path) -> bool:
    """Whether the background compile a marker names has ended without finishing (its process gone, no ``done``
    beside it): then another may start."""
    if (marker.parent / "native-compile.done").exists():
        return False
    try:
        pid = int(marker.read_text() or "0")
    except (OSError, ValueError):
        return False  # being written now
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except OSError:
        return False
    return False


def kernel_status() -> dict[str, Any]:
    """Where this process's kernels come from: ``setting`` (``FREEFLOAT_KERNELS``), ``folder`` (this machine's cache
    folder) and ``native`` (how many compiled kernels it holds), ``portable`` (the portable kernels' folder, or None) and
    ``portable_note`` (why they are not used, or None), ``manifest`` (theirs, or None), ``background`` (the background
    compile of this machine's kernels: ``not started``, ``running`` or ``done``)."""
    folder = cache_dir()
    portable = portable_dir()
    started, done = (folder / "native-compile.started"), (folder / "native-compile.done")
    background = "done" if done.exists() else "not started" if not started.exists() or _marker_is_dead(started) else "running"
    return {
        "setting": kernels_setting(),
        "folder": str(folder),
        "native": sum(1 for _ in folder.rglob("*.nbc")) if folder.is_dir() else 0,
        "portable": portable,
        "portable_note": _PORTABLE_STATE.get("unusable"),
        "manifest": portable_manifest(),
        "background": background,
    }


# ----------------------------------------------------------------- one compile per kernel and machine
#: How long a process waits for another that compiles the same kernel (s) before it compiles the kernel itself.
COMPILE_WAIT = 900.0
_LOCKS: dict[str, filelock.BaseFileLock] = {}
_WAITED: list[bool] = []


def _hold(index: str, name: str) -> bool:
    """Take the compile lock of the kernel whose cache index is ``index`` (a file lock beside it, given back when its
    process ends however it ends): at once, or after waiting (said once per process) while another process compiles
    the kernel; False when the lock cannot be made (an unwritable folder) or the wait ran out (:data:`COMPILE_WAIT`).
    From here until :func:`_release`, the kernel is what this process compiles (:func:`watch_compiles`)."""
    if index in _LOCKS:
        return True
    try:
        os.makedirs(os.path.dirname(index), exist_ok=True)
        lock = filelock.FileLock(index + ".lock", thread_local=False)
        try:
            lock.acquire(timeout=0)
        except filelock.Timeout:
            if not _WAITED:
                _WAITED.append(True)
                notice(f"waiting for another process that compiles the engine's kernel {name} for this machine (once)")
            _begin(index, f"waiting for another process that compiles the engine's kernel {name}")
            lock.acquire(timeout=COMPILE_WAIT)
    except (OSError, filelock.Timeout):
        _end(index)
        return False
    _LOCKS[index] = lock
    _begin(index, f"compiling the engine's kernel {name} for this machine (once)")
    return True


def _release(index: str) -> None:
    lock = _LOCKS.pop(index, None)
    if lock is not None:
        lock.release()
    _end(index)


# ----------------------------------------------------------------- what this process compiles now
#: How often (s) a compile's watchers are told that it still runs (:func:`watch_compiles`).
WATCH_PERIOD = 0.5
_ACTIVE: dict[str, tuple[str, float]] = {}  # a kernel's index -> (what this process does for it, since)
_WATCHERS: list[Callable[[str | None, float], None]] = []
_ACTIVITY = threading.Lock()
_TICKER: list[threading.Thread] = []


def compiling_now() -> tuple[str, float] | None:
    """What this process waits for now: (what, seconds so far) of its longest-running compile of an engine kernel
    ("compiling the engine's kernel rk4_steps for this machine (once)", or "waiting for another process that compiles
    the engine's kernel ..."), None when it compiles nothing."""
    with _ACTIVITY:
        if not _ACTIVE:
            return None
        what, since = min(_ACTIVE.values(), key=lambda entry: entry[1])
    return what, time.perf_counter() - since


@contextlib.contextmanager
def watch_compiles(callback: Callable[[str | None, float], None]) -> Iterator[None]:
    """Inside the block, ``callback(what, seconds)`` is called, from a thread of its own, when this process starts to
    compile one of the engine's kernels (or to wait for another process that compiles it), every
    :data:`WATCH_PERIOD` s while that lasts (``what`` as :func:`compiling_now` says it, ``seconds`` so far), and once
    with ``what`` None when it has ended (``seconds``: how long it lasted). A compile blocks the thread that needs the
    kernel: this is how a progress bar of that thread can say what it waits for."""
    with _ACTIVITY:
        _WATCHERS.append(callback)
    try:
        yield
    finally:
        with _ACTIVITY:
            _WATCHERS.remove(callback)


def _begin(index: str, what: str) -> None:
    with _ACTIVITY:
        since = _ACTIVE.get(index, (what, time.perf_counter()))[1]
        _ACTIVE[index] = (what, since)
        if not _WATCHERS or _TICKER:
            return
        ticker = threading.Thread(target=_tick, name="freefloat-compile-watch", daemon=True)
        _TICKER.append(ticker)
    ticker.start()


def _end(index: str) -> None:
    with _ACTIVITY:
        _ACTIVE.pop(index, None)


def _tick() -> None:
    """Tell the watchers what this process compiles until it compiles nothing (or nobody watches), then that it ended."""
    first = time.perf_counter()
    try:
        while True:
            now = compiling_now()
            with _ACTIVITY:
                watchers = list(_WATCHERS)
                if now is None or not watchers:
                    _TICKER.clear()
                    break
            for callback in watchers:
                callback(*now)
            time.sleep(WATCH_PERIOD)
        for callback in watchers:
            callback(None, time.perf_counter() - first)
    except BaseException:  # (a watcher that raises: no more watching in this compile; never the compile's failure)
        with _ACTIVITY:
            _TICKER.clear()


#: What freefloat's cache reports (:class:`.gate.CacheEvents`).
EVENTS = gate.CacheEvents(
    folder=lambda: str(cache_dir()),
    stamp=source_key,
    portable=portable_dir,
    missed=lambda folder: _announce_compile(folder),
    loaded_portable=_loaded_portable,
    hold=_hold,
    release=_release,
    broken=_broken,
    unwritable=_unwritable,
)
