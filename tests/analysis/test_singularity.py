"""det J* maps (1992 eq. 17): values, one batched call, plotting."""

from __future__ import annotations

import dataclasses

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.figure import Figure

import freefloat as ff
from freefloat.analysis import singularity


@pytest.fixture(scope="module")
def captured_map() -> ff.workspace.DeterminantMap:
    captured = ff.models.papadopoulos1992(arms=1).with_payload(end_effector=0, mass=400.0, inertia=25.0)
    return ff.workspace.jacobian_determinant_map(captured)


def test_map_equals_pointwise_determinant() -> None:
    model = ff.models.papadopoulos1992(arms=2)
    q_fixed = np.array([0.3, -0.7, 1.1, 0.4])
    dmap = ff.workspace.jacobian_determinant_map(model, (1, 3), n=(7, 5), ranges=((-1.0, 2.0), (0.5, 3.0)), q_fixed=q_fixed)
    assert dmap.values.shape == (7, 5)
    assert dmap.joints == (1, 3)
    assert dmap.joint_names == ("arm1_q2", "arm2_q2")
    np.testing.assert_allclose(dmap.angles_x, np.linspace(-1.0, 2.0, 7))
    np.testing.assert_allclose(dmap.angles_y, np.linspace(0.5, 3.0, 5))
    np.testing.assert_array_equal(dmap.q_fixed, q_fixed)
    for a, b in [(0, 0), (6, 4), (3, 1), (2, 3)]:
        q = q_fixed.copy()
        q[1], q[3] = dmap.angles_x[a], dmap.angles_y[b]
        expected = float(ff.jacobian_determinant(model, q))
        assert dmap.values[a, b] == pytest.approx(expected, rel=1e-12, abs=1e-15)
    assert np.ptp(dmap.values) > 1e-3  # not a constant map
    by_name = ff.workspace.jacobian_determinant_map(
        model, ("arm1_q2", "arm2_q2"), n=(7, 5), ranges=((-1.0, 2.0), (0.5, 3.0)), q_fixed=q_fixed
    )
    np.testing.assert_array_equal(by_name.values, dmap.values)


def test_map_is_one_batched_call(monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[tuple[int, ...]] = []
    real = singularity.jacobian_determinant

    def counting(model: ff.Model, q: np.ndarray) -> np.ndarray:
        calls.append(np.shape(q))
        return real(model, q)

    monkeypatch.setattr(singularity, "jacobian_determinant", counting)
    dmap = ff.workspace.jacobian_determinant_map(ff.models.papadopoulos1991(), n=(9, 11))
    assert calls == [(9, 11, 2)]
    assert dmap.values.shape == (9, 11)


def test_default_grid_is_one_degree(captured_map: ff.workspace.DeterminantMap) -> None:
    assert captured_map.values.shape == (361, 361)
    assert captured_map.angles_x[0] == pytest.approx(-np.pi)
    assert captured_map.angles_y[-1] == pytest.approx(np.pi)
    np.testing.assert_allclose(np.diff(np.degrees(captured_map.angles_x)), 1.0)
    np.testing.assert_array_equal(captured_map.q_fixed, [0.0, 0.0])
    assert captured_map.model_name == "papadopoulos1992_one_arm+payload"
    assert captured_map.unit == "m²"


def test_captured_one_arm_has_dynamic_singularities(captured_map: ff.workspace.DeterminantMap) -> None:
    values = captured_map.values
    assert captured_map.has_sign_change
    assert values.min() < -0.05 and values.max() > 0.05
    # For every q1 the determinant changes sign along q2: a zero curve crosses the whole map.
    signs = np.sign(values)
    assert np.all(np.any(signs[:, :-1] * signs[:, 1:] <= 0, axis=1))


def test_result_is_frozen(captured_map: ff.workspace.DeterminantMap) -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        captured_map.model_name = "x"  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        captured_map.values[0, 0] = 1.0


def test_plot_on_given_axes(captured_map: ff.workspace.DeterminantMap) -> None:
    fig = Figure()
    ax = fig.add_subplot()
    artists = captured_map.plot(ax)
    assert artists.mesh.axes is ax
    assert artists.contour is not None and artists.contour.axes is ax
    assert sum(len(seg) for seg in artists.contour.allsegs[0]) > 100  # the det J* = 0 curves
    # the colours are the map's values (one cell per grid point, rows along y), the black curves are det J* = 0:
    # det J* at their points (deg -> rad; other joints as in the map) is zero to the grid's resolution
    np.testing.assert_array_equal(np.asarray(artists.mesh.get_array()).reshape(captured_map.values.T.shape), captured_map.values.T)
    points = np.radians(np.concatenate(artists.contour.allsegs[0]))
    q = np.tile(captured_map.q_fixed, (len(points), 1))
    q[:, list(captured_map.joints)] = points
    step = float(captured_map.angles_x[1] - captured_map.angles_x[0])
    slope = max(float(np.abs(g).max()) for g in np.gradient(captured_map.values, step))
    captured = ff.models.papadopoulos1992(arms=1).with_payload(end_effector=0, mass=400.0, inertia=25.0)
    off = np.abs(ff.jacobian_determinant(captured, q)).max()
    assert off < 0.01 * slope * step
    assert artists.colorbar.ax is not ax and "det" in artists.colorbar.ax.get_ylabel()
    assert ax.get_xlabel() == "arm1_q1 (deg)" and ax.get_ylabel() == "arm1_q2 (deg)"
    assert ax.get_xlim() == pytest.approx((-180.5, 180.5))
    assert ax.get_title()
    rad = Figure().add_subplot()
    captured_map.plot(rad, degrees=False)
    assert rad.get_xlabel() == "arm1_q1 (rad)"
    assert rad.get_xlim()[1] < 3.2


def test_plot_without_axes_makes_one_pyplot_figure(captured_map: ff.workspace.DeterminantMap) -> None:
    """Issue 11: a plot() without axes is a pyplot figure, so plt.show() and notebooks display it."""
    before = plt.get_fignums()
    artists = captured_map.plot()
    fig = artists.mesh.get_figure(root=True)
    assert isinstance(fig, Figure)
    assert plt.get_fignums() == [*before, fig.number]


def test_no_contour_without_sign_change() -> None:
    dmap = singularity.DeterminantMap(
        model_name="m",
        joints=(0, 1),
        joint_names=("a", "b"),
        angles_x=np.linspace(0.0, 1.0, 3),
        angles_y=np.linspace(0.0, 1.0, 4),
        values=np.ones((3, 4)),
        q_fixed=np.zeros(2),
    )
    assert not dmap.has_sign_change
    artists = dmap.plot(Figure().add_subplot())
    assert artists.contour is None


def test_bad_arguments() -> None:
    model = ff.models.papadopoulos1991()
    with pytest.raises(ValueError, match="two different joints"):
        ff.workspace.jacobian_determinant_map(model, (0, 0))
    with pytest.raises(ff.UnknownNameError, match="q3"):
        ff.workspace.jacobian_determinant_map(model, ("q1", "q3"))
    with pytest.raises(ValueError, match="n:"):
        ff.workspace.jacobian_determinant_map(model, n=1)
    with pytest.raises(ValueError, match="lower < upper"):
        ff.workspace.jacobian_determinant_map(model, ranges=((1.0, 0.0), (0.0, 1.0)))
    with pytest.raises(ff.ShapeError, match=r"q_fixed: expected shape \(2,\)"):
        ff.workspace.jacobian_determinant_map(model, q_fixed=[0.0, 0.0, 0.0])
    with pytest.raises(ff.ShapeError, match="values"):
        singularity.DeterminantMap("m", (0, 1), ("a", "b"), np.zeros(2), np.zeros(3), np.zeros((3, 2)), np.zeros(2))
