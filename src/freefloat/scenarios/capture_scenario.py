"""Capture scenarios (1992 §V) from TOML files: what ``freefloat capture SCENARIO.toml`` reads, runs and writes.

A scenario names the robot, the payload and the payload's desired path; the
run is :func:`freefloat.analysis.capture.plan_capture` (post-capture PIW, path
placement, approach distance of eq. 19, capture posture and spacecraft
orientation of eqs. 20-21), plus the best posture on each family of eq. 21
for a planar two-link arm. Schema (docs/workspaces.md)::

    model = "papadopoulos1992-one-arm"   # built-in name, or a model file (path relative to the scenario)
    # end_effectors = ["left", "right"]  # optional, model files only: the model's end effectors (default: the file's, else every leaf)
    # strict = true                      # optional, model files only: refuse non-physical inertias instead of correcting them
    end_effector = "arm1_ee"             # optional: grasping end effector, name or index (default 0)
    samples = 262144                     # optional: configurations sampled for the PIW

    [payload]
    mass = 400.0                         # kg, > 0
    inertia = 25.0                       # kg m² about the payload CM: I (Izz of a planar model), [Ixx, Iyy, Izz] or 3x3
    offset = [0.0, 0.0, 0.0]             # optional: payload CM from the end-effector point, grasping body frame, m

    [path]
    points = [[0.0, 0.0], [0.0, 0.25]]   # polyline, inertial frame, m: A = points[0] (2D or 3D)
    rule = "perpendicular"               # optional: "perpendicular" (the paper's) or "max_margin"
    # R_plus = 0.54                      # optional: impose R+ (m) instead of choosing it

    [singularity]                        # optional: what counts as a dynamic singularity (PIW, posture, path check)
    rows = "position"                    # "position" (translational rows of J*), "full" or "auto" (the paper's; default)
    measure = "sigma_min"                # "sigma_min", "manipulability", "det" or "auto" (default)
    threshold = 0.02                     # singular where |measure| <= threshold (default 0)
    strategy = "auto"                    # "auto" (PIW, else a path-checked plan), "piw" (the paper's) or "path"

    [joint_limits]                       # optional, rad: joint name = [lower, upper]
    # arm1_q1 = [-2.5, 2.5]
    [joint_limits_deg]                   # optional, the same in degrees
    # arm1_q2 = [-150.0, 150.0]

Every error names the field and the fix (:class:`~freefloat.ModelError`).
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..analysis.capture import (
    STRATEGIES,
    CapturePlan,
    CapturePosture,
    PathMotion,
    _is_two_link,
    capture_families,
    optimal_capture_posture,
    plan_capture,
)
from ..analysis.singularity import MEASURES, ROWS, SingularityCriterion
from ..core.errors import ModelError, UnknownNameError
from ..core.model import MAX_LENGTH, Model, inertia_matrix
from ..io.model_files import read_toml
from .scenario import description_of, refuse_model_file, scenario_model

__all__ = [
    "CaptureResult",
    "CaptureScenario",
    "capture_scenario_from_dict",
    "load_capture_scenario",
    "plot_capture_families",
    "plot_capture_plan",
    "run_capture_scenario",
    "write_capture_outputs",
]

_TOP_KEYS = {
    "model", "end_effectors", "strict", "end_effector", "samples", "payload", "path", "singularity", "joint_limits", "joint_limits_deg",
    "description",
}  # fmt: skip
_SINGULARITY_KEYS = {"rows", "measure", "threshold", "strategy"}
_PAYLOAD_KEYS = {"mass", "inertia", "offset"}
_PATH_KEYS = {"points", "rule", "R_plus"}


@dataclass(frozen=True, eq=False)
class CaptureScenario:
    """A validated capture scenario. ``model`` is the robot before capture, joint limits applied."""

    source: str
    model: Model
    end_effector: int
    mass: float
    inertia: np.ndarray
    offset: np.ndarray
    path: np.ndarray
    rule: str = "perpendicular"
    R_plus: float | None = None
    samples: int = 1 << 18
    description: str = ""
    criterion: SingularityCriterion = field(default_factory=SingularityCriterion)
    strategy: str = "auto"


def _where(source: str, field: str) -> str:
    return f"{source}: {field}" if source else field


def _check_keys(table: Any, allowed: set[str], source: str, field: str) -> dict[str, Any]:
    if not isinstance(table, dict):
        raise ModelError(
            _where(source, field), f"expected a table, got {table!r}", f"write [{field}] with keys {', '.join(sorted(allowed))}"
        )
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise ModelError(
            _where(source, f"{field}.{unknown[0]}" if field else unknown[0]), "unknown key", f"use one of {', '.join(sorted(allowed))}"
        )
    return table


def _number(value: Any, source: str, field: str, fix: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ModelError(_where(source, field), f"expected a number, got {value!r}", fix)
    out = float(value)
    if not np.isfinite(out):
        raise ModelError(_where(source, field), f"must be finite, got {value!r}", fix)
    return out


def _with_limits(model: Model, data: dict[str, Any], source: str) -> Model:
    lower, upper = model.joint_lower.copy(), model.joint_upper.copy()
    for key, scale in (("joint_limits", 1.0), ("joint_limits_deg", np.pi / 180.0)):
        if key not in data:
            continue
        table = data[key]
        if not isinstance(table, dict):
            raise ModelError(
                _where(source, key), f"expected a table, got {table!r}", f"write [{key}] with lines joint_name = [lower, upper]"
            )
        unit = "rad" if key == "joint_limits" else "deg"
        for name, value in table.items():
            field = f"{key}.{name}"
            try:
                j = model.joint_index(name)
            except UnknownNameError as exc:
                raise ModelError(_where(source, field), str(exc), "use a joint name of the model") from None
            fix = f"give [lower, upper] in {unit} with lower < upper"
            if not isinstance(value, list) or len(value) != 2:
                raise ModelError(_where(source, field), f"expected [lower, upper], got {value!r}", fix)
            lo, hi = (_number(v, source, field, fix) * scale for v in value)
            if not lo < hi:
                raise ModelError(_where(source, field), f"lower {value[0]} is not below upper {value[1]}", fix)
            lower[j], upper[j] = lo, hi
    if np.array_equal(lower, model.joint_lower) and np.array_equal(upper, model.joint_upper):
        return model
    return dataclasses.replace(model, joint_lower=lower, joint_upper=upper)


def _path(table: dict[str, Any], source: str) -> np.ndarray:
    fix = "give points = [[x, y], ...] (or [x, y, z]) in m, inertial frame: at least the start A and one more point"
    if "points" not in table:
        raise ModelError(_where(source, "path.points"), "is missing", fix)
    points = table["points"]
    if not isinstance(points, list) or len(points) == 0:
        raise ModelError(_where(source, "path.points"), "is empty", fix)
    if len(points) < 2:
        raise ModelError(_where(source, "path.points"), f"has {len(points)} point; the path needs at least two", fix)
    rows = []
    for k, point in enumerate(points):
        if not isinstance(point, list) or len(point) not in (2, 3):
            raise ModelError(_where(source, f"path.points[{k}]"), f"expected [x, y] or [x, y, z], got {point!r}", fix)
        rows.append([_number(v, source, f"path.points[{k}]", fix) for v in point])
    if len({len(r) for r in rows}) != 1:
        raise ModelError(_where(source, "path.points"), "mixes 2D and 3D points", fix)
    arr = np.array(rows, dtype=float)
    if np.abs(arr).max() > MAX_LENGTH:
        too_far = f"{np.abs(arr).max():g} m is beyond the {MAX_LENGTH:g} m freefloat accepts for a position (a unit slip?)"
        raise ModelError(_where(source, "path.points"), too_far, fix)
    if np.linalg.norm(arr[1] - arr[0]) == 0.0:
        raise ModelError(
            _where(source, "path.points"), "the first segment A-B has zero length", "make the second point differ from the first"
        )
    return arr


def capture_scenario_from_dict(
    data: dict[str, Any],
    *,
    source: str = "",
    base_dir: Path | None = None,
    model_loader: Callable[[str], Model] | None = None,
    end_effectors: Any = None,
) -> CaptureScenario:
    """Validate a scenario given as a dict (the parsed TOML). ``base_dir``: where relative model paths start;
    ``model_loader``: reads the ``model`` key instead (then ``end_effectors`` and ``strict`` are its business);
    ``end_effectors``: replaces the scenario's ``end_effectors`` (the command line's ``-e``)."""
    if isinstance(data, dict) and "duration" in data and "payload" not in data:
        where, problem = source or "scenario", "is a simulation scenario (it has a duration and no [payload])"
        raise ModelError(where, problem, "run it with `freefloat simulate`, not `capture`")
    refuse_model_file(data, source)
    data = _check_keys(data, _TOP_KEYS, source, "")
    if model_loader is not None and isinstance(data.get("model"), str):
        loaded = model_loader(data["model"])
    else:
        loaded = scenario_model(data, source, base_dir, end_effectors)[0]
    model = _with_limits(loaded, data, source)
    ee = data.get("end_effector", 0)
    if isinstance(ee, bool) or not isinstance(ee, (int, str)):
        raise ModelError(
            _where(source, "end_effector"), f"expected a name or an index, got {ee!r}", f"use one of {model.end_effector_names}"
        )
    if model.n_end_effectors == 0:
        raise ModelError(
            _where(source, "model"),
            f"model {model.name!r} has no end effectors",
            "a capture needs an arm to grasp with: give a model with one",
        )
    try:
        e = model.end_effector_index(ee)
    except UnknownNameError as exc:
        raise ModelError(
            _where(source, "end_effector"), str(exc), f"give an index 0..{model.n_end_effectors - 1} or a name of the model"
        ) from None
    samples = data.get("samples", 1 << 18)
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 16:
        raise ModelError(_where(source, "samples"), f"expected an integer >= 16, got {samples!r}", "e.g. samples = 262144")
    if "payload" not in data:
        raise ModelError(_where(source, "payload"), "is missing", "add a [payload] table with mass (kg) and inertia (kg m²)")
    payload = _check_keys(data["payload"], _PAYLOAD_KEYS, source, "payload")
    if "mass" not in payload:
        raise ModelError(_where(source, "payload.mass"), "is missing", "give the payload mass in kg (> 0)")
    mass = _number(payload["mass"], source, "payload.mass", "give the payload mass in kg (> 0)")
    if mass <= 0.0:
        raise ModelError(_where(source, "payload.mass"), f"must be positive, got {payload['mass']!r}", "give the payload mass in kg (> 0)")
    if "inertia" not in payload:
        raise ModelError(
            _where(source, "payload.inertia"), "is missing", "give I (kg m²), [Ixx, Iyy, Izz] or a 3x3 matrix about the payload CM"
        )
    inertia = inertia_matrix(payload["inertia"], _where(source, "payload.inertia"))
    offset_raw = payload.get("offset", [0.0, 0.0, 0.0])
    offset_fix = "give offset = [x, y, z] in m, grasping body frame"
    if not isinstance(offset_raw, list) or len(offset_raw) != 3:
        raise ModelError(_where(source, "payload.offset"), f"expected [x, y, z], got {offset_raw!r}", offset_fix)
    offset = np.array([_number(v, source, "payload.offset", offset_fix) for v in offset_raw])
    if "path" not in data:
        raise ModelError(_where(source, "path"), "is missing", "add a [path] table with points = [[x, y], ...] (m)")
    path_table = _check_keys(data["path"], _PATH_KEYS, source, "path")
    points = _path(path_table, source)
    rule = path_table.get("rule", "perpendicular")
    if rule not in ("perpendicular", "max_margin"):
        raise ModelError(_where(source, "path.rule"), f"unknown rule {rule!r}", 'use "perpendicular" (the paper\'s) or "max_margin"')
    r_plus = None
    if "R_plus" in path_table:
        r_plus = _number(path_table["R_plus"], source, "path.R_plus", "give R+ in m (> 0) or leave it out")
        if r_plus <= 0.0:
            raise ModelError(_where(source, "path.R_plus"), f"must be positive, got {r_plus!r}", "give R+ in m (> 0) or leave it out")
    criterion, strategy = _singularity(data.get("singularity", {}), source)
    description = description_of(data, source)
    return CaptureScenario(
        source=source,
        model=model,
        end_effector=e,
        mass=mass,
        inertia=inertia,
        offset=offset,
        path=points,
        rule=str(rule),
        R_plus=r_plus,
        samples=int(samples),
        description=str(description),
        criterion=criterion,
        strategy=strategy,
    )


def _singularity(table: Any, source: str) -> tuple[SingularityCriterion, str]:
    """The [singularity] table: a SingularityCriterion and the planning strategy."""
    table = _check_keys(table, _SINGULARITY_KEYS, source, "singularity")
    choices = {"rows": ROWS, "measure": MEASURES, "strategy": STRATEGIES}
    for key, allowed in choices.items():
        if key in table and table[key] not in allowed:
            raise ModelError(_where(source, f"singularity.{key}"), f"unknown value {table[key]!r}", f"use one of {', '.join(allowed)}")
    threshold = 0.0
    if "threshold" in table:
        fix = "give threshold >= 0 in the measure's unit (m/rad for sigma_min of the position rows)"
        threshold = _number(table["threshold"], source, "singularity.threshold", fix)
        if threshold < 0.0:
            raise ModelError(_where(source, "singularity.threshold"), f"must be >= 0, got {threshold!r}", fix)
    criterion = SingularityCriterion(rows=table.get("rows", "auto"), measure=table.get("measure", "auto"), threshold=threshold)
    return criterion, str(table.get("strategy", "auto"))


def load_capture_scenario(
    path: str | Path, *, model_loader: Callable[[str], Model] | None = None, end_effectors: Any = None
) -> CaptureScenario:
    """Read and validate a capture scenario TOML file (schema in the module docstring); ``end_effectors`` replaces the
    scenario's (the command line's ``-e``)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: is not a file; give a scenario TOML file" if path.exists() else f"{path}: no such scenario file")
    data = read_toml(path, "scenario")
    return capture_scenario_from_dict(data, source=str(path), base_dir=path.parent, model_loader=model_loader, end_effectors=end_effectors)


@dataclass(frozen=True, eq=False)
class CaptureResult:
    """A capture scenario run: the §V plan and, for a planar two-link arm, the best posture on each eq. 21 family."""

    scenario: CaptureScenario
    plan: CapturePlan
    family_postures: tuple[CapturePosture | None, ...]

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready summary; lengths in m, angles in rad and deg (``_deg``)."""
        p, placement = self.plan, self.plan.placement
        piw = p.piw

        def posture(post: CapturePosture | None) -> dict[str, Any] | None:
            if post is None:
                return None
            return {
                "family": post.family,
                "q": post.q.tolist(),
                "q_deg": np.degrees(post.q).tolist(),
                "measure": post.measure,
                "det": post.det,
                "residual": post.residual,
                "attitude_xyzw": post.attitude.tolist(),
                "theta": post.theta,
                "theta_deg": None if post.theta is None else float(np.degrees(post.theta)),
            }

        return {
            "scenario": self.scenario.source,
            "model": self.scenario.model.name,
            "end_effector": p.end_effector,
            "robot_mass": self.scenario.model.total_mass,
            "payload_mass": self.scenario.mass,
            "piw": {"R_min": piw.R_min, "R_max": piw.R_max, "intervals": [list(iv) for iv in piw.piw], "pdw": [list(iv) for iv in piw.pdw]},
            "reachable_after": {"R_min": piw.reachable.R_min, "R_max": piw.reachable.R_max},
            "path": placement.path.tolist(),
            "rule": placement.rule,
            "interval": list(placement.interval),
            "margin": placement.margin,
            "R_plus": placement.R_plus,
            "cm_plus": placement.cm_plus.tolist(),
            "approach_distance": placement.approach_distance,
            "approach_point": None if placement.approach_point is None else placement.approach_point.tolist(),
            "posture": posture(p.posture),
            "family_postures": [posture(f) for f in self.family_postures],
            "method": p.method,
            "why_path": p.why_path,
            "end_effectors": list(p.before.end_effector_names),  # the model's, in J* row order
            "singularity": {**p.criterion.as_dict(), "described": p.criterion.describe(p.captured)},
            "motion": None if p.motion is None else _motion_dict(p.motion),
            # every check a plan must pass (plan_capture returns no plan that fails one)
            "checks": {
                # a PIW plan's path lies in the PIW (place_path); a path-checked plan is checked by its motion instead
                "path_in_workspace": bool(placement.margin >= 0.0) if p.method == "piw" else None,
                "motion_follows_path": None if p.motion is None else p.motion.follows_path,
                "singularity_free": None if p.motion is None else p.motion.singularity_free,
                "within_joint_limits": None if p.motion is None else p.motion.within_limits,
            },
        }

    def render_text(self) -> str:
        """What ``freefloat capture`` prints."""
        sc, p, placement = self.scenario, self.plan, self.plan.placement
        piw = p.piw
        length = float(np.sum(np.linalg.norm(np.diff(placement.path, axis=0), axis=1)))

        def vec(v: np.ndarray) -> str:
            return "[" + ", ".join(f"{x:.6f}" for x in v) + "]"

        widest = "none" if piw.R_min is None else f"[{piw.R_min:.6f}, {piw.R_max:.6f}]"
        lines = [
            f"capture scenario {sc.source or '(dict)'} (Papadopoulos 1992 §V)",
            f"  model              {sc.model.name} ({sc.model.total_mass:.6g} kg), grasping end effector {p.end_effector}",
            f"  payload            {sc.mass:.6g} kg, inertia diag {vec(np.diag(sc.inertia))} kg m², CM offset {vec(sc.offset)} m",
            f"  after capture      reachable [{piw.reachable.R_min:.6f}, {piw.reachable.R_max:.6f}] m; PIW {widest} m (widest)",
            f"  path               {placement.path.shape[0]} points, length {length:.6g} m, start A = {vec(placement.start)} m (inertial)",
            f"  placement          rule {placement.rule}: path inside [{placement.interval[0]:.6f}, {placement.interval[1]:.6f}] m, "
            f"margin {placement.margin:.6f} m",
            f"  R+                 {placement.R_plus:.6f} m (CM+ to A)",
            f"  CM+                {vec(placement.cm_plus)} m (inertial)",
        ]
        if placement.approach_distance is not None and placement.approach_point is not None:
            lines += [
                f"  approach distance  R = {placement.approach_distance:.6f} m (eq. 19: (M + m_p)/M R+)",
                f"  free-flyer CM      {vec(placement.approach_point)} m before capture (on the line A -> CM+)",
            ]
        if p.method == "path":
            lines.append(f"  plan               path checked ({p.why_path}): the free-floating motion along it from this posture")
            lines.append("                     and attitude was integrated (1992 eqs. 12, 14): singularity-free, within the joint limits")
        if p.motion is not None:
            m = p.motion
            lines.append(f"  singularity        {m.criterion}")
            lines.append(
                f"  along the path     min |measure| {m.min_measure:.6g} over {m.s.size} points (threshold {m.threshold:g}), "
                f"max deviation {m.deviation:.2e} m: {'singularity-free' if m.singularity_free else 'MEETS A SINGULARITY'}"
            )
            margin = "no limits" if not np.isfinite(m.limit_margin) else f"closest approach {m.limit_margin:.4g}"
            lines.append(f"  joint limits       {'kept' if m.within_limits else 'CROSSED'} along the path ({margin})")
        if p.method == "path":
            lines.append("  capture posture    the most dexterous checked posture on |r_E| = R+ within the joint limits:")
        else:
            lines.append("  capture posture    max |det J*| subject to |r_E| = R+ (eq. 21) and the joint limits:")
        chosen = p.posture
        measure_name = {"sigma_min": "σ_min of J*", "det": "|det J*|"}.get(p.criterion.measure, "sqrt det J*J*ᵀ")
        shown = [f for f in self.family_postures if f is not None] or [chosen]
        for post in shown:
            fam = "" if post.family is None else f"family {post.family + 1} ({'+' if post.family == 0 else '-'}acos)  "
            det = f"det J* = {post.det:+.6f}" if post.det is not None else f"{measure_name} = {post.measure:.6f}"
            theta = "" if post.theta is None else f", θ = {np.degrees(post.theta):.2f} deg"
            mark = "  <- chosen" if len(shown) > 1 and np.allclose(post.q, chosen.q, atol=1e-6) else ""
            lines.append(f"    {fam}q = [{', '.join(f'{v:.2f}' for v in np.degrees(post.q))}] deg, {det}{theta}{mark}")
        quat = ", ".join(f"{v:.6f}" for v in chosen.attitude)
        theta = "" if chosen.theta is None else f"θ = {np.degrees(chosen.theta):.2f} deg, "
        lines.append(f"  spacecraft         {theta}attitude quaternion [x, y, z, w] = [{quat}] (eq. 20: end effector on A)")
        return "\n".join(lines) + "\n"


def _motion_dict(motion: PathMotion) -> dict[str, Any]:
    return {
        "points": int(motion.s.size),
        "min_measure": motion.min_measure,
        "threshold": motion.threshold,
        "max_deviation": motion.deviation,
        "singularity_free": motion.singularity_free,
        "within_joint_limits": motion.within_limits,
        "joint_limit_margin": motion.limit_margin if np.isfinite(motion.limit_margin) else None,
        "q_end": motion.q[-1].tolist(),
        "attitude_end_xyzw": motion.attitude[-1].tolist(),
    }


def run_capture_scenario(scenario: CaptureScenario) -> CaptureResult:
    """Run 1992 §V for a scenario. Raises :class:`~freefloat.analysis.capture.PathDoesNotFitError` when the path fits nowhere."""
    plan = plan_capture(
        scenario.model,
        scenario.end_effector,
        scenario.path,
        mass=scenario.mass,
        inertia=scenario.inertia,
        offset=tuple(scenario.offset),
        rule=scenario.rule,
        R_plus=scenario.R_plus,
        samples=scenario.samples,
        criterion=scenario.criterion,
        strategy=scenario.strategy,
    )
    families: tuple[CapturePosture | None, ...] = ()
    if _is_two_link(plan.captured) and plan.method == "piw":
        found: list[CapturePosture | None] = []
        for k in (0, 1):
            try:
                found.append(
                    optimal_capture_posture(
                        plan.captured, scenario.end_effector, plan.placement.R_plus, direction=plan.placement.direction, family=k
                    )
                )
            except ValueError:  # no posture on this family within the joint limits
                found.append(None)
        families = tuple(found)
    return CaptureResult(scenario=scenario, plan=plan, family_postures=families)


def write_capture_outputs(result: CaptureResult, out: Path, *, dpi: int = 200) -> list[Path]:
    """``capture.json``, ``capture_plan.png`` (like the paper's Fig. 7) and, for a two-link arm, ``capture_families.png`` (Fig. 6)."""
    from matplotlib.figure import Figure

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    path = out / "capture.json"
    path.write_text(json.dumps(result.as_dict(), indent=2, allow_nan=False) + "\n")
    written.append(path)
    fig = Figure(figsize=(7.4, 8.4), layout="constrained")
    ax = fig.add_subplot(projection=None if result.plan.captured.is_planar else "3d")
    plot_capture_plan(result.plan, ax)
    path = out / "capture_plan.png"
    fig.savefig(path, dpi=dpi, bbox_inches="tight", pad_inches=0.15)
    written.append(path)
    if result.family_postures:
        fig = Figure(figsize=(7.0, 4.6), layout="constrained")
        ax = fig.add_subplot()
        plot_capture_families(result.plan, ax)
        path = out / "capture_families.png"
        fig.savefig(path, dpi=dpi, bbox_inches="tight", pad_inches=0.15)
        written.append(path)
    return written


def plot_capture_plan(plan: CapturePlan, ax: Any) -> None:
    """The §V plan like the paper's Fig. 7 (:meth:`CapturePlan.plot`), with a legend, labels in m and a title.

    ``ax``: 2D axes, or 3D axes (``projection="3d"``) for a spatial model."""
    plan.plot(ax)
    placement = plan.placement
    handles, labels = ax.get_legend_handles_labels()
    ax.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, -0.08), ncols=2, fontsize="small", frameon=False)
    r = "" if placement.approach_distance is None else f", approach distance R = {placement.approach_distance:.3f} m"
    how = "" if plan.method == "piw" else "; path checked free-floating"
    measure = "" if plan.motion is None else f"\nmin |measure| along the path {plan.motion.min_measure:.3g} ({plan.motion.criterion})"
    ax.set_title(f"Capture at A: R+ = {placement.R_plus:.3f} m{r}{how}{measure}\n(1992 §V, eqs. 19-21)", fontsize="medium")


def plot_capture_families(plan: CapturePlan, ax: Any, *, marks: dict[str, float] | None = None) -> None:
    """q2(q1) of both eq. 21 families and det J* along them (the paper's Fig. 6), with the optimum marked.

    ``marks``: extra vertical lines, label -> q1 in degrees (e.g. the paper's printed optimum).
    """
    q1 = np.linspace(-np.pi, np.pi, 1441)
    fam = capture_families(plan.captured, plan.end_effector, plan.placement.R_plus, q1)
    artists = fam.plot(ax)
    twin: Any = artists[1].axes  # fam.plot draws det J* on a twin y axis
    assert twin is not None
    best = plan.posture
    k = 0 if best.family is None else best.family
    twin.plot(
        np.degrees(best.q[0]),
        fam.det[np.argmin(np.abs(q1 - best.q[0])), k],
        "k*",
        ms=12,
        label=f"optimum q1 = {np.degrees(best.q[0]):.1f}°",
    )
    handles = [*artists, *twin.get_lines()[-1:]]
    for n, (label, value) in enumerate((marks or {}).items()):
        handles.append(ax.axvline(value, color="0.4", ls=":" if n == 0 else "-.", lw=1.2, label=label))
    ax.set_xlim(-180.0, 180.0)
    ax.set_xticks(np.arange(-180.0, 181.0, 45.0))
    ax.legend(handles=handles, loc="center", fontsize="x-small", ncols=3, framealpha=0.9)
    twin.set_ylabel("det J* (m²)")
    ax.set_title(f"Eq. 21 at R+ = {plan.placement.R_plus:.3f} m: the two families q2(q1) and det J* (1992 Fig. 6)", fontsize="medium")
