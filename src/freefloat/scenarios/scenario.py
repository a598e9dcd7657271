"""Simulation scenarios from TOML files: what ``freefloat simulate SCENARIO.toml --out DIR`` reads, runs and writes.

A scenario names the robot, its initial state, how long to simulate, the
integrator, and either an open-loop actuation profile or a built-in
controller. Schema (docs/simulation.md)::

    description = "..."                    # optional
    model = "papadopoulos1992"             # built-in name, or a model file (path relative to the scenario)
    # end_effectors = ["tool0"]            # optional, model files only: the end effectors (default: the file's, else every leaf)
    # strict = true                        # optional, model files only: refuse non-physical inertias instead of correcting them
    duration = 10.0                        # s, > 0
    # passive = "model"                    # the joints' damping and friction: "model" (as the model file gives them) or "ignore"

    [initial]                              # optional; omitted fields are zero / identity
    q = [0.1, 0.2, 0.3, 0.4]               # rad, model.joint_names order (or a table: joint name = value)
    # q_deg = [...]                        # the same in degrees (one of q / q_deg)
    qdot = [0.0, 0.0, 0.0, 0.0]            # rad/s (or qdot_deg)
    omega = [0.0, 0.0, 0.0]                # rad/s, spacecraft frame (or omega_deg)
    attitude = [0.0, 0.0, 0.0, 1.0]        # quaternion [x, y, z, w], spacecraft -> inertial
    # euler321_deg = [roll, pitch, yaw]    # or the attitude as 1991 eq. 11 Euler angles, degrees
    r_cm = [0.0, 0.0, 0.0]                 # m, inertial frame (each component within 1e12 m)
    v_cm = [0.0, 0.0, 0.0]                 # m/s, inertial frame (within 1e8 m/s)

    [integrator]                           # optional
    method = "DOP853"                      # an adaptive scipy method, or "RK4" (then fixed_step is required)
    rtol = 1e-10                           # adaptive only; in [2.2e-14, 1)
    atol = 1e-10                           # in (0, 1)
    # fixed_step = 0.001                   # s, RK4 only
    output_period = 0.01                   # s between recorded states
    # sample_period = 0.01                 # s, zero-order hold of the actuation
    # max_wall_time = 600.0                # s of computing, then the run stops with what it computed (default: no limit)

    [actuation]                            # open loop, one of: constant, piecewise, sinusoid
    type = "sinusoid"
    amplitude = [1.0, 0.5, 1.0, 0.5]       # N m  (sinusoid: offset + amplitude sin(2 pi f t + phase))
    frequency = [0.1, 0.2, 0.1, 0.2]       # Hz, within 1e6 Hz
    phase = [0.0, 0.0, 0.0, 0.0]           # rad (optional)
    offset = [0.0, 0.0, 0.0, 0.0]          # N m (optional)
    # constant:  joint_torque = [...]
    # piecewise: times = [0.0, 2.0, 4.0] and joint_torque = [[...], [...], [...]] (each row held until the next time)
    # every type: spacecraft_force = [...] (N), spacecraft_torque = [...] (N m), constant, spacecraft frame
    # torques and forces within 1e19 N m (N)

    # [controller]                         # instead of [actuation]: a built-in controller
    # type = "joint_pd"                    # tau = kp (q_ref - q) + kd (qdot_ref - qdot)
    # kp = 50.0                            # N m/rad: a number or one per joint
    # kd = 20.0                            # N m s/rad
    # q_ref = [...]                        # rad (or q_ref_deg), qdot_ref (rad/s) optional

    [limits]                               # optional actuator saturation (symmetric)
    joint_torque = 10.0                    # N m: a number or one per joint
    # spacecraft_force, spacecraft_torque

    [joint_limits]                         # optional: the model's joint limits in the simulation
    mode = "stop"                          # "stop": hard stops (momentum-conserving impulses); "flag": no stops, violations recorded
    restitution = 0.0                      # rate after an impact = -restitution x rate before

    [outputs]                              # optional
    name = "trajectory"                    # file stem: NAME.npz, NAME.csv, NAME.png, NAME_momentum.png
    npz = true
    csv = true
    plots = true

Every error names the field and the fix (:class:`~freefloat.ModelError`). Finite values that no space
robot has are refused with the bound they pass (:mod:`freefloat.core.numbers`): an initial position or
speed of the CM beyond 1e12 m or 1e8 m/s, rates beyond 1e4 rad/s, torques and forces beyond 1e19 N m
(or N), a sinusoid faster than 1e6 Hz or with a phase beyond 1e6 rad, tolerances outside the ranges above.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from ..core.errors import ModelError
from ..core.model import Model
from ..core.numbers import MAX_EFFORT, MAX_FREQUENCY, MAX_JOINT_VALUE, MAX_RATE, real_array, tolerance_problem
from ..core.state import Actuation, ActuatorLimits, State
from ..io.model_files import load, read_toml, with_wheels
from ..models import load_model
from ..simulation import RunEstimate, estimate_run
from ..simulation.pd import JointPD
from ..simulation.simulate import METHODS, PASSIVE, simulate
from ..simulation.trajectory import Trajectory

__all__ = [
    "ACTUATION_TYPES",
    "CONTROLLER_TYPES",
    "Scenario",
    "estimate_scenario",
    "load_scenario",
    "run_scenario",
    "scenario_from_dict",
]

#: Open-loop actuation profiles of ``[actuation] type``.
ACTUATION_TYPES = ("constant", "piecewise", "sinusoid")
#: Built-in controllers of ``[controller] type``.
CONTROLLER_TYPES = ("joint_pd",)

_TOP_KEYS = {
    "description", "model", "end_effectors", "strict", "duration", "initial", "integrator", "actuation", "controller", "limits",
    "joint_limits", "passive", "outputs", "wheels",
}  # fmt: skip
_JOINT_LIMIT_KEYS = {"mode", "restitution"}
_INITIAL_KEYS = {"q", "q_deg", "qdot", "qdot_deg", "omega", "omega_deg", "attitude", "euler321_deg", "r_cm", "v_cm", "wheel_speed"}
_INTEGRATOR_KEYS = {"method", "rtol", "atol", "fixed_step", "output_period", "sample_period", "max_wall_time"}
_ACTUATION_KEYS = {
    "constant": {"type", "joint_torque", "spacecraft_force", "spacecraft_torque"},
    "piecewise": {"type", "times", "joint_torque", "spacecraft_force", "spacecraft_torque"},
    "sinusoid": {"type", "amplitude", "frequency", "phase", "offset", "spacecraft_force", "spacecraft_torque"},
}
_CONTROLLER_KEYS = {"joint_pd": {"type", "kp", "kd", "q_ref", "q_ref_deg", "qdot_ref"}}
_LIMIT_KEYS = {"joint_torque", "spacecraft_force", "spacecraft_torque"}
_OUTPUT_KEYS = {"name", "npz", "csv", "plots"}


@dataclass(frozen=True, eq=False)
class Scenario:
    """A validated simulation scenario: everything :func:`freefloat.simulate` needs.

    ``controller`` is the callable ``(t, state) -> joint torques or Actuation``
    built from ``[actuation]`` or ``[controller]`` (None: free-floating).
    ``options`` are the keyword arguments passed to :func:`freefloat.simulate`.
    """

    source: str
    model: Model
    initial_state: State
    duration: float
    controller: Callable[[float, State], Any] | None
    options: dict[str, Any] = field(default_factory=dict)
    description: str = ""
    output_name: str = "trajectory"
    write_npz: bool = True
    write_csv: bool = True
    write_plots: bool = True
    input_files: tuple[Path, ...] = ()


# --------------------------------------------------------------------- field readers
def _where(source: str, name: str) -> str:
    return f"{source}: {name}" if source else name


def _table(value: Any, allowed: set[str], source: str, name: str) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise ModelError(_where(source, name), f"expected a table, got {value!r}", f"write [{name}] with keys {', '.join(sorted(allowed))}")
    unknown = sorted(set(value) - allowed)
    if unknown:
        key = f"{name}.{unknown[0]}" if name else unknown[0]
        raise ModelError(_where(source, key), "unknown key", f"use one of {', '.join(sorted(allowed))}")
    return value


def _number(value: Any, source: str, name: str, fix: str, *, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ModelError(_where(source, name), f"expected a number, got {value!r}", fix)
    out = float(value)
    if not np.isfinite(out):
        raise ModelError(_where(source, name), f"must be finite, got {value!r}", fix)
    if positive and out <= 0:
        raise ModelError(_where(source, name), f"must be positive, got {value!r}", fix)
    return out


def _array(value: Any, shape: tuple[int, ...], source: str, name: str, fix: str) -> np.ndarray:
    """A finite float array of exactly ``shape`` (-1: any length >= 1)."""
    try:
        arr = real_array(value, name)  # booleans, text and tables are not numbers
    except TypeError:
        raise ModelError(_where(source, name), f"expected numbers, got {value!r}", fix) from None
    if arr.ndim != len(shape) or any(s not in (-1, a) for s, a in zip(shape, arr.shape, strict=True)):
        want = "(" + ", ".join("n" if s == -1 else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"
        raise ModelError(_where(source, name), f"expected shape {want}, got {arr.shape} from {value!r}", fix)
    if not np.all(np.isfinite(arr)):
        raise ModelError(_where(source, name), "has NaN or infinite entries", fix)
    return arr


def _per_joint(value: Any, model: Model, source: str, name: str, unit: str, *, scalar_ok: bool = False) -> np.ndarray:
    """One value per joint: a list in joint order, a table by joint name, or (``scalar_ok``) one number for all."""
    n = model.n_joints
    joints = ", ".join(model.joint_names) or "none"
    fix = f"give {n} values ({unit}) in the order {joints}" + (", or one number for all" if scalar_ok else "")
    if isinstance(value, dict):
        out = np.zeros(n)
        for key, item in value.items():
            if key not in model.joint_names:
                raise ModelError(_where(source, f"{name}.{key}"), f"unknown joint of {model.name!r}", f"use one of {joints}")
            out[model.joint_names.index(key)] = _number(item, source, f"{name}.{key}", f"give a number ({unit})")
        return out
    if scalar_ok and isinstance(value, (int, float)) and not isinstance(value, bool):
        return np.full(n, _number(value, source, name, fix))
    return _array(value, (n,), source, name, fix)


def _built(make: Callable[[], Any], source: str, table: str) -> Any:
    """``make()`` (a State, a JointPD); its ValueError or TypeError (a joint angle beyond reach) a ModelError naming the table."""
    try:
        return make()
    except (TypeError, ValueError) as exc:
        raise ModelError(_where(source, table), str(exc), f"fix the [{table}] table") from None


def _one_of(table: dict[str, Any], names: tuple[str, str], source: str, where: str) -> tuple[str, Any] | None:
    given = [k for k in names if k in table]
    if len(given) > 1:
        raise ModelError(_where(source, f"{where}.{given[1]}"), f"given together with {where}.{given[0]}", "keep only one of them")
    return (given[0], table[given[0]]) if given else None


def _rate(rates: np.ndarray, source: str, name: str) -> None:
    """Initial rates beyond :data:`~freefloat.core.numbers.MAX_RATE` are refused when the scenario is read, before the run."""
    fastest = float(np.max(np.abs(rates), initial=0.0))
    if fastest > MAX_RATE:
        raise ModelError(
            _where(source, name),
            f"{fastest:.3g} rad/s (or m/s) is beyond {MAX_RATE:g}, which no joint or spacecraft of a space robot reaches",
            "check the units (rad/s, or deg/s with the _deg key) and the size",
        )


def _bounded(arr: np.ndarray, source: str, name: str, limit: float, unit: str, why: str, fix: str) -> np.ndarray:
    """``arr`` if no entry's magnitude exceeds ``limit``; else a ModelError that names the field, the largest entry and the bound."""
    largest = float(np.max(np.abs(arr), initial=0.0))
    if largest > limit:
        raise ModelError(_where(source, name), f"{largest:.3g} {unit} is beyond {limit:g} {unit}, {why}", fix)
    return arr


def _effort(arr: np.ndarray, source: str, name: str, unit: str) -> np.ndarray:
    """Torques (N m) or forces (N) up to :data:`~freefloat.core.numbers.MAX_EFFORT`."""
    why = "which would spin the largest inertia a model may have (1e15 kg m^2) past 1e4 rad/s within a second"
    return _bounded(arr, source, name, MAX_EFFORT, unit, why, f"check the units ({unit}) and the size")


# --------------------------------------------------------------------- sections
def _initial_state(data: Any, model: Model, source: str) -> State:
    table = _table(data, _INITIAL_KEYS, source, "initial")
    fields: dict[str, Any] = {}
    for base, unit in (("q", "rad"), ("qdot", "rad/s")):
        pick = _one_of(table, (base, f"{base}_deg"), source, "initial")
        if pick is not None:
            key, value = pick
            arr = _per_joint(value, model, source, f"initial.{key}", "deg" if key.endswith("_deg") else unit)
            fields[base] = np.radians(arr) if key.endswith("_deg") else arr
            if base == "qdot":
                _rate(fields[base], source, f"initial.{key}")
    pick = _one_of(table, ("omega", "omega_deg"), source, "initial")
    if pick is not None:
        key, value = pick
        arr = _array(value, (3,), source, f"initial.{key}", "give [wx, wy, wz], spacecraft frame")
        fields["omega"] = np.radians(arr) if key == "omega_deg" else arr
        _rate(fields["omega"], source, f"initial.{key}")
    pick = _one_of(table, ("attitude", "euler321_deg"), source, "initial")
    if pick is not None:
        key, value = pick
        if key == "attitude":
            quat = _array(value, (4,), source, "initial.attitude", "give a unit quaternion [x, y, z, w] (scalar last)")
            if abs(np.linalg.norm(quat) - 1.0) > 1e-6:
                raise ModelError(
                    _where(source, "initial.attitude"),
                    f"quaternion norm {np.linalg.norm(quat):.6g} is not 1",
                    "give a unit quaternion [x, y, z, w] (scalar last), or euler321_deg = [roll, pitch, yaw]",
                )
            fields["attitude"] = quat
        else:
            angles = _array(value, (3,), source, "initial.euler321_deg", "give [roll, pitch, yaw] in degrees (1991 eq. 11)")
            fields["attitude"] = Rotation.from_euler("ZYX", angles[::-1], degrees=True)
    for key, what in (("r_cm", "m, inertial frame"), ("v_cm", "m/s, inertial frame")):
        if key in table:
            fields[key] = _array(table[key], (3,), source, f"initial.{key}", f"give [x, y, z] ({what})")
    if "wheel_speed" in table:
        names = ", ".join(w.name for w in model.wheels) or f"none: {model.name!r} has no [[wheels]]"
        fix = f"give one speed per reaction wheel in rad/s, relative to the spacecraft ({names})"
        fields["wheel_speed"] = _array(table["wheel_speed"], (model.n_wheels,), source, "initial.wheel_speed", fix)
    return _built(lambda: State(**fields), source, "initial")


def _integrator(data: Any, source: str, duration: float) -> dict[str, Any]:
    table = _table(data, _INTEGRATOR_KEYS, source, "integrator")
    method = table.get("method", "DOP853")
    choices = (*METHODS, "RK4")
    if method not in choices:
        raise ModelError(_where(source, "integrator.method"), f"unknown integrator {method!r}", f"choose one of {', '.join(choices)}")
    options: dict[str, Any] = {}
    for key in ("rtol", "atol", "fixed_step", "output_period", "sample_period", "max_wall_time"):
        if key in table:
            options[key] = _number(table[key], source, f"integrator.{key}", "give a positive number", positive=True)
            problem = tolerance_problem(key, options[key]) if key in ("rtol", "atol") else None
            if problem is not None:
                raise ModelError(_where(source, f"integrator.{key}"), *problem)
    if method == "RK4":
        if "fixed_step" not in options:
            raise ModelError(_where(source, "integrator.fixed_step"), "missing: RK4 needs a step", "give fixed_step (s), e.g. 0.001")
        for key in ("rtol", "atol"):
            if key in options:
                raise ModelError(
                    _where(source, f"integrator.{key}"),
                    "only used by the adaptive methods",
                    f"remove it, or choose method = {METHODS[0]!r}",
                )
        steps = duration / options["fixed_step"]
        if round(steps) < 1 or abs(steps - round(steps)) > 1e-9 * max(1.0, steps):
            raise ModelError(
                _where(source, "integrator.fixed_step"),
                f"{options['fixed_step']} s does not divide duration {duration} s",
                "choose a step that does",
            )
    else:
        if "fixed_step" in table:
            raise ModelError(
                _where(source, "integrator.fixed_step"), f"only used by RK4, not {method}", 'set method = "RK4" or remove fixed_step'
            )
        options["method"] = method
    return options


def _thrusters(table: dict[str, Any], source: str, where: str) -> tuple[np.ndarray | None, np.ndarray | None]:
    out = []
    for key, unit in (("spacecraft_force", "N"), ("spacecraft_torque", "N m")):
        name = f"{where}.{key}"
        out.append(
            _effort(_array(table[key], (3,), source, name, f"give [x, y, z] ({unit}, spacecraft frame)"), source, name, unit)
            if key in table
            else None
        )
    return out[0], out[1]


@dataclass(frozen=True)
class _OpenLoop:
    """Open-loop actuation ``(t, state) -> Actuation``: joint torques from a profile, constant thrusters."""

    kind: str
    params: dict[str, np.ndarray]
    spacecraft_force: np.ndarray | None = None
    spacecraft_torque: np.ndarray | None = None

    def joint_torque(self, t: float) -> np.ndarray:
        p = self.params
        if self.kind == "constant":
            return p["joint_torque"].copy()
        if self.kind == "piecewise":
            k = int(np.searchsorted(p["times"], t, side="right")) - 1
            return p["joint_torque"][max(k, 0)].copy()
        return np.asarray(p["offset"] + p["amplitude"] * np.sin(2.0 * np.pi * p["frequency"] * t + p["phase"]))

    def __call__(self, t: float, state: State) -> Any:
        return Actuation(
            joint_torque=self.joint_torque(t), spacecraft_force=self.spacecraft_force, spacecraft_torque=self.spacecraft_torque
        )


def _table_type(data: Any, source: str, name: str, types: tuple[str, ...]) -> str:
    """The ``type`` of the table [``name``] (an actuation or a controller), which must be one of ``types``."""
    if not isinstance(data, dict):
        raise ModelError(_where(source, name), f"expected a table, got {data!r}", f"write [{name}] with type = one of {', '.join(types)}")
    kind = data.get("type")
    if kind not in types:
        raise ModelError(_where(source, f"{name}.type"), f"unknown or missing {name} type {kind!r}", f"choose one of {', '.join(types)}")
    return str(kind)


def description_of(data: dict[str, Any], source: str) -> str:
    """The scenario's ``description`` (a string; empty when absent)."""
    description = data.get("description", "")
    if not isinstance(description, str):
        raise ModelError(_where(source, "description"), f"expected a string, got {description!r}", "write the description in quotes")
    return description


def _actuation(data: Any, model: Model, source: str) -> _OpenLoop:
    kind = _table_type(data, source, "actuation", ACTUATION_TYPES)
    table = _table(data, _ACTUATION_KEYS[kind], source, "actuation")
    n = model.n_joints
    params: dict[str, np.ndarray] = {}

    def need(key: str) -> Any:
        if key not in table:
            raise ModelError(_where(source, f"actuation.{key}"), f"missing (needed by type = {kind!r})", f"give actuation.{key}")
        return table[key]

    if kind == "constant":
        params["joint_torque"] = _per_joint(need("joint_torque"), model, source, "actuation.joint_torque", "N m", scalar_ok=True)
        _effort(params["joint_torque"], source, "actuation.joint_torque", "N m")
    elif kind == "piecewise":
        times = _array(need("times"), (-1,), source, "actuation.times", "give the switching times (s), starting at 0, increasing")
        if times[0] != 0.0 or np.any(np.diff(times) <= 0):
            raise ModelError(
                _where(source, "actuation.times"), f"must start at 0 and increase strictly, got {times.tolist()}", "fix the times (s)"
            )
        params["times"] = times
        params["joint_torque"] = _array(
            need("joint_torque"),
            (times.size, n),
            source,
            "actuation.joint_torque",
            f"give one row of {n} torques (N m) per time ({times.size} rows)",
        )
        _effort(params["joint_torque"], source, "actuation.joint_torque", "N m")
    else:
        params["amplitude"] = _per_joint(need("amplitude"), model, source, "actuation.amplitude", "N m", scalar_ok=True)
        params["frequency"] = _per_joint(need("frequency"), model, source, "actuation.frequency", "Hz", scalar_ok=True)
        for key, unit in (("phase", "rad"), ("offset", "N m")):
            params[key] = _per_joint(table[key], model, source, f"actuation.{key}", unit, scalar_ok=True) if key in table else np.zeros(n)
        for key in ("amplitude", "offset"):
            _effort(params[key], source, f"actuation.{key}", "N m")
        _bounded(
            params["frequency"],
            source,
            "actuation.frequency",
            MAX_FREQUENCY,
            "Hz",
            "which no actuator of a space robot follows (resolving it would take steps below a microsecond)",
            "check the units (Hz, not rad/s) and the size",
        )
        _bounded(
            params["phase"],
            source,
            "actuation.phase",
            MAX_JOINT_VALUE,
            "rad",
            "a phase that sin() cannot resolve (its rounding error is 1e-10 rad)",
            "give the phase in radians, within one turn",
        )
    force, torque = _thrusters(table, source, "actuation")
    return _OpenLoop(kind, params, force, torque)


def _controller(data: Any, model: Model, source: str) -> JointPD:
    kind = _table_type(data, source, "controller", CONTROLLER_TYPES)
    table = _table(data, _CONTROLLER_KEYS[kind], source, "controller")
    gains = {}
    for key, unit in (("kp", "N m/rad"), ("kd", "N m s/rad")):
        if key not in table:
            raise ModelError(_where(source, f"controller.{key}"), "missing", f"give the gain ({unit}): a number or one per joint")
        gains[key] = _per_joint(table[key], model, source, f"controller.{key}", unit, scalar_ok=True)
        if np.any(gains[key] < 0):
            raise ModelError(_where(source, f"controller.{key}"), "has negative gains", "give gains >= 0")
    q_ref = np.zeros(model.n_joints)
    pick = _one_of(table, ("q_ref", "q_ref_deg"), source, "controller")
    if pick is not None:
        key, value = pick
        q_ref = _per_joint(value, model, source, f"controller.{key}", "deg" if key == "q_ref_deg" else "rad")
        q_ref = np.radians(q_ref) if key == "q_ref_deg" else q_ref
    qdot_ref = (
        _per_joint(table["qdot_ref"], model, source, "controller.qdot_ref", "rad/s") if "qdot_ref" in table else np.zeros(model.n_joints)
    )
    return _built(lambda: JointPD(kp=gains["kp"], kd=gains["kd"], q_ref=q_ref, qdot_ref=qdot_ref), source, "controller")


def _limits(data: Any, model: Model, source: str) -> ActuatorLimits:
    table = _table(data, _LIMIT_KEYS, source, "limits")
    values: dict[str, Any] = {}
    for key, size, unit in (("joint_torque", model.n_joints, "N m"), ("spacecraft_force", 3, "N"), ("spacecraft_torque", 3, "N m")):
        if key not in table:
            continue
        fix = f"give a positive limit ({unit}): a number or {size} values"
        value = table[key]
        arr = (
            np.full(size, _number(value, source, f"limits.{key}", fix))
            if isinstance(value, (int, float))
            else _array(value, (size,), source, f"limits.{key}", fix)
        )
        if np.any(arr <= 0):
            raise ModelError(_where(source, f"limits.{key}"), f"must be positive, got {value!r}", fix)
        values[key] = arr
    return ActuatorLimits(**values)


# --------------------------------------------------------------------- public
def _joint_limits(data: Any, source: str) -> dict[str, Any]:
    """``[joint_limits]``: mode = "stop" (hard stops, default) or "flag"; restitution in [0, 1]."""
    table = _table(data, _JOINT_LIMIT_KEYS, source, "joint_limits")
    options: dict[str, Any] = {}
    if "mode" in table:
        if table["mode"] not in ("stop", "flag"):
            raise ModelError(_where(source, "joint_limits.mode"), f"unknown mode {table['mode']!r}", 'write "stop" (hard stops) or "flag"')
        options["joint_limits"] = table["mode"]
    if "restitution" in table:
        value = _number(table["restitution"], source, "joint_limits.restitution", "give a number in [0, 1]")
        if not 0.0 <= value <= 1.0:
            raise ModelError(
                _where(source, "joint_limits.restitution"), f"{value} is outside [0, 1]", "0: the joint stops dead, 1: elastic"
            )
        options["restitution"] = value
    return options


def scenario_model(top: dict[str, Any], source: str, base: Path | None, end_effectors: Any = None) -> tuple[Model, Path | None]:
    """The model a scenario file names (its ``model``, ``end_effectors`` and ``strict`` keys), and the model file read.

    ``model`` is a path relative to the scenario's folder ``base``, a plain path or a built-in name
    (exactly as the CLI's MODEL argument); ``end_effectors`` (the command line's ``-e``, when given)
    replaces the scenario's key. Shared by simulation and capture scenarios.
    """
    if "model" not in top or not isinstance(top["model"], str):
        raise ModelError(
            _where(source, "model"),
            f"missing or not a string ({top.get('model')!r})",
            'give a built-in name such as "papadopoulos1992", or a model file path',
        )
    chosen = end_effectors if end_effectors is not None else top.get("end_effectors")
    if chosen is not None and (not isinstance(chosen, list) or not all(isinstance(n, str) and n.strip() for n in chosen)):
        raise ModelError(_where(source, "end_effectors"), f"expected a list of names, got {chosen!r}", 'write end_effectors = ["tool0"]')
    strict = top.get("strict", False)
    if not isinstance(strict, bool):
        raise ModelError(_where(source, "strict"), f"expected true or false, got {strict!r}", "write strict = true or leave it out")
    spec = top["model"]
    found: Path | None
    try:
        near = base / spec if base is not None else None
        if near is not None and (near.exists() or near.is_symlink()):  # a folder or a broken link there: load names it
            model, found = load(near, end_effectors=chosen, strict=strict), near
        else:
            path = Path(spec)
            model, found = load_model(spec, end_effectors=chosen, strict=strict), (path if path.is_file() else None)
    except (ModelError, FileNotFoundError) as exc:
        raise ModelError(_where(source, "model"), str(exc), "fix the model name or path (relative to the scenario file)") from exc
    return scenario_wheels(model, top, source, base), found


def scenario_wheels(model: Model, top: dict[str, Any], source: str, base: Path | None) -> Model:
    """``model`` with the scenario's reaction wheels (its ``[[wheels]]`` tables, or ``wheels = "FILE"``: a side file of
    them, relative to the scenario's folder ``base``; docs/wheels.md), which replace the model's; ``model`` without."""
    if "wheels" not in top:
        return model
    wheels = top["wheels"]
    if isinstance(wheels, str) and base is not None and (base / wheels).is_file():
        wheels = base / wheels
    try:
        return with_wheels(model, wheels)
    except ModelError as exc:
        raise ModelError(_where(source, exc.field), exc.problem, exc.fix) from None


def refuse_model_file(data: Any, source: str) -> None:
    """A model file (its ``[[bodies]]``) given where a scenario belongs: a ModelError that says so."""
    if isinstance(data, dict) and "bodies" in data:
        raise ModelError(
            source or "scenario", "is a model file (it has [[bodies]]), not a scenario", 'name it in a scenario: model = "PATH"'
        )


def scenario_from_dict(data: Any, *, source: str = "", base: Path | None = None, end_effectors: Any = None) -> Scenario:
    """Validate a scenario given as a dict (a parsed TOML file); ``base``: folder of relative model paths;
    ``end_effectors``: replaces the scenario's ``end_effectors`` (the command line's ``-e``)."""
    if isinstance(data, dict) and "payload" in data and "path" in data:
        raise ModelError(
            source or "scenario", "is a capture scenario (it has [payload] and [path])", "run it with `freefloat capture`, not `simulate`"
        )
    refuse_model_file(data, source)
    top = _table(data, _TOP_KEYS, source, "")
    model, model_file = scenario_model(top, source, base, end_effectors)
    if "duration" not in top:
        raise ModelError(_where(source, "duration"), "missing", "give the simulated time in seconds, e.g. duration = 10.0")
    duration = _number(top["duration"], source, "duration", "give the simulated time in seconds (> 0)", positive=True)
    initial = _initial_state(top.get("initial", {}), model, source)
    options = _integrator(top.get("integrator", {}), source, duration)
    if "actuation" in top and "controller" in top:
        raise ModelError(
            _where(source, "controller"), "given together with [actuation]", "keep one: an open-loop [actuation] profile or a [controller]"
        )
    controller: Callable[[float, State], Any] | None = None
    if "actuation" in top:
        controller = _actuation(top["actuation"], model, source)
    elif "controller" in top:
        controller = _controller(top["controller"], model, source)
    if "limits" in top:
        options["limits"] = _limits(top["limits"], model, source)
    if "joint_limits" in top:
        options.update(_joint_limits(top["joint_limits"], source))
    if "passive" in top:
        if not isinstance(top["passive"], str) or top["passive"] not in PASSIVE:
            raise ModelError(
                _where(source, "passive"),
                f"unknown value {top['passive']!r}",
                'write "model" (the joints\' damping and friction the model has, the default) or "ignore"',
            )
        options["passive"] = top["passive"]
    outputs = _table(top.get("outputs", {}), _OUTPUT_KEYS, source, "outputs")
    name = outputs.get("name", "trajectory")
    if not isinstance(name, str) or not name or Path(name).name != name or name.startswith("."):
        raise ModelError(
            _where(source, "outputs.name"), f"must be a plain file stem, got {name!r}", 'give a name such as "trajectory" (no folders)'
        )
    flags = {}
    for key in ("npz", "csv", "plots"):
        value = outputs.get(key, True)
        if not isinstance(value, bool):
            raise ModelError(_where(source, f"outputs.{key}"), f"expected true or false, got {value!r}", "write true or false")
        flags[key] = value
    description = description_of(top, source)
    return Scenario(
        source=source,
        model=model,
        initial_state=initial,
        duration=duration,
        controller=controller,
        options=options,
        description=description,
        output_name=name,
        write_npz=flags["npz"],
        write_csv=flags["csv"],
        write_plots=flags["plots"],
        input_files=tuple(p for p in (Path(source) if source else None, model_file) if p is not None),
    )


def load_scenario(path: str | Path, *, end_effectors: Any = None) -> Scenario:
    """Read and validate a scenario TOML file (schema in the module docstring and docs/simulation.md);
    ``end_effectors`` replaces the scenario's (the command line's ``-e``)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: is not a file; give a scenario TOML file" if path.exists() else f"{path}: no such scenario file")
    data = read_toml(path, "scenario")
    return scenario_from_dict(data, source=str(path), base=path.parent, end_effectors=end_effectors)


def estimate_scenario(scenario: Scenario) -> RunEstimate:
    """Steps, samples, outputs, memory and wall time of the scenario's run, before it starts (:func:`freefloat.simulation.estimate_run`)."""
    options = {key: scenario.options.get(key) for key in ("fixed_step", "sample_period", "output_period")}
    return estimate_run(scenario.model, scenario.duration, controller=scenario.controller is not None, **options)


def run_scenario(scenario: Scenario, *, progress: Any = None, warn_after: float | None = 60.0) -> Trajectory:
    """Simulate a scenario; a failure part-way raises :class:`~freefloat.SimulationError` with the partial trajectory.

    ``progress`` and ``warn_after`` as in :func:`freefloat.simulate`; Ctrl-C returns the
    trajectory so far (status ``"interrupted"``).
    """
    return simulate(
        scenario.model,
        scenario.initial_state,
        scenario.duration,
        scenario.controller,
        progress=progress,
        warn_after=warn_after,
        **scenario.options,
    )
