"""The figures of ``--plot`` and ``--profile``: drawn by :mod:`pcl_rg.plot` after the
work, of the points in the file's units, which the axes name."""

from __future__ import annotations

import argparse
import contextlib
import math
import os
from collections.abc import Iterator, Sequence

import numpy as np

from .._classification import valid_points
from ..io import PointFile
from ..io._crs import metre_factors
from ._flags import EXIT_FAILURE, CliError
from ._run import Run

__all__ = ["plots", "stated_metres_per_unit"]


# Short names of the length units a file may state (io._crs.GIVEN_UNITS and EPSG's).
_UNIT_NAMES = {1.0: "m", 0.3048: "ft", 1200.0 / 3937.0: "US ft", 1000.0: "km"}


def stated_metres_per_unit(cloud: PointFile) -> tuple[float, float, float] | None:
    """Metres per unit of x, y and z as `cloud`'s file states them (metres when it states
    none); None when they are not lengths (longitude and latitude) or cannot be read."""
    try:
        return metre_factors(cloud.units)[0]
    except ValueError:
        return None


def _unit_name(metres_per_unit: float) -> str:
    """A figure axis's unit: its short name, or its size in metres. Files write a
    unit's size with fewer digits than a float64 holds (0.304800609601219)."""
    for size, name in _UNIT_NAMES.items():
        if math.isclose(metres_per_unit, size, rel_tol=1e-9):
            return name
    return f"units of {metres_per_unit:g} m"


@contextlib.contextmanager
def _figure_errors(path: str) -> Iterator[None]:
    """A figure that cannot be written, after OUTPUT is: a failure (exit 1), not usage."""
    try:
        yield
    except OSError as error:
        reason = error.strerror or str(error)
        raise CliError(f"cannot write figure {path!r}: {reason}", EXIT_FAILURE) from None


def plots(
    run: Run,
    args: argparse.Namespace,
    points: np.ndarray,
    *,
    title: str,
    classes: np.ndarray | None = None,
    segments: np.ndarray | None = None,
    metres_per_unit: Sequence[float] | None,
) -> None:
    """The figures --plot and --profile ask for, of `points` in the file's units, which
    `metres_per_unit` (x, y, z; None: not known) names on the axes."""
    top, side = getattr(args, "plot", None), getattr(args, "profile", None)
    if top is None and side is None:
        return
    from .. import plot

    units = (
        ("units", "units")
        if metres_per_unit is None
        else (_unit_name(metres_per_unit[0]), _unit_name(metres_per_unit[2]))
    )

    keep = valid_points(points)
    xyz = points[keep]
    cls = None if classes is None else np.asarray(classes)[keep].astype(np.int64)
    seg = None if segments is None else np.asarray(segments)[keep].astype(np.int64)
    files = []
    with run.stage("plot", "drawing figures"):
        if top is not None:
            with _figure_errors(top):
                plot.top_view(xyz, top, classes=cls, segments=seg, title=title, units=units)
            files.append(os.path.abspath(top))
        if side is not None:
            if args.profile_line is not None:
                x0, y0, x1, y1 = args.profile_line
            elif len(xyz):
                lower, upper = xyz.min(axis=0), xyz.max(axis=0)
                middle = (lower[1] + upper[1]) / 2
                x0, y0, x1, y1 = lower[0], middle, max(upper[0], lower[0] + 1.0), middle
            else:
                x0, y0, x1, y1 = 0.0, 0.0, 1.0, 0.0
            try:
                with _figure_errors(side):
                    n = plot.profile(
                        xyz,
                        side,
                        (x0, y0),
                        (x1, y1),
                        width=args.profile_width,
                        classes=cls,
                        segments=seg,
                        units=units,
                    )
            except ValueError as error:  # after OUTPUT is written: a failure, not usage
                raise CliError(f"--profile: {error}", EXIT_FAILURE) from None
            run.result["profile_points"] = n
            files.append(os.path.abspath(side))
    run.result["figures"] = files
    for path in files:
        run.say(f"wrote {path}")
