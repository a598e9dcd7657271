"""The papers' figures read right (issues 11 item 4, 19 item 8): pyplot figures, scales, shared limits, styles and legends.

1991 Fig. 5: linear axes, a full-range and a zoomed row per quantity, each row's y axis shared by both
columns, so the operational-space peak does not hide the rest. 1992 Fig. 4: the guaranteed workspaces
are hatched bands that stay readable where they overlap, (a) and (b) have the same axis ranges, the bus
is drawn at its size. 1992 Fig. 7: the workspaces before and after capture (the paper's caption), the
robot drawn unlike the payload path, no internal names in the legend, the planned motion visible. The
singularity maps keep their contour labels inside the axes.
"""

from __future__ import annotations

import re

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.patches import Wedge

from freefloat.papers import paper1991_figures as f91
from freefloat.papers import paper1992_figures as f92
from freefloat.papers.paper1991 import Results1991, compute_1991
from freefloat.papers.paper1992 import Results1992, compute_1992

#: Legend text that looks like an identifier: snake_case words such as arm1_ee or merge_gap.
INTERNAL = re.compile(r"\b[a-z]+[0-9]*_[a-z0-9_]+\b")


@pytest.fixture(scope="module")
def r1991() -> Results1991:
    return compute_1991()


@pytest.fixture(scope="module")
def r1992() -> Results1992:
    return compute_1992()


def pyplot_managed(fig: object) -> bool:
    return any(plt.figure(n) is fig for n in plt.get_fignums())


def legend_texts(ax: object) -> list[str]:
    legend = ax.get_legend()  # type: ignore[attr-defined]
    assert legend is not None
    return [t.get_text() for t in legend.get_texts()]


def test_every_1991_figure_is_a_pyplot_figure(r1991: Results1991) -> None:
    for make in f91.FIGURES:
        fig = make(r1991)
        assert pyplot_managed(fig), make.__name__


def test_every_1992_figure_is_a_pyplot_figure(r1992: Results1992) -> None:
    for make in (f92.figure_4, f92.figure_6, f92.figure_7):
        assert pyplot_managed(make(r1992)), make.__name__


def test_1991_fig5_linear_full_range_and_zoomed_panels_with_peaks_stated(r1991: Results1991) -> None:
    """Issue 19 item 8.4: linear axes only (a symlog axis bends the curves at ±5 N); per quantity a full-range row
    that holds the t = 0 peak and a zoomed row that holds the later values at a readable scale."""
    fig = f91.figure_5(r1991)
    axes = np.array(fig.axes).reshape(4, 2)  # force, force zoomed, torque, torque zoomed; one column per controller
    for row in axes:
        assert all(ax.get_yscale() == "linear" for ax in row)
        assert row[0].get_ylim() == row[1].get_ylim()  # one y scale per row, both controllers
        assert row[0].get_shared_y_axes().joined(row[0], row[1])
    later = r1991.runs["tj"].t >= f91.FIG5_ZOOM_FROM
    for (full, zoom), values in (
        ((0, 1), [traj.spacecraft_force[traj.t <= 5.0, :2] for traj in r1991.runs.values()]),
        ((2, 3), [traj.spacecraft_torque[traj.t <= 5.0, 2] for traj in r1991.runs.values()]),
    ):
        lo, hi = axes[full, 0].get_ylim()
        assert lo <= min(float(v.min()) for v in values) and hi >= max(float(v.max()) for v in values)  # the peak shows
        z_lo, z_hi = axes[zoom, 0].get_ylim()
        settled = [v[later[: len(v)]] for v in values]
        assert z_lo <= min(float(v.min()) for v in settled) and z_hi >= max(float(v.max()) for v in settled)
        assert (z_hi - z_lo) < 0.05 * (hi - lo)  # zoomed: the few-newton tail fills its panel
        for ax in axes[full]:  # the zoomed range is marked in the full-range panel
            assert any(t.startswith("zoomed below") for t in legend_texts(ax))
    ct = r1991.runs["ct"]
    first = ct.t <= 5.0
    peak = float(np.max(np.linalg.norm(ct.spacecraft_force[first, :2], axis=1)))
    assert peak > 1000.0  # the operational-space spike at t = 0 of the issue (1077 N)
    texts = [t.get_text() for ax in axes.ravel() for t in ax.texts]
    assert any(f"peak {peak:.4g} N" in t for t in texts)
    for ax in axes[[1, 3]].ravel():
        assert legend_texts(ax) in (["f_x", "f_y"], ["n_z"])


def test_1992_fig4_hatched_bands_and_shared_limits(r1992: Results1992) -> None:
    fig = f92.figure_4(r1992)
    left, right = fig.axes[:2]
    assert left.get_xlim() == right.get_xlim() and left.get_ylim() == right.get_ylim()
    limit = max(r1992.reachable[f"{t}.arm{a}"].R_max for t in ("T3", "T5") for a in (1, 2))
    assert left.get_xlim()[1] >= limit
    bands = [p for p in left.patches if isinstance(p, Wedge) and p.get_label().startswith("arm")]
    assert len(bands) == 2  # both arms' guaranteed workspaces, identical in Table III
    assert {p.get_hatch() for p in bands} == {"////", "\\\\\\\\"}  # crossing hatchings where they overlap
    assert all(p.get_facecolor()[3] == 0.0 for p in bands)  # unfilled: no blended colour that matches no legend entry
    assert len({p.get_edgecolor() for p in bands}) == 2 and len({str(p.get_linestyle()) for p in bands}) == 2
    texts = legend_texts(left)
    for arm in (1, 2):
        assert any(t.startswith(f"arm {arm}: guaranteed [0.685, 1.259] m") for t in texts), texts
    # the legend shows each band exactly as drawn
    handles = {h.get_label(): h for h in left.get_legend().legend_handles}
    for band in bands:
        assert handles[band.get_label()].get_hatch() == band.get_hatch()
    assert any("no guaranteed workspace" in t for t in legend_texts(right))
    for ax in (left, right):
        assert not [t for t in legend_texts(ax) if INTERNAL.search(t)]


def test_1992_fig7_workspaces_before_and_after_capture(r1992: Results1992) -> None:
    fig = f92.figure_7(r1992)
    ax = fig.axes[0]
    texts = legend_texts(ax)
    for needed in (
        "reachable workspace before capture",
        "reachable workspace after capture",
        "path-independent workspace (PIW) after capture",
        "path-dependent workspace (PDW)",
        "payload path A→B",
        "robot at capture (A)",
        "robot with the payload at B",
    ):
        assert any(t.startswith(needed) for t in texts), (needed, texts)
    assert not [t for t in texts if INTERNAL.search(t)], texts
    # the robot and the payload path are drawn differently
    lines = {line.get_label(): line for line in ax.get_lines()}
    robot, path = lines["robot at capture (A)"], lines["payload path A→B"]
    assert robot.get_color() != path.get_color() and robot.get_linewidth() != path.get_linewidth()
    # the path is the whole path A -> B (0.25 m), not a stub
    xy = path.get_xydata()
    assert np.linalg.norm(xy[-1] - xy[0]) == pytest.approx(0.25, abs=1e-12)
    # the robot at B holds the payload at B: the end of the planned motion
    motion = r1992.plan.motion
    assert motion is not None and motion.singularity_free
    np.testing.assert_allclose(motion.end_effector[-1, :2], xy[-1], atol=1e-6)


def test_1992_fig4_bus_at_its_true_size(r1992: Results1992) -> None:
    """Issue 19 item 8.5: the spacecraft bus of Table I (400 kg, 66.67 kg m²: a 1 m cube) drawn 1 m wide, not as a marker."""
    from matplotlib.patches import Polygon

    from freefloat.mechanics.kinematics import spacecraft_box_size
    from freefloat.models import papadopoulos1992

    size = spacecraft_box_size(papadopoulos1992(arms=2))[0]
    np.testing.assert_allclose(size, 1.0, atol=1e-4)
    fig = f92.figure_4(r1992)
    for ax in fig.axes[:2]:
        (bus,) = [p for p in ax.patches if isinstance(p, Polygon)]
        xy = bus.get_xy()
        np.testing.assert_allclose(np.ptp(xy, axis=0), size[:2], atol=1e-9)  # Fig. 4 draws the spacecraft unrotated
        assert bus.get_visible() and bus.get_facecolor()[3] > 0.0 and bus.get_linewidth() > 0.0
        assert not [line for line in ax.get_lines() if line.get_marker() == "s"]  # no fixed-size square marker


def test_1992_fig7_planned_motion_visible_and_in_the_legend(r1992: Results1992) -> None:
    """Issue 19 item 8.6: the planned end-effector motion follows the payload path: it is drawn on top of it, and its
    legend handle is a visible line that looks like it."""
    fig = f92.figure_7(r1992)
    ax = fig.axes[0]
    lines = {line.get_label(): line for line in ax.get_lines()}
    motion, path = lines["planned end-effector motion"], lines["payload path A→B"]
    assert motion.get_zorder() > path.get_zorder()  # not hidden under the thick path it follows
    handles = {t.get_text(): h for t, h in zip(ax.get_legend().get_texts(), ax.get_legend().legend_handles, strict=True)}
    handle = handles["planned end-effector motion"]
    for artist in (motion, handle):
        assert artist.get_visible() and artist.get_linewidth() > 0.0 and (artist.get_alpha() is None or artist.get_alpha() > 0.0)
        assert artist.get_linestyle() not in ("None", "", " ")
    assert (handle.get_color(), handle.get_linestyle(), handle.get_linewidth()) == (
        motion.get_color(),
        motion.get_linestyle(),
        motion.get_linewidth(),
    )
    assert handle.get_color() != path.get_color()


def test_1992_singularity_maps_contour_labels_inside_the_axes(r1992: Results1992) -> None:
    """Issue 19 item 8.7: every |r_E| contour label lies wholly inside its map (no "436 m" cut at the edge), and every
    PDW boundary radius is labelled."""
    fig = f92.figure_singularity_maps(r1992)  # the 1° grid the demo writes
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    maps = [ax for ax in fig.axes if ax.get_title().startswith("(")]
    assert len(maps) == 2
    for ax in maps:
        labels = [t for t in ax.texts if t.get_text().endswith(" m")]
        assert len({t.get_text() for t in labels}) == 3, [t.get_text() for t in labels]  # three PDW boundaries inside (0, R_max)
        box = ax.get_window_extent(renderer)
        for label in labels:
            extent = label.get_window_extent(renderer)
            assert box.x0 <= extent.x0 and extent.x1 <= box.x1 and box.y0 <= extent.y0 and extent.y1 <= box.y1, label.get_text()
    plt.close(fig)
