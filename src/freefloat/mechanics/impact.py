"""The grasp of a moving target as an impact: :func:`impact` (``ff.capture.impact``) and its :class:`Impact`.

At the instant of the grasp the target (:class:`~freefloat.core.target.Target`) becomes rigidly fixed to
the grasping body k at its relative pose of that instant. The grasp is impulsive: positions and attitudes do
not change, velocities jump, and no external impulse acts, so the linear and angular momentum of robot plus
target are conserved.

Coordinates. The robot's generalized velocities zdot0 = [rdot_cm, omega0, qdot] (1991 eq. 8; rdot_cm of the
robot's CM, inertial; omega0 spacecraft frame) also describe the combined system after the grasp (the target
moves with body k). In them the target's twist V_t = [v_t; w_t] (its CM velocity and angular velocity,
inertial) is J_t zdot0, J_t the point Jacobian J+ of the target's CM on body k (1991 eqs. 7-10,
:func:`~freefloat.point_jacobian`), and the kinetic energy of the combined system is ½ zdot0ᵀ H zdot0 with

    H = H+ + J_tᵀ M_t J_t,      M_t = diag(m_t 1, R_t I_t R_tᵀ)   (the target's spatial inertia about its CM, inertial)

(H+ the robot's, 1991 eq. 15). The generalized momentum balance of the grasp is

    H zdot0⁺ = H+ zdot0⁻ + J_tᵀ M_t V_t⁻ + [0; tau_hat]                                  (1)

whose first six rows are the conservation of linear momentum and of angular momentum about the robot's CM
(a fixed point during the impulse). ``joints="free"``: the joints carry no impulsive torque, tau_hat = 0,
and (1) gives zdot0⁺. ``joints="locked"``: the joint rates keep their values, qdot⁺ = qdot⁻; the six rows
of the spacecraft give its rates, and the joint rows of (1) give tau_hat, the impulse of the torque each
joint applied (N m s, N s for a sliding joint). Any other choice of base coordinates that keeps q (the
spacecraft twist, or the combined model's zdot0, whose rdot_cm is the new system CM's velocity) is related
to these by a map that leaves qdot alone, so the joint rows of (1) are the same in all of them.

Energy. With u = V_t⁻ - J_t zdot0⁻ (the target's twist relative to the grasping body) and
Δ = zdot0⁺ - zdot0⁻, the energy lost is

    E⁻ - E⁺ = ½ uᵀ M_t u - ½ Δᵀ H Δ - qdot⁻ᵀ tau_hat

(computed so, without the cancellation of E⁻ - E⁺). For free joints it is >= 0 (Kelvin's theorem: a
plastic impact). For locked joints ½ uᵀ M_t u - ½ Δᵀ H Δ >= 0 as well, but the locked joints do the work
qdot⁻ᵀ tau_hat on the system (they hold their rates through the impulse): the energy lost is >= 0 when the
joints are at rest before the grasp, and may be negative (energy given by the joint motors) when they move.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.conventions import attitude_matrix, skew
from ..core.errors import ShapeError
from ..core.model import Model, resolve_model
from ..core.state import State
from ..core.target import Target
from ..core.wheels import wheel_joint_model
from .jacobians import point_jacobian
from .kinematics import body_rotations, point_positions
from .momentum import system_inertia_matrix

__all__ = ["GRASP_REACH", "JOINT_MODES", "Impact", "impact"]

#: What the joints do during the grasp: "free" (no impulsive torque) or "locked" (the joint rates do not jump).
JOINT_MODES = ("free", "locked")
#: The grasping hand must be on the target: its end-effector point at most this many of the target's largest radii
#: of gyration, sqrt(max eig(I_c) / m), from the target's CM. Every homogeneous convex body lies within 4 of them of
#: its CM (a cube's corner 2.1, a rod's end 1.7, a slender cone's tip 3.9); 10 leaves room for bodies that are not (a
#: bus with long solar arrays: the arrays' tips about 5; a light boom on a compact bus can reach beyond 10: grasp such
#: a target at its bus). A hand farther away is not on the target (a position in the wrong frame or unit): the impact
#: is refused rather than computed for a body the hand does not touch.
GRASP_REACH = 10.0


@dataclass(frozen=True, eq=False)
class Impact:
    """The outcome of a grasp (:func:`impact`); the arrays carry the batch shape of the call (``...``).

    Attributes
        state          the post-impact :class:`~freefloat.State` of :attr:`model`: q and attitude unchanged; r_cm,
                       v_cm the new system CM and its velocity (inertial); omega (spacecraft frame) and qdot after
        impulse        (..., 6) the grasp impulse on the target, [linear (N s); angular about its CM (N m s)],
                       inertial frame: the jump of its momentum
        joint_impulse  (..., N) the impulse of the torque each locked joint applied (N m s; N s for a sliding
                       joint): the joint rows of the generalized momentum balance; zeros for ``joints="free"``
        energy_lost    (...) J, kinetic energy before (robot + target) minus after (>= 0 for free joints)
        target_twist   (..., 6) the target's [CM velocity; angular velocity] after the grasp, inertial frame
        robot          the robot's model before the grasp
        end_effector   the name of the grasping end effector
        joints         "free" or "locked"
        payload_mass, payload_inertia, payload_offset
                       the target as a payload of the grasping body: (...) kg, (..., 3, 3) kg m² about its CM in
                       the body's axes, (..., 3) m its CM from the end-effector point in the body frame
                       (the arguments of ``Model.with_payload``)
        wheel_impulse  (..., W) for a robot with reaction wheels: the impulse of each wheel's motor torque (N m s).
                       The wheels are joints of the grasp like the others (:mod:`freefloat.core.wheels`):
                       ``"free"``, no motor impulse (each rotor keeps its own spin; its speed relative to the
                       spacecraft, ``state.wheel_speed``, changes with the spacecraft's rate); ``"locked"``, the
                       motors hold the wheel speeds relative to the spacecraft. None without wheels.
    """

    state: State
    impulse: np.ndarray
    joint_impulse: np.ndarray
    energy_lost: Any
    target_twist: np.ndarray
    robot: Model
    end_effector: str
    joints: str
    payload_mass: Any
    payload_inertia: np.ndarray
    payload_offset: np.ndarray
    wheel_impulse: Any = None

    @property
    def shape(self) -> tuple[int, ...]:
        """The batch shape of the call: () for one robot state and one target."""
        return tuple(np.shape(self.payload_mass))

    @property
    def model(self) -> Any:
        """The combined model: the robot with the target fixed to the grasping body (``Model.with_payload``).

        One :class:`~freefloat.Model` for a single impact; for a batch, an object array of models of the batch
        shape, built when first read (one model per target: slow for large batches).
        """
        found = self.__dict__.get("_model")
        if found is None:
            if not self.shape:
                found = self._combined(())
            else:
                found = np.empty(self.shape, dtype=object)
                for index in np.ndindex(*self.shape):
                    found[index] = self._combined(index)
            object.__setattr__(self, "_model", found)
        return found

    def _combined(self, index: tuple[int, ...]) -> Model:
        return self.robot.with_payload(
            self.end_effector,
            mass=float(np.asarray(self.payload_mass)[index]),
            inertia=self.payload_inertia[index],
            offset=self.payload_offset[index],
            name="target",
        )


def _spatial(mass: np.ndarray, inertia: np.ndarray, twist: np.ndarray) -> np.ndarray:
    """M_t V: [m v; I w] for twists (..., 6, K) or (..., 6)."""
    if twist.ndim == mass.ndim + 1:
        return np.concatenate([mass[..., None] * twist[..., 0:3], np.einsum("...ij,...j->...i", inertia, twist[..., 3:6])], axis=-1)
    return np.concatenate([mass[..., None, None] * twist[..., 0:3, :], inertia @ twist[..., 3:6, :]], axis=-2)


def impact(model: Any, state: State, target: Target, end_effector: str | int = 0, joints: str = "free") -> Impact:
    """The grasp of a moving target as an impact: the robot's and the target's velocities just after it.

    ``model``: the robot (a :class:`~freefloat.Model`, a built-in model name or a model file); ``state``: its
    :class:`~freefloat.State` at the grasp (q, attitude, r_cm the robot's CM, v_cm, omega, qdot);
    ``target``: a :class:`Target`, or a batch of them; ``end_effector``: the grasping end effector (name or
    index): the target becomes fixed to its body, at the pose it has at that instant (its CM need not be at
    the end-effector point); ``joints``: "free" (no impulsive joint torque) or "locked" (the joint rates do not
    jump: brakes or motors take the impulse). A batched state and a batch of targets broadcast; one robot state
    and 10^4 targets are one call (one 6+N solve per target).

    Returns an :class:`Impact`: ``.model`` the combined model (``Model.with_payload`` with the target's mass,
    its inertia in the grasping body's axes and its CM offset from the end-effector point), ``.state`` its
    post-impact state, ``.impulse``, ``.joint_impulse``, ``.energy_lost``. The equations (generalized momentum
    balance, 1991 eqs. 7-10 and 15) are in the module docstring and docs/impact.md.

    Examples
    --------
    >>> import freefloat as ff
    >>> model = ff.models.papadopoulos1992(arms=1)
    >>> state = ff.State(q=[0.5, 1.0])
    >>> tip = ff.end_effector_positions(model, state.q)[0]
    >>> target = ff.capture.Target(mass=100.0, inertia=10.0, position=tip, velocity=[0.0, 0.05, 0.0])
    >>> r = ff.capture.impact(model, state, target, joints="free")
    >>> r.model.total_mass - model.total_mass
    100.0
    >>> bool(r.energy_lost >= 0.0)
    True
    """
    model = resolve_model(model)
    if not isinstance(joints, str) or joints not in JOINT_MODES:
        raise ValueError(f"joints: expected one of {', '.join(map(repr, JOINT_MODES))}, got {joints!r}")
    if not isinstance(state, State):
        raise TypeError(f"state: expected a freefloat.State, got {type(state).__name__}")
    if not isinstance(target, Target):
        raise TypeError(f"target: expected a freefloat.capture.Target, got {type(target).__name__}")
    if model.wheels:
        return _with_wheels(model, state, target, end_effector, joints)
    e = model.end_effector_index(end_effector)
    k = int(model.end_effector_body[e])
    robot = state.resolve(model)
    try:
        batch = np.broadcast_shapes(robot.q.shape[:-1], target.shape)
    except ValueError:
        raise ShapeError(f"impact: the state's batch shape {robot.q.shape[:-1]} and the target's {target.shape} do not broadcast") from None
    n = model.n_joints

    # the grasping body: its frame (origin, inertial; orientation T0 ⁰T_k) and the Jacobian of its origin
    t0 = attitude_matrix(robot.attitude)
    rot_k = t0 @ body_rotations(model, robot.q)[..., k, :, :]
    origin_k = robot.r_cm + np.einsum("...ij,...j->...i", t0, point_positions(model, robot.q, k))
    _check_reach(target, origin_k + np.einsum("...ij,j->...i", rot_k, model.end_effector_point[e]), model.end_effector_names[e])
    jac_o = point_jacobian(model, robot.q, k, np.zeros(3), attitude=t0)  # rows [v_o; w_k], inertial
    h_robot = system_inertia_matrix(model, robot.q)

    # J_t: the Jacobian of the target's CM as a point of body k, v_t = v_o + w_k x d
    d = target.position - origin_k
    jac_t = np.array(np.broadcast_to(jac_o, (*batch, 6, 6 + n)))
    jac_t[..., 0:3, :] -= skew(d) @ jac_o[..., 3:6, :]
    mass = np.broadcast_to(target.mass, batch)
    inertia_i = np.broadcast_to(target.inertia_inertial, (*batch, 3, 3))
    twist_before = np.broadcast_to(np.concatenate([target.velocity, target.angular_velocity], axis=-1), (*batch, 6))
    zdot_before = np.broadcast_to(robot.velocity, (*batch, 6 + n))

    h = h_robot + np.swapaxes(jac_t, -1, -2) @ _spatial(mass, inertia_i, jac_t)
    p_before = np.einsum("...ij,...j->...i", h_robot, robot.velocity) + np.einsum(
        "...ji,...j->...i", jac_t, _spatial(mass, inertia_i, twist_before)
    )
    if joints == "free":
        zdot_after = np.linalg.solve(h, p_before[..., None])[..., 0]
        joint_impulse = np.zeros((*batch, n))
    else:
        qdot = zdot_before[..., 6:]
        rhs = p_before[..., :6] - np.einsum("...ij,...j->...i", h[..., :6, 6:], qdot)
        zdot_after = np.concatenate([np.linalg.solve(h[..., :6, :6], rhs[..., None])[..., 0], qdot], axis=-1)
        joint_impulse = np.einsum("...ij,...j->...i", h[..., 6:, :], zdot_after) - p_before[..., 6:]

    twist_after = np.einsum("...ij,...j->...i", jac_t, zdot_after)
    impulse = _spatial(mass, inertia_i, twist_after - twist_before)
    relative = twist_before - np.einsum("...ij,...j->...i", jac_t, zdot_before)
    jump = zdot_after - zdot_before
    energy_lost = 0.5 * (
        np.sum(relative * _spatial(mass, inertia_i, relative), axis=-1) - np.einsum("...i,...ij,...j->...", jump, h, jump)
    ) - np.sum(zdot_before[..., 6:] * joint_impulse, axis=-1)

    # the combined model's state: the new system CM and its velocity (the total momentum over the total mass)
    m_robot = model.total_mass
    total = m_robot + mass
    r_cm = (m_robot * robot.r_cm + mass[..., None] * target.position) / total[..., None]
    v_cm = (m_robot * zdot_after[..., 0:3] + mass[..., None] * twist_after[..., 0:3]) / total[..., None]
    after = State._trusted(
        q=np.array(np.broadcast_to(robot.q, (*batch, n))),
        qdot=zdot_after[..., 6:],
        omega=zdot_after[..., 3:6],
        attitude=np.array(np.broadcast_to(robot.attitude, (*batch, 4))),
        r_cm=r_cm,
        v_cm=v_cm,
    )

    # the target as a payload of body k: its inertia in the body's axes, its CM from the end-effector point
    rot_k = np.broadcast_to(rot_k, (*batch, 3, 3))
    inertia_k = np.swapaxes(rot_k, -1, -2) @ inertia_i @ rot_k
    offset = np.einsum("...ji,...j->...i", rot_k, d) - model.end_effector_point[e]
    result = Impact(
        state=after,
        impulse=impulse,
        joint_impulse=joint_impulse,
        energy_lost=float(energy_lost) if not batch else energy_lost,
        target_twist=twist_after,
        robot=model,
        end_effector=model.end_effector_names[e],
        joints=joints,
        payload_mass=float(mass) if not batch else np.array(mass),
        payload_inertia=0.5 * (inertia_k + np.swapaxes(inertia_k, -1, -2)),
        payload_offset=offset,
    )
    if not batch:
        _ = result.model  # one impact: build the combined model now, so that its errors are the call's
    return result


def _check_reach(target: Target, tip: np.ndarray, name: str) -> None:
    """Refuse a target whose CM is farther from the end-effector point ``tip`` (..., 3) (inertial) than
    :data:`GRASP_REACH` of its largest radii of gyration (a ValueError naming the positions and the distance)."""
    gyration = np.sqrt(np.linalg.eigvalsh(target.inertia)[..., -1] / target.mass)
    distance = np.linalg.norm(target.position - tip, axis=-1)
    excess = np.broadcast_to(distance - GRASP_REACH * gyration, np.broadcast_shapes(distance.shape, gyration.shape))
    if not np.any(excess > 0.0):
        return
    index = np.unravel_index(int(np.argmax(excess)), excess.shape) if excess.shape else ()
    where = f"target{list(map(int, index)) if index else ''}"
    cm = np.broadcast_to(target.position, (*excess.shape, 3))[index]
    hand = np.broadcast_to(tip, (*excess.shape, 3))[index]
    r_g = float(np.broadcast_to(gyration, excess.shape)[index])
    raise ValueError(
        f"{where}: its CM at [{', '.join(f'{x:.6g}' for x in cm)}] m is {float(np.broadcast_to(distance, excess.shape)[index]):.6g} m "
        f"from the grasping end effector {name!r} at [{', '.join(f'{x:.6g}' for x in hand)}] m (inertial), more than "
        f"{GRASP_REACH:g} of its radii of gyration ({GRASP_REACH:g} x {r_g:.3g} m): the hand is not on the target; give the "
        "target's position where the hand grasps it (inertial frame, m)"
    )


def _with_wheels(model: Model, state: State, target: Target, end_effector: str | int, joints: str) -> Impact:
    """:func:`impact` of a robot with reaction wheels: the impact of its wheel-joint model (the wheels joints of the
    spacecraft, :func:`freefloat.core.wheels.wheel_joint_model`), read back as the robot's (its state with the wheel
    speeds, the wheels' impulses apart)."""
    n = model.n_joints
    robot = state.resolve(model)
    inner = impact(
        wheel_joint_model(model),
        State._trusted(
            q=np.concatenate([robot.q, np.zeros_like(robot.wheel_speed)], axis=-1),
            qdot=np.concatenate([robot.qdot, robot.wheel_speed], axis=-1),
            omega=robot.omega,
            attitude=robot.attitude,
            r_cm=robot.r_cm,
            v_cm=robot.v_cm,
        ),
        target,
        end_effector,
        joints,
    )
    after = inner.state
    result = dataclasses.replace(
        inner,
        state=State._trusted(
            q=after.q[..., :n],
            qdot=after.qdot[..., :n],
            wheel_speed=after.qdot[..., n:],
            omega=after.omega,
            attitude=after.attitude,
            r_cm=after.r_cm,
            v_cm=after.v_cm,
        ),
        joint_impulse=inner.joint_impulse[..., :n],
        wheel_impulse=inner.joint_impulse[..., n:],
        robot=model,
    )
    if not result.shape:
        _ = result.model
    return result
