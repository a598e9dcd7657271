"""Capture of a payload (1992 §V): eq. 19, path placement, eq. 21 families and the optimal capture posture."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import freefloat as ff
from freefloat.analysis.capture import (
    PathDoesNotFitError,
    approach_distance,
    capture_families,
    optimal_capture_posture,
    place_path,
    plan_capture,
)
from freefloat.analysis.workspace import end_effector_radius, path_independent_workspace, reachable_workspace
from trees import build_random_model

ONE = ff.models.papadopoulos1992(arms=1)
CAPTURED = ONE.with_payload(0, mass=400.0, inertia=25.0)
PIW = path_independent_workspace(CAPTURED, samples=1 << 16)


def test_approach_distance_eq19() -> None:
    assert approach_distance(470.0, 400.0, 0.540) == pytest.approx(870.0 / 470.0 * 0.540)
    np.testing.assert_allclose(approach_distance(470.0, [0.0, 400.0], 0.5), [0.5, 0.5 * 870.0 / 470.0])
    for bad in ((0.0, 400.0, 0.5), (470.0, -1.0, 0.5), (470.0, 400.0, -0.1), (float("nan"), 1.0, 1.0)):
        with pytest.raises(ValueError):
            approach_distance(*bad)


def test_place_path_straight_segment_is_centred_radially() -> None:
    length = 0.25
    placement = place_path(PIW, [[0.0, 0.0], [0.0, length]])
    r_in, r_out = placement.interval
    assert (r_in, r_out) == (PIW.R_min, PIW.R_max)
    s = r_in + r_out
    assert placement.R_plus == pytest.approx((s * s - length**2) / (2.0 * s), abs=1e-9)  # closed form of the rule
    assert placement.R_plus - r_in == pytest.approx(r_out - np.hypot(placement.R_plus, length), abs=1e-9)  # equal margins
    assert placement.margin == pytest.approx(placement.R_plus - r_in, abs=1e-9)
    # (CM+)A ⟂ AB, and the whole path lies in the annulus around CM+
    np.testing.assert_allclose(placement.direction @ np.array([0.0, 1.0]), 0.0, atol=1e-12)
    np.testing.assert_allclose(placement.direction, [1.0, 0.0], atol=1e-12)  # CM+ on the left of AB: A is at +x from CM+
    pts = np.linspace([0.0, 0.0], [0.0, length], 101)
    d = np.linalg.norm(pts - placement.cm_plus, axis=1)
    assert np.all(d >= r_in - 1e-12) and np.all(d <= r_out + 1e-12)
    # eq. 19 from the model's masses: the free-flyer's CM before capture, on the line A -> CM+
    assert placement.robot_mass == pytest.approx(ONE.total_mass) and placement.payload_mass == pytest.approx(400.0)
    assert placement.approach_distance == pytest.approx(approach_distance(470.0, 400.0, placement.R_plus))
    assert placement.approach_point is not None
    assert np.linalg.norm(placement.approach_point - placement.start) == pytest.approx(placement.approach_distance)
    u, v = placement.approach_point - placement.start, placement.cm_plus - placement.start
    assert u[0] * v[1] - u[1] * v[0] == pytest.approx(0.0, abs=1e-12) and u @ v > 0.0


def test_place_path_polylines_rules_and_3d() -> None:
    path = [[0.0, 0.0], [0.1, 0.15], [0.05, 0.3]]
    perpendicular = place_path(PIW, path)
    free = place_path(PIW, path, rule="max_margin")
    assert free.margin >= perpendicular.margin - 1e-12
    for placement in (perpendicular, free):
        pts = np.concatenate([np.linspace(a, b, 50) for a, b in zip(placement.path[:-1], placement.path[1:], strict=True)])
        d = np.linalg.norm(pts - placement.cm_plus, axis=1)
        assert d.min() >= placement.interval[0] + placement.margin - 1e-9 and d.max() <= placement.interval[1] - placement.margin + 1e-9
    imposed = place_path(PIW, path, R_plus=0.5)
    assert imposed.R_plus == pytest.approx(0.5)
    three = place_path(PIW, [[0.0, 0.0, 0.0], [0.0, 0.25, 0.0], [0.05, 0.3, 0.05]])
    assert three.cm_plus.shape == (3,) and abs(three.direction @ np.array([0.0, 1.0, 0.0])) < 1e-12
    assert place_path((0.2, 1.0), [[0.0, 0.0], [0.3, 0.0]]).interval == (0.2, 1.0)


def test_place_path_errors() -> None:
    with pytest.raises(PathDoesNotFitError, match="dynamic singularities") as fits_reach:
        place_path(PIW, [[0.0, 0.0], [0.0, 0.9]])  # longer than the PIW allows, shorter than the reachable workspace
    assert fits_reach.value.fits_reachable is True and fits_reach.value.margin < 0
    with pytest.raises(PathDoesNotFitError, match="thrusters are needed") as nowhere:
        place_path(PIW, [[0.0, 0.0], [0.0, 2.0]])
    assert nowhere.value.fits_reachable is False
    with pytest.raises(ValueError, match="rule"):
        place_path(PIW, [[0.0, 0.0], [0.0, 0.2]], rule="closest")
    with pytest.raises(ValueError, match="zero length"):
        place_path(PIW, [[0.0, 0.0], [0.0, 0.0]])
    with pytest.raises(ValueError, match="2D or 3D"):
        place_path(PIW, np.zeros((3, 4)))
    with pytest.raises(ValueError, match="workspace"):
        place_path((1.0, 0.5), [[0.0, 0.0], [0.0, 0.2]])


def test_capture_families_solve_eq21() -> None:
    r_plus = 0.54
    q1 = np.linspace(-np.pi, np.pi, 720, endpoint=False).reshape(3, 240)
    fam = capture_families(CAPTURED, 0, r_plus, q1)
    assert fam.q2.shape == (*q1.shape, 2) and fam.det.shape == (*q1.shape, 2)
    valid = np.isfinite(fam.q2)
    assert valid.all()  # R+ = 0.54 is reachable for every q1 here
    q = np.stack([np.broadcast_to(q1[..., None], fam.q2.shape), fam.q2], axis=-1)
    np.testing.assert_allclose(end_effector_radius(CAPTURED, q), r_plus, atol=1e-12)
    np.testing.assert_allclose(fam.det, ff.jacobian_determinant(CAPTURED, q), atol=1e-15)
    near_max = capture_families(CAPTURED, 0, 1.2, np.linspace(-np.pi, np.pi, 361))
    assert np.isnan(near_max.q2).any() and np.isfinite(near_max.q2).any()
    with pytest.raises(ff.ModelError, match="two-link"):
        capture_families(ff.models.papadopoulos1992(arms=2), 0, 1.0, 0.0)


@pytest.mark.parametrize("r_plus", [0.54, 0.3, 1.0])
def test_optimal_posture_is_the_best_on_both_families(r_plus: float) -> None:
    posture = optimal_capture_posture(CAPTURED, 0, r_plus)
    assert abs(posture.residual) < 1e-10  # the constraint |r_E| = R+ holds
    assert float(end_effector_radius(CAPTURED, posture.q)) == pytest.approx(r_plus, abs=1e-10)
    assert posture.det is not None and posture.measure == pytest.approx(abs(posture.det))
    # a dense scan of both eq. 21 families finds nothing better
    fam = capture_families(CAPTURED, 0, r_plus, np.linspace(-np.pi, np.pi, 200_001))
    assert np.nanmax(np.abs(fam.det)) <= posture.measure * (1.0 + 1e-9)
    assert np.nanmax(np.abs(fam.det)) >= posture.measure * (1.0 - 1e-8)
    assert posture.family in (0, 1)
    # the attitude puts the end effector at R+ along the direction (+x): eq. 20 with x_E = R+, y_E = 0
    r_inertial = ff.end_effector_positions(CAPTURED, posture.q, attitude=posture.attitude)[0]
    np.testing.assert_allclose(r_inertial, [r_plus, 0.0, 0.0], atol=1e-10)
    assert posture.theta is not None
    np.testing.assert_allclose(Rotation.from_quat(posture.attitude).as_rotvec(), [0.0, 0.0, posture.theta], atol=1e-12)


@pytest.mark.parametrize("family", [0, 1])
def test_optimal_posture_on_each_family(family: int) -> None:
    r_plus = 0.54
    posture = optimal_capture_posture(CAPTURED, 0, r_plus, family=family)
    assert posture.family == family and abs(posture.residual) < 1e-10
    fam = capture_families(CAPTURED, 0, r_plus, np.linspace(-np.pi, np.pi, 100_001))
    # the posture lies on its family: q2 = q2_family(q1)
    on = capture_families(CAPTURED, 0, r_plus, posture.q[0])
    assert abs(np.angle(np.exp(1j * (on.q2[family] - posture.q[1])))) < 1e-7
    # and is the best of that family over a dense scan
    best = np.nanmax(np.abs(fam.det[:, family]))
    assert best * (1.0 - 1e-8) <= posture.measure <= best * (1.0 + 1e-9)
    with pytest.raises(ValueError, match="family"):
        optimal_capture_posture(CAPTURED, 0, r_plus, family=2)
    with pytest.raises(ff.ModelError, match="two-link"):
        optimal_capture_posture(ff.models.papadopoulos1992(arms=2), 0, 1.0, family=0)


def test_optimal_posture_limits_direction_and_3d() -> None:
    limited = ff.ModelBuilder("limited")
    limited.add_body("bus", mass=300.0, inertia=40.0)
    limited.add_body("l1", mass=30.0, inertia=2.0, com=(0.5, 0.0, 0.0))
    limited.add_body("l2", mass=20.0, inertia=1.5, com=(0.5, 0.0, 0.0), end_effector=(1.0, 0.0, 0.0))
    limited.add_joint("q1", parent="bus", child="l1", origin=(0.5, 0.0, 0.0), limits=(-0.5, 0.5))
    limited.add_joint("q2", parent="l1", child="l2", origin=(1.0, 0.0, 0.0), limits=(0.2, 1.5))
    model = limited.build()
    posture = optimal_capture_posture(model, 0, 1.8, direction=[0.0, 1.0])
    assert np.all(posture.q >= [-0.5 - 1e-12, 0.2 - 1e-12]) and np.all(posture.q <= [0.5 + 1e-12, 1.5 + 1e-12])
    assert abs(posture.residual) < 1e-10
    q1 = np.linspace(-0.5, 0.5, 2001)
    fam = capture_families(model, 0, 1.8, q1)
    inside = (fam.q2 >= 0.2) & (fam.q2 <= 1.5)
    assert np.max(np.abs(np.where(inside, fam.det, 0.0))) <= posture.measure * (1.0 + 1e-9)
    np.testing.assert_allclose(ff.end_effector_positions(model, posture.q, attitude=posture.attitude)[0], [0.0, 1.8, 0.0], atol=1e-10)
    with pytest.raises(ValueError, match="outside the reachable"):
        optimal_capture_posture(model, 0, 5.0)
    # 3D: a random six-joint arm; the constraint holds and sampling near the constraint finds nothing better
    arm = build_random_model(np.random.default_rng(3), [6], [None], [None])
    reach = reachable_workspace(arm, samples=1 << 13)
    r_plus = 0.5 * (reach.R_min + reach.R_max)
    best = optimal_capture_posture(arm, 0, r_plus, direction=[0.0, 0.0, 1.0])
    assert best.theta is None and abs(best.residual) < 1e-10
    np.testing.assert_allclose(ff.end_effector_positions(arm, best.q, attitude=best.attitude)[0], [0.0, 0.0, r_plus], atol=1e-9)
    q = np.random.default_rng(4).uniform(-np.pi, np.pi, size=(1 << 17, 6))
    band = np.abs(end_effector_radius(arm, q) - r_plus) < 2e-3
    assert band.sum() > 50
    sampled = np.prod(np.linalg.svd(ff.generalized_jacobian(arm, q[band]), compute_uv=False), axis=-1)  # |det J*| (6 x 6)
    assert np.max(sampled) <= best.measure * 1.02


def test_plan_capture_end_to_end_and_plots() -> None:
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Wedge

    plan = plan_capture(ONE, 0, [[0.0, 0.0], [0.0, 0.25]], mass=400.0, inertia=25.0, samples=1 << 16)
    assert plan.captured.total_mass == pytest.approx(870.0)
    assert plan.approach_distance == pytest.approx(870.0 / 470.0 * plan.placement.R_plus)
    assert plan.posture.R_plus == pytest.approx(plan.placement.R_plus)
    # the end effector, placed by the posture's attitude around CM+, is at the path start A
    tip = plan.placement.cm_plus + ff.end_effector_positions(plan.captured, plan.posture.q, attitude=plan.posture.attitude)[0, :2]
    np.testing.assert_allclose(tip, plan.placement.start, atol=1e-9)
    # the plot (Fig. 7) draws the plan's own numbers: the path, CM+ and the free-flyer's CM, the PIW about CM+,
    # the robot at capture with its end effector on A, and the planned end-effector motion
    ax = Figure().add_subplot()
    artists = plan.plot(ax)
    lines = {line.get_label(): line for line in artists if isinstance(line, Line2D)}
    np.testing.assert_allclose(lines["payload path A→B"].get_xydata(), plan.placement.path, atol=1e-12)
    np.testing.assert_allclose(lines["CM+ (system CM after capture)"].get_xydata(), [plan.placement.cm_plus[:2]], atol=1e-12)
    assert plan.placement.approach_point is not None
    np.testing.assert_allclose(lines["free-flyer CM before capture"].get_xydata(), [plan.placement.approach_point[:2]], atol=1e-12)
    assert plan.motion is not None
    np.testing.assert_allclose(lines["planned end-effector motion"].get_xydata(), plan.motion.end_effector[:, :2], atol=1e-12)
    rings = [a for a in artists if isinstance(a, Wedge)]
    assert [(w.center, w.r - (w.width or w.r), w.r) for w in rings[: len(plan.piw.piw)]] == [
        (pytest.approx(plan.placement.cm_plus[:2]), pytest.approx(lo, abs=1e-12), pytest.approx(hi)) for lo, hi in plan.piw.piw
    ]
    robot = lines["robot at capture (A)"]
    links = [a for a in artists[artists.index(robot) :] if isinstance(a, Line2D) and a.get_color() == robot.get_color()]
    tips = next(a for a in links if a.get_marker() == "o" and a.get_markersize() == 5)
    np.testing.assert_allclose(tips.get_xydata()[-1], plan.placement.start, atol=1e-9)  # the end effector on A
    # Fig. 6: q2(q1) of both eq. 21 families, and det J* along them on the second axis
    families = capture_families(CAPTURED, 0, 0.54, np.linspace(-np.pi, np.pi, 91))
    drawn = families.plot()
    assert [a.get_label() for a in drawn] == ["q2, family 1", "det J*, family 1", "q2, family 2", "det J*, family 2"]
    for k in (0, 1):
        q2, det = drawn[2 * k].get_xydata(), drawn[2 * k + 1].get_xydata()
        np.testing.assert_allclose(q2, np.degrees(np.column_stack([families.q1, families.q2[:, k]])), atol=1e-12)
        np.testing.assert_allclose(det, np.column_stack([np.degrees(families.q1), families.det[:, k]]), atol=1e-12)
        assert drawn[2 * k + 1].axes is not drawn[2 * k].axes  # det J* on the twin axis
    with pytest.raises(PathDoesNotFitError):
        plan_capture(ONE, 0, [[0.0, 0.0], [0.0, 3.0]], mass=400.0, inertia=25.0, samples=1 << 12)
