"""Simulation with controllers in the loop: ``simulate`` (one run) and ``rollout`` (a batch).

The state is integrated in the paper's coordinates (1991 eq. 19): the system
CM position and velocity (inertial), the spacecraft attitude quaternion
[x, y, z, w] with dq/dt = 1/2 q ⊗ [omega0, 0] (omega0 in the spacecraft frame),
omega0, q and qdot. Accelerations come from :func:`freeflyer.forward_dynamics`.

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

import itertools
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from . import _batch, _compiled
from .dynamics import forward_dynamics
from .errors import FreeflyerError, ShapeError
from .model import Model
from .pd import JointPD
from .state import Actuation, State, pack_state, unpack_state
from .trajectory import Trajectory

__all__ = ["ActuatorLimits", "SimulationError", "rollout", "simulate"]

Controller = Callable[[float, State], Any]

#: The adaptive integrators of ``scipy.integrate.solve_ivp`` that ``simulate(method=...)`` accepts.
METHODS = ("DOP853", "RK45", "RK23", "Radau", "BDF", "LSODA")


class SimulationError(FreeflyerError, RuntimeError):
    """A simulation failed part-way; ``trajectory`` holds what was computed up to the failure."""

    def __init__(self, message: str, trajectory: Trajectory | None = None) -> None:
        super().__init__(message)
        self.trajectory = trajectory


_NOT_SATURATED = np.array(False)
_NOT_SATURATED.flags.writeable = False


@dataclass(frozen=True)
class ActuatorLimits:
    """Symmetric actuator limits: each component is saturated to [-limit, +limit].

    ``joint_torque`` (scalar or (N,), N m), ``spacecraft_force`` (scalar or (3,),
    N, spacecraft frame), ``spacecraft_torque`` (scalar or (3,), N m). ``None``
    means unlimited. Saturation is recorded in ``Trajectory.saturated``.
    """

    joint_torque: Any = None
    spacecraft_force: Any = None
    spacecraft_torque: Any = None

    def __post_init__(self) -> None:
        for name in ("joint_torque", "spacecraft_force", "spacecraft_torque"):
            limit = getattr(self, name)
            if limit is None:
                continue
            try:
                lim = np.asarray(limit, dtype=float)
            except (TypeError, ValueError) as exc:
                raise ValueError(f"ActuatorLimits.{name}: expected a positive number or an array of them, got {limit!r}") from exc
            if lim.ndim > 1 or np.any(~np.isfinite(lim)) or np.any(lim <= 0):
                raise ValueError(
                    f"ActuatorLimits.{name}: every limit must be positive and finite (a scalar or one per component), got {limit!r}"
                )

    def apply(self, tau: np.ndarray, force: np.ndarray, torque: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        if self.joint_torque is None and self.spacecraft_force is None and self.spacecraft_torque is None:
            return tau, force, torque, _NOT_SATURATED if tau.ndim == 1 else np.zeros(tau.shape[:-1], dtype=bool)
        saturated = np.zeros(tau.shape[:-1], dtype=bool)
        out = []
        for value, limit, name in (
            (tau, self.joint_torque, "joint_torque"),
            (force, self.spacecraft_force, "spacecraft_force"),
            (torque, self.spacecraft_torque, "spacecraft_torque"),
        ):
            if limit is None:
                out.append(value)
                continue
            lim = np.asarray(limit, dtype=float)
            if np.any(lim <= 0) or not np.all(np.isfinite(lim)):
                raise ValueError(f"limits.{name}: every limit must be positive and finite, got {limit!r}")
            clipped = np.clip(value, -lim, lim)
            saturated |= np.any(clipped != value, axis=-1)
            out.append(clipped)
        return out[0], out[1], out[2], saturated


def _actuation(model: Model, raw: Any, batch: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Controller output -> (tau, f_S, n_S) arrays, with errors that name what is wrong."""
    n = model.n_joints
    if raw is None:
        raise TypeError(f"controller returned None; return joint torques of shape {(*batch, n)} or a freeflyer.Actuation")
    if isinstance(raw, np.ndarray) and raw.shape == (*batch, n) and raw.dtype == np.float64:
        total = float(raw.dot(raw)) if raw.ndim == 1 else float(raw.sum())
        if total - total == 0.0:  # finite (NaN and inf propagate): the fast path of plain torques
            zeros = _zeros(batch)
            return raw, zeros, zeros
    if not isinstance(raw, Actuation):
        raw = Actuation(joint_torque=raw)
    parts = []
    for name, size, what in (
        ("joint_torque", n, f"one torque per joint: {', '.join(model.joint_names) or 'none'}"),
        ("spacecraft_force", 3, "thruster force, spacecraft frame"),
        ("spacecraft_torque", 3, "thruster torque, spacecraft frame"),
    ):
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
        if not np.isfinite(arr).all():
            raise ValueError(f"controller returned a non-finite {name}: {arr}")
        parts.append(arr)
    return parts[0], parts[1], parts[2]


_ZEROS: dict[tuple[int, ...], np.ndarray] = {}


def _zeros(batch: tuple[int, ...]) -> np.ndarray:
    """A shared read-only zero thrust (batch, 3)."""
    if batch not in _ZEROS:
        zeros = np.zeros((*batch, 3))
        zeros.flags.writeable = False
        _ZEROS[batch] = zeros
    return _ZEROS[batch]


def _call_controller(controller: Controller, model: Model, t: float, x: np.ndarray, batch: tuple[int, ...]) -> tuple[np.ndarray, ...]:
    """Evaluate the controller at (t, x); any failure becomes a SimulationError that says when and what."""
    try:
        raw = controller(t, unpack_state(model, x))
    except Exception as exc:
        raise SimulationError(f"the controller raised {type(exc).__name__} at t = {t:.6g} s: {exc}") from exc
    try:
        return _actuation(model, raw, batch)
    except (TypeError, ValueError) as exc:
        raise SimulationError(f"bad controller output at t = {t:.6g} s: {exc}") from exc


def _derivative(model: Model, x: np.ndarray, tau: np.ndarray, force: np.ndarray, torque: np.ndarray, external: Any) -> np.ndarray:
    n = model.n_joints
    quat = x[..., 6:10] / np.linalg.norm(x[..., 6:10], axis=-1, keepdims=True)
    omega = x[..., 10:13]
    q, qdot = x[..., 13 : 13 + n], x[..., 13 + n :]
    velocity = np.concatenate([x[..., 3:6], omega, qdot], axis=-1)
    acc = forward_dynamics(model, q, velocity, tau, spacecraft_force=force, spacecraft_torque=torque, attitude=quat, external=external)
    vec, w = quat[..., 0:3], quat[..., 3:4]
    dquat = 0.5 * np.concatenate([w * omega + np.cross(vec, omega), -np.sum(vec * omega, axis=-1, keepdims=True)], axis=-1)
    return np.concatenate([x[..., 3:6], acc[..., 0:3], dquat, acc[..., 3:6], qdot, acc[..., 6:]], axis=-1)


def _rhs(model: Model, external: Any, backend: str) -> Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray]:
    """The state derivative ``f(x, tau, force, torque)`` of one state: compiled (numba) or the numpy reference."""
    if not _compiled.use_compiled(backend, external):
        return partial(_derivative, model, external=external)
    kernels = _compiled.kernels(model)
    run = kernels.module.deriv_blocks
    n = model.n_joints

    def compiled(x: np.ndarray, tau: np.ndarray, force: np.ndarray, torque: np.ndarray) -> np.ndarray:
        if not np.abs(x[13 : 13 + n]).max(initial=0.0) <= _batch._MAX_TABLE_ANGLE:
            return _derivative(model, x, tau, force, torque, external)  # beyond the sin/cos table (or NaN): the reference path
        u = np.concatenate([tau, force, torque])[None]
        out = np.empty((1, x.shape[-1]))
        run(0, 1, np.ascontiguousarray(x, dtype=float)[None], u, out)
        return out[0]

    return compiled


def _rk4_step(f: Callable[[np.ndarray], np.ndarray], x: np.ndarray, dt: float) -> np.ndarray:
    k1 = f(x)
    k2 = f(x + 0.5 * dt * k1)
    k3 = f(x + 0.5 * dt * k2)
    k4 = f(x + dt * k3)
    out = x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    out[..., 6:10] /= np.linalg.norm(out[..., 6:10], axis=-1, keepdims=True)
    return out


def _stepper(model: Model, dt: float, external: Any, backend: str) -> Callable[..., np.ndarray]:
    """One RK4 step ``step(x, tau, force, torque) -> new x``: compiled (numba) or the numpy reference."""
    if _compiled.use_compiled(backend, external):
        kernels = _compiled.kernels(model)

        n = model.n_joints
        single = kernels.module.steps_single

        def compiled_step(x: np.ndarray, tau: np.ndarray, force: np.ndarray, torque: np.ndarray) -> np.ndarray:
            out = np.array(x, dtype=float, order="C")
            u = np.empty((*x.shape[:-1], n + 6))
            u[..., :n], u[..., n : n + 3], u[..., n + 3 :] = tau, force, torque
            if out.ndim == 1:
                single(out, u, dt, 1)
            else:
                kernels.steps_batch(out, u, dt, 1)
            return out

        return compiled_step

    def numpy_step(x: np.ndarray, tau: np.ndarray, force: np.ndarray, torque: np.ndarray) -> np.ndarray:
        return _rk4_step(partial(_derivative, model, tau=tau, force=force, torque=torque, external=external), x, dt)

    return numpy_step


class _Recorder:
    def __init__(self, model: Model) -> None:
        self.model = model
        self.t: list[float] = []
        self.x: list[np.ndarray] = []
        self.act: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []

    def add(self, t: float, x: np.ndarray, act: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]) -> None:
        self.t.append(float(t))
        x = x.copy()
        x[..., 6:10] /= np.linalg.norm(x[..., 6:10], axis=-1, keepdims=True)
        self.x.append(x)
        self.act.append(act)

    def trajectory(self, status: str = "finished", message: str = "") -> Trajectory:
        model = self.model
        n = model.n_joints
        if self.x:
            xs = np.stack(self.x)
            acts = [np.stack([a[i] for a in self.act]) for i in range(4)]
        else:
            xs = np.zeros((0, 13 + 2 * n))
            acts = [np.zeros((0, n)), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0,), dtype=bool)]
        return _trajectory(model, np.asarray(self.t), xs, (acts[0], acts[1], acts[2], acts[3]), status, message)


def _trajectory(
    model: Model,
    t: np.ndarray,
    xs: np.ndarray,
    acts: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    status: str = "finished",
    message: str = "",
    *,
    copy: bool = True,
) -> Trajectory:
    """A Trajectory from stacked flat states xs (T, ..., S) and actuation.

    ``copy=False`` keeps the fields as views of ``xs`` (for the large arrays of
    batched rollouts, which nothing else holds); otherwise each field gets its own array.
    """
    s = unpack_state(model, xs)
    own = np.array if copy else np.asarray
    return Trajectory(
        t=t,
        q=own(s.q),
        qdot=own(s.qdot),
        omega=own(s.omega),
        attitude=own(s.attitude),
        r_cm=own(s.r_cm),
        v_cm=own(s.v_cm),
        joint_torque=own(acts[0]),
        spacecraft_force=own(acts[1]),
        spacecraft_torque=own(acts[2]),
        saturated=own(acts[3]),
        status=status,
        message=message,
        model_name=model.name,
        model=model,
    )


def _progress(enabled: bool, duration: float) -> Any:
    if not enabled:
        return None
    from rich.console import Console
    from rich.progress import Progress

    bar = Progress(console=Console(stderr=True), transient=True)
    bar.start()
    bar.add_task("simulating", total=duration)
    return bar


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
    progress: bool = False,
    backend: str = "auto",
) -> Trajectory:
    """Simulate ``model`` from ``initial_state`` for ``duration`` seconds.

    ``controller(t, state)`` returns joint torques (N,) or an :class:`Actuation`
    (None: free-floating, no actuation). Adaptive integration (scipy
    ``solve_ivp`` with ``method``, ``rtol``, ``atol``) unless ``fixed_step``
    (s) selects RK4. ``sample_period`` holds the controller output between
    samples. States are output every ``output_period`` (default 0.01 s, or the
    fixed step if larger). ``events``: callables (t, state) -> float; the run
    stops where one crosses zero (scipy's ``terminal``/``direction`` attributes
    are honoured). ``external``: wrenches passed to forward dynamics.
    ``backend``: ``"auto"`` evaluates the equations of motion (the RK4 steps, or
    the right-hand side the adaptive integrator calls) with the compiled kernels
    of :mod:`freeflyer._compiled` when numba is installed and there are no
    ``external`` wrenches, ``"numpy"`` with the numpy reference
    (:func:`freeflyer.forward_dynamics`), ``"numba"`` insists on the compiled
    kernels. Both give the same numbers to rounding (tests/test_compiled.py).

    A failure part-way (controller error, non-finite state, integrator
    failure) raises :class:`SimulationError` whose ``trajectory`` holds the
    states computed up to the failure.
    """
    if not isinstance(initial_state, State):
        raise TypeError(f"initial_state: expected a freeflyer.State, got {type(initial_state).__name__}")
    state = initial_state.resolve(model)
    if np.asarray(state.q).ndim != 1:
        raise ShapeError("initial_state: simulate takes one state; use freeflyer.rollout for a batch of states")
    duration = _positive("duration", duration)
    for name, value in (("fixed_step", fixed_step), ("sample_period", sample_period), ("output_period", output_period)):
        if value is not None:
            _positive(name, value)
    if fixed_step is not None and abs(round(duration / fixed_step) * fixed_step - duration) > 1e-9 * duration:
        raise ValueError(f"fixed_step: {fixed_step} does not divide duration {duration}; choose a step that does")
    if fixed_step is None:
        if not (isinstance(method, str) and method in METHODS) and not isinstance(method, type):
            raise ValueError(f"method: unknown integrator {method!r}; choose one of {', '.join(METHODS)} (or pass fixed_step for RK4)")
        _positive("rtol", rtol)
        _positive("atol", atol)
    if controller is not None and not callable(controller):
        raise TypeError(f"controller: expected a callable (t, state) -> joint torques or Actuation, got {type(controller).__name__}")
    limits = limits or ActuatorLimits()
    if backend not in _compiled.BACKENDS:
        raise ValueError(f"backend: expected 'auto', 'numpy' or 'numba', got {backend!r}")
    if backend == "numba":
        _compiled.use_compiled(backend, external)  # a clear error now if the compiled path cannot run this
    period = output_period or max(0.01, fixed_step or 0.0)
    x0 = pack_state(state)
    rec = _Recorder(model)
    zero = (np.zeros(model.n_joints), np.zeros(3), np.zeros(3))

    def command(t: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        if controller is None:
            return (*zero, np.array(False))
        tau, force, torque = _call_controller(controller, model, t, x, ())
        return limits.apply(tau, force, torque)

    bar = _progress(progress, duration)
    try:
        if fixed_step is not None:
            status = _run_rk4(model, x0, duration, float(fixed_step), sample_period, period, command, events, external, rec, bar, backend)
        else:
            status = _run_adaptive(
                model, x0, duration, method, rtol, atol, sample_period, period, command, events, external, rec, bar, backend
            )
    except SimulationError as exc:
        exc.trajectory = rec.trajectory("failed", str(exc))
        raise
    except (FreeflyerError, ValueError, ArithmeticError, RuntimeError, TypeError, KeyError, IndexError) as exc:
        t_fail = rec.t[-1] if rec.t else 0.0
        message = f"simulation failed after t = {t_fail:.6g} s: {type(exc).__name__}: {exc}"
        raise SimulationError(message, rec.trajectory("failed", message)) from exc
    finally:
        if bar is not None:
            bar.stop()
    return rec.trajectory(*status)


def _positive(name: str, value: Any) -> float:
    """``value`` as a positive finite float, or a ValueError naming ``name``."""
    try:
        out = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected a positive number, got {value!r}") from exc
    if not np.isfinite(out) or out <= 0:
        raise ValueError(f"{name}: must be positive and finite, got {value!r}")
    return out


def _check_finite(t: float, x: np.ndarray) -> None:
    total = float(x.dot(x)) if x.ndim == 1 else float(x.sum())
    if total - total != 0.0 and not np.isfinite(x).all():  # NaN and inf propagate into the sum (overflow: checked in full)
        raise SimulationError(f"the state became non-finite at t = {t:.6g} s (unstable controller or too large a step?)")


def _event_value(events: Sequence[Any], model: Model, t: float, x: np.ndarray) -> np.ndarray:
    return np.array([_event(ev, model, t, x) for ev in events])


def _event(ev: Any, model: Model, t: float, x: np.ndarray) -> float:
    try:
        return float(ev(t, unpack_state(model, x)))
    except Exception as exc:
        raise SimulationError(f"event {getattr(ev, '__name__', ev)!r} raised {type(exc).__name__} at t = {t:.6g} s: {exc}") from exc


def _run_rk4(
    model: Model,
    x0: np.ndarray,
    duration: float,
    dt: float,
    sample_period: float | None,
    period: float,
    command: Any,
    events: Sequence[Any],
    external: Any,
    rec: _Recorder,
    bar: Any,
    backend: str = "numpy",
) -> tuple[str, str]:
    steps = round(duration / dt)  # simulate() checked that dt divides the duration
    if _compiled.use_compiled(backend, external) and not events:
        return _run_rk4_compiled(model, x0, steps, dt, sample_period, period, command, rec, bar)
    step = _stepper(model, dt, external, backend)
    hold = sample_period or dt
    stride = max(1, round(period / dt))
    x, t = x0.copy(), 0.0
    act = command(0.0, x)
    next_sample = hold
    rec.add(0.0, x, act)
    prev_ev = _event_value(events, model, 0.0, x) if events else None
    for i in range(1, steps + 1):
        tau, force, torque, _ = act
        x = step(x, tau, force, torque)
        t = i * dt
        _check_finite(t, x)
        if t >= next_sample - 1e-12 * hold and i < steps:
            act = command(t, x)
            next_sample += hold
        if i % stride == 0 or i == steps:
            rec.add(t, x, act)
        if bar is not None and i % max(1, steps // 100) == 0:
            bar.update(bar.task_ids[0], completed=t)
        if events:
            now = _event_value(events, model, t, x)
            for k, ev in enumerate(events):
                direction = getattr(ev, "direction", 0)
                crossed = (prev_ev[k] < 0 <= now[k] and direction >= 0) or (prev_ev[k] > 0 >= now[k] and direction <= 0)  # type: ignore[index]
                if crossed and getattr(ev, "terminal", True):
                    if rec.t[-1] != t:
                        rec.add(t, x, act)
                    return "event", f"event {k} ({getattr(ev, '__name__', 'event')}) at t = {t:.6g} s"
            prev_ev = now
    return "finished", ""


def _run_rk4_compiled(
    model: Model, x0: np.ndarray, steps: int, dt: float, sample_period: float | None, period: float, command: Any, rec: _Recorder, bar: Any
) -> tuple[str, str]:
    """RK4 with the compiled kernels, in place: runs of steps between samples and outputs go without Python."""
    run = _compiled.kernels(model).module.steps_single
    n = model.n_joints
    # sample instants: every step without a sample period, else the steps nearest k * sample_period
    sample_steps = 1 if sample_period is None else None
    next_sample_time = sample_period or dt
    stride = max(1, round(period / dt))
    x = np.array(x0, dtype=float, order="C")
    x[6:10] /= np.linalg.norm(x[6:10])
    u = np.empty(n + 6)
    act = command(0.0, x)
    u[:n], u[n : n + 3], u[n + 3 :] = act[0], act[1], act[2]
    rec.add(0.0, x, act)
    report = max(1, steps // 100)
    i = 0
    while i < steps:
        if sample_steps == 1:
            todo = 1
        else:
            to_sample = max(1, round(next_sample_time / dt) - i)
            todo = min(to_sample, stride - i % stride, steps - i)
        run(x, u, dt, todo)
        i += todo
        t = i * dt
        _check_finite(t, x)
        if i < steps and (sample_steps == 1 or t >= next_sample_time - 1e-9 * dt):
            act = command(t, x.copy())  # a copy: x is advanced in place, the controller may keep its state
            u[:n], u[n : n + 3], u[n + 3 :] = act[0], act[1], act[2]
            if sample_period is not None:
                next_sample_time += sample_period
        if i % stride == 0 or i == steps:
            rec.add(t, x, act)
        if bar is not None and i % report < todo:
            bar.update(bar.task_ids[0], completed=t)
    return "finished", ""


def _run_adaptive(
    model: Model,
    x0: np.ndarray,
    duration: float,
    method: str,
    rtol: float,
    atol: float,
    sample_period: float | None,
    period: float,
    command: Any,
    events: Sequence[Any],
    external: Any,
    rec: _Recorder,
    bar: Any,
    backend: str = "numpy",
) -> tuple[str, str]:
    n_out = int(np.floor(duration / period + 1e-9))
    t_out = np.append(np.arange(n_out + 1) * period, duration) if n_out * period < duration - 1e-12 else np.arange(n_out + 1) * period
    if sample_period is not None:
        # sample instants k * sample_period (no accumulated rounding), each one a restart of the integrator
        n_samples = int(np.ceil(duration / sample_period - 1e-9))
        bounds = np.append(np.arange(n_samples) * sample_period, duration)
    else:
        bounds = np.linspace(0.0, duration, 101 if bar is not None else 2)
    derivative = _rhs(model, external, backend)
    ivp_events = []
    for ev in events:

        def wrapped(t: float, y: np.ndarray, ev: Any = ev) -> float:
            return _event(ev, model, t, y)

        wrapped.terminal = getattr(ev, "terminal", True)  # type: ignore[attr-defined]
        wrapped.direction = getattr(ev, "direction", 0)  # type: ignore[attr-defined]
        ivp_events.append(wrapped)
    x = x0.copy()
    held = command(0.0, x) if sample_period is not None else None
    rec.add(0.0, x, held if held is not None else command(0.0, x))
    for a, b in itertools.pairwise(bounds):

        def rhs(t: float, y: np.ndarray, held: Any = held) -> np.ndarray:
            tau, force, torque, _ = held if held is not None else command(t, y)
            return derivative(y, tau, force, torque)

        inside = t_out[(t_out > a + 1e-12) & (t_out <= b + 1e-12)]
        # always evaluate at b too: the next piece starts from the state there
        t_eval = inside if inside.size and inside[-1] >= b - 1e-12 else np.append(inside, b)
        t_eval[-1] = b
        sol = solve_ivp(rhs, (a, b), x, method=method, rtol=rtol, atol=atol, t_eval=t_eval, events=ivp_events or None)
        if sol.status == -1:
            raise SimulationError(f"integrator failed between t = {a:.6g} and {b:.6g} s: {sol.message}")
        x = sol.y[:, -1] if sol.y.shape[1] else x
        _check_finite(float(sol.t[-1]) if sol.t.size else a, x)
        # the actuation recorded at a sample instant is the one applied from there on
        last = sol.status == 0 and b < duration - 1e-12 * duration
        new_held = command(b, x) if held is not None and last else held
        for k, tk in enumerate(sol.t[: inside.size]):
            _check_finite(float(tk), sol.y[:, k])
            act = held if held is None or tk < b - 1e-12 else new_held
            rec.add(float(tk), sol.y[:, k], act if act is not None else command(float(tk), sol.y[:, k]))
        held = new_held
        if bar is not None:
            bar.update(bar.task_ids[0], completed=b)
        if sol.status == 1:
            hit = [k for k, te in enumerate(sol.t_events) if len(te)]
            t_ev = float(sol.t_events[hit[0]][0])
            y_ev = sol.y_events[hit[0]][0]
            rec.add(t_ev, y_ev, held if held is not None else command(t_ev, y_ev))
            return "event", f"event {hit[0]} at t = {t_ev:.6g} s"
    return "finished", ""


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
    backend: str = "auto",
) -> Trajectory:
    """Simulate a batch of initial states at once with fixed-step RK4.

    ``initial_states`` is a :class:`State` whose fields have a leading batch
    axis B (fields may broadcast). ``controller(t, states)`` sees the whole
    batch (fields (B, ...)) and returns batched torques (B, N) or an
    :class:`Actuation` of batched arrays; per-trajectory controller parameters
    are arrays of length B that the controller closes over. Returns a
    :class:`Trajectory` whose arrays are (T, B, ...).

    ``backend`` as in :func:`simulate`: with the compiled kernels the RK4 steps
    of the whole batch run in parallel (blocks of trajectories on a thread
    pool, see :mod:`freeflyer._compiled`), and a controller
    that is None or a :class:`freeflyer.pd.JointPD` (gains per trajectory,
    open-loop feed-forward) runs compiled too, with no Python per step.
    """
    state = initial_states.resolve(model)
    x = pack_state(state)
    if x.ndim != 2:
        raise ShapeError(f"initial_states: expected fields with one leading batch axis (B, ...), got a state of shape {x.shape}")
    batch = x.shape[:1]
    limits = limits or ActuatorLimits()
    duration, dt = _positive("duration", duration), _positive("dt", dt)
    steps = round(float(duration) / dt)
    if steps <= 0 or abs(steps * dt - duration) > 1e-9 * duration:
        raise ValueError(f"dt: {dt} must divide duration {duration}")
    hold = round((sample_period or dt) / dt)
    stride = max(1, round((output_period or dt) / dt))
    zero = (np.zeros((*batch, model.n_joints)), np.zeros((*batch, 3)), np.zeros((*batch, 3)))

    def command(t: float, xx: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        if controller is None:
            return (*zero, np.zeros(batch, dtype=bool))
        return limits.apply(*_call_controller(controller, model, t, xx, batch))

    rec = _Recorder(model)
    if _compiled.use_compiled(backend, external) and (controller is None or isinstance(controller, JointPD)):
        compiled = _compiled.rollout_rows(model, x, dt, steps, hold, stride, controller, limits)
        if compiled is not None:
            return _trajectory(model, *compiled, copy=False)  # the kernels keep the quaternions normalised
    step = _stepper(model, dt, external, backend)
    act = command(0.0, x)
    rec.add(0.0, x, act)
    for i in range(1, steps + 1):
        tau, force, torque, _ = act
        x = step(x, tau, force, torque)
        if i % hold == 0 and i < steps:
            act = command(i * dt, x)
        if i % stride == 0 or i == steps:
            rec.add(i * dt, x, act)
    return rec.trajectory()
