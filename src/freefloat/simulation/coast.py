"""The free motion of a target before it is grasped: :func:`coast` (a torque-free rigid body).

No force and no torque act on the target (``ff.capture.Target``): its CM moves uniformly,

    p(t) = p0 + v0 t,      v(t) = v0                                            (inertial frame)

and its angular momentum about the CM, L = R I Rᵀ ω (inertial frame), is constant, while the body turns
by Euler's equations I ω̇_b = -ω_b x I ω_b (ω_b in the target's frame). Because L is constant, the
attitude alone carries the rotation: with R(t) the rotation from the target's frame to the inertial one
(the unit quaternion q = [x, y, z, w], scalar last),

    ω_b = I⁻¹ Rᵀ L,        q̇ = ½ q ⊗ [ω_b; 0]                                    (1)

which is Euler's equations with their first integral L built in. (1) is integrated once over the whole
span by scipy's ``solve_ivp`` (DOP853, ``rtol`` 1e-12 by default) with dense output, so the target is known
at any instant (output times, the event function of a capture); the quaternion is normalised where it is
read. The angular momentum is then constant to rounding by construction, and the kinetic energy
½ Lᵀ R I⁻¹ Rᵀ L to the integrator's tolerance (tests/simulation/test_capture_event.py checks both, and
an axisymmetric target against its closed form: R(t) = exp(t L/I_t) R0 exp(-t (I_a - I_t)/I_t ω3 e3)).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from ..core.errors import SimulationError
from ..core.target import Target

__all__ = ["Coast", "coast"]


class Coast:
    """A target coasting from t = 0 to ``duration`` (:func:`coast`); :meth:`at` gives it at any instant in between."""

    def __init__(self, target: Target, duration: float, rtol: float = 1e-12) -> None:
        if not isinstance(target, Target):
            raise TypeError(f"target: expected a freefloat.capture.Target, got {type(target).__name__}")
        if target.shape:
            raise ValueError(f"target: expected one target, got a batch of shape {target.shape}")
        self.target = target
        self.duration = float(duration)
        self.rtol = float(rtol)
        self.momentum_cm = target.momentum[3:]  # L about the CM, inertial frame: constant
        self._inverse = np.linalg.inv(target.inertia)
        spin = float(np.linalg.norm(target.angular_velocity))
        self._solution: Any = None
        if self.duration > 0.0 and spin > 0.0:
            sol = solve_ivp(
                self._rate, (0.0, self.duration), target.attitude, method="DOP853", rtol=self.rtol, atol=self.rtol * 1e-3, dense_output=True
            )
            if sol.status != 0:
                raise SimulationError(f"the target's torque-free motion could not be integrated over {self.duration:g} s: {sol.message}")
            self._solution = sol.sol

    def _rate(self, t: float, quat: np.ndarray) -> np.ndarray:
        """dq/dt of (1): ½ q ⊗ [ω_b; 0] with ω_b = I⁻¹ Rᵀ L (q = [x, y, z, w])."""
        vec, w = quat[:3], quat[3]
        r_t = Rotation.from_quat(quat).as_matrix().T
        omega_b = self._inverse @ (r_t @ self.momentum_cm)
        return 0.5 * np.concatenate([w * omega_b + np.cross(vec, omega_b), [-(vec @ omega_b)]])

    def attitude(self, t: Any) -> np.ndarray:
        """The target's attitude quaternion(s) [x, y, z, w] at ``t`` (s, scalar or (T,)): (..., 4), unit."""
        times = np.asarray(t, dtype=float)
        self._check_span(times)
        if self._solution is None:
            return np.array(np.broadcast_to(self.target.attitude, (*times.shape, 4)))
        quat = np.moveaxis(np.asarray(self._solution(times)), 0, -1)
        return quat / np.linalg.norm(quat, axis=-1, keepdims=True)

    def at(self, t: Any) -> Target:
        """The target at ``t`` (s, scalar: one :class:`Target`; (T,): a batch of T): its CM moved uniformly, its
        attitude and angular velocity (inertial, R I⁻¹ Rᵀ L) from (1)."""
        times = np.asarray(t, dtype=float)
        quat = self.attitude(times)
        rot = Rotation.from_quat(quat.reshape(-1, 4)).as_matrix()
        omega = np.einsum("kij,jl,kml,m->ki", rot, self._inverse, rot, self.momentum_cm)  # R I⁻¹ Rᵀ L
        target = self.target
        return Target(
            mass=np.broadcast_to(target.mass, times.shape),
            inertia=np.broadcast_to(target.inertia, (*times.shape, 3, 3)),
            position=target.position + times[..., None] * target.velocity,
            attitude=quat,
            velocity=np.broadcast_to(target.velocity, (*times.shape, 3)),
            angular_velocity=omega.reshape((*times.shape, 3)),
        )

    def point(self, t: float, point: np.ndarray) -> np.ndarray:
        """A point fixed in the target (``point`` (3,) m in its frame, from its CM) at ``t``: (3,) m, inertial frame."""
        quat = self.attitude(t)
        return self.target.position + t * self.target.velocity + Rotation.from_quat(quat).as_matrix() @ point

    def _check_span(self, times: np.ndarray) -> None:
        if times.size and (np.min(times) < 0.0 or np.max(times) > self.duration * (1.0 + 1e-12)):
            asked = f"{times.min():g} to {times.max():g} s"
            raise ValueError(f"t: the target's motion is known from 0 to {self.duration:g} s, asked at {asked}")


def coast(target: Target, duration: float, *, rtol: float = 1e-12) -> Coast:
    """The torque-free motion of ``target`` (one ``ff.capture.Target``) over [0, ``duration``] s.

    Returns a :class:`Coast`: ``.at(t)`` the target at ``t`` (a :class:`Target`, a batch for an array of
    times), ``.attitude(t)``, ``.point(t, p)`` a point of the target in the inertial frame. Its CM moves
    uniformly; its attitude follows Euler's equations with its angular momentum L (about its CM, inertial
    frame) constant, integrated by DOP853 to ``rtol`` (equations in the module docstring).

    Examples
    --------
    >>> import freefloat as ff
    >>> t = ff.capture.Target(mass=10.0, inertia=[1.0, 2.0, 3.0], position=[0.0, 0.0, 0.0], angular_velocity=[0.1, 0.2, 0.3])
    >>> motion = ff.simulation.coast(t, 100.0)
    >>> bool(abs(motion.at(100.0).momentum - t.momentum).max() < 1e-14)
    True
    """
    try:
        span = float(duration)
    except (TypeError, ValueError):
        raise ValueError(f"duration: expected a number of seconds, got {duration!r}") from None
    if not np.isfinite(span) or span < 0.0:
        raise ValueError(f"duration: must be finite and >= 0, got {duration!r}")
    return Coast(target, span, rtol)
