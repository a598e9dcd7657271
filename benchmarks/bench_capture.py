"""Capture benchmark (issue 22): the grasp of a moving target as an impact, in batches, and its use by the planner.

* **Impacts per second**: ``ff.capture.impact(model, state, targets)`` for a batch of 10^4 random targets (10^3 with
  ``--quick``: random mass 0.5-2000 kg, inertia, attitude, a CM within ~0.3 m of the end effector, velocity and
  angular velocity), on one robot state (``one_state``: a robot meeting many possible targets) and on 10^4 robot
  states, one per target (``per_target_state``: what the capture planner's ranking does, one candidate posture
  per target), joints free and locked, best of ``repeats``; for the 1992 two-arm system (planar, N = 4) and
  ``ff.models.spacecraft_7dof()`` (3D, N = 7). Reference: the same call in a Python loop, one robot state and one
  target at a time (as a user without the batch would write it: each call builds its combined model), over the
  first ``loop`` targets; before timing, the batch must equal that loop (impulse, joint impulse, post-impact
  velocities, energy lost; relative to the largest entry, at least 1): to 1e-12 on one robot state (the same H+ and
  Jacobians for all), to 1e-9 on per-target states (H+ from the batched kernel differs from the single-state one
  by rounding, ~2e-13 on entries of 1e3 kg m², which random 7-DOF postures amplify by cond(H) up to ~1e6: measured
  1e-10), otherwise the run stops; the largest difference is reported.
* **The planner's ranking**: ``plan_capture`` for the 1992 §V example (2^16 PIW samples) without a moving target and
  with a spinning one ranked by the spacecraft rate after the grasp (145 candidate postures on the eq. 21
  families, their free-floating motions along the path and one batched impact call), best of ``repeats``.
* **The capture-and-detumble example** (``examples/scenarios/tumbling_satellite_capture.toml``, a 500 kg satellite
  tumbling at 3 deg/s): the whole scenario as ``freefloat capture`` runs it (read, plan, grasp, 30 s of
  ``Detumble`` with its three reaction wheels), the sequence alone (the grasp and the detumbling simulation), best
  of ``repeats``, and writing its outputs (JSON, markdown, figures, the 20-frame GIF) once.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

import freefloat as ff
from bench_core import machine_line
from bench_workspace import best_of
from freefloat.analysis.capture import plan_capture
from freefloat.scenarios.capture_scenario import load_capture_scenario, run_capture_scenario, write_capture_outputs
from freefloat.scenarios.capture_sequence import run_capture_sequence

TUMBLING = Path(__file__).resolve().parents[1] / "examples" / "scenarios" / "tumbling_satellite_capture.toml"


def random_case(model: ff.Model, count: int, seed: int) -> tuple[ff.State, ff.State, ff.capture.Target]:
    """One robot state, ``count`` robot states (random postures within the limits, rates, attitudes) and ``count`` targets
    near end effector 0 of the first state."""
    rng = np.random.default_rng(seed)
    lo, hi = np.maximum(model.joint_lower, -np.pi), np.minimum(model.joint_upper, np.pi)
    n = model.n_joints

    def states(size: tuple[int, ...]) -> ff.State:
        return ff.State(
            q=rng.uniform(lo, hi, size=(*size, n)),
            qdot=rng.normal(scale=0.3, size=(*size, n)),
            omega=rng.normal(scale=0.3, size=(*size, 3)),
            attitude=Rotation.random(int(np.prod(size)), random_state=rng).as_quat().reshape((*size, 4)),
            r_cm=rng.normal(scale=2.0, size=(*size, 3)),
            v_cm=rng.normal(scale=0.3, size=(*size, 3)),
        )

    one = states(())
    tip = one.r_cm + Rotation.from_quat(one.attitude).apply(ff.end_effector_positions(model, one.q)[0])
    mass = np.exp(rng.uniform(np.log(0.5), np.log(2000.0), size=count))
    moments = mass[:, None] * rng.uniform(0.01, 0.019, size=(count, 3))  # each below the sum of the other two
    rot = Rotation.random(count, random_state=rng).as_matrix()
    target = ff.capture.Target(
        mass=mass,
        inertia=rot @ (moments[:, :, None] * np.eye(3)) @ np.swapaxes(rot, 1, 2),
        position=tip + rng.normal(scale=0.3, size=(count, 3)),
        attitude=Rotation.random(count, random_state=rng).as_quat(),
        velocity=rng.normal(scale=0.5, size=(count, 3)),
        angular_velocity=rng.normal(scale=0.3, size=(count, 3)),
    )
    return one, states((count,)), target


def _fields(r: Any) -> dict[str, np.ndarray]:
    return {
        "impulse": r.impulse,
        "joint_impulse": r.joint_impulse,
        "omega": r.state.omega,
        "qdot": r.state.qdot,
        "v_cm": r.state.v_cm,
        "energy_lost": np.asarray(r.energy_lost),
    }


def _single(state: ff.State, k: int | None) -> ff.State:
    if k is None:
        return state
    fields = ("q", "qdot", "omega", "attitude", "r_cm", "v_cm")
    return ff.State(**{name: getattr(state, name)[k] for name in fields})


def bench_impacts(model: ff.Model, count: int, loop: int, repeats: int, log: Callable[[str], None]) -> dict[str, Any]:
    one, many, target = random_case(model, count, seed=7)
    out: dict[str, Any] = {"model": model.name, "joints": model.n_joints, "targets": count}
    for case, state in (("one_state", one), ("per_target_state", many)):
        for joints in ("free", "locked"):
            log(f"[impact] {model.name}: {case}, {joints} joints, {count:,} targets, best of {repeats}")
            batch = ff.capture.impact(model, state, target, joints=joints)
            worst = 0.0
            t0 = time.perf_counter()
            for k in range(loop):
                single = ff.capture.impact(model, _single(state, None if case == "one_state" else k), target[k], joints=joints)
                for name, value in _fields(single).items():
                    ref = _fields(batch)[name][k]
                    worst = max(worst, float(np.max(np.abs(value - ref)) / max(1.0, float(np.max(np.abs(ref))))))
            loop_s = time.perf_counter() - t0
            if worst > (1e-12 if case == "one_state" else 1e-9):
                raise AssertionError(f"{model.name} {case} {joints}: batch and loop differ by {worst:.2e} (relative)")
            seconds, _ = best_of(lambda s=state, j=joints: ff.capture.impact(model, s, target, joints=j), repeats)
            out[f"{case}.{joints}"] = {
                "seconds": seconds,
                "impacts_per_s": count / seconds,
                "loop_impacts_per_s": loop / loop_s,
                "ratio": (count / seconds) / (loop / loop_s),
                "batch_vs_loop_max_rel": worst,
                "loop_targets": loop,
            }
    return out


def bench_planner(repeats: int, log: Callable[[str], None]) -> dict[str, Any]:
    model = ff.models.papadopoulos1992(arms=1)
    kwargs: dict[str, Any] = {"mass": 400.0, "inertia": 25.0, "samples": 1 << 16}
    path = [[0.0, 0.0], [0.0, 0.25]]
    moving = {"target_velocity": [0.02, 0.01, 0.0], "target_angular_velocity": [0.0, 0.0, 0.1], "rank_by": "spacecraft_rate"}
    log(f"[planner] plan_capture, 1992 §V, at rest and moving, best of {repeats}")
    rest_s, _ = best_of(lambda: plan_capture(model, 0, path, **kwargs), repeats)
    moving_s, plan = best_of(lambda: plan_capture(model, 0, path, **kwargs, **moving), repeats)
    r = plan.ranking
    return {
        "at_rest_s": rest_s,
        "moving_ranked_s": moving_s,
        "ranking_extra_s": moving_s - rest_s,
        "candidates": len(r),
        "valid": int(np.sum(r.valid)),
        "rate_after_grasp_chosen": float(r.spacecraft_rate[r.chosen]),
        "rate_after_grasp_most_dexterous": float(r.spacecraft_rate[r.planner]),
    }


def bench_sequence(repeats: int, log: Callable[[str], None]) -> dict[str, Any]:
    """The example capture-and-detumble scenario: end to end, the sequence alone and its outputs."""
    log(f"[sequence] {TUMBLING.name}: the scenario end to end and the sequence alone, best of {repeats}")
    scenario_s, result = best_of(lambda: run_capture_scenario(load_capture_scenario(TUMBLING)), repeats)
    settings = result.scenario.detumble
    assert settings is not None and result.sequence is not None
    sequence_s, sequence = best_of(lambda: run_capture_sequence(result.plan, settings), repeats)
    with tempfile.TemporaryDirectory() as folder:
        t0 = time.perf_counter()
        write_capture_outputs(result, Path(folder))
        outputs_s = time.perf_counter() - t0
    cost, after = sequence.cost, sequence.run.after
    assert after is not None
    return {
        "scenario_s": scenario_s,
        "sequence_s": sequence_s,
        "outputs_s": outputs_s,
        "detumble_duration_s": settings.duration,
        "samples": int(after.t.size),
        "time_to_rest": cost.time_to_rest,
        "delta_v": cost.delta_v,
        "momentum_change_max": float(np.abs(sequence.momentum_after - sequence.momentum_before).max()),
    }


def run(quick: bool, log: Callable[[str], None]) -> dict[str, Any]:
    """``run.py`` entry: 10^4 targets (10^3 with quick), a loop over 300 (100), best of 5 (3)."""
    count, loop, repeats = (1_000, 100, 3) if quick else (10_000, 300, 5)
    systems = {"papadopoulos1992": ff.models.papadopoulos1992(), "spacecraft_7dof": ff.models.spacecraft_7dof()}
    return {
        "impacts": {key: bench_impacts(model, count, loop, repeats, log) for key, model in systems.items()},
        "planner": bench_planner(3 if not quick else 1, log),
        "sequence": bench_sequence(3 if not quick else 1, log),
        "settings": {"targets": count, "loop": loop, "repeats": repeats},
    }


def table(report: dict[str, Any]) -> str:
    lines = [f"ff.capture.impact, a batch of {report['settings']['targets']:,} random targets (best of {report['settings']['repeats']})"]
    lines.append(f"{'system':18s} {'robot states':18s} {'joints':7s} {'impacts/s':>12s} {'loop/s':>10s} {'ratio':>8s} {'batch-loop':>11s}")
    for key, entry in report["impacts"].items():
        for case in ("one_state", "per_target_state"):
            for joints in ("free", "locked"):
                e = entry[f"{case}.{joints}"]
                lines.append(
                    f"{key:18s} {case:18s} {joints:7s} {e['impacts_per_s']:>12,.0f} {e['loop_impacts_per_s']:>10,.0f} "
                    f"{e['ratio']:>7,.0f}x {e['batch_vs_loop_max_rel']:>11.1e}"
                )
    p = report["planner"]
    lines.append("")
    lines.append(
        f"plan_capture, 1992 §V (2^16 PIW samples): at rest {p['at_rest_s']:.2f} s; a spinning target ranked by the spacecraft "
        f"rate {p['moving_ranked_s']:.2f} s ({p['candidates']} candidates, {p['valid']} valid; |ω0⁺| "
        f"{p['rate_after_grasp_chosen']:.3g} rad/s chosen, {p['rate_after_grasp_most_dexterous']:.3g} at the most dexterous)"
    )
    q = report["sequence"]
    lines.append(
        f"capture and detumble example (tumbling_satellite_capture.toml, {q['detumble_duration_s']:g} s of Detumble, "
        f"{q['samples']} samples): scenario {q['scenario_s']:.2f} s, sequence alone {q['sequence_s']:.2f} s, outputs with "
        f"the GIF {q['outputs_s']:.2f} s; at rest from {q['time_to_rest']:.6g} s, delta-v {q['delta_v']:.4g} m/s"
    )
    lines.append(machine_line(report["machine"]))
    return "\n".join(lines)
