"""One case of the bad-input table (tests/test_bad_inputs.py) and the scenario files the cases read.

The table's modules (``test_bad_inputs`` and the ``bad_inputs_*`` modules it gathers) build their cases with
:func:`api` and :func:`cli`; a CLI case that names ``{files}/NAME`` for a NAME of :data:`SCENARIO_FILES` gets that
file written into its scratch folder (:func:`add_file` registers one).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["SCENARIO_FILES", "Case", "add_file", "api", "cli"]

#: Files (path under the scratch folder's ``files/`` -> text) that the CLI cases name as ``{files}/NAME``.
SCENARIO_FILES: dict[str, str] = {}


def add_file(name: str, text: str) -> None:
    """Register the file ``files/NAME`` with ``text`` (two cases may not make the same file)."""
    if name in SCENARIO_FILES:
        raise ValueError(f"two cases make files/{name}")
    SCENARIO_FILES[name] = text


@dataclass(frozen=True)
class Case:
    id: str
    run: Callable[[Path], Any] | list[str]  # an API call (given the files folder) or a CLI argv ("{files}" is replaced)
    expect: Any  # exception class (or a tuple of them); CLI exit code; or a warning class
    match: str
    files: tuple[str, ...] = ()  # the SCENARIO_FILES it reads


def api(id: str, run: Callable[[Path], Any], expect: Any, match: str) -> Case:
    """An API case: ``run(files)`` must raise ``expect`` (or warn it) with a message matching ``match``."""
    return Case(id, run, expect, match)


def cli(id: str, argv: str, match: str, code: int = 1) -> Case:
    """A CLI case: ``freefloat ARGV`` must exit ``code`` with one ``error: ...`` line matching ``match``."""
    args = argv.split()
    return Case(id, args, code, match, tuple(name for a in args if (name := a.removeprefix("{files}/")) in SCENARIO_FILES))
