"""The integration loops behind :func:`freeflyer.simulate` and :func:`freeflyer.rollout` (private).

The state derivative (numpy reference :func:`_derivative`, or the compiled
kernels of :mod:`freeflyer.mechanics._compiled`), one RK4 step, the fixed-step
and adaptive (scipy ``solve_ivp``) loops, events, and the recorder that turns
the flat states into a :class:`~freeflyer.Trajectory`. The flat state is
``x = [r_cm, v_cm, attitude (x, y, z, w), omega, q, qdot]`` (see
:mod:`freeflyer.core.state`).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from functools import partial
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from ..core.errors import SimulationError
from ..core.model import Model
from ..core.state import unpack_state
from ..mechanics import _batch, _compiled
from ..mechanics.dynamics import forward_dynamics
from .trajectory import Trajectory


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
