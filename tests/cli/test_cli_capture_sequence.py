"""``freefloat capture`` with a [detumble] table (issue 22 item 7): the capture sequence of a tumbling target (the
grasp at the planned posture, then ff.control.Detumble), its report (text, capture.json, capture.md), its run, its
figures and its animation; the example examples/scenarios/tumbling_satellite_capture.toml."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner, Result

import freefloat as ff
from freefloat.cli import app
from freefloat.scenarios.capture_scenario import capture_scenario_from_dict
from freefloat.scenarios.capture_sequence import DetumbleSettings
from images import check_png

ROOT = Path(__file__).resolve().parents[2]
TUMBLING = ROOT / "examples" / "scenarios" / "tumbling_satellite_capture.toml"
SCENARIO = tomllib.loads(TUMBLING.read_text())
ONE = ff.models.papadopoulos1992(arms=1)
FIGURES = ("capture_momentum.png", "capture_rates.png", "capture_actuation.png", "capture_wheels.png")


def invoke(*args: str) -> Result:
    return CliRunner().invoke(app, list(args))


@pytest.fixture(scope="module")
def written(tmp_path_factory: pytest.TempPathFactory) -> tuple[Result, Path]:
    out = tmp_path_factory.mktemp("tumbling") / "out"
    return invoke("capture", str(TUMBLING), "--out", str(out)), out


def _report(out: Path) -> dict[str, Any]:
    data: dict[str, Any] = json.loads((out / "capture.json").read_text())
    return data


def test_the_example_writes_the_report_the_run_the_figures_and_the_animation(written: tuple[Result, Path]) -> None:
    result, out = written
    assert result.exit_code == 0, result.output
    names = {
        "capture.json", "capture_plan.png", "capture_tradeoff.png", "capture.md",
        "capture_detumble.npz", *FIGURES, "capture_detumble.gif", "freefloat-manifest.json",
    }  # fmt: skip
    assert {p.name for p in out.iterdir()} == names
    for name in FIGURES:
        check_png(out / name, (7.0, 7.0), 120)
    with Image.open(out / "capture_detumble.gif") as gif:
        assert gif.n_frames == SCENARIO["detumble"]["frames"]
    markdown = (out / "capture.md").read_text()
    for name in ("capture_plan.png", "capture_tradeoff.png", *FIGURES, "capture_detumble.gif"):
        assert f"]({name})" in markdown and (out / name).is_file()
    assert result.stdout.rstrip("\n") in markdown  # the whole report, plan and sequence
    assert "reaction wheels  rw_x, rw_y, rw_z: peak speed" in markdown and "limits acted on: rw_z" in result.stdout
    sequence = _report(out)["sequence"]
    assert sequence["combined_mass"] == pytest.approx(ONE.total_mass + SCENARIO["payload"]["mass"], rel=1e-15)


def test_momentum_of_robot_and_target_is_the_same_before_and_after_the_grasp(written: tuple[Result, Path]) -> None:
    _, out = written
    data = _report(out)
    impact, grasp = data["sequence"]["impact"], data["grasp"]
    before, after = np.array(impact["momentum_before"]), np.array(impact["momentum_after"])
    np.testing.assert_allclose(after, before, rtol=1e-12, atol=1e-12 * np.abs(before).max())
    np.testing.assert_allclose(impact["momentum_change"], after - before, rtol=0.0, atol=0.0)
    # before: the robot at rest and the target as the scenario gives it (m v; I w + p x m v about the origin)
    payload = SCENARIO["payload"]
    linear = payload["mass"] * np.array(payload["velocity"])
    angular = payload["inertia"] * np.array(payload["angular_velocity"]) + np.cross(grasp["target_position"], linear)
    np.testing.assert_allclose(before, np.concatenate([linear, angular]), rtol=1e-12, atol=1e-12)
    # after, from the recorded run: its first sample is the post-impact state of the combined system
    run = np.load(out / "capture_detumble.npz")
    np.testing.assert_allclose(data["sequence"]["combined_mass"] * run["v_cm"][0], linear, rtol=1e-12, atol=1e-15)
    assert impact["energy_lost"] > 0.0 and impact["joint_impulse"] == [0.0, 0.0]  # free joints


def test_the_run_reaches_rest_below_the_stated_thresholds(written: tuple[Result, Path]) -> None:
    _, out = written
    detumble, rest = _report(out)["sequence"]["detumble"], SCENARIO["detumble"]
    run = np.load(out / "capture_detumble.npz")
    t = run["t"]
    still = (
        (np.linalg.norm(run["omega"], axis=1) <= rest["rest_rate"])
        & (np.abs(run["qdot"]).max(axis=1) <= rest["rest_joint_rate"])
        & (np.linalg.norm(run["v_cm"], axis=1) <= rest["rest_velocity"])
    )
    assert still[-1] and not still[0]
    first = int(np.flatnonzero(~still)[-1]) + 1
    assert detumble["at_rest"] is True and detumble["time_to_rest"] == t[first]
    assert t[-1] == pytest.approx(rest["duration"], abs=1e-12)
    final = detumble["final_rates"]
    assert final["omega"] == np.linalg.norm(run["omega"][-1]) and final["omega"] <= rest["rest_rate"]
    assert final["v_cm"] == np.linalg.norm(run["v_cm"][-1]) and final["v_cm"] <= rest["rest_velocity"]
    assert final["qdot_max"] == np.abs(run["qdot"][-1]).max() and final["qdot_max"] <= rest["rest_joint_rate"]


def test_the_delta_v_is_the_thruster_impulse_over_the_combined_mass(written: tuple[Result, Path]) -> None:
    _, out = written
    detumble = _report(out)["sequence"]["detumble"]
    run = np.load(out / "capture_detumble.npz")
    t, force = run["t"], np.linalg.norm(run["spacecraft_force"], axis=1)
    mass = ONE.total_mass + SCENARIO["payload"]["mass"]
    impulse = float(force[:-1] @ np.diff(t))  # the actuation is held between the samples (sample_period = outputs)
    assert detumble["thruster_impulse"] == pytest.approx(impulse, rel=1e-12)
    assert detumble["delta_v"] == pytest.approx(impulse / mass, rel=1e-12)
    # physics: the thrust is along -v_cm throughout, so the delta-v is the CM's change of speed
    assert detumble["delta_v"] == pytest.approx(np.linalg.norm(run["v_cm"][0] - run["v_cm"][-1]), rel=1e-6)
    isp = SCENARIO["detumble"]["specific_impulse"]
    assert detumble["propellant_mass"] == pytest.approx(mass * -np.expm1(-impulse / mass / (isp * ff.control.STANDARD_GRAVITY)), rel=1e-12)
    assert detumble["peak_force"] == force.max() and detumble["peak_joint_torque"] == np.abs(run["joint_torque"]).max(axis=0).tolist()


def test_no_animation_skips_the_gif(tmp_path: Path) -> None:
    out = tmp_path / "out"
    result = invoke("capture", str(TUMBLING), "--out", str(out), "--no-animation")
    assert result.exit_code == 0, result.output
    assert (out / "capture_momentum.png").is_file() and not (out / "capture_detumble.gif").exists()
    assert "capture_detumble.gif" not in (out / "capture.md").read_text()
    assert "capture sequence   grasp at t = 0" in result.stdout


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("gain = 0.5", "detumble.gain: unknown key"),
        ("rate_gain = -0.5", "detumble.rate_gain: must be positive, got -0.5"),
        ("sample_period = 45.0", "detumble.sample_period: 45 s exceeds the duration"),
    ],
)
def test_a_bad_detumble_table_is_refused_naming_the_field(tmp_path: Path, line: str, message: str) -> None:
    key = line.split(" = ")[0]
    text = "".join(row for row in TUMBLING.read_text().splitlines(keepends=True) if not row.startswith(f"{key} "))
    scenario = tmp_path / "bad.toml"
    scenario.write_text(text.replace("[detumble]\n", f"[detumble]\n{line}\n"))
    result = invoke("capture", str(scenario))
    assert result.exit_code == 1 and message in result.output, result.output


def test_the_detumble_table_is_read_with_its_units_and_defaults() -> None:
    data = tomllib.loads(TUMBLING.read_text())
    data["detumble"] = {"rate_gain": 2, "attitude": [0.0, 0.0, 0.6, 0.8], "force": False}
    settings = capture_scenario_from_dict(data).detumble
    defaults = DetumbleSettings()
    assert settings is not None and settings.rate_gain == 2.0 and settings.force is False
    assert settings.attitude == (0.0, 0.0, 0.6, 0.8) and settings.duration == defaults.duration
    del data["detumble"]
    assert capture_scenario_from_dict(data).detumble is None


def test_the_wheels_take_the_spin_within_their_limits_and_say_where_a_limit_acted(written: tuple[Result, Path]) -> None:
    """The example detumbles with three reaction wheels (torque_by = "wheels"): their report equals the recorded run,
    the limits hold, the z wheel's torque limit acts (recorded), no thruster torque is used, and at rest the wheels
    hold the system's spin."""
    _, out = written
    wheels = _report(out)["sequence"]["detumble"]["wheels"]
    run = np.load(out / "capture_detumble.npz")
    tables = SCENARIO["wheels"]
    assert wheels["names"] == [w["name"] for w in tables]
    assert wheels["peak_speed"] == np.abs(run["wheel_speed"]).max(axis=0).tolist()
    assert wheels["peak_torque"] == np.abs(run["wheel_torque"]).max(axis=0).tolist()
    assert wheels["final_speed"] == run["wheel_speed"][-1].tolist()
    limits = np.array([w["max_torque"] for w in tables]), np.array([w["max_speed"] for w in tables])
    assert (np.abs(run["wheel_torque"]) <= limits[0]).all() and (np.abs(run["wheel_speed"]) <= limits[1]).all()
    assert wheels["saturated"] == [False, False, True] and run["wheel_torque_saturated"][:, 2].any()
    assert np.abs(run["spacecraft_torque"]).max() == 0.0
    # the wheels hold the spin the target brought (about the z axis: 187.5 kg m² x 3 deg/s = 9.8 N m s, and the CM motion's)
    assert np.linalg.norm(run["omega"][-1]) < SCENARIO["detumble"]["rest_rate"]
    assert abs(tables[2]["inertia"] * run["wheel_speed"][-1, 2]) > 5.0
