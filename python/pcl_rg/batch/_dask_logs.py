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
# Ctrl-C runs). So the `distributed` loggers, of the main process and of each worker
# process, are kept below this level.
DASK_LOG_LEVEL = logging.CRITICAL


class QuietDaskLogs(WorkerPlugin):
    """Keeps the `distributed` loggers of each worker process below
    :data:`DASK_LOG_LEVEL`.

    The cluster's ``silence_logs`` reaches only the main process and the nanny's own
    logger in a worker process, not the worker's. Registered with the scheduler, the
    plugin also reaches a worker that Dask restarts during the run.
    """

    def setup(self, worker: Any) -> None:
        logging.getLogger("distributed").setLevel(DASK_LOG_LEVEL)
