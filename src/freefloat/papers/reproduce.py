"""``freefloat reproduce 1991|1992 --out DIR``: compute a paper's rows, draw its figures, write its report.

The compute modules (:mod:`.paper1991`, :mod:`.paper1992`) never import the
figure modules; this module joins them: rows from the compute module, figures
from the figure module, ``report.json`` and ``report.md`` from
:mod:`.paper_report`.
"""

from __future__ import annotations

from pathlib import Path

from .paper1991 import INTRO as INTRO_1991
from .paper1991 import compute_1991, rows_1991
from .paper1991_figures import FIGURE_NAMES as FIGURES_1991
from .paper1991_figures import write_figures
from .paper1992 import INTRO as INTRO_1992
from .paper1992 import TITLE as TITLE_1992
from .paper1992 import Results1992, compute_1992, rows_1992
from .paper1992_figures import FIGURE_NAMES as FIGURES_1992
from .paper1992_figures import write_figures_1992
from .paper_report import write_report

__all__ = ["output_names", "reproduce_1991", "reproduce_1992"]


def output_names(paper: str) -> list[str]:
    """The files ``reproduce`` of ``paper`` ("1991" or "1992") writes, relative to its folder: known before the
    work, so that a command can refuse to replace a file before it computes anything."""
    return ["report.json", "report.md", *(FIGURES_1991 if paper == "1991" else FIGURES_1992)]


def reproduce_1991(out: Path) -> list[Path]:
    """Compute §V, write the figures, ``report.json`` and ``report.md`` into ``out``; return the written paths."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    res = compute_1991()
    rows = rows_1991(res)
    figures = write_figures(res, out)
    json_path, md_path = write_report(
        out, "1991", "Papadopoulos & Dubowsky 1991, §V: paper vs freefloat", rows, [str(f) for f in figures], INTRO_1991
    )
    return [json_path, md_path, *figures]


def reproduce_1992(out: Path, *, results: Results1992 | None = None) -> list[Path]:
    """Reproduce the 1992 paper: ``out/report.json``, ``out/report.md`` and the figures (Figs. 4, 6, 7, singularity maps).

    Computes every row of :func:`~freefloat.papers.paper1992.rows_1992` (Tables II-VI and §V) and draws
    the figures of :mod:`freefloat.papers.paper1992_figures`; returns the written
    paths (report.json, report.md, then the figures). ``results``: a
    precomputed :func:`~freefloat.papers.paper1992.compute_1992` (default: computed here, a few seconds).
    """
    out = Path(out)
    r = results if results is not None else compute_1992()
    rows = rows_1992(r)
    figures = write_figures_1992(r, out)
    json_path, md_path = write_report(out, "1992", TITLE_1992, rows, [str(f) for f in figures], INTRO_1992)
    return [json_path, md_path, *figures]
