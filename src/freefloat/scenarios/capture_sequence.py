"""The capture sequence of a moving (tumbling) target: what ``freefloat capture`` runs after the plan when the
scenario has a ``[detumble]`` table (its schema: :mod:`.capture_scenario`; docs/impact.md, "The capture sequence
from the command line").

The sequence is the plan's, then one simulation, ``ff.simulate(robot, plan.grasp_state, t_grasp + duration,
capture=ff.Capture(target, at=t_grasp, controller_after=Detumble(...)))``, in two phases:

1. before the grasp (``[grasp] time`` t_grasp, default 0): the robot at rest in the planned capture posture
   (``plan.grasp_state``) floats free, uncontrolled (with zero momentum it stays where it is), while the target
   moves on its own, torque-free (:func:`~freefloat.simulation.coast`), from where it is at t = 0 to where the plan
   grasps it (``plan.target``, with its motion) at t_grasp: its motion run backwards in time for t_grasp gives its
   state at t = 0. At t_grasp the grasp is the impact of ``ff.capture.impact`` (momentum of robot + target kept);
2. :class:`~freefloat.control.Detumble` on the combined model from the post-impact state for ``duration`` seconds
   (thrusters, joint torques and, with ``torque_by = "wheels"``, the reaction wheels; the controller sampled every
   ``sample_period``, the outputs at the same times so that :func:`~freefloat.control.detumble_cost` integrates the
   held actuation exactly).

What happened in each phase is reported (:meth:`CaptureSequence.phases`): the joints that met a hard stop (the
model's joint limits: the time, the limit and the rate at the stop), and the outputs where an actuator limit acted
(the reaction wheels' torque and speed limits). Before the run its cost is estimated (:func:`estimate_sequence`,
the estimate of ``ff.simulate``): recorded states beyond the free memory are refused, and a run estimated to take
long warns (``freefloat capture`` asks, as ``freefloat simulate`` does). The approach itself (the free flight to
the approach point of eq. 19) is not simulated.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..control.detumble import Detumble, DetumbleCost, detumble_cost
from ..core._figures import draw_box, move_box
from ..core.conventions import attitude_matrix
from ..core.target import Target
from ..mechanics.kinematics import forward_kinematics, system_cm
from ..mechanics.momentum import angular_momentum, linear_momentum, wheel_spin_momentum
from ..simulation.capture_event import Capture, CaptureRun
from ..simulation.coast import coast
from ..simulation.simulate import simulate
from ..simulation.trajectory_plots import animate_trajectory
from .capture_settings import DetumbleSettings

if TYPE_CHECKING:
    from ..analysis.capture import CapturePlan
    from ..simulation.trajectory import Trajectory

__all__ = ["CaptureSequence", "DetumbleSettings", "run_capture_sequence", "write_sequence_outputs"]

#: What the sequence writes under ``--out`` (the animation unless ``--no-animation``).
SEQUENCE_FILES = ("capture.md", "capture_detumble.npz", "capture_momentum.png", "capture_rates.png", "capture_actuation.png")
ANIMATION_FILE = "capture_detumble.gif"
#: The reaction wheels' figure, written when the model has wheels.
WHEEL_FIGURE = "capture_wheels.png"


@dataclass(frozen=True, eq=False)
class CaptureSequence:
    """The grasp and the detumbling run: the :class:`~freefloat.simulation.capture_event.CaptureRun`, its cost and
    the momentum of robot + target just before and just after the grasp ([linear N s; angular about the inertial
    origin N m s], inertial frame)."""

    settings: DetumbleSettings
    run: CaptureRun
    cost: DetumbleCost
    momentum_before: np.ndarray
    momentum_after: np.ndarray
    grasp_time: float = 0.0

    def phases(self) -> list[dict[str, Any]]:
        """What happened in each phase (JSON-ready): ``"before the grasp"`` (0 to the grasp) and ``"detumbling"`` (the
        grasp to the end), each with its times, the joints that met a hard stop (``joint_limit_events``: joint,
        bound, limit, kind, t, t_end, value: :class:`~freefloat.simulation.trajectory.JointLimitEvent`), the outputs
        where any actuator limit acted (``limited_outputs`` of ``outputs``) and, with reaction wheels, the outputs where
        each wheel's torque or speed limit acted."""
        run = self.run
        phases = [("before the grasp", run.before)] + ([] if run.after is None else [("detumbling", run.after)])
        return [_phase(name, traj) for name, traj in phases]

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready: the impact (momentum before and after, impulses, energy lost) and the detumbling cost."""
        hit, cost, s = self.run.impact, self.cost, self.settings
        assert hit is not None and self.run.after is not None
        after = self.run.after
        return {
            "settings": {
                "rate_gain": s.rate_gain,
                "duration": s.duration,
                "sample_period": s.sample_period,
                "specific_impulse": s.specific_impulse,
                "rest_rate": s.rest_rate,
                "rest_velocity": s.rest_velocity,
                "rest_joint_rate": s.rest_joint_rate,
                "attitude_xyzw": None if s.attitude is None else list(s.attitude),
                "force": s.force,
                "torque_by": s.torque_by,
            },
            "grasp_time": self.grasp_time,
            "phases": self.phases(),
            "combined_mass": float(hit.model.total_mass),
            "impact": {
                "momentum_before": self.momentum_before.tolist(),  # robot + target [N s; N m s about the origin], inertial
                "momentum_after": self.momentum_after.tolist(),  # the combined system's
                "momentum_change": (self.momentum_after - self.momentum_before).tolist(),
                "impulse": hit.impulse.tolist(),
                "joint_impulse": hit.joint_impulse.tolist(),
                "energy_lost": float(hit.energy_lost),
            },
            "detumble": {
                "status": after.status,
                "thruster_impulse": cost.thruster_impulse,
                "torque_impulse": cost.torque_impulse,
                "delta_v": cost.delta_v,
                "propellant_mass": cost.propellant_mass,
                "peak_joint_torque": cost.peak_joint_torque.tolist(),
                "peak_force": cost.peak_force,
                "peak_torque": cost.peak_torque,
                "time_to_rest": cost.time_to_rest,  # s, an output time (the run's clock: the grasp is at grasp_time)
                "rest_after_grasp": None if cost.time_to_rest is None else cost.time_to_rest - self.grasp_time,  # s
                "at_rest": cost.time_to_rest is not None,
                "final_rates": {"v_cm": cost.final_rates[0], "omega": cost.final_rates[1], "qdot_max": cost.final_rates[2]},
                "wheels": None
                if cost.peak_wheel_speed is None
                else {
                    "names": [w.name for w in after.model.wheels] if after.model is not None else [],
                    "peak_speed": cost.peak_wheel_speed.tolist(),
                    "peak_momentum": cost.peak_wheel_momentum.tolist(),  # type: ignore[union-attr]
                    "peak_torque": cost.peak_wheel_torque.tolist(),  # type: ignore[union-attr]
                    "saturated": cost.wheel_saturated.tolist(),  # type: ignore[union-attr]
                    "final_speed": after.wheel_speed[-1].tolist(),  # type: ignore[index]
                },
            },
        }

    def lines(self) -> list[str]:
        """The text of the sequence (appended to ``freefloat capture``'s)."""
        d = self.as_dict()
        imp, det, s = d["impact"], d["detumble"], self.settings

        def vec(v: Any) -> str:
            return "[" + ", ".join(f"{x:.6g}" for x in v) + "]"

        change = np.abs(self.momentum_after - self.momentum_before).max()
        rest = (
            "not at rest at the end"
            if det["time_to_rest"] is None
            else f"at rest from t = {det['time_to_rest']:.6g} s, {det['rest_after_grasp']:.6g} s after the grasp"
        )
        isp = "" if det["propellant_mass"] is None else f", propellant {det['propellant_mass']:.6g} kg (Isp {s.specific_impulse:g} s)"
        final = det["final_rates"]
        return [
            f"capture sequence   grasp at t = {self.grasp_time:g} s in the planned posture, then Detumble (rate gain "
            f"{s.rate_gain:g} 1/s) for {s.duration:g} s",
            f"  momentum before  {vec(imp['momentum_before'])} (robot + target: N s; N m s about the origin, inertial)",
            f"  momentum after   {vec(imp['momentum_after'])} (combined system); largest change {change:.3g}",
            f"  grasp impulse    {vec(imp['impulse'])}; joint impulse {vec(imp['joint_impulse'])}; energy lost {imp['energy_lost']:.6g} J",
            f"  detumble         {rest} (|ω0| <= {s.rest_rate:g} rad/s, |q̇| <= {s.rest_joint_rate:g}, |v_cm| <= {s.rest_velocity:g} m/s)",
            f"  final rates      |v_cm| {final['v_cm']:.3g} m/s, |ω0| {final['omega']:.3g} rad/s, max |q̇| {final['qdot_max']:.3g} rad/s",
            f"  thrusters        impulse {det['thruster_impulse']:.6g} N s, delta-v {det['delta_v']:.6g} m/s{isp}; "
            f"peak force {det['peak_force']:.6g} N, peak torque {det['peak_torque']:.6g} N m",
            f"  joint torques    peak {vec(det['peak_joint_torque'])} N m",
            *_wheel_lines(det["wheels"]),
            *_phase_lines(d["phases"]),
        ]

    def markdown(self, source: str, report: str, *, animation: bool = True) -> str:
        """``capture.md``: the whole report (``report``, the text of ``freefloat capture``) with the figures of the plan
        and of the sequence, and the animation."""
        names = ["capture_plan.png", "capture_tradeoff.png", *(n for n in SEQUENCE_FILES if n.endswith(".png"))]
        if self.run.after is not None and self.run.after.wheel_speed is not None:
            names.append(WHEEL_FIGURE)
        figures = [f"![{name[:-4].replace('_', ' ')}]({name})" for name in [*names, *([ANIMATION_FILE] if animation else [])]]
        text = report.rstrip("\n")
        return f"# Capture sequence: {source}\n\n```text\n{text}\n```\n\n" + "\n\n".join(figures) + "\n"


def _wheel_lines(wheels: dict[str, Any] | None) -> list[str]:
    if wheels is None:
        return ["  reaction wheels  none (the model has no [[wheels]])"]

    def vec(v: Any) -> str:
        return "[" + ", ".join(f"{x:.6g}" for x in v) + "]"

    limited = [n for n, hit in zip(wheels["names"], wheels["saturated"], strict=True) if hit]
    return [
        f"  reaction wheels  {', '.join(wheels['names'])}: peak speed {vec(wheels['peak_speed'])} rad/s, peak spin momentum "
        f"{vec(wheels['peak_momentum'])} N m s, peak torque {vec(wheels['peak_torque'])} N m",
        f"                   final speed {vec(wheels['final_speed'])} rad/s; limits acted on: {', '.join(limited) or 'none'}",
    ]


def _robot_momentum(model: Any, state: Any) -> np.ndarray:
    """[linear; angular about the inertial origin] of a resolved state, inertial frame (the wheels' spin included)."""
    lin = linear_momentum(model, state.velocity)
    spin = state.wheel_speed if model.wheels else None
    ang = angular_momentum(model, state.q, state.velocity, attitude=state.attitude, wheel_speed=spin) + np.cross(state.r_cm, lin)
    return np.concatenate([lin, ang])


def _phase(name: str, traj: Trajectory) -> dict[str, Any]:
    """One phase of :meth:`CaptureSequence.phases`."""
    limited = np.asarray(traj.saturated, dtype=bool)
    out: dict[str, Any] = {
        "phase": name,
        "t_start": float(traj.t[0]),
        "t_end": float(traj.t[-1]),
        "outputs": int(traj.t.size),
        "joint_limit_events": [dataclasses.asdict(e) for e in traj.joint_limit_events],
        "limited_outputs": int(limited.sum()),
        "wheels": None,
    }
    if traj.wheel_speed is not None and traj.model is not None and traj.model.wheels:
        torque, speed = np.asarray(traj.wheel_torque_saturated, dtype=bool), np.asarray(traj.wheel_speed_saturated, dtype=bool)
        out["wheels"] = {
            w.name: {"torque_limited_outputs": int(torque[:, i].sum()), "speed_limited_outputs": int(speed[:, i].sum())}
            for i, w in enumerate(traj.model.wheels)
        }
    return out


def _phase_lines(phases: list[dict[str, Any]]) -> list[str]:
    """The text of :meth:`CaptureSequence.phases`: per phase, the hard stops met and the actuator limits that acted."""
    lines = []
    for k, phase in enumerate(phases):
        head = "  phases           " if k == 0 else "                   "
        stops = [
            f"{e['joint']} at its {e['bound']} {'stop' if e['kind'] == 'impact' else 'limit'} {e['limit']:.6g} at t = {e['t']:.6g} s "
            f"({'rate' if e['kind'] == 'impact' else 'reached'} {e['value']:.3g})"
            for e in phase["joint_limit_events"]
        ]
        wheels = [
            f"{name} torque at {w['torque_limited_outputs']}, speed at {w['speed_limited_outputs']}"
            for name, w in (phase["wheels"] or {}).items()
            if w["torque_limited_outputs"] or w["speed_limited_outputs"]
        ]
        limits = (
            "no actuator limit acted"
            if not phase["limited_outputs"]
            else (
                f"an actuator limit acted at {phase['limited_outputs']} of {phase['outputs']} outputs"
                + (f" (wheels: {'; '.join(wheels)})" if wheels else "")
            )
        )
        joints = "no joint met a stop" if not stops else f"JOINT LIMITS: {'; '.join(stops)}"
        lines.append(f"{head}{phase['phase']} (t = {phase['t_start']:.6g} to {phase['t_end']:.6g} s): {joints}; {limits}")
    return lines


def _earlier(target: Target, seconds: float) -> Target:
    """The target ``seconds`` before it is ``target`` (one target): its torque-free motion run backwards. Reversed in
    time, a torque-free motion is the torque-free motion with the velocities negated (Euler's equations are even in
    ω), so coasting the target with -v, -ω for ``seconds`` and negating the velocities gives it."""
    reverse = Target(
        mass=target.mass, inertia=target.inertia, position=target.position, attitude=target.attitude,
        velocity=-target.velocity, angular_velocity=-target.angular_velocity,
    )  # fmt: skip
    back = coast(reverse, seconds).at(seconds)
    return Target(
        mass=back.mass, inertia=back.inertia, position=back.position, attitude=back.attitude,
        velocity=-back.velocity, angular_velocity=-back.angular_velocity,
    )  # fmt: skip


def run_capture_sequence(plan: CapturePlan, settings: DetumbleSettings, grasp_time: float = 0.0) -> CaptureSequence:
    """The grasp at the planned posture at ``grasp_time`` (s) and the detumbling run (module docstring) of a moving
    target's plan; the target at t = 0 is where its own motion brings it to the planned grasp at ``grasp_time``."""
    if plan.grasp_state is None or plan.target is None or plan.impact is None:
        raise ValueError("[detumble]: needs a moving target (give [payload] velocity or angular_velocity)")
    if isinstance(grasp_time, bool) or not isinstance(grasp_time, (int, float)) or not (np.isfinite(grasp_time) and grasp_time >= 0.0):
        raise ValueError(f"grasp_time: expected a finite time >= 0 (s), got {grasp_time!r}")
    robot = plan.before
    target = plan.target if grasp_time == 0.0 else _earlier(plan.target, float(grasp_time))
    controller = Detumble(
        robot, rate_gain=settings.rate_gain, attitude=settings.attitude, force=settings.force, torque_by=settings.torque_by
    )
    capture = Capture(target, at=float(grasp_time), end_effector=plan.end_effector, joints=plan.impact.joints, controller_after=controller)
    period = settings.sample_period
    run = simulate(
        robot, plan.grasp_state, grasp_time + settings.duration, capture=capture, sample_period=period, output_period=period,
        warn_after=None,  # estimated by the caller (estimate_sequence)
    )  # fmt: skip
    assert run.impact is not None and run.after is not None and run.t_capture is not None
    cost = detumble_cost(
        run.after,
        specific_impulse=settings.specific_impulse,
        rest_rate=settings.rest_rate,
        rest_velocity=settings.rest_velocity if settings.force else None,
        rest_joint_rate=settings.rest_joint_rate,
    )
    before = _robot_momentum(robot, run.before.state(-1).resolve(robot))
    grasped = run.coast.at(run.t_capture)
    target_momentum = np.array(grasped.momentum, dtype=float)
    target_momentum[3:] += np.cross(grasped.position, target_momentum[:3])
    after = _robot_momentum(run.impact.model, run.impact.state.resolve(run.impact.model))
    return CaptureSequence(
        settings=settings, run=run, cost=cost, momentum_before=before + target_momentum, momentum_after=after, grasp_time=float(grasp_time)
    )


def write_sequence_outputs(
    sequence: CaptureSequence, source: str, report: str, out: Path, *, dpi: int = 120, animation: bool = True
) -> list[Path]:
    """``capture.md`` (``report``: the text of the whole run), the run (``capture_detumble.npz``), the figures and the
    animation (``capture_detumble.gif``)."""
    from matplotlib.figure import Figure

    after = sequence.run.after
    assert after is not None
    written = [out / "capture.md", after.save(out / "capture_detumble.npz", overwrite=True)]
    written[0].write_text(sequence.markdown(source, report, animation=animation))
    figures = [("capture_momentum.png", _plot_momentum), ("capture_rates.png", _plot_rates), ("capture_actuation.png", _plot_actuation)]
    if after.wheel_speed is not None:
        figures.append((WHEEL_FIGURE, _plot_wheels))
    for name, draw in figures:
        fig = Figure(figsize=(7.0, 7.0), layout="constrained")
        draw(sequence, fig.subplots(3, 1, sharex=True))
        fig.savefig(out / name, dpi=dpi)
        written.append(out / name)
    if animation:
        overlay = _target_overlay(sequence)
        frames = sequence.settings.frames
        written.append(
            animate_trajectory(
                after, out / ANIMATION_FILE, max_frames=frames, fps=10, dpi=60, overwrite=True, progress=False, overlay=overlay
            )
        )
    return written


def _target_corners(sequence: CaptureSequence) -> np.ndarray:
    """The grasped target drawn as the uniform box of its mass and inertia (as the spacecraft bus is drawn), held by
    the grasping body: its corners (T, 8, 3) at the outputs of the detumbling run, inertial frame."""
    after, hit = sequence.run.after, sequence.run.impact
    assert after is not None and hit is not None and after.model is not None
    model = after.model
    e = model.end_effector_index(hit.end_effector)
    k = int(model.end_effector_body[e])
    moments, axes = np.linalg.eigh(np.asarray(hit.payload_inertia, dtype=float))
    size = np.sqrt(np.maximum(6.0 * (moments.sum() - 2.0 * moments) / float(hit.payload_mass), 0.0))
    signs = np.array([[1.0 if c >> i & 1 else -1.0 for i in range(3)] for c in range(8)])
    local = model.end_effector_point[e] + np.asarray(hit.payload_offset) + (signs * (0.5 * size)) @ axes.T  # body k frame
    rot, pos = forward_kinematics(model, after.q)
    corners = pos[:, k, None, :] + np.einsum("tij,cj->tci", rot[:, k], local) - system_cm(model, after.q)[:, None, :]
    return np.asarray(np.einsum("tij,tcj->tci", attitude_matrix(after.attitude), corners) + after.r_cm[:, None, :])


def _target_overlay(sequence: CaptureSequence) -> Any:
    """The animation's overlay (:func:`~freefloat.simulation.trajectory_plots.animate_trajectory`): the target's box."""
    corners = _target_corners(sequence)

    def overlay(ax: Any, frames: np.ndarray) -> tuple[np.ndarray, Any]:
        box = draw_box(ax, corners[frames[0]], color="C3", alpha=0.9, label="target")
        ax.legend(fontsize="x-small", loc="upper right")

        def draw(i: int) -> list[Any]:
            move_box(box, corners[frames[i]])
            return [box]

        return corners[frames], draw

    return overlay


_XYZ = ("x", "y", "z")


def _plot_momentum(sequence: CaptureSequence, axes: Any) -> None:
    """Momentum of robot + target over the whole run (both phases; the combined system's after the grasp), with the
    values just before and just after the grasp marked."""
    run, after = sequence.run, sequence.run.after
    assert after is not None and run.t_capture is not None
    lin, ang = np.asarray(run.linear_momentum), np.asarray(run.angular_momentum)
    t_e = run.t_capture
    for ax, values, k0, unit, what in ((axes[0], lin, 0, "N s", "linear"), (axes[1], ang, 3, "N m s", "angular (origin)")):
        for i in range(3):
            (line,) = ax.plot(run.t, values[:, i], label=f"{what} {_XYZ[i]}")
            ax.plot([t_e], [sequence.momentum_before[k0 + i]], "o", color=line.get_color(), mfc="none", ms=9)
            ax.plot([t_e], [sequence.momentum_after[k0 + i]], "x", color=line.get_color(), ms=7)
        ax.axvline(t_e, color="0.5", ls=":", lw=0.8)
        ax.set_ylabel(unit)
        ax.legend(fontsize="x-small", loc="upper right")
    hit = run.impact
    assert hit is not None
    impulse = ", ".join(f"{x:.3g}" for x in hit.impulse)
    axes[0].set_title(
        f"Momentum of robot + target (o before the grasp at t = {t_e:g} s, x after), then detumbling\n"
        f"grasp impulse on the target [{impulse}]\n(N s; N m s about its CM), energy lost {hit.energy_lost:.3g} J",
        fontsize="medium",
    )
    axes[2].plot(after.t, np.linalg.norm(after.v_cm, axis=-1), label="|v_cm| (m/s)")
    axes[2].plot(after.t, np.linalg.norm(after.omega, axis=-1), label="|ω0| (rad/s)")
    axes[2].set_yscale("log")
    axes[2].legend(fontsize="x-small")
    axes[2].set_xlabel("t (s)")


def _plot_rates(sequence: CaptureSequence, axes: Any) -> None:
    """ω0 (spacecraft frame), joint rates and v_cm (inertial) against time, the rest thresholds dashed."""
    after, s = sequence.run.after, sequence.settings
    assert after is not None
    names = after.model.joint_names if after.model is not None else [f"q{j}" for j in range(after.qdot.shape[1])]
    for ax, values, labels, unit, bound in (
        (axes[0], after.omega, [f"ω0 {a}" for a in _XYZ], "rad/s", s.rest_rate),
        (axes[1], after.qdot, [f"q̇ {n}" for n in names], "rad/s", s.rest_joint_rate),
        (axes[2], after.v_cm, [f"v_cm {a}" for a in _XYZ], "m/s", s.rest_velocity),
    ):
        for i, label in enumerate(labels):
            ax.plot(after.t, values[:, i], label=label)
        for sign in (-1.0, 1.0):
            ax.axhline(sign * bound, color="0.5", ls="--", lw=0.8)
        ax.set_ylabel(unit)
        ax.legend(fontsize="x-small", loc="upper right")
    stops = list(after.joint_limit_events)
    for e in stops:  # the joints' hard stops: where, and which
        axes[1].axvline(e.t, color="C3", lw=1.0, alpha=0.8)
        axes[1].annotate(f"{e.joint} {e.bound} stop", (e.t, 1.0), xycoords=("data", "axes fraction"), fontsize="x-small", color="C3",
                         rotation=90, va="top", ha="right")  # fmt: skip
    marked = f"; red: {len(stops)} hard stop{'s' if len(stops) != 1 else ''} of the joints" if stops else ""
    axes[0].set_title(f"Rates after the grasp (dashed: the rest thresholds{marked})", fontsize="medium")
    axes[2].set_xlabel("t (s)")


def _plot_actuation(sequence: CaptureSequence, axes: Any) -> None:
    """Thruster force and torque (spacecraft frame) and joint torques against time, held between samples."""
    after = sequence.run.after
    assert after is not None
    names = after.model.joint_names if after.model is not None else [f"q{j}" for j in range(after.joint_torque.shape[1])]
    for ax, values, labels, unit in (
        (axes[0], after.spacecraft_force, [f"f_S {a}" for a in _XYZ], "N"),
        (axes[1], after.spacecraft_torque, [f"n_S {a}" for a in _XYZ], "N m"),
        (axes[2], after.joint_torque, [f"τ {n}" for n in names], "N m"),
    ):
        for i, label in enumerate(labels):
            ax.step(after.t, values[:, i], where="post", label=label)
        ax.set_ylabel(unit)
        ax.legend(fontsize="x-small", loc="upper right")
    axes[0].set_title("Thruster force and torque (spacecraft frame) and joint torques", fontsize="medium")
    axes[2].set_xlabel("t (s)")


def _plot_wheels(sequence: CaptureSequence, axes: Any) -> None:
    """The reaction wheels: speed (relative to the spacecraft), motor torque applied, and the rotor's spin momentum,
    with the limits dashed and the outputs where a limit acted marked."""
    after = sequence.run.after
    assert after is not None and after.model is not None and after.wheel_speed is not None
    wheels = after.model.wheels
    spin = wheel_spin_momentum(after.model, after.wheel_speed, after.omega)
    limited = np.asarray(after.wheel_torque_saturated) | np.asarray(after.wheel_speed_saturated)
    for i, wheel in enumerate(wheels):
        (line,) = axes[0].plot(after.t, after.wheel_speed[:, i], label=f"Ω {wheel.name}")
        axes[1].step(after.t, after.wheel_torque[:, i], where="post", color=line.get_color(), label=f"u {wheel.name}")  # type: ignore[index]
        axes[2].plot(after.t, spin[:, i], color=line.get_color(), label=f"Js (Ω + a·ω0) {wheel.name}")
        hits = limited[:, i]
        if hits.any():
            axes[1].plot(after.t[hits], after.wheel_torque[hits, i], "x", color=line.get_color(), ms=4)  # type: ignore[index]
        for ax, bound in ((axes[0], wheel.max_speed), (axes[1], wheel.max_torque)):
            if np.isfinite(bound):
                for sign in (-1.0, 1.0):
                    ax.axhline(sign * bound, color=line.get_color(), ls="--", lw=0.8)
    for ax, unit in zip(axes, ("rad/s", "N m", "N m s"), strict=True):
        ax.set_ylabel(unit)
        ax.legend(fontsize="x-small", loc="upper right")
    axes[0].set_title(
        "Reaction wheels: speed, motor torque, spin momentum\n(dashed: the limits; x: an output where a limit acted)", fontsize="medium"
    )
    axes[2].set_xlabel("t (s)")
