"""Mimic joints: dependent coordinates q_mimic = multiplier q_leader + offset (docs/model-files.md, "Mimic joints").

:func:`resolve_mimics` and :func:`leader_limits` serve the :class:`~freefloat.core.builder.ModelBuilder` (chains of
mimics resolved to their root leader, the laws composed; a mimic joint's limits carried to its leader);
:func:`body_joints` makes a :class:`~freefloat.core.model.Model`'s map from q (its independent joints) to the joints of
its bodies 1..B-1 (``Model.body_joint_*``, ``Model.mimic_matrix``), which the engine and the closed forms read.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from .errors import ModelError

__all__ = ["body_joints", "leader_limits", "resolve_mimics"]


def _frozen(arr: Any, dtype: Any = float) -> np.ndarray:
    out = np.array(arr, dtype=dtype, copy=True)
    out.setflags(write=False)
    return out


def resolve_mimics(
    joints: Sequence[Any], mimics: Sequence[tuple[str, str, float, float]], close_names: Callable[[str, list[str]], str]
) -> dict[str, tuple[str, float, float]]:
    """Each mimic joint's root leader and composed law {joint: (leader, multiplier, offset)}; errors name the joint.

    ``joints``: the builder's joint specifications (name, type); ``mimics``: (joint, leader, multiplier, offset) as
    given; ``close_names(name, known)``: the "did you mean" hint of an unknown name."""
    by_name = {j.name: j for j in joints}
    direct: dict[str, tuple[str, float, float]] = {}
    for joint, leader, multiplier, offset in mimics:
        path = f"mimic ({joint})"
        if joint not in by_name:
            raise ModelError(path, f"there is no joint named {joint!r}{close_names(joint, list(by_name))}", "name a joint of the model")
        if by_name[joint].type == "fixed":
            raise ModelError(
                path,
                f"joint {joint!r} is fixed: it has no coordinate to follow another",
                "make it revolute or prismatic, or drop its mimic",
            )
        if leader not in by_name:
            raise ModelError(
                f"{path}.leader",
                f"joint {joint!r} mimics {leader!r}, which is not a joint of the model{close_names(leader, list(by_name))}",
                "name a joint of the model",
            )
        if by_name[leader].type == "fixed":
            raise ModelError(
                f"{path}.leader",
                f"joint {joint!r} mimics the fixed joint {leader!r}, which has no coordinate",
                f"make {joint!r} fixed at its offset, or name a revolute or prismatic leader",
            )
        direct[joint] = (leader, multiplier, offset)
    resolved: dict[str, tuple[str, float, float]] = {}
    for joint in direct:
        chain = [joint]
        leader, multiplier, offset = direct[joint]
        while leader in direct:
            if leader in chain:
                loop = " -> ".join([*chain, leader])
                raise ModelError(
                    f"mimic ({joint})",
                    f"joint {joint!r} mimics itself through a chain of mimic joints ({loop})",
                    "let the chain end at a joint that is not a mimic joint",
                )
            chain.append(leader)
            leader, r, c = direct[leader][0], direct[leader][1], direct[leader][2]
            multiplier, offset = multiplier * r, multiplier * c + offset
        resolved[joint] = (leader, multiplier, offset)
    return resolved


def leader_limits(
    movable: Sequence[Any], laws: dict[str, tuple[str, float, float]], lower: np.ndarray, upper: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The body joints' limits (B - 1) with each mimic joint's limits carried to its leader through the law (intersected)."""
    lower, upper = lower.copy(), upper.copy()
    row = {j.name: k for k, j in enumerate(movable)}
    for j in movable:
        if j.name not in laws or not (np.isfinite(j.lower) or np.isfinite(j.upper)):
            continue
        leader, multiplier, offset = laws[j.name]
        if multiplier == 0.0:
            continue
        ends = sorted(((j.lower - offset) / multiplier, (j.upper - offset) / multiplier))
        k = row[leader]
        lower[k], upper[k] = max(lower[k], ends[0]), min(upper[k], ends[1])
        if not lower[k] < upper[k]:
            raise ModelError(
                f"mimic ({j.name})",
                f"its limits [{j.lower:g}, {j.upper:g}] leave no range of its leader {leader!r} through the law "
                f"q = {multiplier:g} q_{leader} + {offset:g}",
                "widen the limits of the mimic joint or of its leader",
            )
    return lower, upper


def body_joints(model: Any, joint_types: Sequence[str], parameters: Sequence[str]) -> dict[str, Any]:
    """The joints of bodies 1..B-1 of a :class:`~freefloat.core.model.Model` and the map from q to their values, each
    mimic record checked (``joint_types``: the valid types; ``parameters``: the joints' own parameters, ``joint_<name>``)."""
    n_b, n = len(model.body_names), len(model.joint_names)
    if not model.mimic:
        return {
            "names": model.joint_names,
            "type": model.joint_type,
            "prismatic": model._prismatic,
            "coordinate": _frozen(np.arange(n), int),
            "multiplier": _frozen(np.ones(n)),
            "offset": _frozen(np.zeros(n)),
            "matrix": _frozen(np.eye(n)),
        }
    if n_b - 1 != n + len(model.mimic):
        raise ModelError(
            "mimic",
            f"{n} joints and {len(model.mimic)} mimic joints for {n_b - 1} moving bodies",
            "give one joint per body below the spacecraft",
        )
    by_body: dict[int, dict[str, Any]] = {}
    for i, record in enumerate(model.mimic):
        path = f"mimic[{i}] ({record.get('joint')})"
        body = record.get("body")
        if body not in model.body_names or body == model.body_names[0]:
            raise ModelError(f"{path}.body", f"{body!r} is not a moving body of the model", "name the body the mimic joint moves")
        k = model.body_names.index(body)
        if k in by_body:
            raise ModelError(f"{path}.body", f"body {body!r} has two mimic joints", "give each body one joint")
        if record.get("leader") not in model.joint_names:
            raise ModelError(
                f"{path}.leader", f"{record.get('leader')!r} is not an independent joint of the model", "name a joint of joint_names"
            )
        if record.get("type", "revolute") not in joint_types:
            raise ModelError(f"{path}.type", f"unknown joint type {record.get('type')!r}", f"use one of {', '.join(joint_types)}")
        for key in ("multiplier", "offset"):
            value = record.get(key, 1.0 if key == "multiplier" else 0.0)
            if isinstance(value, (bool, str)) or not np.isfinite(float(value)):
                raise ModelError(f"{path}.{key}", f"is {value!r}", "give a finite number")
        by_body[k] = record
    names: list[str] = []
    types: list[str] = []
    lower: list[float] = []
    upper: list[float] = []
    coordinate: list[int] = []
    multiplier: list[float] = []
    offset: list[float] = []
    passive: dict[str, list[float]] = {key: [] for key in parameters}
    j = 0
    for k in range(1, n_b):
        law = by_body.get(k)
        if law is None:
            names.append(model.joint_names[j])
            types.append(model.joint_type[j])
            lower.append(model.joint_lower[j])
            upper.append(model.joint_upper[j])
            coordinate.append(j)
            multiplier.append(1.0)
            offset.append(0.0)
            for key in passive:
                passive[key].append(float(getattr(model, f"joint_{key}")[j]))
            j += 1
        else:
            names.append(str(law["joint"]))
            types.append(str(law.get("type", "revolute")))
            lower.append(float(law.get("lower", -np.inf)))
            upper.append(float(law.get("upper", np.inf)))
            coordinate.append(model.joint_names.index(law["leader"]))
            multiplier.append(float(law.get("multiplier", 1.0)))
            offset.append(float(law.get("offset", 0.0)))
            for key in passive:
                passive[key].append(float(law.get(key, 0.0)))
    if len(set(names)) != len(names):
        raise ModelError("mimic", f"a mimic joint shares its name with another joint ({names})", "give every joint a unique name")
    matrix = np.zeros((n_b - 1, n))
    matrix[np.arange(n_b - 1), coordinate] = multiplier
    return {
        "names": tuple(names),
        "type": tuple(types),
        "prismatic": _frozen([t == "prismatic" for t in types], bool),
        "coordinate": _frozen(coordinate, int),
        "multiplier": _frozen(multiplier),
        "offset": _frozen(offset),
        "matrix": _frozen(matrix),
        "lower": np.array(lower),
        "upper": np.array(upper),
        **{key: np.array(values) for key, values in passive.items()},
    }
