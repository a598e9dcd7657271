"""Joint stops in a stored trajectory: the spans of output samples in which a joint is beyond a limit, found in one
compiled pass over the samples, one range of trajectories per thread."""

from __future__ import annotations

from typing import Any

import numpy as np

from .buffers import owned
from .cache import kernel
from .threads import range_count, run_ranges, threads_for


# ----------------------------------------------------------------- joint-limit spans of recorded trajectories
@kernel(inline="always")
def _span_closed(
    b: int, i: int, side: int, t: int, opened: np.ndarray, furthest: np.ndarray, spans: np.ndarray, value: np.ndarray, count: int
) -> int:  # pragma: no cover - compiled
    """The open span of joint i of trajectory b beyond its limit ``side``, closed at sample t: recorded at ``count``
    (when there is room). Returns the count of spans found."""
    if count < value.shape[0]:
        spans[count, 0], spans[count, 1], spans[count, 2] = b, i, side
        spans[count, 3], spans[count, 4] = opened[b, i, side], t
        value[count] = furthest[b, i, side]
    opened[b, i, side] = -1
    return count + 1


@kernel()
def limit_spans(
    q: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    first: int,
    last: int,
    opened: np.ndarray,
    furthest: np.ndarray,
    spans: np.ndarray,
    value: np.ndarray,
) -> int:  # pragma: no cover - compiled
    """The spans of consecutive samples in which a joint of the trajectories first..last of q (T, B, N) is beyond a
    limit (q > upper or q < lower; NaN is neither, as in the comparisons): one pass over the samples, in time order.

    Writes spans (S, 5): trajectory, joint, bound (0 upper, 1 lower), first sample beyond, first sample back inside
    (T: none), and value (S,): the furthest value reached, the spans of a (trajectory, joint, bound) in time order, as
    many as they hold; returns the count found (more than they hold: call again with more room). ``opened`` (B, N, 2)
    int64 and ``furthest`` (B, N, 2): scratch (the open span's start, -1 when none, and its furthest value). No array
    is made or grown here: arrays that a loop may replace are reference-counted at every sample, which made the pass
    many times slower. The pass reads q in place (a view of a rollout's states is fine) and is several times faster
    than numpy on the same spans."""
    steps, _, joints = q.shape
    count = 0
    for b in range(first, last):
        for i in range(joints):
            opened[b, i, 0] = -1
            opened[b, i, 1] = -1
    for t in range(steps):
        for b in range(first, last):
            for i in range(joints):
                v = q[t, b, i]
                if v > upper[i]:
                    if opened[b, i, 0] < 0:
                        opened[b, i, 0] = t
                        furthest[b, i, 0] = v
                    elif v > furthest[b, i, 0]:
                        furthest[b, i, 0] = v
                elif opened[b, i, 0] >= 0:
                    count = _span_closed(b, i, 0, t, opened, furthest, spans, value, count)
                if v < lower[i]:
                    if opened[b, i, 1] < 0:
                        opened[b, i, 1] = t
                        furthest[b, i, 1] = v
                    elif v < furthest[b, i, 1]:
                        furthest[b, i, 1] = v
                elif opened[b, i, 1] >= 0:
                    count = _span_closed(b, i, 1, t, opened, furthest, spans, value, count)
    for b in range(first, last):  # the spans still open after the last sample
        for i in range(joints):
            for side in range(2):
                if opened[b, i, side] >= 0:
                    count = _span_closed(b, i, side, steps, opened, furthest, spans, value, count)
    return count


def limit_spans_batch(q: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`limit_spans` of every trajectory of q (T, B, N), on one range of trajectories per thread from 16 of them:
    (spans (S, 5), value (S,)), the ranges' spans one after another (trajectories in order). Each range starts with
    room for 2 spans per joint and trajectory; one that finds more runs again with room for all of them."""
    lower, upper = owned(lower), owned(upper)  # C-contiguous, writable float64: one compiled signature
    batch, joints = q.shape[1], q.shape[2]
    opened = np.empty((batch, joints, 2), dtype=np.int64)
    furthest = np.empty((batch, joints, 2))
    parts = threads_for(batch, 16)
    found: list[Any] = [None] * range_count(batch, parts)

    def run(r: int, first: int, last: int) -> None:
        room = 2 * joints * (last - first) + 16
        while True:
            spans, value = np.empty((room, 5), dtype=np.int64), np.empty(room)
            count = limit_spans(q, lower, upper, first, last, opened, furthest, spans, value)
            if count <= room:
                found[r] = (spans[:count], value[:count])
                return
            room = count

    run_ranges(run, batch, parts)
    spans, value = (np.concatenate(part) for part in zip(*found, strict=True))
    return spans, value
