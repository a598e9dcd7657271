"""Real-file flaws (issue 12): corrected with a warning and a record, or refused with a clear error.

One test per kind of refused input, the inertia correction (default, record, ``strict``), named
end effectors against leaves, and the whole-model check (H+ singular).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import freefloat as ff
from freefloat.analysis.workspace import reachable_workspace
from freefloat.core.errors import ModelCorrectionWarning
from robots import REAL_ROBOTS, spacecraft_urdf


def link(name: str, mass: float, inertia: tuple[float, ...] = (1.0, 1.0, 1.0, 0.0, 0.0, 0.0), xyz: str = "0 0 0") -> str:
    ixx, iyy, izz, ixy, ixz, iyz = inertia
    return (
        f'<link name="{name}"><inertial><origin xyz="{xyz}" rpy="0 0 0"/><mass value="{mass}"/>'
        f'<inertia ixx="{ixx}" iyy="{iyy}" izz="{izz}" ixy="{ixy}" ixz="{ixz}" iyz="{iyz}"/></inertial></link>'
    )


def frame(name: str) -> str:
    return f'<link name="{name}"/>'


def joint(name: str, kind: str, parent: str, child: str, xyz: str = "0.5 0 0", axis: str = "0 0 1", extra: str = "") -> str:
    limit = '<limit lower="-1" upper="1" effort="1" velocity="1"/>' if kind in ("revolute", "prismatic") else ""
    axis_xml = f'<axis xyz="{axis}"/>' if kind != "fixed" else ""
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}" rpy="0 0 0"/>{axis_xml}{limit}{extra}</joint>'
    )


def urdf(tmp_path: Path, *parts: str, name: str = "robot.urdf") -> Path:
    path = tmp_path / name
    path.write_text('<?xml version="1.0"?><robot name="test">' + "".join(parts) + "</robot>", encoding="utf-8")
    return path


def arm(*extra: str, link2: str | None = None) -> list[str]:
    """A 500 kg spacecraft with a two-link arm (revolute, prismatic)."""
    return [
        link("bus", 500.0, (80.0, 90.0, 60.0, 0.0, 0.0, 0.0)),
        link("l1", 10.0, (0.1, 0.5, 0.5, 0.0, 0.0, 0.0), xyz="0.3 0 0"),
        link2 or link("l2", 5.0, (0.05, 0.2, 0.2, 0.0, 0.0, 0.0), xyz="0.2 0 0"),
        joint("q1", "revolute", "bus", "l1"),
        joint("s2", "prismatic", "l1", "l2", xyz="0.6 0 0", axis="1 0 0"),
        *extra,
    ]


# ----------------------------------------------------------------------------- inertia corrections
ETS_LIKE = (0.1, 0.1, 0.5, 0.0, 0.0, 0.0)  # 0.5 > 0.1 + 0.1: the triangle inequality fails, as in the public ETS-VII URDF


def test_non_physical_inertia_is_corrected_with_a_warning_and_a_record(tmp_path: Path) -> None:
    path = urdf(tmp_path, *arm(link2=link("l2", 5.0, ETS_LIKE, xyz="0.2 0 0")))
    with pytest.warns(ModelCorrectionWarning, match=r"link\[2\] \(l2\)\.inertia violates the triangle inequality.*change") as record:
        model = ff.load(path)
    assert len(record) == 1
    (fix,) = model.corrections
    assert fix["field"] == "inertia" and "l2" in fix["where"] and "triangle" in fix["defect"]
    used = np.array(fix["used"])
    moments = np.linalg.eigvalsh(used)
    assert moments[2] <= moments[0] + moments[1] + 1e-12 and moments[0] >= 0.0
    # the nearest physical inertia: the moments (0.1, 0.1, 0.5) projected onto I3 <= I1 + I2 -> (0.2, 0.2, 0.4)
    np.testing.assert_allclose(np.sort(moments), [0.2, 0.2, 0.4], atol=1e-9)
    assert fix["change_kg_m2"] == pytest.approx(np.linalg.norm(used - np.diag([0.1, 0.1, 0.5])))
    np.testing.assert_allclose(model.inertia[model.body_index("l2")], used)


def test_strict_load_refuses_the_non_physical_inertia(tmp_path: Path) -> None:
    path = urdf(tmp_path, *arm(link2=link("l2", 5.0, ETS_LIKE, xyz="0.2 0 0")))
    with pytest.raises(ff.ModelError, match=r"l2\)\.inertia: violates the triangle inequality.*strict=False"):
        ff.load(path, strict=True)


def test_negative_moment_is_corrected_too(tmp_path: Path) -> None:
    path = urdf(tmp_path, *arm(link2=link("l2", 5.0, (-0.01, 0.2, 0.2, 0.0, 0.0, 0.0), xyz="0.2 0 0")))
    with pytest.warns(ModelCorrectionWarning, match="not positive definite"):
        model = ff.load(path)
    assert np.linalg.eigvalsh(model.inertia[2])[0] >= -1e-15


def test_point_mass_links_load_without_a_warning(tmp_path: Path) -> None:
    """A small link with zero inertia (Baxter's gripper links) is a point mass: physical, nothing to correct."""
    path = urdf(tmp_path, *arm(link2=link("l2", 0.5, (0.0, 0.0, 0.0, 0.0, 0.0, 0.0), xyz="0.2 0.1 0")))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model = ff.load(path, strict=True)
    assert model.corrections == ()


def test_model_with_singular_h_plus_is_refused(tmp_path: Path) -> None:
    """A point mass on the axis of its revolute joint: that joint moves no mass and no inertia."""
    parts = [
        link("bus", 500.0, (80.0, 90.0, 60.0, 0.0, 0.0, 0.0)),
        link("tip", 1.0, (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)),
        joint("spin", "revolute", "bus", "tip"),
    ]
    with pytest.raises(ff.ModelError, match=r"joint 'spin'.*H\+ is singular"):
        ff.load(urdf(tmp_path, *parts))


# ----------------------------------------------------------------------------- refused joints
def test_mimic_joints_are_read_and_strict_does_not_refuse_them(tmp_path: Path) -> None:
    """The Panda as distributed: its second finger mimics the first (a dependent coordinate, not a defect)."""
    path = spacecraft_urdf(REAL_ROBOTS["panda"][0], tmp_path)
    for strict in (False, True):
        model = ff.load(path, strict=strict)
        assert "panda_finger_joint2" not in model.joint_names and "panda_finger_joint2" in model.body_joint_names
        assert [r["leader"] for r in model.mimic] == ["panda_finger_joint1"]


@pytest.mark.parametrize(
    ("extra", "match"),
    [
        ('<mimic joint="q1" multiplier="2" offset="0.1"/>', None),
        ('<mimic joint="s2"/>', r"robot.urdf: mimic \(s2\): joint 's2' mimics itself through a chain of mimic joints \(s2 -> s2\)"),
        (
            '<mimic joint="nope"/>',
            r"robot.urdf: mimic \(s2\)\.leader: joint 's2' mimics 'nope', which is not a joint of the model; name a joint",
        ),
        (
            '<mimic joint="fix"/>',
            r"robot.urdf: mimic \(s2\)\.leader: joint 's2' mimics the fixed joint 'fix', which has no coordinate; make 's2' fixed",
        ),
        ('<mimic joint="q1" multiplier="nan"/>', r"joint\[1\] \(s2\)\.mimic: is nan; give a finite number"),
    ],
)
def test_bad_mimic_joints_are_refused_naming_the_joint(tmp_path: Path, extra: str, match: str | None) -> None:
    parts = arm(link("l3", 1.0, xyz="0.1 0 0"), joint("fix", "fixed", "bus", "l3", xyz="0 1 0"))
    parts[4] = joint("s2", "prismatic", "l1", "l2", xyz="0.6 0 0", axis="1 0 0", extra=extra)
    if match is None:  # a revolute leader, a prismatic follower: q_s2 = 2 q1 + 0.1 (m from rad)
        model = ff.load(urdf(tmp_path, *parts))
        assert model.joint_names == ("q1",) and model.mimic[0]["multiplier"] == 2.0 and model.mimic[0]["offset"] == 0.1
        return
    with pytest.raises(ff.ModelError, match=match):
        ff.load(urdf(tmp_path, *parts))


@pytest.mark.parametrize("kind", ["floating", "planar"])
def test_floating_and_planar_joints_inside_the_tree_are_refused(tmp_path: Path, kind: str) -> None:
    parts = [*arm(), link("l3", 1.0, xyz="0.1 0 0"), joint("odd", kind, "l2", "l3")]
    with pytest.raises(ff.ModelError, match=rf"joint\[2\] \(odd\)\.type: '{kind}'.*not supported"):
        ff.load(urdf(tmp_path, *parts))


def test_closed_loop_is_refused_naming_the_joint(tmp_path: Path) -> None:
    parts = [*arm(), joint("loop", "revolute", "bus", "l2", xyz="0 1 0")]
    with pytest.raises(ff.ModelError, match=r"\(loop\)\.child: body 'l2' already has parent joint 's2'.*closes a loop"):
        ff.load(urdf(tmp_path, *parts))


def test_prismatic_joint_with_zero_axis_is_refused(tmp_path: Path) -> None:
    parts = arm()
    parts[-1] = joint("s2", "prismatic", "l1", "l2", xyz="0.6 0 0", axis="0 0 0")
    with pytest.raises(ff.ModelError, match=r"\(s2\)\.axis: is the zero vector"):
        ff.load(urdf(tmp_path, *parts))


def test_end_effector_that_is_not_a_link_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ff.ModelError, match=r"'gripper' is not a body or frame of the model"):
        ff.load(urdf(tmp_path, *arm()), end_effectors=["gripper"])


# ----------------------------------------------------------------------------- chosen end effectors
def appendages() -> list[str]:
    """The arm plus a fixed solar array and antenna on the bus, and a tool frame on the last link."""
    return arm(
        link("solar_array", 20.0, (5.0, 5.0, 9.0, 0.0, 0.0, 0.0)),
        link("antenna", 2.0, (0.1, 0.1, 0.15, 0.0, 0.0, 0.0)),
        frame("tool"),
        joint("array_mount", "fixed", "bus", "solar_array", xyz="0 2 0"),
        joint("antenna_mount", "fixed", "bus", "antenna", xyz="0 -1 0.5"),
        joint("tool_mount", "fixed", "l2", "tool", xyz="0.4 0 0"),
    )


def test_named_tool_frame_gives_one_end_effector_and_a_square_jstar(tmp_path: Path) -> None:
    path = urdf(tmp_path, *appendages())
    model = ff.load(path, end_effectors=["tool"])
    assert model.end_effector_names == ("tool",) and model.end_effector_rule == "named"
    np.testing.assert_allclose(model.end_effector_point[0], [0.4, 0.0, 0.0])
    # planar rows of this planar-in-x-y arm: J* restricted to [vx, vy] is 2 x 2
    assert ff.generalized_jacobian(model, [0.2, 0.1]).shape == (6, 2)


def test_without_names_every_leaf_is_an_end_effector(tmp_path: Path) -> None:
    model = ff.load(urdf(tmp_path, *appendages()))
    assert model.end_effector_rule == "leaves"
    assert set(model.end_effector_names) == {"solar_array", "antenna", "tool"}
    assert ff.generalized_jacobian(model, [0.2, 0.1]).shape == (18, 2)


def test_end_effectors_named_in_a_toml_file_survive_a_round_trip(tmp_path: Path) -> None:
    model = ff.load(urdf(tmp_path, *appendages()), end_effectors=[("gripper", "l2", [0.4, 0.0, 0.0])])
    out = ff.save(model, tmp_path / "robot.toml")
    again = ff.load(out)
    assert again.end_effector_names == ("gripper",) and again.end_effector_rule == "named"
    np.testing.assert_allclose(ff.end_effector_positions(again, [0.3, 0.2]), ff.end_effector_positions(model, [0.3, 0.2]))
    assert again.joint_type == ("revolute", "prismatic")


# ----------------------------------------------------------------------------- prismatic reach
def test_workspace_with_a_prismatic_joint_uses_its_limits(tmp_path: Path) -> None:
    model = ff.load(urdf(tmp_path, *arm()), end_effectors=[("tip", "l2", [0.4, 0.0, 0.0])])
    ws = reachable_workspace(model, "tip", samples=1 << 10, starts=4)
    # the tip slides 0.6 + s + 0.4 m from joint q1 (s in [-1, 1] m); its reach about the CM grows with s
    r_far = float(np.linalg.norm(ff.end_effector_positions(model, [0.0, 1.0])[0]))
    assert ws.R_max == pytest.approx(r_far, rel=1e-6)


def test_workspace_refuses_an_unlimited_prismatic_joint() -> None:
    b = ff.ModelBuilder("slider")
    b.add_body("bus", mass=500.0, inertia=[80.0, 90.0, 60.0])
    b.add_body("rod", mass=5.0, inertia=[0.05, 0.2, 0.2], end_effector=[0.5, 0, 0])
    b.add_joint("s", parent="bus", child="rod", origin=[0.5, 0, 0], axis=[1, 0, 0], type="prismatic")
    with pytest.raises(ff.ModelError, match=r"joint 's'\.limits: is a prismatic joint without limits"):
        reachable_workspace(b.build())
