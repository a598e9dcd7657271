"""Every ``plot()`` of the analysis results makes a pyplot figure when no axes are given (issue 11 item 4), so
``plt.show()`` and notebooks display it, and draws on the given axes otherwise (no new figure)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pytest

import freefloat as ff
from freefloat.analysis.capture import capture_families, optimal_capture_posture, place_path, plan_capture
from freefloat.analysis.workspace import (
    guaranteed_workspace,
    path_independent_workspace,
    payload_effect,
    reachable_workspace,
    workspace_cloud,
)

ONE = ff.models.papadopoulos1992(arms=1)
CAPTURED = ONE.with_payload(0, mass=400.0, inertia=25.0)
PIW = path_independent_workspace(CAPTURED, samples=1 << 14)
PLAN = plan_capture(ONE, 0, [[0.0, 0.0], [0.0, 0.25]], mass=400.0, inertia=25.0, samples=1 << 14)

PLOTS: dict[str, Callable[[Any], Any]] = {
    "ReachableWorkspace": lambda ax: reachable_workspace(CAPTURED).plot(ax),
    "GuaranteedWorkspace": lambda ax: guaranteed_workspace(ff.models.papadopoulos1992(arms=2)).plot(ax),
    "PathIndependentWorkspace": lambda ax: PIW.plot(ax),
    "PayloadEffect": lambda ax: payload_effect(ff.models.papadopoulos1992(arms=2), 0, 400.0, 25.0).plot(ax),
    "CaptureFamilies": lambda ax: capture_families(CAPTURED, 0, 0.54, np.linspace(-np.pi, np.pi, 91)).plot(ax),
    "CapturePosture": lambda ax: optimal_capture_posture(CAPTURED, 0, 0.54).plot(CAPTURED, ax),
    "PathPlacement": lambda ax: place_path(PIW, [[0.0, 0.0], [0.0, 0.25]]).plot(ax),
    "CapturePlan": lambda ax: PLAN.plot(ax),
    "DeterminantMap": lambda ax: ff.workspace.jacobian_determinant_map(CAPTURED, n=21).plot(ax).mesh,
    "WorkspaceCloud.plot_section": lambda ax: workspace_cloud(CAPTURED, samples=256).plot_section(ax),
}


def _figure_of(drawn: Any) -> Any:
    first = drawn[0] if isinstance(drawn, list) else drawn
    return first.get_figure(root=True)


@pytest.mark.parametrize("name", list(PLOTS))
def test_plot_without_axes_is_a_pyplot_figure(name: str) -> None:
    before = set(plt.get_fignums())
    fig = _figure_of(PLOTS[name](None))
    assert fig.number in set(plt.get_fignums()) - before


@pytest.mark.parametrize("name", list(PLOTS))
def test_plot_on_given_axes_draws_there(name: str) -> None:
    ax = plt.figure().add_subplot()
    count = len(plt.get_fignums())
    fig = _figure_of(PLOTS[name](ax))
    assert fig is ax.get_figure(root=True)
    assert len(plt.get_fignums()) == count


def test_cloud_plot_is_3d_on_a_pyplot_figure() -> None:
    artists = workspace_cloud(ff.models.spacecraft_7dof(), samples=256).plot()
    ax = artists[0].axes
    assert ax.name == "3d" and plt.fignum_exists(ax.get_figure(root=True).number)
