"""Coordinated spacecraft/manipulator controllers of Papadopoulos & Dubowsky 1991, §IV.

Both act on task coordinates z1 (eq. 22, :class:`~freefloat.control.tasks.TaskSpace`)
measured inertially, with e = z1,des − z1 (eq. 26), and return the thruster
force and torque at the spacecraft CM (spacecraft frame) and the joint torques
as an :class:`~freefloat.Actuation`, through the inversion of eq. 21:

    [f_S; n_S; τ] = J_q⁻ᵀ Q_c                                           (eq. 30)

:class:`TransposedJacobianController` (eq. 29)
    Q_c = J_zᵀ (K_p e + K_d ė). No inverse of J_z: it keeps running at singular J_z.

:class:`OperationalSpaceController` (eq. 27)
    Q_c = J_zᵀ { H~ (K_p e + K_d ė + z̈1,des) + C~ } with, for a general (m x n) J_z,

        H~ = (J_z H+⁻¹ J_zᵀ)⁻¹                       (eq. 25 when J_z is square: J_z⁻ᵀ H+ J_z⁻¹)
        J̄  = H+⁻¹ J_zᵀ H~                            (dynamically consistent generalized inverse;
                                                       J̄ = J_z⁻¹ when J_z is square)
        C~ = J̄ᵀ C+ − H~ J̇_z ż0                       (eq. 24: J_z⁻ᵀ C+ − H~ J̇_z ż0 when square)

    With an exact model and full row rank J_z this gives z̈1 = K_p e + K_d ė + z̈1,des,
    i.e. ë + K_d ė + K_p e = 0 (eq. 28), for square and for redundant (m < n) J_z alike.
    (J_z H+⁻¹ J_zᵀ)⁻¹ is taken with a damped inverse: with r = σ_min/σ_max of J_z, ε =
    ``singular_tolerance`` and a_i the eigenvalues of J_z H+⁻¹ J_zᵀ, each 1/a_i becomes
    a_i/(a_i² + λ²), λ² = (1 − (r/ε)²) (ε a_max)² when r < ε, else 0: the exact inverse
    away from singularities, bounded (≤ 1/(2λ)) at them, continuous at r = ε.

Near a singular J_z (σ_min/σ_max of J_z below ``singular_tolerance``) both warn
with :class:`~freefloat.NearSingularWarning` (once each time they enter the
region) and keep running. For redundant tasks (m < 6 + N) the null-space motion
is not controlled by eqs. 27/29; ``null_space_damping`` (N m s per rad/s, default
0 = the paper's law) adds −(1 − J_zᵀ J̄ᵀ) d ż0, a damping that does not disturb the
task (eq. 27) or acts on the whole ż0 after removing its task part (eq. 29).

Actuation limits (``limits``, an :class:`~freefloat.ActuatorLimits`) saturate
each output component; the unsaturated values are in ``Actuation.extras``.

``torque_by="wheels"`` sends the spacecraft torque n_S to the reaction wheels instead of the thrusters
(:func:`freefloat.control.wheels.wheel_torques`, ``Actuation.wheel_torque``); ``force_by="none"`` gives no thruster
force (1991 §II: wheels for the attitude, thrusters or nothing for the CM).
"""

from __future__ import annotations

import copy
import dataclasses
import warnings
from typing import Any

import numpy as np

from ..core.conventions import attitude_matrix
from ..core.errors import NearSingularWarning, ShapeError
from ..core.model import Model
from ..core.state import Actuation, ActuatorLimits, State
from ..mechanics.dynamics import nonlinear_forces
from ..mechanics.forces import _actuation_0
from ..mechanics.momentum import system_inertia_matrix
from . import _compiled
from ._compiled import batch_call
from .desired import DesiredPoint, as_desired
from .tasks import TaskSpace
from .wheels import check_actuators, route_actuation

__all__ = ["OperationalSpaceController", "TransposedJacobianController", "actuation_of", "damped_inverse", "gain_matrix"]


def gain_matrix(value: Any, dim: int, name: str) -> np.ndarray:
    """A gain as a (dim, dim) symmetric positive definite matrix: from a scalar, a diagonal (dim,) or a matrix."""
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        mat = arr * np.eye(dim)
    elif arr.shape == (dim,):
        mat = np.diag(arr)
    elif arr.shape == (dim, dim):
        mat = arr
    else:
        raise ShapeError(f"{name}: expected a scalar, a diagonal of shape ({dim},) or a ({dim}, {dim}) matrix, got shape {arr.shape}")
    if not np.all(np.isfinite(mat)):
        raise ValueError(f"{name}: has NaN or infinite entries; give finite gains")
    if not np.allclose(mat, mat.T, rtol=1e-12, atol=1e-12 * max(1.0, float(np.max(np.abs(mat))))):
        raise ValueError(f"{name}: gain matrix is not symmetric; give a symmetric positive definite matrix (eq. 27 uses diagonal gains)")
    eig = np.linalg.eigvalsh(mat)
    if eig[0] <= 0.0:
        raise ValueError(
            f"{name}: gains must be positive definite (eq. 27), smallest eigenvalue {eig[0]:.6g}; give positive gains, e.g. {name}=30.0"
        )
    return mat


def damped_inverse(matrix: np.ndarray, closeness: float, tolerance: float) -> np.ndarray:
    """Inverse of a symmetric positive semidefinite matrix, damped near a singular J_z (see the module docstring).

    ``closeness`` is σ_min/σ_max of J_z; at or above ``tolerance`` the inverse is exact, below it each
    1/a_i becomes a_i/(a_i² + λ²) with λ² = (1 − (closeness/tolerance)²) (tolerance · a_max)².
    """
    a, v = np.linalg.eigh(matrix)
    a = np.maximum(a, 0.0)
    a_max = float(a[-1])
    if a_max <= 0.0:
        return np.zeros_like(matrix)
    lam2 = (1.0 - (closeness / tolerance) ** 2) * (tolerance * a_max) ** 2 if closeness < tolerance else 0.0
    with np.errstate(divide="ignore"):
        inv = np.where(a > 0.0, a / (a * a + lam2), 0.0) if lam2 > 0.0 else 1.0 / a
    return (v * inv) @ v.T


def actuation_of(
    model: Model,
    state: State,
    generalized_force: np.ndarray,
    limits: ActuatorLimits | None,
    extras: dict[str, Any],
    actuators: tuple[str, str] = ("thrusters", "thrusters"),
) -> Actuation:
    """The actuation that applies Q_c (6 + N, first block inertial) at the resolved ``state``: [f_S; n_S; τ] = J_q⁻ᵀ Q_c
    (1991 eq. 30), then saturated by ``limits``; ``extras`` (with the attitude matrix under ``"_t0"``) gains Q_c, the
    unsaturated values and ``saturated``. Every controller of :mod:`freefloat.control` ends here. ``actuators`` =
    (torque_by, force_by) (:mod:`freefloat.control.wheels`): the spacecraft torque to the reaction wheels (``"wheels"``,
    ``extras["wheel_torque"]``), the force to nobody (``"none"``)."""
    q = np.asarray(state.q, dtype=float)
    t0 = np.asarray(extras.pop("_t0"))
    q_0 = generalized_force.copy()
    q_0[0:3] = t0.T @ generalized_force[0:3]  # Q's first block into the spacecraft frame
    force, torque, tau = _actuation_0(model, q[None], q_0[None])
    force, torque, tau = force[0], torque[0], tau[0]
    extras.update(generalized_force=generalized_force, joint_torque=tau, spacecraft_force=force, spacecraft_torque=torque)
    force, torque, wheel = route_actuation(model, state, force, torque, actuators, extras)
    if limits is not None:
        tau, force, torque, saturated = limits.apply(tau, force, torque)
        extras["saturated"] = bool(saturated)
    return Actuation(joint_torque=tau, spacecraft_force=force, spacecraft_torque=torque, wheel_torque=wheel, extras=extras)


def _closeness(jac: np.ndarray) -> float:
    """σ_min/σ_max of J_z (0 when J_z has more rows than columns: the task is over-determined)."""
    sv = np.linalg.svd(jac, compute_uv=False)
    rows, cols = jac.shape
    return float(sv[-1] / sv[0]) if sv[0] > 0 and rows <= cols else 0.0


class _TaskController:
    """Shared parts of the two controllers (desired motion, gains, errors, J_q⁻ᵀ, limits, warnings)."""

    law = ""

    def __init__(
        self,
        model: Model,
        task: TaskSpace,
        desired: Any,
        kp: Any,
        kd: Any,
        *,
        limits: ActuatorLimits | None = None,
        singular_tolerance: float = 1e-2,
        null_space_damping: float = 0.0,
        torque_by: str = "thrusters",
        force_by: str = "thrusters",
    ) -> None:
        self.models = _compiled.models_of(model)  # one model, or payload variants per trajectory
        model = self.models[0]
        self.actuators = check_actuators(model, torque_by, force_by)
        if not isinstance(task, TaskSpace):
            raise TypeError(f"task: expected a freefloat.TaskSpace, got {type(task).__name__}")
        if task.model is not model:
            raise ValueError(f"task: built for model {task.model.name!r}, not for {model.name!r}; build the task from this model")
        self.model = model
        self.task = task
        self.desired = as_desired(desired)
        for z in getattr(self.desired, "targets", list)():
            for row in np.reshape(z, (-1, np.shape(z)[-1])) if np.ndim(z) == 2 else [z]:  # a set point per trajectory: (B, size)
                task.check_target(row, "desired")
        self.kp_rows = _compiled.gains(kp, task.dim, "kp", gain_matrix)  # (1 or B, dim, dim)
        self.kd_rows = _compiled.gains(kd, task.dim, "kd", gain_matrix)
        self.kp = self.kp_rows[0] if self.kp_rows.shape[0] == 1 else self.kp_rows
        self.kd = self.kd_rows[0] if self.kd_rows.shape[0] == 1 else self.kd_rows
        if not (np.isfinite(singular_tolerance) and 0.0 < singular_tolerance < 1.0):
            raise ValueError(f"singular_tolerance: expected a number in (0, 1), got {singular_tolerance!r}")
        if not (np.isfinite(null_space_damping) and null_space_damping >= 0.0):
            raise ValueError(f"null_space_damping: expected a non-negative number, got {null_space_damping!r}")
        if limits is not None and not isinstance(limits, ActuatorLimits):
            raise TypeError(f"limits: expected a freefloat ActuatorLimits, got {type(limits).__name__}")
        self.limits = limits
        self.singular_tolerance = float(singular_tolerance)
        self.null_space_damping = float(null_space_damping)
        self._near_singular = False

    # ------------------------------------------------------------ pieces
    def desired_point(self, t: float) -> DesiredPoint:
        """z1,des, ż1,des, z̈1,des at time t, checked against the task's sizes."""
        point = self.desired(float(t))
        z = np.asarray(point.z, dtype=float)
        if z.shape != (self.task.size,):
            raise ShapeError(f"desired(t={t:g}): z has shape {z.shape}; expected ({self.task.size},) ({', '.join(self.task.labels)})")
        rates = []
        for name, value in (("zdot", point.zdot), ("zddot", point.zddot)):
            arr = np.asarray(value, dtype=float)
            if arr.size == 0:
                arr = np.zeros(self.task.dim)
            if arr.shape != (self.task.dim,):
                raise ShapeError(f"desired(t={t:g}): {name} has shape {arr.shape}; expected ({self.task.dim},)")
            rates.append(arr)
        if not (np.all(np.isfinite(z)) and np.all(np.isfinite(rates[0])) and np.all(np.isfinite(rates[1]))):
            raise ValueError(f"desired(t={t:g}): returned NaN or infinite values")
        return DesiredPoint(z, rates[0], rates[1])

    def _warn_singular(self, ratio: np.ndarray) -> None:
        """Warn (once each time it enters the region) when σ_min/σ_max of J_z is below the tolerance (any trajectory)."""
        worst = float(np.min(ratio))
        near = worst < self.singular_tolerance
        if near and not self._near_singular:
            warnings.warn(
                f"{self.law}: J_z (1991 eq. 23) is near singular (sigma_min/sigma_max = {worst:.2e} < {self.singular_tolerance:g}); "
                "the task loses a direction there and the controller keeps running without it",
                NearSingularWarning,
                stacklevel=3,
            )
        self._near_singular = near

    def compiled_law(self, batch: int | None = None) -> Any:
        """The controller's law as arrays for the compiled loops, for a run of ``batch`` trajectories (None: one
        simulation), or None when its desired motion is a Python function. :func:`freefloat.simulate` and
        :func:`freefloat.rollout` run it in their compiled loops, with no Python per step."""
        return _compiled.task_law(self, batch)

    def compiled_run_done(self, law: Any) -> None:
        """After a compiled run of :meth:`compiled_law`: the near-singular warning, once, if J_z came near singular at a
        sample (the compiled loop cannot warn as it goes)."""
        self._near_singular = False
        self._warn_singular(law.lowest)

    def parameter_rows(self) -> dict[str, int]:
        """The number of rows of each parameter that may have one per trajectory (1: shared)."""
        desired = [len(z) if np.ndim(z) == 2 else 1 for z in getattr(self.desired, "targets", list)()]
        return {"kp": self.kp_rows.shape[0], "kd": self.kd_rows.shape[0], "model": len(self.models), "desired": max(desired, default=1)}

    @property
    def per_trajectory(self) -> bool:
        """Whether a parameter has one row per trajectory (gains, set points, models): then it runs on a batch of states."""
        return max(self.parameter_rows().values()) > 1

    def __call__(self, t: float, state: State) -> Actuation:
        """The actuation at time t (1991 eq. 30): thruster force and torque (spacecraft frame), joint torques.

        The numpy form of the law (``_generalized_force``, then :func:`actuation_of`): the readable reference that the
        compiled form of the same law, run inside the compiled loops of :func:`freefloat.simulate` and
        :func:`freefloat.rollout`, is checked against (tests/control/test_compiled.py). ``state`` may hold a batch of B
        states (a rollout): row b is computed with the per-trajectory parameters' row b, one state at a time."""
        state = state.resolve(self.model)
        if np.ndim(state.q) == 1:
            if self.per_trajectory:
                raise ShapeError(
                    "state: one state, but the controller has per-trajectory parameters (gains, set points or models with a "
                    "row per trajectory); give a batch of states, one per row, or run it in freefloat.rollout"
                )
            q_c, extras = self._generalized_force(float(t), state)
            return actuation_of(self.model, state, q_c, self.limits, extras, self.actuators)
        return batch_call(self, float(t), state)

    def generalized_force(self, t: float, state: State) -> np.ndarray:
        """Q_c (6 + N) in the zdot0 coordinates (first block inertial); (B, 6 + N) for a batch of states."""
        state = state.resolve(self.model)
        if np.ndim(state.q) == 1 and not self.per_trajectory:
            return self._generalized_force(float(t), state)[0]  # no J_q⁻ᵀ: Q_c is all that is asked
        return np.asarray(self(t, state).extras["generalized_force"])

    def row(self, b: int) -> _TaskController:
        """The controller of trajectory b: its row of every per-trajectory parameter (gains, set point, model)."""
        one = copy.copy(self)
        model = self.models[b if len(self.models) > 1 else 0]
        one.models, one.model = (model,), model
        one.task = self.task if model is self.task.model else dataclasses.replace(self.task, model=model)
        one.kp_rows, one.kd_rows = (r[b if r.shape[0] > 1 else 0][None] for r in (self.kp_rows, self.kd_rows))
        one.kp, one.kd = one.kp_rows[0], one.kd_rows[0]
        one.desired = _compiled.desired_row(self.desired, b)
        return one

    def _check_singular(self, jac: np.ndarray) -> float:
        ratio = _closeness(jac)
        self._warn_singular(np.asarray(ratio))
        return ratio

    def _generalized_force(self, t: float, state: State) -> tuple[np.ndarray, dict[str, Any]]:
        raise NotImplementedError


class TransposedJacobianController(_TaskController):
    """1991 eqs. 29-30: Q_c = J_zᵀ (K_p e + K_d ė), then [f_S; n_S; τ] = J_q⁻ᵀ Q_c.

    ``desired``: a set point (task coordinates), a desired motion
    (:mod:`freefloat.control.desired`) or a callable ``f(t)``. ``kp``, ``kd``: scalars,
    diagonals (task.dim,) or symmetric positive definite matrices. Never
    inverts J_z. Returns an :class:`~freefloat.Actuation` whose ``extras`` hold
    the error ``e``, its rate, Q_c and ``sigma_ratio`` (σ_min/σ_max of J_z).
    """

    law = "transposed-Jacobian controller (1991 eq. 29)"

    def _generalized_force(self, t: float, state: State) -> tuple[np.ndarray, dict[str, Any]]:
        des = self.desired_point(t)
        z, jac, zdot, _ = self.task.evaluate(state)
        e = self.task.error(des.z, z)
        edot = des.zdot - zdot
        q_c = jac.T @ (self.kp @ e + self.kd @ edot)
        ratio = self._check_singular(jac)
        if self.null_space_damping > 0.0:
            velocity = np.asarray(state.velocity)
            pinv = np.linalg.pinv(jac, rcond=self.singular_tolerance)
            q_c -= self.null_space_damping * (velocity - pinv @ (jac @ velocity))
        return q_c, {"error": e, "error_rate": edot, "sigma_ratio": ratio, "_t0": attitude_matrix(state.attitude)}


class OperationalSpaceController(_TaskController):
    """1991 eq. 27: Q_c = J_zᵀ {H~ (K_p e + K_d ė + z̈1,des) + C~}, with H~, C~ of eqs. 24-25.

    Arguments as :class:`TransposedJacobianController`. For non-square J_z the
    dynamically consistent generalized inverse is used (module docstring);
    near a singular J_z the inverse is damped and a
    :class:`~freefloat.NearSingularWarning` is issued. With an exact model the
    error obeys ë + K_d ė + K_p e = 0 (eq. 28).
    """

    law = "operational-space controller (1991 eq. 27)"

    def task_dynamics(self, state: State) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(H~, C~, J̄) of eqs. 24-25 at ``state`` (generalized for non-square J_z; damped near singular J_z)."""
        state = state.resolve(self.model)
        _, jac, _, bias = self.task.evaluate(state, bias=True)
        assert bias is not None
        return self._task_dynamics(state, jac, bias, _closeness(jac))

    def _task_dynamics(
        self, state: State, jac: np.ndarray, bias: np.ndarray, closeness: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q = np.asarray(state.q)
        h_plus = system_inertia_matrix(self.model, q)
        c_plus = nonlinear_forces(self.model, q, state.velocity)  # its r_cm rows are zero: no frame question there
        h_inv_jt = np.linalg.solve(h_plus, jac.T)
        h_tilde = damped_inverse(jac @ h_inv_jt, closeness, self.singular_tolerance)
        j_bar = h_inv_jt @ h_tilde
        c_tilde = j_bar.T @ c_plus - h_tilde @ bias
        return h_tilde, c_tilde, j_bar

    def _generalized_force(self, t: float, state: State) -> tuple[np.ndarray, dict[str, Any]]:
        des = self.desired_point(t)
        z, jac, zdot, bias = self.task.evaluate(state, bias=True)
        assert bias is not None
        e = self.task.error(des.z, z)
        edot = des.zdot - zdot
        ratio = self._check_singular(jac)
        h_tilde, c_tilde, j_bar = self._task_dynamics(state, jac, bias, ratio)
        command = self.kp @ e + self.kd @ edot + des.zddot
        q_c = jac.T @ (h_tilde @ command + c_tilde)
        if self.null_space_damping > 0.0:
            velocity = np.asarray(state.velocity)
            q_c -= self.null_space_damping * (velocity - jac.T @ (j_bar.T @ velocity))
        extras = {"error": e, "error_rate": edot, "sigma_ratio": ratio, "_t0": attitude_matrix(state.attitude)}
        return q_c, extras
