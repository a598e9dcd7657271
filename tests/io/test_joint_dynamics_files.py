"""The joints' own dynamics given beside a file (``ff.load(..., joints=...)``: URDF has no rotor inertia) and written
back (issue 21): a table or a TOML side file, each name and value checked; URDF keeps damping and friction and says
what it cannot keep."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import freefloat as ff
from freefloat.core.errors import ModelError, UnmodelledElementWarning
from robots import REAL_ROBOTS, load_real, spacecraft_urdf


def ur5(tmp_path: Path) -> tuple[Path, ff.Model]:
    path = spacecraft_urdf(REAL_ROBOTS["ur5"][0], tmp_path)
    return path, load_real("ur5", path)


def test_a_table_sets_the_rotors_of_a_urdf_robot(tmp_path: Path) -> None:
    path, plain = ur5(tmp_path)
    first, second = plain.joint_names[:2]
    model = ff.load(path, joints={first: {"armature": 0.4, "damping": 2.0}, second: {"friction": 0.5}})
    assert model.joint_armature[0] == 0.4 and model.joint_damping[0] == 2.0 and model.joint_friction[1] == 0.5
    assert model.joint_armature[1:].sum() == 0.0 and model.joint_damping[1:].sum() == 0.0
    q = np.linspace(-1, 1, plain.n_joints)
    extra = ff.system_inertia_matrix(model, q) - ff.system_inertia_matrix(plain, q)
    assert extra[6, 6] == pytest.approx(0.4, rel=1e-12) and np.abs(np.delete(extra.ravel(), 6 * extra.shape[0] + 6)).max() < 1e-12


def test_a_toml_side_file_does_the_same(tmp_path: Path) -> None:
    path, plain = ur5(tmp_path)
    side = tmp_path / "rotors.toml"
    side.write_text("".join(f"[{name}]\narmature = {0.1 * (j + 1)}\n\n" for j, name in enumerate(plain.joint_names)))
    model = ff.load(path, joints=side)
    np.testing.assert_allclose(model.joint_armature, 0.1 * np.arange(1, plain.n_joints + 1), rtol=1e-15)
    builtin = ff.load("papadopoulos1992", joints={"arm1_q1": {"damping": 3.0}})
    assert builtin.joint_damping[0] == 3.0


@pytest.mark.parametrize(
    ("joints", "needle"),
    [
        ({"shoulder_pan": {"armature": 0.1}}, r"joints: shoulder_pan: is not a joint of .* \(did you mean 'shoulder_pan_joint'"),
        ({"shoulder_pan_joint": {"inertia": 0.1}}, r"joints: shoulder_pan_joint\.inertia: unknown key; allowed keys: armature"),
        ({"shoulder_pan_joint": {"damping": "high"}}, r"shoulder_pan_joint\.damping: cannot read 'high' as a number"),
        ({"shoulder_pan_joint": {"friction": -1.0}}, r"joints\[0\] \(shoulder_pan_joint\)\.friction: is -1\.0"),
        ({"shoulder_pan_joint": 0.3}, r"shoulder_pan_joint: expected a table"),
    ],
)
def test_bad_joint_tables_name_the_joint_and_the_key(tmp_path: Path, joints: dict, needle: str) -> None:
    path, _ = ur5(tmp_path)
    with pytest.raises(ff.ModelError, match=needle):
        ff.load(path, joints=joints)


def test_urdf_keeps_damping_and_friction_and_says_it_cannot_keep_the_rotors(tmp_path: Path) -> None:
    path, plain = ur5(tmp_path)
    model = ff.load(path, joints={plain.joint_names[2]: {"armature": 0.2, "damping": 1.5, "friction": 0.3}})
    with pytest.warns(UnmodelledElementWarning, match=rf"the armature of joint '{plain.joint_names[2]}' 0\.2 is not written"):
        saved = ff.save(model, tmp_path / "out.urdf")
    again = ff.load(saved)
    np.testing.assert_array_equal(again.joint_damping, model.joint_damping)
    np.testing.assert_array_equal(again.joint_friction, model.joint_friction)
    assert not again.joint_armature.any()
    kept = ff.save(model, tmp_path / "out.toml")  # TOML keeps all three (and the UR5's wrist at gimbal lock, silently)
    back = ff.load(kept)
    np.testing.assert_array_equal(back.joint_armature, model.joint_armature)
    q = np.linspace(-1, 1, model.n_joints)
    h = ff.system_inertia_matrix(model, q)
    assert np.abs(ff.system_inertia_matrix(back, q) - h).max() < 1e-12 * np.abs(h).max()


def _follower(**dynamics: float) -> ff.Model:
    """A bus, a link on joint ``lead`` and a link on ``follow`` (a mimic of ``lead``, ratio -0.5), ``follow`` with
    ``dynamics`` (armature, damping, friction) given to the builder."""
    b = ff.ModelBuilder("follower")
    b.add_body("bus", mass=100.0, inertia=[10.0, 12.0, 14.0])
    b.add_body("one", mass=2.0, inertia=[0.02, 0.03, 0.04], com=[0.2, 0.0, 0.0])
    b.add_body("two", mass=1.0, inertia=[0.01, 0.02, 0.02], com=[0.1, 0.05, 0.0])
    b.add_joint("lead", parent="bus", child="one", origin=[0.5, 0, 0], axis=[0, 0, 1])
    b.add_joint("follow", parent="one", child="two", origin=[0.4, 0, 0], axis=[0, 1, 0], **dynamics)
    b.add_mimic("follow", leader="lead", multiplier=-0.5)
    return b.build()


def test_a_mimic_joint_takes_its_own_rotor_and_friction() -> None:
    """``joints=`` may name a mimic joint: its armature, damping and friction go into its mimic record (it has no column
    of q), as the builder puts them; it was refused as "is not a joint"."""
    from freefloat.io.model_files import with_joint_dynamics

    entry = {"armature": 0.05, "damping": 0.3, "friction": 0.2}
    bare, built = _follower(), _follower(**entry)
    named = with_joint_dynamics(bare, {"follow": entry})
    assert named.mimic == built.mimic and named.joint_names == ("lead",)
    q = np.random.default_rng(4).uniform(-1.0, 1.0, (3, 1))
    np.testing.assert_array_equal(ff.system_inertia_matrix(named, q), ff.system_inertia_matrix(built, q))
    assert not np.array_equal(ff.system_inertia_matrix(named, q), ff.system_inertia_matrix(bare, q))
    with pytest.raises(ModelError, match=r"joints: follow\.armature: cannot read 'a lot' as a number"):
        with_joint_dynamics(bare, {"follow": {"armature": "a lot"}})
    with pytest.raises(ModelError, match=r"is not a joint of 'follower'.*name one of its joints: lead, follow"):
        with_joint_dynamics(bare, {"folow": {"armature": 0.1}})
