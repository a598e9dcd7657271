"""3D analysis of real arms (issue 11 item 3): the singularity criterion, PIW and capture plans of 6- and 7-DOF arms,
each plan replayed in a free-floating simulation that must meet no singularity of the chosen measure."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation

import freefloat as ff
from freefloat.analysis.capture import CapturePlan, PathDoesNotFitError, free_floating_path_motion, plan_capture
from freefloat.analysis.singularity import SingularityCriterion
from freefloat.analysis.workspace import path_independent_workspace, singularity_measure

DATA = Path(__file__).resolve().parents[1] / "data"
#: The issue's user-style arm: a 500 kg spacecraft with a 6-DOF arm whose wrist link has 0.005 kg m² inertia.
USER_ARM = DATA / "user_arm_6dof.urdf"
POSITION = SingularityCriterion(rows="position", measure="sigma_min", threshold=0.02)
PATH_3D = np.array([[0.0, 0.0, 0.0], [0.0, 0.2, 0.0]])


@pytest.fixture(scope="module")
def user_arm() -> ff.Model:
    model = ff.load(USER_ARM)
    assert model.n_joints == 6 and not model.is_planar and model.total_mass == pytest.approx(519.2)
    assert model.inertia[-1][0, 0] == pytest.approx(0.005)  # the light wrist of the issue
    return model


# ----------------------------------------------------------------------------------------------------------------- the criterion
def test_criterion_rows_and_measures_match_direct_computation(user_arm: ff.Model) -> None:
    q = np.random.default_rng(3).uniform(-2.5, 2.5, (40, 6))
    jac = ff.generalized_jacobian(user_arm, q)
    s_pos = np.linalg.svd(jac[:, 0:3], compute_uv=False)
    s_full = np.linalg.svd(jac, compute_uv=False)
    np.testing.assert_allclose(SingularityCriterion("position", "sigma_min").evaluate(user_arm, q), s_pos[:, -1], rtol=1e-12)
    np.testing.assert_allclose(SingularityCriterion("position", "manipulability").evaluate(user_arm, q), np.prod(s_pos, axis=1), rtol=1e-12)
    np.testing.assert_allclose(SingularityCriterion("full", "sigma_min").evaluate(user_arm, q), s_full[:, -1], rtol=1e-12)
    np.testing.assert_allclose(SingularityCriterion().evaluate(user_arm, q), ff.jacobian_determinant(user_arm, q), rtol=1e-10)
    np.testing.assert_allclose(
        SingularityCriterion(measure="manipulability").evaluate(user_arm, q), np.abs(ff.jacobian_determinant(user_arm, q)), rtol=1e-10
    )
    np.testing.assert_allclose(singularity_measure(user_arm, q, criterion=POSITION), s_pos[:, -1], rtol=1e-12)
    assert SingularityCriterion("position").row_indices(user_arm).tolist() == [0, 1, 2]
    assert SingularityCriterion("position").resolved_measure(user_arm) == "sigma_min"  # 3 x 6: no determinant
    planar = ff.models.papadopoulos1992(arms=1)
    assert SingularityCriterion("full").row_indices(planar).tolist() == [0, 1, 5]
    assert SingularityCriterion("position").row_indices(planar).tolist() == [0, 1]
    assert "0.02" in POSITION.describe(user_arm) and "translational" in POSITION.describe(user_arm)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"rows": "wrist"}, "rows"),
        ({"measure": "volume"}, "measure"),
        ({"threshold": -1.0}, "threshold"),
        ({"threshold": float("nan")}, "threshold"),
    ],
)
def test_criterion_rejects_bad_input(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        SingularityCriterion(**kwargs)


def test_det_needs_a_square_jacobian(user_arm: ff.Model) -> None:
    with pytest.raises(ValueError, match="not square"):
        SingularityCriterion("position", "det").evaluate(user_arm, np.zeros(6))


def test_piw_with_threshold_holds_no_near_singular_configuration() -> None:
    """Every configuration whose end effector lies at a PIW radius has σ_min of the translational J* above the threshold."""
    captured = ff.models.spacecraft_7dof().with_payload(0, mass=100.0, inertia=5.0)
    piw = path_independent_workspace(captured, samples=1 << 14, criterion=POSITION)
    assert piw.piw and piw.R_max - piw.R_min > 0.5  # a wide PIW with the translational rows
    assert "translational" in piw.criterion and "0.02" in piw.criterion
    lo, hi = captured.joint_lower, captured.joint_upper
    q = np.random.default_rng(11).uniform(lo, hi, (100_000, 7))
    r = np.linalg.norm(ff.end_effector_positions(captured, q)[:, 0], axis=-1)
    inside = np.zeros(r.shape, dtype=bool)
    for a, b in piw.piw:
        inside |= (r > a + 1e-3) & (r < b - 1e-3)
    assert inside.sum() > 1000
    assert np.min(POSITION.evaluate(captured, q[inside])) > POSITION.threshold
    # and the near-singular configurations all lie in the PDW
    near = POSITION.is_singular(captured, q)
    assert near.sum() > 100 and not np.any(inside & near)


# ----------------------------------------------------------------------------------------------------------------- replay
def free_floating_replay(plan: CapturePlan, duration: float = 8.0, dt: float = 2e-3) -> ff.Trajectory:
    """Simulate the captured system free-floating (no thrusters) from the plan's capture state, joint torques from
    computed torque on the free-floating dynamics tracking the plan's motion q(s) with a minimum-jerk s(t)."""
    motion = plan.motion
    assert motion is not None
    model = plan.captured
    spline = CubicSpline(motion.s, motion.q, axis=0)
    length = float(motion.s[-1])

    def reference(t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        tau = min(max(t / duration, 0.0), 1.0)
        s = length * (10 * tau**3 - 15 * tau**4 + 6 * tau**5)
        sd = length * (30 * tau**2 - 60 * tau**3 + 30 * tau**4) / duration
        sdd = length * (60 * tau - 180 * tau**2 + 120 * tau**3) / duration**2
        d1, d2 = spline(s, 1), spline(s, 2)
        return spline(s), d1 * sd, d2 * sd**2 + d1 * sdd

    def controller(t: float, state: ff.State) -> np.ndarray:
        q_ref, qd_ref, qdd_ref = reference(t)
        qdd = qdd_ref + 400.0 * (q_ref - state.q) + 40.0 * (qd_ref - state.qdot)
        velocity = np.concatenate([state.v_cm, state.omega, state.qdot])
        h = ff.system_inertia_matrix(model, state.q)
        c = ff.nonlinear_forces(model, state.q, velocity)
        base = -np.linalg.solve(h[:6, :6], h[:6, 6:] @ qdd + c[:6])  # no spacecraft force or torque: free-floating
        return h[6:, :6] @ base + h[6:, 6:] @ qdd + c[6:]

    state0 = ff.State(q=plan.posture.q, attitude=plan.posture.attitude, r_cm=motion.cm)
    traj = ff.simulate(model, state0, duration, controller=controller, fixed_step=dt, output_period=0.02, joint_limits="flag")
    assert not traj.joint_limits_violated, traj.joint_limit_events  # the plan keeps the joints within their limits
    return traj


def check_replay(plan: CapturePlan) -> tuple[float, float]:
    """The replay follows the path, keeps zero momentum and meets no singularity; returns (min measure, max deviation)."""
    traj = free_floating_replay(plan)
    assert traj.status == "finished"
    assert np.max(np.abs(traj.spacecraft_force)) == 0.0 and np.max(np.abs(traj.spacecraft_torque)) == 0.0
    assert np.max(np.linalg.norm(traj.angular_momentum, axis=-1)) < 1e-6
    ee = traj.end_effector_positions[:, 0]
    a, b = plan.placement.path[0], plan.placement.path[-1]
    t = np.clip((ee - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
    deviation = float(np.max(np.linalg.norm(ee - (a + t[:, None] * (b - a)), axis=-1)))
    assert deviation < 2e-3  # m: the payload CM stays on the straight path AB
    np.testing.assert_allclose(ee[0], a, atol=1e-9)
    np.testing.assert_allclose(ee[-1], b, atol=2e-3)
    measure = plan.criterion.evaluate(plan.captured, traj.q)
    assert np.min(np.abs(measure)) > plan.criterion.threshold
    return float(np.min(np.abs(measure))), deviation


# ----------------------------------------------------------------------------------------------------------------- the arms
def test_user_arm_full_jacobian_has_no_piw_for_the_path(user_arm: ff.Model) -> None:
    """What the user met: with the full 6 x 6 J* the wrist is singular at (almost) every radius; the paper's PIW rule fails."""
    with pytest.raises(PathDoesNotFitError, match="fits in no PIW annulus"):
        plan_capture(user_arm, 0, PATH_3D, mass=50.0, inertia=2.0, samples=1 << 14, strategy="piw")


def test_user_arm_6dof_capture_plan_replays_without_singularity(user_arm: ff.Model) -> None:
    plan = plan_capture(user_arm, 0, PATH_3D, mass=50.0, inertia=2.0, samples=1 << 14, criterion=POSITION)
    assert plan.method == "path"  # no PIW annulus fits: the placement was checked along the path
    assert plan.motion is not None and plan.motion.singularity_free and plan.motion.within_limits
    assert plan.motion.min_measure > POSITION.threshold
    posture = plan.posture
    np.testing.assert_allclose(
        plan.placement.cm_plus + ff.end_effector_positions(plan.captured, posture.q, attitude=posture.attitude)[0],
        PATH_3D[0],
        atol=1e-9,
    )
    assert plan.placement.approach_distance == pytest.approx((user_arm.total_mass + 50.0) / user_arm.total_mass * plan.placement.R_plus)
    min_measure, deviation = check_replay(plan)
    print(
        f"6-DOF: R+ = {plan.placement.R_plus:.4f} m, q = {np.round(posture.q, 4)}, replay min σ_min = {min_measure:.4f} m/rad, "
        f"deviation {deviation:.2e} m"
    )


def test_7dof_benchmark_arm_capture_plan_replays_without_singularity() -> None:
    model = ff.models.spacecraft_7dof()
    plan = plan_capture(model, 0, PATH_3D, mass=100.0, inertia=5.0, samples=1 << 14, criterion=POSITION)
    assert plan.method == "piw"  # the path lies in the PIW of the translational J*
    assert plan.piw.R_min is not None and plan.piw.R_min <= plan.placement.R_plus <= plan.piw.R_max
    assert plan.motion is not None and plan.motion.singularity_free and plan.motion.within_limits
    min_measure, deviation = check_replay(plan)
    print(
        f"7-DOF: R+ = {plan.placement.R_plus:.4f} m, PIW {plan.piw.piw}, replay min σ_min = {min_measure:.4f} m/rad, "
        f"deviation {deviation:.2e} m"
    )


def test_path_motion_is_the_zero_momentum_motion() -> None:
    """The planned motion keeps the momentum zero: ω0 from finite differences equals -D⁻¹ D_q q̇ (1992 eq. 12)."""
    model = ff.models.spacecraft_7dof().with_payload(0, mass=100.0, inertia=5.0)
    q0 = np.array([0.3, 1.2, -0.2, -1.3, 0.4, 1.0, 0.2])
    cm = np.zeros(3)
    att = np.array([0.0, 0.0, 0.0, 1.0])
    a = ff.end_effector_positions(model, q0)[0]
    motion = free_floating_path_motion(model, 0, q0, att, cm, np.array([a, a + np.array([0.0, 0.1, 0.05])]), criterion=POSITION)[0]
    assert motion.follows_path and motion.deviation < 1e-8
    k = motion.s.size // 2
    dq = (motion.q[k + 1] - motion.q[k - 1]) / 2.0
    rot = Rotation.from_quat(motion.attitude[k - 1]).inv() * Rotation.from_quat(motion.attitude[k + 1])
    dphi = rot.as_rotvec() / 2.0
    h = ff.system_inertia_matrix(model, motion.q[k])
    np.testing.assert_allclose(h[3:6, 3:6] @ dphi + h[3:6, 6:] @ dq, 0.0, atol=1e-6 * np.linalg.norm(h[3:6, 6:] @ dq))
