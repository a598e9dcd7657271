"""Equations of motion (1991 eqs. 18-21) against themselves, finite differences and mechanics.

- H+ rebuilt column by column from Newton-Euler inverse dynamics (zero
  velocity, unit accelerations) equals ff.system_inertia_matrix;
- C+ equals inverse dynamics at zero acceleration, and the quasi-Lagrangian
  form Hdot y - 1/2 d/dq (y^T H y) + [omega0 x h] with every derivative taken
  by central differences of H+;
- dH+/dt and the point bias acceleration Jdot+ zdot0 against central differences;
- free-floating forward dynamics conserves the inertial linear and angular
  momentum and obeys dT/dt = qdot^T tau; with thrusters and an external wrench
  dT/dt = Q^T zdot0 and the momentum rates equal the applied force and moment;
- Q^T zdot0 equals the power of every force, with point velocities taken by
  central differences of plain forward kinematics (virtual work, eq. 18);
- the spacecraft-fixed mode leaves the spacecraft at rest;
- batch equals loop, each entry on the path its label names; bad inputs give clear errors.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import freefloat as ff
from freefloat.engine import calls as _engine
from freefloat.mechanics._batches import PAIR_BUDGET
from spies import count_calls, count_pieces
from trees import build_random_model, random_trees

SEEDS = st.integers(0, 2**32 - 1)
RTOL = 1e-9
#: Central-difference step. Truncation O(H^2 |f'''|) ~ 1e-10 and rounding ~ 1e-16 |f| / H ~ 1e-11, relative
#: to the scale of the quantity, so finite-difference checks use FD_RTOL = 1e-7 (a 1000x margin) and
#: would still catch any missing term (those are O(1) relative).
H = 1e-5
FD_RTOL = 1e-7


def close(ours: np.ndarray, ref: np.ndarray, rtol: float = RTOL, scale: float | None = None) -> None:
    ours, ref = np.asarray(ours, dtype=float), np.asarray(ref, dtype=float)
    scale = float(np.max(np.abs(ref))) if scale is None else scale
    assert scale > 0.0, "reference is all zeros: the comparison would say nothing"
    np.testing.assert_allclose(ours, ref, rtol=rtol, atol=rtol * scale)


def random_state(model: ff.Model, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, zdot0 and an attitude quaternion."""
    n = model.n_joints
    return rng.uniform(-np.pi, np.pi, n), rng.normal(size=6 + n), Rotation.random(random_state=rng).as_quat()


def random_wrench(model: ff.Model, rng: np.random.Generator, frame: str | None = None) -> ff.ExternalWrench:
    body = int(rng.integers(0, model.n_bodies))
    return ff.ExternalWrench(
        body=body,
        force=rng.normal(scale=10.0, size=3),
        torque=rng.normal(scale=10.0, size=3),
        point=rng.normal(scale=0.5, size=3),
        frame=frame or str(rng.choice(["inertial", "spacecraft", "body"])),
    )


def models() -> list[ff.Model]:
    rng = np.random.default_rng(12)
    return [
        ff.models.papadopoulos1991(),
        ff.models.papadopoulos1992(),
        ff.models.papadopoulos1992(arms=1).with_payload(0, mass=400.0, inertia=25.0),
        build_random_model(rng, [3, 2, 4], [1, None, 2], [None, 0, 1], name="tree"),
    ]


MODELS = models()
IDS = [m.name for m in MODELS]


def central(fn: Callable[[float], np.ndarray]) -> np.ndarray:
    return (fn(H) - fn(-H)) / (2 * H)


def moved(q: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray, attitude: np.ndarray, t: float) -> tuple[np.ndarray, ...]:
    """State after time t on the second-order path with constant zddot0 (accurate to O(t^3)).

    omega0 is in the spacecraft frame, so the attitude turns on the right: T0(t) = T0 exp(t w + t^2/2 wdot)
    (to second order; the commutator term of the exponential is O(t^3) for the velocity at t = 0).
    """
    w, wd = velocity[3:6], acceleration[3:6]
    att = Rotation.from_quat(attitude) * Rotation.from_rotvec(t * w + 0.5 * t * t * wd)
    q_t = q + t * velocity[6:] + 0.5 * t * t * acceleration[6:]
    v_t = velocity + t * acceleration
    return q_t, v_t, att.as_quat()


def momenta(model: ff.Model, q: np.ndarray, velocity: np.ndarray, attitude: np.ndarray) -> np.ndarray:
    """[linear momentum, angular momentum about the CM], inertial frame."""
    return np.concatenate([ff.linear_momentum(model, velocity), ff.angular_momentum(model, q, velocity, attitude=attitude)])


# ----------------------------------------------------------------- H+ and C+ from inverse dynamics
@pytest.mark.parametrize("model", MODELS, ids=IDS)
@pytest.mark.parametrize("method", ["recursive", "barycentric"])
def test_inertia_matrix_from_inverse_dynamics_columns(model: ff.Model, method: str) -> None:
    rng = np.random.default_rng(1)
    q, _, att = random_state(model, rng)
    n = 6 + model.n_joints
    f, t, tau = ff.inverse_dynamics(model, q, np.zeros(n), np.eye(n), att, method=method)  # one column per unit acceleration
    columns = ff.generalized_forces(model, q, tau, f, t, attitude=att)  # (n, n): row j = H+ e_j
    close(columns.T, ff.system_inertia_matrix(model, q))


@pytest.mark.parametrize("model", MODELS, ids=IDS)
def test_nonlinear_forces_are_inverse_dynamics_at_zero_acceleration(model: ff.Model) -> None:
    rng = np.random.default_rng(2)
    for _ in range(3):
        q, v, att = random_state(model, rng)
        for method, other in (("recursive", "barycentric"), ("barycentric", "recursive")):
            f, t, tau = ff.inverse_dynamics(model, q, v, np.zeros_like(v), att, method=method)
            close(ff.generalized_forces(model, q, tau, f, t, attitude=att), ff.nonlinear_forces(model, q, v, method=other))
        close(ff.nonlinear_forces(model, q, v, method="barycentric"), ff.nonlinear_forces(model, q, v, method="recursive"), rtol=1e-10)
        assert np.all(ff.nonlinear_forces(model, q, v)[0:3] == 0.0)  # the CM moves as a particle


@given(random_trees(), SEEDS)
@settings(max_examples=100)
def test_nonlinear_forces_quasi_lagrangian_form_by_finite_differences(model: ff.Model, seed: int) -> None:
    """C+ = Hdot y - 1/2 d/dq (y^T H+ y) + [0; omega0 x h; 0], every derivative by central differences of H+."""
    rng = np.random.default_rng(seed)
    q, v, _ = random_state(model, rng)
    qd = v[6:]
    h_dot = central(lambda t: ff.system_inertia_matrix(model, q + t * qd))
    grad = np.array([central(lambda t, e=e: v @ ff.system_inertia_matrix(model, q + t * e) @ v) for e in np.eye(model.n_joints)])
    ref = h_dot @ v
    ref[6:] -= 0.5 * grad
    ref[3:6] += np.cross(v[3:6], (ff.system_inertia_matrix(model, q) @ v)[3:6])
    scale = float(np.max(np.abs(ff.system_inertia_matrix(model, q)))) * float(np.max(np.abs(v))) ** 2
    close(ff.nonlinear_forces(model, q, v), ref, rtol=FD_RTOL, scale=scale)
    close(ff.mechanics.system_inertia_matrix_rate(model, q, qd), h_dot, rtol=FD_RTOL, scale=scale)


@given(random_trees(), SEEDS)
@settings(max_examples=100)
def test_point_bias_acceleration_by_finite_differences(model: ff.Model, seed: int) -> None:
    """Jdot+ zdot0 = d/dt (J+(q(t), T0(t)) zdot0) at constant zdot0, T0(t) = T0 exp(t [omega0]x)."""
    rng = np.random.default_rng(seed)
    q, v, att = random_state(model, rng)
    body, point = int(rng.integers(0, model.n_bodies)), rng.normal(size=3)

    def jz(t: float) -> np.ndarray:
        a = (Rotation.from_quat(att) * Rotation.from_rotvec(t * v[3:6])).as_quat()
        return ff.point_jacobian(model, q + t * v[6:], body, point, attitude=a) @ v

    ours = ff.mechanics.point_bias_acceleration(model, q, v, body, point, attitude=att)
    close(ours, central(jz), rtol=FD_RTOL, scale=float(np.max(np.abs(ours))))


@given(random_trees(), SEEDS)
@settings(max_examples=60)
def test_engine_rates_and_biases_equal_the_barycentric_forms(model: ff.Model, seed: int) -> None:
    """dH+/dt and Jdot+ zdot0 of the engine (differentiated composite bodies; Newton-Euler's forward pass) against the
    barycentric forms (pair inertias turning with their bodies; the barycentric vectors differentiated)."""
    rng = np.random.default_rng(seed)
    q, v, att = random_state(model, rng)
    fast = ff.mechanics.system_inertia_matrix_rate(model, q, v[6:])
    ref = ff.mechanics.system_inertia_matrix_rate(model, q, v[6:], method="barycentric")
    close(fast, ref, rtol=1e-12, scale=float(np.max(np.abs(ref))))
    for body in range(model.n_bodies):
        point = rng.normal(size=3)
        ours = ff.mechanics.point_bias_acceleration(model, q, v, body, point, attitude=att)
        ref = ff.mechanics.point_bias_acceleration(model, q, v, body, point, attitude=att, method="barycentric")
        close(ours, ref, rtol=1e-12, scale=float(np.max(np.abs(ref))))


def test_engine_rate_of_h_plus_with_prismatic_joints_by_finite_differences() -> None:
    """The engine's dH+/dt holds for sliding joints too (the barycentric form is revolute-only)."""
    model = build_random_model(np.random.default_rng(5), [3, 2], [0, None], [1, None], prismatic=0.5)
    assert model.has_prismatic
    rng = np.random.default_rng(2)
    q, qd = rng.uniform(-0.4, 0.4, (5, model.n_joints)), rng.normal(size=(5, model.n_joints))
    fd = central(lambda t: ff.system_inertia_matrix(model, q + t * qd))
    close(ff.mechanics.system_inertia_matrix_rate(model, q, qd), fd, rtol=FD_RTOL, scale=float(np.max(np.abs(fd))))
    with pytest.raises(ValueError, match="prismatic"):
        ff.mechanics.system_inertia_matrix_rate(model, q, qd, method="barycentric")


# ----------------------------------------------------------------- conservation and energy
def check_free_floating_state(model: ff.Model, q: np.ndarray, v: np.ndarray, att: np.ndarray, tau: np.ndarray, method: str) -> None:
    acc = ff.forward_dynamics(model, q, v, tau, attitude=att, method=method)
    assert np.all(acc[0:3] == 0.0)  # d/dt (M rdot_cm) = 0 exactly
    # d/dt h_I = T0 (omega0 x h + d/dt h), h = D omega0 + D_q qdot, with the analytic dH+/dt
    hp, hp_dot = ff.system_inertia_matrix(model, q), ff.mechanics.system_inertia_matrix_rate(model, q, v[6:])
    h0 = (hp @ v)[3:6]
    h0_dot = (hp @ acc + hp_dot @ v)[3:6]
    scale = float(np.max(np.abs(hp[3:6] @ np.abs(acc)))) + float(np.max(np.abs(hp_dot[3:6] @ np.abs(v))))
    close(np.cross(v[3:6], h0) + h0_dot, np.zeros(3), scale=scale)
    # the same by central differences of the inertial momenta along the motion
    rate = central(lambda t: momenta(model, *moved(q, v, acc, att, t)))
    close(rate, np.zeros(6), rtol=FD_RTOL, scale=float(np.max(np.abs(momenta(model, q, v, att)))) * float(np.max(np.abs(v))))
    # work-energy: dT/dt = qdot^T tau
    t_dot = v @ hp @ acc + 0.5 * v @ hp_dot @ v
    close(t_dot, v[6:] @ tau, scale=float(np.abs(v[6:]) @ np.abs(tau)))
    t_dot_fd = central(lambda t: ff.kinetic_energy(model, *moved(q, v, acc, att, t)[:2]))
    close(t_dot_fd, v[6:] @ tau, rtol=FD_RTOL, scale=float(ff.kinetic_energy(model, q, v)) * float(np.max(np.abs(v))))


@pytest.mark.parametrize("model", MODELS, ids=IDS)
def test_free_floating_conserves_momentum_and_energy_rate_is_joint_power(model: ff.Model) -> None:
    rng = np.random.default_rng(3)
    for _ in range(3):
        q, v, att = random_state(model, rng)
        tau = rng.normal(scale=10.0, size=model.n_joints)
        for method in ("barycentric", "recursive"):
            check_free_floating_state(model, q, v, att, tau, method)


@pytest.mark.parametrize("model", MODELS, ids=IDS)
def test_free_flying_momentum_rates_equal_applied_force_and_moment(model: ff.Model) -> None:
    """With thrusters and an external wrench: dp/dt = total force, dh/dt = total moment about the CM, dT/dt = Q^T zdot0."""
    rng = np.random.default_rng(4)
    q, v, att = random_state(model, rng)
    n = model.n_joints
    tau, f_s, n_s = rng.normal(size=n), rng.normal(scale=20.0, size=3), rng.normal(scale=20.0, size=3)
    w = random_wrench(model, rng, frame="inertial")
    acc = ff.forward_dynamics(model, q, v, tau, f_s, n_s, att, external=[w])
    t0 = Rotation.from_quat(att).as_matrix()
    k = model.body_index(w.body)
    r_s = ff.point_positions(model, q, 0, model.com[0])  # spacecraft CM from the system CM, spacecraft frame
    r_p = ff.point_positions(model, q, k, w.point)
    force = t0 @ f_s + w.force
    moment = t0 @ (n_s + np.cross(r_s, f_s)) + w.torque + np.cross(t0 @ r_p, w.force)
    rate = central(lambda t: momenta(model, *moved(q, v, acc, att, t)))
    close(rate, np.concatenate([force, moment]), rtol=FD_RTOL)
    q_gen = ff.generalized_forces(model, q, tau, f_s, n_s, external=[w], attitude=att)
    t_dot = central(lambda t: ff.kinetic_energy(model, *moved(q, v, acc, att, t)[:2]))
    close(t_dot, q_gen @ v, rtol=FD_RTOL, scale=float(np.abs(q_gen) @ np.abs(v)))


# ----------------------------------------------------------------- generalized forces by virtual work
def fd_point_motion(model: ff.Model, q: np.ndarray, v: np.ndarray, att: np.ndarray, body: int, point: np.ndarray) -> np.ndarray:
    """[velocity of a body point; angular velocity of the body], inertial, from plain forward kinematics."""

    def pose(t: float) -> tuple[np.ndarray, Rotation]:
        q_t = q + t * v[6:]
        a = Rotation.from_quat(att) * Rotation.from_rotvec(t * v[3:6])
        rot, pos = ff.forward_kinematics(model, q_t)
        x0 = pos[body] + rot[body] @ point - ff.system_cm(model, q_t)
        return t * v[0:3] + a.apply(x0), a * Rotation.from_matrix(rot[body])

    (xp, rp), (xm, rm) = pose(H), pose(-H)
    return np.concatenate([(xp - xm) / (2 * H), (rp * rm.inv()).as_rotvec() / (2 * H)])


@given(random_trees(), SEEDS)
@settings(max_examples=100)
def test_generalized_forces_by_virtual_work(model: ff.Model, seed: int) -> None:
    """Q^T zdot0 = power of thrusters, joint torques and external wrenches (1991 eq. 18), any frame."""
    rng = np.random.default_rng(seed)
    q, v, att = random_state(model, rng)
    t0 = Rotation.from_quat(att).as_matrix()
    tau, f_s, n_s = rng.normal(size=model.n_joints), rng.normal(size=3), rng.normal(size=3)
    wrenches = [random_wrench(model, rng, frame) for frame in ("inertial", "spacecraft", "body")]
    s_motion = fd_point_motion(model, q, v, att, 0, model.com[0])
    power = f_s @ (t0.T @ s_motion[0:3]) + n_s @ (t0.T @ s_motion[3:6]) + tau @ v[6:]
    terms = [abs(power)]
    rot = ff.body_rotations(model, q)
    for w in wrenches:
        k = model.body_index(w.body)
        to_inertial = {"inertial": np.eye(3), "spacecraft": t0, "body": t0 @ rot[k]}[w.frame]
        motion = fd_point_motion(model, q, v, att, k, np.asarray(w.point))
        p = (to_inertial @ w.force) @ motion[0:3] + (to_inertial @ w.torque) @ motion[3:6]
        power, terms = power + p, [*terms, abs(p)]
    q_gen = ff.generalized_forces(model, q, tau, f_s, n_s, external=wrenches, attitude=att)
    close(q_gen @ v, power, rtol=FD_RTOL, scale=sum(terms) + float(np.abs(q_gen) @ np.abs(v)))
    # the thruster part is J_q^T [f_S; n_S; tau] (eq. 21) and inverts exactly (eq. 30)
    q_c = ff.generalized_forces(model, q, tau, f_s, n_s, attitude=att)
    close(q_c, ff.actuation_jacobian(model, q, attitude=att).T @ np.concatenate([f_s, n_s, tau]))
    for ours, ref in zip(ff.mechanics.actuation_from_generalized_forces(model, q, q_c, attitude=att), (f_s, n_s, tau), strict=True):
        close(ours, ref)


# ----------------------------------------------------------------- forward/inverse consistency
@given(random_trees(), SEEDS)
@settings(max_examples=100)
def test_forward_inverts_inverse_dynamics(model: ff.Model, seed: int) -> None:
    rng = np.random.default_rng(seed)
    q, v, att = random_state(model, rng)
    acc = rng.normal(size=v.shape)
    w = random_wrench(model, rng)
    f_s, n_s, tau = ff.inverse_dynamics(model, q, v, acc, att, external=w, method="recursive")
    for method in ("barycentric", "recursive"):
        close(ff.forward_dynamics(model, q, v, tau, f_s, n_s, att, external=w, method=method), acc)


# ----------------------------------------------------------------- spacecraft held fixed
@pytest.mark.parametrize("model", MODELS, ids=IDS)
def test_spacecraft_fixed_mode_keeps_the_spacecraft_at_rest(model: ff.Model) -> None:
    rng = np.random.default_rng(5)
    q, v, att = random_state(model, rng)
    qd, tau = v[6:], rng.normal(size=model.n_joints)
    w = random_wrench(model, rng)
    qdd, f_s, n_s = ff.mechanics.spacecraft_fixed_dynamics(model, q, qd, tau, att, external=w)
    # the held state: omega0 = 0, spacecraft CM at rest -> rdot_cm = -T0 J12_S qdot
    z = np.linalg.solve(ff.actuation_jacobian(model, q, attitude=att), np.concatenate([np.zeros(6), qd]))
    acc = ff.forward_dynamics(model, q, z, tau, f_s, n_s, att, external=w)
    close(acc[6:], qdd)
    s_acc = ff.point_jacobian(model, q, 0, attitude=att) @ acc + ff.mechanics.point_bias_acceleration(model, q, z, 0, attitude=att)
    scale = float(np.max(np.abs(ff.point_jacobian(model, q, 0, attitude=att)) @ np.abs(acc)))
    close(s_acc, np.zeros(6), scale=scale)
    # with no joint motion and no torque or external wrench nothing needs holding
    qdd0, f0, n0 = ff.mechanics.spacecraft_fixed_dynamics(model, q, np.zeros_like(qd), np.zeros_like(tau))
    assert np.max(np.abs(np.concatenate([qdd0, f0, n0]))) < 1e-12


# ----------------------------------------------------------------- batches
Inputs = dict[str, np.ndarray]
#: label -> call; a label that names a method says the path the call takes (asserted by the test below).
BATCHED: dict[str, Callable[[ff.Model, Inputs, ff.ExternalWrench], np.ndarray]] = {
    "C+ barycentric": lambda m, x, w: ff.nonlinear_forces(m, x["q"], x["v"], method="barycentric"),
    "C+ recursive": lambda m, x, w: ff.nonlinear_forces(m, x["q"], x["v"], method="recursive"),
    "Hdot": lambda m, x, w: ff.mechanics.system_inertia_matrix_rate(m, x["q"], x["v"][..., 6:]),
    "Q": lambda m, x, w: ff.generalized_forces(m, x["q"], x["tau"], x["f_s"], x["n_s"], external=[w], attitude=x["att"]),
    "forward barycentric": lambda m, x, w: ff.forward_dynamics(
        m, x["q"], x["v"], x["tau"], x["f_s"], x["n_s"], x["att"], external=[w], method="barycentric"
    ),
    "forward recursive": lambda m, x, w: ff.forward_dynamics(
        m, x["q"], x["v"], x["tau"], x["f_s"], x["n_s"], x["att"], external=[w], method="recursive"
    ),
    "inverse barycentric": lambda m, x, w: np.concatenate(
        ff.inverse_dynamics(m, x["q"], x["v"], x["acc"], x["att"], external=[w], method="barycentric"), axis=-1
    ),
    "inverse recursive": lambda m, x, w: np.concatenate(
        ff.inverse_dynamics(m, x["q"], x["v"], x["acc"], x["att"], external=[w], method="recursive"), axis=-1
    ),
    "fixed": lambda m, x, w: np.concatenate(
        ff.mechanics.spacecraft_fixed_dynamics(m, x["q"], x["v"][..., 6:], x["tau"], x["att"], external=[w]), axis=-1
    ),
    "bias": lambda m, x, w: ff.mechanics.point_bias_acceleration(m, x["q"], x["v"], 2, [0.1, 0.0, 0.0], attitude=x["att"]),
}


@pytest.mark.parametrize("model", MODELS[1:], ids=IDS[1:])
def test_batch_equals_loop(model: ff.Model, monkeypatch: pytest.MonkeyPatch) -> None:
    """Each call on a (2, 3) batch equals the loop; "barycentric" entries reach the closed form of C+ and
    not the engine, "recursive" entries the engine and not the closed form (counting spies)."""
    closed_form = count_calls(monkeypatch, ff.mechanics.dynamics._c_plus_barycentric)
    engine = [count_calls(monkeypatch, f) for f in (_engine.residual_rows, _engine.accelerations)]
    rng = np.random.default_rng(6)
    shape = (2, 3)
    n = model.n_joints
    x = {
        "q": rng.uniform(-3, 3, (*shape, n)),
        "v": rng.normal(size=(*shape, 6 + n)),
        "acc": rng.normal(size=(*shape, 6 + n)),
        "att": Rotation.random(6, random_state=rng).as_quat().reshape((*shape, 4)),
        "tau": rng.normal(size=(*shape, n)),
        "f_s": rng.normal(size=(*shape, 3)),
        "n_s": rng.normal(size=(3,)),  # broadcasts
    }
    w = ff.ExternalWrench(body=1, force=rng.normal(size=(*shape, 3)), torque=rng.normal(size=3), point=[0.1, 0.2, 0.3], frame="body")
    batched = {}
    for key, call in BATCHED.items():
        closed_form.clear()
        for calls in engine:
            calls.clear()
        batched[key] = call(model, x, w)
        engine_calls = sum(map(len, engine))
        if "barycentric" in key:
            assert closed_form and not engine_calls, f"{key}: closed form {len(closed_form)}, engine {engine_calls} calls"
        if "recursive" in key:
            assert engine_calls and not closed_form, f"{key}: closed form {len(closed_form)}, engine {engine_calls} calls"
    for idx in np.ndindex(*shape):
        wi = ff.ExternalWrench(body=1, force=w.force[idx], torque=w.torque, point=w.point, frame="body")
        xi = {key: value if key == "n_s" else value[idx] for key, value in x.items()}
        for key, call in BATCHED.items():
            value = call(model, xi, wi)
            assert batched[key][idx].shape == value.shape, key
            np.testing.assert_allclose(batched[key][idx], value, rtol=1e-12, atol=1e-12 * np.max(np.abs(value)), err_msg=key)


def test_unbatched_in_unbatched_out_and_broadcasting() -> None:
    model = ff.models.papadopoulos1992()
    n = model.n_joints
    assert ff.forward_dynamics(model, np.zeros(n), np.zeros(6 + n), np.zeros(n)).shape == (6 + n,)
    assert ff.nonlinear_forces(model, np.zeros(n), np.zeros(6 + n)).shape == (6 + n,)
    f, t, tau = ff.inverse_dynamics(model, np.zeros(n), np.zeros(6 + n), np.zeros(6 + n))
    assert f.shape == (3,) and t.shape == (3,) and tau.shape == (n,)
    # one configuration, many velocities
    out = ff.forward_dynamics(model, np.zeros(n), np.ones((5, 6 + n)), np.zeros(n), method="recursive")
    assert out.shape == (5, 6 + n)
    qdd, f, t = ff.mechanics.spacecraft_fixed_dynamics(model, np.zeros((4, n)), np.zeros(n))
    assert qdd.shape == (4, n) and f.shape == (4, 3) and t.shape == (4, 3)


def test_large_batch_runs_in_pieces(monkeypatch: pytest.MonkeyPatch) -> None:
    """More configurations than one slice of the closed form of C+ (``_batches.pieces``: at most PAIR_BUDGET / B^2
    per kernel call): cut into three slices (counted), still equal to the loop at the slice boundaries."""
    model = MODELS[-1]
    step = PAIR_BUDGET // model.n_bodies**2  # configurations per slice
    size = 2 * step + 7
    rng = np.random.default_rng(8)
    q = rng.uniform(-3, 3, (size, model.n_joints))
    v = rng.normal(size=(size, 6 + model.n_joints))
    slices = count_pieces(monkeypatch)
    out = ff.nonlinear_forces(model, q, v, method="barycentric")
    assert slices == [3], f"pieces cut the batch into {slices} slices, expected [3]"
    for i in (0, step - 1, step, 2 * step - 1, 2 * step, size - 1):
        one = ff.nonlinear_forces(model, q[i], v[i], method="barycentric")
        np.testing.assert_allclose(out[i], one, rtol=1e-12, atol=1e-12 * np.max(np.abs(out[i])))


# ----------------------------------------------------------------- bad input
def test_bad_shapes_name_the_argument_and_the_expected_shape() -> None:
    model = ff.models.papadopoulos1992()
    n = model.n_joints
    q, v = np.zeros(n), np.zeros(6 + n)
    cases = [
        (lambda: ff.forward_dynamics(model, np.zeros(3), v, np.zeros(n)), "q", f"(..., {n})"),
        (lambda: ff.forward_dynamics(model, q, np.zeros(6), np.zeros(n)), "velocity", f"(..., {6 + n})"),
        (lambda: ff.forward_dynamics(model, q, v, np.zeros(n + 1)), "joint_torque", f"(..., {n})"),
        (lambda: ff.forward_dynamics(model, q, v, np.zeros(n), np.zeros(2)), "spacecraft_force", "(..., 3)"),
        (lambda: ff.forward_dynamics(model, q, v, np.zeros(n), None, np.zeros(4)), "spacecraft_torque", "(..., 3)"),
        (lambda: ff.forward_dynamics(model, q, v, np.zeros(n), attitude=np.zeros(3)), "attitude", "(..., 4)"),
        (lambda: ff.inverse_dynamics(model, q, v, np.zeros(5)), "acceleration", f"(..., {6 + n})"),
        (lambda: ff.nonlinear_forces(model, q, np.zeros((2, 5))), "velocity", f"(..., {6 + n})"),
        (lambda: ff.mechanics.system_inertia_matrix_rate(model, q, np.zeros(n + 2)), "qdot", f"(..., {n})"),
        (lambda: ff.mechanics.spacecraft_fixed_dynamics(model, q, np.zeros(1)), "qdot", f"(..., {n})"),
        (lambda: ff.mechanics.actuation_from_generalized_forces(model, q, np.zeros(n)), "generalized_force", f"(..., {6 + n})"),
        (lambda: ff.generalized_forces(model, q, external=[ff.ExternalWrench(1, force=np.zeros(2))]), "external[0].force", "(..., 3)"),
        (lambda: ff.generalized_forces(model, q, external=[ff.ExternalWrench(1, point=np.zeros((2, 3)))]), "external[0].point", "(3,)"),
        (lambda: ff.mechanics.point_bias_acceleration(model, q, v, 1, point=[1.0, 2.0]), "point", "(..., 3)"),
    ]
    for call, name, shape in cases:
        with pytest.raises(ff.ShapeError) as info:
            call()
        assert str(info.value).startswith(f"{name}:") and shape in str(info.value), str(info.value)
    # mismatched batch shapes do not broadcast
    with pytest.raises(ValueError, match=r"broadcast|shape"):
        ff.forward_dynamics(model, np.zeros((2, n)), np.zeros((3, 6 + n)), np.zeros(n))


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_inputs_name_the_argument(bad: float) -> None:
    model = ff.models.papadopoulos1991()
    n = model.n_joints
    q, v, tau = np.zeros(n), np.zeros(6 + n), np.zeros(n)

    def poisoned(size: int) -> np.ndarray:
        x = np.zeros(size)
        x[-1] = bad
        return x

    cases = [
        (lambda: ff.forward_dynamics(model, poisoned(n), v, tau), "q"),
        (lambda: ff.forward_dynamics(model, q, poisoned(6 + n), tau), "velocity"),
        (lambda: ff.forward_dynamics(model, q, v, poisoned(n)), "joint_torque"),
        (lambda: ff.forward_dynamics(model, q, v, tau, poisoned(3)), "spacecraft_force"),
        (lambda: ff.forward_dynamics(model, q, v, tau, None, poisoned(3)), "spacecraft_torque"),
        (lambda: ff.forward_dynamics(model, q, v, tau, attitude=poisoned(4)), "attitude"),
        (lambda: ff.inverse_dynamics(model, q, v, poisoned(6 + n)), "acceleration"),
        (lambda: ff.nonlinear_forces(model, q, poisoned(6 + n), method="recursive"), "velocity"),
        (lambda: ff.mechanics.spacecraft_fixed_dynamics(model, q, poisoned(n)), "qdot"),
        (lambda: ff.generalized_forces(model, q, external=ff.ExternalWrench(0, torque=poisoned(3))), "external[0].torque"),
        (lambda: ff.mechanics.actuation_from_generalized_forces(model, q, poisoned(6 + n)), "generalized_force"),
    ]
    for call, name in cases:
        with pytest.raises(ValueError) as info:
            call()
        assert str(info.value).startswith(f"{name}:"), str(info.value)


def test_other_bad_input() -> None:
    model = ff.models.papadopoulos1991()
    n = model.n_joints
    q, v = np.zeros(n), np.zeros(6 + n)
    with pytest.raises(ValueError, match=r"attitude: quaternion norm .* is not 1"):
        ff.forward_dynamics(model, q, v, np.zeros(n), attitude=[0.0, 0.0, 0.0, 2.0])
    with pytest.raises(ValueError, match=r"attitude: .*not a proper rotation"):
        ff.inverse_dynamics(model, q, v, v, attitude=np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ValueError, match=r"method: expected 'recursive' .*or 'barycentric'"):
        ff.nonlinear_forces(model, q, v, method="lagrange")
    with pytest.raises(ValueError, match=r"external\[0\]\.frame"):
        ff.forward_dynamics(model, q, v, np.zeros(n), external=[ff.ExternalWrench(0, frame="world")])
    with pytest.raises(TypeError, match=r"external\[1\]: expected an ff\.ExternalWrench"):
        ff.generalized_forces(model, q, external=[ff.ExternalWrench(0), (0, [1, 0, 0])])
    with pytest.raises(ff.UnknownNameError, match="link3"):
        ff.generalized_forces(model, q, external=[ff.ExternalWrench("link3")])
    with pytest.raises(TypeError):
        ff.forward_dynamics(model, q, v, np.zeros(n), thrust=np.zeros(3))  # type: ignore[call-arg]
    # a Rotation and a quaternion give the same answer
    rot = Rotation.from_euler("z", 0.3)
    close(
        ff.forward_dynamics(model, q, v, np.ones(n), [1.0, 0, 0], attitude=rot),
        ff.forward_dynamics(model, q, v, np.ones(n), [1.0, 0, 0], attitude=rot.as_quat()),
        rtol=1e-14,
    )
