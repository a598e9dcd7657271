"""The grasp of a moving target (``ff.capture.impact``) and its combined model against Pinocchio, on a route that never
goes through freefloat: the robot is a URDF written from raw random numbers (``trees.random_urdf``), read by freefloat
with ``ff.load`` and by Pinocchio's own parser (``pinocchio.buildModelFromUrdf`` with a free flyer); the target is
appended by Pinocchio (``appendBodyToJoint``) from its raw mass, inertia and pose; every conversion between the two
(configuration, velocities, the CM) is made here with Pinocchio's calls. The grasping end effectors are tool links on
fixed joints, off their last links' origins, so the end-effector point (the payload's offset) is never zero.

Checked: freefloat's post-impact state (ω0, q̇, the combined CM and its velocity), its impulse on the target and its
joint impulse against the generalized momentum balance M_c ν⁺ = M_r ν⁻ + J_tᵀ h_t⁻ in Pinocchio's coordinates; and
freefloat's combined model (``Impact.model``) itself: its H+ against Pinocchio's CRBA of the combined model, its
end-effector positions and the angular momentum of the post-impact state against Pinocchio's.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import freefloat as ff
from freefloat.io.oracles import pinocchio_root_joint
from impacts import random_state, random_target
from oracle_checks import EXCEEDS, MARGIN, Agreement
from trees import random_urdf

#: The worst relative error max |ours - ref| / max |ref| of any check below, measured 2026-12-01 on the 2-core dev VM
#: (numpy 2.4, Pinocchio 4.1.0; pytest -s prints AGREEMENT per quantity): 2.9e-14.
MEASURED = 3e-14
BOUND = MARGIN * MEASURED
AGREEMENT = Agreement("ff.capture.impact and its combined model: worst relative error vs Pinocchio from the raw URDF")
#: (seed, joints per arm) of the raw robots; each grasps with each of its end effectors, both joint modes.
ROBOTS = [(11, [3, 2]), (12, [5]), (13, [2, 2, 3])]


def teardown_module() -> None:
    AGREEMENT.print()


class Raw:
    """A raw URDF read by freefloat and by Pinocchio, and the conversions between their coordinates (Pinocchio's calls)."""

    def __init__(self, seed: int, joints: list[int], directory: Path) -> None:
        self.rng = np.random.default_rng(seed)
        path = directory / f"raw{seed}.urdf"
        path.write_text(random_urdf(self.rng, joints), encoding="utf-8")
        self.model = ff.load(path, end_effectors=[f"a{m}_tool" for m in range(len(joints))])
        self.pm = pin.buildModelFromUrdf(str(path), pinocchio_root_joint())  # (the one place that names the joint class)
        assert self.pm.nv == 6 + self.model.n_joints and self.pm.names[1] == "root_joint"
        self.ids = [self.pm.getJointId(name) for name in self.model.joint_names]
        self.idx_v = [self.pm.joints[i].idx_v for i in self.ids]

    def configuration(self, state: ff.State) -> np.ndarray:
        """Pinocchio's q: the joints by name (a continuous joint as (cos, sin)), the base placed so that the CM of the
        robot is at ``state.r_cm``."""
        qp = pin.neutral(self.pm)
        qp[3:7] = state.attitude  # [x, y, z, w] in both
        for i, value in zip(self.ids, state.q, strict=True):
            joint = self.pm.joints[i]
            qp[joint.idx_q : joint.idx_q + joint.nq] = value if joint.nq == 1 else (np.cos(value), np.sin(value))
        qp[0:3] = state.r_cm - pin.centerOfMass(self.pm, self.pm.createData(), qp)
        return qp

    def to_freefloat(self, pm: pin.Model, qp: np.ndarray) -> np.ndarray:
        """T with zdot0 = T ν for Pinocchio's model ``pm`` (the robot or the combined one): ṙ_cm = J_com ν, ω0 = the
        base's local angular velocity, q̇ by name."""
        n = self.model.n_joints
        t = np.zeros((6 + n, 6 + n))
        t[0:3] = pin.jacobianCenterOfMass(pm, pm.createData(), qp)
        t[3:6, 3:6] = np.eye(3)
        t[6 + np.arange(n), self.idx_v] = 1.0
        return t


def crba(pm: pin.Model, qp: np.ndarray) -> np.ndarray:
    m = pin.crba(pm, pm.createData(), qp)
    return np.triu(m) + np.triu(m, 1).T  # Pinocchio fills the upper triangle


def reference(raw: Raw, state: ff.State, target: ff.capture.Target, e: int, joints: str) -> dict:
    """The grasp by Pinocchio alone: the combined model, ν⁺, the impulse on the target, the joint impulse."""
    pm, s = pin.Model(raw.pm), state.resolve(raw.model)  # a copy: the target's frame is added to it
    qp = raw.configuration(s)
    nu_before = np.linalg.solve(raw.to_freefloat(pm, qp), s.velocity)
    tool = pm.getFrameId(raw.model.end_effector_names[e])
    data = pm.createData()
    pin.forwardKinematics(pm, data, qp)
    pin.updateFramePlacements(pm, data)
    joint = pm.frames[tool].parentJoint
    placement = data.oMi[joint].inverse() * pin.SE3(target.rotation_matrix, np.asarray(target.position, dtype=float))
    combined = pin.Model(pm)
    combined.appendBodyToJoint(joint, pin.Inertia(float(target.mass), np.zeros(3), np.asarray(target.inertia, dtype=float)), placement)
    grasp = pm.addFrame(pin.Frame("target", joint, placement, pin.FrameType.OP_FRAME), False)
    data = pm.createData()
    pin.computeJointJacobians(pm, data, qp)
    pin.updateFramePlacements(pm, data)
    jac_t = pin.getFrameJacobian(pm, data, grasp, pin.LOCAL_WORLD_ALIGNED)  # [v of the target CM; w], world
    inertia_world = target.rotation_matrix @ target.inertia @ target.rotation_matrix.T
    twist_before = np.concatenate([target.velocity, target.angular_velocity])

    def momentum(twist: np.ndarray) -> np.ndarray:
        return np.concatenate([float(target.mass) * twist[:3], inertia_world @ twist[3:]])

    m_r, m_c = crba(pm, qp), crba(combined, qp)
    rhs = m_r @ nu_before + jac_t.T @ momentum(twist_before)
    if joints == "free":
        nu = np.linalg.solve(m_c, rhs)
    else:
        nu = np.concatenate([np.linalg.solve(m_c[:6, :6], rhs[:6] - m_c[:6, 6:] @ nu_before[6:]), nu_before[6:]])
    data_c = combined.createData()
    pin.centerOfMass(combined, data_c, qp, nu)
    pin.forwardKinematics(combined, data_c, qp, nu)
    pin.updateFramePlacements(combined, data_c)
    t_c = raw.to_freefloat(combined, qp)
    t_inv = np.linalg.inv(t_c)
    centroidal = pin.computeCentroidalMomentum(combined, combined.createData(), qp, nu)
    return {
        "velocity": t_c @ nu,  # [v_cm (combined), ω0, q̇]
        "r_cm": data_c.com[0].copy(),
        "impulse": momentum(jac_t @ nu - twist_before),
        "joint_impulse": (m_c @ nu - rhs)[raw.idx_v],  # by name
        "H+": t_inv.T @ m_c @ t_inv,  # freefloat's coordinates
        "tips": np.array([data_c.oMf[combined.getFrameId(name)].translation for name in raw.model.end_effector_names]),
        "angular_momentum": centroidal.angular.copy(),  # about the combined CM, world
    }


def compare(raw: Raw, state: ff.State, target: ff.capture.Target, e: int, joints: str, bound: float = BOUND) -> None:
    r = ff.capture.impact(raw.model, state, target, end_effector=e, joints=joints)
    ref = reference(raw, state, target, e, joints)
    s = r.state.resolve(r.model)
    AGREEMENT.check(f"{joints}: post-impact zdot0", s.velocity, ref["velocity"], bound)
    AGREEMENT.check(f"{joints}: combined CM", s.r_cm, ref["r_cm"], bound)
    AGREEMENT.check(f"{joints}: impulse on the target", r.impulse, ref["impulse"], bound)
    if joints == "locked":
        AGREEMENT.check("locked: joint impulse", r.joint_impulse, ref["joint_impulse"], bound)
    # the combined model itself, at the post-impact state
    AGREEMENT.check("combined model: H+", ff.system_inertia_matrix(r.model, s.q), ref["H+"], bound)
    tips = s.r_cm + s.rotation.apply(ff.end_effector_positions(r.model, s.q))
    AGREEMENT.check("combined model: end-effector positions", tips, ref["tips"], bound)
    h = ff.angular_momentum(r.model, s.q, s.velocity, attitude=s.attitude)
    AGREEMENT.check(f"{joints}: combined model: angular momentum", h, ref["angular_momentum"], bound)


@pytest.mark.parametrize("joints", ["free", "locked"])
@pytest.mark.parametrize(("seed", "arms"), ROBOTS)
def test_impact_and_combined_model_agree_with_pinocchio_from_the_raw_urdf(seed: int, arms: list[int], joints: str, tmp_path: Path) -> None:
    raw = Raw(seed, arms, tmp_path)
    assert np.all(np.linalg.norm(raw.model.end_effector_point, axis=-1) > 0.3)  # grasps off the body origins
    for e in range(raw.model.n_end_effectors):
        state = random_state(raw.model, raw.rng)
        compare(raw, state, random_target(raw.model, state, e, raw.rng), e, joints)


@pytest.mark.parametrize(
    "wrong",
    ["target mass", "end-effector point", "payload offset"],
)
def test_a_1e_7_error_fails_the_bound(wrong: str, tmp_path: Path) -> None:
    """The same comparison with one number wrong by 1e-7 (relative) on freefloat's side exceeds the bound: the target's
    mass, the end-effector point in the robot (the grasp point), the target's position (the payload's offset)."""
    raw = Raw(11, [3, 2], tmp_path)
    state = random_state(raw.model, raw.rng)
    target = random_target(raw.model, state, 0, raw.rng)
    ref = reference(raw, state, target, 0, "free")
    model, given = raw.model, target
    if wrong == "target mass":
        given = ff.capture.Target(**{**vars(target), "mass": target.mass * (1 + 1e-7)})
    elif wrong == "payload offset":
        given = ff.capture.Target(**{**vars(target), "position": target.position * (1 + 1e-7)})
    else:
        model = dataclasses.replace(model, end_effector_point=model.end_effector_point * (1 + 1e-7))
    r = ff.capture.impact(model, state, given, end_effector=0, joints="free")
    s = r.state.resolve(r.model)
    ours = np.concatenate([s.velocity, s.r_cm, (s.r_cm + s.rotation.apply(ff.end_effector_positions(r.model, s.q))).ravel()])
    with AGREEMENT.not_recorded(), pytest.raises(AssertionError, match=EXCEEDS):
        AGREEMENT.check("wrong on purpose", ours, np.concatenate([ref["velocity"], ref["r_cm"], ref["tips"].ravel()]), BOUND)
