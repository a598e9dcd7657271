"""The capture sequence of a moving (tumbling) target: what ``freefloat capture`` runs after the plan when the
scenario has a ``[detumble]`` table (its schema: :mod:`.capture_scenario`; docs/impact.md, "The capture sequence
from the command line").

The sequence is the plan's, then one simulation:

1. the robot at rest in the planned capture posture (``plan.grasp_state``) grasps the target (``plan.target``) at
   t = 0: ``ff.simulate(robot, plan.grasp_state, duration, capture=ff.Capture(plan.target, at=0.0,
   controller_after=Detumble(...)))``, the impact of ``ff.capture.impact`` (momentum of robot + target conserved);
2. :class:`~freefloat.control.Detumble` on the combined model from the post-impact state for ``duration`` seconds
   (thrusters and joint torques, the controller sampled every ``sample_period``, the outputs at the same times so
   that :func:`~freefloat.control.detumble_cost` integrates the held actuation exactly).

The approach itself (the free flight to the approach point of eq. 19) is not simulated: the robot starts at rest
at the planned pre-grasp state. Reaction wheels are not modelled: no wheel speeds are reported.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..control.detumble import Detumble, DetumbleCost, detumble_cost
from ..mechanics.momentum import angular_momentum, linear_momentum, wheel_spin_momentum
from ..simulation.capture_event import Capture, CaptureRun
from ..simulation.simulate import simulate

if TYPE_CHECKING:
    from ..analysis.capture import CapturePlan

__all__ = ["CaptureSequence", "DetumbleSettings", "run_capture_sequence", "write_sequence_outputs"]

#: What the sequence writes under ``--out`` (the animation unless ``--no-animation``).
SEQUENCE_FILES = ("capture.md", "capture_detumble.npz", "capture_momentum.png", "capture_rates.png", "capture_actuation.png")
ANIMATION_FILE = "capture_detumble.gif"
#: The reaction wheels' figure, written when the model has wheels.
WHEEL_FIGURE = "capture_wheels.png"


@dataclass(frozen=True)
class DetumbleSettings:
    """The scenario's ``[detumble]`` table: :class:`~freefloat.control.Detumble` and
    :func:`~freefloat.control.detumble_cost` settings, SI units."""

    rate_gain: float = 0.5  # 1/s
    duration: float = 20.0  # s
    sample_period: float = 0.05  # s, the controller's and the outputs'
    specific_impulse: float | None = None  # s
    rest_rate: float = 1e-3  # rad/s
    rest_velocity: float = 1e-3  # m/s
    rest_joint_rate: float = 1e-3  # rad/s
    attitude: tuple[float, float, float, float] | None = None  # [x, y, z, w], spacecraft -> inertial
    force: bool = True
    frames: int = 40  # frames of the animation
    torque_by: str = "thrusters"  # or "wheels": the spacecraft torque by the reaction wheels


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
                "time_to_rest": cost.time_to_rest,
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
        rest = "not at rest at the end" if det["time_to_rest"] is None else f"at rest from t = {det['time_to_rest']:.6g} s"
        isp = "" if det["propellant_mass"] is None else f", propellant {det['propellant_mass']:.6g} kg (Isp {s.specific_impulse:g} s)"
        final = det["final_rates"]
        return [
            f"capture sequence   grasp at t = 0 from the planned posture, then Detumble (rate gain {s.rate_gain:g} 1/s) "
            f"for {s.duration:g} s",
            f"  momentum before  {vec(imp['momentum_before'])} (robot + target: N s; N m s about the origin, inertial)",
            f"  momentum after   {vec(imp['momentum_after'])} (combined system); largest change {change:.3g}",
            f"  grasp impulse    {vec(imp['impulse'])}; joint impulse {vec(imp['joint_impulse'])}; energy lost {imp['energy_lost']:.6g} J",
            f"  detumble         {rest} (|ω0| <= {s.rest_rate:g} rad/s, |q̇| <= {s.rest_joint_rate:g}, |v_cm| <= {s.rest_velocity:g} m/s)",
            f"  final rates      |v_cm| {final['v_cm']:.3g} m/s, |ω0| {final['omega']:.3g} rad/s, max |q̇| {final['qdot_max']:.3g} rad/s",
            f"  thrusters        impulse {det['thruster_impulse']:.6g} N s, delta-v {det['delta_v']:.6g} m/s{isp}; "
            f"peak force {det['peak_force']:.6g} N, peak torque {det['peak_torque']:.6g} N m",
            f"  joint torques    peak {vec(det['peak_joint_torque'])} N m",
            *_wheel_lines(det["wheels"]),
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


def run_capture_sequence(plan: CapturePlan, settings: DetumbleSettings) -> CaptureSequence:
    """The grasp at the planned posture and the detumbling run (module docstring) of a moving target's plan."""
    if plan.grasp_state is None or plan.target is None or plan.impact is None:
        raise ValueError("[detumble]: needs a moving target (give [payload] velocity or angular_velocity)")
    robot, target = plan.before, plan.target
    controller = Detumble(
        robot, rate_gain=settings.rate_gain, attitude=settings.attitude, force=settings.force, torque_by=settings.torque_by
    )
    capture = Capture(target, at=0.0, end_effector=plan.end_effector, joints=plan.impact.joints, controller_after=controller)
    period = settings.sample_period
    run = simulate(robot, plan.grasp_state, settings.duration, capture=capture, sample_period=period, output_period=period)
    assert run.impact is not None and run.after is not None
    cost = detumble_cost(
        run.after,
        specific_impulse=settings.specific_impulse,
        rest_rate=settings.rest_rate,
        rest_velocity=settings.rest_velocity if settings.force else None,
        rest_joint_rate=settings.rest_joint_rate,
    )
    before = _robot_momentum(robot, plan.grasp_state.resolve(robot))
    target_momentum = target.momentum.copy()
    target_momentum[3:] += np.cross(target.position, target_momentum[:3])
    after = _robot_momentum(run.impact.model, run.impact.state.resolve(run.impact.model))
    return CaptureSequence(settings=settings, run=run, cost=cost, momentum_before=before + target_momentum, momentum_after=after)


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
        written.append(
            after.animate(out / ANIMATION_FILE, max_frames=sequence.settings.frames, fps=10, dpi=60, overwrite=True, progress=False)
        )
    return written


_XYZ = ("x", "y", "z")


def _plot_momentum(sequence: CaptureSequence, axes: Any) -> None:
    """Momentum of robot + target over the run (the combined system's), with the values before and after the grasp."""
    after = sequence.run.after
    assert after is not None
    lin = np.asarray(after.linear_momentum)
    ang = np.asarray(after.angular_momentum) + np.cross(after.r_cm, lin)
    for ax, values, k0, unit, what in ((axes[0], lin, 0, "N s", "linear"), (axes[1], ang, 3, "N m s", "angular (origin)")):
        for i in range(3):
            (line,) = ax.plot(after.t, values[:, i], label=f"{what} {_XYZ[i]}")
            ax.plot([after.t[0]], [sequence.momentum_before[k0 + i]], "o", color=line.get_color(), mfc="none", ms=9)
            ax.plot([after.t[0]], [sequence.momentum_after[k0 + i]], "x", color=line.get_color(), ms=7)
        ax.set_ylabel(unit)
        ax.legend(fontsize="x-small", loc="upper right")
    hit = sequence.run.impact
    assert hit is not None
    impulse = ", ".join(f"{x:.3g}" for x in hit.impulse)
    axes[0].set_title(
        f"Momentum of robot + target: o before the grasp, x after; then the detumbling thrusters\n"
        f"grasp impulse on the target [{impulse}] (N s; N m s about its CM), energy lost {hit.energy_lost:.3g} J",
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
    axes[0].set_title("Rates after the grasp (dashed: the rest thresholds)", fontsize="medium")
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
