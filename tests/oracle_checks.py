"""What the comparisons with an independent engine share: the error, the bound, and a model wrong on purpose.

Used by tests/oracle (Pinocchio), tests/models/test_zoo.py, tests/simulation/test_simulate.py and
tests/io/test_mjcf.py (MuJoCo). Each comparison states its measured agreement and its bound as

    MEASURED = 2.1e-13  # where and when it was measured
    BOUND = MARGIN * MEASURED

so that the bound says what the agreement is, and each oracle has a test in which a model wrong by a
relative 1e-7 in one link's mass or inertia (:func:`perturbed`) makes the same comparison exceed its
bound: a safety net that can fail.
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Iterator

import numpy as np
from scipy.spatial.transform import Rotation

import freefloat as ff

#: Bound / measured agreement: room for other machines, BLAS builds and library versions, still far below
#: what a model error of 1e-7 (relative) in one link's mass or inertia does.
MARGIN = 100.0
#: The start of the message of a comparison that exceeds its bound (the perturbation tests match it).
EXCEEDS = "exceeds its bound"


def relative_error(name: str, ours: np.ndarray | float, ref: np.ndarray | float) -> float:
    """max |ours - ref| / max |ref|, the shapes equal and ``ref`` not all zeros."""
    ours, ref = np.asarray(ours, dtype=float), np.asarray(ref, dtype=float)
    assert ours.shape == ref.shape, f"{name}: shape {ours.shape} != {ref.shape}"
    scale = float(np.max(np.abs(ref))) if ref.size else 0.0
    assert scale > 0.0, f"{name}: reference is all zeros, the comparison would say nothing"
    return float(np.max(np.abs(ours - ref))) / scale


def assert_within(name: str, error: float, bound: float) -> None:
    """Fail with the error and the bound in the message when ``error`` exceeds ``bound``."""
    if not error <= bound:
        raise AssertionError(f"{name}: {EXCEEDS}: error {error:.3e} > bound {bound:.3e}")


class Agreement:
    """The worst error seen per quantity, printed by a module's teardown (pytest -s): how MEASURED is measured."""

    def __init__(self, title: str) -> None:
        self.title = title
        self.worst: dict[str, float] = {}
        self._recording = True

    def record(self, name: str, error: float) -> None:
        if self._recording:
            self.worst[name] = max(self.worst.get(name, 0.0), error)

    def check(self, name: str, ours: np.ndarray | float, ref: np.ndarray | float, bound: float) -> None:
        """:func:`relative_error` of ``ours`` within ``bound``, recorded."""
        error = relative_error(name, ours, ref)
        self.record(name, error)
        assert_within(name, error, bound)

    @contextlib.contextmanager
    def not_recorded(self) -> Iterator[None]:
        """Checks inside do not count (for models that are wrong on purpose)."""
        self._recording = False
        try:
            yield
        finally:
            self._recording = True

    def print(self, not_oracle: tuple[str, ...] = ()) -> None:
        """Each quantity's worst error, then the worst of those that are oracle agreements (names not starting
        with one of ``not_oracle``)."""
        width = max((len(k) for k in self.worst), default=0)
        print(f"\n{self.title}:")
        for key in sorted(self.worst):
            print(f"  {key:<{width}}  {self.worst[key]:.2e}")
        oracle = [v for k, v in self.worst.items() if not k.startswith(not_oracle)]
        if oracle:
            print(f"  worst oracle agreement: {max(oracle):.2e}")


def perturbed(model: ff.Model, name: str, index: tuple[int, ...], delta: float) -> ff.Model:
    """``model`` with one number of the field ``name`` changed by ``delta``; rotations and axes stay orthonormal and unit.

    An inertia entry off the diagonal changes on both sides of it (the tensor stays symmetric).
    """
    arr = np.array(getattr(model, name))
    if name == "joint_rotation":  # index (body, axis): turn the joint frame by delta about that axis
        arr[index[0]] = arr[index[0]] @ Rotation.from_rotvec(delta * np.eye(3)[index[1]]).as_matrix()
    else:
        arr[index] += delta
    if name == "inertia" and index[1] != index[2]:
        arr[index[0], index[2], index[1]] = arr[index]
    if name == "joint_axis":
        arr[index[0]] /= np.linalg.norm(arr[index[0]])
    return dataclasses.replace(model, **{name: arr})


def relatively_perturbed(model: ff.Model, name: str, index: tuple[int, ...], relative: float = 1e-7) -> ff.Model:
    """``model`` with the entry ``index`` of ``name`` (``"mass"`` or ``"inertia"``) times (1 + relative)."""
    value = float(np.asarray(getattr(model, name))[index])
    assert value != 0.0, f"{name}{list(index)} is zero: a relative change would change nothing"
    return perturbed(model, name, index, relative * value)
