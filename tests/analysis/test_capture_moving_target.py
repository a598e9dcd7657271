"""The 1992 §V capture planner with a moving target (issue 22 item 6): the impact at the planned grasp, and the
candidate capture postures along the eq. 21 families ranked by what the grasp does to the robot."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from scipy.spatial.transform import Rotation

import freefloat as ff
from freefloat.analysis.capture import CapturePlan, capture_families, plan_capture
from freefloat.analysis.singularity import SingularityCriterion
from freefloat.core.errors import ModelError, ShapeError

ONE = ff.models.papadopoulos1992(arms=1)
PATH = [[0.0, 0.0], [0.0, 0.25]]
PAYLOAD = {"mass": 400.0, "inertia": 25.0, "samples": 1 << 16}
#: A drifting, spinning payload (inertial frame): 2 cm/s and 0.1 rad/s.
MOTION = {"target_velocity": [0.02, 0.01, 0.0], "target_angular_velocity": [0.0, 0.0, 0.1]}
#: Every field of a plan that the 1992 §V procedure computes (the moving-target fields aside).
PLAN_FIELDS = ("placement", "posture", "motion", "piw")


def _plan(model: ff.Model = ONE, **kwargs: object) -> CapturePlan:
    return plan_capture(model, 0, PATH, **PAYLOAD, **kwargs)  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def paper() -> CapturePlan:
    return _plan()


@pytest.fixture(scope="module")
def ranked() -> dict[str, CapturePlan]:
    """The spinning target's plan ranked by each criterion (joint impulse: locked joints)."""
    out = {name: _plan(**MOTION, rank_by=name) for name in ("measure", "spacecraft_rate", "impulse", "angular_impulse")}
    out["joint_impulse"] = _plan(**MOTION, rank_by="joint_impulse", joints="locked")
    return out


def _same_dataclass(a: object, b: object) -> None:
    """Every field equal exactly (arrays element by element)."""
    for f in dataclasses.fields(a):  # type: ignore[arg-type]
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray):
            assert np.array_equal(x, y), f.name
        elif dataclasses.is_dataclass(x):
            _same_dataclass(x, y)
        elif not isinstance(x, ff.Model):
            assert x == y, f.name


def _grasp_by_hand(
    plan: CapturePlan, q: np.ndarray, attitude: np.ndarray, cm_plus: np.ndarray, **options: Any
) -> tuple[ff.State, ff.capture.Target]:
    """The robot at rest and the payload at a capture (CM+, q, attitude), from the end-effector point (the payload is
    grasped at its CM) and eq. 19: no code of the planner's. ``options``: mass and inertia (default the §V payload's),
    target_velocity and target_angular_velocity (default :data:`MOTION`)."""
    mass, inertia = options.get("mass", 400.0), options.get("inertia", 25.0)
    rot = Rotation.from_quat(attitude)
    tip = cm_plus + rot.apply(ff.end_effector_positions(plan.captured, q)[0])
    robot = plan.before.total_mass
    hand = rot.as_matrix() @ ff.body_rotations(plan.captured, q)[plan.captured.end_effector_body[0]]
    target = ff.capture.Target(
        mass=mass,
        inertia=inertia,
        position=tip,
        attitude=Rotation.from_matrix(hand),
        velocity=options.get("target_velocity", MOTION["target_velocity"]),
        angular_velocity=options.get("target_angular_velocity", MOTION["target_angular_velocity"]),
    )
    return ff.State(q=q, attitude=attitude, r_cm=((robot + mass) * cm_plus - mass * tip) / robot), target


# ------------------------------------------------------------------------------------------- the papers' plan unchanged
def test_ranking_by_the_measure_reproduces_the_paper_plan_exactly(paper: CapturePlan, ranked: dict[str, CapturePlan]) -> None:
    moving = ranked["measure"]
    for name in PLAN_FIELDS:
        _same_dataclass(getattr(paper, name), getattr(moving, name))
    assert (moving.method, moving.why_path) == (paper.method, paper.why_path) == ("piw", "")
    assert paper.impact is None and paper.ranking is None and paper.grasp_state is None and paper.target is None
    assert moving.ranking is not None and moving.ranking.chosen == moving.ranking.planner == 0
    np.testing.assert_array_equal(moving.ranking.q[0], paper.posture.q)  # the planner's own posture is candidate 0


def test_a_target_at_rest_gives_zero_impulse_and_the_unchanged_plan(paper: CapturePlan) -> None:
    for rank_by in ("measure", "spacecraft_rate", "impulse"):
        rest = _plan(target_velocity=[0.0, 0.0, 0.0], target_angular_velocity=[0.0, 0.0, 0.0], rank_by=rank_by)
        for name in PLAN_FIELDS:
            _same_dataclass(getattr(paper, name), getattr(rest, name))
        assert rest.impact is not None and rest.ranking is not None
        assert not np.any(rest.impact.impulse) and not np.any(rest.impact.joint_impulse) and rest.impact.energy_lost == 0.0
        assert not np.any(rest.impact.state.omega) and not np.any(rest.impact.state.qdot) and not np.any(rest.impact.state.v_cm)
        for name in ("spacecraft_rate", "impulse", "angular_impulse", "joint_impulse", "energy_lost"):
            assert not np.any(rest.ranking.values(name)), name
        assert rest.ranking.chosen == rest.ranking.planner  # all tie: the paper's posture


# ---------------------------------------------------------------------------------------------- the impact at the grasp
def test_the_reported_impact_is_the_grasp_at_the_planned_pose(ranked: dict[str, CapturePlan]) -> None:
    for rank_by, plan in ranked.items():
        hit, state, target = plan.impact, plan.grasp_state, plan.target
        assert hit is not None and state is not None and target is not None
        # the robot at rest at the approach point of eq. 19, the payload's CM on the path start A
        assert plan.placement.approach_point is not None
        np.testing.assert_allclose(state.r_cm[:2], plan.placement.approach_point, rtol=0.0, atol=1e-12)
        np.testing.assert_allclose(target.position[:2], plan.placement.start, rtol=0.0, atol=1e-12)
        assert state.qdot is None and state.omega is None and state.v_cm is None  # at rest
        np.testing.assert_array_equal(state.q, plan.posture.q)
        # the same state and target built by hand, and ff.capture.impact called directly
        by_hand = _grasp_by_hand(plan, plan.posture.q, plan.posture.attitude, np.append(plan.placement.cm_plus, 0.0))
        joints = "locked" if rank_by == "joint_impulse" else "free"
        direct = ff.capture.impact(ONE, *by_hand, end_effector=0, joints=joints)
        assert hit.joints == joints
        for name in ("impulse", "joint_impulse", "energy_lost", "target_twist"):
            np.testing.assert_allclose(getattr(hit, name), getattr(direct, name), rtol=0.0, atol=1e-12, err_msg=name)
        for name in ("omega", "qdot", "v_cm", "r_cm"):
            np.testing.assert_allclose(getattr(hit.state, name), getattr(direct.state, name), rtol=0.0, atol=1e-12, err_msg=name)
        # after the grasp: the system CM at CM+, the combined model the plan's captured one, momentum conserved
        np.testing.assert_allclose(hit.state.r_cm[:2], plan.placement.cm_plus, rtol=0.0, atol=1e-12)
        assert hit.model.total_mass == pytest.approx(plan.captured.total_mass, rel=1e-15)
        np.testing.assert_allclose(870.0 * hit.state.v_cm, 400.0 * np.array(MOTION["target_velocity"]), rtol=0.0, atol=1e-12)
        assert np.linalg.norm(hit.impulse) > 0.1 and hit.energy_lost > 0.0


def test_every_candidate_impact_is_the_direct_call(ranked: dict[str, CapturePlan]) -> None:
    """The ranking's batched impacts equal a loop of ff.capture.impact on grasps built by hand, to 1e-12."""
    for joints, plan in (("free", ranked["spacecraft_rate"]), ("locked", ranked["joint_impulse"])):
        r = plan.ranking
        assert r is not None
        for k in range(len(r)):
            hit = ff.capture.impact(ONE, *_grasp_by_hand(plan, r.q[k], r.attitude[k], r.cm_plus[k]), end_effector=0, joints=joints)
            expected = {
                "spacecraft_rate": np.linalg.norm(hit.state.omega),
                "impulse": np.linalg.norm(hit.impulse[:3]),
                "angular_impulse": np.linalg.norm(hit.impulse[3:]),
                "joint_impulse": np.linalg.norm(hit.joint_impulse),
                "energy_lost": hit.energy_lost,
            }
            for name, value in expected.items():
                assert r.values(name)[k] == pytest.approx(value, rel=0.0, abs=1e-12), (joints, k, name)
        assert np.all(r.joint_impulse == 0.0) if joints == "free" else np.all(r.joint_impulse > 0.0)


# ---------------------------------------------------------------------------------------------------------- the ranking
@pytest.mark.parametrize("rank_by", ["spacecraft_rate", "impulse", "angular_impulse", "joint_impulse"])
def test_the_ranking_picks_the_smallest_value_among_the_valid_candidates(rank_by: str, ranked: dict[str, CapturePlan]) -> None:
    plan = ranked[rank_by]
    r = plan.ranking
    assert r is not None and r.rank_by == rank_by
    value = r.values()
    assert r.valid[r.chosen] and value[r.chosen] == np.min(value[r.valid])
    assert r.chosen != r.planner and value[r.chosen] < value[r.planner]
    # the plan is the chosen candidate's: posture, attitude, the measure at capture, the motion checked along the path
    np.testing.assert_array_equal(plan.posture.q, r.q[r.chosen])
    np.testing.assert_array_equal(plan.posture.attitude, r.attitude[r.chosen])
    assert plan.posture.measure == pytest.approx(r.measure[r.chosen], rel=1e-12)
    assert plan.posture.family == r.family[r.chosen]
    assert plan.motion is not None and plan.motion.usable and plan.motion.min_measure == r.min_measure[r.chosen]
    np.testing.assert_allclose(plan.motion.end_effector[0, :2], plan.placement.start, atol=1e-9)  # eq. 20: the hand on A
    tip = plan.placement.cm_plus + ff.end_effector_positions(plan.captured, plan.posture.q, attitude=plan.posture.attitude)[0, :2]
    np.testing.assert_allclose(tip, plan.placement.start, atol=1e-9)


def test_the_measure_ranking_is_the_most_dexterous_candidate(ranked: dict[str, CapturePlan]) -> None:
    r = ranked["measure"].ranking
    assert r is not None and np.all(r.valid)  # the path lies in the PIW, no joint limits: every posture passes
    assert r.measure[r.planner] >= np.max(r.measure) * (1.0 - 1e-12)


def test_a_spinning_target_turns_the_spacecraft_less_when_ranked_by_its_rate(ranked: dict[str, CapturePlan]) -> None:
    paper, slow = ranked["measure"], ranked["spacecraft_rate"]
    assert paper.impact is not None and slow.impact is not None
    assert np.max(np.abs(np.degrees(slow.posture.q - paper.posture.q))) > 10.0  # a different posture
    rate_paper, rate_slow = np.linalg.norm(paper.impact.state.omega), np.linalg.norm(slow.impact.state.omega)
    assert rate_slow < 0.1 * rate_paper  # measured: 1.03e-4 rad/s against 1.32e-2 rad/s
    assert slow.posture.measure < paper.posture.measure  # the price: a posture closer to a singularity


def test_the_tradeoff_arrays_have_one_entry_per_candidate(ranked: dict[str, CapturePlan]) -> None:
    r = ranked["spacecraft_rate"].ranking
    assert r is not None
    q1 = np.linspace(-np.pi, np.pi, 72, endpoint=False)  # the eq. 21 families on a 5° grid, and the paper's posture
    fam = capture_families(ranked["spacecraft_rate"].captured, 0, r.R_plus[0], q1)
    count = 1 + int(np.sum(np.isfinite(fam.q2)))
    assert len(r) == count
    for name in ("measure", "min_measure", "valid", "spacecraft_rate", "impulse", "angular_impulse", "joint_impulse", "energy_lost"):
        assert getattr(r, name).shape == (count,), name
    assert r.q.shape == (count, 2) and r.attitude.shape == (count, 4) and r.cm_plus.shape == (count, 3)
    np.testing.assert_array_equal(r.family[1:], np.repeat([0, 1], np.sum(np.isfinite(fam.q2), axis=0)))
    np.testing.assert_allclose(r.q[1:][r.family[1:] == 1, 1], fam.q2[np.isfinite(fam.q2[:, 1]), 1], atol=0.0)


def test_only_candidates_that_pass_the_checks_are_chosen() -> None:
    """Joint limits q1 ±179°, q2 ±150°: some postures turn a joint across a limit along the path; the ranking skips them,
    the slowest spacecraft among them included."""
    limited = dataclasses.replace(ONE, joint_lower=np.radians([-179.0, -150.0]), joint_upper=np.radians([179.0, 150.0]))
    plan = _plan(limited, **MOTION, rank_by="spacecraft_rate")
    r = plan.ranking
    assert r is not None and plan.method == "piw"
    assert 0 < np.sum(~r.valid) < len(r)
    assert plan.motion is not None and plan.motion.within_limits and r.valid[r.chosen]
    assert np.min(r.spacecraft_rate[~r.valid]) < r.spacecraft_rate[r.chosen]  # measured 4.9e-5 against 3.1e-4 rad/s
    assert np.all(np.abs(r.q[:, 1]) <= np.radians(150.0))  # no candidate starts outside the limits
    assert r.spacecraft_rate[r.chosen] == np.min(r.spacecraft_rate[r.valid])


def test_a_path_checked_plan_ranks_its_checked_placements() -> None:
    """q1 limited to 150°: the paper's posture fails along AB; the path-checked candidates (CM+, R+, posture, attitude) are
    ranked, and the plan's placement is the chosen one's."""
    limited = dataclasses.replace(ONE, joint_lower=np.radians([-180.0, -180.0]), joint_upper=np.radians([150.0, 180.0]))
    plan = _plan(limited, **MOTION, rank_by="spacecraft_rate")
    r = plan.ranking
    assert r is not None and plan.method == "path" and r.chosen != r.planner
    assert r.spacecraft_rate[r.chosen] == np.min(r.spacecraft_rate[r.valid])
    np.testing.assert_allclose(plan.placement.cm_plus, r.cm_plus[r.chosen, :2], atol=0.0)
    assert plan.placement.R_plus == r.R_plus[r.chosen] == plan.posture.R_plus
    assert plan.approach_distance == pytest.approx(870.0 / 470.0 * plan.placement.R_plus, rel=1e-14)
    assert plan.motion is not None and plan.motion.usable and np.all(plan.motion.q[:, 0] <= np.radians(150.0) + 1e-12)
    paper = _plan(limited, **MOTION)  # the planner's own choice, by the smallest measure along the path: today's plan
    assert paper.ranking is not None and paper.ranking.chosen == paper.ranking.planner == r.planner
    still = _plan(limited)
    for name in PLAN_FIELDS:
        _same_dataclass(getattr(paper, name), getattr(still, name))
    hit, by_hand = plan.impact, _grasp_by_hand(plan, plan.posture.q, plan.posture.attitude, r.cm_plus[r.chosen])
    assert hit is not None
    np.testing.assert_allclose(hit.impulse, ff.capture.impact(limited, *by_hand).impulse, rtol=0.0, atol=1e-12)


def test_a_spatial_arm_ranks_sampled_postures_and_grasps_a_tumbling_target() -> None:
    """The 7-DOF arm (translational J*, σ_min > 0.02 m/rad): its PIW plan's candidates are the optimum and 32 postures
    sampled on |r_E| = R+; ranked by the spacecraft rate after grasping a tumbling target, the grasp is the one built
    by hand from the 3D end-effector point and the grasping body's attitude."""
    model = ff.models.spacecraft_7dof()
    motion = {"target_velocity": [0.01, 0.02, -0.01], "target_angular_velocity": [0.05, -0.02, 0.1]}
    criterion = SingularityCriterion(rows="position", measure="sigma_min", threshold=0.02)
    path = [[0.0, 0.0, 0.0], [0.0, 0.2, 0.0]]
    plan = plan_capture(model, 0, path, mass=100.0, inertia=5.0, samples=1 << 14, criterion=criterion, rank_by="spacecraft_rate", **motion)
    r = plan.ranking
    assert r is not None and plan.method == "piw" and len(r) == 33 and np.all(r.family == -1)
    assert 0 < np.sum(r.valid) < len(r) and r.valid[r.chosen] and r.chosen != r.planner
    assert r.spacecraft_rate[r.chosen] == np.min(r.spacecraft_rate[r.valid]) < r.spacecraft_rate[r.planner]
    np.testing.assert_allclose(np.linalg.norm(ff.end_effector_positions(plan.captured, r.q)[:, 0], axis=-1), r.R_plus, atol=1e-9)
    assert plan.target is not None and plan.impact is not None and plan.motion is not None and plan.motion.usable
    np.testing.assert_allclose(plan.target.position, plan.placement.start, atol=1e-12)
    by_hand = _grasp_by_hand(plan, plan.posture.q, plan.posture.attitude, plan.placement.cm_plus, mass=100.0, inertia=5.0, **motion)
    direct = ff.capture.impact(model, *by_hand)
    for name in ("impulse", "target_twist"):
        np.testing.assert_allclose(getattr(plan.impact, name), getattr(direct, name), rtol=0.0, atol=1e-12, err_msg=name)
    np.testing.assert_allclose(plan.impact.state.velocity, direct.state.velocity, rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(plan.impact.state.r_cm, plan.placement.cm_plus, atol=1e-12)


# ------------------------------------------------------------------------------------------------- the trade-off figure
@pytest.mark.parametrize(("rank_by", "y"), [("spacecraft_rate", None), ("measure", None), ("impulse", "energy_lost")])
def test_the_tradeoff_figure_draws_the_plans_arrays(rank_by: str, y: str | None, ranked: dict[str, CapturePlan]) -> None:
    plan = ranked[rank_by]
    r = plan.ranking
    assert r is not None
    shown = y or ("spacecraft_rate" if rank_by == "measure" else rank_by)
    ax = Figure().add_subplot()
    artists = plan.plot_tradeoff(ax, y=y)
    lines = {a.get_label(): a for a in artists if isinstance(a, Line2D)}
    value = r.values(shown)
    for k, label in ((0, "family 1 (+acos): pass the checks"), (1, "family 2 (-acos): pass the checks")):
        pick = (r.family == k) & r.valid
        np.testing.assert_array_equal(lines[label].get_xydata(), np.column_stack([r.measure[pick], value[pick]]))
    drawn = sum(len(lines[label].get_xydata()) for label in lines if label.endswith("pass the checks"))
    assert drawn == int(np.sum(r.valid)) == len(r)  # every candidate once (each on a family, all valid)
    np.testing.assert_array_equal(lines["most dexterous (1992 §V)"].get_xydata(), [[r.measure[r.planner], value[r.planner]]])
    np.testing.assert_array_equal(lines[f"chosen (rank by {rank_by})"].get_xydata(), [[r.measure[r.chosen], value[r.chosen]]])
    labels = {"spacecraft_rate": "spacecraft rate after the grasp |ω0⁺| (rad/s)", "energy_lost": "energy lost in the grasp (J)"}
    assert ax.get_ylabel() == labels[shown]
    assert ax.get_xlabel().startswith("singularity measure at capture")


def test_plot_tradeoff_needs_a_moving_target(paper: CapturePlan) -> None:
    with pytest.raises(ValueError, match="no ranking; give plan_capture the target's motion"):
        paper.plot_tradeoff()


# --------------------------------------------------------------------------------------------- bad input, refused first
@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"rank_by": "cheapest"}, ValueError, r"rank_by: unknown criterion 'cheapest'; use one of measure, spacecraft_rate"),
        ({"rank_by": "spacecraft_rate"}, ValueError, r"rank_by: 'spacecraft_rate' ranks the grasp of a moving target, and no motion"),
        ({"joints": "locked"}, ValueError, r"joints: what the joints do at the grasp matters only for a moving target"),
        ({**MOTION, "joints": "welded"}, ValueError, r"joints: unknown joint mode 'welded'; use 'free'"),
        ({**MOTION, "rank_by": "joint_impulse"}, ValueError, r"rank_by: 'joint_impulse' is zero for free joints .*give joints = 'locked'"),
        ({"target_velocity": [0.0, 0.1]}, ShapeError, r"target_velocity: expected shape \(\.\.\., 3\) \(velocity of the target's CM"),
        ({"target_velocity": [[0.0, 0.1, 0.0]]}, ShapeError, r"target_velocity: expected 3 numbers \(one target\), got shape \(1, 3\)"),
        ({"target_angular_velocity": [0.0, np.nan, 0.0]}, ValueError, r"target_angular_velocity: has NaN or infinite entries"),
        ({"target_angular_velocity": [0.0, 0.0, np.inf]}, ValueError, r"target_angular_velocity: has NaN or infinite entries"),
        ({"target_velocity": [1e300, 0.0, 0.0]}, ValueError, r"target_velocity: 1e\+300 is beyond 1e\+08 \(m/s\)"),
        ({"target_velocity": ["fast", 0.0, 0.0]}, ModelError, r"target_velocity: cannot read \['fast', 0\.0, 0\.0\] as real numbers"),
        ({"target_angular_velocity": [True, False, True]}, ModelError, r"target_angular_velocity: cannot read \[True, False, True\] as"),
    ],
)
def test_bad_moving_target_options_are_refused_before_the_work(kwargs: dict, error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        plan_capture(ONE, 0, PATH, mass=400.0, inertia=25.0, samples=1 << 40, **kwargs)  # 2^40 samples: refused before sampling
