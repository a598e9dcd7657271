"""Capture scenarios (1992 §V) from TOML files: what ``freefloat capture SCENARIO.toml`` reads and runs (what it
reports and writes: :mod:`.capture_outputs`).

A scenario names the robot, the payload (and, for a moving target, its motion at the grasp) and the payload's
desired path; the run is :func:`freefloat.analysis.capture.plan_capture` (post-capture PIW, path placement,
approach distance of eq. 19, capture posture and spacecraft orientation of eqs. 20-21; for a moving target the
impact at the grasp and the candidate postures ranked), plus the best posture on each family of eq. 21 for a
planar two-link arm. Schema (docs/workspaces.md, docs/impact.md)::

    model = "papadopoulos1992-one-arm"   # built-in name, or a model file (path relative to the scenario)
    # end_effectors = ["left", "right"]  # optional, model files only: the model's end effectors (default: the file's, else every leaf)
    # strict = true                      # optional, model files only: refuse non-physical inertias instead of correcting them
    end_effector = "arm1_ee"             # optional: grasping end effector, name or index (default 0)
    samples = 262144                     # optional: configurations sampled for the PIW

    [payload]
    mass = 400.0                         # kg, > 0
    inertia = 25.0                       # kg m² about the payload CM: I (Izz of a planar model), [Ixx, Iyy, Izz] or 3x3
    offset = [0.0, 0.0, 0.0]             # optional: payload CM from the end-effector point, grasping body frame, m
    # velocity = [0.0, 0.02, 0.0]        # optional, a moving target: its CM velocity at the grasp, inertial frame, m/s
    # angular_velocity = [0.0, 0.0, 0.1] # optional, a moving target: its angular velocity, inertial frame, rad/s

    [path]
    points = [[0.0, 0.0], [0.0, 0.25]]   # polyline, inertial frame, m: A = points[0] (2D or 3D)
    rule = "perpendicular"               # optional: "perpendicular" (the paper's) or "max_margin"
    # R_plus = 0.54                      # optional: impose R+ (m) instead of choosing it

    [singularity]                        # optional: what counts as a dynamic singularity (PIW, posture, path check)
    rows = "position"                    # "position" (translational rows of J*), "full" or "auto" (the paper's; default)
    measure = "sigma_min"                # "sigma_min", "manipulability", "det" or "auto" (default)
    threshold = 0.02                     # singular where |measure| <= threshold (default 0)
    strategy = "auto"                    # "auto" (PIW, else a path-checked plan), "piw" (the paper's) or "path"

    # [grasp]                            # optional, a moving target only (payload velocity / angular_velocity given)
    # joints = "free"                    # "free" or "locked" during the grasp (ff.capture.impact)
    # time = 0.0                         # s, with [detumble]: the grasp time of the sequence (the target moves on its
                                         # own until then, to be where the plan grasps it at that time)
    # rank_by = "spacecraft_rate"        # "measure" (1992 §V; default), "spacecraft_rate", "impulse", "angular_impulse",
                                         # "joint_impulse" (locked joints): the posture with the smallest value

    # [detumble]                         # optional, a moving target only: the capture sequence (.capture_sequence)
    # rate_gain = 0.5                    # 1/s: ff.control.Detumble's, every rate decays as exp(-k t)
    # duration = 20.0                    # s of detumbling after the grasp (at [grasp] time, default t = 0)
    # sample_period = 0.05               # s, the controller's samples and the outputs
    # specific_impulse = 220.0           # optional, s: the propellant mass
    # rest_rate = 1e-3                   # rad/s; rest_joint_rate (rad/s), rest_velocity (m/s): what counts as at rest
    # attitude = [0.0, 0.0, 0.0, 1.0]    # optional: a commanded spacecraft attitude [x, y, z, w]
    # force = true                       # false: thruster torque only
    # torque_by = "wheels"               # the spacecraft torque by the reaction wheels ([[wheels]]), not the thrusters
    # frames = 40                        # frames of the animation

    [[wheels]]                           # optional: the spacecraft's reaction wheels (docs/wheels.md), or
    # name = "rw_z"                      # wheels = "FILE.toml", a side file of [[wheels]] tables
    # axis = [0.0, 0.0, 1.0]             # spin axis, spacecraft frame (Basilisk gsHat_B)
    # inertia = 0.3                      # kg m² about it (Js); max_torque (N m), max_speed (rad/s), viscous, coulomb

    [joint_limits]                       # optional, rad: joint name = [lower, upper]
    # arm1_q1 = [-2.5, 2.5]
    [joint_limits_deg]                   # optional, the same in degrees
    # arm1_q2 = [-150.0, 150.0]

Every error names the field and the fix (:class:`~freefloat.ModelError`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..analysis._capture_families import _is_two_link
from ..analysis._capture_ranking import check_twist, grasp_problem
from ..analysis.capture import STRATEGIES, CapturePosture, optimal_capture_posture
from ..analysis.singularity import MEASURES, ROWS, SingularityCriterion
from ..core.errors import ModelError, UnknownNameError
from ..core.model import MAX_LENGTH, Model, inertia_matrix
from ..io.model_files import read_toml
from ..mechanics.impact import GRASP_REACH
from ..simulation import RunEstimate
from ._plan_memo import fixed_plan
from .capture_outputs import CaptureResult, plot_capture_families, plot_capture_plan, write_capture_outputs
from .capture_sequence import run_capture_sequence
from .capture_settings import DetumbleSettings, check_sequence_estimate, detumble_settings, estimate_sequence
from .scenario import description_of, refuse_model_file, scenario_model, scenario_wheels

__all__ = [
    "CaptureResult",
    "CaptureScenario",
    "capture_scenario_from_dict",
    "estimate_capture_sequence",
    "load_capture_scenario",
    "plot_capture_families",
    "plot_capture_plan",
    "run_capture_scenario",
    "write_capture_outputs",
]

_TOP_KEYS = {
    "model", "end_effectors", "strict", "end_effector", "samples", "payload", "path", "singularity", "joint_limits", "joint_limits_deg",
    "description", "grasp", "detumble", "wheels",
}  # fmt: skip
_SINGULARITY_KEYS = {"rows", "measure", "threshold", "strategy"}
_PAYLOAD_KEYS = {"mass", "inertia", "offset", "velocity", "angular_velocity"}
_PATH_KEYS = {"points", "rule", "R_plus"}
_GRASP_KEYS = {"joints", "rank_by", "time"}
_DETUMBLE_KEYS = {f.name for f in dataclasses.fields(DetumbleSettings)}


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
    velocity: np.ndarray | None = None
    angular_velocity: np.ndarray | None = None
    joints: str | None = None
    rank_by: str = "measure"
    detumble: DetumbleSettings | None = None
    grasp_time: float = 0.0  # s: the grasp of the capture sequence ([grasp] time)


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
        loaded = scenario_wheels(model_loader(data["model"]), data, source, base_dir)
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
    if np.abs(offset).max() > MAX_LENGTH:
        too_far = f"{np.abs(offset).max():g} m is beyond the {MAX_LENGTH:g} m freefloat accepts for a position (a unit slip?)"
        raise ModelError(_where(source, "payload.offset"), too_far, offset_fix)
    gyration = float(np.sqrt(np.linalg.eigvalsh(inertia)[-1] / mass))  # m, the payload's largest radius of gyration
    if np.linalg.norm(offset) > GRASP_REACH * gyration:  # the hand would not be on the payload (ff.capture.impact's rule)
        raise ModelError(
            _where(source, "payload.offset"),
            f"puts the payload's CM {np.linalg.norm(offset):.6g} m from the hand, beyond {GRASP_REACH:g} of its radii of "
            f"gyration ({GRASP_REACH:g} x {gyration:.3g} m): the hand is not on the payload",
            "give the CM's offset from the grasp point in m (grasping body frame), or check payload.inertia and mass",
        )
    velocity = _twist(payload, "velocity", source)
    angular_velocity = _twist(payload, "angular_velocity", source)
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
    grasp = _check_keys(data.get("grasp", {}), _GRASP_KEYS, source, "grasp")
    broken = grasp_problem(velocity is not None or angular_velocity is not None, grasp.get("joints"), grasp.get("rank_by", "measure"))
    if broken is not None:
        raise ModelError(_where(source, f"grasp.{broken[0]}"), broken[1], broken[2])
    detumble = None
    if "detumble" in data:
        if velocity is None and angular_velocity is None:
            fix = "give the target's motion ([payload] velocity or angular_velocity) or drop [detumble]"
            raise ModelError(_where(source, "detumble"), "needs a moving target", fix)
        detumble = detumble_settings(_check_keys(data["detumble"], _DETUMBLE_KEYS, source, "detumble"), source)
        if detumble.torque_by == "wheels" and not model.wheels:
            fix = 'declare the spacecraft\'s [[wheels]] in the scenario or its model file (docs/wheels.md), or use "thrusters"'
            raise ModelError(_where(source, "detumble.torque_by"), f"'wheels', but {model.name!r} has no reaction wheels", fix)
    grasp_time = 0.0
    if "time" in grasp:
        fix = "give the grasp time of the capture sequence in s (>= 0), or leave it out (t = 0)"
        grasp_time = _number(grasp["time"], source, "grasp.time", fix)
        if grasp_time < 0.0:
            raise ModelError(_where(source, "grasp.time"), f"must be >= 0, got {grasp['time']!r}", fix)
        if detumble is None and grasp_time != 0.0:  # the default, 0, says nothing
            fix = "add a [detumble] table (the capture sequence simulates the time before the grasp) or drop grasp.time"
            raise ModelError(_where(source, "grasp.time"), "is the grasp time of the capture sequence, and there is none", fix)
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
        velocity=velocity,
        angular_velocity=angular_velocity,
        joints=grasp.get("joints"),
        rank_by=str(grasp.get("rank_by", "measure")),
        detumble=detumble,
        grasp_time=grasp_time,
    )


def _twist(payload: dict[str, Any], key: str, source: str) -> np.ndarray | None:
    """``payload.velocity`` (m/s) or ``payload.angular_velocity`` (rad/s): the target's motion at the grasp, inertial frame."""
    if key not in payload:
        return None
    unit = "m/s" if key == "velocity" else "rad/s"
    fix = f"give {key} = [x, y, z] in {unit}, inertial frame, or leave it out (a payload at rest)"
    raw = payload[key]
    if not isinstance(raw, list) or len(raw) != 3:
        raise ModelError(_where(source, f"payload.{key}"), f"expected [x, y, z], got {raw!r}", fix)
    return check_twist([_number(v, source, f"payload.{key}", fix) for v in raw], _where(source, f"payload.{key}"), key)


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


def estimate_capture_sequence(scenario: CaptureScenario) -> RunEstimate | None:
    """Steps, samples, outputs, memory and wall time of the scenario's capture sequence (None without [detumble]):
    :func:`freefloat.simulation.estimate_run`, as ``freefloat simulate`` estimates its runs."""
    if scenario.detumble is None:
        return None
    return estimate_sequence(scenario.model, scenario.detumble, scenario.grasp_time)


def run_capture_scenario(scenario: CaptureScenario, *, warn_after: float | None = 60.0) -> CaptureResult:
    """Run 1992 §V for a scenario. Raises :class:`~freefloat.analysis.capture.PathDoesNotFitError` when the path fits nowhere.

    The capture sequence ([detumble]) is estimated first, before the plan (:func:`estimate_capture_sequence`): one
    whose recorded states would not fit in memory raises :class:`~freefloat.MemoryBudgetError`, and one estimated
    to take over ``warn_after`` seconds (None: never) warns :class:`~freefloat.core.errors.LongRunWarning`, as ``ff.simulate`` does.
    The robot's plan is computed once per distinct robot and path in a process (:mod:`._plan_memo`): a run with only
    the target's motion, the grasp time or the detumbling changed reuses it."""
    estimate = estimate_capture_sequence(scenario)
    if estimate is not None:
        check_sequence_estimate(estimate, warn_after)
    plan = fixed_plan(scenario).moving(scenario.velocity, scenario.angular_velocity, joints=scenario.joints, rank_by=scenario.rank_by)
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
    sequence = None if scenario.detumble is None else run_capture_sequence(plan, scenario.detumble, scenario.grasp_time)
    return CaptureResult(scenario=scenario, plan=plan, family_postures=families, sequence=sequence)
