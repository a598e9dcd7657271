"""One simulation, checked and planned (private): :func:`plan_run` turns the arguments of :func:`freefloat.simulate`
into a :class:`RunPlan`, the one object the run (:func:`._integrate.run`) reads.

:func:`plan_run` makes every check before the run, in the order its errors come: the initial state and the model, the
controller's parameters, the times, the integrator's options, the external wrenches, the joint limits at the initial
angles, then the checks that need the engine (:func:`._prerun.check_run`: the run's estimate and wall-clock budget,
a sampled joint PD's stability, RK4 steps against the joints' damping and friction). Bad input raises before any
step, with the argument's name in the message.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.errors import ShapeError
from ..core.model import Model
from ..core.numbers import tolerance_problem
from ..core.state import ActuatorLimits, State, dissipates, pack_state
from ..core.state_layout import span
from ..core.wheels import wheel_joint_model
from ..mechanics.forces import _engine_wrenches, _wrenches
from ._controller import Command, command_of
from ._guard import DivergenceGuard
from ._prerun import RunChecks, check_run
from ._stops import JointStops
from .pd import JointPD

__all__ = ["METHODS", "PASSIVE", "RunPlan", "engine_wrenches", "integrated_model", "passive_model", "plan_run", "positive"]

#: The adaptive integrators of ``scipy.integrate.solve_ivp`` that ``simulate(method=...)`` accepts.
METHODS = ("DOP853", "RK45", "RK23", "Radau", "BDF", "LSODA")
#: What ``simulate(passive=...)`` and ``rollout(passive=...)`` accept.
PASSIVE = ("model", "ignore")


@dataclass(frozen=True, eq=False)
class RunPlan:
    """Everything one simulation needs, fixed before its first step (:func:`plan_run`).

    The models
        model          what the engine integrates: the user's model, its reaction wheels as joints
                       (:func:`freefloat.core.wheels.wheel_joint_model`; the model itself without wheels), the joints'
                       damping and friction as ``passive`` says
        user           the user's model (``passive`` applied): the controller, the events and the trajectory see it
    The times (s)
        x0             the flat initial state of ``model`` (``core.state_layout``; with the dissipated energy's slot when it
                       integrates it; not modified)
        duration       the run's length
        fixed_step     the RK4 step; None: the adaptive integrator ``method`` (scipy ``solve_ivp``, ``rtol``, ``atol``)
        steps          the number of RK4 steps (``fixed_step`` divides ``duration``; 0 for the adaptive integrator)
        sample_period  the controller's zero-order hold; None: continuous (adaptive) or every step (RK4)
        output_period  the time between recorded states
    The inputs
        controller     the user's controller (or None), for the compiled path and its gains
        command        the controller as the loops call it (:func:`._controller.command_of`: limits applied)
        limits         the actuator limits (:class:`~freefloat.core.state.ActuatorLimits`)
        wrenches       the constant external wrenches in the engine's form (index rows, float rows:
                       :func:`engine_wrenches`)
        events         the user's events, callables (t, state) -> float
    What watches the run
        stops          the joint limits: hard stops or flags (:class:`._stops.JointStops`; it records its impacts)
        guard          the divergence guard and the wall clock (:class:`._guard.DivergenceGuard`)
        checks         what was known before the run (:class:`._prerun.RunChecks`: the estimate, the wall limit)
        progress       the progress mode of :class:`._guard.Progress`
    """

    model: Model
    user: Model
    x0: np.ndarray
    duration: float
    fixed_step: float | None
    steps: int
    sample_period: float | None
    output_period: float
    method: Any
    rtol: float
    atol: float
    controller: Any
    command: Command
    limits: ActuatorLimits
    wrenches: tuple[np.ndarray, np.ndarray]
    events: Sequence[Any]
    stops: JointStops
    guard: DivergenceGuard
    checks: RunChecks
    progress: Any


def plan_run(
    model: Model,
    initial_state: State,
    duration: float,
    controller: Any,
    *,
    method: Any,
    rtol: float,
    atol: float,
    fixed_step: float | None,
    sample_period: float | None,
    output_period: float | None,
    limits: ActuatorLimits | None,
    events: Sequence[Any],
    external: Any,
    progress: Any,
    warn_after: float | None,
    divergence_guard: bool,
    joint_limits: str,
    restitution: float,
    max_wall_time: float | str | None,
    passive: str,
) -> RunPlan:
    """The plan of ``simulate(model, initial_state, duration, controller, **options)`` (the arguments as
    :func:`freefloat.simulate` documents them), after every check (module docstring)."""
    if not isinstance(initial_state, State):
        raise TypeError(f"initial_state: expected a freefloat.State, got {type(initial_state).__name__}")
    user = passive_model(model, passive)
    state = initial_state.resolve(user)
    if np.asarray(state.q).ndim != 1:
        raise ShapeError("initial_state: simulate takes one state; use freefloat.rollout for a batch of states")
    if isinstance(controller, JointPD):  # its gains, references and feed-forward one value per joint, before the run
        controller.check_batch((user.n_joints,))
    duration = positive("duration", duration)
    for name, value in (("fixed_step", fixed_step), ("sample_period", sample_period), ("output_period", output_period)):
        if value is not None:
            positive(name, value)
    if fixed_step is not None and abs(round(duration / fixed_step) * fixed_step - duration) > 1e-9 * duration:
        raise ValueError(f"fixed_step: {fixed_step} does not divide duration {duration}; choose a step that does")
    if fixed_step is None:
        if not (isinstance(method, str) and method in METHODS) and not isinstance(method, type):
            raise ValueError(f"method: unknown integrator {method!r}; choose one of {', '.join(METHODS)} (or pass fixed_step for RK4)")
        for name, value in (("rtol", rtol), ("atol", atol)):
            problem = tolerance_problem(name, positive(name, value))
            if problem is not None:
                raise ValueError(f"{name}: {problem[0]}; {problem[1]}")
    if controller is not None and not callable(controller):
        raise TypeError(f"controller: expected a callable (t, state) -> joint torques or Actuation, got {type(controller).__name__}")
    limits = limits or ActuatorLimits()
    # the controller, the events and the trajectory see the user's model; the engine integrates its reaction wheels as
    # joints (freefloat.core.wheels.wheel_joint_model: the flat state [..., q, wheel angles, qdot, wheel speeds])
    integrated = integrated_model(user, passive)
    wrenches = engine_wrenches(integrated, external)  # a clear error now for bad wrenches
    x0 = pack_state(state, 0.0 if dissipates(integrated) else None)  # with the dissipated energy's slot when there are passive torques
    stops = JointStops(integrated, joint_limits, restitution)
    stops.check_initial(x0[span("q", integrated.n_joints)])
    period = output_period or max(0.01, fixed_step or 0.0)
    checks = check_run(
        integrated, user, x0, controller, duration, fixed_step=fixed_step, sample_period=sample_period,
        output_period=output_period, warn_after=warn_after, wall_time=_wall_time(max_wall_time),
    )  # fmt: skip
    h = sample_period or fixed_step
    n_wheels = user.n_wheels
    pd = controller if not external and not n_wheels else None  # the energy test of a joint PD holds without external wrenches
    what = "controller sample" if sample_period else "RK4 step"
    guard = DivergenceGuard(integrated, x0, min(duration, period), h, what, divergence_guard, pd, checks.wall_limit, duration, n_wheels)
    step = None if fixed_step is None else float(fixed_step)
    return RunPlan(
        model=integrated, user=user, x0=x0, duration=duration, fixed_step=step, steps=0 if step is None else round(duration / step),
        sample_period=sample_period, output_period=period, method=method, rtol=rtol, atol=atol, controller=controller,
        command=command_of(controller, user, integrated, limits), limits=limits, wrenches=wrenches, events=events,
        stops=stops, guard=guard, checks=checks, progress=progress,
    )  # fmt: skip


def passive_model(model: Model, passive: Any) -> Model:
    """The model a run simulates: ``model``, or without its joints' damping and friction for ``passive="ignore"``."""
    if not isinstance(model, Model):
        raise TypeError(f"model: expected a freefloat.Model, got {type(model).__name__}")
    if not isinstance(passive, str) or passive not in PASSIVE:
        raise ValueError(f"passive: {passive!r} is not one of {', '.join(map(repr, PASSIVE))} (the joints' damping and friction)")
    return model if passive == "model" else model.without_passive()


def integrated_model(user: Model, passive: str) -> Model:
    """What the engine integrates for the model ``user`` (``passive`` applied: :func:`passive_model`): its reaction
    wheels as joints (:func:`freefloat.core.wheels.wheel_joint_model`, the wheels' bearing friction their joints'
    damping and friction, dropped with ``passive="ignore"``); ``user`` itself without wheels."""
    return wheel_joint_model(user) if passive == "model" else wheel_joint_model(user).without_passive()


def engine_wrenches(model: Model, external: Any) -> tuple[np.ndarray, np.ndarray]:
    """External wrenches (constant; forces and couples (3,)) as the engine takes them."""
    ext_i, ext_f = _engine_wrenches(model, _wrenches(external))
    if ext_f.ndim != 2:
        raise ShapeError(f"external: a simulation takes constant wrenches (force and torque of shape (3,)), got {ext_f.shape[:-2]} batches")
    return ext_i, ext_f


def _wall_time(max_wall_time: Any) -> float | str | None:
    """``max_wall_time`` checked: "auto", None or a positive number of seconds (:func:`._prerun.check_run` turns
    "auto" into seconds from the run's estimate)."""
    if max_wall_time is None:
        return None
    if isinstance(max_wall_time, str):
        if max_wall_time != "auto":
            raise ValueError(f"max_wall_time: expected seconds, 'auto' or None, got {max_wall_time!r}")
        return "auto"
    return positive("max_wall_time", max_wall_time)


def positive(name: str, value: Any) -> float:
    """``value`` as a positive finite float, or a ValueError naming ``name`` (text and booleans are not numbers here)."""
    if isinstance(value, (str, bytes, bool, np.bool_)):
        raise ValueError(f"{name}: expected a positive number, got {type(value).__name__} {value!r}")
    try:
        out = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected a positive number, got {value!r}") from exc
    if not np.isfinite(out) or out <= 0:
        raise ValueError(f"{name}: must be positive and finite, got {value!r}")
    return out
