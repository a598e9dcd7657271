"""The papers' systems, built in: ``papadopoulos1991()`` and ``papadopoulos1992(arms=1|2)``."""

from .papers import papadopoulos1991, papadopoulos1992, planar_link

__all__ = ["papadopoulos1991", "papadopoulos1992", "planar_link"]
