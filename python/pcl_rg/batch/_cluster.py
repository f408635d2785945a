"""The Dask client of a batch run, with a local cluster that Ctrl-C cannot cut in half."""

from __future__ import annotations

import contextlib
import os
import signal
import threading
import warnings
from collections.abc import Iterator
from multiprocessing import resource_tracker
from typing import Any

from .._caller import outside_stacklevel
from .._held_signals import held_signals


@contextlib.contextmanager
def _workers_deaf_to_ctrl_c() -> Iterator[None]:
    """SIGINT blocked in the calling thread for the block, so that the threads started
    in it (Dask's event loop, which starts and restarts the worker processes) and the
    processes they start inherit the blocked signal.

    Ctrl-C in a terminal signals the whole foreground process group, the workers too:
    each printed a KeyboardInterrupt traceback beside pcl-rg's one-line message, and
    one that died while starting failed the run with "Nanny failed to start" (exit 1,
    not 130). The main process alone handles Ctrl-C and closes the cluster, which
    ends the workers. A SIGINT that reaches the calling thread meanwhile is delivered
    when the block ends (held_signals then holds it).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    # The first process a thread starts by "spawn" starts multiprocessing's resource
    # tracker, and the thread unblocks SIGINT and SIGTERM after: started here, before the
    # block, the tracker leaves the event loop's mask alone.
    resource_tracker.ensure_running()
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


# Seconds a Client may take beyond twice Dask's connect timeout (_connect): the
# scheduler's handshake and the Client's start after the connection.
CONNECT_SLACK_SECONDS = 5.0


def _connect(scheduler: str) -> Any:
    """A Client of the scheduler at `scheduler`, or ConnectionError when what answers
    there is not one.

    Dask's own connect timeout does not cover a server that accepts the connection and
    then stays silent (dask/distributed#8071): the Client waited for ever. And an HTTP
    server (the dashboard's port, 8787) sent back bytes that Dask read as a message
    length, which failed as "MemoryError: Unable to allocate 3.07 EiB". So the Client
    is made in a thread of its own, given twice Dask's connect timeout and
    CONNECT_SLACK_SECONDS.
    """
    import dask
    from dask.utils import parse_timedelta
    from distributed import Client

    connect_timeout = parse_timedelta(dask.config.get("distributed.comm.timeouts.connect"))
    limit = 2.0 * connect_timeout + CONNECT_SLACK_SECONDS
    port_hint = "a scheduler listens on port 8786 unless told otherwise"
    outcome: dict[str, Any] = {}
    # A Client that connects after the caller gave up is closed at once, not left open
    # in a thread that nobody joins.
    given_up = False
    lock = threading.Lock()

    def connect() -> None:
        try:
            client = Client(scheduler)
        except BaseException as error:  # handed to the caller's thread below
            with lock:
                outcome["error"] = error
            return
        with lock:
            late = given_up
            if not late:
                outcome["client"] = client
        if late:
            client.close()

    # A daemon thread: one still waiting on a silent server must not hold up the exit.
    attempt = threading.Thread(target=connect, name="pcl_rg connect", daemon=True)
    attempt.start()
    attempt.join(limit)
    with lock:
        given_up = not outcome
    if given_up:
        raise ConnectionError(
            f"no Dask scheduler answered at {scheduler} within {limit:g} s "
            f"(is one running there? {port_hint})"
        )
    error = outcome.get("error")
    if isinstance(error, MemoryError):
        raise ConnectionError(
            f"what answered at {scheduler} is not a Dask scheduler (is it a dashboard's "
            f"address? {port_hint})"
        ) from error
    if error is not None:
        raise error
    return outcome["client"]


#: How long a run waits for the first worker of a scheduler that has none before it
#: says so; the tasks would otherwise wait in silence.
WORKER_WAIT_SECONDS = 60.0


def _wait_for_a_worker(client: Any, scheduler: str) -> None:
    """Return once the scheduler has a worker, or with a warning after
    WORKER_WAIT_SECONDS: the run then goes on and waits, since an adaptive cluster
    (dask-jobqueue's, with no minimum) starts its workers only when tasks come, and a
    batch queue may start them late."""
    import asyncio

    try:
        client.wait_for_workers(1, timeout=WORKER_WAIT_SECONDS)
    except (TimeoutError, asyncio.TimeoutError):  # Dask's is asyncio's: not 3.10's builtin
        warnings.warn(
            f"the Dask scheduler at {scheduler} has had no worker for "
            f"{WORKER_WAIT_SECONDS:g} s; the run waits for one (start some with "
            f"`dask worker {scheduler}`)",
            stacklevel=outside_stacklevel(),
        )


@contextlib.contextmanager
def dask_client(workers: int | None, scheduler: str | None) -> Iterator[Any]:
    """A Dask client: of `scheduler`, or of a local cluster of one-thread processes."""
    from distributed import Client, LocalCluster

    from ._dask_logs import DASK_LOG_LEVEL, QuietDaskLogs

    if scheduler:
        with _connect(scheduler) as client:
            _wait_for_a_worker(client, scheduler)
            yield client
        return
    # A LocalCluster registers itself with Dask before its workers have started. An
    # interrupt in between left a cluster that nobody owned, and Dask's exit hook then
    # failed to close it: a traceback ending in "AssertionError: Status.init" after
    # pcl-rg's own one-line message. Held back, the interrupt is raised once the
    # cluster is whole, and the stack closes it.
    with contextlib.ExitStack() as stack:
        with held_signals() as held, _workers_deaf_to_ctrl_c():
            cluster = stack.enter_context(
                LocalCluster(
                    n_workers=workers or os.cpu_count() or 1,
                    threads_per_worker=1,
                    processes=True,
                    # Any free port: the scheduler's HTTP server (the dashboard, when
                    # bokeh is installed) must not collide with another cluster's 8787.
                    dashboard_address=":0",
                    silence_logs=DASK_LOG_LEVEL,
                )
            )
            client = stack.enter_context(Client(cluster))
            # Registered with the scheduler, the plugin also reaches a worker that
            # Dask restarts later in the run.
            client.register_plugin(QuietDaskLogs(), name="pcl_rg quiet dask logs")
        held.run_pending()
        yield client
