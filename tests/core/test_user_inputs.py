"""The smaller points of issue 11 item 6: each bad input a new user met gets a clear error.

Physical bounds (``freefloat.core.model``): a body's mass in (0, 1e9] kg, positions within 1e4 m,
principal inertias up to 1e15 kg m^2. Model names wherever a model is taken; NaN/inf joint angles;
a workspace of a model without end effectors; no internal parameter name in a default's error;
``inspect`` shows each joint's rotation; singular grammar; a trajectory CSV that pandas reads.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import freefloat as ff
from freefloat.cli import app
from freefloat.core.model import MAX_INERTIA, MAX_LENGTH, MAX_MASS

ARM = Path(__file__).parents[2] / "examples" / "models" / "six_dof_arm.urdf"


def one_link(*, mass: float = 5.0, origin=(0.5, 0.0, 0.0), com=(0.5, 0.0, 0.0), inertia=(0.01, 0.4, 0.4)) -> ff.Model:
    b = ff.ModelBuilder("t")
    b.add_body("bus", mass=100.0, inertia=10.0)
    b.add_body("link", mass=mass, inertia=inertia, com=com)
    b.add_joint("q1", parent="bus", child="link", origin=origin, axis=[0, 0, 1])
    return b.build()


@pytest.mark.parametrize(
    ("kwargs", "needle"),
    [
        ({"mass": 1e300}, r"bodies\[1\] \(link\)\.mass: 1e\+300 kg is above the 1e\+09 kg"),
        ({"origin": (1e200, 0.0, 0.0)}, r"joints\[0\] \(q1\)\.origin: 1e\+200 m is beyond the 10000 m"),
        ({"com": (0.0, 2e4, 0.0)}, r"bodies\[1\] \(link\)\.com: 20000 m is beyond"),
        ({"inertia": (1e16, 1e16, 1e16)}, r"bodies\[1\] \(link\)\.inertia: 1e\+16 kg m\^2 is above"),
    ],
)
def test_absurd_magnitudes_are_refused_with_the_bound(kwargs: dict, needle: str) -> None:
    with pytest.raises(ff.ModelError, match=needle):
        one_link(**kwargs)


def test_the_bounds_admit_real_spacecraft() -> None:
    assert MAX_MASS == 1e9 and MAX_LENGTH == 1e4 and MAX_INERTIA == 1e15
    big = one_link(mass=4.2e5, origin=(50.0, 0.0, 0.0), inertia=(1e7, 1e7, 1e7))  # a station-sized module on a 50 m boom
    assert big.total_mass == pytest.approx(4.2e5 + 100.0)
    with pytest.raises(ff.ModelError, match=r"with_payload.*mass: 1e\+300 kg"):
        ff.models.papadopoulos1992(arms=1).with_payload(end_effector=0, mass=1e300, inertia=1.0)


def test_model_names_are_accepted_wherever_a_model_is() -> None:
    q = np.radians([30.0, 45.0, -20.0, 60.0])
    model = ff.models.papadopoulos1992(arms=2)
    assert np.array_equal(ff.generalized_jacobian("papadopoulos1992", q), ff.generalized_jacobian(model, q))
    assert np.array_equal(ff.mechanics.system_inertia_matrix("papadopoulos1992", q), ff.system_inertia_matrix(model, q))
    assert ff.end_effector_positions(str(ARM), np.zeros(6)).shape == (1, 3)  # a model file path, too
    assert ff.barycentric_vectors(model=ff.models.papadopoulos1992(arms=1)).c_star.shape[0] == 3
    assert ff.simulate("papadopoulos1992-one-arm", ff.State(), 0.05).status == "finished"
    assert ff.load("papadopoulos1992").joint_names == model.joint_names
    with pytest.raises(TypeError, match=r"model: expected a freefloat\.Model, a built-in model name .* got int"):
        ff.generalized_jacobian(42, q)
    with pytest.raises(ff.ModelError, match="did you mean 'papadopoulos1992'"):
        ff.generalized_jacobian("papadopulos1992", q)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_joint_angles_raise(bad: float) -> None:
    q = np.zeros((3, 4))
    q[2, 1] = bad
    model = ff.models.papadopoulos1992(arms=2)
    for func in (ff.end_effector_positions, ff.generalized_jacobian, ff.system_inertia_matrix, ff.jacobian_determinant):
        with pytest.raises(ValueError, match=r"q: has NaN or infinite entries \(first at index \(2, 1\), joint 'arm1_q2'\)"):
            func(model, q)


def test_a_model_without_end_effectors_has_no_workspace(tmp_path: Path) -> None:
    b = ff.ModelBuilder("bare_bus")
    b.add_body("bus", mass=100.0, inertia=10.0)
    bare = b.build()
    assert str(bare).endswith("1 body, 0 joints, 0 end effectors, mass 100 kg)")
    with pytest.raises(ValueError, match=r"model 'bare_bus' has no end effectors.*a workspace needs one"):
        ff.workspace.workspace_limits(bare)
    path = ff.save(bare, tmp_path / "bare.toml")
    result = CliRunner().invoke(app, ["workspace", str(path)])  # a file without joints is refused when it is read
    assert (
        result.exit_code == 1 and "bare.toml: has no movable joint (1 bodies after merging fixed joints, 0 end effectors)" in result.output
    )
    capture = tmp_path / "capture.toml"
    capture.write_text(
        f'model = "{path.as_posix()}"\n[payload]\nmass = 400.0\ninertia = 25.0\n[path]\npoints = [[0.0, 0.0], [0.0, 0.25]]\n'
    )
    result = CliRunner().invoke(app, ["capture", str(capture)])
    assert result.exit_code == 1 and "bare.toml: has no movable joint" in result.output


def test_a_zero_reach_error_names_the_end_effector_not_an_internal_parameter() -> None:
    model = ff.models.papadopoulos1992(arms=1)
    reach = dataclasses.replace(ff.workspace.reachable_workspace(model, 0), R_max=0.0)
    with pytest.raises(ValueError, match="end effector 'arm1_ee': its reachable workspace has zero size") as info:
        ff.workspace.path_independent_workspace(model, 0, reachable=reach, samples=64)
    assert "merge_gap" not in str(info.value)


def test_inspect_shows_each_joint_rotation_and_axis() -> None:
    result = CliRunner().invoke(app, ["inspect", str(ARM), "--json"])
    assert result.exit_code == 0
    joint = json.loads(result.output)["joints"][0]
    assert joint["name"] == "shoulder_yaw" and joint["rpy_deg"] == pytest.approx([0.0, 0.0, 90.0])
    assert np.allclose(joint["rotation"], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-12)
    assert joint["axis_parent"] == pytest.approx([0, 0, 1])
    text = CliRunner().invoke(app, ["inspect", str(ARM)]).output
    assert "rpy (deg)" in text and "axis in parent" in text and "1 end effector\n" in text.replace(",", "\n")
    assert str(ff.load(ARM)).endswith("7 bodies, 6 joints, 1 end effector, mass 525.1 kg)")


def test_trajectory_csv_reads_cleanly_with_pandas(tmp_path: Path) -> None:
    model = ff.models.papadopoulos1992(arms=2)
    traj = ff.simulate(model, ff.State(q=[0.1, 0.2, 0.3, 0.4]), 0.5, lambda t, s: np.ones(4), fixed_step=0.01)
    path = traj.save(tmp_path / "run.csv")
    frame = pd.read_csv(path)
    joints = [f"q[{name}]" for name in model.joint_names]  # columns named by joint
    assert list(frame.columns[:6]) == ["t", *joints, "qdot[arm1_q1]"] and joints == ["q[arm1_q1]", "q[arm1_q2]", "q[arm2_q1]", "q[arm2_q2]"]
    assert "attitude[w]" in frame.columns and "omega[z]" in frame.columns and "saturated" in frame.columns and len(frame) == len(traj)
    np.testing.assert_allclose(frame[joints].to_numpy(), traj.q, rtol=1e-15)
    np.testing.assert_allclose(frame["t"].to_numpy(), traj.t)
    meta = json.loads((tmp_path / "run.csv.json").read_text())
    assert meta["freefloat_trajectory"]["model_name"] == "papadopoulos1992" and meta["columns"] == list(frame.columns)


def test_a_model_without_joints_has_no_path_independent_workspace(tmp_path: Path) -> None:
    """A spacecraft with a tool fixed at its CM: a clear error (it was a ZeroDivisionError, or an internal parameter's name)."""
    b = ff.ModelBuilder("bus_with_tool")
    b.add_body("bus", mass=500.0, inertia=[80.0, 90.0, 100.0])
    b.add_body("tool", mass=0.0, inertia=0.0, frame=True)
    b.add_joint("mount", parent="bus", child="tool", type="fixed")
    model = b.build()
    with pytest.raises(ValueError, match=r"^model 'bus_with_tool' has no joints") as info:
        ff.workspace.path_independent_workspace(model, 0, samples=64)
    assert "merge_gap" not in str(info.value)
    # as a file, it is refused when it is read: a model file without joints is a truncated or wrong file
    path = ff.save(model, tmp_path / "bus_with_tool.toml")
    result = CliRunner().invoke(app, ["workspace", str(path), "--piw", "--samples", "64"])
    assert result.exit_code == 1 and "bus_with_tool.toml: has no movable joint" in result.output
    assert "Traceback" not in result.output


@pytest.mark.parametrize("declared", ["load", "builder", "file"])
def test_a_wheel_speed_limit_beyond_the_fastest_wheel_speed_is_refused_when_declared(declared: str, tmp_path: Path) -> None:
    """A wheel's max_speed above MAX_RATE (1e4 rad/s, the largest wheel speed a State takes) could never act: it is
    refused where the wheel is declared, naming ``wheels[i].max_speed``; the bound itself is accepted."""
    from freefloat.core.numbers import MAX_RATE

    def declare(speed: float) -> ff.Model:
        wheel = {"name": "rw", "axis": [0.0, 0.0, 1.0], "inertia": 0.1, "max_speed": speed}
        if declared == "load":
            return ff.load("papadopoulos1992", wheels=[wheel])
        if declared == "builder":
            b = ff.ModelBuilder("t")
            b.add_body("bus", mass=100.0, inertia=10.0)
            b.add_wheel(**wheel)
            return b.build()
        path = tmp_path / f"model-{speed}.toml"
        text = ff.save(ff.load("papadopoulos1992"), tmp_path / f"plain-{speed}.toml").read_text()
        path.write_text(text + f'\n[[wheels]]\nname = "rw"\naxis = [0.0, 0.0, 1.0]\ninertia = 0.1\nmax_speed = {speed!r}\n')
        return ff.load(path)

    assert declare(MAX_RATE).wheels[0].max_speed == MAX_RATE
    with pytest.raises(ff.ModelError, match=r"wheels\[0\] \(rw\)\.max_speed: 10000\.1 rad/s is beyond 10000 rad/s .*check the units"):
        declare(MAX_RATE + 0.1)
