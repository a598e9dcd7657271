"""Capture of a moving target during a simulation: :class:`Capture` (``ff.Capture``) and :class:`CaptureRun`.

``ff.simulate(model, state, duration, controller, capture=ff.Capture(target, at=t | within=d, ...))`` runs in
two phases:

1. The robot alone (``model``), the target coasting meanwhile, torque-free (:func:`~freefloat.simulation.coast`),
   until the capture event: the time ``at``, or the first instant the end-effector point comes within
   ``within`` metres of the grasp point (a point fixed in the target, in its frame). The distance event is a
   terminal event of the run (direction: closing): the adaptive integrator locates the crossing (scipy's
   root finding); fixed-step RK4 takes it at the end of the step that crossed (the run's events, one check
   per step). A start already within the distance captures at t = 0.
2. At the event the grasp is the impact of ``ff.capture.impact`` (:mod:`freefloat.mechanics.impact`) on the
   robot's state there and the target's: the combined model (``impact.model``) runs from the post-impact
   state (``impact.state``) to the end. The target is fixed to the grasping body at its pose of that
   instant (a remaining gap, at most ``within``, is closed by the grasp: the target is not moved). The
   controllers are told: ``on_capture(impact)`` is called on the controller and on ``controller_after``
   (where they have it), and ``controller_after`` (if given) replaces the controller for phase 2 (the
   combined model has the same joints, so the same controller may go on).

Phase 2 restarts the integrator at the event: its output times are t_e + k ``output_period`` and its
controller samples t_e + k ``sample_period`` (t is absolute in both phases: controllers and events see the
run's time). Its dissipated energy (the joints' damping and friction) goes on from phase 1's at the event: both
count from t = 0 (the grasp's own loss is ``impact.energy_lost``, apart). With ``fixed_step`` the capture time ``at``
must be a multiple of the step.

The result, a :class:`CaptureRun`, holds both phase trajectories, the impact, the event time, the target's
motion up to the grasp and the momentum of robot plus target throughout (inertial frame, about the inertial
origin), the same before and after the event to rounding. A capture that never triggers ends the run as
usual, with ``status == "no capture"`` and a message giving the closest approach and its time.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.errors import SimulationError
from ..core.model import Model
from ..core.numbers import real_array
from ..core.state import State, pack_state
from ..core.target import Target
from ..mechanics.impact import JOINT_MODES, Impact, impact
from ..mechanics.kinematics import end_effector_positions
from ._integrate import run
from ._plan import plan_run, positive
from ._record import _Recorder
from .coast import Coast, coast
from .pd import JointPD
from .trajectory import Trajectory

__all__ = ["Capture", "CaptureRun"]


def _time(value: Any, name: str) -> float | None:
    if value is None:
        return None
    if isinstance(value, (str, bytes, bool, np.bool_)):
        raise TypeError(f"Capture.{name}: expected a number, got {type(value).__name__} {value!r}")
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"Capture.{name}: expected a number, got {value!r}") from None
    return out


@dataclass(frozen=True, eq=False)
class Capture:
    """A capture event for :func:`freefloat.simulate` (``simulate(..., capture=ff.Capture(...))``).

    Parameters
        target            the ``ff.capture.Target`` at t = 0 (one target): it coasts, torque-free, until the event
        at                the capture time (s, 0 <= at <= duration), or None
        within            the capture distance (m, > 0), or None: the event is the first instant the end-effector
                          point comes within this distance of the grasp point. Give ``at`` or ``within``, not both
        grasp_point       (3,) m, the point of the target the end effector closes on, in the target's frame from
                          its CM (default: the CM)
        end_effector      the grasping end effector, name or index (default 0)
        joints            "free" or "locked": the joints during the grasp (``ff.capture.impact``)
        controller_after  a controller for the combined model after the grasp (None: the same controller)

    At the event the controller and ``controller_after`` are told through their method ``on_capture(impact)``,
    where they have one. ``simulate`` then returns a :class:`CaptureRun` (the module docstring says how the run goes).
    Bad values raise ``ValueError`` / ``TypeError`` naming the field (``Capture.within: ...``); the end effector
    and ``at`` against the duration are checked by ``simulate``, which knows the model and the duration.

    Examples
    --------
    >>> import freefloat as ff
    >>> model = ff.models.papadopoulos1992(arms=1)
    >>> state = ff.State(q=[0.5, 1.0])
    >>> tip = ff.end_effector_positions(model, state.q)[0]
    >>> target = ff.capture.Target(mass=100.0, inertia=10.0, position=tip + [0.3, 0.0, 0.0], velocity=[-0.1, 0.0, 0.0])
    >>> run = ff.simulate(model, state, 5.0, capture=ff.Capture(target, within=0.05))
    >>> run.status, round(run.t_capture, 6), run.after.model.total_mass - model.total_mass
    ('finished', 2.5, 100.0)
    """

    target: Target
    at: float | None = None
    within: float | None = None
    grasp_point: Any = (0.0, 0.0, 0.0)
    end_effector: str | int = 0
    joints: str = "free"
    controller_after: Callable[[float, State], Any] | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.target, Target):
            raise TypeError(f"Capture.target: expected a freefloat.capture.Target, got {type(self.target).__name__}")
        if self.target.shape:
            raise ValueError(f"Capture.target: expected one target, got a batch of shape {self.target.shape}")
        at, within = _time(self.at, "at"), _time(self.within, "within")
        if (at is None) == (within is None):
            raise ValueError(
                "Capture: give either at (the capture time, s) or within (the capture distance, m), "
                f"not {'both' if at is not None else 'neither'}"
            )
        if at is not None and not (np.isfinite(at) and at >= 0.0):
            raise ValueError(f"Capture.at: the capture time must be finite and >= 0 s, got {self.at!r}")
        if within is not None and not (np.isfinite(within) and within > 0.0):
            raise ValueError(f"Capture.within: the capture distance must be finite and > 0 m, got {self.within!r}")
        point = real_array(self.grasp_point, "Capture.grasp_point")
        if point.shape != (3,) or not np.all(np.isfinite(point)):
            raise ValueError(f"Capture.grasp_point: expected 3 finite numbers (m, target frame, from its CM), got {self.grasp_point!r}")
        if not isinstance(self.end_effector, (str, int, np.integer)) or isinstance(self.end_effector, bool):
            raise TypeError(f"Capture.end_effector: expected a name or an index, got {self.end_effector!r}")
        if not isinstance(self.joints, str) or self.joints not in JOINT_MODES:
            raise ValueError(f"Capture.joints: expected one of {', '.join(map(repr, JOINT_MODES))}, got {self.joints!r}")
        if self.controller_after is not None and not callable(self.controller_after):
            what = type(self.controller_after).__name__
            raise TypeError(f"Capture.controller_after: expected a callable (t, state) -> joint torques, got {what}")
        object.__setattr__(self, "at", at)
        object.__setattr__(self, "within", within)
        point.setflags(write=False)
        object.__setattr__(self, "grasp_point", point)


@dataclass(frozen=True, eq=False)
class CaptureRun:
    """A simulation with a capture event (``ff.simulate(..., capture=...)``): both phases and the grasp.

    Attributes
        before      :class:`Trajectory` of the robot alone (its model) from 0 to the event (its last sample: the
                    state just before the grasp), or to the end when there was no capture
        after       :class:`Trajectory` of the combined model from the event (its first sample: ``impact.state``)
                    to the end; None without a capture
        impact      the grasp (:class:`~freefloat.mechanics.impact.Impact`: ``.model``, ``.state``,
                    ``.impulse``, ``.joint_impulse``, ``.energy_lost``); None without a capture
        t_capture   the event time (s); None without a capture
        target      the coasting target at the output times of ``before`` (a batch ``ff.capture.Target`` of
                    ``len(before)``: ``.position``, ``.attitude``, ``.velocity``, ``.angular_velocity``, inertial)
        coast       its torque-free motion (:class:`~freefloat.simulation.coast.Coast`: ``.at(t)`` at any instant up to
                    the event, or to the end without a capture)
        capture     the :class:`Capture` asked for
        status      "finished" (captured, run to the end), "no capture" (the event never came), or the status of
                    the phase that stopped ("event": a terminal event of yours, "interrupted": Ctrl-C; "failed": the
                    ``run`` of the ``SimulationError`` raised by a failure after the grasp)
        message     what happened (the closest approach and its time when there was no capture)
        closest_approach  (distance m, time s): the end effector's closest approach to the grasp point up to the
                    grasp (at the outputs of ``before``; without a grasp, also at every point of the trajectory the
                    distance event was evaluated at)
    """

    before: Trajectory
    after: Trajectory | None
    impact: Impact | None
    t_capture: float | None
    target: Target
    coast: Coast
    capture: Capture
    status: str
    message: str
    closest_approach: tuple[float, float]

    @property
    def captured(self) -> bool:
        """True when the grasp happened."""
        return self.impact is not None

    @property
    def t(self) -> np.ndarray:
        """The output times of both phases (T1 + T2,), s: the event time appears twice (before and after the grasp)."""
        return self.before.t if self.after is None else np.concatenate([self.before.t, self.after.t])

    @property
    def dissipated_energy(self) -> np.ndarray | None:
        """The energy the joints' damping and friction have dissipated since t = 0 (T1 + T2,), J: phase 2's goes on from
        phase 1's (the grasp's loss, ``impact.energy_lost``, is not in it); None when a phase's is unknown."""
        before, after = self.before.dissipated_energy, None if self.after is None else self.after.dissipated_energy
        if before is None or (self.after is not None and after is None):
            return None
        return before if after is None else np.concatenate([before, after])

    @property
    def linear_momentum(self) -> np.ndarray:
        """Linear momentum of robot plus target (T1 + T2, 3), N s, inertial frame: constant without external forces."""
        before = self.before.linear_momentum + self.target.mass[:, None] * self.target.velocity
        return before if self.after is None else np.concatenate([before, self.after.linear_momentum])

    @property
    def angular_momentum(self) -> np.ndarray:
        """Angular momentum of robot plus target about the inertial origin (a fixed point) (T1 + T2, 3), N m s,
        inertial frame: each system's about its CM plus r_cm x its linear momentum."""
        robot = _about_origin(self.before)
        target = self.target.momentum[:, 3:] + np.cross(self.target.position, self.target.mass[:, None] * self.target.velocity)
        before = robot + target
        return before if self.after is None else np.concatenate([before, _about_origin(self.after)])

    @property
    def grasp_distance(self) -> np.ndarray:
        """The distance from the end-effector point to the grasp point at the output times of ``before`` (T1,), m."""
        end = _end_effector_index(self.before.model, self.capture.end_effector)  # type: ignore[arg-type]
        tips = self.before.end_effector_positions[:, end]
        grasp = _grasp_points(self.target, self.capture.grasp_point)
        return np.asarray(np.linalg.norm(tips - grasp, axis=-1))


def _grasp_points(target: Target, point: np.ndarray) -> np.ndarray:
    """The grasp point (3,) of the target's frame at each of a batch of targets: (T, 3) m, inertial frame."""
    return np.asarray(target.position + np.einsum("...ij,j->...i", target.rotation_matrix, point))


def _about_origin(traj: Trajectory) -> np.ndarray:
    return np.asarray(traj.angular_momentum + np.cross(traj.r_cm, traj.linear_momentum))


def _end_effector_index(model: Model, end_effector: str | int) -> int:
    try:
        return model.end_effector_index(end_effector)
    except KeyError as exc:
        raise ValueError(f"Capture.end_effector: {exc.args[0] if exc.args else exc}") from None


def _still(model: Model, state: State, t: float) -> Trajectory:
    """A one-sample trajectory: ``state`` at ``t`` (a phase of zero length), no actuation."""
    rec = _Recorder(model)
    zeros = (np.zeros(model.n_joints), np.zeros(3), np.zeros(3), np.array(False))
    rec.add(t, pack_state(state.resolve(model)), zeros)
    return rec.trajectory()


def _shifted(traj: Trajectory, dt: float, dissipated: float) -> Trajectory:
    """``traj`` with its times (and its joint-limit events') moved by ``dt`` and its dissipated energy by ``dissipated``
    (J: the energy dissipated before it started, so that it counts from the start of the whole run)."""
    events = tuple(dataclasses.replace(e, t=e.t + dt, t_end=None if e.t_end is None else e.t_end + dt) for e in traj.joint_limit_events)
    energy = None if traj.dissipated_energy is None else traj.dissipated_energy + dissipated
    return dataclasses.replace(traj, t=traj.t + dt, joint_limit_events=events, dissipated_energy=energy)


def _later(func: Any, dt: float) -> Any:
    """``func(t, state)`` seen from a run that starts at ``dt``: called with the absolute time; scipy's event
    attributes (``terminal``, ``direction``) and ``__name__`` kept."""
    if func is None or dt == 0.0 or (isinstance(func, JointPD) and func.feedforward is None):  # time-invariant: itself
        return func

    def shifted(t: float, state: State) -> Any:
        return func(t + dt, state)

    for name in ("terminal", "direction", "__name__"):
        if hasattr(func, name):
            setattr(shifted, name, getattr(func, name))
    return shifted


class _Gap:
    """The capture's event function: |end-effector point - grasp point| - within (m); terminal, closing. It keeps
    the closest approach among the points the integrator checked."""

    terminal = True
    direction = -1.0
    __name__ = "capture"

    def __init__(self, model: Model, end: int, motion: Coast, capture: Capture) -> None:
        self.model, self.end, self.motion, self.capture = model, end, motion, capture
        self.closest = (np.inf, 0.0)

    def distance(self, t: float, state: State) -> float:
        tip = state.r_cm + state.rotation.apply(end_effector_positions(self.model, state.q)[self.end])
        distance = float(np.linalg.norm(tip - self.motion.point(t, self.capture.grasp_point)))
        if distance < self.closest[0]:
            self.closest = (distance, float(t))
        return distance

    def __call__(self, t: float, state: State) -> float:
        return self.distance(t, state) - float(self.capture.within)  # type: ignore[arg-type]


def simulate_capture(model: Model, state: State, duration: float, controller: Any, capture: Capture, **options: Any) -> CaptureRun:
    """``ff.simulate(model, state, duration, controller, capture=capture, **options)``: a run with the grasp of a
    moving target (``options``: the other keyword arguments of :func:`freefloat.simulate`, all of them).

    Phase 1 simulates the robot alone (``model``) from t = 0 to the event, the target meanwhile coasting torque-free
    (:func:`~freefloat.simulation.coast`: its CM uniformly, its attitude by Euler's equations, inertial frame). The
    event is the time ``capture.at`` (s), or the first instant the end-effector point comes within ``capture.within``
    (m) of the grasp point (a terminal event of the run). At the event the grasp is the impact of
    :func:`freefloat.capture.impact` (:mod:`freefloat.mechanics.impact`: the generalized momentum balance
    H zdot0⁺ = H+ zdot0⁻ + J_tᵀ M_t V_t⁻ + [0; tau_hat], H+ of 1991 eq. 15, J_t the J+ of the target's CM on the
    grasping body, 1991 eqs. 7-10), which conserves the linear and angular momentum of robot plus target; phase 2
    simulates the combined model (``impact.model``) from the post-impact state (``impact.state``) to ``duration``,
    with the same options and absolute times (the module docstring has the details). Each phase is one run planned
    and checked as :func:`freefloat.simulate` plans one (:func:`._plan.plan_run`, :func:`._integrate.run`).

    Returns a :class:`CaptureRun`: both phases' trajectories, the impact, the event time (s), the target's motion and
    the momentum of robot plus target (inertial frame, about the inertial origin) throughout.
    """
    duration = positive("duration", duration)
    if not isinstance(capture, Capture):
        raise TypeError(f"capture: expected a freefloat.Capture, got {type(capture).__name__}")
    if not isinstance(model, Model):
        raise TypeError(f"model: expected a freefloat.Model, got {type(model).__name__}")
    end = _end_effector_index(model, capture.end_effector)
    step = options.get("fixed_step")
    if capture.at is not None:
        if capture.at > duration:
            raise ValueError(f"Capture.at: the capture time {capture.at:g} s is beyond the duration {duration:g} s")
        if step is not None and abs(round(capture.at / step) * step - capture.at) > 1e-9 * max(duration, step):
            raise ValueError(f"Capture.at: {capture.at:g} s is not a multiple of fixed_step = {step:g} s; choose a time that is")
    _check_controllers(model, controller, capture.controller_after)
    events: Sequence[Any] = tuple(options.get("events", ()))
    motion = coast(capture.target, duration if capture.at is None else capture.at)
    gap = _Gap(model, end, motion, capture)
    resolved = state.resolve(model)

    # phase 1: the robot alone until the event
    if capture.at is not None:
        before = _phase(model, state, capture.at, controller, options) if capture.at > 0.0 else _still(model, resolved, 0.0)
        fired = before.status == "finished"
        if fired and before.t[-1] != capture.at:  # RK4's i * dt may miss the capture time by a rounding: the time asked
            before = dataclasses.replace(before, t=np.append(before.t[:-1], capture.at))
    elif gap(0.0, resolved) <= 0.0:
        before, fired = _still(model, resolved, 0.0), True
    else:
        before = _phase(model, state, duration, controller, {**options, "events": (*events, gap)})
        fired = before.status == "event" and before.message.startswith(f"event {len(events)} ")
    target = motion.at(before.t)
    distance = _closest(before, None if fired else gap, target, capture, end)  # after a grasp, the gap saw beyond it
    if not fired:
        return _missed(before, motion, target, capture, distance, duration)

    # the grasp, then phase 2: the combined model from the post-impact state
    t_e = float(before.t[-1])
    try:
        grasp = impact(model, before.state(-1), motion.at(t_e), end_effector=end, joints=capture.joints)
    except ValueError as exc:  # the hand not on the target: said with the capture's time
        when = f"Capture.at = {capture.at:g} s" if capture.at is not None else f"Capture.within: the event at t = {t_e:.6g} s"
        raise ValueError(f"{when}: {exc}") from None
    after_controller = capture.controller_after if capture.controller_after is not None else controller
    for told in {id(c): c for c in (controller, capture.controller_after) if c is not None}.values():
        tell = getattr(told, "on_capture", None)
        if callable(tell):
            tell(grasp)
    remaining = duration - t_e
    spent = 0.0 if before.dissipated_energy is None else float(before.dissipated_energy[-1])  # phase 2 goes on from it
    run = dict(before=before, impact=grasp, t_capture=t_e, target=target, coast=motion, capture=capture, closest_approach=distance)
    if remaining <= 1e-12 * duration:
        after = _shifted(_still(grasp.model, grasp.state, 0.0), t_e, spent)
    else:
        later = {**options, "events": tuple(_later(ev, t_e) for ev in events)}
        try:
            after = _shifted(_phase(grasp.model, grasp.state, remaining, _later(after_controller, t_e), later), t_e, spent)
        except SimulationError as exc:  # the message's times count from the grasp (the second run's own clock): said so
            message = f"after the grasp at t = {t_e:.6g} s (times from the grasp): {exc}"
            failed = None if exc.trajectory is None else _shifted(exc.trajectory, t_e, spent)
            error = SimulationError(message, failed)
            error.run = CaptureRun(after=failed, status="failed", message=message, **run)  # type: ignore[attr-defined, arg-type]
            raise error from exc
    message = f"captured at t = {t_e:.6g} s ({capture.joints} joints, energy lost {grasp.energy_lost:.6g} J)"
    if after.message:
        message += f"; after the grasp (times from the grasp): {after.message}"
    return CaptureRun(after=after, status=after.status, message=message, **run)  # type: ignore[arg-type]


def _phase(model: Model, state: State, duration: float, controller: Any, options: dict[str, Any]) -> Trajectory:
    """One phase of the run: a simulation planned and checked as :func:`freefloat.simulate` plans one."""
    return run(plan_run(model, state, duration, controller, **options))


def _check_controllers(model: Model, controller: Any, after: Any) -> None:
    """Before the run: a controller made for another robot (its ``model``: other joints or wheels) is refused; the
    controller of phase 2 is told of the grasp and then controls the combined model, which has the robot's joints."""
    for name, told in (("controller", controller), ("Capture.controller_after", after)):
        other = getattr(told, "model", None)
        if not isinstance(other, Model) or other is model:
            continue
        mine = (model.joint_names, tuple(w.name for w in model.wheels))
        theirs = (other.joint_names, tuple(w.name for w in other.wheels))
        if mine != theirs:
            raise ValueError(
                f"{name}: was made for model {other.name!r} (joints {list(other.joint_names)}, wheels {list(theirs[1])}), "
                f"not for the simulated {model.name!r} (joints {list(model.joint_names)}, wheels {list(mine[1])}); make it with the "
                "robot that grasps (ff.control.Detumble(robot, ...)): after the grasp it controls the combined model"
            )


def _closest(before: Trajectory, gap: _Gap | None, target: Target, capture: Capture, end: int) -> tuple[float, float]:
    """The closest approach (distance, time) of the end effector to the grasp point over ``before``: at its outputs and
    (``gap``, a run without a grasp) at the points of the trajectory the event function saw (each step's end, and
    the integrator's dense output where it looked for the crossing)."""
    tips = before.end_effector_positions[:, end]
    grasp = _grasp_points(target, capture.grasp_point)
    distances = np.linalg.norm(tips - grasp, axis=-1)
    k = int(np.argmin(distances))
    best = (float(distances[k]), float(before.t[k]))
    return gap.closest if gap is not None and gap.closest[0] < best[0] else best


def _missed(
    before: Trajectory, motion: Coast, target: Target, capture: Capture, closest: tuple[float, float], duration: float
) -> CaptureRun:
    """The run without a capture: all of it kept, the reason (and the closest approach) in its message."""
    if before.status == "finished":
        status = "no capture"
        message = (
            f"no capture: the end effector came no closer than {closest[0]:.6g} m to the grasp point (at t = {closest[1]:.6g} s), "
            f"not within {capture.within:g} m, in the {duration:g} s run"
        )
    else:
        status, message = before.status, f"no capture: the run stopped before the event ({before.message})"
    return CaptureRun(
        before=before, after=None, impact=None, t_capture=None, target=target, coast=motion, capture=capture,
        status=status, message=message, closest_approach=closest,
    )  # fmt: skip
