"""Built-in systems: the papers' ``papadopoulos1991()`` and ``papadopoulos1992(arms=1|2)``, and a 3D ``spacecraft_7dof()``."""

from .papers import papadopoulos1991, papadopoulos1992, planar_link
from .spacecraft import spacecraft_7dof

__all__ = ["papadopoulos1991", "papadopoulos1992", "planar_link", "spacecraft_7dof"]
