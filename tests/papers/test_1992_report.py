"""``freefloat reproduce 1992``: report.json holds every 1992 row id of DESIGN.md with a computed value, and the figures."""

from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

from freefloat.cli import app
from freefloat.papers.paper1992 import PRINTED
from freefloat.papers.paper1992_figures import FIGURE_NAMES

COEFFICIENTS = ("alpha", "beta", "gamma", "delta", "epsilon")
LIMITS = ("R_max", "R_min", "GW_max", "GW_min")
#: The required 1992 row ids of DESIGN.md ("Paper-vs-freefloat report"), spelled out.
REQUIRED = (
    [f"92.{t}.arm{a}.{k}" for t in ("T2", "T4") for a in (1, 2) for k in COEFFICIENTS]
    + [f"92.{t}.arm{a}.{k}" for t in ("T3", "T5") for a in (1, 2) for k in LIMITS]
    + [f"92.S5.{k}" for k in ("alpha", "beta", "gamma")]
    + [f"92.T6.{k}" for k in ("R_max", "R_min", "PIW_max", "PIW_min", "GW_max", "GW_min")]
    + [f"92.S5.{k}" for k in ("approach_distance", "q1_deg", "q2_deg", "theta_deg")]
)
#: Where the workspace does not exist (Table V prints n/a; eq. 16 gives R'_max < R'_min): ours is null.
NOT_EXISTING = {"92.T5.arm2.GW_max", "92.T5.arm2.GW_min"}


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
    for key in REQUIRED:
        row = rows[key]
        assert set(row) == {"id", "paper", "ours", "agrees", "note"}
        printed = PRINTED[key]
        assert row["paper"] == (None if printed is None else float(printed)), key
        if key in NOT_EXISTING:
            assert row["ours"] is None and row["paper"] is None and row["note"].startswith("n/a")
        else:
            assert isinstance(row["ours"], float), key
        if row["agrees"] is False:  # every disagreement says why
            assert len(row["note"]) > 20, key
    # agreement is at the printed precision: a few spot checks against the printed strings
    assert rows["92.T2.arm1.beta"]["agrees"] is True and abs(rows["92.T2.arm1.beta"]["ours"] - 0.907) <= 5e-4
    assert rows["92.T4.arm2.gamma"]["agrees"] is False  # misprint, see its note
    assert "misprint" in rows["92.T4.arm2.gamma"]["note"]
    # the figures exist, are listed in the report and linked from report.md
    assert report["figures"] == list(FIGURE_NAMES)
    md = (out / "report.md").read_text()
    for name in FIGURE_NAMES:
        assert (out / name).stat().st_size > 20_000
        assert f"({name})" in md
    assert [Path(line).name for line in result.stdout.splitlines()] == ["report.json", "report.md", *FIGURE_NAMES]
