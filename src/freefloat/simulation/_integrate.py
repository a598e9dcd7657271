"""One simulation run from its plan (private): :func:`run`, and the integration loops behind :func:`freefloat.simulate`
and :func:`freefloat.rollout`.

:func:`run` takes the :class:`~._plan.RunPlan` that :func:`~._plan.plan_run` made, and runs it inside the engine's
compiled loop when it can (:func:`._compiled_runs.compiled_simulation`), else in the fixed-step loop
(:func:`_run_rk4`: runs of RK4 steps between controller samples, outputs and events as one compiled call each) or
the adaptive one (:func:`_run_adaptive`: scipy ``solve_ivp`` over the engine's state derivative, piece by piece
between controller samples). The state derivative and RK4 steps are the engine's (:class:`freefloat.engine.Stepper`).
The flat state is ``x = [r_cm, v_cm, attitude (x, y, z, w), omega, q, qdot]`` (see
:mod:`freefloat.core.state`), with the energy the joints' damping and friction have dissipated as one more
component, last, when the run models them (:func:`~freefloat.core.state.dissipates`): the integrators integrate its
rate (the engine's dissipated power) with the state, so every loop here carries it (the joint stops' restarts too) and
the record (:mod:`._record`) takes it off into ``Trajectory.dissipated_energy``.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterator, Sequence
from types import SimpleNamespace
from typing import Any, cast

import numpy as np
from scipy.integrate import solve_ivp

from .. import engine
from ..core.errors import FreefloatError, SimulationError
from ..core.model import Model
from ..core.numbers import MAX_EFFORT
from ..core.state import unpack_state
from ..core.state_layout import Q_AT, span
from ._compiled_runs import compiled_simulation
from ._controller import check_output, plain_torques, zero_thrust
from ._guard import Progress
from ._plan import RunPlan, engine_wrenches
from ._record import _Recorder
from ._stops import with_limit_events
from ._wheels import user_trajectory
from .trajectory import Trajectory


def run(plan: RunPlan) -> Trajectory:
    """The simulation ``plan`` describes: inside the engine's compiled loop when it can be (a built-in controller with
    fixed steps, no events or stops, a short run: :func:`._compiled_runs.compiled_simulation`), else the RK4 or
    adaptive loop, with progress and the divergence guard. Ctrl-C returns the trajectory so far (status
    ``"interrupted"``); a failure raises a :class:`SimulationError` that holds it."""
    if plan.fixed_step is not None and not plan.events and not plan.stops.active:
        compiled = compiled_simulation(plan)  # the controller inside the compiled loop, when it can be
        if compiled is not None:
            return _finish(plan, compiled)
    rec = _Recorder(plan.model)
    bar = Progress(plan.progress, plan.duration)
    try:
        plan.guard.check(0.0, plan.x0)  # an initial rate beyond meaning: stopped now, named (its first step would be non-finite)
        status = _run_rk4(plan, rec, bar) if plan.fixed_step is not None else _run_adaptive(plan, rec, bar)
    except KeyboardInterrupt:
        t_stop = rec.t[-1] if rec.t else 0.0
        return _finish(plan, rec.trajectory("interrupted", f"interrupted (Ctrl-C) after t = {t_stop:.6g} s of {plan.duration:g} s"))
    except SimulationError as exc:
        exc.trajectory = _finish(plan, rec.trajectory("failed", str(exc)))
        raise
    except (FreefloatError, ValueError, ArithmeticError, RuntimeError, TypeError, KeyError, IndexError) as exc:
        t_fail = rec.t[-1] if rec.t else 0.0
        message = f"simulation failed after t = {t_fail:.6g} s: {type(exc).__name__}: {exc}"
        raise SimulationError(message, _finish(plan, rec.trajectory("failed", message))) from exc
    finally:
        bar.close()
    return _finish(plan, rec.trajectory(*status))


def _finish(plan: RunPlan, traj: Trajectory) -> Trajectory:
    """The user's trajectory of a run: its joint-limit events, and the reaction wheels apart from the joints."""
    traj = with_limit_events(traj, plan.stops)
    return user_trajectory(plan.user, traj) if plan.user.wheels else traj


def _u(model: Model, tau: np.ndarray, force: np.ndarray, torque: np.ndarray, out: np.ndarray) -> np.ndarray:
    """out = [tau, f_S, n_S] (..., N + 6)."""
    n = model.n_joints
    out[..., :n], out[..., n : n + 3], out[..., n + 3 :] = tau, force, torque
    return out


def _check_effort(t: float | None, u: np.ndarray) -> None:
    """After a failed step: an actuation beyond :data:`~freefloat.core.numbers.MAX_EFFORT` is the cause (it overflows the
    dynamics), said as such rather than as a failure of H+. Checked only then: the fast path of a controller's torques
    costs nothing more."""
    largest = float(np.max(np.abs(u))) if u.size else 0.0
    if not largest <= MAX_EFFORT:
        raise SimulationError(
            f"the actuation reached {largest:.3g} (N m or N) {'at this state' if t is None else f'at t = {t:.6g} s'}, beyond "
            f"{MAX_EFFORT:.0e}, more than any actuator "
            "gives (it would spin the largest inertia a model may have beyond 1e4 rad/s within a second); check the "
            "controller's gains and units"
        )


def _refused(t: float, act: Any, u: np.ndarray) -> None:
    """The RK4 kernel refused the actuation u before stepping (``engine.REFUSED``): the controller's output named, as
    the full checks of its output name it."""
    try:
        for name, value in zip(("joint_torque", "spacecraft_force", "spacecraft_torque"), act[:3], strict=True):
            check_output(name, np.asarray(value, dtype=float))
    except ValueError as exc:
        raise SimulationError(f"bad controller output at t = {t:.6g} s: {exc}") from exc
    _check_effort(t, u)
    raise SimulationError(f"the engine refused the actuation at t = {t:.6g} s: {u}")  # (not reached: a check above names it)


def _record(rec: _Recorder, t: float, x: np.ndarray, act: Any, u: np.ndarray) -> None:
    """Record (t, x, act) in the fixed-step loop, whose plain torques the kernel checks only at its next step: a record
    checks them first (:func:`plain_torques`, ~0.4 us; one in every output period), so that no trajectory, finished by
    an event or failed, holds an actuation the run refused."""
    if not plain_torques(act[0]):
        _refused(t, act, u)
    rec.add(t, x, act)


def _rhs(model: Model, wrenches: tuple[np.ndarray, np.ndarray]) -> Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray]:
    """The state derivative ``f(x, tau, force, torque)`` of one state (the engine, one compiled call) under the external
    ``wrenches`` (the engine's form: :func:`~._plan.engine_wrenches`)."""
    stepper = engine.Stepper(model, wrenches)
    u = np.zeros(model.n_joints + 6)

    def derivative(x: np.ndarray, tau: np.ndarray, force: np.ndarray, torque: np.ndarray) -> np.ndarray:
        out = np.empty(x.shape[0])  # the flat state's length, with the dissipated energy or without it
        if not stepper.derivative(np.ascontiguousarray(x, dtype=float), _u(model, tau, force, torque, u), out):
            _check_effort(None, u)
            raise SimulationError("H+ (1991 eq. 15) is not positive definite at this state: the mass properties are not physical")
        return out

    return derivative


def _stepper(model: Model, dt: float, external: Any) -> Callable[..., np.ndarray]:
    """One RK4 step of a batch of states ``step(x (B, S), tau, force, torque) -> new x`` (the engine, threads across B)."""
    ext = engine_wrenches(model, external)

    def step(x: np.ndarray, tau: np.ndarray, force: np.ndarray, torque: np.ndarray) -> np.ndarray:
        u = _u(model, tau, force, torque, np.empty((*x.shape[:-1], model.n_joints + 6)))
        return engine.rk4_batch(model, x, u, dt, 1, ext)

    return step


def _check_finite(t: float, x: np.ndarray) -> None:
    with np.errstate(over="ignore", invalid="ignore"):
        total = float(x.dot(x)) if x.ndim == 1 else float(x.sum())
    if total - total != 0.0 and not np.isfinite(x).all():  # NaN and inf propagate into the sum (overflow: checked in full)
        raise SimulationError(f"the state became non-finite at t = {t:.6g} s (unstable controller or too large a step?)")


def _guarded(guard: Any, rec: _Recorder, t: float, x: np.ndarray, act: Any) -> None:
    """The divergence guard at (t, x); a diverged state is recorded (finite, it shows the growth) before the error."""
    try:
        guard.check(t, x)
    except SimulationError:
        if not rec.t or rec.t[-1] != t:
            rec.add(t, x, act)
        raise


def _event_value(events: Sequence[Any], model: Model, t: float, x: np.ndarray) -> np.ndarray:
    return np.array([_event(ev, model, t, x) for ev in events])


def _event(ev: Any, model: Model, t: float, x: np.ndarray) -> float:
    try:
        return float(ev(t, unpack_state(model, x)))
    except Exception as exc:
        raise SimulationError(f"event {getattr(ev, '__name__', ev)!r} raised {type(exc).__name__} at t = {t:.6g} s: {exc}") from exc


def _run_rk4(plan: RunPlan, rec: _Recorder, bar: Progress) -> tuple[str, str]:
    """Fixed-step RK4 on the engine, in place: runs of steps between samples, outputs and events go without Python.
    Records into ``rec``, shows progress on ``bar``; returns (status, message).

    With joint stops, a run of steps that ends beyond a limit is redone step by step and the stop
    acts at the end of the step that crossed (:mod:`._stops`). The events see the states of the user's model
    (``plan.user``; the engine integrates ``plan.model``, its reaction wheels as joints).
    """
    model, view, command, events, guard, stops = plan.model, plan.user, plan.command, plan.events, plan.guard, plan.stops
    dt, sample_period, steps = cast(float, plan.fixed_step), plan.sample_period, plan.steps  # (run() calls it with fixed steps)
    stepper = engine.Stepper(model, plan.wrenches)
    n = model.n_joints
    # the compiled steps stop where Python must look: a joint beyond a stop, a rate the guard must test
    quiet_guard = guard.budget is None  # no per-step energy test: the rate test is the kernel's
    rate = guard.rate_limit if quiet_guard else np.inf
    stepper.watch(
        rate, stops.lower if stops.active else None, stops.upper if stops.active else None, guard.joint_rate_limits if quiet_guard else None
    )
    # sample instants: every step without a sample period, else the steps nearest k * sample_period
    next_sample_time = sample_period or dt
    stride = max(1, round(plan.output_period / dt))
    x = np.array(plan.x0, dtype=float, order="C")
    attitude = span("attitude", n)
    x[attitude] /= np.linalg.norm(x[attitude])
    u = np.empty(n + 6)
    quiet = zero_thrust(())  # read-only: a command that carries it has no thrust
    act = command(0.0, x.copy(), True)  # the kernel checks the plain torques before it steps (Stepper.REFUSED)
    _u(model, act[0], act[1], act[2], u)
    held = True
    _record(rec, 0.0, x, act, u)
    prev_ev = _event_value(events, view, 0.0, x) if events else None
    rk4, ints, why, refused = stepper.rk4, stepper.ints, stepper.reason_at, stepper.REFUSED  # the hot loop: a controller may run every step
    every_step = bool(events) or sample_period is None
    torques = u[:n]
    i = 0
    while i < steps:
        if every_step:
            todo = 1
        else:
            to_sample = max(1, round(next_sample_time / dt) - i)
            todo = min(to_sample, stride - i % stride, steps - i)
        done = rk4(x, u, dt, todo)  # the kernel checks u, then that x stays finite, and watches it
        reason = ints.item(why)
        if reason & refused:
            _refused(i * dt, act, u)
        if done != todo and not reason:
            i += abs(done)
            t = i * dt
            _check_effort(t, u)
            _check_finite(t, x)
            raise SimulationError(f"H+ (1991 eq. 15) is not positive definite at t = {t:.6g} s: the mass properties are not physical")
        if reason & 2:  # the step that crossed a limit: the stop acts at its end
            stops.apply((i + done) * dt, x)
        i += done
        t = i * dt
        if reason or not quiet_guard:
            _guarded(guard, rec, t, x, act)
        if done != todo:  # stopped early to look: go on to the planned sample or output
            continue
        if i < steps and (sample_period is None or t >= next_sample_time - 1e-9 * dt):
            act = command(t, x.copy(), True)  # a copy: x is advanced in place, the controller may keep its state
            torques[...] = act[0]  # (a view made once: half the time of u[:n] = ...)
            thrust = act[1] is not quiet or act[2] is not quiet
            if thrust or held:  # the thrust held so far or the new one
                u[n : n + 3], u[n + 3 :] = act[1], act[2]
            held = thrust
            if sample_period is not None:
                next_sample_time += sample_period
        if i % stride == 0 or i == steps:
            _record(rec, t, x, act, u)
        if todo > 1 or not i & 7 or i == steps:  # the progress and the wall clock every 8 steps: each reads the clock
            bar.update(t)
            guard.clock(t)
        if events:
            now = _event_value(events, view, t, x)
            for k, ev in enumerate(events):
                direction = getattr(ev, "direction", 0)
                crossed = (prev_ev[k] < 0 <= now[k] and direction >= 0) or (prev_ev[k] > 0 >= now[k] and direction <= 0)  # type: ignore[index]
                if crossed and getattr(ev, "terminal", True):
                    if rec.t[-1] != t:
                        _record(rec, t, x, act, u)
                    return "event", f"event {k} ({getattr(ev, '__name__', 'event')}) at t = {t:.6g} s"
            prev_ev = now
    return "finished", ""


def _pieces(duration: float, sample_period: float | None, period: float) -> Iterator[tuple[float, float]]:
    """The integration pieces (a, b), each one a restart of the integrator: between sample instants
    k * sample_period (no accumulated rounding); without a sample period, pieces that double from 1 %
    of the duration (1, 2, 4, ... %: few restarts, and Ctrl-C keeps all but the last piece), each at
    most 10,000 output periods long. Lazy: a run of 1e12 samples costs no memory up front."""
    if sample_period is not None:
        count = int(np.ceil(duration / sample_period - 1e-9))
        for k in range(count):
            yield k * sample_period, (k + 1) * sample_period if k + 1 < count else duration
        return
    a, length, longest = 0.0, 0.01 * duration, 1e4 * period
    while a < duration:
        b = a + min(length, longest)
        if b >= duration * (1.0 - 1e-9):
            b = duration
        yield a, b
        a, length = b, 2.0 * length


def _outputs_in(a: float, b: float, period: float, n_out: int, extra: float | None) -> np.ndarray:
    """Output instants k * period (k <= n_out) in (a, b], and ``extra`` (the duration) if it is in there."""
    k_lo = max(0, int(np.floor((a + 1e-12) / period)) - 1)
    k_hi = min(n_out, int(np.floor((b + 1e-12) / period)) + 1)
    grid = np.arange(k_lo, k_hi + 1) * period
    if extra is not None:
        grid = np.append(grid, extra)
    return grid[(grid > a + 1e-12) & (grid <= b + 1e-12)]


def _run_adaptive(plan: RunPlan, rec: _Recorder, bar: Progress) -> tuple[str, str]:
    """Adaptive integration (scipy ``solve_ivp``) piece by piece between controller samples; records into ``rec``,
    shows progress on ``bar``; returns (status, message). The events see the user's model, as in :func:`_run_rk4`.

    With joint stops, the pieces end at every output instant too, terminal events locate each
    crossing of a limit (the stop acts there and the piece goes on), and a joint resting on its
    stop is put back on it at the end of each piece (:mod:`._stops`).
    """
    adaptive = _Adaptive(plan, rec, bar)
    duration, period, command = plan.duration, plan.output_period, plan.command
    x = plan.x0.copy()
    held = command(0.0, x.copy()) if plan.sample_period is not None else None  # copies: a controller may keep its state
    rec.add(0.0, x, held if held is not None else command(0.0, x.copy()))
    for a, b in _pieces(duration, plan.sample_period, period):
        if plan.stops.active:  # a resting joint is put back on its stop at the end of each piece: end them at the outputs too
            extra = duration if adaptive.end_extra else None
            cuts = [float(c) for c in _outputs_in(a, b, period, adaptive.n_out, extra) if c < b - 1e-12]
            bounds = [a, *cuts, b]
        else:
            bounds = [a, b]
        message, x, held = adaptive.piece(bounds, x, held)
        bar.update(b)
        plan.guard.clock(b)
        if message:
            return "event", message
    return "finished", ""


class _Adaptive:
    """One adaptive run of ``plan``: the engine's state derivative, the user's events as scipy's, and the output grid
    (``n_out`` instants k ``output_period``, and the duration when ``end_extra``: it is an output instant of its own)."""

    def __init__(self, plan: RunPlan, rec: _Recorder, bar: Progress) -> None:
        self.plan, self.rec, self.bar = plan, rec, bar
        self.n_out = int(np.floor(plan.duration / plan.output_period + 1e-9))
        self.end_extra = self.n_out * plan.output_period < plan.duration - 1e-12
        self.derivative = _rhs(plan.model, plan.wrenches)
        self.events: list[Any] = []
        for ev in plan.events:

            def wrapped(t: float, y: np.ndarray, ev: Any = ev) -> float:
                return _event(ev, plan.user, t, y)

            wrapped.terminal = getattr(ev, "terminal", True)  # type: ignore[attr-defined]
            wrapped.direction = getattr(ev, "direction", 0)  # type: ignore[attr-defined]
            self.events.append(wrapped)

    def piece(self, bounds: list[float], x: np.ndarray, held: Any) -> tuple[str, np.ndarray, Any]:
        """One controller sample (held actuation) over ``bounds``; returns (event message or "", end state, next actuation)."""
        plan, rec, bar, derivative = self.plan, self.rec, self.bar, self.derivative
        guard, command = plan.guard, plan.command
        period, duration = plan.output_period, plan.duration
        b_end = bounds[-1]
        for a, b in itertools.pairwise(bounds):

            def rhs(t: float, y: np.ndarray, held: Any = held) -> np.ndarray:
                guard.tick(t, y)
                bar.update(t)  # progress inside a piece (a clock read between redraws)
                tau, force, torque, _ = held if held is not None else command(t, y)
                return derivative(y, tau, force, torque)

            inside = _outputs_in(a, b, period, self.n_out, duration if self.end_extra else None)
            # always evaluate at b too: the next piece starts from the state there
            t_eval = inside if inside.size and inside[-1] >= b - 1e-12 else np.append(inside, b)
            t_eval[-1] = b
            sol = self.solve(rhs, a, b, x, t_eval)
            if sol.status == -1:
                raise SimulationError(f"integrator failed between t = {a:.6g} and {b:.6g} s: {sol.message}")
            x = sol.y[:, -1] if sol.y.shape[1] else x
            _check_finite(float(sol.t[-1]) if sol.t.size else a, x)
            _guarded(guard, rec, float(sol.t[-1]) if sol.t.size else a, x, held if held is not None else command(b, x))
            # the actuation recorded at a sample instant is the one applied from there on
            last = sol.status == 0 and b >= b_end and b < duration - 1e-12 * duration
            new_held = command(b, x) if held is not None and last else held
            for k, tk in enumerate(sol.t[: inside.size]):
                _check_finite(float(tk), sol.y[:, k])
                act = held if held is None or tk < b - 1e-12 else new_held
                rec.add(float(tk), sol.y[:, k], act if act is not None else command(float(tk), sol.y[:, k]))
            held = new_held
            if sol.status == 1:
                hit = [k for k, te in enumerate(sol.t_events) if len(te)]
                t_ev = float(sol.t_events[hit[0]][0])
                y_ev = sol.y_events[hit[0]][0]
                rec.add(t_ev, y_ev, held if held is not None else command(t_ev, y_ev))
                return f"event {hit[0]} at t = {t_ev:.6g} s", x, held
        return "", x, held

    def solve(self, rhs: Any, a: float, b: float, x: np.ndarray, t_eval: np.ndarray) -> Any:
        """``solve_ivp`` over (a, b); with joint stops, restarted at each crossing of a limit after the stop acted there."""
        plan, events, stops = self.plan, self.events, self.plan.stops
        method, rtol, atol = plan.method, plan.rtol, plan.atol
        if not stops.active:
            return solve_ivp(rhs, (a, b), x, method=method, rtol=rtol, atol=atol, t_eval=t_eval, events=events or None)
        ts: list[float] = []
        ys: list[np.ndarray] = []
        t0, y0 = a, x
        while True:
            stops.release(y0)
            limits = _stop_events(stops.model, stops)
            todo = t_eval[t_eval > t0 + 1e-12 * max(1.0, abs(t0))]
            sol = solve_ivp(rhs, (t0, b), y0, method=method, rtol=rtol, atol=atol, t_eval=todo, events=[*events, *limits] or None)
            if sol.status == -1:
                return sol
            ts += [float(t) for t in np.asarray(sol.t)]
            ys += [np.asarray(sol.y)[:, k].copy() for k in range(len(sol.t))]
            hits = [k for k, te in enumerate(sol.t_events or []) if len(te)] if sol.status == 1 else []
            if hits and hits[0] < len(events):  # a user's event: stop there (perhaps before any output instant of the piece)
                return SimpleNamespace(
                    status=1, message=sol.message, t=np.array(ts), y=np.stack(ys, axis=1) if ys else np.zeros((len(y0), 0)),
                    t_events=sol.t_events[: len(events)],
                    y_events=sol.y_events[: len(events)],
                )  # fmt: skip
            if not hits:
                break
            t_hit = float(sol.t_events[hits[0]][0])
            joint = limits[hits[0] - len(events)].joint
            if t_hit <= t0 + 1e-12 * max(1.0, abs(t0)):  # no progress: a bounce shorter than a step, at the limit
                stops.resting.add(joint)  # on its stop until the piece ends (put back there)
            t0, y0 = t_hit, sol.y_events[hits[0]][0].copy()
            stops.apply(t0, y0, joints=[joint])
            if b - t0 <= 1e-12 * max(1.0, abs(b)):
                ts.append(b)
                ys.append(y0)
                break
        end = ys[-1].copy()
        if stops.beyond(end):  # a joint resting on its stop: back on it at the end of the piece
            stops.apply(b, end)
            ys[-1] = end
        return SimpleNamespace(status=0, message="", t=np.array(ts), y=np.stack(ys, axis=1), t_events=None, y_events=None)


def _stop_events(model: Model, stops: Any) -> list[Any]:
    """Terminal events at each finite limit of the joints not resting on a stop (upper: rising, lower: falling)."""
    found = []
    for i in range(model.n_joints):
        if i in stops.resting:
            continue
        for limit, direction in ((stops.upper[i], 1.0), (stops.lower[i], -1.0)):
            if np.isfinite(limit):

                def crossing(t: float, y: np.ndarray, index: int = Q_AT + i, limit: float = float(limit)) -> float:
                    return float(y[index] - limit)

                crossing.terminal = True  # type: ignore[attr-defined]
                crossing.direction = direction  # type: ignore[attr-defined]
                crossing.joint = i  # type: ignore[attr-defined]
                found.append(crossing)
    return found
