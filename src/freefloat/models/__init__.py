"""Built-in systems (``ff.models``): the papers' ``papadopoulos1991()`` and ``papadopoulos1992(arms=1|2)``,
a 3D ``spacecraft_7dof()``, the zoo of published space manipulators (:mod:`.zoo`: ``ssrms_station()``,
``ets7()``, ``dual_arm_servicer()``, ``astrobee_arm()``, each with ``provenance(name)``), and
:func:`load_model` (a built-in name or a model file path).

Layer: imports :mod:`freefloat.core` and :mod:`freefloat.io` (model files).
"""

from .papers import papadopoulos1991, papadopoulos1992, planar_link
from .registry import BUILTIN_MODELS, load_model
from .spacecraft import spacecraft_7dof
from .zoo import ZOO, astrobee_arm, dual_arm_servicer, ets7, provenance, ssrms_station

__all__ = [
    "BUILTIN_MODELS",
    "ZOO",
    "astrobee_arm",
    "dual_arm_servicer",
    "ets7",
    "load_model",
    "papadopoulos1991",
    "papadopoulos1992",
    "planar_link",
    "provenance",
    "spacecraft_7dof",
    "ssrms_station",
]
