"""The checks of a campaign file's fields that :mod:`.spec` and :mod:`.maps` share (the rest: the scenario files')."""

from __future__ import annotations

from typing import Any

from ..core.errors import ModelError
from ..scenarios.scenario import _where

__all__ = ["integer_field"]


def integer_field(table: dict[str, Any], key: str, default: int, low: int, source: str, where: str, fix: str) -> int:
    """``table[key]`` (``default`` when absent): an integer >= ``low``, else a ModelError naming ``where.key``."""
    value = table.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise ModelError(_where(source, f"{where}.{key}"), f"expected an integer >= {low}, got {value!r}", fix)
    return value
