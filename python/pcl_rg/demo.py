"""The main job on the built-in synthetic scene: every algorithm, one table, figures."""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import datasets
from .statistical_outlier_removal import statistical_outlier_removal
from .voxel_grid import voxel_grid

__all__ = ["DemoReport", "run_demo"]

UTM_OFFSET = (500_000.0, 5_000_000.0, 0.0)


@dataclass
class DemoReport:
    """Rows of the demo table and the files written."""

    rows: list[dict[str, Any]] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)

    def table(self) -> str:
        header = f"{'stage':<28}{'points in':>12}{'points out':>12}{'time s':>9}  result"
        lines = [header, "-" * len(header)]
        for row in self.rows:
            lines.append(
                f"{row['stage']:<28}{row['points_in']:>12,}{row['points_out']:>12,}"
                f"{row['seconds']:>9.3f}  {row['result']}"
            )
        return "\n".join(lines)


def _timed(function: Callable[[], Any]) -> tuple[Any, float]:
    start = time.perf_counter()
    value = function()
    return value, time.perf_counter() - start


def run_demo(output: str | os.PathLike = "demo-output", *, seed: int = 0,
             size: float = 300.0, plots: bool = True) -> DemoReport:
    """Run every algorithm on the synthetic scene and write figures to `output`.

    Parameters
    ----------
    output : path-like
        Folder for the figures (created if missing).
    seed, size : int, float
        Scene seed and side length in metres (density 4 points/m2, at a UTM-sized
        offset so the local-origin handling is exercised).
    plots : bool
        Write PNG figures (needs matplotlib).

    Returns
    -------
    DemoReport
        The table rows and the paths written.

    Examples
    --------
    >>> import tempfile
    >>> from pcl_rg.demo import run_demo
    >>> with tempfile.TemporaryDirectory() as d:
    ...     report = run_demo(d, size=100.0, plots=False)
    >>> [row["stage"] for row in report.rows][:2]
    ['StatisticalOutlierRemoval', 'VoxelGrid']
    """
    out = Path(output)
    out.mkdir(parents=True, exist_ok=True)
    report = DemoReport()
    scene = datasets.synthetic_scene(seed=seed, size=size, offset=UTM_OFFSET)
    points, labels = scene.points, scene.labels
    n = len(points)

    inlier, seconds = _timed(lambda: statistical_outlier_removal(points, mean_k=10, std_mul=2.0))
    noise = labels == datasets.NOISE
    caught = int((~inlier & noise).sum())
    report.rows.append(dict(
        stage="StatisticalOutlierRemoval", points_in=n, points_out=int(inlier.sum()),
        seconds=seconds,
        result=f"{caught}/{int(noise.sum())} noise points removed, "
               f"{int((~inlier & ~noise).sum())} others",
    ))

    kept = points[inlier]
    grid, seconds = _timed(lambda: voxel_grid(kept, 1.0))
    report.rows.append(dict(
        stage="VoxelGrid", points_in=len(kept), points_out=len(grid.centroids),
        seconds=seconds, result="leaf 1.0 m",
    ))

    if plots:
        from .plot import top_view

        path = out / "scene_classes.png"
        top_view(points, path, classes=labels,
                 title=f"synthetic scene: true classes ({n:,} points)")
        report.files.append(path)
        path = out / "sor_outliers.png"
        top_view(points, path, classes=np.where(inlier, 2, 7).astype(np.uint8),
                 class_names={2: ("kept", "#bbbbbb"), 7: ("SOR outlier", "#d62728")},
                 title="StatisticalOutlierRemoval (mean_k 10, std_mul 2)")
        report.files.append(path)
    return report
