"""1991 §V: the report rows of DESIGN.md, computed by ``reproduce_1991`` (one run for the module)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from freefloat.papers.paper1991 import section5_setup
from freefloat.papers.paper1991_figures import FIGURE_NAMES
from freefloat.papers.reproduce import reproduce_1991
from images import check_paper_figure

REQUIRED = [
    "91.S5.initial_ee.x",
    "91.S5.initial_ee.y",
    *[
        f"91.S5.{c}.{k}"
        for c in ("tj", "ct")
        for k in (
            "t1pct.spacecraft_position",
            "t1pct.spacecraft_attitude",
            "t1pct.end_effector",
            "ee_path_deviation_max",
            "peak_thrust_force_5s",
            "peak_thrust_torque_5s",
            "final_error_max",
        )
    ],
    "91.S5.fixed.final_sin_q2",
    "91.S5.fixed.reaches_B",
    "91.S5.free_floating.reaches_B_straight",
    "91.S5.free_floating.min_abs_det_J_star",
]


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("r1991")
    written = reproduce_1991(out)
    assert [p.name for p in written] == ["report.json", "report.md", *FIGURE_NAMES]
    data = json.loads((out / "report.json").read_text())
    assert data["paper"] == "1991" and data["figures"] == list(FIGURE_NAMES)
    table = (out / "report.md").read_text()
    for row in data["rows"]:  # report.md: one table line per row, with its printed and computed numbers
        line = next(line for line in table.splitlines() if line.startswith(f"| `{row['id']}` |"))
        cells = [c.strip() for c in line.strip("|").split("|")]
        assert cells[1:3] == ["–" if v is None else f"{v:.6g}" for v in (row["paper"], row["ours"])], line
    for name in FIGURE_NAMES:
        check_paper_figure(out / name)
        assert f"({name})" in table
    return {r["id"]: r for r in data["rows"]}


def test_required_rows_present_and_computed(report):
    for row_id in REQUIRED:
        assert row_id in report, row_id
        ours = report[row_id]["ours"]
        assert ours is not None and math.isfinite(ours), row_id


def test_initial_end_effector_is_the_papers(report):
    # printed (2.0, 0.0); ours from the printed angles and Table I
    assert report["91.S5.initial_ee.x"]["agrees"] is True
    assert report["91.S5.initial_ee.y"]["agrees"] is True
    assert report["91.S5.initial_ee.x"]["ours"] == pytest.approx(2.0, abs=0.05)


@pytest.mark.parametrize("controller", ["tj", "ct"])
def test_reaches_B_and_the_spacecraft_target(report, controller):
    # every component of e = z1,des - z1 = [x_s, y_s, θ, x_E, y_E] errors at 30 s: EE at (1.5, 1.5), spacecraft at (0.5, 0.5, 15°)
    assert report[f"91.S5.{controller}.final_error_max"]["ours"] < 1e-5
    assert 0.0 < report[f"91.S5.{controller}.t1pct.end_effector"]["ours"] < 30.0


def test_operational_space_follows_eq28_and_a_straight_line(report):
    assert report["91.S5.ct.error_dynamics_residual"]["ours"] < 1e-6
    # all five error components share one scalar solution of eq. 28 from rest: the EE moves on the line A-B
    assert report["91.S5.ct.ee_path_deviation_max"]["ours"] < 1e-6
    assert report["91.S5.tj.ee_path_deviation_max"]["ours"] > report["91.S5.ct.ee_path_deviation_max"]["ours"]


def test_alternatives(report):
    _, task, state, target = section5_setup()
    assert report["91.S5.fixed.reaches_B"]["ours"] == 1.0
    # the fixed-spacecraft end configuration is the elbow solution of the 2-link arm from its shoulder
    shoulder = task.coordinates(state)[0:2] + 0.5 * np.array([np.cos(np.radians(21)), np.sin(np.radians(21))])
    d = np.linalg.norm(target[3:5] - shoulder)
    assert report["91.S5.fixed.final_sin_q2"]["ours"] == pytest.approx(np.sqrt(1 - ((d * d - 2) / 2) ** 2), abs=1e-5)
    assert report["91.S5.free_floating.reaches_B_straight"]["ours"] == 0.0
    assert report["91.S5.free_floating.min_abs_det_J_star"]["ours"] < 1e-3 * report["91.S5.free_floating.det_J_star_at_A"]["ours"]
