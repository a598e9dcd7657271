"""Reproduction of the papers (``ff.papers``): every printed number recomputed, compared, and reported.

- :mod:`.paper1991`: Papadopoulos & Dubowsky 1991 §V (coordinated control), rows and results;
  :mod:`.paper1991_figures` its figures.
- :mod:`.paper1992`: Papadopoulos 1992 Tables II-VI and §V (workspaces, capture), rows and results;
  :mod:`.paper1992_figures` its figures.
- :mod:`.reproduce`: ``freefloat reproduce 1991|1992`` (rows + figures + report).
- :mod:`.paper_report`: the report format (``report.json``, ``report.md``); :mod:`.report`: model reports
  (``freefloat inspect``).

Compute modules never import figure modules. Layer: the top of the library (only the CLI is above it).
"""

from __future__ import annotations

from .paper1991 import Results1991, compute_1991, rows_1991
from .paper1992 import Results1992, compute_1992, rows_1992
from .reproduce import reproduce_1991, reproduce_1992

__all__ = ["Results1991", "Results1992", "compute_1991", "compute_1992", "reproduce_1991", "reproduce_1992", "rows_1991", "rows_1992"]
