"""Model files by every path a user types (issue 40): relative to the working directory, with spaces and accents, and
through a symbolic link to a file in another folder; for each source (TOML, URDF, MJCF) and each way in (``ff.load``,
``freefloat inspect``, ``workspace``, ``specialise``, a simulation scenario's and a capture scenario's ``model``).

The MJCF file reads an ``<include>`` and a mesh (``meshdir``) relative to the folder of the path it is named by, as
MuJoCo does: through a link they are found next to the link, not next to the file it points at (docs/model-files.md,
"Paths"); a scenario's model likewise, next to the scenario as named. Every test runs in ``tmp_path/work``; the files
lie in other folders.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

import freefloat as ff
from freefloat.cli import app

ROOT = Path(__file__).resolve().parents[2]
ONE_ARM = ROOT / "examples" / "models" / "papadopoulos1992_one_arm.toml"  # the 1992 §V system
CAPTURE = ROOT / "examples" / "scenarios" / "papadopoulos1992_capture.toml"

# the same system in MuJoCo's format: link 2 in an included file, a mesh on the spacecraft (both relative to this file)
MJCF = """<mujoco>
  <compiler meshdir="meshes"/>
  <asset><mesh name="tetra" file="tetra.obj"/></asset>
  <worldbody>
    <body name="spacecraft"><freejoint/><inertial pos="0 0 0" mass="400" diaginertia="66.67 66.67 66.67"/>
      <geom type="mesh" mesh="tetra"/>
      <body name="arm1_link1" pos="0.5 0 0"><joint name="arm1_q1" type="hinge" axis="0 0 1"/>
        <inertial pos="0.5 0 0" mass="40" diaginertia="0.05 3.33 3.33"/>
        <include file="parts/link2.xml"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
LINK2 = """<mujoco><body name="arm1_link2" pos="1 0 0"><joint name="arm1_q2" type="hinge" axis="0 0 1"/>
  <inertial pos="0.5 0 0" mass="30" diaginertia="0.0375 2.5 2.5"/><site name="arm1_ee" pos="1 0 0"/></body></mujoco>
"""
TETRA = "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"

SOURCES = ("toml", "urdf", "xml")
FORMS = ("relative", "spaces-unicode", "symlink")
runner = CliRunner()


def write_sources(folder: Path, stem: str, references: bool = True) -> None:
    """The one-arm system as ``folder/STEM.toml``, ``.urdf`` and ``.xml``, with the MJCF file's include and mesh
    (``references``) or without them."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{stem}.toml").write_text(ONE_ARM.read_text(), encoding="utf-8")
    ff.save(ff.load(ONE_ARM), folder / f"{stem}.urdf")
    (folder / f"{stem}.xml").write_text(MJCF, encoding="utf-8")
    if references:
        write_references(folder)


def write_references(folder: Path) -> None:
    """What the MJCF file refers to, in ``folder``: ``parts/link2.xml`` and ``meshes/tetra.obj``."""
    (folder / "parts").mkdir(parents=True)
    (folder / "meshes").mkdir()
    (folder / "parts" / "link2.xml").write_text(LINK2, encoding="utf-8")
    (folder / "meshes" / "tetra.obj").write_text(TETRA, encoding="utf-8")


def place(tmp_path: Path, form: str, source: str) -> tuple[str, str]:
    """Write the files for ``form``; the path of the ``source`` file as typed in ``tmp_path/work``, and as a scenario in
    ``tmp_path/scenarios`` names it."""
    if form == "relative":
        write_sources(tmp_path / "models", "arm")
        return f"../models/arm.{source}", f"../models/arm.{source}"
    if form == "spaces-unicode":
        write_sources(tmp_path / "my models", "bras_é")
        return str(tmp_path / "my models" / f"bras_é.{source}"), f"../my models/bras_é.{source}"
    write_sources(tmp_path / "real", "arm", references=False)  # the real file's folder holds no parts/ and no meshes/
    write_references(tmp_path / "elsewhere")  # the link's folder holds them (a variant of a shared model)
    link = tmp_path / "elsewhere" / f"lien.{source}"
    link.symlink_to(tmp_path / "real" / f"arm.{source}")
    return str(link), f"../elsewhere/lien.{source}"


@pytest.fixture
def work(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """``tmp_path/work``, the working directory of the test."""
    (tmp_path / "work").mkdir()
    (tmp_path / "scenarios").mkdir()
    monkeypatch.chdir(tmp_path / "work")
    return tmp_path


def assert_one_arm(model: ff.Model) -> None:
    """``model`` is the 1992 one-arm system: joints, end effector, mass, and H+ and the tip at a posture."""
    reference = ff.load(ONE_ARM)
    q = np.array([0.4, -1.1])
    assert model.joint_names == reference.joint_names and model.end_effector_names == ("arm1_ee",)
    assert model.total_mass == pytest.approx(reference.total_mass, rel=1e-12)
    np.testing.assert_allclose(ff.system_inertia_matrix(model, q), ff.system_inertia_matrix(reference, q), rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(ff.end_effector_positions(model, q), ff.end_effector_positions(reference, q), rtol=1e-12, atol=1e-12)


def invoke(*args: str) -> Any:
    result = runner.invoke(app, list(args))
    assert result.exit_code == 0, result.output
    assert "warning:" not in result.stderr and "error:" not in result.stderr, result.stderr
    return result


@pytest.mark.parametrize("source", SOURCES)
@pytest.mark.parametrize("form", FORMS)
def test_load(work: Path, form: str, source: str) -> None:
    path, _ = place(work, form, source)
    assert_one_arm(ff.load(path))
    assert_one_arm(ff.load(Path(path)))
    assert Path.cwd() == work / "work"  # the loader left the working directory as it found it


@pytest.mark.parametrize("source", SOURCES)
@pytest.mark.parametrize("form", FORMS)
def test_inspect(work: Path, form: str, source: str) -> None:
    path, _ = place(work, form, source)
    info = json.loads(invoke("inspect", path, "--json").stdout)
    assert [j["name"] for j in info["joints"]] == ["arm1_q1", "arm1_q2"]
    assert info["total_mass"] == pytest.approx(470.0, rel=1e-12)


@pytest.mark.parametrize("source", SOURCES)
@pytest.mark.parametrize("form", FORMS)
def test_workspace(work: Path, form: str, source: str) -> None:
    path, _ = place(work, form, source)
    limits = json.loads(invoke("workspace", path, "--samples", "16", "--no-piw", "--json").stdout)
    reference = json.loads(invoke("workspace", str(ONE_ARM), "--samples", "16", "--no-piw", "--json").stdout)
    assert limits["end_effectors"] == reference["end_effectors"]


@pytest.mark.parametrize("source", SOURCES)
@pytest.mark.parametrize("form", FORMS)
def test_specialise(work: Path, form: str, source: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """The model reaches the compiler (a spy here: compiling is tests/mechanics/test_specialise.py's)."""
    import freefloat.mechanics.specialised as specialised

    seen: list[ff.Model] = []
    monkeypatch.setattr(specialised, "specialise", lambda model, kinds, progress=None: seen.append(model) or {"jstar": 0.0})
    path, _ = place(work, form, source)
    invoke("specialise", path, "--kind", "jstar")
    assert len(seen) == 1
    assert_one_arm(seen[0])


@pytest.mark.parametrize("source", SOURCES)
@pytest.mark.parametrize("form", FORMS)
def test_simulation_scenario(work: Path, form: str, source: str) -> None:
    """``model = "..."`` relative to the scenario's folder, the scenario itself named relative to the working directory."""
    _, named = place(work, form, source)
    scenario = work / "scenarios" / "run.toml"
    scenario.write_text(f'model = "{named}"\nduration = 0.02\n[integrator]\nmethod = "RK4"\nfixed_step = 0.01\n', encoding="utf-8")
    invoke("simulate", "../scenarios/run.toml", "--out", "out")
    summary = json.loads((work / "work" / "out" / "trajectory.json").read_text())
    assert summary["status"] == "finished"


@pytest.mark.parametrize("source", SOURCES)
@pytest.mark.parametrize("form", FORMS)
def test_capture_scenario(work: Path, form: str, source: str) -> None:
    _, named = place(work, form, source)
    text = CAPTURE.read_text().replace('model = "papadopoulos1992-one-arm"', f'model = "{named}"')
    assert named in text
    (work / "scenarios" / "capture.toml").write_text(text, encoding="utf-8")
    result = invoke("capture", "../scenarios/capture.toml")
    assert "arm1_ee" in result.stdout and "approach" in result.stdout.lower()


def test_a_link_reads_the_mjcf_references_next_to_itself_as_mujoco_does(work: Path) -> None:
    """Through a link, the include and the mesh are read from the link's folder, where MuJoCo itself reads them
    (``from_xml_path`` of the link); a link whose folder lacks them fails in both, freefloat's error naming the include."""
    import mujoco

    link, _ = place(work, "symlink", "xml")
    assert os.readlink(link) == str(work / "real" / "arm.xml") and not (work / "real" / "parts").exists()
    model = ff.load(link)
    assert_one_arm(model)
    assert mujoco.MjModel.from_xml_path(link).nbody == model.n_bodies + 1  # MuJoCo's world body besides
    bare = work / "bare"
    bare.mkdir()
    (bare / "arm.xml").symlink_to(work / "elsewhere" / "lien.xml")  # a chain of links; no parts/ next to the first
    with pytest.raises(ValueError, match=r"parts/link2\.xml"):
        mujoco.MjModel.from_xml_path(str(bare / "arm.xml"))
    with pytest.raises(ff.ModelError, match=r"arm\.xml: MuJoCo could not compile it: .*parts/link2\.xml"):
        ff.load(bare / "arm.xml")


@pytest.mark.parametrize("source", SOURCES)
def test_a_scenario_through_a_link_finds_its_model_next_to_the_link(work: Path, source: str) -> None:
    """The scenario's ``model = "arm.EXT"`` is relative to the folder of the scenario's path as given (the rule of the
    MJCF references): next to a link to the scenario, not next to the file it points at."""
    (work / "shared").mkdir()
    real = work / "shared" / "run.toml"
    real.write_text(f'model = "arm.{source}"\nduration = 0.02\n[integrator]\nmethod = "RK4"\nfixed_step = 0.01\n', encoding="utf-8")
    write_sources(work / "variant", "arm")
    (work / "variant" / "run.toml").symlink_to(real)
    invoke("simulate", "../variant/run.toml", "--out", "out")
    assert json.loads((work / "work" / "out" / "trajectory.json").read_text())["status"] == "finished"
    (work / "lonely").mkdir()
    (work / "lonely" / "run.toml").symlink_to(real)  # no model next to this link: the one in variant/ is not found
    write_sources(work / "shared", "arm")  # nor the one next to the real file
    result = runner.invoke(app, ["simulate", "../lonely/run.toml", "--out", "out2"])
    assert result.exit_code == 1 and f"model: arm.{source}: no such model file" in result.stderr, result.output


def test_a_chain_of_links_is_named_by_the_file_it_misses(work: Path) -> None:
    """``a.urdf -> b.urdf -> gone/arm.urdf``: the message names the missing file at the end of the chain; a loop of links
    is named as a loop."""
    (work / "work" / "b.urdf").symlink_to("gone/arm.urdf")
    (work / "work" / "a.urdf").symlink_to("b.urdf")
    missing = work / "work" / "gone" / "arm.urdf"
    with pytest.raises(ff.ModelError, match=rf"^a\.urdf: is a symbolic link to {missing}, which does not exist"):
        ff.load("a.urdf")
    result = runner.invoke(app, ["inspect", "a.urdf"])
    assert result.exit_code == 1 and result.stderr.startswith(f"error: a.urdf: is a symbolic link to {missing}, which"), result.output
    (work / "work" / "loop1.xml").symlink_to("loop2.xml")
    (work / "work" / "loop2.xml").symlink_to("loop1.xml")
    with pytest.raises(ff.ModelError, match=r"^loop1\.xml: is a loop of symbolic links"):
        ff.load("loop1.xml")


@pytest.mark.parametrize("source", SOURCES)
def test_a_file_name_that_is_not_utf8_is_one_clear_error(work: Path, source: str) -> None:
    """A name made on another system (bytes that are not UTF-8: Python's surrogate escapes) is refused before any
    reader sees it (MuJoCo's parser raised a TypeError, the URDF reader called the file malformed)."""
    write_sources(work / "models", "arm")
    name = os.fsdecode(b"bras\xe9." + source.encode())  # Latin-1 e-acute
    os.link(work / "models" / f"arm.{source}", work / "models" / name)
    for given in (f"../models/{name}", Path("..") / "models" / name):
        with pytest.raises(ff.ModelError, match=rf"^\.\./models/bras\\xe9\.{source}: the file name is not valid UTF-8; rename"):
            ff.load(given)
    result = runner.invoke(app, ["inspect", f"../models/{name}"])
    assert result.exit_code == 1 and result.stderr.splitlines() == [
        f"error: ../models/bras\\xe9.{source}: the file name is not valid UTF-8; rename the file (and its folders) to a UTF-8 name"
    ], result.output


@pytest.mark.parametrize("source", SOURCES)
def test_the_home_folder_is_expanded(work: Path, source: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """``~/models/arm.EXT`` (quoted, so no shell expanded it) in ff.load, inspect and a scenario's model."""
    monkeypatch.setenv("HOME", str(work))
    write_sources(work / "models", "arm")
    assert_one_arm(ff.load(f"~/models/arm.{source}"))
    info = json.loads(invoke("inspect", f"~/models/arm.{source}", "--json").stdout)
    assert info["total_mass"] == pytest.approx(470.0, rel=1e-12)
    (work / "scenarios" / "run.toml").write_text(
        f'model = "~/models/arm.{source}"\nduration = 0.02\n[integrator]\nmethod = "RK4"\nfixed_step = 0.01\n', encoding="utf-8"
    )
    invoke("simulate", "~/scenarios/run.toml", "--out", "~/out")
    assert json.loads((work / "out" / "trajectory.json").read_text())["status"] == "finished"


def test_a_path_with_backslashes_that_names_nothing_hints_at_the_separator(work: Path) -> None:
    write_sources(work / "work" / "models", "arm")
    with pytest.raises(ff.ModelError, match=r"^models\\arm\.urdf: file not found \(use / as the separator"):
        ff.load("models\\arm.urdf")
    result = runner.invoke(app, ["inspect", "models\\arm.urdf"])
    assert result.exit_code == 1 and "no such model file; use / as the separator" in result.stderr, result.output
    assert_one_arm(ff.load("models/arm.urdf"))
