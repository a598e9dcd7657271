"""Simulation with controllers in the loop: :func:`simulate`, batched :func:`rollout`, :class:`Trajectory`, :class:`JointPD`.

:mod:`.simulate` holds the public calls; one simulation goes down through
:mod:`._plan` (its checks and its :class:`~._plan.RunPlan`, with :mod:`._prerun`'s checks that need the engine)
and :mod:`._integrate` (the run: the compiled loop of :mod:`._compiled_runs`, or the RK4 and adaptive loops, with
the controller of :mod:`._controller`, the joint stops of :mod:`._stops`, the guard of :mod:`._guard` and the
record of :mod:`._record`) to the engine; :mod:`.trajectory` holds the recorded result, :mod:`.pd` a joint-space PD
controller that the compiled rollouts run without Python, :mod:`.capture_event`
the capture of a moving target during a run (:class:`Capture`, :class:`CaptureRun`)
and :mod:`.coast` the target's torque-free motion until then.

Layer: imports :mod:`freefloat.core`, the engine's door :mod:`freefloat.engine` and :mod:`freefloat.mechanics` only.
"""

from __future__ import annotations

from ..core.errors import SimulationError
from ..core.state import ActuatorLimits
from ._guard import RunEstimate, estimate_run
from ._prerun import pd_gain_bounds, pd_stability
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
