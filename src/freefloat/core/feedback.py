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

__all__ = ["LOG_PERIOD", "interactive", "notice", "progress_log", "status"]

#: Seconds between two progress lines sent to the logger (outside a terminal).
LOG_PERIOD = 10.0

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


@contextmanager
def status(message: str) -> Iterator[None]:
    """A step of a long computation (``"sampling 65,536 configurations for the PIW of arm1_ee"``): a spinner with the
    message on a terminal while it runs (it disappears after), elsewhere a line to the ``freefloat.progress`` logger
    when it starts and one with its duration when it ends."""
    start = time.perf_counter()
    if interactive():
        from rich.console import Console

        with Console(stderr=True).status(message):
            yield
        return
    progress_log.info("%s ...", message)
    yield
    progress_log.info("%s: done in %.3g s", message, time.perf_counter() - start)
