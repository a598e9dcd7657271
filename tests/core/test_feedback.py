"""Feedback on every slow step (issue "What a user still meets", item 7): the first-use compile says what it does,
long steps say what they compute, and outside a terminal progress goes to the ``freefloat.progress`` logger."""

from __future__ import annotations

import pytest

import freefloat as ff
from freefloat.analysis import _workspace_search
from freefloat.core import feedback
from freefloat.engine import folders as _numba_cache


def test_the_first_compile_is_announced_once(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(_numba_cache, "_ANNOUNCED", [])
    monkeypatch.setattr(_numba_cache, "_PORTABLE_STATE", {})  # nothing known of the portable kernels: no reason added
    _numba_cache._announce_compile("/somewhere/numba/0.68-abc/_engine")
    _numba_cache._announce_compile("/somewhere/numba/0.68-abc/_drivers")
    err = capsys.readouterr().err.splitlines()
    assert err == [
        "freefloat: compiling the engine's kernels for this machine as they are first used: once, seconds for one kind of "
        "call, a few minutes for all of them (the next uses load them from /somewhere/numba/0.68-abc in under a second)"
    ]


def test_a_cache_miss_announces_and_a_hit_does_not(monkeypatch: pytest.MonkeyPatch) -> None:
    said: list[str] = []
    monkeypatch.setattr(_numba_cache, "_announce_compile", lambda folder: said.append(folder))
    import dataclasses

    from numba.core.caching import FunctionCache  # the gate's cache is numba's, with freefloat's folder

    from freefloat.engine import gate

    assert gate._CACHE is not None
    # nothing portable and no compile lock: the miss is this machine's cache's own
    events = dataclasses.replace(_numba_cache.EVENTS, portable=lambda: None, hold=lambda index, name: False)
    monkeypatch.setattr(gate._CACHE[1], "events", events)
    monkeypatch.setattr(FunctionCache, "load_overload", lambda self, sig, ctx: None)  # a miss
    cache = gate._CACHE[1](_numba_cache.cache_dir)
    assert cache.load_overload(None, None) is None and len(said) == 1
    monkeypatch.setattr(FunctionCache, "load_overload", lambda self, sig, ctx: "compiled")  # a hit
    assert cache.load_overload(None, None) == "compiled" and len(said) == 1


def test_status_outside_a_terminal_logs_start_and_end(monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    monkeypatch.setattr(feedback, "interactive", lambda: False)
    monkeypatch.setattr(feedback, "QUICK", 0.0)  # every step logs its end, however quick
    caplog.set_level("INFO", logger="freefloat.progress")
    limits = ff.workspace.workspace_limits(ff.models.papadopoulos1992(arms=1), piw=True, samples=1024)
    assert limits.piw[0] is not None
    lines = [r.getMessage() for r in caplog.records if r.name == "freefloat.progress"]
    assert "[3/3] PIW of arm1_ee (1,024 samples) ..." in lines
    assert any(line.startswith("[3/3] PIW of arm1_ee (1,024 samples): done in ") for line in lines)


def test_status_on_a_terminal_shows_a_transient_spinner(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(feedback, "interactive", lambda: True)
    with feedback.status("computing"):
        pass
    assert capsys.readouterr().out == ""  # nothing on standard output; the spinner is on stderr and removed


def test_a_quick_step_logs_its_start_only(monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    monkeypatch.setattr(feedback, "interactive", lambda: False)
    caplog.set_level("INFO", logger="freefloat.progress")
    with feedback.status("a quick step"):
        pass
    assert [r.getMessage() for r in caplog.records] == ["a quick step ..."]


def test_piw_sampling_counts_its_configurations(monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    """Outside a terminal, a sampling of several chunks logs its count as it goes (here every chunk: LOG_PERIOD 0)."""
    monkeypatch.setattr(feedback, "interactive", lambda: False)
    monkeypatch.setattr(feedback, "LOG_PERIOD", 0.0)
    caplog.set_level("INFO", logger="freefloat.progress")
    ff.workspace.workspace_limits(ff.models.papadopoulos1992(arms=1), piw=True, samples=200_000)
    counts = [r.getMessage().split(": ", 1)[1].split(" configurations")[0] for r in caplog.records if "configurations (" in r.getMessage()]
    done = [int(c.split(" / ")[0].replace(",", "")) for c in counts]
    total = int(counts[-1].split(" / ")[1].replace(",", ""))
    chunk = _workspace_search.CHUNK
    assert total >= 200_000 * 0.99 and done == [*range(chunk, total, chunk), total], counts  # one line per chunk


def test_capture_search_counts_its_stages(monkeypatch: pytest.MonkeyPatch) -> None:
    """The path-checked capture search reports one stage per candidate radius, then the batch integration."""
    seen: list[str] = []
    real = feedback.Step.advance

    def spy(self: feedback.Step, amount: float) -> None:
        real(self, amount)
        seen.append(self.count())

    monkeypatch.setattr(feedback.Step, "advance", spy)
    model = ff.models.papadopoulos1992(arms=1)
    ff.capture.plan_capture(model, "arm1_ee", mass=400.0, inertia=25.0, path=[[0.0, 0.0], [0.0, 0.25]], strategy="path")
    stages = [c for c in seen if c.endswith("stages (100%)") or "stages" in c]
    assert stages and stages[-1].split(" / ")[0] == stages[-1].split(" / ")[1].split(" ")[0], stages
