"""Error hierarchy of freefloat: every error and warning class, in one module.

Every error names what is wrong and how to fix it. The classes derive from the
matching built-in exceptions so that ``except ValueError`` keeps working.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from typing import Any

__all__ = [
    "CampaignError",
    "EngineWarning",
    "FreefloatError",
    "LongRunWarning",
    "MemoryBudgetError",
    "ModelCorrectionWarning",
    "ModelError",
    "NearSingularWarning",
    "PathDoesNotFitError",
    "SettingError",
    "ShapeError",
    "SimulationError",
    "SingularConfigurationError",
    "StiffGainsWarning",
    "UnknownNameError",
    "UnmodelledElementWarning",
]


class FreefloatError(Exception):
    """Base class of every error raised by freefloat."""


class ModelError(FreefloatError, ValueError):
    """A model description is not physical or not a valid tree.

    The message starts with the field path (``bodies[2].inertia``) and ends
    with the fix.
    """

    def __init__(self, field: str, problem: str, fix: str) -> None:
        self.field = field
        self.problem = problem
        self.fix = fix
        super().__init__(f"{field}: {problem}; {fix}")


class ShapeError(FreefloatError, ValueError):
    """An array argument has the wrong shape ("expected (..., 7), got (5,)")."""


class UnknownNameError(FreefloatError, KeyError):
    """A body, joint or end-effector name that the model does not have."""

    def __init__(self, kind: str, name: object, known: Iterable[str]) -> None:
        known = list(known)
        close = difflib.get_close_matches(str(name), known, n=3)
        hint = f" Did you mean {', '.join(repr(c) for c in close)}?" if close else ""
        self.message = f"unknown {kind} {name!r}; known: {', '.join(known) or '(none)'}.{hint}"
        super().__init__(self.message)

    def __str__(self) -> str:  # KeyError would quote the whole message
        return self.message


class SingularConfigurationError(FreefloatError, ArithmeticError):
    """A request needs the inverse of a matrix that is singular here."""

    def __init__(self, what: str, determinant: float, fix: str = "") -> None:
        self.determinant = determinant
        super().__init__(f"{what} is singular (determinant {determinant:.3e}). {fix}".strip())


class ModelCorrectionWarning(UserWarning):
    """A loaded model file had data that is not physical and freefloat corrected it (say what and by how much).

    Every correction is also recorded in ``Model.corrections``. Turn these into errors with
    ``ff.load(path, strict=True)`` (or ``warnings.simplefilter("error", ModelCorrectionWarning)``).
    """


class UnmodelledElementWarning(ModelCorrectionWarning):
    """A loaded model file has an element that acts on free-floating dynamics but that freefloat does not model
    (joint damping, a gear ratio, a tendon, ...): it was dropped. The message names the element and every joint,
    actuator ... it concerns; ``Model.unmodelled`` records it; ``ff.load(path, strict=True)`` refuses the file
    instead. Which elements are modelled, ignored or dropped: :data:`freefloat.io.unmodelled.ELEMENTS`.
    """


class NearSingularWarning(UserWarning):
    """A matrix is close to singular; results may be inaccurate."""


class SimulationError(FreefloatError, RuntimeError):
    """A simulation failed part-way; ``trajectory`` holds what was computed up to the failure.

    ``trajectory`` is a :class:`freefloat.Trajectory` (or None).
    """

    def __init__(self, message: str, trajectory: Any = None) -> None:
        super().__init__(message)
        self.trajectory = trajectory


class CampaignError(FreefloatError, ValueError):
    """A campaign cannot start or go on: an output directory holding another campaign, a scheduler that does not
    answer, a second runner on the same directory. The message names the option and the fix."""


class StiffGainsWarning(UserWarning):
    """Joint PD gains that the sampled (zero-order hold) loop cannot keep stable, found before a run.

    The message names each joint, its effective inertia and the largest stable gains for the sample period.
    """


class EngineWarning(UserWarning):
    """One of numba's internals that the compiled engine uses for speed is not available (a numba outside the tested
    range, a renamed lookup, or ``FREEFLOAT_NUMBA_INTERNALS=0``): the engine runs on numba's public interface instead,
    with the same results. Said once per process."""


class LongRunWarning(UserWarning):
    """A simulation is estimated, before it starts, to take longer than the caller's limit (steps and seconds in the message)."""


class MemoryBudgetError(FreefloatError, ValueError):
    """A call would need more memory than the machine has free: refused before anything is allocated, with the
    estimate and the way out (fewer samples, a coarser grid, smaller batches) in the message
    (:func:`freefloat.core.resources.require_memory`)."""


class SettingError(FreefloatError, ValueError):
    """An environment variable of freefloat's holds a value it does not accept: the message names the variable and
    its values."""


class PathDoesNotFitError(FreefloatError, ValueError):
    """The desired path fits in no annulus of the workspace: the thrusters are needed (1992 §V).

    ``fits_reachable`` is True when the path would fit in the reachable
    workspace but not in the PIW (dynamic singularities may occur: use the
    thrusters or a special path), False when it does not fit even there.
    """

    def __init__(self, message: str, *, margin: float, fits_reachable: bool | None) -> None:
        self.margin = margin
        self.fits_reachable = fits_reachable
        super().__init__(message)
