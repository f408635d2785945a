"""What a batch run works on: the input files, their outputs and which tiles border which."""

from __future__ import annotations

import glob
import math
import os
import re
import warnings
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from .._caller import outside_stacklevel
from ..io import EXTENSIONS, Extent
from ..io._atomic import special_file

__all__ = [
    "Box",
    "box_of",
    "covers",
    "expand_inputs",
    "footprint",
    "grow",
    "meets",
    "neighbours",
    "output_paths",
    "survey_box",
    "survey_spacing",
]


class Box(NamedTuple):
    """A closed horizontal box (xmin, ymin, xmax, ymax) in the files' coordinates."""

    xmin: float
    ymin: float
    xmax: float
    ymax: float


# How much of a .txt file a folder's or glob's listing reads to tell a tile from notes.
TEXT_SNIFF = 4096


def _text_tile(path: str) -> bool:
    """Whether a ``.txt`` file is XYZ text: its first row that is no comment and no
    point count holds three numbers or more (a README.txt beside the tiles is no tile).
    No such row within TEXT_SNIFF bytes: a tile when they end in a ``# x y z`` header
    (an empty cloud, as write_points writes it) or fill TEXT_SNIFF (its read decides)."""
    try:
        with open(path, "rb") as stream:
            head = stream.read(TEXT_SNIFF)
    except OSError:
        return True  # a tile: its read reports why it cannot be read, for it alone
    named = False
    for line in head.removeprefix(b"\xef\xbb\xbf").decode("ascii", "replace").splitlines():
        words = line.split()
        if not words:
            continue
        if words[0].startswith(("#", "//")):
            names = re.split(r"[\s,;]+", line.strip().lstrip("#/").strip())
            named = [n.lower() for n in names[:3]] == ["x", "y", "z"]
            continue
        if len(words) == 1 and words[0].isdigit():
            continue  # the point count some writers put first
        try:
            [float(word) for word in words[:3]]
        except ValueError:
            return False
        return len(words) >= 3
    return named or len(head) == TEXT_SNIFF


def _is_point_file(path: str) -> bool:
    """Whether an entry of a folder or a glob's match is a tile: a point file's extension,
    and a regular file (a FIFO would block its worker's read for ever: skipped, with a
    warning, as a folder, device or broken link of that name); XYZ text in a .txt only."""
    ext = os.path.splitext(path)[1].lower()
    if ext not in EXTENSIONS:
        return False
    if not os.path.isfile(path):
        warnings.warn(
            f"skipped {path!r}: not a regular file (a folder, FIFO, device or broken link)",
            stacklevel=outside_stacklevel(),
        )
        return False
    return ext != ".txt" or _text_tile(path)


def expand_inputs(inputs: Sequence[str | os.PathLike[str]]) -> list[str]:
    """Files, folders (their point files, not recursive) and globs, as absolute paths.

    The order is the order given, each folder and glob sorted; a file named twice (also
    through a link, soft or hard) counts once, under its first name. Links are not
    resolved: an output is named after the input's name as listed. A ``.txt`` file in
    a folder or glob is a tile only when it holds XYZ text (:func:`_text_tile`); a
    named file always is.
    Raises ValueError for a name that is no file, folder or matching glob, or that is
    not a regular file (a FIFO would block the read for ever).
    """
    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    found: list[str] = []
    for item in inputs:
        name = os.fspath(item)
        if os.path.isdir(name):
            matches = sorted(os.path.join(name, f) for f in os.listdir(name))
            matches = [m for m in matches if _is_point_file(m)]
            if not matches:
                raise ValueError(f"folder {name!r} holds no point file ({', '.join(EXTENSIONS)})")
        elif os.path.isfile(name):
            matches = [name]
        elif os.path.exists(name):
            raise ValueError(
                f"input {name!r} is not a regular file (a FIFO or device would block the "
                "read for ever)"
            )
        elif glob.has_magic(name):
            matches = [m for m in sorted(glob.glob(name)) if _is_point_file(m)]
            if not matches:
                raise ValueError(f"{name!r} matches no point file")
        else:
            raise ValueError(f"input {name!r}: no such file or folder")
        found += [os.path.abspath(m) for m in matches]
    first: dict[tuple[int, int], str] = {}
    for path in found:  # one file under two names: links, also hard ones
        stat = os.stat(path)
        first.setdefault((stat.st_dev, stat.st_ino), path)
    if not first:
        raise ValueError("no input files")
    return list(first.values())


def output_paths(paths: Sequence[str], folder: str) -> list[str]:
    """``folder/<input's file name>`` for each input (a link's own name); never an
    input, also through links, never twice."""
    outputs = [os.path.join(os.path.abspath(folder), os.path.basename(p)) for p in paths]
    inputs = {(s.st_dev, s.st_ino): p for p in paths for s in [os.stat(p)]}
    seen: dict[str, str] = {}
    files: dict[object, str] = {}  # what each output resolves to: a link's target
    for path, output in zip(paths, outputs, strict=True):
        if output in seen:
            raise ValueError(
                f"inputs {seen[output]!r} and {path!r} have the same file name: their outputs "
                f"would both be {output!r}"
            )
        seen[output] = path
        resolved: object = os.path.realpath(output)
        if os.path.exists(output):
            if special_file(output):
                raise ValueError(
                    f"output {output!r} is not a regular file (a FIFO, device or socket); "
                    "refusing to replace it"
                )
            if os.path.isdir(output):
                raise ValueError(
                    f"output {output!r} is a folder, not a file; move it or choose another --out"
                )
            stat = os.stat(output)
            other = inputs.get((stat.st_dev, stat.st_ino))
            if other is not None:
                what = "the input itself" if other == path else f"the input {other!r}"
                raise ValueError(f"output {output!r} is {what}; choose another --out")
            resolved = (stat.st_dev, stat.st_ino)
        if resolved in files:  # links in the folder: one tile's points would be lost
            raise ValueError(
                f"outputs {files[resolved]!r} and {output!r} are one file (a link in the "
                "output folder); remove the link"
            )
        files[resolved] = output
    return outputs


def box_of(extent: Extent) -> Box:
    return Box(extent.xmin, extent.ymin, extent.xmax, extent.ymax)


#: A tile whose header spacing, sqrt(box area / points), exceeds this multiple of the
#: median tile's is left out of the survey's spacing: its box is mostly empty (a stray
#: point far away).
SPARSE_TILE = 2.0


def survey_spacing(extents: Sequence[Extent]) -> float:
    """The nominal point spacing of a survey from its tiles' headers:
    sqrt(sum of the tiles' XY box areas / their number of points), NaN when undefined.

    The unset lengths of the ground filters take one spacing for all tiles from this,
    so that every tile of a survey runs with the same parameters. Tiles whose own
    spacing (the same on their box alone) is more than SPARSE_TILE times the median
    tile's do not count: one point 700 km from a tile would make its box, and so the
    survey's spacing, hundreds of times too large. Only tiles above the median are
    left out, so denser tiles, and slivers of a few points, never push the others
    out; tiles without area count with their points, as before.
    """
    tiles = [((e.xmax - e.xmin) * (e.ymax - e.ymin), e.points) for e in extents if e.points]
    spaced = sorted(area / points for area, points in tiles if area > 0.0)
    if not spaced:
        return math.nan
    median = spaced[(len(spaced) - 1) // 2]  # of the area per point; the lower one
    kept = [(area, points) for area, points in tiles if area / points <= SPARSE_TILE**2 * median]
    return math.sqrt(sum(area for area, _ in kept) / sum(points for _, points in kept))


def grow(box: Box, margin: float) -> Box:
    return Box(box.xmin - margin, box.ymin - margin, box.xmax + margin, box.ymax + margin)


def meets(a: Box, b: Box) -> bool:
    """Whether two closed boxes share a point."""
    return a.xmin <= b.xmax and b.xmin <= a.xmax and a.ymin <= b.ymax and b.ymin <= a.ymax


def neighbours(boxes: Sequence[Box | None], margin: float) -> list[list[int]]:
    """For each tile, the other tiles whose box meets its box grown by `margin`.

    A tile without a box (unreadable, or no finite point) has and is no neighbour.
    Each tile's test runs over all the boxes at once in NumPy, in the arithmetic of
    :func:`grow` and :func:`meets`: a survey of 10,000 tiles took 11 s in Python.
    """
    others = np.array([b if b is not None else (np.nan,) * 4 for b in boxes], float)
    others = others.reshape(len(boxes), 4)
    result: list[list[int]] = []
    for i, box in enumerate(boxes):
        if box is None:
            result.append([])
            continue
        reach = grow(box, margin)
        hit = (  # NaN, a tile without a box, meets nothing
            (reach.xmin <= others[:, 2])
            & (others[:, 0] <= reach.xmax)
            & (reach.ymin <= others[:, 3])
            & (others[:, 1] <= reach.ymax)
        )
        hit[i] = False
        result.append(np.flatnonzero(hit).tolist())
    return result


def covers(a: Box, b: Box) -> bool:
    """Whether box `a` holds all of box `b`."""
    return a.xmin <= b.xmin and a.ymin <= b.ymin and a.xmax >= b.xmax and a.ymax >= b.ymax


def room_inside(points: np.ndarray, box: Box, survey: Box) -> np.ndarray:
    """Distance from each point to the nearest side of `box` beyond which points may lie.

    A side at or outside the survey's box has nothing beyond it: infinite room.
    """
    room = np.full(len(points), np.inf)
    x, y = points[:, 0], points[:, 1]
    if box.xmin > survey.xmin:
        room = np.minimum(room, x - box.xmin)
    if box.xmax < survey.xmax:
        room = np.minimum(room, box.xmax - x)
    if box.ymin > survey.ymin:
        room = np.minimum(room, y - box.ymin)
    if box.ymax < survey.ymax:
        room = np.minimum(room, box.ymax - y)
    return room


def survey_box(boxes: Sequence[Box | None]) -> Box | None:
    """The box of every tile's box."""
    present = [b for b in boxes if b is not None]
    if not present:
        return None
    return Box(
        min(b.xmin for b in present),
        min(b.ymin for b in present),
        max(b.xmax for b in present),
        max(b.ymax for b in present),
    )


#: Gaps between a tile's points wider than this (m) split its footprint: wider than
#: the tiles of an ordinary survey, so that only points far from the rest (a stray
#: return, a bad GPS fix) get boxes of their own.
FOOTPRINT_GAP = 1000.0


def footprint(xy: np.ndarray, gap: float = FOOTPRINT_GAP) -> list[Box]:
    """Boxes that together hold the points `xy` ((N, 2)), each bounding its points.

    One box, their bounding box, unless they span more than `gap` on an axis; then
    the points split on each axis where consecutive coordinates lie more than `gap`
    apart, and every pair of an x part and a y part that holds points gets a box. A
    tile's buffer then surrounds its points: a stray point far away adds a small box
    instead of stretching one box over the whole survey.
    """
    if not len(xy):
        return []
    low, high = xy.min(axis=0), xy.max(axis=0)
    if (high - low <= gap).all():
        return [Box(float(low[0]), float(low[1]), float(high[0]), float(high[1]))]
    key = np.zeros(len(xy), np.int64)
    for axis in (0, 1):
        values = np.sort(xy[:, axis])
        starts = values[1:][np.diff(values) > gap]  # the first coordinate of each later part
        key = key * (len(starts) + 1) + np.searchsorted(starts, xy[:, axis], side="right")
    order = np.argsort(key, kind="stable")
    first = np.flatnonzero(np.r_[True, np.diff(key[order]) != 0])
    lows = np.minimum.reduceat(xy[order], first)
    highs = np.maximum.reduceat(xy[order], first)
    return [Box(float(a), float(b), float(c), float(d)) for (a, b), (c, d) in zip(lows, highs)]
