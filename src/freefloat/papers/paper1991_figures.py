"""Figures of ``freefloat reproduce 1991``, like the paper's Figs. 3, 4 and 5, plus the two alternatives of §V.

Drawn from :class:`freefloat.papers.paper1991.Results1991` on pyplot figures,
saved as PNG and closed:

* ``fig3_coordinated_motion.png``: the system in the inertial plane with
  snapshots, the end-effector path and the line A-B, for eq. 30 (``tj``) and
  eq. 27 (``ct``) side by side (the paper's Fig. 3);
* ``fig4_spacecraft_errors.png``: the spacecraft position and attitude errors
  against time (the paper's Fig. 4);
* ``fig5_thruster_forces.png``: the thruster forces (spacecraft frame) and
  torque over the first 5 s (the paper's Fig. 5);
* ``fig_alternatives.png``: the spacecraft held fixed, and the free-floating
  straight-line attempt with det J* along the path.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.spatial.transform import Rotation

from ..core._figures import new_figure, save_and_close
from ..mechanics.kinematics import forward_kinematics, system_cm

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from ..core.model import Model
    from .paper1991 import Results1991

__all__ = ["FIGURE_NAMES", "draw_planar_system", "figure_3", "figure_4", "figure_5", "figure_alternatives", "write_figures"]

FIGURE_NAMES = ("fig3_coordinated_motion.png", "fig4_spacecraft_errors.png", "fig5_thruster_forces.png", "fig_alternatives.png")

COLORS = {"tj": "tab:blue", "ct": "tab:red"}
LABELS = {"tj": "transposed Jacobian, eq. 30", "ct": "operational space, eq. 27"}
SNAPSHOTS = (0.0, 1.0, 2.0, 4.0, 30.0)
#: Fig. 5: the zoomed panels show the range the forces and torque take from this time on (s).
FIG5_ZOOM_FROM = 0.5


def draw_planar_system(ax: Axes, model: Model, q: Any, theta: float, r_cm: Any, *, color: str = "k", alpha: float = 1.0) -> list[Any]:
    """The §V system in the inertial x-y plane: the spacecraft a 1 m square turned by θ, the links, the end effector."""
    rot, pos = forward_kinematics(model, np.asarray(q, dtype=float))
    t0 = Rotation.from_euler("z", theta).as_matrix()
    cm = system_cm(model, np.asarray(q, dtype=float))
    origin = np.asarray(r_cm, dtype=float)

    def to_i(p: np.ndarray) -> np.ndarray:
        return origin + t0 @ (p - cm)

    half = float(np.linalg.norm(model.joint_origin[1] - model.com[0]))
    corners = np.array([[half, half, 0], [-half, half, 0], [-half, -half, 0], [half, -half, 0], [half, half, 0]]) + model.com[0]
    box = np.array([to_i(c) for c in corners])
    artists = ax.plot(box[:, 0], box[:, 1], "-", color=color, lw=1.2, alpha=alpha)
    chain = [to_i(pos[k]) for k in range(1, model.n_bodies)]
    tip = to_i(pos[model.end_effector_body[0]] + rot[model.end_effector_body[0]] @ model.end_effector_point[0])
    pts = np.array([*chain, tip])
    artists += ax.plot(pts[:, 0], pts[:, 1], "-o", color=color, lw=2.0, ms=3, alpha=alpha)
    sc = to_i(model.com[0])
    artists += ax.plot(sc[0], sc[1], "+", color=color, ms=6, alpha=alpha)
    return artists


def _figure(**kw: Any) -> Any:
    return new_figure(**kw)


def figure_3(res: Results1991) -> Any:
    """The system in the inertial plane with snapshots, the end-effector path and the line A-B (Fig. 3).

    Eq. 30 and eq. 27 side by side. A pyplot figure."""
    fig = _figure(figsize=(11, 5.2))
    axes = fig.subplots(1, 2, sharex=True, sharey=True)
    a = res.task.coordinates(res.initial)[3:5]
    b = res.target[3:5]
    for ax, (name, traj) in zip(axes, res.runs.items(), strict=True):
        z = res.task.coordinates(_states(traj))
        for k, ts in enumerate(SNAPSHOTS):
            i = int(np.argmin(np.abs(traj.t - ts)))
            shade = 0.25 + 0.75 * k / (len(SNAPSHOTS) - 1)
            draw_planar_system(ax, res.model, traj.q[i], float(z[i, 2]), traj.r_cm[i], color=COLORS[name], alpha=shade)
            ax.annotate(f"{ts:g} s", z[i, 0:2], textcoords="offset points", xytext=(-8, -14), fontsize=7, color="0.3")
        ax.plot(z[:, 3], z[:, 4], "-", color="k", lw=1, label="end-effector path")
        ax.plot(z[:, 0], z[:, 1], ":", color="0.4", lw=1, label="spacecraft CM path")
        ax.plot([a[0], b[0]], [a[1], b[1]], "--", color="0.5", lw=0.8, label="line A-B")
        ax.plot(*a, "ko", ms=4)
        ax.plot(*b, "k*", ms=9)
        ax.annotate("A", a, xytext=(5, -10), textcoords="offset points")
        ax.annotate("B", b, xytext=(5, 4), textcoords="offset points")
        ax.plot(*res.target[0:2], "x", color="0.2", ms=8, label="spacecraft target")
        ax.set_title(LABELS[name], fontsize=10)
        ax.set_xlabel("x (m), inertial")
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("y (m), inertial")
    axes[0].legend(fontsize=8, loc="lower left")
    fig.suptitle("1991 Fig. 3: coordinated spacecraft/manipulator motion (snapshots at 0, 1, 2, 4, 30 s)", fontsize=11)
    return fig


def _states(traj: Any) -> Any:
    from ..core.state import State

    return State(q=traj.q, attitude=traj.attitude, r_cm=traj.r_cm)


def figure_4(res: Results1991) -> Any:
    """The spacecraft position and attitude errors against time (Fig. 4). A pyplot figure."""
    fig = _figure(figsize=(9, 6))
    ax_pos, ax_att = fig.subplots(2, 1, sharex=True)
    for name, traj in res.runs.items():
        e = res.errors[name]
        ax_pos.plot(traj.t, e[:, 0], "-", color=COLORS[name], label=f"x_s, {LABELS[name]}")
        ax_pos.plot(traj.t, e[:, 1], "--", color=COLORS[name], label=f"y_s, {LABELS[name]}")
        ax_att.plot(traj.t, np.degrees(e[:, 2]), "-", color=COLORS[name], label=LABELS[name])
    ax_pos.set_ylabel("spacecraft position error (m)")
    ax_att.set_ylabel("spacecraft attitude error (deg)")
    ax_att.set_xlabel("time (s)")
    for ax in (ax_pos, ax_att):
        ax.axhline(0.0, color="0.5", lw=0.6)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        ax.set_xlim(0, 20)
    fig.suptitle("1991 Fig. 4: spacecraft errors e = z1,des - z1", fontsize=11)
    return fig


def _zoom_range(values: list[np.ndarray]) -> tuple[float, float]:
    """y limits of a zoomed Fig. 5 panel: the range of ``values`` (and 0), padded by 10 %."""
    lo = min(0.0, *(float(np.min(v)) for v in values))
    hi = max(0.0, *(float(np.max(v)) for v in values))
    pad = 0.1 * max(hi - lo, 1e-9)
    return lo - pad, hi + pad


def figure_5(res: Results1991) -> Any:
    """The thruster forces (spacecraft frame) and torque over the first 5 s (Fig. 5). A pyplot figure.

    Linear axes throughout. Per quantity two rows, both columns (controllers) sharing each row's
    y axis: the full range, with the operational-space controller's peak at t = 0 (about 1 kN;
    each panel states its peak), and below it the same curves zoomed to the range they take
    from t = ``FIG5_ZOOM_FROM`` s on (shaded in the full-range panel), where the initial peak
    leaves the panel.
    """
    fig = _figure(figsize=(10, 9.6))
    axes = fig.subplots(4, 2, sharex=True, sharey="row")
    later: dict[str, list[np.ndarray]] = {"N": [], "N m": []}
    for col, (name, traj) in enumerate(res.runs.items()):
        first = traj.t <= 5.0 + 1e-9
        t = traj.t[first]
        force, torque = traj.spacecraft_force[first, :2], traj.spacecraft_torque[first, 2]
        ax_f, zoom_f, ax_n, zoom_n = axes[:, col]
        for ax in (ax_f, zoom_f):
            ax.plot(t, force[:, 0], "-", color=COLORS[name], label="f_x")
            ax.plot(t, force[:, 1], "--", color=COLORS[name], label="f_y")
        for ax in (ax_n, zoom_n):
            ax.plot(t, torque, "-", color=COLORS[name], label="n_z")
        ax_f.set_title(LABELS[name], fontsize=10)
        for ax, values, unit in ((ax_f, np.linalg.norm(force, axis=1), "N"), (ax_n, np.abs(torque), "N m")):
            k = int(np.argmax(values))
            ax.text(
                0.98,
                0.95,
                f"peak {values[k]:.4g} {unit} at t = {t[k]:.2f} s",
                transform=ax.transAxes,
                ha="right",
                va="top",
                fontsize=8,
                bbox={"boxstyle": "round", "fc": "white", "ec": "0.7"},
            )
        settled = t >= FIG5_ZOOM_FROM
        later["N"].append(force[settled])
        later["N m"].append(torque[settled])
    for row, unit in ((1, "N"), (3, "N m")):
        lo, hi = _zoom_range(later[unit])
        axes[row, 0].set_ylim(lo, hi)
        for ax in axes[row - 1]:
            ax.axhspan(lo, hi, color="0.85", zorder=0, label=f"zoomed below ({lo:.3g} to {hi:.3g} {unit})")
    for ax in axes.ravel():
        ax.axhline(0.0, color="0.5", lw=0.6)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="center right")
    for ax in axes[3]:
        ax.set_xlabel("time (s)")
    axes[0, 0].set_ylabel("thruster force,\nspacecraft frame (N)")
    axes[1, 0].set_ylabel(f"force (N), zoomed to\nt ≥ {FIG5_ZOOM_FROM:g} s")
    axes[2, 0].set_ylabel("thruster torque (N m)")
    axes[3, 0].set_ylabel(f"torque (N m), zoomed\nto t ≥ {FIG5_ZOOM_FROM:g} s")
    fig.suptitle("1991 Fig. 5: reaction-jet forces and torque over the first 5 s (full range, then zoomed; linear axes)", fontsize=11)
    return fig


def figure_alternatives(res: Results1991) -> Any:
    """The spacecraft held fixed, and the free-floating straight-line attempt with det J* along the path. A pyplot figure."""
    from ..core.state import State

    fig = _figure(figsize=(13, 4.8))
    ax_fixed, ax_free, ax_det = fig.subplots(1, 3)
    a = res.task.coordinates(res.initial)[3:5]
    b = res.target[3:5]
    fx = res.fixed
    for k, i in enumerate((0, len(fx.t) // 15, len(fx.t) // 6, len(fx.t) - 1)):
        # spacecraft at rest: place the drawing by the spacecraft CM
        q = fx.q[i]
        att = Rotation.from_euler("z", fx.theta).as_quat()
        sc_rel = res.task.coordinates(State(q=q, attitude=att))[0:2]  # spacecraft CM relative to the system CM
        r_cm = np.array([*(fx.spacecraft_position - sc_rel), 0.0])
        draw_planar_system(ax_fixed, res.model, q, fx.theta, r_cm, color="tab:green", alpha=0.3 + 0.7 * k / 3)
    ax_fixed.plot(fx.end_effector[:, 0], fx.end_effector[:, 1], "k-", lw=1)
    ax_fixed.set_title(f"spacecraft held: q2 at B = {np.degrees(fx.q[-1, 1]):.1f}°", fontsize=10)
    fp = res.free
    for k, i in enumerate(np.linspace(0, len(fp.s) - 1, 4).astype(int)):
        y = fp.y[i]
        draw_planar_system(ax_free, res.model, y[1:], float(y[0]), np.zeros(3), color="tab:purple", alpha=0.3 + 0.7 * k / 3)
    ax_free.plot(fp.end_effector[:, 0], fp.end_effector[:, 1], "k-", lw=1.5)
    ax_free.set_title(f"free-floating, resolved rate via J*: stops at s = {fp.s[-1]:.3f}", fontsize=10)
    for ax in (ax_fixed, ax_free):
        ax.plot([a[0], b[0]], [a[1], b[1]], "--", color="0.5", lw=0.8)
        ax.plot(*a, "ko", ms=4)
        ax.plot(*b, "k*", ms=9)
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
        ax.set_xlabel("x (m), inertial")
    ax_fixed.set_ylabel("y (m), inertial")
    ax_det.plot(fp.s, fp.det_j_star, "-", color="tab:purple")
    ax_det.axhline(0.0, color="0.5", lw=0.6)
    ax_det.set_xlabel("path parameter s along A-B")
    ax_det.set_ylabel("det ⁰J* (m²)")
    ax_det.set_xlim(0, 1)
    ax_det.grid(alpha=0.3)
    ax_det.set_title("dynamic singularity on the straight line", fontsize=10)
    fig.suptitle("1991 §V: the alternatives to coordinated control", fontsize=11)
    return fig


def write_figures(res: Results1991, out: Path) -> list[Path]:
    """Write the four figures into ``out``; returns their paths."""
    out = Path(out)
    return [save_and_close(make(res), out / name, dpi=150) for name, make in zip(FIGURE_NAMES, FIGURES, strict=True)]


FIGURES = (figure_3, figure_4, figure_5, figure_alternatives)
