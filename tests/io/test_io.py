"""Model files: TOML and URDF round trips, the example model files, no overwriting."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings

import freefloat as ff
from trees import random_trees

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "models"

# Arrays that a file stores digit for digit (repr of a float round-trips exactly).
EXACT = ("parent", "joint_origin", "joint_lower", "joint_upper", "mass", "com", "end_effector_body", "end_effector_point")
# Arrays that pass through a conversion: rotations through rpy angles, axes through a renormalisation,
# inertias through the parallel-axis shift of the builder (to the body frame origin and back).
CONVERTED = ("joint_rotation", "joint_axis", "inertia")


def assert_same_model(got: ff.Model, want: ff.Model, *, end_effector_names: bool = True, rtol: float = 1e-12) -> None:
    assert got.body_names == want.body_names
    assert got.joint_names == want.joint_names
    if end_effector_names:
        assert got.end_effector_names == want.end_effector_names
    assert got.n_end_effectors == want.n_end_effectors
    for name in EXACT:
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name), err_msg=name)
    for name in CONVERTED:
        value = getattr(want, name)
        np.testing.assert_allclose(getattr(got, name), value, rtol=0, atol=rtol * max(1.0, float(np.max(np.abs(value)))), err_msg=name)


def round_trip(model: ff.Model, suffix: str) -> ff.Model:
    with tempfile.TemporaryDirectory() as tmp:
        path = ff.save(model, Path(tmp) / f"model{suffix}")
        assert path.is_file()
        return ff.load(path)


@settings(max_examples=40)
@given(model=random_trees())
def test_toml_round_trip(model: ff.Model) -> None:
    loaded = round_trip(model, ".toml")
    assert_same_model(loaded, model)
    assert loaded.name == model.name


@settings(max_examples=40)
@given(model=random_trees())
def test_urdf_round_trip(model: ff.Model) -> None:
    loaded = round_trip(model, ".urdf")
    # URDF has no end-effector names: each end effector becomes a massless link named after it
    # (with "_tip" where a body already has that name) and comes back under that link's name.
    assert_same_model(loaded, model, end_effector_names=False)
    for got, want in zip(loaded.end_effector_names, model.end_effector_names, strict=True):
        assert got in (want, f"{want}_tip")


@pytest.mark.parametrize("suffix", [".toml", ".urdf"])
def test_round_trip_of_the_paper_models_with_a_payload(suffix: str) -> None:
    model = ff.models.papadopoulos1992().with_payload(0, mass=400.0, inertia=25.0)
    loaded = round_trip(model, suffix)
    assert_same_model(loaded, model, end_effector_names=suffix == ".toml")
    assert np.all(np.isinf(loaded.joint_lower)) and np.all(np.isinf(loaded.joint_upper))  # continuous joints stay continuous
    q = np.deg2rad([79.0, 97.97, -30.0, 45.0])
    np.testing.assert_allclose(ff.generalized_jacobian(loaded, q), ff.generalized_jacobian(model, q), rtol=0, atol=1e-12)


EXAMPLE_FILES = {
    "papadopoulos1991.toml": ff.models.papadopoulos1991,
    "papadopoulos1992_two_arm.toml": ff.models.papadopoulos1992,
    "papadopoulos1992_one_arm.toml": lambda: ff.models.papadopoulos1992(arms=1),
}


@pytest.mark.parametrize("filename", list(EXAMPLE_FILES))
def test_example_model_files_equal_the_built_in_models(filename: str) -> None:
    loaded = ff.load(EXAMPLES / filename)
    built_in = EXAMPLE_FILES[filename]()
    assert loaded.name == built_in.name
    # The built-in link inertias are computed (m * 0.05**2 / 2 = 0.05000000000000001); the files hold
    # the decimal values, hence 1e-12 and not bitwise.
    assert_same_model(loaded, built_in)
    assert loaded.is_planar
    q = np.linspace(-1.0, 1.0, loaded.n_joints)
    np.testing.assert_allclose(ff.system_inertia_matrix(loaded, q), ff.system_inertia_matrix(built_in, q), rtol=1e-12, atol=1e-12)


def test_every_example_model_file_is_tested() -> None:
    assert sorted(p.name for p in EXAMPLES.glob("*.toml")) == sorted(EXAMPLE_FILES)


@pytest.mark.parametrize("suffix", [".toml", ".urdf"])
def test_save_refuses_to_overwrite(tmp_path: Path, suffix: str) -> None:
    path = tmp_path / f"model{suffix}"
    path.write_text("keep me", encoding="utf-8")
    with pytest.raises(FileExistsError, match="overwrite"):
        ff.save(ff.models.papadopoulos1991(), path)
    assert path.read_text(encoding="utf-8") == "keep me"
    ff.save(ff.models.papadopoulos1991(), path, overwrite=True)
    assert_same_model(ff.load(path), ff.models.papadopoulos1991(), end_effector_names=suffix == ".toml")


def test_save_refuses_an_unknown_extension(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"\.toml or \.urdf"):
        ff.save(ff.models.papadopoulos1991(), tmp_path / "model.yaml")
    assert not (tmp_path / "model.yaml").exists()
