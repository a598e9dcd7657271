"""Every Jacobian against central finite differences of plain forward kinematics.

The motion along a generalized velocity zdot0 = [rdot_cm (inertial), omega0
(spacecraft frame), qdot] is integrated here, independently of the library's
Jacobian kernels: q(t) = q + t qdot, T0(t) = T0 exp(t [omega0]x) (omega0 is in
the spacecraft frame, so it multiplies on the right), r_cm(t) = r_cm + t rdot_cm.
Positions come from ``ff.forward_kinematics`` and ``ff.system_cm`` (the
recursive route, checked against a scipy reference in test_kinematics.py).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import freefloat as ff
from freefloat.core.conventions import euler321_from_matrix
from trees import build_random_model, random_trees

SEEDS = st.integers(0, 2**32 - 1)
H = 1e-5  # central-difference step (s); truncation O(H^2) ~ 1e-10, rounding ~ 1e-11


def pose(model: ff.Model, q: np.ndarray, body: int, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A point of a body relative to the system CM and the body orientation, spacecraft frame."""
    rot, pos = ff.forward_kinematics(model, q)
    return pos[body] + rot[body] @ point - ff.system_cm(model, q), rot[body]


def moved(t0: Rotation, r_cm: np.ndarray, q: np.ndarray, zdot0: np.ndarray, t: float) -> tuple[Rotation, np.ndarray, np.ndarray]:
    """Attitude, system CM and joint angles after time t along a constant zdot0."""
    return t0 * Rotation.from_rotvec(t * zdot0[3:6]), r_cm + t * zdot0[0:3], q + t * zdot0[6:]


def fd_point_velocity(model: ff.Model, q: np.ndarray, t0: Rotation, zdot0: np.ndarray, body: int, point: np.ndarray) -> np.ndarray:
    """[velocity of the point; angular velocity of the body], inertial, by central differences."""
    r_cm = np.array([0.3, -0.2, 0.1])
    out = []
    for t in (H, -H):
        att, cm, qq = moved(t0, r_cm, q, zdot0, t)
        p0, r0 = pose(model, qq, body, point)
        out.append((cm + att.apply(p0), att * Rotation.from_matrix(r0)))
    (x_plus, rot_plus), (x_minus, rot_minus) = out
    return np.concatenate([(x_plus - x_minus) / (2 * H), (rot_plus * rot_minus.inv()).as_rotvec() / (2 * H)])


def fd_columns(fn: Callable[[np.ndarray], np.ndarray], n: int) -> np.ndarray:
    """Columns of a Jacobian from a directional-derivative function over the unit vectors of R^n."""
    return np.stack([fn(np.eye(n)[i]) for i in range(n)], axis=-1)


def length_scale(model: ff.Model) -> float:
    return 1.0 + float(np.sum(np.linalg.norm(model.joint_origin, axis=1)) + np.sum(np.linalg.norm(model.com, axis=1)))


# ----------------------------------------------------------------- J+ (1991 eqs. 7-10)
@settings(max_examples=40)
@given(model=random_trees(), seed=SEEDS)
def test_point_jacobian_matches_finite_differences(model: ff.Model, seed: int) -> None:
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, size=model.n_joints)
    t0 = Rotation.random(random_state=rng)
    body = int(rng.integers(model.n_bodies))
    point = rng.normal(size=3)
    n = 6 + model.n_joints
    fd = fd_columns(lambda z: fd_point_velocity(model, q, t0, z, body, point), n)
    tol = 1e-8 * length_scale(model)
    np.testing.assert_allclose(ff.point_jacobian(model, q, body, point, attitude=t0), fd, rtol=0, atol=tol)
    # Without an attitude the Jacobian is the spacecraft-frame ⁰J+, eq. 9: J+ = diag(T0, T0) ⁰J+ on columns 3:.
    j0 = ff.point_jacobian(model, q, body, point)
    fd0 = fd_columns(lambda z: fd_point_velocity(model, q, Rotation.identity(), z, body, point), n)
    np.testing.assert_allclose(j0, fd0, rtol=0, atol=tol)
    np.testing.assert_array_equal(j0[0:3, 0:3], np.eye(3))  # eq. 10a: rdot_cm enters with the unit matrix
    np.testing.assert_array_equal(j0[3:6, 0:6], np.hstack([np.zeros((3, 3)), np.eye(3)]))
    # Default point: the body CM (m = CM).
    np.testing.assert_allclose(ff.point_jacobian(model, q, body), ff.point_jacobian(model, q, body, model.com[body]), rtol=0, atol=1e-14)


@settings(max_examples=25)
@given(model=random_trees(), seed=SEEDS)
def test_end_effector_jacobian_matches_finite_differences(model: ff.Model, seed: int) -> None:
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, size=model.n_joints)
    t0 = Rotation.random(random_state=rng)
    for e, name in enumerate(model.end_effector_names):
        body, point = int(model.end_effector_body[e]), model.end_effector_point[e]
        fd = fd_columns(lambda z, b=body, p=point: fd_point_velocity(model, q, t0, z, b, p), 6 + model.n_joints)
        np.testing.assert_allclose(ff.end_effector_jacobian(model, q, name, attitude=t0), fd, rtol=0, atol=1e-8 * length_scale(model))


# ----------------------------------------------------------------- J_q (1991 eq. 21)
@settings(max_examples=25)
@given(model=random_trees(), seed=SEEDS)
def test_actuation_jacobian_maps_to_spacecraft_velocities_and_is_invertible(model: ff.Model, seed: int) -> None:
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, size=model.n_joints)
    t0 = Rotation.random(random_state=rng)
    n = 6 + model.n_joints

    def spacecraft_velocities(z: np.ndarray) -> np.ndarray:
        v = fd_point_velocity(model, q, t0, z, 0, model.com[0])
        # [spacecraft CM velocity in the spacecraft frame, omega0, qdot]
        return np.concatenate([t0.inv().apply(v[0:3]), t0.inv().apply(v[3:6]), z[6:]])

    j_q = ff.actuation_jacobian(model, q, attitude=t0)
    np.testing.assert_allclose(j_q, fd_columns(spacecraft_velocities, n), rtol=0, atol=1e-8 * length_scale(model))
    # Block upper triangular with unit (rotation) diagonal blocks: det = det(T0^T) = 1, always invertible.
    assert abs(np.linalg.det(j_q) - 1.0) < 1e-9
    np.testing.assert_allclose(np.linalg.inv(j_q) @ j_q, np.eye(n), rtol=0, atol=1e-9 * np.linalg.cond(j_q))
    np.testing.assert_array_equal(j_q[6:, :], np.hstack([np.zeros((n - 6, 6)), np.eye(n - 6)]))
    # Without an attitude the first block is the unit matrix (spacecraft frame = inertial frame).
    np.testing.assert_array_equal(ff.actuation_jacobian(model, q)[0:3, 0:3], np.eye(3))


# ----------------------------------------------------------------- J_z (1991 eqs. 22-23)
def wrap(angle: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * angle))


@settings(max_examples=25)
@given(model=random_trees(max_arms=2, max_joints=5), seed=SEEDS)
def test_task_jacobian_matches_finite_differences_of_euler_angles_and_quaternions(model: ff.Model, seed: int) -> None:
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, size=model.n_joints)
    t0 = Rotation.random(random_state=rng)
    targets = [(int(b), p) for b, p in zip(model.end_effector_body, model.end_effector_point, strict=True)] + [(0, model.com[0])]
    r_cm = np.zeros(3)
    # Euler 3-2-1 rates are undefined at ±90° pitch (1991 eq. 12): stay away from it.
    for body, point in targets:
        pitch = euler321_from_matrix(t0.as_matrix() @ pose(model, q, body, point)[1])[1]
        assume(np.cos(pitch) > 0.05)

    def outputs(z: np.ndarray, t: float, kind: str) -> list[np.ndarray]:
        att, cm, qq = moved(t0, r_cm, q, z, t)
        out = []
        for body, point in targets:
            p0, r0 = pose(model, qq, body, point)
            rot_i = att.as_matrix() @ r0
            out.append(cm + att.apply(p0))
            out.append(euler321_from_matrix(rot_i) if kind == "euler321" else Rotation.from_matrix(rot_i).as_quat())
        return out

    n = 6 + model.n_joints
    for kind in ("euler321", "quaternion"):
        centre = outputs(np.zeros(n), 0.0, kind)

        def rates(z: np.ndarray, kind: str = kind, centre: list[np.ndarray] = centre) -> np.ndarray:
            plus, minus = outputs(z, H, kind), outputs(z, -H, kind)
            rows = []
            for i, (a, b, c) in enumerate(zip(plus, minus, centre, strict=True)):
                if i % 2 == 0:
                    rows.append((a - b) / (2 * H))
                elif kind == "euler321":
                    rows.append(wrap(a - b) / (2 * H))
                else:  # align the signs of q and -q with the quaternion at t = 0
                    rows.append((a * np.sign(a @ c) - b * np.sign(b @ c)) / (2 * H))
            return np.concatenate(rows)

        j_z = ff.task_jacobian(model, q, attitude=t0, orientation=kind)
        assert j_z.shape == (len(targets) * (7 if kind == "quaternion" else 6), n)
        np.testing.assert_allclose(j_z, fd_columns(rates, n), rtol=0, atol=2e-7 * length_scale(model))
    # orientation=None keeps the position rows; spacecraft=False drops the spacecraft rows.
    j_pos = ff.task_jacobian(model, q, attitude=t0, orientation=None, spacecraft=False)
    full = ff.task_jacobian(model, q, attitude=t0, orientation="euler321", spacecraft=False)
    np.testing.assert_allclose(j_pos, np.concatenate([full[6 * e : 6 * e + 3] for e in range(model.n_end_effectors)]), rtol=0, atol=1e-14)


def test_task_jacobian_of_the_1991_example_is_invertible_away_from_sin_q2_zero() -> None:
    """1991 §V: the planar z1 = [x_s, y_s, θ, x_E, y_E] Jacobian is singular only when sin(q2) = 0."""
    model = ff.models.papadopoulos1991()
    rows = [6, 7, 11, 0, 1]  # spacecraft x, y, yaw (θ3 of the 3-2-1 angles); end-effector x, y
    cols = [0, 1, 5, 6, 7]  # rdot_cm x, y; omega0 z; qdot
    for q2, singular in ((np.deg2rad(60.3), False), (0.0, True), (np.pi, True)):
        j = ff.task_jacobian(model, [np.deg2rad(-58.0), q2], attitude=Rotation.from_euler("z", 21.0, degrees=True))
        det = np.linalg.det(j[np.ix_(rows, cols)])
        assert (abs(det) < 1e-12) == singular, det


# ----------------------------------------------------------------- J* (1992 eq. 14)
def free_floating_omega0(model: ff.Model, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
    """omega0 = -D^-1 D_q qdot (1992 eq. 12 with zero angular momentum)."""
    blocks = ff.inertia_blocks(model, q)
    return -np.linalg.solve(blocks.D, blocks.D_q @ qdot)


def fd_free_floating(model: ff.Model, q: np.ndarray, t0: Rotation, qdot: np.ndarray) -> np.ndarray:
    """End-effector [v; w] per end effector (inertial) when the joints move at qdot and the system floats.

    The attitude is stepped with the midpoint rule, T0(±h) = T0 exp(±h omega0(q ± h/2)), so
    the spacecraft turns as momentum conservation dictates along the joint path.
    """
    ees = []
    for t in (H, -H):
        att = t0 * Rotation.from_rotvec(t * free_floating_omega0(model, q + 0.5 * t * qdot, qdot))
        qq = q + t * qdot
        rot, pos = ff.forward_kinematics(model, qq)
        cm = ff.system_cm(model, qq)  # the system CM stays at the inertial origin (zero linear momentum)
        body = model.end_effector_body
        tips = pos[body] + np.einsum("eij,ej->ei", rot[body], model.end_effector_point) - cm
        ees.append((att.apply(tips), [att * Rotation.from_matrix(r) for r in rot[body]]))
    (x_plus, r_plus), (x_minus, r_minus) = ees
    out = []
    for e in range(model.n_end_effectors):
        out.append((x_plus[e] - x_minus[e]) / (2 * H))
        out.append((r_plus[e] * r_minus[e].inv()).as_rotvec() / (2 * H))
    return np.concatenate(out)


@settings(max_examples=20)
@given(model=random_trees(), seed=SEEDS)
def test_generalized_jacobian_matches_free_floating_finite_differences(model: ff.Model, seed: int) -> None:
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, size=model.n_joints)
    t0 = Rotation.random(random_state=rng)
    j_star = ff.generalized_jacobian(model, q)
    assert j_star.shape == (6 * model.n_end_effectors, model.n_joints)
    # V_E = diag(T0, ..., T0) ⁰J* qdot  (1992 eq. 14)
    t_blocks = np.kron(np.eye(2 * model.n_end_effectors), t0.as_matrix())
    for qdot in rng.normal(size=(2, model.n_joints)):
        np.testing.assert_allclose(t_blocks @ j_star @ qdot, fd_free_floating(model, q, t0, qdot), rtol=0, atol=1e-8 * length_scale(model))


@settings(max_examples=25)
@given(model=random_trees(), seed=SEEDS)
def test_generalized_jacobian_equals_its_definition_from_point_jacobians(model: ff.Model, seed: int) -> None:
    """J*_E = J+_E[:, q] + J+_E[:, omega0] (-D^-1 D_q): eliminate omega0 with eq. 12."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, size=(2, model.n_joints))
    blocks = ff.inertia_blocks(model, q)
    x = -np.linalg.solve(blocks.D, blocks.D_q)
    expected = np.concatenate(
        [(j[..., 6:] + j[..., 3:6] @ x) for j in (ff.end_effector_jacobian(model, q, e) for e in range(model.n_end_effectors))], axis=-2
    )
    np.testing.assert_allclose(ff.generalized_jacobian(model, q), expected, rtol=0, atol=1e-10 * length_scale(model))


def test_generalized_jacobian_of_a_square_3d_arm_has_a_determinant() -> None:
    """One 6-joint arm: ⁰J* is 6 x 6 and det ⁰J* (1992 eq. 17) is its determinant."""
    model = build_random_model(np.random.default_rng(11), [6], [None], [None])
    q = np.random.default_rng(12).uniform(-np.pi, np.pi, size=(3, 6))
    assert not model.is_planar
    np.testing.assert_allclose(ff.jacobian_determinant(model, q), np.linalg.det(ff.generalized_jacobian(model, q)), rtol=1e-10)
    np.testing.assert_allclose(ff.manipulability(model, q), np.abs(np.linalg.det(ff.generalized_jacobian(model, q))), rtol=1e-8)


# ----------------------------------------------------------------- drift (nonzero momentum)
@settings(max_examples=15)
@given(model=random_trees(), seed=SEEDS)
def test_generalized_jacobian_drift_matches_motion_with_momentum(model: ff.Model, seed: int) -> None:
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, size=model.n_joints)
    t0 = Rotation.random(random_state=rng)
    h = rng.normal(scale=50.0, size=3)  # inertial angular momentum about the system CM (N m s)
    p = rng.normal(scale=50.0, size=3)  # inertial linear momentum (N s)
    qdot = rng.normal(size=model.n_joints)
    blocks = ff.inertia_blocks(model, q)
    # The motion with these momenta: rdot_cm = p / M, omega0 from T0^T h = D omega0 + D_q qdot.
    omega0 = np.linalg.solve(blocks.D, t0.inv().apply(h) - blocks.D_q @ qdot)
    zdot0 = np.concatenate([p / model.total_mass, omega0, qdot])
    np.testing.assert_allclose(ff.angular_momentum(model, q, zdot0, attitude=t0), h, rtol=1e-10)

    drift = ff.mechanics.generalized_jacobian_drift(model, q, h, p, attitude=t0)
    v_e = np.kron(np.eye(2 * model.n_end_effectors), t0.as_matrix()) @ ff.generalized_jacobian(model, q) @ qdot + drift
    # Velocities are linear in zdot0: difference along the unit direction (the step error grows with speed^3).
    speed = np.linalg.norm(zdot0)
    fd = speed * np.concatenate(
        [
            fd_point_velocity(model, q, t0, zdot0 / speed, int(b), pt)
            for b, pt in zip(model.end_effector_body, model.end_effector_point, strict=True)
        ]
    )
    np.testing.assert_allclose(v_e, fd, rtol=0, atol=1e-8 * length_scale(model) * speed)
    # Without linear momentum the drift loses exactly p / M in the velocity rows.
    no_p = ff.mechanics.generalized_jacobian_drift(model, q, h, attitude=t0).reshape(-1, 6)
    np.testing.assert_allclose(
        drift.reshape(-1, 6) - no_p, np.tile(np.concatenate([p / model.total_mass, np.zeros(3)]), (model.n_end_effectors, 1))
    )
    # Zero momentum, zero drift.
    np.testing.assert_array_equal(ff.mechanics.generalized_jacobian_drift(model, q, np.zeros(3)), np.zeros(6 * model.n_end_effectors))
