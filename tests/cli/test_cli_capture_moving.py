"""``freefloat capture`` with a moving target (issue 22 item 6): the scenario's [payload] velocity and angular_velocity
and its [grasp] table, the impact in the report, the ranking table, the trade-off figure and ``--rank-by``."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner, Result

import freefloat as ff
from freefloat.cli import app
from images import check_png

ROOT = Path(__file__).resolve().parents[2]
MOVING = ROOT / "examples" / "scenarios" / "papadopoulos1992_capture_moving.toml"
AT_REST = ROOT / "examples" / "scenarios" / "papadopoulos1992_capture.toml"
ONE = ff.models.papadopoulos1992(arms=1)


def invoke(*args: str) -> Result:
    return CliRunner().invoke(app, list(args))


def _impact_from_report(data: dict[str, Any]) -> Any:
    """ff.capture.impact on the robot and the target as capture.json describes them."""
    grasp = data["grasp"]
    state = ff.State(q=data["posture"]["q"], attitude=data["posture"]["attitude_xyzw"], r_cm=grasp["robot_cm_before"])
    target = ff.capture.Target(
        mass=data["payload_mass"],
        inertia=25.0,
        position=grasp["target_position"],
        attitude=grasp["target_attitude_xyzw"],
        velocity=grasp["target_velocity"],
        angular_velocity=grasp["target_angular_velocity"],
    )
    return ff.capture.impact(ONE, state, target, end_effector=0, joints=grasp["joints"])


def test_the_moving_target_example_reports_the_impact_and_the_ranking(tmp_path: Path) -> None:
    out = tmp_path / "out"
    result = invoke("capture", str(MOVING), "--out", str(out))
    assert result.exit_code == 0, result.output
    names = {"capture.json", "capture_plan.png", "capture_families.png", "capture_tradeoff.png", "freefloat-manifest.json"}
    assert {p.name for p in out.iterdir()} == names
    check_png(out / "capture_tradeoff.png", (7.0, 5.2), 200, tight=True)
    data = json.loads((out / "capture.json").read_text())
    grasp = data["grasp"]
    assert grasp["rank_by"] == "spacecraft_rate" and grasp["joints"] == "free"
    assert grasp["target_velocity"] == [0.02, 0.01, 0.0] and grasp["target_angular_velocity"] == [0.0, 0.0, 0.1]
    # the impact reported is ff.capture.impact on the robot (at rest at the approach point) and the payload (on A)
    np.testing.assert_allclose(grasp["robot_cm_before"][:2], data["approach_point"], atol=1e-12)
    np.testing.assert_allclose(grasp["target_position"][:2], data["path"][0], atol=1e-12)
    hit = _impact_from_report(data)
    impact = grasp["impact"]
    np.testing.assert_allclose(impact["impulse"], hit.impulse, rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(impact["joint_impulse"], hit.joint_impulse, rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(impact["spacecraft_rate_after"], hit.state.omega, rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(impact["joint_rates_after"], hit.state.qdot, rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(impact["cm_velocity_after"], hit.state.v_cm, rtol=0.0, atol=1e-12)
    assert impact["energy_lost"] == pytest.approx(hit.energy_lost, rel=0.0, abs=1e-12) and impact["energy_lost"] > 0.0
    # the ranking: one row per candidate, the chosen one the slowest spacecraft among those that pass every check
    ranking = grasp["ranking"]
    columns = {name: np.array(value) for name, value in ranking["columns"].items()}
    count = ranking["candidates"]
    assert count == 145 and all(len(value) == count for value in columns.values())  # the paper's posture + 2 x 72 on eq. 21
    valid = columns["valid"]
    chosen = ranking["chosen"]
    assert valid[chosen] and columns["spacecraft_rate"][chosen] == np.min(columns["spacecraft_rate"][valid])
    assert chosen != ranking["planner"] == 0
    np.testing.assert_array_equal(columns["q"][chosen], data["posture"]["q"])
    assert columns["spacecraft_rate"][chosen] == pytest.approx(np.linalg.norm(hit.state.omega), rel=0.0, abs=1e-15)
    # the text: the chosen posture, the grasp and the table's rows
    text = result.stdout
    q_deg = ", ".join(f"{v:.2f}" for v in data["posture"]["q_deg"])
    assert f"    ranked by spacecraft_rate: q = [{q_deg}] deg" in text and "<- chosen (the most dexterous has |det J*| = 0.0" in text
    assert f"energy lost {impact['energy_lost']:.6g} J" in text
    assert f"145 candidate captures, {int(valid.sum())} pass every check; rank by spacecraft_rate" in text
    cells = r" +(\S+)" * 4
    row = re.search(rf"^ +{chosen} +\[{re.escape(q_deg)}\]{cells} +pass +chosen \(rank by spacecraft_rate\)", text, re.M)
    assert row is not None, text
    printed = [float(v) for v in row.groups()]
    expected = [columns[name][chosen] for name in ("measure", "spacecraft_rate", "impulse", "angular_impulse")]
    np.testing.assert_allclose(printed, expected, rtol=1e-5)
    assert re.search(r"^ +0 +\[90\.52, 92\.29\] .* pass +most dexterous \(1992 §V\)$", text, re.M), text


def test_rank_by_option_and_the_default_ranking(tmp_path: Path) -> None:
    """``--rank-by`` replaces the scenario's; ``--rank-by measure`` gives the paper's plan of the target at rest."""
    by_impulse = invoke("capture", str(MOVING), "--rank-by", "impulse", "--out", str(tmp_path / "impulse"))
    assert by_impulse.exit_code == 0, by_impulse.output
    data = json.loads((tmp_path / "impulse" / "capture.json").read_text())
    ranking = data["grasp"]["ranking"]
    impulse, valid = np.array(ranking["columns"]["impulse"]), np.array(ranking["columns"]["valid"])
    assert data["grasp"]["rank_by"] == "impulse" and impulse[ranking["chosen"]] == np.min(impulse[valid])
    assert np.linalg.norm(data["grasp"]["impact"]["impulse"][:3]) == pytest.approx(np.min(impulse[valid]), rel=1e-12)
    paper = invoke("capture", str(MOVING), "--rank-by", "measure", "--out", str(tmp_path / "measure"))
    rest = invoke("capture", str(AT_REST), "--out", str(tmp_path / "rest"))
    assert paper.exit_code == 0 and rest.exit_code == 0, paper.output + rest.output
    moving, still = (json.loads((tmp_path / name / "capture.json").read_text()) for name in ("measure", "rest"))
    assert still["grasp"] is None and moving["grasp"]["ranking"]["chosen"] == 0
    for key in ("posture", "family_postures", "R_plus", "cm_plus", "approach_point", "motion", "piw", "checks"):
        assert moving[key] == still[key], key
    assert not (tmp_path / "rest" / "capture_tradeoff.png").exists()


def test_locked_joints_rank_by_joint_impulse(tmp_path: Path) -> None:
    scenario = tmp_path / "locked.toml"
    text = MOVING.read_text().replace('joints = "free"', 'joints = "locked"')
    scenario.write_text(text.replace('rank_by = "spacecraft_rate"', 'rank_by = "joint_impulse"'))
    result = invoke("capture", str(scenario), "--out", str(tmp_path / "out"))
    assert result.exit_code == 0, result.output
    data = json.loads((tmp_path / "out" / "capture.json").read_text())
    grasp = data["grasp"]
    assert grasp["joints"] == "locked" and grasp["rank_by"] == "joint_impulse"
    joint = np.array(grasp["ranking"]["columns"]["joint_impulse"])
    assert np.linalg.norm(grasp["impact"]["joint_impulse"]) == pytest.approx(np.min(joint), rel=1e-12)
    np.testing.assert_allclose(grasp["impact"]["joint_rates_after"], [0.0, 0.0], atol=0.0)  # locked: the joint rates do not jump
    np.testing.assert_allclose(grasp["impact"]["joint_impulse"], _impact_from_report(data).joint_impulse, rtol=0.0, atol=1e-12)
    assert "|τ̂| N m s" in result.stdout and "least joint impulse" in result.stdout
