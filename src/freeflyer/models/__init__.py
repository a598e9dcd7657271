"""Built-in systems (``ff.models``): the papers' ``papadopoulos1991()`` and ``papadopoulos1992(arms=1|2)``,
a 3D ``spacecraft_7dof()``, and :func:`load_model` (a built-in name or a model file path).

Layer: imports :mod:`freeflyer.core` and :mod:`freeflyer.io` (model files).
"""

from .papers import papadopoulos1991, papadopoulos1992, planar_link
from .registry import BUILTIN_MODELS, load_model
from .spacecraft import spacecraft_7dof

__all__ = ["BUILTIN_MODELS", "load_model", "papadopoulos1991", "papadopoulos1992", "planar_link", "spacecraft_7dof"]
