"""Built-in models by name, and :func:`load_model`: a built-in name or a model file path.

This is how a MODEL argument of the CLI and the ``model = ...`` field of a
scenario file are read.
"""

from __future__ import annotations

import difflib
import functools
from collections.abc import Callable

from ..core.errors import ModelError
from ..core.model import Model, register_model_resolver
from ..io._readers import SEPARATOR_HINT, model_path, not_a_file
from ..io.model_files import EndEffectors, load
from .papers import papadopoulos1991, papadopoulos1992
from .spacecraft import spacecraft_7dof
from .zoo import ZOO, astrobee_arm, dual_arm_servicer, ets7, ssrms_station

__all__ = ["BUILTIN_MODELS", "load_model"]

BUILTIN_MODELS: dict[str, tuple[str, Callable[[], Model]]] = {
    "papadopoulos1991": ("Papadopoulos & Dubowsky 1991, §V example", papadopoulos1991),
    "papadopoulos1992": ("Papadopoulos 1992, Table I, two arms", lambda: papadopoulos1992(arms=2)),
    "papadopoulos1992-one-arm": ("Papadopoulos 1992, Table I, manipulator 2 removed", lambda: papadopoulos1992(arms=1)),
    "spacecraft-7dof": ("1500 kg bus with a 7-DOF S-R-S arm (KUKA iiwa kinematics x2), the 3D benchmark system", spacecraft_7dof),
    "ssrms-station": (f"zoo: {ZOO['ssrms-station'][1]}", ssrms_station),
    "ets7": (f"zoo: {ZOO['ets7'][1]}", ets7),
    "dual-arm-servicer": (f"zoo: {ZOO['dual-arm-servicer'][1]}", dual_arm_servicer),
    "astrobee-arm": (f"zoo: {ZOO['astrobee-arm'][1]}", astrobee_arm),
}
"""Built-in models by CLI name: (one-line description, factory returning the :class:`~freefloat.Model`)."""

_MODEL_SUFFIXES = (".toml", ".urdf", ".xml")


@functools.lru_cache(maxsize=len(BUILTIN_MODELS))
def _builtin(key: str) -> Model:
    """A built-in model, built once (models are immutable)."""
    return BUILTIN_MODELS[key][1]()


def load_model(spec: str, *, end_effectors: EndEffectors = None, strict: bool = False) -> Model:
    """A built-in model by name (case and ``-``/``_`` ignored) or a model file by path.

    ``end_effectors`` and ``strict``: as :func:`freefloat.load` (a built-in model's end effectors
    are part of it; ``strict`` refuses a built-in model whose published data needed corrections).
    """
    if not isinstance(spec, str):
        raise TypeError(f"model: expected a built-in model name or a model file path, got {type(spec).__name__}")
    key = spec.strip().lower().replace("_", "-")
    if key in BUILTIN_MODELS:
        if end_effectors:
            raise ModelError(
                f"MODEL {spec!r}", "is a built-in model, whose end effectors are fixed", "name end effectors for model files only"
            )
        model = _builtin(key)
        if strict and model.corrections:
            where = ", ".join(str(c["where"]).rsplit(": ", 1)[-1] for c in model.corrections)
            raise ModelError(
                f"MODEL {spec!r}",
                f"is a built-in model whose published data needed {len(model.corrections)} correction(s) ({where}), which strict refuses",
                "drop --strict (strict=False) to use the corrected model; `freefloat inspect` lists the corrections",
            )
        return model
    path = model_path(spec)  # ~ expanded; a name that is not UTF-8 refused
    if path.is_file():
        return load(spec, end_effectors=end_effectors, strict=strict)
    if path.exists() or path.is_symlink():  # a folder, a device, a broken symbolic link
        raise ModelError(spec, not_a_file(path) or "is not a file", "give the path of a .toml, .urdf or MJCF .xml model file")
    if "\\" in spec:
        raise FileNotFoundError(f"{spec}: no such model file; {SEPARATOR_HINT}")
    if path.suffix.lower() in _MODEL_SUFFIXES or "/" in spec or spec.startswith("~"):
        raise FileNotFoundError(f"{spec}: no such model file")
    close = difflib.get_close_matches(key, list(BUILTIN_MODELS), n=3, cutoff=0.5)
    hint = f"did you mean {', '.join(repr(c) for c in close)}? " if close else ""
    raise ModelError(
        f"MODEL {spec!r}",
        "is neither a model file nor a built-in model",
        f"{hint}built-in models: {', '.join(BUILTIN_MODELS)}; or give a .toml, .urdf or MJCF .xml path",
    )


register_model_resolver(load_model)  # model names wherever a model is taken (freefloat/__init__.py)
