"""Model files: TOML (freefloat's own schema, docs/model-files.md) and URDF.

``load(path)`` picks the reader from the extension. ``save(model, path)``
writes TOML or URDF and refuses to overwrite an existing file unless asked.
URDF is parsed and written by ``yourdfpy``, MJCF by MuJoCo's own parser
(:mod:`freefloat.io.mjcf`); the root link is the spacecraft. End effectors are the
ones named (``end_effectors=``, or ``[[end_effectors]]`` in TOML); when none is
named, every leaf link is one, at its frame origin (``Model.end_effector_rule``).

Real files have flaws: a link inertia that is not physical is, by default, replaced by the
nearest physical one with a :class:`~freefloat.core.errors.ModelCorrectionWarning` that names
the link, the defect and the size of the change, and recorded in ``Model.corrections``;
``strict=True`` makes each such defect the clear error it was. Point masses and zero inertias
of small links are accepted when the whole model is physical (H+ positive definite). What acts on
the dynamics but is not modelled (``<dynamics damping>``, a ``<mechanicalReduction>``, ...:
:data:`freefloat.io.unmodelled.ELEMENTS`) is dropped with an ``UnmodelledElementWarning`` and
recorded in ``Model.unmodelled`` (``strict``: an error).
"""

from __future__ import annotations

import dataclasses
import difflib
import os
import tomllib
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from ..core.builder import ModelBuilder
from ..core.errors import ModelCorrectionWarning, ModelError, UnmodelledElementWarning
from ..core.model import JOINT_PASSIVE, Model, resolve_model
from ..core.wheels import wheels_from
from ._readers import EndEffectors, end_effector_specs, model_path, naming_file, not_a_file, physical_inertia
from .mjcf import load_mjcf
from .unmodelled import report_unmodelled, urdf_unmodelled

__all__ = ["load", "load_toml", "load_urdf", "save", "to_toml_dict", "to_urdf_string"]

_BODY_KEYS = {"name", "mass", "inertia", "com", "end_effector", "end_effector_name", "frame"}
_JOINT_KEYS = {"name", "type", "parent", "child", "origin", "rpy", "axis", "limits", *JOINT_PASSIVE, "mimic"}
_MIMIC_KEYS = {"joint", "multiplier", "offset"}
_TOP_KEYS = {"name", "description", "bodies", "joints", "end_effectors", "corrections", "wheels"}
_CORRECTION_KEYS = {"body", "field", "given", "why"}
_EE_KEYS = {"name", "body", "point"}


def load(path: str | Path, *, end_effectors: EndEffectors = None, strict: bool = False, joints: Any = None, wheels: Any = None) -> Model:
    """Load a model from a ``.toml``, ``.urdf`` or MJCF (``.xml`` with a ``<mujoco>`` root) file, or a
    built-in model by name (``ff.load("papadopoulos1992")``).

    ``end_effectors``: the end effectors, as link names (the point is the link frame origin) or
    (name, link, point) triples, point in the link frame; default: what the file names, else
    every leaf. ``strict``: refuse non-physical inertias instead of correcting them (URDF, MJCF).
    The loaded model must be physical as a whole: H+ positive definite at q = 0.
    ``joints``: the joints' own dynamics, for files that cannot say them (URDF has no rotor inertia) or to
    replace the file's: ``{joint name: {"armature": kg m², "damping": N m s/rad, "friction": N m, "stiffness": N m/rad,
    "springref": rad}}``
    (docs/model-files.md), or the path of a TOML file of such tables (``[panda_joint1]`` then
    ``armature = 0.1``). A value given here replaces the file's; the others keep the file's.
    ``wheels``: the spacecraft's reaction wheels, for files that cannot say them (URDF, MJCF) or to replace the
    file's: a list of tables ``{"name", "axis", "inertia", "max_torque", "max_speed", "viscous", "coulomb"}``
    (docs/wheels.md), or the path of a TOML side file of ``[[wheels]]`` tables. The spacecraft body of the file must
    include the wheels' mass and inertia (locked).
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path: expected a model file path or a built-in model name (str or pathlib.Path), got {type(path).__name__}")
    if end_effectors is not None:
        if isinstance(end_effectors, (str, bytes)) or not isinstance(end_effectors, Sequence):
            raise TypeError(f'end_effectors: expected a list of names, e.g. ["tool0"], got {end_effectors!r}')
        if len(end_effectors) == 0:
            raise ModelError("end_effectors", "is empty", "name at least one end effector, or pass None for the file's (else every leaf)")
    given = os.fspath(path)  # errors quote the path as given (Path drops a leading "./")
    if isinstance(given, bytes):
        given = os.fsdecode(given)
    path = model_path(given)  # ~ expanded; a name that is not UTF-8 refused
    if not path.suffix and not path.exists() and not path.is_symlink():
        builtin = resolve_model(str(path), "path")  # a built-in name (or an error listing them)
        builtin = builtin if joints is None else with_joint_dynamics(builtin, joints)
        return builtin if wheels is None else with_wheels(builtin, wheels)
    problem = not_a_file(path)
    if problem is not None:
        raise ModelError(str(given), problem, "give the path of a .toml, .urdf or MJCF .xml model file")
    suffix = path.suffix.lower()
    root = _xml_root(path) if suffix == ".xml" else ""
    if suffix == ".toml":
        model = load_toml(path, end_effectors=end_effectors)
    elif suffix == ".urdf" or root == "robot":
        model = load_urdf(path, end_effectors=end_effectors, strict=strict)
    elif suffix == ".mjcf" or root == "mujoco":
        model = load_mjcf(path, end_effectors=end_effectors, strict=strict)
    elif suffix == ".xml":
        raise ModelError(str(path), f"the root element <{root}> is neither a URDF <robot> nor an MJCF <mujoco>", "give a URDF or MJCF file")
    else:
        raise ModelError(str(path), f"unknown model file type {suffix!r}", "use a .toml (freefloat schema), .urdf or MJCF .xml file")
    if model.n_joints == 0:
        raise ModelError(
            str(path),
            f"has no movable joint ({model.n_bodies} bodies after merging fixed joints, {model.n_end_effectors} end effectors): "
            "nothing in it is an arm",
            "check that the file is complete (a truncated file loses its joints); a bare spacecraft is built with ff.ModelBuilder",
        )
    if joints is not None:
        model = with_joint_dynamics(model, joints)
    if wheels is not None:
        model = with_wheels(model, wheels)
    check_whole_model(model)
    return model


def with_joint_dynamics(model: Model, joints: Any) -> Model:
    """``model`` with the joints' armature, damping, friction and springs of ``joints`` (see :func:`load`), each name
    checked."""
    where = "joints"
    if isinstance(joints, (str, os.PathLike)):
        where = str(joints)
        joints = read_toml(Path(joints), "joint dynamics file")
    if not isinstance(joints, dict):
        raise TypeError(f"joints: expected a table {{joint name: {{armature, damping, ...}}}} or a TOML file, got {joints!r}")
    values = {key: np.array(getattr(model, f"joint_{key}"), dtype=float) for key in JOINT_PASSIVE}
    mimic = {record["joint"]: dict(record) for record in model.mimic}  # a mimic joint's own dynamics are in its record
    for name, entry in joints.items():
        if name in mimic:
            _check_keys(entry, set(JOINT_PASSIVE), f"{where}: {name}")
            for key, value in entry.items():
                if isinstance(value, (bool, str)) or not isinstance(value, (int, float)):
                    raise ModelError(f"{where}: {name}.{key}", f"cannot read {value!r} as a number", f"give the {JOINT_PASSIVE[key]}")
                mimic[name][key] = float(value)
            continue
        if name not in model.joint_names:
            close = difflib.get_close_matches(str(name), (*model.joint_names, *mimic), n=3)
            raise ModelError(
                f"{where}: {name}",
                f"is not a joint of {model.name!r}" + (f" (did you mean {', '.join(map(repr, close))}?)" if close else ""),
                f"name one of its joints: {', '.join((*model.joint_names, *mimic))}",
            )
        _check_keys(entry, set(JOINT_PASSIVE), f"{where}: {name}")
        for key, value in entry.items():
            if isinstance(value, (bool, str)) or not isinstance(value, (int, float)):
                raise ModelError(f"{where}: {name}.{key}", f"cannot read {value!r} as a number", f"give the {JOINT_PASSIVE[key]}")
            values[key][model.joint_names.index(name)] = float(value)
    given: dict[str, Any] = {f"joint_{key}": values[key] for key in JOINT_PASSIVE}
    return dataclasses.replace(model, **given, mimic=tuple(mimic[record["joint"]] for record in model.mimic))


def _xml_root(path: Path) -> str:
    """The tag of the XML file's root element: ``mujoco`` (MJCF), ``robot`` (URDF) or another."""
    import xml.etree.ElementTree as ElementTree

    try:
        for _, element in ElementTree.iterparse(path, events=("start",)):
            return str(element.tag)
    except ElementTree.ParseError as exc:
        raise ModelError(str(path), f"malformed XML: {exc}", "fix the file so that it is valid URDF or MJCF XML") from None
    return ""


def check_whole_model(model: Model) -> None:
    """Refuse a model whose H+ (1991 eq. 15) is singular at q = 0: some joint then moves no mass or inertia."""
    from ..mechanics.momentum import system_inertia_matrix

    h = system_inertia_matrix(model, np.zeros(model.n_joints))
    joint_block = h[6:, 6:]
    if model.n_joints == 0:
        return
    values, vectors = np.linalg.eigh(joint_block)
    scale = max(float(np.max(np.abs(np.diag(h)))), 1e-300)
    if values[0] <= 1e-12 * scale:
        j = int(np.argmax(np.abs(vectors[:, 0])))
        raise ModelError(
            f"{model.name}: joint {model.joint_names[j]!r}",
            f"the system inertia matrix H+ is singular at q = 0 (smallest eigenvalue {values[0]:.3g}, largest entry {scale:.3g}):"
            " this joint (with others, maybe) moves no mass and no inertia",
            "give the links outboard of it a mass and an inertia, or make the joint fixed",
        )


def read_toml(path: str | Path, what: str = "model file") -> dict[str, Any]:
    """The table of a TOML file; malformed TOML or text that is not UTF-8 is a ModelError naming the file."""
    path = Path(path)
    if not path.is_file():
        raise ModelError(str(path), "file not found", f"give the path of the {what} (a .toml file)")
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ModelError(str(path), f"malformed TOML: {exc}", "fix the TOML syntax at that line") from None
    except UnicodeDecodeError:
        raise ModelError(str(path), "is not UTF-8 text", f"save the {what} as UTF-8 TOML") from None


def load_toml(path: str | Path, *, end_effectors: EndEffectors = None) -> Model:
    """Read a model in freefloat's TOML schema (see docs/model-files.md); errors name the file and the field."""
    return naming_file(path, lambda: from_dict(read_toml(path), source=str(path), end_effectors=end_effectors))


def _require(entry: dict[str, Any], key: str, path: str, fix: str) -> Any:
    if key not in entry:
        raise ModelError(f"{path}.{key}", "is missing", fix)
    return entry[key]


def _check_keys(entry: Any, allowed: set[str], path: str) -> None:
    if not isinstance(entry, dict):
        raise ModelError(path, f"expected a table, got {type(entry).__name__}", "write it as a [[table]] entry")
    unknown = sorted(set(entry) - allowed)
    if unknown:
        raise ModelError(f"{path}.{unknown[0]}", "unknown key", f"allowed keys: {', '.join(sorted(allowed))}")


def from_dict(data: dict[str, Any], source: str = "", *, end_effectors: EndEffectors = None) -> Model:
    """Build a model from the parsed TOML tables (same schema as the file)."""
    _check_keys(data, _TOP_KEYS, "model")
    bodies = data.get("bodies")
    if not isinstance(bodies, list) or not bodies:
        raise ModelError("bodies", "is missing or empty", "add [[bodies]] tables, the first being the spacecraft")
    builder = ModelBuilder(str(data.get("name", Path(source).stem or "model")))
    declared, records = _declared_corrections(data, source)
    for i, body in enumerate(bodies):
        path = f"bodies[{i}]"
        _check_keys(body, _BODY_KEYS, path)
        frame = bool(body.get("frame", False))
        name = _require(body, "name", path, "name every body")
        if name in declared:
            if "inertia" in body:
                raise ModelError(f"{path} ({name}).inertia", "is given twice: here and in [[corrections]]", "keep one of them")
            inertia: Any = declared.pop(name)
        elif frame:
            inertia = 0.0
        else:
            inertia = _require(body, "inertia", path, "give the inertia about the CM (3x3, [Ixx, Iyy, Izz] or a number)")
        builder.add_body(
            name,
            mass=0.0 if frame else _require(body, "mass", path, "give the mass in kg"),
            inertia=inertia,
            com=body.get("com", (0.0, 0.0, 0.0)),
            end_effector=body.get("end_effector"),
            end_effector_name=body.get("end_effector_name"),
            frame=frame,
        )
    for path, joint in _table_array(data, "joints", _JOINT_KEYS):
        builder.add_joint(
            _require(joint, "name", path, "name every joint"),
            parent=_require(joint, "parent", path, "name the parent body"),
            child=_require(joint, "child", path, "name the child body"),
            origin=joint.get("origin", (0.0, 0.0, 0.0)),
            rpy=joint.get("rpy"),
            axis=joint.get("axis", (0.0, 0.0, 1.0)),
            type=joint.get("type", "revolute"),
            limits=joint.get("limits"),
            **{key: joint.get(key, 0.0) for key in JOINT_PASSIVE},
        )
        if "mimic" in joint:  # mimic = {joint = "leader", multiplier = 1.0, offset = 0.0}: q = multiplier q_leader + offset
            law = joint["mimic"]
            if not isinstance(law, dict):
                raise ModelError(
                    f"{path}.mimic",
                    f"expected a table {{joint = ..., multiplier = ..., offset = ...}}, got {law!r}",
                    "name the leader joint",
                )
            _check_keys(law, _MIMIC_KEYS, f"{path}.mimic")
            builder.add_mimic(
                joint["name"],
                leader=_require(law, "joint", f"{path}.mimic", "name the joint it follows"),
                multiplier=law.get("multiplier", 1.0),
                offset=law.get("offset", 0.0),
            )
    named = end_effector_specs(end_effectors, source)
    if not named:
        for path, entry in _table_array(data, "end_effectors", _EE_KEYS):
            named.append(
                (
                    _require(entry, "name", path, "name every end effector"),
                    _require(entry, "body", path, "name the body (or frame) that holds it"),
                    entry.get("point", (0.0, 0.0, 0.0)),
                )
            )
    for name, body, point in named:
        builder.add_end_effector(name, body=body, point=point)
    if declared:
        unknown = sorted(declared)[0]
        raise ModelError("corrections", f"names body {unknown!r}, which is not in [[bodies]]", "name a body of the model")
    model = builder.build(source=source, corrections=records)
    return with_wheels(model, data["wheels"], "wheels") if "wheels" in data else model


def with_wheels(model: Model, wheels: Any, where: str = "wheels") -> Model:
    """``model`` with the reaction wheels ``wheels`` (see :func:`load`): a list of tables (:data:`WHEEL_KEYS`) or
    :class:`~freefloat.core.wheels.ReactionWheel`, or the path of a TOML side file of ``[[wheels]]`` tables. They replace
    the model's own wheels; each error names the wheel and the field."""
    if isinstance(wheels, (str, os.PathLike)):
        where = f"{wheels}: wheels"
        data = read_toml(Path(wheels), "reaction-wheel file")
        _check_keys(data, {"wheels"}, str(wheels))
        wheels = data.get("wheels", [])
    return dataclasses.replace(model, wheels=wheels_from(wheels, where))


def _table_array(data: dict[str, Any], key: str, allowed: set[str]) -> list[tuple[str, dict[str, Any]]]:
    """(path, table) of each ``[[key]]`` table of a TOML file, keys checked; missing means none."""
    listed = data.get(key, [])
    if not isinstance(listed, list):
        raise ModelError(key, "expected an array of tables", f"write them as [[{key}]] tables")
    out = []
    for i, entry in enumerate(listed):
        _check_keys(entry, allowed, f"{key}[{i}]")
        out.append((f"{key}[{i}]", entry))
    return out


def _declared_corrections(data: dict[str, Any], source: str) -> tuple[dict[str, np.ndarray], list[dict[str, Any]]]:
    """``[[corrections]]`` of a TOML file: published inertias that are not physical, corrected on loading.

    Each entry gives a body, ``field = "inertia"``, the published value (``given``) and ``why``; the
    body's inertia is the nearest physical one to ``given`` (:func:`~freefloat.core.model.nearest_physical_inertia`),
    recorded in ``Model.corrections``. A ``given`` that is physical is an error (nothing to correct).
    """
    used: dict[str, np.ndarray] = {}
    records: list[dict[str, Any]] = []
    for path, entry in _table_array(data, "corrections", _CORRECTION_KEYS):
        body = str(_require(entry, "body", path, "name the body whose published inertia is corrected"))
        if entry.get("field", "inertia") != "inertia":
            raise ModelError(f"{path}.field", f"cannot correct {entry.get('field')!r}", 'only field = "inertia" is corrected')
        given = np.asarray(_require(entry, "given", path, "give the published 3x3 inertia"), dtype=float)
        if given.shape != (3, 3):
            raise ModelError(f"{path}.given", f"expected a 3x3 matrix, got shape {given.shape}", "give the published 3x3 inertia")
        where = f"{source or 'model'}: {path} ({body}).inertia"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ModelCorrectionWarning)  # declared in the file: recorded, not warned
            before = len(records)
            used[body] = physical_inertia(given, where, False, records)
        if len(records) == before:
            raise ModelError(f"{path}.given", "is a physical inertia: there is nothing to correct", "give it as the body's inertia instead")
        records[-1]["why"] = str(entry.get("why", ""))
    return used, records


def _list(arr: np.ndarray) -> list[Any]:
    return np.asarray(arr, dtype=float).tolist()


def _leaf_hosts(model: Model) -> set[int]:
    has_child = set(int(p) for p in model.parent[1:])
    return {k for k in range(1, model.n_bodies) if k not in has_child}


def to_toml_dict(model: Model) -> dict[str, Any]:
    """The TOML tables of a model (after fixed joints were merged)."""
    leaves = _leaf_hosts(model) if model.end_effector_rule == "leaves" else set()
    tips: dict[int, list[int]] = {}
    for e, k in enumerate(model.end_effector_body):
        tips.setdefault(int(k), []).append(e)
    bodies: list[dict[str, Any]] = []
    joints: list[dict[str, Any]] = []
    frames: list[tuple[dict[str, Any], dict[str, Any]]] = []
    laws = _mimic_laws(model)
    own = model.expanded()  # the joint of each body (mimic joints included), its own type, limits and parameters
    for k, name in enumerate(model.body_names):
        body: dict[str, Any] = {"name": name, "mass": float(model.mass[k]), "inertia": _list(model.inertia[k]), "com": _list(model.com[k])}
        ees = tips.get(k, [])
        if k in leaves and len(ees) == 1:
            e = ees[0]
            body["end_effector"] = _list(model.end_effector_point[e])
            body["end_effector_name"] = model.end_effector_names[e]
        else:
            for e in ees:  # end effectors of non-leaf bodies become massless frames
                frame_name = _frame_name(model, e)
                frames.append(
                    (
                        {"name": frame_name, "frame": True},
                        {
                            "name": f"{frame_name}_fixed",
                            "type": "fixed",
                            "parent": name,
                            "child": frame_name,
                            "origin": _list(model.end_effector_point[e]),
                        },
                    )
                )
        bodies.append(body)
        if k > 0:
            j = k - 1
            joint: dict[str, Any] = {
                "name": own.joint_names[j],
                "type": _file_joint_type(own, j),
                "parent": model.body_names[model.parent[k]],
                "child": name,
                "origin": _list(model.joint_origin[k]),
                "rpy": _list(_rpy(model.joint_rotation[k])),
                "axis": _list(model.joint_axis[k]),
            }
            if joint["type"] != "continuous" and (np.isfinite(own.joint_lower[j]) or np.isfinite(own.joint_upper[j])):
                joint["limits"] = [float(own.joint_lower[j]), float(own.joint_upper[j])]
            for key in JOINT_PASSIVE:
                value = float(getattr(own, f"joint_{key}")[j])
                if value != 0.0:
                    joint[key] = value
            if joint["name"] in laws:
                leader, multiplier, offset = laws[joint["name"]]
                joint["mimic"] = {"joint": leader, "multiplier": multiplier, "offset": offset}
            joints.append(joint)
    for body, joint in frames:
        bodies.append(body)
        joints.append(joint)
    out: dict[str, Any] = {"name": model.name, "bodies": bodies, "joints": joints}
    if model.wheels:
        out["wheels"] = [w.as_dict() for w in model.wheels]
    if model.end_effector_rule == "named":
        out["end_effectors"] = [
            {"name": name, "body": _frame_name(model, e), "point": [0.0, 0.0, 0.0]} for e, name in enumerate(model.end_effector_names)
        ]
    return out


def _rpy(rotation: np.ndarray) -> np.ndarray:
    """Fixed-axis roll, pitch, yaw of a joint placement. At a pitch of +-90 degrees (gimbal lock: a UR5's wrist) only the
    sum or difference of roll and yaw is defined; scipy then sets yaw to zero, which still gives the same rotation."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Gimbal lock detected", category=UserWarning)
        return Rotation.from_matrix(rotation).as_euler("xyz")


def _mimic_laws(model: Model) -> dict[str, tuple[str, float, float]]:
    """{mimic joint: (its root leader, multiplier, offset)} of a model (empty without mimic joints)."""
    return {r["joint"]: (str(r["leader"]), float(r["multiplier"]), float(r["offset"])) for r in model.mimic}


def _file_joint_type(model: Model, j: int) -> str:
    """The joint's type in a file: prismatic, revolute (with limits) or continuous (a revolute joint without)."""
    if model.joint_type[j] == "prismatic":
        return "prismatic"
    return "revolute" if np.isfinite(model.joint_lower[j]) or np.isfinite(model.joint_upper[j]) else "continuous"


def _frame_name(model: Model, e: int) -> str:
    """Name of the massless frame that carries end effector e in a file (unique among bodies)."""
    name = model.end_effector_names[e]
    return name if name not in model.body_names else f"{name}_tip"


# --------------------------------------------------------------------- URDF
def load_urdf(path: str | Path, *, end_effectors: EndEffectors = None, strict: bool = False) -> Model:
    """Read a URDF file (via yourdfpy). Root link = spacecraft; end effectors as :func:`load` says."""
    import xml.etree.ElementTree as ElementTree

    import yourdfpy

    path = Path(path)
    try:  # yourdfpy silently falls back to a recovering parser on bad XML: check well-formedness first
        tree = ElementTree.parse(path)
    except ElementTree.ParseError as exc:
        raise ModelError(str(path), f"malformed URDF XML: {exc}", "fix the file so that it is valid URDF XML") from None
    _check_urdf_elements(tree.getroot(), str(path))  # yourdfpy's own errors name neither the element nor the attribute
    try:
        with np.errstate(all="ignore"):  # NaN or infinity in an <origin>: refused below, naming it (not a RuntimeWarning of numpy)
            urdf = yourdfpy.URDF.load(
                str(path), build_scene_graph=False, load_meshes=False, build_collision_scene_graph=False, load_collision_meshes=False
            )
    except Exception as exc:  # yourdfpy and lxml raise many types for bad XML
        raise ModelError(str(path), f"malformed URDF: {type(exc).__name__}: {exc}", "fix the file so that it is valid URDF XML") from None
    model = naming_file(path, lambda: from_urdf_robot(urdf.robot, source=str(path), end_effectors=end_effectors, strict=strict))
    unmodelled = report_unmodelled(urdf_unmodelled(tree.getroot()), str(path), strict)
    return dataclasses.replace(model, unmodelled=unmodelled) if unmodelled else model


# What yourdfpy reads as numbers: element tag -> {attribute: how many numbers (0: one or more)}; box sizes and mesh
# scales may be separated by commas too.
_URDF_NUMBERS: dict[str, dict[str, int]] = {
    "origin": {"xyz": 3, "rpy": 3},
    "mass": {"value": 1},
    "inertia": dict.fromkeys(("ixx", "ixy", "ixz", "iyy", "iyz", "izz"), 1),
    "axis": {"xyz": 3},
    "limit": dict.fromkeys(("lower", "upper", "effort", "velocity"), 1),
    "mimic": dict.fromkeys(("multiplier", "offset"), 1),
    "calibration": dict.fromkeys(("rising", "falling"), 1),
    "safety_controller": dict.fromkeys(("soft_lower_limit", "soft_upper_limit", "k_position", "k_velocity"), 1),
    "box": {"size": 3},
    "cylinder": {"radius": 1, "length": 1},
    "sphere": {"radius": 1},
    "mesh": {"scale": 0},
    "color": {"rgba": 0},
}
# attributes yourdfpy cannot do without: element tag -> attributes
_URDF_REQUIRED = {"link": ("name",), "joint": ("name",), "box": ("size",), "cylinder": ("radius", "length"), "sphere": ("radius",)}


def _urdf_descendants(element: Any, where: str) -> Any:
    """(path, element) of every element under ``element``: ``where.visual.geometry.box``, with ``[i]`` where a tag repeats."""
    children = list(element)
    for child in children:
        tag = str(child.tag)
        same = [c for c in children if c.tag == child.tag]
        path = f"{where}.{tag}" + (f"[{same.index(child)}]" if len(same) > 1 else "")
        yield path, child
        yield from _urdf_descendants(child, path)


def _urdf_attributes(element: Any, where: str) -> None:
    """The attributes of one URDF element that yourdfpy reads: present where required, numbers where numbers."""
    tag = str(element.tag)
    for attr in _URDF_REQUIRED.get(tag, ()):
        if attr not in element.attrib:
            raise ModelError(f"{where}.{attr}", "is missing", f'give the <{tag}> element its {attr}="..." attribute')
    for attr, count in _URDF_NUMBERS.get(tag, {}).items():
        text = element.get(attr)
        if text is None:
            continue
        tokens = (text.replace(",", " ") if tag in ("box", "mesh") else text).split()
        want = "a number" if count == 1 else f"{count} numbers separated by spaces" if count else "numbers separated by spaces"
        for token in tokens:
            try:
                float(token)
            except ValueError:
                shown = repr(token) if token == text.strip() else f"{token!r} (in {attr}={text!r})"
                raise ModelError(
                    f"{where}.{attr}", f"cannot read {shown} as a number", f"write {want} in SI units (m, rad, kg, kg m^2)"
                ) from None
        if (count and len(tokens) != count) or not tokens:
            raise ModelError(f"{where}.{attr}", f"expected {want}, got {len(tokens)} ({attr}={text!r})", f"write {want}")


def _check_urdf_elements(root: Any, source: str) -> None:
    """What yourdfpy would fail on with an error that names neither the element nor the attribute (a text where a
    number belongs, a joint without ``<parent>``), refused with a ModelError that names them:
    ``robot.urdf: link[0] (spacecraft).inertial.mass.value: cannot read 'heavy' ... as a number``.
    ``root``: the parsed XML root (``xml.etree``); links and joints are numbered as yourdfpy numbers them."""
    if root.tag != "robot":
        return
    if "name" not in root.attrib:
        raise ModelError(f"{source}: robot.name", "is missing", 'give the robot a name: <robot name="...">')
    for kind in ("link", "joint", "material"):
        for i, element in enumerate(root.findall(kind)):
            if kind != "material":
                _urdf_attributes(element, f"{source}: {kind}[{i}]")
            where = f"{source}: {kind}[{i}] ({element.get('name')})"
            if kind == "joint":
                for role in ("parent", "child"):
                    found = element.find(role)
                    if found is None or not found.get("link"):
                        problem = "is missing" if found is None else "has no link attribute"
                        raise ModelError(f"{where}.{role}", problem, f'name the joint\'s {role} link: <{role} link="NAME"/>')
            for path, child in _urdf_descendants(element, where):
                _urdf_attributes(child, path)


def missing_limit(path: str, kind: str, strict: bool, corrections: list[dict[str, Any]]) -> None:
    """A URDF revolute or prismatic joint without ``<limit>``, which the URDF specification requires: taken as
    unlimited (a continuous joint, an unlimited slide) with a warning and a record; ``strict``: a ModelError."""
    fix = 'add <limit lower="..." upper="..." effort="..." velocity="..."/> to the joint, or declare it "continuous"'
    if strict:
        raise ModelError(path, f"a {kind} joint without <limit> (the URDF specification requires one)", fix)
    corrections.append({"where": path, "field": "limit", "defect": f"{kind} joint without <limit>", "correction": "taken as unlimited"})
    warnings.warn(
        f"{path}: a {kind} joint without <limit> (the URDF specification requires one); taken as unlimited. {fix}, or load "
        "with strict=True to refuse instead.",
        ModelCorrectionWarning,
        stacklevel=4,
    )


_URDF_REFUSED = {
    "floating": "a floating joint inside the tree (only the spacecraft, the root link, moves freely)",
    "planar": "a planar joint inside the tree (two translations and a rotation in one joint)",
}


def _urdf_origin(origin: Any, path: str) -> np.ndarray:
    """A URDF ``<origin>`` as a 4x4 transform; NaN or infinity in its xyz or rpy is a ModelError (not a NaN rotation)."""
    matrix = np.eye(4) if origin is None else np.asarray(origin, dtype=float)
    if not np.all(np.isfinite(matrix)):
        raise ModelError(path, "has NaN or infinite entries in xyz or rpy", "give finite numbers: xyz in m, rpy in rad")
    return matrix


def from_urdf_robot(robot: Any, source: str = "", *, end_effectors: EndEffectors = None, strict: bool = False) -> Model:
    """Build a model from a ``yourdfpy.Robot`` (see :func:`load` for ``end_effectors`` and ``strict``)."""
    builder = ModelBuilder(robot.name or "urdf")
    corrections: list[dict[str, Any]] = []
    for i, link in enumerate(robot.links):
        path = f"{source or 'urdf'}: link[{i}] ({link.name})"
        inertial = link.inertial
        if inertial is None or inertial.mass is None or float(inertial.mass) == 0.0:
            builder.add_body(link.name, mass=0.0, inertia=0.0, frame=True)
            continue
        origin = _urdf_origin(inertial.origin, f"{path}.inertial.origin")
        rot = origin[:3, :3]
        inertia = np.zeros((3, 3)) if inertial.inertia is None else np.asarray(inertial.inertia, dtype=float)
        inertia = physical_inertia(rot @ inertia @ rot.T, f"{path}.inertia", strict, corrections)
        try:
            builder.add_body(link.name, mass=float(inertial.mass), inertia=inertia, com=origin[:3, 3], degenerate_ok=True)
        except ModelError as exc:
            raise ModelError(f"{path}.{exc.field.split('.')[-1]}", exc.problem, exc.fix) from None
    for i, joint in enumerate(robot.joints):
        path = f"{source or 'urdf'}: joint[{i}] ({joint.name})"
        if joint.type in _URDF_REFUSED:
            raise ModelError(
                f"{path}.type",
                f"{joint.type!r}: {_URDF_REFUSED[joint.type]} is not supported",
                "freefloat models revolute, continuous, prismatic and fixed joints: split it into such joints, or make it fixed",
            )
        if joint.type not in ("revolute", "continuous", "prismatic", "fixed"):
            raise ModelError(
                f"{path}.type",
                f"unsupported joint type {joint.type!r}",
                "freefloat models revolute, continuous, prismatic and fixed joints",
            )
        mimic = getattr(joint, "mimic", None)
        if mimic is not None:  # a dependent coordinate: q = multiplier q_leader + offset (checked by the builder)
            try:
                builder.add_mimic(
                    joint.name,
                    leader=mimic.joint,
                    multiplier=1.0 if mimic.multiplier is None else mimic.multiplier,
                    offset=0.0 if mimic.offset is None else mimic.offset,
                )
            except ModelError as exc:
                raise ModelError(f"{path}.mimic", exc.problem, exc.fix) from None
        origin = _urdf_origin(joint.origin, f"{path}.origin")
        limits = None
        if (
            joint.type in ("revolute", "prismatic")
            and joint.limit is not None
            and joint.limit.lower is not None
            and joint.limit.upper is not None
        ):
            limits = (joint.limit.lower, joint.limit.upper)
        elif joint.type in ("revolute", "prismatic") and joint.limit is None:
            missing_limit(f"{path}.limit", joint.type, strict, corrections)
        try:
            builder.add_joint(
                joint.name,
                parent=joint.parent,
                child=joint.child,
                origin=origin[:3, 3],
                rotation=origin[:3, :3],
                axis=(1.0, 0.0, 0.0) if joint.axis is None else joint.axis,
                type=joint.type,
                limits=limits,
                **_urdf_dynamics(joint, path),
            )
        except ModelError as exc:
            raise ModelError(f"{path}.{exc.field.split('.')[-1]}", exc.problem, exc.fix) from None
    for name, body, point in end_effector_specs(end_effectors, source or "urdf"):
        builder.add_end_effector(name, body=body, point=point)
    try:
        return builder.build(source=source, corrections=corrections)
    except ModelError as exc:
        if not exc.field.startswith("mimic"):
            raise
        raise ModelError(f"{source or 'urdf'}: {exc.field}", exc.problem, exc.fix) from None


def _urdf_dynamics(joint: Any, path: str) -> dict[str, float]:
    """A moving joint's ``<dynamics damping friction>`` (absent: 0) as ``add_joint`` keywords (yourdfpy gives the text)."""
    dynamics = getattr(joint, "dynamics", None)
    if dynamics is None or joint.type == "fixed":
        return {}
    out = {}
    for key in ("damping", "friction"):
        value = getattr(dynamics, key, None)
        if value is None:
            continue
        try:
            out[key] = float(value)
        except (TypeError, ValueError):
            raise ModelError(
                f"{path}.dynamics.{key}", f"cannot read {value!r} as a number", f"give the joint's {key} as a number"
            ) from None
    return out


def to_urdf_string(model: Model) -> str:
    """The model as URDF text (end effectors as massless fixed frames; named ones are not re-named on reading)."""
    import yourdfpy

    links = []
    joints = []
    laws = _mimic_laws(model)
    own = model.expanded()  # the joint of each body, mimic joints included
    for k, name in enumerate(model.body_names):
        origin = np.eye(4)
        origin[:3, 3] = model.com[k]
        links.append(
            yourdfpy.Link(
                name=name, inertial=yourdfpy.Inertial(origin=origin, mass=float(model.mass[k]), inertia=np.array(model.inertia[k]))
            )
        )
        if k > 0:
            j = k - 1
            place = np.eye(4)
            place[:3, :3], place[:3, 3] = model.joint_rotation[k], model.joint_origin[k]
            bounded = bool(np.isfinite(own.joint_lower[j]) and np.isfinite(own.joint_upper[j]))
            kind = "prismatic" if own.joint_type[j] == "prismatic" else ("revolute" if bounded else "continuous")
            law = laws.get(own.joint_names[j])
            joints.append(
                yourdfpy.Joint(
                    name=own.joint_names[j],
                    type=kind,
                    parent=model.body_names[model.parent[k]],
                    child=name,
                    origin=place,
                    axis=np.array(model.joint_axis[k]),
                    limit=yourdfpy.Limit(effort=0.0, velocity=0.0, lower=float(own.joint_lower[j]), upper=float(own.joint_upper[j]))
                    if bounded
                    else None,
                    dynamics=yourdfpy.Dynamics(damping=float(own.joint_damping[j]), friction=float(own.joint_friction[j]))
                    if own.joint_damping[j] or own.joint_friction[j]
                    else None,
                    mimic=None if law is None else yourdfpy.Mimic(joint=law[0], multiplier=law[1], offset=law[2]),
                )
            )
    for e in range(model.n_end_effectors):
        ee_name = _frame_name(model, e)
        links.append(yourdfpy.Link(name=ee_name))
        place = np.eye(4)
        place[:3, 3] = model.end_effector_point[e]
        joints.append(
            yourdfpy.Joint(
                name=f"{ee_name}_fixed", type="fixed", parent=model.body_names[model.end_effector_body[e]], child=ee_name, origin=place
            )
        )
    if np.any(own.joint_armature):
        rotors = ", ".join(f"{own.joint_names[j]!r} {own.joint_armature[j]:g}" for j in np.flatnonzero(own.joint_armature))
        warnings.warn(
            f"{model.name}: URDF has no element for a joint's rotor inertia: the armature of joint {rotors} is not written "
            "(save as TOML to keep it, or give it to ff.load(..., joints=...) when reading the URDF)",
            UnmodelledElementWarning,
            stacklevel=3,
        )
    if np.any(own.joint_stiffness):
        springs = ", ".join(f"{own.joint_names[j]!r} {own.joint_stiffness[j]:g}" for j in np.flatnonzero(own.joint_stiffness))
        warnings.warn(
            f"{model.name}: URDF has no element for a joint's spring: the stiffness of joint {springs} is not written "
            "(save as TOML or MJCF to keep it)",
            UnmodelledElementWarning,
            stacklevel=3,
        )
    urdf = yourdfpy.URDF(robot=yourdfpy.Robot(name=model.name, links=links, joints=joints), build_scene_graph=False, load_meshes=False)
    text = urdf.write_xml_string()  # yourdfpy returns bytes (lxml tostring), despite its docstring
    text = text.decode("utf-8") if isinstance(text, bytes) else text
    return _with_mimic_elements(text, laws) if laws else text


def _with_mimic_elements(text: str, laws: dict[str, tuple[str, float, float]]) -> str:
    """URDF text with a ``<mimic joint= multiplier= offset=>`` in each mimic joint (yourdfpy reads them, but does not write them)."""
    import xml.etree.ElementTree as ElementTree

    root = ElementTree.fromstring(text)
    for joint in root.findall("joint"):
        law = laws.get(str(joint.get("name")))
        if law is not None:
            ElementTree.SubElement(joint, "mimic", joint=law[0], multiplier=repr(law[1]), offset=repr(law[2]))
    return ElementTree.tostring(root, encoding="unicode")


# --------------------------------------------------------------------- save
def save(model: Model, path: str | Path, *, overwrite: bool = False) -> Path:
    """Write ``model`` as TOML or URDF (by extension). Never overwrites unless ``overwrite=True``."""
    import tomli_w

    path = Path(path)
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path}: exists; freefloat does not overwrite files (pass overwrite=True or choose another name)")
    suffix = path.suffix.lower()
    if suffix == ".toml":
        text = tomli_w.dumps(to_toml_dict(model))
    elif suffix == ".urdf":
        text = to_urdf_string(model)
    else:
        raise ValueError(f"{path}: unknown model file type {suffix!r}; use .toml or .urdf")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path
