"""The core against Pinocchio, an independent rigid-body engine.

On every paper system and on random 3D trees (``trees.random_trees``: 1-3
arms, branches, fixed joints, 1-7 joints per arm, random masses, inertias,
axes and placements), and on the same trees after a round trip through a URDF
file read by both freefloat and Pinocchio's own URDF parser, these agree within
``BOUND`` (relative, max |ours - ref| / max |ref|: MARGIN times the measured
agreement): total mass and system CM, end-effector positions relative to
the CM, linear and angular momentum, kinetic energy, the whole H+ and each of
its blocks D, D_q, D_qq at its own scale, the generalized Jacobian J*, the point Jacobian of a random body point, and
end-effector velocities with nonzero momentum (J* plus the drift term). Both
algorithms of each quantity are checked: the engine (the default) and the
barycentric closed forms (``method="barycentric"``).

Nothing on the Pinocchio side goes through freefloat's formulas: freefloat's
zdot0 = [rdot_cm, omega0, qdot] is related to Pinocchio's v = [v_local,
w_local, qdot] by zdot0 = T v with T built from Pinocchio's own CM Jacobian
(rdot_cm = J_com v, omega0 = w_local), so that H+ = T^-T M T^-1 and any
Pinocchio Jacobian J over v is J T^-1 over zdot0. Joints are mapped by name.

A freefloat model wrong by 1e-8 (relative) in one number fails the bound
(``test_comparison_detects_a_1e_8_model_error``).
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from unittest import mock

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.linalg import block_diag
from scipy.spatial.transform import Rotation

import freefloat as ff
from freefloat.io.oracles import pinocchio_configuration, pinocchio_root_joint, pinocchio_velocity, to_pinocchio
from oracle_checks import EXCEEDS, MARGIN, Agreement, perturbed
from trees import build_random_model, random_trees

#: Agreement with Pinocchio: the worst relative error max |ours - ref| / max |ref| of any check (pytest -s prints
#: AGREEMENT at teardown), measured 2026-11-26 on the 2-core dev VM (numpy 2.4.6, Pinocchio 4.1.0, derandomized
#: hypothesis): 1.4e-13 over the random trees (J* qdot + drift of one tree; 5.9e-14 through URDF), 1.7e-14 over
#: the paper systems (directly and through URDF), 3.8e-15 over the batches. tests/oracle/test_real_robots.py and
#: tests/models/test_zoo.py state their own.
MEASURED = 1.4e-13
BOUND = MARGIN * MEASURED
MEASURED_PAPER = 1.7e-14
PAPER_BOUND = MARGIN * MEASURED_PAPER
MEASURED_BATCH = 3.8e-15
BATCH_BOUND = MARGIN * MEASURED_BATCH
AGREEMENT = Agreement("worst relative error vs Pinocchio")
not_recorded = AGREEMENT.not_recorded


def check(name: str, actual: np.ndarray | float, desired: np.ndarray | float, bound: float = BOUND) -> None:
    """max |actual - desired| / max |desired| within ``bound``."""
    AGREEMENT.check(name, actual, desired, bound)


def teardown_module() -> None:
    AGREEMENT.print()


#: The blocks of H+ (1991 eq. 15), each compared at its own scale: D_qq (the arm) is small beside D on a large spacecraft.
H_BLOCKS = {"D": (slice(3, 6), slice(3, 6)), "D_q": (slice(3, 6), slice(6, None)), "D_qq": (slice(6, None), slice(6, None))}


def check_hplus(name: str, ours: np.ndarray, ref: np.ndarray, bound: float) -> None:
    check(name, ours, ref, bound)
    for block, index in H_BLOCKS.items():
        check(f"{name} {block}", ours[index], ref[index], bound)


class PinocchioSystem:
    """A Pinocchio model of a freefloat model: joints matched by name, end effectors by frame name."""

    def __init__(self, model: ff.Model, pin_model: pin.Model, frame_names: tuple[str, ...]) -> None:
        self.model, self.pm, self.data = model, pin_model, pin_model.createData()
        n = model.n_joints
        assert pin_model.nv == 6 + n, f"Pinocchio has nv = {pin_model.nv}, freefloat 6 + {n}"
        assert (
            pin_model.names[1] == "root_joint" and pin_model.joints[1].nq == 7 and pin_model.joints[1].nv == 6
        )  # a 6-DOF root joint, quaternion-parametrised
        ids = [pin_model.getJointId(name) for name in model.joint_names]
        assert all(0 < i < pin_model.njoints for i in ids), "a freefloat joint is missing in Pinocchio"
        # the Pinocchio joint that moves freefloat body k (a mimic joint too: Pinocchio's JointModelMimic, mimic=True)
        self.body_joint = [1, *(pin_model.getJointId(name) for name in model.body_joint_names)]
        self.idx_q = [pin_model.joints[i].idx_q for i in ids]
        self.nq = [pin_model.joints[i].nq for i in ids]
        self.idx_v = np.array([pin_model.joints[i].idx_v for i in ids], dtype=int)
        assert sorted(self.idx_v.tolist()) == list(range(6, 6 + n))
        self.frames = [pin_model.getFrameId(name) for name in frame_names]
        assert all(f < pin_model.nframes for f in self.frames), f"end-effector frames {frame_names} not all in Pinocchio"

    def mass_matrix(self, qp: np.ndarray) -> np.ndarray:
        """Pinocchio's CRBA, both triangles. With mimic joints in the WORLD convention: in its default (LOCAL) one,
        Pinocchio 4.1 returns wrong entries for a model with a JointModelMimic once its data has been used (measured
        errors of order 1 on random trees; the WORLD convention agrees with freefloat to 1e-13)."""
        if self.model.has_mimic:
            m = pin.crba(self.pm, self.data, qp, pin.Convention.WORLD)
        else:
            m = pin.crba(self.pm, self.data, qp)
        return np.triu(m) + np.triu(m, 1).T  # Pinocchio fills the upper triangle

    def configuration(self, q: np.ndarray, quat: np.ndarray, base: np.ndarray) -> np.ndarray:
        out = pin.neutral(self.pm)
        out[0:3], out[3:7] = base, quat
        for j, (i, nq) in enumerate(zip(self.idx_q, self.nq, strict=True)):
            if nq == 1:  # revolute with limits
                out[i] = q[j]
            else:  # continuous: Pinocchio stores (cos q, sin q)
                assert nq == 2
                out[i : i + 2] = np.cos(q[j]), np.sin(q[j])
        return out

    def velocity_transform(self, qp: np.ndarray) -> np.ndarray:
        """T with zdot0 = T v: rdot_cm = J_com v (world), omega0 = w_local, qdot by name."""
        n = self.model.n_joints
        t = np.zeros((6 + n, 6 + n))
        t[0:3] = pin.jacobianCenterOfMass(self.pm, self.data, qp)
        t[3:6, 3:6] = np.eye(3)
        t[6 + np.arange(n), self.idx_v] = 1.0
        return t

    def reference(self, q: np.ndarray, quat: np.ndarray, base: np.ndarray, zdot0: np.ndarray, body: int, point: np.ndarray) -> dict:
        """Everything Pinocchio says, in freefloat's terms (inertial frame = Pinocchio's world)."""
        pm, data = self.pm, self.data
        qp = self.configuration(q, quat, base)
        t = self.velocity_transform(qp)
        t_inv = np.linalg.inv(t)
        v = t_inv @ zdot0
        out: dict = {"qp": qp, "v": v}
        pin.forwardKinematics(pm, data, qp, v)
        pin.updateFramePlacements(pm, data)
        com = pin.centerOfMass(pm, data, qp, v).copy()
        out["total_mass"] = pin.computeTotalMass(pm)
        out["cm"] = com
        out["cm_velocity"] = data.vcom[0].copy()
        out["ee_positions"] = np.array([data.oMf[f].translation - com for f in self.frames])
        out["ee_velocities"] = np.concatenate([pin.getFrameVelocity(pm, data, f, pin.LOCAL_WORLD_ALIGNED).vector for f in self.frames])
        hg = pin.computeCentroidalMomentum(pm, data, qp, v)
        out["linear_momentum"], out["angular_momentum"] = hg.linear.copy(), hg.angular.copy()
        m = self.mass_matrix(qp)
        # computeKineticEnergy refuses Pinocchio's mimic joints (4.1): then 1/2 v^T M v from its CRBA
        out["kinetic_energy"] = 0.5 * v @ m @ v if self.model.has_mimic else pin.computeKineticEnergy(pm, data, qp, v)
        out["H+"] = t_inv.T @ m @ t_inv
        # J*: zero centroidal momentum, A_b v_base + A_q qdot = 0
        ag = pin.computeCentroidalMap(pm, data, qp)
        pin.computeJointJacobians(pm, data, qp)
        pin.updateFramePlacements(pm, data)
        base_rate = -np.linalg.solve(ag[:, 0:6], ag[:, self.idx_v])
        jacs = [pin.getFrameJacobian(pm, data, f, pin.LOCAL_WORLD_ALIGNED) for f in self.frames]
        out["J*"] = np.concatenate([jac[:, self.idx_v] + jac[:, 0:6] @ base_rate for jac in jacs])
        out["ee_jacobians"] = [jac @ t_inv for jac in jacs]
        joint = self.body_joint[body]
        place = pin.SE3(np.eye(3), np.asarray(point, dtype=float))
        out["point_position"] = data.oMi[joint].act(np.asarray(point, dtype=float)) - com
        out["point_jacobian"] = pin.getFrameJacobian(pm, data, joint, place, pin.LOCAL_WORLD_ALIGNED) @ t_inv
        return out


def compare(model: ff.Model, system: PinocchioSystem, rng: np.random.Generator, bound: float = BOUND) -> dict:
    """Draw a configuration, attitude, base position, velocity and body point; check every quantity within ``bound``."""
    n = model.n_joints
    q = rng.uniform(-np.pi, np.pi, size=n)
    quat = Rotation.random(random_state=rng).as_quat()
    base = rng.normal(scale=3.0, size=3)
    zdot0 = rng.normal(size=6 + n)
    body = int(rng.integers(model.n_bodies))
    point = rng.normal(scale=0.5, size=3)
    ref = system.reference(q, quat, base, zdot0, body, point)
    t0 = Rotation.from_quat(quat).as_matrix()
    n_e = model.n_end_effectors

    check("cm velocity (consistency of T)", ref["cm_velocity"], zdot0[0:3])  # guards the transform itself
    check("total mass", model.total_mass, ref["total_mass"], bound)
    check("system CM", base + t0 @ ff.system_cm(model, q), ref["cm"], bound)
    check("end-effector positions", ff.end_effector_positions(model, q, attitude=quat), ref["ee_positions"], bound)
    check("linear momentum", ff.linear_momentum(model, zdot0), ref["linear_momentum"], bound)
    check("angular momentum", ff.angular_momentum(model, q, zdot0, attitude=quat), ref["angular_momentum"], bound)
    check("kinetic energy", ff.kinetic_energy(model, q, zdot0), ref["kinetic_energy"], bound)
    check_hplus("H+", ff.system_inertia_matrix(model, q), ref["H+"], bound)
    jstar = block_diag(*([t0] * (2 * n_e))) @ ff.generalized_jacobian(model, q)
    check("J*", jstar, ref["J*"], bound)
    drift = ff.mechanics.generalized_jacobian_drift(model, q, ref["angular_momentum"], ref["linear_momentum"], attitude=quat)
    check("end-effector velocity J* qdot + drift", jstar @ zdot0[6:] + drift, ref["ee_velocities"], bound)
    for e in range(n_e):
        check("end-effector Jacobian J+", ff.end_effector_jacobian(model, q, e, attitude=quat), ref["ee_jacobians"][e], bound)
    check("point position", t0 @ ff.point_positions(model, q, body, point), ref["point_position"], bound)
    check("point Jacobian", ff.point_jacobian(model, q, body, point, attitude=quat), ref["point_jacobian"], bound)
    # the second algorithm of each quantity, the barycentric closed forms, against the same oracle
    bary = {"method": "barycentric"}
    check("end-effector positions (barycentric)", ff.end_effector_positions(model, q, attitude=quat, **bary), ref["ee_positions"], bound)
    check_hplus("H+ (barycentric, 1991 eq. 16)", ff.system_inertia_matrix(model, q, **bary), ref["H+"], bound)
    check("J* (barycentric)", block_diag(*([t0] * (2 * n_e))) @ ff.generalized_jacobian(model, q, **bary), ref["J*"], bound)
    check("point position (barycentric)", t0 @ ff.point_positions(model, q, body, point, **bary), ref["point_position"], bound)
    check("point Jacobian (barycentric)", ff.point_jacobian(model, q, body, point, attitude=quat, **bary), ref["point_jacobian"], bound)
    return {"q": q, "quat": quat, "base": base, "zdot0": zdot0, **ref}


def pinocchio_of(model: ff.Model) -> PinocchioSystem:
    return PinocchioSystem(model, to_pinocchio(model), model.end_effector_names)


def check_bridge(model: ff.Model, system: PinocchioSystem, case: dict) -> None:
    """freefloat.io.oracles' own conversions agree with the ones built here from Pinocchio's CM Jacobian."""
    qp = pinocchio_configuration(model, case["q"], case["quat"], case["base"])
    np.testing.assert_array_equal(qp, case["qp"])
    check("oracles.pinocchio_velocity", pinocchio_velocity(model, system.pm, case["q"], case["zdot0"], case["quat"]), case["v"])


def urdf_round_trip(model: ff.Model, directory: str) -> tuple[ff.Model, PinocchioSystem]:
    """Save as URDF, reload with freefloat, parse the same file with Pinocchio's URDF reader (no gravity: in orbit)."""
    path = ff.save(model, Path(directory) / f"{model.name}.urdf")
    loaded = ff.load(path)
    pin_model = pin.buildModelFromUrdf(str(path), pinocchio_root_joint())
    pin_model.gravity = pin.Motion.Zero()
    # In URDF an end effector is a massless leaf link, renamed <name>_tip when a body already has its name.
    tips = tuple(name if name not in model.body_names else f"{name}_tip" for name in model.end_effector_names)
    assert loaded.end_effector_names == tips
    return loaded, PinocchioSystem(loaded, pin_model, tips)


def assert_same_model(loaded: ff.Model, model: ff.Model) -> None:
    assert loaded.body_names == model.body_names
    assert loaded.joint_names == model.joint_names
    assert loaded.joint_type == model.joint_type
    np.testing.assert_array_equal(loaded.parent, model.parent)
    np.testing.assert_array_equal(loaded.end_effector_body, model.end_effector_body)
    np.testing.assert_array_equal(loaded.joint_lower, model.joint_lower)
    np.testing.assert_array_equal(loaded.joint_upper, model.joint_upper)
    for name in ("mass", "com", "inertia", "joint_origin", "joint_rotation", "joint_axis", "end_effector_point"):
        np.testing.assert_allclose(getattr(loaded, name), getattr(model, name), rtol=0.0, atol=1e-12, err_msg=name)
    assert loaded.total_mass == pytest.approx(model.total_mass, rel=1e-15)


# ------------------------------------------------------------------ paper systems
PAPER_SYSTEMS = {
    "papadopoulos1991": ff.models.papadopoulos1991,
    "papadopoulos1992": ff.models.papadopoulos1992,
    "papadopoulos1992-one-arm": lambda: ff.models.papadopoulos1992(arms=1),
    "papadopoulos1992-one-arm-payload": lambda: ff.models.papadopoulos1992(arms=1).with_payload(0, mass=400.0, inertia=25.0),
}


@pytest.mark.parametrize("name", list(PAPER_SYSTEMS))
def test_paper_system_matches_pinocchio(name: str) -> None:
    model = PAPER_SYSTEMS[name]()
    system = pinocchio_of(model)
    rng = np.random.default_rng(list(PAPER_SYSTEMS).index(name))
    for _ in range(8):
        case = compare(model, system, rng, PAPER_BOUND)
        check_bridge(model, system, case)


@pytest.mark.parametrize("name", list(PAPER_SYSTEMS))
def test_paper_system_urdf_matches_pinocchio_urdf_parser(name: str) -> None:
    """Continuous joints: Pinocchio's parser gives them (cos q, sin q) coordinates."""
    model = PAPER_SYSTEMS[name]()
    with tempfile.TemporaryDirectory() as directory:
        loaded, system = urdf_round_trip(model, directory)
    assert_same_model(loaded, model)
    assert all(nq == 2 for nq in system.nq)
    rng = np.random.default_rng(100 + list(PAPER_SYSTEMS).index(name))
    for _ in range(4):
        compare(loaded, system, rng, PAPER_BOUND)


# ------------------------------------------------------------------ random trees
SEEDS = st.integers(0, 2**32 - 1)


@settings(max_examples=500)
@given(model=random_trees(), seed=SEEDS)
def test_random_tree_matches_pinocchio(model: ff.Model, seed: int) -> None:
    system = pinocchio_of(model)
    case = compare(model, system, np.random.default_rng(seed))
    check_bridge(model, system, case)


@settings(max_examples=200)
@given(model=random_trees(prismatic=0.4), seed=SEEDS)
def test_random_tree_with_prismatic_joints_matches_pinocchio(model: ff.Model, seed: int) -> None:
    """Sliding joints mixed in: both algorithms (engine and barycentric) against Pinocchio's prismatic joints."""
    system = pinocchio_of(model)
    assert any(system.pm.joints[i].shortname() == "JointModelPrismaticUnaligned" for i in range(system.pm.njoints))
    case = compare(model, system, np.random.default_rng(seed))
    check_bridge(model, system, case)


@settings(max_examples=200)
@given(model=random_trees(), seed=SEEDS)
def test_random_tree_urdf_matches_pinocchio_urdf_parser(model: ff.Model, seed: int) -> None:
    with tempfile.TemporaryDirectory() as directory:
        loaded, system = urdf_round_trip(model, directory)
    assert_same_model(loaded, model)
    compare(loaded, system, np.random.default_rng(seed))


@settings(max_examples=50)
@given(model=random_trees(prismatic=0.4), seed=SEEDS)
def test_random_tree_with_prismatic_joints_urdf_matches_pinocchio_urdf_parser(model: ff.Model, seed: int) -> None:
    """Sliding joints written to URDF (type="prismatic", limits in m) read back by both parsers."""
    with tempfile.TemporaryDirectory() as directory:
        loaded, system = urdf_round_trip(model, directory)
    assert_same_model(loaded, model)
    compare(loaded, system, np.random.default_rng(seed))


@st.composite
def random_trees_with_specs(draw: st.DrawFn) -> tuple[ff.Model, ff.ModelBuilder]:
    """``random_trees()`` together with the builder that made it (fixed joints not yet merged)."""
    builders: list[ff.ModelBuilder] = []
    build = ff.ModelBuilder.build

    def capture(self: ff.ModelBuilder, **kwargs: str) -> ff.Model:
        builders.append(self)
        return build(self, **kwargs)

    with mock.patch.object(ff.ModelBuilder, "build", capture):
        model = draw(random_trees())
    return model, builders[-1]


def _num(value: float) -> str:
    return repr(float(value))


def _xyz(values: np.ndarray) -> str:
    return " ".join(_num(v) for v in values)


def _origin(xyz: np.ndarray, rotation: np.ndarray) -> str:
    return f'<origin xyz="{_xyz(xyz)}" rpy="{_xyz(Rotation.from_matrix(rotation).as_euler("xyz"))}"/>'


INERTIA_ENTRIES = {"xx": (0, 0), "xy": (0, 1), "xz": (0, 2), "yy": (1, 1), "yz": (1, 2), "zz": (2, 2)}


def unmerged_urdf(builder: ff.ModelBuilder, rng: np.random.Generator) -> str:
    """URDF text of a builder's bodies and joints as given: fixed joints kept, each inertia in a randomly rotated <inertial> frame."""
    lines = [f'<robot name="{builder.name}">']
    for body in builder._bodies:
        rot = Rotation.random(random_state=rng).as_matrix()
        i = rot.T @ body.inertia @ rot  # the inertia in the rotated inertial frame
        lines.append(
            f'<link name="{body.name}"><inertial>{_origin(body.com, rot)}<mass value="{_num(body.mass)}"/>'
            "<inertia " + " ".join(f'i{a}="{_num(i[r, c])}"' for a, (r, c) in INERTIA_ENTRIES.items()) + "/>"
            "</inertial></link>"
        )
    for joint in builder._joints:
        text = f'<joint name="{joint.name}" type="{joint.type}"><parent link="{joint.parent}"/><child link="{joint.child}"/>'
        text += _origin(joint.origin, joint.rotation)
        if joint.type != "fixed":
            text += f'<axis xyz="{_xyz(joint.axis)}"/>'
        if joint.type == "revolute":
            text += f'<limit lower="{_num(joint.lower)}" upper="{_num(joint.upper)}" effort="0" velocity="0"/>'
        lines.append(text + "</joint>")
    return "\n".join([*lines, "</robot>"])


@settings(max_examples=200)
@given(tree=random_trees_with_specs(), seed=SEEDS)
def test_random_tree_urdf_with_fixed_joints_matches_pinocchio_urdf_parser(tree: tuple[ff.Model, ff.ModelBuilder], seed: int) -> None:
    """Fixed joints and rotated <inertial> frames merged by freefloat's reader and, independently, by Pinocchio's."""
    model, builder = tree
    rng = np.random.default_rng(seed)
    with tempfile.TemporaryDirectory() as directory:
        path = Path(directory) / "tree.urdf"
        path.write_text(unmerged_urdf(builder, rng), encoding="utf-8")
        loaded = ff.load(path)
        pin_model = pin.buildModelFromUrdf(str(path), pinocchio_root_joint())
    fixed = sum(joint.type == "fixed" for joint in builder._joints)
    assert sum(frame.type == pin.FrameType.FIXED_JOINT for frame in pin_model.frames[1:]) == fixed
    system = PinocchioSystem(loaded, pin_model, loaded.end_effector_names)
    assert loaded.end_effector_names == model.end_effector_names
    assert_same_model(loaded, model)
    compare(loaded, system, rng)


# ------------------------------------------------------------------ batches
def batch_models() -> list[ff.Model]:
    return [ff.models.papadopoulos1992(), build_random_model(np.random.default_rng(7), [4, 3, 2], [1, None, 0], [2, 0, None])]


@pytest.mark.parametrize("which", [0, 1], ids=["papadopoulos1992", "random-tree"])
def test_batch_matches_pinocchio_loop(which: int) -> None:
    """Batched calls over (2, 2600) configurations (crossing the 4096 chunk) equal Pinocchio case by case."""
    model = batch_models()[which]
    system = pinocchio_of(model)
    rng = np.random.default_rng(11 + which)
    n, n_e = model.n_joints, model.n_end_effectors
    shape = (2, 2600)
    q = rng.uniform(-np.pi, np.pi, size=(*shape, n))
    rot = Rotation.random(int(np.prod(shape)), random_state=rng)
    quat = rot.as_quat().reshape(*shape, 4)
    zdot0 = rng.normal(size=(*shape, 6 + n))
    body, point = model.n_bodies - 1, rng.normal(scale=0.5, size=3)

    cm = ff.system_cm(model, q)
    positions = ff.end_effector_positions(model, q, attitude=quat)
    h = ff.angular_momentum(model, q, zdot0, attitude=quat)
    p = ff.linear_momentum(model, zdot0)
    energy = ff.kinetic_energy(model, q, zdot0)
    hplus = ff.system_inertia_matrix(model, q)
    jstar = ff.generalized_jacobian(model, q)
    drift = ff.mechanics.generalized_jacobian_drift(model, q, h, p, attitude=quat)
    point_jac = ff.point_jacobian(model, q, body, point, attitude=quat)
    assert positions.shape == (*shape, n_e, 3) and hplus.shape == (*shape, 6 + n, 6 + n) and jstar.shape == (*shape, 6 * n_e, n)
    assert drift.shape == (*shape, 6 * n_e) and point_jac.shape == (*shape, 6, 6 + n) and energy.shape == shape

    flat = np.concatenate([[0, 4095, 4096, 4097, 2 * 2600 - 1], rng.choice(2 * 2600, size=25, replace=False)])
    for i in flat:
        c = np.unravel_index(int(i), shape)
        ref = system.reference(q[c], quat[c], np.zeros(3), zdot0[c], body, point)
        t0 = Rotation.from_quat(quat[c]).as_matrix()
        check("batch: system CM", t0 @ cm[c], ref["cm"], BATCH_BOUND)
        check("batch: end-effector positions", positions[c], ref["ee_positions"], BATCH_BOUND)
        check("batch: angular momentum", h[c], ref["angular_momentum"], BATCH_BOUND)
        check("batch: linear momentum", p[c], ref["linear_momentum"], BATCH_BOUND)
        check("batch: kinetic energy", energy[c], ref["kinetic_energy"], BATCH_BOUND)
        check("batch: H+", hplus[c], ref["H+"], BATCH_BOUND)
        jstar_i = block_diag(*([t0] * (2 * n_e))) @ jstar[c]
        check("batch: J*", jstar_i, ref["J*"], BATCH_BOUND)
        check("batch: J* qdot + drift", jstar_i @ zdot0[c][6:] + drift[c], ref["ee_velocities"], BATCH_BOUND)
        check("batch: point Jacobian", point_jac[c], ref["point_jacobian"], BATCH_BOUND)


# ------------------------------------------------------------------ the comparison can fail
@pytest.mark.parametrize(
    ("name", "index"),
    [
        ("mass", (2,)),
        ("com", (3, 1)),
        ("inertia", (1, 0, 0)),
        ("joint_origin", (2, 2)),
        ("joint_axis", (4, 0)),
        ("joint_rotation", (5, 2)),
        ("end_effector_point", (1, 1)),
    ],
)
def test_comparison_detects_a_1e_8_model_error(name: str, index: tuple[int, ...]) -> None:
    """The same checks reject a freefloat model that differs from Pinocchio's by 1e-8 (relative) in one number."""
    model = batch_models()[1]
    system = pinocchio_of(model)
    value = float(np.max(np.abs(getattr(model, name))))
    wrong = perturbed(model, name, index, 1e-8 * max(value, 1.0))
    with not_recorded(), pytest.raises(AssertionError, match=EXCEEDS):
        compare(wrong, system, np.random.default_rng(3))
    compare(model, system, np.random.default_rng(3))
