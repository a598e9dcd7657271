"""The ``workspace`` and ``capture`` commands: tables, JSON, files written, and one-line errors on bad input."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner, Result

import freefloat as ff
from freefloat.analysis.workspace_report import workspace_limits
from freefloat.cli import app

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "scenarios" / "papadopoulos1992_capture.toml"
runner = CliRunner()


def invoke(*args: str) -> Result:
    return runner.invoke(app, list(args))


def assert_one_line_error(result: Result, *needles: str) -> str:
    assert result.exit_code == 1, result.output
    assert result.stdout == ""
    lines = result.stderr.splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("error: ") and "Traceback" not in result.output
    for needle in needles:
        assert needle in lines[0], lines[0]
    return lines[0]


SCENARIO = """\
model = "papadopoulos1992-one-arm"
end_effector = 0
samples = 4096

[payload]
mass = 400.0
inertia = 25.0

[path]
points = [[0.0, 0.0], [0.0, 0.25]]
"""


def scenario(tmp_path: Path, text: str = SCENARIO, name: str = "scenario.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


# --------------------------------------------------------------------- workspace
def test_workspace_table_and_files(tmp_path: Path) -> None:
    out = tmp_path / "ws"
    result = invoke("workspace", "papadopoulos1992-one-arm", "--payload-mass", "400", "--payload-inertia", "25", "--out", str(out))
    assert result.exit_code == 0, result.output
    text = result.stdout
    # Table VI after capture: R_max 1.2356, GW [0.2701, 0.7759], PIW [0.3689, 0.7759] (1992 §V)
    assert "R_max  1.235632" in text and "R'_min 0.270115" in text and "R'_max 0.775862" in text
    assert "[0.368861, 0.775862] (widest)" in text
    assert "closed_form, accuracy" in text and "PIW method" in text
    written = {p.name for p in out.iterdir()}
    assert written == {"workspace.json", "workspace_papadopoulos1992_one_arm_payload_arm1_ee.png", "freefloat-manifest.json"}
    data = json.loads((out / "workspace.json").read_text())
    assert data["payload_mass"] == 400.0
    assert data["end_effectors"][0]["piw"]["R_min"] == pytest.approx(0.368861, abs=1e-6)
    assert (out / "workspace_papadopoulos1992_one_arm_payload_arm1_ee.png").stat().st_size > 10_000


def test_workspace_json_one_arm_no_piw() -> None:
    result = invoke("workspace", "papadopoulos1992", "--arm", "arm2_ee", "--no-piw", "--json")
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert [e["name"] for e in data["end_effectors"]] == ["arm2_ee"]
    entry = data["end_effectors"][0]
    assert entry["reachable"]["R_max"] == pytest.approx(2.5) and entry["reachable"]["method"] == "closed_form"
    assert entry["guaranteed"]["R_min"] == pytest.approx(0.685185, abs=1e-6)
    assert entry["piw"] is None and data["piw_note"] == "not requested"
    by_index = json.loads(invoke("workspace", "papadopoulos1992", "--arm", "1", "--no-piw", "--json").stdout)
    assert by_index["end_effectors"] == data["end_effectors"]


def test_workspace_skips_piw_when_jacobian_is_not_square() -> None:
    model = ff.models.spacecraft_7dof()  # J* is 6 x 7: no determinant
    limits = workspace_limits(model)
    assert limits.piw == (None,) and "not square" in limits.piw_note
    reach = limits.reachable[0]
    assert reach.method == "sampling" and reach.R_min < reach.R_max
    assert "not computed" in limits.render_text()


@pytest.mark.parametrize(
    ("args", "needles"),
    [
        (("--arm", "5"), ("unknown end effector 5", "0=arm1_ee")),
        (("--arm", "arm3_ee"), ("unknown end effector 'arm3_ee'",)),
        (("--payload-mass", "-5", "--payload-inertia", "1"), ("mass", "must be positive")),
        (("--payload-mass", "5", "--payload-inertia", "1,2,9"), ("inertia",)),
    ],
)
def test_workspace_bad_input(args: tuple[str, ...], needles: tuple[str, ...]) -> None:
    assert_one_line_error(invoke("workspace", "papadopoulos1992", "--no-piw", *args), *needles)


# --------------------------------------------------------------------- capture
def test_capture_example_scenario(tmp_path: Path) -> None:
    before = hashlib.sha256(EXAMPLE.read_bytes()).hexdigest()
    out = tmp_path / "capture"
    result = invoke("capture", str(EXAMPLE), "--out", str(out))
    assert result.exit_code == 0, result.output
    text = result.stdout
    assert "R+                 0.545062 m" in text
    assert "approach distance  R = 1.008945 m" in text
    assert "family 1 (+acos)  q = [90.52, 92.29] deg" in text and "family 2 (-acos)  q = [-90.52, -92.29] deg" in text
    assert "θ = -123.00 deg" in text and "<- chosen" in text
    assert hashlib.sha256(EXAMPLE.read_bytes()).hexdigest() == before  # the input is never written
    assert {p.name for p in out.iterdir()} == {"capture.json", "capture_plan.png", "capture_families.png", "freefloat-manifest.json"}
    data = json.loads((out / "capture.json").read_text())
    assert data["approach_distance"] == pytest.approx(870.0 / 470.0 * data["R_plus"])
    q = np.array(data["posture"]["q"])
    r_e = np.linalg.norm(ff.end_effector_positions(ff.models.papadopoulos1992(arms=1).with_payload(0, 400.0, 25.0), q)[0])
    assert r_e == pytest.approx(data["R_plus"], abs=1e-9)
    assert [f["family"] for f in data["family_postures"]] == [0, 1]


def test_capture_joint_limits_in_degrees(tmp_path: Path) -> None:
    """Limits in degrees are read and kept: with q1 in [-180, 150] deg a plan keeps them along the whole path; with q1 in
    [-60, 60] deg the payload cannot be moved along AB free-floating (q1 must turn about 87 deg), which is an error (it
    was a plan whose motion crossed the limit, reported as a success)."""
    text = SCENARIO + "\n[joint_limits_deg]\narm1_q1 = [-180.0, 150.0]\n"
    result = invoke("capture", str(scenario(tmp_path, text)), "--out", str(tmp_path / "out"))
    assert result.exit_code == 0, result.output
    data = json.loads((tmp_path / "out" / "capture.json").read_text())
    q1 = np.degrees([data["posture"]["q"][0], data["motion"]["q_end"][0]])
    assert np.all((-180.0 - 1e-6 <= q1) & (q1 <= 150.0 + 1e-6)) and "joint limits       kept along the path" in result.stdout
    narrow = invoke("capture", str(scenario(tmp_path, SCENARIO + "\n[joint_limits_deg]\narm1_q1 = [-60.0, 60.0]\n")))
    assert narrow.exit_code == 1 and "a joint crosses its limit" in narrow.output and "within the joint limits" in narrow.output


@pytest.mark.parametrize(
    ("text", "needles"),
    [
        (SCENARIO.replace("mass = 400.0", "mass = -400.0"), ("payload.mass", "must be positive")),
        (SCENARIO.replace("inertia = 25.0", "inertia = [1.0, 1.0, 5.0]"), ("payload.inertia",)),
        (SCENARIO.replace("points = [[0.0, 0.0], [0.0, 0.25]]", "points = []"), ("path.points", "is empty")),
        (SCENARIO.replace("[0.0, 0.25]]", "[0.0, 3.0]]"), ("fits in no", "the thrusters are needed")),
        (SCENARIO.replace("end_effector = 0", "end_effector = 3"), ("end_effector", "unknown end effector 3")),
        (SCENARIO.replace("[payload]", "[payload"), ("malformed TOML",)),
        (SCENARIO.replace("mass = 400.0", "mass = 400.0\ncolour = 'red'"), ("payload.colour", "unknown key")),
        (SCENARIO.replace('model = "papadopoulos1992-one-arm"', 'model = "papadopoulos1993"'), ("neither a model file nor a built-in",)),
    ],
    ids=["negative-mass", "inertia-triangle", "empty-path", "fits-nowhere", "arm-out-of-range", "malformed", "unknown-key", "model"],
)
def test_capture_bad_input(tmp_path: Path, text: str, needles: tuple[str, ...]) -> None:
    assert_one_line_error(invoke("capture", str(scenario(tmp_path, text))), *needles)


def test_capture_missing_scenario_file(tmp_path: Path) -> None:
    assert_one_line_error(invoke("capture", str(tmp_path / "nope.toml")), "no such scenario file")
