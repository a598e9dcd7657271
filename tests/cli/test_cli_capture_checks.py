"""A capture plan is a success only when every check it reports holds (issue "What a user still meets", item 3).

The 1992 §V scenario with arm1_q1 limited to 150 deg: the paper's capture posture in the PIW turns q1
from 90.5 deg to 177.7 deg along AB, across that limit. ``strategy = "piw"`` refuses with exit 1 and the
reason; ``"auto"`` searches on and returns a path-checked plan that keeps the limit, and says why.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from freefloat.cli import app

SCENARIO = Path(__file__).resolve().parents[2] / "examples" / "scenarios" / "papadopoulos1992_capture.toml"


def limited(tmp_path: Path, strategy: str) -> Path:
    text = SCENARIO.read_text().replace(
        "# [joint_limits_deg]", '[joint_limits_deg]\narm1_q1 = [-180.0, 150.0]\n[singularity]\nstrategy = "' + strategy + '"\n#'
    )
    path = tmp_path / f"capture_{strategy}.toml"
    path.write_text(text)
    return path


def test_the_paper_plan_across_a_joint_limit_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["capture", str(limited(tmp_path, "piw")), "--out", str(out)])
    assert result.exit_code == 1 and result.output.startswith("error: the path fits in the PIW, but the paper's capture posture fails")
    assert "a joint crosses its limit" in result.output and len(result.output.splitlines()) == 1
    assert not out.exists()  # nothing written, no empty folder left


def test_auto_searches_on_and_reports_every_check(tmp_path: Path) -> None:
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["capture", str(limited(tmp_path, "auto")), "--out", str(out)])
    assert result.exit_code == 0, result.output
    data = json.loads((out / "capture.json").read_text())
    assert data["method"] == "path" and data["why_path"].startswith("the paper's capture posture in the PIW fails along the path")
    assert data["checks"] == {"path_in_workspace": None, "motion_follows_path": True, "singularity_free": True, "within_joint_limits": True}
    assert np.degrees(max(data["posture"]["q"][0], data["motion"]["q_end"][0])) <= 150.0 + 1e-9
    assert "path checked (the paper's capture posture in the PIW fails" in result.output


@pytest.mark.parametrize("strategy", ["auto", "piw"])
def test_without_the_limit_the_paper_plan_passes_every_check(tmp_path: Path, strategy: str) -> None:
    out = tmp_path / "out"
    path = tmp_path / "paper.toml"
    path.write_text(SCENARIO.read_text() + f'\n[singularity]\nstrategy = "{strategy}"\n')
    result = CliRunner().invoke(app, ["capture", str(path), "--out", str(out)])
    assert result.exit_code == 0, result.output
    data = json.loads((out / "capture.json").read_text())
    assert data["method"] == "piw" and data["why_path"] == "" and all(v is True for v in data["checks"].values())
