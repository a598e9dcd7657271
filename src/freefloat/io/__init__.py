"""Reading and writing models, and the bridges to other engines.

- :mod:`.model_files`: TOML and URDF model files (:func:`load`, :func:`save`, :func:`read_toml`).
- :mod:`.unmodelled`: which elements of a URDF or MJCF file are modelled, ignored or dropped with a warning.
- :mod:`.mujoco_bridge`: a model and state in MuJoCo (MJCF), imported on demand.
- :mod:`.oracles`: a model and state in Pinocchio, for the cross-checks; imported on demand.

Layer: imports :mod:`freefloat.core` and :mod:`freefloat.mechanics` (may import every layer below it).
"""

from __future__ import annotations

from .model_files import load, load_toml, load_urdf, read_toml, save, to_toml_dict, to_urdf_string

__all__ = ["load", "load_toml", "load_urdf", "read_toml", "save", "to_toml_dict", "to_urdf_string"]
