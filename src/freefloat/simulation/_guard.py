"""What keeps a simulation from hanging (private): the cost estimate, progress, the divergence guard.

- :func:`estimate_run`: steps, controller samples, outputs, memory and wall time of a run, before it starts (the
  other checks before a run, which need the engine too, are :mod:`._prerun`'s, made with it in one call).
- :class:`Progress`: a progress bar that appears once a run has lasted ``delay`` seconds, or a callback.
- :class:`DivergenceGuard`: stops a run whose state grows without bound (see its docstring).
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import engine
from ..core.errors import SimulationError
from ..core.feedback import LOG_PERIOD, interactive, progress_log
from ..core.model import Model
from ..core.numbers import MAX_RATE  # beyond it a run stops: the actuation or the initial state is not physical
from ..core.state_layout import ATTITUDE_AT, qdot_at, span, state_length
from ..mechanics.momentum import system_inertia_matrix
from ..mechanics.springs import spring_energy

__all__ = [
    "DIVERGENCE_ANGLE",
    "MAX_RATE",
    "DivergenceGuard",
    "Progress",
    "RunEstimate",
    "estimate_run",
]

#: A joint (or the spacecraft) turning more than this many radians within one controller sample or
#: RK4 step, with the kinetic energy grown tenfold, is a diverging run. A stable sampled PD turns a
#: joint at most 4 x its angle error per sample (see :func:`._prerun.pd_gain_bounds`), so 20 rad is never met
#: by a stable loop, and nothing a sampled controller or an RK4 step computes is meaningful there.
DIVERGENCE_ANGLE = 20.0
#: A joint PD (no feed-forward, no reference rate, no external wrench) whose kinetic energy exceeds
#: this many times what it can supply (the initial kinetic energy + 1/2 sum kp (q0 - q_ref)^2) diverges.
ENERGY_FACTOR = 100.0
#: The adaptive integrator's mean step over its last ~100 steps below this fraction of the output
#: period (or of the duration, if shorter): the step size collapsed (the equations are too stiff for
#: the method, or the state diverges): a billion steps per recorded state.
MIN_STEP_FRACTION = 1e-9
#: The default wall-clock budget of a run (``max_wall_time="auto"``): this many times the estimate of
#: :func:`estimate_run`, and at least :data:`MIN_WALL_BUDGET` seconds.
WALL_BUDGET_FACTOR = 20.0
MIN_WALL_BUDGET = 60.0
#: Seconds of a running simulation before the automatic progress bar appears.
PROGRESS_DELAY = 2.0
#: Per controller sample: the cost assumed for a light Python controller and the recording (s).
_SAMPLE_COST = 2e-5


@dataclass(frozen=True)
class RunEstimate:
    """What a run will cost, known before it starts.

    ``steps``: RK4 steps (adaptive: a lower bound, one step per controller sample or output);
    ``samples``: controller evaluations; ``outputs``: recorded states; ``memory_bytes``: the
    recorded arrays; ``seconds``: estimated wall time (adaptive: a lower bound, the step count
    is not known before the run); ``compiles``: the engine's kernels for the run are not compiled on this machine
    yet (the run compiles them first; ``seconds`` excludes that and comes from a typical per-body cost, not timed);
    ``compile_seconds``: about how long that compile takes (the time measured when freefloat's portable kernels were
    built), None when not known.
    """

    steps: int
    samples: int
    outputs: int
    memory_bytes: int
    seconds: float
    adaptive: bool
    compiles: bool = False
    compile_seconds: float | None = None

    def describe(self) -> str:
        """One line: steps, samples, outputs, memory and time (and the compile before the run, if any)."""
        bound = "at least " if self.adaptive else ""
        compiling = ""
        if self.compiles:
            about = f"about {_duration(self.compile_seconds)} of " if self.compile_seconds else ""
            compiling = f", after {about}compiling the engine's kernels for this machine (once)"
        return (
            f"{bound}{self.steps:.3g} steps, {self.samples:.3g} controller samples, {self.outputs:.3g} recorded states "
            f"({self.memory_bytes / 1e6:.3g} MB), estimated {bound}{_duration(self.seconds)}" + compiling
        )


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.2g} s"
    if seconds < 7200:
        return f"{seconds / 60:.3g} min"
    if seconds < 86400 * 365:
        return f"{seconds / 3600:.3g} h"
    return f"{seconds / 86400 / 365:.3g} years"


_EVAL_COST: dict[tuple[int, int], float] = {}


#: Seconds per body per state derivative assumed before the engine's kernels are compiled on this machine (the
#: estimate of a first run, which compiles them at its start): a conservative figure for a current CPU core.
UNTIMED_COST_PER_BODY = 1e-6


def _derivative_cost(model: Model, *, fixed_step: bool = False) -> tuple[float, bool]:
    """Seconds per state derivative of ``model`` on this machine, and whether that was timed.

    Timed once per tree size, on a kernel that is ready (compiled in this process or in the cache; never compiled
    for the estimate): one RK4 step of the stepper (four derivatives), the kernel of a fixed-step run with a Python
    controller, first when ``fixed_step``; else the state derivative, the adaptive integrators' kernel, first. Before
    either is compiled, :data:`UNTIMED_COST_PER_BODY` per body, not timed (False).
    """
    n = model.n_joints
    key = (model.n_bodies, n)
    if key not in _EVAL_COST:
        stepper = engine.Stepper(model)
        x = np.zeros(stepper.size)
        x[ATTITUDE_AT + 3] = 1.0  # the unit quaternion [x, y, z, w]
        u = np.zeros(n + 6)
        order = ("rk4", "derivative") if fixed_step else ("derivative", "rk4")
        kind = next((k for k in order if stepper.ready(k)), None)  # the first ready one: the other is not loaded
        if kind is None:
            return UNTIMED_COST_PER_BODY * model.n_bodies, False
        y, out = x.copy(), np.empty_like(x)
        repeats = 20 if kind == "rk4" else 50
        start = time.perf_counter()
        for _ in range(repeats):
            if kind == "rk4":
                y[:] = x
                stepper.rk4(y, u, 1e-6, 1)
            else:
                stepper.derivative(x, u, out)
        _EVAL_COST[key] = (time.perf_counter() - start) / (repeats * (4 if kind == "rk4" else 1))
    return _EVAL_COST[key], True


def estimate_run(
    model: Model,
    duration: float,
    *,
    fixed_step: float | None = None,
    sample_period: float | None = None,
    output_period: float | None = None,
    controller: bool = True,
) -> RunEstimate:
    """Steps, controller samples, outputs, memory and wall time of ``simulate`` with these options (see :class:`RunEstimate`).

    ``controller``: whether a controller is sampled (False: free-floating, no Python per sample).
    The time is the engine's timed state derivative (4 per RK4 step, 12 per DOP853 step) plus
    20 us per controller sample and recorded state.
    """
    period = output_period or max(0.01, fixed_step or 0.0)
    outputs = int(duration / period) + 1
    cost, timed = _derivative_cost(model, fixed_step=fixed_step is not None)
    if fixed_step is not None:
        steps = round(duration / fixed_step)
        samples = round(duration / sample_period) if sample_period else steps
        seconds = steps * 4 * cost + (samples if controller else 0) * _SAMPLE_COST + outputs * _SAMPLE_COST
    else:
        samples = round(duration / sample_period) if sample_period else 0
        steps = max(samples, outputs)
        seconds = steps * 12 * cost + samples * _SAMPLE_COST + outputs * _SAMPLE_COST
    width = state_length(model.n_joints) + model.n_joints + 7
    compile_s = None if timed else engine.Stepper(model).compile_seconds("rk4" if fixed_step is not None else "derivative")
    return RunEstimate(
        int(steps), int(samples), int(outputs), int(outputs * width * 8), float(seconds), fixed_step is None, not timed, compile_s
    )


class Progress:
    """Progress of a run: ``mode`` True (a bar at once), None (a bar once the run has lasted
    :data:`PROGRESS_DELAY` s), False (none), or a callable ``callback(t, duration)`` called each
    time the simulated time has advanced by 1 % of the duration, and at the end. :meth:`update`
    is cheap (a clock read) between redraws.

    The bar is drawn on standard error when it is a terminal; elsewhere (a batch job, a notebook,
    a CI log) the same progress goes to the ``freefloat.progress`` logger at INFO, one line every
    :data:`freefloat.core.feedback.LOG_PERIOD` seconds. ``what`` names the work ("simulating").

    While the work waits (:meth:`waiting`: a compile of one of the engine's kernels in this process, said by the
    engine's compile watcher, or the workers of a campaign compiling), the bar or the log says what it waits for and
    for how long; the time left is estimated from the work done per second of wall time without the waits.
    """

    def __init__(
        self,
        mode: bool | Callable[[float, float], Any] | None,
        duration: float,
        what: str = "simulating",
        unit: str = "s",
        *,
        rate: bool = False,
    ) -> None:
        self.what, self.unit, self.rate = what, unit, rate
        self.logged = 0.0
        self.callback = mode if callable(mode) else None
        self.enabled = mode is not False
        self.delay = 0.0 if mode is True else PROGRESS_DELAY
        self.duration = duration
        self.start = time.perf_counter()
        self.last = 0.0
        self.next_t = 0.0
        self.t = 0.0
        self.bar: Any = None
        self.waited = 0.0  # wall time (s) the work waited (compiles), left out of the rate and the time left
        self.note = ""  # what it waits for now, and for how long ("" when it waits for nothing)
        self._wait_since: float | None = None
        self._wait_said = True
        self._lock = threading.Lock()
        self._watch: contextlib.ExitStack | None = None
        if self.enabled and self.callback is None:
            self._watch = contextlib.ExitStack()
            self._watch.enter_context(engine.watch_compiles(lambda what, _: self.waiting(what)))

    def update(self, t: float) -> None:
        """Report simulated time ``t`` (s)."""
        if not self.enabled:
            return
        if self.callback is not None:
            if t >= self.next_t or t >= self.duration:
                self.next_t = t + 0.01 * self.duration
                self.callback(float(t), self.duration)
            return
        now = time.perf_counter()
        if now - self.last < 0.1:
            return
        self.last = now
        self.t = float(t)
        self._show(now)

    def waiting(self, what: str | None) -> None:
        """The work waits for ``what`` ("compiling the engine's kernel rk4_steps for this machine (once)", "2 workers
        compiling the engine") from now until this is called with None: said with the time waited so far (called
        again to redraw it), and that time left out of the rate and of the estimate of the time left."""
        if not self.enabled or self.callback is not None:
            return
        now = time.perf_counter()
        if what is None:
            if self._wait_since is None:
                return
            self.waited += now - self._wait_since
            self._wait_since, self.note = None, ""
        else:
            if self._wait_since is None:
                self._wait_since, self._wait_said = now, False
            self.note = f"{what}, {_duration(now - self._wait_since)} elapsed"
        self._show(now)

    def _working(self, now: float) -> float:
        """Wall time (s) of work so far: the time since the start without the waits."""
        waiting = now - self._wait_since if self._wait_since is not None else 0.0
        return max(now - self.start - self.waited - waiting, 0.0)

    def _left(self, now: float) -> str:
        t = self.t
        return f"about {_duration(self._working(now) * (self.duration - t) / t)} left" if t > 0 else ""

    def _show(self, now: float) -> None:
        """Draw the bar, or log a line (every :data:`LOG_PERIOD` s, and when a wait starts), once the delay is over."""
        with self._lock:
            if self.bar is None:
                if now - self.start < self.delay:
                    return
                if not interactive():  # no terminal: a line to the logger now and then
                    if now - self.logged >= LOG_PERIOD or (self.note and not self._wait_said):
                        self.logged, self._wait_said = now, True
                        left, elapsed = self._left(now), now - self.start
                        progress_log.info(
                            "%s: %.4g / %.4g %s (%.0f%%)%s, %s elapsed%s%s", self.what, self.t, self.duration, self.unit,
                            100.0 * self.t / self.duration, self._rate(now), _duration(elapsed), f", {left}" if left else "",
                            f"; waiting: {self.note}" if self.note else "",
                        )  # fmt: skip
                    return
                from rich.console import Console
                from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

                self.bar = Progress(
                    TextColumn(self.what),
                    BarColumn(),
                    TextColumn("{task.completed:.4g} / {task.total:.4g} " + self.unit),
                    TextColumn("{task.fields[rate]}"),
                    TimeElapsedColumn(),
                    TextColumn("{task.fields[left]}"),
                    TextColumn("{task.fields[note]}"),
                    console=Console(stderr=True),
                    transient=True,
                )
                self.bar.start()
                self.bar.add_task(self.what, total=self.duration, rate="", left="", note="")
            note = f"waiting: {self.note}" if self.note else ""
            self.bar.update(self.bar.task_ids[0], completed=self.t, rate=self._rate(now), left=self._left(now), note=note)

    def _rate(self, now: float) -> str:
        """``", 2.5 runs/s"`` with ``rate`` (the work done per second of wall time so far, without the waits), else empty."""
        working = self._working(now)
        return f", {self.t / working:.3g} {self.unit}/s" if self.rate and working > 0 else ""

    def close(self) -> None:
        """Remove the bar (if one appeared) and stop watching the engine's compiles."""
        if self._watch is not None:
            self._watch.close()
            self._watch = None
        with self._lock:
            if self.bar is not None:
                self.bar.stop()
                self.bar = None


class DivergenceGuard:
    """Stops a run whose state grows without bound, with a :class:`SimulationError` that names the joint.

    Three tests:

    - **growth**: the fastest joint (or the spacecraft) turns more than :data:`DIVERGENCE_ANGLE`
      rad within one controller sample (or RK4 step) ``h`` while the kinetic energy has grown
      more than tenfold from its initial value: no stable loop does that (a stable sampled PD
      turns a joint at most 4x its error per sample), and nothing sampled that fast means
      anything. Checked at every controller sample and output, and inside adaptive steps.
    - **energy** (a :class:`~freefloat.JointPD` without feed-forward, reference rate or external
      wrenches): the kinetic energy exceeds :data:`ENERGY_FACTOR` times the energy the PD can
      supply, ``budget`` = initial kinetic energy + 1/2 sum kp (q0 - q_ref)^2 (a stable PD only
      loses energy; its sampled version gains a bounded fraction).
    - **step collapse** (adaptive integrators): the mean step over the last ~100 steps falls
      below :data:`MIN_STEP_FRACTION` of ``resolution`` (the output period, or the duration if shorter).
    - **beyond meaning** (every integrator, with or without a controller): a joint rate or a spacecraft
      spin above :data:`MAX_RATE` (the controller's torques or the initial state are not physical; an
      adaptive integrator would otherwise shrink its steps to follow the motion for ever).
    - **wall clock** (:meth:`clock`): the run has computed for longer than ``wall_limit`` seconds.
    """

    def __init__(
        self,
        model: Model,
        x0: np.ndarray,
        resolution: float,
        h: float | None,
        what: str,
        enabled: bool = True,
        controller: Any = None,
        wall_limit: float | None = None,
        duration: float = 0.0,
        wheels: int = 0,
    ) -> None:
        self.model = model
        # the last ``wheels`` joints of ``model`` are reaction wheels (freefloat.core.wheels.wheel_joint_model): their speed is
        # the actuator's, fast by design, so only the beyond-meaning test looks at it
        self.robot = model.n_joints - wheels
        self.wall_limit = wall_limit  # independent of ``enabled``: divergence_guard=False still ends
        self.duration = duration
        self.started = time.perf_counter()
        self.n = n = model.n_joints
        # the flat state's blocks the tests read (core.state_layout): q, the robot's joint rates, the wheels' speeds, v_cm, omega0
        self._q, self._v_cm, self._omega = span("q", n), span("v_cm", n), span("omega", n)
        self._rates = slice(qdot_at(n), qdot_at(n) + self.robot)
        self._speeds = slice(qdot_at(n) + self.robot, qdot_at(n) + n)
        self.h = h
        self.what = what
        self.enabled = enabled
        # the energy the motion may take without actuation: the kinetic energy, and the joints' springs' potential
        springs = float(spring_energy(model, x0[self._q])) if model.has_springs else 0.0
        self.energy0 = self._energy(x0, initial=True) + springs
        self.budget = self._pd_budget(controller, x0)
        self.min_step = MIN_STEP_FRACTION * resolution
        self.evals = 0
        self.window_t: list[float] = []
        self.rate_checked = -1.0

    def _pd_budget(self, controller: Any, x0: np.ndarray) -> float | None:
        from .pd import JointPD

        if not isinstance(controller, JointPD) or controller.feedforward is not None or np.any(np.asarray(controller.qdot_ref) != 0):
            return None
        n = self.n
        try:
            kp = np.broadcast_to(np.asarray(controller.kp, dtype=float), (n,))
            error = np.broadcast_to(np.asarray(controller.q_ref, dtype=float), (n,)) - x0[self._q]
        except ValueError:
            return None
        return self.energy0 + 0.5 * float(np.sum(np.abs(kp) * error**2))

    def _energy(self, x: np.ndarray, *, initial: bool = False) -> float:
        velocity = np.concatenate([x[self._v_cm], x[self._omega], x[span("qdot", self.n)]])  # (a dissipated energy may follow)
        # the initial state's H+ by the barycentric sums (one configuration, numpy: no kernel to compile before the run);
        # later, the engine's H+ directly: a diverging state is past what the public calls accept (|q| > 1e6)
        with np.errstate(over="ignore", invalid="ignore"):
            if initial:
                h_plus = system_inertia_matrix(self.model, x[self._q], method="barycentric")
            else:
                h_plus = engine.inertia_matrix(self.model, np.ascontiguousarray(x[self._q]))
            energy = 0.5 * float(velocity @ h_plus @ velocity)
        return energy if np.isfinite(energy) else np.inf

    def _rates_grew(self, x: np.ndarray) -> bool:
        """Whether the fastest rate is 1.2x the one at the last energy test (the kinetic energy, an H+ evaluation,
        cannot have grown much without the rates growing: it is tested then, not at every step)."""
        rates = x[self._rates]
        rate = max(float(np.abs(rates).max(initial=0.0)), float(np.abs(x[self._omega]).max()), float(np.abs(x[self._v_cm]).max()))
        if rate <= 1.2 * self.rate_checked:
            return False
        self.rate_checked = rate
        return True

    def _fastest(self, x: np.ndarray) -> tuple[str, float, str]:
        """The fastest joint or the spacecraft: (who, rate, unit of the rate)."""
        n = self.n
        rates = np.abs(x[self._rates])
        spin = float(np.linalg.norm(x[self._omega]))
        if n and rates.max() >= spin:
            i = int(np.argmax(rates))
            return f"joint {self.model.joint_names[i]!r}", float(rates[i]), "m/s" if self.model.prismatic[i] else "rad/s"
        return "the spacecraft", spin, "rad/s"

    @property
    def rate_limit(self) -> float:
        """The joint rate (rad/s) above which :meth:`check` must look (inf: never)."""
        if not self.enabled:
            return float("inf")
        return min(DIVERGENCE_ANGLE / self.h, MAX_RATE) if self.h else MAX_RATE

    @property
    def joint_rate_limits(self) -> np.ndarray:
        """Per joint of ``model``, the rate above which :meth:`check` must look: :attr:`rate_limit` for the robot's joints,
        :data:`MAX_RATE` for the reaction wheels' (inf: never)."""
        out = np.full(self.n, MAX_RATE if self.enabled else np.inf)
        out[: self.robot] = self.rate_limit
        return out

    def quiet(self, values: list[float]) -> bool:
        """True when the flat state ``values`` (a list: plain floats are cheaper than numpy for a few joints)
        cannot fail :meth:`check`: no energy test to make and every rate too slow for the growth test."""
        if not self.enabled:
            return True
        if self.budget is not None:
            return False
        rates, spin = values[self._rates], values[self._omega]
        bound = max(max(rates, default=0.0), -min(rates, default=0.0), 1.7320508075688772 * max(max(spin), -min(spin)))
        return bound <= self.rate_limit and self._wheels_below(values)

    def _wheels_below(self, x: Any) -> bool:
        """True when every reaction wheel turns slower than :data:`MAX_RATE` (always, for a model without wheels)."""
        return self.robot == self.n or float(np.abs(np.asarray(x[self._speeds])).max()) <= MAX_RATE

    def check(self, t: float, x: np.ndarray) -> None:
        """Raise if the state at ``t`` has grown without bound (the growth and energy tests)."""
        if not self.enabled:
            return
        if self.budget is not None and self.budget > 0 and self._rates_grew(x):
            energy = self._energy(x)
            if energy > ENERGY_FACTOR * self.budget:
                who, rate, _ = self._fastest(x)
                raise SimulationError(
                    f"the simulation diverged at t = {t:.6g} s: the kinetic energy is {energy:.3g} J, over {ENERGY_FACTOR:g} times "
                    f"the {self.budget:.3g} J the joint PD can supply (initial kinetic energy + 1/2 sum kp (q0 - q_ref)^2); "
                    f"fastest: {who} at {rate:.3g} rad/s. The sampled PD is unstable: lower the gains (see StiffGainsWarning) "
                    "or shorten the sample period"
                )
        # fast path, every step: a bound on the fastest rate in plain floats (the spin norm <= sqrt(3) max |omega_i|)
        rates, spin = x[self._rates].tolist(), x[self._omega].tolist()
        bound = max(max(rates, default=0.0), -min(rates, default=0.0), 1.7320508075688772 * max(max(spin), -min(spin)))
        if not self._wheels_below(x):
            speeds = np.abs(x[self._speeds])
            i = int(np.argmax(speeds))
            raise SimulationError(
                f"the simulation left what the model can mean at t = {t:.6g} s: reaction wheel "
                f"{self.model.joint_names[self.robot + i]!r} turns at {speeds[i]:.3g} rad/s, beyond {MAX_RATE:g} rad/s. Give the "
                "wheel its speed limit (max_speed, Basilisk's Omega_max) or check the controller's wheel torques"
            )
        if bound <= self.rate_limit:
            return
        who, rate, unit = self._fastest(x)
        if self.h is not None and rate * self.h > DIVERGENCE_ANGLE:
            energy = self._energy(x)
            if energy > 10.0 * self.energy0:
                raise SimulationError(
                    f"the simulation diverged at t = {t:.6g} s: {who} turns at {rate:.3g} rad/s, {rate * self.h:.3g} rad per "
                    f"{self.what} of {self.h:.3g} s, and the kinetic energy grew to {energy:.3g} J (the energy at the start: "
                    f"{self.energy0:.3g} J). The sampled controller is unstable or the step too long: lower the gains (see "
                    "StiffGainsWarning) or shorten the sample period / step"
                )
        if rate > MAX_RATE:
            raise SimulationError(
                f"the simulation left what the model can mean at t = {t:.6g} s: {who} moves at {rate:.3g} {unit}, beyond "
                f"{MAX_RATE:g} {unit}, which no joint or spacecraft of a space robot reaches. The actuation (the controller's "
                "output) or the initial state is not physical: check its units and size (pass divergence_guard=False to "
                "simulate it anyway)"
            )

    def clock(self, t: float) -> None:
        """Raise once the run has computed for longer than ``wall_limit`` seconds (None: never)."""
        if self.wall_limit is None:
            return
        elapsed = time.perf_counter() - self.started
        if elapsed <= self.wall_limit:
            return
        pace = f"; at this pace the rest would take {_duration(elapsed * (self.duration - t) / t)}" if t > 0 else ""
        raise SimulationError(
            f"the simulation used its wall-clock budget of {_duration(self.wall_limit)}: {_duration(elapsed)} of computing "
            f"reached t = {t:.6g} s of {self.duration:g} s{pace}. Pass max_wall_time (seconds, or None for no limit) to give "
            "it more time, or shorten the run; the trajectory so far is attached (error.trajectory)"
        )

    def tick(self, t: float, y: np.ndarray) -> None:
        """Called at each right-hand-side evaluation of an adaptive integrator: every test, every 64 calls."""
        self.evals += 1
        if self.evals % 64:
            return
        self.clock(t)
        if not self.enabled:
            return
        self.check(t, y)
        self.window_t.append(t)
        if len(self.window_t) < 20:  # 20 x 64 evaluations: about 100 steps of DOP853 (12 per step)
            return
        span = max(self.window_t) - min(self.window_t)
        self.window_t.clear()
        mean_step = span / (20 * 64 / 12)
        if mean_step < self.min_step:
            who, rate, _ = self._fastest(y)
            raise SimulationError(
                f"the adaptive step collapsed to {mean_step:.3g} s at t = {t:.6g} s (fastest: {who} at {rate:.3g} rad/s): "
                "the equations are too stiff for this integrator or the state diverges; use fixed_step (RK4) with a "
                "short step, lower the gains, or check the model's small inertias"
            )
