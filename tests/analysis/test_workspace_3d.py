"""Spatial workspaces drawn in 3D (issue 11 item 3): sections through the system CM, point clouds, 3D capture plans."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest
from PIL import Image

import freefloat as ff
from freefloat.analysis.capture import plan_capture
from freefloat.analysis.singularity import SingularityCriterion
from freefloat.analysis.workspace import (
    guaranteed_workspace,
    path_independent_workspace,
    plot_workspace_sections,
    reachable_workspace,
    workspace_cloud,
    workspace_limits,
    write_workspace_plots,
)

ARM = ff.models.spacecraft_7dof()
POSITION = SingularityCriterion("position", "sigma_min", 0.02)


def test_cloud_points_and_measure() -> None:
    cloud = workspace_cloud(ARM, samples=1024, criterion=POSITION)
    assert cloud.points.shape == (1024, 3) and cloud.q.shape == (1024, 7)
    np.testing.assert_allclose(cloud.points, ff.end_effector_positions(ARM, cloud.q)[:, 0])
    np.testing.assert_allclose(cloud.measure, POSITION.evaluate(ARM, cloud.q))
    assert np.all((cloud.q >= ARM.joint_lower) & (cloud.q <= ARM.joint_upper))
    reach = reachable_workspace(ARM, samples=1 << 12)
    radii = np.linalg.norm(cloud.points, axis=1)
    assert reach.R_min - 1e-9 <= radii.min() and radii.max() <= reach.R_max + 1e-9
    np.testing.assert_array_equal(cloud.singular, np.abs(cloud.measure) <= 0.02)
    with pytest.raises(ValueError, match="samples"):
        workspace_cloud(ARM, samples=3)


def test_sections_are_labelled_by_their_planes_and_the_cloud_is_3d() -> None:
    reach = reachable_workspace(ARM, samples=1 << 12)
    gw = guaranteed_workspace(ARM, samples=1 << 12)
    piw = path_independent_workspace(ARM, samples=1 << 12, criterion=POSITION, reachable=reach)
    fig = plot_workspace_sections(reach, gw, piw, workspace_cloud(ARM, samples=2048, criterion=POSITION))
    assert plt.fignum_exists(fig.number)
    xy, xz, yz, cloud_ax = fig.axes[:4]
    assert (xy.get_xlabel(), xy.get_ylabel()) == ("x (m)", "y (m)")
    assert (xz.get_xlabel(), xz.get_ylabel()) == ("x (m)", "z (m)")
    assert (yz.get_xlabel(), yz.get_ylabel()) == ("y (m)", "z (m)")
    assert cloud_ax.name == "3d" and cloud_ax.get_zlabel() == "z (m, spacecraft frame)"
    for ax in (xy, xz, yz):
        assert ax.get_xlim()[1] >= reach.R_max and ax.get_ylim()[1] >= reach.R_max
    labels = [t.get_text() for t in xy.get_legend().get_texts()]
    assert any(t.startswith("reachable [") for t in labels) and any(t.startswith("path-independent") for t in labels)
    with pytest.raises(ValueError, match="plane"):
        reach.plot(plane="xw")


def test_write_workspace_plots_3d_and_planar(tmp_path: Path) -> None:
    limits = workspace_limits(ARM, samples=1 << 12, criterion=POSITION, piw=True)
    (png,) = write_workspace_plots(limits, tmp_path, dpi=40, cloud_samples=512)
    with Image.open(png) as image:
        width, height = image.size
    assert width > 400 and height > 400
    planar = workspace_limits(ff.models.papadopoulos1992(arms=1), samples=1 << 12)
    assert len(write_workspace_plots(planar, tmp_path / "planar", dpi=40)) == 1


def test_capture_plan_of_a_spatial_arm_plots_in_3d() -> None:
    plan = plan_capture(ARM, 0, [[0.0, 0.0, 0.0], [0.0, 0.2, 0.0]], mass=100.0, inertia=5.0, samples=1 << 13, criterion=POSITION)
    artists = plan.plot()
    ax = artists[0].axes
    assert ax.name == "3d" and plt.fignum_exists(ax.get_figure(root=True).number)
    labels = {a.get_label() for a in artists}
    assert {"payload path A→B", "robot at capture (A)", "robot with the payload at B", "CM+ (system CM after capture)"} <= labels


def test_singularity_map_of_a_spatial_arm_with_the_chosen_measure() -> None:
    """The map of σ_min of the translational J* of the 7-DOF arm over two joints, its threshold drawn as a contour."""
    dmap = ff.workspace.jacobian_determinant_map(ARM, ("j2", "j4"), n=41, ranges=((-2.0, 2.0), (-2.0, 2.0)), criterion=POSITION)
    q = np.zeros((41, 41, 7))
    grid = np.linspace(-2.0, 2.0, 41)
    q[..., 1], q[..., 3] = grid[:, None], grid[None, :]
    np.testing.assert_allclose(dmap.values, POSITION.evaluate(ARM, q))
    assert dmap.measure == "σ_min(⁰J*)" and dmap.threshold == 0.02 and "translational" in dmap.criterion
    assert dmap.values.min() < 0.02 < dmap.values.max()  # the arm is singular when stretched (j4 = 0)
    artists = dmap.plot()
    assert artists.contour is not None and artists.contour.levels.tolist() == [0.02]
    assert artists.colorbar.ax.get_ylabel() == "σ_min(⁰J*)"
    assert plt.fignum_exists(artists.mesh.get_figure(root=True).number)
    with pytest.raises(ff.ShapeError, match="not square"):
        ff.workspace.jacobian_determinant_map(ARM, (0, 1), n=5)  # det J* needs a square J*: pass a criterion
