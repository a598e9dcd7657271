"""Barycentric kinematics (1992 eqs. 4-10, 1991 eqs. 1-3) against plain recursive forward kinematics.

Three routes to the same positions, all relative to the system CM in the
spacecraft frame: the barycentric sums (``method="barycentric"``), the engine's
recursion (the default), and a reference forward kinematics written here from
the model arrays with scipy rotations (no library kernel).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import freefloat as ff
from trees import build_random_model, random_trees

SEEDS = st.integers(0, 2**32 - 1)


def reference_fk(model: ff.Model, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotations ⁰T_k (B, 3, 3) and frame origins (B, 3), spacecraft frame, for one q (N,)."""
    rot = np.zeros((model.n_bodies, 3, 3))
    pos = np.zeros((model.n_bodies, 3))
    rot[0] = np.eye(3)
    for k in range(1, model.n_bodies):
        p = model.parent[k]
        joint = Rotation.from_rotvec(model.joint_axis[k] * q[k - 1]).as_matrix()
        rot[k] = rot[p] @ model.joint_rotation[k] @ joint
        pos[k] = pos[p] + rot[p] @ model.joint_origin[k]
    return rot, pos


def reference_cm_positions(model: ff.Model, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(body CMs relative to the system CM (B, 3), system CM from the spacecraft origin (3,))."""
    rot, pos = reference_fk(model, q)
    cms = pos + np.einsum("kij,kj->ki", rot, model.com)
    cm = model.mass @ cms / model.total_mass
    return cms - cm, cm


def scale_of(model: ff.Model) -> float:
    """A length scale of the model (m), for absolute tolerances."""
    return 1.0 + float(np.sum(np.linalg.norm(model.joint_origin, axis=1)) + np.sum(np.linalg.norm(model.com, axis=1)))


@settings(max_examples=100)
@given(model=random_trees(), seed=SEEDS)
def test_barycentric_positions_equal_recursive_forward_kinematics(model: ff.Model, seed: int) -> None:
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, size=(3, model.n_joints))
    tol = 1e-12 * scale_of(model)

    cm_bary = ff.body_cm_positions(model, q, method="barycentric")
    ee_bary = ff.end_effector_positions(model, q, method="barycentric")
    np.testing.assert_allclose(cm_bary, ff.body_cm_positions(model, q, method="recursive"), rtol=0, atol=tol)
    np.testing.assert_allclose(ee_bary, ff.end_effector_positions(model, q, method="recursive"), rtol=0, atol=tol)

    body = int(rng.integers(model.n_bodies))
    point = rng.normal(size=3)
    pp_bary = ff.point_positions(model, q, body, point)
    for c in range(q.shape[0]):
        rot, pos = reference_fk(model, q[c])
        rho, cm = reference_cm_positions(model, q[c])
        np.testing.assert_allclose(cm_bary[c], rho, rtol=0, atol=tol)
        tips = pos[model.end_effector_body] + np.einsum("eij,ej->ei", rot[model.end_effector_body], model.end_effector_point)
        np.testing.assert_allclose(ee_bary[c], tips - cm, rtol=0, atol=tol)
        np.testing.assert_allclose(pp_bary[c], pos[body] + rot[body] @ point - cm, rtol=0, atol=tol)
        np.testing.assert_allclose(ff.system_cm(model, q[c]), cm, rtol=0, atol=tol)
        np.testing.assert_allclose(ff.body_rotations(model, q[c]), rot, rtol=0, atol=1e-12)
        np.testing.assert_allclose(ff.mechanics.end_effector_rotations(model, q[c]), rot[model.end_effector_body], rtol=0, atol=1e-12)


@settings(max_examples=100)
@given(model=random_trees(), seed=SEEDS)
def test_mass_weighted_cm_offsets_sum_to_zero(model: ff.Model, seed: int) -> None:
    """1992 eq. 3: sum_k m_k rho_k = 0, and its root, sum_k m_k v_ik = 0 for every body i."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, size=(4, model.n_joints))
    rho = ff.body_cm_positions(model, q)
    first_moment = np.einsum("k,cki->ci", model.mass, rho)
    assert np.max(np.abs(first_moment)) <= 1e-12 * model.total_mass * scale_of(model)
    # The barycentric identity that makes eq. 4 work for trees: for each body i,
    # the mass-weighted sum of its vectors v_ik over all bodies k vanishes.
    table = model.bary.point_table  # [k, i] = v_ik
    assert np.max(np.abs(np.einsum("k,kix->ix", model.mass, table))) <= 1e-12 * model.total_mass * scale_of(model)


@settings(max_examples=30)
@given(model=random_trees(), seed=SEEDS)
def test_attitude_rotates_end_effector_positions_into_the_inertial_frame(model: ff.Model, seed: int) -> None:
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, size=(2, model.n_joints))
    att = Rotation.random(2, random_state=rng)
    r0 = ff.end_effector_positions(model, q)
    expected = np.einsum("cij,cej->cei", att.as_matrix(), r0)
    for attitude in (att, att.as_quat(), att.as_matrix()):
        np.testing.assert_allclose(ff.end_effector_positions(model, q, attitude=attitude), expected, rtol=0, atol=1e-12 * scale_of(model))
    # The distance to the system CM is invariant under the attitude (1992 §III, reachable workspace).
    np.testing.assert_allclose(np.linalg.norm(expected, axis=-1), np.linalg.norm(r0, axis=-1), rtol=1e-13)


def test_unknown_method_is_refused() -> None:
    model = ff.models.papadopoulos1991()
    with pytest.raises(ValueError, match="method"):
        ff.body_cm_positions(model, np.zeros(2), method="euler")


def check_payload_shift(model: ff.Model, q: np.ndarray, end_effector: int, mass: float, offset: np.ndarray) -> None:
    """1992 §IV: after capture the system CM moves towards CM_p, on the line to it (eq. 19)."""
    before = {name: np.array(getattr(model, name)) for name in ("mass", "com", "inertia")}
    loaded = model.with_payload(end_effector, mass=mass, inertia=0.1, offset=offset)
    for name, value in before.items():  # a NEW model; the old one is untouched
        np.testing.assert_array_equal(getattr(model, name), value)
    assert loaded.total_mass == pytest.approx(model.total_mass + mass, rel=1e-15)

    k = int(model.end_effector_body[end_effector])
    rot, pos = reference_fk(model, q)
    c_p = pos[k] + rot[k] @ (model.end_effector_point[end_effector] + offset)  # payload CM, spacecraft frame
    _, cm_old = reference_cm_positions(model, q)
    cm_new = ff.system_cm(loaded, q)
    big_m = model.total_mass
    tol = 1e-12 * scale_of(model)
    # On the segment from the old CM to CM_p, at the fraction m_p / (M + m_p).
    np.testing.assert_allclose(cm_new, cm_old + mass / (big_m + mass) * (c_p - cm_old), rtol=0, atol=tol)
    # 1992 eq. 19: R = (M + m_p) / M R_+.
    r_before, r_after = np.linalg.norm(c_p - cm_old), np.linalg.norm(c_p - cm_new)
    assert r_before == pytest.approx((big_m + mass) / big_m * r_after, rel=1e-10, abs=tol)
    # The end-effector point itself does not move with respect to the spacecraft.
    tip_old = ff.end_effector_positions(model, q) + ff.system_cm(model, q)
    tip_new = ff.end_effector_positions(loaded, q) + cm_new
    np.testing.assert_allclose(tip_new, tip_old, rtol=0, atol=tol)
    # And the barycentric route still equals the recursive one on the new model.
    np.testing.assert_allclose(ff.body_cm_positions(loaded, q, method="barycentric"), ff.body_cm_positions(loaded, q), rtol=0, atol=tol)


@settings(max_examples=30)
@given(model=random_trees(), seed=SEEDS)
def test_payload_moves_the_system_cm_towards_the_payload(model: ff.Model, seed: int) -> None:
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, size=model.n_joints)
    e = int(rng.integers(model.n_end_effectors))
    check_payload_shift(model, q, e, float(rng.uniform(1.0, 2000.0)), rng.normal(scale=0.3, size=3))


@pytest.mark.parametrize("arms", [1, 2])
def test_payload_in_the_1992_system(arms: int) -> None:
    model = ff.models.papadopoulos1992(arms=arms)
    q = np.deg2rad(np.array([79.0, 97.97, -30.0, 45.0][: model.n_joints]))
    check_payload_shift(model, q, 0, 400.0, np.zeros(3))


def test_payload_shortens_the_barycentric_vectors_named_in_1992_section_iv() -> None:
    """1992 §IV: grabbing a payload with arm 1 shortens r*_0⁽¹⁾, the r* of arm 1 and the l* of arm 2."""
    model = ff.models.papadopoulos1992()
    loaded = model.with_payload(0, mass=400.0, inertia=25.0)
    arm1 = [model.body_index("arm1_link1"), model.body_index("arm1_link2")]
    arm2 = [model.body_index("arm2_link1"), model.body_index("arm2_link2")]
    before, after = model.bary, loaded.bary
    r0_arm1 = model.body_index("arm1_link1")  # r_star row c: the joint of child c on its parent
    assert np.linalg.norm(after.r_star[r0_arm1]) < np.linalg.norm(before.r_star[r0_arm1])
    assert np.linalg.norm(after.r_star[arm1[1]]) < np.linalg.norm(before.r_star[arm1[1]])  # r* of arm-1 link 1
    for k in arm2:
        assert np.linalg.norm(after.l_star[k]) < np.linalg.norm(before.l_star[k])
    # ... so the reachable radius of arm 1 (sum of the coefficient magnitudes) shrinks and that of arm 2 grows.
    reach = [np.sum(np.abs(ff.planar.position_coefficients(m, e))) for m in (model, loaded) for e in (0, 1)]
    assert reach[2] < reach[0] and reach[3] > reach[1]


def test_random_tree_helper_builds_branches_and_merges_fixed_joints() -> None:
    """The generator behind the property tests makes what it promises (a guard on the tests themselves)."""
    model = build_random_model(np.random.default_rng(7), [3, 2], [1, None], [0, 1])
    assert model.n_joints == model.n_bodies - 1
    assert not any("fixed" in name for name in model.body_names)  # merged into their hosts
    assert model.n_end_effectors == 3  # arm 0 has a branch
