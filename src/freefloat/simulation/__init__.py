"""Simulation with controllers in the loop: :func:`simulate`, batched :func:`rollout`, :class:`Trajectory`, :class:`JointPD`.

:mod:`.simulate` holds the public calls and their checks, :mod:`._integrate`
the integration loops (scipy adaptive or RK4, numpy or compiled kernels),
:mod:`.trajectory` the recorded result, :mod:`.pd` a joint-space PD
controller that the compiled rollouts run without Python, :mod:`.capture_event`
the capture of a moving target during a run (:class:`Capture`, :class:`CaptureRun`)
and :mod:`.coast` the target's torque-free motion until then.

Layer: imports :mod:`freefloat.core` and :mod:`freefloat.mechanics` only.
"""

from __future__ import annotations

from ..core.errors import SimulationError
from ..core.state import ActuatorLimits
from ._guard import RunEstimate, estimate_run, pd_gain_bounds, pd_stability
from .capture_event import Capture, CaptureRun
from .coast import Coast, coast
from .pd import JointPD
from .simulate import METHODS, rollout, simulate
from .trajectory import JointLimitEvent, Trajectory

__all__ = [
    "METHODS",
    "ActuatorLimits",
    "Capture",
    "CaptureRun",
    "Coast",
    "JointLimitEvent",
    "JointPD",
    "RunEstimate",
    "SimulationError",
    "Trajectory",
    "coast",
    "estimate_run",
    "pd_gain_bounds",
    "pd_stability",
    "rollout",
    "simulate",
]
