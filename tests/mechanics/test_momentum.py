"""H+ (1991 eqs. 14-17), its blocks D, D_q, D_qq, and the angular momentum (1992 eq. 12).

The references are computed here from finite differences of plain forward
kinematics: body CM velocities and body angular velocities along a generalized
velocity zdot0, then T = sum 1/2 m |c_dot|^2 + 1/2 w^T I w and
h = sum (I w + m rho x rho_dot), with no use of the barycentric kernels.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import freefloat as ff
from freefloat.mechanics.momentum import _pair_inertias
from trees import build_random_model, random_trees

SEEDS = st.integers(0, 2**32 - 1)
H = 1e-5  # central-difference step


def body_states(model: ff.Model, q: np.ndarray, t0: Rotation, r_cm: np.ndarray) -> tuple[np.ndarray, np.ndarray, Rotation]:
    """Inertial body CMs (B, 3), CMs relative to the system CM (B, 3), body orientations (a stack of B)."""
    rot, pos = ff.forward_kinematics(model, q)
    cms = pos + np.einsum("kij,kj->ki", rot, model.com)
    rho0 = cms - model.mass @ cms / model.total_mass
    rho = t0.apply(rho0)
    return r_cm + rho, rho, t0 * Rotation.from_matrix(rot)


def fd_body_velocities(model: ff.Model, q: np.ndarray, t0: Rotation, zdot0: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(CM velocities (B, 3), angular velocities (B, 3), rho (B, 3)), all inertial, by central differences."""
    r_cm = np.array([1.0, -2.0, 0.5])
    states = []
    for t in (H, -H):
        att = t0 * Rotation.from_rotvec(t * zdot0[3:6])  # omega0 in the spacecraft frame
        states.append(body_states(model, q + t * zdot0[6:], att, r_cm + t * zdot0[0:3]))
    (c_plus, _, r_plus), (c_minus, _, r_minus) = states
    c_dot = (c_plus - c_minus) / (2 * H)
    omega = (r_plus * r_minus.inv()).as_rotvec() / (2 * H)
    _, rho, _ = body_states(model, q, t0, r_cm)
    return c_dot, omega, rho


def inertial_inertias(model: ff.Model, q: np.ndarray, t0: Rotation) -> np.ndarray:
    rot = np.einsum("ij,kjl->kil", t0.as_matrix(), ff.body_rotations(model, q))
    return np.einsum("kij,kjl,kml->kim", rot, model.inertia, rot)


def fd_kinetic_energy(model: ff.Model, q: np.ndarray, t0: Rotation, zdot0: np.ndarray) -> float:
    c_dot, omega, _ = fd_body_velocities(model, q, t0, zdot0)
    inertia = inertial_inertias(model, q, t0)
    return float(0.5 * model.mass @ np.sum(c_dot**2, axis=1) + 0.5 * np.einsum("ki,kij,kj->", omega, inertia, omega))


def fd_angular_momentum(model: ff.Model, q: np.ndarray, t0: Rotation, zdot0: np.ndarray) -> np.ndarray:
    """Inertial angular momentum about the system CM, sum (I_k w_k + m_k rho_k x rho_dot_k)."""
    c_dot, omega, rho = fd_body_velocities(model, q, t0, zdot0)
    rho_dot = c_dot - zdot0[0:3]
    inertia = inertial_inertias(model, q, t0)
    return np.einsum("kij,kj->i", inertia, omega) + np.einsum("k,ki->i", model.mass, np.cross(rho, rho_dot))


def inertia_scale(model: ff.Model) -> float:
    size = 1.0 + float(np.sum(np.linalg.norm(model.joint_origin, axis=1)) + np.sum(np.linalg.norm(model.com, axis=1)))
    return model.total_mass * size**2


@settings(max_examples=100)
@given(model=random_trees(), seed=SEEDS)
def test_system_inertia_matrix_is_symmetric_positive_definite(model: ff.Model, seed: int) -> None:
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, size=(3, model.n_joints))
    h = ff.system_inertia_matrix(model, q)
    np.testing.assert_allclose(h, np.swapaxes(h, -1, -2), rtol=0, atol=1e-12 * inertia_scale(model))
    assert np.all(np.linalg.eigvalsh(h) > 0.0)
    np.testing.assert_array_less(0.0, np.linalg.cholesky(h)[..., np.arange(h.shape[-1]), np.arange(h.shape[-1])])


@settings(max_examples=50)
@given(model=random_trees(), seed=SEEDS)
def test_system_inertia_matrix_block_structure(model: ff.Model, seed: int) -> None:
    """1991 eq. 15: H+ = [[M 1, 0, 0], [0, D, D_q], [0, D_q^T, D_qq]]."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, size=(2, model.n_joints))
    h = ff.system_inertia_matrix(model, q)
    blocks = ff.inertia_blocks(model, q)
    n = model.n_joints
    assert h.shape == (2, 6 + n, 6 + n)
    np.testing.assert_array_equal(h[:, 0:3, 0:3], np.broadcast_to(model.total_mass * np.eye(3), (2, 3, 3)))
    np.testing.assert_array_equal(h[:, 0:3, 3:], 0.0)
    np.testing.assert_array_equal(h[:, 3:, 0:3], 0.0)
    np.testing.assert_array_equal(h[:, 3:6, 3:6], blocks.D)
    np.testing.assert_array_equal(h[:, 3:6, 6:], blocks.D_q)
    np.testing.assert_array_equal(h[:, 6:, 3:6], np.swapaxes(blocks.D_q, -1, -2))
    np.testing.assert_array_equal(h[:, 6:, 6:], blocks.D_qq)
    assert blocks.D.shape == (2, 3, 3) and blocks.D_q.shape == (2, 3, n) and blocks.D_qq.shape == (2, n, n)


def fd_inertia_matrix(model: ff.Model, q: np.ndarray, t0: Rotation, columns: np.ndarray) -> np.ndarray:
    """The matrix of the quadratic form T(zdot0) restricted to ``columns`` of zdot0, from finite differences.

    Body velocities are linear in zdot0: c_dot_k = C_k zdot0 and w_k = W_k zdot0, with the columns of C_k, W_k
    the finite-difference velocities along unit vectors. Then T = 1/2 zdot0^T (sum_k m_k C_k^T C_k + W_k^T I_k W_k) zdot0.
    """
    n = 6 + model.n_joints
    vel = [fd_body_velocities(model, q, t0, np.eye(n)[i]) for i in columns]
    c = np.stack([v[0] for v in vel], axis=-1)  # (B, 3, n)
    w = np.stack([v[1] for v in vel], axis=-1)
    inertia = inertial_inertias(model, q, t0)
    return np.einsum("k,kxa,kxb->ab", model.mass, c, c) + np.einsum("kxa,kxy,kyb->ab", w, inertia, w)


@settings(max_examples=30)
@given(model=random_trees(), seed=SEEDS)
def test_system_inertia_matrix_rebuilt_from_kinetic_energy(model: ff.Model, seed: int) -> None:
    """H+ as the quadratic form of T = sum 1/2 m |c_dot|^2 + 1/2 w^T I w (1991 eq. 14), by finite differences."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, size=model.n_joints)
    t0 = Rotation.random(random_state=rng)  # H+ does not depend on the attitude
    n = 6 + model.n_joints
    h = ff.system_inertia_matrix(model, q)
    np.testing.assert_allclose(h, fd_inertia_matrix(model, q, t0, np.arange(n)), rtol=0, atol=1e-8 * np.max(np.abs(h)))
    # And the energy of random velocities, T = 1/2 zdot0^T H+ zdot0, each from its own finite differences.
    for zdot0 in rng.normal(size=(3, n)):
        assert ff.kinetic_energy(model, q, zdot0) == pytest.approx(fd_kinetic_energy(model, q, t0, zdot0), rel=1e-8)


@settings(max_examples=40)
@given(model=random_trees(), seed=SEEDS)
def test_angular_momentum_equals_the_sum_over_bodies(model: ff.Model, seed: int) -> None:
    """1992 eq. 12: h = T0 (D omega0 + D_q qdot) = sum_k (I_k w_k + m_k rho_k x rho_dot_k)."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, size=model.n_joints)
    t0 = Rotation.random(random_state=rng)
    zdot0 = rng.normal(size=6 + model.n_joints)  # rdot_cm does not change h about the CM
    h_fd = fd_angular_momentum(model, q, t0, zdot0)
    tol = 1e-9 * inertia_scale(model) * np.linalg.norm(zdot0)
    np.testing.assert_allclose(ff.angular_momentum(model, q, zdot0, attitude=t0), h_fd, rtol=0, atol=tol)
    np.testing.assert_allclose(ff.angular_momentum(model, q, zdot0), t0.inv().apply(h_fd), rtol=0, atol=tol)
    blocks = ff.inertia_blocks(model, q)
    np.testing.assert_allclose(t0.apply(blocks.D @ zdot0[3:6] + blocks.D_q @ zdot0[6:]), h_fd, rtol=0, atol=tol)
    np.testing.assert_array_equal(ff.linear_momentum(model, zdot0), model.total_mass * zdot0[0:3])


# ----------------------------------------------------------------- 1991 eq. 16b as printed
def printed_and_corrected_dqq(model: ff.Model, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """D_qq from the per-body blocks D_ij (1991 eq. 17), as printed in eq. 16b and as derived.

    Printed: D_qq = sum_j F_j^T D_j F_j with D_j = sum_i D_ij (eq. 16a).
    Derived from T = 1/2 sum_ij w_i^T D_ij w_j with w_i = w_0 + F_i qdot (eq. 5):
    D_qq = sum_ij F_i^T D_ij F_j.
    """
    rot = ff.body_rotations(model, q)
    pair = _pair_inertias(model, rot[None])[0]  # (B, B, 3, 3): D_ij, spacecraft frame
    axes = np.einsum("kij,kj->ki", rot[1:], model.joint_axis[1:])  # ⁰T_l u_l
    f = np.einsum("lk,lx->kxl", model.subtree[1:].astype(float), axes)  # F_k (B, 3, N), eq. 6 for trees
    d_j = pair.sum(axis=0)
    printed = np.einsum("jxa,jxy,jyb->ab", f, d_j, f)
    corrected = np.einsum("ixa,ijxy,jyb->ab", f, pair, f)
    return printed, corrected


def test_dqq_as_printed_in_1991_eq_16b_is_not_symmetric_and_differs_from_the_kinetic_energy() -> None:
    """Documents a misprint: eq. 16b's D_qq = sum_j F_j^T D_j F_j is not the joint block of H+.

    On a 3D chain D_j is not a symmetric 3x3 matrix, so the printed form is not
    even symmetric; the kinetic energy needs sum_ij F_i^T D_ij F_j, which is
    what freefloat uses (and what the finite-difference test above confirms).
    """
    model = build_random_model(np.random.default_rng(5), [4], [None], [None])  # a 3D chain, as in the paper
    q = np.random.default_rng(6).uniform(-np.pi, np.pi, size=model.n_joints)
    printed, corrected = printed_and_corrected_dqq(model, q)
    ours = ff.inertia_blocks(model, q).D_qq
    # The joint block of H+ from the kinetic energy alone (finite differences, no D_ij):
    dqq_fd = fd_inertia_matrix(model, q, Rotation.identity(), 6 + np.arange(model.n_joints))
    scale = np.max(np.abs(ours))
    np.testing.assert_allclose(ours, dqq_fd, rtol=0, atol=1e-8 * scale)
    np.testing.assert_allclose(corrected, ours, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(ours, ours.T, rtol=0, atol=1e-12 * scale)
    assert np.max(np.abs(printed - printed.T)) > 1e-3 * scale  # the printed form is not symmetric
    assert np.max(np.abs(printed - dqq_fd)) > 1e-3 * scale  # and not the kinetic-energy block
    # Eqs. 16a and the D_q of 16b are right as printed: D = sum_j D_j, D_q = sum_j D_j F_j.
    rot = ff.body_rotations(model, q)
    pair = _pair_inertias(model, rot[None])[0]
    axes = np.einsum("kij,kj->ki", rot[1:], model.joint_axis[1:])
    f = np.einsum("lk,lx->kxl", model.subtree[1:].astype(float), axes)
    blocks = ff.inertia_blocks(model, q)
    np.testing.assert_allclose(pair.sum(axis=(0, 1)), blocks.D, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(np.einsum("jxy,jyl->xl", pair.sum(axis=0), f), blocks.D_q, rtol=0, atol=1e-12 * scale)


def test_dqq_as_printed_differs_even_for_the_planar_1991_example() -> None:
    """In the plane the printed form happens to be symmetric, but it is still not the energy's block."""
    model = ff.models.papadopoulos1991()
    q = np.deg2rad([-58.0, 60.3])
    printed, corrected = printed_and_corrected_dqq(model, q)
    ours = ff.inertia_blocks(model, q).D_qq
    np.testing.assert_allclose(corrected, ours, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(printed, printed.T, rtol=1e-12)
    assert np.max(np.abs(printed - ours)) > 1e-2 * np.max(np.abs(ours))


def test_pair_inertias_are_transposes_of_each_other() -> None:
    """D_ji = D_ij^T (1991 eq. 17, the i < j and i > j cases), which makes H+ symmetric."""
    model = build_random_model(np.random.default_rng(8), [3, 2], [1, None], [None, 0])
    rot = ff.body_rotations(model, np.random.default_rng(9).uniform(-np.pi, np.pi, size=model.n_joints))
    pair = _pair_inertias(model, rot[None])[0]
    np.testing.assert_allclose(pair, np.swapaxes(np.swapaxes(pair, 0, 1), -1, -2), rtol=0, atol=1e-12 * np.max(np.abs(pair)))


def test_zero_momentum_rate_is_eq12_and_the_only_solve_of_d() -> None:
    """zero_momentum_rate: the angular momentum of [0, omega0, qdot] is the h0 asked for (1992 eq. 12), in the vector,
    matrix and map forms alike; and no other function of the package solves with the D block of H+."""
    import ast
    from pathlib import Path

    model = ff.models.spacecraft_7dof()
    rng = np.random.default_rng(11)
    q = rng.uniform(-2.0, 2.0, (4, model.n_joints))
    qdot = rng.normal(size=(4, model.n_joints))
    h0 = rng.normal(size=(4, 3)) * 50.0
    h_plus = ff.mechanics.system_inertia_matrix(model, q)
    omega = ff.mechanics.zero_momentum_rate(h_plus, qdot, h0)
    velocity = np.concatenate([np.zeros((4, 3)), omega, qdot], axis=1)
    np.testing.assert_allclose(ff.mechanics.angular_momentum(model, q, velocity), h0, rtol=0, atol=1e-12 * np.abs(h0).max())
    free = ff.mechanics.zero_momentum_rate(h_plus, qdot)
    np.testing.assert_allclose(ff.mechanics.angular_momentum(model, q, np.concatenate([np.zeros((4, 3)), free, qdot], 1)), 0.0, atol=1e-11)
    matrix = ff.mechanics.zero_momentum_rate(h_plus, qdot[..., None])  # K = 1 column
    np.testing.assert_allclose(matrix[..., 0], free, rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(np.einsum("kij,kj->ki", ff.mechanics.zero_momentum_rate(h_plus), qdot), free, rtol=1e-12, atol=1e-14)
    package = Path(ff.__file__).parent
    solvers = []
    for path in sorted(package.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call) and ast.unparse(node.func).endswith("linalg.solve"):
                text = ast.unparse(node.args[0])
                if "3:6, 3:6" in text or text.endswith(".D") or "[:3, :3]" in text or text == "d":  # the D block, however named
                    solvers.append(f"{path.relative_to(package)}: {ast.unparse(node)}")
    assert sorted(solvers) == ["mechanics/momentum.py: np.linalg.solve(d, d_q)", "mechanics/momentum.py: np.linalg.solve(d, rhs)"], solvers
