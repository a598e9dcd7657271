"""Model reports: what ``freefloat inspect`` prints and ``freefloat demo`` writes.

:func:`model_info` gathers everything about a model into a JSON-ready dict
(plain floats, lists, strings); :func:`render_text` and :func:`render_markdown`
lay the same content out as aligned text or Markdown tables. Units are SI,
lengths in m, angles (joint limits only) in degrees. Every vector is in a body
frame (see :mod:`freefloat.conventions`): joint origins in the parent body's
frame, joint axes in the joint frame, CMs, end-effector points and the
barycentric vectors of 1992 eqs. 5-9 in the frame of the body they belong to.
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from ..core.model import Model
from ..mechanics.kinematics import system_cm

__all__ = ["PAPER_PAYLOAD", "model_info", "paper_systems", "render_markdown", "render_text", "write_model_reports"]


def _float(x: Any) -> float:
    return float(x) + 0.0  # + 0.0 turns -0.0 into 0.0


def _vec(arr: Any) -> list[float]:
    return [_float(x) for x in np.asarray(arr, dtype=float).ravel()]


def _limit(value: float) -> float | None:
    return float(np.degrees(value)) if np.isfinite(value) else None


def model_info(model: Model) -> dict[str, Any]:
    """Everything ``freefloat inspect`` shows, as a JSON-ready dict.

    Keys: ``name, source, total_mass`` (kg), ``is_planar``, ``n_bodies``,
    ``n_joints``, ``n_end_effectors``, ``system_cm_q0`` (system CM at q = 0,
    from the spacecraft frame origin, spacecraft frame, m), ``payloads`` (as
    recorded by :meth:`Model.with_payload`), and the lists

    - ``joints``: index, name, type (revolute or prismatic), parent, child (bodies), origin (m,
      parent frame), rotation (3x3, joint frame -> parent frame) and rpy_deg (the same as URDF's
      fixed-axis roll, pitch, yaw, degrees), axis (joint frame) and axis_parent (the axis in the
      parent frame at q = 0), limits ([lower, upper] in rad or m, null = none) and limits_deg
      (revolute joints; null otherwise);
      and the joint's own dynamics: armature (kg m², kg), damping and friction (Model.joint_*);
    - ``wheels``: each reaction wheel (docs/wheels.md; the text shows one line each): name, axis (spacecraft frame),
      inertia (Js, kg m²), max_torque (N m) and max_speed (rad/s, null = none), viscous and coulomb friction;
    - ``mimic``: each mimic joint (a dependent coordinate, no column of q): name, leader (the independent
      joint it follows), multiplier and offset (q = multiplier q_leader + offset), type and child body;
    - ``end_effector_rule``: "named" (the file or the caller named them), "leaf sites" (MJCF
      sites on leaf bodies) or "leaves" (every leaf body, when nothing is named);
    - ``corrections``: every change the loader made to the file's data (where, defect, what was
      used instead, size of the change);
    - ``unmodelled``: every element of the file that acts on the dynamics and that the loader
      dropped (where, element, effect, items: the joints, actuators ... it concerns);
    - ``end_effectors``: index, name, body, point (m, body frame), r_star
      (barycenter of the body -> end-effector point, m, body frame, 1992 eq. 10);
    - ``bodies``: index, name, mass (kg), cm (m, body frame), inertia (3x3
      about the CM, kg m², body axes), principal_moments (kg m², ascending);
    - ``barycentric``: per body, outboard_mass_fraction μ* (1992 eq. 6),
      barycenter, c_star, l_star (body frame, m) and r_star (barycenter of the
      parent body -> this body's joint, parent frame, m; zero for the spacecraft),
      exactly the rows of :func:`freefloat.barycentric_vectors`.
    """
    bary = model.bary
    joints = []
    body_of = {name: k + 1 for k, name in enumerate(model.body_joint_names)}  # the body each joint moves
    for j, name in enumerate(model.joint_names):
        k = body_of[name]
        lower, upper = _limit(model.joint_lower[j]), _limit(model.joint_upper[j])
        sliding = model.joint_type[j] == "prismatic"
        raw: list[float | None] = [v if np.isfinite(v) else None for v in (_float(model.joint_lower[j]), _float(model.joint_upper[j]))]
        joints.append(
            {
                "index": j,
                "name": name,
                "type": model.joint_type[j],
                "parent": model.body_names[int(model.parent[k])],
                "child": model.body_names[k],
                "origin": _vec(model.joint_origin[k]),
                "rotation": [_vec(row) for row in model.joint_rotation[k]],
                "rpy_deg": _rpy_deg(model.joint_rotation[k]),
                "axis": _vec(model.joint_axis[k]),
                "axis_parent": _vec(model.joint_rotation[k] @ model.joint_axis[k]),
                "limits": None if raw == [None, None] else raw,
                "limits_deg": None if sliding or (lower is None and upper is None) else [lower, upper],
                "armature": _float(model.joint_armature[j]),
                "damping": _float(model.joint_damping[j]),
                "friction": _float(model.joint_friction[j]),
            }
        )
    end_effectors = []
    for e, name in enumerate(model.end_effector_names):
        k = int(model.end_effector_body[e])
        end_effectors.append(
            {
                "index": e,
                "name": name,
                "body": model.body_names[k],
                "point": _vec(model.end_effector_point[e]),
                "r_star": _vec(bary.end_effector_table[e, k]),
            }
        )
    bodies = []
    barycentric = []
    for k, name in enumerate(model.body_names):
        inertia = np.asarray(model.inertia[k])
        bodies.append(
            {
                "index": k,
                "name": name,
                "mass": _float(model.mass[k]),
                "cm": _vec(model.com[k]),
                "inertia": [_vec(row) for row in inertia],
                "principal_moments": _vec(np.linalg.eigvalsh(inertia)),
            }
        )
        barycentric.append(
            {
                "index": k,
                "body": name,
                "outboard_mass_fraction": _float(bary.outboard_mass_fraction[k]),
                "barycenter": _vec(bary.barycenter[k]),
                "c_star": _vec(bary.c_star[k]),
                "l_star": _vec(bary.l_star[k]),
                "r_star": _vec(bary.r_star[k]),
            }
        )
    payloads = [
        {
            "name": str(p["name"]),
            "end_effector": str(p["end_effector"]),
            "body": str(p["body"]),
            "mass": _float(p["mass"]),
            "cm": _vec(p["cm"]),
            "inertia": [_vec(row) for row in np.asarray(p["inertia"], dtype=float)],
        }
        for p in model.payloads
    ]
    return {
        "name": model.name,
        "source": model.source,
        "total_mass": _float(model.total_mass),
        "is_planar": bool(model.is_planar),
        "n_bodies": model.n_bodies,
        "n_joints": model.n_joints,
        "n_end_effectors": model.n_end_effectors,
        "system_cm_q0": _vec(system_cm(model, np.zeros(model.n_joints))),
        "payloads": payloads,
        "end_effector_rule": model.end_effector_rule,
        "corrections": [_jsonable(c) for c in model.corrections],
        "unmodelled": [_jsonable(u) for u in model.unmodelled],
        "joints": joints,
        "mimic": [
            {
                "name": str(r["joint"]),
                "leader": str(r["leader"]),
                "multiplier": _float(r["multiplier"]),
                "offset": _float(r["offset"]),
                "type": str(r["type"]),
                "child": str(r["body"]),
            }
            for r in model.mimic
        ],
        "end_effectors": end_effectors,
        "bodies": bodies,
        "barycentric": barycentric,
        "wheels": [
            {
                "name": w.name,
                "axis": _vec(w.axis),
                "inertia": _float(w.inertia),
                **{key: (_float(getattr(w, key)) if np.isfinite(getattr(w, key)) else None) for key in ("max_torque", "max_speed")},
                "viscous": _float(w.viscous),
                "coulomb": _float(w.coulomb),
            }
            for w in model.wheels
        ],
    }


def _rpy_deg(rotation: np.ndarray) -> list[float]:
    """URDF roll, pitch, yaw (deg) of a joint frame; at ±90° pitch (gimbal lock) yaw is set to 0 and roll
    carries the rest, a valid rpy of the same rotation (scipy says so with a warning, not needed here)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Gimbal lock detected", category=UserWarning)
        return _vec(Rotation.from_matrix(rotation).as_euler("xyz", degrees=True))


def _jsonable(value: Any) -> Any:
    """Plain JSON types (floats, lists, dicts, str) of a correction record; non-finite floats as strings."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_jsonable(v) for v in value]
    if isinstance(value, (float, np.floating)):
        return float(value) if np.isfinite(value) else str(float(value))
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        return int(value)
    return value


_RULES = {
    "named": "named (only the listed ones)",
    "leaf sites": "every site on a leaf body (MJCF; none named)",
    "leaves": "every leaf body (none named)",
}


# --------------------------------------------------------------------- layout
def _num(x: float | None) -> str:
    if x is None:
        return "none"
    x = 0.0 if abs(x) < 1e-13 else x
    return f"{x:.6g}"


@dataclass(frozen=True)
class _Table:
    title: str
    headers: tuple[str, ...]
    rows: tuple[tuple[Any, ...], ...]  # cells: str, int, float, None or a list of floats (a vector)
    notes: tuple[str, ...] = ()


def _cells(table: _Table, *, markdown: bool = False) -> list[list[str]]:
    """Cells as strings; the components of a vector column are padded to a common width
    (and, for Markdown, set in code so that they line up); Markdown text is escaped."""
    columns: list[list[str]] = []
    for c in range(len(table.headers)):
        values = [row[c] for row in table.rows]
        if values and all(isinstance(v, list) for v in values):
            parts = [[_num(x) for x in v] for v in values]
            widths = [max((len(p[i]) for p in parts if i < len(p)), default=0) for i in range(max(len(p) for p in parts))]
            tick = "`" if markdown else ""
            columns.append([tick + "[" + ", ".join(s.rjust(w) for s, w in zip(p, widths, strict=False)) + "]" + tick for p in parts])
        else:
            text = [v if isinstance(v, str) else str(v) if isinstance(v, int) else _num(v) for v in values]
            columns.append([_md_escape(t) for t in text] if markdown else text)
    return [[columns[c][r] for c in range(len(columns))] for r in range(len(table.rows))]


def _numeric(table: _Table, c: int) -> bool:
    return all(isinstance(row[c], (int, float)) and not isinstance(row[c], bool) for row in table.rows)


def _count(n: int, word: str) -> str:
    plural = "bodies" if word == "body" else f"{word}s"
    return f"{n} {word if n == 1 else plural}"


def _summary(info: dict[str, Any]) -> list[tuple[str, str]]:
    cm = info["system_cm_q0"]
    lines = [
        ("source", info["source"] or "(not recorded)"),
        ("total mass", f"{_num(info['total_mass'])} kg"),
        ("planar", "yes" if info["is_planar"] else "no"),
        (
            "size",
            f"{_count(info['n_bodies'], 'body')}, {_count(info['n_joints'], 'joint')}, {_count(info['n_end_effectors'], 'end effector')}",
        ),
        ("system CM at q = 0", f"[{', '.join(_num(x) for x in cm)}] m (spacecraft frame, from its origin)"),
        ("end effectors", _RULES.get(info.get("end_effector_rule", ""), str(info.get("end_effector_rule")))),
        ("corrections", f"{len(info.get('corrections', []))} (listed below)" if info.get("corrections") else "none"),
        ("not modelled", f"{len(info.get('unmodelled', []))} kind(s) dropped (listed below)" if info.get("unmodelled") else "none"),
    ]
    for w in info.get("wheels", []):
        limits = ", ".join(
            f"{label} {_num(w[key]) + ' ' + unit if w[key] is not None else 'none'}"
            for key, label, unit in (("max_torque", "max torque", "N m"), ("max_speed", "max speed", "rad/s"))
        )
        lines.append(
            (
                f"wheel {w['name']}",
                f"axis [{', '.join(_num(x) for x in w['axis'])}] (spacecraft frame), Js {_num(w['inertia'])} kg m², {limits}",
            )
        )
    kinds = [j.get("type", "revolute") for j in info["joints"]]
    if "prismatic" in kinds:
        lines.append(("joint types", f"{kinds.count('revolute')} revolute, {kinds.count('prismatic')} prismatic (q in m)"))
    for p in info["payloads"]:
        moments = np.linalg.eigvalsh(np.asarray(p["inertia"]))
        lines.append(
            (
                "payload" if p["name"] == "payload" else f"payload {p['name']}",
                f"{_num(p['mass'])} kg, principal moments [{', '.join(_num(x) for x in moments)}] kg m², "
                f"held by {p['end_effector']} (merged into {p['body']})",
            )
        )
    return lines


def _tables(info: dict[str, Any]) -> list[_Table]:
    joints = _Table(
        "Joints",
        ("#", "name", "type", "parent", "child", "origin (m)", "rpy (deg)", "axis", "axis in parent", "limits"),
        tuple(
            (
                j["index"],
                j["name"],
                j.get("type", "revolute"),
                j["parent"],
                j["child"],
                j["origin"],
                j["rpy_deg"],
                j["axis"],
                j["axis_parent"],
                _limits_text(j),
            )
            for j in info["joints"]
        ),
        (
            "origin, rpy: joint frame in the parent body frame (rpy: fixed-axis roll, pitch, yaw, as URDF); "
            "axis: unit vector in the joint frame, and in the parent frame at q = 0; limits in deg (revolute) or m.",
        ),
    )
    effectors = _Table(
        "End effectors",
        ("#", "name", "body", "point (m)", "r* (m)"),
        tuple((e["index"], e["name"], e["body"], e["point"], e["r_star"]) for e in info["end_effectors"]),
        ("point: in the body frame; r*: barycenter of the body -> end-effector point, body frame (1992 eq. 10).",),
    )
    bodies = _Table(
        "Mass properties",
        ("#", "body", "mass (kg)", "CM (m)", "principal moments (kg m²)"),
        tuple((b["index"], b["name"], b["mass"], b["cm"], b["principal_moments"]) for b in info["bodies"]),
        ("CM: in the body frame, from the inboard joint (the spacecraft: from its frame origin); moments about the CM.",),
    )
    bary = _Table(
        "Barycentric vectors (1992 eqs. 5-9)",
        ("#", "body", "μ*", "barycenter (m)", "c* (m)", "l* (m)", "r* (m)"),
        tuple(
            (b["index"], b["body"], b["outboard_mass_fraction"], b["barycenter"], b["c_star"], b["l_star"], b["r_star"])
            for b in info["barycentric"]
        ),
        (
            "μ*: outboard mass fraction, the mass on the far side of the body's joint over the total mass (eq. 6).",
            "barycenter, c* (barycenter -> CM) and l* (barycenter -> inboard joint): body frame.",
            "r*: barycenter of the parent body -> this body's joint, parent body frame (eq. 8a); zero for the spacecraft.",
        ),
    )
    tables = [joints, effectors, bodies, bary]
    own = [j for j in info["joints"] if j.get("armature") or j.get("damping") or j.get("friction")]
    if own:
        tables.insert(
            1,
            _Table(
                "Joint dynamics",
                ("#", "name", "armature", "damping", "friction"),
                tuple((j["index"], j["name"], j["armature"], j["damping"], j["friction"]) for j in own),
                (
                    "armature: rotor inertia on the joint's diagonal of H+ (kg m², kg when prismatic); damping (N m s/rad, N s/m) "
                    "and Coulomb friction (N m, N): passive torques (docs/model-files.md). Joints not listed have none.",
                ),
            ),
        )
    if info.get("mimic"):
        tables.insert(
            1,
            _Table(
                "Mimic joints",
                ("name", "type", "child", "leader", "law"),
                tuple(
                    (m["name"], m["type"], m["child"], m["leader"], f"q = {_num(m['multiplier'])} q_{m['leader']} + {_num(m['offset'])}")
                    for m in info["mimic"]
                ),
                ("A mimic joint has no column of q, qdot, tau, J* or H+: it moves with its leader, by the law.",),
            ),
        )
    if info.get("corrections"):
        tables.append(
            _Table(
                "Corrections made when loading",
                ("#", "where", "defect", "used instead", "change"),
                tuple(
                    (
                        i,
                        str(c.get("where", "")),
                        str(c.get("defect", "")),
                        str(c.get("correction", "")),
                        f"{_num(c.get('change_kg_m2'))} kg m² ({_num(100.0 * float(c.get('relative_change', 0.0)))} %)",
                    )
                    for i, c in enumerate(info["corrections"])
                ),
                ("Load with strict=True (CLI: --strict) to refuse such data instead.",),
            )
        )
    if info.get("unmodelled"):
        tables.append(
            _Table(
                "Not modelled: dropped when loading",
                ("#", "element", "effect", "found"),
                tuple(
                    (i, str(u.get("element", "")), str(u.get("effect", "")), "; ".join(u.get("items", [])))
                    for i, u in enumerate(info["unmodelled"])
                ),
                (
                    "These act on the dynamics of the robot in the file; freefloat's model leaves them out (docs/model-files.md).",
                    "Load with strict=True (CLI: --strict) to refuse such files instead.",
                ),
            )
        )
    return tables


def _limits_text(joint: dict[str, Any]) -> str:
    if joint.get("type") == "prismatic":
        lim = joint.get("limits")
        return "none" if lim is None else f"[{_num(lim[0])}, {_num(lim[1])}] m"
    lim = joint["limits_deg"]
    return "none" if lim is None else f"[{_num(lim[0])}, {_num(lim[1])}] deg"


def render_text(info: dict[str, Any]) -> str:
    """The inspect report as aligned plain text (from :func:`model_info`)."""
    summary = _summary(info)
    width = max(len(k) for k, _ in summary)
    lines = [info["name"], *(f"  {k.ljust(width)}  {v}" for k, v in summary)]
    for table in _tables(info):
        lines += ["", table.title]
        cells = [list(table.headers), *_cells(table)]
        widths = [max(len(row[c]) for row in cells) for c in range(len(table.headers))]
        numeric = [_numeric(table, c) for c in range(len(table.headers))]
        for row in cells:
            text = "  ".join(s.rjust(w) if num else s.ljust(w) for s, w, num in zip(row, widths, numeric, strict=True))
            lines.append("  " + text.rstrip())
        lines += [f"  {note}" for note in table.notes]
    return "\n".join(lines) + "\n"


def _md_escape(text: str) -> str:
    return text.replace("\\", "\\\\").replace("|", "\\|").replace("*", "\\*").replace("<", "&lt;")


def render_markdown(info: dict[str, Any], *, level: int = 2, description: str = "") -> str:
    """The inspect report as Markdown: a heading at ``level``, ``description`` (a paragraph),
    a summary list and one table per section."""
    head = "#" * level
    lines = [f"{head} `{info['name']}`", ""]
    if description:
        lines += [_md_escape(description), ""]
    lines += [f"- **{k}**: {_md_escape(v)}" for k, v in _summary(info)]
    for table in _tables(info):
        lines += ["", f"{head}# {_md_escape(table.title)}", ""]
        lines.append("| " + " | ".join(_md_escape(h) for h in table.headers) + " |")
        lines.append("|" + "|".join("---:" if _numeric(table, c) else "---" for c in range(len(table.headers))) + "|")
        for row in _cells(table, markdown=True):
            lines.append("| " + " | ".join(row) + " |")
        if table.notes:
            lines.append("")
            lines += [f"- {_md_escape(note)}" for note in table.notes]
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------- files
def write_model_reports(
    models: Iterable[tuple[str, str, Model]],
    out_dir: str | Path,
    *,
    title: str = "freefloat model report",
    preamble: Sequence[str] = (),
) -> list[Path]:
    """For each (slug, description, model): write ``out_dir/<slug>.json`` (the inspect JSON) and
    ``out_dir/<slug>.md``; then ``out_dir/report.md`` gathering them all. Returns the paths written.

    ``out_dir`` is created. Existing report files of the same names are replaced
    (they are outputs, never a user's input).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    sections = [f"# {title}", "", *preamble]
    for slug, description, model in models:
        info = model_info(model)
        json_path = out / f"{slug}.json"
        json_path.write_text(json.dumps(info, indent=2) + "\n", encoding="utf-8")
        md = render_markdown(info, level=2, description=description)
        md_path = out / f"{slug}.md"
        md_path.write_text(md, encoding="utf-8")
        written += [json_path, md_path]
        sections += ["", md.rstrip("\n")]
    report = out / "report.md"
    report.write_text("\n".join(sections).rstrip("\n") + "\n", encoding="utf-8")
    written.append(report)
    return written


# --------------------------------------------------------------------- the papers' systems
#: The payload of 1992 §V: mass (kg) and moment of inertia about its CM (kg m²).
PAPER_PAYLOAD = (400.0, 25.0)


def paper_systems() -> list[tuple[str, str, Model]]:
    """(slug, description, model) of every system of the two papers, before and after capture."""
    from ..models import papadopoulos1991, papadopoulos1992

    mass, inertia = PAPER_PAYLOAD
    one_arm = papadopoulos1992(arms=1)
    two_arm = papadopoulos1992(arms=2)
    payload = f"the {mass:g} kg, {inertia:g} kg m² payload"
    return [
        (
            "papadopoulos1991",
            "Papadopoulos & Dubowsky 1991, §V example (Table I): a two-link arm on a 40 kg spacecraft.",
            papadopoulos1991(),
        ),
        ("papadopoulos1992", "Papadopoulos 1992, Table I: two two-link manipulators on a 400 kg spacecraft.", two_arm),
        ("papadopoulos1992_one_arm", "Papadopoulos 1992, Table I with manipulator 2 removed (§V).", one_arm),
        (
            "papadopoulos1992_one_arm_captured",
            f"Papadopoulos 1992 §V: the one-arm system after capturing {payload} (Table VI).",
            one_arm.with_payload(end_effector=0, mass=mass, inertia=inertia),
        ),
        (
            "papadopoulos1992_captured",
            f"Papadopoulos 1992: the two-arm system with {payload} held by arm 1 (Tables IV, V).",
            two_arm.with_payload(end_effector="arm1_ee", mass=mass, inertia=inertia),
        ),
    ]
