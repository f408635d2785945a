"""Dask's own log lines kept out of a batch run's output, on the local cluster that
the run starts (imported with Dask, when a run starts one)."""

from __future__ import annotations

import logging
from typing import Any

from distributed.diagnostics.plugin import WorkerPlugin

# Every failure of a run reaches the caller as a raised error. What Dask logs as ERROR
# meanwhile is noise about its own shutdown: a worker whose heartbeat found the
# scheduler already closed printed a 30-line "Failed to communicate with scheduler
# during heartbeat" traceback after pcl-rg's one-line "interrupted" (CI, once in many
# Ctrl-C runs). So the terminal output of the `distributed` loggers keeps only what
# is at this level or above: in each worker process for good (QuietDaskLogs), and in
# the main process while the cluster is open (its ``silence_logs``, undone when it
# closes: a library's caller keeps its own logging).
DASK_LOG_LEVEL = logging.CRITICAL


def below_dask_log_level(record: logging.LogRecord) -> bool:
    """A logging filter: whether `record` is at :data:`DASK_LOG_LEVEL` or above."""
    return record.levelno >= DASK_LOG_LEVEL


class QuietDaskLogs(WorkerPlugin):
    """Adds :func:`below_dask_log_level` to the terminal handlers of each worker
    process's `distributed` logger.

    The cluster's ``silence_logs`` raises those handlers' level while the worker runs,
    but the worker's ``close`` puts the old level back, and the heartbeat's traceback
    came after that. A filter stays. It is on the terminal handlers only, not on the
    logger: the worker's own log (``Client.get_worker_logs``, the dashboard) still
    records everything. Registered with the scheduler, the plugin also reaches a
    worker that Dask restarts during the run.
    """

    def setup(self, worker: Any) -> None:
        for handler in logging.getLogger("distributed").handlers:
            terminal = isinstance(handler, logging.StreamHandler) and not isinstance(
                handler, logging.FileHandler
            )
            if terminal:  # addFilter adds the same filter once
                handler.addFilter(below_dask_log_level)
