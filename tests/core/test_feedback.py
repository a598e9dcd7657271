"""Feedback on every slow step (issue "What a user still meets", item 7): the first-use compile says what it does,
long steps say what they compute, and outside a terminal progress goes to the ``freefloat.progress`` logger."""

from __future__ import annotations

import pytest

import freefloat as ff
from freefloat.core import feedback
from freefloat.mechanics import _numba_cache


def test_the_first_compile_is_announced_once(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(_numba_cache, "_ANNOUNCED", [])
    _numba_cache._announce_compile("/somewhere/numba/0.68-abc/_engine")
    _numba_cache._announce_compile("/somewhere/numba/0.68-abc/_drivers")
    err = capsys.readouterr().err.splitlines()
    assert err == [
        "freefloat: compiling the engine's kernels for this machine: once, usually 30-60 s in all (the next uses load them "
        "from /somewhere/numba/0.68-abc in under a second)"
    ]


def test_a_cache_miss_announces_and_a_hit_does_not(monkeypatch: pytest.MonkeyPatch) -> None:
    said: list[str] = []
    monkeypatch.setattr(_numba_cache, "_announce_compile", lambda folder: said.append(folder))
    monkeypatch.setattr(_numba_cache.FunctionCache, "load_overload", lambda self, sig, ctx: None)  # a miss
    cache = _numba_cache._Cache(_numba_cache.cache_dir)
    assert cache.load_overload(None, None) is None and len(said) == 1
    monkeypatch.setattr(_numba_cache.FunctionCache, "load_overload", lambda self, sig, ctx: "compiled")  # a hit
    assert cache.load_overload(None, None) == "compiled" and len(said) == 1


def test_status_outside_a_terminal_logs_start_and_end(monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    monkeypatch.setattr(feedback, "interactive", lambda: False)
    caplog.set_level("INFO", logger="freefloat.progress")
    limits = ff.workspace.workspace_limits(ff.models.papadopoulos1992(arms=1), piw=True, samples=1024)
    assert limits.piw[0] is not None
    lines = [r.getMessage() for r in caplog.records if r.name == "freefloat.progress"]
    assert "PIW of arm1_ee: 1,024 sampled configurations ..." in lines
    assert any(line.startswith("PIW of arm1_ee: 1,024 sampled configurations: done in ") for line in lines)


def test_status_on_a_terminal_shows_a_transient_spinner(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(feedback, "interactive", lambda: True)
    with feedback.status("computing"):
        pass
    assert capsys.readouterr().out == ""  # nothing on standard output; the spinner is on stderr and removed
