"""Every error names the field that is wrong and says how to fix it (STYLE.md, Errors)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

import freefloat as ff

INERTIA_FIX = "use the inertia of a real body about its CM"


def builder(*names: str) -> ff.ModelBuilder:
    b = ff.ModelBuilder("broken")
    for name in names:
        b.add_body(name, mass=1.0, inertia=1.0)
    return b


@contextmanager
def raises_model_error(field: str, *words: str) -> Iterator[None]:
    """Expect a ModelError whose message starts with ``field``, contains all ``words`` and ends with the fix."""
    with pytest.raises(ff.ModelError) as info:
        yield
    error = info.value
    message = str(error)
    assert error.field == field and message.startswith(f"{field}: "), f"{message!r} does not start with the field {field!r}"
    for word in words:
        assert word in message, f"{word!r} not in {message!r}"
    assert error.fix and message.endswith(error.fix), message
    assert isinstance(error, ValueError) and isinstance(error, ff.FreefloatError)


# ----------------------------------------------------------------- bodies
@pytest.mark.parametrize("mass", [0.0, -3.0, float("nan"), float("inf")])
def test_non_positive_mass(mass: float) -> None:
    with raises_model_error("bodies[0] (bus).mass", "must be positive", "give the body's mass in kg (> 0)"):
        ff.ModelBuilder().add_body("bus", mass=mass, inertia=1.0)


def test_inertia_not_symmetric() -> None:
    with raises_model_error("bodies[1] (link).inertia", "is not symmetric", INERTIA_FIX, "symmetric"):
        builder("bus").add_body("link", mass=1.0, inertia=[[1.0, 0.2, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])


def test_inertia_not_positive_definite() -> None:
    with raises_model_error("bodies[0] (bus).inertia", "is not positive definite", INERTIA_FIX, "positive definite"):
        ff.ModelBuilder().add_body("bus", mass=1.0, inertia=[1.0, -1.0, 1.0])


def test_inertia_violates_the_triangle_inequality() -> None:
    with raises_model_error("bodies[0] (bus).inertia", "violates the triangle inequality", "3 > 1 + 1", "each principal moment <= the sum"):
        ff.ModelBuilder().add_body("bus", mass=1.0, inertia=[1.0, 1.0, 3.0])


def test_duplicate_body_names() -> None:
    with raises_model_error("bodies[1] (bus).name", "duplicate body name 'bus'", "unique name"):
        builder("bus", "bus")


# ----------------------------------------------------------------- joints and tree
def test_zero_joint_axis() -> None:
    with raises_model_error("joints[0] (q1).axis", "is the zero vector", "give a nonzero axis"):
        builder("bus", "link").add_joint("q1", parent="bus", child="link", axis=[0.0, 0.0, 0.0])


def test_cycle() -> None:
    b = builder("bus", "a", "b")
    b.add_joint("q1", parent="bus", child="a").add_joint("q2", parent="a", child="b").add_joint("q3", parent="b", child="bus")
    with raises_model_error("joints", "cycle", "leave the spacecraft (root) without a parent joint"):
        b.build()


def test_cycle_beside_the_tree() -> None:
    b = builder("bus", "a", "b")
    b.add_joint("q1", parent="a", child="b").add_joint("q2", parent="b", child="a")
    with raises_model_error("joints", "not reachable from the spacecraft 'bus'", "cycle", "exactly one parent joint"):
        b.build()


def test_disconnected_body() -> None:
    b = builder("bus", "a", "lost")
    b.add_joint("q1", parent="bus", child="a")
    with raises_model_error("joints", "'lost'", "not connected to the spacecraft 'bus'", "connect every body to the tree"):
        b.build()


def test_duplicate_joint_names() -> None:
    b = builder("bus", "a", "b").add_joint("q1", parent="bus", child="a")
    with raises_model_error("joints[1] (q1).name", "duplicate joint name 'q1'", "unique name"):
        b.add_joint("q1", parent="a", child="b")


@pytest.mark.parametrize(
    ("role", "parent", "child", "wrong", "close"),
    [("parent", "spacecraf", "link", "spacecraf", "spacecraft"), ("child", "spacecraft", "lnk", "lnk", "link")],
)
def test_unknown_parent_or_child(role: str, parent: str, child: str, wrong: str, close: str) -> None:
    b = builder("spacecraft", "link").add_joint("q1", parent=parent, child=child)
    with raises_model_error(
        f"joints[0] (q1).{role}", f"unknown body {wrong!r}", f"did you mean {close!r}", "name a body defined in the model"
    ):
        b.build()


# ----------------------------------------------------------------- files
def test_malformed_toml(tmp_path: Path) -> None:
    path = tmp_path / "bad.toml"
    path.write_text('name = "x"\n[[bodies]\nname = "bus"\n', encoding="utf-8")
    with raises_model_error(str(path), "malformed TOML", "line 2", "fix the TOML syntax"):
        ff.load(path)


def test_toml_with_an_unknown_key(tmp_path: Path) -> None:
    path = tmp_path / "unknown.toml"
    path.write_text('[[bodies]]\nname = "bus"\nmass = 10.0\ninertia = 1.0\ncolour = "red"\n', encoding="utf-8")
    with raises_model_error(f"{path}: bodies[0].colour", "unknown key", "allowed keys", "mass"):  # the file and the field
        ff.load(path)


def test_toml_with_a_missing_mass(tmp_path: Path) -> None:
    path = tmp_path / "nomass.toml"
    path.write_text('[[bodies]]\nname = "bus"\ninertia = 1.0\n', encoding="utf-8")
    with raises_model_error(f"{path}: bodies[0].mass", "is missing", "give the mass in kg"):
        ff.load(path)


def test_malformed_urdf(tmp_path: Path) -> None:
    path = tmp_path / "bad.urdf"
    path.write_text('<robot name="x"><link name="bus"></robot>', encoding="utf-8")
    with raises_model_error(str(path), "malformed URDF", "line 1", "valid URDF XML"):
        ff.load(path)


URDF_SCREW = """<robot name="slider">
  <link name="bus"><inertial><mass value="10"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="carriage"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="slide" type="screw">
    <parent link="bus"/><child link="carriage"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
"""


def test_urdf_with_an_unsupported_joint_type(tmp_path: Path) -> None:
    path = tmp_path / "slider.urdf"
    path.write_text(URDF_SCREW, encoding="utf-8")
    with raises_model_error(
        f"{path}: joint[0] (slide).type", "unsupported joint type 'screw'", "revolute, continuous, prismatic and fixed"
    ):
        ff.load(path)


# ----------------------------------------------------------------- arguments
def test_q_of_the_wrong_shape() -> None:
    model = ff.models.papadopoulos1992()
    for bad, shape in ((np.zeros(3), "(3,)"), (np.zeros((5, 2)), "(5, 2)"), (0.0, "()")):
        with pytest.raises(ff.ShapeError) as info:
            ff.end_effector_positions(model, bad)
        message = str(info.value)
        assert "q: expected shape (..., 4)" in message and f"got {shape}" in message
        assert "arm1_q1, arm1_q2, arm2_q1, arm2_q2" in message  # what the 4 values are
    assert issubclass(ff.ShapeError, ValueError)


def test_velocity_of_the_wrong_shape() -> None:
    model = ff.models.papadopoulos1991()
    with pytest.raises(ff.ShapeError, match=r"velocity: expected shape \(\.\.\., 8\) \(zdot0 = \[rdot_cm, omega0, qdot\]\), got \(7,\)"):
        ff.angular_momentum(model, np.zeros(2), np.zeros(7))


def test_unknown_end_effector() -> None:
    model = ff.models.papadopoulos1992()
    with pytest.raises(ff.UnknownNameError) as info:
        ff.end_effector_jacobian(model, np.zeros(4), "arm1_e")
    message = str(info.value)
    assert "unknown end effector 'arm1_e'" in message
    assert "Did you mean 'arm1_ee'" in message
    assert "known: arm1_ee, arm2_ee" in message
    assert isinstance(info.value, KeyError)
    with pytest.raises(ff.UnknownNameError, match="unknown end effector 7"):
        model.end_effector_index(7)


@pytest.mark.parametrize("mass", [0.0, -400.0])
def test_payload_with_non_positive_mass(mass: float) -> None:
    model = ff.models.papadopoulos1992()
    with raises_model_error("with_payload(end_effector='arm1_ee').mass", "must be positive", "give the payload mass in kg (> 0)"):
        model.with_payload(0, mass=mass, inertia=25.0)


@pytest.mark.parametrize(
    ("inertia", "problem"),
    [
        (-25.0, "not positive definite"),
        ([1.0, 1.0, 3.0], "triangle inequality"),
        ([[1.0, 0.5, 0], [0, 1.0, 0], [0, 0, 1.0]], "not symmetric"),
    ],
)
def test_payload_with_a_bad_inertia(inertia: object, problem: str) -> None:
    model = ff.models.papadopoulos1992()
    with raises_model_error("with_payload(end_effector='arm2_ee').inertia", problem, INERTIA_FIX):
        model.with_payload("arm2_ee", mass=400.0, inertia=inertia)


def test_non_unit_quaternion_attitude() -> None:
    model = ff.models.papadopoulos1992()
    with pytest.raises(ValueError) as info:
        ff.end_effector_positions(model, np.zeros(4), attitude=[0.0, 0.0, 0.0, 2.0])
    message = str(info.value)
    assert message.startswith("attitude:")
    assert "norm 2 is not 1" in message
    assert "pass a unit quaternion [x, y, z, w] (scalar last)" in message
    with pytest.raises(ff.ShapeError, match=r"attitude: expected a quaternion \[x, y, z, w\] of shape \(\.\.\., 4\), got \(3,\)"):
        ff.end_effector_positions(model, np.zeros(4), attitude=[0.0, 0.0, 1.0])
