"""The project's bad-input table (issue "What a user still meets"): every case with its expected outcome.

Each API case must raise the named exception class (or warning) with a message that matches (one clear sentence that
names the field and the fix); each CLI case must exit 1 with a single ``error: ...`` line that matches (exit 2 with
click's usage message for the few a parser refuses). For every case: no traceback, no hang (a 60 s alarm), no input
file changed, and nothing written outside the output folder (the case runs in a scratch working directory whose
listing, and that of the bad files, is compared before and after; a refused run leaves no output folder either).

The classes of the issue: malformed, truncated, binary and empty files, wrong types, NaN/inf/huge values, wrong
shapes, unknown names, out-of-range end effectors, odd output paths, huge durations and sample counts, stiff gains,
non-physical inertias, loops, ball joints. On the command line they are crossed with the commands: every bad model
file (:data:`BAD_MODELS`) given to ``inspect``, ``specialise`` and ``workspace`` and named by a simulation and a
capture scenario; every key of both scenario schemas broken (:data:`SIMULATION_EDITS`, :data:`CAPTURE_EDITS`); every
numeric option given NaN, infinities, negative, zero, huge and text values; ``-e`` on every command; every ``--out``
given an unwritable, odd or occupied folder (:data:`BAD_OUTS`). Each case must fail before the work: none runs long.

``tests/sweep_bad_inputs.py`` runs the same table and prints the issue's summary (clear / unclear / traceback /
silent / hang).
"""

from __future__ import annotations

import json
import os
import re
import signal
import tomllib
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

import bad_inputs_campaigns
import bad_inputs_capture
import bad_inputs_models
import freefloat as ff
from bad_case import SCENARIO_FILES, Case, api, cli
from bad_case import add_file as _add
from freefloat.cli import app
from freefloat.core.errors import MemoryBudgetError, ModelCorrectionWarning, ModelError, SettingError, ShapeError, UnknownNameError

ROOT = Path(__file__).resolve().parents[1]
ARM_URDF = ROOT / "examples" / "models" / "six_dof_arm.urdf"
TOML = ROOT / "examples" / "models" / "papadopoulos1992_two_arm.toml"
SCENARIO = ROOT / "examples" / "scenarios" / "papadopoulos1992_joint_pd.toml"
CAPTURE = ROOT / "examples" / "scenarios" / "papadopoulos1992_capture.toml"
MOVING = ROOT / "examples" / "scenarios" / "papadopoulos1992_capture_moving.toml"

ARM = ARM_URDF.read_text()
MJCF = (  # a bus and one link on a hinge, in MuJoCo's format
    '<mujoco><worldbody><body name="bus"><freejoint/><inertial pos="0 0 0" mass="100" diaginertia="10 10 10"/>'
    '<body name="a" pos="1 0 0"><joint name="j" type="hinge" axis="0 0 1"/><inertial pos="0.5 0 0" mass="1" diaginertia="0.1 0.1 0.1"/>'
    '<site name="tip" pos="1 0 0"/></body></body></worldbody></mujoco>'
)
SIM = SCENARIO.read_text()
CAP = CAPTURE.read_text()


def _edit(text: str, *changes: tuple[str, str]) -> str:
    """``text`` with each (old, new) replaced once; an ``old`` that is not there is an error (the case would test nothing)."""
    for old, new in changes:
        if old not in text:
            raise ValueError(f"{old!r} is not in the file the case edits")
        text = text.replace(old, new, 1)
    return text


def _joint(parent: str, child: str) -> tuple[str, str]:
    """An extra revolute joint ``loop`` from ``parent`` to ``child`` of the six-DOF arm (an edit for :func:`_edit`)."""
    return "</robot>", (
        f'<joint name="loop" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>'
    )


# the files a run of freefloat writes, made by hand (no manifest) in "earlier/", listed with wrong checksums in "changed/"
_OUTPUTS = ("README.md", "report.json", "workspace.json", "capture.json", "trajectory.json")
_MANIFEST = {"written_by": "freefloat", "files": {name: {"sha256": "0" * 64, "command": "demo"} for name in _OUTPUTS}}

# files the cases read, made in the scratch folder ("files/NAME")
BAD_FILES: dict[str, str | bytes] = {
    "empty.toml": "",
    "empty.urdf": "",
    "binary.urdf": bytes(range(256)) * 4,
    "binary.toml": b"\x00\xff\xfe" * 100,
    "truncated.toml": TOML.read_text().split("# ---- manipulator 1")[0],  # cut after the spacecraft body: no joints left
    "cut_mid_table.toml": TOML.read_text()[:1500],
    "no_joints.urdf": '<robot name="bus"><link name="bus"><inertial><mass value="500"/>'
    '<inertia ixx="80" iyy="80" izz="80" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>',
    "malformed.urdf": "<robot name='x'><link name='a'></robot>",
    "no_limit.urdf": ARM.replace('<limit lower="-3.0" upper="3.0" effort="100" velocity="1"/>', "", 1),
    "ball.urdf": _edit(ARM, ('type="revolute"', 'type="spherical"')),
    "floating.urdf": _edit(ARM, ('type="revolute"', 'type="floating"')),
    "negative_mass.urdf": ARM.replace('<mass value="', '<mass value="-', 2),
    "loop.urdf": _edit(ARM, _joint("tool0", "spacecraft")),  # back to the root: every body has a parent
    "two_parents.urdf": _edit(ARM, _joint("tool0", "shoulder")),  # a second parent for the shoulder
    "unknown_link.urdf": _edit(ARM, _joint("tool0", "bus")),
    "nan_inertia.urdf": _edit(ARM, ('ixx="80"', 'ixx="nan"')),
    "huge_inertia.urdf": _edit(ARM, ('ixx="80"', 'ixx="1e300"')),
    "inf_origin.urdf": _edit(ARM, ('<origin xyz="0 0 0"/>', '<origin xyz="inf 0 0"/>')),
    "nan_joint_origin.urdf": _edit(ARM, ('<origin xyz="0.9 0 0.5"', '<origin xyz="nan 0 0.5"')),
    "massless.urdf": _edit(ARM, ('<mass value="500"/>', "<mass/>")),
    "text_mass.urdf": _edit(ARM, ('<mass value="500"/>', '<mass value="heavy"/>')),
    "text_axis.urdf": _edit(ARM, ('<axis xyz="0 0 1"/>', '<axis xyz="0 0 up"/>')),
    "no_parent.urdf": _edit(ARM, ('<parent link="spacecraft"/>', "")),
    "parent_without_link.urdf": _edit(ARM, ('<parent link="spacecraft"/>', "<parent/>")),
    "triangle.urdf": _edit(ARM, ('ixx="80"', 'ixx="10000"')),  # corrected with a warning; refused with --strict
    "geared.urdf": _edit(  # dropped with a warning; refused with --strict
        ARM,
        (
            "</robot>",
            '<transmission name="t"><joint name="shoulder_yaw"/><actuator name="m"><mechanicalReduction>100'
            "</mechanicalReduction></actuator></transmission></robot>",
        ),
    ),
    "model.obj": "v 0 0 0\n",
    "q_deg_short.toml": SIM.replace("q_deg = [0.0, 90.0, 180.0, -90.0]", "q_deg = [0.0, 90.0]"),
    "q_and_q_deg.toml": SIM.replace("q_deg = [0.0, 90.0, 180.0, -90.0]", "q_deg = [0.0, 90.0, 180.0, -90.0]\nq = [0, 0, 0, 0]"),
    "unknown_joint_ref.toml": SIM.replace("arm1_q1 = 40.0", "arm9_q1 = 40.0"),
    "rk4_without_step.toml": SIM.replace("fixed_step = 0.002                   # s\n", ""),
    "step_not_dividing.toml": SIM.replace("fixed_step = 0.002", "fixed_step = 0.003"),
    "unknown_method.toml": SIM.replace('method = "RK4"', 'method = "Euler"'),
    "unknown_controller.toml": SIM.replace('type = "joint_pd"', 'type = "lqr"'),
    "negative_limit.toml": SIM.replace("joint_torque = 10.0", "joint_torque = -10.0"),
    "text_gain.toml": SIM.replace("kp = 20.0", 'kp = "stiff"'),
    "bool_gain.toml": SIM.replace("kp = 20.0", "kp = true"),
    "no_model.toml": SIM.replace('model = "papadopoulos1992"', ""),
    "missing_model_file.toml": SIM.replace('model = "papadopoulos1992"', 'model = "nothere.urdf"'),
    "malformed_scenario.toml": SIM.replace("[initial]", "[initial"),
    "capture_inertia_text.toml": CAP.replace("inertia = 25.0", 'inertia = "heavy"'),
    "capture_path_1d.toml": CAP.replace("points = [[0.0, 0.0], [0.0, 0.25]]", "points = [0.0, 0.25]"),
    "capture_path_nan.toml": CAP.replace("points = [[0.0, 0.0], [0.0, 0.25]]", "points = [[0.0, nan], [0.0, 0.25]]"),
    "capture_bad_rule.toml": CAP.replace('rule = "perpendicular"', 'rule = "diagonal"'),
    "capture_singularity_key.toml": CAP + '\n[singularity]\nrows = "position"\ncolour = "red"\n',
    "capture_limit_order.toml": CAP.replace("# [joint_limits_deg]", "[joint_limits_deg]\narm1_q1 = [50.0, -50.0]\n#"),
    "capture_limit_unknown_joint.toml": CAP.replace("# [joint_limits_deg]", "[joint_limits_deg]\narm9_q1 = [-50.0, 50.0]\n#"),
    "broken.xml": '<mujoco><worldbody><body name="a"><joint type="hinge"/><geom size="x"/></body></worldbody></mujoco>',
    "not_mujoco.xml": "<html><body>not a robot</body></html>",
    "ball.xml": _edit(MJCF, ('type="hinge"', 'type="ball"')),
    "huge_mass.xml": _edit(MJCF, ('mass="1"', 'mass="1e12"')),
    "ref.xml": _edit(MJCF, ('type="hinge"', 'type="hinge" ref="0.5"')),  # dropped with a warning; refused with --strict
    "negative_damping.xml": _edit(MJCF, ('type="hinge"', 'type="hinge" damping="-0.5"')),
    "trajectory.csv": "t,q[a]\n0,0\n",
    "trajectory.npz": "not an npz file",
    "old.gif": b"GIF89a",  # an animation of the user's: --animate never replaces it
    **{f"earlier/{name}": "{}\n" for name in _OUTPUTS},
    **{f"changed/{name}": "{}\n" for name in _OUTPUTS},
    "changed/freefloat-manifest.json": json.dumps(_MANIFEST),
}

# (id, MODEL as the command line gives it, as a scenario in files/sim or files/cap names it, what the error says)
BAD_MODELS = [
    ("missing", "nothere.urdf", "nothere.urdf", r"nothere\.urdf: no such model file"),
    ("unknown-name", "papadopoulos1993", "papadopoulos1993", r"MODEL 'papadopoulos1993': .*did you mean 'papadopoulos1992'"),
    ("directory", "{files}", "..", r"is not a file; give the path of a \.toml"),
    ("device", "/dev/null", "/dev/null", r"/dev/null: is not a file"),
    ("empty-toml", "{files}/empty.toml", "../empty.toml", r"empty\.toml: bodies: is missing or empty"),
    ("empty-urdf", "{files}/empty.urdf", "../empty.urdf", r"empty\.urdf: malformed URDF XML: no element found"),
    ("binary-urdf", "{files}/binary.urdf", "../binary.urdf", r"binary\.urdf: malformed URDF XML: not well-formed"),
    ("binary-toml", "{files}/binary.toml", "../binary.toml", r"binary\.toml: is not UTF-8 text"),
    ("truncated-toml", "{files}/truncated.toml", "../truncated.toml", r"truncated\.toml: has no movable joint"),
    ("cut-mid-table", "{files}/cut_mid_table.toml", "../cut_mid_table.toml", r"cut_mid_table\.toml: malformed TOML: Unterminated string"),
    ("no-joints", "{files}/no_joints.urdf", "../no_joints.urdf", r"no_joints\.urdf: has no movable joint"),
    ("malformed-urdf", "{files}/malformed.urdf", "../malformed.urdf", r"malformed\.urdf: malformed URDF XML: mismatched tag"),
    (
        "ball-joint",
        "{files}/ball.urdf",
        "../ball.urdf",
        r"ball\.urdf: joint\[0\] \(shoulder_yaw\)\.type: unsupported joint type 'spherical'",
    ),
    (
        "floating-joint",
        "{files}/floating.urdf",
        "../floating.urdf",
        r"floating\.urdf: joint\[0\] \(shoulder_yaw\)\.type: 'floating': a floating",
    ),
    (
        "negative-mass",
        "{files}/negative_mass.urdf",
        "../negative_mass.urdf",
        r"negative_mass\.urdf: link\[0\] \(spacecraft\)\.mass: must be positive",
    ),
    ("massless", "{files}/massless.urdf", "../massless.urdf", r"massless\.urdf: bodies \(spacecraft\)\.mass: a massless body"),
    (
        "text-mass",
        "{files}/text_mass.urdf",
        "../text_mass.urdf",
        r"text_mass\.urdf: link\[0\] \(spacecraft\)\.inertial\.mass\.value: cannot read 'heavy' as a number; write a number",
    ),
    (
        "text-axis",
        "{files}/text_axis.urdf",
        "../text_axis.urdf",
        r"text_axis\.urdf: joint\[0\] \(shoulder_yaw\)\.axis\.xyz: cannot read 'up' \(in xyz='0 0 up'\) as a number",
    ),
    (
        "no-parent",
        "{files}/no_parent.urdf",
        "../no_parent.urdf",
        r"no_parent\.urdf: joint\[0\] \(shoulder_yaw\)\.parent: is missing; name the joint's parent link",
    ),
    (
        "parent-without-link",
        "{files}/parent_without_link.urdf",
        "../parent_without_link.urdf",
        r"parent_without_link\.urdf: joint\[0\] \(shoulder_yaw\)\.parent: has no link attribute",
    ),
    (
        "nan-inertia",
        "{files}/nan_inertia.urdf",
        "../nan_inertia.urdf",
        r"nan_inertia\.urdf: link\[0\] \(spacecraft\)\.inertia: has NaN or infinite",
    ),
    (
        "huge-inertia",
        "{files}/huge_inertia.urdf",
        "../huge_inertia.urdf",
        r"huge_inertia\.urdf: link\[0\] \(spacecraft\)\.inertia: 1e\+300 kg m\^2 is above",
    ),
    (
        "inf-origin",
        "{files}/inf_origin.urdf",
        "../inf_origin.urdf",
        r"inf_origin\.urdf: link\[0\] \(spacecraft\)\.inertial\.origin: has NaN or infinite",
    ),
    (
        "nan-joint-origin",
        "{files}/nan_joint_origin.urdf",
        "../nan_joint_origin.urdf",
        r"joint\[0\] \(shoulder_yaw\)\.origin: has NaN or infinite",
    ),
    ("loop", "{files}/loop.urdf", "../loop.urdf", r"loop\.urdf: joints: every body has a parent joint, so the joints form a cycle"),
    (
        "two-parents",
        "{files}/two_parents.urdf",
        "../two_parents.urdf",
        r"two_parents\.urdf: joints\[7\] \(loop\)\.child: body 'shoulder' already has",
    ),
    (
        "unknown-link",
        "{files}/unknown_link.urdf",
        "../unknown_link.urdf",
        r"unknown_link\.urdf: joints\[7\] \(loop\)\.child: unknown body 'bus'",
    ),
    ("unknown-suffix", "{files}/model.obj", "../model.obj", r"model\.obj: unknown model file type '\.obj'"),
    ("broken-mjcf", "{files}/broken.xml", "../broken.xml", r"broken\.xml: MuJoCo could not compile it"),
    ("mjcf-ball-joint", "{files}/ball.xml", "../ball.xml", r"ball\.xml: body 'a': joint 'j'\.type: a ball joint inside the tree"),
    ("mjcf-huge-mass", "{files}/huge_mass.xml", "../huge_mass.xml", r"huge_mass\.xml: bodies\[1\] \(a\)\.mass: 1e\+12 kg is above"),
    (
        "xml-not-a-robot",
        "{files}/not_mujoco.xml",
        "../not_mujoco.xml",
        r"not_mujoco\.xml: the root element <html> is neither a URDF <robot> nor",
    ),
]


# scenario files that one case reads each ("files/sim/NAME", "files/cap/NAME"): made only for the case that names them
SCENARIO_FILES.update(
    {
        "sim/arm.toml": f'model = "{ARM_URDF.as_posix()}"\nduration = 1.0\n',  # valid: the six-DOF arm file, for -e
        "cap/arm.toml": f'model = "{ARM_URDF.as_posix()}"\n[payload]\nmass = 10.0\ninertia = 1.0\n'
        "[path]\npoints = [[1.0, 0.0, 0.0], [1.0, 0.1, 0.0]]\n",
    }
)


for _id, _, _name, _ in BAD_MODELS:
    _add(f"sim/model-{_id}.toml", _edit(SIM, ('model = "papadopoulos1992"', f'model = "{_name}"')))
    _add(f"cap/model-{_id}.toml", _edit(CAP, ('model = "papadopoulos1992-one-arm"', f'model = "{_name}"')))

# ---- scenario files with one key broken: (id, what the error says, edits of the example scenario)
_QDEG = "q_deg = [0.0, 90.0, 180.0, -90.0]"
_INITIAL = "[initial]\n" + _QDEG
_PD = SIM[SIM.index("[controller]") : SIM.index("[limits]")]  # replaced by an [actuation] table
_RK4 = ("fixed_step = 0.002                   # s\n", "")  # with method = "DOP853": an adaptive run
_LIMIT = "joint_torque = 10.0"  # the last table: [outputs] and [joint_limits] go after it


def _act(body: str) -> tuple[str, str]:
    return _PD, f"[actuation]\n{body}\n\n"


def _after(anchor: str, lines: str) -> tuple[str, str]:
    return anchor, f"{anchor}\n{lines}"


SIMULATION_EDITS: list[tuple[str, str, tuple[tuple[str, str], ...]]] = [
    ("model-key-not-a-string", r"model: missing or not a string \(5\)", (('model = "papadopoulos1992"', "model = 5"),)),
    (
        "end-effectors-not-a-list",
        r"end_effectors: expected a list of names, got 'arm1_ee'",
        (_after("duration = 10.0", 'end_effectors = "arm1_ee"'),),
    ),
    ("end-effectors-of-builtin", r"model: .*whose end effectors are fixed", (_after("duration = 10.0", 'end_effectors = ["arm1_ee"]'),)),
    # reaction wheels (docs/wheels.md)
    (
        "wheels-axis-not-unit",
        r"wheels\[0\] \(rw\)\.axis: is not a unit vector \(norm 1\.41421\); give the unit spin axis",
        (_after("duration = 10.0", 'wheels = [{name = "rw", axis = [1.0, 1.0, 0.0], inertia = 0.1}]'),),
    ),
    (
        "wheels-unknown-key",
        r"wheels\[0\]\.Js: unknown key 'Js'; use the keys name, axis, inertia",
        (_after("duration = 10.0", 'wheels = [{name = "rw", axis = [1.0, 0.0, 0.0], Js = 0.1}]'),),
    ),
    (
        "wheels-larger-than-the-spacecraft",
        r"wheels: the wheels' spin inertias .* are not smaller than the spacecraft body's inertia",
        (_after("duration = 10.0", 'wheels = [{name = "rw", axis = [1.0, 0.0, 0.0], inertia = 1e5}]'),),
    ),
    (
        "wheel-speed-without-wheels",
        r"initial\.wheel_speed: .*has no \[\[wheels\]\]",
        (("[initial]", "[initial]\nwheel_speed = [10.0]"),),
    ),
    ("strict-not-a-bool", r"strict: expected true or false, got 'yes'", (_after("duration = 10.0", 'strict = "yes"'),)),
    ("description-not-a-string", r"description: expected a string, got 5", (("description = ", "description = 5\n#"),)),
    ("unknown-key", r"sim/unknown-key\.toml: colour: unknown key", (_after("duration = 10.0", "colour = 'red'"),)),
    ("duration-text", r"duration: expected a number, got '10'", (("duration = 10.0", 'duration = "10"'),)),
    ("duration-bool", r"duration: expected a number, got True", (("duration = 10.0", "duration = true"),)),
    ("duration-array", r"duration: expected a number, got \[10\.0\]", (("duration = 10.0", "duration = [10.0]"),)),
    ("duration-nan", r"duration: must be finite, got nan", (("duration = 10.0", "duration = nan"),)),
    ("duration-inf", r"duration: must be finite, got inf", (("duration = 10.0", "duration = inf"),)),
    ("duration-negative", r"duration: must be positive, got -1\.0", (("duration = 10.0", "duration = -1.0"),)),
    ("duration-zero", r"duration: must be positive, got 0\.0", (("duration = 10.0", "duration = 0.0"),)),
    ("duration-missing", r"duration: missing", (("duration = 10.0", ""),)),
    ("duration-huge", r"estimated to take over 60 s \(5e\+302 steps.*pass --yes", (("duration = 10.0", "duration = 1e300"),)),
    ("duration-tiny", r"integrator\.fixed_step: 0\.002 s does not divide duration 1e-300 s", (("duration = 10.0", "duration = 1e-300"),)),
    ("initial-not-a-table", r"initial: expected a table, got 5", (_after("duration = 10.0", "initial = 5"), (_INITIAL, ""))),
    ("initial-unknown-key", r"initial\.qddot: unknown key", (_after(_INITIAL, "qddot = [0.0, 0.0, 0.0, 0.0]"),)),
    ("q-deg-short", r"initial\.q_deg: expected shape \(4,\), got \(2,\)", ((_QDEG, "q_deg = [0.0, 90.0]"),)),
    ("q-deg-nested", r"initial\.q_deg: expected shape \(4,\), got \(2, 2\)", ((_QDEG, "q_deg = [[0.0, 90.0], [180.0, -90.0]]"),)),
    ("q-deg-nan", r"initial\.q_deg: has NaN or infinite entries", ((_QDEG, "q_deg = [nan, 90.0, 180.0, -90.0]"),)),
    ("q-deg-inf", r"initial\.q_deg: has NaN or infinite entries", ((_QDEG, "q_deg = [0.0, inf, 180.0, -90.0]"),)),
    ("q-deg-huge", r"initial: State\.q: 1\.75e\+298 .*is beyond 1e\+06", ((_QDEG, "q_deg = [1e300, 90.0, 180.0, -90.0]"),)),
    ("q-deg-text", r"initial\.q_deg: expected numbers, got \['a'", ((_QDEG, 'q_deg = ["a", "b", "c", "d"]'),)),
    ("q-deg-bool", r"initial\.q_deg: expected numbers, got \[True", ((_QDEG, "q_deg = [true, false, true, false]"),)),
    ("q-deg-unknown-joint", r"initial\.q_deg\.arm9_q1: unknown joint", ((_QDEG, "q_deg = { arm9_q1 = 10.0 }"),)),
    ("q-deg-table-text", r"initial\.q_deg\.arm1_q1: expected a number, got 'x'", ((_QDEG, 'q_deg = { arm1_q1 = "x" }'),)),
    ("q-and-q-deg", r"initial\.q_deg: given together with initial\.q", (_after(_INITIAL, "q = [0.0, 0.0, 0.0, 0.0]"),)),
    ("qdot-nan", r"initial\.qdot: has NaN or infinite entries", (_after(_INITIAL, "qdot = [nan, 0.0, 0.0, 0.0]"),)),
    ("qdot-short", r"initial\.qdot: expected shape \(4,\), got \(1,\)", (_after(_INITIAL, "qdot = [0.0]"),)),
    ("qdot-huge", r"initial\.qdot: 1e\+300 rad/s \(or m/s\) is beyond 10000", (_after(_INITIAL, "qdot = [1e300, 0.0, 0.0, 0.0]"),)),
    ("omega-wrong-shape", r"initial\.omega: expected shape \(3,\), got \(2,\)", (_after(_INITIAL, "omega = [0.0, 1.0]"),)),
    ("omega-inf", r"initial\.omega: has NaN or infinite entries", (_after(_INITIAL, "omega = [0.0, 0.0, inf]"),)),
    ("omega-huge", r"initial\.omega: 1e\+300 rad/s \(or m/s\) is beyond 10000", (_after(_INITIAL, "omega = [0.0, 0.0, 1e300]"),)),
    ("attitude-not-unit", r"initial\.attitude: quaternion norm 2 is not 1", (_after(_INITIAL, "attitude = [0.0, 0.0, 0.0, 2.0]"),)),
    ("attitude-nan", r"initial\.attitude: has NaN or infinite entries", (_after(_INITIAL, "attitude = [nan, 0.0, 0.0, 1.0]"),)),
    ("attitude-wrong-shape", r"initial\.attitude: expected shape \(4,\), got \(3,\)", (_after(_INITIAL, "attitude = [0.0, 0.0, 1.0]"),)),
    ("attitude-bool", r"initial\.attitude: expected numbers, got \[False", (_after(_INITIAL, "attitude = [false, false, false, true]"),)),
    (
        "attitude-and-euler",
        r"initial\.euler321_deg: given together with initial\.attitude",
        (_after(_INITIAL, "attitude = [0.0, 0.0, 0.0, 1.0]\neuler321_deg = [0.0, 0.0, 10.0]"),),
    ),
    ("euler-wrong-shape", r"initial\.euler321_deg: expected shape \(3,\), got \(2,\)", (_after(_INITIAL, "euler321_deg = [0.0, 10.0]"),)),
    ("r-cm-inf", r"initial\.r_cm: has NaN or infinite entries", (_after(_INITIAL, "r_cm = [inf, 0.0, 0.0]"),)),
    ("v-cm-text", r"initial\.v_cm: expected numbers, got \['fast'", (_after(_INITIAL, 'v_cm = ["fast", 0.0, 0.0]'),)),
    (
        "r-cm-huge",
        r"initial: State\.r_cm: 1e\+300 is beyond 1e\+12 \(m\), farther than any space robot goes",
        (_after(_INITIAL, "r_cm = [1e300, 0.0, 0.0]"),),
    ),
    (
        "v-cm-huge",
        r"initial: State\.v_cm: -1e\+300 is beyond 1e\+08 \(m/s\), a third of the speed of light",
        (_after(_INITIAL, "v_cm = [0.0, -1e300, 0.0]"),),
    ),
    ("integrator-unknown-key", r"integrator\.steps: unknown key", (_after('method = "RK4"', "steps = 100"),)),
    ("method-unknown", r"integrator\.method: unknown integrator 'Euler'", (('method = "RK4"', 'method = "Euler"'),)),
    ("method-number", r"integrator\.method: unknown integrator 4", (('method = "RK4"', "method = 4"),)),
    ("rk4-without-step", r"integrator\.fixed_step: missing: RK4 needs a step", (_RK4,)),
    ("fixed-step-zero", r"integrator\.fixed_step: must be positive, got 0\.0", (("fixed_step = 0.002", "fixed_step = 0.0"),)),
    ("fixed-step-negative", r"integrator\.fixed_step: must be positive, got -0\.002", (("fixed_step = 0.002", "fixed_step = -0.002"),)),
    ("fixed-step-nan", r"integrator\.fixed_step: must be finite, got nan", (("fixed_step = 0.002", "fixed_step = nan"),)),
    ("fixed-step-text", r"integrator\.fixed_step: expected a number, got 'fast'", (("fixed_step = 0.002", 'fixed_step = "fast"'),)),
    (
        "fixed-step-not-dividing",
        r"integrator\.fixed_step: 0\.003 s does not divide duration 10\.0 s",
        (("fixed_step = 0.002", "fixed_step = 0.003"),),
    ),
    (
        "fixed-step-huge",
        r"integrator\.fixed_step: 1e\+300 s does not divide duration 10\.0 s",
        (("fixed_step = 0.002", "fixed_step = 1e300"),),
    ),
    (
        "fixed-step-tiny",
        r"estimated to take over 60 s \(1e\+301 steps.*pass --yes",
        (("fixed_step = 0.002", "fixed_step = 1e-300"), ("sample_period = 0.01", "#"), ("output_period = 0.02", "#")),
    ),
    ("rtol-with-rk4", r"integrator\.rtol: only used by the adaptive methods", (_after('method = "RK4"', "rtol = 1e-6"),)),
    ("fixed-step-with-adaptive", r"integrator\.fixed_step: only used by RK4, not DOP853", (('method = "RK4"', 'method = "DOP853"'),)),
    ("rtol-nan", r"integrator\.rtol: must be finite, got nan", (('method = "RK4"', 'method = "DOP853"\nrtol = nan'), _RK4)),
    ("atol-negative", r"integrator\.atol: must be positive, got -1e-09", (('method = "RK4"', 'method = "DOP853"\natol = -1e-9'), _RK4)),
    (
        "rtol-huge",
        r"integrator\.rtol: 1e\+300 is not below 1: a relative tolerance of 1 or more asks for no accuracy",
        (('method = "RK4"', 'method = "DOP853"\nrtol = 1e300'), _RK4),
    ),
    ("rtol-one", r"integrator\.rtol: 1 is not below 1", (('method = "RK4"', 'method = "DOP853"\nrtol = 1.0'), _RK4)),
    (
        "rtol-tiny",
        r"integrator\.rtol: 1e-300 is below 2\.22e-14, 100 machine epsilons",
        (('method = "RK4"', 'method = "DOP853"\nrtol = 1e-300'), _RK4),
    ),
    (
        "atol-huge",
        r"integrator\.atol: 1e\+300 is not below 1: an absolute tolerance",
        (('method = "RK4"', 'method = "DOP853"\natol = 1e300'), _RK4),
    ),
    ("output-period-zero", r"integrator\.output_period: must be positive, got 0\.0", (("output_period = 0.02", "output_period = 0.0"),)),
    (
        "output-period-text",
        r"integrator\.output_period: expected a number, got 'often'",
        (("output_period = 0.02", 'output_period = "often"'),),
    ),
    (
        "output-period-tiny",
        r"1e\+301 recorded states .*pass --yes",
        (("output_period = 0.02", "output_period = 1e-300"), ("sample_period = 0.01", "#")),
    ),
    (
        "sample-period-negative",
        r"integrator\.sample_period: must be positive, got -0\.01",
        (("sample_period = 0.01", "sample_period = -0.01"),),
    ),
    (
        "max-wall-time-negative",
        r"integrator\.max_wall_time: must be positive, got -1\.0",
        (_after("output_period = 0.02", "max_wall_time = -1.0"),),
    ),
    (
        "max-wall-time-text",
        r"integrator\.max_wall_time: expected a number, got 'soon'",
        (_after("output_period = 0.02", 'max_wall_time = "soon"'),),
    ),
    ("controller-not-a-table", r"controller: expected a table, got 5", (_after("duration = 10.0", "controller = 5"), (_PD, ""))),
    ("controller-unknown-type", r"controller\.type: unknown or missing controller type 'lqr'", (('type = "joint_pd"', 'type = "lqr"'),)),
    ("controller-missing-type", r"controller\.type: unknown or missing controller type None", (('type = "joint_pd"', ""),)),
    ("controller-unknown-key", r"controller\.ki: unknown key", (_after("kd = 30.0", "ki = 1.0"),)),
    ("kp-missing", r"controller\.kp: missing", (("kp = 20.0", ""),)),
    ("kp-text", r"controller\.kp: expected numbers, got 'stiff'", (("kp = 20.0", 'kp = "stiff"'),)),
    ("kp-bool", r"controller\.kp: expected numbers, got True", (("kp = 20.0", "kp = true"),)),
    ("kp-bool-list", r"controller\.kp: expected numbers, got \[True", (("kp = 20.0", "kp = [true, true, true, true]"),)),
    ("kp-nan", r"controller\.kp: must be finite, got nan", (("kp = 20.0", "kp = nan"),)),
    ("kp-inf", r"controller\.kp: must be finite, got inf", (("kp = 20.0", "kp = inf"),)),
    ("kp-negative", r"controller\.kp: has negative gains", (("kp = 20.0", "kp = -20.0"),)),
    ("kd-negative", r"controller\.kd: has negative gains", (("kd = 30.0", "kd = -30.0"),)),
    ("kp-wrong-length", r"controller\.kp: expected shape \(4,\), got \(2,\)", (("kp = 20.0", "kp = [20.0, 20.0]"),)),
    ("kp-unknown-joint", r"controller\.kp\.arm9_q1: unknown joint", (("kp = 20.0", "kp = { arm9_q1 = 20.0 }"),)),
    ("q-ref-unknown-joint", r"controller\.q_ref_deg\.arm9_q1: unknown joint", (("arm1_q1 = 40.0", "arm9_q1 = 40.0"),)),
    ("q-ref-nan", r"controller\.q_ref_deg\.arm1_q1: must be finite, got nan", (("arm1_q1 = 40.0", "arm1_q1 = nan"),)),
    ("q-ref-huge", r"controller: JointPD\.q_ref: 1\.75e\+298 is beyond 1e\+06", (("arm1_q1 = 40.0", "arm1_q1 = 1e300"),)),
    (
        "q-ref-and-q-ref-deg",
        r"controller\.q_ref_deg: given together with controller\.q_ref",
        (_after("kd = 30.0", "q_ref = [0.0, 0.0, 0.0, 0.0]"),),
    ),
    ("qdot-ref-wrong-shape", r"controller\.qdot_ref: expected shape \(4,\), got \(1,\)", (_after("kd = 30.0", "qdot_ref = [0.0]"),)),
    (
        "qdot-ref-huge",
        r"controller: JointPD\.qdot_ref: 1e\+300 is beyond 10000 \(rad/s or m/s\)",
        (_after("kd = 30.0", "qdot_ref = [1e300, 0.0, 0.0, 0.0]"),),
    ),
    (
        "controller-and-actuation",
        r"controller: given together with \[actuation\]",
        (_after(_LIMIT, '[actuation]\ntype = "constant"\njoint_torque = 1.0'),),
    ),
    ("actuation-unknown-type", r"actuation\.type: unknown or missing actuation type 'ramp'", (_act('type = "ramp"'),)),
    ("actuation-missing-type", r"actuation\.type: unknown or missing actuation type None", (_act("joint_torque = 1.0"),)),
    ("actuation-unknown-key", r"actuation\.frequency: unknown key", (_act('type = "constant"\njoint_torque = 1.0\nfrequency = 1.0'),)),
    ("torque-missing", r"actuation\.joint_torque: missing \(needed by type = 'constant'\)", (_act('type = "constant"'),)),
    (
        "torque-wrong-shape",
        r"actuation\.joint_torque: expected shape \(4,\), got \(2,\)",
        (_act('type = "constant"\njoint_torque = [1.0, 2.0]'),),
    ),
    ("torque-nan", r"actuation\.joint_torque: must be finite, got nan", (_act('type = "constant"\njoint_torque = nan'),)),
    ("torque-text", r"actuation\.joint_torque: expected numbers, got 'strong'", (_act('type = "constant"\njoint_torque = "strong"'),)),
    (
        "times-not-from-zero",
        r"actuation\.times: must start at 0 and increase strictly, got \[1\.0, 2\.0\]",
        (_act('type = "piecewise"\ntimes = [1.0, 2.0]\njoint_torque = [[0.0, 0.0, 0.0, 0.0], [1.0, 1.0, 1.0, 1.0]]'),),
    ),
    (
        "times-decreasing",
        r"actuation\.times: must start at 0 and increase strictly, got \[0\.0, 2\.0, 1\.0\]",
        (_act('type = "piecewise"\ntimes = [0.0, 2.0, 1.0]\njoint_torque = [[0, 0, 0, 0], [1, 1, 1, 1], [0, 0, 0, 0]]'),),
    ),
    (
        "piecewise-rows",
        r"actuation\.joint_torque: expected shape \(2, 4\), got \(1, 4\)",
        (_act('type = "piecewise"\ntimes = [0.0, 1.0]\njoint_torque = [[0.0, 0.0, 0.0, 0.0]]'),),
    ),
    ("frequency-missing", r"actuation\.frequency: missing \(needed by type = 'sinusoid'\)", (_act('type = "sinusoid"\namplitude = 1.0'),)),
    ("frequency-nan", r"actuation\.frequency: must be finite, got nan", (_act('type = "sinusoid"\namplitude = 1.0\nfrequency = nan'),)),
    (
        "frequency-huge",
        r"actuation\.frequency: 1e\+300 Hz is beyond 1e\+06 Hz, which no actuator .*check the units \(Hz, not rad/s\)",
        (_act('type = "sinusoid"\namplitude = 1.0\nfrequency = 1e300'),),
    ),
    (
        "phase-huge",
        r"actuation\.phase: 1e\+300 rad is beyond 1e\+06 rad",
        (_act('type = "sinusoid"\namplitude = 1.0\nfrequency = 1.0\nphase = 1e300'),),
    ),
    (
        "amplitude-huge",
        r"actuation\.amplitude: 1e\+300 N m is beyond 1e\+19 N m",
        (_act('type = "sinusoid"\namplitude = 1e300\nfrequency = 1.0'),),
    ),
    ("torque-huge", r"actuation\.joint_torque: 1e\+300 N m is beyond 1e\+19 N m", (_act('type = "constant"\njoint_torque = 1e300'),)),
    (
        "spacecraft-force-huge",
        r"actuation\.spacecraft_force: 1e\+300 N is beyond 1e\+19 N",
        (_act('type = "constant"\njoint_torque = 0.0\nspacecraft_force = [1e300, 0.0, 0.0]'),),
    ),
    (
        "phase-wrong-shape",
        r"actuation\.phase: expected shape \(4,\), got \(2,\)",
        (_act('type = "sinusoid"\namplitude = 1.0\nfrequency = 1.0\nphase = [0.0, 0.0]'),),
    ),
    (
        "spacecraft-force-wrong-shape",
        r"actuation\.spacecraft_force: expected shape \(3,\), got \(2,\)",
        (_act('type = "constant"\njoint_torque = 0.0\nspacecraft_force = [1.0, 0.0]'),),
    ),
    (
        "spacecraft-torque-inf",
        r"actuation\.spacecraft_torque: has NaN or infinite entries",
        (_act('type = "constant"\njoint_torque = 0.0\nspacecraft_torque = [0.0, 0.0, inf]'),),
    ),
    ("limits-zero", r"limits\.joint_torque: must be positive, got 0\.0", ((_LIMIT, "joint_torque = 0.0"),)),
    ("limits-negative", r"limits\.joint_torque: must be positive, got -10\.0", ((_LIMIT, "joint_torque = -10.0"),)),
    ("limits-nan", r"limits\.joint_torque: must be finite, got nan", ((_LIMIT, "joint_torque = nan"),)),
    ("limits-text", r"limits\.joint_torque: expected numbers, got 'strong'", ((_LIMIT, 'joint_torque = "strong"'),)),
    ("limits-bool", r"limits\.joint_torque: expected a number, got True", ((_LIMIT, "joint_torque = true"),)),
    ("limits-wrong-shape", r"limits\.joint_torque: expected shape \(4,\), got \(2,\)", ((_LIMIT, "joint_torque = [10.0, 10.0]"),)),
    ("limits-force-negative", r"limits\.spacecraft_force: must be positive, got -1\.0", (_after(_LIMIT, "spacecraft_force = -1.0"),)),
    ("limits-unknown-key", r"limits\.joint_speed: unknown key", (_after(_LIMIT, "joint_speed = 1.0"),)),
    ("joint-limits-mode", r"joint_limits\.mode: unknown mode 'bounce'", (_after(_LIMIT, '[joint_limits]\nmode = "bounce"'),)),
    (
        "restitution-above-one",
        r"joint_limits\.restitution: 2\.0 is outside \[0, 1\]",
        (_after(_LIMIT, "[joint_limits]\nrestitution = 2.0"),),
    ),
    (
        "restitution-text",
        r"joint_limits\.restitution: expected a number, got 'soft'",
        (_after(_LIMIT, '[joint_limits]\nrestitution = "soft"'),),
    ),
    (
        "outputs-name-escapes",
        r"outputs\.name: must be a plain file stem, got '\.\./escape'",
        (_after(_LIMIT, '[outputs]\nname = "../escape"'),),
    ),
    (
        "outputs-name-absolute",
        r"outputs\.name: must be a plain file stem, got '/tmp/run'",
        (_after(_LIMIT, '[outputs]\nname = "/tmp/run"'),),
    ),
    ("outputs-name-empty", r"outputs\.name: must be a plain file stem, got ''", (_after(_LIMIT, '[outputs]\nname = ""'),)),
    ("outputs-name-hidden", r"outputs\.name: must be a plain file stem, got '\.hidden'", (_after(_LIMIT, '[outputs]\nname = ".hidden"'),)),
    ("outputs-name-number", r"outputs\.name: must be a plain file stem, got 5", (_after(_LIMIT, "[outputs]\nname = 5"),)),
    ("outputs-npz-text", r"outputs\.npz: expected true or false, got 'yes'", (_after(_LIMIT, '[outputs]\nnpz = "yes"'),)),
    ("outputs-unknown-key", r"outputs\.pdf: unknown key", (_after(_LIMIT, "[outputs]\npdf = true"),)),
]

_EE = 'end_effector = "arm1_ee"'
_PAYLOAD = CAP[CAP.index("[payload]") : CAP.index("[path]")]
_PATH = CAP[CAP.index("[path]") : CAP.index("# [joint_limits_deg]")]
_PTS = "points = [[0.0, 0.0], [0.0, 0.25]]"
_RULE = 'rule = "perpendicular"'
_END = "# [joint_limits_deg]"  # the last table: [singularity] and [joint_limits] go before it
_INERTIA = "inertia = 25.0                        # kg m² about the payload CM (Izz of the planar model)"

CAPTURE_EDITS: list[tuple[str, str, tuple[tuple[str, str], ...]]] = [
    ("model-key-not-a-string", r"model: missing or not a string \(5\)", (('model = "papadopoulos1992-one-arm"', "model = 5"),)),
    ("model-key-missing", r"model: missing or not a string \(None\)", (('model = "papadopoulos1992-one-arm"', ""),)),
    ("end-effectors-not-a-list", r"end_effectors: expected a list of names, got 'arm1_ee'", (_after(_EE, 'end_effectors = "arm1_ee"'),)),
    ("strict-not-a-bool", r"strict: expected true or false, got 'yes'", (_after(_EE, 'strict = "yes"'),)),
    ("unknown-key", r"cap/unknown-key\.toml: colour: unknown key", (_after(_EE, 'colour = "red"'),)),
    ("description-not-a-string", r"description: expected a string, got 5", (("description = ", "description = 5\n#"),)),
    ("ee-out-of-range", r"end_effector: unknown end effector 7; known: 0=arm1_ee", ((_EE, "end_effector = 7"),)),
    ("ee-negative", r"end_effector: unknown end effector -1", ((_EE, "end_effector = -1"),)),
    ("ee-unknown-name", r"end_effector: unknown end effector 'nowhere'", ((_EE, 'end_effector = "nowhere"'),)),
    ("ee-bool", r"end_effector: expected a name or an index, got True", ((_EE, "end_effector = true"),)),
    ("ee-float", r"end_effector: expected a name or an index, got 0\.5", ((_EE, "end_effector = 0.5"),)),
    ("samples-few", r"samples: expected an integer >= 16, got 15", (_after(_EE, "samples = 15"),)),
    ("samples-text", r"samples: expected an integer >= 16, got 'many'", (_after(_EE, 'samples = "many"'),)),
    ("samples-float", r"samples: expected an integer >= 16, got 1000000\.0", (_after(_EE, "samples = 1e6"),)),
    ("samples-bool", r"samples: expected an integer >= 16, got True", (_after(_EE, "samples = true"),)),
    ("samples-huge", r"sampling 1e\+12 configurations .*more than this machine has free", (_after(_EE, "samples = 1000000000000"),)),
    (
        "samples-int64",
        r"sampling 9\.22e\+18 configurations .*more than this machine has free",
        (_after(_EE, "samples = 9223372036854775807"),),
    ),
    ("payload-missing", r"payload: is missing", ((_PAYLOAD, ""),)),
    ("payload-not-a-table", r"payload: expected a table, got 5", ((_PAYLOAD, ""), _after(_EE, "payload = 5"))),
    ("payload-unknown-key", r"payload\.volume: unknown key", (_after("inertia = 25.0", "volume = 1.0"),)),
    ("mass-missing", r"payload\.mass: is missing", (("mass = 400.0", ""),)),
    ("mass-nan", r"payload\.mass: must be finite, got nan", (("mass = 400.0", "mass = nan"),)),
    ("mass-inf", r"payload\.mass: must be finite, got inf", (("mass = 400.0", "mass = inf"),)),
    ("mass-negative", r"payload\.mass: must be positive, got -400\.0", (("mass = 400.0", "mass = -400.0"),)),
    ("mass-zero", r"payload\.mass: must be positive, got 0\.0", (("mass = 400.0", "mass = 0.0"),)),
    ("mass-text", r"payload\.mass: expected a number, got 'heavy'", (("mass = 400.0", 'mass = "heavy"'),)),
    ("mass-bool", r"payload\.mass: expected a number, got True", (("mass = 400.0", "mass = true"),)),
    ("mass-huge", r"mass: 1e\+300 kg is above the 1e\+09 kg freefloat accepts", (("mass = 400.0", "mass = 1e300"),)),
    ("inertia-missing", r"payload\.inertia: is missing", (("inertia = 25.0", ""),)),
    ("inertia-nan", r"payload\.inertia: has NaN or infinite entries", (("inertia = 25.0", "inertia = nan"),)),
    ("inertia-negative", r"payload\.inertia: is not positive definite", (("inertia = 25.0", "inertia = -25.0"),)),
    (
        "inertia-wrong-shape",
        r"payload\.inertia: expected shape \(3, 3\), \(3,\) or a scalar, got \(2,\)",
        (("inertia = 25.0", "inertia = [1.0, 2.0]"),),
    ),
    ("inertia-triangle", r"payload\.inertia: violates the triangle inequality", (("inertia = 25.0", "inertia = [1.0, 1.0, 5.0]"),)),
    ("inertia-huge", r"payload\.inertia: 1e\+300 kg m\^2 is above", (("inertia = 25.0", "inertia = 1e300"),)),
    ("inertia-text", r"payload\.inertia: cannot read 'heavy' as an inertia", (("inertia = 25.0", 'inertia = "heavy"'),)),
    ("inertia-bool", r"payload\.inertia: cannot read True as an inertia", (("inertia = 25.0", "inertia = true"),)),
    (
        "inertia-bool-list",
        r"payload\.inertia: cannot read \[True, True, True\] as an inertia",
        (("inertia = 25.0", "inertia = [true, true, true]"),),
    ),
    (
        "offset-wrong-shape",
        r"payload\.offset: expected \[x, y, z\], got \[0\.0, 0\.0\]",
        (("offset = [0.0, 0.0, 0.0]", "offset = [0.0, 0.0]"),),
    ),
    ("offset-nan", r"payload\.offset: must be finite, got nan", (("offset = [0.0, 0.0, 0.0]", "offset = [nan, 0.0, 0.0]"),)),
    ("offset-huge", r"offset: 1e\+300 m is beyond the 10000 m", (("offset = [0.0, 0.0, 0.0]", "offset = [1e300, 0.0, 0.0]"),)),
    ("path-missing", r"path: is missing", ((_PATH, ""),)),
    ("path-unknown-key", r"path\.speed: unknown key", (_after(_RULE, "speed = 1.0"),)),
    ("points-missing", r"path\.points: is missing", ((_PTS, ""),)),
    ("points-empty", r"path\.points: is empty", ((_PTS, "points = []"),)),
    ("points-one", r"path\.points: has 1 point; the path needs at least two", ((_PTS, "points = [[0.0, 0.0]]"),)),
    ("points-flat", r"path\.points\[0\]: expected \[x, y\] or \[x, y, z\], got 0\.0", ((_PTS, "points = [0.0, 0.25]"),)),
    ("points-zero-length", r"path\.points: the first segment A-B has zero length", ((_PTS, "points = [[0.0, 0.0], [0.0, 0.0]]"),)),
    ("points-mixed", r"path\.points: mixes 2D and 3D points", ((_PTS, "points = [[0.0, 0.0], [0.0, 0.25, 0.0]]"),)),
    ("points-nan", r"path\.points\[0\]: must be finite, got nan", ((_PTS, "points = [[0.0, nan], [0.0, 0.25]]"),)),
    ("points-inf", r"path\.points\[1\]: must be finite, got inf", ((_PTS, "points = [[0.0, 0.0], [0.0, inf]]"),)),
    ("points-huge", r"path\.points: 1e\+300 m is beyond the 10000 m", ((_PTS, "points = [[0.0, 0.0], [0.0, 1e300]]"),)),
    ("points-text", r"path\.points\[1\]: expected a number, got 'a'", ((_PTS, 'points = [[0.0, 0.0], ["a", "b"]]'),)),
    ("rule-unknown", r"path\.rule: unknown rule 'diagonal'", ((_RULE, 'rule = "diagonal"'),)),
    ("rule-number", r"path\.rule: unknown rule 5", ((_RULE, "rule = 5"),)),
    ("R-plus-negative", r"path\.R_plus: must be positive, got -0\.5", (_after(_RULE, "R_plus = -0.5"),)),
    ("R-plus-zero", r"path\.R_plus: must be positive, got 0\.0", (_after(_RULE, "R_plus = 0.0"),)),
    ("R-plus-nan", r"path\.R_plus: must be finite, got nan", (_after(_RULE, "R_plus = nan"),)),
    ("R-plus-text", r"path\.R_plus: expected a number, got 'far'", (_after(_RULE, 'R_plus = "far"'),)),
    ("singularity-rows", r"singularity\.rows: unknown value 'diagonal'", ((_END, '[singularity]\nrows = "diagonal"\n#'),)),
    ("singularity-measure", r"singularity\.measure: unknown value 'volume'", ((_END, '[singularity]\nmeasure = "volume"\n#'),)),
    ("singularity-strategy", r"singularity\.strategy: unknown value 'fastest'", ((_END, '[singularity]\nstrategy = "fastest"\n#'),)),
    ("singularity-threshold-negative", r"singularity\.threshold: must be >= 0, got -1\.0", ((_END, "[singularity]\nthreshold = -1.0\n#"),)),
    ("singularity-threshold-nan", r"singularity\.threshold: must be finite, got nan", ((_END, "[singularity]\nthreshold = nan\n#"),)),
    (
        "singularity-threshold-huge",
        r"threshold: 1e\+300 is at or above 3\.26 \(m\^2\), a bound that \|det\| of J\* never reaches on "
        r"'papadopoulos1992_one_arm\+payload'",
        ((_END, "[singularity]\nthreshold = 1e300\n#"),),
    ),
    (
        "singularity-threshold-text",
        r"singularity\.threshold: expected a number, got 'small'",
        ((_END, '[singularity]\nthreshold = "small"\n#'),),
    ),
    ("singularity-unknown-key", r"singularity\.colour: unknown key", ((_END, '[singularity]\ncolour = "red"\n#'),)),
    (
        "limits-order",
        r"joint_limits_deg\.arm1_q1: lower 50\.0 is not below upper -50\.0",
        ((_END, "[joint_limits_deg]\narm1_q1 = [50.0, -50.0]\n#"),),
    ),
    ("limits-unknown-joint", r"joint_limits_deg\.arm9_q1: unknown joint", ((_END, "[joint_limits_deg]\narm9_q1 = [-50.0, 50.0]\n#"),)),
    (
        "limits-not-a-pair",
        r"joint_limits_deg\.arm1_q1: expected \[lower, upper\], got 50\.0",
        ((_END, "[joint_limits_deg]\narm1_q1 = 50.0\n#"),),
    ),
    (
        "limits-three",
        r"expected \[lower, upper\], got \[-50\.0, 0\.0, 50\.0\]",
        ((_END, "[joint_limits_deg]\narm1_q1 = [-50.0, 0.0, 50.0]\n#"),),
    ),
    ("limits-text", r"joint_limits_deg\.arm1_q1: expected a number, got 'a'", ((_END, '[joint_limits_deg]\narm1_q1 = ["a", "b"]\n#'),)),
    ("limits-nan", r"joint_limits\.arm1_q1: must be finite, got nan", ((_END, "[joint_limits]\narm1_q1 = [nan, 1.0]\n#"),)),
    ("limits-not-a-table", r"joint_limits: expected a table, got 5", (_after(_EE, "joint_limits = 5"),)),
    # a moving target: [payload] velocity, angular_velocity and the [grasp] table
    ("velocity-wrong-shape", r"payload\.velocity: expected \[x, y, z\], got \[0\.0, 0\.1\]", (_after(_INERTIA, "velocity = [0.0, 0.1]"),)),
    ("velocity-not-a-list", r"payload\.velocity: expected \[x, y, z\], got 0\.1", (_after(_INERTIA, "velocity = 0.1"),)),
    ("velocity-text", r"payload\.velocity: expected a number, got 'fast'", (_after(_INERTIA, 'velocity = ["fast", 0.0, 0.0]'),)),
    ("velocity-huge", r"payload\.velocity: 1e\+300 is beyond 1e\+08 \(m/s\)", (_after(_INERTIA, "velocity = [1e300, 0.0, 0.0]"),)),
    (
        "angular-velocity-nan",
        r"payload\.angular_velocity: must be finite, got nan",
        (_after(_INERTIA, "angular_velocity = [0.0, nan, 0.0]"),),
    ),
    (
        "angular-velocity-inf",
        r"payload\.angular_velocity: must be finite, got inf",
        (_after(_INERTIA, "angular_velocity = [0.0, 0.0, inf]"),),
    ),
    ("grasp-not-a-table", r"grasp: expected a table, got 5", (_after(_EE, "grasp = 5"),)),
    ("grasp-unknown-key", r"grasp\.colour: unknown key; use one of joints, rank_by", ((_END, '[grasp]\ncolour = "red"\n#'),)),
    (
        "rank-by-unknown",
        r"grasp\.rank_by: unknown criterion 'cheapest'; use one of measure, spacecraft_rate, impulse",
        ((_END, '[grasp]\nrank_by = "cheapest"\n#'),),
    ),
    ("rank-by-number", r"grasp\.rank_by: unknown criterion 5", ((_END, "[grasp]\nrank_by = 5\n#"),)),
    (
        "rank-by-at-rest",
        r"grasp\.rank_by: 'impulse' ranks the grasp of a moving target, and no motion of the target is given; give the target's",
        ((_END, '[grasp]\nrank_by = "impulse"\n#'),),
    ),
    (
        "joints-at-rest",
        r"grasp\.joints: what the joints do at the grasp matters only for a moving target",
        ((_END, '[grasp]\njoints = "locked"\n#'),),
    ),
    (
        "joints-unknown",
        r"grasp\.joints: unknown joint mode 'welded'",
        (_after(_INERTIA, "velocity = [0.0, 0.1, 0.0]"), (_END, '[grasp]\njoints = "welded"\n#')),
    ),
    (
        "joint-impulse-free",
        r"grasp\.rank_by: 'joint_impulse' is zero for free joints .*give joints = 'locked'",
        (_after(_INERTIA, "velocity = [0.0, 0.1, 0.0]"), (_END, '[grasp]\nrank_by = "joint_impulse"\n#')),
    ),
    # the capture sequence: the [detumble] table (a moving target only)
    (
        "detumble-unknown-key",
        r"detumble\.gain: unknown key; use one of attitude, duration, force",
        (_after(_INERTIA, "velocity = [0.0, 0.1, 0.0]"), (_END, "[detumble]\ngain = 0.5\n#")),
    ),
    (
        "detumble-rate-gain-negative",
        r"detumble\.rate_gain: must be positive, got -0\.5; give detumble\.rate_gain in 1/s",
        (_after(_INERTIA, "velocity = [0.0, 0.1, 0.0]"), (_END, "[detumble]\nrate_gain = -0.5\n#")),
    ),
    (
        "detumble-duration-text",
        r"detumble\.duration: expected a number, got 'long'",
        (_after(_INERTIA, "velocity = [0.0, 0.1, 0.0]"), (_END, '[detumble]\nduration = "long"\n#')),
    ),
    (
        "detumble-attitude-not-unit",
        r"detumble\.attitude: has norm 2, not 1",
        (_after(_INERTIA, "velocity = [0.0, 0.1, 0.0]"), (_END, "[detumble]\nattitude = [0.0, 0.0, 0.0, 2.0]\n#")),
    ),
    ("detumble-at-rest", r"detumble: needs a moving target", ((_END, "[detumble]\nrate_gain = 0.5\n#"),)),
    (
        "detumble-torque-by-unknown",
        r"detumble\.torque_by: unknown 'gyros'; write torque_by = \"thrusters\" or \"wheels\"",
        (_after(_INERTIA, "velocity = [0.0, 0.1, 0.0]"), (_END, '[detumble]\ntorque_by = "gyros"\n#')),
    ),
    (
        "detumble-torque-by-wheels-without-wheels",
        r"detumble\.torque_by: 'wheels', but 'papadopoulos1992_one_arm' has no reaction wheels; declare the spacecraft's",
        (_after(_INERTIA, "velocity = [0.0, 0.1, 0.0]"), (_END, '[detumble]\ntorque_by = "wheels"\n#')),
    ),
]
for _id, _, _changes in SIMULATION_EDITS:
    _add(f"sim/{_id}.toml", _edit(SIM, *_changes))
for _id, _, _changes in CAPTURE_EDITS:
    _add(f"cap/{_id}.toml", _edit(CAP, *_changes))


M = ff.models.papadopoulos1992
Q = [0.1, 0.2, 0.3, 0.4]
S = ff.State(q=Q)


def _short_traj() -> ff.Trajectory:
    return ff.simulate(M(), S, 0.02, fixed_step=0.01)


def _builder(body: dict[str, Any] | None = None, joint: dict[str, Any] | None = None, *, extra: str = "") -> Callable[[Path], Any]:
    """A bus and one link ``a`` on joint ``j1``, with the link's and the joint's arguments changed as given; ``extra``:
    "loop" adds a joint from ``a`` back to the bus, "duplicate" adds a second body named ``bus``."""

    def run(files: Path) -> Any:
        b = ff.ModelBuilder("x")
        b.add_body("bus", mass=100.0, inertia=10.0)
        b.add_body("bus" if extra == "duplicate" else "a", **{"mass": 1.0, "inertia": 0.1, **(body or {})})
        if extra != "duplicate":
            b.add_joint("j1", **{"parent": "bus", "child": "a", "axis": [0, 0, 1], **(joint or {})})
        if extra == "loop":
            b.add_joint("j2", parent="a", child="bus", axis=[0, 0, 1])
        return b.build()

    return run


def _kernels_setting(value: str) -> str:
    """``FREEFLOAT_KERNELS=value`` read as the engine reads it at the first kernel a process needs (the variable put
    back after; the subprocess cases are in tests/engine/test_compile_once.py)."""
    from freefloat.engine import kernels_setting

    before = os.environ.get("FREEFLOAT_KERNELS")
    os.environ["FREEFLOAT_KERNELS"] = value
    try:
        return kernels_setting()
    finally:
        if before is None:
            del os.environ["FREEFLOAT_KERNELS"]
        else:
            os.environ["FREEFLOAT_KERNELS"] = before


CASES = [
    api(
        "env-kernels-unknown",
        lambda f: _kernels_setting("fast"),
        SettingError,
        r"^FREEFLOAT_KERNELS='fast' is not a setting: use one of auto, portable, native",
    ),
    # ---- loading files and names
    api("load-none", lambda f: ff.load(None), TypeError, r"^path: expected a model file path or a built-in model name"),
    api("load-int", lambda f: ff.load(123), TypeError, r"^path: expected a model file path"),
    api("load-missing", lambda f: ff.load(f / "nothere.urdf"), ModelError, r"file not found; give the path"),
    api("load-directory", lambda f: ff.load(f), ModelError, r"file not found|not a file"),
    api("load-empty-toml", lambda f: ff.load(f / "empty.toml"), ModelError, r"empty.toml"),
    api("load-empty-urdf", lambda f: ff.load(f / "empty.urdf"), ModelError, r"empty.urdf"),
    api("load-binary-urdf", lambda f: ff.load(f / "binary.urdf"), ModelError, r"binary.urdf"),
    api("load-binary-toml", lambda f: ff.load(f / "binary.toml"), ModelError, r"binary.toml"),
    api("load-truncated-toml", lambda f: ff.load(f / "truncated.toml"), ModelError, r"truncated.toml: has no movable joint"),
    api("load-cut-mid-table", lambda f: ff.load(f / "cut_mid_table.toml"), ModelError, r"cut_mid_table.toml"),
    api("load-urdf-without-joints", lambda f: ff.load(f / "no_joints.urdf"), ModelError, r"no_joints.urdf: has no movable joint"),
    api("load-malformed-urdf", lambda f: ff.load(f / "malformed.urdf"), ModelError, r"malformed.urdf"),
    api("load-revolute-without-limit", lambda f: ff.load(f / "no_limit.urdf"), ModelCorrectionWarning, r"revolute joint without <limit>"),
    api("load-revolute-without-limit-strict", lambda f: ff.load(f / "no_limit.urdf", strict=True), ModelError, r"without <limit>"),
    api("load-ball-joint", lambda f: ff.load(f / "ball.urdf"), ModelError, r"unsupported joint type 'spherical'"),
    api("load-floating-joint", lambda f: ff.load(f / "floating.urdf"), ModelError, r"'floating': a floating joint inside the tree"),
    api("load-negative-mass", lambda f: ff.load(f / "negative_mass.urdf"), ModelError, r"mass"),
    api("load-loop", lambda f: ff.load(f / "loop.urdf"), ModelError, r"loop|cycle|root|parent"),
    api("load-unknown-suffix", lambda f: ff.load(f / "model.obj"), ModelError, r"unknown model file type '.obj'"),
    api("load-empty-end-effectors", lambda f: ff.load(ARM_URDF, end_effectors=[]), ModelError, r"end_effectors: is empty"),
    api("load-string-end-effectors", lambda f: ff.load(ARM_URDF, end_effectors="tool0"), TypeError, r"expected a list of names"),
    api("load-unknown-end-effector", lambda f: ff.load(ARM_URDF, end_effectors=["nowhere"]), ModelError, r"nowhere"),
    api("load-unknown-name", lambda f: ff.load("papadopoulos1993"), ModelError, r"did you mean 'papadopoulos1992'"),
    api("models-unknown-name", lambda f: ff.models.load_model("astrobee"), ModelError, r"did you mean 'astrobee-arm'"),
    api("models-strict-corrected", lambda f: ff.models.load_model("ets7", strict=True), ModelError, r"which strict refuses"),
    api("models-builtin-end-effectors", lambda f: ff.models.load_model("ets7", end_effectors=["hand"]), ModelError, r"fixed"),
    api("builder-loop", _builder(extra="loop"), ModelError, r"loop|cycle|already|parent"),
    api("builder-negative-mass", _builder({"mass": -1.0}), ModelError, r"mass"),
    api("builder-nan-mass", _builder({"mass": float("nan")}), ModelError, r"mass"),
    api("builder-triangle-inertia", _builder({"inertia": [1.0, 1.0, 5.0]}), ModelError, r"inertia"),
    api("builder-huge-mass", _builder({"mass": 1e30}), ModelError, r"mass"),
    api("payload-negative-mass", lambda f: M().with_payload(0, mass=-1.0, inertia=1.0), ModelError, r"mass"),
    api("payload-end-effector-out-of-range", lambda f: M().with_payload(5, mass=1.0, inertia=1.0), UnknownNameError, r"end effector"),
    api("payload-bad-inertia", lambda f: M().with_payload(0, mass=1.0, inertia=[1.0, 1.0, 5.0]), ModelError, r"inertia"),
    # ---- joint angles, points and other arrays
    api("q-wrong-length", lambda f: ff.generalized_jacobian(M(), [0.1, 0.2]), ShapeError, r"expected shape \(\.\.\., 4\)"),
    api("q-nan", lambda f: ff.generalized_jacobian(M(), [np.nan, 0, 0, 0]), ValueError, r"NaN or infinite"),
    api("q-inf", lambda f: ff.system_inertia_matrix(M(), [np.inf, 0, 0, 0]), ValueError, r"NaN or infinite"),
    api("q-huge", lambda f: ff.generalized_jacobian(M(), [1e300, 0, 0, 0]), ValueError, r"beyond 1e\+06"),
    api("q-complex", lambda f: ff.generalized_jacobian(M(), [1j, 0, 0, 0]), TypeError, r"complex numbers"),
    api("q-bool", lambda f: ff.generalized_jacobian(M(), [True, False, True, False]), TypeError, r"booleans"),
    api("q-text", lambda f: ff.end_effector_positions(M(), ["a", "b", "c", "d"]), TypeError, r"text"),
    api("q-none", lambda f: ff.end_effector_positions(M(), None), TypeError, r"objects that are not all numbers"),
    api("q-ragged", lambda f: ff.end_effector_positions(M(), [[0, 0, 0, 0], [0, 0]]), TypeError, r"regular array"),
    api("q-scalar", lambda f: ff.end_effector_positions(M(), 0.3), ShapeError, r"expected shape"),
    api("point-nan", lambda f: ff.point_jacobian(M(), Q, 1, [np.nan, 0, 0]), ValueError, r"point: has NaN"),
    api("point-shape", lambda f: ff.point_jacobian(M(), Q, 1, [0, 0]), ShapeError, r"point: expected shape"),
    api("point-unknown-body", lambda f: ff.point_jacobian(M(), Q, "nowhere"), UnknownNameError, r"body"),
    api("velocity-shape", lambda f: ff.forward_dynamics(M(), Q, np.zeros(5), np.zeros(4)), ShapeError, r"velocity"),
    api("attitude-not-unit", lambda f: ff.end_effector_positions(M(), Q, attitude=[0, 0, 0, 2]), ValueError, r"quaternion|norm"),
    api("momentum-nan", lambda f: ff.mechanics.generalized_jacobian_drift(M(), Q, [np.nan, 0, 0]), ValueError, r"angular_momentum"),
    api("state-wrong-q", lambda f: ff.simulate(M(), ff.State(q=[0.1]), 1.0), ShapeError, r"q"),
    api("state-bool-q", lambda f: ff.State(q=[True, False, True, False]), TypeError, r"State.q: expected real numbers, got booleans"),
    api("state-complex-omega", lambda f: ff.State(omega=[1j, 0, 0]), TypeError, r"State.omega: expected real numbers, got complex"),
    api("state-huge-q", lambda f: ff.State(q=[1e300, 0, 0, 0]), ValueError, r"State.q: 1e\+300 is beyond 1e\+06"),
    api("limits-bool", lambda f: ff.ActuatorLimits(joint_torque=True), ValueError, r"ActuatorLimits.joint_torque"),
    api("payload-bool-mass", lambda f: M().with_payload(0, mass=True, inertia=1.0), ModelError, r"mass.*cannot read True"),
    api("map-fractional-n", lambda f: ff.workspace.jacobian_determinant_map(M(), n=5.5), ValueError, r"n: expected an integer >= 2"),
    # ---- simulation
    api("duration-text", lambda f: ff.simulate(M(), S, "10"), ValueError, r"duration: expected a positive number, got str"),
    api("duration-negative", lambda f: ff.simulate(M(), S, -1.0), ValueError, r"duration: must be positive"),
    api("duration-zero", lambda f: ff.simulate(M(), S, 0.0), ValueError, r"duration"),
    api("duration-nan", lambda f: ff.simulate(M(), S, float("nan")), ValueError, r"duration"),
    api("duration-inf", lambda f: ff.simulate(M(), S, float("inf")), ValueError, r"duration"),
    api("duration-bool", lambda f: ff.simulate(M(), S, True), ValueError, r"duration"),
    api("step-not-dividing", lambda f: ff.simulate(M(), S, 1.0, fixed_step=0.3), ValueError, r"does not divide"),
    api("method-unknown", lambda f: ff.simulate(M(), S, 1.0, method="Euler"), ValueError, r"unknown integrator 'Euler'"),
    api("controller-not-callable", lambda f: ff.simulate(M(), S, 1.0, 5), TypeError, r"controller: expected a callable"),
    api("controller-wrong-shape", lambda f: ff.simulate(M(), S, 1.0, lambda t, s: np.zeros(3)), ff.SimulationError, r"shape \(3,\)"),
    api("controller-nan", lambda f: ff.simulate(M(), S, 1.0, lambda t, s: np.full(4, np.nan)), ff.SimulationError, r"non-finite"),
    api(
        "controller-huge-adaptive", lambda f: ff.simulate(M(), S, 1.0, lambda t, s: np.full(4, 1e12)), ff.SimulationError, r"what the model"
    ),
    api("controller-raises", lambda f: ff.simulate(M(), S, 1.0, lambda t, s: 1 / 0), ff.SimulationError, r"ZeroDivisionError"),
    api("state-not-a-state", lambda f: ff.simulate(M(), {"q": Q}, 1.0), TypeError, r"initial_state: expected a freefloat.State"),
    api("wall-time-text", lambda f: ff.simulate(M(), S, 1.0, max_wall_time="soon"), ValueError, r"max_wall_time"),
    api("pd-negative-kd", lambda f: ff.JointPD(kp=10.0, kd=-5.0), ValueError, r"JointPD.kd: must be >= 0"),
    api("pd-negative-kp", lambda f: ff.JointPD(kp=-10.0, kd=5.0), ValueError, r"JointPD.kp: must be >= 0"),
    api("pd-nan", lambda f: ff.JointPD(kp=np.nan, kd=5.0), ValueError, r"JointPD.kp: has NaN"),
    api("pd-text", lambda f: ff.JointPD(kp="stiff", kd=5.0), TypeError, r"JointPD.kp: expected real numbers"),
    api("rollout-dt-not-dividing", lambda f: ff.rollout(M(), ff.State(q=np.zeros((2, 4))), 1.0, dt=0.3), ValueError, r"dt"),
    api(
        "rollout-sample-below-dt",
        lambda f: ff.rollout(M(), ff.State(q=np.zeros((2, 4))), 0.1, dt=0.01, sample_period=0.001),
        ValueError,
        r"sample_period: 0.001 s must be a whole multiple of dt",
    ),
    api(
        "rollout-nan-output-period",
        lambda f: ff.rollout(M(), ff.State(q=np.zeros((2, 4))), 0.1, dt=0.01, output_period=float("nan")),
        ValueError,
        r"output_period: must be positive",
    ),
    api("rollout-unbatched", lambda f: ff.rollout(M(), S, 1.0, dt=0.01), ShapeError, r"leading batch axis"),
    # ---- workspaces, maps, capture
    api("map-huge", lambda f: ff.workspace.jacobian_determinant_map(M(), n=100_000), MemoryBudgetError, r"a map of 100000 x 100000"),
    api("map-same-joint", lambda f: ff.workspace.jacobian_determinant_map(M(), (0, 0)), ValueError, r"two different joints"),
    api(
        "measure-unknown",
        lambda f: ff.mechanics.jacobian_measure(ff.models.spacecraft_7dof(), np.zeros(7), None, "smax"),
        ValueError,
        r"^measure: expected one of det, sigma_min, manipulability, condition, sigma_max, got 'smax'",
    ),
    api(
        "measure-repeated-rows",
        lambda f: ff.mechanics.jacobian_measure(ff.models.spacecraft_7dof(), np.zeros(7), [0, 1, 1], "sigma_max"),
        ValueError,
        r"^rows: expected distinct indices",
    ),
    api(
        "measure-det-not-square",
        lambda f: ff.mechanics.jacobian_measure(ff.models.spacecraft_7dof(), np.zeros(7), None, "det"),
        ff.ShapeError,
        r"not square; use 'sigma_min'",
    ),
    api(
        "measure-nan-q",
        lambda f: ff.mechanics.jacobian_measure(ff.models.spacecraft_7dof(), np.full(7, np.nan), None, "sigma_max"),
        ValueError,
        r"^q: has NaN or infinite entries",
    ),
    api(
        "reach-huge-samples",
        lambda f: ff.workspace.reachable_workspace(ff.models.spacecraft_7dof(), 0, samples=10**9),
        MemoryBudgetError,
        r"ask for fewer samples",
    ),
    api(
        "piw-few-samples",
        lambda f: ff.workspace.path_independent_workspace(M(), 0, samples=3),
        ValueError,
        r"samples: expected an integer >= 16",
    ),
    api("piw-bool-samples", lambda f: ff.workspace.path_independent_workspace(M(), 0, samples=True), ValueError, r"samples"),
    api(
        "capture-negative-R",
        lambda f: ff.capture.plan_capture(M(arms=1), 0, [[0, 0], [0, 0.25]], mass=400.0, inertia=25.0, R_plus=-0.5),
        ValueError,
        r"R_plus: expected a positive distance",
    ),
    api("capture-empty-path", lambda f: ff.capture.plan_capture(M(arms=1), 0, [], mass=400.0, inertia=25.0), ValueError, r"path"),
    api(
        "capture-rank-by-unknown",
        lambda f: ff.capture.plan_capture(M(arms=1), 0, [[0, 0], [0, 0.25]], mass=400.0, inertia=25.0, rank_by="cheapest"),
        ValueError,
        r"rank_by: unknown criterion 'cheapest'; use one of measure, spacecraft_rate",
    ),
    api(
        "capture-rank-by-at-rest",
        lambda f: ff.capture.plan_capture(M(arms=1), 0, [[0, 0], [0, 0.25]], mass=400.0, inertia=25.0, rank_by="impulse"),
        ValueError,
        r"rank_by: 'impulse' ranks the grasp of a moving target, and no motion of the target is given",
    ),
    api(
        "capture-target-velocity-shape",
        lambda f: ff.capture.plan_capture(M(arms=1), 0, [[0, 0], [0, 0.25]], mass=400.0, inertia=25.0, target_velocity=[0.0, 0.1]),
        ShapeError,
        r"target_velocity: expected shape \(\.\.\., 3\) \(velocity of the target's CM, inertial frame\), got \(2,\)",
    ),
    api(
        "capture-target-angular-velocity-nan",
        lambda f: ff.capture.plan_capture(
            M(arms=1), 0, [[0, 0], [0, 0.25]], mass=400.0, inertia=25.0, target_angular_velocity=[0.0, float("nan"), 0.0]
        ),
        ValueError,
        r"target_angular_velocity: has NaN or infinite entries",
    ),
    api(
        "capture-joint-impulse-free",
        lambda f: ff.capture.plan_capture(
            M(arms=1), 0, [[0, 0], [0, 0.25]], mass=400.0, inertia=25.0, target_velocity=[0.0, 0.1, 0.0], rank_by="joint_impulse"
        ),
        ValueError,
        r"rank_by: 'joint_impulse' is zero for free joints",
    ),
    api(
        "capture-far-path",
        lambda f: ff.capture.plan_capture(M(arms=1), 0, [[0, 0], [0, 3.0]], mass=400.0, inertia=25.0),
        ff.capture.PathDoesNotFitError,
        r"fits|thrusters",
    ),
    # ---- more files, models and results
    api("load-broken-mjcf", lambda f: ff.load(f / "broken.xml"), ModelError, r"broken.xml: MuJoCo could not compile it"),
    api("load-xml-not-a-robot", lambda f: ff.load(f / "not_mujoco.xml"), ModelError, r"not_mujoco.xml"),
    api("load-bytes-path", lambda f: ff.load(b"robot.urdf"), TypeError, r"path: expected a model file path"),
    api("load-end-effector-bad-triple", lambda f: ff.load(ARM_URDF, end_effectors=[("tip", "tool0")]), ModelError, r"end_effectors\[0\]"),
    api("builder-duplicate-body", _builder(extra="duplicate"), ModelError, r"duplicate|already"),
    api("builder-zero-axis", _builder(joint={"axis": [0, 0, 0]}), ModelError, r"axis"),
    api("builder-unknown-parent", _builder(joint={"parent": "nowhere"}), (ModelError, UnknownNameError), r"nowhere"),
    api("builder-unknown-joint-type", _builder(joint={"type": "ball"}), ModelError, r"ball"),
    api("trajectory-load-bad-csv", lambda f: ff.Trajectory.load(f / "trajectory.csv"), ValueError, r"trajectory.csv"),
    api("trajectory-load-bad-npz", lambda f: ff.Trajectory.load(f / "trajectory.npz"), ValueError, r"trajectory.npz"),
    api("trajectory-save-unknown-type", lambda f: _short_traj().save(f / "run.xlsx"), ValueError, r"unknown trajectory file type '.xlsx'"),
    api(
        "trajectory-save-existing",
        lambda f: _short_traj().save(f / "trajectory.csv"),
        FileExistsError,
        r"never|not overwrite",
    ),
    api("animate-bad-type", lambda f: _short_traj().animate(f / "x.avi"), ValueError, r"unknown animation type '.avi'"),
    api("animate-bad-fps", lambda f: _short_traj().animate(f / "x.gif", fps=0), ValueError, r"fps"),
    api("save-model-unknown-type", lambda f: ff.save(M(), f / "model.obj2"), ValueError, r"unknown model file type"),
    api("inverse-dynamics-shape", lambda f: ff.inverse_dynamics(M(), Q, np.zeros(10), np.zeros(9)), ShapeError, r"acceleration"),
    api("forward-dynamics-torque-shape", lambda f: ff.forward_dynamics(M(), Q, np.zeros(10), np.zeros(3)), ShapeError, r"joint_torque"),
    api("forward-dynamics-bool-torque", lambda f: ff.forward_dynamics(M(), Q, np.zeros(10), [True] * 4), TypeError, r"joint_torque"),
    api("task-jacobian-attitude", lambda f: ff.task_jacobian(M(), Q, attitude="up"), (TypeError, ValueError), r"attitude"),
    api("function-wrong-model-type", lambda f: ff.generalized_jacobian(42, Q), TypeError, r"model: expected a freefloat.Model"),
    api("function-unknown-model-name", lambda f: ff.generalized_jacobian("papadopoulos1993", Q), ModelError, r"did you mean"),
    # ---- scenario files, through the API
    api(
        "scenario-q-deg-short",
        lambda f: ff.scenarios.load_scenario(f / "q_deg_short.toml"),
        ModelError,
        r"initial.q_deg: expected shape \(4,\)",
    ),
    api("scenario-q-and-q-deg", lambda f: ff.scenarios.load_scenario(f / "q_and_q_deg.toml"), ModelError, r"q_deg|one of"),
    api("scenario-unknown-joint-ref", lambda f: ff.scenarios.load_scenario(f / "unknown_joint_ref.toml"), ModelError, r"arm9_q1"),
    api("scenario-rk4-without-step", lambda f: ff.scenarios.load_scenario(f / "rk4_without_step.toml"), ModelError, r"fixed_step"),
    api("scenario-step-not-dividing", lambda f: ff.scenarios.load_scenario(f / "step_not_dividing.toml"), ModelError, r"does not divide"),
    api(
        "scenario-unknown-method",
        lambda f: ff.scenarios.load_scenario(f / "unknown_method.toml"),
        ModelError,
        r"unknown integrator 'Euler'",
    ),
    api("scenario-unknown-controller", lambda f: ff.scenarios.load_scenario(f / "unknown_controller.toml"), ModelError, r"lqr"),
    api(
        "scenario-negative-limit",
        lambda f: ff.scenarios.load_scenario(f / "negative_limit.toml"),
        (ModelError, ValueError),
        r"joint_torque",
    ),
    api("scenario-text-gain", lambda f: ff.scenarios.load_scenario(f / "text_gain.toml"), (ModelError, TypeError), r"kp"),
    api("scenario-bool-gain", lambda f: ff.scenarios.load_scenario(f / "bool_gain.toml"), (ModelError, TypeError), r"kp"),
    api("scenario-no-model", lambda f: ff.scenarios.load_scenario(f / "no_model.toml"), ModelError, r"model: missing"),
    api("scenario-missing-model-file", lambda f: ff.scenarios.load_scenario(f / "missing_model_file.toml"), ModelError, r"nothere.urdf"),
    api("scenario-malformed", lambda f: ff.scenarios.load_scenario(f / "malformed_scenario.toml"), ModelError, r"malformed TOML"),
    api("scenario-missing-file", lambda f: ff.scenarios.load_scenario(f / "nothere.toml"), FileNotFoundError, r"no such scenario file"),
    api("capture-inertia-text", lambda f: ff.scenarios.load_capture_scenario(f / "capture_inertia_text.toml"), ModelError, r"inertia"),
    api("capture-path-1d", lambda f: ff.scenarios.load_capture_scenario(f / "capture_path_1d.toml"), ModelError, r"path.points"),
    api("capture-path-nan", lambda f: ff.scenarios.load_capture_scenario(f / "capture_path_nan.toml"), ModelError, r"path.points"),
    api("capture-bad-rule", lambda f: ff.scenarios.load_capture_scenario(f / "capture_bad_rule.toml"), ModelError, r"diagonal"),
    api("capture-singularity-key", lambda f: ff.scenarios.load_capture_scenario(f / "capture_singularity_key.toml"), ModelError, r"colour"),
    api("capture-limit-order", lambda f: ff.scenarios.load_capture_scenario(f / "capture_limit_order.toml"), ModelError, r"arm1_q1"),
    api(
        "capture-limit-unknown-joint",
        lambda f: ff.scenarios.load_capture_scenario(f / "capture_limit_unknown_joint.toml"),
        ModelError,
        r"arm9_q1",
    ),
    # ---- what the command-line table found: the same inputs through the API
    api(
        "load-unknown-link",
        lambda f: ff.load(f / "unknown_link.urdf"),
        ModelError,
        r"unknown_link\.urdf: joints\[7\] \(loop\)\.child: unknown body",
    ),
    api("load-two-parents", lambda f: ff.load(f / "two_parents.urdf"), ModelError, r"two_parents\.urdf: .*already has parent joint"),
    api("load-nan-inertia", lambda f: ff.load(f / "nan_inertia.urdf"), ModelError, r"\(spacecraft\)\.inertia: has NaN or infinite entries"),
    api("load-huge-inertia", lambda f: ff.load(f / "huge_inertia.urdf"), ModelError, r"\(spacecraft\)\.inertia: 1e\+300 kg m\^2 is above"),
    api("load-inf-inertial-origin", lambda f: ff.load(f / "inf_origin.urdf"), ModelError, r"inertial\.origin: has NaN or infinite entries"),
    api(
        "load-nan-joint-origin",
        lambda f: ff.load(f / "nan_joint_origin.urdf"),
        ModelError,
        r"\(shoulder_yaw\)\.origin: has NaN or infinite",
    ),
    api(
        "load-mjcf-huge-mass",
        lambda f: ff.load(f / "huge_mass.xml"),
        ModelError,
        r"huge_mass\.xml: bodies\[1\] \(a\)\.mass: 1e\+12 kg is above",
    ),
    api(
        "load-strict-ref",  # (was load-strict-stiffness: the joints' springs are modelled now; <joint ref> is still not)
        lambda f: ff.load(f / "ref.xml", strict=True),
        ModelError,
        r"ref\.xml: MJCF <joint ref>: is not modelled by freefloat \(.*\): joint 'j' ref=0\.00872665 rad; remove",
    ),
    api(
        "load-joints-unknown-name",
        lambda f: ff.load("papadopoulos1992", joints={"arm1_q7": {"armature": 0.1}}),
        ModelError,
        r"^joints: arm1_q7: is not a joint of 'papadopoulos1992' \(did you mean 'arm1_q2', 'arm1_q1'",
    ),
    api(
        "load-joints-unknown-key",
        lambda f: ff.load("papadopoulos1992", joints={"arm1_q1": {"spring": 0.1}}),  # (stiffness is a key now)
        ModelError,
        r"^joints: arm1_q1\.spring: unknown key; allowed keys: armature, damping, friction, springref, stiffness",
    ),
    api(
        "load-joints-text",
        lambda f: ff.load("papadopoulos1992", joints={"arm1_q1": {"armature": "big"}}),
        ModelError,
        r"^joints: arm1_q1\.armature: cannot read 'big' as a number",
    ),
    api(
        "load-joints-negative",
        lambda f: ff.load("papadopoulos1992", joints={"arm1_q1": {"damping": -2.0}}),
        ModelError,
        r"^joints\[0\] \(arm1_q1\)\.damping: is -2\.0; give the viscous damping",
    ),
    api("load-joints-not-a-table", lambda f: ff.load("papadopoulos1992", joints=[1, 2]), TypeError, r"^joints: expected a table"),
    api("load-joints-missing-file", lambda f: ff.load("papadopoulos1992", joints=f / "nothere.toml"), ModelError, r"nothere\.toml"),
    api(
        "load-mjcf-negative-damping",
        lambda f: ff.load(f / "negative_damping.xml"),
        ModelError,
        r"negative_damping\.xml|damping",
    ),
    api("builder-negative-armature", _builder(joint={"armature": -1.0}), ModelError, r"joints\[0\] \(j1\)\.armature: is -1\.0"),
    api("builder-text-friction", _builder(joint={"friction": "lots"}), ModelError, r"joints\[0\] \(j1\)\.friction: cannot read 'lots'"),
    api("builder-nan-damping", _builder(joint={"damping": float("nan")}), ModelError, r"joints\[0\] \(j1\)\.damping: is nan"),
    api("builder-negative-stiffness", _builder(joint={"stiffness": -3.0}), ModelError, r"joints\[0\] \(j1\)\.stiffness: is -3\.0"),
    api("builder-nan-springref", _builder(joint={"springref": float("nan")}), ModelError, r"joints\[0\] \(j1\)\.springref: is nan"),
    api("simulate-passive-unknown", lambda f: ff.simulate(M(), S, 0.1, passive="off"), ValueError, r"^passive: 'off' is not one of"),
    api("rollout-passive-none", lambda f: ff.rollout(M(), ff.State(q=[Q, Q]), 0.1, dt=0.01, passive=None), ValueError, r"^passive: None"),
    api(
        "load-massless-body", lambda f: ff.load(f / "massless.urdf"), ModelError, r"massless\.urdf: bodies \(spacecraft\)\.mass: a massless"
    ),
    api(
        "builder-nan-rotation",
        _builder(joint={"rotation": np.full((3, 3), np.nan)}),
        ModelError,
        r"\.rotation: has NaN or infinite entries",
    ),
    api(
        "payload-bool-inertia",
        lambda f: M().with_payload(0, mass=1.0, inertia=[True, True, True]),
        ModelError,
        r"inertia: cannot read \[True, True, True\] as an inertia",
    ),
    api(
        "capture-huge-path",
        lambda f: ff.capture.plan_capture(M(arms=1), 0, [[0, 0], [0, 1e300]], mass=400.0, inertia=25.0),
        ValueError,
        r"path: 1e\+300 m is beyond the 10000 m",
    ),
    api(
        "capture-huge-threshold",
        lambda f: ff.capture.plan_capture(
            M(arms=1),
            0,
            [[0, 0], [0, 0.25]],
            mass=400.0,
            inertia=25.0,
            samples=256,
            criterion=ff.workspace.SingularityCriterion(threshold=1e10),
            strategy="path",
        ),
        ValueError,
        r"threshold: 1e\+10 is at or above 3\.26 \(m\^2\), a bound .*every configuration would count as singular",
    ),
    api(
        "simulate-huge-initial-rate",
        lambda f: ff.simulate(M(), ff.State(q=Q, qdot=[1e300, 0, 0, 0]), 1.0),
        ff.SimulationError,
        r"at t = 0 s: joint 'arm1_q1' moves at 1e\+300 rad/s, beyond 10000 rad/s",
    ),
    api(
        "simulate-huge-initial-spin",
        lambda f: ff.simulate(M(), ff.State(q=Q, omega=[0, 0, 1e100]), 1.0, fixed_step=0.01),
        ff.SimulationError,
        r"at t = 0 s: the spacecraft moves at 1e\+100 rad/s, beyond 10000 rad/s",
    ),
    api(
        "simulate-huge-sample-period",
        lambda f: ff.simulate(M(), S, 0.02, ff.JointPD(kp=1.0, kd=1.0), fixed_step=0.01, sample_period=1e300, divergence_guard=False),
        ff.core.errors.StiffGainsWarning,
        r"JointPD sampled every 1e\+300 s is unstable",
    ),
    api(
        "pd-huge-q-ref",
        lambda f: ff.JointPD(kp=1.0, kd=1.0, q_ref=[1e300, 0, 0, 0]),
        ValueError,
        r"JointPD\.q_ref: 1e\+300 is beyond 1e\+06",
    ),
    # ---- absurd but finite: positions, speeds, rates, torques, tolerances, thresholds beyond any space robot's
    api(
        "state-huge-r-cm",
        lambda f: ff.State(r_cm=[1e300, 0, 0]),
        ValueError,
        r"^State\.r_cm: 1e\+300 is beyond 1e\+12 \(m\), farther than any space robot goes .*check the units \(metres\)",
    ),
    api(
        "state-huge-v-cm",
        lambda f: ff.State(v_cm=[0, 0, -1e9]),
        ValueError,
        r"^State\.v_cm: -1e\+09 is beyond 1e\+08 \(m/s\), a third of the speed of light",
    ),
    api(
        "simulate-huge-rtol",
        lambda f: ff.simulate(M(), S, 1.0, rtol=1e300),
        ValueError,
        r"^rtol: 1e\+300 is not below 1: a relative tolerance of 1 or more asks for no accuracy at all; give a small",
    ),
    api("simulate-tiny-rtol", lambda f: ff.simulate(M(), S, 1.0, rtol=1e-300), ValueError, r"^rtol: 1e-300 is below 2\.22e-14"),
    api("simulate-huge-atol", lambda f: ff.simulate(M(), S, 1.0, atol=1e300), ValueError, r"^atol: 1e\+300 is not below 1"),
    *(
        api(
            f"simulate-controller-torque-{v:.0e}",
            lambda f, v=v: ff.simulate(M(), S, 1.0, lambda t, s: np.full(4, v)),
            ff.SimulationError,
            re.escape(f"controller returned a joint_torque of {v:.0e}, beyond 1e+19 (N m or N)"),
        )
        for v in (1e20, 1e200, 1e300)
    ),
    *(  # the fixed-step loop: the compiled step refuses the torques before it steps (Stepper.REFUSED), the same words
        api(
            f"simulate-rk4-controller-torque-{name}",
            lambda f, v=v, lim=lim: ff.simulate(M(), S, 1.0, lambda t, s: np.full(4, v), fixed_step=0.01, limits=lim),
            ff.SimulationError,
            needle,
        )
        for name, v, lim, needle in (
            ("1e20", 1e20, None, re.escape("controller returned a joint_torque of 1e+20, beyond 1e+19 (N m or N)")),
            ("nan", np.nan, None, "controller returned a non-finite joint_torque"),
            ("inf-with-limits", np.inf, ff.ActuatorLimits(joint_torque=5.0), "controller returned a non-finite joint_torque"),
        )
    ),
    api(
        "pd-huge-qdot-ref",
        lambda f: ff.JointPD(kp=1.0, kd=1.0, qdot_ref=[1e300, 0, 0, 0]),
        ValueError,
        r"^JointPD\.qdot_ref: 1e\+300 is beyond 10000 \(rad/s or m/s\), which no joint .*check the units",
    ),
    api(
        "pd-huge-feedforward",
        lambda f: ff.JointPD(kp=1.0, kd=1.0, feedforward=[[1e300, 0, 0, 0]]),
        ValueError,
        r"^JointPD\.feedforward: 1e\+300 is beyond 1e\+19 \(N m or N\)",
    ),
    api(
        "pd-empty-feedforward",
        lambda f: ff.JointPD(kp=1.0, kd=1.0, feedforward=np.zeros((0, 4))),
        ShapeError,
        r"^JointPD\.feedforward: expected \(K, N\) or \(K, B, N\) torques per sample, K >= 1, got shape \(0, 4\) "
        r"\(no feed-forward: leave it None\)",
    ),
    api(
        "pd-text-feedforward-period",
        lambda f: ff.JointPD(kp=1.0, kd=1.0, feedforward=np.zeros((2, 4)), feedforward_period="fast"),
        ValueError,
        r"^JointPD\.feedforward_period: give the time between feed-forward samples \(s, a finite number > 0\), got 'fast'",
    ),
    api(
        "workspace-huge-threshold",
        lambda f: ff.workspace.workspace_limits(M(), criterion=ff.workspace.SingularityCriterion(threshold=1e300)),
        ValueError,
        r"^threshold: 1e\+300 is at or above 5\.09e\+05 \(m\^4\), a bound that \|det\| of J\* never reaches on 'papadopoulos1992'",
    ),
    api(
        "piw-huge-threshold",
        lambda f: ff.workspace.path_independent_workspace(
            M(), 0, samples=256, criterion=ff.workspace.SingularityCriterion(rows="position", measure="sigma_min", threshold=1e300)
        ),
        ValueError,
        r"^threshold: 1e\+300 is at or above 26\.7 \(m\), a bound that \|sigma_min\| of J\* never reaches",
    ),
    api(
        "load-text-mass",
        lambda f: ff.load(f / "text_mass.urdf"),
        ModelError,
        r"text_mass\.urdf: link\[0\] \(spacecraft\)\.inertial\.mass\.value: cannot read 'heavy' as a number",
    ),
    api(
        "load-no-parent",
        lambda f: ff.load(f / "no_parent.urdf"),
        ModelError,
        r"no_parent\.urdf: joint\[0\] \(shoulder_yaw\)\.parent: is missing",
    ),
    api(
        "load-parent-without-link",
        lambda f: ff.load(f / "parent_without_link.urdf"),
        ModelError,
        r"parent_without_link\.urdf: joint\[0\] \(shoulder_yaw\)\.parent: has no link attribute",
    ),
    api(
        "scenario-bool-array",
        lambda f: ff.scenarios.scenario_from_dict(
            {"model": "papadopoulos1992", "duration": 1.0, "initial": {"q": [True, False, True, False]}}
        ),
        ModelError,
        r"initial\.q: expected numbers, got \[True",
    ),
    api(
        "scenario-huge-step",
        lambda f: ff.scenarios.scenario_from_dict(
            {"model": "papadopoulos1992", "duration": 1.0, "integrator": {"method": "RK4", "fixed_step": 1e300}}
        ),
        ModelError,
        r"integrator\.fixed_step: 1e\+300 s does not divide duration 1\.0 s",
    ),
    api(
        "capture-scenario-description",
        lambda f: ff.scenarios.capture_scenario_from_dict(tomllib.loads(_edit(CAP, ("description = ", "description = 5\n#")))),
        ModelError,
        r"description: expected a string, got 5",
    ),
]

# ---- the command line
_FILE_MODELS = {  # command -> (its arguments with a model file whose end effectors -e may name, with a built-in model)
    "inspect": (f"inspect {ARM_URDF}", "inspect papadopoulos1992"),
    "specialise": (f"specialise {ARM_URDF}", "specialise papadopoulos1992"),
    "workspace": (f"workspace {ARM_URDF}", "workspace papadopoulos1992"),
    "capture": ("capture {files}/cap/arm.toml", f"capture {CAPTURE}"),
    "simulate": ("simulate {files}/sim/arm.toml --out out", f"simulate {SCENARIO} --out out"),
}
END_EFFECTORS = [  # (id, on the model file (else the built-in model), arguments, what the error says)
    ("ee-unknown", True, "-e nowhere", r"end_effectors\[0\] \(nowhere\)\.body: 'nowhere' is not a body or frame"),
    ("ee-index", True, "-e 7", r"end_effectors\[0\] \(7\)\.body: '7' is not a body or frame"),
    ("ee-empty", True, "--end-effector=", r"end_effectors(\[0\]\.name)?: expected a (non-empty string|list of names), got \[?''"),
    ("ee-duplicate", True, "-e tool0 -e tool0", r"end_effectors\[1\]\.name: duplicate end-effector name 'tool0'"),
    ("ee-of-builtin", False, "-e arm1_ee", r"is a built-in model, whose end effectors are fixed"),
]
PAYLOAD = [  # inspect and workspace: (id, arguments, what the error says, exit code)
    ("mass-nan", "--payload-mass nan --payload-inertia 1", r"^error: --payload-mass: must be positive and finite, got nan", 1),
    ("mass-inf", "--payload-mass inf --payload-inertia 1", r"^error: --payload-mass: must be positive and finite, got inf", 1),
    ("mass-minus-inf", "--payload-mass -inf --payload-inertia 1", r"^error: --payload-mass: must be positive and finite, got -inf", 1),
    ("mass-negative", "--payload-mass -5 --payload-inertia 1", r"^error: --payload-mass: must be positive and finite, got -5\.0", 1),
    ("mass-zero", "--payload-mass 0 --payload-inertia 1", r"^error: --payload-mass: must be positive and finite, got 0\.0", 1),
    ("mass-huge", "--payload-mass 1e300 --payload-inertia 1", r"^error: --payload-mass: 1e\+300 kg is above the 1e\+09 kg", 1),
    ("mass-text", "--payload-mass heavy --payload-inertia 1", r"Invalid value for '--payload-mass'", 2),
    ("inertia-nan", "--payload-mass 5 --payload-inertia nan", r"^error: --payload-inertia: has NaN or infinite entries", 1),
    ("inertia-negative", "--payload-mass 5 --payload-inertia -1", r"^error: --payload-inertia: is not positive definite", 1),
    ("inertia-huge", "--payload-mass 5 --payload-inertia 1e300", r"^error: --payload-inertia: 1e\+300 kg m\^2 is above", 1),
    ("inertia-text", "--payload-mass 5 --payload-inertia heavy", r"--payload-inertia: cannot read 'heavy' as numbers", 1),
    ("inertia-two-numbers", "--payload-mass 5 --payload-inertia 1,2", r"--payload-inertia: expected 1, 3 or 9 numbers, got 2", 1),
    ("inertia-empty", "--payload-mass 5 --payload-inertia=", r"--payload-inertia: expected 1, 3 or 9 numbers, got 0", 1),
    ("inertia-triangle", "--payload-mass 5 --payload-inertia 1,1,5", r"^error: --payload-inertia: violates the triangle inequality", 1),
    ("inertia-not-symmetric", "--payload-mass 5 --payload-inertia 1,2,3,4,5,6,7,8,9", r"^error: --payload-inertia: is not symmetric", 1),
    (
        "ee-out-of-range",
        "--payload-mass 5 --payload-inertia 1 --payload-ee 5",
        r"^error: --payload-ee: unknown end effector 5; known: 0=arm1_ee, 1=arm2_ee",
        1,
    ),
    ("ee-unknown", "--payload-mass 5 --payload-inertia 1 --payload-ee nowhere", r"^error: --payload-ee: unknown end effector 'nowhere'", 1),
    ("inertia-without-mass", "--payload-inertia 1", r"--payload-inertia and --payload-ee need --payload-mass", 1),
    ("mass-without-inertia", "--payload-mass 400", r"--payload-mass needs --payload-inertia", 1),
]
CRITERION = [  # workspace and capture: (id, arguments, what the error says, exit code)
    ("threshold-nan", "--threshold nan", r"threshold: expected a finite number >= 0 .*got nan", 1),
    ("threshold-inf", "--threshold inf", r"threshold: expected a finite number >= 0 .*got inf", 1),
    ("threshold-minus-inf", "--threshold -inf", r"threshold: expected a finite number >= 0 .*got -inf", 1),
    ("threshold-negative", "--threshold -1", r"threshold: expected a finite number >= 0 .*got -1\.0", 1),
    (
        "threshold-huge",
        "--threshold 1e300",
        r"threshold: 1e\+300 is at or above \S+ \(m\^\d\), a bound that \|det\| of J\* never reaches",
        1,
    ),
    ("threshold-text", "--threshold small", r"Invalid value for '--threshold'", 2),
    ("rows-unknown", "--rows diagonal", r"rows: expected one of auto, full, position, got 'diagonal'", 1),
    ("rows-empty", "--rows=", r"rows: expected one of auto, full, position, got ''", 1),
    ("measure-unknown", "--measure volume", r"measure: expected one of .*, got 'volume'", 1),
    ("measure-empty", "--measure=", r"measure: expected one of .*, got ''", 1),
]
BAD_OUTS = [  # every command with --out: (id, arguments, what the error says)
    ("out-proc", "--out /proc/freefloat-out", r"--out /proc/freefloat-out: cannot create this folder"),
    ("out-under-proc", "--out /proc/nothere/out", r"--out /proc/nothere/out: cannot create this folder"),
    ("out-is-a-file", "--out {files}/empty.toml", r"empty\.toml: exists and is not a directory; choose another --out"),
    ("out-is-a-device", "--out /dev/null", r"--out /dev/null: exists and is not a directory"),
    ("out-under-a-file", "--out {files}/empty.toml/sub", r"empty\.toml/sub: cannot create this folder \(Not a directory\)"),
    ("out-empty", "--out=", r"--out: an empty path would write into the current directory"),
    ("out-earlier-run", "--out {files}/earlier", r"the run would replace files \(\S+/earlier/\S+ exists\); nothing was run"),
    ("out-earlier-run-overwrite", "--out {files}/earlier --overwrite", r"was not written by freefloat .*; nothing was run"),
    ("out-changed-since", "--out {files}/changed --overwrite", r"was changed after freefloat wrote it.*; nothing was run"),
]
_OUT_COMMANDS = {"demo": "demo", "reproduce": "reproduce 1992", "workspace": "workspace papadopoulos1992"}
_OUT_COMMANDS |= {"capture": f"capture {CAPTURE}", "simulate": f"simulate {SCENARIO}"}
BAD_SCENARIOS = [  # simulate and capture: (id, SCENARIO, what the error says)
    ("scenario-missing", "{files}/nothere.toml", r"nothere\.toml: no such scenario file"),
    ("scenario-directory", "{files}", r"files: is not a file; give a scenario TOML file"),
    ("scenario-empty", "{files}/empty.toml", r"empty\.toml: model: missing or not a string \(None\)"),
    ("scenario-binary", "{files}/binary.toml", r"binary\.toml: is not UTF-8 text; save the scenario as UTF-8 TOML"),
    ("scenario-malformed", "{files}/malformed_scenario.toml", r"malformed_scenario\.toml: malformed TOML: Expected ']'"),
    ("scenario-cut-mid-table", "{files}/cut_mid_table.toml", r"cut_mid_table\.toml: malformed TOML: Unterminated string"),
    ("scenario-is-a-urdf", str(ARM_URDF), r"six_dof_arm\.urdf: malformed TOML: Invalid statement"),
    ("scenario-is-a-model", str(TOML), r"papadopoulos1992_two_arm\.toml: is a model file \(it has \[\[bodies\]\]\), not a scenario"),
]

CASES += [
    cli(f"cli-{command}-model-{id}", f"{command} {model}", match)
    for command in ("inspect", "specialise", "workspace")
    for id, model, _, match in BAD_MODELS
]
CASES += [
    cli(f"cli-simulate-model-{id}", f"simulate {{files}}/sim/model-{id}.toml --out out", rf"model: .*{match}")
    for id, _, _, match in BAD_MODELS
]
CASES += [cli(f"cli-capture-model-{id}", f"capture {{files}}/cap/model-{id}.toml", rf"model: .*{match}") for id, _, _, match in BAD_MODELS]
CASES += [cli(f"cli-simulate-{id}", f"simulate {{files}}/sim/{id}.toml --out out", match) for id, match, _ in SIMULATION_EDITS]
CASES += [cli(f"cli-capture-{id}", f"capture {{files}}/cap/{id}.toml", match) for id, match, _ in CAPTURE_EDITS]
CASES += [cli(f"cli-simulate-{id}", f"simulate {path} --out out", match) for id, path, match in BAD_SCENARIOS]

# reaction wheels through the API (the files' and scenarios' wheels are in SIMULATION_EDITS and CAPTURE_EDITS)
WHEELED = [{"name": "rw", "axis": [0.0, 0.0, 1.0], "inertia": 0.1}]
CASES += [
    api(
        "wheel-torque-without-wheels",
        lambda f: ff.simulate(M(arms=1), ff.State(), 0.1, lambda t, s: ff.Actuation(wheel_torque=[0.1]), fixed_step=0.01),
        ff.SimulationError,
        r"bad controller output at t = 0 s: controller returned wheel torques, but 'papadopoulos1992_one_arm' has no reaction wheels",
    ),
    api(
        "wheel-speed-without-wheels",
        lambda f: ff.State(wheel_speed=[1.0]).resolve(M(arms=1)),
        ShapeError,
        r"State\.wheel_speed: expected shape \(\.\.\., 0\) \('papadopoulos1992_one_arm' has no reaction wheels\)",
    ),
    # (rollout simulates wheels now, per-trajectory wheels included: the case that it refused them became these)
    api(
        "rollout-wheel-variants-of-another-number",
        lambda f: ff.rollout(
            [ff.load("papadopoulos1992", wheels=WHEELED), ff.load("papadopoulos1992", wheels=[*WHEELED, {**WHEELED[0], "name": "rw2"}])],
            ff.State(q=np.zeros((2, 4))),
            0.1,
            dt=0.01,
        ),
        ModelError,
        r"model\[1\]\.wheels: 'papadopoulos1992' has 2 reaction wheels, model\[0\] \('papadopoulos1992'\) 1; per-trajectory models "
        r"may differ in their wheels' inertia, max_torque, max_speed, viscous and coulomb, not in their number or axes",
    ),
    api(
        "rollout-wheel-variants-of-other-axes",
        lambda f: ff.rollout(
            [ff.load("papadopoulos1992", wheels=WHEELED), ff.load("papadopoulos1992", wheels=[{**WHEELED[0], "axis": [1.0, 0.0, 0.0]}])],
            ff.State(q=np.zeros((2, 4))),
            0.1,
            dt=0.01,
        ),
        ModelError,
        r"model\[1\]\.wheels: the reaction wheels of 'papadopoulos1992' spin about other axes than model\[0\]'s",
    ),
    api(
        "controller-wheel-variants-of-other-axes",
        lambda f: ff.control.Detumble(
            [ff.load("papadopoulos1992", wheels=WHEELED), ff.load("papadopoulos1992", wheels=[{**WHEELED[0], "axis": [0.0, 1.0, 0.0]}])],
            torque_by="wheels",
        ),
        ModelError,
        r"model\[1\]\.wheels: the reaction wheels of 'papadopoulos1992' spin about other axes .* run each set of wheels as its own rollout",
    ),
    api(
        "torque-by-wheels-without-wheels",
        lambda f: ff.control.Detumble(M(arms=1), torque_by="wheels"),
        ValueError,
        r"torque_by: 'wheels', but 'papadopoulos1992_one_arm' has no reaction wheels; declare them",
    ),
    api("torque-by-unknown", lambda f: ff.control.Detumble(M(arms=1), torque_by="gyros"), ValueError, r"torque_by: expected one of"),
    api(
        "wheel-torque-limit-negative",
        lambda f: ff.load("papadopoulos1992", wheels=[{**WHEELED[0], "max_torque": -1.0}]),
        ModelError,
        r"wheels\[0\] \(rw\)\.max_torque: must be positive and finite, got -1\.0; give the torque limit in N m",
    ),
    api(
        "wheel-speed-wrong-size",
        lambda f: ff.simulate(ff.load("papadopoulos1992", wheels=WHEELED), ff.State(wheel_speed=[1.0, 2.0]), 0.1, fixed_step=0.01),
        ShapeError,
        r"State\.wheel_speed: expected shape \(\.\.\., 1\) \(one speed per reaction wheel of 'papadopoulos1992': rw\)",
    ),
]

# campaigns (docs/campaigns.md): each refused before any cluster starts or any run is computed
_CAMPAIGN = f'scenario = "{SCENARIO.as_posix()}"\n[parameters]\n'
_add("camp/unknown-parameter.toml", _CAMPAIGN + '"target.mass" = { values = [1.0, 2.0] }\n')
_add("camp/unknown-distribution.toml", _CAMPAIGN + '"controller.kp" = { distribution = "weibull", shape = 2.0 }\n')
_add("camp/ok.toml", _CAMPAIGN + '"controller.kp" = { values = [1.0, 2.0] }\n')
CASES += [
    cli(
        "cli-campaign-unknown-parameter",
        "campaign {files}/camp/unknown-parameter.toml --out out",
        r"parameters\.target\.mass: unknown parameter",
    ),
    cli(
        "cli-campaign-unknown-distribution",
        "campaign {files}/camp/unknown-distribution.toml --out out",
        r"parameters\.controller\.kp\.distribution: unknown distribution 'weibull'",
    ),
    cli(
        "cli-campaign-unreachable-scheduler",
        "campaign {files}/camp/ok.toml --out out --scheduler tcp://127.0.0.1:1",
        r"--scheduler tcp://127\.0\.0\.1:1: no Dask scheduler answered within 4 s",
    ),
]
CASES += [cli(f"cli-capture-{id}", f"capture {path}", match) for id, path, match in BAD_SCENARIOS]
CASES += [
    cli(f"cli-{command}-{id}", f"{args[0] if on_file else args[1]} {option}", match)
    for command, args in _FILE_MODELS.items()
    for id, on_file, option, match in END_EFFECTORS
]
CASES += [
    cli(f"cli-{command}-payload-{id}", f"{command} papadopoulos1992 {args}", match, code)
    for command in ("inspect", "workspace")
    for id, args, match, code in PAYLOAD
]
CASES += [
    cli(f"cli-{command}-{id}", f"{prefix} {args}", match, code)
    for command, prefix in (("workspace", "workspace papadopoulos1992"), ("capture", f"capture {CAPTURE}"))
    for id, args, match, code in CRITERION
]
CASES += [
    cli(f"cli-{command}-{id}", f"{prefix} {args}", match) for command, prefix in _OUT_COMMANDS.items() for id, args, match in BAD_OUTS
]
CASES += [  # capture --rank-by: how a moving target's capture posture is chosen
    cli(
        "cli-capture-option-rank-by-unknown", f"capture {CAPTURE} --rank-by cheapest", r"--rank-by 'cheapest': unknown criterion 'cheapest'"
    ),
    cli("cli-capture-option-rank-by-empty", f"capture {CAPTURE} --rank-by=", r"--rank-by '': unknown criterion ''"),
    cli(
        "cli-capture-option-rank-by-at-rest",
        f"capture {CAPTURE} --rank-by spacecraft_rate",
        r"--rank-by 'spacecraft_rate': 'spacecraft_rate' ranks the grasp of a moving target, and no motion of the target is given",
    ),
    cli(
        "cli-capture-option-rank-by-joint-impulse-free",
        f"capture {MOVING} --rank-by joint_impulse",
        r"--rank-by 'joint_impulse': 'joint_impulse' is zero for free joints",
    ),
]
CASES += [
    cli(f"cli-{command}-strict-{id}", f"{command} {model} --strict", match)
    for command in ("inspect", "specialise", "workspace")
    for id, model, match in (
        ("ets7", "ets7", r"MODEL 'ets7': is a built-in model whose published data needed 3 correction\(s\) .*which strict refuses"),
        ("triangle", "{files}/triangle.urdf", r"triangle\.urdf: link\[0\] \(spacecraft\)\.inertia: violates the triangle inequality"),
        ("no-limit", "{files}/no_limit.urdf", r"no_limit\.urdf: joint\[0\] \(shoulder_yaw\)\.limit: a revolute joint without <limit>"),
        ("ref", "{files}/ref.xml", r"ref\.xml: MJCF <joint ref>: is not modelled by freefloat .*'j' ref=0\.0087"),
        ("gear", "{files}/geared.urdf", r"geared\.urdf: URDF <transmission> .*: is not .*'shoulder_yaw'\) mechanicalReduction=100"),
    )
]


def _tj(kp: Any, model: Any = None) -> Any:
    """The 1991 §V transposed-Jacobian controller with gains ``kp`` (one row per trajectory when (B, d))."""
    from freefloat.papers.paper1991 import section5_setup

    robot, task, _, target = section5_setup()
    return ff.control.TransposedJacobianController(robot if model is None else model, task, target, kp, 60.0)


def _s5() -> Any:
    from freefloat.papers.paper1991 import section5_setup

    return section5_setup()


CASES += [  # the built-in controllers compiled: per-trajectory parameters (issue 23)
    api(
        "compiled-kp-rows-single-simulation",
        lambda f: ff.simulate(_s5()[0], _s5()[2], 0.1, _tj(np.full((3, 5), 30.0)), fixed_step=0.01),
        ShapeError,
        r"kp: 3 per-trajectory values, but a single simulation has one trajectory; use freefloat\.rollout",
    ),
    api(
        "compiled-kp-rows-vs-batch",
        lambda f: ff.rollout(_s5()[0], ff.State(q=np.tile(_s5()[2].q, (4, 1))), 0.1, dt=0.01, controller=_tj(np.full((3, 5), 30.0))),
        ShapeError,
        r"kp: 3 per-trajectory values, but the rollout has 4 trajectories",
    ),
    api(
        "controller-rows-one-state",
        lambda f: _tj(np.full((3, 5), 30.0))(0.0, _s5()[2]),
        ShapeError,
        r"state: one state, but the controller has per-trajectory parameters",
    ),
    api(
        "controller-models-of-two-structures",
        lambda f: _tj(30.0, [_s5()[0], M()]),
        ValueError,
        r"model\[1\]: 'papadopoulos1992' has another structure than model\[0\]",
    ),
    api(
        "rollout-models-count",
        lambda f: ff.rollout([M(), M().with_payload(mass=10.0, inertia=1.0)], ff.State(q=np.zeros((4, 4))), 0.1, dt=0.01),
        ShapeError,
        r"model: 2 per-trajectory models, but initial_states has 4 trajectories",
    ),
]
_SIM = f"simulate {SCENARIO} --out out"
CASES += [
    # workspace: the end effectors to analyse and the samples of the PIW
    cli(
        "cli-workspace-arm-unknown", "workspace papadopoulos1992 --arm nowhere", r"unknown end effector 'nowhere'; known: arm1_ee, arm2_ee"
    ),
    cli("cli-workspace-arm-out-of-range", "workspace papadopoulos1992 --arm 7", r"unknown end effector 7; known: 0=arm1_ee, 1=arm2_ee"),
    cli("cli-workspace-arm-negative", "workspace papadopoulos1992 --arm -1", r"unknown end effector '-1'"),
    cli("cli-workspace-arm-empty", "workspace papadopoulos1992 --arm=", r"unknown end effector ''"),
    cli(
        "cli-workspace-samples-huge",
        "workspace papadopoulos1992 --samples 1000000000",
        r"more than this machine has free .*ask for fewer samples",
    ),
    cli(
        "cli-workspace-samples-1e30",
        f"workspace papadopoulos1992 --samples {10**30}",
        r"sampling 1e\+30 configurations .*ask for fewer samples",
    ),
    cli(
        "cli-workspace-samples-few",
        "workspace papadopoulos1992 --samples 3",
        r"'--samples': Input should be greater than or equal to 16",
        2,
    ),
    cli(
        "cli-workspace-samples-zero",
        "workspace papadopoulos1992 --samples 0",
        r"'--samples': Input should be greater than or equal to 16",
        2,
    ),
    cli("cli-workspace-samples-float", "workspace papadopoulos1992 --samples 1e6", r"'--samples': Input should be a valid integer", 2),
    cli("cli-workspace-samples-text", "workspace papadopoulos1992 --samples many", r"'--samples': Input should be a valid integer", 2),
    # capture: the planning strategy
    cli(
        "cli-capture-strategy-unknown",
        f"capture {CAPTURE} --strategy fastest",
        r"--strategy 'fastest': unknown; choose one of auto, piw, path",
    ),
    cli("cli-capture-strategy-empty", f"capture {CAPTURE} --strategy=", r"--strategy '': unknown; choose one of auto, piw, path"),
    # simulate: the wall-clock limit, the animation file and the kind of scenario
    cli("cli-simulate-wall-time-nan", f"{_SIM} --max-wall-time nan", r"--max-wall-time: expected a positive number of seconds, got nan"),
    cli("cli-simulate-wall-time-inf", f"{_SIM} --max-wall-time inf", r"--max-wall-time: expected a positive number of seconds, got inf"),
    cli("cli-simulate-wall-time-minus-inf", f"{_SIM} --max-wall-time -inf", r"--max-wall-time: expected a positive number .*got -inf"),
    cli("cli-simulate-wall-time-zero", f"{_SIM} --max-wall-time 0", r"--max-wall-time: expected a positive number of seconds, got 0\.0"),
    cli(
        "cli-simulate-wall-time-negative",
        f"{_SIM} --max-wall-time -5",
        r"--max-wall-time: expected a positive number of seconds, got -5\.0",
    ),
    cli("cli-simulate-wall-time-text", f"{_SIM} --max-wall-time soon", r"Invalid value for '--max-wall-time'", 2),
    cli("cli-simulate-animate-proc", f"{_SIM} --animate /proc/x.gif", r"--animate /proc/x\.gif: cannot write into /proc"),
    cli(
        "cli-simulate-animate-under-proc",
        f"{_SIM} --animate /proc/nothere/x.gif",
        r"--animate /proc/nothere/x\.gif: cannot write into /proc",
    ),
    cli("cli-simulate-animate-type", f"{_SIM} --animate x.avi", r"--animate x\.avi: unknown animation type '\.avi'"),
    cli("cli-simulate-animate-directory", f"{_SIM} --animate {{files}}", r"unknown animation type ''; use \.gif \(Pillow\) or \.mp4"),
    cli("cli-simulate-animate-empty", f"{_SIM} --animate=", r"--animate \.: unknown animation type ''"),
    cli("cli-simulate-animate-existing", f"{_SIM} --animate {{files}}/old.gif", r"old\.gif: exists; freefloat never overwrites a file"),
    cli(
        "cli-simulate-animate-under-a-file",
        f"{_SIM} --animate {{files}}/empty.toml/x.gif",
        r"cannot write into \S+/empty\.toml \(NotADirectoryError\)",
    ),
    cli("cli-simulate-capture-scenario", f"simulate {CAPTURE} --out out", r"is a capture scenario \(it has \[payload\] and \[path\]\)"),
    cli("cli-capture-simulation-scenario", f"capture {SCENARIO}", r"is a simulation scenario \(it has a duration and no \[payload\]\)"),
    # reproduce and specialise: the paper, the kind of kernel
    cli("cli-reproduce-unknown", "reproduce 1993 --out out", r"PAPER '1993': unknown; choose one of 1991, 1992"),
    cli("cli-reproduce-float", "reproduce 1991.0 --out out", r"PAPER '1991\.0': unknown; choose one of 1991, 1992"),
    cli("cli-reproduce-short", "reproduce 92 --out out", r"PAPER '92': unknown; choose one of 1991, 1992"),
    cli("cli-specialise-unknown-kind", "specialise papadopoulos1992 --kind everything", r"unknown kind of specialised kernel 'everything'"),
    cli(
        "cli-specialise-kind-case", "specialise papadopoulos1992 --kind JSTAR", r"unknown kind of specialised kernel 'JSTAR'; known: jstar"
    ),
    cli("cli-specialise-kind-empty", "specialise papadopoulos1992 --kind=", r"unknown kind of specialised kernel ''; known: jstar"),
    cli("cli-unknown-option", "inspect papadopoulos1992 --colour red", r"No such option: --colour", code=2),
    cli("cli-unknown-command", "simulat x.toml", r"No such command 'simulat'", code=2),
]

# The classes of issue 40 (campaign specs and storage, the cluster, the capture sequence, targets, detumbling, wheels,
# per-trajectory parameters, relative paths), one module each.
CASES += bad_inputs_campaigns.CASES + bad_inputs_capture.CASES + bad_inputs_models.CASES


class Hang(BaseException):
    """The alarm of :func:`scratch_dir`: a BaseException, so that neither the library nor the command line's error handler
    (which turns OSError, such as TimeoutError, into an ``error:`` line) can take it for a bad input."""


@dataclass
class Scratch:
    """A case's scratch folder: the working directory ``work``, the bad files in ``files``; ``side_effects`` after it closed."""

    work: Path
    files: Path
    side_effects: list[str] = field(default_factory=list)


def _listing(folder: Path) -> list[str]:
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*"))


@contextmanager
def scratch_dir(root: Path, scenarios: tuple[str, ...] = (), seconds: int = 60) -> Iterator[Scratch]:
    """Run a case in ``root``: the bad files in ``root/files`` (:data:`BAD_FILES` and the ``scenarios`` of
    :data:`SCENARIO_FILES`), the working directory ``root/work`` (empty), memory answers
    independent of the machine (FREEFLOAT_MEMORY_LIMIT=16G) and an alarm that raises :class:`Hang` after ``seconds``.

    When the block ends, ``side_effects`` lists what the case changed: an input file, a file next to the inputs, a file in
    the working directory (an output folder that a refused run left behind included)."""
    files, work = root / "files", root / "work"
    made = {**BAD_FILES, **{name: SCENARIO_FILES[name] for name in scenarios}}
    inputs = {files / name: content if isinstance(content, bytes) else content.encode() for name, content in made.items()}
    for folder in sorted({path.parent for path in inputs}):
        folder.mkdir(parents=True)
    for path, content in inputs.items():
        path.write_bytes(content)
    inputs |= {path: path.read_bytes() for path in (ARM_URDF, TOML, SCENARIO, CAPTURE)}
    work.mkdir()
    listing = _listing(files)
    scratch = Scratch(work, files)
    cwd, memory = Path.cwd(), os.environ.get("FREEFLOAT_MEMORY_LIMIT")
    os.chdir(work)
    os.environ["FREEFLOAT_MEMORY_LIMIT"] = "16G"  # memory answers independent of the machine

    def timeout(signum: int, frame: Any) -> None:
        raise Hang(f"the case ran over {seconds} s")

    previous = signal.signal(signal.SIGALRM, timeout)
    signal.alarm(seconds)
    try:
        yield scratch
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
        os.chdir(cwd)
        if memory is None:
            del os.environ["FREEFLOAT_MEMORY_LIMIT"]
        else:
            os.environ["FREEFLOAT_MEMORY_LIMIT"] = memory
        changed = [str(p) for p, content in inputs.items() if not p.is_file() or p.read_bytes() != content]
        scratch.side_effects += [f"input changed: {p}" for p in changed]
        scratch.side_effects += [f"written next to the inputs: {n}" for n in sorted(set(_listing(files)) - set(listing))]
        scratch.side_effects += [f"written into the working directory: {n}" for n in _listing(work)]


def outcome(case: Case, files: Path) -> tuple[str, str]:
    """Run a case (bad files in ``files``) and classify what happened: ``clear`` (the expected error, its message matches),
    ``unclear`` (an error of the right kind whose message does not match, or a CLI error that is not one ``error:`` line),
    ``traceback`` (an unexpected exception) or ``silent`` (no error); with the output or the message. A hang is the alarm
    of :func:`scratch_dir` (:class:`Hang`), which this lets through."""
    if isinstance(case.run, list):
        result = CliRunner().invoke(app, [a.replace("{files}", str(files)) for a in case.run])
        shown = f"exit {result.exit_code}: {result.output.strip()}"
        if (result.exception is not None and not isinstance(result.exception, SystemExit)) or "Traceback" in result.output:
            return "traceback", f"{result.exception!r} {shown}"
        if result.exit_code == 0 != case.expect:
            return "silent", shown
        if result.exit_code != case.expect:
            return "unclear", shown
        if case.expect == 1:
            lines = [line for line in result.stderr.splitlines() if line.startswith("error: ")]
            clear = len(lines) == 1 and re.search(case.match, lines[0]) is not None
        else:
            clear = re.search(case.match, result.output) is not None
        return ("clear" if clear else "unclear"), shown
    if isinstance(case.expect, type) and issubclass(case.expect, Warning):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                case.run(files)
            except Exception as exc:
                return "traceback", repr(exc)
        messages = [str(w.message) for w in caught if issubclass(w.category, case.expect)]
        if not messages:
            return "silent", f"no {case.expect.__name__}"
        return ("clear" if any(re.search(case.match, m) for m in messages) else "unclear"), "; ".join(messages)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ModelCorrectionWarning)
            case.run(files)
    except case.expect as exc:
        message = str(exc)
        if isinstance(exc, (MemoryError, RecursionError)):
            return "traceback", repr(exc)
        return ("clear" if message.strip() and re.search(case.match, message) else "unclear"), f"{type(exc).__name__}: {message}"
    except Exception as exc:
        return "traceback", f"{type(exc).__name__}: {exc}"
    return "silent", "no error"


@pytest.fixture(scope="module", autouse=True)
def _kernels_compiled() -> None:
    """The engine's kernels that the cases reach, compiled (or loaded) before the first case: a case's alarm times the
    case, not a first compile (``make test`` runs the files on parallel workers, so this file may be the first to need
    them; a cold compile of the RK4 stepper took 61 s on a loaded machine)."""
    model = M()
    ff.simulate(model, S, 0.02, fixed_step=0.01)  # the compiled RK4 stepper
    ff.simulate(model, S, 0.02)  # the state derivative (adaptive)
    for batch in (1, 3):  # the rollout loop, serial and on threads
        ff.rollout(model, ff.State(q=np.tile(Q, (batch, 1))), 0.002, dt=1e-3)
    q = np.tile(Q, (300, 1))
    ff.generalized_jacobian(model, q), ff.generalized_jacobian(model, q[:1])  # J*, threads and serial
    ff.workspace.singularity_measure(model, q), ff.jacobian_determinant(model, q[:1])  # the measures


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_bad_input(case: Case, tmp_path: Path) -> None:
    with scratch_dir(tmp_path, case.files) as scratch:
        kind, shown = outcome(case, scratch.files)
    assert kind == "clear", f"{kind}: {shown}"
    assert not scratch.side_effects, scratch.side_effects


def test_the_table_covers_both_sides() -> None:
    counts = {"api": sum(not isinstance(c.run, list) for c in CASES), "cli": sum(isinstance(c.run, list) for c in CASES)}
    assert counts["api"] >= 129 and counts["cli"] >= 231 and len({c.id for c in CASES}) == len(CASES), counts
