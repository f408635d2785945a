"""The working memory that the C++ core keeps between calls.

The core's large arrays (4 MiB and up: on 10M points tin_ground's come to about
1.3 GB at their peak) are kept when a call frees them, so that the next call reuses
them instead of having the kernel map and zero fresh memory. On the 2-core hosts of
benchmarks/RESULTS.md that saved tin_ground up to a second of system time per call on
10M points. Kept and live together, the core's arrays never take more than the most
they have taken at once in this process; but what other code allocates between calls
(the next tile read, NumPy's arrays) comes on top of the kept blocks, so call
`release_memory` before such work when the peak matters. ``pcl_rg.batch`` does so after
each task.
"""

from __future__ import annotations

import operator

from . import _core

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
    limit of `set_memory_cache_limit` and within the most memory its arrays have
    ever taken at once in this process. Call this after the last filter of a
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
        If `nbytes` is negative or larger than 2**64 - 1.
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
    if isinstance(nbytes, bool):
        raise TypeError("nbytes must be an integer number of bytes, got a bool")
    try:
        value = operator.index(nbytes)
    except TypeError:
        raise TypeError(
            f"nbytes must be an integer number of bytes, got {type(nbytes).__name__}"
        ) from None
    if not 0 <= value < 2**64:
        raise ValueError(f"nbytes must be in [0, 2**64 - 1], got {value}")
    return int(_core.block_cache_set_limit(value))
