"""Memory checked before it is taken: every sampling, map and batch call estimates its peak memory first.

:func:`require_memory` compares an estimate with the memory this machine has free
(``MemAvailable`` of ``/proc/meminfo`` on Linux, or less when a container's control-group limit leaves less;
elsewhere the physical memory from ``os.sysconf``)
and raises :class:`~freefloat.core.errors.MemoryBudgetError`, naming the estimate, what is free and
the way out, when the estimate exceeds :data:`MEMORY_FRACTION` of it. No MemoryError, and no machine
driven into swap, reaches the user. ``FREEFLOAT_MEMORY_LIMIT`` (bytes, or with a K/M/G suffix) sets
the free memory by hand (a batch job's share, or a test).
"""

from __future__ import annotations

import os
from pathlib import Path

from .errors import MemoryBudgetError

__all__ = ["MEMORY_FRACTION", "available_memory", "format_bytes", "require_memory"]

#: The largest share of the free memory one call may plan to use.
MEMORY_FRACTION = 0.8


def format_bytes(nbytes: float) -> str:
    """``nbytes`` in readable units (``"3.2 GB"``)."""
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if nbytes >= size:
            return f"{nbytes / size:.3g} {unit}"
    return f"{nbytes:.0f} B"


def _cgroup_room() -> int | None:
    """Bytes left under this process's control-group memory limit (a container's), or None where there is none."""
    for limit_file, usage_file in (
        ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),  # cgroup v2
        ("/sys/fs/cgroup/memory/memory.limit_in_bytes", "/sys/fs/cgroup/memory/memory.usage_in_bytes"),  # v1
    ):
        try:
            limit = Path(limit_file).read_text().strip()
            usage = int(Path(usage_file).read_text().strip())
        except (OSError, ValueError):
            continue
        if limit == "max" or not limit.isdigit() or int(limit) >= 1 << 60:  # no limit set
            return None
        return max(int(limit) - usage, 0)
    return None


def available_memory() -> int | None:
    """Bytes of memory free for a new allocation (None where it cannot be read): the machine's free memory, or the
    room left under a container's limit when that is smaller."""
    limit = os.environ.get("FREEFLOAT_MEMORY_LIMIT", "").strip()
    if limit:
        scale = {"K": 1 << 10, "M": 1 << 20, "G": 1 << 30}.get(limit[-1].upper(), 1)
        try:
            return int(float(limit.rstrip("KMGkmg")) * scale)
        except ValueError:
            raise MemoryBudgetError(f"FREEFLOAT_MEMORY_LIMIT={limit!r}: expected bytes, e.g. 8G or 500M") from None
    free: int | None = None
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                free = int(line.split()[1]) * 1024
    except OSError:
        pass
    if free is None:
        try:
            free = int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
        except (ValueError, OSError, AttributeError):
            free = None
    room = _cgroup_room()
    if room is None:
        return free
    return room if free is None else min(free, room)


def require_memory(nbytes: float, what: str, fix: str) -> None:
    """Refuse ``what`` (a phrase: "a map of 1e10 configurations") when its estimated ``nbytes`` exceed
    :data:`MEMORY_FRACTION` of the free memory; ``fix`` says what to do instead."""
    if nbytes < 1 << 26:  # under 64 MB: not worth a look
        return
    free = available_memory()
    if free is None or nbytes <= MEMORY_FRACTION * free:
        return
    raise MemoryBudgetError(
        f"{what} would need about {format_bytes(nbytes)} of memory, more than this machine has free ({format_bytes(free)}); {fix}"
    )
