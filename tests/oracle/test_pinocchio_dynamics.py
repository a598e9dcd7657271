"""Forward and inverse dynamics against Pinocchio's ABA and RNEA (free-flyer root, zero gravity).

On every paper system (1991, 1992 with two and one arms, each also with the
1992 400 kg payload) and on 200 random 3D trees, at random attitudes,
velocities, joint torques, thruster forces and torques and with an external
wrench on a random body point (given in a random frame), these agree within
``BOUND`` (relative, max |ours - ref| / max |ref|; MARGIN times the measured
agreement):

- forward dynamics zddot0 (both methods: H+ / C+ with Cholesky, and the
  articulated-body recursion) against ``pin.aba``;
- inverse dynamics (f_S, n_S, tau) (both methods) against ``pin.rnea``;
- C+ against ``pin.rnea`` at zero zddot0, and our two C+ routes against each
  other (1e-10);
- the spacecraft-fixed mode: with the returned thruster wrench ``pin.aba``
  gives zero spacecraft acceleration and the same joint accelerations.

Pinocchio's state is (q_pin, nu, nu_dot) with the base twist in the local
frame at the spacecraft frame origin; it is converted to and from zdot0,
zddot0 by ``freefloat.io.oracles`` (pinocchio_acceleration: d/dt of the velocity
map rdot_cm = T0 (v_O + w x c + J_c qdot) with c, J_c and Jdot_c qdot from
Pinocchio's own CM routines). That conversion is itself checked against
Pinocchio's CM acceleration (``pin.centerOfMass`` with nu_dot). Thruster
wrenches at the spacecraft CM become a base wrench at the frame origin,
external wrenches a ``pin.Force`` at the joint frame of their body.

The Pinocchio model above is built by freefloat's own converter
(``freefloat.io.oracles.to_pinocchio``). The independent route: the same
system written to a URDF file, read by freefloat and by Pinocchio's own URDF
parser (free-flyer root), joints matched by name (``PinocchioSystem`` of
tests/oracle/test_pinocchio_core.py, continuous joints as (cos q, sin q)),
zdot0 = T nu with T from Pinocchio's CM Jacobian; then H+ = T^-T M T^-1,
C+ = T^-T rnea(nu, a0) with a0 the Pinocchio acceleration of zddot0 = 0, and
zddot0 = T aba(...) + [CM acceleration at a = 0; 0; 0] (``run_urdf_case``).

A freefloat model wrong by a relative 1e-7 in one link's mass or inertia
fails these bounds (``test_a_1e_7_model_error_fails_the_bound``).
"""

from __future__ import annotations

import tempfile

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import freefloat as ff
from freefloat.io.oracles import (
    acceleration_from_pinocchio,
    pinocchio_acceleration,
    pinocchio_configuration,
    pinocchio_velocity,
    to_pinocchio,
    velocity_from_pinocchio,
)
from oracle.test_pinocchio_core import H_BLOCKS, PinocchioSystem, urdf_round_trip
from oracle_checks import EXCEEDS, MARGIN, Agreement, assert_within, relatively_perturbed
from trees import random_trees

#: Agreement with Pinocchio: the worst relative error max |ours - ref| / max |ref| of any oracle check (pytest -s
#: prints AGREEMENT at teardown), measured 2026-11-26 on the 2-core dev VM (numpy 2.4.6, Pinocchio 4.1.0, derandomized
#: hypothesis): 3.4e-13 over the random trees (forward dynamics of one tree; 1.4e-13 with prismatic joints,
#: 2.3e-14 through the URDF parser), 5.7e-14 over the paper systems (3.6e-14 through the URDF parser), 3.4e-15
#: over the batch.
MEASURED = 3.5e-13
BOUND = MARGIN * MEASURED
MEASURED_PAPER = 5.8e-14
PAPER_BOUND = MARGIN * MEASURED_PAPER
MEASURED_BATCH = 3.4e-15
BATCH_BOUND = MARGIN * MEASURED_BATCH
#: Not oracle agreements: conversions and their round trips, and our two routes of C+ against each other.
ROUND_TRIP = 1e-12
SELF = 1e-10
AGREEMENT = Agreement("worst relative error vs Pinocchio (dynamics)")
SPACECRAFT_AT_REST = "spacecraft_fixed: spacecraft acceleration / joint accelerations"


def check(name: str, ours: np.ndarray, ref: np.ndarray, bound: float = BOUND) -> None:
    """max |ours - ref| / max |ref| within ``bound``."""
    AGREEMENT.check(name, ours, ref, bound)


def teardown_module() -> None:
    AGREEMENT.print(not_oracle=("map:", "C+ barycentric vs recursive"))


def paper_systems() -> list[tuple[str, ff.Model]]:
    base = [
        ("1991", ff.models.papadopoulos1991()),
        ("1992", ff.models.papadopoulos1992()),
        ("1992_one_arm", ff.models.papadopoulos1992(arms=1)),
    ]
    return base + [(f"{name}+payload", m.with_payload(0, mass=400.0, inertia=25.0)) for name, m in base]


class Case:
    """A random state and random inputs for one model, with their Pinocchio counterparts."""

    def __init__(self, model: ff.Model, rng: np.random.Generator, oracle: ff.Model | None = None) -> None:
        """Pinocchio's model is made from ``oracle`` (default ``model``): a different one makes ``model`` wrong on purpose."""
        n = model.n_joints
        self.model, self.pm = model, to_pinocchio(model if oracle is None else oracle)
        assert np.all(self.pm.gravity.vector == 0.0)
        self.data = self.pm.createData()
        self.q = rng.uniform(-np.pi, np.pi, size=n)
        self.velocity = np.concatenate([rng.normal(size=3), rng.normal(size=3), rng.normal(size=n)])
        self.acceleration = np.concatenate([rng.normal(size=3), rng.normal(size=3), rng.normal(size=n)])
        self.attitude = Rotation.random(random_state=rng).as_quat()
        scale = model.total_mass
        self.tau = rng.normal(scale=0.1 * scale, size=n)
        self.force = rng.normal(scale=scale, size=3)
        self.torque = rng.normal(scale=scale, size=3)
        body = int(rng.integers(0, model.n_bodies))
        frame = str(rng.choice(["inertial", "spacecraft", "body"]))
        self.wrench = ff.ExternalWrench(
            body=model.body_names[body],
            force=rng.normal(scale=scale, size=3),
            torque=rng.normal(scale=scale, size=3),
            point=rng.normal(scale=0.5, size=3),
            frame=frame,
        )
        self.q_pin = pinocchio_configuration(model, self.q, self.attitude)
        self.nu = pinocchio_velocity(model, self.pm, self.q, self.velocity, self.attitude)

    def fext(self, wrench: ff.ExternalWrench | None) -> list[pin.Force]:
        """The external wrench as Pinocchio forces at the joint frame (= freefloat body frame) of its body."""
        out = [pin.Force.Zero() for _ in range(self.pm.njoints)]
        if wrench is None:
            return out
        k = self.model.body_index(wrench.body)
        t0 = Rotation.from_quat(self.attitude).as_matrix()
        t_k = ff.body_rotations(self.model, self.q)[k]
        to_body = {"inertial": t_k.T @ t0.T, "spacecraft": t_k.T, "body": np.eye(3)}[wrench.frame]
        f, n = to_body @ wrench.force, to_body @ wrench.torque
        out[k + 1] = pin.Force(f, n + np.cross(wrench.point, f))
        return out

    def base_wrench(self, force: np.ndarray, torque: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """Pinocchio's generalized force: thrusters at the spacecraft CM moved to the frame origin, [f; n; tau]."""
        return np.concatenate([force, torque + np.cross(self.model.com[0], force), tau])


def run_case(model: ff.Model, rng: np.random.Generator, bound: float = BOUND, oracle: ff.Model | None = None) -> None:
    """Every dynamics quantity against Pinocchio (made from ``oracle``, default ``model``) within ``bound``; a model
    with prismatic joints runs the engine only (the barycentric closed forms of C+, 1991 eqs. 18-21, are written
    for revolute joints and refuse it)."""
    c = Case(model, rng, oracle)
    methods = ("recursive",) if model.has_prismatic else ("barycentric", "recursive")
    m, pm, data = c.model, c.pm, c.data
    ext = [c.wrench]

    # the acceleration map against Pinocchio's own CM acceleration, and its round trip
    nu_dot = pinocchio_acceleration(m, pm, c.q, c.velocity, c.acceleration, c.attitude)
    pin.centerOfMass(pm, data, c.q_pin, c.nu, nu_dot)
    check("map: rddot_cm vs pin.centerOfMass", data.acom[0], c.acceleration[0:3], ROUND_TRIP)
    check("map: round trip zddot0", acceleration_from_pinocchio(m, pm, c.q, c.nu, nu_dot, c.attitude), c.acceleration, ROUND_TRIP)
    check("map: round trip zdot0", velocity_from_pinocchio(m, pm, c.q, c.nu, c.attitude), c.velocity, ROUND_TRIP)

    # forward dynamics, free-flying with an external wrench
    nu_dot_ref = pin.aba(pm, data, c.q_pin, c.nu, c.base_wrench(c.force, c.torque, c.tau), c.fext(c.wrench))
    ref = acceleration_from_pinocchio(m, pm, c.q, c.nu, nu_dot_ref, c.attitude)
    for method in methods:
        ours = ff.forward_dynamics(m, c.q, c.velocity, c.tau, c.force, c.torque, c.attitude, external=ext, method=method)
        check(f"forward_dynamics zddot0 ({method})", ours, ref, bound)

    # forward dynamics, free-floating (no thrusters, no external wrench)
    nu_dot_ref = pin.aba(pm, data, c.q_pin, c.nu, c.base_wrench(np.zeros(3), np.zeros(3), c.tau), c.fext(None))
    ref = acceleration_from_pinocchio(m, pm, c.q, c.nu, nu_dot_ref, c.attitude)
    for method in methods:
        check(
            f"forward_dynamics free-floating ({method})",
            ff.forward_dynamics(m, c.q, c.velocity, c.tau, attitude=c.attitude, method=method),
            ref,
            bound,
        )

    # inverse dynamics at a random acceleration, with the external wrench
    tau_pin = pin.rnea(pm, data, c.q_pin, c.nu, nu_dot, c.fext(c.wrench))
    f_ref = tau_pin[0:3]
    n_ref = tau_pin[3:6] - np.cross(m.com[0], f_ref)
    for method in methods:
        f_s, n_s, tau = ff.inverse_dynamics(m, c.q, c.velocity, c.acceleration, c.attitude, external=ext, method=method)
        check(f"inverse_dynamics spacecraft_force ({method})", f_s, f_ref, bound)
        check(f"inverse_dynamics spacecraft_torque ({method})", n_s, n_ref, bound)
        check(f"inverse_dynamics joint_torque ({method})", tau, tau_pin[6:], bound)

    # C+: both routes against each other and against RNEA at zddot0 = 0 mapped by Q = J_q^T [f_S, n_S, tau]
    c_rec = ff.nonlinear_forces(m, c.q, c.velocity, method="recursive")
    if model.has_prismatic:
        with pytest.raises(ff.ModelError, match="prismatic"):
            ff.nonlinear_forces(m, c.q, c.velocity, method="barycentric")
        c_bary = c_rec
    else:
        c_bary = ff.nonlinear_forces(m, c.q, c.velocity, method="barycentric")
        check("C+ barycentric vs recursive", c_bary, c_rec, SELF)
    nu_dot0 = pinocchio_acceleration(m, pm, c.q, c.velocity, np.zeros_like(c.velocity), c.attitude)
    tau0 = pin.rnea(pm, data, c.q_pin, c.nu, nu_dot0)
    c_pin = ff.generalized_forces(m, c.q, tau0[6:], tau0[0:3], tau0[3:6] - np.cross(m.com[0], tau0[0:3]), attitude=c.attitude)
    check("C+ vs pin.rnea", c_bary, c_pin, bound)

    # spacecraft held fixed: the returned wrench keeps the spacecraft at rest in Pinocchio
    qdd, f_s, n_s = ff.mechanics.spacecraft_fixed_dynamics(m, c.q, c.velocity[6:], c.tau, c.attitude, external=ext)
    nu_fixed = np.concatenate([np.zeros(6), c.velocity[6:]])
    nu_dot_fixed = pin.aba(pm, data, c.q_pin, nu_fixed, c.base_wrench(f_s, n_s, c.tau), c.fext(c.wrench))
    rest = float(np.max(np.abs(nu_dot_fixed[0:6]))) / float(np.max(np.abs(nu_dot_fixed[6:])))
    AGREEMENT.record(SPACECRAFT_AT_REST, rest)
    assert_within(SPACECRAFT_AT_REST, rest, bound)
    check("spacecraft_fixed qddot", qdd, nu_dot_fixed[6:], bound)
    # and the fixed-base joint dynamics from Pinocchio's own mass matrix block
    m_pin = pin.crba(pm, data, c.q_pin)
    bias = pin.rnea(pm, data, c.q_pin, nu_fixed, np.zeros(pm.nv), c.fext(c.wrench))
    check("spacecraft_fixed qddot vs crba block", qdd, np.linalg.solve(m_pin[6:, 6:], c.tau - bias[6:]), bound)


@pytest.mark.parametrize(("name", "model"), paper_systems(), ids=[n for n, _ in paper_systems()])
def test_paper_systems_against_pinocchio(name: str, model: ff.Model) -> None:
    rng = np.random.default_rng(sum(map(ord, name)))  # seeded per system
    for _ in range(10):
        run_case(model, rng, PAPER_BOUND)


@given(random_trees(), st.integers(0, 2**32 - 1))
@settings(max_examples=200)
def test_random_trees_against_pinocchio(model: ff.Model, seed: int) -> None:
    run_case(model, np.random.default_rng(seed))


@given(random_trees(prismatic=0.4), st.integers(0, 2**32 - 1))
@settings(max_examples=100)
def test_random_trees_with_prismatic_joints_against_pinocchio(model: ff.Model, seed: int) -> None:
    run_case(model, np.random.default_rng(seed))


@pytest.mark.parametrize("count", [5, 300])  # serial and threaded engine drivers
def test_batched_forward_dynamics_against_pinocchio(count: int) -> None:
    """A batch of states in one call equals Pinocchio state by state."""
    model = ff.models.papadopoulos1992()
    rng = np.random.default_rng(7)
    cases = [Case(model, rng) for _ in range(count)]
    ours = ff.forward_dynamics(
        model,
        np.stack([c.q for c in cases]),
        np.stack([c.velocity for c in cases]),
        np.stack([c.tau for c in cases]),
        np.stack([c.force for c in cases]),
        np.stack([c.torque for c in cases]),
        np.stack([c.attitude for c in cases]),
    )
    for i, c in enumerate(cases):
        if i % 17 and i != count - 1:
            continue  # a sample of the batch, first and last included
        nu_dot = pin.aba(c.pm, c.data, c.q_pin, c.nu, c.base_wrench(c.force, c.torque, c.tau), c.fext(None))
        check("forward_dynamics batched", ours[i], acceleration_from_pinocchio(model, c.pm, c.q, c.nu, nu_dot, c.attitude), BATCH_BOUND)


# ------------------------------------------------------------------ the independent route: Pinocchio's URDF parser
def pinocchio_forward(system: PinocchioSystem, qp: np.ndarray, nu: np.ndarray, u: np.ndarray, fext: list | None = None) -> np.ndarray:
    """Pinocchio's forward dynamics: ABA; with mimic joints (which its ABA refuses, 4.1) M^-1 (u - RNEA(q, nu, 0))
    from its CRBA and RNEA, which model them."""
    pm, data = system.pm, system.data
    if not system.model.has_mimic:
        return pin.aba(pm, data, qp, nu, u) if fext is None else pin.aba(pm, data, qp, nu, u, fext)
    m = system.mass_matrix(qp)
    zero = np.zeros(pm.nv)
    bias = pin.rnea(pm, data, qp, nu, zero) if fext is None else pin.rnea(pm, data, qp, nu, zero, fext)
    return np.linalg.solve(m, u - bias)


def run_urdf_case(model: ff.Model, system: PinocchioSystem, rng: np.random.Generator, bound: float = BOUND) -> None:
    """H+, C+ and forward dynamics against a Pinocchio model of the same URDF file read by Pinocchio's own parser.

    Nothing here goes through ``freefloat.io.oracles``: with zdot0 = T nu (T from Pinocchio's CM Jacobian,
    ``PinocchioSystem.velocity_transform``), zddot0 = T a + b0 with b0 = [Pinocchio's CM acceleration at a = 0;
    0; 0] (omega0 = w_local and qdot are velocity coordinates, their rates are Pinocchio's a). So
    H+ = T^-T M T^-1 and C+ = T^-T rnea(nu, -T^-1 b0), the generalized forces of zddot0 = 0 (power is invariant).
    """
    pm, data = system.pm, system.data
    assert np.all(pm.gravity.vector == 0.0)
    n = model.n_joints
    q = rng.uniform(-np.pi, np.pi, size=n) * np.where(model.prismatic, 0.1, 1.0)
    quat = Rotation.random(random_state=rng).as_quat()
    zdot0 = rng.normal(size=6 + n)
    scale = model.total_mass
    tau, force, torque = rng.normal(scale=0.1 * scale, size=n), rng.normal(scale=scale, size=3), rng.normal(scale=scale, size=3)
    body = int(rng.integers(0, model.n_bodies))
    wrench = ff.ExternalWrench(
        body=body,
        force=rng.normal(scale=scale, size=3),
        torque=rng.normal(scale=scale, size=3),
        point=rng.normal(scale=0.5, size=3),
        frame="body",
    )
    methods = ("recursive",) if model.expanded().has_prismatic else ("barycentric", "recursive")

    qp = system.configuration(q, quat, rng.normal(size=3))
    t = system.velocity_transform(qp)
    t_inv = np.linalg.inv(t)
    nu = t_inv @ zdot0
    pin.centerOfMass(pm, data, qp, nu, np.zeros(pm.nv))
    b0 = np.zeros(6 + n)
    b0[0:3] = data.acom[0]
    m_pin = system.mass_matrix(qp)
    h, h_ref = ff.system_inertia_matrix(model, q), t_inv.T @ m_pin @ t_inv
    check("URDF: H+", h, h_ref, bound)
    for block, index in H_BLOCKS.items():
        check(f"URDF: H+ {block}", h[index], h_ref[index], bound)
    c_ref = t_inv.T @ pin.rnea(pm, data, qp, nu, -t_inv @ b0)
    for method in methods:
        check(f"URDF: C+ ({method})", ff.nonlinear_forces(model, q, zdot0, method=method), c_ref, bound)

    # thrusters at the spacecraft CM: a base wrench at the frame origin; joint torques by name; the external
    # wrench (body frame, at a body point) a pin.Force at the joint frame of its body (= the freefloat body frame)
    u = np.zeros(pm.nv)
    u[0:3], u[3:6] = force, torque + np.cross(model.com[0], force)
    u[system.idx_v] = tau
    fext = [pin.Force.Zero() for _ in range(pm.njoints)]
    fext[system.body_joint[body]] = pin.Force(wrench.force, wrench.torque + np.cross(wrench.point, wrench.force))
    ref = t @ pinocchio_forward(system, qp, nu, u, fext) + b0
    free = t @ pinocchio_forward(system, qp, nu, np.where(np.arange(pm.nv) < 6, 0.0, u)) + b0
    for method in methods:
        ours = ff.forward_dynamics(model, q, zdot0, tau, force, torque, quat, external=[wrench], method=method)
        check(f"URDF: forward_dynamics zddot0 ({method})", ours, ref, bound)
        check(
            f"URDF: forward_dynamics free-floating ({method})",
            ff.forward_dynamics(model, q, zdot0, tau, attitude=quat, method=method),
            free,
            bound,
        )


@pytest.mark.parametrize(("name", "model"), paper_systems(), ids=[n for n, _ in paper_systems()])
def test_paper_systems_against_pinocchio_urdf_parser(name: str, model: ff.Model) -> None:
    with tempfile.TemporaryDirectory() as directory:
        loaded, system = urdf_round_trip(model, directory)
    rng = np.random.default_rng(sum(map(ord, name)))
    for _ in range(4):
        run_urdf_case(loaded, system, rng, PAPER_BOUND)


@given(random_trees(prismatic=0.3), st.integers(0, 2**32 - 1))
@settings(max_examples=40)
def test_random_trees_against_pinocchio_urdf_parser(model: ff.Model, seed: int) -> None:
    with tempfile.TemporaryDirectory() as directory:
        loaded, system = urdf_round_trip(model, directory)
    run_urdf_case(loaded, system, np.random.default_rng(seed))


# ------------------------------------------------------------------ the comparison can fail
@pytest.mark.parametrize(("field", "index"), [("mass", (2,)), ("inertia", (2, 2, 2))])
@pytest.mark.parametrize("route", ["converter", "URDF parser"])
def test_a_1e_7_model_error_fails_the_bound(field: str, index: tuple[int, ...], route: str) -> None:
    """The same comparisons, with freefloat's model wrong by a relative 1e-7 in one link's mass or inertia, exceed
    the bound; Pinocchio keeps the right model (the check passes with the right one)."""
    model = ff.models.papadopoulos1992()  # two arms
    wrong = relatively_perturbed(model, field, index, 1e-7)
    if route == "converter":
        run_case(model, np.random.default_rng(5), PAPER_BOUND)
        with AGREEMENT.not_recorded(), pytest.raises(AssertionError, match=EXCEEDS):
            run_case(wrong, np.random.default_rng(5), PAPER_BOUND, oracle=model)
        return
    with tempfile.TemporaryDirectory() as directory:
        loaded, system = urdf_round_trip(model, directory)
    run_urdf_case(loaded, system, np.random.default_rng(5), PAPER_BOUND)
    with AGREEMENT.not_recorded(), pytest.raises(AssertionError, match=EXCEEDS):
        run_urdf_case(relatively_perturbed(loaded, field, index, 1e-7), system, np.random.default_rng(5), PAPER_BOUND)
