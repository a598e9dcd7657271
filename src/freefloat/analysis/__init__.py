"""Analysis of a model: workspaces, dynamic singularities and payload capture (Papadopoulos 1992 §III-V).

Two namespaces gather the public names: :mod:`freefloat.analysis.workspace`
(``ff.workspace``: reachable, guaranteed and path-independent workspaces,
determinant maps, workspace limits) and :mod:`freefloat.analysis.capture`
(``ff.capture``: the §V capture procedure and path placement).

Layer: imports :mod:`freefloat.core` and :mod:`freefloat.mechanics` only.
"""

from __future__ import annotations

from . import capture, workspace

__all__ = ["capture", "workspace"]
