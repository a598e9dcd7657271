"""The built-in controllers inside the compiled loops of :func:`freefloat.simulate` and :func:`freefloat.rollout` (private).

A controller that describes itself as a compiled law (``controller.compiled_law(batch)``: the controllers of
:mod:`freefloat.control`, whose ``__call__`` is the numpy form of the same law, :mod:`freefloat.engine.laws`) or a
:class:`~freefloat.JointPD` runs in the engine's rollout loop (:func:`freefloat.engine.calls.law_rollout`) with no
Python per step: a rollout of B trajectories, or one simulation as a rollout of one. The results are those of the
Python loop (the same law, the same RK4 step, the same samples, limits and records; ``tests/control/test_compiled.py``).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any, NamedTuple, cast

import numpy as np

from .. import engine
from ..core.errors import SimulationError
from ..core.model import Model
from ..core.state import ActuatorLimits
from ..core.wheels import check_same_wheels, wheel_limits
from ..engine import actuator_bounds, same_structure, tree
from ._guard import PROGRESS_DELAY, Progress, _derivative_cost
from ._plan import RunPlan, integrated_model, passive_model
from ._record import _trajectory
from ._wheels import user_trajectory
from .pd import JointPD
from .trajectory import Trajectory

__all__ = [
    "PER_TRAJECTORY",
    "Plant",
    "after_run",
    "compiled_rollout",
    "compiled_simulation",
    "law_of",
    "law_rows",
    "output_times",
    "plant_models",
]

#: The fields of a control law with a row per trajectory (1 row: shared).
PER_TRAJECTORY = (
    "floats",
    "kp",
    "kd",
    "start",
    "goal",
    "zdot",
    "zddot",
    "rate_gain",
    "attitude",
    "attitude_gain",
    "lowest",
    "wheel_momentum",
    "wheel_limits",
    "wheel_flags",
)


#: Seconds of one sample of a compiled control law (measured 10-20 µs for the §V OSC): a run's estimate.
LAW_SAMPLE_COST = 2e-5


def law_of(controller: Any, batch: int | None) -> Any:
    """The compiled law of ``controller`` for a run of ``batch`` trajectories (None: one simulation), or None: it has
    none (a Python controller), or it needs Python (a desired motion given as a function). Raises the controller's
    errors for per-trajectory values of another length than the batch. The law routes the spacecraft torque to the
    reaction wheels (``torque_by="wheels"``) and gives no thruster force (``force_by="none"``) as its controller says."""
    make = getattr(controller, "compiled_law", None)
    return make(batch) if callable(make) else None


def after_run(controller: Any, law: Any) -> None:
    """Tell the controller what its compiled run met (``controller.compiled_run_done(law)``: the task controllers warn
    of a near-singular J_z there, once per run)."""
    done = getattr(controller, "compiled_run_done", None)
    if law is not None and callable(done):
        done(law)


def law_rows(law: Any, rows: slice, batch: int) -> Any:
    """The law of the trajectories ``rows`` of a batch of ``batch`` (its per-trajectory fields cut to those rows)."""
    if batch == 1:
        return law
    return law._replace(**{f: getattr(law, f)[rows] for f in PER_TRAJECTORY if getattr(law, f).shape[0] == batch})


class Plant(NamedTuple):
    """What a rollout simulates (:func:`plant_models`)."""

    #: the user's model (model[0] of per-trajectory models; ``passive`` applied): the states and trajectory are its
    user: Model
    #: what the engine integrates: ``user``'s reaction wheels as joints (``user`` itself without wheels)
    model: Model
    #: (K, F): the floats of ``model`` for each of the K models (1, or one per trajectory)
    floats: np.ndarray
    #: (K, 2, W): each model's wheel limits [max_torque; max_speed] (N m, rad/s; inf: none)
    wheel_limits: np.ndarray
    #: whether one of the K models has passive torques (damping, friction: its wheels' bearings too), so that the
    #: states carry the dissipated energy (:func:`~freefloat.core.state.dissipates`)
    dissipates: bool


def plant_models(model: Any, passive: str) -> Plant:
    """The model a rollout simulates, and its parameters per trajectory: ``model`` is one model, or a sequence of B
    variants of one structure (payload variants, :meth:`~freefloat.Model.with_payload`; the same reaction wheels with
    other inertias, limits or friction), the joints' passive torques as ``passive`` says."""
    many = isinstance(model, Sequence) and not isinstance(model, (str, bytes))
    if many and not model:
        raise ValueError("model: an empty sequence of models; give one model or one per trajectory")
    users = [passive_model(m, passive) for m in (model if many else [model])]
    models = [integrated_model(u, passive) for u in users]
    for i, other in enumerate(models[1:], start=1):
        check_same_wheels(users[0], users[i], i)
        if not same_structure(tree(models[0]), tree(other)):
            raise ValueError(
                f"model[{i}]: {users[i].name!r} has another structure than model[0] ({users[0].name!r}); per-trajectory "
                "models must be payload variants of one robot (model.with_payload(...)): the same bodies and joints"
            )
    floats = np.stack([tree(m).floats for m in models])
    limits = np.concatenate([wheel_limits_rows(u) for u in users])
    return Plant(users[0], models[0], floats, limits, any(m.has_passive for m in models))


def compiled_simulation(plan: RunPlan) -> Trajectory | None:
    """One fixed-step simulation with its controller inside the compiled loop: the trajectory, or None when the Python
    loop must run it (a Python controller, a sample period that is not a whole number of steps, a feed-forward on
    another period), or when it failed or its divergence guard (checked at the recorded outputs) stops it: the Python
    loop then runs it again and reports the failure as it does.

    The run is one call of a compiled kernel, which shows no progress and defers Ctrl-C to its end: only a run estimated
    to take under :data:`~._guard.PROGRESS_DELAY` (and under the plan's wall-clock limit) goes there; a longer one runs
    in the Python-stepped loop (compiled steps between the controller's samples), with progress and Ctrl-C. The run is
    :func:`compiled_rollout` of one trajectory. The trajectory is that of ``plan.model`` (a model's reaction wheels as
    joints, their saturation flags in ``saturated``: :func:`._wheels.user_trajectory` makes the user's)."""
    model, controller, duration, sample_period = plan.model, plan.controller, plan.duration, plan.sample_period
    wall_limit = plan.checks.wall_limit
    law = law_of(controller, None)
    if law is None and not isinstance(controller, JointPD):
        return None
    dt = cast(float, plan.fixed_step)  # (run() calls it for fixed steps only)
    steps = plan.steps
    ratio = (sample_period or dt) / dt
    if ratio > steps + 1:  # sampled once, at the start (a period beyond the run): the Python loop holds it
        return None
    hold = max(1, round(ratio))
    if sample_period is not None and sample_period > dt and abs(hold * dt - sample_period) > 1e-12 * sample_period:
        return None
    seconds = steps * (4.0 * _derivative_cost(model, fixed_step=True)[0] + (LAW_SAMPLE_COST if law is not None else 0.0) / hold)
    if seconds > PROGRESS_DELAY or (wall_limit is not None and seconds > 0.5 * wall_limit):
        return None
    stride = max(1, round(plan.output_period / dt))
    try:
        pd = controller if isinstance(controller, JointPD) else None
        bar = Progress(False, duration)
        run = compiled_rollout(model, plan.x0[None], dt, steps, hold, stride, pd, plan.limits, plan.wrenches, bar, law, user=plan.user)
    except SimulationError:
        return None
    if run is None:
        return None
    times, xs, acts, _, _ = run
    traj = _trajectory(model, times, xs[:, 0], (acts[0][:, 0], acts[1][:, 0], acts[2][:, 0], acts[3][:, 0]))
    try:
        for t, x in zip(times, xs[:, 0], strict=True):
            plan.guard.check(float(t), x)
    except SimulationError:
        return None
    after_run(controller, law)
    return traj


#: A compiled rollout of more trajectories than this runs in chunks (progress, Ctrl-C) of at least this many.
ROLLOUT_CHUNK_MIN = 64
#: How much faster the kernels specialised to a structure run rollouts (benchmarks/README.md): for the estimate.
SPECIALISED_SPEEDUP = 5.0


def output_times(dt: float, steps: int, stride: int) -> np.ndarray:
    """The times a rollout of ``steps`` steps of ``dt`` records: t = 0, every ``stride``-th step and the last."""
    k = np.arange(0, steps + 1, stride)
    return (k if k[-1] == steps else np.append(k, steps)) * dt


def compiled_rollout(
    model: Model,
    x0: np.ndarray,
    dt: float,
    steps: int,
    hold: int,
    stride: int,
    controller: JointPD | None,
    limits: ActuatorLimits,
    ext: tuple[np.ndarray, np.ndarray],
    bar: Progress,
    law: Any = None,
    plant: np.ndarray | None = None,
    user: Model | None = None,
    wheels: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray], str, str] | None:
    """A whole batched rollout with a joint PD (or none) or a control law (``law``: a built-in controller's
    ``compiled_law``), compiled, in chunks of trajectories, on the mass properties ``plant`` (the floats of 1 or B
    variants of ``model``: :func:`plant_models`; None: the model's), under the external wrenches ``ext`` (the
    engine's form: :func:`._plan.engine_wrenches`).

    ``model`` is what the engine integrates for the user's model ``user`` (None: ``model`` itself): its W reaction
    wheels as its last joints (:func:`freefloat.core.wheels.wheel_joint_model`), their limits ``wheels`` (1 or B,
    2, W) (None: ``user``'s) applied in the loop (:func:`freefloat.engine.laws.wheel_limits`; a joint PD drives no
    wheel).

    Returns the output times (T,), the states (T, B, S), the actuation (tau, f_S, n_S,
    saturated; with wheels tau holds the wheel torques after the joint torques and saturated (T, B, 1 + 2W) is [any,
    torque saturated (W), speed saturated (W)]), the status and message; or None when the controller needs Python (a
    feed-forward sampled at another period than the controller, or gains that do not broadcast: the Python
    path reports those). A trajectory that fails (H+ not positive definite, a non-finite state)
    raises a SimulationError. The trajectories run in chunks (about 20 for a large batch) so that
    ``bar`` shows progress and Ctrl-C keeps the finished chunks (status "interrupted").
    """
    user = model if user is None else user
    n = model.n_joints
    w = user.n_wheels
    batch = x0.shape[0]
    if law is not None and (int(law.ints[2]) != n - w or (law.setup[5] and law.wheel_inverse.shape[0] != w)):
        return None  # a controller made for another model's joints or wheels: the Python path names it
    lim = actuator_bounds(limits, n - w, w)  # (the same errors as the Python path)
    zeros = np.zeros((batch, n - w))
    feed = np.zeros((1, batch, n - w))
    gains: list[Any] = [zeros, zeros, zeros, zeros]
    if law is None and controller is not None:
        gains = [controller.kp, controller.kd, controller.q_ref, controller.qdot_ref]
        if controller.feedforward is not None:
            ff = np.asarray(controller.feedforward, dtype=float)
            if ff.shape[0] > 1 and not np.isclose(float(controller.feedforward_period or 0.0), hold * dt, rtol=1e-9, atol=0.0):
                return None
            feed = np.broadcast_to(ff[:, None, :] if ff.ndim == 2 else ff, (ff.shape[0], batch, n - w))
    try:
        arrays = tuple(np.broadcast_to(np.asarray(g, dtype=float), (batch, n - w)) for g in gains)
    except ValueError:
        return None
    if w:  # the joint PD drives the robot's joints only: zero gains and references for the wheels
        arrays = tuple(np.concatenate([a, np.zeros((batch, w))], axis=1) for a in arrays)
    slots, held = wheel_slots(steps, hold, stride)
    if law is not None:  # the wheels' limits (and the rows their flags go to) as the law's per-trajectory arrays
        limits_w = wheel_limits_rows(user) if wheels is None else np.ascontiguousarray(wheels, dtype=float)
        recorded = held.max() + 1 if w else 0
        flags_w = np.zeros((batch, recorded, 2 * w), dtype=bool)
        law = law._replace(wheel_limits=limits_w, wheel_slot=slots if w else slots[:0], wheel_flags=flags_w)
    per_trajectory = plant is not None and plant.shape[0] > 1
    fast = law is None and not per_trajectory and engine.specialised_rollouts(model, batch, ext)
    # chunks only for a long rollout (progress, Ctrl-C): joining the chunks copies every output once
    threads = max(1, os.cpu_count() or 1)
    seconds = _derivative_cost(model, fixed_step=True)[0] * 4 * steps * batch / threads / (SPECIALISED_SPEEDUP if fast else 1.0)
    long_run = bar.enabled and (bar.callback is not None or bar.delay == 0.0 or seconds > PROGRESS_DELAY)
    least = ROLLOUT_CHUNK_MIN * threads if fast else ROLLOUT_CHUNK_MIN  # specialised: a lane block per thread at least
    chunk = batch if batch <= least or not long_run else least * -(-max(least, -(-batch // 20)) // least)
    parts: list[tuple[np.ndarray, ...]] = []
    status, message = "finished", ""
    try:
        for start in range(0, batch, chunk):
            rows = slice(start, min(batch, start + chunk))
            if law is not None or per_trajectory:
                chunk_law = None if law is None else law_rows(law, rows, batch)
                pd = None if law is not None else (*(g[rows] for g in arrays), feed[:, rows])
                plant_c = plant if plant is None or plant.shape[0] == 1 else plant[rows]
                parts.append(engine.law_rollout(model, plant_c, x0[rows], dt, steps, hold, stride, chunk_law, lim, ext, pd))
            else:
                gains_c = tuple(g[rows] for g in arrays)
                parts.append(engine.rollout(model, x0[rows], dt, steps, hold, stride, gains_c, feed[:, rows], lim, ext))  # type: ignore[arg-type]
            bar.update(steps * dt * rows.stop / batch)
    except KeyboardInterrupt:
        if not parts:
            raise
        finished = sum(p[0].shape[1] for p in parts)
        status, message = "interrupted", f"interrupted (Ctrl-C): the first {finished} of {batch} trajectories are complete"
    if len(parts) == 1:  # one chunk: its arrays as they are (a join would copy every output once)
        xs, us, sat, done = parts[0]
    else:
        xs, us, sat = (np.concatenate([p[i] for p in parts], axis=1) for i in range(3))
        done = np.concatenate([p[3] for p in parts])
    if w:  # [any, torque saturated (W), speed saturated (W)] at each output: the flags of the sample it holds
        flags = np.zeros((*sat.shape, 2 * w), dtype=bool) if law is None else law.wheel_flags[: sat.shape[1], held].transpose(1, 0, 2)
        sat = np.concatenate([sat[..., None], flags & np.isfinite(xs[..., :1])], axis=-1)
    times = output_times(dt, steps, stride)
    acts = (us[:, :, :n], us[:, :, n : n + 3], us[:, :, n + 3 :], sat)
    if np.any(done < steps):
        first = int(np.argmin(done))
        t_fail = float(done[first] * dt)
        message = (
            f"trajectory {first} of the rollout became non-finite or singular at t = {t_fail:.6g} s "
            "(unstable controller or too large a step?); its later samples are NaN"
        )
        traj = _trajectory(model, times, xs, acts, "failed", message, copy=False)
        raise SimulationError(message, user_trajectory(user, traj) if w else traj)
    return times, xs, acts, status, message


def wheel_slots(steps: int, hold: int, stride: int) -> tuple[np.ndarray, np.ndarray]:
    """Where the compiled loops write the wheels' saturation flags of a rollout of ``steps`` steps, its controller
    sampled every ``hold`` steps and its outputs every ``stride`` (:func:`output_times`): (the slot of each sample
    (samples,), -1 for a sample no output holds; the slot each output holds (T,)). An output at step k holds the sample
    at step ``hold * (k // hold)`` (before the last step; the last output, the sample before it)."""
    k = np.round(output_times(1.0, steps, stride)).astype(np.int64)
    sample = np.where(k < steps, k // hold, (steps - 1) // hold)
    recorded, held = np.unique(sample, return_inverse=True)
    slots = np.full((steps - 1) // hold + 1, -1, dtype=np.int64)
    slots[recorded] = np.arange(recorded.size)
    return slots, held.reshape(-1)


def wheel_limits_rows(user: Model) -> np.ndarray:
    """(1, 2, W): ``user``'s wheel limits [max_torque; max_speed] as a law's row shared by every trajectory."""
    return np.stack(wheel_limits(user)).reshape(1, 2, user.n_wheels)
