"""Run long core calls one after another, to be stopped by SIGINT from the parent.

tests/test_interrupt.py starts this script and, for each job, waits for its
``calling`` line, sends SIGINT a while later and times the ``interrupted`` line.
Each job prints JSON lines on stdout:

- ``{"job": name, "event": "calling"}`` right before the long call;
- ``{"job": name, "event": "interrupted"}`` as soon as KeyboardInterrupt arrives,
  or ``{"job": name, "event": "finished", "seconds": s}`` if the call ended first;
- ``{"job": name, "event": "after", ...}`` with the Python and OS thread counts
  before and after the call and whether a second, short call gave the result of a
  call made before the interrupted one.

The long calls are sized to run for many seconds (they are never meant to finish):
tin_ground on a large flat cloud, the others through a parameter that multiplies the
work (grid_ground's small cells) or a large k.
"""

from __future__ import annotations

import json
import os
import signal
import sys
import threading
import time
from collections.abc import Callable

import numpy as np

import pcl_rg


def _flat(n: int, side: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(0.0, side, (n, 2)), rng.normal(0.0, 0.05, n)])


def _os_threads() -> int:
    return len(os.listdir("/proc/self/task"))


def _digest(result: object) -> bytes:
    arrays = result if isinstance(result, tuple) else (result,)
    return b"".join(np.ascontiguousarray(a).tobytes() for a in arrays)


def _jobs() -> dict[str, tuple[Callable[[], object], Callable[[], bytes]]]:
    """name -> (the long call, a short call whose result is compared before and after)."""
    small = _flat(20_000, 100.0, 1)
    airborne = _flat(6_000_000, 1000.0, 3)
    surface = _flat(600_000, 150.0, 2)
    return {
        # 6 M points, most of them ground: about 7 s on two cores.
        "tin_ground": (
            lambda: pcl_rg.tin_ground(airborne),
            lambda: _digest(pcl_rg.tin_ground(small)),
        ),
        # Cells of 0.21 m: 22.7 M cells (a dense grid) for 6 M points, about 4 s on two cores.
        "grid_ground": (
            lambda: pcl_rg.grid_ground(airborne, cell_size=0.21),
            lambda: _digest(pcl_rg.grid_ground(small)),
        ),
        # k = 100 on 600 k points: several seconds in the normals loop.
        "normals": (
            lambda: pcl_rg.normals(surface, k=100),
            lambda: _digest(tuple(pcl_rg.normals(small, k=10))),
        ),
        "region_growing": (
            lambda: pcl_rg.region_growing(surface, k=100),
            lambda: _digest(pcl_rg.region_growing(small, k=10)),
        ),
    }


def _emit(**record: object) -> None:
    print(json.dumps(record), flush=True)


def main(names: list[str]) -> None:
    # As in a terminal, also when the tests run in the background of a shell, which
    # starts its children with SIGINT ignored (Python then installs no handler).
    signal.signal(signal.SIGINT, signal.default_int_handler)
    jobs = _jobs()
    # OpenMP starts its pool of threads in the first parallel region and keeps it: start
    # it here, so that the counts below see only threads a call would leave behind.
    pcl_rg.normals(_flat(20_000, 100.0, 5), k=10)
    for name in names or list(jobs):
        long_call, short_call = jobs[name]
        expected = short_call()  # also the warm-up: OpenMP's threads exist from here on
        python_before, os_before = threading.active_count(), _os_threads()
        _emit(job=name, event="calling")
        start = time.perf_counter()
        try:
            long_call()
        except KeyboardInterrupt:
            _emit(job=name, event="interrupted")
        else:
            _emit(job=name, event="finished", seconds=time.perf_counter() - start)
        _emit(
            job=name,
            event="after",
            python_threads=[python_before, threading.active_count()],
            os_threads=[os_before, _os_threads()],
            second_call_same=short_call() == expected,
        )


if __name__ == "__main__":
    main(sys.argv[1:])
