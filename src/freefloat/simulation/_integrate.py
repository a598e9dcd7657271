"""The integration loops behind :func:`freefloat.simulate` and :func:`freefloat.rollout` (private).

The state derivative and RK4 steps are the engine's (:mod:`freefloat.engine.calls`,
one compiled call per run of steps); here are the fixed-step
and adaptive (scipy ``solve_ivp``) loops, events, and the recorder that turns
the flat states into a :class:`~freefloat.Trajectory`. The flat state is
``x = [r_cm, v_cm, attitude (x, y, z, w), omega, q, qdot]`` (see
:mod:`freefloat.core.state`), with the energy the joints' damping and friction have dissipated as one more
component, last, when the run models them (:func:`~freefloat.core.state.dissipates`): the integrators integrate its
rate (the engine's dissipated power) with the state, so every loop here carries it (the joint stops' restarts too) and
:func:`_trajectory` takes it off into ``Trajectory.dissipated_energy``.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterator, Sequence
from types import SimpleNamespace
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from .. import engine
from ..core.errors import ShapeError, SimulationError
from ..core.model import Model
from ..core.numbers import MAX_EFFORT
from ..core.resources import MEMORY_FRACTION, available_memory, format_bytes
from ..core.state import dissipated, unpack_state
from ..mechanics.forces import _engine_wrenches, _wrenches
from .trajectory import Trajectory


def _engine_inputs(model: Model, external: Any) -> tuple[np.ndarray, np.ndarray]:
    """External wrenches (constant; forces and couples (3,)) as the engine takes them."""
    ext_i, ext_f = _engine_wrenches(model, _wrenches(external))
    if ext_f.ndim != 2:
        raise ShapeError(f"external: a simulation takes constant wrenches (force and torque of shape (3,)), got {ext_f.shape[:-2]} batches")
    return ext_i, ext_f


_ZEROS: dict[tuple[int, ...], np.ndarray] = {}


def zero_thrust(batch: tuple[int, ...]) -> np.ndarray:
    """A shared read-only zero thrust (batch, 3): a controller's plain joint torques carry it as their spacecraft force
    and torque (the fixed-step loop then writes only the torques)."""
    if batch not in _ZEROS:
        zeros = np.zeros((*batch, 3))
        zeros.flags.writeable = False
        _ZEROS[batch] = zeros
    return _ZEROS[batch]


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


def plain_torques(raw: np.ndarray) -> bool:
    """True when every entry of ``raw`` is finite and within :data:`~freefloat.core.numbers.MAX_EFFORT` (N m or N).
    For one configuration on Python floats (a third of numpy's reductions on a few values, every step of a
    simulation); a NaN or inf makes the sum non-finite, a sum that overflows sends finite values to the full check."""
    if raw.ndim != 1:
        return bool(np.abs(raw).max(initial=0.0) <= MAX_EFFORT)  # NaN compares false
    values = raw.tolist()
    return not values or (-MAX_EFFORT <= min(values) and max(values) <= MAX_EFFORT and math.isfinite(sum(values)))


def check_output(name: str, arr: np.ndarray) -> None:
    """A controller's output ``name`` (an array): a ValueError that says what is wrong when an entry is not finite or
    beyond :data:`~freefloat.core.numbers.MAX_EFFORT` (N m or N)."""
    if not np.isfinite(arr).all():
        raise ValueError(f"controller returned a non-finite {name}: {arr}")
    if np.abs(arr).max(initial=0.0) > MAX_EFFORT:
        raise ValueError(
            f"controller returned a {name} of {np.abs(arr).max():.3g}, beyond {MAX_EFFORT:.0e} (N m or N), more than any actuator "
            "gives (it would spin the largest inertia a model may have beyond 1e4 rad/s within a second); check the controller's "
            "gains and units"
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


def _rhs(model: Model, external: Any) -> Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray]:
    """The state derivative ``f(x, tau, force, torque)`` of one state (the engine, one compiled call)."""
    stepper = engine.Stepper(model, _engine_inputs(model, external))
    u = np.zeros(model.n_joints + 6)

    def derivative(x: np.ndarray, tau: np.ndarray, force: np.ndarray, torque: np.ndarray) -> np.ndarray:
        out = np.empty(x.shape[0])  # 13 + 2N, or 14 + 2N with the dissipated energy
        if not stepper.derivative(np.ascontiguousarray(x, dtype=float), _u(model, tau, force, torque, u), out):
            _check_effort(None, u)
            raise SimulationError("H+ (1991 eq. 15) is not positive definite at this state: the mass properties are not physical")
        return out

    return derivative


def _stepper(model: Model, dt: float, external: Any) -> Callable[..., np.ndarray]:
    """One RK4 step of a batch of states ``step(x (B, S), tau, force, torque) -> new x`` (the engine, threads across B)."""
    ext = _engine_inputs(model, external)

    def step(x: np.ndarray, tau: np.ndarray, force: np.ndarray, torque: np.ndarray) -> np.ndarray:
        u = _u(model, tau, force, torque, np.empty((*x.shape[:-1], model.n_joints + 6)))
        return engine.rk4_batch(model, x, u, dt, 1, ext)

    return step


#: The recorder looks at the free memory every this many recorded states.
RECORD_CHECK = 1 << 16


class _Recorder:
    def __init__(self, model: Model) -> None:
        self.model = model
        self.t: list[float] = []
        self.x: list[np.ndarray] = []
        self.act: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []

    def add(self, t: float, x: np.ndarray, act: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]) -> None:
        if len(self.t) % RECORD_CHECK == RECORD_CHECK - 1:
            self._check_memory(x)
        self.t.append(float(t))
        self.x.append(x.copy())  # the attitudes are normalised at the end, all at once (:meth:`trajectory`)
        self.act.append(act)

    def _check_memory(self, x: np.ndarray) -> None:
        """A run records its states as it goes (a 1e12 s run allocates nothing up front): stop it, with what it
        recorded, before the records and their final stacking (about 3 times the records) exceed the free memory."""
        per_sample = 8 * (x.size + sum(np.size(a) for a in self.act[-1])) + 200  # floats, and the lists' own objects
        recorded = len(self.t) * per_sample
        free = available_memory()
        if free is not None and 3 * recorded > MEMORY_FRACTION * free:
            raise SimulationError(
                f"the run has recorded {len(self.t):,} states ({format_bytes(recorded)}), and recording more would exceed the "
                f"memory this machine has free ({format_bytes(free)}): record fewer states (a longer output_period) or "
                "shorten the run; the states so far are attached"
            )

    def trajectory(self, status: str = "finished", message: str = "") -> Trajectory:
        model = self.model
        n = model.n_joints
        # the records whole: an interrupt (Ctrl-C, SIGTERM) between the appends of :meth:`add` leaves one list longer
        kept = min(len(self.t), len(self.x), len(self.act))
        if kept:
            xs = np.stack(self.x[:kept])
            xs[..., 6:10] /= np.linalg.norm(xs[..., 6:10], axis=-1, keepdims=True)
            acts = [np.stack([a[i] for a in self.act[:kept]]) for i in range(4)]
        else:
            xs = np.zeros((0, 13 + 2 * n))  # (no slot: no dissipated energy either)
            acts = [np.zeros((0, n)), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0,), dtype=bool)]
        return _trajectory(model, np.asarray(self.t[:kept]), xs, (acts[0], acts[1], acts[2], acts[3]), status, message)


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
    """A Trajectory from stacked flat states xs (T, ..., S) and actuation; the dissipated energy from their last slot
    (S = 14 + 2N; zeros for states without it: :func:`~freefloat.core.state.dissipated`), the other fields from the rest.

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
        dissipated_energy=own(dissipated(model, xs)),
        status=status,
        message=message,
        model_name=model.name,
        model=model,
    )


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
    guard: Any,
    stops: Any,
    view: Model | None = None,
) -> tuple[str, str]:
    """Fixed-step RK4 on the engine, in place: runs of steps between samples, outputs and events go without Python.

    With joint stops, a run of steps that ends beyond a limit is redone step by step and the stop
    acts at the end of the step that crossed (:mod:`._stops`). ``view``: the model whose states the events see (the
    user's model with reaction wheels when ``model`` integrates them as joints; default ``model``).
    """
    view = view or model
    steps = round(duration / dt)  # simulate() checked that dt divides the duration
    stepper = engine.Stepper(model, _engine_inputs(model, external))
    n = model.n_joints
    # the compiled steps stop where Python must look: a joint beyond a stop, a rate the guard must test
    quiet_guard = guard.budget is None  # no per-step energy test: the rate test is the kernel's
    rate = guard.rate_limit if quiet_guard else np.inf
    stepper.watch(
        rate, stops.lower if stops.active else None, stops.upper if stops.active else None, guard.joint_rate_limits if quiet_guard else None
    )
    # sample instants: every step without a sample period, else the steps nearest k * sample_period
    next_sample_time = sample_period or dt
    stride = max(1, round(period / dt))
    x = np.array(x0, dtype=float, order="C")
    x[6:10] /= np.linalg.norm(x[6:10])
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
    guard: Any,
    stops: Any,
    view: Model | None = None,
) -> tuple[str, str]:
    """Adaptive integration (scipy ``solve_ivp``) piece by piece between controller samples (``view``: as in
    :func:`_run_rk4`).

    With joint stops, the pieces end at every output instant too, terminal events locate each
    crossing of a limit (the stop acts there and the piece goes on), and a joint resting on its
    stop is put back on it at the end of each piece (:mod:`._stops`).
    """
    n_out = int(np.floor(duration / period + 1e-9))
    end_extra = n_out * period < duration - 1e-12  # the duration is an output instant of its own
    derivative = _rhs(model, external)
    ivp_events = []
    for ev in events:

        def wrapped(t: float, y: np.ndarray, ev: Any = ev) -> float:
            return _event(ev, view or model, t, y)

        wrapped.terminal = getattr(ev, "terminal", True)  # type: ignore[attr-defined]
        wrapped.direction = getattr(ev, "direction", 0)  # type: ignore[attr-defined]
        ivp_events.append(wrapped)
    x = x0.copy()
    held = command(0.0, x.copy()) if sample_period is not None else None  # copies: a controller may keep its state
    rec.add(0.0, x, held if held is not None else command(0.0, x.copy()))
    for a, b in _pieces(duration, sample_period, period):
        if stops.active:  # a resting joint is put back on its stop at the end of each piece: end them at the outputs too
            cuts = [float(c) for c in _outputs_in(a, b, period, n_out, duration if end_extra else None) if c < b - 1e-12]
            bounds = [a, *cuts, b]
        else:
            bounds = [a, b]
        outputs = (period, n_out, duration, end_extra)
        status = _adaptive_piece(
            model, bounds, x, held, command, derivative, guard, method, rtol, atol, ivp_events, stops, rec, outputs, bar
        )
        x, held = status[1], status[2]
        bar.update(b)
        guard.clock(b)
        if status[0]:
            return "event", status[0]
    return "finished", ""


def _adaptive_piece(
    model: Model,
    bounds: list[float],
    x: np.ndarray,
    held: Any,
    command: Any,
    derivative: Any,
    guard: Any,
    method: str,
    rtol: float,
    atol: float,
    ivp_events: list[Any],
    stops: Any,
    rec: _Recorder,
    outputs: tuple[float, int, float, bool],
    bar: Any,
) -> tuple[str, np.ndarray, Any]:
    """One controller sample (held actuation) over ``bounds``; returns (event message or "", end state, next actuation).

    ``outputs`` = (output period, number of outputs, duration, whether the duration is an extra output).
    """
    period, n_out, duration, end_extra = outputs
    b_end = bounds[-1]
    for a, b in itertools.pairwise(bounds):

        def rhs(t: float, y: np.ndarray, held: Any = held) -> np.ndarray:
            guard.tick(t, y)
            bar.update(t)  # progress inside a piece (a clock read between redraws)
            tau, force, torque, _ = held if held is not None else command(t, y)
            return derivative(y, tau, force, torque)

        inside = _outputs_in(a, b, period, n_out, duration if end_extra else None)
        # always evaluate at b too: the next piece starts from the state there
        t_eval = inside if inside.size and inside[-1] >= b - 1e-12 else np.append(inside, b)
        t_eval[-1] = b
        sol = _solve(rhs, a, b, x, t_eval, method, rtol, atol, ivp_events, stops)
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


def _stop_events(model: Model, stops: Any) -> list[Any]:
    """Terminal events at each finite limit of the joints not resting on a stop (upper: rising, lower: falling)."""
    found = []
    for i in range(model.n_joints):
        if i in stops.resting:
            continue
        for limit, direction in ((stops.upper[i], 1.0), (stops.lower[i], -1.0)):
            if np.isfinite(limit):

                def crossing(t: float, y: np.ndarray, index: int = 13 + i, limit: float = float(limit)) -> float:
                    return float(y[index] - limit)

                crossing.terminal = True  # type: ignore[attr-defined]
                crossing.direction = direction  # type: ignore[attr-defined]
                crossing.joint = i  # type: ignore[attr-defined]
                found.append(crossing)
    return found


def _solve(
    rhs: Any, a: float, b: float, x: np.ndarray, t_eval: np.ndarray, method: str, rtol: float, atol: float, events: list[Any], stops: Any
) -> Any:
    """``solve_ivp`` over (a, b); with joint stops, restarted at each crossing of a limit after the stop acted there."""
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
