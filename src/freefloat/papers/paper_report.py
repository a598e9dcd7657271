"""The paper-vs-freefloat report: ``report.json`` and ``report.md`` (format in DESIGN.md).

A row is ``{"id", "paper", "ours", "agrees", "note"}``. ``paper`` is the printed
number (``None`` where the paper prints none), ``ours`` freefloat's computed
answer (``None`` where the quantity does not exist, e.g. a guaranteed workspace
that is empty). ``agrees`` is ``True`` when ``ours`` rounds to the printed value
at the printed precision (:func:`agrees_at_precision`), ``None`` where there is
no printed number to compare with.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

__all__ = ["agrees_at_precision", "make_row", "render_report_markdown", "report_summary", "write_report"]


def agrees_at_precision(printed: str | None, ours: float | None) -> bool | None:
    """True when ``ours`` rounds to ``printed`` at the number of decimals printed.

    ``printed`` is the number as the paper prints it (a string, so its precision is
    known: "0.540" has 3 decimals). ``None`` printed gives ``None``; a printed number
    with no computed counterpart gives ``False``.
    """
    if printed is None:
        return None
    if ours is None:
        return False
    decimals = len(printed.split(".")[1]) if "." in printed else 0
    return bool(abs(float(ours) - float(printed)) <= 0.5 * 10.0**-decimals * (1.0 + 1e-9))


def make_row(row_id: str, printed: str | None, ours: float | None, note: str = "") -> dict[str, Any]:
    """One report row; ``printed`` as the paper prints it (string) or ``None``."""
    return {
        "id": row_id,
        "paper": None if printed is None else float(printed),
        "ours": None if ours is None else float(ours),
        "agrees": agrees_at_precision(printed, ours),
        "note": note,
    }


def report_summary(rows: Sequence[dict[str, Any]]) -> tuple[int, int, int]:
    """(rows, rows compared with the paper, rows that agree): a row is compared where ``agrees`` is not None."""
    compared = [r for r in rows if r["agrees"] is not None]
    return len(rows), len(compared), sum(1 for r in compared if r["agrees"] is True)


def _cell(x: Any) -> str:
    if x is None:
        return "–"
    if isinstance(x, bool):
        return "yes" if x else "**no**"
    if isinstance(x, float):
        return f"{x:.6g}"
    return str(x).replace("|", "\\|")


def render_report_markdown(paper: str, title: str, rows: Sequence[dict[str, Any]], figures: Sequence[str] = (), intro: str = "") -> str:
    """Human-readable ``report.md``: a table of every row, then the figures."""
    _, n_cmp, n_ok = report_summary(rows)
    lines = [f"# {title}", ""]
    if intro:
        lines += [intro, ""]
    lines += [
        f"{len(rows)} rows; {n_cmp} with a printed number, of which {n_ok} agree at the printed precision.",
        "",
        "| id | paper | ours | agrees | note |",
        "|---|---:|---:|:---:|---|",
    ]
    lines += [f"| `{r['id']}` | {_cell(r['paper'])} | {_cell(r['ours'])} | {_cell(r['agrees'])} | {_cell(r['note'])} |" for r in rows]
    if figures:
        lines += ["", "## Figures", ""]
        lines += [f"![{Path(f).stem}]({Path(f).name})" for f in figures]
    return "\n".join(lines) + "\n"


def write_report(
    out: Path, paper: str, title: str, rows: Sequence[dict[str, Any]], figures: Sequence[str] = (), intro: str = ""
) -> tuple[Path, Path]:
    """Write ``out/report.json`` and ``out/report.md``; ``out`` is created. Returns both paths."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    ids = [r["id"] for r in rows]
    duplicates = sorted({i for i in ids if ids.count(i) > 1})
    if duplicates:
        raise ValueError(f"report rows: duplicate ids {duplicates}; every row id must be unique")
    json_path, md_path = out / "report.json", out / "report.md"
    payload = {"paper": paper, "rows": list(rows), "figures": [Path(f).name for f in figures]}
    json_path.write_text(json.dumps(payload, indent=2, allow_nan=False) + "\n")
    md_path.write_text(render_report_markdown(paper, title, rows, figures, intro))
    return json_path, md_path
