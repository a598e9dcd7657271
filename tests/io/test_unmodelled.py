"""Nothing silently dropped (issue 21, item 4): an element of a URDF or MJCF file that acts on free-floating
dynamics and is not modelled warns once, naming it, is recorded in ``Model.unmodelled`` and listed by
``inspect``; ``strict`` refuses it; elements without such an effect load without a word. The table of
elements (``freefloat.io.unmodelled.ELEMENTS``) is the one docs/model-files.md lists.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import pytest
from test_model_corrections import arm, joint, urdf
from typer.testing import CliRunner

import freefloat as ff
from freefloat.cli import app
from freefloat.core.errors import ModelCorrectionWarning, UnmodelledElementWarning
from freefloat.io.unmodelled import _MJCF_FINDERS, _URDF_FINDERS, ELEMENTS, NOT_MODELLED, STATUSES

DOCS = Path(__file__).resolve().parents[2] / "docs" / "model-files.md"


def mjcf(
    tmp_path: Path, joint_attrs: str = "", body: str = "", after: str = "", option: str = "", root: str = '<freejoint name="root"/>'
) -> Path:
    """A spacecraft with two hinged links; ``joint_attrs`` go on the shoulder, ``body`` into the last link,
    ``after`` after ``<worldbody>``, ``option`` into ``<option>``."""
    path = tmp_path / "arm.xml"
    path.write_text(
        f"""<mujoco model="arm">
  <compiler angle="radian"/>
  <option gravity="0 0 -9.81" {option}/>
  <worldbody>
    <light pos="0 0 3"/>
    <camera name="overview" pos="0 -3 1"/>
    <body name="bus">
      {root}
      <geom type="box" size="0.5 0.5 0.5" mass="400"/>
      <body name="upper" pos="0.6 0 0">
        <joint name="shoulder" axis="0 0 1" {joint_attrs}/>
        <geom type="capsule" fromto="0 0 0 0.8 0 0" size="0.05" mass="10"/>
        <body name="fore" pos="0.8 0 0">
          <joint name="elbow" axis="0 0 1" range="-1.5 1.5"/>
          <geom type="capsule" fromto="0 0 0 0.6 0 0" size="0.04" mass="5"/>
          <site name="grip" pos="0.6 0 0"/>
          {body}
        </body>
      </body>
    </body>
  </worldbody>
  {after}
</mujoco>
""",
        encoding="utf-8",
    )
    return path


def loaded(path: Path, **kwargs: object) -> tuple[ff.Model, list[str]]:
    """The model and the texts of the UnmodelledElementWarnings its loading gave (any other warning fails the test)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = ff.load(path, **kwargs)  # type: ignore[arg-type]
    others = [w for w in caught if not issubclass(w.category, UnmodelledElementWarning)]
    assert not others, [str(w.message) for w in others]
    return model, [str(w.message) for w in caught]


# ----------------------------------------------------------------------------- the table
def test_the_table_is_complete_and_documented() -> None:
    docs = DOCS.read_text(encoding="utf-8")
    keys = [row.key for row in ELEMENTS]
    assert len(keys) == len(set(keys))
    for row in ELEMENTS:
        assert row.status in STATUSES, row
        status = "**not modelled: warns**" if row.status == NOT_MODELLED else row.status
        assert f"| `{row.element}` | {status} |" in docs, f"docs/model-files.md does not list {row.file} {row.element} as {status}"
        finders = _URDF_FINDERS if row.file == "URDF" else _MJCF_FINDERS
        if row.status == NOT_MODELLED:
            assert row.key in finders, f"{row.key} is not modelled and nothing looks for it"
    assert set(_URDF_FINDERS) | set(_MJCF_FINDERS) <= set(keys)
    assert issubclass(UnmodelledElementWarning, ModelCorrectionWarning)  # the CLI prints it, strict-style filters catch it


# ----------------------------------------------------------------------------- MJCF
MJCF_CASES = {
    "free joint": (
        {"root": '<joint name="root" type="free" armature="0.02"/>'},
        "MJCF <freejoint> armature, damping, frictionloss",
        "joint 'root' armature=0.02",
    ),
    "ref": ({"joint_attrs": 'ref="0.5"'}, "MJCF <joint ref>", "joint 'shoulder' ref=0.5 rad"),
    "tendon": (
        {"after": '<tendon><fixed name="couple"><joint joint="shoulder" coef="1"/><joint joint="elbow" coef="-1"/></fixed></tendon>'},
        "MJCF <tendon>",
        "tendon 'couple'",
    ),
    "equality connect": (
        {"after": '<equality><connect name="loop" body1="fore" body2="bus" anchor="0.6 0 0"/></equality>'},
        "MJCF <equality> connect, weld, tendon, flex",
        "equality 'loop' (connect)",
    ),
    "gear": (
        {"after": '<actuator><motor name="m1" joint="shoulder" gear="120"/></actuator>'},
        "MJCF <actuator gear>",
        "actuator 'm1' gear=120",
    ),
    "servo": (
        {"after": '<actuator><position name="p2" joint="elbow" kp="30"/></actuator>'},
        "MJCF <position>, <velocity>, <general biasprm>",
        "actuator 'p2' biasprm=0 -30 0",
    ),
    "site actuator": (
        {"after": '<actuator><motor name="thrust" site="grip" gear="1 0 0 0 0 0"/></actuator>'},
        "MJCF <actuator> on a tendon, site, body or slider-crank",
        "actuator 'thrust' (site)",
    ),
    "fluid": ({"option": 'density="1.2" viscosity="1e-5"'}, "MJCF <option density viscosity>", "density=1.2, viscosity=1e-05"),
}


@pytest.mark.parametrize("case", MJCF_CASES)
def test_mjcf_element_that_is_not_modelled_warns_once_is_recorded_and_strict_refuses_it(tmp_path: Path, case: str) -> None:
    parts, element, item = MJCF_CASES[case]
    path = mjcf(tmp_path, **parts)
    model, texts = loaded(path)
    assert len(texts) == 1, texts
    assert texts[0].startswith(f"{path}: {element}") and "is not modelled and was dropped" in texts[0], texts[0]
    assert item in texts[0], texts[0]
    assert "strict=True" in texts[0]
    assert [u["element"] for u in model.unmodelled] == [texts[0].split(": ")[1].split(" is not modelled")[0]]
    assert item in ", ".join(model.unmodelled[0]["items"])
    with pytest.raises(ff.ModelError, match=re.escape(element)) as refused:
        ff.load(path, strict=True)
    assert item in str(refused.value) and "strict=False" in str(refused.value) and "remove it" in str(refused.value)


def test_mjcf_one_warning_lists_every_joint(tmp_path: Path) -> None:
    path = mjcf(tmp_path, body="", after="<default><joint ref='0.5'/></default>")
    _, texts = loaded(path)
    assert len(texts) == 1
    assert "joint 'shoulder' ref=0.5 rad, joint 'elbow' ref=0.5 rad" in texts[0], texts


def test_mjcf_with_only_ignored_elements_loads_without_a_word(tmp_path: Path) -> None:
    """Geometry, contacts, cameras, lights, Earth's gravity, gravity compensation, control ranges, limit softness,
    a joint motor with gear 1, an actuator's gain and activation dynamics, sensors and keyframes: no effect on
    freefloat's dynamics, no warning."""
    path = mjcf(
        tmp_path,
        joint_attrs='range="-1 1" solreflimit="0.05 1" margin="0.01" actuatorfrcrange="-50 50" damping="0" armature="0"',
        body='<geom type="sphere" size="0.05" contype="1" conaffinity="1" friction="0.5"/><camera name="wrist_cam"/>',
        after="""<actuator><motor name="m1" joint="shoulder" gear="1" ctrlrange="-10 10" forcerange="-20 20"/>
    <general name="g2" joint="elbow" gainprm="5" dyntype="filter" dynprm="0.1"/></actuator>
  <sensor><jointpos joint="elbow"/></sensor>
  <contact><exclude body1="bus" body2="fore"/></contact>
  <keyframe><key name="home" qpos="0 0 0 1 0 0 0 0.1 0.2"/></keyframe>""",
        option='timestep="0.001" integrator="RK4" wind="1 0 0"',
    )
    text = path.read_text(encoding="utf-8").replace('<body name="bus">', '<body name="bus" gravcomp="1">')
    path.write_text(text, encoding="utf-8")
    model, texts = loaded(path)
    assert texts == [] and model.unmodelled == ()
    ff.load(path, strict=True)


# ----------------------------------------------------------------------------- URDF
def test_joint_dynamics_of_the_files_are_read_without_a_warning(tmp_path: Path) -> None:
    """Modelled since issue 21: MJCF armature, damping, frictionloss of hinges and slides, URDF <dynamics damping friction>."""
    path = mjcf(tmp_path, joint_attrs='armature="0.02" damping="0.5" frictionloss="0.3"')
    model, texts = loaded(path)
    assert texts == []
    shoulder = model.joint_names.index("shoulder")
    assert (model.joint_armature[shoulder], model.joint_damping[shoulder], model.joint_friction[shoulder]) == (0.02, 0.5, 0.3)
    assert model.joint_armature.sum() == 0.02 and not model.unmodelled
    parts = arm()
    parts[3] = joint("q1", "revolute", "bus", "l1", extra='<dynamics damping="0.7" friction="0.2"/>')
    model, texts = loaded(urdf(tmp_path, *parts))
    assert texts == [] and (model.joint_damping[0], model.joint_friction[0]) == (0.7, 0.2) and not model.joint_armature.any()
    # a joint coupling of first order is a mimic joint (issue 21, item 1), read without a word
    coupled, texts = loaded(mjcf(tmp_path, after='<equality><joint name="mimic" joint1="elbow" joint2="shoulder"/></equality>'))
    assert texts == [] and [(r["joint"], r["leader"]) for r in coupled.mimic] == [("elbow", "shoulder")]
    assert coupled.joint_names == ("shoulder",) and not coupled.unmodelled


TRANSMISSION = """<transmission name="{name}"><type>transmission_interface/SimpleTransmission</type>
  <joint name="{joint}"><hardwareInterface>hardware_interface/EffortJointInterface</hardwareInterface></joint>
  <actuator name="{name}_motor"><mechanicalReduction>{reduction}</mechanicalReduction></actuator></transmission>"""


def test_urdf_transmission_with_a_reduction_warns_and_strict_refuses_it(tmp_path: Path) -> None:
    path = urdf(
        tmp_path,
        *arm(TRANSMISSION.format(name="t1", joint="q1", reduction="160"), TRANSMISSION.format(name="t2", joint="s2", reduction="1")),
    )
    model, texts = loaded(path)
    assert len(texts) == 1 and "URDF <transmission> <mechanicalReduction> other than 1 is not modelled" in texts[0], texts
    assert "transmission 't1' (joint 'q1') mechanicalReduction=160" in texts[0] and "'t2'" not in texts[0]
    assert model.unmodelled[0]["items"] == ["transmission 't1' (joint 'q1') mechanicalReduction=160"]
    with pytest.raises(ff.ModelError, match="mechanicalReduction=160"):
        ff.load(path, strict=True)


def test_urdf_with_only_ignored_elements_loads_without_a_word(tmp_path: Path) -> None:
    """Visual and collision geometry, effort and velocity limits, safety controller, calibration, gazebo, a
    transmission without reduction, zero damping and friction, dynamics of a fixed joint: no warning."""
    visual = (
        '<link name="bus"><visual><geometry><box size="1 1 1"/></geometry><material name="grey"><color rgba="0.5 0.5 0.5 1"/>'
        '</material></visual><collision><geometry><box size="1 1 1"/></geometry></collision><inertial><origin xyz="0 0 0"/>'
        '<mass value="500"/><inertia ixx="80" iyy="90" izz="60" ixy="0" ixz="0" iyz="0"/></inertial></link>'
    )
    parts = arm(
        '<link name="tool"/>',
        joint("tool_mount", "fixed", "l2", "tool", extra='<dynamics damping="3"/>'),
        TRANSMISSION.format(name="t1", joint="q1", reduction="1"),
        '<gazebo reference="l1"><material>Gazebo/Grey</material></gazebo>',
    )
    parts[0] = visual
    parts[3] = joint(
        "q1",
        "revolute",
        "bus",
        "l1",
        extra='<dynamics damping="0.0" friction="0.0"/><safety_controller soft_lower_limit="-0.9" soft_upper_limit="0.9"'
        ' k_position="10" k_velocity="1"/><calibration rising="0.1"/>',
    )
    path = urdf(tmp_path, *parts)
    model, texts = loaded(path)
    assert texts == [] and model.unmodelled == ()
    ff.load(path, strict=True)


# ----------------------------------------------------------------------------- inspect
@pytest.mark.filterwarnings("always::freefloat.core.errors.UnmodelledElementWarning")  # its warning line is what it checks
def test_inspect_lists_what_was_dropped_and_strict_refuses(tmp_path: Path) -> None:
    path = mjcf(tmp_path, joint_attrs='ref="0.3"', after='<actuator><motor name="m1" joint="shoulder" gear="120"/></actuator>')
    runner = CliRunner()
    result = runner.invoke(app, ["inspect", str(path)])
    assert result.exit_code == 0, result.output
    assert "warning: " in result.output and "MJCF <joint ref> is not modelled and was dropped" in result.output
    assert re.search(r"not modelled +2 kind\(s\) dropped \(listed below\)", result.output), result.output
    table = result.output.split("Not modelled: dropped when loading", 1)[1]
    assert "MJCF <joint ref>" in table and "joint 'shoulder' ref=0.3 rad" in table
    assert "actuator 'm1' gear=120" in table
    as_json = runner.invoke(app, ["inspect", "--json", str(path)])
    assert '"unmodelled"' in as_json.output and "joint 'shoulder' ref=0.3 rad" in as_json.output
    refused = runner.invoke(app, ["inspect", "--strict", str(path)])
    assert refused.exit_code == 1
    assert "error: " in refused.output and "MJCF <joint ref>: is not modelled by freefloat" in refused.output


def test_inspect_of_a_clean_file_says_none(tmp_path: Path) -> None:
    result = CliRunner().invoke(app, ["inspect", str(mjcf(tmp_path))])
    assert result.exit_code == 0, result.output
    assert re.search(r"not modelled +none", result.output) and "Not modelled: dropped" not in result.output
    assert "warning:" not in result.output
