"""Large results are written into recycled buffers (``_arrays.new_output``): a result the caller still holds, or any
view of it, is never written again; a dropped one's memory serves the next call; the kept memory is bounded."""

from __future__ import annotations

import gc
from collections.abc import Iterator

import numpy as np
import pytest

import freefloat as ff
from freefloat.engine import buffers as _arrays

#: Configurations whose J* (12 x 4 for the 1992 system: 384 bytes each) is above RECYCLE_MIN.
SIZE = 20_000


@pytest.fixture(autouse=True)
def _no_kept_buffers() -> Iterator[None]:
    """Each test starts with no buffer kept (the module's list, emptied; the process's other calls keep theirs after)."""
    kept, written = list(_arrays._RECYCLED), dict(_arrays._WRITTEN)
    _arrays._RECYCLED.clear()
    _arrays._WRITTEN.clear()
    yield
    _arrays._RECYCLED[:] = kept
    _arrays._WRITTEN.clear()
    _arrays._WRITTEN.update(written)


def _address(a: np.ndarray) -> int:
    return int(a.__array_interface__["data"][0])


def test_held_results_and_their_views_are_never_written_again() -> None:
    model = ff.models.papadopoulos1992()
    rng = np.random.default_rng(3)
    qs = [rng.uniform(-np.pi, np.pi, (SIZE, 4)) for _ in range(4)]
    assert ff.generalized_jacobian(model, qs[0]).nbytes >= _arrays.RECYCLE_MIN  # the path under test
    first = ff.generalized_jacobian(model, qs[0])
    copy_first = first.copy()
    view = ff.generalized_jacobian(model, qs[1])[::3, 2:, 1]  # only a strided view of the second result is kept
    copy_view = view.copy()
    later = [ff.generalized_jacobian(model, q) for q in qs[2:] for _ in range(3)]  # the results dropped in turn
    gc.collect()
    np.testing.assert_array_equal(first, copy_first)
    np.testing.assert_array_equal(view, copy_view)
    for k, q in enumerate(qs[2:]):
        np.testing.assert_array_equal(later[3 * k], ff.generalized_jacobian(model, q))
    assert not any(np.shares_memory(first, r) or np.shares_memory(view, r) for r in later)


def test_a_dropped_result_gives_its_memory_to_the_next_call() -> None:
    model = ff.models.papadopoulos1992()
    q = np.random.default_rng(4).uniform(-np.pi, np.pi, (SIZE, 4))
    a = ff.generalized_jacobian(model, q)
    where = _address(a)
    b = ff.generalized_jacobian(model, q)  # a still held: another buffer
    assert _address(b) != where
    del a
    c = ff.generalized_jacobian(model, q)
    assert _address(c) == where
    np.testing.assert_array_equal(c, b)
    small = ff.generalized_jacobian(model, q[:100])  # under RECYCLE_MIN: a plain array of its own
    assert small.base is None or small.base.nbytes < _arrays.RECYCLE_MIN


def test_the_kept_buffers_stay_under_their_bound() -> None:
    shape = (_arrays.RECYCLE_MAX // 8 // 1000 - 1, 1000)  # just under the largest recycled size
    held = [_arrays.new_output(shape) for _ in range(4)]  # all held: more than RECYCLE_HELD in all
    assert sum(b.nbytes for b in _arrays._RECYCLED) <= _arrays.RECYCLE_HELD
    del held
    again = [_arrays.new_output(shape) for _ in range(2)]
    assert sum(b.nbytes for b in _arrays._RECYCLED) <= _arrays.RECYCLE_HELD
    assert all(any(np.shares_memory(a, b) for b in _arrays._RECYCLED) for a in again)  # the freed ones served them
    too_large = _arrays.new_output((_arrays.RECYCLE_MAX // 8 + 1,))
    assert not any(np.shares_memory(too_large, b) for b in _arrays._RECYCLED)


def test_release_buffers_drops_the_free_buffers_and_keeps_the_held_ones() -> None:
    """ff.mechanics.release_buffers gives back the kept buffers no result uses, and not the one under a held result."""
    model = ff.models.papadopoulos1992()
    rng = np.random.default_rng(5)
    held = ff.generalized_jacobian(model, rng.uniform(-np.pi, np.pi, (SIZE, 4)))
    copy_held = held.copy()
    ff.generalized_jacobian(model, rng.uniform(-np.pi, np.pi, (SIZE + 100, 4)))  # dropped at once
    gc.collect()
    assert len(_arrays._RECYCLED) == 2
    dropped = ff.mechanics.release_buffers()
    assert dropped >= (SIZE + 100) * 12 * 4 * 8 and dropped < 2 * (SIZE + 100) * 12 * 4 * 8
    assert len(_arrays._RECYCLED) == 1 and held.base is _arrays._RECYCLED[0]
    assert ff.mechanics.release_buffers() == 0  # the held one stays while held
    ff.generalized_jacobian(model, rng.uniform(-np.pi, np.pi, (SIZE, 4)))  # a new buffer: the held one is not free
    np.testing.assert_array_equal(held, copy_held)
    del held
    gc.collect()
    assert ff.mechanics.release_buffers() > 0 and _arrays._RECYCLED == []


def test_written_before_tells_a_filled_buffer_from_a_new_one() -> None:
    """The streaming stores of the specialised maps are used only where the pages are mapped: in the part of a kept
    buffer that a kernel has filled (``mark_written``), not in a new one, not in one handed out again but never filled,
    not past the part filled, and not once the buffer was dropped."""
    shape = (SIZE, 12, 4)
    first = _arrays.new_output(shape)
    assert not _arrays.written_before(first)  # a new buffer: its pages are mapped at the first write
    del first
    gc.collect()
    second = _arrays.new_output(shape)
    assert not _arrays.written_before(second)  # handed out again, but nothing marked it filled
    _arrays.mark_written(second[: SIZE // 2])
    assert _arrays.written_before(second[: SIZE // 2]) and _arrays.written_before(second[SIZE // 4 : SIZE // 2])
    assert not _arrays.written_before(second) and not _arrays.written_before(second[SIZE // 2 :])
    _arrays.mark_written(second[SIZE // 2 + 1 :])  # not from within the filled part: not recorded
    assert not _arrays.written_before(second)
    _arrays.mark_written(second)
    assert _arrays.written_before(second)
    assert not _arrays.written_before(np.empty(shape))  # not a kept buffer
    del second
    gc.collect()
    assert _arrays.release_buffers() > 0
    assert not _arrays._WRITTEN  # a dropped buffer's record is forgotten
    assert not _arrays.written_before(_arrays.new_output(shape))
