"""The tasks of ``denoise``, run inside a Dask worker (:mod:`._tasks` holds the others).

Between stage 1 (`cache_tile`) and stage 2 one task finds the merged survey's float32
origin (`survey_origin`); stage 2 (`denoise_distances`) returns each tile's mean
neighbour distances and their sums, from which the engine takes one threshold
(`sor_threshold`); stage 3 (`denoise_write`) applies it.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from .. import _core
from .._classification import noise_classes, usable_points
from .._far_points import check_fewer_than_kept
from ._origin import far_points_error, merged_float32_origin
from ._plan import Box, covers, grow, meets, room_inside
from ._tasks import (
    Job,
    Tile,
    context_parts,
    guarded,
    in_metres,
    load_cached,
    tile_folder,
    write_tile,
    writing,
)

__all__ = ["denoise_distances", "denoise_write", "sor_threshold", "survey_origin"]


def survey_origin(job: Job, tiles: list[Tile]) -> dict[str, Any]:
    """Between stages 1 and 2 of ``denoise``: the float32 origin of one run over the
    merged survey (of `tiles`, stage 1 done), from which its far points are decided."""
    folders = [tile_folder(job, tile) for tile in tiles]
    return guarded(lambda: {"origin": merged_float32_origin(folders)})


def denoise_distances(
    job: Job, tile: Tile, survey: Box, origin: tuple, others: list[Tile]
) -> dict[str, Any]:
    """Stage 2 of ``denoise``: each own point's mean neighbour distance, exact.

    The k nearest neighbours of a point are exact when the farthest of them is closer
    than the buffer's edge. Where it is not, the buffer doubles (up to the whole
    survey) until it is: the distances are then those of the merged cloud. Points
    beyond float32's reach of `origin`, the merged run's (:func:`survey_origin`), are
    far, as in the merged run.
    """

    def work() -> dict[str, Any]:
        own = load_cached(job, tile)
        valid = usable_points(own)
        mine = np.ascontiguousarray(own.points[valid])
        margin = job.buffer
        while True:
            reach = grow(tile.box, margin)
            near = [other for other in others if meets(reach, other.box)]
            parts = context_parts(job, near, [reach])
            xyz = np.concatenate([mine] + [p.points for _, _, p in parts])
            whole = covers(reach, survey)
            if not len(mine):
                distance = np.empty(0, np.float32)
                break
            metres = in_metres(job, xyz)
            # Far points are left out, as the core leaves them out, but here whatever
            # their number: the limit on it is the merged run's, over the whole survey
            # (_origin.far_points_error).
            kept = _core.rows_within_float32_reach(metres, np.asarray(origin, float))
            if not len(kept) or kept[0] >= len(mine):  # every own point far: no buffer
                distance = np.full(len(mine), np.inf, np.float32)
                break
            if job.params.mean_k >= len(kept):  # too few points yet: a wider buffer
                if whole:  # the merged run's messages, in its order
                    k, n = job.params.mean_k, len(xyz)
                    if k >= n:
                        raise ValueError(f"mean_k must be < the number of points ({n}), got {k}")
                    too_many_far = far_points_error(n - len(kept), n)
                    if too_many_far:
                        raise ValueError(too_many_far)
                    check_fewer_than_kept("mean_k", k, len(kept), n)
                margin = max(2.0 * margin, 1.0)  # from a zero buffer too
                continue
            # In the merged run's float32 frame: the same coordinates, so the same
            # distances, as one run over the merged survey (when none of its points is
            # far; that run frames its kept points anew).
            _, kept_distance, _, kept_farthest = _core.statistical_outlier_removal(
                metres if len(kept) == len(xyz) else metres[kept],
                job.params.to_core(),
                np.asarray(origin, float),
            )
            distance = np.full(len(xyz), np.inf, np.float32)  # a far point's, as the core's
            farthest = distance.copy()
            distance[kept], farthest[kept] = kept_distance, kept_farthest
            # Distances in metres; farthest as a bound on x, y offsets in their unit.
            distance, farthest = distance[: len(mine)], farthest[: len(mine)] / job.scale[0]
            # A far point (inf: left out, as in the merged run) waits for no buffer.
            short = np.isfinite(farthest) & (farthest > room_inside(mine, reach, survey))
            if not short.any() or whole:
                break
            margin = max(2.0 * margin, float(farthest[short].max()) * 1.01 + margin)
        with writing("the scratch folder"):
            np.save(os.path.join(tile_folder(job, tile), "distance.npy"), distance)
        counted = distance[np.isfinite(distance)]  # far points stay out of mu and sigma
        d64 = counted.astype(np.float64)
        squares = (counted * counted).astype(np.float64)  # float products, as PCL sums them
        return {
            "points": len(own),
            "count": len(counted),
            "far": len(distance) - len(counted),
            "sum": float(d64.sum()),
            "sum_sq": float(squares.sum()),
            "buffer_used": margin,
        }

    return guarded(work)


def denoise_write(
    job: Job, tile: Tile, threshold: float, measured: dict[str, Any]
) -> dict[str, Any]:
    """Stage 3 of ``denoise``: the global threshold applied, class 7 for outliers.

    `measured` is the tile's stage-2 result; its buffer and time are reported too.
    """

    def work() -> dict[str, Any]:
        own = load_cached(job, tile)
        valid = usable_points(own)
        distance = np.load(os.path.join(tile_folder(job, tile), "distance.npy"))
        outlier = np.zeros(len(own), bool)
        outlier[valid] = (distance > threshold) | np.isinf(distance)  # far: always
        classes = noise_classes(own, valid, outlier)
        write_tile(tile, own.points, dict(own.fields, classification=classes), own)
        return {
            "points": len(own),
            "noise": int(outlier.sum()),
            "far_points": int(np.isinf(distance).sum()),  # of the `usable` points
            "usable": int(valid.sum()),
            "threshold": threshold,
            "buffer_used": measured["buffer_used"],
            "distance_seconds": measured["seconds"],
        }

    return guarded(work)


def sor_threshold(sums: list[dict[str, Any]], std_mul: float) -> float:
    """mu + std_mul * sigma over every tile's distances, as the core computes it."""
    count = float(sum(s["count"] for s in sums))
    if count < 2:  # no deviation to measure: as the core, no point is an outlier
        return float("nan")
    total = sum(s["sum"] for s in sums)
    total_sq = sum(s["sum_sq"] for s in sums)
    mean = total / count
    variance = (total_sq - total * total / count) / (count - 1.0)
    return mean + std_mul * float(np.sqrt(variance)) if variance >= 0 else float("nan")
