"""What ``freefloat capture`` reports and writes (private home of :class:`CaptureResult`; see ``ff.scenarios``).

:class:`CaptureResult` is a capture scenario run (:func:`~freefloat.scenarios.capture_scenario.run_capture_scenario`):
its JSON summary (:meth:`CaptureResult.as_dict`, ``capture.json``), its text (:meth:`CaptureResult.render_text`) and
the figures: the plan like the 1992 paper's Fig. 7 (``capture_plan.png``), the eq. 21 families like its Fig. 6
(``capture_families.png``, a planar two-link arm) and, for a moving target, the trade-off among the candidate capture
postures (``capture_tradeoff.png``). Lengths in m, angles in rad (and deg where a key ends in ``_deg``), the target's
motion and the impact in the inertial frame except the spacecraft rate (spacecraft frame).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..analysis.capture import RANKINGS, CapturePlan, CapturePosture, CaptureRanking, PathMotion, capture_families
from .capture_sequence import CaptureSequence, write_sequence_outputs

if TYPE_CHECKING:
    from .capture_scenario import CaptureScenario

__all__ = ["CaptureResult", "plot_capture_families", "plot_capture_plan", "plot_capture_tradeoff", "write_capture_outputs"]


@dataclass(frozen=True, eq=False)
class CaptureResult:
    """A capture scenario run: the §V plan and, for a planar two-link arm, the best posture on each eq. 21 family."""

    scenario: CaptureScenario
    plan: CapturePlan
    family_postures: tuple[CapturePosture | None, ...]
    sequence: CaptureSequence | None = None  # the grasp and the detumbling run ([detumble]), :mod:`.capture_sequence`

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready summary; lengths in m, angles in rad and deg (``_deg``)."""
        p, placement = self.plan, self.plan.placement
        piw = p.piw

        def posture(post: CapturePosture | None) -> dict[str, Any] | None:
            if post is None:
                return None
            return {
                "family": post.family,
                "q": post.q.tolist(),
                "q_deg": np.degrees(post.q).tolist(),
                "measure": post.measure,
                "det": post.det,
                "residual": post.residual,
                "attitude_xyzw": post.attitude.tolist(),
                "theta": post.theta,
                "theta_deg": None if post.theta is None else float(np.degrees(post.theta)),
            }

        return {
            "scenario": self.scenario.source,
            "model": self.scenario.model.name,
            "end_effector": p.end_effector,
            "robot_mass": self.scenario.model.total_mass,
            "payload_mass": self.scenario.mass,
            "piw": {"R_min": piw.R_min, "R_max": piw.R_max, "intervals": [list(iv) for iv in piw.piw], "pdw": [list(iv) for iv in piw.pdw]},
            "reachable_after": {"R_min": piw.reachable.R_min, "R_max": piw.reachable.R_max},
            "path": placement.path.tolist(),
            "rule": placement.rule,
            "interval": list(placement.interval),
            "margin": placement.margin,
            "R_plus": placement.R_plus,
            "cm_plus": placement.cm_plus.tolist(),
            "approach_distance": placement.approach_distance,
            "approach_point": None if placement.approach_point is None else placement.approach_point.tolist(),
            "posture": posture(p.posture),
            "family_postures": [posture(f) for f in self.family_postures],
            "method": p.method,
            "why_path": p.why_path,
            "end_effectors": list(p.before.end_effector_names),  # the model's, in J* row order
            "singularity": {**p.criterion.as_dict(), "described": p.criterion.describe(p.captured)},
            "motion": None if p.motion is None else _motion_dict(p.motion),
            "grasp": _grasp_dict(p),
            # every check a plan must pass (plan_capture returns no plan that fails one)
            "checks": {
                # a PIW plan's path lies in the PIW (place_path); a path-checked plan is checked by its motion instead
                "path_in_workspace": bool(placement.margin >= 0.0) if p.method == "piw" else None,
                "motion_follows_path": None if p.motion is None else p.motion.follows_path,
                "singularity_free": None if p.motion is None else p.motion.singularity_free,
                "within_joint_limits": None if p.motion is None else p.motion.within_limits,
            },
            "sequence": None if self.sequence is None else self.sequence.as_dict(),
        }

    def render_text(self) -> str:
        """What ``freefloat capture`` prints."""
        sc, p, placement = self.scenario, self.plan, self.plan.placement
        piw = p.piw
        length = float(np.sum(np.linalg.norm(np.diff(placement.path, axis=0), axis=1)))

        def vec(v: np.ndarray) -> str:
            return "[" + ", ".join(f"{x:.6f}" for x in v) + "]"

        widest = "none" if piw.R_min is None else f"[{piw.R_min:.6f}, {piw.R_max:.6f}]"
        lines = [
            f"capture scenario {sc.source or '(dict)'} (Papadopoulos 1992 §V)",
            f"  model              {sc.model.name} ({sc.model.total_mass:.6g} kg), grasping end effector {p.end_effector}",
            f"  payload            {sc.mass:.6g} kg, inertia diag {vec(np.diag(sc.inertia))} kg m², CM offset {vec(sc.offset)} m",
            f"  after capture      reachable [{piw.reachable.R_min:.6f}, {piw.reachable.R_max:.6f}] m; PIW {widest} m (widest)",
            f"  path               {placement.path.shape[0]} points, length {length:.6g} m, start A = {vec(placement.start)} m (inertial)",
            f"  placement          rule {placement.rule}: path inside [{placement.interval[0]:.6f}, {placement.interval[1]:.6f}] m, "
            f"margin {placement.margin:.6f} m",
            f"  R+                 {placement.R_plus:.6f} m (CM+ to A)",
            f"  CM+                {vec(placement.cm_plus)} m (inertial)",
        ]
        if placement.approach_distance is not None and placement.approach_point is not None:
            lines += [
                f"  approach distance  R = {placement.approach_distance:.6f} m (eq. 19: (M + m_p)/M R+)",
                f"  free-flyer CM      {vec(placement.approach_point)} m before capture (on the line A -> CM+)",
            ]
        if p.method == "path":
            lines.append(f"  plan               path checked ({p.why_path}): the free-floating motion along it from this posture")
            lines.append("                     and attitude was integrated (1992 eqs. 12, 14): singularity-free, within the joint limits")
        if p.motion is not None:
            m = p.motion
            lines.append(f"  singularity        {m.criterion}")
            lines.append(
                f"  along the path     min |measure| {m.min_measure:.6g} over {m.s.size} points (threshold {m.threshold:g}), "
                f"max deviation {m.deviation:.2e} m: {'singularity-free' if m.singularity_free else 'MEETS A SINGULARITY'}"
            )
            margin = "no limits" if not np.isfinite(m.limit_margin) else f"closest approach {m.limit_margin:.4g}"
            lines.append(f"  joint limits       {'kept' if m.within_limits else 'CROSSED'} along the path ({margin})")
        if p.method == "path":
            lines.append("  capture posture    the most dexterous checked posture on |r_E| = R+ within the joint limits:")
        else:
            lines.append("  capture posture    max |det J*| subject to |r_E| = R+ (eq. 21) and the joint limits:")
        chosen = p.posture
        measure_name = {"sigma_min": "σ_min of J*", "det": "|det J*|"}.get(p.criterion.measure, "sqrt det J*J*ᵀ")
        ranked = p.ranking is not None and p.ranking.chosen != p.ranking.planner
        shown = [f for f in self.family_postures if f is not None] or ([] if ranked else [chosen])
        for post in shown:
            fam = "" if post.family is None else f"family {post.family + 1} ({'+' if post.family == 0 else '-'}acos)  "
            det = f"det J* = {post.det:+.6f}" if post.det is not None else f"{measure_name} = {post.measure:.6f}"
            theta = "" if post.theta is None else f", θ = {np.degrees(post.theta):.2f} deg"
            mark = "  <- chosen" if len(shown) > 1 and np.allclose(post.q, chosen.q, atol=1e-6) else ""
            lines.append(f"    {fam}q = [{', '.join(f'{v:.2f}' for v in np.degrees(post.q))}] deg, {det}{theta}{mark}")
        if ranked and p.ranking is not None:
            det = f"det J* = {chosen.det:+.6f}" if chosen.det is not None else f"{measure_name} = {chosen.measure:.6f}"
            theta = "" if chosen.theta is None else f", θ = {np.degrees(chosen.theta):.2f} deg"
            lines.append(
                f"    ranked by {p.ranking.rank_by}: q = [{', '.join(f'{v:.2f}' for v in np.degrees(chosen.q))}] deg, {det}{theta}  "
                f"<- chosen (the most dexterous has {'|det J*|' if chosen.det is not None else measure_name} = "
                f"{p.ranking.measure[p.ranking.planner]:.6f})"
            )
        quat = ", ".join(f"{v:.6f}" for v in chosen.attitude)
        theta = "" if chosen.theta is None else f"θ = {np.degrees(chosen.theta):.2f} deg, "
        lines.append(f"  spacecraft         {theta}attitude quaternion [x, y, z, w] = [{quat}] (eq. 20: end effector on A)")
        sequence = [] if self.sequence is None else self.sequence.lines()
        return "\n".join(lines + _grasp_lines(p) + sequence) + "\n"


#: Column headings of the ranking table (:func:`_grasp_lines`): criterion -> (heading, what its best row is called).
_COLUMNS = {
    "measure": ("measure", "most dexterous"),
    "spacecraft_rate": ("|ω0⁺| rad/s", "slowest spacecraft"),
    "impulse": ("|p̂| N s", "least impulse"),
    "angular_impulse": ("|L̂| N m s", "least angular impulse"),
    "joint_impulse": ("|τ̂| N m s", "least joint impulse"),
}


def _table_rows(ranking: CaptureRanking) -> dict[int, list[str]]:
    """The rows of the ranking table: candidate index -> what it is (chosen, most dexterous, best of a criterion)."""
    rows: dict[int, list[str]] = {ranking.chosen: [f"chosen (rank by {ranking.rank_by})"]}
    rows.setdefault(ranking.planner, []).append("most dexterous (1992 §V)")
    valid = np.flatnonzero(ranking.valid)
    for name in RANKINGS[1:]:
        if name == "joint_impulse" and ranking.joints == "free":
            continue
        best = int(valid[np.argmin(ranking.values(name)[valid])])
        rows.setdefault(best, []).append(_COLUMNS[name][1])
    return rows


def _grasp_lines(plan: CapturePlan) -> list[str]:
    """The text of a moving target's grasp: its motion, the impact at the chosen capture and the ranking table."""
    hit, ranking, target, state = plan.impact, plan.ranking, plan.target, plan.grasp_state
    if hit is None or ranking is None or target is None or state is None:
        return []

    def vec(v: np.ndarray, digits: int = 6) -> str:
        return "[" + ", ".join(f"{x:.{digits}g}" for x in v) + "]"

    lines = [
        f"  moving target      CM velocity {vec(target.velocity)} m/s, angular velocity {vec(target.angular_velocity)} rad/s "
        f"(inertial), {ranking.joints} joints at the grasp",
        f"  before the grasp   robot at rest, its CM at {_fixed(state.r_cm)} m; the target's CM at {_fixed(target.position)} m (inertial)",
        f"  the grasp          impulse on the target {vec(hit.impulse[:3])} N s, {vec(hit.impulse[3:])} N m s about its CM "
        f"(inertial); joint impulse {vec(hit.joint_impulse)} N m s",
        f"  after the grasp    spacecraft rate {vec(hit.state.omega)} rad/s (|ω0⁺| = {np.linalg.norm(hit.state.omega):.6g}), "
        f"joint rates {vec(hit.state.qdot)} rad/s, system CM velocity {vec(hit.state.v_cm)} m/s; energy lost {hit.energy_lost:.6g} J",
        f"  ranking            {len(ranking)} candidate captures, {int(ranking.valid.sum())} pass every check; rank by "
        f"{ranking.rank_by}; measure: {ranking.measure_name}",
    ]
    heads = [_COLUMNS[name][0] for name in RANKINGS if name != "joint_impulse" or ranking.joints == "locked"]
    lines.append("    " + f"{'#':>4}  {'q (deg)':<28}" + "".join(f"{h:>14}" for h in heads) + "  checks")
    for i, what in _table_rows(ranking).items():
        q = ", ".join(f"{v:.2f}" for v in np.degrees(ranking.q[i]))
        cells = "".join(f"{ranking.values(name)[i]:>14.6g}" for name in RANKINGS if name != "joint_impulse" or ranking.joints == "locked")
        ok = "pass" if ranking.valid[i] else "FAIL"
        lines.append(f"    {i:>4}  {'[' + q + ']':<28}{cells}  {ok}    {', '.join(what)}")
    return lines


def _fixed(v: np.ndarray) -> str:
    """A position, m, to the micrometre."""
    return "[" + ", ".join(f"{round(float(x), 6) + 0.0:.6f}" for x in v) + "]"


def _grasp_dict(plan: CapturePlan) -> dict[str, Any] | None:
    """JSON of a moving target's grasp (None without one): its motion, the robot before, the impact, the ranking."""
    hit, ranking, target, state = plan.impact, plan.ranking, plan.target, plan.grasp_state
    if hit is None or ranking is None or target is None or state is None:
        return None
    return {
        "target_velocity": target.velocity.tolist(),
        "target_angular_velocity": target.angular_velocity.tolist(),
        "target_position": target.position.tolist(),
        "target_attitude_xyzw": target.attitude.tolist(),
        "robot_cm_before": state.r_cm.tolist(),
        "joints": hit.joints,
        "rank_by": ranking.rank_by,
        "impact": {
            "impulse": hit.impulse.tolist(),  # [linear N s; angular about the target's CM N m s], inertial
            "joint_impulse": hit.joint_impulse.tolist(),
            "spacecraft_rate_after": hit.state.omega.tolist(),  # spacecraft frame
            "joint_rates_after": hit.state.qdot.tolist(),
            "cm_velocity_after": hit.state.v_cm.tolist(),  # the combined system's CM, inertial
            "energy_lost": float(hit.energy_lost),
        },
        "ranking": {
            "measure": ranking.measure_name,
            "candidates": len(ranking),
            "planner": ranking.planner,
            "chosen": ranking.chosen,
            "columns": {
                "q": ranking.q.tolist(),
                "attitude_xyzw": ranking.attitude.tolist(),
                "cm_plus": ranking.cm_plus.tolist(),
                "R_plus": ranking.R_plus.tolist(),
                "family": ranking.family.tolist(),
                "valid": ranking.valid.tolist(),
                "min_measure": ranking.min_measure.tolist(),
                **{name: ranking.values(name).tolist() for name in (*RANKINGS, "energy_lost")},
            },
        },
    }


def _motion_dict(motion: PathMotion) -> dict[str, Any]:
    return {
        "points": int(motion.s.size),
        "min_measure": motion.min_measure,
        "threshold": motion.threshold,
        "max_deviation": motion.deviation,
        "singularity_free": motion.singularity_free,
        "within_joint_limits": motion.within_limits,
        "joint_limit_margin": motion.limit_margin if np.isfinite(motion.limit_margin) else None,
        "q_end": motion.q[-1].tolist(),
        "attitude_end_xyzw": motion.attitude[-1].tolist(),
    }


def write_capture_outputs(result: CaptureResult, out: Path, *, dpi: int = 200, animation: bool = True) -> list[Path]:
    """``capture.json``, ``capture_plan.png`` (like the paper's Fig. 7), for a two-link arm ``capture_families.png``
    (Fig. 6) and, for a moving target, ``capture_tradeoff.png`` (:func:`plot_capture_tradeoff`); with a capture
    sequence (``[detumble]``) its report ``capture.md``, run, figures and (``animation``) GIF
    (:func:`~freefloat.scenarios.capture_sequence.write_sequence_outputs`)."""
    from matplotlib.figure import Figure

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "capture.json"
    path.write_text(json.dumps(result.as_dict(), indent=2, allow_nan=False) + "\n")
    written = [path]
    plan = result.plan
    figures: list[tuple[str, tuple[float, float], Any]] = [("capture_plan.png", (7.4, 8.4), plot_capture_plan)]
    if result.family_postures:
        figures.append(("capture_families.png", (7.0, 4.6), plot_capture_families))
    if plan.ranking is not None:
        figures.append(("capture_tradeoff.png", (7.0, 5.2), plot_capture_tradeoff))
    for name, size, draw in figures:
        fig = Figure(figsize=size, layout="constrained")
        draw(plan, fig.add_subplot(projection="3d" if name == "capture_plan.png" and not plan.captured.is_planar else None))
        path = out / name
        fig.savefig(path, dpi=dpi, bbox_inches="tight", pad_inches=0.15)
        written.append(path)
    if result.sequence is not None:
        written += write_sequence_outputs(result.sequence, result.scenario.source, result.render_text(), out, animation=animation)
    return written


def plot_capture_plan(plan: CapturePlan, ax: Any) -> None:
    """The §V plan like the paper's Fig. 7 (:meth:`CapturePlan.plot`), with a legend, labels in m and a title.

    ``ax``: 2D axes, or 3D axes (``projection="3d"``) for a spatial model."""
    plan.plot(ax)
    placement = plan.placement
    handles, labels = ax.get_legend_handles_labels()
    ax.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, -0.08), ncols=2, fontsize="small", frameon=False)
    r = "" if placement.approach_distance is None else f", approach distance R = {placement.approach_distance:.3f} m"
    how = "" if plan.method == "piw" else "; path checked free-floating"
    measure = "" if plan.motion is None else f"\nmin |measure| along the path {plan.motion.min_measure:.3g} ({plan.motion.criterion})"
    ax.set_title(f"Capture at A: R+ = {placement.R_plus:.3f} m{r}{how}{measure}\n(1992 §V, eqs. 19-21)", fontsize="medium")


def plot_capture_families(plan: CapturePlan, ax: Any, *, marks: dict[str, float] | None = None) -> None:
    """q2(q1) of both eq. 21 families and det J* along them (the paper's Fig. 6), with the optimum marked.

    ``marks``: extra vertical lines, label -> q1 in degrees (e.g. the paper's printed optimum).
    """
    q1 = np.linspace(-np.pi, np.pi, 1441)
    fam = capture_families(plan.captured, plan.end_effector, plan.placement.R_plus, q1)
    artists = fam.plot(ax)
    twin: Any = artists[1].axes  # fam.plot draws det J* on a twin y axis
    assert twin is not None
    r = plan.ranking
    marked = [(plan.posture.q, plan.posture.family, "k*", "optimum")]
    if r is not None and r.chosen != r.planner:  # a moving target ranked by the grasp: the optimum and the chosen one
        marked = [(r.q[r.planner], int(r.family[r.planner]), "k*", "optimum"), (r.q[r.chosen], int(r.family[r.chosen]), "r*", "chosen")]
    for q, family, style, what in marked:
        k = 0 if family is None or family < 0 else family
        twin.plot(np.degrees(q[0]), fam.det[np.argmin(np.abs(q1 - q[0])), k], style, ms=12, label=f"{what} q1 = {np.degrees(q[0]):.1f}°")
    handles = [*artists, *twin.get_lines()[-len(marked) :]]
    for n, (label, value) in enumerate((marks or {}).items()):
        handles.append(ax.axvline(value, color="0.4", ls=":" if n == 0 else "-.", lw=1.2, label=label))
    ax.set_xlim(-180.0, 180.0)
    ax.set_xticks(np.arange(-180.0, 181.0, 45.0))
    ax.legend(handles=handles, loc="center", fontsize="x-small", ncols=3, framealpha=0.9)
    twin.set_ylabel("det J* (m²)")
    ax.set_title(f"Eq. 21 at R+ = {plan.placement.R_plus:.3f} m: the two families q2(q1) and det J* (1992 Fig. 6)", fontsize="medium")


def plot_capture_tradeoff(plan: CapturePlan, ax: Any, *, y: str | None = None) -> None:
    """The trade-off among a moving target's candidate capture postures (:meth:`CapturePlan.plot_tradeoff`), with a
    legend and a title naming the target's motion and the joints at the grasp."""
    plan.plot_tradeoff(ax, y=y)
    assert plan.ranking is not None and plan.target is not None
    ax.legend(loc="best", fontsize="small", framealpha=0.9)
    v, w = plan.target.velocity, plan.target.angular_velocity
    ax.set_title(
        f"Capture postures of a moving target: v = [{', '.join(f'{x:.3g}' for x in v)}] m/s, "
        f"ω = [{', '.join(f'{x:.3g}' for x in w)}] rad/s,\n{plan.ranking.joints} joints; {len(plan.ranking)} candidates on |r_E| = R+ "
        f"(1992 §V, eq. 21), rank by {plan.ranking.rank_by}",
        fontsize="medium",
    )
