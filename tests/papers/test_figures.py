"""The papers' figures read right (issue 11 item 4): pyplot figures, scales, shared limits, styles and legends.

1991 Fig. 5: both columns share each row's y axis on a symmetric-log scale, so the operational-space
peak does not hide the rest. 1992 Fig. 4: the guaranteed workspaces are hatched bands that stay
readable where they overlap, and (a) and (b) have the same axis ranges. 1992 Fig. 7: the workspaces
before and after capture (the paper's caption), the robot drawn unlike the payload path, no internal
names in the legend.
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


def test_1991_fig5_shared_symlog_scales_and_peaks_stated(r1991: Results1991) -> None:
    fig = f91.figure_5(r1991)
    axes = np.array(fig.axes).reshape(2, 2)
    for row in axes:
        assert all(ax.get_yscale() == "symlog" for ax in row)
        assert row[0].get_ylim() == row[1].get_ylim()  # one y scale per row, both controllers
        assert row[0].get_shared_y_axes().joined(row[0], row[1])
    ct = r1991.runs["ct"]
    first = ct.t <= 5.0
    peak = float(np.max(np.linalg.norm(ct.spacecraft_force[first, :2], axis=1)))
    assert peak > 1000.0  # the operational-space spike at t = 0 of the issue (1077 N)
    lo, hi = axes[0, 1].get_ylim()
    assert hi >= peak
    # the symlog axis is linear within ±5 N: the few-newton tail spans a visible share of the axis, not a flat line
    transform = axes[0, 1].yaxis.get_transform()
    span = transform.transform(np.array([hi])) - transform.transform(np.array([lo]))
    tail = transform.transform(np.array([5.0])) - transform.transform(np.array([-5.0]))
    assert float(tail[0] / span[0]) > 0.15
    texts = [t.get_text() for ax in axes.ravel() for t in ax.texts]
    assert any(f"peak {peak:.4g} N" in t for t in texts)
    for ax in axes.ravel():
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
