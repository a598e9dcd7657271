"""Model files: TOML (freeflyer's own schema, docs/model-files.md) and URDF.

``load(path)`` picks the reader from the extension. ``save(model, path)``
writes TOML or URDF and refuses to overwrite an existing file unless asked.
URDF is parsed and written by ``yourdfpy``; the root link is the spacecraft and
every leaf link is an end effector at its frame origin.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from ..core.builder import ModelBuilder
from ..core.errors import ModelError
from ..core.model import Model, resolve_model

__all__ = ["load", "load_toml", "load_urdf", "save", "to_toml_dict", "to_urdf_string"]

_BODY_KEYS = {"name", "mass", "inertia", "com", "end_effector", "end_effector_name", "frame"}
_JOINT_KEYS = {"name", "type", "parent", "child", "origin", "rpy", "axis", "limits"}
_TOP_KEYS = {"name", "description", "bodies", "joints"}


def load(path: str | Path) -> Model:
    """Load a model from a ``.toml`` or ``.urdf`` file, or a built-in model by name (``ff.load("papadopoulos1992")``)."""
    path = Path(path)
    if not path.suffix and not path.exists():
        return resolve_model(str(path), "path")  # a built-in name (or an error listing them)
    if not path.is_file():
        raise ModelError(str(path), "file not found", "give the path of a .toml or .urdf model file")
    suffix = path.suffix.lower()
    if suffix == ".toml":
        return load_toml(path)
    if suffix in (".urdf", ".xml"):
        return load_urdf(path)
    raise ModelError(str(path), f"unknown model file type {suffix!r}", "use a .toml (freeflyer schema) or .urdf file")


# --------------------------------------------------------------------- TOML
def read_toml(path: str | Path, what: str = "model file") -> dict[str, Any]:
    """The table of a TOML file; malformed TOML or text that is not UTF-8 is a ModelError naming the file."""
    path = Path(path)
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ModelError(str(path), f"malformed TOML: {exc}", "fix the TOML syntax at that line") from None
    except UnicodeDecodeError:
        raise ModelError(str(path), "is not UTF-8 text", f"save the {what} as UTF-8 TOML") from None


def load_toml(path: str | Path) -> Model:
    """Read a model in freeflyer's TOML schema (see docs/model-files.md)."""
    return from_dict(read_toml(path), source=str(path))


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


def from_dict(data: dict[str, Any], source: str = "") -> Model:
    """Build a model from the parsed TOML tables (same schema as the file)."""
    _check_keys(data, _TOP_KEYS, "model")
    bodies = data.get("bodies")
    if not isinstance(bodies, list) or not bodies:
        raise ModelError("bodies", "is missing or empty", "add [[bodies]] tables, the first being the spacecraft")
    builder = ModelBuilder(str(data.get("name", Path(source).stem or "model")))
    for i, body in enumerate(bodies):
        path = f"bodies[{i}]"
        _check_keys(body, _BODY_KEYS, path)
        frame = bool(body.get("frame", False))
        builder.add_body(
            _require(body, "name", path, "name every body"),
            mass=0.0 if frame else _require(body, "mass", path, "give the mass in kg"),
            inertia=0.0 if frame else _require(body, "inertia", path, "give the inertia about the CM (3x3, [Ixx, Iyy, Izz] or a number)"),
            com=body.get("com", (0.0, 0.0, 0.0)),
            end_effector=body.get("end_effector"),
            end_effector_name=body.get("end_effector_name"),
            frame=frame,
        )
    joints = data.get("joints", [])
    if not isinstance(joints, list):
        raise ModelError("joints", "expected an array of tables", "write joints as [[joints]] tables")
    for i, joint in enumerate(joints):
        path = f"joints[{i}]"
        _check_keys(joint, _JOINT_KEYS, path)
        builder.add_joint(
            _require(joint, "name", path, "name every joint"),
            parent=_require(joint, "parent", path, "name the parent body"),
            child=_require(joint, "child", path, "name the child body"),
            origin=joint.get("origin", (0.0, 0.0, 0.0)),
            rpy=joint.get("rpy"),
            axis=joint.get("axis", (0.0, 0.0, 1.0)),
            type=joint.get("type", "revolute"),
            limits=joint.get("limits"),
        )
    return builder.build(source=source)


def _list(arr: np.ndarray) -> list[Any]:
    return np.asarray(arr, dtype=float).tolist()


def _leaf_hosts(model: Model) -> set[int]:
    has_child = set(int(p) for p in model.parent[1:])
    return {k for k in range(1, model.n_bodies) if k not in has_child}


def to_toml_dict(model: Model) -> dict[str, Any]:
    """The TOML tables of a model (after fixed joints were merged)."""
    leaves = _leaf_hosts(model)
    tips: dict[int, list[int]] = {}
    for e, k in enumerate(model.end_effector_body):
        tips.setdefault(int(k), []).append(e)
    bodies: list[dict[str, Any]] = []
    joints: list[dict[str, Any]] = []
    frames: list[tuple[dict[str, Any], dict[str, Any]]] = []
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
                "name": model.joint_names[j],
                "type": "revolute" if np.isfinite(model.joint_lower[j]) or np.isfinite(model.joint_upper[j]) else "continuous",
                "parent": model.body_names[model.parent[k]],
                "child": name,
                "origin": _list(model.joint_origin[k]),
                "rpy": _list(Rotation.from_matrix(model.joint_rotation[k]).as_euler("xyz")),
                "axis": _list(model.joint_axis[k]),
            }
            if joint["type"] == "revolute":
                joint["limits"] = [float(model.joint_lower[j]), float(model.joint_upper[j])]
            joints.append(joint)
    for body, joint in frames:
        bodies.append(body)
        joints.append(joint)
    return {"name": model.name, "bodies": bodies, "joints": joints}


def _frame_name(model: Model, e: int) -> str:
    """Name of the massless frame that carries end effector e in a file (unique among bodies)."""
    name = model.end_effector_names[e]
    return name if name not in model.body_names else f"{name}_tip"


# --------------------------------------------------------------------- URDF
def load_urdf(path: str | Path) -> Model:
    """Read a URDF file (via yourdfpy). Root link = spacecraft; each leaf link an end effector."""
    import xml.etree.ElementTree as ElementTree

    import yourdfpy

    path = Path(path)
    try:  # yourdfpy silently falls back to a recovering parser on bad XML: check well-formedness first
        ElementTree.parse(path)
    except ElementTree.ParseError as exc:
        raise ModelError(str(path), f"malformed URDF XML: {exc}", "fix the file so that it is valid URDF XML") from None
    try:
        urdf = yourdfpy.URDF.load(
            str(path), build_scene_graph=False, load_meshes=False, build_collision_scene_graph=False, load_collision_meshes=False
        )
    except Exception as exc:  # yourdfpy and lxml raise many types for bad XML
        raise ModelError(str(path), f"malformed URDF: {type(exc).__name__}: {exc}", "fix the file so that it is valid URDF XML") from None
    return from_urdf_robot(urdf.robot, source=str(path))


def from_urdf_robot(robot: Any, source: str = "") -> Model:
    """Build a model from a ``yourdfpy.Robot``."""
    builder = ModelBuilder(robot.name or "urdf")
    for i, link in enumerate(robot.links):
        path = f"{source or 'urdf'}: link[{i}] ({link.name})"
        inertial = link.inertial
        if inertial is None or inertial.mass is None or float(inertial.mass) == 0.0:
            builder.add_body(link.name, mass=0.0, inertia=0.0, frame=True)
            continue
        origin = np.eye(4) if inertial.origin is None else np.asarray(inertial.origin, dtype=float)
        rot = origin[:3, :3]
        inertia = np.zeros((3, 3)) if inertial.inertia is None else np.asarray(inertial.inertia, dtype=float)
        try:
            builder.add_body(link.name, mass=float(inertial.mass), inertia=rot @ inertia @ rot.T, com=origin[:3, 3])
        except ModelError as exc:
            raise ModelError(f"{path}.{exc.field.split('.')[-1]}", exc.problem, exc.fix) from None
    for i, joint in enumerate(robot.joints):
        path = f"{source or 'urdf'}: joint[{i}] ({joint.name})"
        if joint.type not in ("revolute", "continuous", "fixed"):
            raise ModelError(
                f"{path}.type", f"unsupported joint type {joint.type!r}", "freeflyer models revolute, continuous and fixed joints"
            )
        origin = np.eye(4) if joint.origin is None else np.asarray(joint.origin, dtype=float)
        limits = None
        if joint.type == "revolute" and joint.limit is not None and joint.limit.lower is not None and joint.limit.upper is not None:
            limits = (joint.limit.lower, joint.limit.upper)
        builder.add_joint(
            joint.name,
            parent=joint.parent,
            child=joint.child,
            origin=origin[:3, 3],
            rotation=origin[:3, :3],
            axis=(1.0, 0.0, 0.0) if joint.axis is None else joint.axis,
            type=joint.type,
            limits=limits,
        )
    return builder.build(source=source)


def to_urdf_string(model: Model) -> str:
    """The model as URDF text (leaf end effectors as massless fixed frames)."""
    import yourdfpy

    links = []
    joints = []
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
            bounded = bool(np.isfinite(model.joint_lower[j]) and np.isfinite(model.joint_upper[j]))
            joints.append(
                yourdfpy.Joint(
                    name=model.joint_names[j],
                    type="revolute" if bounded else "continuous",
                    parent=model.body_names[model.parent[k]],
                    child=name,
                    origin=place,
                    axis=np.array(model.joint_axis[k]),
                    limit=yourdfpy.Limit(effort=0.0, velocity=0.0, lower=float(model.joint_lower[j]), upper=float(model.joint_upper[j]))
                    if bounded
                    else None,
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
    urdf = yourdfpy.URDF(robot=yourdfpy.Robot(name=model.name, links=links, joints=joints), build_scene_graph=False, load_meshes=False)
    text = urdf.write_xml_string()  # yourdfpy returns bytes (lxml tostring), despite its docstring
    return text.decode("utf-8") if isinstance(text, bytes) else text


# --------------------------------------------------------------------- save
def save(model: Model, path: str | Path, *, overwrite: bool = False) -> Path:
    """Write ``model`` as TOML or URDF (by extension). Never overwrites unless ``overwrite=True``."""
    import tomli_w

    path = Path(path)
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path}: exists; freeflyer does not overwrite files (pass overwrite=True or choose another name)")
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
