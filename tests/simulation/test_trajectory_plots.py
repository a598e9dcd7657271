"""Trajectory plots and animations (issue 11 items 3 and 4): pyplot figures, 3D paths of spatial arms, GIF files."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib import animation
from PIL import Image

import freefloat as ff
from freefloat.simulation import trajectory_plots


@pytest.fixture(scope="module")
def spatial() -> ff.Trajectory:
    model = ff.models.spacecraft_7dof()
    pd = ff.JointPD(kp=20.0, kd=5.0, q_ref=[0.8, 1.0, 0.3, -1.2, 0.4, 0.9, 0.1])
    return ff.simulate(model, ff.State(q=np.full(7, 0.3)), 1.0, controller=pd, output_period=0.05)


@pytest.fixture(scope="module")
def planar() -> ff.Trajectory:
    model = ff.models.papadopoulos1992(arms=1)
    return ff.simulate(model, ff.State(q=[0.3, 0.5]), 1.0, controller=ff.JointPD(kp=5.0, kd=3.0, q_ref=[1.0, 1.2]), output_period=0.1)


def test_plot_makes_a_pyplot_figure_or_draws_on_given_axes(planar: ff.Trajectory) -> None:
    artists = planar.plot()
    fig = artists[0].get_figure(root=True)
    assert plt.fignum_exists(fig.number)  # plt.show() and notebooks display it
    before = plt.get_fignums()
    axes = plt.figure().subplots(2, 2).ravel()
    drawn = planar.plot(axes)
    assert {a.axes for a in drawn} <= set(axes)
    assert len(plt.get_fignums()) == len(before) + 1  # only the user's figure
    # what is drawn is the trajectory: joint angles (deg), attitude (deg), spacecraft CM, joint torques, against t
    expected = [
        (axes[0], np.degrees(planar.q), ["arm1_q1", "arm1_q2"]),
        (axes[1], np.degrees(planar.spacecraft_euler321), ["roll", "pitch", "yaw"]),
        (axes[2], planar.spacecraft_position, ["x", "y", "z"]),
        (axes[3], planar.joint_torque, ["arm1_q1", "arm1_q2"]),
    ]
    for ax, values, labels in expected:
        lines = ax.get_lines()
        assert [line.get_label() for line in lines] == labels
        for k, line in enumerate(lines):
            np.testing.assert_allclose(line.get_xdata(), planar.t)
            np.testing.assert_allclose(line.get_ydata(), values[:, k])
    assert np.ptp(planar.q[:, 1]) > 0.1 and np.ptp(planar.joint_torque[:, 0]) > 0.1  # not a still picture


def test_plot_path_spatial_is_3d_with_attitude_over_time(spatial: ff.Trajectory) -> None:
    artists = spatial.plot_path()
    fig = artists[0].get_figure(root=True)
    assert plt.fignum_exists(fig.number)
    ax3d, ax_att = fig.axes
    assert ax3d.name == "3d" and ax3d.get_zlabel() == "z (m, inertial)"
    labels = [t.get_text() for t in ax3d.get_legend().get_texts()]
    assert "end effector tool" in labels and {"spacecraft x axis", "spacecraft y axis", "spacecraft z axis"} <= set(labels)
    # the drawn end-effector path is the trajectory's, in 3D
    path = next(a for a in artists if a.get_label() == "end effector tool")
    x, y, z = path.get_data_3d()
    np.testing.assert_allclose(np.stack([x, y, z], axis=1), spatial.end_effector_positions[:, 0])
    assert ax_att.get_xlabel() == "time (s)" and "attitude" in ax_att.get_ylabel()
    np.testing.assert_allclose(ax_att.get_lines()[2].get_ydata(), np.degrees(spatial.spacecraft_euler321[:, 2]))


def test_plot_path_planar_stays_2d(planar: ff.Trajectory) -> None:
    artists = planar.plot_path()
    assert artists[0].axes.name == "rectilinear"
    # the end-effector and spacecraft CM paths drawn are the trajectory's, in the x-y plane
    by_label = {a.get_label(): a for a in artists}
    np.testing.assert_allclose(by_label["end effector arm1_ee"].get_xydata(), planar.end_effector_positions[:, 0, :2])
    np.testing.assert_allclose(by_label["spacecraft CM"].get_xydata(), planar.spacecraft_position[:, :2])
    np.testing.assert_allclose(by_label["system CM (t = 0)"].get_xydata(), [planar.r_cm[0, :2]])


def test_animate_writes_a_gif_with_the_expected_frames(spatial: ff.Trajectory, tmp_path: Path) -> None:
    path = spatial.animate(tmp_path / "motion.gif", fps=10)
    with Image.open(path) as gif:
        assert gif.format == "GIF"
        assert gif.n_frames == len(spatial.t) == 21
    seen: list[tuple[float, float]] = []
    fewer = spatial.animate(tmp_path / "fewer.gif", max_frames=7, progress=lambda done, total: seen.append((done, total)))
    with Image.open(fewer) as gif:
        assert gif.n_frames == 7
    assert seen[-1] == (7.0, 7.0) and all(total == 7.0 for _, total in seen)  # progress counts the frames
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fewer.gif", "motion.gif"]  # no partial file left beside them
    assert plt.get_fignums() == []  # the animation's figure is closed


def test_animate_planar_and_refusals(planar: ff.Trajectory, tmp_path: Path) -> None:
    target = planar.animate(tmp_path / "planar.gif")
    with Image.open(target) as gif:
        assert gif.n_frames == len(planar.t)
    stamp = target.read_bytes()
    with pytest.raises(FileExistsError, match="does not overwrite"):
        planar.animate(target)
    assert target.read_bytes() == stamp
    with pytest.raises(ValueError, match=r"\.gif"):
        planar.animate(tmp_path / "motion.avi")
    with pytest.raises(ValueError, match="fps"):
        planar.animate(tmp_path / "x.gif", fps=0)
    if not animation.FFMpegWriter.isAvailable():
        with pytest.raises(ValueError, match="ffmpeg"):
            planar.animate(tmp_path / "motion.mp4")
    else:
        data = planar.animate(tmp_path / "motion.mp4").read_bytes()
        assert data[4:8] == b"ftyp" and b"moov" in data and b"mdat" in data  # an MP4 container with its index and frames


def test_bus_box_has_the_spacecraft_inertia() -> None:
    """The bus drawn in figures: the uniform box with the spacecraft's mass and inertia (the papers' 1 m cube)."""
    from freefloat.mechanics.kinematics import spacecraft_box, spacecraft_box_size

    size, axes = spacecraft_box_size(ff.models.papadopoulos1992(arms=1))
    np.testing.assert_allclose(size, 1.0, atol=1e-4)  # 400 kg, 66.67 kg m²: Table I's 1 m spacecraft
    np.testing.assert_allclose(axes, np.eye(3))
    model = ff.models.spacecraft_7dof()
    size, axes = spacecraft_box_size(model)
    a2 = size**2
    box_inertia = model.mass[0] / 12.0 * np.diag([a2[1] + a2[2], a2[0] + a2[2], a2[0] + a2[1]])
    np.testing.assert_allclose(axes @ box_inertia @ axes.T, model.inertia[0], atol=1e-9)
    q = np.full((3, 7), 0.3)
    corners = spacecraft_box(model, q)
    assert corners.shape == (3, 8, 3)
    for k in range(3):  # batch equals loop; the box is centred on the spacecraft CM
        np.testing.assert_allclose(corners[k], spacecraft_box(model, q[k]))
        np.testing.assert_allclose(corners[k].mean(axis=0), ff.point_positions(model, q[k], 0, model.com[0]), atol=1e-12)


def _recorded_figures(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """Keep every figure the animation makes (it closes them), to look at the last frame drawn."""
    made: list[Any] = []
    original = trajectory_plots.new_figure

    def record(**kw: Any) -> Any:
        made.append(original(**kw))
        return made[-1]

    monkeypatch.setattr(trajectory_plots, "new_figure", record)
    return made


def test_animation_draws_the_bus_at_its_size(
    planar: ff.Trajectory, spatial: ff.Trajectory, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 19 item 8.2: every frame shows the spacecraft bus, at the model's size, where the spacecraft is."""
    from matplotlib.patches import Polygon
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from freefloat.mechanics.kinematics import spacecraft_box

    made = _recorded_figures(monkeypatch)
    planar.animate(tmp_path / "planar.gif", max_frames=4)
    ax = made[-1].axes[0]
    (bus,) = [p for p in ax.patches if isinstance(p, Polygon)]
    last = spacecraft_box(planar.model, planar.q[-1], attitude=planar.attitude[-1]) + planar.r_cm[-1]
    xy = bus.get_xy()
    gaps = np.linalg.norm(xy[:-1, None, :] - last[None, [0, 1, 3, 2], :2], axis=-1)
    assert len(xy) == 5 and np.all(gaps.min(axis=1) < 1e-12) and np.all(gaps.min(axis=0) < 1e-12)  # the last frame's bus
    np.testing.assert_allclose(np.linalg.norm(xy[1] - xy[0]), 1.0, atol=1e-4)  # a 1 m square
    assert bus.get_visible() and bus.get_facecolor()[3] > 0.0 and bus.get_linewidth() > 0.0
    lo, hi = np.array([ax.get_xlim(), ax.get_ylim()]).T
    assert np.all(xy >= lo) and np.all(xy <= hi)
    spatial.animate(tmp_path / "spatial.gif", max_frames=3)
    ax3d = made[-1].axes[0]
    assert len([c for c in ax3d.collections if isinstance(c, Poly3DCollection)]) == 1


def test_plot_path_draws_the_bus_inside_the_axes(spatial: ff.Trajectory) -> None:
    from freefloat.mechanics.kinematics import spacecraft_box

    artists = spatial.plot_path()
    ax = artists[0].axes
    buses = [a for a in artists if a.get_label() == "spacecraft bus"]
    assert len(buses) == 1 and "spacecraft bus" in [t.get_text() for t in ax.get_legend().get_texts()]
    limits = np.array([ax.get_xlim(), ax.get_ylim(), ax.get_zlim()])
    for k in (0, -1):
        corners = spacecraft_box(spatial.model, spatial.q[k], attitude=spatial.attitude[k]) + spatial.r_cm[k]
        assert np.all(corners >= limits[:, 0]) and np.all(corners <= limits[:, 1])
