"""Counting spies on freefloat's private functions, so that a test can assert which path it took.

A test that says it checks the barycentric form, or a batch cut into chunks, must reach that code;
these wrap the private function with a counter (``pytest.MonkeyPatch``, undone after the test),
everywhere it is bound: in its own module and in every freefloat module that imported it by name.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

import pytest

import freefloat
import freefloat.mechanics._batches


def replace_everywhere(monkeypatch: pytest.MonkeyPatch, original: Callable[..., Any], replacement: Callable[..., Any]) -> None:
    """Bind ``replacement`` wherever a loaded freefloat module holds ``original`` under its name."""
    name = original.__name__
    modules = [m for key, m in list(sys.modules.items()) if key.startswith("freefloat") and getattr(m, name, None) is original]
    assert modules, f"{name}: no freefloat module holds it (renamed?): the spy would count nothing"
    for module in modules:
        monkeypatch.setattr(module, name, replacement)


def count_calls(monkeypatch: pytest.MonkeyPatch, original: Callable[..., Any]) -> list[int]:
    """Spy on ``original``: the returned list grows by one entry per call."""
    calls: list[int] = []

    def spy(*args: Any, **kwargs: Any) -> Any:
        calls.append(1)
        return original(*args, **kwargs)

    replace_everywhere(monkeypatch, original, spy)
    return calls


def count_kernel_runs(monkeypatch: pytest.MonkeyPatch, original: Callable[..., Any]) -> list[int]:
    """Spy on a batch driver ``original(kernel, ...)`` (``_batches.chunked`` or ``_batches.pieces``): one entry per
    call of the driver, the number of times it ran its kernel, i.e. the pieces it cut the batch into."""
    runs: list[int] = []

    def spy(kernel: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        runs.append(0)
        index = len(runs) - 1

        def counted(*arrays: Any) -> Any:
            runs[index] += 1
            return kernel(*arrays)

        return original(counted, *args, **kwargs)

    replace_everywhere(monkeypatch, original, spy)
    return runs


def count_chunks(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """:func:`count_kernel_runs` of ``freefloat.mechanics._batches.chunked`` (chunks of ``_batches.CHUNK`` configurations)."""
    return count_kernel_runs(monkeypatch, freefloat.mechanics._batches.chunked)


def count_pieces(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """:func:`count_kernel_runs` of ``freefloat.mechanics._batches.pieces`` (slices within ``_batches.PAIR_BUDGET``)."""
    return count_kernel_runs(monkeypatch, freefloat.mechanics._batches.pieces)


def compiled_runs(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Spy on the engine's compiled rollout loops (``_engine.law_rollout``, ``_engine.rollout``): one entry per call,
    the name of the law that ran inside (``"transposed_jacobian"``, ``"operational_space"``, ``"detumble"``, or
    ``"joint_pd"`` for the joint PD), so that a test that compares the compiled path with the Python loop can assert
    that the compiled path ran at all, with the law it names."""
    from freefloat.engine import calls as _engine
    from freefloat.engine import laws as _laws

    names = {_laws.TRANSPOSED_JACOBIAN: "transposed_jacobian", _laws.OPERATIONAL_SPACE: "operational_space", _laws.DETUMBLE: "detumble"}
    runs: list[str] = []
    law_rollout, rollout = _engine.law_rollout, _engine.rollout

    def law_spy(*args: Any, **kwargs: Any) -> Any:
        law = args[7] if len(args) > 7 else kwargs.get("law")
        runs.append("joint_pd" if law is None else names[int(law.setup[0])])
        return law_rollout(*args, **kwargs)

    def pd_spy(*args: Any, **kwargs: Any) -> Any:
        runs.append("joint_pd")
        return rollout(*args, **kwargs)

    replace_everywhere(monkeypatch, law_rollout, law_spy)
    replace_everywhere(monkeypatch, rollout, pd_spy)
    return runs


def count_method_calls(monkeypatch: pytest.MonkeyPatch, cls: type, name: str) -> list[int]:
    """Spy on the method ``cls.name`` (e.g. a controller's ``__call__``: its Python form): one entry per call."""
    original = getattr(cls, name)
    calls: list[int] = []

    def spy(self: Any, *args: Any, **kwargs: Any) -> Any:
        calls.append(1)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(cls, name, spy)
    return calls


class Paths:
    """Runs a simulation on one path and asserts that it took it (the spies above)."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        from freefloat.control import Detumble, OperationalSpaceController, TransposedJacobianController

        self.runs = compiled_runs(monkeypatch)
        laws = (TransposedJacobianController, OperationalSpaceController, Detumble, freefloat.JointPD)
        self.calls = [count_method_calls(monkeypatch, cls, "__call__") for cls in laws]

    def compiled(self, law: str, run: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        """``run(*args, **kwargs)``, which must run ``law`` inside the compiled loop and never call a controller from
        Python."""
        runs, calls = len(self.runs), sum(map(len, self.calls))
        out = run(*args, **kwargs)
        assert self.runs[runs:] and set(self.runs[runs:]) == {law}, f"the compiled loop ran {self.runs[runs:]}, not {law}"
        assert sum(map(len, self.calls)) == calls, "the compiled run called the controller from Python"
        return out

    def python(self, run: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        """``run(*args, **kwargs)``, which must call the controller from Python every sample and run no compiled law."""
        runs, calls = len(self.runs), sum(map(len, self.calls))
        out = run(*args, **kwargs)
        laws = [r for r in self.runs[runs:] if r != "joint_pd"]  # (the Python loop's compiled RK4 steps between samples)
        assert not laws, f"the Python run ran a compiled law: {laws}"
        assert sum(map(len, self.calls)) > calls
        return out
