"""``freefloat reproduce 1992``: report.json holds every 1992 row id of DESIGN.md, the paper's printed numbers and ours.

The printed numbers are typed from the paper in tests/printed_1992.py (``PAPER``), not read from
:data:`freefloat.papers.paper1992.PRINTED`, so a wrong entry there is found. Every computed number either agrees
with the printed one at the printed precision (half a unit of its last digit) or differs by what docs/workspaces.md
documents ("Paper vs freefloat", the table and the paragraphs below it): ``DOCUMENTED`` holds those values of ours
as the docs state them, and the docs table itself is checked against the report, row by row.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from freefloat.cli import app
from freefloat.papers.paper1992 import PRINTED
from freefloat.papers.paper1992_figures import FIGURE_NAMES
from images import check_paper_figure
from printed_1992 import COEFFICIENTS, DOCUMENTED, LIMITS, PAPER, matches, paper_or_documented

ROOT = Path(__file__).resolve().parents[2]
#: The required 1992 row ids of DESIGN.md ("Paper-vs-freefloat report"), spelled out.
REQUIRED = (
    [f"92.{t}.arm{a}.{k}" for t in ("T2", "T4") for a in (1, 2) for k in COEFFICIENTS]
    + [f"92.{t}.arm{a}.{k}" for t in ("T3", "T5") for a in (1, 2) for k in LIMITS]
    + [f"92.S5.{k}" for k in ("alpha", "beta", "gamma")]
    + [f"92.T6.{k}" for k in ("R_max", "R_min", "PIW_max", "PIW_min", "GW_max", "GW_min")]
    + [f"92.S5.{k}" for k in ("approach_distance", "q1_deg", "q2_deg", "theta_deg")]
)


def docs_table() -> dict[str, tuple[str | None, str | None, bool]]:
    """docs/workspaces.md's "Paper vs freefloat" table: row id -> (paper, ours, agrees) as written there.

    A cell "A / B" gives one value per id of "T5.arm1.GW_max / GW_min"; "T3.arm{1,2}" is both arms; a row
    ".collinear / .as_printed" extends the ids of the row above it.
    """
    text = (ROOT / "docs" / "workspaces.md").read_text(encoding="utf-8").replace("−", "-")
    table = text[text.index("| row | paper | ours | agrees | why |") :].split("\n\n", 1)[0].splitlines()[2:]
    out: dict[str, tuple[str | None, str | None, bool]] = {}
    above: list[str] = []
    for line in table:
        spec, paper, ours, agrees = (cell.strip() for cell in line.strip("|").split("|")[:4])
        parts = spec.split(" / ")
        first = parts[0]
        ids_of_row = []
        for k, part in enumerate(parts):
            if part.startswith("."):
                ids = [base + part for base in above]
            else:
                name = part if k == 0 else first.rsplit(".", 1)[0] + "." + part
                arms = re.search(r"\{([\d,]+)\}", name)
                ids = [name.replace(arms.group(0), a) for a in arms.group(1).split(",")] if arms else [name]
                ids = ["92." + i for i in ids]
            cell = [c.split(" / ")[k] if " / " in c else c for c in (paper, ours, agrees)]
            for i in ids:
                out[i] = (
                    None if cell[0] == "n/a" else cell[0],
                    None if cell[1] == "None" else cell[1],
                    {"yes": True, "no": False}[cell[2]],
                )
            ids_of_row += ids
        if not spec.startswith("."):
            above = ids_of_row
    return out


def test_printed_table_is_the_papers() -> None:
    """The report's printed numbers (freefloat.papers.paper1992.PRINTED) are the paper's, digit for digit."""
    assert set(PRINTED) == set(PAPER)
    wrong = {k: (PRINTED[k], PAPER[k]) for k in PAPER if PRINTED[k] != PAPER[k]}
    assert not wrong, wrong


def test_reproduce_1992_writes_every_required_row(tmp_path: Path) -> None:
    out = tmp_path / "r92"
    result = CliRunner().invoke(app, ["reproduce", "1992", "--out", str(out)])
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    assert report["paper"] == "1992"
    rows = {row["id"]: row for row in report["rows"]}
    assert len(rows) == len(report["rows"])  # unique ids
    missing = [k for k in REQUIRED if k not in rows]
    assert not missing, missing
    assert set(PAPER) <= set(rows)
    for key, row in rows.items():
        assert set(row) == {"id", "paper", "ours", "agrees", "note"}
        base = key.removesuffix(".as_printed").removesuffix(".collinear")
        printed = PAPER[base]
        assert row["paper"] == (None if printed is None else float(printed)), key
        if printed is None:  # Table V's n/a: arm 2 has no guaranteed workspace (eq. 16 gives R'_max < R'_min)
            assert row["ours"] is None and row["agrees"] is True and row["note"].startswith("n/a"), key
            continue
        assert isinstance(row["ours"], float), key
        paper_or_documented(key, row["ours"])  # the paper's number at its precision, or the documented difference
        assert row["agrees"] is (key not in DOCUMENTED), key
        if key in DOCUMENTED:
            assert len(row["note"]) > 20, key  # every disagreement says why
    assert {k for k in rows if k.endswith(".as_printed")} >= {f"92.T3.arm1.{k}.as_printed" for k in ("R_min", "GW_max", "GW_min")}
    # the notes name the reason of the main differences
    assert "misprint" in rows["92.T4.arm2.gamma"]["note"] and "slip" in rows["92.T4.arm1.beta"]["note"]
    assert "polygon" in rows["92.T3.arm1.R_min"]["note"] and "no assumption we know reproduces it" in rows["92.T6.PIW_min"]["note"]
    assert "round approach distance" in rows["92.S5.R_plus"]["note"]
    # docs/workspaces.md's table says the same as the report, and its paper column is the paper's
    documented = docs_table()
    assert len(documented) >= 30 and set(documented) <= set(rows)
    for key, (paper, ours, agrees) in documented.items():
        assert paper == PAPER[key.removesuffix(".as_printed").removesuffix(".collinear")], key
        row = rows[key]
        assert (ours is None) == (row["ours"] is None) and row["agrees"] is agrees, key
        if ours is not None:
            assert matches(row["ours"], ours), (key, row["ours"], ours)
            if key in DOCUMENTED:
                assert ours == DOCUMENTED[key], key
    # and every documented difference is in the docs: the table, or the coefficients' paragraph below it
    text = (ROOT / "docs" / "workspaces.md").read_text(encoding="utf-8").replace("−", "-")
    for key, value in DOCUMENTED.items():
        if key.startswith("92.T4."):
            assert f"{key.removeprefix('92.')} {value} vs {PAPER[key]}" in text, key
        elif key not in documented:
            assert value in text, key
    # report.md: one table line per row, with the printed and the computed number
    md = (out / "report.md").read_text()
    for key, row in rows.items():
        line = next(line for line in md.splitlines() if line.startswith(f"| `{key}` |"))
        cells = [c.strip() for c in line.strip("|").split("|")]
        assert cells[1] == ("–" if row["paper"] is None else f"{row['paper']:.6g}"), line
        assert cells[2] == ("–" if row["ours"] is None else f"{row['ours']:.6g}"), line
    # the figures: listed in the report, linked from report.md, and PNG images of the size they were drawn at
    assert report["figures"] == list(FIGURE_NAMES)
    for name in FIGURE_NAMES:
        check_paper_figure(out / name)
        assert f"({name})" in md
    assert [Path(line).name for line in result.stdout.splitlines()] == ["report.json", "report.md", *FIGURE_NAMES]


@pytest.mark.parametrize(
    ("text", "value", "ok"), [("0.370", 0.3689, False), ("0.370", 0.3704, True), ("1", 1.0089, True), ("0", 1e-8, False)]
)
def test_matches_reads_the_precision_from_the_digits(text: str, value: float, ok: bool) -> None:
    assert matches(value, text) is ok
