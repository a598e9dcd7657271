"""The record of a run (private): :class:`_Recorder` keeps the flat states and the actuation at the output times,
:func:`_trajectory` turns stacked flat states into a :class:`~freefloat.Trajectory`.

The flat state is ``x = [r_cm, v_cm, attitude (x, y, z, w), omega, q, qdot]`` (:mod:`freefloat.core.state`), with the
energy the joints' damping and friction have dissipated last when the run models them
(:func:`~freefloat.core.state.dissipates`): :func:`_trajectory` takes it off into ``Trajectory.dissipated_energy``.
"""

from __future__ import annotations

import numpy as np

from ..core.errors import SimulationError
from ..core.model import Model
from ..core.resources import MEMORY_FRACTION, available_memory, format_bytes
from ..core.state import dissipated, unpack_state
from ..core.state_layout import span, state_length
from .trajectory import Trajectory

#: The recorder looks at the free memory every this many recorded states.
RECORD_CHECK = 1 << 16


class _Recorder:
    """The outputs of one run as it goes: times, flat states (copied) and actuation (tau, f_S, n_S, saturated)."""

    def __init__(self, model: Model) -> None:
        self.model = model
        self.t: list[float] = []
        self.x: list[np.ndarray] = []
        self.act: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []

    def add(self, t: float, x: np.ndarray, act: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]) -> None:
        if len(self.t) % RECORD_CHECK == RECORD_CHECK - 1:
            self._check_memory(x)
        self.t.append(float(t))
        self.x.append(x.copy())  # the attitudes are normalised at the end, all at once (:meth:`trajectory`)
        self.act.append(act)

    def _check_memory(self, x: np.ndarray) -> None:
        """A run records its states as it goes (a 1e12 s run allocates nothing up front): stop it, with what it
        recorded, before the records and their final stacking (about 3 times the records) exceed the free memory."""
        per_sample = 8 * (x.size + sum(np.size(a) for a in self.act[-1])) + 200  # floats, and the lists' own objects
        recorded = len(self.t) * per_sample
        free = available_memory()
        if free is not None and 3 * recorded > MEMORY_FRACTION * free:
            raise SimulationError(
                f"the run has recorded {len(self.t):,} states ({format_bytes(recorded)}), and recording more would exceed the "
                f"memory this machine has free ({format_bytes(free)}): record fewer states (a longer output_period) or "
                "shorten the run; the states so far are attached"
            )

    def trajectory(self, status: str = "finished", message: str = "") -> Trajectory:
        model = self.model
        n = model.n_joints
        # the records whole: an interrupt (Ctrl-C, SIGTERM) between the appends of :meth:`add` leaves one list longer
        kept = min(len(self.t), len(self.x), len(self.act))
        if kept:
            xs = np.stack(self.x[:kept])
            attitude = span("attitude", n)
            xs[..., attitude] /= np.linalg.norm(xs[..., attitude], axis=-1, keepdims=True)
            acts = [np.stack([a[i] for a in self.act[:kept]]) for i in range(4)]
        else:
            xs = np.zeros((0, state_length(n)))  # (no slot: no dissipated energy either)
            acts = [np.zeros((0, n)), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0,), dtype=bool)]
        return _trajectory(model, np.asarray(self.t[:kept]), xs, (acts[0], acts[1], acts[2], acts[3]), status, message)


def _trajectory(
    model: Model,
    t: np.ndarray,
    xs: np.ndarray,
    acts: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    status: str = "finished",
    message: str = "",
    *,
    copy: bool = True,
) -> Trajectory:
    """A Trajectory from stacked flat states xs (T, ..., S) and actuation; the dissipated energy from their last slot
    (zeros for states without it: :func:`~freefloat.core.state.dissipated`), the other fields from the rest.

    ``copy=False`` keeps the fields as views of ``xs`` (for the large arrays of
    batched rollouts, which nothing else holds); otherwise each field gets its own array.
    """
    s = unpack_state(model, xs)
    own = np.array if copy else np.asarray
    return Trajectory(
        t=t,
        q=own(s.q),
        qdot=own(s.qdot),
        omega=own(s.omega),
        attitude=own(s.attitude),
        r_cm=own(s.r_cm),
        v_cm=own(s.v_cm),
        joint_torque=own(acts[0]),
        spacecraft_force=own(acts[1]),
        spacecraft_torque=own(acts[2]),
        saturated=own(acts[3]),
        dissipated_energy=own(dissipated(model, xs)),
        status=status,
        message=message,
        model_name=model.name,
        model=model,
    )
