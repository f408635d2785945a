"""Ctrl-C and SIGTERM held back while code that must not be cut in half runs."""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Callable, Iterator
from typing import Any


class HeldSignals:
    """The handler of the first signal that arrived in a :func:`held_signals` block."""

    def __init__(self) -> None:
        self.pending: Callable[[], None] | None = None

    def run_pending(self) -> None:
        """Run the held-back handler, if any. One that raises stays pending, so that
        every later call raises too; one that returns has run."""
        if self.pending is not None:
            self.pending()
            self.pending = None


@contextlib.contextmanager
def held_signals() -> Iterator[HeldSignals]:
    """Hold Python's own SIGINT handler (KeyboardInterrupt) and a SIGTERM handler set
    in Python (pcl-rg's raises like Ctrl-C) back for the block; the caller runs the
    first one that arrived with ``run_pending()``, where it is safe to raise.

    Python raises from a handler at whatever Python code runs next: a call from
    lazrs, which then reports its own error and loses the interrupt, or the middle of
    Dask's LocalCluster start, which leaves a cluster nobody can close. Handlers can
    only be set in the main thread; elsewhere, and for signals with no Python handler,
    nothing is held.
    """
    held: dict[int, Callable[[int, Any], Any]] = {}
    if threading.current_thread() is threading.main_thread():
        if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            held[signal.SIGINT] = signal.default_int_handler
        handler = signal.getsignal(signal.SIGTERM)
        if callable(handler):  # not SIG_DFL or SIG_IGN
            held[signal.SIGTERM] = handler
    state = HeldSignals()

    def record(signum: int, frame: object) -> None:
        if state.pending is None:
            state.pending = lambda: held[signum](signum, None)

    previous = {signum: signal.signal(signum, record) for signum in held}
    try:
        yield state
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
