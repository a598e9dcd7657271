"""The engine's threads (``freefloat.engine.threads``): a batch in contiguous ranges, one per thread, each run by the
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
from freefloat.engine import drivers as _drivers
from freefloat.engine import threads as _threads


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


def _in_a_forked_child(target: Any) -> Any:
    """What ``target(queue)`` puts in its queue, run in a child made by ``fork``; the child must end by itself, with
    exit code 0."""
    context = multiprocessing.get_context("fork")
    queue = context.Queue()
    child = context.Process(target=target, args=(queue,))
    child.start()
    child.join(120)
    alive = child.is_alive()
    if alive:
        child.kill()
    assert not alive and child.exitcode == 0
    return queue.get(timeout=5)


def test_a_forked_child_makes_a_pool_of_its_own() -> None:
    """After ``fork`` the parent's pool threads do not exist in the child: its ranges run on a pool of its own (they
    would wait forever on the parent's)."""
    _threads.run_ranges(lambda r, first, last: None, 2, 2)  # the parent's pool exists
    assert _in_a_forked_child(_ranges_in_a_child) == [0, 1]


def test_ranges_run_while_the_interpreter_shuts_down() -> None:
    """Once the interpreter is shutting down, a pool takes no more work ("cannot schedule new futures after interpreter
    shutdown": a thread left running after the main script, an ``atexit`` handler): the ranges run in the calling thread."""
    script = (
        "import atexit\n"
        "from freefloat.engine.threads import run_ranges\n"
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
    real = _drivers.run_kernel

    def spy(run: Any, pre: Any, work: np.ndarray, post: Any, count: int, parts: int) -> None:
        calls.append((count, parts))
        real(run, pre, work, post, count, parts)

    monkeypatch.setattr(_drivers, "run_kernel", spy)
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


# ----------------------------------------------------------------- compiled kernels on numba's threads (run_kernel)
@numba.njit(nogil=True)
def _record(ids: np.ndarray, work: np.ndarray, first: int, last: int, scale: float) -> None:  # pragma: no cover - compiled
    """ids[i] = scale * (numba's thread of row i + 1); the range in its scratch row."""
    for i in range(first, last):
        ids[i] = scale * (numba.get_thread_id() + 1)
    work[0], work[1] = first, last


@numba.njit(nogil=True)
def _refuse_past(ids: np.ndarray, work: np.ndarray, first: int, last: int, limit: int) -> None:  # pragma: no cover - compiled
    for i in range(first, last):
        if i >= limit:
            raise ValueError("row past the limit")
        ids[i] = 1.0


@numba.njit(nogil=True)
def _nested(pair: Any, flag: bool, work: np.ndarray, first: int, last: int, *rest: Any) -> None:  # pragma: no cover - compiled
    """Tuples at the front and ``*args`` at the back: out[i] = a[i] + b[i] (+ c[i] where flag), into rest's last array."""
    a, b = pair
    c, out = rest
    for i in range(first, last):
        out[i] = a[i] + b[i] + (c[i] if flag else 0.0)


@numba.njit(nogil=True)
def _returns(ids: np.ndarray, work: np.ndarray, first: int, last: int) -> int:  # pragma: no cover - compiled
    return last - first


@pytest.fixture
def two_threads() -> Any:
    before = numba.get_num_threads()
    numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))  # type: ignore[attr-defined]
    try:
        yield numba.get_num_threads()
    finally:
        numba.set_num_threads(before)


def test_a_kernel_runs_on_one_range_per_numba_thread(two_threads: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """Each range is run once, by numba's threads (one range per thread, contiguous, lengths one apart at most), through
    the kernel's machine code (no Python in between: the pool's threads are not used)."""
    assert two_threads == 2, "the test machine has at least 2 cores"
    monkeypatch.setattr(_threads, "run_ranges", lambda *a: pytest.fail("the pool ran the ranges"))
    for count, parts in ((2, 2), (7, 2), (1001, 2), (5, 9)):
        ids = np.zeros(count)
        work = np.full((_threads.range_count(count, parts), 2), -1.0)
        _threads.run_kernel(_record, (ids,), work, (2.0,), count, parts)
        used = min(count, parts, two_threads) if parts <= two_threads else min(count, parts)
        bounds = sorted((int(a), int(b)) for a, b in work)
        assert bounds[0][0] == 0 and bounds[-1][1] == count and all(x[1] == y[0] for x, y in itertools.pairwise(bounds))
        assert max(b - a for a, b in bounds) - min(b - a for a, b in bounds) <= 1
        assert set(np.unique(ids)) <= {2.0 * (k + 1) for k in range(two_threads)}  # every row written, by numba's threads
        for a, b in bounds:
            assert len(np.unique(ids[a:b])) == 1  # a range is one thread's
        assert len(np.unique(ids)) == min(used, two_threads)


@pytest.fixture
def fanned(monkeypatch: pytest.MonkeyPatch) -> list[tuple[int, int]]:
    """(ranges, ranges that raised) of each parallel loop that numba's threads ran (``_threads._fan_out``)."""
    seen: list[tuple[int, int]] = []
    real = _threads._fan_out

    def spy(*args: Any) -> int:
        raised = int(real(*args))
        seen.append((args[-1].shape[0], raised))
        return raised

    monkeypatch.setattr(_threads, "_fan_out", spy)
    return seen


def test_a_range_that_raises_is_raised_in_the_calling_thread(two_threads: int, fanned: list[tuple[int, int]]) -> None:
    """A kernel's exception in a range on numba's threads is not lost: that range runs again in the calling thread,
    which raises it; the other range's rows are written."""
    ids = np.zeros(100)
    work = np.zeros((2, 1))
    with pytest.raises(ValueError, match="row past the limit"):
        _threads.run_kernel(_refuse_past, (ids,), work, (70,), 100, 2)
    assert fanned == [(2, 1)]  # raised on numba's threads, in range 1 only
    assert np.all(ids[:50] == 1.0) and np.all(ids[50:70] == 1.0)
    _threads.run_kernel(_refuse_past, (ids,), work, (100,), 100, 2)  # and the same kernel runs on
    assert np.all(ids == 1.0) and fanned[1:] == [(2, 0)]
    with pytest.raises(ValueError, match="a scratch row per range"):
        _threads.run_kernel(_refuse_past, (ids,), work[:1], (100,), 100, 2)


def test_tuples_and_star_arguments_reach_the_kernel(two_threads: int, fanned: list[tuple[int, int]]) -> None:
    """A tuple argument and a kernel's ``*args`` (one tuple, as numba compiles them) are passed field by field to its
    machine code: the values arrive in place; and the kernel is compiled once, for a call in the calling thread and on
    numba's threads alike (the ``*args`` typed as numba's dispatcher types them)."""
    rng = np.random.default_rng(0)
    a, b, c = rng.normal(size=(3, 501))
    for flag in (True, False):
        for parts in (1, 2):
            out = np.zeros(501)
            _threads.run_kernel(_nested, ((a, b), flag), np.zeros((2, 1)), (c, out), 501, parts)
            assert np.array_equal(out, a + b + (c if flag else 0.0))
    assert fanned == [(2, 0), (2, 0)] and len(_nested.overloads) == 1


def test_each_engine_driver_is_compiled_once(two_threads: int) -> None:
    """A driver's range kernel serves a batch in the calling thread and one on threads alike: one overload."""
    model = ff.models.papadopoulos1992()
    q = np.zeros((_drivers.jstar_batch.PARALLEL_MIN + 1, model.n_joints))
    ff.generalized_jacobian(model, q[:1])
    ff.generalized_jacobian(model, q)
    assert len(_drivers.jstar_batch.serial.overloads) == 1


def test_a_kernel_that_returns_a_value_is_refused(two_threads: int) -> None:
    with pytest.raises(TypeError, match="return nothing"):
        _threads.run_kernel(_returns, (np.zeros(4),), np.zeros((2, 1)), (), 4, 2)


def test_while_the_workqueue_layer_is_busy_the_pool_runs_the_ranges(two_threads: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """numba's ``workqueue`` layer takes one parallel loop at a time (a second one at once ends the process): while one
    runs, another thread's call runs its ranges on the pool."""
    monkeypatch.setattr(_threads, "_layer", lambda: "workqueue")
    pooled: list[int] = []
    real = _threads.run_ranges

    def spy(run: Any, count: int, parts: int) -> None:
        pooled.append(count)
        real(run, count, parts)

    monkeypatch.setattr(_threads, "run_ranges", spy)
    ids = np.zeros(300)
    _threads.run_kernel(_record, (ids,), np.zeros((2, 2)), (1.0,), 300, 2)
    assert pooled == [] and set(np.unique(ids)) <= {1.0, 2.0}
    with _threads._WORKQUEUE:  # another loop is running
        _threads.run_kernel(_record, (ids,), np.zeros((2, 2)), (1.0,), 301 - 1, 2)
    assert pooled == [300] and not _threads._WORKQUEUE.locked()


def _kernel_in_a_child(queue: Any) -> None:
    ids = np.zeros(64)
    _threads.run_kernel(_record, (ids,), np.zeros((2, 2)), (1.0,), 64, 2)
    queue.put((_threads._NUMBA_THREADS[0], float(ids.min())))


def test_a_child_forked_after_numba_threads_ran_uses_the_pool(two_threads: int) -> None:
    """GNU OpenMP (numba's threading layer on Linux) ends a child forked after the parent used it, at its first
    parallel loop: in such a child the ranges run on the pool, and the child lives."""
    _threads.run_kernel(_record, (np.zeros(8),), np.zeros((2, 2)), (1.0,), 8, 2)  # the parent's numba threads ran
    assert _in_a_forked_child(_kernel_in_a_child) == (False, 1.0)


def test_a_driver_call_that_compiled_its_parallel_loop_is_not_work(two_threads: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """The time a driver's call took counts towards specialising only when it compiled nothing (``Batched.compiled``):
    neither its kernel nor the parallel loop that calls it on threads (``_threads.compiled_count``)."""
    model = ff.models.papadopoulos1992()
    q = np.zeros((_drivers.jstar_batch.PARALLEL_MIN + 1, model.n_joints))
    ff.generalized_jacobian(model, q)
    ff.generalized_jacobian(model, q)
    assert _drivers.jstar_batch.compiled
    counts = itertools.count()
    monkeypatch.setattr(_drivers, "compiled_count", lambda: next(counts))  # as if the call compiled a signature
    ff.generalized_jacobian(model, q)
    assert not _drivers.jstar_batch.compiled
