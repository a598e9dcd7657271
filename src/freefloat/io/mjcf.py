"""MJCF input (MuJoCo's XML), read by MuJoCo's own parser and compiler (the ``mujoco`` package).

MuJoCo compiles the file (defaults, includes, ``childclass``, inertias from geoms, ...); the
compiled ``MjModel`` is then read into a :class:`~freefloat.Model`:

* the one body under ``<worldbody>`` is the spacecraft; it has a free joint or none;
* every other body has no joint (welded: a fixed joint, merged into its parent) or one
  ``hinge`` (revolute) or ``slide`` (prismatic) joint; ball joints, and bodies with several
  joints, are refused with an error that names them;
* a hinge may sit anywhere in its body (``<joint pos=...>``); freefloat's body frame then starts
  on the axis, at the joint position, with the MJCF body's axes: CMs, sites and child bodies are
  shifted by that offset (a change of reference point only);
* mass, CM and the principal inertia (``body_ipos``, ``body_iquat``, ``body_inertia``) become the
  body's; non-physical inertias get the same treatment as in URDF files (warning or ``strict``);
* ``range`` of limited joints become joint limits (rad, m);
* a joint equality ``<equality><joint joint1="a" joint2="b" polycoef="c0 c1 0 0 0"/>`` of first order
  makes ``a`` a mimic joint of ``b``: q_a = c1 q_b + c0 (both measured from their reference positions,
  as MuJoCo does); higher orders, a ``joint1`` without ``joint2`` and inactive ones are refused;
* end effectors: the sites or bodies named in ``end_effectors=``; else every site on a leaf body
  (``end_effector_rule = "leaf sites"``); else, when no leaf has a site, every leaf body;
* what acts on the dynamics but is not modelled (joint damping, armature, tendons, gear ratios, ...:
  :data:`freefloat.io.unmodelled.ELEMENTS`) is dropped with an ``UnmodelledElementWarning`` and
  recorded in ``Model.unmodelled`` (``strict``: an error); geometry, cameras, lights, gravity and
  control ranges are ignored.

MuJoCo is an optional dependency for this reader: ``pip install "freefloat[mjcf]"``.
"""

from __future__ import annotations

import contextlib
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from ..core.builder import ModelBuilder
from ..core.errors import ModelError
from ..core.model import Model
from ._readers import EndEffectors, end_effector_specs, naming_file, physical_inertia
from .unmodelled import mjcf_unmodelled, report_unmodelled

__all__ = ["from_mjmodel", "load_mjcf"]


def load_mjcf(path: str | Path, *, end_effectors: EndEffectors = None, strict: bool = False) -> Model:
    """Read an MJCF file with MuJoCo's parser; see the module docstring for the mapping."""
    try:
        import mujoco
    except ImportError:
        raise ModelError(
            str(path), "is an MJCF file, which freefloat reads with MuJoCo's own parser", 'install it: pip install "freefloat[mjcf]"'
        ) from None
    # made absolute before the scratch folder below becomes the working directory (a relative path is the caller's), and
    # not resolved: MuJoCo reads <include file>, meshdir and mesh files relative to the folder of the path it is given,
    # a symbolic link's folder included (mujoco.MjModel.from_xml_path("variant/arm.xml") reads variant/'s meshes)
    given = Path(path).absolute()
    try:
        # MuJoCo writes MUJOCO_LOG.TXT into the working directory on some errors: give it a scratch one
        with tempfile.TemporaryDirectory(prefix="freefloat-mujoco-") as scratch, contextlib.chdir(scratch):
            mj = mujoco.MjModel.from_xml_path(str(given))
    except ValueError as exc:  # MuJoCo's parse and compile errors
        raise ModelError(str(path), f"MuJoCo could not compile it: {exc}".replace("\n", " "), "fix the MJCF file") from None
    return naming_file(path, lambda: from_mjmodel(mj, source=str(path), end_effectors=end_effectors, strict=strict))


def _name(mujoco: Any, mj: Any, kind: Any, index: int, fallback: str) -> str:
    return mujoco.mj_id2name(mj, kind, index) or f"{fallback}{index}"


def _quat_matrix(wxyz: np.ndarray) -> np.ndarray:
    return np.asarray(Rotation.from_quat(np.roll(np.asarray(wxyz, dtype=float), -1)).as_matrix())


def from_mjmodel(mj: Any, source: str = "", *, end_effectors: EndEffectors = None, strict: bool = False) -> Model:
    """Build a model from a compiled ``mujoco.MjModel``."""
    import mujoco

    where = source or "mjcf"
    obj = mujoco.mjtObj
    kinds = mujoco.mjtJoint
    bodies = [_name(mujoco, mj, obj.mjOBJ_BODY, b, "body") for b in range(mj.nbody)]
    joints = [_name(mujoco, mj, obj.mjOBJ_JOINT, j, "joint") for j in range(mj.njnt)]
    roots = [b for b in range(1, mj.nbody) if mj.body_parentid[b] == 0]
    if len(roots) != 1:
        raise ModelError(
            f"{where}: worldbody",
            f"holds {len(roots)} bodies ({', '.join(bodies[b] for b in roots) or 'none'}); a space robot has one root, the spacecraft",
            "put the robot under one body (the spacecraft) and remove other bodies from <worldbody>",
        )
    root = roots[0]
    has_child = {int(mj.body_parentid[b]) for b in range(1, mj.nbody)}
    offset = np.zeros((mj.nbody, 3))  # freefloat's body frame origin in the MJCF body frame (the hinge position)
    kind: dict[int, tuple[str, int]] = {}
    for b in range(1, mj.nbody):
        first, count = int(mj.body_jntadr[b]), int(mj.body_jntnum[b])
        path = f"{where}: body {bodies[b]!r}"
        if count > 1:
            names = ", ".join(repr(joints[j]) for j in range(first, first + count))
            raise ModelError(path, f"has {count} joints ({names})", "give each joint its own body (with a mass), one joint per body")
        if count == 0:
            continue
        jtype = int(mj.jnt_type[first])
        if b == root:
            if jtype != kinds.mjJNT_FREE:
                raise ModelError(
                    f"{path}: joint {joints[first]!r}",
                    "the spacecraft (the body under <worldbody>) must have a free joint or none",
                    "move the joint to a body below the spacecraft",
                )
            continue
        if jtype == kinds.mjJNT_HINGE:
            kind[b] = ("revolute", first)
            offset[b] = mj.jnt_pos[first]
        elif jtype == kinds.mjJNT_SLIDE:
            kind[b] = ("prismatic", first)
        else:
            label = {kinds.mjJNT_BALL: "ball", kinds.mjJNT_FREE: "free"}.get(jtype, str(jtype))
            raise ModelError(
                f"{path}: joint {joints[first]!r}.type",
                f"a {label} joint inside the tree is not supported",
                "use hinge (revolute) and slide (prismatic) joints, one per body",
            )

    builder = ModelBuilder(_name(mujoco, mj, obj.mjOBJ_BODY, root, "robot") if not source else Path(source).stem)
    corrections: list[dict[str, Any]] = []
    for b in range(1, mj.nbody):
        mass = float(mj.body_mass[b])
        if mass == 0.0:
            builder.add_body(bodies[b], mass=0.0, inertia=0.0, frame=True)
            continue
        axes = _quat_matrix(mj.body_iquat[b])
        inertia = physical_inertia((axes * mj.body_inertia[b]) @ axes.T, f"{where}: body {bodies[b]!r}.inertia", strict, corrections)
        builder.add_body(bodies[b], mass=mass, inertia=inertia, com=mj.body_ipos[b] - offset[b], degenerate_ok=True)
    for b in range(1, mj.nbody):
        if b == root:
            continue
        parent = int(mj.body_parentid[b])
        turn = _quat_matrix(mj.body_quat[b])
        origin = mj.body_pos[b] + turn @ offset[b] - offset[parent]
        if b not in kind:
            builder.add_joint(f"{bodies[b]}_weld", parent=bodies[parent], child=bodies[b], origin=origin, rotation=turn, type="fixed")
            continue
        jkind, j = kind[b]
        limits = tuple(float(v) for v in mj.jnt_range[j]) if bool(mj.jnt_limited[j]) else None
        dof = int(mj.jnt_dofadr[j])
        builder.add_joint(
            joints[j],
            parent=bodies[parent],
            child=bodies[b],
            origin=origin,
            rotation=turn,
            axis=mj.jnt_axis[j],
            type=jkind,
            limits=limits,
            armature=float(mj.dof_armature[dof]),
            damping=float(mj.dof_damping[dof]),
            friction=float(mj.dof_frictionloss[dof]),  # MuJoCo's is dry friction; freefloat's is smooth (docs/model-files.md)
            stiffness=float(mj.jnt_stiffness[j]),
            # MuJoCo's springref is a qpos; freefloat's q = 0 is the drawn configuration, qpos = ref (qpos0)
            springref=float(mj.qpos_spring[mj.jnt_qposadr[j]] - mj.qpos0[mj.jnt_qposadr[j]]),
        )

    _joint_equalities(mujoco, mj, joints, where, builder)

    sites = {_name(mujoco, mj, obj.mjOBJ_SITE, s, "site"): s for s in range(mj.nsite)}
    named = end_effector_specs(end_effectors, where)
    rule = None
    if not named:
        leaf_sites = [n for n, s in sites.items() if int(mj.site_bodyid[s]) not in has_child and int(mj.site_bodyid[s]) != 0]
        named = [(n, n, (0.0, 0.0, 0.0)) for n in leaf_sites]
        rule = "leaf sites" if named else None
    for name, target, point in named:
        point = np.asarray(point, dtype=float)
        if target in sites:
            s = sites[target]
            b = int(mj.site_bodyid[s])
            builder.add_end_effector(name, body=bodies[b], point=mj.site_pos[s] - offset[b] + _quat_matrix(mj.site_quat[s]) @ point)
        elif target in bodies:
            b = bodies.index(target)
            builder.add_end_effector(name, body=target, point=point - offset[b])
        else:
            builder.add_end_effector(name, body=target, point=point)  # the builder names the unknown body, with suggestions
    model = builder.build(source=source, corrections=corrections)
    unmodelled = report_unmodelled(mjcf_unmodelled(mj), where, strict)
    if rule is not None or unmodelled:
        import dataclasses

        model = dataclasses.replace(model, end_effector_rule=rule or model.end_effector_rule, unmodelled=unmodelled)
    return model


def _joint_equalities(mujoco: Any, mj: Any, joints: list[str], where: str, builder: ModelBuilder) -> None:
    """Each joint equality (``mjEQ_JOINT``) of first order as a mimic joint: joint1 = c0 + c1 joint2; others refused naming the joint."""
    for i in range(mj.neq):
        if int(mj.eq_type[i]) != int(mujoco.mjtEq.mjEQ_JOINT):
            continue
        follower, leader = int(mj.eq_obj1id[i]), int(mj.eq_obj2id[i])
        name = joints[follower]
        path = f"{where}: equality joint {name!r}"
        coef = [float(v) for v in mj.eq_data[i, :5]]
        if leader < 0:
            raise ModelError(
                path,
                f"holds joint {name!r} at {coef[0]:g} (a joint equality without joint2)",
                f"make {name!r} a fixed joint (a weld), or name joint2",
            )
        if any(c != 0.0 for c in coef[2:]):
            raise ModelError(
                f"{path}.polycoef",
                f"{name!r} follows {joints[leader]!r} by a polynomial of order > 1 ({' '.join(f'{c:g}' for c in coef)})",
                "freefloat models mimic joints of first order: polycoef = 'offset multiplier 0 0 0'",
            )
        if not bool(mj.eq_active0[i]):
            raise ModelError(
                path, f"the equality of {name!r} and {joints[leader]!r} is inactive", "remove it, or make it active (active='true')"
            )
        builder.add_mimic(name, leader=joints[leader], multiplier=coef[1], offset=coef[0])
