"""What the core measured during a call, without changing what the call returns.

Every algorithm records what its core counted and timed (iterations, seeds, TIN
size, stage times, thresholds, cluster counts) into the collector that is active
in the calling thread, if any::

    with pcl_rg.collect_diagnostics() as diagnostics:
        labels = pcl_rg.region_growing(points)
    diagnostics["region_growing"]["growth_seconds"]

Without an active collector recording costs one context-variable look-up.
"""

from __future__ import annotations

import contextvars
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any, NamedTuple

__all__ = ["Diagnostics", "Record", "collect_diagnostics", "record", "record_segmentation"]


class Record(NamedTuple):
    """One call's measurements."""

    function: str
    """Public name of the function, e.g. ``"tin_ground"``."""
    values: dict[str, Any]
    """What it measured: counts (int), seconds (float), thresholds (float)."""


class Diagnostics:
    """The records of every call made while collecting, in call order.

    ``diagnostics[name]`` is the values of the latest call of the function
    `name`; ``diagnostics.records`` holds them all.
    """

    def __init__(self) -> None:
        self.records: list[Record] = []

    def __getitem__(self, function: str) -> dict[str, Any]:
        for entry in reversed(self.records):
            if entry.function == function:
                return entry.values
        called = sorted({entry.function for entry in self.records})
        raise KeyError(f"no call of {function!r} was recorded (recorded: {called})")

    def __contains__(self, function: object) -> bool:
        return any(entry.function == function for entry in self.records)

    def __len__(self) -> int:
        """The number of functions recorded (0, and falsy, before any call)."""
        return len({entry.function for entry in self.records})

    def __iter__(self) -> Iterator[str]:
        """The names of the functions recorded, each once, in the order of their first
        call (without it, iteration would fall back to diagnostics[0], a KeyError)."""
        return iter(dict.fromkeys(entry.function for entry in self.records))

    def __repr__(self) -> str:
        return f"Diagnostics({self.records!r})"


_ACTIVE: contextvars.ContextVar[Diagnostics | None] = contextvars.ContextVar(
    "pcl_rg_diagnostics", default=None
)


@contextmanager
def collect_diagnostics() -> Iterator[Diagnostics]:
    """Collect the measurements of every pcl_rg call made in this block.

    Collection is per thread (and per asyncio task): calls made by other
    threads are not recorded. Collectors nest: what an inner one records
    reaches every one around it when its block ends (pcl_rg's own functions
    that collect for themselves, as :func:`pcl_rg.pipeline.seed004` does, hide
    nothing from the caller's).

    Yields
    ------
    Diagnostics
        Filled as the calls return; index it by function name.

    Examples
    --------
    >>> import numpy as np
    >>> import pcl_rg
    >>> points = np.random.default_rng(0).uniform(0.0, 50.0, (3000, 3))
    >>> with pcl_rg.collect_diagnostics() as diagnostics:
    ...     ground = pcl_rg.tin_ground(points)
    >>> diagnostics["tin_ground"]["iterations"] >= 1
    True
    """
    collector = Diagnostics()
    token = _ACTIVE.set(collector)
    try:
        yield collector
    finally:
        _ACTIVE.reset(token)
        outer = _ACTIVE.get()
        if outer is not None:
            outer.records.extend(collector.records)


def record_segmentation(
    function: str,
    points: int,
    labels: Any,
    normals_seconds: float,
    growth_seconds: float,
    far_points: int,
) -> None:
    """Record a region-growing call: its cluster count, its two stage times and how many
    far points it left out."""
    record(
        function,
        points=points,
        clusters=int(labels.max(initial=-1)) + 1,
        normals_seconds=normals_seconds,
        growth_seconds=growth_seconds,
        far_points=far_points,
    )


def record(function: str, **values: Any) -> None:
    """Add one call's measurements to the active collector, if there is one."""
    collector = _ACTIVE.get()
    if collector is not None:
        collector.records.append(Record(function, values))
