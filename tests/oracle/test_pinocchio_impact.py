"""The grasp of a moving target (``ff.capture.impact``) against Pinocchio, an independent engine.

Pinocchio's side never goes through freefloat's impact code, its combined model or its Jacobians: the robot
is converted (``freefloat.io.oracles.to_pinocchio``), the target is appended to the grasping joint by
Pinocchio itself (``appendBodyToJoint``, at the placement Pinocchio's forward kinematics gives for the
target's pose), and in Pinocchio's coordinates ν = [v_base, w_base (local), qdot], which the robot and the
combined system share, the grasp is the generalized momentum balance

    M_c(q) ν⁺ = M_r(q) ν⁻ + J_tᵀ h_t⁻ (+ [0; joint_impulse] for locked joints)

with M_r, M_c the CRBA of the robot and of the combined system, J_t the frame Jacobian of the target's CM
frame on the grasping joint (LOCAL_WORLD_ALIGNED) and h_t⁻ = [m v_t; R I Rᵀ w_t] the target's momentum.
Free joints: ν⁺ solves it; locked joints: qdot⁺ = qdot⁻ and the six base rows give the base velocity, the
joint rows the joint impulse. Compared with freefloat's post-impact state (converted to ν with Pinocchio's CM
Jacobian of the combined system), its impulse on the target and its joint impulse, on random 3D trees with
revolute and prismatic joints and random targets, both joint modes.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import freefloat as ff
from freefloat.io.oracles import pinocchio_configuration, pinocchio_velocity, to_pinocchio
from impacts import random_state, random_target
from oracle_checks import EXCEEDS, MARGIN, Agreement
from trees import random_trees

#: The worst relative error max |ours - ref| / max |ref| of any quantity below, measured 2026-11-26 on the 2-core
#: dev VM (numpy 2.4.6, Pinocchio 4.1.0, derandomized hypothesis; pytest -s prints AGREEMENT): 1.7e-13 (the impulse on
#: the target, a difference of momenta), 5.6e-14 (the post-impact velocity), 7.1e-14 (the locked joints' impulse);
#: run once with 600 examples: 3.9e-13 (post-impact velocity, free joints), 2.6e-13 (joint impulse).
MEASURED = 1.7e-13
BOUND = MARGIN * MEASURED  # 1.7e-11, within the 1e-10
AGREEMENT = Agreement("ff.capture.impact: worst relative error vs Pinocchio")


def teardown_module() -> None:
    AGREEMENT.print()


def crba(pm: pin.Model, qp: np.ndarray) -> np.ndarray:
    m = pin.crba(pm, pm.createData(), qp)
    return np.triu(m) + np.triu(m, 1).T  # Pinocchio fills the upper triangle


def pinocchio_impact(model: ff.Model, state: ff.State, target: ff.capture.Target, e: int, joints: str) -> dict:
    """The same grasp computed by Pinocchio: post-impact ν, the impulse on the target, the joint impulse."""
    s = state.resolve(model)
    pm = to_pinocchio(model)
    k = int(model.end_effector_body[e])
    joint = 1 if k == 0 else pm.getJointId(model.joint_names[k - 1])
    # the base origin that puts the system CM at r_cm, from Pinocchio's CM with the base origin at zero
    at_zero = pinocchio_configuration(model, s.q, s.attitude)
    base = s.r_cm - pin.centerOfMass(pm, pm.createData(), at_zero)
    qp = pinocchio_configuration(model, s.q, s.attitude, base)
    data = pm.createData()
    pin.forwardKinematics(pm, data, qp)
    rot_t = target.rotation_matrix
    placement = data.oMi[joint].inverse() * pin.SE3(rot_t, target.position)  # the target's frame in the joint's
    frame = pm.addFrame(pin.Frame("target", joint, placement, pin.FrameType.OP_FRAME), False)
    combined = pin.Model(pm)
    combined.appendBodyToJoint(joint, pin.Inertia(float(target.mass), np.zeros(3), target.inertia), placement)

    nu_before = pinocchio_velocity(model, pm, s.q, s.velocity, s.attitude)
    data = pm.createData()
    pin.computeJointJacobians(pm, data, qp)
    pin.updateFramePlacements(pm, data)
    jac_t = pin.getFrameJacobian(pm, data, frame, pin.LOCAL_WORLD_ALIGNED)  # [v of the target CM; w], world
    inertia_world = rot_t @ target.inertia @ rot_t.T

    def momentum(twist: np.ndarray) -> np.ndarray:
        return np.concatenate([float(target.mass) * twist[:3], inertia_world @ twist[3:]])

    twist_before = np.concatenate([target.velocity, target.angular_velocity])
    m_r, m_c = crba(pm, qp), crba(combined, qp)
    rhs = m_r @ nu_before + jac_t.T @ momentum(twist_before)
    if joints == "free":
        nu_after = np.linalg.solve(m_c, rhs)
    else:
        qdot = nu_before[6:]
        nu_after = np.concatenate([np.linalg.solve(m_c[:6, :6], rhs[:6] - m_c[:6, 6:] @ qdot), qdot])
    data_c = combined.createData()
    return {
        "nu": nu_after,
        "impulse": momentum(jac_t @ nu_after - twist_before),
        "joint_impulse": (m_c @ nu_after - rhs)[6:],
        "rhs": rhs,
        "combined": combined,
        "energy_after": pin.computeKineticEnergy(combined, data_c, qp, nu_after),
        "energy_before": pin.computeKineticEnergy(pm, pm.createData(), qp, nu_before) + float(target.kinetic_energy),
    }


def compare(model: ff.Model, state: ff.State, target: ff.capture.Target, e: int, joints: str, bound: float = BOUND) -> None:
    r = ff.capture.impact(model, state, target, end_effector=e, joints=joints)
    ref = pinocchio_impact(model, state, target, e, joints)
    s = r.state
    ours = pinocchio_velocity(r.model, ref["combined"], s.q, s.velocity, s.attitude)
    AGREEMENT.check(f"{joints}: post-impact velocity", ours, ref["nu"], bound)
    AGREEMENT.check(f"{joints}: impulse on the target", r.impulse, ref["impulse"], bound)
    # the energy after (the loss would divide Pinocchio's own cancellation E⁻ - E⁺ by a small loss)
    AGREEMENT.check(f"{joints}: energy after", ref["energy_before"] - r.energy_lost, ref["energy_after"], bound)
    if joints == "locked":
        AGREEMENT.check("locked: joint impulse", r.joint_impulse, ref["joint_impulse"], bound)
    else:
        assert np.all(r.joint_impulse == 0.0)
        assert np.abs(ref["joint_impulse"]).max() <= bound * np.abs(ref["rhs"]).max()  # Pinocchio's solve: no joint impulse either


@settings(max_examples=80)
@given(model=random_trees(prismatic=0.3), seed=st.integers(0, 2**32 - 1), joints=st.sampled_from(["free", "locked"]))
def test_impact_agrees_with_pinocchio_on_random_trees(model: ff.Model, seed: int, joints: str) -> None:
    rng = np.random.default_rng(seed)
    state = random_state(model, rng)
    e = int(rng.integers(model.n_end_effectors))
    compare(model, state, random_target(model, state, e, rng), e, joints)


@pytest.mark.parametrize("joints", ["free", "locked"])
def test_impact_agrees_with_pinocchio_on_the_1992_system(joints: str) -> None:
    rng = np.random.default_rng(5)
    model = ff.models.papadopoulos1992(arms=2)
    for e in (0, 1):
        state = random_state(model, rng)
        compare(model, state, random_target(model, state, e, rng), e, joints)


def test_comparison_detects_a_wrong_grasp() -> None:
    """A target 1e-7 heavier on freefloat's side than on Pinocchio's exceeds the bound."""
    rng = np.random.default_rng(6)
    model = ff.models.papadopoulos1992(arms=2)
    state = random_state(model, rng)
    target = random_target(model, state, 0, rng)
    heavier = ff.capture.Target(**{**vars(target), "mass": target.mass * (1 + 1e-7)})
    r = ff.capture.impact(model, state, heavier, joints="free")
    ref = pinocchio_impact(model, state, target, 0, "free")
    with AGREEMENT.not_recorded(), pytest.raises(AssertionError, match=EXCEEDS):
        ours = pinocchio_velocity(r.model, ref["combined"], r.state.q, r.state.velocity, r.state.attitude)
        AGREEMENT.check("wrong on purpose", ours, ref["nu"], BOUND)
