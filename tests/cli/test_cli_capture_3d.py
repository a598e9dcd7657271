"""``freefloat capture`` and ``freefloat workspace`` on spatial arms (issue 11 item 3): the singularity criterion
chosen in the scenario or on the command line, and a plan on the user-style 6-DOF and the 7-DOF benchmark arm."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from typer.testing import CliRunner, Result

import freefloat as ff
from freefloat.analysis.singularity import SingularityCriterion
from freefloat.cli import app
from images import check_png

runner = CliRunner()
USER_ARM = Path(__file__).resolve().parents[1] / "data" / "user_arm_6dof.urdf"


def invoke(*args: str) -> Result:
    return runner.invoke(app, list(args))


def scenario(tmp_path: Path, model: str, singularity: str, *, mass: float = 50.0, r_plus: float | None = None) -> Path:
    text = f"""model = "{model}"
samples = 16384

[payload]
mass = {mass}
inertia = 2.0

[path]
points = [[0.0, 0.0, 0.0], [0.0, 0.2, 0.0]]
{"" if r_plus is None else f"R_plus = {r_plus}"}

{singularity}
"""
    path = tmp_path / "capture.toml"
    path.write_text(text)
    return path


POSITION_TABLE = """[singularity]
rows = "position"
measure = "sigma_min"
threshold = 0.02
"""


def test_capture_user_arm_full_jacobian_piw_only_is_one_line_error(tmp_path: Path) -> None:
    result = invoke("capture", str(scenario(tmp_path, str(USER_ARM), '[singularity]\nstrategy = "piw"')))
    assert result.exit_code == 1, result.output
    assert result.stderr.startswith("error: ") and "fits in no PIW annulus" in result.stderr
    assert len(result.stderr.splitlines()) == 1


def test_capture_user_arm_6dof_position_rows_returns_a_plan(tmp_path: Path) -> None:
    out = tmp_path / "out"
    result = invoke("capture", str(scenario(tmp_path, str(USER_ARM), POSITION_TABLE, r_plus=1.0)), "--out", str(out))
    assert result.exit_code == 0, result.output
    text = result.stdout
    assert "path checked" in text and "singularity-free" in text and "translational rows of J*, 3 x 6" in text
    data = json.loads((out / "capture.json").read_text())
    assert data["method"] == "path"
    assert data["singularity"]["rows"] == "position" and data["singularity"]["threshold"] == 0.02
    assert data["R_plus"] == 1.0
    assert data["motion"]["singularity_free"] and data["motion"]["min_measure"] > 0.02
    assert data["motion"]["within_joint_limits"]
    # the posture and attitude in the JSON put the end effector on A, and σ_min there is what the JSON says
    model = ff.load(USER_ARM).with_payload(0, mass=50.0, inertia=2.0)
    q = np.array(data["posture"]["q"])
    tip = np.array(data["cm_plus"]) + ff.end_effector_positions(model, q, attitude=data["posture"]["attitude_xyzw"])[0]
    np.testing.assert_allclose(tip, [0.0, 0.0, 0.0], atol=1e-9)
    check_png(out / "capture_plan.png", (7.4, 8.4), 200, tight=True, min_colours=64)  # the plan drawn in 3D (no Fig. 6 for 6 joints)
    assert not (out / "capture_families.png").exists()


def test_capture_options_override_the_scenario(tmp_path: Path) -> None:
    """The same full-J* scenario, with --rows position --threshold 0.02 on the command line, returns a plan."""
    path = scenario(tmp_path, "spacecraft_7dof", "", mass=100.0)
    result = invoke("capture", str(path), "--rows", "position", "--measure", "sigma_min", "--threshold", "0.02")
    assert result.exit_code == 0, result.output
    assert "translational rows of J*, 3 x 7" in result.stdout and "singularity-free" in result.stdout
    bad = invoke("capture", str(path), "--rows", "wrist")
    assert bad.exit_code == 1 and "rows" in bad.stderr and len(bad.stderr.splitlines()) == 1
    bad = invoke("capture", str(path), "--strategy", "hope")
    assert bad.exit_code == 1 and "--strategy" in bad.stderr


def test_capture_scenario_singularity_table_errors(tmp_path: Path) -> None:
    for table, needle in (
        ('[singularity]\nrows = "wrist"', "singularity.rows"),
        ("[singularity]\nthreshold = -1", "singularity.threshold"),
        ("[singularity]\ncolour = 1", "singularity.colour"),
    ):
        result = invoke("capture", str(scenario(tmp_path, "spacecraft_7dof", table)))
        assert result.exit_code == 1, result.output
        assert needle in result.stderr


def test_workspace_command_takes_the_criterion() -> None:
    result = invoke("workspace", "spacecraft_7dof", "--piw", "--samples", "4096", "--rows", "position", "--threshold", "0.02", "--json")
    assert result.exit_code == 0, result.output
    entry = json.loads(result.stdout)["end_effectors"][0]
    assert "translational rows" in entry["piw"]["criterion"] and "0.02" in entry["piw"]["criterion"]
    assert entry["piw"]["intervals"]
    crit = SingularityCriterion("position", "auto", 0.02)
    assert crit.resolved_measure(ff.models.spacecraft_7dof()) == "sigma_min"
