"""What is known of a run before it starts (private): :func:`check_run`, one call that returns a :class:`RunChecks`.

The checks of :func:`freefloat.simulate` that need the engine, made once, in this order:

1. the estimate of the run (:func:`~._guard.estimate_run`: steps, samples, outputs, memory and wall time, from the
   engine's timed state derivative) and the wall-clock budget it gives ``max_wall_time="auto"``; a
   :class:`~freefloat.core.errors.LongRunWarning` above ``warn_after`` seconds;
2. a :class:`~freefloat.JointPD` sampled every h against the exact one-sample map of a zero-order-hold PD on the
   free-floating joint inertia M = D_qq - D_qᵀ D⁻¹ D_q (the Schur complement of H+, 1991 eqs. 15-17:
   :func:`freefloat.mechanics.free_floating_joint_inertia`) at the initial angles: each joint alone
   (:func:`pd_gain_bounds`) and all together (:func:`pd_stability`);
3. fixed RK4 steps against the decay rate of each joint's damping and friction on its effective inertia (the diagonal
   of M; :func:`check_passive_step`).

M is computed once (one call of the mechanics, which calls the engine's H+) and shared by 2 and 3; each offending
check warns (:class:`~freefloat.core.errors.StiffGainsWarning`) and its lines are kept in the record.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.errors import LongRunWarning, StiffGainsWarning
from ..core.model import Model
from ..core.state_layout import Q_AT, span
from ..engine import FRICTION_SPEED
from ..mechanics.momentum import free_floating_joint_inertia
from ._guard import MIN_WALL_BUDGET, WALL_BUDGET_FACTOR, RunEstimate, estimate_run
from .pd import JointPD

__all__ = ["RK4_IMAGINARY_LIMIT", "RK4_REAL_LIMIT", "RunChecks", "check_passive_step", "check_run", "pd_gain_bounds", "pd_stability"]

#: RK4's stability limit on the negative real axis: a decay rate c (1/s) is integrated stably by steps dt with c dt below it.
RK4_REAL_LIMIT = 2.785
#: RK4's stability limit on the imaginary axis (2 sqrt 2): an oscillation of w (rad/s) is integrated stably by steps dt
#: with w dt below it.
RK4_IMAGINARY_LIMIT = 2.828

JointInertia = Callable[[Model, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class RunChecks:
    """What :func:`check_run` found before a run.

    ``estimate``: the run's cost (:class:`~._guard.RunEstimate`); ``wall_limit``: its wall-clock budget (s; None: no
    limit); ``stiff_gains``: one line per joint (then the coupled modes) where a sampled JointPD is unstable;
    ``stiff_passive``: one line per joint whose damping and friction the RK4 steps cannot follow. Each non-empty tuple
    was also warned of (StiffGainsWarning).
    """

    estimate: RunEstimate
    wall_limit: float | None
    stiff_gains: tuple[str, ...]
    stiff_passive: tuple[str, ...]


def check_run(
    model: Model,
    user: Model,
    x0: np.ndarray,
    controller: Any,
    duration: float,
    *,
    fixed_step: float | None,
    sample_period: float | None,
    output_period: float | None,
    warn_after: float | None,
    wall_time: float | str | None,
) -> RunChecks:
    """The pre-run checks of one simulation (module docstring), warned of and returned as one :class:`RunChecks`.

    ``model``: what the engine integrates (``user``'s reaction wheels as joints), ``x0`` its flat initial state;
    ``user``: the user's model, whose joints (the first N of ``model``) the controller drives; ``wall_time``: the
    checked ``max_wall_time`` (seconds, ``"auto"`` or None). The warnings point at the caller of
    :func:`freefloat.simulate` (this function is two calls below it).
    """
    estimate = estimate_run(model, duration, fixed_step=fixed_step, sample_period=sample_period, output_period=output_period)
    wall_limit = max(MIN_WALL_BUDGET, WALL_BUDGET_FACTOR * estimate.seconds) if isinstance(wall_time, str) else wall_time  # "auto"
    if warn_after is not None and estimate.seconds > warn_after:
        warnings.warn(
            f"this simulation will take long: {estimate.describe()} (over warn_after = {warn_after:g} s); "
            "it shows progress and Ctrl-C returns what was computed",
            LongRunWarning,
            stacklevel=4,
        )
    found: dict[int, np.ndarray] = {}  # M per model: the same model at the same angles (no wheels) is computed once

    def inertia(which: Model, q: np.ndarray) -> np.ndarray:
        if id(which) not in found:
            found[id(which)] = free_floating_joint_inertia(which, q, method="barycentric")  # one configuration: numpy, no kernel to compile
        return found[id(which)]

    gains = _stiff_gains(user, controller, np.array(x0[Q_AT : Q_AT + user.n_joints]), sample_period or fixed_step, inertia, stacklevel=5)
    passive = _stiff_passive(model, x0[span("q", model.n_joints)], fixed_step, inertia, stacklevel=5)
    return RunChecks(estimate, wall_limit, tuple(gains), tuple(passive))


def pd_gain_bounds(inertia: Any, period: float, kd: Any) -> tuple[np.ndarray, np.ndarray]:
    """Largest stable gains of a PD sampled every ``period`` (zero-order hold) on a free inertia m.

    For m q'' = u, u_k = -kp q_k - kd q'_k held over [kh, (k+1)h), the exact discrete map has
    trace 2 - a/2 - b and determinant 1 - b + a/2 with a = kp h^2/m, b = kd h/m; the Jury
    conditions give 0 < kd < 2 m / h and 0 < kp < 2 kd / h. Returns (kd_max, kp_max) with kp_max
    for the given kd, or for kd_max where kd is above it.
    """
    m = np.asarray(inertia, dtype=float)
    kd_max = 2.0 * m / period
    kd_eff = np.minimum(np.asarray(kd, dtype=float), kd_max)
    return kd_max, 2.0 * kd_eff / period


def _sampled_pd_map(inertia: np.ndarray, kp: np.ndarray, kd: np.ndarray, period: float) -> np.ndarray:
    """The exact one-sample map of M q'' = u, u held at -kp q_k - kd q'_k, on the state (q, q') (2N x 2N)."""
    n = inertia.shape[0]
    h, eye = period, np.eye(n)
    a_p = np.linalg.solve(inertia, np.diag(kp))
    a_d = np.linalg.solve(inertia, np.diag(kd))
    return np.block([[eye - 0.5 * h * h * a_p, h * eye - 0.5 * h * h * a_d], [-h * a_p, eye - h * a_d]])


def pd_stability(model: Model, kp: Any, kd: Any, q0: Any, period: float) -> tuple[float, float, int]:
    """The sampled joint PD, all joints together, linearised at the angles ``q0`` (zero rates, spacecraft free).

    Returns (spectral radius of the one-sample map, largest factor s <= 4 such that s kp, s kd is
    stable (radius < 1), the joint that moves most in the least stable mode). The radius is below 1
    exactly when the linearised sampled loop is stable; the coupling of the joints through the
    free-floating inertia makes it stricter than the per-joint bounds of :func:`pd_gain_bounds`.
    """
    return _stability(free_floating_joint_inertia(model, np.asarray(q0, dtype=float)), kp, kd, period)


def _stability(m: np.ndarray, kp: Any, kd: Any, period: float) -> tuple[float, float, int]:
    """:func:`pd_stability` on the free-floating joint inertia ``m`` (N, N)."""
    n = m.shape[0]
    kp_n = np.broadcast_to(np.asarray(kp, dtype=float), (n,))
    kd_n = np.broadcast_to(np.asarray(kd, dtype=float), (n,))

    def radius(scale: float) -> tuple[float, np.ndarray]:
        with np.errstate(over="ignore", invalid="ignore"):
            step = _sampled_pd_map(m, scale * kp_n, scale * kd_n, period)
        if not np.all(np.isfinite(step)):  # a period or gains so large that the map overflows: unstable
            return float("inf"), np.ones(n)
        values, vectors = np.linalg.eig(step)
        worst = int(np.argmax(np.abs(values)))
        return float(np.abs(values[worst])), np.abs(vectors[:n, worst])

    rho, mode = radius(1.0)
    lo, hi = 0.0, 4.0
    if radius(hi)[0] < 1.0:
        lo = hi
    else:
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if radius(mid)[0] < 1.0 else (lo, mid)
    return rho, lo, int(np.argmax(mode))


def _stiff_gains(model: Model, controller: Any, q0: np.ndarray, period: float | None, inertia: JointInertia, stacklevel: int) -> list[str]:
    """Where a :class:`~freefloat.JointPD` sampled every ``period`` is unstable, at the initial angles ``q0`` with the
    spacecraft free: each joint against :func:`pd_gain_bounds` on its effective inertia (the diagonal of
    ``inertia(model, q0)``, the free-floating joint inertia), and all joints together (:func:`pd_stability`). Warns
    (StiffGainsWarning, ``stacklevel`` as :func:`warnings.warn` counts it from here) and returns the lines, one per
    offending joint, then the coupled one."""
    if not isinstance(controller, JointPD) or period is None or model.n_joints == 0:
        return []
    n = model.n_joints
    try:
        kp = np.broadcast_to(np.asarray(controller.kp, dtype=float), (n,))
        kd = np.broadcast_to(np.asarray(controller.kd, dtype=float), (n,))
    except ValueError:
        return []  # gains per trajectory of a batch, or that do not broadcast: the controller call reports them
    full = inertia(model, q0)
    m = np.diagonal(full)
    kd_max, kp_max = pd_gain_bounds(m, period, kd)
    lines = []
    for i in np.argsort(m):
        if kd[i] >= kd_max[i] or kp[i] >= kp_max[i]:
            lines.append(
                f"joint {model.joint_names[i]!r} (effective inertia {m[i]:.3g} kg m^2, spacecraft free): "
                f"kp = {kp[i]:.3g}, kd = {kd[i]:.3g}; stable needs kd < {kd_max[i]:.3g} N m s/rad and kp < {kp_max[i]:.3g} N m/rad"
            )
    rho, scale, joint = _stability(full, kp, kd, period)
    if rho >= 1.0:
        lines.append(
            f"all joints together (coupled through the free-floating inertia, linearised at the initial angles) grow by "
            f"{rho:.3g} per sample, mostly joint {model.joint_names[joint]!r}; gains times {scale:.3g} or less are stable"
        )
    if lines:
        warnings.warn(
            f"JointPD sampled every {period:.3g} s is unstable: " + "; ".join(lines) + ". Lower the gains below these bounds "
            "(half of them leaves a margin) or sample faster; the run will diverge.",
            StiffGainsWarning,
            stacklevel=stacklevel,
        )
    return lines


def _stiff_passive(model: Model, q0: np.ndarray, step: float | None, inertia: JointInertia, stacklevel: int) -> list[str]:
    """Where fixed RK4 steps of ``step`` s cannot follow a joint's damping or friction: warns (StiffGainsWarning,
    ``stacklevel`` counted from here) and returns the lines, one per offending joint.

    Near rest the smooth friction acts as a damping of F / v_s (:data:`~freefloat.engine.FRICTION_SPEED`); with the
    joint's viscous damping d and its effective inertia m (the diagonal of ``inertia(model, q0)``, the free-floating
    joint inertia), the joint's rate decays at c = (d + F / v_s) / m, and RK4 needs c step < :data:`RK4_REAL_LIMIT`. A
    joint's spring K makes it oscillate at w = sqrt(K / m), and RK4 needs w step < :data:`RK4_IMAGINARY_LIMIT`.
    """
    if step is None or model.n_joints == 0 or not (model.has_passive or model.has_springs):
        return []
    m = np.diagonal(inertia(model, q0))
    # a column of q feels its joint's damping and friction and its mimic joints' (multiplier r): r^2 d, and near rest r^2 F / v_s
    own, law = model.expanded(), model.mimic_matrix
    damping = own.joint_damping @ law**2
    friction = own.joint_friction @ law**2
    rate = (damping + friction / FRICTION_SPEED) / m
    lines = [
        f"joint {model.joint_names[i]!r} (effective inertia {m[i]:.3g}, damping {damping[i]:.3g}, friction "
        f"{friction[i]:.3g}: its rate decays at {rate[i]:.3g} 1/s) needs steps below {RK4_REAL_LIMIT / rate[i]:.3g} s"
        for i in np.argsort(-rate)
        if rate[i] * step >= RK4_REAL_LIMIT
    ]
    stiffness = own.joint_stiffness @ law**2
    omega = np.sqrt(stiffness / m)
    springs = [
        f"joint {model.joint_names[i]!r} (effective inertia {m[i]:.3g}, spring {stiffness[i]:.3g}: it oscillates at "
        f"{omega[i]:.3g} rad/s) needs steps below {RK4_IMAGINARY_LIMIT / omega[i]:.3g} s"
        for i in np.argsort(-omega)
        if omega[i] * step >= RK4_IMAGINARY_LIMIT
    ]
    if lines:
        warnings.warn(
            f"RK4 steps of {step:.3g} s cannot follow the joints' damping and friction: " + "; ".join(lines) + ". Take shorter "
            "steps, use the adaptive integrator (no fixed_step), or simulate without them (passive='ignore'); the run will "
            "diverge.",
            StiffGainsWarning,
            stacklevel=stacklevel,
        )
    if springs:
        lines += springs
        warnings.warn(
            f"RK4 steps of {step:.3g} s cannot follow the joints' springs: " + "; ".join(springs) + ". Take shorter "
            "steps or use the adaptive integrator (no fixed_step); the run will diverge.",
            StiffGainsWarning,
            stacklevel=stacklevel,
        )
    return lines


def check_passive_step(model: Model, q0: np.ndarray, step: float | None) -> list[str]:
    """Warn (:class:`StiffGainsWarning`, at the caller's caller) where fixed RK4 steps of ``step`` s cannot follow a
    joint's damping or friction at the angles ``q0`` (see :func:`_stiff_passive`); returns the lines (one per
    offending joint). For :func:`freefloat.rollout`, whose trajectories have no other pre-run check that needs M."""
    return _stiff_passive(model, q0, step, free_floating_joint_inertia, stacklevel=4)
