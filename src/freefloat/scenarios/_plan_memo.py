"""The capture plan of a scenario, computed once per distinct robot and path in a process (private).

A campaign over a capture scenario (:mod:`freefloat.campaigns`) runs the same robot and path with only the
target changed (its motion, the grasp time, the detumbling settings): the post-capture PIW, the placement, the
posture and the path checks (:func:`freefloat.analysis.capture.fixed_capture_plan`, most of a run) do not depend on
them. :func:`fixed_plan` keeps the last :data:`MEMO_SIZE` of them, keyed by a content hash of the model (every
field it was built from, not its name) and of every other input of the plan, so a run whose robot, payload or path
differs in any number is planned afresh. The target's motion is applied to the kept plan
(:meth:`~freefloat.analysis.capture.FixedCapturePlan.moving`: the candidates' impacts and the ranking).
"""

from __future__ import annotations

import dataclasses
import hashlib
from collections import OrderedDict
from typing import TYPE_CHECKING, Any

import numpy as np

from ..analysis.capture import FixedCapturePlan, fixed_capture_plan

if TYPE_CHECKING:
    from .capture_scenario import CaptureScenario

__all__ = ["MEMO_SIZE", "clear", "fixed_plan", "plan_key"]

#: Plans kept per process (each holds a PIW of a few MB at most).
MEMO_SIZE = 4
_MEMO: OrderedDict[str, FixedCapturePlan] = OrderedDict()


def _token(digest: Any, kind: str, data: bytes) -> None:
    """One framed token: its kind and length before its bytes, so that no two sequences of tokens hash alike
    (``0.1`` then ``24096`` is not ``0.12`` then ``4096``)."""
    digest.update(f"{kind}:{len(data)}:".encode())
    digest.update(data)


def _feed(digest: Any, value: Any) -> None:
    """Hash ``value``'s content: arrays by dtype, shape and bytes; dataclasses by their init fields; containers by item;
    every token framed by :func:`_token`."""
    if isinstance(value, np.ndarray):
        _token(digest, "array", f"{value.dtype.str}{value.shape}".encode())
        _token(digest, "bytes", np.ascontiguousarray(value).tobytes())
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        _token(digest, "dataclass", type(value).__name__.encode())
        for f in dataclasses.fields(value):
            if f.init:
                _token(digest, "field", f.name.encode())
                _feed(digest, getattr(value, f.name))
    elif isinstance(value, dict):
        _token(digest, "dict", str(len(value)).encode())
        for key in sorted(value, key=repr):
            _feed(digest, key)
            _feed(digest, value[key])
    elif isinstance(value, (list, tuple)):
        _token(digest, "seq", str(len(value)).encode())
        for item in value:
            _feed(digest, item)
    else:
        _token(digest, type(value).__name__, repr(value).encode())


def plan_key(scenario: CaptureScenario) -> str:
    """The content hash of what the scenario's fixed plan depends on: the robot (its joint limits and wheels
    included), the grasping end effector, the payload's mass, inertia and offset, the path and the planner's
    settings."""
    digest = hashlib.sha256()
    for value in (
        scenario.model, scenario.end_effector, scenario.mass, scenario.inertia, scenario.offset, scenario.path, scenario.rule,
        scenario.R_plus, scenario.samples, scenario.criterion, scenario.strategy,
    ):  # fmt: skip
        _feed(digest, value)
    return digest.hexdigest()


def fixed_plan(scenario: CaptureScenario) -> FixedCapturePlan:
    """The scenario's fixed plan: the kept one when this process planned the same robot and path, else planned now."""
    key = plan_key(scenario)
    found = _MEMO.get(key)
    if found is not None:
        _MEMO.move_to_end(key)
        return found
    found = fixed_capture_plan(
        scenario.model, scenario.end_effector, scenario.path, mass=scenario.mass, inertia=scenario.inertia,
        offset=tuple(scenario.offset), rule=scenario.rule, R_plus=scenario.R_plus, samples=scenario.samples,
        criterion=scenario.criterion, strategy=scenario.strategy,
    )  # fmt: skip
    _MEMO[key] = found
    while len(_MEMO) > MEMO_SIZE:
        _MEMO.popitem(last=False)
    return found


def clear() -> None:
    """Forget every kept plan."""
    _MEMO.clear()
