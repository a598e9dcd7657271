"""The built-in controllers inside the compiled loops of :func:`freefloat.simulate` and :func:`freefloat.rollout` (private).

A controller that describes itself as a compiled law (``controller.compiled_law(batch)``: the controllers of
:mod:`freefloat.control`, whose ``__call__`` runs the same law, :mod:`freefloat.engine.laws`) or a
:class:`~freefloat.JointPD` runs in the engine's rollout loop (:func:`freefloat.engine.calls.law_rollout`) with no
Python per step: a rollout of B trajectories, or one simulation as a rollout of one. The results are those of the
Python loop (the same law, the same RK4 step, the same samples, limits and records; ``tests/control/test_compiled.py``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..core.errors import SimulationError
from ..core.model import Model
from ..core.state import ActuatorLimits
from ..engine import same_structure, tree
from ._guard import PROGRESS_DELAY, Progress, _derivative_cost
from ._integrate import _trajectory
from .pd import JointPD
from .trajectory import Trajectory

__all__ = ["PER_TRAJECTORY", "after_run", "compiled_simulation", "law_of", "law_rows", "plant_models"]

#: The fields of a control law with a row per trajectory (1 row: shared).
PER_TRAJECTORY = ("floats", "kp", "kd", "start", "goal", "zdot", "zddot", "rate_gain", "attitude", "attitude_gain", "lowest")


#: Seconds of one sample of a compiled control law (measured 10-20 µs for the §V OSC): a run's estimate.
LAW_SAMPLE_COST = 2e-5
PASSIVE = ("model", "ignore")


def passive_model(model: Model, passive: Any) -> Model:
    """The model a run simulates: ``model``, or without its joints' damping and friction for ``passive="ignore"``."""
    if not isinstance(model, Model):
        raise TypeError(f"model: expected a freefloat.Model, got {type(model).__name__}")
    if not isinstance(passive, str) or passive not in PASSIVE:
        raise ValueError(f"passive: {passive!r} is not one of {', '.join(map(repr, PASSIVE))} (the joints' damping and friction)")
    return model if passive == "model" else model.without_passive()


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


def compiled_simulation(
    model: Model,
    x0: np.ndarray,
    duration: float,
    dt: float,
    sample_period: float | None,
    period: float,
    controller: Any,
    limits: ActuatorLimits,
    external: Any,
    guard: Any,
    wall_limit: float | None,
    run_compiled: Callable[..., Any],
) -> Trajectory | None:
    """One fixed-step simulation with its controller inside the compiled loop: the trajectory, or None when the Python
    loop must run it (a Python controller, a sample period that is not a whole number of steps, a feed-forward on
    another period), or when it failed or its divergence guard (checked at the recorded outputs) stops it: the Python
    loop then runs it again and reports the failure as it does.

    The run is one call of a compiled kernel, which shows no progress and defers Ctrl-C to its end: only a run estimated
    to take under :data:`~._guard.PROGRESS_DELAY` (and under ``wall_limit``) goes there; a longer one runs in the
    Python-stepped loop (compiled steps between the controller's samples), with progress and Ctrl-C.
    ``run_compiled``: :func:`freefloat.simulation.simulate._rollout_pd` (the compiled rollout, one trajectory)."""
    law = law_of(controller, None)
    if law is None and not isinstance(controller, JointPD):
        return None
    steps = round(duration / dt)
    ratio = (sample_period or dt) / dt
    if ratio > steps + 1:  # sampled once, at the start (a period beyond the run): the Python loop holds it
        return None
    hold = max(1, round(ratio))
    if sample_period is not None and sample_period > dt and abs(hold * dt - sample_period) > 1e-12 * sample_period:
        return None
    seconds = steps * (4.0 * _derivative_cost(model) + (LAW_SAMPLE_COST if law is not None else 0.0) / hold)
    if seconds > PROGRESS_DELAY or (wall_limit is not None and seconds > 0.5 * wall_limit):
        return None
    stride = max(1, round(period / dt))
    try:
        pd = controller if isinstance(controller, JointPD) else None
        run = run_compiled(model, x0[None], dt, steps, hold, stride, pd, limits, external, Progress(False, duration), law)
    except SimulationError:
        return None
    if run is None:
        return None
    times, xs, acts, _, _ = run
    traj = _trajectory(model, times, xs[:, 0], (acts[0][:, 0], acts[1][:, 0], acts[2][:, 0], acts[3][:, 0]))
    try:
        for t, x in zip(times, xs[:, 0], strict=True):
            guard.check(float(t), x)
    except SimulationError:
        return None
    after_run(controller, law)
    return traj
