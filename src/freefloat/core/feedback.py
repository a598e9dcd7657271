"""What a long step tells the user: one line when it starts, progress while it runs (private helpers).

- :func:`notice`: a one-line message about a step that takes seconds or more (the first-use compile of
  the kernels): on standard error, and to the ``freefloat`` logger (standard :mod:`logging`) at INFO.
- :func:`interactive`: whether standard error is a terminal. Progress bars are drawn only there;
  elsewhere (batch jobs, notebooks, CI logs) progress goes to the ``freefloat.progress`` logger at
  INFO, at most every :data:`LOG_PERIOD` seconds (configure ``logging`` to see it, e.g.
  ``logging.basicConfig(level=logging.INFO)``).
"""

from __future__ import annotations

import logging
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any

__all__ = ["LOG_PERIOD", "QUICK", "Step", "advance", "current", "interactive", "notice", "progress_log", "status"]

#: Seconds between two progress lines sent to the logger (outside a terminal).
LOG_PERIOD = 10.0

#: A step that ends within this many seconds logs no "done" line (its start line is enough).
QUICK = 1.0

logger = logging.getLogger("freefloat")
progress_log = logging.getLogger("freefloat.progress")


def interactive() -> bool:
    """True when standard error is a terminal (a progress bar can be drawn there)."""
    try:
        return bool(sys.stderr.isatty())
    except (AttributeError, ValueError):
        return False


def notice(message: str) -> None:
    """Say ``message`` (one line) on standard error and to the ``freefloat`` logger."""
    logger.info(message)
    try:
        print(f"freefloat: {message}", file=sys.stderr, flush=True)
    except (AttributeError, ValueError, OSError):
        pass


class Step:
    """A step in progress (what :func:`status` yields): :meth:`advance` counts the work done towards ``total``."""

    def __init__(self, message: str, total: float | None, unit: str) -> None:
        self.message, self.total, self.unit = message, total, unit
        self.done = 0.0
        self.start = time.perf_counter()
        self.logged = self.start
        self.bar: Any = None
        self.task: Any = None

    def advance(self, amount: float) -> None:
        """Count ``amount`` more units of work done: the bar moves on a terminal; elsewhere a line goes to the
        ``freefloat.progress`` logger at most every :data:`LOG_PERIOD` seconds."""
        self.done += amount
        if self.bar is not None:
            self.bar.update(self.task, completed=self.done, count=self.count())
            return
        now = time.perf_counter()
        if now - self.logged >= LOG_PERIOD:
            self.logged = now
            progress_log.info("%s: %s, %.3g s elapsed", self.message, self.count(), now - self.start)

    def expect(self, total: float, unit: str) -> None:
        """Set the amount of work the step will count (when it is known only inside the step)."""
        self.total, self.unit = float(total), unit
        if self.bar is not None:
            self.bar.update(self.task, total=self.total, count=self.count())

    def count(self) -> str:
        """``"1,024 / 65,536 configurations (2%)"``, or the count alone without a total."""
        if self.total is None or self.total <= 0:
            return f"{self.done:,.0f} {self.unit}".rstrip()
        return f"{self.done:,.0f} / {self.total:,.0f} {self.unit} ({100.0 * self.done / self.total:.0f}%)".replace("  ", " ")


_STEP: ContextVar[Step | None] = ContextVar("freefloat_feedback_step", default=None)


def current() -> Step | None:
    """The innermost :func:`status` step running in this context (None outside one)."""
    return _STEP.get()


def advance(amount: float) -> None:
    """Count ``amount`` units of work done in the innermost :func:`status` step with a total (nothing outside one)."""
    step = _STEP.get()
    if step is not None and step.total is not None:
        step.advance(amount)


@contextmanager
def status(message: str, total: float | None = None, unit: str = "") -> Iterator[Step]:
    """A step of a long computation (``"PIW of arm1_ee: 65,536 sampled configurations"``).

    On a terminal: a spinner with the message and the elapsed time while it runs, and, with a ``total``, a bar with
    the count of ``unit`` done (the work inside calls :func:`advance`); it disappears when the step ends. Elsewhere
    (batch jobs, notebooks, CI logs): a line to the ``freefloat.progress`` logger when the step starts, one with
    the count every :data:`LOG_PERIOD` seconds, and one with its duration when it ends after more than
    :data:`QUICK` seconds. Yields the :class:`Step`.
    """
    step = Step(message, total, unit)
    token = _STEP.set(step)
    try:
        if interactive():
            from rich.console import Console
            from rich.progress import BarColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

            columns = (SpinnerColumn(), TextColumn(message), BarColumn(), TextColumn("{task.fields[count]}"), TimeElapsedColumn())
            with Progress(*columns, console=Console(stderr=True), transient=True) as bar:
                step.bar, step.task = bar, bar.add_task(message, total=total, count=step.count() if total else "")
                yield step
            step.bar = None
            return
        progress_log.info("%s ...", message)
        yield step
        took = time.perf_counter() - step.start
        if took >= QUICK:
            progress_log.info("%s: done in %.3g s", message, took)
    finally:
        _STEP.reset(token)
