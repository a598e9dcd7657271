"""What the model-file readers share (URDF and TOML in :mod:`.model_files`, MJCF in :mod:`.mjcf`): the end-effector
argument and the correction of a non-physical inertia (a warning and a record, or an error with ``strict``)."""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import ModelCorrectionWarning, ModelError
from ..core.model import MAX_INERTIA, Model, check_inertia, inertia_defect, nearest_physical_inertia

__all__ = ["SEPARATOR_HINT", "EndEffectors", "end_effector_specs", "model_path", "naming_file", "not_a_file", "physical_inertia"]

#: What a user may pass as ``end_effectors=``: link (body) names, or (name, link, point) triples.
EndEffectors = Sequence[str | tuple[str, str, Sequence[float]]] | None


def end_effector_specs(end_effectors: EndEffectors, source: str) -> list[tuple[str, str, Any]]:
    """(name, body, point) for each entry of ``end_effectors=``."""
    out: list[tuple[str, str, Any]] = []
    for i, entry in enumerate(end_effectors or ()):
        if isinstance(entry, str):
            out.append((entry, entry, (0.0, 0.0, 0.0)))
        elif isinstance(entry, (tuple, list)) and len(entry) == 3:
            out.append((str(entry[0]), str(entry[1]), entry[2]))
        else:
            raise ModelError(
                f"{source}: end_effectors[{i}]", f"cannot read {entry!r}", "give a link name or a (name, link, [x, y, z]) triple"
            )
    return out


# --------------------------------------------------------------------- TOML
def physical_inertia(inertia: np.ndarray, path: str, strict: bool, corrections: list[dict[str, Any]]) -> np.ndarray:
    """``inertia`` if physical (zero and semi-definite allowed); else the nearest physical one, with a warning and a record.

    ``strict``: a non-physical inertia is a :class:`ModelError` instead. Shared by the URDF and MJCF readers.
    """
    defect = inertia_defect(inertia, degenerate_ok=True)
    if defect is None:
        return inertia
    if not np.all(np.isfinite(inertia)) or np.abs(inertia).max() > MAX_INERTIA:
        check_inertia(inertia, path)  # raises: NaN, infinity and unit slips are not corrected
    fix = "use the inertia of a real body about its CM (symmetric, principal moments >= 0, each <= the sum of the other two)"
    if strict:
        raise ModelError(path, defect, f"{fix}; or load with strict=False to use the nearest physical inertia, with a warning")
    fixed = nearest_physical_inertia(inertia)
    change = float(np.linalg.norm(fixed - inertia))
    largest = float(np.max(np.abs(np.linalg.eigvalsh(0.5 * (inertia + inertia.T))))) if np.all(np.isfinite(inertia)) else np.inf
    record = {
        "where": path,
        "field": "inertia",
        "defect": defect,
        "correction": "nearest physical inertia (Frobenius norm): principal axes kept, moments projected onto {I_k >= 0, I_a <= I_b + I_c}",
        "given": np.asarray(inertia, dtype=float).tolist(),
        "used": fixed.tolist(),
        "change_kg_m2": change,
        "relative_change": change / largest if largest > 0 else np.inf,
    }
    corrections.append(record)
    warnings.warn(
        f"{path} {defect}; using the nearest physical inertia (change {change:.3g} kg m^2,"
        f" {record['relative_change']:.1%} of the largest moment). Load with strict=True to refuse instead.",
        ModelCorrectionWarning,
        stacklevel=3,
    )
    return fixed


def model_path(given: str) -> Path:
    """The path of a model file as the user typed it, ``~`` expanded; a name that is not valid UTF-8 (a file made on
    another system) is refused here, before a reader that cannot take it (MuJoCo's parser) fails on it."""
    try:
        given.encode("utf-8")
    except UnicodeEncodeError:
        shown = os.fsencode(given).decode("utf-8", "backslashreplace")
        raise ModelError(shown, "the file name is not valid UTF-8", "rename the file (and its folders) to a UTF-8 name") from None
    return Path(os.path.expanduser(given))


def not_a_file(path: Path) -> str | None:
    """What keeps ``path`` from being read as a model file: a broken symbolic link (and the missing file at the end of
    its chain of links), a folder or something else that is not a regular file, or nothing there (with a hint where
    the path has a backslash); None when it is a file (a link to one included)."""
    if path.is_file():
        return None
    if path.is_symlink() and not path.exists():
        target = os.path.realpath(path)
        if os.path.islink(target):
            return f"is a loop of symbolic links (through {target})"
        return f"is a symbolic link to {target}, which does not exist"
    if path.exists():
        return "is not a file"
    return "file not found" + (f" ({SEPARATOR_HINT})" if "\\" in str(path) else "")


#: The hint for a path with a backslash that names nothing (a Windows path typed on Linux or macOS).
SEPARATOR_HINT = "use / as the separator: a backslash is part of a file name here"


def naming_file(path: str | Path, build: Callable[[], Model]) -> Model:
    """``build()``; a ModelError it raises names the file ``path`` (the tree's errors, a loop or a massless moving body, do not)."""
    try:
        return build()
    except ModelError as exc:
        if str(path) in exc.field:
            raise
        raise ModelError(f"{path}: {exc.field}", exc.problem, exc.fix) from None
