"""A capture event (``ff.simulate(..., capture=ff.Capture(...))``) replayed in MuJoCo on a route that never goes
through freefloat: the robot is a URDF written from raw random numbers (``trees.random_urdf``), read by freefloat with
``ff.load`` and by MuJoCo's own URDF compiler (``mujoco.MjSpec.from_string``, a free joint added to the bus); the
target is a MuJoCo body made from its raw mass, inertia and pose. Every conversion between the two (configuration,
velocities, the CM) is made here with MuJoCo's calls.

Before the grasp MuJoCo integrates the robot and the target as a free body of its own. At the grasp MuJoCo builds the
combined system itself: the target a child body of the grasping tool link (a massless link on a fixed joint, off the
last link's origin) at its pose relative to that link at the instant, read from MuJoCo's kinematics; the target's CM is
off the tool point too, so both the end-effector point and the payload's offset enter. MuJoCo has no impulsive weld:
the grasp is the plastic impact M_c ν⁺ = M_r ν⁻ + J_tᵀ h_t⁻ in MuJoCo's coordinates, with MuJoCo's mass matrices of
the robot and of its combined system (``mj_fullM``), the Jacobian of the target's CM in the combined system
(``mj_jac``) and the target's momentum from MuJoCo's state (free joints: all its rows; locked joints: q̇ kept, the six
rows of the base). MuJoCo then integrates its combined system. Both arms grasp, in both joint modes.

Checked against freefloat's run, at every output sample: the robot's state (q, q̇, ω0, attitude, CM and its velocity)
before the grasp, the coasting target at the grasp, the post-impact state, the state of the combined system after it,
the inertial positions of every body origin and end effector, and the total linear and angular momentum.
"""

from __future__ import annotations

from pathlib import Path

import mujoco  # an oracle: a missing one fails the test
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import freefloat as ff
from oracle_checks import MARGIN, Agreement
from trees import random_inertia, random_urdf

#: The worst relative error max |ours - ref| / max |ref| of any check below, measured 2026-12-01 on the 2-core dev VM
#: (numpy 2.4, MuJoCo 4.0.0, RK4 at 1 ms in both; pytest -s prints AGREEMENT per quantity): 3.5e-14, the combined
#: CM after the grasp. A relative 1e-7 error in the target's mass or in its offset from the hand: 1e-8.
MEASURED = 3.5e-14
BOUND = MARGIN * MEASURED
AGREEMENT = Agreement("a capture event: worst relative error vs MuJoCo from the raw URDF")
DT, T_GRASP, DURATION, EVERY = 1e-3, 0.3, 0.6, 50  # s, s, s, steps between output samples
ARMS = [3, 2]


def teardown_module() -> None:
    AGREEMENT.print()


def f(values: object) -> str:
    return " ".join(f"{x:.17g}" for x in np.ravel(np.asarray(values, dtype=float)))


def torques(t: float) -> np.ndarray:
    """Joint torques (freefloat's joint order; the same as the URDF's), held over each step in both."""
    n = sum(ARMS)
    return 0.3 * np.sin(2.0 * t + np.arange(n)) * np.linspace(1.0, 0.4, n)


class Raw:
    """The raw URDF read by freefloat and by MuJoCo's compiler, a robot state and a tumbling target near the hand."""

    def __init__(self, directory: Path, end_effector: int = 0, joints: str = "free") -> None:
        rng = np.random.default_rng(21)
        self.urdf = random_urdf(rng, ARMS)
        path = directory / "raw.urdf"
        path.write_text(self.urdf, encoding="utf-8")
        self.tools = [f"a{m}_tool" for m in range(len(ARMS))]
        self.model = ff.load(path, end_effectors=self.tools)
        self.e, self.joints = end_effector, joints
        n = self.model.n_joints
        self.state = ff.State(
            q=rng.uniform(-0.3, 0.3, size=n), qdot=rng.normal(scale=0.1, size=n), omega=rng.normal(scale=0.05, size=3),
            attitude=Rotation.random(random_state=rng), r_cm=rng.normal(size=3), v_cm=rng.normal(scale=0.1, size=3),
        )  # fmt: skip
        s = self.state.resolve(self.model)
        tip = s.r_cm + s.rotation.apply(ff.end_effector_positions(self.model, s.q)[end_effector])
        k = int(self.model.end_effector_body[end_effector])
        v_tip = (ff.point_jacobian(self.model, s.q, k, self.model.end_effector_point[end_effector], attitude=s.attitude) @ s.velocity)[:3]
        self.target = {
            "mass": 120.0, "inertia": random_inertia(rng, 120.0), "position": tip + np.array([0.25, -0.15, 0.2]),
            "attitude": Rotation.random(random_state=rng).as_quat(), "velocity": v_tip + rng.normal(scale=0.1, size=3),
            "angular_velocity": rng.normal(scale=0.2, size=3),
        }  # fmt: skip

    def spec(self) -> mujoco.MjSpec:
        """MuJoCo's robot from the raw URDF: a free joint on the bus, no gravity, RK4, a motor on each joint, no limits
        (the run checks that the sliding joints stay inside theirs), the massless tool links kept as bodies."""
        spec = mujoco.MjSpec.from_string(self.urdf)
        spec.compiler.fusestatic = False
        spec.option.gravity = [0.0, 0.0, 0.0]
        spec.option.timestep = DT
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4
        spec.body("bus").add_freejoint(name="base")
        for name in self.model.joint_names:
            spec.joint(name).limited = mujoco.mjtLimited.mjLIMITED_FALSE
            spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT, gear=[1, 0, 0, 0, 0, 0])
        return spec

    def target_inertial(self, body: mujoco.MjsBody) -> None:
        body.mass = self.target["mass"]
        i = self.target["inertia"]
        body.fullinertia = [i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2], i[1, 2]]
        body.ipos = [0.0, 0.0, 0.0]


class Mujoco:
    """A compiled MuJoCo model, its data, and the reading of freefloat's quantities off it (MuJoCo's calls only)."""

    def __init__(self, spec: mujoco.MjSpec, joints: tuple[str, ...]) -> None:
        self.m = spec.compile()
        self.d = mujoco.MjData(self.m)
        self.bus = self.m.body("bus").id
        self.qadr = [int(self.m.joint(name).qposadr[0]) for name in joints]
        self.vadr = [int(self.m.joint(name).dofadr[0]) for name in joints]
        self.nv_robot = 6 + len(joints)  # the base and the joints come first; a free target after them
        self.actuators = [self.m.actuator(name).id for name in joints]

    def cm_jacobian(self) -> np.ndarray:
        jac = np.zeros((3, self.m.nv))
        mujoco.mj_jacSubtreeCom(self.m, self.d, jac, self.bus)
        return jac

    def set_robot(self, s: ff.State) -> None:
        """Place the robot at freefloat's state ``s``: the bus quaternion, the joints by name, the bus origin where the
        robot's CM is at ``s.r_cm``; the bus rate in its own frame (ω0), its origin's velocity from the CM's."""
        d = self.d
        d.qpos[0:3] = 0.0
        d.qpos[3:7] = np.roll(s.attitude, 1)  # MuJoCo's [w, x, y, z]
        d.qpos[self.qadr] = s.q
        mujoco.mj_forward(self.m, d)
        d.qpos[0:3] = s.r_cm - d.subtree_com[self.bus]
        d.qvel[: self.nv_robot] = 0.0
        d.qvel[3:6] = s.omega
        d.qvel[self.vadr] = s.qdot
        mujoco.mj_forward(self.m, d)
        d.qvel[0:3] = s.v_cm - self.cm_jacobian() @ d.qvel
        mujoco.mj_forward(self.m, d)

    def read(self) -> dict[str, np.ndarray]:
        """freefloat's state of the robot (or of the combined system: the target is in the bus's subtree) off MuJoCo's,
        and the total momentum of everything (about the inertial origin; the free target's included before the grasp)."""
        d = self.d
        mujoco.mj_forward(self.m, d)
        mujoco.mj_subtreeVel(self.m, d)
        p = float(self.m.body_subtreemass[0]) * d.subtree_linvel[0]  # everything: the world body's subtree
        return {
            "q": d.qpos[self.qadr].copy(), "qdot": d.qvel[self.vadr].copy(), "omega": d.qvel[3:6].copy(),
            "attitude": np.roll(d.qpos[3:7], -1), "r_cm": d.subtree_com[self.bus].copy(), "v_cm": self.cm_jacobian() @ d.qvel,
            "linear momentum": p, "angular momentum": d.subtree_angmom[0] + np.cross(d.subtree_com[0], p),
        }  # fmt: skip

    def step(self, t: float) -> None:
        self.d.ctrl[self.actuators] = torques(t)
        mujoco.mj_step(self.m, self.d)


def ours(model: ff.Model, traj: ff.Trajectory, k: int, lin: np.ndarray, ang: np.ndarray) -> dict[str, np.ndarray]:
    s = traj.state(k).resolve(model)
    return {
        "q": s.q, "qdot": s.qdot, "omega": s.omega, "attitude": s.attitude, "r_cm": s.r_cm, "v_cm": s.v_cm,
        "linear momentum": lin, "angular momentum": ang,
    }  # fmt: skip


def positions(model: ff.Model, traj: ff.Trajectory, k: int) -> np.ndarray:
    """Inertial positions of every body origin and every end effector of freefloat's run at sample ``k``."""
    s = traj.state(k).resolve(model)
    local = [ff.point_positions(model, s.q, b) for b in range(model.n_bodies)]
    return s.r_cm + s.rotation.apply(np.concatenate([np.array(local), ff.end_effector_positions(model, s.q)]))


def mujoco_positions(mj: Mujoco, model: ff.Model, tools: list[str]) -> np.ndarray:
    names = [*model.body_names, *tools]
    return np.array([mj.d.xpos[mj.m.body(name).id] for name in names])


def replay(raw: Raw, target: dict | None = None, check: bool = True) -> dict[str, float]:
    """freefloat's run (with ``target``, default the raw one) against MuJoCo's replay of the raw one: the worst
    relative error per quantity (recorded in AGREEMENT when ``check``; the bound asserted then)."""
    given = ff.capture.Target(**(target or raw.target))
    capture = ff.Capture(given, at=T_GRASP, end_effector=raw.e, joints=raw.joints)
    run = ff.simulate(
        raw.model, raw.state, DURATION, lambda t, s: torques(t), capture=capture, fixed_step=DT, sample_period=DT, output_period=EVERY * DT
    )
    assert run.captured and run.before is not None and run.after is not None and run.impact is not None, run.message
    slides = np.isfinite(raw.model.joint_upper)
    for traj in (run.before, run.after):  # the sliding joints inside their limits: freefloat's stops never act
        assert np.all(np.abs(traj.q[:, slides]) < 0.5)
    errors: dict[str, float] = {}

    def compare(phase: str, mine: dict[str, np.ndarray], theirs: dict[str, np.ndarray]) -> None:
        if "attitude" in mine and theirs["attitude"] @ mine["attitude"] < 0.0:
            theirs = {**theirs, "attitude": -theirs["attitude"]}
        for name, value in mine.items():
            key = f"{phase}: {name}"
            error = float(np.max(np.abs(value - theirs[name]))) / float(np.max(np.abs(theirs[name])))
            errors[key] = max(errors.get(key, 0.0), error)
            if check:
                AGREEMENT.check(key, value, theirs[name], BOUND)

    # before the grasp: the robot and the target as a free body, in one MuJoCo model
    t = raw.target
    spec = raw.spec()
    free = spec.worldbody.add_body(name="target", pos=t["position"], quat=np.roll(t["attitude"], 1))
    free.add_freejoint(name="target")
    raw.target_inertial(free)
    mj = Mujoco(spec, raw.model.joint_names)
    mj.set_robot(raw.state)
    rot_t = Rotation.from_quat(t["attitude"]).as_matrix()
    mj.d.qpos[mj.nv_robot + 1 : mj.nv_robot + 4] = t["position"]
    mj.d.qpos[mj.nv_robot + 4 :] = np.roll(t["attitude"], 1)
    mj.d.qvel[mj.nv_robot :] = np.r_[t["velocity"], rot_t.T @ t["angular_velocity"]]
    i_before = len(run.before)
    n_grasp = round(T_GRASP / DT)
    for i in range(n_grasp):
        mj.step(i * DT)
        if (i + 1) % EVERY == 0:
            k = (i + 1) // EVERY
            compare("before", ours(raw.model, run.before, k, run.linear_momentum[k], run.angular_momentum[k]), mj.read())
    assert k == i_before - 1

    # the target at the grasp, and the grasp by MuJoCo: its combined system and the plastic impact
    mujoco.mj_forward(mj.m, mj.d)
    body_t = mj.m.body("target").id
    p_t, r_t = mj.d.xpos[body_t].copy(), mj.d.xmat[body_t].reshape(3, 3).copy()
    v_t, w_t = mj.d.qvel[mj.nv_robot : mj.nv_robot + 3].copy(), r_t @ mj.d.qvel[mj.nv_robot + 3 :]
    coasted = run.target
    compare(
        "target at the grasp",
        {"position": coasted.position[-1], "velocity": coasted.velocity[-1], "angular velocity": coasted.angular_velocity[-1]},
        {"position": p_t, "velocity": v_t, "angular velocity": w_t},
    )
    tool = mj.m.body(raw.tools[raw.e]).id
    p_h, r_h = mj.d.xpos[tool].copy(), mj.d.xmat[tool].reshape(3, 3).copy()
    m_before = np.zeros((mj.m.nv, mj.m.nv))
    mujoco.mj_fullM(mj.m, mj.d, m_before)
    qpos, nu_before = mj.d.qpos[: mj.nv_robot + 1].copy(), mj.d.qvel[: mj.nv_robot].copy()
    spec = raw.spec()
    relative = np.roll(Rotation.from_matrix(r_h.T @ r_t).as_quat(), 1)  # the target's attitude in the tool link's axes
    held = spec.body(raw.tools[raw.e]).add_body(name="target", pos=r_h.T @ (p_t - p_h), quat=relative)
    raw.target_inertial(held)
    mj = Mujoco(spec, raw.model.joint_names)
    mj.d.qpos[:] = qpos
    mj.d.qvel[:] = nu_before
    mujoco.mj_forward(mj.m, mj.d)
    m_combined = np.zeros((mj.m.nv, mj.m.nv))
    mujoco.mj_fullM(mj.m, mj.d, m_combined)
    jacp, jacr = np.zeros((3, mj.m.nv)), np.zeros((3, mj.m.nv))
    body_t = mj.m.body("target").id
    mujoco.mj_jac(mj.m, mj.d, jacp, jacr, mj.d.xipos[body_t], body_t)
    h_t = np.r_[t["mass"] * v_t, r_t @ t["inertia"] @ r_t.T @ w_t]
    rhs = m_before[: mj.nv_robot, : mj.nv_robot] @ nu_before + np.vstack([jacp, jacr]).T @ h_t
    if raw.joints == "free":  # no impulsive joint torque: all of M_c ν⁺ = rhs
        mj.d.qvel[:] = np.linalg.solve(m_combined, rhs)
    else:  # the joint rates kept: the six rows of the base
        rates = nu_before[6:]
        mj.d.qvel[:] = np.r_[np.linalg.solve(m_combined[:6, :6], rhs[:6] - m_combined[:6, 6:] @ rates), rates]
    combined, after = run.after.model, mj.read()
    assert combined is not None
    s = run.impact.state.resolve(combined)
    compare("impact", {n: getattr(s, n) for n in ("q", "qdot", "omega", "attitude", "r_cm", "v_cm")}, after)
    compare("after: positions", {"bodies": positions(combined, run.after, 0)}, {"bodies": mujoco_positions(mj, combined, raw.tools)})

    # after the grasp: MuJoCo's combined system
    for i in range(n_grasp, round(DURATION / DT)):
        mj.step(i * DT)
        if (i + 1) % EVERY == 0:
            k = (i + 1) // EVERY - n_grasp // EVERY
            j = i_before + k
            compare("after", ours(combined, run.after, k, run.linear_momentum[j], run.angular_momentum[j]), mj.read())
            compare(
                "after: positions", {"bodies": positions(combined, run.after, k)}, {"bodies": mujoco_positions(mj, combined, raw.tools)}
            )
    assert k == len(run.after) - 1
    return errors


@pytest.mark.parametrize("joints", ["free", "locked"])
@pytest.mark.parametrize("end_effector", [0, 1])
def test_a_capture_event_agrees_with_mujoco_from_the_raw_urdf(end_effector: int, joints: str, tmp_path: Path) -> None:
    raw = Raw(tmp_path, end_effector, joints)
    assert np.linalg.norm(raw.model.end_effector_point[raw.e]) > 0.3  # the grasp is off the tool link's body origin
    found = replay(raw)
    assert {key.split(":")[0] for key in found} == {"before", "target at the grasp", "impact", "after"}


@pytest.mark.parametrize("wrong", ["target mass", "grasp offset"])
def test_a_1e_7_error_in_a_raw_number_fails_the_bound(wrong: str, tmp_path: Path) -> None:
    """freefloat's run with the target's mass, or its CM's offset from the hand, wrong by a relative 1e-7 (MuJoCo's
    replay keeps the raw numbers): the grasp and the run after it exceed the bound, the run before it does not."""
    raw = Raw(tmp_path)
    target = dict(raw.target)
    if wrong == "target mass":
        target["mass"] = target["mass"] * (1.0 + 1e-7)
    else:
        s = raw.state.resolve(raw.model)
        tip = s.r_cm + s.rotation.apply(ff.end_effector_positions(raw.model, s.q)[raw.e])
        target["position"] = target["position"] + 1e-7 * (target["position"] - tip)
    with AGREEMENT.not_recorded():
        found = replay(raw, target, check=False)
    robot = max(v for key, v in found.items() if key.startswith("before") and "momentum" not in key)
    after = {key: v for key, v in found.items() if key.startswith(("impact", "after"))}
    assert robot <= BOUND < max(after.values()), (robot, after)
