"""The working memory that the C++ core keeps between calls.

The core's large arrays (4 MiB and up: on 10M points tin_ground's come to about
1.3 GB at their peak) are kept when a call frees them, so that the next call reuses
them instead of having the kernel map and zero fresh memory. On the 2-core hosts of
benchmarks/RESULTS.md that saved tin_ground up to a second of system time per call on
10M points. Between calls the cache keeps at most a quarter more than the most the
core's arrays have asked for at once in this process. (A call may be handed a kept
block larger than it asked for, rather than have kept blocks dropped and new ones
mapped; the quarter leaves room to keep such blocks for the next call: grid_ground on
12 tiles of 2-10M points kept 812 MiB where the largest asked for 666 MiB at once.)
But what other code allocates between calls (the next tile read, NumPy's arrays) comes on top of the
kept blocks, so call `release_memory` before such work when the peak matters.
``pcl_rg.batch`` does so after each task.
"""

from __future__ import annotations

from . import _core
from ._params import check_number

__all__ = ["release_memory", "set_memory_cache_limit"]


def release_memory() -> int:
    """Give the working memory kept between calls back to the system.

    Returns
    -------
    int
        The bytes freed.

    Notes
    -----
    The core keeps each freed array of 4 MiB or more for a later call, within the
    limit of `set_memory_cache_limit` and within a quarter more than the most memory
    its arrays have asked for at once in this process. Call this after the last filter of a
    session, or before other work that needs much memory (the kept arrays would lie
    under it); the next call maps fresh memory again, as it would without the cache.
    Results never depend on the cache: a reused array is written in full before it
    is read.

    Examples
    --------
    >>> import numpy as np, pcl_rg
    >>> points = pcl_rg.datasets.synthetic_scene(seed=0, size=300.0).points
    >>> ground = pcl_rg.tin_ground(points)
    >>> pcl_rg.release_memory() >= 0
    True
    """
    return int(_core.block_cache_release())


def set_memory_cache_limit(nbytes: int) -> int:
    """Set the most working memory the core keeps between calls.

    Parameters
    ----------
    nbytes : int
        Bytes, at least 0. 0 keeps nothing: every array is freed when its call
        ends, and every call maps fresh memory. The default is an eighth of the
        physical memory, or of a cgroup's memory cap when that is lower (0 in an
        AddressSanitizer build).

    Returns
    -------
    int
        The previous limit, in bytes.

    Raises
    ------
    ValueError
        If `nbytes` is negative or does not fit a 64-bit integer.
    TypeError
        If `nbytes` is not an integer (a bool or a float included).

    Notes
    -----
    Lowering the limit frees the kept arrays above it, those kept longest first.
    The limit is one for the process: every thread's calls share the kept memory.

    Examples
    --------
    >>> import pcl_rg
    >>> previous = pcl_rg.set_memory_cache_limit(0)  # keep nothing
    >>> pcl_rg.set_memory_cache_limit(previous)
    0
    """
    value = check_number("nbytes", nbytes, int, minimum=0)
    return int(_core.block_cache_set_limit(value))
