"""The Dask client of a batch run, with a local cluster that Ctrl-C cannot cut in half."""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import threading
from collections.abc import Callable, Iterator
from typing import Any


@contextlib.contextmanager
def held_interrupts() -> Iterator[None]:
    """Hold Ctrl-C (SIGINT) and a SIGTERM handler set in Python back to the block's end.

    A ``LocalCluster`` registers itself with Dask before its workers have started. An
    interrupt in between left a cluster that nobody owned, and Dask's exit hook then
    failed to close it: a traceback ending in ``AssertionError: Status.init`` after
    pcl-rg's own one-line message. Held back, the first interrupt's handler runs when
    the block ends, once the cluster is whole and its owner can close it. Signal
    handlers can only be set in the main thread; elsewhere nothing is held.
    """
    held: dict[int, Callable[[int, Any], Any]] = {}
    if threading.current_thread() is threading.main_thread():
        for signum in (signal.SIGINT, signal.SIGTERM):
            handler = signal.getsignal(signum)
            if callable(handler):  # not SIG_DFL or SIG_IGN
                held[signum] = handler
    arrived: list[int] = []

    def record(signum: int, frame: object) -> None:
        if not arrived:
            arrived.append(signum)

    previous = {signum: signal.signal(signum, record) for signum in held}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    if arrived:
        held[arrived[0]](arrived[0], None)


@contextlib.contextmanager
def dask_client(workers: int | None, scheduler: str | None) -> Iterator[Any]:
    """A Dask client: of `scheduler`, or of a local cluster of one-thread processes."""
    from distributed import Client, LocalCluster

    if scheduler:
        with Client(scheduler) as client:
            yield client
        return
    with contextlib.ExitStack() as stack:
        with held_interrupts():  # an interrupt raises here, and the stack closes both
            cluster = stack.enter_context(
                LocalCluster(
                    n_workers=workers or os.cpu_count() or 1,
                    threads_per_worker=1,
                    processes=True,
                    # Any free port: the scheduler's HTTP server (the dashboard, when
                    # bokeh is installed) must not collide with another cluster's 8787.
                    dashboard_address=":0",
                    silence_logs=logging.ERROR,
                )
            )
            client = stack.enter_context(Client(cluster))
        yield client
