"""Mimic joints in files: TOML and URDF round trips; MJCF joint equalities, against MuJoCo's own (soft) equality.

``<equality><joint joint1="a" joint2="b" polycoef="c0 c1 0 0 0"/>`` makes ``a`` a mimic joint of ``b``
(q_a = c1 q_b + c0). The same file runs in MuJoCo, which enforces the equality as a stiff soft constraint: the
leader's motion under a joint torque, the spacecraft's attitude and the mimic joint's value agree with freefloat's
exact law within MARGIN times the measured agreement (2.1e-10 rad over 1 s, MuJoCo's own violation of the
equality being 2.3e-9 rad with solref 0.0005 s). Higher-order polynomials,
equalities without ``joint2`` and inactive ones are refused naming the joint.
"""

from __future__ import annotations

from pathlib import Path

import mujoco  # an oracle: a missing one fails these tests
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import freefloat as ff
from mechanics.test_mimic import gripper, rel
from oracle_checks import MARGIN

ARM = """<mujoco model="pair">
  <compiler angle="radian" inertiafromgeom="false" autolimits="true"/>
  <option gravity="0 0 0" timestep="1e-4" integrator="RK4"><flag contact="disable"/></option>
  <worldbody>
    <body name="bus" pos="0 0 0">
      <freejoint name="root"/>
      <inertial pos="0.05 -0.02 0.1" mass="200" fullinertia="30 40 50 1 -2 0.5"/>
      <body name="upper" pos="0.6 0 0.2">
        <joint name="shoulder" type="hinge" axis="0 0 1"/>
        <inertial pos="0.3 0.02 0" mass="8" diaginertia="0.05 0.3 0.3"/>
        <body name="fore" pos="0.7 0 0">
          <joint name="elbow" type="hinge" axis="0 1 0.2"/>
          <inertial pos="0.25 0 0.01" mass="5" diaginertia="0.03 0.2 0.2"/>
          <site name="tool" pos="0.5 0 0"/>
        </body>
      </body>
      <body name="mast" pos="-0.5 0 0.5">
        <joint name="tilt" type="hinge" axis="1 0 1"/>
        <inertial pos="0 0.1 0.3" mass="6" diaginertia="0.2 0.2 0.05"/>
      </body>
    </body>
  </worldbody>
  <equality>
    <joint joint1="tilt" joint2="shoulder" polycoef="POLY" solref="0.0005 1" solimp="0.99 0.999 0.001"/>
  </equality>
  <actuator>
    <motor name="shoulder" joint="shoulder"/>
    <motor name="elbow" joint="elbow"/>
  </actuator>
</mujoco>
"""

#: The largest |tilt - (c1 shoulder + c0)| MuJoCo's soft equality allows in the run below (rad), and the agreement
#: of the leader's angle, the elbow's and the attitude (rad), measured 2026-11-26 (MuJoCo 4.0.0, 1e-4 s RK4 steps).
MEASURED_VIOLATION = 2.3e-9
MEASURED_AGREEMENT = 2.1e-10


def write(tmp_path: Path, poly: str = "0.1 -0.8 0 0 0", equality: str | None = None) -> Path:
    text = ARM.replace("POLY", poly)
    if equality is not None:
        text = text.replace(text[text.index("<equality>") : text.index("</equality>") + len("</equality>")], equality)
    path = tmp_path / "pair.xml"
    path.write_text(text, encoding="utf-8")
    return path


def test_a_first_order_joint_equality_is_a_mimic_joint(tmp_path: Path) -> None:
    model = ff.load(write(tmp_path))
    assert model.joint_names == ("shoulder", "elbow") and model.body_joint_names == ("shoulder", "elbow", "tilt")
    assert [(r["joint"], r["leader"], r["multiplier"], r["offset"]) for r in model.mimic] == [("tilt", "shoulder", -0.8, 0.1)]


def test_a_mimic_pair_agrees_with_mujocos_joint_equality(tmp_path: Path) -> None:
    path = write(tmp_path)
    model = ff.load(path, end_effectors=["tool"])
    tau = np.array([2.0, -1.0])
    duration = 1.0
    traj = ff.simulate(model, ff.State(q=[0.0, 0.3]), duration, lambda t, s: tau, fixed_step=1e-3, output_period=0.1)
    mj = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(mj)
    data.joint("elbow").qpos[0] = 0.3
    data.joint("tilt").qpos[0] = 0.1  # on the law at q_shoulder = 0
    data.ctrl[:] = tau
    violation = 0.0
    rows = []
    for step in range(round(duration / mj.opt.timestep) + 1):
        if step % 1000 == 0:
            quat = np.roll(data.joint("root").qpos[3:7], -1)
            rows.append((data.joint("shoulder").qpos[0], data.joint("elbow").qpos[0], quat))
        violation = max(violation, abs(data.joint("tilt").qpos[0] - (-0.8 * data.joint("shoulder").qpos[0] + 0.1)))
        if step < duration / mj.opt.timestep:
            mujoco.mj_step(mj, data)
    assert violation < MARGIN * MEASURED_VIOLATION
    assert len(traj.q) == len(rows) == 11
    worst = 0.0
    for (shoulder, elbow, quat), q, attitude in zip(rows, traj.q, traj.attitude, strict=True):
        worst = max(
            worst, abs(shoulder - q[0]), abs(elbow - q[1]), (Rotation.from_quat(quat).inv() * Rotation.from_quat(attitude)).magnitude()
        )
    assert abs(traj.q[-1, 0]) > 0.1, "the leader should move"
    assert worst < MARGIN * MEASURED_AGREEMENT, worst


@pytest.mark.parametrize(
    ("equality", "match"),
    [
        (
            '<equality><joint joint1="tilt" joint2="shoulder" polycoef="0 1 0.5 0 0"/></equality>',
            r"pair.xml: equality joint 'tilt'\.polycoef: 'tilt' follows 'shoulder' by a polynomial of order > 1 .*'offset multiplier",
        ),
        (
            '<equality><joint joint1="tilt" polycoef="0.2 0 0 0 0"/></equality>',
            r"equality joint 'tilt': holds joint 'tilt' at 0.2 \(a joint equality without joint2\); make 'tilt' a fixed joint",
        ),
        (
            '<equality><joint joint1="tilt" joint2="shoulder" active="false"/></equality>',
            r"equality joint 'tilt': the equality of 'tilt' and 'shoulder' is inactive; remove it, or make it active",
        ),
        (
            '<equality><joint joint1="tilt" joint2="elbow"/><joint joint1="elbow" joint2="tilt"/></equality>',
            r"mimic \(tilt\): joint 'tilt' mimics itself through a chain of mimic joints \(tilt -> elbow -> tilt\)",
        ),
    ],
)
def test_refused_joint_equalities_name_the_joint(tmp_path: Path, equality: str, match: str) -> None:
    with pytest.raises(ff.ModelError, match=match):
        ff.load(write(tmp_path, equality=equality))


# ----------------------------------------------------------------- TOML and URDF
@pytest.mark.parametrize("suffix", [".toml", ".urdf"])
def test_mimic_joints_round_trip_through_files(tmp_path: Path, suffix: str) -> None:
    model = gripper(passive=suffix == ".toml")  # URDF carries no rotor inertia
    loaded = ff.load(ff.save(model, tmp_path / f"gripper{suffix}"))
    assert loaded.joint_names == model.joint_names and loaded.body_joint_names == model.body_joint_names
    assert [(r["joint"], r["leader"]) for r in loaded.mimic] == [(r["joint"], r["leader"]) for r in model.mimic]
    np.testing.assert_allclose(loaded.body_joint_multiplier, model.body_joint_multiplier, rtol=1e-15)
    np.testing.assert_allclose(loaded.body_joint_offset, model.body_joint_offset, rtol=1e-15)
    np.testing.assert_array_equal(loaded.joint_lower, model.joint_lower)
    q = np.random.default_rng(0).uniform(-0.02, 0.02, model.n_joints)
    assert rel(ff.system_inertia_matrix(loaded, q), ff.system_inertia_matrix(model, q)) < 1e-12


def test_inspect_lists_each_mimic_joint_with_its_leader_and_law(tmp_path: Path) -> None:
    import json

    from typer.testing import CliRunner

    from freefloat.cli import app

    path = ff.save(gripper(), tmp_path / "gripper.toml")
    text = CliRunner().invoke(app, ["inspect", str(path)])
    assert text.exit_code == 0, text.output
    assert "Mimic joints" in text.output
    line = next(row for row in text.output.splitlines() if row.strip().startswith("tilt"))
    assert "shoulder" in line and "q = -1 q_shoulder + 0.1" in line
    info = json.loads(CliRunner().invoke(app, ["inspect", str(path), "--json"]).output)
    assert [(m["name"], m["leader"], m["multiplier"]) for m in info["mimic"]] == [
        ("finger_r", "finger_l", -1.0),
        ("mast", "shoulder", 0.5),
        ("tilt", "shoulder", -1.0),
    ]
    assert [j["name"] for j in info["joints"]] == ["shoulder", "elbow", "wrist", "finger_l"]
    assert [j["child"] for j in info["joints"]] == ["upper", "fore", "wrist", "left"]
