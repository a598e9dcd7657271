"""The built-in controllers as the compiled control laws of :mod:`freefloat.engine.laws` (private).

Each controller of :mod:`freefloat.control` describes itself as a :data:`~freefloat.engine.laws.Law` (arrays:
its task, gains, desired motion, its model's mass properties) through :func:`task_law` or :func:`detumble_law`
(``controller.compiled_law(batch)``), and :func:`freefloat.simulate` / :func:`freefloat.rollout` run that law's kernel
inside their compiled loops; the kernel runs nowhere else. The controller's ``__call__`` is the numpy form of the
same law, on one state or, through :func:`batch_call`, on a batch of states row by row: the reference that
tests/control/test_compiled.py checks the kernel against. Per-trajectory parameters have a leading axis of B: gains
(B, d) or (B, d, d), set points (B, size), models (a sequence of B payload variants).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..core.errors import NearSingularWarning, ShapeError
from ..core.model import Model
from ..core.state import Actuation, State, pack_state, unpack_state
from ..core.wheels import check_same_wheels, wheel_arrays
from ..engine import DETUMBLE, OPERATIONAL_SPACE, PROFILES, TRANSPOSED_JACOBIAN, actuator_bounds, make_law, same_structure, tree

__all__ = ["batch_call", "batch_of", "desired_row", "detumble_law", "gains", "models_of", "task_law"]

LAW_CODES = {"transposed": TRANSPOSED_JACOBIAN, "operational": OPERATIONAL_SPACE}


def models_of(model: Any) -> tuple[Model, ...]:
    """A controller's models: one :class:`~freefloat.Model`, or a sequence of B payload variants of one structure
    (the same bodies, joints and placements, the same reaction wheels' spin axes; mass properties and the wheels'
    inertias, limits and friction per trajectory)."""
    if isinstance(model, Model):
        return (model,)
    if isinstance(model, Sequence) and not isinstance(model, (str, bytes)) and model and all(isinstance(m, Model) for m in model):
        first = tree(model[0])
        for i, other in enumerate(model[1:], start=1):
            check_same_wheels(model[0], other, i)
            if not same_structure(first, tree(other)):
                raise ValueError(
                    f"model[{i}]: {other.name!r} has another structure than model[0] ({model[0].name!r}); per-trajectory "
                    "models must be payload variants of one robot (model.with_payload(...)): the same bodies and joints"
                )
        return tuple(model)
    raise TypeError(f"model: expected a freefloat Model or a sequence of Models (one per trajectory), got {type(model).__name__}")


def mass_rows(models: Sequence[Model]) -> np.ndarray:
    """The floats of each model (without the joints' passive torques: the laws' C+ has none), (K, F)."""
    return np.stack([tree(m.without_passive()).floats for m in models]).copy()


def batch_of(name: str, count: int, batch: int | None) -> int:
    """``count`` per-trajectory values of ``name`` checked against the run's ``batch`` (None: one simulation)."""
    if count == 1:
        return 1
    if batch is None:
        raise ShapeError(f"{name}: {count} per-trajectory values, but a single simulation has one trajectory; use freefloat.rollout")
    if count != batch:
        raise ShapeError(f"{name}: {count} per-trajectory values, but the rollout has {batch} trajectories")
    return count


def gains(value: Any, dim: int, name: str, check: Any) -> np.ndarray:
    """Gains as (K, dim, dim): a scalar, a diagonal (dim,) or a matrix (dim, dim) for every trajectory (K = 1); per
    trajectory (K = B) a (B, dim, dim) array, a (B, dim) array of diagonals or (B, 1) scalars (a (dim, dim) array is one
    matrix). ``check(value, dim, name)`` validates one (it returns the (dim, dim) matrix)."""
    arr = np.asarray(value, dtype=float)
    if arr.ndim <= 1 or arr.shape == (dim, dim):
        return check(arr, dim, name)[None].copy()
    if arr.ndim == 2 and arr.shape[1] in (1, dim):
        rows = [np.broadcast_to(row, (dim,)) for row in arr]
    elif arr.ndim == 3:
        rows = list(arr)
    else:
        raise ShapeError(
            f"{name}: expected a scalar, ({dim},), ({dim}, {dim}) or per trajectory (B, {dim}), (B, 1) or (B, {dim}, {dim}), "
            f"got shape {arr.shape}"
        )
    return np.stack([check(row, dim, f"{name}[{b}]") for b, row in enumerate(rows)]).copy()


def _rows(value: Any, width: int, name: str) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 1:
        arr = arr[None]
    if arr.ndim != 2 or arr.shape[1] != width:
        raise ShapeError(f"{name}: expected ({width},) or per trajectory (B, {width}), got shape {np.shape(value)}")
    return np.ascontiguousarray(arr).copy()


def task_law(controller: Any, batch: int | None) -> Any:
    """The :data:`~freefloat.engine.laws.Law` of a task-space controller (eqs. 27, 29), or None when its desired
    motion is a Python function (the simulation then calls the controller from Python). Per-trajectory values are
    checked against ``batch`` (ShapeError naming the parameter)."""
    from .desired import SetPoint, StraightLine

    task = controller.task
    desired = controller.desired
    profile, timing = -1, np.zeros(2)
    size, dim = task.size, task.dim
    zdot, zddot = np.zeros((1, dim)), np.zeros((1, dim))
    if isinstance(desired, SetPoint):
        start = goal = _rows(desired.z, size, "desired")
    elif isinstance(desired, StraightLine) and (desired.task is task or (desired.task is None and size == dim)):
        start, goal = _rows(desired.start, size, "desired.start"), _rows(desired.goal, size, "desired.goal")
        profile, timing = PROFILES.index(desired.profile), np.array([desired.duration, desired.start_time], dtype=float)
        if desired.task is None:  # a plain vector: no angles to wrap, no quaternions (a task of positions only)
            if any(it.kind != "position" for it in task.items):
                return None
    else:
        return None
    models = controller.models
    floats = mass_rows(models)
    for name, count in (
        ("kp", controller.kp_rows.shape[0]),
        ("kd", controller.kd_rows.shape[0]),
        ("desired", start.shape[0]),
        ("desired goal", goal.shape[0]),
        ("model", floats.shape[0]),
    ):
        batch_of(name, count, batch)
    items = np.array([[0 if it.kind == "position" else 1, it.body] for it in task.items], dtype=np.int64)
    points = np.array([it.point if it.kind == "position" else (0.0, 0.0, 0.0) for it in task.items], dtype=float).reshape(-1, 3)
    limits = actuator_bounds(controller.limits, models[0].n_joints)
    quaternions = int(not task.planar and task.orientation == "quaternion")
    setup = np.array([LAW_CODES[controller.law.split("-")[0]], int(task.planar), quaternions, 1, profile], dtype=np.int64)
    return _law(
        controller,
        batch=batch,
        setup=setup,
        items=items,
        points=points,
        models=models,
        floats=floats,
        kp=controller.kp_rows,
        kd=controller.kd_rows,
        start=start,
        goal=goal,
        zdot=zdot,
        zddot=zddot,
        timing=timing,
        settings=np.array([controller.singular_tolerance, controller.null_space_damping]),
        limits=limits,
    )


def detumble_law(controller: Any, batch: int | None) -> Any:
    """The :data:`~freefloat.engine.laws.Law` of :class:`~freefloat.control.detumble.Detumble`."""
    models = controller.models
    floats = mass_rows(models)
    for name, count in (("rate_gain", controller.rate_gain_rows.shape[0]), ("model", floats.shape[0])):
        batch_of(name, count, batch)
    n = models[0].n_joints
    attitude = np.eye(3)[None] if controller.attitude is None else np.asarray(controller.attitude, dtype=float)[None]
    return _law(
        controller,
        batch=batch,
        setup=np.array([DETUMBLE, 0, 0, int(controller.force), -1], dtype=np.int64),
        models=models,
        floats=floats,
        limits=np.full(n + 6, np.inf),
        rate_gain=controller.rate_gain_rows,
        attitude=attitude,
        attitude_gain=np.array([controller.attitude_gain], dtype=float),
    )


def _law(controller: Any, models: Sequence[Model], floats: np.ndarray, batch: int | None, setup: np.ndarray, **given: Any) -> Any:
    """A Law of the given fields for the controller's models (their floats (K, F)), for a run of ``batch`` trajectories
    (its ``lowest`` a row per trajectory: the threads of a rollout write each their own), with the controller's
    actuators (``controller.actuators`` = (torque_by, force_by), :mod:`freefloat.control.wheels`): the setup's last two
    codes, and with the torque by the reaction wheels, their Js a (K, W, 3) per model and the pseudo-inverse of their axes."""
    torque_by, force_by = controller.actuators
    wheels: dict[str, Any] = {}
    if torque_by == "wheels":
        spin = [wheel_arrays(m) for m in models]
        wheels["wheel_momentum"] = np.stack([js[:, None] * axes for axes, js in spin])
        wheels["wheel_inverse"] = np.linalg.pinv(spin[0][0].T)  # the axes are those of every model (models_of)
    codes = np.concatenate([setup, [int(torque_by == "wheels"), int(force_by == "none")]])
    return make_law(np.array(tree(models[0]).ints, dtype=np.int64), floats, setup=codes, lowest=np.ones(batch or 1), **wheels, **given)


def desired_row(desired: Any, b: int) -> Any:
    """The desired motion of trajectory b: row b of a per-trajectory set point (B, size), else ``desired`` itself."""
    from .desired import SetPoint

    if isinstance(desired, SetPoint) and np.ndim(desired.z) == 2:
        return SetPoint(np.asarray(desired.z, dtype=float)[b])
    return desired


def batch_call(controller: Any, t: float, state: State) -> Actuation:
    """A built-in controller on a batch of B resolved states (..., one batch axis): row b by ``controller.row(b)`` (its
    per-trajectory parameters' row b) in numpy, one state at a time; the outputs and extras stacked (B, ...). The
    near-singular warning comes once for the batch, from ``controller``."""
    x = pack_state(state)
    if x.ndim != 2:
        raise ShapeError(f"state: expected one state or a batch with one leading axis (B, ...), got a batch of shape {x.shape[:-1]}")
    count = x.shape[0]
    for name, rows in controller.parameter_rows().items():
        batch_of(name, rows, count)
    acts = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NearSingularWarning)
        for b in range(count):
            acts.append(controller.row(b)(t, unpack_state(controller.model, x[b])))
    extras: dict[str, Any] = {}
    for key in acts[0].extras:
        try:
            extras[key] = np.stack([np.asarray(a.extras[key]) for a in acts])
        except ValueError:  # entries of different shapes: kept per row
            extras[key] = [a.extras[key] for a in acts]
    if "sigma_ratio" in extras and hasattr(controller, "_warn_singular"):
        controller._warn_singular(extras["sigma_ratio"])
    wheel = None if acts[0].wheel_torque is None else np.stack([a.wheel_torque for a in acts])
    return Actuation(
        joint_torque=np.stack([a.joint_torque for a in acts]),
        spacecraft_force=np.stack([a.spacecraft_force for a in acts]),
        spacecraft_torque=np.stack([a.spacecraft_torque for a in acts]),
        wheel_torque=wheel,
        extras=extras,
    )
