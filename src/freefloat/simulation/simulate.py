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

One call of :func:`simulate` goes down once: :func:`._plan.plan_run` checks the arguments and makes the run's
:class:`~._plan.RunPlan` (with the pre-run checks that need the engine, :func:`._prerun.check_run`), and
:func:`._integrate.run` runs it (compiled, RK4 or adaptive) on the engine; with ``capture`` the two phases of
:func:`.capture_event.simulate_capture` are two such runs.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any, overload

import numpy as np

from ..core.errors import ShapeError, SimulationError
from ..core.model import Model
from ..core.resources import require_memory
from ..core.state import ActuatorLimits, State, dissipates, pack_state, state_size
from ..core.state_layout import span
from ._compiled_runs import after_run, compiled_rollout, law_of, output_times, plant_models
from ._controller import Controller, command_of
from ._guard import MAX_RATE, Progress
from ._integrate import _stepper, run
from ._plan import METHODS as METHODS
from ._plan import PASSIVE as PASSIVE
from ._plan import engine_wrenches, plan_run, positive
from ._prerun import check_passive_step
from ._record import _Recorder, _trajectory
from ._stops import with_violations
from ._wheels import user_trajectory
from .capture_event import Capture, CaptureRun, simulate_capture
from .pd import JointPD
from .trajectory import Trajectory

__all__ = ["ActuatorLimits", "SimulationError", "rollout", "simulate"]


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
    options = dict(
        method=method, rtol=rtol, atol=atol, fixed_step=fixed_step, sample_period=sample_period, output_period=output_period,
        limits=limits, events=events, external=external, progress=progress, warn_after=warn_after,
        divergence_guard=divergence_guard, joint_limits=joint_limits, restitution=restitution, max_wall_time=max_wall_time,
        passive=passive,
    )  # fmt: skip
    if capture is not None:
        return simulate_capture(model, initial_state, duration, controller, capture, **options)
    return run(plan_run(model, initial_state, duration, controller, **options))


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

    ``model`` may be a sequence of B models, one per trajectory: payload variants of one robot, or the same reaction
    wheels with other inertias, limits or friction (their number and axes the same); those run with the compiled
    controllers. A model with reaction wheels runs as in :func:`simulate` (``State.wheel_speed`` per trajectory, the
    wheels' limits and bearing friction; the trajectory's wheel arrays (T, B, W)), compiled with the built-in
    controllers (``torque_by="wheels"`` included) and a ``JointPD`` (which drives no wheel).

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
    user, model, plant, wheels, passive_torques = plant_models(model, passive)  # model: what the engine integrates (wheels as joints)
    batch = _batch_shape(initial_states, user)  # from the fields' shapes: nothing per trajectory is made before the checks
    if plant.shape[0] not in (1, batch[0]):
        raise ShapeError(f"model: {plant.shape[0]} per-trajectory models, but initial_states has {batch[0]} trajectories")
    limits = limits or ActuatorLimits()
    duration, dt = positive("duration", duration), positive("dt", dt)
    steps = round(float(duration) / dt)
    if steps <= 0 or abs(steps * dt - duration) > 1e-9 * duration:
        raise ValueError(f"dt: {dt} must divide duration {duration}")
    for name, value in (("sample_period", sample_period), ("output_period", output_period)):
        if value is not None:
            period = positive(name, value)
            if period < dt * (1 - 1e-9) or abs(period / dt - round(period / dt)) > 1e-6:
                raise ValueError(f"{name}: {value} s must be a whole multiple of dt = {dt} s")
    hold = round((sample_period or dt) / dt)
    stride = max(1, round((output_period or dt) / dt))
    outputs = steps // stride + 2
    size = state_size(model) + passive_torques  # the flat state, with the dissipated energy's slot when there are passive torques
    require_memory(  # the recorded times, and the states and actuation of every trajectory
        float(outputs) * (1 + batch[0] * (size + model.n_joints + 7)) * 8,
        f"a rollout of {batch[0]} trajectories x {outputs} recorded states",
        "record fewer states (a longer output_period), run fewer trajectories per call, or a shorter duration",
    )
    state = initial_states.resolve(user)
    x = pack_state(state, 0.0 if passive_torques else None)
    if isinstance(controller, JointPD):
        controller.check_batch((*batch, user.n_joints))

    def users(traj: Trajectory) -> Trajectory:
        """The user's trajectory: the reaction wheels apart from the joints, and the joint-limit violations."""
        return with_violations(user_trajectory(user, traj) if user.wheels else traj)

    if batch[0] == 0:  # every check passed: the empty result, (T, 0, ...) at the times a run would record
        times = output_times(dt, steps, stride)
        none = (np.zeros((times.size, 0, model.n_joints)), np.zeros((times.size, 0, 3)), np.zeros((times.size, 0, 3)))
        flags = np.zeros((times.size, 0, *((1 + 2 * user.n_wheels,) if user.wheels else ())), dtype=bool)
        return users(_trajectory(model, times, np.zeros((times.size, 0, size)), (*none, flags)))
    check_passive_step(model, x[0, span("q", model.n_joints)], dt)  # at the first trajectory's angles
    command = command_of(controller, user, model, limits, batch)
    rec = _Recorder(model)
    bar = Progress(progress, float(duration))
    try:
        law = law_of(controller, batch[0])
        if controller is None or isinstance(controller, JointPD) or law is not None:
            pd = controller if isinstance(controller, JointPD) else None
            ext = engine_wrenches(model, external)
            compiled = compiled_rollout(model, x, dt, steps, hold, stride, pd, limits, ext, bar, law, plant, user, wheels)
            after_run(controller, law)
            if compiled is not None:
                times, xs, acts, status, message = compiled
                return users(_trajectory(model, times, xs, acts, status, message, copy=False))  # quaternions kept unit
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
                    rates = np.concatenate([x[:, span("omega", n)], x[:, span("qdot", n)]], axis=-1)  # omega0 and qdot
                    bad = ~(np.abs(rates) <= MAX_RATE).all(axis=-1) | ~np.isfinite(x[:, : span("q", n).stop]).all(axis=-1)
                if bad.any():  # the divergence guard of simulate: a non-finite state, or a rate beyond what the model can mean
                    first = int(np.argmax(bad))
                    rec.add(i * dt, x, act)
                    message = (
                        f"trajectory {first} of the rollout became non-finite or moves beyond {MAX_RATE:g} rad/s at t = {i * dt:.6g} s: "
                        "the controller's output (or the initial state) is not physical, or the step too long"
                    )
                    raise SimulationError(message, users(rec.trajectory("failed", message)))
                if i % hold == 0 and i < steps:
                    act = command(i * dt, x)
                if i % stride == 0 or i == steps:
                    rec.add(i * dt, x, act)
                bar.update(i * dt)
        except KeyboardInterrupt:
            if rec.t[-1] != i * dt:
                rec.add(i * dt, x, act)
            return users(rec.trajectory("interrupted", f"interrupted (Ctrl-C) at t = {i * dt:.6g} s"))
        return users(rec.trajectory())
    finally:
        bar.close()


rollout.takes_model_sequences = True  # type: ignore[attr-defined]  # ff.rollout(models, ...): one model per trajectory
