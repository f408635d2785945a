"""The work of one tile, run inside a Dask worker: only paths and small results travel.

Stage 1 (`cache_tile`) decodes a tile once and stores its arrays as ``.npy`` files in
the run's scratch folder. Stage 2 reads its own tile back and, memory-mapped, only
the rows of its neighbours that fall inside its buffer, runs the algorithm on both,
and writes the tile's own points. Denoising needs a global mean and deviation, so
its tasks are in :mod:`._denoise_tasks`.

Every task returns a dict and raises nothing for a bad file: a failed tile is a
result, so its neighbours still run (without its buffer).
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import pickle
import resource
import time
from collections.abc import Callable, Iterator
from typing import Any, NamedTuple

import numpy as np

from .. import grid_ground, release_memory, tin_ground, voxel_grid
from .._classification import (
    existing_classes,
    ground_classes,
    no_data_values,
    noise_mask,
    usable_points,
    voxel_attributes,
)
from ..io import CoordinateUnits, PointFile, read_extent, read_points, write_points
from ..io._pcd import unorganized
from ._caught import caught
from ._headers import check_header_box, crs_records
from ._origin import save_sorted_axes
from ._plan import FOOTPRINT_GAP, Box, covers, footprint, grow, meets

__all__ = [
    "Job",
    "cache_tile",
    "context_parts",
    "downsample_tile",
    "ground_tile",
    "guarded",
    "in_metres",
    "load_cached",
    "passed_on",
    "tile_extent",
    "tile_folder",
    "Tile",
    "WriteFailure",
    "write_tile",
    "writing",
]

GROUND_METHODS: dict[str, Callable[..., np.ndarray]] = {"grid": grid_ground, "tin": tin_ground}


@dataclasses.dataclass(frozen=True)
class Job:
    """What every task of a run needs to know, besides its tile."""

    operation: str  # "ground", "denoise" or "downsample"
    params: Any  # the operation's params dataclass
    buffer: float  # in the units of x and y (metres until the engine reads the tiles)
    scratch: str  # folder of the stage-1 arrays
    method: str = "grid"  # ground only
    keep_classes: bool = False  # ground only: non-ground points keep their class
    units: str | None = None  # as given by the caller (GIVEN_UNITS), else the tiles'
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)  # metres per unit of x, y, z


class Tile(NamedTuple):
    """One input of the run, as every task that reads or writes it names it."""

    index: int  # position among the inputs: the name of its scratch folder
    path: str  # the input file
    output: str  # its output file
    box: Box  # its points' xy box (an empty box at 0 when it has no finite point)


class WriteFailure(OSError):
    """An OSError of writing a tile's output or its scratch files (a full disk, no
    permission): the machine's failure, not the tile's data (pcl-rg batch exits with 1,
    as for a single file, not 2)."""


@contextlib.contextmanager
def writing(what: str) -> Iterator[None]:
    try:
        yield
    except WriteFailure:
        raise
    except OSError as error:
        raise WriteFailure(f"cannot write {what}: {error.strerror or error}") from None


def write_tile(tile: Tile, points: np.ndarray, fields: dict, template: PointFile) -> None:
    """The tile's output, as `write_points` writes it; an OSError as a WriteFailure."""
    with writing(tile.output):
        write_points(tile.output, points, fields, template=template)


def _failure(error: BaseException) -> dict[str, Any]:
    return {
        "ok": False,
        "error": f"{type(error).__name__}: {error}",
        "cannot_write": isinstance(error, WriteFailure),
    }


def _peak_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def guarded(work: Callable[[], dict[str, Any]]) -> dict[str, Any]:
    """`work()` with its time and the worker's peak memory; bad input as a failure.

    Either way with ``warnings``: the (category, message) of each warning it raised,
    for the parent to pass on (:mod:`._caught`)."""
    start = time.perf_counter()
    with caught() as found:
        try:
            result = work()
        except Exception as error:  # noqa: BLE001 - any failure is this tile's, and reported
            return dict(_failure(error), warnings=found)
        finally:
            # The core's arrays kept for a next call would lie under the next task's tile
            # (read first) and count as Dask's unmanaged memory while the worker idles.
            release_memory()
    result.update(ok=True, seconds=time.perf_counter() - start, peak_mib=_peak_mib())
    return dict(result, warnings=found)


def passed_on(result: dict[str, Any]) -> dict[str, Any]:
    """A result known before any work (a tile that failed earlier), as a task."""
    return result


def tile_extent(path: str) -> dict[str, Any]:
    """Stage 0: the tile's box, from the header for LAS/LAZ, its CRS's EPSG codes and
    the units its CRS records state."""

    def work() -> dict[str, Any]:
        extent = read_extent(path)
        codes, units = crs_records(path) if extent.from_header else ([], CoordinateUnits())
        return {"extent": tuple(extent), "crs": codes, "units": tuple(units)}

    return guarded(work)


# ---------------------------------------------------------------- stage 1


def tile_folder(job: Job, tile: Tile) -> str:
    return os.path.join(job.scratch, str(tile.index))


# Side of the grid of cells over which stage 1 indexes a tile's context points: a
# neighbour reads only the cells its buffer touches.
INDEX_CELLS = 32


def _context_rows(job: Job, cloud: PointFile) -> np.ndarray:
    """The rows a neighbour may take as context: those the operation itself would use."""
    if job.operation == "ground":
        return np.flatnonzero(_ground_work(cloud))
    return np.flatnonzero(usable_points(cloud))


def cache_tile(job: Job, tile: Tile) -> dict[str, Any]:
    """Stage 1: decode the tile and store points, fields and layout for stage 2.

    Also the footprint of the context rows (:func:`footprint`: their box, or a few
    boxes when some lie far from the rest), and an index of those rows by cell of a
    32 x 32 grid over the footprint's largest box (``cell_rows.npy`` sorted by cell,
    ``cell_start.npy``; rows outside it fall in its border cells), so a neighbour
    reads the cells near its buffer and not the whole tile.
    """

    def work() -> dict[str, Any]:
        cloud = read_points(tile.path)
        check_header_box(tile.path, tile.box, cloud)
        rows = _context_rows(job, cloud)
        xy = cloud.points[rows, :2]
        boxes = footprint(xy)
        largest = max(boxes, key=lambda b: b.xmax - b.xmin + b.ymax - b.ymin, default=None)
        low = np.array(largest[:2]) if largest else np.zeros(2)
        high = np.array(largest[2:]) if largest else np.zeros(2)
        size = np.maximum((high - low) / INDEX_CELLS, 1e-9)
        cell_xy = np.clip(((xy - low) / size).astype(np.int64), 0, INDEX_CELLS - 1)
        cell = cell_xy[:, 1] * INDEX_CELLS + cell_xy[:, 0]
        order = np.argsort(cell, kind="stable")
        starts = np.searchsorted(cell[order], np.arange(INDEX_CELLS * INDEX_CELLS + 1))
        folder = tile_folder(job, tile)
        names = list(cloud.fields)
        with writing("the scratch folder"):
            # Not makedirs: a task still running after an interrupted run removed its
            # scratch folder (on a cluster's worker) must fail, not make it again.
            with contextlib.suppress(FileExistsError):  # a retried task's
                os.mkdir(folder)
            np.save(os.path.join(folder, "points.npy"), cloud.points)
            for k, name in enumerate(names):
                np.save(os.path.join(folder, f"field{k}.npy"), np.asarray(cloud.fields[name]))
            np.save(os.path.join(folder, "cell_rows.npy"), rows[order])
            np.save(os.path.join(folder, "cell_start.npy"), starts)
            with open(os.path.join(folder, "layout.pkl"), "wb") as stream:
                pickle.dump((cloud.format, cloud.header, names, low, size, boxes), stream)
            if job.operation == "denoise":  # for the merged run's origin (survey_origin)
                save_sorted_axes(folder, in_metres(job, cloud.points[rows]))
        return {"points": len(cloud), "usable": len(rows)}

    return guarded(work)


def _layout(job: Job, tile: Tile) -> tuple:
    """Stage 1's layout.pkl: format, header, field names, index origin and cell, footprint."""
    with open(os.path.join(tile_folder(job, tile), "layout.pkl"), "rb") as stream:
        return pickle.load(stream)


def load_cached(job: Job, tile: Tile, mmap: bool = False) -> PointFile:
    folder = tile_folder(job, tile)
    fmt, header, names, *_ = _layout(job, tile)
    mode = "r" if mmap else None
    points = np.load(os.path.join(folder, "points.npy"), mmap_mode=mode)
    fields = {
        name: np.load(os.path.join(folder, f"field{k}.npy"), mmap_mode=mode)
        for k, name in enumerate(names)
    }
    return PointFile(points, fields, fmt, header, tile.path)


# ---------------------------------------------------------------- context


def _inside(points: np.ndarray, box: Box) -> np.ndarray:
    x, y = points[:, 0], points[:, 1]
    return (x >= box.xmin) & (x <= box.xmax) & (y >= box.ymin) & (y <= box.ymax)


def _region(job: Job, tile: Tile) -> list[Box]:
    """Where a tile's buffer reaches: its box grown by the buffer, or, when its points
    lie far inside that box or apart (a stray point far away stretches the header's
    box), its footprint's boxes grown by the buffer."""
    boxes = _layout(job, tile)[5]
    if len(boxes) == 1 and covers(grow(boxes[0], FOOTPRINT_GAP), tile.box):
        return [grow(tile.box, job.buffer)]
    return [grow(box, job.buffer) for box in boxes]


def context_parts(
    job: Job, neighbours: list[Tile], region: list[Box], fields: bool = False
) -> list[tuple[int, np.ndarray, PointFile]]:
    """(tile, rows, rows' points and fields) of each neighbour's context rows in `region`.

    Through the cell index of stage 1, only the cells that meet a box of `region` are
    read from the memory-mapped arrays, so a task holds its own tile and its buffer rows.
    """
    parts = []
    for tile in neighbours:
        if not any(meets(box, tile.box) for box in region):
            continue
        folder = tile_folder(job, tile)
        _, _, _, low, size, _ = _layout(job, tile)
        starts = np.load(os.path.join(folder, "cell_start.npy"))
        cell_rows = np.load(os.path.join(folder, "cell_rows.npy"), mmap_mode="r")
        pieces = []
        for box in region:
            # Clipped before the cast: a box far beyond the tile (a huge buffer) would
            # overflow int64 and wrap to the first column.
            first, last = (
                np.clip(np.floor((np.array(corner) - low) / size), 0, INDEX_CELLS - 1).astype(
                    np.int64
                )
                for corner in ((box.xmin, box.ymin), (box.xmax, box.ymax))
            )
            # Cells of one grid row are consecutive: one slice per row of cells.
            pieces += [
                np.asarray(
                    cell_rows[
                        starts[r * INDEX_CELLS + first[0]] : starts[r * INDEX_CELLS + last[0] + 1]
                    ]
                )
                for r in range(first[1], last[1] + 1)
            ]
        candidates = np.unique(np.concatenate(pieces)) if pieces else np.empty(0, np.int64)
        cloud = load_cached(job, tile, mmap=True)
        xyz = np.asarray(cloud.points[candidates])
        inside = np.zeros(len(candidates), bool)
        for box in region:
            inside |= _inside(xyz, box)
        chosen = candidates[inside]
        subset = PointFile(
            xyz[inside],
            {n: np.asarray(v[chosen]) for n, v in cloud.fields.items()} if fields else {},
            cloud.format,
        )
        parts.append((tile.index, chosen, subset))
        del cloud, cell_rows
    return parts


def in_metres(job: Job, xyz: np.ndarray) -> np.ndarray:
    """Points in metres for the methods, whose lengths are metres."""
    scale = np.asarray(job.scale)
    return xyz if (scale == 1.0).all() else xyz * scale


def _ground_work(cloud: PointFile) -> np.ndarray:
    """The points a ground filter sees: finite, not withheld and not already noise (as
    pcl-rg ground)."""
    return usable_points(cloud) & ~noise_mask(existing_classes(cloud), len(cloud))


def _with_buffer(
    neighbours: list[Tile],
    ready: list[dict[str, Any]],
    work: Callable[[list[Tile]], dict[str, Any]],
) -> dict[str, Any]:
    """`work` on the neighbours whose stage 1 succeeded, guarded.

    `ready` holds the stage-1 results of the tile and then of each neighbour: Dask
    starts a stage-2 task once they exist, and a neighbour that failed gives no buffer.
    """
    if not ready[0]["ok"]:
        return ready[0]
    usable = [n for n, result in zip(neighbours, ready[1:], strict=True) if result["ok"]]
    return guarded(lambda: work(usable))


# ---------------------------------------------------------------- ground


def ground_tile(
    job: Job, tile: Tile, neighbours: list[Tile], ready: list[dict[str, Any]]
) -> dict[str, Any]:
    """Stage 2 of ``ground``: filter the tile with its buffer, write the tile's points.

    `ready`: the stage-1 results of the tile and its neighbours (see :func:`_with_buffer`).
    """

    def work(neighbours: list[Tile]) -> dict[str, Any]:
        own = load_cached(job, tile)
        work_rows = _ground_work(own)
        parts = context_parts(job, neighbours, _region(job, tile))
        xyz = np.concatenate([own.points[work_rows]] + [p.points for _, _, p in parts])
        ground = GROUND_METHODS[job.method](in_metres(job, xyz), params=job.params)
        ground = ground[: int(work_rows.sum())]
        classes = ground_classes(own, work_rows, ground, job.keep_classes)
        write_tile(tile, own.points, dict(own.fields, classification=classes), own)
        return {
            "points": len(own),
            "buffer_points": len(xyz) - int(work_rows.sum()),
            "ground": int(ground.sum()),
        }

    return _with_buffer(neighbours, ready, work)


# ---------------------------------------------------------------- downsample


def _field(cloud: PointFile, name: str, like: np.ndarray) -> np.ndarray:
    """A neighbour's column `name`, zeros of the own tile's dtype where it has none
    (which voxel_attributes then leaves out)."""
    if name in cloud.fields:
        return np.asarray(cloud.fields[name]).astype(like.dtype, copy=False)
    return np.zeros((len(cloud),) + like.shape[1:], like.dtype)


def downsample_tile(
    job: Job, tile: Tile, neighbours: list[Tile], ready: list[dict[str, Any]]
) -> dict[str, Any]:
    """Stage 2 of ``downsample``: the voxels this tile owns, from it and its buffer.

    A voxel straddling tiles belongs to the lowest-numbered tile with a point in it;
    the buffer (at least one leaf) holds every point of every voxel the tile touches,
    and the points are ordered by (tile, row) as in the merged cloud, so centroids,
    counts and first-point attributes are those of the merged run. `ready` as in
    :func:`ground_tile`.
    """

    def work(neighbours: list[Tile]) -> dict[str, Any]:
        own = load_cached(job, tile)
        rows = np.flatnonzero(usable_points(own))
        parts = context_parts(job, neighbours, _region(job, tile), fields=True)
        parts.append((tile.index, rows, own.take(rows)))
        parts.sort(key=lambda part: part[0])
        xyz = np.concatenate([p.points for _, _, p in parts])
        tile_of = np.concatenate([np.full(len(r), t) for t, r, _ in parts])
        fields = {
            name: np.concatenate([_field(p, name, values) for _, _, p in parts])
            for name, values in own.fields.items()
        }
        carried = {
            name: np.concatenate([np.full(len(p), name in p.fields) for _, _, p in parts])
            for name in own.fields
        }
        grid = voxel_grid(in_metres(job, xyz), params=job.params)
        member = np.flatnonzero(grid.voxel_of_point >= 0)
        voxel = grid.voxel_of_point[member]
        owner = np.full(len(grid.counts), np.iinfo(np.int64).max)
        np.minimum.at(owner, voxel, tile_of[member])
        mine = owner == tile.index
        attributes = voxel_attributes(
            fields, member, voxel, grid.counts, carried, no_data_values(own)
        )
        centroids = grid.centroids[mine] / np.asarray(job.scale)  # in the tile's units
        write_tile(tile, centroids, {n: v[mine] for n, v in attributes.items()}, unorganized(own))
        return {"points": len(own), "voxels": int(mine.sum())}

    return _with_buffer(neighbours, ready, work)
