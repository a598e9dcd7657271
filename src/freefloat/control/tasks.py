"""Task coordinates z1 of 1991 eq. 22, their errors, rates, Jacobian J_z (eq. 23) and bias Jdot_z zdot0.

A :class:`TaskSpace` lists what is controlled: positions of points (the end
effectors, the spacecraft CM) and orientations of bodies, all in the inertial
frame ``I``. Its coordinates ``z`` and its velocities ``zdot = J_z zdot0`` are
laid out item by item:

=====================  ==================================  ===========================================
item                   z rows                               zdot rows
=====================  ==================================  ===========================================
position               [x, y, z] (planar: [x, y])           velocity of the point
orientation euler321   Θ = [roll, pitch, yaw] (eq. 11)      dΘ/dt = S(Θ)⁻¹ ω (eq. 11, S of eq. 12)
orientation quaternion [x, y, z, w] (scalar last)           ω (inertial; a "basic Jacobian" row set)
orientation, planar    θ (the yaw)                          ω_z
=====================  ==================================  ===========================================

So ``size`` (rows of z) and ``dim`` (rows of zdot, of J_z, of the errors and
gains) differ only for quaternions. Errors (1991 eq. 26, e = z1,des - z1) are
differences, with Euler angles wrapped to (-π, π] and, for quaternions, the
vector part of the inertial error rotation q_e = q_des ⊗ q⁻¹ times 2 sign(w_e)
(≈ the rotation vector for small errors, so that ė ≈ ω_des - ω).

``TaskSpace.paper1991(model)`` is eq. 22 (each end effector's position and
orientation, then the spacecraft's); ``TaskSpace.planar_1991(model)`` is the §V
z1 = [x_s, y_s, θ, x_E, y_E] (eq. 31). Every method takes a :class:`~freefloat.State`
whose fields may carry leading batch axes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from .. import engine
from ..core.conventions import attitude_matrix, euler321_from_matrix, euler321_rate_matrix
from ..core.errors import ShapeError
from ..core.model import Model
from ..core.state import State

__all__ = ["TaskItem", "TaskSpace"]

ORIENTATIONS = ("euler321", "quaternion")


@dataclass(frozen=True)
class TaskItem:
    """One controlled quantity: the inertial position of a point, or the orientation of a body.

    ``point`` is in the frame of ``body`` (for orientations it is unused).
    ``name`` is how targets and labels refer to it, e.g. ``"ee.position"``.
    """

    name: str
    kind: str  # "position" | "orientation"
    body: int
    point: tuple[float, float, float] = (0.0, 0.0, 0.0)


def _wrap(angle: np.ndarray) -> np.ndarray:
    return (np.asarray(angle) + np.pi) % (2.0 * np.pi) - np.pi


def _euler_rate_derivative(theta: np.ndarray, theta_dot: np.ndarray) -> np.ndarray:
    """dS/dt for S of 1991 eq. 12 (as derived, see docs/paper-notes.md), (..., 3, 3)."""
    t2, t3 = theta[..., 1], theta[..., 2]
    d2, d3 = theta_dot[..., 1], theta_dot[..., 2]
    s2, c2, s3, c3 = np.sin(t2), np.cos(t2), np.sin(t3), np.cos(t3)
    out = np.zeros((*theta.shape[:-1], 3, 3))
    out[..., 0, 0] = -s2 * c3 * d2 - c2 * s3 * d3
    out[..., 1, 0] = -s2 * s3 * d2 + c2 * c3 * d3
    out[..., 2, 0] = -c2 * d2
    out[..., 0, 1] = -c3 * d3
    out[..., 1, 1] = -s3 * d3
    return out


@dataclass(frozen=True, eq=False)
class _Kinematics:
    """Everything a controller needs at one (batch of) state(s), flat batch axis first."""

    z: np.ndarray  # (C, size)
    jacobian: np.ndarray  # (C, dim, 6 + N)
    zdot: np.ndarray  # (C, dim)
    bias: np.ndarray | None  # (C, dim): Jdot_z zdot0


@dataclass(frozen=True, eq=False)
class TaskSpace:
    """The output coordinates z1 of 1991 eq. 22 for a model; see the module docstring for the layout.

    Build it with :meth:`paper1991`, :meth:`planar_1991` or :meth:`create`. ``orientation``
    is ``"euler321"`` (eq. 11; singular at ±90° pitch) or ``"quaternion"``.
    ``planar`` keeps x, y and the yaw θ of every item (the model must be planar
    and the motion must stay in its plane).
    """

    model: Model
    items: tuple[TaskItem, ...]
    orientation: str = "euler321"
    planar: bool = False
    _z_slices: tuple[slice, ...] = field(init=False, repr=False)
    _v_slices: tuple[slice, ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if self.orientation not in ORIENTATIONS:
            raise ValueError(f"orientation: expected 'euler321' or 'quaternion', got {self.orientation!r}")
        if not self.items:
            raise ValueError("items: a task needs at least one item (a position or an orientation)")
        if self.planar and not self.model.is_planar:
            raise ValueError(
                f"planar: model {self.model.name!r} is not planar (joint axes not all along the spacecraft z axis); use planar=False"
            )
        names = [it.name for it in self.items]
        if len(set(names)) != len(names):
            raise ValueError(f"items: duplicate item names {names}; every item needs its own name")
        z_sl, v_sl = [], []
        zi = vi = 0
        for it in self.items:
            if it.kind not in ("position", "orientation"):
                raise ValueError(f"items[{it.name!r}].kind: expected 'position' or 'orientation', got {it.kind!r}")
            if not 0 <= it.body < self.model.n_bodies:
                raise ValueError(f"items[{it.name!r}].body: {it.body} is not a body index (0..{self.model.n_bodies - 1})")
            nz, nv = self._rows(it)
            z_sl.append(slice(zi, zi + nz))
            v_sl.append(slice(vi, vi + nv))
            zi, vi = zi + nz, vi + nv
        object.__setattr__(self, "_z_slices", tuple(z_sl))
        object.__setattr__(self, "_v_slices", tuple(v_sl))

    # ------------------------------------------------------------ construction
    @classmethod
    def create(
        cls,
        model: Model,
        *,
        end_effectors: Any = None,
        end_effector_orientation: bool = True,
        spacecraft: bool = True,
        spacecraft_orientation: bool = True,
        orientation: str = "euler321",
        planar: bool = False,
        spacecraft_first: bool | None = None,
    ) -> TaskSpace:
        """z1 with the chosen end effectors (default all) and the spacecraft CM.

        ``end_effector_orientation=False`` gives position-only end-effector rows;
        ``spacecraft=False`` drops the spacecraft rows (``spacecraft_orientation=False``
        keeps only its position). ``spacecraft_first`` (default: ``planar``) puts the
        spacecraft rows first, as in the §V example (eq. 31); otherwise eq. 22's order.
        """
        if end_effectors is None:
            ees = list(range(model.n_end_effectors))
        else:
            ees = [model.end_effector_index(e) for e in (end_effectors if isinstance(end_effectors, (list, tuple)) else [end_effectors])]
        ee_items: list[TaskItem] = []
        for e in ees:
            name = model.end_effector_names[e]
            body = int(model.end_effector_body[e])
            ee_items.append(TaskItem(f"{name}.position", "position", body, tuple(float(x) for x in model.end_effector_point[e])))  # type: ignore[arg-type]
            if end_effector_orientation:
                ee_items.append(TaskItem(f"{name}.orientation", "orientation", body))
        sc_items: list[TaskItem] = []
        if spacecraft:
            sc_items.append(TaskItem("spacecraft.position", "position", 0, tuple(float(x) for x in model.com[0])))  # type: ignore[arg-type]
            if spacecraft_orientation:
                sc_items.append(TaskItem("spacecraft.orientation", "orientation", 0))
        first = planar if spacecraft_first is None else spacecraft_first
        items = sc_items + ee_items if first else ee_items + sc_items
        return cls(model, tuple(items), orientation=orientation, planar=planar)

    @classmethod
    def paper1991(cls, model: Model, *, orientation: str = "euler321") -> TaskSpace:
        """1991 eq. 22: z1 = [r_E, Θ_E (each end effector), r_S, Θ_S], 12 rows for one end effector."""
        return cls.create(model, orientation=orientation)

    @classmethod
    def planar_1991(cls, model: Model) -> TaskSpace:
        """1991 eq. 31 (§V): z1 = [x_s, y_s, θ, x_E, y_E] (one pair per end effector)."""
        return cls.create(model, end_effector_orientation=False, planar=True)

    # ------------------------------------------------------------ layout
    def _rows(self, item: TaskItem) -> tuple[int, int]:
        if item.kind == "position":
            return (2, 2) if self.planar else (3, 3)
        if self.planar:
            return 1, 1
        return (3, 3) if self.orientation == "euler321" else (4, 3)

    @property
    def size(self) -> int:
        """Rows of z (a quaternion counts 4)."""
        return self._z_slices[-1].stop

    @property
    def dim(self) -> int:
        """Rows of zdot, of J_z and of the errors (a quaternion's rate counts 3)."""
        return self._v_slices[-1].stop

    @property
    def labels(self) -> list[str]:
        """One label per row of zdot (and of the errors): e.g. ``spacecraft.position.x``, ``ee.orientation.yaw``."""
        out = []
        for it in self.items:
            if it.kind == "position":
                axes = "xy" if self.planar else "xyz"
            elif self.planar:
                axes = ("theta",)  # type: ignore[assignment]
            elif self.orientation == "euler321":
                axes = ("roll", "pitch", "yaw")  # type: ignore[assignment]
            else:
                axes = ("wx", "wy", "wz")  # type: ignore[assignment]
            out += [f"{it.name}.{a}" for a in axes]
        return out

    def item_slices(self, name: str) -> tuple[slice, slice]:
        """(rows of z, rows of zdot) of the item called ``name``."""
        for it, zs, vs in zip(self.items, self._z_slices, self._v_slices, strict=True):
            if it.name == name:
                return zs, vs
        raise KeyError(f"task has no item {name!r}; items: {', '.join(it.name for it in self.items)}")

    # ------------------------------------------------------------ kinematics
    def _evaluate(self, state: State, need_bias: bool) -> _Kinematics:
        s = state.resolve(self.model)
        q = np.asarray(s.q)
        batch = q.shape[:-1]
        c = int(np.prod(batch, dtype=int))
        n = self.model.n_joints
        qf = q.reshape(c, n)
        quat = np.asarray(s.attitude).reshape(c, 4)
        t0 = attitude_matrix(quat)
        r_cm = np.asarray(s.r_cm).reshape(c, 3)
        vel = np.asarray(s.velocity).reshape(c, 6 + n)
        rot, _ = engine.frames(self.model, qf)  # ⁰T_k (C, B, 3, 3)
        # every item's point (an orientation item: its body's origin): J+ rows, positions and Jdot+ zdot0 by the engine
        bodies = np.array([it.body for it in self.items], dtype=np.int64)
        points = np.array([it.point if it.kind == "position" else (0.0, 0.0, 0.0) for it in self.items], dtype=float).reshape(-1, 3)
        j_plus = engine.point_jacobians(self.model, qf, bodies, points)  # (C, I, 6, 6 + N), spacecraft frame (1991 eqs. 7-10)
        rho = engine.points(self.model, qf, bodies, points)  # (C, I, 3) from the system CM
        biases = engine.point_biases(self.model, qf, vel, bodies, points) if need_bias else None  # (C, I, 6)
        z = np.zeros((c, self.size))
        jac = np.zeros((c, self.dim, 6 + n))
        bias = np.zeros((c, self.dim)) if need_bias else None
        for p, (it, zs, vs) in enumerate(zip(self.items, self._z_slices, self._v_slices, strict=True)):
            if it.kind == "position":
                full = j_plus[:, p, 0:3].copy()
                full[:, :, 3:] = t0 @ full[:, :, 3:]  # 1991 eq. 9: rows into the inertial frame
                pos = r_cm + np.einsum("cij,cj->ci", t0, rho[:, p])
                rows = slice(0, 2) if self.planar else slice(0, 3)
                z[:, zs] = pos[:, rows]
                jac[:, vs] = full[:, rows]
                if bias is not None:
                    assert biases is not None
                    bias[:, vs] = np.einsum("cij,cj->ci", t0, biases[:, p, 0:3])[:, rows]
                continue
            # orientation of body it.body: R = T0 ⁰T_k, omega_k = T0 (omega0 + F_k qdot)
            r_body = t0 @ rot[:, it.body]
            w_jac = t0 @ j_plus[:, p, 3:6]  # [0, 1, J22] (1991 eq. 10) into the inertial frame
            omega_i = np.einsum("cij,cj->ci", w_jac, vel)
            w_bias = np.einsum("cij,cj->ci", t0, biases[:, p, 3:6]) if biases is not None else None
            if self.planar:
                z[:, zs] = np.arctan2(r_body[:, 1, 0], r_body[:, 0, 0])[:, None]
                jac[:, vs] = w_jac[:, 2:3]
                if bias is not None:
                    assert w_bias is not None
                    bias[:, vs] = w_bias[:, 2:3]
            elif self.orientation == "euler321":
                theta = euler321_from_matrix(r_body)
                s_mat = euler321_rate_matrix(theta)
                z[:, zs] = theta
                jac[:, vs] = np.linalg.solve(s_mat, w_jac)
                if bias is not None:
                    assert w_bias is not None
                    theta_dot = np.linalg.solve(s_mat, omega_i[..., None])[..., 0]
                    s_dot = _euler_rate_derivative(theta, theta_dot)
                    bias[:, vs] = np.linalg.solve(s_mat, (w_bias - np.einsum("cij,cj->ci", s_dot, theta_dot))[..., None])[..., 0]
            else:
                z[:, zs] = Rotation.from_matrix(r_body).as_quat()
                jac[:, vs] = w_jac
                if bias is not None:
                    bias[:, vs] = w_bias
        zdot = np.einsum("cij,cj->ci", jac, vel)
        return _Kinematics(
            z.reshape(*batch, self.size),
            jac.reshape(*batch, self.dim, 6 + n),
            zdot.reshape(*batch, self.dim),
            None if bias is None else bias.reshape(*batch, self.dim),
        )

    def coordinates(self, state: State) -> np.ndarray:
        """z1 (..., size): inertial positions and orientations (see the module docstring)."""
        return self._evaluate(state, False).z

    def jacobian(self, state: State) -> np.ndarray:
        """J_z of 1991 eq. 23, (..., dim, 6 + N): zdot1 = J_z zdot0 (rows inertial)."""
        return self._evaluate(state, False).jacobian

    def velocity(self, state: State) -> np.ndarray:
        """zdot1 = J_z zdot0 (..., dim)."""
        return self._evaluate(state, False).zdot

    def bias(self, state: State) -> np.ndarray:
        """Jdot_z zdot0 (..., dim): zddot1 at zddot0 = 0 (the term that makes C~ of eq. 24)."""
        out = self._evaluate(state, True).bias
        assert out is not None
        return out

    def evaluate(self, state: State, *, bias: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
        """(z1, J_z, zdot1, Jdot_z zdot0 or None) in one pass over the kinematics."""
        k = self._evaluate(state, bias)
        return k.z, k.jacobian, k.zdot, k.bias

    # ------------------------------------------------------------ errors and targets
    def error(self, desired: Any, actual: Any) -> np.ndarray:
        """e = desired ⊖ actual (1991 eq. 26), (..., dim); see the module docstring for orientations."""
        zd = self._z_array(desired, "desired")
        z = self._z_array(actual, "actual")
        batch = np.broadcast_shapes(zd.shape[:-1], z.shape[:-1])
        out = np.zeros((*batch, self.dim))
        for it, zs, vs in zip(self.items, self._z_slices, self._v_slices, strict=True):
            diff = zd[..., zs] - z[..., zs]
            if it.kind == "position":
                out[..., vs] = diff
            elif self.planar or self.orientation == "euler321":
                out[..., vs] = _wrap(diff)
            else:
                qd = np.broadcast_to(zd[..., zs], (*batch, 4)).reshape(-1, 4)
                qa = np.broadcast_to(z[..., zs], (*batch, 4)).reshape(-1, 4)
                qe = (Rotation.from_quat(qd) * Rotation.from_quat(qa).inv()).as_quat()
                sign = np.where(qe[:, 3] < 0.0, -1.0, 1.0)
                out[..., vs] = (2.0 * sign[:, None] * qe[:, 0:3]).reshape(*batch, 3)
        return out

    def interpolate(self, start: Any, goal: Any, s: Any) -> np.ndarray:
        """z on the straight line from ``start`` to ``goal`` at path parameter s (scalar in [0, 1]).

        Positions and angles move linearly (angles along the shortest wrapped
        difference); quaternions by slerp: q(s) = exp(s φ) q_start, φ the inertial
        rotation vector from start to goal. The rate of z along s is
        :meth:`difference` (constant).
        """
        z0 = self._z_array(start, "start")
        z1 = self._z_array(goal, "goal")
        s = float(s)
        out = np.array(z0, dtype=float)
        for it, zs, _ in zip(self.items, self._z_slices, self._v_slices, strict=True):
            if it.kind == "position":
                out[..., zs] = z0[..., zs] + s * (z1[..., zs] - z0[..., zs])
            elif self.planar or self.orientation == "euler321":
                out[..., zs] = z0[..., zs] + s * _wrap(z1[..., zs] - z0[..., zs])
            else:
                phi = (Rotation.from_quat(z1[..., zs]) * Rotation.from_quat(z0[..., zs]).inv()).as_rotvec()
                out[..., zs] = (Rotation.from_rotvec(s * phi) * Rotation.from_quat(z0[..., zs])).as_quat()
        return out

    def difference(self, goal: Any, start: Any) -> np.ndarray:
        """d/ds of :meth:`interpolate` (..., dim): the straight-line direction in zdot coordinates."""
        z0 = self._z_array(start, "start")
        z1 = self._z_array(goal, "goal")
        out = self.error(z1, z0)
        for it, zs, vs in zip(self.items, self._z_slices, self._v_slices, strict=True):
            if it.kind == "orientation" and not self.planar and self.orientation == "quaternion":
                out[..., vs] = (Rotation.from_quat(z1[..., zs]) * Rotation.from_quat(z0[..., zs]).inv()).as_rotvec()
        return out

    def target(self, **parts: Any) -> np.ndarray:
        """A z1 vector from named parts, e.g. ``target(ee_position=[1, 2, 0], spacecraft_orientation=Rotation...)``.

        Keyword names are item names with ``.`` replaced by ``_``. Orientations
        take a scipy ``Rotation``, a 3x3 matrix, a quaternion [x, y, z, w], Euler
        3-2-1 angles [roll, pitch, yaw] (rad, ``euler321`` tasks) or, for planar
        tasks, the angle θ. Every item must be given.
        """
        z = np.zeros(self.size)
        given = dict(parts)
        for it, zs, _ in zip(self.items, self._z_slices, self._v_slices, strict=True):
            key = it.name.replace(".", "_")
            if key not in given:
                raise ValueError(
                    f"target: missing {key}=...; a target needs every item: {', '.join(i.name.replace('.', '_') for i in self.items)}"
                )
            value = given.pop(key)
            z[zs] = self._item_value(it, value, key)
        if given:
            raise TypeError(f"target: unknown items {sorted(given)}; items: {', '.join(i.name.replace('.', '_') for i in self.items)}")
        return z

    def _item_value(self, it: TaskItem, value: Any, key: str) -> np.ndarray:
        if it.kind == "position":
            arr = np.asarray(value, dtype=float)
            want = 2 if self.planar else 3
            if arr.shape != (want,):
                raise ShapeError(f"{key}: expected a position of shape ({want},) (inertial frame, m), got {arr.shape}")
            return arr
        if self.planar:
            arr = np.asarray(value, dtype=float)
            if arr.size != 1:
                raise ShapeError(f"{key}: a planar orientation is one angle θ (rad), got shape {arr.shape}")
            return arr.reshape(1)
        if isinstance(value, Rotation):
            rot = value
        else:
            arr = np.asarray(value, dtype=float)
            if arr.shape == (3, 3):
                rot = Rotation.from_matrix(arr)
            elif arr.shape == (4,):
                if abs(np.linalg.norm(arr) - 1.0) > 1e-6:
                    raise ValueError(f"{key}: quaternion norm {np.linalg.norm(arr):.6g} is not 1; give a unit quaternion [x, y, z, w]")
                rot = Rotation.from_quat(arr)
            elif arr.shape == (3,) and self.orientation == "euler321":
                return arr
            else:
                raise ShapeError(f"{key}: expected a Rotation, a 3x3 matrix, a quaternion (4,) or Euler 3-2-1 angles (3,), got {arr.shape}")
        if self.orientation == "euler321":
            return euler321_from_matrix(rot.as_matrix())
        return np.asarray(rot.as_quat())

    def _z_array(self, value: Any, name: str) -> np.ndarray:
        arr = np.asarray(value, dtype=float)
        if arr.ndim == 0 or arr.shape[-1] != self.size:
            raise ShapeError(
                f"{name}: expected shape (..., {self.size}) (task coordinates {', '.join(it.name for it in self.items)}), got {arr.shape}"
            )
        return arr

    def check_target(self, value: Any, name: str = "target") -> np.ndarray:
        """Validate a z1 target: shape, finite, unit quaternions, Euler pitch away from ±90°, and reach.

        Reach: when the task holds the spacecraft position, every end-effector
        position must lie within the arm's reach of the spacecraft (from the
        spacecraft CM, or from the arm's mount when the spacecraft orientation is
        in the task too). Raises ``ValueError`` naming the field and the fix.
        """
        z = self._z_array(value, name)
        if z.ndim != 1:
            raise ShapeError(f"{name}: expected one target of shape ({self.size},), got {z.shape}")
        if not np.all(np.isfinite(z)):
            raise ValueError(f"{name}: has NaN or infinite entries; give finite task coordinates")
        for it, zs, _ in zip(self.items, self._z_slices, self._v_slices, strict=True):
            if it.kind != "orientation" or self.planar:
                continue
            if self.orientation == "quaternion" and abs(np.linalg.norm(z[zs]) - 1.0) > 1e-6:
                raise ValueError(
                    f"{name}[{it.name}]: quaternion norm {np.linalg.norm(z[zs]):.6g} is not 1; give a unit quaternion [x, y, z, w]"
                )
            if self.orientation == "euler321" and abs(np.cos(z[zs][1])) < 1e-6:
                raise ValueError(
                    f"{name}[{it.name}]: pitch {np.degrees(z[zs][1]):.3f}° is the Euler 3-2-1 representation singularity; "
                    "use TaskSpace(..., orientation='quaternion')"
                )
        self._check_reach(z, name)
        return z

    def _check_reach(self, z: np.ndarray, name: str) -> None:
        names = [it.name for it in self.items]
        if "spacecraft.position" not in names:
            return
        zs_pos, _ = self.item_slices("spacecraft.position")
        sc_pos = z[zs_pos]
        sc_rot = None
        if "spacecraft.orientation" in names:
            zs_o, _ = self.item_slices("spacecraft.orientation")
            if self.planar:
                sc_rot = Rotation.from_euler("z", z[zs_o][0]).as_matrix()[:2, :2]
            elif self.orientation == "euler321":
                sc_rot = Rotation.from_euler("ZYX", z[zs_o][::-1]).as_matrix()
            else:
                sc_rot = Rotation.from_quat(z[zs_o]).as_matrix()
        model = self.model
        for it, zs, _ in zip(self.items, self._z_slices, self._v_slices, strict=True):
            if it.kind != "position" or it.body == 0:
                continue
            chain = [it.body]
            while int(model.parent[chain[-1]]) != 0:
                chain.append(int(model.parent[chain[-1]]))
            chain.reverse()  # first body after the spacecraft ... the point's body
            if any(model.body_joint_prismatic[k - 1] for k in chain):
                continue  # segment lengths change with a sliding joint: this quick check covers turning chains only
            mount = model.joint_origin[chain[0]] - model.com[0]  # spacecraft frame, from the spacecraft CM
            segments = [float(np.linalg.norm(model.joint_origin[k])) for k in chain[1:]] + [float(np.linalg.norm(it.point))]
            reach_max = float(sum(segments))
            reach_min = max(0.0, 2.0 * max(segments) - reach_max)
            if sc_rot is None:
                dist = float(np.linalg.norm(z[zs] - sc_pos))
                reach_max += float(np.linalg.norm(mount[: len(z[zs])] if self.planar else mount))
                reach_min = 0.0
                origin = "the spacecraft CM"
            else:
                m = mount[:2] if self.planar else mount
                dist = float(np.linalg.norm(z[zs] - sc_pos - sc_rot @ m))
                origin = "the arm's mount on the spacecraft"
            slack = 1e-9 * (1.0 + reach_max)
            if dist > reach_max + slack or dist < reach_min - slack:
                raise ValueError(
                    f"{name}[{it.name}]: unreachable: {dist:.4g} m from {origin} at the target spacecraft pose, "
                    f"but the arm reaches {reach_min:.4g}-{reach_max:.4g} m; move the spacecraft target closer or the "
                    "end-effector target into reach"
                )
