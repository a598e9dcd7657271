"""Coordinated control of spacecraft and manipulators (Papadopoulos & Dubowsky 1991 §IV): ``ff.control``.

- :mod:`.tasks`: the task space z1 = [spacecraft position, attitude, end-effector poses] and J_z (:class:`TaskSpace`, :class:`TaskItem`).
- :mod:`.desired`: desired motions (:class:`SetPoint`, :class:`StraightLine`, :func:`MinimumJerk`, :class:`FunctionTrajectory`).
- :mod:`.controllers`: the transposed-Jacobian (eqs. 29-30) and operational-space (eq. 27) controllers.
- :mod:`.detumble`: bringing a system to rest after a capture (:class:`Detumble`, eq. 27 with the task "zero rates")
  and its cost (:func:`detumble_cost`).
- :mod:`.wheels`: the spacecraft torque by reaction wheels (:func:`wheel_torques`; the controllers' ``torque_by``).

A controller is a callable ``(t, state) -> Actuation`` for :func:`freefloat.simulate`.
Layer: imports :mod:`freefloat.core` and :mod:`freefloat.mechanics` only.
"""

from __future__ import annotations

from .controllers import OperationalSpaceController, TransposedJacobianController, actuation_of, damped_inverse, gain_matrix
from .desired import DesiredPoint, FunctionTrajectory, MinimumJerk, SetPoint, StraightLine, as_desired
from .detumble import STANDARD_GRAVITY, Detumble, DetumbleCost, detumble_cost
from .tasks import TaskItem, TaskSpace
from .wheels import wheel_torques

__all__ = [
    "STANDARD_GRAVITY",
    "DesiredPoint",
    "Detumble",
    "DetumbleCost",
    "FunctionTrajectory",
    "MinimumJerk",
    "OperationalSpaceController",
    "SetPoint",
    "StraightLine",
    "TaskItem",
    "TaskSpace",
    "TransposedJacobianController",
    "actuation_of",
    "as_desired",
    "damped_inverse",
    "detumble_cost",
    "gain_matrix",
    "wheel_torques",
]
