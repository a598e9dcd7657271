"""Plots and animations of a :class:`~freefloat.simulation.trajectory.Trajectory` (what ``traj.plot()``,
``traj.plot_path()`` and ``traj.animate(path)`` draw).

Compute stays in the trajectory (its derived arrays) and in
:func:`freefloat.mechanics.kinematics.stick_figure` and
:func:`~freefloat.mechanics.kinematics.spacecraft_box` (the bus); this module only draws.
Without axes, each call makes a pyplot figure, so ``plt.show()`` and notebooks
display it. Spatial models are drawn in 3D (mpl_toolkits.mplot3d), planar
ones in the x-y plane. Animations use :mod:`matplotlib.animation`: GIF with
Pillow (always available), MP4 with ffmpeg when it is installed.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core._figures import draw_box, move_box, new_figure
from ..core.conventions import attitude_matrix
from ..core.numbers import computed_states
from ..mechanics.kinematics import spacecraft_box, stick_figure
from ._guard import Progress

if TYPE_CHECKING:
    from .trajectory import Trajectory

__all__ = ["animate_trajectory", "plot_path", "plot_trajectory"]


def plot_trajectory(traj: Trajectory, axes: Any = None) -> list[Any]:
    """Joint angles, spacecraft attitude and position, and actuation against time (four axes; see ``Trajectory.plot``)."""
    if axes is None:
        axes = new_figure(figsize=(9, 7)).subplots(2, 2, sharex=True).ravel()
    ax_q, ax_att, ax_pos, ax_act = axes
    artists: list[Any] = []
    joints = list(traj.model.joint_names) if traj.model is not None else [f"q{j + 1}" for j in range(traj.q.shape[-1])]
    artists += ax_q.plot(traj.t, np.degrees(traj.q), label=joints)
    ax_q.set_ylabel("joint angle (deg)")
    if traj.model is not None:
        artists += ax_att.plot(traj.t, np.degrees(traj.spacecraft_euler321), label=["roll", "pitch", "yaw"])
        ax_att.set_ylabel("spacecraft attitude, Euler 3-2-1 (deg)")
        artists += ax_pos.plot(traj.t, traj.spacecraft_position, label=["x", "y", "z"])
        ax_pos.set_ylabel("spacecraft CM, inertial (m)")
    else:
        artists += ax_att.plot(traj.t, traj.attitude, label=["x", "y", "z", "w"])
        ax_att.set_ylabel("attitude quaternion")
        artists += ax_pos.plot(traj.t, traj.r_cm, label=["x", "y", "z"])
        ax_pos.set_ylabel("system CM, inertial (m)")
    artists += ax_act.plot(traj.t, traj.joint_torque, label=joints)
    if np.any(traj.spacecraft_force) or np.any(traj.spacecraft_torque):
        artists += ax_act.plot(traj.t, traj.spacecraft_force, linestyle="--", label=["f_x", "f_y", "f_z"])
        artists += ax_act.plot(traj.t, traj.spacecraft_torque, linestyle=":", label=["n_x", "n_y", "n_z"])
    ax_act.set_ylabel("joint torque (N m); thrust (N, --), (N m, :)")
    for ax in (ax_q, ax_att, ax_pos, ax_act):
        ax.legend(fontsize=7, loc="best")
        ax.grid(alpha=0.3)
    for ax in (ax_pos, ax_act):
        ax.set_xlabel("time (s)")
    return artists


def _single(traj: Trajectory, what: str) -> None:
    if np.ndim(traj.q) != 2:
        raise ValueError(f"{what} draws one trajectory; this one holds a batch (q has shape {np.shape(traj.q)}, time first)")


def _spatial(traj: Trajectory) -> bool:
    return traj.model is not None and not traj.model.is_planar


def _set_equal_3d(ax: Any, points: np.ndarray) -> None:
    lo, hi = np.min(points, axis=0), np.max(points, axis=0)
    mid, half = 0.5 * (lo + hi), 0.5 * max(float(np.max(hi - lo)), 1e-3) * 1.1
    ax.set_xlim(mid[0] - half, mid[0] + half)
    ax.set_ylim(mid[1] - half, mid[1] + half)
    ax.set_zlim(mid[2] - half, mid[2] + half)
    ax.set_box_aspect((1.0, 1.0, 1.0))


def _label_axes(ax: Any, dims: int) -> None:
    ax.set_xlabel("x (m, inertial)")
    ax.set_ylabel("y (m, inertial)")
    if dims == 3:
        ax.set_zlabel("z (m, inertial)")


def plot_path(traj: Trajectory, ax: Any = None, *, snapshots: int = 4, axis_length: float | None = None) -> list[Any]:
    """The end-effector paths and the spacecraft CM path in the inertial frame, with the spacecraft attitude over time.

    Spatial models on 3D axes: the spacecraft body axes (x red, y green, z blue) drawn at
    ``snapshots`` + 1 times along the spacecraft CM path (the first and last time written next
    to them); the system at the first and last sample as stick figures with the spacecraft bus
    (:func:`~freefloat.mechanics.kinematics.spacecraft_box`). Planar models in the
    x-y plane with the same content. Without ``ax`` a new pyplot figure holds this panel and,
    beside it, the spacecraft attitude (Euler 3-2-1 angles) against time. Returns the artists.
    """
    model = traj._need_model()
    _single(traj, "plot_path")
    dims = 3 if _spatial(traj) else 2
    attitude_ax = None
    if ax is None:
        fig = new_figure(figsize=(12.0, 5.6))
        grid = fig.add_gridspec(1, 2, width_ratios=(1.4, 1.0))
        ax = fig.add_subplot(grid[0, 0], projection="3d" if dims == 3 else None)
        attitude_ax = fig.add_subplot(grid[0, 1])
    ee = traj.end_effector_positions
    sc = traj.spacecraft_position
    artists: list[Any] = []
    for e, name in enumerate(model.end_effector_names):
        artists += ax.plot(*[ee[:, e, i] for i in range(dims)], "-", color=f"C{(e + 4) % 10}", lw=2.0, label=f"end effector {name}")
        artists += ax.plot(*[[ee[-1, e, i]] for i in range(dims)], "o", color=f"C{(e + 4) % 10}", ms=5)
    artists += ax.plot(*[sc[:, i] for i in range(dims)], ":", color="0.3", lw=1.2, label="spacecraft CM")
    artists += ax.plot(*[[traj.r_cm[0, i]] for i in range(dims)], "k+", ms=10, mew=2, label="system CM (t = 0)")
    pts = np.concatenate([ee.reshape(-1, 3), sc])
    span = float(np.max(np.ptp(pts, axis=0))) if len(pts) > 1 else 1.0
    length = axis_length if axis_length is not None else 0.15 * max(span, 0.5)
    rot = attitude_matrix(traj.attitude)
    picks = np.unique(np.linspace(0, len(traj.t) - 1, snapshots + 1).round().astype(int))
    for n, k in enumerate(picks):
        for i, colour in enumerate(("tab:red", "tab:green", "tab:blue")[:dims]):
            tip = sc[k] + length * rot[k][:, i]
            label = (f"spacecraft {'xyz'[i]} axis" if n == 0 else None) if dims == 3 or i < 2 else None
            artists += ax.plot(*[[sc[k, j], tip[j]] for j in range(dims)], "-", color=colour, lw=1.5, label=label)
        if n in (0, len(picks) - 1):
            artists.append(ax.text(*sc[k][:dims], f" t={traj.t[k]:.3g} s", fontsize=7, color="0.25"))
    for n, (k, alpha) in enumerate(((0, 0.35), (len(traj.t) - 1, 1.0))):
        with computed_states():
            seg = stick_figure(model, traj.q[k], attitude=traj.attitude[k]) + traj.r_cm[k]
            bus = spacecraft_box(model, traj.q[k], attitude=traj.attitude[k]) + traj.r_cm[k]
        artists.append(draw_box(ax, bus, color="0.3", alpha=alpha, label="spacecraft bus" if n else None))
        for a, b in seg:
            artists += ax.plot(*[[a[i], b[i]] for i in range(dims)], "-", color="0.45", lw=2.5, alpha=alpha)
        pts = np.concatenate([pts, seg.reshape(-1, 3), bus])
    _label_axes(ax, dims)
    if dims == 3:
        _set_equal_3d(ax, pts)
    else:
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    ax.set_title(f"{model.name}: end-effector path and spacecraft attitude, {traj.t[0]:.3g}-{traj.t[-1]:.3g} s", fontsize=9)
    if attitude_ax is not None:
        artists += attitude_ax.plot(traj.t, np.degrees(traj.spacecraft_euler321), label=["roll", "pitch", "yaw"])
        attitude_ax.set_xlabel("time (s)")
        attitude_ax.set_ylabel("spacecraft attitude, Euler 3-2-1 (deg)")
        attitude_ax.grid(alpha=0.3)
        attitude_ax.legend(fontsize=8)
        attitude_ax.set_title("spacecraft attitude over time", fontsize=9)
    return artists


def animate_trajectory(
    traj: Trajectory,
    path: str | Path,
    *,
    fps: int = 20,
    max_frames: int = 120,
    dpi: int = 80,
    overwrite: bool = False,
    progress: bool | Callable[[float, float], Any] | None = None,
    overlay: Callable[[Any, np.ndarray], tuple[np.ndarray, Callable[[int], list[Any]]]] | None = None,
) -> Path:
    """Write an animation of the system moving along the trajectory: ``.gif`` (Pillow) or ``.mp4`` (ffmpeg).

    One frame per output sample, or ``max_frames`` evenly spaced samples when there are
    more; ``fps`` frames per second. The system is drawn as a stick figure with the spacecraft
    bus (:func:`~freefloat.mechanics.kinematics.spacecraft_box`; 3D axes for a spatial model),
    with the end-effector trace so far and the time. Never overwrites an
    existing file unless ``overwrite=True``. Returns the path written.
    ``progress``: frames drawn, as :func:`freefloat.simulate`'s (None: a bar on a terminal once
    it has taken 2 s, else lines to the ``freefloat.progress`` logger; a callable
    ``progress(frame, frames)``). ``overlay(ax, frames)``: more to draw (a grasped target), called once with the axes
    and the output indices of the frames; it returns points (..., 3) the axes must show and a function of the frame
    number that moves its artists and returns them.
    """
    import matplotlib.pyplot as plt
    from matplotlib import animation

    model = traj._need_model()
    _single(traj, "animate")
    out = Path(path)
    if out.suffix.lower() not in (".gif", ".mp4"):
        raise ValueError(f"{out}: unknown animation type {out.suffix!r}; use .gif (Pillow) or .mp4 (ffmpeg)")
    if out.exists() and not overwrite:
        raise FileExistsError(f"{out}: exists; freefloat does not overwrite files (pass overwrite=True or choose another name)")
    if len(traj.t) == 0:
        raise ValueError("trajectory: has no samples to animate")
    if isinstance(fps, bool) or not isinstance(fps, int) or fps < 1:
        raise ValueError(f"fps: expected an integer >= 1, got {fps!r}")
    if isinstance(max_frames, bool) or not isinstance(max_frames, int) or max_frames < 1:
        raise ValueError(f"max_frames: expected an integer >= 1, got {max_frames!r}")
    if out.suffix.lower() == ".mp4":
        if not animation.FFMpegWriter.isAvailable():
            raise ValueError(f"{out}: writing .mp4 needs ffmpeg, which is not installed; write a .gif instead")
        writer: Any = animation.FFMpegWriter(fps=fps)
    else:
        writer = animation.PillowWriter(fps=fps)
    frames = np.unique(np.linspace(0, len(traj.t) - 1, min(max_frames, len(traj.t))).round().astype(int))
    dims = 3 if _spatial(traj) else 2
    with computed_states():
        seg = stick_figure(model, traj.q[frames], attitude=traj.attitude[frames]) + traj.r_cm[frames][:, None, None, :]
        bus = spacecraft_box(model, traj.q[frames], attitude=traj.attitude[frames]) + traj.r_cm[frames][:, None, :]
    ee = traj.end_effector_positions
    fig = new_figure(figsize=(5.5, 5.0))
    ax = fig.add_subplot(projection="3d" if dims == 3 else None)
    extra, draw_extra = overlay(ax, frames) if overlay is not None else (np.zeros((0, 3)), lambda i: [])
    pts = np.concatenate([seg.reshape(-1, 3), bus.reshape(-1, 3), ee.reshape(-1, 3), np.reshape(extra, (-1, 3))])
    if dims == 3:
        _set_equal_3d(ax, pts)
    else:
        lo, hi = pts[:, :2].min(axis=0), pts[:, :2].max(axis=0)
        pad = 0.05 * max(float(np.max(hi - lo)), 1e-3)
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
    _label_axes(ax, dims)
    box = draw_box(ax, bus[0], color="0.3")
    links = [ax.plot(*([[0.0, 0.0]] * dims), "-", color="0.3", lw=2.5)[0] for _ in range(seg.shape[1])]
    traces = [ax.plot(*([[]] * dims), "-", color=f"C{e}", lw=1.5)[0] for e in range(model.n_end_effectors)]
    title = ax.set_title("")

    def draw(i: int) -> list[Any]:
        k = int(frames[i])
        move_box(box, bus[i])
        for line, (a, b) in zip(links, seg[i], strict=True):
            line.set_data([a[0], b[0]], [a[1], b[1]])
            if dims == 3:
                line.set_3d_properties([a[2], b[2]])  # type: ignore[attr-defined]
        for e, trace in enumerate(traces):
            trace.set_data(ee[: k + 1, e, 0], ee[: k + 1, e, 1])
            if dims == 3:
                trace.set_3d_properties(ee[: k + 1, e, 2])  # type: ignore[attr-defined]
        title.set_text(f"{model.name}   t = {traj.t[k]:.2f} s")
        return [box, *links, *traces, title, *draw_extra(i)]

    anim = animation.FuncAnimation(fig, draw, frames=len(frames), interval=1000.0 / fps, blit=False)
    out.parent.mkdir(parents=True, exist_ok=True)
    bar = Progress(progress, float(len(frames)), what=f"animating {out.name}", unit="frames")
    partial = out.with_name(f".{out.stem}.partial-{os.getpid()}{out.suffix}")  # the whole file appears at once, or none
    try:
        anim.save(partial, writer=writer, dpi=dpi, progress_callback=lambda i, n: bar.update(float(i + 1)))
        os.replace(partial, out)
    finally:
        partial.unlink(missing_ok=True)
        bar.close()
        plt.close(fig)
    return out
