"""The two families of eq. 21 (1992 §V, Fig. 6) for a planar spacecraft with one two-link arm (private; see ``ff.capture``).

Angles in rad; distances in m from the system CM.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.errors import ModelError
from ..core.model import Model
from ..mechanics.planar import position_coefficients
from ._workspace_reach import singularity_measure
from ._workspace_results import _axes, _freeze

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes

__all__ = ["CaptureFamilies", "capture_families"]


# ----------------------------------------------------------------------------------------------------------------- eq. 21 families
@dataclass(frozen=True, eq=False)
class CaptureFamilies:
    """The two families q2(q1) of eq. 21 and det J* along them (1992 Fig. 6).

    ``q1`` (...) rad; ``q2`` and ``det`` (..., 2): family 0 takes +acos, family
    1 -acos; NaN where |r_E| = R+ has no solution for that q1.
    """

    R_plus: float
    q1: np.ndarray
    q2: np.ndarray
    det: np.ndarray

    def __post_init__(self) -> None:
        _freeze(self)

    def plot(self, ax: Axes | None = None, *, degrees: bool = True) -> list[Artist]:
        """q2(q1) of both families and det J* along them (second y axis), like Fig. 6."""
        ax = _axes(ax)
        s = 180.0 / np.pi if degrees else 1.0
        unit = "deg" if degrees else "rad"
        artists: list[Artist] = []
        twin = ax.twinx()
        for k, style in ((0, "-"), (1, "--")):
            artists += ax.plot(self.q1 * s, self.q2[..., k] * s, "C0" + style, label=f"q2, family {k + 1}")
            artists += twin.plot(self.q1 * s, self.det[..., k], "C3" + style, label=f"det J*, family {k + 1}")
        ax.set_xlabel(f"q1 ({unit})")
        ax.set_ylabel(f"q2 ({unit})")
        twin.set_ylabel("det J*")
        return artists


def _two_link_coefficients(model: Model, end_effector: str | int) -> np.ndarray:
    ok = model.n_joints == 2 and model.n_bodies == 3 and list(model.parent) == [-1, 0, 1]
    if not ok or not model.is_planar:
        raise ModelError(
            f"model {model.name!r}",
            "eq. 21 has two families q2(q1) only for a planar spacecraft with one two-link arm",
            "use optimal_capture_posture, which works for any model",
        )
    return position_coefficients(model, end_effector)


def capture_families(model: Model, end_effector: str | int, R_plus: float, q1: Any) -> CaptureFamilies:
    """Solve eq. 21, |r_E(q1, q2)| = R+, for q2: two families, and det J* along them; batched over q1 (...).

    r_E = a0 + a1 e^{i q1} + a2 e^{i(q1+q2)} with the eq. 20 coefficients
    (complex in general); with w = a0 + a1 e^{i q1},
    q2 = arg w - arg a2 - q1 ± acos((R+² - |w|² - |a2|²) / (2 |a2| |w|)).
    """
    a = _two_link_coefficients(model, end_effector)
    q1 = np.asarray(q1, dtype=float)
    w = a[0] + a[1] * np.exp(1j * q1)
    c = (float(R_plus) ** 2 - np.abs(w) ** 2 - np.abs(a[2]) ** 2) / (2.0 * np.abs(a[2]) * np.maximum(np.abs(w), 1e-300))
    valid = np.abs(c) <= 1.0
    base = np.angle(w) - np.angle(a[2]) - q1
    acos = np.arccos(np.clip(c, -1.0, 1.0))
    q2 = np.stack([base + acos, base - acos], axis=-1)
    q2 = np.angle(np.exp(1j * q2))
    q2 = np.where(valid[..., None], q2, np.nan)
    q = np.stack([np.broadcast_to(q1[..., None], q2.shape), np.nan_to_num(q2)], axis=-1)
    det = np.where(valid[..., None], singularity_measure(model, q), np.nan)
    return CaptureFamilies(R_plus=float(R_plus), q1=q1, q2=q2, det=det)


def _is_two_link(model: Model) -> bool:
    return model.n_joints == 2 and model.is_planar and model.n_bodies == 3 and list(model.parent) == [-1, 0, 1]


def _family_of(model: Model, e: int, R_plus: float, q: np.ndarray) -> int | None:
    """Which eq. 21 family (0: +acos, 1: -acos) a configuration on |r_E| = R+ belongs to; None if not a two-link arm."""
    if not _is_two_link(model):
        return None
    fam = capture_families(model, e, R_plus, q[0])
    gap = np.abs(np.angle(np.exp(1j * (fam.q2 - q[1]))))
    return None if np.all(np.isnan(gap)) else int(np.nanargmin(gap))
