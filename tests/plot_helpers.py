"""Reading what pcl_rg.plot draws: each figure as it is saved."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any


def read_saved_figures(monkeypatch, read: Callable[[Any], Any]) -> list[Any]:
    """Make pcl_rg.plot pass each figure it saves through `read(figure)` first; the list
    of what `read` returned fills as figures are saved."""
    import pcl_rg.plot

    seen: list[Any] = []
    real = pcl_rg.plot._save

    def save(fig, path):
        seen.append(read(fig))
        real(fig, path)

    monkeypatch.setattr(pcl_rg.plot, "_save", save)
    return seen
