"""End effectors chosen everywhere (issue "What a user still meets", item 6): ``workspace``, ``capture`` and
``simulate`` take the same ``--end-effector/-e`` list as ``inspect``, and scenario files an ``end_effectors`` key.

The robot: the 6-DOF user arm of tests/data with two sensor frames (a camera on the bus, a sonar on the
forearm) as extra leaf links, so that the leaf rule gives 3 end effectors and an 18 x 6 J*.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

import freefloat as ff
from freefloat.cli import app

ARM = Path(__file__).resolve().parents[1] / "data" / "user_arm_6dof.urdf"
SENSORS = """  <link name="camera"/>
  <joint name="camera_mount" type="fixed"><parent link="bus"/><child link="camera"/><origin xyz="0.5 0.5 0.5"/></joint>
  <link name="sonar"/>
  <joint name="sonar_mount" type="fixed"><parent link="forearm"/><child link="sonar"/><origin xyz="0.2 0 0.05"/></joint>
</robot>"""

runner = CliRunner()


@pytest.fixture
def robot(tmp_path: Path) -> Path:
    path = tmp_path / "arm_with_sensors.urdf"
    path.write_text(ARM.read_text().replace("</robot>", SENSORS))
    assert sorted(ff.load(path).end_effector_names) == ["camera", "sonar", "tool0"]  # the leaf rule takes every sensor frame
    return path


def test_workspace_takes_end_effectors(robot: Path) -> None:
    every = runner.invoke(app, ["workspace", str(robot), "--samples", "1024", "--json"])
    chosen = runner.invoke(app, ["workspace", str(robot), "--samples", "1024", "--json", "-e", "tool0"])
    assert every.exit_code == 0 and chosen.exit_code == 0, every.output + chosen.output
    assert len(json.loads(every.stdout)["end_effectors"]) == 3
    assert [e["name"] for e in json.loads(chosen.stdout)["end_effectors"]] == ["tool0"]


def test_built_in_models_keep_their_end_effectors(robot: Path) -> None:
    result = runner.invoke(app, ["workspace", "papadopoulos1992", "-e", "arm1_ee"])
    assert result.exit_code == 1 and "is a built-in model, whose end effectors are fixed" in result.output


SIMULATION = """model = "{model}"
duration = 0.05
{key}
[integrator]
method = "RK4"
fixed_step = 0.01
"""


@pytest.mark.parametrize(
    ("key", "option", "names"), [("", [], 3), ('end_effectors = ["tool0"]', [], 1), ("", ["-e", "tool0", "-e", "sonar"], 2)]
)
def test_simulate_scenarios_take_end_effectors(robot: Path, tmp_path: Path, key: str, option: list[str], names: int) -> None:
    scenario = tmp_path / "sim.toml"
    scenario.write_text(SIMULATION.format(model=robot.name, key=key))
    out = tmp_path / "out"
    result = runner.invoke(app, ["simulate", str(scenario), "--out", str(out), *option])
    assert result.exit_code == 0, result.output
    assert len(ff.Trajectory.load(out / "trajectory.npz", model=ff.load(robot)).t) == 6
    summary = json.loads((out / "trajectory.json").read_text())
    assert len(summary["end_effector_names"]) == names, summary.keys()


CAPTURE = """model = "{model}"
{key}
samples = 4096
[payload]
mass = 20.0
inertia = 1.0
[path]
points = [[0.0, 0.0, 0.0], [0.0, 0.1, 0.0]]
R_plus = 1.0
[singularity]
rows = "position"
threshold = 0.02
"""


def test_capture_scenarios_take_end_effectors(robot: Path, tmp_path: Path) -> None:
    scenario = tmp_path / "capture.toml"
    scenario.write_text(CAPTURE.format(model=robot.name, key='end_effectors = ["tool0"]'))
    result = runner.invoke(app, ["capture", str(scenario), "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    data = json.loads((tmp_path / "out" / "capture.json").read_text())
    assert data["end_effector"] == "tool0" and data["end_effectors"] == ["tool0"]  # J* of the tool alone, not of the sensors
    scenario.write_text(CAPTURE.format(model=robot.name, key=""))
    option = runner.invoke(app, ["capture", str(scenario), "-e", "tool0", "--out", str(tmp_path / "out2")])
    assert option.exit_code == 0, option.output
    assert json.loads((tmp_path / "out2" / "capture.json").read_text())["end_effectors"] == ["tool0"]
    every = runner.invoke(app, ["capture", str(scenario), "--out", str(tmp_path / "out3")])  # the leaf rule: 3 end effectors
    assert every.exit_code != 0 or len(json.loads((tmp_path / "out3" / "capture.json").read_text())["end_effectors"]) == 3


@pytest.mark.parametrize(
    ("key", "message"),
    [
        ("end_effectors = []", "end_effectors: is empty"),
        ('end_effectors = "tool0"', "expected a list of names"),
        ('end_effectors = ["nowhere"]', "nowhere"),
        ("strict = 1", "strict: expected true or false"),
    ],
)
def test_bad_end_effector_keys_are_clear_errors(robot: Path, tmp_path: Path, key: str, message: str) -> None:
    scenario = tmp_path / "sim.toml"
    scenario.write_text(SIMULATION.format(model=robot.name, key=key))
    result = runner.invoke(app, ["simulate", str(scenario), "--out", str(tmp_path / "out")])
    assert result.exit_code == 1 and result.output.startswith("error: ") and message in result.output, result.output
    assert "Traceback" not in result.output and not (tmp_path / "out").exists()
