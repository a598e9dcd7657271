"""The engine's threads (``freefloat.mechanics._threads``): a batch in contiguous ranges, one per thread, each run by the
same compiled kernel; every range finished before the call returns or raises, Ctrl-C included; the engine's drivers on
them give the numbers of one thread."""

from __future__ import annotations

import itertools
import multiprocessing
import subprocess
import sys
import threading
import time
from typing import Any

import numba
import numpy as np
import pytest

import freefloat as ff
from freefloat.mechanics import _drivers, _threads


def test_the_ranges_cover_the_batch_once_in_as_many_threads() -> None:
    lock = threading.Lock()
    for count, parts in ((1, 4), (7, 2), (10, 3), (1001, 2), (5, 5)):
        seen: list[tuple[int, int, int, int]] = []

        def run(r: int, first: int, last: int, seen: list[tuple[int, int, int, int]] = seen) -> None:
            time.sleep(0.01)  # long enough for every range to be running at once
            with lock:
                seen.append((r, first, last, threading.get_ident()))

        _threads.run_ranges(run, count, parts)
        used = min(count, parts)
        assert sorted(r for r, *_ in seen) == list(range(used))
        bounds = sorted((first, last) for _, first, last, _ in seen)
        assert bounds[0][0] == 0 and bounds[-1][1] == count and all(a[1] == b[0] for a, b in itertools.pairwise(bounds))
        lengths = [last - first for first, last in bounds]
        assert max(lengths) - min(lengths) <= 1
        assert len({ident for *_, ident in seen}) == min(used, 1 + _threads._pool()._max_workers)
        assert any(ident == threading.get_ident() for r, *_, ident in seen if r == 0)  # range 0: the calling thread


def test_an_error_in_a_range_is_raised_after_every_range_finished() -> None:
    done: list[int] = []

    def run(r: int, first: int, last: int) -> None:
        if r == 1:
            raise ValueError("range 1 failed")
        time.sleep(0.05)
        done.append(r)

    with pytest.raises(ValueError, match="range 1 failed"):
        _threads.run_ranges(run, 10, 2)
    assert done == [0]


def test_ctrl_c_in_the_calling_thread_waits_for_the_other_ranges() -> None:
    """A KeyboardInterrupt in range 0 is raised only once the ranges on the pool have finished: none of them writes into
    the call's outputs afterwards (a recycled buffer may serve the next call)."""
    finished: list[float] = []

    def run(r: int, first: int, last: int) -> None:
        if r == 0:
            raise KeyboardInterrupt
        time.sleep(0.2)
        finished.append(time.perf_counter())

    with pytest.raises(KeyboardInterrupt):
        _threads.run_ranges(run, 2, 2)
    caught = time.perf_counter()
    assert len(finished) == 1 and finished[0] <= caught


def _ranges_in_a_child(queue: Any) -> None:
    seen: list[int] = []
    _threads.run_ranges(lambda r, first, last: seen.append(r), 4, 2)
    queue.put(sorted(seen))


def test_a_forked_child_makes_a_pool_of_its_own() -> None:
    """After ``fork`` the parent's pool threads do not exist in the child: its ranges run on a pool of its own (they
    would wait forever on the parent's)."""
    _threads.run_ranges(lambda r, first, last: None, 2, 2)  # the parent's pool exists
    context = multiprocessing.get_context("fork")
    queue = context.Queue()
    child = context.Process(target=_ranges_in_a_child, args=(queue,))
    child.start()
    child.join(60)
    alive = child.is_alive()
    if alive:
        child.kill()
    assert not alive and child.exitcode == 0 and queue.get(timeout=5) == [0, 1]


def test_ranges_run_while_the_interpreter_shuts_down() -> None:
    """Once the interpreter is shutting down, a pool takes no more work ("cannot schedule new futures after interpreter
    shutdown": a thread left running after the main script, an ``atexit`` handler): the ranges run in the calling thread."""
    script = (
        "import atexit\n"
        "from freefloat.mechanics._threads import run_ranges\n"
        "run_ranges(lambda r, first, last: None, 2, 2)  # the pool exists\n"
        "def at_exit():\n"
        "    seen = []\n"
        "    run_ranges(lambda r, first, last: seen.append((r, first, last)), 4, 2)\n"
        "    print(sorted(seen), flush=True)\n"
        "atexit.register(at_exit)\n"
    )
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0 and result.stdout.strip() == "[(0, 0, 2), (1, 2, 4)]", result.stdout + result.stderr


def test_the_engine_on_two_threads_equals_one_thread(monkeypatch: pytest.MonkeyPatch) -> None:
    """A batch of the drivers' threshold or more runs on one range per numba thread (asserted), and gives bit for bit the
    numbers of one thread; a smaller one runs on one range."""
    model = ff.models.papadopoulos1992()
    size = _drivers.jstar_batch.PARALLEL_MIN + 1
    q = np.random.default_rng(0).uniform(-3, 3, (size, model.n_joints))
    calls: list[tuple[int, int]] = []
    real = _drivers.run_ranges

    def spy(run: object, count: int, parts: int) -> None:
        calls.append((count, parts))
        real(run, count, parts)  # type: ignore[arg-type]

    monkeypatch.setattr(_drivers, "run_ranges", spy)
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = ff.generalized_jacobian(model, q)
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))  # type: ignore[attr-defined]
        threads = numba.get_num_threads()
        two = ff.generalized_jacobian(model, q)
        ff.generalized_jacobian(model, q[: size - 2])
    finally:
        numba.set_num_threads(before)
    assert calls == [(size, 1), (size, threads), (size - 2, 1)]
    assert np.array_equal(one, two)
