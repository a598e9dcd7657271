"""Trajectory plots and animations (issue 11 items 3 and 4): pyplot figures, 3D paths of spatial arms, GIF files."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib import animation
from PIL import Image

import freefloat as ff


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


def test_animate_writes_a_gif_with_the_expected_frames(spatial: ff.Trajectory, tmp_path: Path) -> None:
    path = spatial.animate(tmp_path / "motion.gif", fps=10)
    with Image.open(path) as gif:
        assert gif.format == "GIF"
        assert gif.n_frames == len(spatial.t) == 21
    fewer = spatial.animate(tmp_path / "fewer.gif", max_frames=7)
    with Image.open(fewer) as gif:
        assert gif.n_frames == 7
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
        assert planar.animate(tmp_path / "motion.mp4").stat().st_size > 0
