"""Warnings raised in a tile's task, caught there and handed back with its result.

Left alone, a worker process prints a warning on its own stderr in Python's format,
naming a line of Dask's (``…/dask/_task_spec.py:768: UserWarning: …``), and no
``pcl-rg: warning:`` line; with an existing scheduler it lands in the worker's log,
not the user's. A task records its warnings instead; the parent re-emits each, named
by its tile (:func:`pcl_rg.batch._engine.run`).

``warnings.catch_warnings`` is not per thread before Python 3.14: tasks of one
multi-threaded worker (an in-process cluster, ``dask worker --nthreads 4``) would
take each other's warnings and restore each other's settings. So the first task that
starts in a process installs one hook that hands each task thread's warnings to its
own list, and the last that ends removes it. While it is in, every warning is shown
("always"): a worker outlives a run and would otherwise show a repeated warning only
once, and the parent's filters, not the worker's, decide what the user sees.
"""

from __future__ import annotations

import contextlib
import threading
import warnings
from collections.abc import Iterator
from typing import Any

__all__ = ["caught"]

_lock = threading.Lock()
_thread = threading.local()  # .found: the running task's list, on its thread
_tasks = 0  # tasks running in this process
_saved: Any = None  # the catch_warnings that restores the process's settings


def _show(message: Any, category: type[Warning], *where: Any, previous: Any) -> None:
    found = getattr(_thread, "found", None)
    if found is None:  # a thread that is no task: as before
        previous(message, category, *where)
    else:
        found.append((category, str(message)))


@contextlib.contextmanager
def caught() -> Iterator[list[tuple[type[Warning], str]]]:
    """The warnings raised on this thread within the block: (category, message) each."""
    global _tasks, _saved
    with _lock:
        if _tasks == 0:
            _saved = warnings.catch_warnings()
            _saved.__enter__()
            warnings.simplefilter("always")
            previous = warnings.showwarning
            warnings.showwarning = lambda *args: _show(*args, previous=previous)
        _tasks += 1
    found: list[tuple[type[Warning], str]] = []
    _thread.found = found
    try:
        yield found
    finally:
        _thread.found = None
        with _lock:
            _tasks -= 1
            if _tasks == 0:
                _saved.__exit__(None, None, None)
                _saved = None
