"""The planar view against an independent planar closed form of the papers' systems.

Everything on the reference side is computed here from the printed masses,
lengths and inertias (1991 Table I, 1992 Table I) with the chain formulas of
1992 eqs. 5-9, written with complex numbers: a point of the system relative
to the system CM is x + i y = sum_i a_i exp(i φ_i) (1992 eq. 18), with φ_0 = θ
and φ = θ + q1 + ... + qk for link k. The free-floating Jacobian follows from
angular momentum conservation about z, with the planar inertia terms
W_ij = I_i δ_ij + sum_k m_k a_ki a_kj cos(φ_i - φ_j).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import freefloat as ff
from trees import random_trees


@dataclass(frozen=True)
class Link:
    inboard: float  # |l|: CM to inboard joint (m)
    outboard: float  # |r|: CM to outboard joint (m)
    mass: float
    inertia: float  # about the CM, normal to the plane


@dataclass(frozen=True)
class PlanarSystem:
    """A spacecraft (CM at the origin of its frame) with planar chains mounted on its x axis."""

    mass0: float
    inertia0: float
    mounts: tuple[float, ...]  # r_0^(m): x of the first joint of arm m (signed)
    arms: tuple[tuple[Link, ...], ...]

    def with_payload(self, arm: int, mass: float, inertia: float) -> PlanarSystem:
        """A payload grasped at its CM by the tip of ``arm`` becomes part of the last link (1992 §IV)."""
        last = self.arms[arm][-1]
        length = last.inboard + last.outboard
        m = last.mass + mass
        d = (last.mass * last.inboard + mass * length) / m  # new CM, from the inboard joint
        merged = Link(d, length - d, m, last.inertia + last.mass * (last.inboard - d) ** 2 + inertia + mass * (length - d) ** 2)
        arms = list(self.arms)
        arms[arm] = (*self.arms[arm][:-1], merged)
        return PlanarSystem(self.mass0, self.inertia0, self.mounts, tuple(arms))


LINKS_1991 = (Link(0.5, 0.5, 4.0, 0.333), Link(0.5, 0.5, 3.0, 0.250))
LINKS_1992 = (Link(0.5, 0.5, 40.0, 3.33), Link(0.5, 0.5, 30.0, 2.5))
SYSTEM_1991 = PlanarSystem(40.0, 6.667, (0.5,), (LINKS_1991,))
SYSTEM_1992 = PlanarSystem(400.0, 66.67, (0.5, -0.5), (LINKS_1992, LINKS_1992))
SYSTEM_1992_ONE_ARM = PlanarSystem(400.0, 66.67, (0.5,), (LINKS_1992,))


class ClosedForm:
    """Barycentric coefficients (1992 eqs. 5-9) and the planar kinematics built on them."""

    def __init__(self, system: PlanarSystem) -> None:
        self.system = system
        links = [link for arm in system.arms for link in arm]
        self.masses = np.array([system.mass0] + [link.mass for link in links])
        self.inertias = np.array([system.inertia0] + [link.inertia for link in links])
        big_m = self.masses.sum()
        # Body order: spacecraft, then each arm's links (the papers' and freefloat's order).
        self.arm_of = [-1] + [m for m, arm in enumerate(system.arms) for _ in arm]
        self.index_in_arm = [0] + [i for arm in system.arms for i in range(1, len(arm) + 1)]
        n_bodies = len(self.masses)
        # μ*_i of link i in its arm (eq. 6), and μ*_{i+1} (zero after the last link).
        mu = np.zeros(n_bodies)
        mu_next = np.zeros(n_bodies)
        k = 1
        for arm in system.arms:
            for i in range(len(arm)):
                mu[k] = sum(link.mass for link in arm[i:]) / big_m
                mu_next[k] = sum(link.mass for link in arm[i + 1 :]) / big_m
                k += 1
        l_vec = np.array([0.0] + [-link.inboard for link in links])  # l: CM -> inboard joint, along the link
        r_vec = np.array([0.0] + [link.outboard for link in links])  # r: CM -> outboard joint
        c = l_vec * (1.0 - mu) + r_vec * mu_next  # eq. 5b
        first_link = [1 + sum(len(a) for a in system.arms[:m]) for m in range(len(system.arms))]
        c[0] = sum(mount * mu[f] for mount, f in zip(system.mounts, first_link, strict=True))  # eq. 5a
        self.c_star = -c  # eqs. 8b, 9
        self.l_star = l_vec - c  # eq. 9
        self.r_star = r_vec - c  # eq. 9
        self.r0_star = np.array(system.mounts) - c[0]  # eq. 8a
        self.r_vec = r_vec
        # F[k, j] = 1 when joint j (moving body j + 1) is between the spacecraft and body k.
        self.path = np.zeros((n_bodies, n_bodies - 1))
        for k in range(1, n_bodies):
            for j in range(k - self.index_in_arm[k] + 1, k + 1):
                self.path[k, j - 1] = 1.0

    def coefficients(self, body: int, tip: bool = False) -> np.ndarray:
        """a_i of the CM of ``body`` (eq. 4b), or of the tip of its arm's last link (eq. 10)."""
        a = np.empty(len(self.masses))
        arm = self.arm_of[body]
        a[0] = self.c_star[0] if body == 0 else self.r0_star[arm]
        for i in range(1, len(a)):
            if self.arm_of[i] == arm and i < body:
                a[i] = self.r_star[i]
            elif i == body:
                a[i] = self.c_star[i] + (self.r_vec[i] if tip else 0.0)
            else:
                a[i] = self.l_star[i]
        return a

    def end_effector_coefficients(self, arm: int) -> np.ndarray:
        last = sum(len(a) for a in self.system.arms[: arm + 1])
        return self.coefficients(last, tip=True)

    def phi(self, theta: float, q: np.ndarray) -> np.ndarray:
        """Absolute angle of every body: θ for the spacecraft, θ + q1 + ... + qk for link k."""
        return theta + self.path @ q

    def planar_inertia(self, phi: np.ndarray) -> np.ndarray:
        """W_ij = I_i δ_ij + sum_k m_k a_ki a_kj cos(φ_i - φ_j): T = 1/2 φ_dot^T W φ_dot (CM at rest)."""
        a = np.array([self.coefficients(k) for k in range(len(self.masses))])  # a[k, i]
        cos = np.cos(phi[:, None] - phi[None, :])
        return np.diag(self.inertias) + np.einsum("k,ki,kj->ij", self.masses, a, a) * cos

    def generalized_jacobian(self, q: np.ndarray) -> np.ndarray:
        """Planar ⁰J* (θ = 0): rows [v_x, v_y, ω_z] per end effector, columns qdot.

        Zero angular momentum about z: 1^T W (1 θ_dot + F qdot) = 0, so
        θ_dot = -(1^T W F / 1^T W 1) qdot; then φ_dot = 1 θ_dot + F qdot and
        d/dt (sum a_i e^{iφ_i}) = sum a_i i e^{iφ_i} φ_dot_i.
        """
        phi = self.phi(0.0, q)
        w = self.planar_inertia(phi)
        ones = np.ones(len(phi))
        theta_dot = -(ones @ w @ self.path) / (ones @ w @ ones)  # (N,)
        phi_dot = ones[:, None] * theta_dot[None, :] + self.path  # (B, N)
        rows = []
        for arm in range(len(self.system.arms)):
            a = self.end_effector_coefficients(arm)
            v = (a * 1j * np.exp(1j * phi)) @ phi_dot
            last = sum(len(x) for x in self.system.arms[: arm + 1])
            rows += [v.real, v.imag, phi_dot[last]]
        return np.array(rows)

    def system_inertia_matrix(self, q: np.ndarray) -> np.ndarray:
        """Planar H+ over (x_cm, y_cm, θ, q): blockdiag(M 1, G^T W G) with G = [1 | F]."""
        w = self.planar_inertia(self.phi(0.0, q))
        g = np.hstack([np.ones((len(self.masses), 1)), self.path])
        n = g.shape[1]
        out = np.zeros((2 + n, 2 + n))
        out[0:2, 0:2] = self.masses.sum() * np.eye(2)
        out[2:, 2:] = g.T @ w @ g
        return out


CASES = {
    "1991": (ff.models.papadopoulos1991, SYSTEM_1991),
    "1992": (ff.models.papadopoulos1992, SYSTEM_1992),
    "1992-one-arm": (lambda: ff.models.papadopoulos1992(arms=1), SYSTEM_1992_ONE_ARM),
    "1992+payload": (
        lambda: ff.models.papadopoulos1992().with_payload(0, mass=400.0, inertia=25.0),
        SYSTEM_1992.with_payload(0, 400.0, 25.0),
    ),
    "1992-one-arm+payload": (
        lambda: ff.models.papadopoulos1992(arms=1).with_payload(0, mass=400.0, inertia=25.0),
        SYSTEM_1992_ONE_ARM.with_payload(0, 400.0, 25.0),
    ),
    "1992+payload-arm2": (
        lambda: ff.models.papadopoulos1992().with_payload(1, mass=150.0, inertia=8.0),
        SYSTEM_1992.with_payload(1, 150.0, 8.0),
    ),
}


@pytest.fixture(params=list(CASES), name="case")
def fixture_case(request: pytest.FixtureRequest) -> tuple[ff.Model, ClosedForm]:
    build, system = CASES[request.param]
    return build(), ClosedForm(system)


def configurations(model: ff.Model, count: int = 6) -> np.ndarray:
    rng = np.random.default_rng(model.n_joints * 1000 + count)
    return np.concatenate(
        [np.deg2rad([[79.0, 97.97, -30.0, 120.0][: model.n_joints]]), rng.uniform(-np.pi, np.pi, size=(count, model.n_joints))]
    )


def test_paper_models_are_planar_and_coefficients_are_real(case: tuple[ff.Model, ClosedForm]) -> None:
    model, ref = case
    assert model.is_planar
    for e in range(model.n_end_effectors):
        coeffs = ff.planar.position_coefficients(model, e)
        np.testing.assert_array_equal(coeffs.imag, 0.0)
        np.testing.assert_allclose(coeffs.real, ref.end_effector_coefficients(e), rtol=0, atol=1e-12)


def test_end_effector_positions_equal_eq_18(case: tuple[ff.Model, ClosedForm]) -> None:
    """x_E + i y_E = sum_i a_i exp(i φ_i) (1992 eq. 18), in the spacecraft frame and with a yaw θ."""
    model, ref = case
    for q in configurations(model):
        planar = ff.planar.end_effector_positions(model, q)
        for theta in (0.0, 0.7, -2.5):
            phi = ref.phi(theta, q)
            attitude = Rotation.from_euler("z", theta)
            full = ff.end_effector_positions(model, q, attitude=attitude)
            for e in range(model.n_end_effectors):
                z = np.sum(ref.end_effector_coefficients(e) * np.exp(1j * phi))
                np.testing.assert_allclose(full[e], [z.real, z.imag, 0.0], rtol=0, atol=1e-12)
                if theta == 0.0:
                    np.testing.assert_allclose(planar[e], [z.real, z.imag], rtol=0, atol=1e-12)
        # Body CMs too (eq. 4): the coefficients of every body's CM.
        cms = ff.body_cm_positions(model, q)
        for k in range(model.n_bodies):
            z = np.sum(ref.coefficients(k) * np.exp(1j * ref.phi(0.0, q)))
            np.testing.assert_allclose(cms[k], [z.real, z.imag, 0.0], rtol=0, atol=1e-12)


def test_generalized_jacobian_equals_the_planar_closed_form(case: tuple[ff.Model, ClosedForm]) -> None:
    model, ref = case
    for q in configurations(model):
        expected = ref.generalized_jacobian(q)
        np.testing.assert_allclose(ff.planar.generalized_jacobian(model, q, angular=True), expected, rtol=0, atol=1e-12)
        keep = [r for r in range(expected.shape[0]) if r % 3 != 2]
        np.testing.assert_allclose(ff.planar.generalized_jacobian(model, q), expected[keep], rtol=0, atol=1e-12)


def test_planar_system_inertia_matrix_equals_the_closed_form(case: tuple[ff.Model, ClosedForm]) -> None:
    model, ref = case
    for q in configurations(model):
        expected = ref.system_inertia_matrix(q)
        np.testing.assert_allclose(ff.planar.system_inertia_matrix(model, q), expected, rtol=1e-12, atol=1e-12 * np.max(np.abs(expected)))


def test_planar_view_is_rows_and_columns_of_3d(case: tuple[ff.Model, ClosedForm]) -> None:
    """Planar = (x, y, θ, q): rows/columns 0, 1, 5, 6.. of the 3D results; the other rows vanish."""
    model, _ = case
    q = configurations(model)
    idx = ff.planar.velocity_indices(model)
    np.testing.assert_array_equal(idx, np.concatenate([[0, 1, 5], 6 + np.arange(model.n_joints)]))
    h = ff.system_inertia_matrix(model, q)
    np.testing.assert_array_equal(ff.planar.system_inertia_matrix(model, q), h[..., idx[:, None], idx[None, :]])
    j = ff.generalized_jacobian(model, q)
    np.testing.assert_array_equal(
        ff.planar.generalized_jacobian(model, q, angular=True),
        j[..., [6 * e + r for e in range(model.n_end_effectors) for r in (0, 1, 5)], :],
    )
    np.testing.assert_array_equal(ff.planar.end_effector_positions(model, q), ff.end_effector_positions(model, q)[..., :2])
    # Out of the plane nothing moves: v_z, ω_x, ω_y rows of J* are zero, z of every point is constant.
    out_of_plane = [6 * e + r for e in range(model.n_end_effectors) for r in (2, 3, 4)]
    np.testing.assert_allclose(j[..., out_of_plane, :], 0.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(ff.end_effector_positions(model, q)[..., 2], 0.0, rtol=0, atol=1e-12)
    # ... and H+ does not couple the plane to the rest (θx, θy, z rows are decoupled from (x, y, θz, q)).
    rest = [2, 3, 4]
    np.testing.assert_allclose(h[..., rest, :][..., :, idx], 0.0, rtol=0, atol=1e-9)


def test_jacobian_determinant_uses_the_planar_rows(case: tuple[ff.Model, ClosedForm]) -> None:
    """1992 eq. 17 for a planar model: det of the 2E x N matrix of [v_x, v_y] rows."""
    model, ref = case
    q = configurations(model)
    expected = np.array(
        [np.linalg.det(ref.generalized_jacobian(qq)[[r for r in range(3 * model.n_end_effectors) if r % 3 != 2]]) for qq in q]
    )
    np.testing.assert_allclose(ff.jacobian_determinant(model, q), expected, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(
        ff.jacobian_determinant(model, q), np.linalg.det(ff.planar.generalized_jacobian(model, q)), rtol=1e-12, atol=1e-14
    )


def test_a_planar_model_has_square_planar_jacobians() -> None:
    for model in (ff.models.papadopoulos1991(), ff.models.papadopoulos1992(), ff.models.papadopoulos1992(arms=1)):
        assert ff.planar.generalized_jacobian(model, np.zeros(model.n_joints)).shape == (2 * model.n_end_effectors, model.n_joints)


@settings(max_examples=30)
@given(model=random_trees())
def test_random_3d_trees_are_not_planar(model: ff.Model) -> None:
    assert not model.is_planar
    with pytest.raises(ff.ModelError, match="not planar"):
        ff.planar.generalized_jacobian(model, np.zeros(model.n_joints))


def test_planar_functions_refuse_a_3d_model() -> None:
    model = ff.models.papadopoulos1992()
    b = ff.ModelBuilder("tilted")
    b.add_body("bus", mass=100.0, inertia=10.0)
    b.add_body("link", mass=5.0, inertia=[0.01, 0.4, 0.4], com=[0.5, 0, 0], end_effector=[1, 0, 0])
    b.add_joint("q1", parent="bus", child="link", origin=[0.5, 0, 0], axis=[0, 1, 1])
    tilted = b.build()
    assert model.is_planar and not tilted.is_planar
    for fn in (ff.planar.end_effector_positions, ff.planar.generalized_jacobian, ff.planar.system_inertia_matrix):
        with pytest.raises(ff.ModelError, match="not planar"):
            fn(tilted, np.zeros(1))
    with pytest.raises(ff.ModelError, match="not planar"):
        ff.planar.position_coefficients(tilted)


@given(theta=st.floats(-np.pi, np.pi), seed=st.integers(0, 2**32 - 1))
@settings(max_examples=20)
def test_reach_is_independent_of_the_spacecraft_yaw(theta: float, seed: int) -> None:
    """|r_E| does not depend on θ (1992 §III), so R_max = sum |a_i| is reached with all φ_i aligned."""
    model = ff.models.papadopoulos1992()
    ref = ClosedForm(SYSTEM_1992)
    q = np.random.default_rng(seed).uniform(-np.pi, np.pi, size=4)
    a = ref.end_effector_coefficients(0)
    z = np.sum(a * np.exp(1j * ref.phi(theta, q)))
    assert abs(z) == pytest.approx(np.linalg.norm(ff.end_effector_positions(model, q)[0]), rel=1e-12)
    assert abs(z) <= np.sum(np.abs(a)) + 1e-12
