"""What a batch run works on: the input files, their outputs and which tiles border which."""

from __future__ import annotations

import glob
import math
import os
from collections.abc import Sequence
from typing import NamedTuple

from ..io import EXTENSIONS, Extent

__all__ = [
    "Box",
    "box_of",
    "covers",
    "expand_inputs",
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


def _is_point_file(path: str) -> bool:
    return os.path.isfile(path) and os.path.splitext(path)[1].lower() in EXTENSIONS


def expand_inputs(inputs: Sequence[str | os.PathLike[str]]) -> list[str]:
    """Files, folders (their point files, not recursive) and globs, as absolute paths.

    The order is the order given, each folder and glob sorted; a file named twice
    counts once. Raises ValueError for a name that is no file, folder or matching glob.
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
        elif glob.has_magic(name):
            matches = [m for m in sorted(glob.glob(name)) if _is_point_file(m)]
            if not matches:
                raise ValueError(f"{name!r} matches no point file")
        else:
            raise ValueError(f"input {name!r}: no such file or folder")
        found += [os.path.abspath(m) for m in matches]
    unique = list(dict.fromkeys(os.path.realpath(p) for p in found))
    if not unique:
        raise ValueError("no input files")
    return unique


def output_paths(paths: Sequence[str], folder: str) -> list[str]:
    """``folder/<input's file name>`` for each input; never an input, never twice."""
    outputs = [os.path.join(os.path.abspath(folder), os.path.basename(p)) for p in paths]
    seen: dict[str, str] = {}
    for path, output in zip(paths, outputs, strict=True):
        if output in seen:
            raise ValueError(
                f"inputs {seen[output]!r} and {path!r} have the same file name: their outputs "
                f"would both be {output!r}"
            )
        seen[output] = path
        if os.path.exists(output) and os.path.samefile(output, path):
            raise ValueError(f"output {output!r} is the input itself; choose another --out")
    return outputs


def box_of(extent: Extent) -> Box:
    return Box(extent.xmin, extent.ymin, extent.xmax, extent.ymax)


def survey_spacing(extents: Sequence[Extent]) -> float:
    """The nominal point spacing of a survey from its tiles' headers:
    sqrt(sum of the tiles' XY box areas / their number of points), NaN when undefined.

    The unset lengths of the ground filters take one spacing for all tiles from this,
    so that every tile of a survey runs with the same parameters.
    """
    area = sum((e.xmax - e.xmin) * (e.ymax - e.ymin) for e in extents)
    points = sum(e.points for e in extents)
    return math.sqrt(area / points) if points and area > 0.0 else math.nan


def grow(box: Box, margin: float) -> Box:
    return Box(box.xmin - margin, box.ymin - margin, box.xmax + margin, box.ymax + margin)


def meets(a: Box, b: Box) -> bool:
    """Whether two closed boxes share a point."""
    return a.xmin <= b.xmax and b.xmin <= a.xmax and a.ymin <= b.ymax and b.ymin <= a.ymax


def neighbours(boxes: Sequence[Box | None], margin: float) -> list[list[int]]:
    """For each tile, the other tiles whose box meets its box grown by `margin`.

    A tile without a box (unreadable, or no finite point) has and is no neighbour.
    """
    result: list[list[int]] = []
    for i, box in enumerate(boxes):
        if box is None:
            result.append([])
            continue
        reach = grow(box, margin)
        result.append(
            [j for j, other in enumerate(boxes) if j != i and other and meets(reach, other)]
        )
    return result


def covers(a: Box, b: Box) -> bool:
    """Whether box `a` holds all of box `b`."""
    return a.xmin <= b.xmin and a.ymin <= b.ymin and a.xmax >= b.xmax and a.ymax >= b.ymax


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
