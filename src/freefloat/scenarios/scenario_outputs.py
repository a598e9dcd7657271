"""What ``freefloat simulate SCENARIO.toml --out DIR`` writes: NAME.npz, NAME.csv, NAME.png, NAME_momentum.png, NAME.json.

:func:`simulate_scenario` runs a :class:`~freefloat.scenarios.Scenario` and
writes its outputs; a partial trajectory is written too when the simulation
fails part-way. Files the scenario reads are never written.
"""

from __future__ import annotations

import dataclasses
import json
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import SimulationError
from ..simulation.trajectory import Trajectory
from .scenario import Scenario, run_scenario

__all__ = ["check_animation_target", "output_names", "simulate_scenario", "trajectory_summary", "write_trajectory_outputs"]


def check_animation_target(path: Path | str) -> Path:
    """Before a run: refuse an animation file that could not be written (``--animate PATH``).

    The type (``.gif``: Pillow, ``.mp4``: ffmpeg, which must be installed), a file that exists
    (never overwritten), and a folder that cannot be written (tried with a scratch file in the
    nearest existing folder, which is removed) are errors that name the fix.
    """
    from matplotlib import animation

    target = Path(path)
    if target.suffix.lower() not in (".gif", ".mp4"):
        raise ValueError(f"--animate {target}: unknown animation type {target.suffix!r}; use .gif (Pillow) or .mp4 (ffmpeg)")
    if target.suffix.lower() == ".mp4" and not animation.FFMpegWriter.isAvailable():
        raise ValueError(f"--animate {target}: writing .mp4 needs ffmpeg, which is not installed; write a .gif instead")
    if target.exists() or target.is_symlink():
        raise FileExistsError(f"--animate {target}: exists; freefloat never overwrites a file (choose another name)")
    folder = next(p for p in (target.parent.absolute(), *target.parent.absolute().parents) if p.exists())
    try:
        if not folder.is_dir():
            raise NotADirectoryError(folder)
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".freefloat-write-test-"):
            pass
    except OSError as exc:
        raise OSError(
            f"--animate {target}: cannot write into {folder} ({exc.strerror or type(exc).__name__}); choose a folder you can write to"
        ) from None
    return target


def output_names(scenario: Scenario) -> list[str]:
    """The files a run of ``scenario`` writes, relative to its output directory (the summary NAME.json first)."""
    stem = scenario.output_name
    names = [f"{stem}.json"]
    names += [f"{stem}.npz"] if scenario.write_npz else []
    names += [f"{stem}.csv", f"{stem}.csv.json"] if scenario.write_csv else []
    names += [f"{stem}.png", f"{stem}_momentum.png"] if scenario.write_plots else []
    return names


def write_trajectory_outputs(traj: Trajectory, out: Path, scenario: Scenario) -> list[Path]:
    """Write NAME.json (summary), NAME.npz, NAME.csv (+ NAME.csv.json, its metadata), NAME.png and NAME_momentum.png into ``out``.

    Existing files are replaced here: ``freefloat simulate`` writes through
    :func:`freefloat.io.outputs.staged_outputs`, which never clobbers. A file
    the scenario reads (the scenario itself, its model file) is never written:
    that is an error.
    """
    targets = [out / name for name in output_names(scenario) if not name.endswith(".csv.json")]
    inputs = {p.resolve() for p in scenario.input_files}
    for target in targets:
        if target.resolve() in inputs:
            raise FileExistsError(
                f"{target}: is an input of this scenario; freefloat never overwrites its inputs (choose another --out or outputs.name)"
            )
    written = []
    for target in targets:
        if target.suffix in (".npz", ".csv"):
            traj.save(target, overwrite=True)
            if target.suffix == ".csv":
                written.append(target.with_name(target.name + ".json"))
        elif target.suffix == ".json":  # (the CSV's metadata sidecar NAME.csv.json is written by Trajectory.save)
            target.write_text(json.dumps(trajectory_summary(traj, scenario), indent=2) + "\n", encoding="utf-8")
        elif target.stem.endswith("_momentum"):
            _save_momentum_plot(traj, target)
        else:
            _save_trajectory_plot(traj, target)
        written.append(target)
    return written


def simulate_scenario(scenario: Scenario, out: Path, *, progress: Any = None, animation: Path | None = None) -> list[Path]:
    """Run a scenario and write its outputs into ``out``; what ``freefloat simulate`` does.

    When the simulation fails part-way, the partial trajectory is written (status
    ``"failed"`` and the reason in NAME.json and the files' metadata) and the
    :class:`~freefloat.SimulationError` is raised again, naming the files.
    ``animation``: also write an animation of the trajectory there (``.gif`` or
    ``.mp4``, :meth:`~freefloat.Trajectory.animate`); an existing file is refused
    before the run.
    """
    if animation is not None:
        animation = check_animation_target(animation)
    try:
        traj = run_scenario(scenario, progress=progress, warn_after=None)  # the caller has seen the estimate
    except SimulationError as exc:
        if exc.trajectory is None:
            raise
        written = write_trajectory_outputs(exc.trajectory, out, scenario)
        raise SimulationError(f"{exc} (partial trajectory up to the failure written to {written[0].parent})", exc.trajectory) from exc
    written = write_trajectory_outputs(traj, out, scenario)
    if animation is not None and traj.status != "interrupted":  # an interrupted run is written at once, not animated
        written.append(traj.animate(animation, progress=progress))
    return written


def trajectory_summary(traj: Trajectory, scenario: Scenario) -> dict[str, Any]:
    """The summary of a run (``NAME.json`` of ``freefloat simulate``): status, final state, momentum change, energies."""
    summary: dict[str, Any] = {
        "scenario": scenario.source,
        "description": scenario.description,
        "model": scenario.model.name,
        "joint_names": list(scenario.model.joint_names),
        "end_effector_names": list(scenario.model.end_effector_names),
        "status": traj.status,
        "message": traj.message,
        "samples": len(traj),
        "t_end": float(traj.t[-1]) if len(traj) else None,
        "joint_limit_events": [dataclasses.asdict(e) for e in traj.joint_limit_events],
    }
    if len(traj):
        h = traj.angular_momentum
        summary["final_state"] = {k: np.asarray(getattr(traj, k)[-1]).tolist() for k in ("q", "qdot", "omega", "attitude", "r_cm", "v_cm")}
        summary["angular_momentum_change"] = float(np.max(np.linalg.norm(h - h[0], axis=-1)))
        summary["kinetic_energy"] = {"initial": float(traj.kinetic_energy[0]), "final": float(traj.kinetic_energy[-1])}
        summary["saturated_fraction"] = float(np.mean(traj.saturated))
        summary["final_end_effector_positions"] = np.asarray(traj.end_effector_positions[-1]).tolist()  # inertial frame, m
    return summary


def _save_trajectory_plot(traj: Trajectory, path: Path) -> None:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 7), layout="constrained")
    traj.plot(fig.subplots(2, 2, sharex=True).ravel())
    fig.suptitle(f"{traj.model_name}: {traj.status}" + (f" ({traj.message})" if traj.message else ""), fontsize=9)
    fig.savefig(path, dpi=110)


def _save_momentum_plot(traj: Trajectory, path: Path) -> None:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 7), layout="constrained")
    ax_h, ax_p, ax_e = fig.subplots(3, 1, sharex=True)
    if len(traj):
        ax_h.plot(traj.t, traj.angular_momentum, label=["x", "y", "z"])
        ax_p.plot(traj.t, traj.linear_momentum, label=["x", "y", "z"])
        ax_e.plot(traj.t, traj.kinetic_energy)
        ax_h.legend(loc="upper right", fontsize=8)
    ax_h.set_ylabel("angular momentum\nabout CM (N m s)")
    ax_p.set_ylabel("linear momentum (N s)")
    ax_e.set_ylabel("kinetic energy (J)")
    ax_e.set_xlabel("time (s)")
    fig.savefig(path, dpi=110)
