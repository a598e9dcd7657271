"""Simulation with controllers in the loop: ``simulate`` (one run) and ``rollout`` (a batch).

The state is integrated in the paper's coordinates (1991 eq. 19): the system
CM position and velocity (inertial), the spacecraft attitude quaternion
[x, y, z, w] with dq/dt = 1/2 q ⊗ [omega0, 0] (omega0 in the spacecraft frame),
omega0, q and qdot. Accelerations come from :func:`freefloat.forward_dynamics`.

Integrators: an adaptive one from scipy (``solve_ivp``, default DOP853 with
tolerances exposed), or fixed-step classical RK4 (``fixed_step=dt``), which is
also what batched rollouts use (scipy has no batched fixed-step integrator).
After each RK4 step the quaternion is renormalised (a projection onto unit
quaternions, of the order of the local truncation error).

A controller is a callable ``controller(t, state) -> joint torques (N,) or
Actuation``. With ``sample_period`` it is sampled and held (zero-order hold);
without it, it is evaluated continuously (adaptive) or once per step (RK4).
"""

from __future__ import annotations

import dataclasses
import os
import warnings
from collections.abc import Callable, Sequence
from typing import Any, overload

import numpy as np

from .. import engine
from ..core.errors import FreefloatError, LongRunWarning, ShapeError, SimulationError
from ..core.model import Model
from ..core.numbers import tolerance_problem
from ..core.resources import require_memory
from ..core.state import Actuation, ActuatorLimits, State, dissipates, pack_state, state_size, unpack_state
from ..core.wheels import wheel_joint_model
from ..engine import actuator_bounds
from ._compiled_runs import PASSIVE as PASSIVE
from ._compiled_runs import after_run, compiled_simulation, law_of, law_rows, passive_model, plant_models
from ._guard import (
    MAX_RATE,
    MIN_WALL_BUDGET,
    PROGRESS_DELAY,
    WALL_BUDGET_FACTOR,
    DivergenceGuard,
    Progress,
    _derivative_cost,
    check_passive_step,
    check_pd_gains,
    estimate_run,
)
from ._integrate import _engine_inputs, _Recorder, _run_adaptive, _run_rk4, _stepper, _trajectory, check_output, plain_torques, zero_thrust
from ._stops import JointStops, limit_violations
from ._wheels import limit_wheel_torque, user_trajectory
from .capture_event import Capture, CaptureRun, simulate_capture
from .pd import JointPD
from .trajectory import Trajectory

__all__ = ["ActuatorLimits", "SimulationError", "rollout", "simulate"]

Controller = Callable[[float, State], Any]

#: The adaptive integrators of ``scipy.integrate.solve_ivp`` that ``simulate(method=...)`` accepts.
METHODS = ("DOP853", "RK45", "RK23", "Radau", "BDF", "LSODA")


_FLOAT64 = np.dtype(np.float64)
_QUIET = zero_thrust(())


def _actuation(model: Model, raw: Any, batch: tuple[int, ...], kernel_checks: bool = False) -> tuple[np.ndarray, ...]:
    """Controller output -> (tau, f_S, n_S) arrays, and the wheel torques last for a model with reaction wheels (zeros
    when not given), with errors that name what is wrong.

    ``kernel_checks``: plain torques (a float64 array of shape (*batch, N)) go through unchecked, because the caller's
    kernel checks them before it steps (the RK4 loop of :func:`simulate`: the engine's ``rk4_steps`` refuses an entry that is
    not finite or beyond MAX_EFFORT, and the loop then names it with :func:`check_output`)."""
    n = model.n_joints
    if (
        raw.__class__ is np.ndarray
        and (raw.dtype is _FLOAT64 or raw.dtype == _FLOAT64)
        and raw.shape == (*batch, n)
        and (kernel_checks or plain_torques(raw))
    ):
        zeros = zero_thrust(batch) if batch else _QUIET  # the fast path of plain torques, finite and in range
        return (raw, zeros, zeros, np.zeros((*batch, model.n_wheels))) if model.wheels else (raw, zeros, zeros)
    if raw is None:
        raise TypeError(f"controller returned None; return joint torques of shape {(*batch, n)} or a freefloat.Actuation")
    if not isinstance(raw, Actuation):
        raw = Actuation(joint_torque=raw)
    if raw.wheel_torque is not None and not model.wheels:
        raise ValueError(f"controller returned wheel torques, but {model.name!r} has no reaction wheels (model.wheels; docs/wheels.md)")
    parts = []
    fields = [
        ("joint_torque", n, f"one torque per joint: {', '.join(model.joint_names) or 'none'}"),
        ("spacecraft_force", 3, "thruster force, spacecraft frame"),
        ("spacecraft_torque", 3, "thruster torque, spacecraft frame"),
    ]
    if model.wheels:
        fields.append(("wheel_torque", model.n_wheels, f"one per wheel: {', '.join(w.name for w in model.wheels)}"))
    for name, size, what in fields:
        value = getattr(raw, name)
        if value is None:
            parts.append(np.zeros((*batch, size)))
            continue
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"controller returned a {name} that is not numbers: {value!r}") from exc
        if arr.shape != (*batch, size):
            raise ShapeError(f"controller returned {name} of shape {arr.shape}; expected {(*batch, size)} ({what})")
        check_output(name, arr)
        parts.append(arr)
    return tuple(parts)


#: What ``simulate(passive=...)`` and ``rollout(passive=...)`` accept.
def _call_controller(
    controller: Controller, model: Model, t: float, x: np.ndarray, batch: tuple[int, ...], kernel_checks: bool = False
) -> tuple[np.ndarray, ...]:
    """Evaluate the controller at (t, x); any failure becomes a SimulationError that says when and what. Returns
    (tau, f_S, n_S), and the wheel torques last for a model with reaction wheels. ``kernel_checks``: see
    :func:`_actuation`."""
    state = unpack_state(model, x)
    norm = np.linalg.norm(state.attitude, axis=-1, keepdims=True)
    if np.any(np.abs(norm - 1.0) > 1e-12):  # an integrator's stage state: its quaternion drifts off unit length
        x = x.copy()
        state = unpack_state(model, x)
        state.attitude[...] /= norm  # the controller sees the attitude the stage stands for (a view into the copy)
    try:
        raw = controller(t, state)
    except Exception as exc:
        raise SimulationError(f"the controller raised {type(exc).__name__} at t = {t:.6g} s: {exc}") from exc
    try:
        return _actuation(model, raw, batch, kernel_checks)
    except (TypeError, ValueError) as exc:
        raise SimulationError(f"bad controller output at t = {t:.6g} s: {exc}") from exc


@overload
def simulate(
    model: Model,
    initial_state: State,
    duration: float,
    controller: Controller | None = None,
    *,
    method: str = "DOP853",
    rtol: float = 1e-10,
    atol: float = 1e-10,
    fixed_step: float | None = None,
    sample_period: float | None = None,
    output_period: float | None = None,
    limits: ActuatorLimits | None = None,
    events: Sequence[Callable[[float, State], float]] = (),
    external: Any = (),
    progress: bool | Callable[[float, float], Any] | None = None,
    warn_after: float | None = 60.0,
    divergence_guard: bool = True,
    joint_limits: str = "stop",
    restitution: float = 0.0,
    max_wall_time: float | str | None = None,
    passive: str = "model",
    capture: None = None,
) -> Trajectory: ...


@overload
def simulate(
    model: Model,
    initial_state: State,
    duration: float,
    controller: Controller | None = None,
    *,
    method: str = "DOP853",
    rtol: float = 1e-10,
    atol: float = 1e-10,
    fixed_step: float | None = None,
    sample_period: float | None = None,
    output_period: float | None = None,
    limits: ActuatorLimits | None = None,
    events: Sequence[Callable[[float, State], float]] = (),
    external: Any = (),
    progress: bool | Callable[[float, float], Any] | None = None,
    warn_after: float | None = 60.0,
    divergence_guard: bool = True,
    joint_limits: str = "stop",
    restitution: float = 0.0,
    max_wall_time: float | str | None = None,
    passive: str = "model",
    capture: Capture,
) -> CaptureRun: ...


def simulate(
    model: Model,
    initial_state: State,
    duration: float,
    controller: Controller | None = None,
    *,
    method: str = "DOP853",
    rtol: float = 1e-10,
    atol: float = 1e-10,
    fixed_step: float | None = None,
    sample_period: float | None = None,
    output_period: float | None = None,
    limits: ActuatorLimits | None = None,
    events: Sequence[Callable[[float, State], float]] = (),
    external: Any = (),
    progress: bool | Callable[[float, float], Any] | None = None,
    warn_after: float | None = 60.0,
    divergence_guard: bool = True,
    joint_limits: str = "stop",
    restitution: float = 0.0,
    max_wall_time: float | str | None = None,
    passive: str = "model",
    capture: Capture | None = None,
) -> Trajectory | CaptureRun:
    """Simulate ``model`` from ``initial_state`` for ``duration`` seconds.

    ``controller(t, state)`` returns joint torques (N,) or an :class:`Actuation`
    (None: free-floating, no actuation). Adaptive integration (scipy
    ``solve_ivp`` with ``method``, ``rtol`` in [2.2e-14, 1) and ``atol`` in
    (0, 1): :data:`freefloat.core.numbers.MIN_RTOL`) unless ``fixed_step``
    (s) selects RK4. ``sample_period`` holds the controller output between
    samples. States are output every ``output_period`` (default 0.01 s, or the
    fixed step if larger). ``events``: callables (t, state) -> float; the run
    stops where one crosses zero (scipy's ``terminal``/``direction`` attributes
    are honoured). ``external``: constant wrenches (:class:`ExternalWrench`).
    The equations of motion (the RK4 steps, or the right-hand side the
    adaptive integrator calls) are the engine's (:mod:`freefloat.engine.calls`):
    runs of RK4 steps between controller samples are one compiled call.

    A failure part-way (controller error, non-finite state, integrator
    failure, divergence) raises :class:`SimulationError` whose ``trajectory``
    holds the states computed up to the failure.

    Joint limits (``model.joint_lower`` / ``joint_upper``): ``joint_limits="stop"``
    (default) makes them hard stops, momentum-conserving joint impulses with
    coefficient of ``restitution`` e in [0, 1] (the rate after = -e x the rate
    before; :mod:`freefloat.simulation._stops`), recorded as impacts in
    ``traj.joint_limit_events``; ``"flag"`` applies no stops and records each
    span of time beyond a limit there instead (``traj.joint_limits_violated``).

    ``passive``: ``"model"`` (default) applies the joints' passive torques the model has (viscous damping and smooth
    Coulomb friction, ``model.joint_damping`` / ``joint_friction``: :func:`freefloat.mechanics.passive_torque`);
    ``"ignore"`` simulates without them (the paper systems have none). The energy they dissipate is
    ``traj.dissipated_energy``: integrated with the state (its rate, the dissipated power, is one more component of the
    integrated state), so it is exact to the integrator's accuracy at every output time, however seldom the run
    records; zeros with ``"ignore"`` or a model without them. Being internal torques, they change no momentum. The rotors' inertia
    (``model.joint_armature``) is inertia, always modelled.

    Runs cannot hang unnoticed:

    - before the run, its steps, samples, outputs and wall time are estimated
      (:func:`freefloat.simulation.estimate_run`); above ``warn_after`` seconds
      (None: never) a :class:`~freefloat.core.errors.LongRunWarning` says so;
    - a :class:`JointPD` sampled every ``sample_period`` (or RK4 step) whose
      gains are unstable on a joint's free-floating effective inertia gets a
      :class:`~freefloat.core.errors.StiffGainsWarning` naming the joint and
      the largest stable gains;
    - ``divergence_guard``: a state growing without bound, a joint rate or spacecraft
      spin beyond what a space robot can mean (:data:`freefloat.simulation._guard.MAX_RATE`),
      or an adaptive step collapsing stops the run with a :class:`SimulationError`
      naming the joint (see :class:`freefloat.simulation._guard.DivergenceGuard`);
    - ``max_wall_time``: the run stops with a :class:`SimulationError` (the trajectory so
      far attached) once it has computed this many seconds; ``"auto"`` is 20 x the estimate
      and at least 60 s (the estimate knows the engine's speed, not a slow Python controller's);
      None (default): no limit;
    - ``progress``: True a bar on stderr, None (default) a bar once the run
      has lasted 2 s, False none, or a callable ``progress(t, duration)``;
    - Ctrl-C (KeyboardInterrupt) returns the trajectory computed so far with
      ``status == "interrupted"``.

    ``capture``: a :class:`~freefloat.simulation.capture_event.Capture` (``ff.Capture``): the grasp of a moving
    target at a time or when the end effector comes within a distance of it; the run then returns a
    :class:`~freefloat.simulation.capture_event.CaptureRun` (both phases, the impact, the target's motion, the
    momentum of robot plus target throughout) instead of a Trajectory (:mod:`freefloat.simulation.capture_event`).
    """
    if capture is not None:
        options = dict(
            method=method, rtol=rtol, atol=atol, fixed_step=fixed_step, sample_period=sample_period, output_period=output_period,
            limits=limits, events=events, external=external, progress=progress, warn_after=warn_after,
            divergence_guard=divergence_guard, joint_limits=joint_limits, restitution=restitution, max_wall_time=max_wall_time,
            passive=passive,
        )  # fmt: skip
        return simulate_capture(simulate, model, initial_state, _positive("duration", duration), controller, capture, options)
    if not isinstance(initial_state, State):
        raise TypeError(f"initial_state: expected a freefloat.State, got {type(initial_state).__name__}")
    model = passive_model(model, passive)
    state = initial_state.resolve(model)
    if np.asarray(state.q).ndim != 1:
        raise ShapeError("initial_state: simulate takes one state; use freefloat.rollout for a batch of states")
    if isinstance(controller, JointPD):  # its gains, references and feed-forward one value per joint, before the run
        controller.check_batch((model.n_joints,))
    duration = _positive("duration", duration)
    for name, value in (("fixed_step", fixed_step), ("sample_period", sample_period), ("output_period", output_period)):
        if value is not None:
            _positive(name, value)
    if fixed_step is not None and abs(round(duration / fixed_step) * fixed_step - duration) > 1e-9 * duration:
        raise ValueError(f"fixed_step: {fixed_step} does not divide duration {duration}; choose a step that does")
    if fixed_step is None:
        if not (isinstance(method, str) and method in METHODS) and not isinstance(method, type):
            raise ValueError(f"method: unknown integrator {method!r}; choose one of {', '.join(METHODS)} (or pass fixed_step for RK4)")
        for name, value in (("rtol", rtol), ("atol", atol)):
            problem = tolerance_problem(name, _positive(name, value))
            if problem is not None:
                raise ValueError(f"{name}: {problem[0]}; {problem[1]}")
    if controller is not None and not callable(controller):
        raise TypeError(f"controller: expected a callable (t, state) -> joint torques or Actuation, got {type(controller).__name__}")
    limits = limits or ActuatorLimits()
    # the controller, the events and the trajectory see the user's model; the engine integrates its reaction wheels as
    # joints (freefloat.core.wheels.wheel_joint_model: the flat state [..., q, wheel angles, qdot, wheel speeds])
    user, n_wheels = model, model.n_wheels
    model = wheel_joint_model(user) if passive == "model" else wheel_joint_model(user).without_passive()
    _engine_inputs(model, external)  # a clear error now for bad wrenches
    x0 = pack_state(state, 0.0 if dissipates(model) else None)  # with the dissipated energy's slot when there are passive torques
    q0 = x0[13 : 13 + model.n_joints]
    stops = JointStops(model, joint_limits, restitution)
    stops.check_initial(q0)
    period = output_period or max(0.01, fixed_step or 0.0)
    rec = _Recorder(model)
    zero = (np.zeros(model.n_joints), np.zeros(3), np.zeros(3))
    unlimited = np.zeros(1 + 2 * n_wheels, dtype=bool) if n_wheels else np.array(False)
    speeds = slice(13 + 2 * model.n_joints - n_wheels, 13 + 2 * model.n_joints)

    clips = not limits.unlimited
    # the compiled step may check plain torques only where they reach it unchanged: clipping would make an inf or a huge
    # torque finite (np.clip), and a model's wheel torques are limited and joined to them in Python
    unchanged = not clips and not n_wheels

    def command(t: float, x: np.ndarray, kernel_checks: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        if controller is None:
            return (*zero, unlimited)
        parts = _call_controller(controller, user, t, x, (), kernel_checks and unchanged)
        if not n_wheels:
            return limits.apply(*parts) if clips else (parts[0], parts[1], parts[2], unlimited)
        tau, force, torque, saturated = limits.apply(*parts[:3])
        wheel, torque_limited, speed_limited = limit_wheel_torque(user, parts[3], x[speeds])
        flags = np.concatenate([[bool(saturated) or torque_limited.any() or speed_limited.any()], torque_limited, speed_limited])
        return np.concatenate([tau, wheel]), force, torque, flags

    def finish(traj: Trajectory) -> Trajectory:
        traj = _with_limits(traj, stops)
        return user_trajectory(user, traj) if n_wheels else traj

    estimate = estimate_run(model, duration, fixed_step=fixed_step, sample_period=sample_period, output_period=output_period)
    wall_limit = _wall_limit(max_wall_time, estimate.seconds)
    if warn_after is not None:
        if estimate.seconds > warn_after:
            warnings.warn(
                f"this simulation will take long: {estimate.describe()} (over warn_after = {warn_after:g} s); "
                "it shows progress and Ctrl-C returns what was computed",
                LongRunWarning,
                stacklevel=2,
            )
    h = sample_period or fixed_step
    check_pd_gains(user, controller, np.asarray(state.q, dtype=float), h)
    check_passive_step(model, q0, fixed_step)
    pd = controller if not external and not n_wheels else None  # the energy test of a joint PD holds without external wrenches
    what = "controller sample" if sample_period else "RK4 step"
    guard = DivergenceGuard(model, x0, min(duration, period), h, what, divergence_guard, pd, wall_limit, duration, n_wheels)
    if (
        fixed_step is not None and not events and not stops.active and not n_wheels
    ):  # the controller inside the compiled loop, when it can be
        compiled = compiled_simulation(
            model, x0, duration, float(fixed_step), sample_period, period, controller, limits, external, guard, wall_limit, _rollout_pd
        )
        if compiled is not None:
            return _with_limits(compiled, stops)
    bar = Progress(progress, duration)
    try:
        guard.check(0.0, x0)  # an initial rate beyond meaning: stopped now, named (its first step would be non-finite)
        if fixed_step is not None:
            status = _run_rk4(
                model, x0, duration, float(fixed_step), sample_period, period, command, events, external, rec, bar, guard, stops, user
            )
        else:
            status = _run_adaptive(
                model, x0, duration, method, rtol, atol, sample_period, period, command, events, external, rec, bar, guard, stops, user
            )
    except KeyboardInterrupt:
        t_stop = rec.t[-1] if rec.t else 0.0
        return finish(rec.trajectory("interrupted", f"interrupted (Ctrl-C) after t = {t_stop:.6g} s of {duration:g} s"))
    except SimulationError as exc:
        exc.trajectory = finish(rec.trajectory("failed", str(exc)))
        raise
    except (FreefloatError, ValueError, ArithmeticError, RuntimeError, TypeError, KeyError, IndexError) as exc:
        t_fail = rec.t[-1] if rec.t else 0.0
        message = f"simulation failed after t = {t_fail:.6g} s: {type(exc).__name__}: {exc}"
        raise SimulationError(message, finish(rec.trajectory("failed", message))) from exc
    finally:
        bar.close()
    return finish(rec.trajectory(*status))


def _with_limits(traj: Trajectory, stops: JointStops) -> Trajectory:
    """The trajectory with its joint-limit events: the stops' impacts, or (stops off) the spans beyond a limit."""
    found = stops.events if stops.active else (limit_violations(stops.model, traj.t, traj.q) if len(traj) else [])
    return dataclasses.replace(traj, joint_limit_events=tuple(found)) if found else traj


def _wall_limit(max_wall_time: Any, estimate: float) -> float | None:
    """The wall-clock budget (s) of ``max_wall_time``: "auto", None or a positive number of seconds."""
    if max_wall_time is None:
        return None
    if isinstance(max_wall_time, str):
        if max_wall_time != "auto":
            raise ValueError(f"max_wall_time: expected seconds, 'auto' or None, got {max_wall_time!r}")
        return max(MIN_WALL_BUDGET, WALL_BUDGET_FACTOR * estimate)
    return _positive("max_wall_time", max_wall_time)


def _positive(name: str, value: Any) -> float:
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


def _batch_shape(initial_states: Any, model: Model) -> tuple[int]:
    """The batch (B,) of a rollout's initial states, from the shapes of their fields (no field is copied or resolved
    yet: a rollout too large for memory is refused before it makes anything per trajectory). Errors name
    ``initial_states``: not a State, not one leading batch axis. An empty batch (B = 0) is a batch: the rollout gives
    an empty result, as every batched call does (J* of 0 configurations is (0, 6E, N))."""
    if not isinstance(initial_states, State):
        raise TypeError(
            f"initial_states: expected a freefloat.State whose fields have a leading batch axis, got {type(initial_states).__name__}"
        )
    values = (getattr(initial_states, f.name) for f in dataclasses.fields(State))
    shapes = [np.shape(value)[:-1] for value in values if value is not None]
    try:
        batch = np.broadcast_shapes(*shapes) if shapes else ()
    except ValueError:
        initial_states.resolve(model)  # raises the State's own error, naming the fields and their shapes
        raise
    if len(batch) != 1:
        size = state_size(model) + dissipates(model)
        raise ShapeError(f"initial_states: expected fields with one leading batch axis (B, ...), got a state of shape {(*batch, size)}")
    return (int(batch[0]),)


def rollout(
    model: Model,
    initial_states: State,
    duration: float,
    *,
    dt: float,
    controller: Controller | None = None,
    sample_period: float | None = None,
    output_period: float | None = None,
    limits: ActuatorLimits | None = None,
    external: Any = (),
    progress: bool | Callable[[float, float], Any] | None = None,
    passive: str = "model",
) -> Trajectory:
    """Simulate a batch of initial states at once with fixed-step RK4.

    ``initial_states`` is a :class:`State` whose fields have a leading batch
    axis B (fields may broadcast). ``controller(t, states)`` sees the whole
    batch (fields (B, ...)) and returns batched torques (B, N) or an
    :class:`Actuation` of batched arrays; per-trajectory controller parameters
    are arrays of length B that the controller closes over. Returns a
    :class:`Trajectory` whose arrays are (T, B, ...).

    The RK4 steps of the whole batch run on the engine with the trajectories
    on numba's threads; a controller that is None or a
    :class:`freefloat.simulation.pd.JointPD` (gains per trajectory, open-loop
    feed-forward) runs compiled too, with no Python per step (one call for
    the whole rollout).

    Rollouts apply no joint stops: each span of a trajectory beyond a joint
    limit is recorded in ``joint_limit_events`` (``kind == "violation"``,
    with the ``trajectory`` index).

    ``passive`` as in :func:`simulate` (the joints' damping and friction: ``"model"`` or ``"ignore"``).

    ``progress`` as in :func:`simulate` (a bar once the run has lasted 2 s, True, False, or a
    callable ``progress(t, duration)``; for a compiled rollout, t is the duration times the
    fraction of trajectories finished). Ctrl-C returns what was computed, with status
    ``"interrupted"``: the finished trajectories of a compiled rollout (in chunks of
    trajectories), or every trajectory up to the last step of a Python-controlled one.
    """
    model, plant = plant_models(model, passive)
    batch = _batch_shape(initial_states, model)  # from the fields' shapes: nothing per trajectory is made before the checks
    if plant.shape[0] not in (1, batch[0]):
        raise ShapeError(f"model: {plant.shape[0]} per-trajectory models, but initial_states has {batch[0]} trajectories")
    limits = limits or ActuatorLimits()
    duration, dt = _positive("duration", duration), _positive("dt", dt)
    steps = round(float(duration) / dt)
    if steps <= 0 or abs(steps * dt - duration) > 1e-9 * duration:
        raise ValueError(f"dt: {dt} must divide duration {duration}")
    for name, value in (("sample_period", sample_period), ("output_period", output_period)):
        if value is not None:
            period = _positive(name, value)
            if period < dt * (1 - 1e-9) or abs(period / dt - round(period / dt)) > 1e-6:
                raise ValueError(f"{name}: {value} s must be a whole multiple of dt = {dt} s")
    hold = round((sample_period or dt) / dt)
    stride = max(1, round((output_period or dt) / dt))
    outputs = steps // stride + 2
    size = state_size(model) + dissipates(model)  # the flat state, with the dissipated energy's slot when there are passive torques
    require_memory(  # the recorded times, and the states and actuation of every trajectory
        float(outputs) * (1 + batch[0] * (size + model.n_joints + 7)) * 8,
        f"a rollout of {batch[0]} trajectories x {outputs} recorded states",
        "record fewer states (a longer output_period), run fewer trajectories per call, or a shorter duration",
    )
    state = initial_states.resolve(model)
    x = pack_state(state, 0.0 if dissipates(model) else None)
    if isinstance(controller, JointPD):
        controller.check_batch((*batch, model.n_joints))
    if batch[0] == 0:  # every check passed: the empty result, (T, 0, ...) at the times a run would record
        times = _output_times(dt, steps, stride)
        none = (np.zeros((times.size, 0, model.n_joints)), np.zeros((times.size, 0, 3)), np.zeros((times.size, 0, 3)))
        return _trajectory(model, times, np.zeros((times.size, 0, size)), (*none, np.zeros((times.size, 0), dtype=bool)))
    check_passive_step(model, x[0, 13 : 13 + model.n_joints], dt)  # at the first trajectory's angles
    zero = (np.zeros((*batch, model.n_joints)), np.zeros((*batch, 3)), np.zeros((*batch, 3)))

    def command(t: float, xx: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        if controller is None:
            return (*zero, np.zeros(batch, dtype=bool))
        return limits.apply(*_call_controller(controller, model, t, xx, batch))

    rec = _Recorder(model)
    bar = Progress(progress, float(duration))
    try:
        law = law_of(controller, batch[0])
        if controller is None or isinstance(controller, JointPD) or law is not None:
            pd = controller if isinstance(controller, JointPD) else None
            compiled = _rollout_pd(model, x, dt, steps, hold, stride, pd, limits, external, bar, law, plant)
            after_run(controller, law)
            if compiled is not None:
                times, xs, acts, status, message = compiled
                return _batch_limits(_trajectory(model, times, xs, acts, status, message, copy=False))  # quaternions kept unit
        if plant.shape[0] > 1:
            raise ValueError(
                "model: per-trajectory models run with the compiled controllers only (the built-in ones: JointPD, "
                "ff.control's TransposedJacobianController, OperationalSpaceController, Detumble); give this controller one model"
            )
        step = _stepper(model, dt, external)
        act = command(0.0, x)
        rec.add(0.0, x, act)
        try:
            n = model.n_joints
            for i in range(1, steps + 1):
                tau, force, torque, _ = act
                x = step(x, tau, force, torque)
                with np.errstate(invalid="ignore"):
                    rates = np.concatenate([x[:, 10:13], x[:, 13 + n : 13 + 2 * n]], axis=-1)  # omega0 and qdot
                    bad = ~(np.abs(rates) <= MAX_RATE).all(axis=-1) | ~np.isfinite(x[:, : 13 + n]).all(axis=-1)
                if bad.any():  # the divergence guard of simulate: a non-finite state, or a rate beyond what the model can mean
                    first = int(np.argmax(bad))
                    rec.add(i * dt, x, act)
                    message = (
                        f"trajectory {first} of the rollout became non-finite or moves beyond {MAX_RATE:g} rad/s at t = {i * dt:.6g} s: "
                        "the controller's output (or the initial state) is not physical, or the step too long"
                    )
                    raise SimulationError(message, _batch_limits(rec.trajectory("failed", message)))
                if i % hold == 0 and i < steps:
                    act = command(i * dt, x)
                if i % stride == 0 or i == steps:
                    rec.add(i * dt, x, act)
                bar.update(i * dt)
        except KeyboardInterrupt:
            if rec.t[-1] != i * dt:
                rec.add(i * dt, x, act)
            return _batch_limits(rec.trajectory("interrupted", f"interrupted (Ctrl-C) at t = {i * dt:.6g} s"))
        return _batch_limits(rec.trajectory())
    finally:
        bar.close()


rollout.takes_model_sequences = True  # type: ignore[attr-defined]  # ff.rollout(models, ...): one model per trajectory


#: A compiled rollout of more trajectories than this runs in chunks (progress, Ctrl-C) of at least this many.
ROLLOUT_CHUNK_MIN = 64
#: How much faster the kernels specialised to a structure run rollouts (measured 4-8x, docs/performance.md): for the estimate.
SPECIALISED_SPEEDUP = 5.0


def _batch_limits(traj: Trajectory) -> Trajectory:
    """A rollout's joint-limit violations (rollouts apply no stops), each with its trajectory index."""
    model = traj.model
    if model is None or not len(traj):
        return traj
    found = limit_violations(model, traj.t, traj.q)
    return dataclasses.replace(traj, joint_limit_events=tuple(found)) if found else traj


def _output_times(dt: float, steps: int, stride: int) -> np.ndarray:
    """The times a rollout of ``steps`` steps of ``dt`` records: t = 0, every ``stride``-th step and the last."""
    k = np.arange(0, steps + 1, stride)
    return (k if k[-1] == steps else np.append(k, steps)) * dt


def _rollout_pd(
    model: Model,
    x0: np.ndarray,
    dt: float,
    steps: int,
    hold: int,
    stride: int,
    controller: JointPD | None,
    limits: ActuatorLimits,
    external: Any,
    bar: Progress,
    law: Any = None,
    plant: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray], str, str] | None:
    """A whole batched rollout with a joint PD (or none) or a control law (``law``: a built-in controller's
    ``compiled_law``), compiled, in chunks of trajectories, on the mass properties ``plant`` (the floats of 1 or B
    payload variants of ``model``: :func:`~._compiled_runs.plant_models`; None: the model's).

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
    ext = _engine_inputs(model, external)
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
    times = _output_times(dt, steps, stride)
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
