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
from typing import Any, cast

import numpy as np

from .. import engine
from ..core.errors import SimulationError
from ..core.model import Model
from ..core.state import ActuatorLimits
from ..engine import actuator_bounds, same_structure, tree
from ._guard import PROGRESS_DELAY, Progress, _derivative_cost
from ._plan import RunPlan, passive_model
from ._record import _trajectory
from .pd import JointPD
from .trajectory import Trajectory

__all__ = ["PER_TRAJECTORY", "after_run", "compiled_rollout", "compiled_simulation", "law_of", "law_rows", "output_times", "plant_models"]

#: The fields of a control law with a row per trajectory (1 row: shared).
PER_TRAJECTORY = ("floats", "kp", "kd", "start", "goal", "zdot", "zddot", "rate_gain", "attitude", "attitude_gain", "lowest")


#: Seconds of one sample of a compiled control law (measured 10-20 µs for the §V OSC): a run's estimate.
LAW_SAMPLE_COST = 2e-5


def law_of(controller: Any, batch: int | None) -> Any:
    """The compiled law of ``controller`` for a run of ``batch`` trajectories (None: one simulation), or None: it has
    none (a Python controller), or it needs Python (a desired motion given as a function). Raises the controller's
    errors for per-trajectory values of another length than the batch. A controller that drives reaction wheels
    (``torque_by="wheels"``) or a task controller with ``force_by="none"`` runs from Python: the compiled loops route
    nothing to wheels and zero no force (the detumbling law's ``force=False`` is in the law itself)."""
    torque_by, force_by = getattr(controller, "actuators", ("thrusters", "thrusters"))
    if torque_by != "thrusters" or (force_by != "thrusters" and getattr(controller, "force", True)):
        return None
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


def plant_models(model: Any, passive: str) -> tuple[Model, np.ndarray]:
    """The model a rollout simulates and its mass properties per trajectory: ``model`` is one model, or a sequence of B
    payload variants of one structure (:meth:`~freefloat.Model.with_payload`): (the first, with the joints' passive
    torques as ``passive`` says, and the floats of each (K, F))."""
    given = list(model) if isinstance(model, Sequence) and not isinstance(model, (str, bytes)) else [model]
    for i, each in enumerate(given):
        if isinstance(each, Model) and each.wheels:
            where = f"model[{i}]" if len(given) > 1 or given[0] is not model else "model"
            raise ValueError(
                f"{where}: {each.name!r} has reaction wheels, which rollout does not simulate yet; run each trajectory with "
                "freefloat.simulate, which integrates them (docs/wheels.md)"
            )
    if isinstance(model, Sequence) and not isinstance(model, (str, bytes)):
        if not model:
            raise ValueError("model: an empty sequence of models; give one model or one per trajectory")
        models = [passive_model(m, passive) for m in model]
        for i, other in enumerate(models[1:], start=1):
            if not same_structure(tree(models[0]), tree(other)):
                raise ValueError(
                    f"model[{i}]: {other.name!r} has another structure than model[0] ({models[0].name!r}); per-trajectory "
                    "models must be payload variants of one robot (model.with_payload(...)): the same bodies and joints"
                )
        return models[0], np.stack([tree(m).floats for m in models])
    single = passive_model(model, passive)
    return single, np.array(tree(single).floats)[None]


def compiled_simulation(plan: RunPlan) -> Trajectory | None:
    """One fixed-step simulation with its controller inside the compiled loop: the trajectory, or None when the Python
    loop must run it (a Python controller, a sample period that is not a whole number of steps, a feed-forward on
    another period), or when it failed or its divergence guard (checked at the recorded outputs) stops it: the Python
    loop then runs it again and reports the failure as it does.

    The run is one call of a compiled kernel, which shows no progress and defers Ctrl-C to its end: only a run estimated
    to take under :data:`~._guard.PROGRESS_DELAY` (and under the plan's wall-clock limit) goes there; a longer one runs
    in the Python-stepped loop (compiled steps between the controller's samples), with progress and Ctrl-C. The run is
    :func:`compiled_rollout` of one trajectory."""
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
    seconds = steps * (4.0 * _derivative_cost(model) + (LAW_SAMPLE_COST if law is not None else 0.0) / hold)
    if seconds > PROGRESS_DELAY or (wall_limit is not None and seconds > 0.5 * wall_limit):
        return None
    stride = max(1, round(plan.output_period / dt))
    try:
        pd = controller if isinstance(controller, JointPD) else None
        bar = Progress(False, duration)
        run = compiled_rollout(model, plan.x0[None], dt, steps, hold, stride, pd, plan.limits, plan.wrenches, bar, law)
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
) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray], str, str] | None:
    """A whole batched rollout with a joint PD (or none) or a control law (``law``: a built-in controller's
    ``compiled_law``), compiled, in chunks of trajectories, on the mass properties ``plant`` (the floats of 1 or B
    payload variants of ``model``: :func:`plant_models`; None: the model's), under the external wrenches ``ext`` (the
    engine's form: :func:`._plan.engine_wrenches`).

    Returns the output times (T,), the states (T, B, S), the actuation (tau, f_S, n_S,
    saturated), the status and message; or None when the controller needs Python (a feed-forward
    sampled at another period than the controller, or gains that do not broadcast: the Python
    path reports those). A trajectory that fails (H+ not positive definite, a non-finite state)
    raises a SimulationError. The trajectories run in chunks (about 20 for a large batch) so that
    ``bar`` shows progress and Ctrl-C keeps the finished chunks (status "interrupted").
    """
    n = model.n_joints
    batch = x0.shape[0]
    lim = actuator_bounds(limits, n)  # (the same errors as the Python path)
    zeros = np.zeros((batch, n))
    feed = np.zeros((1, batch, n))
    gains: list[Any] = [zeros, zeros, zeros, zeros]
    if law is None and controller is not None:
        gains = [controller.kp, controller.kd, controller.q_ref, controller.qdot_ref]
        if controller.feedforward is not None:
            ff = np.asarray(controller.feedforward, dtype=float)
            if ff.shape[0] > 1 and not np.isclose(float(controller.feedforward_period or 0.0), hold * dt, rtol=1e-9, atol=0.0):
                return None
            feed = np.broadcast_to(ff[:, None, :] if ff.ndim == 2 else ff, (ff.shape[0], batch, n))
    try:
        arrays = tuple(np.broadcast_to(np.asarray(g, dtype=float), (batch, n)) for g in gains)
    except ValueError:
        return None
    per_trajectory = plant is not None and plant.shape[0] > 1
    fast = law is None and not per_trajectory and engine.specialised_rollouts(model, batch, ext)
    # chunks only for a long rollout (progress, Ctrl-C): joining the chunks copies every output once
    threads = max(1, os.cpu_count() or 1)
    seconds = _derivative_cost(model) * 4 * steps * batch / threads / (SPECIALISED_SPEEDUP if fast else 1.0)
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
    times = output_times(dt, steps, stride)
    if np.any(done < steps):
        first = int(np.argmin(done))
        t_fail = float(done[first] * dt)
        message = (
            f"trajectory {first} of the rollout became non-finite or singular at t = {t_fail:.6g} s "
            "(unstable controller or too large a step?); its later samples are NaN"
        )
        traj = _trajectory(model, times, xs, (us[:, :, :n], us[:, :, n : n + 3], us[:, :, n + 3 :], sat), "failed", message, copy=False)
        raise SimulationError(message, traj)
    return times, xs, (us[:, :, :n], us[:, :, n : n + 3], us[:, :, n + 3 :], sat), status, message
