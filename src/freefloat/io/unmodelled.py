"""What freefloat does with each element of a URDF or MJCF file, in one table (:data:`ELEMENTS`).

Each row is an element or attribute and its status:

* ``modelled``: read into the :class:`~freefloat.Model`;
* ``ignored``: has no effect on the free-floating dynamics freefloat computes (visual and collision
  geometry, cameras, lights, control ranges, gravity: a robot in orbit is weightless): read past
  without a warning;
* ``not modelled``: acts on the free-floating dynamics, but freefloat leaves it out: a file that gives
  it (a value other than the neutral one) loads with one
  :class:`~freefloat.core.errors.UnmodelledElementWarning` per row, naming every joint, actuator,
  tendon ... concerned, recorded in ``Model.unmodelled`` and listed by ``freefloat inspect``;
  ``strict=True`` refuses the file instead, naming the element;
* ``refused``: an error on loading, naming the element (the readers raise it).

When freefloat comes to model an element, its row moves to ``modelled`` (its finder, below, is then
no longer called). docs/model-files.md lists the rows; a test checks that it names each one.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.errors import ModelError, UnmodelledElementWarning

__all__ = ["ELEMENTS", "STATUSES", "Element", "mjcf_unmodelled", "report_unmodelled", "urdf_unmodelled"]

MODELLED, IGNORED, NOT_MODELLED, REFUSED = "modelled", "ignored", "not modelled", "refused"
STATUSES = (MODELLED, IGNORED, NOT_MODELLED, REFUSED)
#: A warning lists this many items (joints, actuators, ...) and counts the rest.
_SHOWN = 8


@dataclass(frozen=True)
class Element:
    """One row of :data:`ELEMENTS`: ``key`` (``"mjcf.joint.damping"``), the ``file`` format (URDF or MJCF),
    the ``element`` as written in the file, its ``status`` (one of :data:`STATUSES`) and ``effect``: what it
    does, or why it does not matter to free-floating dynamics."""

    key: str
    file: str
    element: str
    status: str
    effect: str


ELEMENTS: tuple[Element, ...] = (
    # ------------------------------------------------------------------ URDF
    Element("urdf.inertial", "URDF", "<link><inertial> (mass, origin, inertia)", MODELLED, "the link's mass, CM and inertia"),
    Element("urdf.joint", "URDF", "<joint> revolute, continuous, prismatic, fixed (origin, axis)", MODELLED, "the tree"),
    Element("urdf.limit.range", "URDF", "<limit lower upper>", MODELLED, "joint limits"),
    Element("urdf.mimic", "URDF", "<mimic>", MODELLED, "a joint driven by another joint: a mimic joint (Model.mimic)"),
    Element("urdf.joint.refused", "URDF", "<joint> floating, planar", REFUSED, "several degrees of freedom inside the tree"),
    Element("urdf.dynamics.damping", "URDF", "<joint><dynamics damping>", MODELLED, "viscous joint damping (Model.joint_damping)"),
    Element("urdf.dynamics.friction", "URDF", "<joint><dynamics friction>", MODELLED, "Coulomb joint friction (Model.joint_friction)"),
    Element(
        "urdf.transmission.reduction",
        "URDF",
        "<transmission> <mechanicalReduction> other than 1",
        NOT_MODELLED,
        "the gear ratio between actuator and joint torque (freefloat's inputs are joint torques)",
    ),
    Element("urdf.visual", "URDF", "<visual>, <collision>, <material>", IGNORED, "geometry: freefloat has no contact model"),
    Element("urdf.limit.effort", "URDF", "<limit effort velocity>", IGNORED, "bounds on the actuators, not passive dynamics"),
    Element("urdf.safety", "URDF", "<safety_controller>, <calibration>", IGNORED, "controller and sensor settings"),
    Element("urdf.gazebo", "URDF", "<gazebo>", IGNORED, "simulator settings"),
    Element("urdf.transmission.unit", "URDF", "<transmission> without reduction or with 1", IGNORED, "a joint torque, freefloat's input"),
    Element("urdf.nonstandard", "URDF", "attributes outside the URDF specification", IGNORED, "not read by URDF parsers"),
    # ------------------------------------------------------------------ MJCF
    Element("mjcf.body", "MJCF", "<body> tree, <inertial>, mass and inertia from <geom>", MODELLED, "the bodies' mass, CM, inertia"),
    Element("mjcf.joint", "MJCF", "<joint> hinge, slide (pos, axis), <freejoint>", MODELLED, "the tree (free joint: the spacecraft)"),
    Element("mjcf.joint.range", "MJCF", "<joint range> (limited)", MODELLED, "joint limits"),
    Element("mjcf.site", "MJCF", "<site>", MODELLED, "end effectors (others are ignored)"),
    Element("mjcf.joint.refused", "MJCF", "<joint> ball, free inside the tree; several joints per body", REFUSED, "not a tree"),
    Element("mjcf.joint.armature", "MJCF", "<joint armature> of a hinge or slide", MODELLED, "rotor inertia (Model.joint_armature)"),
    Element("mjcf.joint.damping", "MJCF", "<joint damping> of a hinge or slide", MODELLED, "viscous joint damping (Model.joint_damping)"),
    Element(
        "mjcf.joint.frictionloss",
        "MJCF",
        "<joint frictionloss> of a hinge or slide",
        MODELLED,
        "Coulomb joint friction (Model.joint_friction; smooth in freefloat, dry in MuJoCo)",
    ),
    Element(
        "mjcf.freejoint.passive",
        "MJCF",
        "<freejoint> armature, damping, frictionloss",
        NOT_MODELLED,
        "an inertia or a drag on the spacecraft's own motion (freefloat's spacecraft floats free)",
    ),
    Element(
        "mjcf.joint.stiffness",
        "MJCF",
        "<joint stiffness springref> of a hinge or slide",
        MODELLED,
        "a joint spring, -stiffness (q - springref) (Model.joint_stiffness, joint_springref)",
    ),
    Element(
        "mjcf.joint.ref",
        "MJCF",
        "<joint ref>",
        NOT_MODELLED,
        "freefloat's q = 0 is the configuration drawn in the file (MuJoCo's qpos = ref); range is read as written",
    ),
    Element("mjcf.tendon", "MJCF", "<tendon>", NOT_MODELLED, "couples joints (length limits, stiffness, damping, actuators)"),
    Element(
        "mjcf.equality.joint",
        "MJCF",
        "<equality><joint>",
        MODELLED,
        "a joint coupling of first order: a mimic joint (Model.mimic; other orders are refused)",
    ),
    Element(
        "mjcf.equality.other",
        "MJCF",
        "<equality> connect, weld, tendon, flex",
        NOT_MODELLED,
        "closes a kinematic loop or welds bodies: a constraint force",
    ),
    Element(
        "mjcf.actuator.gear",
        "MJCF",
        "<actuator gear> other than 1",
        NOT_MODELLED,
        "the gear ratio between actuator force and joint torque (freefloat's inputs are joint torques)",
    ),
    Element(
        "mjcf.actuator.bias",
        "MJCF",
        "<position>, <velocity>, <general biasprm>",
        NOT_MODELLED,
        "a servo's bias force (-kp q - kv q̇) acts as a joint spring and damper",
    ),
    Element(
        "mjcf.actuator.transmission",
        "MJCF",
        "<actuator> on a tendon, site, body or slider-crank",
        NOT_MODELLED,
        "forces that are not one joint's torque",
    ),
    Element("mjcf.option.fluid", "MJCF", "<option density viscosity>", NOT_MODELLED, "fluid drag and lift on the geoms"),
    Element("mjcf.flex", "MJCF", "<flex>, <flexcomp>", NOT_MODELLED, "deformable bodies"),
    Element("mjcf.plugin", "MJCF", "<plugin>", NOT_MODELLED, "engine plugins (they may add passive forces)"),
    Element("mjcf.geom", "MJCF", "<geom> as geometry, contacts (<contact>, contype, friction, solref)", IGNORED, "no contact model"),
    Element("mjcf.visual", "MJCF", "<camera>, <light>, <material>, <texture>, <visual>", IGNORED, "rendering"),
    Element("mjcf.actuator.range", "MJCF", "<actuator ctrlrange forcerange>, <joint actuatorfrcrange>", IGNORED, "control bounds"),
    Element("mjcf.actuator.motor", "MJCF", "<motor> on a joint with gear 1", IGNORED, "a joint torque, freefloat's input"),
    Element(
        "mjcf.actuator.gain",
        "MJCF",
        "<actuator> gain and activation dynamics (gainprm, dyntype)",
        IGNORED,
        "the map from control signal to actuator force: a controller's concern",
    ),
    Element("mjcf.gravity", "MJCF", "<option gravity>, <body gravcomp>", IGNORED, "a free-floating robot in orbit is weightless"),
    Element("mjcf.limit.softness", "MJCF", "<joint solreflimit solimplimit margin>", IGNORED, "the softness of the limit constraint"),
    Element("mjcf.option", "MJCF", "<option timestep integrator>, <flag>, <size>", IGNORED, "simulator settings"),
    Element("mjcf.other", "MJCF", "<sensor>, <keyframe>, <custom>, <option wind magnetic>", IGNORED, "no force on the robot"),
)
ROWS = {row.key: row for row in ELEMENTS}

Finder = Callable[[Any], list[str]]


def report_unmodelled(found: dict[str, list[str]], source: str, strict: bool) -> tuple[dict[str, Any], ...]:
    """Warn (:class:`UnmodelledElementWarning`) once per row of ``found`` (row key -> the items it concerns) and
    return the records for ``Model.unmodelled``; ``strict``: a :class:`ModelError` naming the first row instead."""
    records = []
    for key, items in found.items():
        if not items:
            continue
        row = ROWS[key]
        listed = ", ".join(items[:_SHOWN]) + (f" and {len(items) - _SHOWN} more" if len(items) > _SHOWN else "")
        if strict:
            raise ModelError(
                f"{source}: {row.file} {row.element}",
                f"is not modelled by freefloat ({row.effect}): {listed}",
                "remove it from the file to load the model freefloat computes, or load with strict=False to drop it with a warning",
            )
        records.append({"where": source, "element": f"{row.file} {row.element}", "effect": row.effect, "items": list(items)})
        warnings.warn(
            f"{source}: {row.file} {row.element} is not modelled and was dropped ({row.effect}): {listed}."
            " Load with strict=True to refuse instead.",
            UnmodelledElementWarning,
            stacklevel=4,
        )
    return tuple(records)


def _find(finders: dict[str, Finder], data: Any) -> dict[str, list[str]]:
    """Run the finder of every ``not modelled`` row (rows that became modelled or ignored are not looked for)."""
    return {key: finder(data) for key, finder in finders.items() if ROWS[key].status == NOT_MODELLED}


# --------------------------------------------------------------------- URDF (the XML tree)
_MOVING = ("revolute", "continuous", "prismatic")


def _urdf_reduction(root: Any) -> list[str]:
    out = []
    for transmission in root.findall("transmission"):
        joints = ", ".join(repr(j.get("name")) for j in transmission.findall("joint"))
        for reduction in transmission.iter("mechanicalReduction"):
            value = _number(reduction.text)
            if value is not None and value != 1.0:
                out.append(f"transmission {transmission.get('name')!r} (joint {joints}) mechanicalReduction={value:g}")
    return out


def _number(text: str | None) -> float | None:
    try:
        return float(text) if text is not None else None
    except ValueError:
        return None


_URDF_FINDERS: dict[str, Finder] = {
    "urdf.transmission.reduction": _urdf_reduction,
}


def urdf_unmodelled(root: Any) -> dict[str, list[str]]:
    """Row key -> the items of a URDF file (its parsed ``xml.etree`` root) that freefloat does not model."""
    return _find(_URDF_FINDERS, root)


# --------------------------------------------------------------------- MJCF (the compiled mjModel: defaults filled in)
def _mjcf_joint_values(field: str, label: str) -> Callable[..., Any]:
    """A per-degree-of-freedom field (``dof_damping``): the joints where it is not 0 (a free joint's six at once), as
    (joint, item) pairs."""

    def find(mj: Any, with_index: bool = True) -> list[Any]:
        out = []
        for j in range(mj.njnt):
            first = int(mj.jnt_dofadr[j])
            values = np.asarray(getattr(mj, field)[first : first + _dofs(mj, j)], dtype=float)
            if np.any(values != 0.0):
                shown = f"{values[0]:g}" if np.all(values == values[0]) else f"[{_numbers(values)}]"
                out.append((j, f"joint {_name(mj, 'mjOBJ_JOINT', j)} {label}={shown}"))
        return out

    return find


def _mjcf_free_joint(mj: Any) -> list[str]:
    """The free joints (the spacecraft's) with armature, damping or frictionloss."""
    import mujoco

    free = int(mujoco.mjtJoint.mjJNT_FREE)
    out = []
    for field, label in (("dof_armature", "armature"), ("dof_damping", "damping"), ("dof_frictionloss", "frictionloss")):
        out += [item for j, item in _mjcf_joint_values(field, label)(mj, with_index=True) if int(mj.jnt_type[j]) == free]
    return out


def _dofs(mj: Any, j: int) -> int:
    import mujoco

    return {int(mujoco.mjtJoint.mjJNT_FREE): 6, int(mujoco.mjtJoint.mjJNT_BALL): 3}.get(int(mj.jnt_type[j]), 1)


def _one_dof_joints(mj: Any) -> Iterable[tuple[int, int, str]]:
    """(joint, qpos address, unit of its qpos) of the hinge (rad: MuJoCo compiles degrees to radians) and slide (m) joints."""
    import mujoco

    units = {int(mujoco.mjtJoint.mjJNT_HINGE): "rad", int(mujoco.mjtJoint.mjJNT_SLIDE): "m"}
    for j in range(mj.njnt):
        if int(mj.jnt_type[j]) in units:
            yield j, int(mj.jnt_qposadr[j]), units[int(mj.jnt_type[j])]


def _mjcf_ref(mj: Any) -> list[str]:
    return [f"joint {_name(mj, 'mjOBJ_JOINT', j)} ref={mj.qpos0[a]:g} {unit}" for j, a, unit in _one_dof_joints(mj) if mj.qpos0[a] != 0.0]


def _mjcf_tendons(mj: Any) -> list[str]:
    return [f"tendon {_name(mj, 'mjOBJ_TENDON', t)}" for t in range(mj.ntendon)]


def _mjcf_equality(joint: bool) -> Finder:
    def find(mj: Any) -> list[str]:
        import mujoco

        kind = mujoco.mjtEq
        out = []
        for e in range(mj.neq):
            eq_type = int(mj.eq_type[e])
            if (eq_type == int(kind.mjEQ_JOINT)) == joint:
                label = kind(eq_type).name.removeprefix("mjEQ_").lower()
                out.append(f"equality {_name(mj, 'mjOBJ_EQUALITY', e)} ({label})")
        return out

    return find


def _actuator(mj: Any, a: int) -> str:
    return f"actuator {_name(mj, 'mjOBJ_ACTUATOR', a)}"


def _mjcf_gear(mj: Any) -> list[str]:
    trivial = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    out = []
    for a in range(mj.nu):
        gear = np.asarray(mj.actuator_gear[a], dtype=float)
        if not np.array_equal(gear, trivial):
            out.append(f"{_actuator(mj, a)} gear={_numbers(gear if np.any(gear[1:]) else gear[:1])}")
    return out


def _mjcf_bias(mj: Any) -> list[str]:
    return [
        f"{_actuator(mj, a)} biasprm={_numbers(mj.actuator_biasprm[a][:3])}"
        for a in range(mj.nu)
        if int(mj.actuator_biastype[a]) != 0 and np.any(mj.actuator_biasprm[a] != 0.0)
    ]


def _mjcf_transmission(mj: Any) -> list[str]:
    import mujoco

    joint = int(mujoco.mjtTrn.mjTRN_JOINT)
    return [
        f"{_actuator(mj, a)} ({mujoco.mjtTrn(int(mj.actuator_trntype[a])).name.removeprefix('mjTRN_').lower()})"
        for a in range(mj.nu)
        if int(mj.actuator_trntype[a]) != joint
    ]


def _mjcf_fluid(mj: Any) -> list[str]:
    return [f"{name}={value:g}" for name, value in (("density", mj.opt.density), ("viscosity", mj.opt.viscosity)) if value != 0.0]


def _mjcf_count(count: str, kind: str, label: str) -> Finder:
    return lambda mj: [f"{label} {_name(mj, kind, i)}" for i in range(int(getattr(mj, count)))]


def _numbers(values: Any) -> str:
    return " ".join(f"{float(v):g}" for v in values)


def _name(mj: Any, kind: str, index: int) -> str:
    import mujoco

    name = mujoco.mj_id2name(mj, getattr(mujoco.mjtObj, kind), index)
    return repr(name) if name else f"#{index}"


_MJCF_FINDERS: dict[str, Finder] = {
    "mjcf.freejoint.passive": _mjcf_free_joint,
    "mjcf.joint.ref": _mjcf_ref,
    "mjcf.tendon": _mjcf_tendons,
    "mjcf.equality.other": _mjcf_equality(joint=False),
    "mjcf.actuator.gear": _mjcf_gear,
    "mjcf.actuator.bias": _mjcf_bias,
    "mjcf.actuator.transmission": _mjcf_transmission,
    "mjcf.option.fluid": _mjcf_fluid,
    "mjcf.flex": _mjcf_count("nflex", "mjOBJ_FLEX", "flex"),
    "mjcf.plugin": _mjcf_count("nplugin", "mjOBJ_PLUGIN", "plugin"),
}


def mjcf_unmodelled(mj: Any) -> dict[str, list[str]]:
    """Row key -> the items of a compiled ``mujoco.MjModel`` that freefloat does not model."""
    return _find(_MJCF_FINDERS, mj)
