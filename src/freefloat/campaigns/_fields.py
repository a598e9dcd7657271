"""The checks of a campaign file's fields that :mod:`.spec` and :mod:`.maps` share (the rest: the scenario files')."""

from __future__ import annotations

from typing import Any

from ..core.errors import ModelError
from ..scenarios.scenario import _where

__all__ = ["MAX_RUNS", "integer_field", "plan_estimate"]

#: The most runs a campaign plans (the grid's points times ``runs.count``, or a map's chunks): the plan is drawn and
#: hashed before the first run (about 0.1 ms and 0.5 kB a run), and the store is read whole on --resume.
MAX_RUNS = 1_000_000
#: What planning costs a run: seconds to draw and hash it, bytes to hold it (the plan is held whole).
PLAN_SECONDS_PER_RUN = 1e-4
PLAN_BYTES_PER_RUN = 512


def plan_estimate(runs: int) -> str:
    """What planning ``runs`` runs takes (one phrase): its time and memory, before the first run."""
    seconds, mib = runs * PLAN_SECONDS_PER_RUN, runs * PLAN_BYTES_PER_RUN / 2**20
    return f"planning them takes about {seconds:,.3g} s and {mib:,.3g} MiB before the first run"


def integer_field(table: dict[str, Any], key: str, default: int, low: int, source: str, where: str, fix: str) -> int:
    """``table[key]`` (``default`` when absent): an integer >= ``low``, else a ModelError naming ``where.key``."""
    value = table.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise ModelError(_where(source, f"{where}.{key}"), f"expected an integer >= {low}, got {value!r}", fix)
    return value
