"""Pictures of point clouds: top views and vertical profiles, to PNG (matplotlib)."""

from __future__ import annotations

import os
from collections.abc import Mapping

import numpy as np
import numpy.typing as npt

from ._validation import as_points

__all__ = ["CLASS_COLOURS", "top_view"]

# ASPRS classes as used in pcl_rg's outputs and synthetic scenes.
CLASS_COLOURS: dict[int, tuple[str, str]] = {
    1: ("unclassified / object", "#d62728"),
    2: ("ground", "#8c6d31"),
    5: ("vegetation", "#2ca02c"),
    6: ("building", "#1f77b4"),
    7: ("noise", "#e377c2"),
}


def _pyplot():
    try:
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt
    except ImportError as error:  # pragma: no cover - depends on the environment
        raise ImportError(
            "pcl_rg.plot needs matplotlib: pip install 'pcl_rg[plot]'"
        ) from error
    return plt


def top_view(
    points: npt.ArrayLike,
    path: str | os.PathLike,
    *,
    classes: npt.ArrayLike | None = None,
    class_names: Mapping[int, tuple[str, str]] | None = None,
    title: str = "",
    max_points: int = 400_000,
) -> None:
    """Write a top view (x, y) of the points to a PNG file.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Coordinates in metres.
    path : str or path-like
        Output PNG file.
    classes : array_like of int, shape (N,), optional
        A class per point (ASPRS codes, see `CLASS_COLOURS`), drawn in its
        colour with a legend. Without it, points are coloured by height.
    class_names : mapping, optional
        Code -> (label, colour) overriding `CLASS_COLOURS`.
    title : str
        Figure title.
    max_points : int
        At most this many points are drawn (an even, seeded subsample).

    Examples
    --------
    >>> import numpy as np, tempfile, os
    >>> from pcl_rg.plot import top_view
    >>> pts = np.random.default_rng(0).uniform(0, 10, (100, 3))
    >>> with tempfile.TemporaryDirectory() as d:
    ...     top_view(pts, os.path.join(d, "v.png"), classes=np.full(100, 2))
    ...     os.path.getsize(os.path.join(d, "v.png")) > 0
    True
    """
    plt = _pyplot()
    xyz = as_points(points)
    labels = None if classes is None else np.asarray(classes).ravel()
    if labels is not None and len(labels) != len(xyz):
        raise ValueError(f"classes must have one entry per point ({len(xyz)}), got {len(labels)}")
    if len(xyz) > max_points:
        keep = np.sort(np.random.default_rng(0).choice(len(xyz), max_points, replace=False))
        xyz = xyz[keep]
        labels = None if labels is None else labels[keep]
    names = {**CLASS_COLOURS, **(class_names or {})}
    fig, ax = plt.subplots(figsize=(8, 8), dpi=110)
    try:
        if labels is None:
            sc = ax.scatter(xyz[:, 0], xyz[:, 1], c=xyz[:, 2], s=0.3, cmap="viridis", linewidths=0)
            fig.colorbar(sc, ax=ax, label="z (m)", shrink=0.8)
        else:
            # Draw the most common class first so rarer ones stay visible on top.
            codes, counts = np.unique(labels, return_counts=True)
            for code in codes[np.argsort(-counts)]:
                sel = labels == code
                label, colour = names.get(int(code), (f"class {code}", None))
                ax.scatter(xyz[sel, 0], xyz[sel, 1], s=0.3, color=colour, linewidths=0,
                           label=f"{label} ({sel.sum():,})")
            ax.legend(markerscale=20, loc="upper right", fontsize=8)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        if title:
            ax.set_title(title)
        fig.savefig(os.fspath(path), bbox_inches="tight")
    finally:
        plt.close(fig)
