"""The Dask client of a batch run, with a local cluster that Ctrl-C cannot cut in half."""

from __future__ import annotations

import contextlib
import logging
import os
from collections.abc import Iterator
from typing import Any

from .._held_signals import held_signals


@contextlib.contextmanager
def dask_client(workers: int | None, scheduler: str | None) -> Iterator[Any]:
    """A Dask client: of `scheduler`, or of a local cluster of one-thread processes."""
    from distributed import Client, LocalCluster

    if scheduler:
        with Client(scheduler) as client:
            yield client
        return
    # A LocalCluster registers itself with Dask before its workers have started. An
    # interrupt in between left a cluster that nobody owned, and Dask's exit hook then
    # failed to close it: a traceback ending in "AssertionError: Status.init" after
    # pcl-rg's own one-line message. Held back, the interrupt is raised once the
    # cluster is whole, and the stack closes it.
    with contextlib.ExitStack() as stack:
        with held_signals() as held:
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
        held.run_pending()
        yield client
