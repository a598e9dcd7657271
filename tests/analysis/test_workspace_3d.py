"""Spatial workspaces drawn in 3D (issue 11 item 3): sections through the system CM, point clouds, 3D capture plans."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest

import freefloat as ff
from freefloat.analysis.capture import CapturePlan, plan_capture
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
from images import check_png

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
    assert png.name == f"workspace_{ARM.name}_{ARM.end_effector_names[0]}.png"
    check_png(png, (12.0, 11.0), 40, tight=True, min_colours=32)  # three sections and the 3D cloud
    planar = workspace_limits(ff.models.papadopoulos1992(arms=1), samples=1 << 12)
    (flat,) = write_workspace_plots(planar, tmp_path / "planar", dpi=40)
    check_png(flat, (6.4, 6.0), 40, tight=True)  # the annuli in the plane


@pytest.fixture(scope="module")
def plan_3d() -> CapturePlan:
    return plan_capture(ARM, 0, [[0.0, 0.0, 0.0], [0.0, 0.2, 0.0]], mass=100.0, inertia=5.0, samples=1 << 13, criterion=POSITION)


def test_capture_plan_of_a_spatial_arm_plots_in_3d(plan_3d: CapturePlan) -> None:
    plan = plan_3d
    artists = plan.plot()
    ax = artists[0].axes
    assert ax.name == "3d" and plt.fignum_exists(ax.get_figure(root=True).number)
    labels = {a.get_label() for a in artists}
    assert {"payload path A→B", "robot at capture (A)", "robot with the payload at B", "CM+ (system CM after capture)"} <= labels
    # in 3D, the plan's own points: the payload path, CM+, the planned end-effector motion
    by_label = {a.get_label(): a for a in artists if hasattr(a, "get_data_3d")}
    np.testing.assert_allclose(np.column_stack(by_label["payload path A→B"].get_data_3d()), plan.placement.path, atol=1e-12)
    np.testing.assert_allclose(
        np.column_stack(by_label["CM+ (system CM after capture)"].get_data_3d()), [plan.placement.cm_plus], atol=1e-12
    )
    assert plan.motion is not None
    np.testing.assert_allclose(np.column_stack(by_label["planned end-effector motion"].get_data_3d()), plan.motion.end_effector, atol=1e-12)


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


def test_3d_capture_plan_holds_everything_drawn_at_equal_scales(plan_3d: CapturePlan) -> None:
    """Issue 19 item 8.1: the robot at both postures (links and bus), the path and the CMs inside the axes, x, y, z
    on equal ranges in a cube, the bus the size of the model's."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from freefloat.mechanics.kinematics import spacecraft_box, spacecraft_box_size

    ax = plan_3d.plot()[0].axes
    limits = np.array([ax.get_xlim(), ax.get_ylim(), ax.get_zlim()])  # (3, 2)
    spans = limits[:, 1] - limits[:, 0]
    np.testing.assert_allclose(spans, spans[0], rtol=1e-12)  # equal ranges
    np.testing.assert_allclose(ax.get_box_aspect() / ax.get_box_aspect()[0], 1.0)  # drawn as a cube
    drawn = [np.stack(line.get_data_3d(), axis=1) for line in ax.get_lines() if len(line.get_xdata())]
    at_b = spacecraft_box(plan_3d.captured, plan_3d.motion.q[-1], attitude=plan_3d.motion.attitude[-1]) + plan_3d.motion.cm
    at_a = spacecraft_box(plan_3d.captured, plan_3d.posture.q, attitude=plan_3d.posture.attitude) + plan_3d.placement.cm_plus
    points = np.concatenate([*drawn, at_a, at_b])
    assert len(drawn) > 20  # both robots' links, joints, the paths and the marks
    assert np.all(points >= limits[:, 0] - 1e-9) and np.all(points <= limits[:, 1] + 1e-9)
    buses = [c for c in ax.collections if isinstance(c, Poly3DCollection)]
    assert len(buses) == 2  # the bus at A and at B
    size = spacecraft_box_size(ARM)[0]
    assert np.all(size > 1.5) and np.all(spans >= size.max())  # the 1500 kg bus, about 2 m, fits


def test_cloud_plot_has_a_colour_bar_naming_the_measure_and_its_unit() -> None:
    """Issue 19 item 8.3: the colour of the cloud is explained by a colour bar with the quantity and its unit."""
    artists = workspace_cloud(ARM, samples=512, criterion=POSITION).plot()
    scatter, bar_ax = artists[0], artists[-1]
    fig = scatter.get_figure(root=True)
    assert bar_ax in fig.axes and bar_ax is not scatter.axes
    assert bar_ax.get_ylabel() == "|σ_min(⁰J*)| (m)"  # translational rows: m/s per rad/s
    bar = scatter.colorbar
    assert bar is not None and bar.ax is bar_ax
    planar = workspace_cloud(ff.models.papadopoulos1992(arms=1), samples=64)
    assert (planar.symbol, planar.unit) == ("det ⁰J*", "m²")
    full = workspace_cloud(ARM, samples=64)
    assert full.symbol == "σ_min(⁰J*)" and "mixed" in full.unit  # velocity and rotation rows together
